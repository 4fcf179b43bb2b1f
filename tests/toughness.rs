//! The toughness criterion (`systems/toughness.rs`, `docs/toughness.md`): stress intensity
//! factors of static cracks against closed forms, and a toughness-dominated KGD fracture grown
//! at its tip against the similarity solution (`docs/verification.md` R7, R7b). The verify
//! cases `sif` and `kgd_k` run the same at more resolutions.

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;
use hydrofrac::verify::coupled_cases::{Regime, kgd_run_in};
use hydrofrac::verify::sif_cases::CrackMesh;
use hydrofrac::verify::sif_cases::{CrackLoad, crack_sif};
use std::f64::consts::PI;

/// Sneddon's pressurised crack at a/h = 20: K_I = p sqrt(pi a) within 2.5 % (measured -1.9 %
/// raw: the linear elements' stiffness, -4.2 % in area at this a/h, and +0.37 % from the fixed
/// edges at 20a), K_II zero to 1e-3 (the diagonal pattern is not mirror-symmetric about the
/// crack), and the same at both tips.
#[test]
fn pressurised_crack_k_i_matches_sneddon() {
    let (a, p) = (1.0, 1e6);
    let r = crack_sif(
        a,
        a / 20.0,
        20.0 * a,
        0.0,
        CrackLoad::Pressure(p),
        CrackMesh::Snapped,
    )
    .unwrap();
    let k = p * (PI * a).sqrt();
    for tip in 0..2 {
        let e = r.k1[tip] / k - 1.0;
        assert!(e.abs() < 0.025, "tip {tip}: K_I error {e:.4}");
        assert!(
            r.k2[tip].abs() / k < 1e-3,
            "tip {tip}: K_II / K = {:.2e}",
            r.k2[tip] / k
        );
    }
    assert!((r.k1[0] - r.k1[1]).abs() / k < 1e-6);
    // Growth straight ahead.
    assert!(r.theta[1].abs() < 1e-2, "theta {}", r.theta[1]);
}

/// A 45-degree crack under remote uniaxial tension: K_I = K_II = sigma sqrt(pi a) / 2 within
/// 2.5 % (measured -1.5 / -1.6 % at a/h = 19.8), and the maximum hoop stress angle -53.13
/// degrees within 0.5 degree (measured -53.11).
#[test]
fn inclined_crack_under_tension_mixed_mode() {
    let (a, s) = (1.0, 1e6);
    let h = a / (14.0 * 2f64.sqrt());
    let r = crack_sif(
        a,
        h,
        20.0 * a,
        0.25 * PI,
        CrackLoad::TensionY(s),
        CrackMesh::Snapped,
    )
    .unwrap();
    let k = 0.5 * s * (PI * a).sqrt();
    for tip in 0..2 {
        let (e1, e2) = (r.k1[tip] / k - 1.0, r.k2[tip].abs() / k - 1.0);
        assert!(
            e1.abs() < 0.025 && e2.abs() < 0.025,
            "tip {tip}: K_I {e1:.4}, K_II {e2:.4}"
        );
        let theta = r.theta[tip].abs().to_degrees();
        assert!((theta - 53.13).abs() < 0.5, "tip {tip}: theta {theta}");
    }
}

/// A crack at 30 degrees, no direction of the regular or graded meshes, on a mesh that follows
/// it, under remote uniaxial tension: K_I = sigma sqrt(pi a) cos^2(30), K_II = sigma sqrt(pi a)
/// sin(30) cos(30) within 2.5 % at a/h = 20 (measured -0.7 % and -1.1 %; the straight-crack
/// discretisation error of the pressurised crack is -1.3 % here), and the maximum hoop stress
/// angle within 0.5 degree of the closed form's.
#[test]
fn crack_at_30_degrees_on_a_conforming_mesh_mixed_mode() {
    let (a, s) = (1.0, 1e6);
    let angle = PI / 6.0;
    let r = crack_sif(
        a,
        a / 20.0,
        20.0 * a,
        angle,
        CrackLoad::TensionY(s),
        CrackMesh::Conforming,
    )
    .unwrap();
    assert!(r.snap_error < 1e-9, "snapping error {}", r.snap_error);
    let k0 = s * (PI * a).sqrt();
    let (k1, k2) = (k0 * angle.cos().powi(2), k0 * angle.sin() * angle.cos());
    let theta_exact = hydrofrac::systems::toughness::max_hoop_stress(k1, k2)
        .0
        .abs()
        .to_degrees();
    for tip in 0..2 {
        let (e1, e2) = (r.k1[tip] / k1 - 1.0, r.k2[tip].abs() / k2 - 1.0);
        assert!(
            e1.abs() < 0.025 && e2.abs() < 0.025,
            "tip {tip}: K_I {e1:.4}, K_II {e2:.4}"
        );
        let theta = r.theta[tip].abs().to_degrees();
        assert!(
            (theta - theta_exact).abs() < 0.5,
            "tip {tip}: theta {theta} against {theta_exact}"
        );
    }
}

