//! The quasi-static solid scheme (`time.solid_scheme: QuasiStatic`) against the explicit one
//! and closed forms: the same physics must give the same static answers.
//! - In-situ stress: uniform -20 / -10 MPa to round-off (one linear solve).
//! - Sneddon's crack (the shipped scenario, a/h = 20): the displacements of the explicit
//!   scheme's static relaxation (residual 1e-8) to 1e-6 relative.
//! - A joint pressed and sheared below the Coulomb limit sticks: no joint slides, the normal
//!   force sums to the applied load, as in the explicit scheme's friction test.
//! - A static run is one step; the factorisation is reused while nothing changes.

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};
use hydrofrac::systems::SystemId;

use crate::support_scenes as scenes;

fn load(path: &str, sets: &[&str]) -> Scenario {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    // Edited by the tests (the solid scheme, ...), so taken apart; validated again to run.
    Scenario::load(std::path::Path::new(path), &sets)
        .unwrap()
        .into_inner()
}

fn qs(sc: Scenario) -> Simulation {
    let sc = sc
        .with_overrides(&["time.solid_scheme=QuasiStatic".into()])
        .unwrap();
    Simulation::new(sc.validate().unwrap(), &[]).unwrap()
}

#[test]
fn insitu_stress_is_uniform_after_one_solve() {
    let mut sim = qs(load("scenarios/insitu_stress.ron", &[]));
    assert!(sim.schedule().is_enabled(SystemId::Solve));
    assert!(!sim.schedule().is_enabled(SystemId::Integrate));
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    assert_eq!(sim.step(), 1);
    let (mean, min, max) = sim.solid().stress_summary(&sim.params().solid);
    for (k, want) in [(0, -20e6), (1, -10e6), (2, 0.0)] {
        for s in [mean[k], min[k], max[k]] {
            assert!((s - want).abs() <= 1e-9 * 20e6, "stress {k}: {s} vs {want}");
        }
    }
}

#[test]
fn sneddon_matches_the_explicit_static_answer() {
    let sc = load("scenarios/sneddon.ron", &[]);
    let mut ex = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    assert_eq!(ex.run(|_| {}).unwrap(), Finish::Converged);
    let mut q = qs(sc);
    assert_eq!(q.run(|_| {}).unwrap(), Finish::Converged);
    assert_eq!(q.step(), 1);
    let scale = ex
        .solid()
        .u
        .iter()
        .fold(0.0f64, |m, u| m.max(u[0].abs()).max(u[1].abs()));
    let diff = ex
        .solid()
        .u
        .iter()
        .zip(&q.solid().u)
        .fold(0.0f64, |m, (a, b)| {
            m.max((a[0] - b[0]).abs()).max((a[1] - b[1]).abs())
        });
    // The explicit relaxation stops at a force residual of 1e-8; its displacement error is of
    // that order times the conditioning of the graded mesh, well below 1e-6.
    assert!(
        diff <= 1e-6 * scale,
        "max |u_qs - u_explicit| = {diff:.3e} m against max |u| = {scale:.3e} m"
    );
    // The crack opened: the joints' openings are positive and of Sneddon's size
    // 4 p (1 - nu^2) a / E = 1.92e-4 m at the centre.
    let open = q
        .solid()
        .joint_state
        .iter()
        .fold(0.0f64, |m, s| m.max(s.opening));
    assert!(
        (open - 1.92e-4).abs() < 0.06 * 1.92e-4,
        "max opening {open:e}"
    );
}

