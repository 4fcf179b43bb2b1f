//! The reservoir verification cases in quick mode pass their own checks (`docs/verification.md`
//! R14-R17b): Oda and the permeameter, the continuum front, Lauwerier, Gringarten and the two
//! heat models against each other. The full ladders run in `hydrofrac verify`.

use hydrofrac::verify::{CaseResult, heat_continuum_cases, heat_discrete_cases};
use hydrofrac::verify::{heat_models_cases, upscale_cases};

fn assert_case(name: &str, res: &CaseResult) {
    assert!(!res.checks.is_empty(), "{name} checked nothing");
    assert!(res.passed(), "{name}: {:?}", res.failures());
    // Error and wall time at more than one level, finite.
    assert!(res.rows.len() >= 2, "{name}: {} rows", res.rows.len());
    for r in &res.rows {
        assert!(r.error.is_finite() && r.wall_s.is_finite(), "{name}: {r:?}");
    }
}

#[test]
fn oda_quick() {
    assert_case("oda", &upscale_cases::oda_case(true).unwrap());
}

#[test]
fn heat_continuum_quick() {
    assert_case(
        "heat_continuum",
        &heat_continuum_cases::heat_continuum(true).unwrap(),
    );
}

#[test]
fn lauwerier_quick() {
    assert_case(
        "lauwerier",
        &heat_discrete_cases::lauwerier_case(true).unwrap(),
    );
}

#[test]
fn gringarten_quick() {
    assert_case(
        "gringarten",
        &heat_discrete_cases::gringarten_case(true).unwrap(),
    );
}

#[test]
fn heat_models_quick() {
    assert_case(
        "heat_models",
        &heat_models_cases::heat_models(true).unwrap(),
    );
}
