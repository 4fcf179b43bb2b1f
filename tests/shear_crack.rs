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
