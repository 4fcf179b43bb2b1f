//! The production stage of `hydrofrac run` (`production:`, `src/production.rs`): the coupled
//! hydro-mechanical steady state between two pressure wells against the rigid steady solver,
//! what the coupling adds when the fractures can open, and named errors for a bad
//! `production` section.

use hydrofrac::production_stage::{
    NetworkState, production_sim, run_production, solve_state, solve_state_reporting,
};
use hydrofrac::reservoir::doublet::{PressureWell, doublet_flow, network_of_view};
use hydrofrac::scenario::Scenario;

/// A 20 m x 20 m block under Example I's in-situ stress (sigma_yy = -10 MPa across the
/// fracture) with one horizontal fracture from the pump at (0, 10) m to (14, 10) m; wells at its
/// ends. `scale` multiplies the rock's E and the joints' K_n, K_t.
fn scene(scale: f64, production: &str) -> Scenario {
    scene_on(
        "Regular(width: 20.0, height: 20.0, h: 1.0)",
        scale,
        production,
    )
}

/// [`scene`] on `mesh`.
fn scene_on(mesh: &str, scale: f64, production: &str) -> Scenario {
    let text = format!(
        r#"(
    name: "production_test",
    mesh: {mesh},
    material: (young: {e}, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -20e6, syy: -10e6),
    initial_state: InSitu,
    fracture: Some((
        strength: Some(1e6),
        residual_aperture: 5e-4,
        preexisting: [(from: (0.0, 10.0), to: (14.0, 10.0))],
        normal_stiffness: Some({kn}),
        shear_stiffness: Some({kt}),
    )),
    flow_boundaries: [(name: "pump", at: Node((0.0, 10.0)), kind: Pump(p_max: 18e6, q_half: 2.0))],
    time: (end: Time(1.0), flow_scheme: Implicit),
    {production}
)"#,
        e = 20e9 * scale,
        kn = 20e9 * scale,
        kt = 8.3e9 * scale,
    );
    Scenario::parse(&text, "production_test.ron").expect("valid scenario")
}

const WELLS: &str = "production: Some((wells: (injection: (0.0, 10.0), production: (14.0, 10.0), \
                     production_pressure: 0.0, pressure_drops: [15e6], reach: 0.5))),";

/// The rigid steady solver's rate through the network at setup with every cell at the residual
/// aperture, m^2/s.
fn rigid_rate(sc: &Scenario, dp: f64) -> f64 {
    let sim = production_sim(sc, None, None).unwrap();
    let net = network_of_view(&sim.flow().unwrap().view, Some(5e-4));
    let wells = [
        PressureWell {
            position: [0.0, 10.0],
            pressure: dp,
        },
        PressureWell {
            position: [14.0, 10.0],
            pressure: 0.0,
        },
    ];
    let prod = doublet_flow(&net, &wells, sim.params().fluid.mu, 0.5).unwrap();
    -prod.wells[1].1
}

