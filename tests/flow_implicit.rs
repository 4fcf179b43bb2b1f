//! The implicit (backward-Euler) flow step against the explicit one and the references of
//! `docs/verification.md` R10-R13. Tolerances and their reasons are stated at each check (the
//! verification cases' own are in `src/verify/flow_cases.rs`).

use crate::support_cli as cli;

use hydrofrac::flow::implicit::{
    ImplicitError, ImplicitSolver, Pattern, assemble, implicit_step, residual,
};
use hydrofrac::flow::pressure_of;
use hydrofrac::network::Fracture;
use hydrofrac::scenario::{
    Coords, End, FlowBcKind, FlowScheme, FlowTarget, InitialFluid, Scenario,
};
use hydrofrac::sim::Simulation;
use hydrofrac::systems::RunError;
use hydrofrac::verify::{CaseResult, flow_cases as fc};

fn assert_case(name: &str, res: &CaseResult) {
    let failed = res.failures();
    assert!(failed.is_empty(), "{name} failed:\n{}", failed.join("\n"));
}

fn single_fracture(n: usize, initial: InitialFluid, end: End) -> Scenario {
    fc::flow_scenario(
        "implicit_single",
        fc::net(
            vec![Fracture {
                from: [0.0, 0.0],
                to: [10.0, 0.0],
                aperture: 1e-4,
            }],
            None,
            10.0 / n as f64,
        ),
        vec![
            fc::bc(
                "in",
                FlowTarget::Node(Coords::two([0.0, 0.0])),
                FlowBcKind::Pressure(1e6),
            ),
            fc::bc(
                "out",
                FlowTarget::Node(Coords::two([10.0, 0.0])),
                FlowBcKind::Pressure(0.0),
            ),
        ],
        initial,
        end,
        fc::WATER,
    )
}

/// Item 10: backward-Euler steps of ten diffusion times L^2/D from a fracture full at rest damp
/// the slowest mode by 1/(1 + 10 pi^2/4) ~ 0.039 each (not exp(-24.7): backward Euler), so after
/// eight steps the transient is below 6e-12 of the pressure drop. The state must then match the
/// direct sparse solve cell by cell to 1e-9 of the drop (the flux pressures, and the pressures of
/// the stored masses, which differ from them by the Newton residual, here below 1e-12 K =
/// 2e-3 Pa), and the inlet rate the cubic law Q = a^3 dp / (12 mu L) to 1e-9. The system is
/// linear once every cell is full, so Newton needs at most two linear solves per step.
#[test]
fn one_long_step_reaches_the_direct_steady_solution() {
    let mut direct = Simulation::new(
        single_fracture(40, InitialFluid::Full(0.0), End::SteadyDirect)
            .validate()
            .unwrap(),
        &[],
    )
    .unwrap();
    direct.run(|_| {}).unwrap();
    let pd = direct.flow().unwrap().view.pressure.clone();
    let dt = fc::long_step(1e-4, 10.0);
    let sc = fc::implicit(
        single_fracture(40, InitialFluid::Full(0.0), End::Time(8.0 * dt)),
        dt,
    );
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    sim.run(|_| {}).unwrap();
    assert_eq!(sim.step(), 8);
    let f = sim.flow().unwrap();
    let solver = f.implicit.as_ref().unwrap();
    assert!(solver.last_iterations <= 2, "{solver:?}");
    assert!(solver.last_residual <= 1e-12, "{solver:?}");
    assert_eq!(pd.len(), f.view.n_cells());
    for (c, &pdc) in pd.iter().enumerate() {
        let p = pressure_of(f.view.excess[c], f.view.volume[c], &sim.params().fluid);
        assert!((p - pdc).abs() < 1e-9 * 1e6, "cell {c}: {p} vs {pdc}");
        // The view's pressure is the end-of-step pressure used for the fluxes.
        assert!((f.view.pressure[c] - pdc).abs() < 1e-9 * 1e6);
    }
    let q = fc::rate(&sim, "in");
    let exact = 1e-12 * 1e6 / (12.0 * fc::WATER.viscosity * 10.0);
    assert!((q - exact).abs() < 1e-9 * exact, "{q} vs {exact}");
    let (_, _, _, err) = sim.flow_balance().unwrap();
    assert!(err < 1e-14, "balance {err}");
}

