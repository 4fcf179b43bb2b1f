//! The event catalogue (`seismicity:`, `systems/src/seismicity.rs`, `docs/seismicity.md`):
//! event detection, moment and magnitude exact on prescribed slip, the b-value of a synthetic
//! catalogue, a slip-weakening event that runs dynamically and arrests, the outputs of a run,
//! restarts, and the refusals.

use crate::support_cli as cli;
use hydrofrac::checkpoint;
use hydrofrac::scenario::{Scenario, SeismicitySpec, SlipWeakening, SolidScheme};
use hydrofrac::sim::{Finish, Simulation};
use hydrofrac::verify::seismicity_cases::{
    prescribed_run, seismicity_case, slip_weakening_case, slip_weakening_scenario,
};

/// Prescribed slip on two fractures: M0' = G sum |slip| L, the stress drop, Mw and the
/// hypocentre to round-off; the set sliding between v_stop and v_start opens nothing; the
/// two fractures' simultaneous slips are two events (not connected).
#[test]
fn prescribed_slip_gives_exact_moments() {
    let p = prescribed_run().unwrap();
    assert_eq!(p.events, 2);
    assert_eq!(p.sub_threshold_events, 0);
    for (what, (m, e)) in [
        ("M0' of A", p.moment_a),
        ("M0' of B", p.moment_b),
        ("stress drop of A", p.drop_a),
    ] {
        assert!(((m - e) / e).abs() < 1e-12, "{what}: {m} against {e}");
    }
    assert!((p.magnitude_a.0 - p.magnitude_a.1).abs() < 1e-12);
    let (x, at) = p.hypocentre_a;
    assert!(at.iter().any(|a| (x - a).abs() < 1e-12), "hypocentre {x}");
}

/// The whole `verify seismicity` case (quick): the prescribed slip and the synthetic
/// catalogues' b-values within 2 sigma of the b = 1 they were drawn with.
#[test]
fn verify_seismicity_passes() {
    let r = seismicity_case(true).unwrap();
    assert!(r.passed(), "{:?}", r.failures());
}

/// `verify slip_weakening` (quick, b/h = 10): the crack slides dynamically (peak rate above
/// 0.1 m/s), arrests, and its event's M0' is within 18 % of the residual-friction static
/// crack's.
#[test]
fn slip_weakening_event_runs_and_arrests() {
    let r = slip_weakening_case(true).unwrap();
    assert!(r.passed(), "{:?}", r.failures());
}