/// With the rock and the joints 1000 times stiffer, 15 MPa of injection pressure against 10 MPa
/// of normal stress opens the fracture by about (p - sigma_n) L / E' = 3e-7 m, far below the
/// residual aperture: every hydraulic aperture stays a_r, so the coupled steady state must
/// give the rigid solver's rate. 1e-6: the iteration's tolerance is 1e-4 on pressure changes,
/// but with constant apertures the flow is the same linear solve, so the rates agree to
/// round-off. With the real rock (E = 20 GPa) the same pressure opens the fracture near the
/// injector by millimetres: the coupled rate must exceed the frozen one by more than 10 %
/// (measured: see the assertion message), and the frozen one (no fluid pressure: closed) must be
/// the rigid one.
#[test]
fn coupled_steady_state_matches_the_rigid_solver_when_the_rock_is_stiff() {
    let dp = 15e6;
    let stiff = scene(1000.0, WELLS);
    let stage = stiff.production.clone().unwrap();
    let mut sim = production_sim(&stiff, None, None).unwrap();
    let s = solve_state(&mut sim, &stage, NetworkState::Before, dp).unwrap();
    let rigid = rigid_rate(&stiff, dp);
    assert!(rigid > 0.0, "the wells are connected: rigid rate {rigid}");
    let rel = (s.row.rate - rigid).abs() / rigid;
    assert!(
        rel < 1e-6,
        "stiff rock: coupled {:.9e} vs rigid {rigid:.9e} m^2/s (rel {rel:.2e}); max aperture {:.3e} m",
        s.row.rate,
        s.row.max_aperture
    );
    assert!(s.row.converged, "{:?}", s.row);
    assert_eq!(s.row.new_cells, 0);

    let soft = scene(1.0, WELLS);
    let mut sim = production_sim(&soft, None, None).unwrap();
    let s = solve_state(&mut sim, &stage, NetworkState::Before, dp).unwrap();
    let rigid = rigid_rate(&soft, dp);
    eprintln!(
        "soft rock, dp = 15 MPa: coupled {:.4e}, frozen {:.4e}, rigid {rigid:.4e} m^2/s, {} iterations, max aperture {:.3e} m",
        s.row.rate, s.row.rate_frozen, s.row.iterations, s.row.max_aperture
    );
    let frozen_rel = (s.row.rate_frozen - rigid).abs() / rigid;
    assert!(
        frozen_rel < 1e-6,
        "frozen {:.6e} vs rigid {rigid:.6e}",
        s.row.rate_frozen
    );
    assert!(s.row.converged, "{:?}", s.row);
    assert!(
        s.row.rate > 1.1 * s.row.rate_frozen && s.row.max_aperture > 1e-3,
        "the coupling opens the fracture: coupled {:.4e}, frozen {:.4e} m^2/s, max aperture {:.3e} m",
        s.row.rate,
        s.row.rate_frozen,
        s.row.max_aperture
    );
}

/// A bad `production` section is refused at validation with one line naming the field.
#[test]
fn bad_production_sections_are_named() {
    let good = "(injection: (0.0, 10.0), production: (14.0, 10.0), production_pressure: 0.0, \
                pressure_drops: [9e6], reach: 0.5)";
    for (section, field) in [
        (
            good.replace("[9e6]", "[]"),
            "production.wells.pressure_drops",
        ),
        (
            good.replace("[9e6]", "[9e6, -1.0]"),
            "production.wells.pressure_drops[1]",
        ),
        (
            good.replace("reach: 0.5", "reach: 0.0"),
            "production.wells.reach",
        ),
        (
            good.replace("(0.0, 10.0)", "(NaN, 10.0)"),
            "production.wells.injection",
        ),
        (format!("{good}, relaxation: 1.5"), "production.relaxation"),
        (format!("{good}, tolerance: 0.0"), "production.tolerance"),
        (
            format!("{good}, max_iterations: 0"),
            "production.max_iterations",
        ),
    ] {
        let text = format!("production: Some((wells: {section})),");
        let sc = scene(1.0, &text);
        let err = sc.validate().unwrap_err().to_string();
        assert!(
            err.contains(field) && !err.contains('\n'),
            "{field}: got `{err}`"
        );
    }
    // Production needs a coupled run: no flow boundaries.
    let mut sc = scene(1.0, WELLS);
    sc.flow_boundaries.clear();
    let err = sc.validate().unwrap_err().to_string();
    assert!(err.contains("production"), "{err}");
}

/// The two ways to find the rock's equilibria (`production.rock`: the quasi-static Newton solve,
/// the default, or dynamic relaxation with the explicit scheme) have the same static answer, so
/// they must give the same coupled rate on the soft scene, where the pressure opens the fracture
/// by millimetres. 2e-3: each stops its fixed-point iteration at a relative change of 1e-3 and
/// its equilibria at a relative residual of 1e-6, from different iterates.
#[test]
fn quasi_static_and_relaxed_rock_give_the_same_production() {
    same_production_on("Regular(width: 20.0, height: 20.0, h: 1.0)", usize::MAX);
}