/// `scenarios/kgd_toughness.ron` (dimensionless toughness 4.9) at h = 2 m, 15 cells along the
/// final half-length: the fracture grows only at its tip (no strength test runs) and along
/// y = 0, conserves mass to 1e-9, and the tracked tip's half-length is within 4 % of the
/// toughness-dominated solution at 140 s (measured +3.4 %; the mesh tip is +6.6 %), and the
/// well pressure and opening stay within 11 % of the solution over the last fifth of the run.
#[test]
fn toughness_kgd_grows_at_the_tip_to_the_similarity_length() {
    let r = kgd_run_in(2.0, "QuasiStatic", &[], Regime::Toughness(5e6)).unwrap();
    assert!(r.balance < 1e-9, "mass balance {:.2e}", r.balance);
    let e = (r.l_tracked - r.exact[0]) / r.exact[0];
    assert!(
        e.abs() < 0.04,
        "tracked length {} against {}",
        r.l_tracked,
        r.exact[0]
    );
    assert!(
        r.l > 20.0,
        "the fracture grew from its 2 m notch: l = {}",
        r.l
    );
    // Between splits the well pressure and opening follow a saw-tooth about the solution
    // (measured over 112-140 s: pressure -8.9 to +0.7 %, opening -5.5 to -0.5 %, 21 steps).
    let b = r
        .band
        .expect("a toughness run measures its saw-tooth")
        .range(0.8 * 140.0);
    assert!(b.steps >= 10, "{} steps in the last fifth", b.steps);
    for (what, [lo, hi]) in [("pressure", b.p), ("opening", b.w)] {
        assert!(
            lo <= hi && lo.abs().max(hi.abs()) < 0.11,
            "{what} error over the last fifth {lo:+.3} to {hi:+.3}"
        );
    }
    // Water fills an opened edge within a step: no fluid lag, as the toughness asymptote that
    // places the tracked tip assumes.
    assert_eq!(r.lag, 0.0, "fluid lag");
    let src = std::fs::read_to_string("scenarios/kgd_toughness.ron").unwrap();
    let sc = Scenario::parse(&src, "kgd_toughness.ron").unwrap();
    let mut sim = Simulation::new(
        sc.with_overrides(&["time.end=Time(40.0)".into()])
            .unwrap()
            .validate()
            .unwrap(),
        &[],
    )
    .unwrap();
    sim.run(|_| {}).unwrap();
    let fr = sim.fracture();
    assert_eq!(
        fr.strength_counts.evaluated + fr.strength_counts.screened,
        0
    );
    assert!(fr.tips.evaluations > 0);
    assert_eq!(
        fr.tips.geometry.len(),
        1,
        "one tip (the well end lies on the symmetry plane)"
    );
    for j in &sim.solid().joint_nodes {
        for n in j {
            assert!(
                sim.solid().x0[*n as usize][1].abs() < 1e-9,
                "a joint off the line y = 0"
            );
        }
    }
}

