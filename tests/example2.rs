//! The CI-sized variant of the seed's Example II (`scenarios/example2_small.ron`) through
//! `hydrofrac run`: the stimulation grows a new fracture and balances mass, the production
//! after it exceeds the production before, and the production stage writes its table, figures
//! and summary entries, finite. One pressure drop (9 MPa, below the 10 MPa normal stress on the
//! horizontal fractures, so each state is one iteration) keeps the test under a minute; the
//! coupling's effect at higher drops is `tests/production.rs`'s.

use hydrofrac::driver::{RunOptions, run_file};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn small_example2_stimulates_and_produces() {
    let out = std::env::temp_dir().join(format!("hydrofrac-example2-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let report = run_file(
        &root().join("scenarios/example2_small.ron"),
        &RunOptions {
            out: Some(out.clone()),
            quiet: true,
            set: vec!["production.wells.pressure_drops=[9e6]".into()],
            ..Default::default()
        },
    )
    .expect("run");
    let s = &report.summary;
    // The stimulation grows at least one new fracture cell.
    let new_cells = s["fractures"]["new_cells"].as_u64().unwrap();
    assert!(new_cells >= 1, "no new fracture: {}", s["fractures"]);
    // Mass balance over the stimulation: the engine's implicit flow conserves mass to
    // round-off (Kahan-summed masses; measured 1e-16); 1e-10 leaves room for the order of
    // summation, not for a lost cell.
    let err = s["flow"]["mass_balance_error"].as_f64().unwrap();
    assert!(err < 1e-10, "mass balance error {err}");
    // The production table: before and after, finite, rates >= 0, coupled >= frozen within
    // the iteration's tolerance (opening only adds aperture), and more after than before:
    // before, the starter is not connected to the network (0); the stimulation connects it.
    let csv = std::fs::read_to_string(out.join("production.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("state,dp,rate,rate_frozen,")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .skip(1)
                .take(3)
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 2, "{csv}");
    assert!(
        csv.contains("\nbefore,") && csv.contains("\nafter,"),
        "{csv}"
    );
    for r in &rows {
        assert!(r.iter().all(|x| x.is_finite()), "{r:?}");
        assert!(r[1] >= 0.0 && r[2] >= 0.0, "{r:?}");
        assert!(r[1] >= r[2] * (1.0 - 1e-3), "coupled below frozen: {r:?}");
    }
    let (before, after) = (rows[0][1], rows[1][1]);
    assert!(
        after > before && after > 1e-4,
        "production before {before:.4e}, after {after:.4e} m^2/s"
    );
    for f in [
        "production_flow_before.png",
        "production_flow_after.png",
        "network_before.png",
        "network_after.png",
        "preexisting_fractures.csv",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let p = &s["production"];
    assert_eq!(p["rows"].as_array().unwrap().len(), 2, "{p}");
    assert!(p["fractures_grew"].is_boolean());
    assert!(
        !serde_json::to_string(p).unwrap().contains("null"),
        "no null in the production summary: {p}"
    );
    let _ = std::fs::remove_dir_all(&out);
}