/// Items 10 and 13 through the verification cases: cubic law (single, X and T junctions) and
/// the pump operating point, explicit and implicit beside the direct solve and the closed form.
#[test]
fn cubic_law_and_pump_curve_both_schemes() {
    let res = fc::cubic_law(true).unwrap();
    assert_case("cubic_law", &res);
    assert_eq!(res.errors("single_implicit_vs_direct").len(), 3);
    let res = fc::pump_curve(true).unwrap();
    assert_case("pump_curve", &res);
    assert_eq!(res.errors("pump_rate_implicit").len(), 2);
}

/// Item 11: backward Euler is first order in time. On the finest quick mesh the difference to
/// the explicit run (same space discretisation, time error negligible) must halve with dt:
/// observed order in [0.9, 1.1] (the case's check), and fall monotonically over 10..160 steps.
#[test]
fn diffusion_time_error_is_first_order() {
    let res = fc::diffusion(true).unwrap();
    assert_case("diffusion", &res);
    let e = res.errors("time_error_implicit_dt");
    assert_eq!(e.len(), 5);
    for w in e.windows(2) {
        assert!(w[1].1 < 0.6 * w[0].1, "not falling with dt: {e:?}");
    }
}

/// Item 12: injected - produced = stored change to 1e-12 relative after every step, over a pump
/// on / off / on run that starts from empty cells (the filling branch P = 0 and the full
/// branch both in play), for the implicit scheme at its default step (29x the explicit bound)
/// and at 1 ms, 10 ms and 0.1 s (56x to 5,600x the bound). With 10 ms the pump restart at
/// 1.5 s lands on cells just at the kink e = 0, where plain backtracking stalled; the line
/// search's kink candidate must get through. The injected volume agrees with the explicit run
/// within 5e-3 for the two shorter steps (O(dt) time error; measured 6e-5 and 4e-5) and 5e-2
/// for the longer ones.
#[test]
fn implicit_mass_balance_pump_on_off_on_from_empty() {
    let (ex, _, worst_ex, _) = fc::mass_balance_run(2.0, None).unwrap();
    assert!(worst_ex < 1e-12);
    let inj_ex = ex.flow_balance().unwrap().0;
    for (dt, agree) in [
        (None, 5e-3),
        (Some(1e-3), 5e-3),
        (Some(1e-2), 5e-2),
        (Some(0.1), 5e-2),
    ] {
        let (im, _, worst, mixed) = fc::mass_balance_run(2.0, Some(dt)).unwrap();
        assert!(worst < 1e-12, "dt {dt:?}: balance {worst}");
        assert!(mixed > 0, "no filling front");
        let f = im.flow().unwrap();
        assert_eq!(f.substeps, 1);
        let s = f.implicit.as_ref().unwrap();
        assert_eq!(s.symbolic_count(), 1, "one symbolic LU for the run");
        let inj = im.flow_balance().unwrap().0;
        assert!(
            (inj - inj_ex).abs() < agree * inj_ex,
            "dt {dt:?}: injected {inj} vs explicit {inj_ex}"
        );
    }
}

