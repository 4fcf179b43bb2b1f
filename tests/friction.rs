//! Joint contact with Coulomb friction (seed (8)-(11), `docs/verification.md` R8): a block cut by a
//! horizontal fracture across its whole width, pressed by sigma = 10 MPa and sheared by tau.
//! Below the friction limit (tau = 0.8 sigma tan phi) the joint sticks: the run reaches static
//! equilibrium, no joint slides, every joint carries |F_t| < F_n tan phi and about sigma per
//! metre in compression. Above it (tau = 1.2 sigma tan phi) the joint slides: the sliding joints
//! carry exactly F_t = F_n tan phi and the upper block runs away along the fracture.

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};

use crate::support_scenes as scenes;

fn block(tau: f64, end: &str) -> Simulation {
    let sc = Scenario::parse(&scenes::friction_block(tau, end), "friction.ron").unwrap();
    Simulation::new(sc.validate().unwrap(), &[]).unwrap()
}

const SIGMA: f64 = 10e6;

#[test]
fn joint_sticks_below_the_coulomb_limit() {
    let mu = 30f64.to_radians().tan();
    let mut sim = block(0.8 * SIGMA * mu, "Static(tol: 1e-9)");
    assert_eq!(sim.solid().joint_nodes.len(), 8);
    assert!(
        sim.schedule()
            .is_enabled(hydrofrac::systems::SystemId::Contact)
    );
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    for (k, st) in sim.solid().joint_state.iter().enumerate() {
        assert!(!st.sliding, "joint {k} slides");
        assert!(
            st.shear_force.abs() < mu * st.normal_force,
            "joint {k}: {st:?}"
        );
        // Compression of about sigma per metre of joint (the fixed base disturbs the ends).
        assert!(
            (st.normal_force - SIGMA).abs() < 0.35 * SIGMA,
            "joint {k}: F_n = {}",
            st.normal_force
        );
        assert!(st.opening < 0.0, "joint {k} should be closed");
    }
    let fn_total: f64 = sim.solid().joint_state.iter().map(|s| s.normal_force).sum();
    assert!(
        (fn_total - 8.0 * SIGMA).abs() < 1e-3 * 8.0 * SIGMA,
        "total normal force {fn_total}"
    );
}

#[test]
fn joint_slides_above_the_coulomb_limit() {
    let mu = 30f64.to_radians().tan();
    let mut sim = block(1.2 * SIGMA * mu, "Time(0.2)");
    sim.run(|_| {}).unwrap();
    let sliding: Vec<_> = sim
        .solid()
        .joint_state
        .iter()
        .filter(|s| s.sliding)
        .collect();
    assert!(
        sliding.len() >= 6,
        "only {} of 8 joints slide",
        sliding.len()
    );
    for st in &sliding {
        assert!((st.shear_force.abs() - mu * st.normal_force).abs() <= 1e-9 * st.normal_force);
    }
    // The upper block has moved along the fracture far beyond elastic shear (tau/G * 2 m ~ 1 mm).
    let top = sim
        .solid()
        .x0
        .iter()
        .zip(&sim.solid().u)
        .filter(|(x, _)| x[1] == 4.0)
        .map(|(_, u)| u[0].abs())
        .fold(0.0, f64::max);
    assert!(top > 0.05, "upper block moved only {top} m");
}