#[test]
fn joint_sticks_below_the_coulomb_limit() {
    let mu = 30f64.to_radians().tan();
    let sigma = 10e6;
    let tau = 0.8 * sigma * mu;
    let text = scenes::friction_block(tau, "Static(tol: 1e-9)");
    let mut sim = qs(Scenario::parse(&text, "friction.ron").unwrap());
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let states = &sim.solid().joint_state;
    assert_eq!(states.len(), 8);
    for (k, st) in states.iter().enumerate() {
        assert!(!st.sliding, "joint {k} slides");
        assert!(st.opening < 0.0, "joint {k} is open");
        assert!(
            st.shear_force.abs() < mu * st.normal_force,
            "joint {k}: {st:?}"
        );
    }
    let total: f64 = states.iter().map(|s| s.normal_force).sum();
    assert!(
        (total - 8.0 * sigma).abs() < 1e-6 * 8.0 * sigma,
        "total normal force {total:e} vs {:e}",
        8.0 * sigma
    );
}

/// A flow-only scene (no rock) is refused with the field and the reason; every shipped rock
/// scenario is accepted (the coupled ones included).
#[test]
fn bad_combinations_are_refused_with_the_field() {
    let sets = ["time.solid_scheme=QuasiStatic".to_string()];
    let path = "scenarios/flow_network.ron";
    let e = match Scenario::load(std::path::Path::new(path), &sets) {
        Ok(_) => panic!("{path}: QuasiStatic accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("time.solid_scheme") && e.contains("rock mesh"),
        "{e}"
    );
    for path in [
        "scenarios/example1_cross.ron",
        "scenarios/example1_offset.ron",
        "scenarios/kgd.ron",
        "scenarios/sneddon.ron",
        "scenarios/insitu_stress.ron",
    ] {
        let sc = Scenario::load(std::path::Path::new(path), &sets).unwrap();
        Simulation::new(sc, &[]).unwrap();
    }
}

/// A contact state that changes inside the Newton iteration: the block's joint starts closed
/// (touching faces carry the normal spring) and the prescribed lift of the top opens it, so the
/// iteration has to drop the springs and re-solve. Closed form: the upper block moves up
/// rigidly by the lift, every joint opens by exactly the lift, and no element is stressed.
#[test]
fn a_joint_that_opens_during_the_iteration_converges_to_the_rigid_lift() {
    let lift = 1e-4;
    let text = format!(
        r#"(
        name: "lift",
        mesh: Regular(width: 8.0, height: 4.0, h: 1.0),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: Sides(bottom: Fixed, top: Normal({lift})),
        pins: [(at: (0.0, 4.0), ux: 0.0)],
        fracture: Some((preexisting: [(from: (0.0, 2.0), to: (8.0, 2.0))])),
        time: (end: Static(tol: 1e-9)),
    )"#
    );
    let mut sim = qs(Scenario::parse(&text, "lift.ron").unwrap());
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let counts = sim.quasi_static_counts().unwrap();
    assert!(counts.numeric_factorisations >= 2, "{counts:?}");
    for (k, st) in sim.solid().joint_state.iter().enumerate() {
        assert!(
            (st.opening - lift).abs() <= 1e-9 * lift,
            "joint {k}: {st:?}"
        );
        assert_eq!((st.normal_force, st.shear_force), (0.0, 0.0), "joint {k}");
    }
    let (_, min, max) = sim.solid().stress_summary(&sim.params().solid);
    for k in 0..3 {
        assert!(
            min[k].abs().max(max[k].abs()) < 1.0,
            "stress {k}: {} .. {} Pa",
            min[k],
            max[k]
        );
    }
}

/// Past the Coulomb limit the block has no static equilibrium: the solve stops with an error
/// that names the step and says the joints slide, instead of iterating forever or writing NaN.
#[test]
fn sliding_past_the_friction_limit_is_a_clear_error() {
    let tau = 1.2 * 10e6 * 30f64.to_radians().tan();
    let text = scenes::friction_block(tau, "Static(tol: 1e-9)");
    let mut sim = qs(Scenario::parse(&text, "friction.ron").unwrap());
    let e = sim.run(|_| {}).expect_err("no equilibrium").to_string();
    assert!(e.contains("step 1") && e.contains("joints slide"), "{e}");
    assert!(
        sim.solid()
            .u
            .iter()
            .all(|u| u[0].is_finite() && u[1].is_finite())
    );
}