/// The same on a mesh of 0.2 m triangles along the fracture and 1 m ones away from it, where
/// dynamic relaxation gives each node the mass of one common step (`production::fictitious_masses`):
/// the fine elements would otherwise set the step for all. The relaxation must reach the same
/// static answer, in fewer steps than the fine elements' step allows: measured 41,590 steps
/// with the scaled masses against 87,672 with the rock's (the bound below lies between; rates
/// 3.869301e-1 and 3.869355e-1 against the quasi-static 3.869504e-1 m^2/s).
#[test]
fn relaxation_with_scaled_masses_gives_the_quasi_static_production_on_a_graded_mesh() {
    same_production_on(
        "Conforming(width: 20.0, height: 20.0, h: 0.2, h_far: 1.0)",
        60_000,
    );
}

/// Production at 15 MPa by both rocks on `mesh`: rates within 2e-3; the relaxation in at most
/// `max_steps` steps.
fn same_production_on(mesh: &str, max_steps: usize) {
    let dp = 15e6;
    let mut rates = Vec::new();
    for rock in ["QuasiStatic", "Explicit"] {
        let wells = WELLS.replace("reach: 0.5)", &format!("reach: 0.5), rock: {rock}"));
        let sc = scene_on(mesh, 1.0, &wells);
        let stage = sc.production.clone().unwrap();
        let mut sim = production_sim(&sc, None, None).unwrap();
        let t0 = std::time::Instant::now();
        let s = solve_state(&mut sim, &stage, NetworkState::Before, dp).unwrap();
        eprintln!(
            "{rock}: rate {:.6e} m^2/s, {} iterations, {} equilibrium steps, {:.3} s",
            s.row.rate,
            s.row.iterations,
            s.row.relax_steps,
            t0.elapsed().as_secs_f64()
        );
        assert!(s.row.converged, "{rock}: {:?}", s.row);
        assert!(
            s.row.relax_steps as usize <= max_steps,
            "{rock}: {} steps",
            s.row.relax_steps
        );
        rates.push(s.row.rate);
    }
    let rel = (rates[0] - rates[1]).abs() / rates[1];
    assert!(
        rel < 2e-3,
        "quasi-static {:.6e} vs relaxed {:.6e} m^2/s (rel {rel:.2e})",
        rates[0],
        rates[1]
    );
}

/// The same production state in pools of 1 and 2 threads gives the same bits (the rates, every
/// cell's aperture and every flux of the coupled flow, the rock's displacements): the equilibria and the flow solves sum in a
/// fixed order whatever the thread count.
#[test]
fn production_is_the_same_for_any_thread_count() {
    let dp = 15e6;
    let sc = scene(1.0, WELLS);
    let stage = sc.production.clone().unwrap();
    let bits = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut sim = production_sim(&sc, None, None).unwrap();
            let s = solve_state(&mut sim, &stage, NetworkState::Before, dp).unwrap();
            let mut b = vec![s.row.rate.to_bits(), s.row.rate_frozen.to_bits()];
            b.extend(s.flow.cells.iter().map(|c| c.2.to_bits()));
            b.extend(s.flow.fluxes.iter().map(|f| f.2.to_bits()));
            b.extend(sim.solid().u.iter().flat_map(|x| x.map(f64::to_bits)));
            (b, s.row.iterations)
        })
    };
    let (one, it) = bits(1);
    assert!(it > 1, "the pressure opens the fracture: {it} iterations");
    assert_eq!(one, bits(2).0);
}