/// Gravity (`gravity: Some((0, -g))`) on a block on rollers with a fixed base: at equilibrium
/// the base reactions carry the weight rho g W H (to the relaxation tolerance, 1e-6), and the
/// vertical stress grows linearly with depth, -rho g (H - y), matched at the element centroids to
/// within the CST's first-order error (5 % of the base stress).
#[test]
fn gravity_loads_the_rock_with_its_weight() {
    let text = r#"(
        name: "column",
        mesh: Regular(width: 4.0, height: 10.0, h: 0.5),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: Sides(bottom: Fixed, left: Normal(0.0), right: Normal(0.0)),
        gravity: Some((0.0, -9.81)),
        time: (end: Static(tol: 1e-10)),
    )"#;
    let mut sim = Simulation::new(
        Scenario::parse(text, "column.ron")
            .unwrap()
            .validate()
            .unwrap(),
        &[],
    )
    .unwrap();
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let weight = 2700.0 * 9.81 * 4.0 * 10.0;
    let base: f64 = (0..sim.solid().n_nodes())
        .filter(|&i| sim.solid().x0[i][1] == 0.0)
        .map(|i| sim.solid().force[i][1])
        .sum();
    assert!(
        (base + weight).abs() < 1e-6 * weight,
        "base reaction {base} vs weight {weight}"
    );
    for (k, c) in sim.solid().conn.iter().enumerate() {
        let yc = c
            .iter()
            .map(|&a| sim.solid().x0[a as usize][1])
            .sum::<f64>()
            / 3.0;
        let exact = -2700.0 * 9.81 * (10.0 - yc);
        let err = (sim.solid().stress[k][1] - exact).abs();
        assert!(
            err < 0.05 * 2700.0 * 9.81 * 10.0,
            "element {k}: syy {} vs {exact}",
            sim.solid().stress[k][1]
        );
    }
}

/// Inclined block under gravity (`docs/verification.md` R8, `fracture_cases::inclined_block`:
/// gravity rotated by psi, a 4 m x 2 m rock cut along y = 1 m, relaxed under the normal
/// component, then the tangential component ramped in undamped). Sliding (psi > phi): the
/// mean acceleration of the upper block's centre of mass over 0.1 s is within 2 % (`docs/verification.md`
/// R8) of g (sin psi - cos psi tan phi) (m/s^2) and every joint slides throughout the
/// window. Sticking (psi < phi): no joint ever slides, and the centre of mass moves by less
/// than 1e-4 m (elastic deformation only, ~1e-5 m; a sliding block would move millimetres).
/// Near the limit (psi = 29, phi = 30 deg) joints at the ends may slip locally, but the block
/// stays put (same 1e-4 m bound).
#[test]
fn inclined_block_slides_with_the_coulomb_acceleration_or_sticks() {
    use hydrofrac::verify::fracture_cases::inclined_block;
    for (psi, phi) in [(30.0, 20.0), (45.0, 30.0)] {
        let r = inclined_block(psi, phi, 0.25).unwrap();
        let rel = (r.accel - r.expected) / r.expected;
        assert!(
            rel.abs() < 0.02,
            "psi {psi} phi {phi}: {r:?}, error {rel:.3e}"
        );
        assert_eq!(r.sliding_min, r.joints, "psi {psi} phi {phi}: {r:?}");
        assert!(r.slip > 0.01, "psi {psi} phi {phi}: {r:?}");
    }
    for (psi, phi) in [(20.0, 30.0), (29.0, 30.0)] {
        let r = inclined_block(psi, phi, 0.25).unwrap();
        assert!(r.slip.abs() < 1e-4, "psi {psi} phi {phi}: {r:?}");
        assert!(
            r.accel.abs() < 0.01 * 9.81 * psi.to_radians().sin(),
            "psi {psi} phi {phi}: {r:?}"
        );
        if psi == 20.0 {
            assert_eq!(r.sliding_ever, 0, "psi {psi} phi {phi}: {r:?}");
        }
    }
}

