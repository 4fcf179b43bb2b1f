//! Flow on 3D fracture surfaces (issue 38, item 5): one cell per disc triangle, the cubic law
//! across shared edges, compressible water, rate boundaries at 3D points, the explicit coupling
//! with the TET4 rock.
//! - radial injection into a rigid disc against the line-source solution, first order in h,
//!   mass conserved to round-off (`hydrofrac verify radial3d`, quick);
//! - the pumped penny at rest against the static penny of the same mesh: the pressure its
//!   fluid mass and the mesh's compliance give, uniform, the opened volume
//!   (`hydrofrac verify penny_flow`, quick);
//! - `scenarios/penny_injection.ron` as shipped (shortened): the injected volume, the mass
//!   balance, the well's series columns, the fracture frames' pressure and aperture, a restart
//!   from a checkpoint bit for bit, the same bits on one and two threads; a pump and a
//!   pressure well at a cell against their closed forms; two discs crossing along a line;
//! - flow boundaries of the wrong dimension or off the fracture, the quasi-static rock with
//!   flow and a prescribed pressure beside the fluid's are refused by field.

use crate::support_cli as cli;
use crate::support_vtu as vtu;

fn assert_passed(name: &str, r: &hydrofrac::verify::CaseResult) {
    for c in &r.checks {
        assert!(c.pass, "{name}: {} = {:e} ({})", c.what, c.value, c.limit);
    }
    assert!(!r.checks.is_empty());
}

#[test]
fn radial_flow_in_a_rigid_disc_converges_to_the_line_source() {
    let r = hydrofrac::verify::flow3d_cases::radial3d(true).unwrap();
    assert_passed("radial3d", &r);
    assert_eq!(r.rows.len(), 2);
    // The error halves with h (first order): 8.9 and 4.5 % measured.
    assert!(r.rows[1].error < 0.6 * r.rows[0].error, "{:?}", r.rows);
}

#[test]
fn the_pumped_penny_rests_at_the_pressure_of_its_fluid_mass_and_compliance() {
    let r = hydrofrac::verify::flow3d_cases::penny_flow(true).unwrap();
    assert_passed("penny_flow", &r);
}

/// `penny_injection.ron` to `end` s with extra `--set`s.
fn injection(name: &str, end: f64, sets: &[&str]) -> (std::path::PathBuf, serde_json::Value) {
    let out = cli::tmp(name);
    let e = format!("time.end=Time({end})");
    let mut extra = vec!["--set", &e];
    for s in sets {
        extra.push("--set");
        extra.push(s);
    }
    let s = cli::run_ok(cli::scenario("penny_injection.ron"), &out, &extra);
    assert_eq!(s["status"], "ok", "{s}");
    (out, s)
}

#[test]
fn the_shipped_injection_keeps_its_mass_and_writes_pressure_and_aperture() {
    let (out, s) = injection("pumped", 0.004, &["output.frame_every=300"]);
    let f = &s["flow"];
    assert_eq!(f["cells"], 32);
    // 1e-3 m^3/s for 0.004 s (the schedule's factor is 1 up to 0.02 s).
    let inj = f["injected_volume"].as_f64().unwrap();
    assert!((inj / 4e-6 - 1.0).abs() < 1e-9, "{inj}");
    assert!(f["mass_balance_error"].as_f64().unwrap() < 1e-12, "{f}");
    assert!(
        f["boundaries"][0]["pressure"].as_f64().unwrap() > 1e5,
        "{f}"
    );
    assert!(s["fracture"]["opened_volume"].as_f64().unwrap() > 0.0);
    let series = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let head = series.lines().next().unwrap();
    for col in [
        "well_pressure",
        "well_rate",
        "injected_volume",
        "mass_balance_error",
    ] {
        assert!(head.split(',').any(|c| c == col), "{col} in {head}");
    }
    let frames = vtu::read_pvd(&out.join("network.pvd")).unwrap();
    let last = vtu::read_vtu(&out.join(&frames.last().unwrap().1)).unwrap();
    let p = last.cell_array("pressure").expect("pressure");
    let a = last.cell_array("aperture").expect("aperture");
    assert_eq!((p.len(), a.len()), (32, 32));
    assert!(p.iter().all(|x| x.is_finite() && *x >= 0.0) && p.iter().any(|x| *x > 1e5));
    // The hydraulic aperture is max(opening, a_r), a_r = 1e-4 m.
    assert!(a.iter().all(|x| *x >= 1e-4), "{a:?}");
    // The aperture and pressure maps and the well's curves, as PNG.
    for png in [
        "fracture_aperture.png",
        "fracture_pressure.png",
        "boundary_pressure.png",
        "boundary_rate.png",
    ] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
}