/// The symbolic factorisation is reused while the pattern is unchanged and redone when it
/// changes (a different network in the same solver).
#[test]
fn symbolic_factorisation_reused_until_the_pattern_changes() {
    let mut solver = ImplicitSolver::new();
    for n in [20, 40] {
        let mut sim = Simulation::new(
            single_fracture(n, InitialFluid::Full(0.0), End::Time(1.0))
                .validate()
                .unwrap(),
            &[],
        )
        .unwrap();
        let specs = sim.scenario().flow_boundaries.clone();
        let fp = sim.params().fluid;
        let f = sim.flow_mut().unwrap();
        let dt = 100.0 * f.dt_crit;
        for k in 0..5 {
            implicit_step(&mut f.view, &fp, &specs, dt, k as f64 * dt, &mut solver).unwrap();
        }
    }
    assert_eq!(solver.symbolic_count(), 2);
    assert_eq!(solver.steps, 10);
}

/// A Newton failure is an error naming the step, the cell and its residual, not a NaN: the
/// filling run with 0.1 s steps (the well fracture fills within a few steps, so some step
/// turns cells from filling to full and needs more than one linear solve) and the iteration
/// cap forced to 1.
#[test]
fn newton_failure_names_step_cell_and_residual() {
    let (sim, ..) = fc::mass_balance_run(2.0, Some(Some(0.1))).unwrap();
    let mut sc = sim.scenario().clone();
    sc.time.dt = Some(0.1);
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    sim.flow_mut().unwrap().implicit.as_mut().unwrap().max_iter = 1;
    let err = loop {
        match sim.step_once() {
            Ok(()) => assert!(sim.step() < 20, "a one-iteration Newton never failed"),
            Err(e) => break e,
        }
    };
    let msg = err.to_string();
    let RunError::ImplicitFlow { step, source, .. } = err else {
        panic!("unexpected error {err}");
    };
    assert!(step >= 1);
    let ImplicitError::NotConverged { residual, cell, .. } = *source else {
        panic!("unexpected error {source}");
    };
    assert!(residual.is_finite() && residual > 1e-12, "{residual}");
    assert!(cell.starts_with("cell "), "{cell}");
    assert!(
        msg.contains("step ") && msg.contains("cell ") && msg.contains("residual"),
        "{msg}"
    );
}

/// Deterministic: the same bits for 1 and 2 threads (the implicit step is sequential; the
/// explicit sub-steps and the monitor around it are not).
#[test]
fn implicit_same_bits_for_any_thread_count() {
    let run = |threads: usize| {
        crate::support_bits::on_threads(threads, || {
            let (sim, ..) = fc::mass_balance_run(2.0, Some(Some(1e-3))).unwrap();
            let f = sim.flow().unwrap();
            let mut bits: Vec<u64> = f.view.excess.iter().map(|x| x.to_bits()).collect();
            bits.extend(f.view.bcs.iter().map(|b| b.volume_in.to_bits()));
            bits
        })
    };
    assert_eq!(run(1), run(2));
}

/// The scenario switch: `time.flow_scheme` parses (default Explicit), unknown values are
/// rejected, and `time.flow_dt` with the implicit scheme in a scene with a rock mesh is refused.
#[test]
fn scenario_switch() {
    let path = std::path::Path::new("scenarios/flow_single_fracture.ron");
    let sc = Scenario::load(path, &[]).unwrap();
    assert_eq!(sc.time.flow_scheme, FlowScheme::Explicit);
    let sc = Scenario::load(path, &["time.flow_scheme=\"Implicit\"".into()]).unwrap();
    assert_eq!(sc.time.flow_scheme, FlowScheme::Implicit);
    assert!(Scenario::load(path, &["time.flow_scheme=\"Crank\"".into()]).is_err());
    // Edited after loading: taken apart, and validated again (refused).
    let mut sc = Scenario::load(std::path::Path::new("scenarios/insitu_stress.ron"), &[])
        .unwrap()
        .into_inner();
    sc.time.flow_scheme = FlowScheme::Implicit;
    sc.time.flow_dt = Some(1e-6);
    let e = sc.validate().unwrap_err().to_string();
    assert!(e.contains("time.flow_dt"), "{e}");
}

