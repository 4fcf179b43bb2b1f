//! The fluid-driven frictional shear crack (`verify shear_crack`, `docs/shear_crack.md`):
//! lambda(T) by quadrature and bisection against checked values and both asymptotes, and the
//! quick run (10 faces along the final slip half-length at T = 0.1 and 0.8): the slip front's
//! lambda within the quick tolerance, the pressure against erfc, the moment's growth as the
//! injected volume squared, mass conserved.

use hydrofrac::verify::shear_crack_cases::{
    lambda_critically_stressed, lambda_exact, lambda_marginally_pressurised, shear_crack,
};

/// lambda(T) against values computed independently (4,000-point midpoint rule and bisection),
/// to 5e-4 relative (the values' own rounding).
#[test]
fn lambda_matches_checked_values() {
    for (t, l) in [(0.1, 3.6405), (0.8, 0.2834), (0.02, 17.968), (0.95, 0.0697)] {
        let got = lambda_exact(t);
        assert!(
            (got / l - 1.0).abs() < 5e-4,
            "T = {t}: lambda {got}, expected {l}"
        );
    }
}

/// Both limits within 0.5 %: lambda = 2 / (pi^{3/2} T) at T = 0.01 (critically stressed) and
/// (pi^{3/2} / 4) (1 - T) at T = 0.99 (marginally pressurised).
#[test]
fn lambda_approaches_its_asymptotes() {
    let small = lambda_exact(0.01) / lambda_critically_stressed(0.01) - 1.0;
    let near_one = lambda_exact(0.99) / lambda_marginally_pressurised(0.99) - 1.0;
    assert!(small.abs() < 5e-3, "T = 0.01: {:+.3} %", 100.0 * small);
    assert!(
        near_one.abs() < 5e-3,
        "T = 0.99: {:+.3} %",
        100.0 * near_one
    );
    assert!(lambda_exact(0.0).is_nan() && lambda_exact(1.0).is_nan());
}

/// `verify shear_crack --quick`: every check passes (lambda within the quick tolerance at both
/// T, the pressure, the moment's slope, the mass balance).
#[test]
fn quick_run_passes() {
    let res = shear_crack(true).unwrap();
    let failed = res.failures();
    assert!(
        failed.is_empty(),
        "shear_crack failed:\n{}",
        failed.join("\n")
    );
}

/// `time.linear_solver: Auto` on the shear crack (T = 0.1, 10 faces): the Cholesky tangent's
/// Newton fails once the front joints slide (the case itself asks for `Lu`); Auto then solves
/// that step again by LU and keeps the LU for 8 steps, 16 after the next retry, and so on, so
/// the run takes no cutback (before the retry: 140 cutbacks in 340 steps and the front stuck
/// at a step of 1e-5 t_end) and as many steps as with `Lu`, with one retry per doubling
/// (measured 4 in 213 steps; at least 2, at most 6 = 1 + log2(213 / 8)). Measured wall, same build: Auto
/// 2.88 s, `Lu` 2.61 s.
#[test]
fn auto_solver_falls_back_to_lu() {
    use hydrofrac::scenario::LinearSolver;
    use hydrofrac::sim::{Finish, Simulation};
    use hydrofrac::verify::shear_crack_cases::Setup;
    let steps = |lin: LinearSolver| {
        let mut sc = Setup::new(0.1, 10).scenario();
        sc.time.linear_solver = lin;
        let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
        assert_eq!(sim.run(|_| {}).unwrap(), Finish::EndTime);
        sim.quasi_static_counts().unwrap()
    };
    let (auto, lu) = (steps(LinearSolver::Auto), steps(LinearSolver::Lu));
    assert_eq!(auto.cutbacks, 0, "{auto:?}");
    // At least two: the run went back to the Cholesky tangent after the first hold (kept to
    // the end, the LU made Example I cross quasi-static 2.7 times slower, 50 s against 18.6 s).
    assert!((2..=6).contains(&auto.lu_retries), "{auto:?}");
    let ratio = auto.steps as f64 / lu.steps as f64;
    assert!(
        (0.95..=1.05).contains(&ratio),
        "{} against {} steps",
        auto.steps,
        lu.steps
    );
}