#[test]
fn a_pump_and_the_implicit_flow_step_drive_the_penny_too() {
    // The pump's operating point lies on its curve q = q_half tan(pi/2 (1 - p / p_max)).
    let dir = cli::tmp_dir("pump");
    let text = std::fs::read_to_string(cli::scenario("penny_injection.ron"))
        .unwrap()
        .replace("kind: Rate(1e-3)", "kind: Pump(p_max: 5e6, q_half: 1e-3)");
    let path = dir.join("pump.ron");
    std::fs::write(&path, text).unwrap();
    let s = cli::run_ok(&path, &dir.join("out"), &["--set", "time.end=Time(0.004)"]);
    let b = &s["flow"]["boundaries"][0];
    let (p, q) = (b["pressure"].as_f64().unwrap(), b["rate"].as_f64().unwrap());
    let on_curve = 1e-3 * (std::f64::consts::FRAC_PI_2 * (1.0 - p / 5e6)).tan();
    assert!(
        p > 1e6 && (q / on_curve - 1.0).abs() < 1e-6,
        "p {p}, q {q} vs {on_curve}"
    );
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
    // One backward-Euler flow step per solid step instead of the sub-steps.
    let (_, s) = injection("implicit", 0.004, &["time.flow_scheme=Implicit"]);
    assert_eq!(s["flow"]["scheme"], "implicit");
    assert!(
        s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12,
        "{}",
        s["flow"]
    );
    let inj = s["flow"]["injected_volume"].as_f64().unwrap();
    assert!((inj / 4e-6 - 1.0).abs() < 1e-9, "{inj}");
}

#[test]
fn a_pressure_well_at_a_cell_feeds_empty_cells_through_its_connection() {
    // `Cell` joins the triangle nearest the point with kappa = a^3 / (6 mu); the cells start
    // empty (`initial_fluid: Empty`, pressure zero until full), so while the disc fills the
    // well's rate is kappa times its pressure: 1e-12 / (6 x 8.9e-4) x 2e6 = 3.745e-4 m^3/s.
    let dir = cli::tmp_dir("cell3");
    let text = std::fs::read_to_string(cli::scenario("penny_injection.ron"))
        .unwrap()
        .replace("Node((0.0, 0.0, 0.0))", "Cell((0.1, 0.1, 0.0))")
        .replace("initial_fluid: Full(0.0),", "initial_fluid: Empty,")
        .replace("kind: Rate(1e-3)", "kind: Pressure(2e6)");
    let path = dir.join("cell3.ron");
    std::fs::write(&path, text).unwrap();
    let s = cli::run_ok(&path, &dir.join("out"), &["--set", "time.end=Time(0.004)"]);
    let b = &s["flow"]["boundaries"][0];
    let want = 1e-12 / (6.0 * 8.9e-4) * 2e6;
    let q = b["rate"].as_f64().unwrap();
    assert!((q / want - 1.0).abs() < 1e-12, "rate {q} vs {want}");
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
}

