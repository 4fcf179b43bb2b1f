//! Issue 41's residuals, each a defect found by trying the binary as a new user would: the
//! input or the run that once failed, and what it must do now.

use crate::support_cli as cli;
use crate::support_finite as finite;

use cli::{assert_refused, run, run_ok, scenario, tmp};

/// A failed quasi-static load increment of the production stage that had split faces first
/// (a 90 MPa pressure drop on `example2_small.ron`) is rolled back to the whole state before it,
/// the trial split's nodes included (it panicked on `copy_from_slice`: 10,380 displacements
/// into 10,687). The run ends `ok` with one row per state and only finite values.
#[test]
fn a_failed_production_increment_after_a_split_rolls_back() {
    let out = tmp("rollback");
    let s = run_ok(
        scenario("example2_small.ron"),
        &out,
        &[
            "--set",
            "time.end=Time(0.01)",
            "--set",
            "production.wells.pressure_drops=[90e6]",
            "--set",
            "production.max_iterations=1",
            "--set",
            "production.max_steps=100",
        ],
    );
    assert_eq!(s["status"], "ok", "{s}");
    let rows = s["production"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "{s}");
    assert!(s["production"]["fractures_grew"].as_bool().unwrap(), "{s}");
    let bad = finite::non_finite_tokens(&out);
    assert!(bad.is_empty(), "{bad:?}");
    std::fs::remove_dir_all(&out).unwrap();
}

/// An adaptive step bound on the wrong side of the other bound's default (`time.dt_max`
/// 1e-308 s against the default `dt_min`, the end time x 1e-9; `time.dt_min` 100 s against the
/// default `dt_max`, the end time / 100) is refused before anything runs, naming the field
/// (the clamp of the adaptive step panicked at the first step).
#[test]
fn adaptive_step_bounds_on_the_wrong_side_of_a_default_are_refused() {
    for (set, field, words) in [
        ("time.dt_max=1e-308", "time.dt_max", "below the shortest adaptive step"),
        ("time.dt_min=100.0", "time.dt_min", "above the longest adaptive step"),
    ] {
        let out = tmp("bounds");
        let o = run(&[
            "run",
            &scenario("kgd_toughness.ron"),
            "--quiet",
            "--out",
            out.to_str().unwrap(),
            "--set",
            set,
        ]);
        assert_refused(&o, &[field, words]);
        assert!(!out.exists(), "{set}: created {}", out.display());
    }
}