/// The slip-weakening crack through `hydrofrac run`: events.csv (header, rows, finite), the
/// three figures of a run without injection, summary.json `seismicity`, and the
/// `seismicity` system in the timing table at under 5 % of the run's system time.
#[test]
fn run_writes_the_catalogue() {
    let dir = cli::tmp_dir("catalogue");
    let file = dir.join("crack.ron");
    let sc = slip_weakening_scenario(10.0, 0.05);
    std::fs::write(&file, ron::to_string(&sc).unwrap()).unwrap();
    let out = dir.join("out");
    let s = cli::run_ok(&file, &out, &[]);
    let csv = std::fs::read_to_string(out.join("events.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(hydrofrac::catalogue::COLUMNS));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let seis = &s["seismicity"];
    assert_eq!(
        rows.len() as u64,
        seis["events"].as_u64().unwrap(),
        "{seis}"
    );
    assert!(!rows.is_empty());
    assert!(rows.iter().flatten().all(|x| x.is_finite()), "{csv}");
    let largest = rows.iter().map(|r| r[16]).fold(f64::MIN, f64::max);
    assert_eq!(largest, seis["largest_magnitude"].as_f64().unwrap());
    for f in [
        "events_map.png",
        "events_magnitude.png",
        "events_gutenberg_richter.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(!out.join("events_moment.png").exists(), "no injection here");
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(!text.contains("null") && !text.contains("NaN"), "{text}");
    let systems = s["systems"].as_array().unwrap();
    let time = |name: &str| {
        systems
            .iter()
            .find(|x| x["name"] == name)
            .and_then(|x| x["total_s"].as_f64())
            .unwrap()
    };
    let total: f64 = systems.iter().filter_map(|x| x["total_s"].as_f64()).sum();
    assert!(
        time("seismicity") < 0.05 * total,
        "seismicity {} s of {total} s",
        time("seismicity")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run checkpointed in the middle of its event and restarted ends with the same catalogue
/// (the running event's joints, slips and start tractions are in the checkpoint).
#[test]
fn restart_keeps_the_catalogue() {
    let sc = slip_weakening_scenario(10.0, 0.05);
    let mut whole = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    assert_eq!(whole.run(|_| {}).unwrap(), Finish::EndTime);
    let events = whole.catalogue().unwrap().events.clone();
    assert!(!events.is_empty());

    let mut first = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    // 5 ms into the run, inside the crack's main event (about 25 ms long).
    while first.time() < 0.005 || first.catalogue().unwrap().running() == 0 {
        first.step_once().unwrap();
        assert!(first.finish().is_none(), "no event running after 5 ms");
    }
    let (header, state) = first.checkpoint_state().unwrap();
    let bytes = checkpoint::encode(&header, &state).unwrap();
    let (_, state) = checkpoint::decode(&bytes).unwrap();
    let mut restarted = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    restarted.restore(state).unwrap();
    assert_eq!(restarted.run(|_| {}).unwrap(), Finish::EndTime);
    assert_eq!(restarted.catalogue().unwrap().events, events);
}

/// The slip-weakening crack's scenario edited by `edit` is refused, naming `field` and saying
/// `needle`.
fn refused(edit: impl FnOnce(&mut Scenario), field: &str, needle: &str) {
    let mut sc = slip_weakening_scenario(10.0, 0.05);
    edit(&mut sc);
    let e = sc.validate().unwrap_err().to_string();
    assert!(e.contains(field) && e.contains(needle), "{e}");
}

/// Bad settings are refused with the field and the reason.
#[test]
fn bad_seismicity_settings_are_refused() {
    fn seis(sc: &mut Scenario) -> &mut SeismicitySpec {
        sc.seismicity.as_mut().unwrap()
    }
    fn weak(sc: &mut Scenario) -> &mut SlipWeakening {
        let f = sc.fracture.as_mut().unwrap();
        f.slip_weakening.as_mut().unwrap()
    }
    refused(
        |sc| seis(sc).v_stop = Some(1.0),
        "seismicity.v_stop",
        "above the opening rate",
    );
    refused(
        |sc| seis(sc).v_start = f64::NAN,
        "seismicity.v_start",
        "not a finite number",
    );
    refused(
        |sc| seis(sc).width = Some(-1.0),
        "seismicity.width",
        "must be > 0",
    );
    refused(
        |sc| sc.fracture = None,
        "seismicity",
        "needs a mesh with a `fracture` section",
    );
    refused(
        |sc| sc.time.solid_scheme = SolidScheme::QuasiStatic,
        "fracture.slip_weakening",
        "explicit rock",
    );
    refused(
        |sc| weak(sc).residual_deg = 40.0,
        "fracture.slip_weakening.residual_deg",
        "[0, friction_deg",
    );
    refused(
        |sc| weak(sc).dc = 0.0,
        "fracture.slip_weakening.dc",
        "must be > 0",
    );
}

/// Both solid schemes catalogue the same crack sliding under constant friction (25 degrees,
/// below its 30-degree stress ratio) at b/h = 10: the largest event's M0' of each within 18 %
/// of the static crack's closed form (the mesh's first-order error, as in `verify
/// slip_weakening`) and within 5 % of each other (the same mesh and joints; the explicit
/// event leaves out the elastic offsets from before it opened).
#[test]
fn both_schemes_catalogue_a_sliding_crack() {
    use hydrofrac::verify::seismicity_cases::constant_friction_run;
    let (n_qs, m_qs, exact) =
        constant_friction_run(SolidScheme::QuasiStatic, 10.0, 25.0, 0.01).unwrap();
    let (n_ex, m_ex, _) = constant_friction_run(SolidScheme::Explicit, 10.0, 25.0, 0.1).unwrap();
    assert!(
        n_qs >= 1 && n_ex >= 1,
        "events: {n_qs} quasi-static, {n_ex} explicit"
    );
    for (what, m) in [("quasi-static", m_qs), ("explicit", m_ex)] {
        let e = (m / exact - 1.0).abs();
        assert!(e < 0.18, "{what}: M0' {m:.4e} against {exact:.4e} ({e:.3})");
    }
    let d = (m_qs / m_ex - 1.0).abs();
    assert!(
        d < 0.05,
        "quasi-static {m_qs:.4e} against explicit {m_ex:.4e}"
    );
}