/// The inclined block on the quasi-static rock with implicit dynamics (`time.inertia:
/// BackwardEuler`, h = 0.25 m, 200 steps of 0.5 ms, the full gravity from rest): past the
/// friction angle the block slides with a = g (sin psi - cos psi tan phi) within 1 % (backward
/// Euler conserves momentum, so the window's mean acceleration is the mean net force; the
/// residual error is the joints' contact vibration, damped by the scheme), every joint slides;
/// a block just below the limit (psi = 29, phi = 30 deg) stays put (slip < 1e-4 m, elastic
/// only). The static quasi-static solve of a sliding block has no equilibrium at all.
#[test]
fn implicit_dynamics_slides_the_block_at_the_coulomb_acceleration() {
    use hydrofrac::verify::fracture_cases::inclined_block_implicit;
    for (psi, phi) in [(30.0, 20.0), (45.0, 30.0)] {
        let r = inclined_block_implicit(psi, phi, 0.25, 5e-4, 200).unwrap();
        let rel = (r.accel - r.expected) / r.expected;
        println!("psi {psi} phi {phi}: error {rel:.3e}, {r:?}");
        assert!(
            rel.abs() < 0.01,
            "psi {psi} phi {phi}: {r:?}, error {rel:.3e}"
        );
        assert_eq!(r.sliding_min, r.joints, "psi {psi} phi {phi}: {r:?}");
    }
    // Without inertia there is no equilibrium to find: the solve stops with a clear error.
    let e = hydrofrac::verify::fracture_cases::inclined_block_quasi_static(30.0, 20.0, 0.25)
        .unwrap_err()
        .to_string();
    assert!(e.contains("slid"), "{e}");
    let r = inclined_block_implicit(29.0, 30.0, 0.25, 5e-4, 200).unwrap();
    println!("psi 29 phi 30: {r:?}");
    assert!(r.slip.abs() < 1e-4, "psi 29 phi 30: {r:?}");
    assert!(r.accel.abs() < 0.01 * 9.81 * 0.5, "psi 29 phi 30: {r:?}");
}

/// `hydrofrac verify friction --quick` passes its own checks (2 % on the sliding acceleration at
/// h = 0.5 and 0.25 m, no sliding and < 1e-4 m displacement when sticking; with the
/// quasi-static scheme, the sticking block's weight carried by the joints to 1e-5).
#[test]
fn verify_friction_case_passes() {
    let res = hydrofrac::verify::fracture_cases::friction(true).unwrap();
    let failed = res.failures();
    assert!(failed.is_empty(), "friction failed:\n{}", failed.join("\n"));
}

/// `hydrofrac verify contact --quick` passes its own checks (the implicit-dynamics block at
/// two step lengths: 1 % on the sliding acceleration, at most 5 Newton iterations per step,
/// < 1e-4 m for the sticking block; the explicit scheme beside it at 2 %).
#[test]
fn verify_contact_case_passes() {
    let res = hydrofrac::verify::fracture_cases::contact(true).unwrap();
    for r in &res.rows {
        println!("{} {:.3e} {:.3} s", r.metric, r.error, r.wall_s);
    }
    let failed = res.failures();
    assert!(failed.is_empty(), "contact failed:\n{}", failed.join("\n"));
}

/// The stick-slip load cycle of `verify contact` (docs/verification.md R8c): two blocks on a
/// joint, one pushed against the other, loaded and unloaded twice on the quasi-static rock.
/// The work of the loads equals the stored energy's change plus the friction dissipation to
/// 1e-6 of the dissipation at a tenth of the blocks' weight (exact for the trapezoid rule at
/// exact equilibria; left over: the joint force's O(delta_t / L) couple); at the full weight
/// the imbalance is ten times larger (5-20 x: it is that couple, proportional to the load,
/// and not the Newton tolerance); no joint gives energy back in any step; the joints pass
/// from stick to slip and back to stick; at most 5 Newton iterations per step on average.
#[test]
fn load_cycle_balances_work_stored_energy_and_friction() {
    let c = hydrofrac::verify::contact_cases::load_cycle(0.25, 20, 0.1).unwrap();
    let full = hydrofrac::verify::contact_cases::load_cycle(0.25, 20, 1.0).unwrap();
    println!(
        "{c:#?}\nimbalance {:.3e}, at the full weight {:.3e}",
        c.imbalance(),
        full.imbalance()
    );
    assert!(c.imbalance() < 1e-6, "imbalance {:.3e}", c.imbalance());
    let ratio = full.imbalance() / c.imbalance();
    assert!((5.0..20.0).contains(&ratio), "imbalance ratio {ratio:.2}");
    assert!(c.dissipated > 0.0 && c.dissipated < c.work);
    assert!(
        c.min_joint_step >= -1e-9 * c.dissipated,
        "{}",
        c.min_joint_step
    );
    assert_eq!(c.opened, 0);
    assert!(
        c.sliding_max > 0 && c.sliding_max < c.joints,
        "{}",
        c.sliding_max
    );
    assert!(c.slipping_steps > 0 && c.restick > 0);
    assert!(c.newton_iterations as f64 <= 5.0 * c.steps as f64);
}
