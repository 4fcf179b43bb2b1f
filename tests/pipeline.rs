//! The reservoir pipeline end to end on a short Example I stimulation (0.5 s: the hydraulic
//! fracture crosses the vertical pre-existing one at x = 16 m and reaches x = 17 m), two years
//! of heat: before/after table, physics consistency between the models, outputs finite, the
//! output folder's rules.

use crate::support_cli as cli;
use crate::support_finite as finite;
use crate::support_vtu as vtu;

use cli::root;
use hydrofrac::pipeline::{PipelineOptions, State, run_pipeline};
use std::path::{Path, PathBuf};

/// The shipped pipeline with a 0.5 s stimulation, the production well at (14, 50) m on the new
/// fracture (4 m from the pre-existing one's end: not connected before), 2 years of heat on
/// coarser grids.
fn short_pipeline(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios/example1_reservoir.ron")).unwrap();
    let stim = root().join("scenarios/example1_cross.ron");
    let text = text
        .replace(
            "stimulation: \"example1_cross.ron\",",
            &format!(
                "stimulation: {:?},\n    stimulation_set: [\"time.end.Time=0.5\"],",
                stim.display().to_string()
            ),
        )
        .replace("production: (37.0, 50.0)", "production: (14.0, 50.0)")
        .replace("years: 30.0", "years: 2.0")
        .replace(
            "report_years: [1.0, 10.0, 30.0]",
            "report_years: [0.5, 2.0]",
        )
        .replace("size: (400.0, 300.0)", "size: (200.0, 200.0)")
        .replace("zone_origin: (150.0, 100.0)", "zone_origin: (50.0, 50.0)")
        .replace("h_min: 0.25", "h_min: 0.5");
    assert!(text.contains("time.end.Time=0.5") && text.contains("(14.0, 50.0)"));
    let path = dir.join("pipeline.ron");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn stimulation_improves_production_and_heat() {
    let tmp = cli::tmp_dir("pipeline");
    let file = short_pipeline(&tmp);
    let out = tmp.join("out");
    let opts = PipelineOptions {
        out: Some(out.clone()),
        quiet: true,
        ..Default::default()
    };
    let r = run_pipeline(&file, &opts).unwrap();

    // Before: the production well is 4 m from the nearest fracture (the pre-existing one ends
    // at x = 10 m): nothing through the network, only the matrix in the continuum.
    let before = r
        .reservoir
        .iter()
        .find(|x| x.state == State::Before)
        .unwrap();
    let after = r
        .reservoir
        .iter()
        .find(|x| x.state == State::After)
        .unwrap();
    assert_eq!(before.models[0].rate, 0.0);
    assert!(before.models[1].rate > 0.0);
    // After: the network's rate is the cubic law through 14 m of residual aperture (0.5 mm),
    // a^3 dp / (12 mu L) = 1.25e-10 * 12e6 / (12 * 2e-4 * 14) = 0.0446 m^2/s. Measured +0.9 %:
    // the production well's node joins two cells, and the one beyond it adds a short parallel
    // path (a chain ending in one cell gives the cubic law to 1e-10, `reservoir::production`
    // unit test); 2 % allows that.
    let cubic = 5e-4f64.powi(3) * 12e6 / (12.0 * 2e-4 * 14.0);
    let discrete = after.models[0].rate;
    let continuum = after.models[1].rate;
    println!("network {discrete:e}, cubic law {cubic:e}, continuum {continuum:e}");
    assert!(
        (discrete / cubic - 1.0).abs() < 0.02,
        "network rate {discrete:e} vs {cubic:e}"
    );
    // The continuum on the upscaled field carries the same flow (measured +1.7 %: 5 m blocks,
    // the wells' fractured-block index, the matrix in parallel; in the shipped example the
    // anisotropic index gave 50x less); 5 %. Before, it carries the matrix's flow, at least
    // 1e3 times less.
    assert!(
        (continuum / discrete - 1.0).abs() < 0.05,
        "continuum {continuum:e} vs {discrete:e}"
    );
    assert!(continuum > 1e3 * before.models[1].rate);
    // More flow, more power, more heat after two years, in both models.
    for m in 0..2 {
        assert!(after.models[m].heat > before.models[m].heat, "model {m}");
        assert!(
            after.models[m].power[1] > before.models[m].power[1],
            "model {m}"
        );
    }
    // The production temperature stays between the injection and the initial temperature.
    for row in &r.reservoir {
        for f in &row.models {
            for t in &f.temperature {
                assert!((323.15 - 1e-6..=423.15 + 1e-6).contains(t), "{t}");
            }
        }
    }
    let eb = r.summary["energy_balance"].as_f64().unwrap();
    assert!(eb < 1e-9, "energy balance {eb:e}");

    // Outputs: the table, series, figures, ParaView field; nothing non-finite anywhere.
    let csv = std::fs::read_to_string(out.join("reservoir.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[1].starts_with("before,") && lines[2].starts_with("after,"));
    for f in [
        "network_production.csv",
        "permeability.csv",
        "heat_discrete_after.csv",
        "heat_continuum_before.csv",
        "heat_temperature.png",
        "heat_power.png",
        "permeability_flow_after.png",
        "production_flow_after.png",
        "summary.json",
        "stimulation/summary.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let bad = finite::non_finite_tokens(&out);
    assert!(bad.is_empty(), "{bad:?}");
    let v = vtu::read_vtu(&out.join("permeability.vtu")).unwrap();
    assert!(v.types.iter().all(|&t| t == 9));
    let k = v.cell_array("after_k_flow_xx").unwrap();
    assert_eq!(k.len(), 400);
    assert!(k.iter().any(|&x| x > 1e-13) && k.iter().all(|&x| x >= 1e-17));
    // Temperature frames: every snapshot of the continuum after the stimulation, between the
    // injection and the initial temperature.
    let frames = vtu::read_pvd(&out.join("temperature_continuum_after.pvd")).unwrap();
    assert_eq!(frames.len(), 2, "{frames:?}");
    for (_, f) in &frames {
        let v = vtu::read_vtu(&out.join(f)).unwrap();
        let t = v.cell_array("temperature").unwrap();
        assert!(
            t.iter()
                .all(|x| (323.15 - 1e-6..=423.15 + 1e-6).contains(x))
        );
        assert!(t.iter().any(|&x| x < 420.0), "no cooling in {f}");
    }

    // The folder's rules: a second run into it replaces its own files; a foreign file in a
    // folder without a manifest is refused and left alone.
    let manifest = std::fs::read_to_string(out.join("hydrofrac-manifest.txt")).unwrap();
    assert!(manifest.contains("reservoir.csv"));
    let foreign = tmp.join("foreign");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
    let err = run_pipeline(
        &file,
        &PipelineOptions {
            out: Some(foreign.clone()),
            quiet: true,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("not empty"), "{err}");
    assert_eq!(
        std::fs::read_to_string(foreign.join("notes.txt")).unwrap(),
        "mine"
    );
    let _ = std::fs::remove_dir_all(&tmp);
}

/// Bad pipeline files get one clear line naming the file position or the field.
#[test]
fn bad_pipelines_are_named() {
    let tmp = cli::tmp_dir("bad");
    let good = std::fs::read_to_string(root().join("scenarios/example1_reservoir.ron")).unwrap();
    for (from, to, expect) in [
        ("years: 30.0", "years: -1.0", "heat.years"),
        (
            "pressure_drops: [9e6, 12e6, 15e6]",
            "pressure_drops: []",
            "production.pressure_drops",
        ),
        ("blocks: (20, 20)", "blocks: (0, 20)", "upscaling.blocks"),
        ("growth: 1.3", "growth: 0.5", "heat.discrete.growth"),
        (
            "report_years: [1.0, 10.0, 30.0]",
            "report_years: [1.0, 40.0]",
            "heat.report_years[1]",
        ),
        (
            "viscosity: 2e-4,\n    ),",
            "viscosity: 2e-4,\n        colour: 3,\n    ),",
            "colour",
        ),
        (
            "initial_temperature: 423.15",
            "initial_temperature: NaN",
            "heat.initial_temperature",
        ),
    ] {
        assert!(good.contains(from), "{from}");
        let path = tmp.join("bad.ron");
        std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
        let err = run_pipeline(
            &path,
            &PipelineOptions {
                out: Some(tmp.join("out")),
                quiet: true,
                ..Default::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains(expect), "{to}: {err}");
        assert!(!tmp.join("out").exists(), "{to}: the folder was touched");
    }
    let _ = std::fs::remove_dir_all(&tmp);
}