/// The viscosity-dominated KGD grown by the toughness criterion (`scenarios/kgd_m.ron`, K_Ic =
/// 2.4 MPa sqrt(m)) at h = 2 m, t = 3.25 s (15 cells along the half-length), against the
/// similarity solution (`docs/toughness.md`, "The fluid at a viscous tip"):
/// - as shipped (`LinearOpening`, `filling: FrontInCell`): fluid front, well opening and net
///   well pressure within the issue's 3 % at 15-20 cells (measured +0.6, +0.8, +2.5 %);
/// - with `filling: Dry` (the seed's: the cell the fluid is filling carries zero on its whole
///   face) the dry cell's closing load holds the tip back, and the pressure error is more than
///   1.5 times as large (measured -1.5, +2.4, +5.1 %);
///   (with the seed's `CellMean` transmissibility as well it is -8.7, +8.0, +14.6 %: `verify kgd`
///   and `flow::tests::linear_opening_transmissibility_and_its_slopes`);
/// - all: mass conserved; the mesh tip runs into the cell the fluid is filling, 1-2 cells
///   (2-4 m) ahead of the last full cell (measured 2 m). The bound fails if the lag grows.
#[test]
fn viscous_kgd_with_toughness_the_front_in_the_tip_cell_and_the_linear_opening() {
    let run = |sets: &[&str]| {
        let mut extra = vec!["time.end=Time(3.25)".to_string()];
        extra.extend(sets.iter().map(|s| s.to_string()));
        kgd_run_in(
            2.0,
            "QuasiStatic",
            &extra,
            Regime::ViscosityToughness(2.4e6),
        )
        .unwrap()
    };
    let shipped = run(&[]);
    let dry = run(&["fluid.filling=Dry"]);
    for r in [&shipped, &dry] {
        assert!(r.balance < 1e-9, "mass balance {:.2e}", r.balance);
        assert!(
            r.lag >= 2.0 - 1e-9 && r.lag <= 4.0 + 1e-9,
            "fluid lag {} m (1-2 cells of 2 m expected)",
            r.lag
        );
    }
    let e = shipped.errors_front();
    for k in 0..3 {
        assert!(e[k].abs() < 0.03, "kgd_m.ron errors {e:?}");
    }
    let ed = dry.errors_front();
    assert!(
        ed[2].abs() > 1.5 * e[2].abs(),
        "filling Dry {ed:?} against FrontInCell {e:?}"
    );
}

/// `criterion: Some(Strength(x))` is `strength: Some(x)`: the same run to the bit; both given
/// is refused, naming the field.
#[test]
fn strength_criterion_by_name_is_the_old_field() {
    let src = std::fs::read_to_string("scenarios/kgd.ron").unwrap();
    let run = |text: &str| {
        let sc = Scenario::parse(text, "kgd.ron")
            .unwrap()
            .with_overrides(&[
                "mesh.h=2.0".into(),
                "time.solid_scheme=QuasiStatic".into(),
                "time.end=Time(1.0)".into(),
            ])
            .unwrap();
        let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
        sim.run(|_| {}).unwrap();
        (sim.solid().u.clone(), sim.solid().joint_nodes.len())
    };
    let named = src.replace(
        "strength: Some(0.1e6),",
        "criterion: Some(Strength(0.1e6)),",
    );
    assert_ne!(named, src);
    let (a, b) = (run(&src), run(&named));
    assert!(a.1 > 2, "the fracture grew");
    assert_eq!(a, b);
    let both = src.replace(
        "strength: Some(0.1e6),",
        "strength: Some(0.1e6), criterion: Some(Strength(0.1e6)),",
    );
    let err = Scenario::parse(&both, "kgd.ron")
        .unwrap()
        .validate()
        .expect_err("refused");
    assert!(err.to_string().contains("fracture.criterion"), "{err}");
}

/// The displacement-correlation screen (`DC_SCREEN`) skips the integrals at tips far from
/// K_Ic without changing the run: the toughness KGD at h = 2 m gives the same displacements to
/// the bit with and without it, and the screen did pass tips over.
#[test]
fn the_tip_screen_changes_nothing() {
    let src = std::fs::read_to_string("scenarios/kgd_toughness.ron").unwrap();
    let run = |screen: bool| {
        let sc = Scenario::parse(&src, "kgd_toughness.ron")
            .unwrap()
            .with_overrides(&["time.end=Time(60.0)".into()])
            .unwrap();
        let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
        sim.fracture_mut().tips.no_screen = !screen;
        sim.run(|_| {}).unwrap();
        let t = &sim.fracture().tips;
        (
            sim.solid().u.clone(),
            sim.solid().joint_nodes.len(),
            t.screened,
            t.evaluations,
        )
    };
    let (a, b) = (run(true), run(false));
    assert_eq!((a.0, a.1), (b.0, b.1));
    assert_eq!(b.2, 0);
    assert!(a.2 > 0 && a.2 < a.3, "screened {} of {}", a.2, a.3);
}