#[test]
fn the_injection_restarts_bit_for_bit_and_gives_the_same_bits_on_one_thread() {
    let (whole, a) = injection("whole", 0.004, &["output.checkpoint_every=Steps(300)"]);
    let ckpt = whole.join("checkpoint.ckpt");
    let c = ckpt.to_str().unwrap().to_string();
    let part = cli::tmp("part");
    let b = cli::run_ok(
        cli::scenario("penny_injection.ron"),
        &part,
        &["--set", "time.end=Time(0.004)", "--restart", &c],
    );
    assert_eq!(b["restarted_from"]["bit_identical"], true, "{b}");
    for key in [
        "injected_volume",
        "stored_volume_change",
        "mass_balance_error",
    ] {
        assert_eq!(a["flow"][key], b["flow"][key], "{key}");
    }
    assert_eq!(
        a["fracture"]["opened_volume"],
        b["fracture"]["opened_volume"]
    );
    // One thread against the machine's (two in CI): the same summary figures to the bit.
    let one = cli::tmp("one");
    let o = cli::bin()
        .env("RAYON_NUM_THREADS", "1")
        .args([
            "run",
            &cli::scenario("penny_injection.ron"),
            "--quiet",
            "--out",
        ])
        .arg(&one)
        .args(["--set", "time.end=Time(0.004)"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(one.join("summary.json")).unwrap()).unwrap();
    for key in ["injected_volume", "stored_volume_change"] {
        assert_eq!(a["flow"][key], t["flow"][key], "{key}");
    }
    assert_eq!(
        a["fracture"]["opened_volume"],
        t["fracture"]["opened_volume"]
    );
}

/// Two discs of the quarter box: A horizontal (z = 0, R = 1 m, the well at its centre) and B
/// on the plane y = `y` (radius `r`). Returns each B triangle's pressure at the end (Pa) and
/// the summary.
fn two_discs(name: &str, y: f64, r: f64) -> (Vec<f64>, serde_json::Value) {
    let dir = cli::tmp_dir(name);
    let text = format!(
        "(name: \"two_discs\",
          mesh: GradedBox(size: (6.0, 6.0, 12.0), origin: (0.0, 0.0, -6.0), h: 0.25,
                          fine: (0.0, 0.0, -1.0, 1.5, 1.5, 1.0), ratio: 1.5),
          material: (young: 20e9, poisson: 0.2, density: 2700.0),
          boundary: Sides3(left: Normal(0.0), right: Normal(0.0), front: Normal(0.0),
                           back: Normal(0.0), bottom: Normal(0.0), top: Normal(0.0)),
          fracture: Some((
              discs: [(center: (0.0, 0.0, 0.0), normal: (0.0, 0.0, 1.0), radius: 1.0),
                      (center: (0.0, {y}, 0.0), normal: (0.0, 1.0, 0.0), radius: {r})],
              residual_aperture: 1e-4)),
          initial_fluid: Full(0.0),
          flow_boundaries: [(name: \"well\", at: Node((0.0, 0.0, 0.0)), kind: Rate(1e-3))],
          damping: Local(0.1),
          time: (end: Time(0.01), safety: 0.9),
          output: (frame_every: 100000, series_every: 100))"
    );
    let path = dir.join("two.ron");
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out");
    let s = cli::run_ok(&path, &out, &[]);
    assert_eq!(s["status"], "ok", "{s}");
    let frames = vtu::read_pvd(&out.join("network.pvd")).unwrap();
    let last = vtu::read_vtu(&out.join(&frames.last().unwrap().1)).unwrap();
    let p = last.cell_array("pressure").unwrap().to_vec();
    // Disc B's triangles: all three corners on the plane y = `y`.
    let b: Vec<f64> = (0..p.len())
        .filter(|&k| (0..3).all(|c| (last.points[3 * k + c][1] - y).abs() < 1e-9))
        .map(|k| p[k])
        .collect();
    assert!(!b.is_empty());
    (b, s)
}

#[test]
fn fluid_crosses_into_a_second_disc_only_where_the_two_intersect() {
    // B (y = 0.5, R = 0.75) cuts A along the line y = 0.5, z = 0: the well's water reaches
    // every B triangle through the edges on that line (an edge on four triangles joins every
    // two). B moved to y = 1.5 (R = 0.4) misses A: its cells keep their zero pressure.
    let (crossing, s) = two_discs("crossing", 0.5, 0.75);
    assert!(crossing.iter().all(|&p| p > 1e5), "{crossing:?}");
    assert!(s["flow"]["mass_balance_error"].as_f64().unwrap() < 1e-12);
    let (apart, _) = two_discs("apart", 1.5, 0.4);
    assert!(apart.iter().all(|&p| p == 0.0), "{apart:?}");
}

#[test]
fn flow_boundaries_of_the_wrong_dimension_or_off_the_fracture_are_refused_by_field() {
    let dir = cli::tmp("refused");
    std::fs::create_dir_all(&dir).unwrap();
    let pumped = std::fs::read_to_string(cli::scenario("penny_injection.ron")).unwrap();
    let cases: Vec<(String, &[&str])> = vec![
        (
            pumped.replace("Node((0.0, 0.0, 0.0))", "Node((0.0, 0.0))"),
            &["flow_boundaries[0].at", "(x, y, z)"],
        ),
        (
            pumped.replace("Node((0.0, 0.0, 0.0))", "Node((3.0, 3.0, 0.0))"),
            &["flow_boundaries[0].at", "nearest fracture node"],
        ),
        (
            pumped.replace("time: (end:", "time: (solid_scheme: QuasiStatic, end:"),
            &["time.solid_scheme", "quasi-static"],
        ),
        (
            pumped.replace(
                "residual_aperture: 1e-4,",
                "residual_aperture: 1e-4, pressure: 1e6,",
            ),
            &["fracture.pressure", "fluid"],
        ),
        (
            "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
              material: (young: 2e10, poisson: 0.2, density: 2700.0),
              boundary: Sides(bottom: Fixed),
              fracture: Some((preexisting: [(from: (1.0, 2.0), to: (3.0, 2.0))])),
              flow_boundaries: [(at: Node((2.0, 2.0, 0.0)), kind: Rate(1e-4))],
              time: (end: Time(0.01)))"
                .to_string(),
            &["flow_boundaries[0].at", "2D"],
        ),
    ];
    cli::assert_all_refused(&dir, &cases);
}