/// The CLI with the switch: the shipped single-fracture scene run implicitly with 0.5 s steps
/// reaches the cubic law (1e-8, the scene's steady tolerance 1e-10) with one flow step per step
/// and the explicit stability check skipped (the step is about 1e5 x the explicit bound).
#[test]
fn cli_single_fracture_implicit() {
    let out = cli::tmp("implicit");
    let s = cli::run_ok(
        "scenarios/flow_single_fracture.ron",
        &out,
        &[
            "--set",
            "time.flow_scheme=\"Implicit\"",
            "--set",
            "time.dt=0.5",
        ],
    );
    assert_eq!(s["finish"], "converged");
    assert_eq!(s["flow"]["substeps"], 1);
    assert!(s["flow"]["dt"].as_f64().unwrap() > 1e3 * s["flow"]["dt_critical"].as_f64().unwrap());
    let q = s["flow"]["boundaries"][0]["rate"].as_f64().unwrap();
    let exact = 1e-12 * 2e6 / (12.0 * 8.9e-4 * 10.0);
    assert!((q - exact).abs() < 1e-8 * exact, "{q} vs {exact}");
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
    let _ = std::fs::remove_dir_all(&out);
}

// With a rock mesh the network is the rock's fractures (a coupled run; a rigid network cannot
// be combined with a mesh): one implicit step per solid step is tested in tests/coupling.rs
// (`explicit_and_implicit_schemes_agree`).

/// The chord iterations (the kept factor of an earlier Jacobian, `ImplicitSolver::chord`)
/// reach Newton's answer: on the fracture filling from empty through the 1 MPa inlet (cells
/// switch from filling to full, so the kept Jacobian is sometimes wrong and Newton takes
/// over) and then draining towards steady flow, 40 steps of 20 explicit bounds each, every
/// cell's excess mass and pressure agree with the solver that factorises at every iteration
/// to 1e-9 of the cell's reference mass and of the pressure drop (each step converges to a
/// relative mass residual of 1e-12, so the two differ by about that per step; 1e-9 leaves
/// room for 40 steps and the filling's kinks, not for a wrong direction, which would stop
/// short of the tolerance or fail). The chord saves factorisations: fewer than half of the
/// Newton-only run's.
#[test]
fn chord_iterations_reach_newtons_answer_with_fewer_factorisations() {
    let sim = Simulation::new(
        single_fracture(40, InitialFluid::Empty, End::Time(1.0))
            .validate()
            .unwrap(),
        &[],
    )
    .unwrap();
    let specs = sim.scenario().flow_boundaries.clone();
    let fp = sim.params().fluid;
    let f0 = sim.flow().unwrap();
    let dt = 20.0 * f0.dt_crit;
    let run = |chord: bool| {
        let mut view = f0.view.clone();
        let mut solver = ImplicitSolver::new();
        solver.chord = chord;
        for k in 0..40 {
            implicit_step(&mut view, &fp, &specs, dt, k as f64 * dt, &mut solver).unwrap();
        }
        (view, solver)
    };
    let (vc, sc) = run(true);
    let (vn, sn) = run(false);
    assert!(sc.chord_iterations > 0 && sn.chord_iterations == 0);
    assert!(
        2 * sc.factorisations < sn.factorisations,
        "chord {} factorisations, Newton {}",
        sc.factorisations,
        sn.factorisations
    );
    for c in 0..vc.n_cells() {
        let m_ref = fp.rho_r * vc.volume[c];
        assert!(
            (vc.excess[c] - vn.excess[c]).abs() <= 1e-9 * m_ref,
            "cell {c}: excess {} vs {}",
            vc.excess[c],
            vn.excess[c]
        );
        assert!(
            (vc.pressure[c] - vn.pressure[c]).abs() <= 1e-9 * 1e6,
            "cell {c}: pressure {} vs {}",
            vc.pressure[c],
            vn.pressure[c]
        );
    }
}