/// Tips within `TRUSTED_RADIUS_EDGES` of another fracture are not trusted: their K decides
/// nothing, so the criterion's passes skip their integrals without changing the run. A
/// pressurised crack whose right tip is half an edge from a second fracture (untrusted) and
/// whose left tip is free (trusted), explicit rock: the same displacements and splits to the
/// bit with the untrusted tips evaluated and passed over, and passed over at every pass.
///
/// (The displacement-correlation screen alone is not neutral on this scene: under the
/// pressure applied at once on a rock at rest the faces' traction terms give the integrals a
/// K_eq past K_Ic while the pair behind has not opened yet; measured 58 joints with the
/// screen against 64 without, docs/toughness.md.)
#[test]
fn untrusted_tips_are_passed_over_without_changing_the_run() {
    let src = r#"(
        name: "untrusted",
        mesh: Regular(width: 20.0, height: 20.0, h: 0.5),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: InSitu(sxx: -1e6, syy: -1e6),
        initial_state: InSitu,
        fracture: Some((
            criterion: Some(Toughness(k_ic: 1.5e6)),
            residual_aperture: 1e-4,
            pressure: Some(4e6),
            preexisting: [(from: (4.0, 10.0), to: (12.0, 10.0)),
                          (from: (12.5, 6.0), to: (12.5, 14.0))],
        )),
        time: (end: Time(2e-3)),
        damping: Local(0.8),
    )"#;
    let run = |keep_untrusted: bool| {
        let sc = Scenario::parse(src, "untrusted.ron").unwrap();
        let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
        sim.fracture_mut().tips.keep_untrusted = keep_untrusted;
        sim.run(|_| {}).unwrap();
        let t = &sim.fracture().tips;
        let untrusted = t.geometry.iter().filter(|g| !g.trusted).count();
        (
            sim.solid().u.clone(),
            sim.solid().joint_nodes.len(),
            t.screened,
            t.evaluations,
            untrusted,
        )
    };
    let (a, b) = (run(false), run(true));
    assert_eq!(
        (&a.0, a.1),
        (&b.0, b.1),
        "skipping untrusted tips changed the run"
    );
    assert!(a.1 > 40, "the crack did not grow: {} joints", a.1);
    assert!(a.4 >= 1, "no untrusted tip");
    // The evaluations are the same; the untrusted tip was passed over where the
    // displacement-correlation screen had not passed it over already (measured 66 against 43
    // of 92).
    assert_eq!(a.3, b.3);
    assert!(a.2 > b.2, "screened {} against {} of {}", a.2, b.2, a.3);
}

/// The seed's crossing case with the toughness criterion (K_Ic = 38.5 MPa sqrt(m), the
/// toughness the strength test acts like on this mesh; initiation by the seed's 1 MPa away
/// from tips), quasi-static: the hydraulic fracture reaches the pre-existing one at x = 16 m,
/// exactly one new fracture starts on its far face near y = 50 m (one per neighbourhood:
/// without the rule three started one edge apart, at y = 49, 50, 51, and arrested), and it runs
/// on past x = 17 m along y = 50 m as in the seed's Fig. 7 (measured: to x = 28 m by 1.5 s).
#[test]
fn example1_cross_with_toughness_crosses() {
    let v = example1_toughness("cross", 1.5);
    let mut far_face = 0;
    let mut reach: f64 = 0.0;
    for c in 0..v.n_cells() {
        let [a, b] = v.cell_nodes[c].map(|n| v.node_ref[n as usize]);
        let (x0, x1) = (a[0].min(b[0]), a[0].max(b[0]));
        if (x0 - 16.0).abs() < 1e-6 && (x1 - 17.0).abs() < 1e-6 && (a[1] - 50.0).abs() < 1.5 {
            far_face += 1;
        }
        if (a[1] - 50.0).abs() < 1e-6 && (b[1] - 50.0).abs() < 1e-6 {
            reach = reach.max(x1);
        }
    }
    assert_eq!(
        far_face, 1,
        "new fractures on the far face within 1 m of y = 50 m"
    );
    assert!(reach > 20.0, "the crossing fracture reaches x = {reach}");
}

/// The crossing case on the explicit rock: the new fracture's tip on the far face is within
/// one edge of the vertical fracture, where the integrals' disc is cut to one edge and K is not
/// measured well (it arrested at x = 17 m when the toughness criterion decided there). With
/// another fracture within `TRUSTED_RADIUS_EDGES` the strength test decides, and the fracture
/// runs on (measured: x = 18 m at 0.62 s, 20 m at 0.76 s, 32 m at 1.5 s; the strength
/// criterion's run reaches 43 m).
#[test]
fn example1_cross_with_toughness_crosses_on_the_explicit_rock() {
    let v = example1_toughness_scheme("cross", 0.8, "Explicit");
    let mut reach: f64 = 0.0;
    let mut off = 0;
    for c in 0..v.n_cells() {
        let [a, b] = v.cell_nodes[c].map(|n| v.node_ref[n as usize]);
        let horizontal = (a[1] - b[1]).abs() < 1e-6;
        if horizontal && (a[1] - 50.0).abs() < 1e-6 {
            reach = reach.max(a[0].max(b[0]));
        } else if horizontal && a[0].min(b[0]) >= 16.0 - 1e-6 {
            off += 1;
        }
    }
    assert!(reach >= 19.0, "the crossing fracture reaches x = {reach}");
    assert_eq!(off, 0, "new fractures off y = 50 m beyond the vertical one");
}