/// Example II's network on a mesh that follows the fractures (h = 2 m to keep it short): under
/// the 9 MPa state's first trial pressure some 1,700 joints switch to slip at once and one
/// Newton solve diverges (it did, to a non-finite residual, before load increments), while
/// the same change applied in increments (`production::MIN_LOAD_INCREMENT`) reaches an
/// equilibrium at every step. So the state must be solved by the quasi-static rock, in more
/// solves than the two a single step per equilibrium takes (frozen state, first iterate).
/// The network is not connected between the wells on this mesh (an en-echelon step of
/// 0.37 m between two fractures at (61.6, 66.4) m that the perturbed h = 1 m mesh's snapping
/// closes), so the rates are zero: what is checked is the equilibrium.
#[test]
fn production_equilibria_are_reached_by_load_increments_where_one_newton_solve_diverges() {
    let sc = Scenario::load(
        std::path::Path::new("scenarios/example2.ron"),
        &[
            "mesh=Conforming(width: 100.0, height: 100.0, h: 2.0, h_far: 2.0)".to_string(),
            "production.wells.pressure_drops=[9e6]".to_string(),
        ],
    )
    .unwrap();
    let stage = sc.production.clone().unwrap();
    let mut sim = production_sim(&sc, None, None).unwrap();
    let heard = std::cell::RefCell::new(Vec::new());
    let s = solve_state_reporting(&mut sim, &stage, NetworkState::Before, 9e6, &|m: &str| {
        heard.borrow_mut().push(m.to_string())
    })
    .expect("the quasi-static rock reaches the equilibrium by increments");
    eprintln!("{:?}", s.row);
    // The progress reports name the increments and the fixed-point iteration.
    let heard = heard.into_inner();
    assert!(
        heard.iter().any(|m| m.contains("no equilibrium at 100 %"))
            && heard.iter().any(|m| m.starts_with("iteration 1: rate")),
        "{heard:?}"
    );
    assert_eq!(s.row.rock, "quasi-static");
    assert!(s.row.converged, "{:?}", s.row);
    assert!(
        s.row.relax_steps > 2,
        "the state took {} solves: no increment was needed, so this scene no longer tests them",
        s.row.relax_steps
    );
    assert!(sim.stats().residual() < stage.static_tol);
    assert_eq!(s.row.rate, 0.0);
}

/// The whole stage (`run_production`: the before and the after states side by side, on two
/// threads when the pool has them) gives the same rows, bit for bit, in pools of 1 and 2
/// threads, in the order before, after. Started from the setup's own state, the after states
/// are the before states' problems, so their rows must equal them too: the two sides share no
/// state.
#[test]
fn production_stage_is_the_same_for_any_thread_count() {
    let sc = scene(1.0, &WELLS.replace("[15e6]", "[9e6, 15e6]"));
    let end = hydrofrac::sim::Simulation::new(sc.clone().validate().unwrap(), &[])
        .unwrap()
        .checkpoint_state()
        .unwrap()
        .1;
    let rows = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let out = run_production(&sc, end.clone(), None, &|_| {}).unwrap();
            assert!(out.failed.is_empty());
            assert_eq!(out.figures.len(), 2);
            out.rows
                .iter()
                .map(|r| {
                    (
                        r.state.name(),
                        r.dp,
                        r.rate.to_bits(),
                        r.rate_frozen.to_bits(),
                        r.iterations,
                    )
                })
                .collect::<Vec<_>>()
        })
    };
    let one = rows(1);
    let names: Vec<_> = one.iter().map(|r| (r.0, r.1)).collect();
    assert_eq!(
        names,
        [
            ("before", 9e6),
            ("before", 15e6),
            ("after", 9e6),
            ("after", 15e6)
        ]
    );
    assert!(one[1].4 > 1, "15 MPa opens the fracture: {one:?}");
    for k in 0..2 {
        assert_eq!(
            (one[k].2, one[k].3, one[k].4),
            (one[k + 2].2, one[k + 2].3, one[k + 2].4)
        );
    }
    assert_eq!(one, rows(2));
}