/// The assembled Jacobian equals central finite differences of the residual, column by
/// column, on a T junction with a pump (open, on its curve), a production rate and a
/// pressure boundary, with cells both full (y > 0) and filling (y < 0): relative error
/// 1e-6 of the column's largest entry (the differences have truncation error O(h^2) with
/// h = 1e-4 |y_j|, well inside every cell's branch of the pressure law, and round-off
/// about eps |r| / h ~ 1e-10 of the entries). A wrong sign, a missing pair or a pump
/// derivative taken at fixed rate shows up at order 1.
#[test]
fn jacobian_matches_finite_differences() {
    let fr = |a: [f64; 2], b: [f64; 2], ap: f64| Fracture {
        from: a,
        to: b,
        aperture: ap,
    };
    let sc = fc::flow_scenario(
        "fd",
        fc::net(
            vec![
                fr([0.0, 0.0], [5.0, 0.0], 2e-4),
                fr([5.0, 0.0], [10.0, 0.0], 1e-4),
                fr([5.0, 0.0], [5.0, 5.0], 1.5e-4),
            ],
            None,
            1.0,
        ),
        vec![
            fc::bc(
                "pump",
                FlowTarget::Node(Coords::two([0.0, 0.0])),
                FlowBcKind::Pump {
                    p_max: 18e6,
                    q_half: 1e-5,
                },
            ),
            fc::bc(
                "prod",
                FlowTarget::Node(Coords::two([10.0, 0.0])),
                FlowBcKind::Rate(-1e-6),
            ),
            fc::bc(
                "side",
                FlowTarget::Node(Coords::two([5.0, 5.0])),
                FlowBcKind::Pressure(3e6),
            ),
        ],
        InitialFluid::Full(1e6),
        End::Time(1.0),
        fc::WATER,
    );
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let specs = sim.scenario().flow_boundaries.clone();
    let fp = sim.params().fluid;
    let f = sim.flow_mut().unwrap();
    let v = &mut f.view;
    let n = v.n_cells();
    let dt = 50.0 * f.dt_crit;
    let w: Vec<f64> = (0..n).map(|i| dt * fp.k / v.volume[i]).collect();
    let y0 = vec![0.0; n];
    // Mixed states, away from the kink: every third cell filling.
    let y: Vec<f64> = (0..n)
        .map(|i| {
            let m = 1e6 * (1.5 + (i as f64 * 0.7).sin());
            if i % 3 == 1 { -0.3 * m } else { m }
        })
        .collect();
    assert!(y.iter().any(|&x| x < 0.0) && y.iter().any(|&x| x > 0.0));
    let pat = Pattern::build(v).unwrap();
    let (mut net, mut r) = (vec![0.0; n], vec![0.0; n]);
    residual(v, &specs, 1.0, &y, &y0, &w, &mut net, &mut r);
    assert!(v.bcs[0].rate > 0.0, "the pump is open");
    let mut values = Vec::new();
    assemble(v, &specs, 1.0, &y, &w, &pat, &mut values);
    let mut dense = vec![0.0; n * n];
    for col in 0..n {
        for s in pat.sparse.col_ptr()[col]..pat.sparse.col_ptr()[col + 1] {
            dense[pat.sparse.row_idx()[s] * n + col] = values[s];
        }
    }
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        let h = 1e-4 * y[j].abs();
        let mut yp = y.clone();
        yp[j] += h;
        residual(v, &specs, 1.0, &yp, &y0, &w, &mut net, &mut rp);
        let mut ym = y.clone();
        ym[j] -= h;
        residual(v, &specs, 1.0, &ym, &y0, &w, &mut net, &mut rm);
        let fd: Vec<f64> = (0..n).map(|i| (rp[i] - rm[i]) / (2.0 * h)).collect();
        let big = fd.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        for i in 0..n {
            let e = (dense[i * n + j] - fd[i]).abs() / big;
            assert!(
                e < 1e-6,
                "J[{i},{j}] = {} vs finite difference {} (y_j = {})",
                dense[i * n + j],
                fd[i],
                y[j]
            );
        }
    }
}