/// The seed's offset case with the same toughness criterion, quasi-static: nothing starts on
/// the far side at y = 50 m, and new fractures start beside the closed vertical fracture 1 m
/// inside its tips (y = 47 and 53 m), where the seed's do: the strength test runs there
/// because a closed tip is not skipped (measured: both at 0.64 s; with the vertical fracture
/// within `TRUSTED_RADIUS_EDGES` of their tips the strength test carries them on; on the
/// explicit rock they reach x = 19 m by 1.5 s, the strength criterion's 20 m).
#[test]
fn example1_offset_with_toughness_branches_near_the_tips() {
    let v = example1_toughness("offset", 0.8);
    let (mut beyond, mut below, mut above) = (0, 0, 0);
    for c in 0..v.n_cells() {
        let [a, b] = v.cell_nodes[c].map(|n| v.node_ref[n as usize]);
        let y = 0.5 * (a[1] + b[1]);
        if a[0].min(b[0]) >= 16.0 - 1e-6 && (a[1] - b[1]).abs() < 1e-6 {
            match y {
                y if (y - 50.0).abs() < 0.5 => beyond += 1,
                y if (45.0..=49.0).contains(&y) => below += 1,
                y if (51.0..=55.0).contains(&y) => above += 1,
                _ => {}
            }
        }
    }
    assert_eq!(beyond, 0, "a fracture on the far side at y = 50 m");
    assert!(
        below >= 1 && above >= 1,
        "branches near the tips: {below} below, {above} above"
    );
}

/// The network of `scenarios/example1_NAME.ron` run to `end` (s) with the toughness criterion
/// (K_Ic = 38.5 MPa sqrt(m), initiation 1 MPa) on the quasi-static rock.
fn example1_toughness(name: &str, end: f64) -> hydrofrac::flow::FlowView {
    example1_toughness_scheme(name, end, "QuasiStatic")
}

/// [`example1_toughness`] with the given solid scheme.
fn example1_toughness_scheme(name: &str, end: f64, scheme: &str) -> hydrofrac::flow::FlowView {
    let src = std::fs::read_to_string(format!("scenarios/example1_{name}.ron")).unwrap();
    let text = src.replace(
        "strength: Some(1e6),",
        "criterion: Some(Toughness(k_ic: 38.5e6, initiation: Some(1e6))),",
    );
    assert_ne!(text, src);
    let sc = Scenario::parse(&text, "example1.ron")
        .unwrap()
        .with_overrides(&[
            format!("time.solid_scheme={scheme}"),
            format!("time.end=Time({end})"),
        ])
        .unwrap();
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    sim.run(|_| {}).unwrap();
    sim.flow().unwrap().view.clone()
}

/// The viscous KGD under a confining stress of 120 MPa (`scenarios/kgd_m.ron`, s0 / p0 = 40.6,
/// h = 1 m, 31 cells) with a residual aperture of 5 % of the well opening: fill number R =
/// a_r^2 s0 / (12 mu h v_tip) = 8.5, above the rule's 2.5 (`docs/toughness.md`, "High
/// confinement"), so within 5 % of the M-vertex (measured front +0.9 %, opening -0.9 %,
/// pressure +4.2 %). Before the fluid's force was taken over the faces' reference length the
/// pressure was +23 %: the in-situ strain (0.43 %) shortened the faces it acted on.
#[test]
fn viscous_kgd_under_high_confinement_within_the_fill_number_rule() {
    let w0 = 14.623e-3;
    let r = kgd_run_in(
        1.0,
        "QuasiStatic",
        &[
            "boundary=InSitu(sxx: -120e6, syy: -120e6)".into(),
            format!("fracture.residual_aperture={:e}", 0.05 * w0),
        ],
        Regime::ViscosityToughness(2.4e6),
    )
    .unwrap();
    assert!((r.exact[1] / w0 - 1.0).abs() < 1e-3, "w0 {}", r.exact[1]);
    assert!(r.balance < 1e-9, "mass balance {:.2e}", r.balance);
    let e = r.errors_front();
    for k in 0..3 {
        assert!(e[k].abs() < 0.05, "errors {e:?}");
    }
}