/// Where the rock without fluid pressure does not settle (a fracture grows in each of its
/// `max_iterations` relaxations: here at the tips of a fracture at 26.6 degrees on a mesh that
/// follows it, sliding under sigma_xx = -30 MPa, sigma_yy = -5 MPa with friction 1 degree,
/// against a strength of 10 kPa: measured 3 new cells in 2 relaxations), the row says that its
/// frozen rate is not an equilibrium's (`frozen_settled`); with a strength the in-situ stress
/// cannot reach at the tips (100 MPa), the same state settles. (On a regular mesh the
/// fracture's staircase interlocks and nothing slides.)
#[test]
fn a_frozen_rock_that_does_not_settle_is_flagged() {
    let make = |strength: f64| {
        let text = format!(
            r#"(
    name: "production_unsettled",
    mesh: Conforming(width: 20.0, height: 20.0, h: 1.0, h_far: 1.0),
    material: (young: 20e9, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -30e6, syy: -5e6),
    initial_state: InSitu,
    fracture: Some((
        strength: Some({strength:e}),
        residual_aperture: 5e-4,
        friction_deg: 1.0,
        preexisting: [(from: (2.0, 7.0), to: (14.0, 13.0))],
    )),
    flow_boundaries: [(name: "pump", at: Node((2.0, 7.0)), kind: Pump(p_max: 18e6, q_half: 2.0))],
    time: (end: Time(1.0), flow_scheme: Implicit),
    production: Some((wells: (injection: (2.0, 7.0), production: (14.0, 13.0),
        production_pressure: 0.0, pressure_drops: [9e6], reach: 0.5), max_iterations: 2,
        rock: Explicit)),
)"#
        );
        Scenario::parse(&text, "production_unsettled.ron").expect("valid scenario")
    };
    for (strength, settled) in [(1e4, false), (1e8, true)] {
        let sc = make(strength);
        let stage = sc.production.clone().unwrap();
        let mut sim = production_sim(&sc, None, None).unwrap();
        let s = solve_state(&mut sim, &stage, NetworkState::Before, 9e6).unwrap();
        assert_eq!(s.row.frozen_settled, settled, "{:?}", s.row);
    }
}

/// The production stage's equilibria take no time: a run whose rock has inertia
/// (`time.solid_scheme: QuasiStatic`, `time.inertia: BackwardEuler`) still gets its production
/// simulation (the stage's scenario drops the inertia, which needs `end: Time`), for the
/// quasi-static and the relaxed production rock alike.
#[test]
fn a_run_with_inertia_gets_its_production_stage() {
    for rock in ["QuasiStatic", "Explicit"] {
        let wells = WELLS.replace("reach: 0.5)", &format!("reach: 0.5), rock: {rock}"));
        let mut sc = scene(1.0, &wells);
        sc.time.solid_scheme = hydrofrac::scenario::SolidScheme::QuasiStatic;
        sc.time.inertia = hydrofrac::scenario::Inertia::BackwardEuler;
        sc.clone().validate().expect("the run itself is valid");
        let sim = production_sim(&sc, None, None);
        assert!(sim.is_ok(), "{rock}: {:?}", sim.err());
    }
}

/// Example II scaled down to a 40 m x 40 m box (`scenarios/example2.ron`: its stress, joints,
/// pump and fracture families; 16 fractures, the same density as its 100 in 100 m x 100 m;
/// network seed 13), friction 30 degrees, wells at the left and right edges' middles. At 12 and
/// 15 MPa its quasi-static rock finds no static equilibrium near the last one, even in the
/// smallest load increment (blocks held only by sliding joints), and settles by implicit
/// dynamics (`production_stage::settle`).
fn settling_scene(rock: &str) -> Scenario {
    let text = format!(
        r#"(
    name: "settle_small",
    mesh: Regular(width: 40.0, height: 40.0, h: 1.0),
    material: (young: 20e9, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -20e6, syy: -10e6),
    initial_state: InSitu,
    fracture: Some((
        strength: Some(1e6),
        residual_aperture: 5e-4,
        preexisting: [(from: (0.0, 20.0), to: (4.0, 20.0))],
        random: Some((seed: 13, count: 16, size: (40.0, 40.0), angles_deg: [60.0, 150.0],
                      jitter_deg: 15.0, length: (15.0, 40.0))),
        friction_deg: 30.0,
        normal_stiffness: Some(20e9),
        shear_stiffness: Some(8.3e9),
    )),
    flow_boundaries: [(name: "pump", at: Node((0.0, 20.0)), kind: Pump(p_max: 18e6, q_half: 2.0))],
    time: (end: Time(0.2), flow_scheme: Implicit),
    damping: Local(0.8),
    production: Some((
        wells: (injection: (0.0, 20.0), production: (40.0, 20.0), production_pressure: 0.0,
                pressure_drops: [9e6, 12e6, 15e6], reach: 10.0),
        rock: {rock},
    )),
)"#
    );
    Scenario::parse(&text, "settle_small.ron").expect("valid scenario")
}

