//! The shipped flow-only scenarios run as written and write their outputs: only the flow systems
//! are scheduled, the network frames and network.csv read back, the figures exist, and the
//! physics in summary.json is right (cubic law, splitting at the junction, mass balance).

use crate::support_cli as cli;
use crate::support_vtu as vtu;

use std::path::{Path, PathBuf};
use vtu::{read_pvd, read_vtu};

/// Run `scenario` into a folder of its own: the folder and `summary.json`.
fn run(scenario: &str, extra: &[&str]) -> (PathBuf, serde_json::Value) {
    let stem = Path::new(scenario).file_stem().unwrap().to_string_lossy();
    let out = cli::tmp(&stem);
    let s = cli::run_ok(scenario, &out, extra);
    (out, s)
}

fn boundary(s: &serde_json::Value, name: &str) -> serde_json::Value {
    s["flow"]["boundaries"]
        .as_array()
        .unwrap()
        .iter()
        .find(|b| b["name"] == name)
        .cloned()
        .unwrap()
}

fn enabled(s: &serde_json::Value) -> Vec<String> {
    s["systems"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|x| x["enabled"] == true)
        .map(|x| x["name"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn single_fracture_matches_the_cubic_law() {
    let (out, s) = run("scenarios/flow_single_fracture.ron", &[]);
    assert_eq!(s["finish"], "converged");
    assert_eq!(enabled(&s), ["flow_substeps", "monitor", "output"]);
    let q = boundary(&s, "inlet")["rate"].as_f64().unwrap();
    let exact = 1e-12 * 2e6 / (12.0 * 8.9e-4 * 10.0);
    assert!((q - exact).abs() < 1e-8 * exact, "{q} vs {exact}");
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
    // Network frames: line cells with pressure, aperture and flow rate.
    let frames = read_pvd(&out.join("network.pvd")).unwrap();
    let last = read_vtu(&out.join(&frames.last().unwrap().1)).unwrap();
    assert_eq!(last.types, vec![3u8; 40]);
    let p = last.cell_array("pressure").unwrap();
    assert!(
        (p[0] - 1.975e6).abs() < 1.0 && (p[39] - 0.025e6).abs() < 1.0,
        "linear pressure: {} {}",
        p[0],
        p[39]
    );
    for a in ["aperture", "flow_rate", "kind"] {
        assert!(last.cell_array(a).is_some(), "{a}");
    }
    let csv = std::fs::read_to_string(out.join("network.csv")).unwrap();
    assert!(
        csv.starts_with("x0,y0,x1,y1,aperture,opening,slip,pressure,flow_rate,kind,created_t\n")
    );
    assert_eq!(csv.lines().count(), 41);
    assert!(csv.lines().nth(1).unwrap().ends_with(",preexisting,0"));
    for png in [
        "network_pressure.png",
        "network_flow.png",
        "boundary_pressure.png",
        "boundary_rate.png",
    ] {
        let b = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&b[..4], b"\x89PNG", "{png}");
    }
    let ts = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let header = ts.lines().next().unwrap();
    for col in [
        "inlet_pressure",
        "inlet_rate",
        "injected_volume",
        "stored_volume",
        "mass_balance_error",
    ] {
        assert!(
            header.split(',').any(|h| h == col),
            "{col} missing in {header}"
        );
    }
}

#[test]
fn single_fracture_direct_steady_solve() {
    let (_, s) = run(
        "scenarios/flow_single_fracture.ron",
        &["--set", "time.end=SteadyDirect"],
    );
    let q = boundary(&s, "inlet")["rate"].as_f64().unwrap();
    let exact = 1e-12 * 2e6 / (12.0 * 8.9e-4 * 10.0);
    assert!((q - exact).abs() < 1e-12 * exact, "{q} vs {exact}");
    assert_eq!(s["steps"], 0);
}

#[test]
fn junction_fills_then_splits_the_flow() {
    let (_, s) = run("scenarios/flow_junction.ron", &[]);
    assert_eq!(s["finish"], "converged");
    let q_in = boundary(&s, "inlet")["rate"].as_f64().unwrap();
    let q_e = -boundary(&s, "east")["rate"].as_f64().unwrap();
    let q_n = -boundary(&s, "north")["rate"].as_f64().unwrap();
    assert!((q_in - 5e-4).abs() < 1e-15);
    assert!(
        (q_e + q_n - q_in).abs() < 1e-8 * q_in,
        "{q_e} + {q_n} != {q_in}"
    );
    // The wider east branch (0.2 mm, 5 m) takes most: continuum ratio (2^3) : 1 = 8.
    assert!(q_e / q_n > 6.0 && q_e / q_n < 10.0, "split {}", q_e / q_n);
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
    assert!(
        s["flow"]["injected_volume"].as_f64().unwrap() > 2.5e-3,
        "the network filled first"
    );
}

#[test]
fn random_network_with_pump_and_production() {
    let (out, s) = run("scenarios/flow_network.ron", &[]);
    assert_eq!(s["finish"], "converged");
    let pump = boundary(&s, "pump");
    let prod = boundary(&s, "production");
    let (p, q) = (
        pump["pressure"].as_f64().unwrap(),
        pump["rate"].as_f64().unwrap(),
    );
    // On the pump curve.
    let curve = 18e6 * (1.0 - std::f64::consts::FRAC_2_PI * (q / 2.0).atan());
    assert!((p - curve).abs() < 1e-6 * curve);
    assert!(
        (q + prod["rate"].as_f64().unwrap()).abs() < 1e-6 * q,
        "steady: in = out"
    );
    assert!(s["flow"]["cells"].as_u64().unwrap() > 150);
    let generated = std::fs::read_to_string(out.join("network_generated.csv")).unwrap();
    assert_eq!(
        generated.lines().count(),
        1 + 2 + 40,
        "header, 2 wells, 40 random fractures"
    );
}
