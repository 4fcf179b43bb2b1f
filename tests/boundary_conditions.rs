//! Traction, normal-displacement and pin boundary conditions against closed-form plane-strain
//! states (a uniform state is exact for CST, so the tolerance is the relaxation's: 1e-6 relative
//! with a residual of 1e-10).

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;

fn solve(text: &str) -> Simulation {
    let sc = Scenario::parse(text, "test.ron")
        .unwrap()
        .validate()
        .unwrap();
    let mut sim = Simulation::new(sc, &[]).unwrap();
    let finish = sim.run(|_| {}).unwrap();
    assert_eq!(
        finish,
        hydrofrac::sim::Finish::Converged,
        "residual {}",
        sim.residual()
    );
    sim
}

fn assert_uniform(sim: &Simulation, expect: [f64; 3], scale: f64) {
    for (e, s) in sim.solid().stress.iter().enumerate() {
        for k in 0..3 {
            assert!(
                (s[k] - expect[k]).abs() < 1e-6 * scale,
                "element {e} stress[{k}] = {:.6e}, expected {:.6e}",
                s[k],
                expect[k]
            );
        }
    }
}

/// Uniaxial tension by a traction on the right side, roller on the left, one pin against
/// vertical rigid motion: sxx = t, syy = sxy = 0 (plane strain: szz = nu t).
#[test]
fn uniaxial_traction() {
    let sim = solve(
        r#"(
        name: "uniaxial",
        mesh: Perturbed(width: 20.0, height: 10.0, h: 1.0, fraction: 0.2, seed: 4),
        material: (young: 20e9, poisson: 0.25, density: 2700.0),
        boundary: Sides(left: Normal(0.0), right: Traction(normal: 5e6, shear: 0.0)),
        pins: [(at: (0.0, 0.0), uy: 0.0)],
        time: (end: Static(tol: 1e-10)),
    )"#,
    );
    assert_uniform(&sim, [5e6, 0.0, 0.0], 5e6);
    // Closed form: u_x(L) = (1 - nu^2) t L / E.
    let (e, nu, t, l) = (20e9, 0.25, 5e6, 20.0);
    let ux_max = sim.solid().u.iter().map(|u| u[0]).fold(f64::MIN, f64::max);
    let expect = (1.0 - nu * nu) * t * l / e;
    assert!(
        (ux_max - expect).abs() < 1e-6 * expect,
        "{ux_max} vs {expect}"
    );
}

/// Confinement by pressure on top (traction normal -p) over a block on rollers: syy = -p,
/// sxx = nu/(1-nu) syy (no lateral strain), sxy = 0.
#[test]
fn confined_compression_by_pressure() {
    let sim = solve(
        r#"(
        name: "oedometer",
        mesh: Regular(width: 10.0, height: 10.0, h: 1.0),
        material: (young: 10e9, poisson: 0.3, density: 2500.0),
        boundary: Sides(left: Normal(0.0), right: Normal(0.0), bottom: Normal(0.0),
                        top: Traction(normal: -8e6, shear: 0.0)),
        time: (end: Static(tol: 1e-10)),
    )"#,
    );
    let syy = -8e6;
    assert_uniform(&sim, [0.3 / 0.7 * syy, syy, 0.0], 8e6);
}

/// Pure shear by tractions: the traction sigma.n of sxy = tau is +tau along the counter-clockwise
/// tangent on the left and right sides and -tau on the bottom and top (the tangent there points
/// the other way); two pins remove rigid motion. Then sxy = tau and sxx = syy = 0 everywhere.
#[test]
fn pure_shear_by_tractions() {
    let tau = 2e6;
    let sim = solve(&format!(
        r#"(
        name: "shear",
        mesh: Perturbed(width: 10.0, height: 10.0, h: 1.0, fraction: 0.2, seed: 8),
        material: (young: 10e9, poisson: 0.2, density: 2500.0),
        boundary: Sides(left: Traction(normal: 0.0, shear: {tau}), right: Traction(normal: 0.0, shear: {tau}),
                        bottom: Traction(normal: 0.0, shear: -{tau}), top: Traction(normal: 0.0, shear: -{tau})),
        pins: [(at: (0.0, 0.0), ux: 0.0, uy: 0.0), (at: (10.0, 0.0), uy: 0.0)],
        time: (end: Static(tol: 1e-10)),
    )"#
    ));
    assert_uniform(&sim, [0.0, 0.0, tau], tau);
}

#[test]
fn pin_far_from_any_node_is_rejected() {
    let sc = Scenario::parse(
        r#"(
        name: "pin",
        mesh: Regular(width: 10.0, height: 10.0, h: 1.0),
        material: (young: 10e9, poisson: 0.2, density: 2500.0),
        pins: [(at: (30.0, 0.0), ux: 0.0)],
        time: (end: Static(tol: 1e-10)),
    )"#,
        "pin.ron",
    )
    .unwrap();
    let e = Simulation::new(sc.validate().unwrap(), &[])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("pins[0].at"), "{e}");
}