/// The settling path where joints slide (Example II's states need it at 12 and 15 MPa; the
/// unit test `a_floating_block_settles_where_the_static_solve_fails` is a block on open
/// faces, with no friction at play): the before states at 9, 12 and 15 MPa in turn, as the
/// stage solves them.
/// The quasi-static rock settles at 12 and 15 MPa and ends in a static equilibrium (its
/// residual below `production.static_tol`), with no relaxation fallback; its rates match the
/// dynamic relaxation's (`rock: Explicit`, the other path to a static state) within 2 %.
/// Measured (2026-12-07, 12 s for both rocks): 72 and 206 settling steps, rates 2.7353e-3 and
/// 3.6082e-3 m^2/s against the relaxation's 2.7325e-3 and 3.6331e-3 (+0.10 and -0.69 %; with
/// every settling step solved to the tolerance 87 and 197 steps, +0.11 and -0.88 %); 9 MPa
/// needs no settling and matches to 2.5e-4, held to 2e-3 as in `same_production_on` (two
/// solvers of one static problem). The settled states' bound is not tighter because with
/// friction the equilibrium depends on the path to it (relaxation's fictitious dynamics
/// against the rock's own motion; 0.74 % on Example II, docs/example2.md); a settling that
/// stopped short of equilibrium fails the residual check instead.
#[test]
fn settling_reaches_the_relaxations_equilibria() {
    let mut rates = Vec::new();
    for rock in ["QuasiStatic", "Explicit"] {
        let sc = settling_scene(rock);
        let stage = sc.production.clone().unwrap();
        let mut sim = production_sim(&sc, None, None).unwrap();
        let mut row_rates = Vec::new();
        for dp in [9e6, 12e6, 15e6] {
            let t0 = std::time::Instant::now();
            let s = solve_state(&mut sim, &stage, NetworkState::Before, dp).unwrap();
            eprintln!(
                "{rock} {:.0} MPa: rate {:.6e} m^2/s, {} settling steps, rock {}, {:.2} s",
                dp / 1e6,
                s.row.rate,
                s.row.settle_steps,
                s.row.rock,
                t0.elapsed().as_secs_f64()
            );
            assert!(s.row.converged, "{rock} {dp}: {:?}", s.row);
            assert!(s.row.fallback.is_none(), "{rock} {dp}: {:?}", s.row);
            if rock == "QuasiStatic" {
                assert_eq!(s.row.rock, "quasi-static", "{dp}: {:?}", s.row);
                // Settling where the scene was built to need it, and not at 9 MPa.
                assert_eq!(s.row.settle_steps > 0, dp > 10e6, "{dp}: {:?}", s.row);
                assert!(
                    sim.stats().residual() < stage.static_tol,
                    "{dp}: static residual {:.2e}",
                    sim.stats().residual()
                );
            }
            assert!(s.row.rate > 0.0, "{rock} {dp}: the wells are connected");
            row_rates.push(s.row.rate);
        }
        rates.push(row_rates);
    }
    for (k, dp) in [9e6, 12e6, 15e6].iter().enumerate() {
        let rel = (rates[0][k] - rates[1][k]).abs() / rates[1][k];
        let bound = if *dp > 10e6 { 2e-2 } else { 2e-3 };
        assert!(
            rel < bound,
            "{:.0} MPa: settled {:.6e} vs relaxed {:.6e} m^2/s (rel {rel:.2e})",
            dp / 1e6,
            rates[0][k],
            rates[1][k]
        );
    }
}
