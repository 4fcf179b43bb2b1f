//! The heat models' solves are timed as systems (`hydrofrac::system` spans). Alone in its test
//! binary: tracing caches each callsite's interest globally, and a test running the same spans
//! on another thread without a subscriber can leave a callsite switched off for this thread's
//! subscriber (seen as a flaky zero count when this test shared `tests/heat_continuum.rs`).

use hydrofrac::reservoir::continuum::run_continuum;
use hydrofrac::verify::heat_continuum_cases::doublet_spec;

/// The pressure solve and the heat steps are timed as systems (`hydrofrac::system` spans):
/// one `darcy_continuum` entry, one `heat_continuum` entry for the set-up and one per step.
#[test]
fn systems_are_timed() {
    use tracing_subscriber::layer::SubscriberExt;
    let timing = hydrofrac::timing::TimingLayer::default();
    let table = timing.table.clone();
    let subscriber = tracing_subscriber::registry().with(timing);
    let spec = doublet_spec(21, 1e-3, 1.0);
    let run = tracing::subscriber::with_default(subscriber, || run_continuum(&spec).unwrap());
    let table = table.lock().unwrap();
    let calls = |name: &str| table.get(name).map_or(0, |t| t.calls);
    assert_eq!(calls("darcy_continuum"), 1);
    assert_eq!(calls("heat_continuum") as usize, run.steps + 1);
}
