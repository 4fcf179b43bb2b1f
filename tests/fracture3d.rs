//! 3D fractures through the engine (issue 38, items 4 and 7): disc fractures opened by node
//! splitting at setup, joints on the sister triangles with the 2D joint model's contact, a
//! prescribed face pressure, both solid schemes.
//! - Sneddon's penny-shaped crack (`scenarios/penny.ron`, a quarter): the opened volume at
//!   R/h = 4 and 8 within bands around the measured errors, first order in h (linear
//!   tetrahedra at a square-root front), the two schemes agreeing to their tolerances, the
//!   topology (one copy per inner node) and the fracture frames read back; the shipped mesh,
//!   graded towards the front, four times closer on the volume and K_I along the front within
//!   5 % by displacement correlation;
//! - superposition: pressure 3 MPa under a 2 MPa in-situ compression opens the disc exactly as
//!   1 MPa does in a free box (linear elasticity, open joints carry nothing);
//! - a disc under a net compression stays closed in every joint, pressed in by the net stress
//!   over the penalty stiffness, the same with both schemes;
//! - the 3D Coulomb law on a joint plane: sticking below the limit, sliding at
//!   |F_t| = mu F_n against the relative motion above it;
//! - the inclined disc (`scenarios/penny_inclined.ron`, a turned grid): under pressure the same
//!   as the horizontal one to round-off; slipping under the in-situ stress without and with
//!   friction as a penny under a uniform stress drop (`hydrofrac verify penny_inclined`,
//!   quick), and as shipped: down the dip, by its potency, the rock around at the in-situ
//!   stress;
//! - discs that lie on no mesh face, discs in 2D, segments in 3D, a bent grid that would
//!   move the box's sides, rollers on a turned grid, a turn to nowhere and refinement planes
//!   off the grid are refused by field.

use crate::support_cli as cli;
use crate::support_vtu as vtu;
use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;

const YOUNG: f64 = 20e9;
const NU: f64 = 0.2;

/// Sneddon's opened volume of the quarter disc (R = 1 m) under pressure p, m^3.
fn quarter_volume(p: f64) -> f64 {
    16.0 * (1.0 - NU * NU) * p / (3.0 * YOUNG) / 4.0
}

/// The shipped penny at R/h = 4 relaxed by the explicit scheme to its static tolerance.
const EXPLICIT4: [&str; 14] = [
    "--set",
    "mesh.h=0.25",
    "--set",
    "mesh.refine=[]",
    "--set",
    "time.solid_scheme=Explicit",
    "--set",
    "time.end=Static(tol: 1e-8)",
    "--set",
    "time.max_steps=100000",
    "--set",
    "damping=Local(0.8)",
    "--set",
    "output.frame_every=0",
];

/// The shipped penny at cell size h without its front refinement, with extra `--set`s.
fn penny(name: &str, h: f64, sets: &[&str]) -> serde_json::Value {
    let out = cli::tmp(name);
    let hs = format!("mesh.h={h}");
    let mut extra = vec!["--set", &hs, "--set", "mesh.refine=[]"];
    for s in sets {
        extra.push("--set");
        extra.push(s);
    }
    let s = cli::run_ok(cli::scenario("penny.ron"), &out, &extra);
    assert_eq!(s["status"], "ok", "{s}");
    s
}

#[test]
fn the_penny_crack_opens_as_sneddon_s_at_first_order_with_both_schemes() {
    let want = quarter_volume(1e6);
    let s4 = penny("qs4", 0.25, &[]);
    let f = &s4["fracture"];
    // R/h = 4: the nodes strictly inside the disc on z = 0 (16 of the quarter) are copied, the
    // 32 faces inside r < R are joints; the bent grid's faces cover the quarter disc to 1 %.
    assert_eq!(f["daughters"], 16);
    assert_eq!(f["joints"], 32);
    let ratio = 4.0 * s4["mesh"]["discs"][0]["area_ratio"].as_f64().unwrap();
    assert!((ratio - 1.0).abs() < 0.01, "area ratio {ratio}");
    assert_eq!(f["joints_closed"], 0);
    // The bent, graded grid's quality is reported: its graded cells far from the disc are
    // long and thin (3.9 degrees measured at the smallest dihedral angle; the bent grid
    // without grading has 23 to 113 degrees).
    let q = &s4["mesh"]["tetrahedra"];
    assert_eq!(q["count"], s4["elements"]);
    let (lo, hi) = (
        q["min_dihedral_deg"].as_f64().unwrap(),
        q["max_dihedral_deg"].as_f64().unwrap(),
    );
    assert!(0.0 < lo && lo < 45.0 && 90.0 < hi && hi < 180.0, "{q}");
    // `fracture.front`: K_I along the front by displacement correlation over the pairs 2 to
    // 5 cells behind it (0.5 to 1.25 m here), against 2 p sqrt(R / pi): the uniform mesh's
    // cells are too coarse there, -18 to -22 % measured (the graded one: the next test).
    let front = &f["front"][0];
    assert_eq!(front["window"][0], 0.5);
    let k_i = 2e6 / std::f64::consts::PI.sqrt();
    for key in ["k_i_min", "k_i_max"] {
        let e = front[key].as_f64().unwrap() / k_i - 1.0;
        assert!((-0.25..-0.15).contains(&e), "{key}: {e} ({front})");
    }
    assert_eq!(front["stretches"].as_array().unwrap().len(), 3, "{front}");
    let e4 = f["opened_volume"].as_f64().unwrap() / want - 1.0;
    // Measured -28.6 % at R/h = 4 and -15.3 % at R/h = 8 (-12.5 % at 10): the
    // linear tetrahedra hold the square-root opening behind the front as a straight one, an
    // error of about 1.3 h / R. The bands are a point either side of the measurements.
    assert!((-0.30..-0.27).contains(&e4), "R/h = 4: volume error {e4}");
    let s8 = penny("qs8", 0.125, &[]);
    let e8 = s8["fracture"]["opened_volume"].as_f64().unwrap() / want - 1.0;
    assert!((-0.165..-0.145).contains(&e8), "R/h = 8: volume error {e8}");
    // First order: halving h halves the error (0.536 measured).
    assert!((0.45..0.62).contains(&(e8 / e4)), "order: {e4} -> {e8}");
    // The centre opening is closer: -16 % and -6.7 % measured.
    let w0 = 8.0 * (1.0 - NU * NU) * 1e6 / (std::f64::consts::PI * YOUNG);
    let c8 = s8["fracture"]["max_opening"].as_f64().unwrap() / w0 - 1.0;
    assert!(
        (-0.09..-0.05).contains(&c8),
        "R/h = 8: centre opening error {c8}"
    );

    // The explicit scheme relaxes to the same static answer: its residual tolerance 1e-8
    // leaves about 1e-8 of the volume (1.5e-8 measured).
    let out = cli::tmp("explicit4");
    let s = cli::run_ok(cli::scenario("penny.ron"), &out, &EXPLICIT4);
    assert_eq!(s["solid_scheme"], "explicit");
    let v_ex = s["fracture"]["opened_volume"].as_f64().unwrap();
    let v_qs = f["opened_volume"].as_f64().unwrap();
    assert!(
        ((v_ex - v_qs) / v_qs).abs() < 1e-6,
        "explicit {v_ex}, quasi-static {v_qs}"
    );
    // The fracture frame reads back: one triangle per joint, and the volume from its
    // openings and areas is the summary's.
    let frames = vtu::read_pvd(&out.join("network.pvd")).expect("network.pvd");
    let last = vtu::read_vtu(&out.join(&frames.last().unwrap().1)).expect("frame");
    assert_eq!(last.types.len(), 32);
    assert!(last.types.iter().all(|&t| t == 5), "VTK triangles");
    let opening = last.cell_array("opening").expect("opening");
    let mut v = 0.0;
    for (k, w) in opening.iter().enumerate() {
        let p = [0, 1, 2].map(|a| last.points[3 * k + a]);
        v += hydrofrac::tet4::triangle_area(p) * w.max(0.0);
    }
    assert!(
        ((v - v_ex) / v_ex).abs() < 1e-9,
        "frame {v}, summary {v_ex}"
    );
}

/// The shipped penny at R/h = 4, with or without its `refine`, solved through the library:
/// its view's opened volume, disc area, tetrahedra and K_I along the front (six stretches,
/// fitted 2 to 5 cells behind it).
fn penny_lib(refined: bool) -> (f64, f64, usize, Vec<f64>) {
    let text = std::fs::read_to_string(cli::scenario("penny.ron")).unwrap();
    let mut sets = vec!["mesh.h=0.25".to_string(), "output.frame_every=0".into()];
    if !refined {
        sets.push("mesh.refine=[]".into());
    }
    let sc = Scenario::parse(&text, "penny.ron")
        .unwrap()
        .with_overrides(&sets)
        .unwrap();
    let mut sim = Simulation::new_3d(sc.validate().unwrap(), &[]).unwrap();
    let _ = sim.run(|_| {}).unwrap();
    let v = sim.solid();
    let o = hydrofrac::model3::opening_3d(v);
    let disc = hydrofrac::scenario::Disc {
        center: [0.0; 3],
        normal: [0.0, 0.0, 1.0],
        radius: 1.0,
    };
    let e1 = YOUNG / (1.0 - NU * NU);
    let k_i = 2.0 * 1e6 / std::f64::consts::PI.sqrt();
    let sif = hydrofrac::model3::front_sif_3d(v, &disc, e1, [0.5, 1.25], 15.0);
    let ks = sif.iter().map(|f| f.k / k_i - 1.0).collect();
    (o.volume, o.area, v.n_elems(), ks)
}

#[test]
fn the_penny_graded_towards_its_front_is_four_times_closer_to_sneddon_s() {
    // The shipped penny's `refine`: cells 16 times finer next to the front's lines and the
    // disc's plane, growing back by 1.5 over about 2 cells. At R/h = 4 the volume error is
    // -6.93 % (measured; -28.6 % without), -3.75 % at R/h = 8 (`verify penny`). The band is
    // half a point either side: the mesh is fixed, so only the solve's round-off could move it.
    let want = quarter_volume(1e6);
    let (v, a, n, ks) = penny_lib(true);
    let e = v / want - 1.0;
    assert!((-0.075..-0.064).contains(&e), "refined R/h = 4: {e}");
    let (v0, a0, n0, ks0) = penny_lib(false);
    let e0 = v0 / want - 1.0;
    assert!(e.abs() < 0.3 * e0.abs(), "refined {e}, plain {e0}");
    // The refinement adds grid lines, not another disc: the disc's area stays within 1 % of
    // the quarter disc's and comes closer to it (the new lines' ends on the circle are more
    // front nodes: 0.9992 of pi R^2 / 4 against 0.9928 without, measured).
    let quarter = std::f64::consts::PI / 4.0;
    assert!((a / quarter - 1.0).abs() < 0.01, "area {a}");
    assert!(
        (a - quarter).abs() < (a0 - quarter).abs(),
        "area {a} against {a0}"
    );
    // The rule (`TetMesh::refine_axis`) fixes the grid: 127,500 tetrahedra against 32,400.
    assert_eq!((n, n0), (127_500, 32_400));
    // K_I = 2 p sqrt(R / pi) along the front, by displacement correlation 2 to 5 cells
    // behind it: -2.9 to -3.95 % on the three stretches with pairs there (measured; issue
    // 38's bound 5 %), against -18 to -22 % without the refinement.
    assert_eq!(ks.len(), 3, "{ks:?}");
    assert!(ks.iter().all(|k| (-0.05..-0.02).contains(k)), "{ks:?}");
    assert!(ks0.iter().all(|k| (-0.25..-0.15).contains(k)), "{ks0:?}");
}

#[test]
fn mass_scaling_relaxes_the_3d_penny_in_fewer_steps_to_the_same_static_state() {
    // The plain penny at R/h = 4 relaxed explicitly to 1e-8 takes 6,773 steps (the first
    // test). Selective mass scaling x4 makes the nodes whose Gershgorin bound is shorter
    // than 4 times the critical step heavier and the step 4 times longer: 2,781 steps
    // (measured). Underwood's masses for static relaxation (`time.mass_scaling`) keep the step
    // and relax every node at the stiffest one's rate: 2,860 steps. The static state is the
    // same: both within 1e-6 of the quasi-static solve (1e-10 measured).
    let v_qs = penny("ms_qs", 0.25, &["output.frame_every=0"])["fracture"]["opened_volume"]
        .as_f64()
        .unwrap();
    let mut sel = EXPLICIT4.to_vec();
    sel.extend(["--set", "time.selective_mass_scaling=Some(4.0)"]);
    let s = cli::run_ok(cli::scenario("penny.ron"), &cli::tmp("ms_sel"), &sel);
    assert_eq!(s["status"], "ok", "{s}");
    let m = &s["mass_scaling"];
    let (t, t0) = (
        m["critical_step"].as_f64().unwrap(),
        m["unscaled_critical_step"].as_f64().unwrap(),
    );
    assert!((t / t0 - 4.0).abs() < 1e-12, "{m}");
    assert!(m["nodes"].as_u64().unwrap() > 0, "{m}");
    assert!(s["steps"].as_u64().unwrap() < 3_000, "{}", s["steps"]);
    let v = s["fracture"]["opened_volume"].as_f64().unwrap();
    assert!(
        ((v - v_qs) / v_qs).abs() < 1e-6,
        "scaled {v}, quasi-static {v_qs}"
    );
    let mut und = EXPLICIT4.to_vec();
    und.extend(["--set", "time.mass_scaling=true"]);
    let s = cli::run_ok(cli::scenario("penny.ron"), &cli::tmp("ms_und"), &und);
    assert_eq!(s["status"], "ok", "{s}");
    assert!(s["steps"].as_u64().unwrap() < 3_000, "{}", s["steps"]);
    let v = s["fracture"]["opened_volume"].as_f64().unwrap();
    assert!(
        ((v - v_qs) / v_qs).abs() < 1e-6,
        "Underwood {v}, quasi-static {v_qs}"
    );
}

/// The quarter penny at R/h = 4 under the in-situ stress `s` (Pa, all three components) and
/// the face pressure `p` (Pa), with the solid scheme `scheme`.
fn confined(name: &str, s: f64, p: f64, scheme: &str) -> serde_json::Value {
    let out = cli::tmp(name);
    let b = format!("boundary=InSitu3(sxx: {s}, syy: {s}, szz: {s})");
    let pr = format!("fracture.pressure={p}");
    let scheme = format!("time.solid_scheme={scheme}");
    let mut sets = vec![
        "mesh.h=0.25",
        "mesh.refine=[]",
        &b,
        "initial_state=InSitu",
        &pr,
        &scheme,
        "time.max_steps=100000",
        "damping=Local(0.8)",
        "output.frame_every=0",
    ];
    if scheme.ends_with("Explicit") {
        sets.push("time.end=Static(tol: 1e-8)");
    }
    let mut extra = Vec::new();
    for s in &sets {
        extra.push("--set");
        extra.push(s);
    }
    cli::run_ok(cli::scenario("penny.ron"), &out, &extra)
}

#[test]
fn a_confined_disc_opens_by_its_net_pressure_and_stays_shut_below_it() {
    // Superposition: p = 3 MPa under a 2 MPa compression is p = 1 MPa in a free box, the
    // joints open; exact in linear elasticity (2e-10 measured: the solve's round-off).
    let free = penny("free", 0.25, &[]);
    let v1 = free["fracture"]["opened_volume"].as_f64().unwrap();
    let s = confined("net", -2e6, 3e6, "QuasiStatic");
    let v = s["fracture"]["opened_volume"].as_f64().unwrap();
    assert!(((v - v1) / v1).abs() < 1e-8, "confined {v}, free {v1}");
    assert_eq!(s["fracture"]["joints_closed"], 0);
    // Below the compression every joint is shut. Each is pressed in by its share of the net
    // stress over the interface stiffness K_n / h (K_n = E): at most 1 MPa x 0.25 m / 20 GPa
    // = 1.25e-5 m, a little less where the intact rock around carries some (1.16e-5 m
    // measured). Both schemes find the same state (the active set in two factorisations).
    let bound = 1e6 * 0.25 / YOUNG;
    let mut seen = Vec::new();
    for scheme in ["QuasiStatic", "Explicit"] {
        let s = confined(&format!("shut{scheme}"), -2e6, 1e6, scheme);
        let f = &s["fracture"];
        assert_eq!(f["joints_closed"], f["joints"], "{scheme}: {f}");
        assert_eq!(f["opened_volume"], 0.0, "{scheme}");
        let d = f["max_interpenetration"].as_f64().unwrap();
        assert!(
            (0.8 * bound..=bound).contains(&d),
            "{scheme}: interpenetration {d} against {bound}"
        );
        seen.push(d);
    }
    assert!(
        ((seen[0] - seen[1]) / seen[0]).abs() < 1e-5,
        "quasi-static {}, explicit {}",
        seen[0],
        seen[1]
    );
}

#[test]
fn the_3d_joint_sticks_below_the_coulomb_limit_and_slides_at_it() {
    // A 1 m cube cut through at z = 0.5 (a disc wider than the box): every node of the plane
    // is copied, the upper block moved rigidly by (dx, dy, -dz) against the lower one.
    let text = "(name: \"plane\", mesh: Box(size: (1.0, 1.0, 1.0), h: 0.5),
        material: (young: 2e10, poisson: 0.2, density: 2700.0),
        boundary: Sides3(bottom: Fixed),
        fracture: Some((discs: [(center: (0.5, 0.5, 0.5), normal: (0.0, 0.0, 1.0),
                                 radius: 10.0)], friction_deg: 30.0)),
        time: (end: Static(tol: 1e-8)))";
    let sc = Scenario::parse(text, "plane.ron")
        .unwrap()
        .validate()
        .unwrap();
    let mut sim = Simulation::new_3d(sc, &[]).unwrap();
    let p = sim.params().joint;
    assert_eq!(p.kn, YOUNG);
    let mu = 30f64.to_radians().tan();
    let v = sim.solid_mut();
    assert_eq!(
        v.joint_nodes.len(),
        8,
        "two triangles per cell face, four faces"
    );
    // The side of each node: the elements around it lie above or below the plane.
    let mut above = vec![false; v.n_nodes()];
    for c in &v.conn {
        let z: f64 = c.iter().map(|&a| v.x0[a as usize][2]).sum::<f64>() / 4.0;
        if z > 0.5 {
            for &a in c {
                above[a as usize] = true;
            }
        }
    }
    let dz = 1e-6;
    for (dx, dy, sliding) in [(1e-7, 0.0, false), (3e-6, 4e-6, true)] {
        // Reset the joints and place the upper block.
        for st in &mut v.joint_state {
            *st = Default::default();
        }
        for ((u, f), &up) in v.u.iter_mut().zip(&mut v.force).zip(&above) {
            *u = if up { [dx, dy, -dz] } else { [0.0; 3] };
            *f = [0.0; 3];
        }
        hydrofrac::systems::fracture::contact_3d(v, &p);
        let (mut fn_sum, mut ft_sum) = (0.0, [0.0; 3]);
        for k in 0..v.joint_nodes.len() {
            let st = v.joint_state[k];
            let l = hydrofrac::model3::joint_len0_3d(v, k);
            // Pressed in by dz: F_n = K_n l dz.
            assert!((st.normal_force - p.kn * l * dz).abs() < 1e-9 * st.normal_force);
            let ft = hydrofrac::model3::face_shear(&st);
            let ft = ft[0].hypot(ft[1]);
            let trial = p.kt * l * dx.hypot(dy);
            assert_eq!(st.sliding, sliding, "joint {k}");
            let want = if sliding { mu * st.normal_force } else { trial };
            assert!(
                (ft - want).abs() < 1e-9 * want,
                "joint {k}: {ft} against {want}"
            );
            fn_sum += st.normal_force;
        }
        // The force on the upper block: up by the normal forces, against its motion by the
        // shear ones.
        for (f, _) in v.force.iter().zip(&above).filter(|x| *x.1) {
            for (s, x) in ft_sum.iter_mut().zip(f) {
                *s += x;
            }
        }
        assert!(
            (ft_sum[2] - fn_sum).abs() < 1e-9 * fn_sum,
            "normal {ft_sum:?}"
        );
        let t = ft_sum[0].hypot(ft_sum[1]);
        let cos = -(ft_sum[0] * dx + ft_sum[1] * dy) / (t * dx.hypot(dy));
        assert!(cos > 1.0 - 1e-12, "shear against the motion: {ft_sum:?}");
        if sliding {
            assert!(
                (t - mu * fn_sum).abs() < 1e-9 * t,
                "Coulomb: {t} against {}",
                mu * fn_sum
            );
        } else {
            assert!(t < mu * fn_sum, "sticks");
        }
    }
}

#[test]
fn an_inclined_disc_opens_as_the_horizontal_one_and_slips_by_its_stress_drop() {
    let r = hydrofrac::verify::inclined3d_cases::penny_inclined(true).unwrap();
    for c in &r.checks {
        assert!(c.pass, "{} = {:e} ({})", c.what, c.value, c.limit);
    }
    // Two levels, five metrics each, and the explicit relaxation at R/h = 3; the checks: the
    // turned and horizontal discs the same, friction's ratio, the slip's direction and the
    // potency's error at each level, the error shrinking, the two schemes the same.
    assert_eq!(r.rows.len(), 11);
    assert_eq!(r.checks.len(), 13);
}

#[test]
fn the_shipped_inclined_penny_slips_down_the_dip_by_its_potency() {
    let out = cli::tmp("penny_inclined");
    let s = cli::run_ok(cli::scenario("penny_inclined.ron"), &out, &[]);
    let f = &s["fracture"];
    // tau - mu sigma_n = 10 - 0.3 x 20 = 4 MPa on the disc; the closed-form potency
    // 16 (1 - nu) 4 MPa R^3 / (3 (2 - nu) G) = 1.138e-3 m^3. R/h = 4 takes 65.7 % of it
    // (the linear tetrahedra's first-order deficit, as the opening's 69 %).
    let g = YOUNG / (2.0 * (1.0 + NU));
    let want = 16.0 * (1.0 - NU) * 4e6 / (3.0 * (2.0 - NU) * g);
    let ratio = f["slip_potency"].as_f64().unwrap() / want;
    assert!((0.64..0.67).contains(&ratio), "potency ratio {ratio}");
    // The disc is shut under 20 MPa: K_I along its front is the joints' interpenetration's,
    // negative and tiny (-20 to -30 kPa m^1/2 measured, against sigma_n sqrt(pi R) = 35 MPa
    // m^1/2).
    for st in f["front"][0]["stretches"].as_array().unwrap() {
        let k = st["k_i"].as_f64().unwrap();
        assert!((-1e5..0.0).contains(&k), "{st}");
    }
    let sv: Vec<f64> = (0..3)
        .map(|d| f["slip_vector"][d].as_f64().unwrap())
        .collect();
    let norm = (sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2]).sqrt();
    let cos = (sv[0] - sv[2]) / (2f64.sqrt() * norm);
    assert!(cos > 0.99985, "down the dip (within 1 degree): {sv:?}");
    // Every joint but the two whose corners all lie on the front slides.
    assert_eq!(f["joints"], 128);
    assert!(f["joints_sliding"].as_u64().unwrap() >= 126, "{f}");
    // The rock far from the disc holds the in-situ stress (the mean over the elements).
    let m = &s["stress_mean"];
    for (k, want) in [("xx", -10e6), ("yy", -10e6), ("zz", -30e6)] {
        let got = m[k].as_f64().unwrap();
        assert!((got / want - 1.0).abs() < 2e-3, "{k}: {got}");
    }
    // The fracture frame reads back on the turned plane: every triangle's corners on
    // x + z = 0, the slip field there.
    let frames = vtu::read_pvd(&out.join("network.pvd")).expect("network.pvd");
    let last = vtu::read_vtu(&out.join(&frames.last().unwrap().1)).expect("frame");
    assert!(last.points.iter().all(|p| (p[0] + p[2]).abs() < 1e-12));
    let slip = last.cell_array("slip").expect("slip");
    assert_eq!(slip.len(), 128);
    let max = slip.iter().copied().fold(0.0, f64::max);
    assert!((max - f["max_slip"].as_f64().unwrap()).abs() < 1e-12 * max);
    // The opening and slip maps, as PNG.
    for png in ["fracture_opening.png", "fracture_slip.png"] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
    }
}

/// The inclined penny under 1 MPa at R/h = 3 in a free cube held by three pins (3-2-1 at
/// three of its corners), on `mesh` (a `mesh: ...` line).
fn pinned_inclined(mesh: &str, corners: [[f64; 3]; 3]) -> String {
    let base = std::fs::read_to_string(cli::scenario("penny_inclined.ron")).unwrap();
    let (a, b) = (
        base.find("    mesh: GradedBox").unwrap(),
        base.find("    material:").unwrap(),
    );
    let [p, q, r] = corners.map(|c| format!("({}, {}, {})", c[0], c[1], c[2]));
    format!("{}    mesh: {mesh},\n{}", &base[..a], &base[b..])
        .replace(
            "boundary: InSitu3(sxx: -10e6, syy: -10e6, szz: -30e6),",
            &format!(
                "boundary: Sides3(), pins: [(at: {p}, ux: Some(0.0), uy: Some(0.0), \
                 uz: Some(0.0)), (at: {q}, uy: Some(0.0), uz: Some(0.0)), \
                 (at: {r}, uz: Some(0.0))],"
            ),
        )
        .replace("initial_state: InSitu,", "")
        .replace("normal_stiffness: 2e12,", "pressure: 1e6,")
}

#[test]
fn an_inclined_disc_embedded_in_a_gmsh_mesh_opens_as_on_the_turned_box() {
    // The turned box's tetrahedra written as a Gmsh file: the disc is found on its faces by
    // its plane, split, loaded and solved as on the box. The two runs differ only in how the
    // mesh arrives (and the Gmsh sides: the bounding box's planes, none held), so they agree
    // to round-off (the same bits measured).
    let graded = "GradedBox(size: (10.0, 10.0, 10.0), origin: (-5.0, -5.0, -5.0), \
                  h: 0.3333333333333333, fine: (-1.3333333333333333, -1.3333333333333333, \
                  -0.3333333333333333, 1.3333333333333333, 1.3333333333333333, \
                  0.3333333333333333), ratio: 1.3, round: Some((center: (0.0, 0.0), \
                  radius: 1.0)), tilt: Some((1.0, 0.0, 1.0)))";
    let spec: hydrofrac::scenario::MeshSpec = ron::from_str(graded).unwrap();
    let m = hydrofrac::sim3::build_tet_mesh(&spec).unwrap();
    let corner = |g: [f64; 3]| {
        *m.nodes
            .iter()
            .min_by(|a, b| {
                let d = |x: &[f64; 3]| {
                    let s = hydrofrac::tetmesh::grid_coords(m.frame.as_ref(), *x);
                    (0..3).map(|k| (s[k] - g[k]).powi(2)).sum::<f64>()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap()
    };
    let corners = [
        corner([-5.0, -5.0, -5.0]),
        corner([5.0, -5.0, -5.0]),
        corner([-5.0, 5.0, -5.0]),
    ];
    let dir = cli::tmp("gmsh_inclined");
    std::fs::create_dir_all(&dir).unwrap();
    let mut msh = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{}\n",
        m.nodes.len()
    );
    for (i, q) in m.nodes.iter().enumerate() {
        msh += &format!("{} {} {} {}\n", i + 1, q[0], q[1], q[2]);
    }
    msh += &format!("$EndNodes\n$Elements\n{}\n", m.tets.len());
    for (i, t) in m.tets.iter().enumerate() {
        let n = t.map(|k| (k + 1).to_string()).join(" ");
        msh += &format!("{} 4 2 1 1 {n}\n", i + 1);
    }
    msh += "$EndElements\n";
    std::fs::write(dir.join("turned.msh"), msh).unwrap();
    let run = |name: &str, mesh: &str| {
        let path = dir.join(format!("{name}.ron"));
        std::fs::write(&path, pinned_inclined(mesh, corners)).unwrap();
        cli::run_ok(&path, &dir.join(name), &[])
    };
    let boxed = run("boxed", graded);
    let gmsh = run("gmsh", "Gmsh3(file: \"turned.msh\")");
    assert_eq!(gmsh["mesh"]["kind"], "Gmsh3");
    let (fb, fg) = (&boxed["fracture"], &gmsh["fracture"]);
    assert_eq!(fb["joints"], 72);
    assert_eq!(fg["joints"], fb["joints"]);
    let (vb, vg) = (
        fb["opened_volume"].as_f64().unwrap(),
        fg["opened_volume"].as_f64().unwrap(),
    );
    assert!((vg / vb - 1.0).abs() < 1e-9, "Gmsh {vg}, box {vb}");
    // Held by pins only, the free cube opens the disc more than the held one of
    // `verify penny_inclined` (-38.6 % of Sneddon's at R/h = 3): 16 p R^3 / (3 E') = 2.56e-4.
    let want = 16.0 * 1e6 * (1.0 - NU * NU) / (3.0 * YOUNG);
    assert!(
        (0.55..0.70).contains(&(vb / want)),
        "volume ratio {}",
        vb / want
    );
}

#[test]
fn discs_off_the_mesh_and_fractures_of_the_wrong_dimension_are_refused_by_field() {
    let dir = cli::tmp("refused");
    std::fs::create_dir_all(&dir).unwrap();
    let penny = std::fs::read_to_string(cli::scenario("penny.ron")).unwrap();
    let radial_k = std::fs::read_to_string(cli::scenario("radial_k.ron")).unwrap();
    let cases: Vec<(String, &[&str])> = vec![
        // Between grid planes.
        (
            penny.replace("center: (0.0, 0.0, 0.0)", "center: (0.0, 0.0, 0.05)"),
            &["fracture.discs[0]", "grid plane"],
        ),
        // Not along an axis.
        (
            penny.replace("normal: (0.0, 0.0, 1.0)", "normal: (0.0, 1.0, 1.0)"),
            &["fracture.discs[0]"],
        ),
        (
            penny.replace("radius: 1.0)]", "radius: -1.0)]"),
            &["fracture.discs[0].radius"],
        ),
        (
            penny.replace("discs: [", "preexisting: [(from: (0.0, 0.0), to: (1.0, 0.0))], discs: ["),
            &["fracture.preexisting", "disc"],
        ),
        // The bent grid would move the far side x = 1.5 m (within 2 R).
        (
            penny.replace("size: (10.0, 10.0, 20.0)", "size: (1.5, 10.0, 20.0)")
                .replace("fine: (0.0, 0.0, -0.5, 1.5, 1.5, 0.5)", "fine: (0.0, 0.0, -0.2, 1.2, 1.2, 0.2)"),
            &["mesh.round"],
        ),
        (
            "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
              material: (young: 2e10, poisson: 0.2, density: 2700.0),
              boundary: Sides(bottom: Fixed),
              fracture: Some((discs: [(center: (2.0, 2.0, 0.0), normal: (0.0, 0.0, 1.0), radius: 1.0)])),
              time: (end: Static(tol: 1e-8)))"
                .to_string(),
            &["fracture.discs", "2D"],
        ),
        (
            "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
              material: (young: 2e10, poisson: 0.2, density: 2700.0),
              boundary: Sides(bottom: Fixed),
              fracture: Some((strength: Some(1e6), grow_in: DiscPlanes)),
              time: (end: Static(tol: 1e-8)))"
                .to_string(),
            &["fracture.grow_in", "2D"],
        ),
        // The toughness criterion in 3D grows fronts in the discs' planes only, with no
        // initiation away from them.
        (
            radial_k.replace("grow_in: DiscPlanes,", ""),
            &["fracture.criterion", "DiscPlanes"],
        ),
        (
            radial_k.replace(
                "Toughness(k_ic: 20e6)",
                "Toughness(k_ic: 20e6, initiation: Some(1e6))",
            ),
            &["fracture.criterion.initiation"],
        ),
        // Refinement planes off the grid's lines, outside the box, coarser or not growing.
        (
            penny.replace("(axis: X, at: 1.0, factor: 16.0)", "(axis: X, at: 1.05, factor: 16.0)"),
            &["mesh.refine[0].at", "no grid line", "1 and 1.1 m"],
        ),
        (
            penny.replace("(axis: Y, at: 1.0, factor: 16.0)", "(axis: Y, at: 12.0, factor: 16.0)"),
            &["mesh.refine[1].at", "outside the box"],
        ),
        (
            penny.replace("(axis: Z, at: 0.0, factor: 16.0)", "(axis: Z, at: 0.0, factor: 0.5)"),
            &["mesh.refine[2].factor", "[1, 1000]"],
        ),
        (
            penny.replace(
                "(axis: X, at: 1.0, factor: 16.0)",
                "(axis: X, at: 1.0, factor: 16.0, ratio: 1.0)",
            ),
            &["mesh.refine[0].ratio", "(1, 10]"],
        ),
        // A turned grid's sides are oblique: no rollers.
        (
            std::fs::read_to_string(cli::scenario("penny_inclined.ron"))
                .unwrap()
                .replace(
                    "boundary: InSitu3(sxx: -10e6, syy: -10e6, szz: -30e6),",
                    "boundary: Sides3(left: Normal(0.0), right: Fixed, front: Fixed, \
                     back: Fixed, bottom: Fixed, top: Fixed),",
                )
                .replace("initial_state: InSitu,", ""),
            &["boundary.left", "oblique"],
        ),
        (
            std::fs::read_to_string(cli::scenario("penny_inclined.ron"))
                .unwrap()
                .replace("tilt: Some((1.0, 0.0, 1.0))", "tilt: Some((0.0, 0.0, 0.0))"),
            &["mesh.tilt"],
        ),
    ];
    cli::assert_all_refused(&dir, &cases);
}

#[test]
fn a_3d_run_restarted_from_its_checkpoint_ends_bit_for_bit_as_the_whole_run() {
    // The explicit penny at R/h = 4 with a checkpoint every 500 steps: the last one before
    // the end (step 3,500 of 3,6xx) is restarted into another folder.
    let mut sets = EXPLICIT4.to_vec();
    sets.extend(["--set", "output.checkpoint_every=Steps(500)"]);
    let whole = cli::tmp("whole");
    let a = cli::run_ok(cli::scenario("penny.ron"), &whole, &sets);
    assert!(a["checkpoints"]["written"].as_u64().unwrap() >= 2, "{a}");
    let ckpt = whole.join("checkpoint.ckpt");
    let part = cli::tmp("part");
    let mut extra: Vec<&str> = sets.to_vec();
    let c = ckpt.to_str().unwrap();
    extra.extend(["--restart", c]);
    let b = cli::run_ok(cli::scenario("penny.ron"), &part, &extra);
    assert_eq!(b["restarted_from"]["bit_identical"], true);
    let from = b["restarted_from"]["step"].as_u64().unwrap();
    assert!(from > 0 && from < a["steps"].as_u64().unwrap());
    for key in ["steps", "time", "residual"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    for key in ["opened_volume", "max_opening"] {
        assert_eq!(a["fracture"][key], b["fracture"][key], "{key}");
    }
    // A 2D checkpoint is refused by a 3D run, naming the dimension, before any output.
    let dir = cli::tmp("flat");
    std::fs::create_dir_all(&dir).unwrap();
    let flat = dir.join("flat.ron");
    std::fs::write(
        &flat,
        "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
          material: (young: 2e10, poisson: 0.2, density: 2700.0),
          boundary: Sides(bottom: Fixed, top: Traction(normal: -1e6, shear: 0.0)),
          time: (end: Static(tol: 1e-6), max_steps: 100000), damping: Local(0.8),
          output: (checkpoint_every: Steps(10)))",
    )
    .unwrap();
    let s2 = cli::run_ok(&flat, &dir.join("out"), &[]);
    assert_eq!(s2["status"], "ok");
    let wrong = cli::tmp("wrong");
    let c2 = dir.join("out").join("checkpoint.ckpt");
    let penny = cli::scenario("penny.ron");
    let mut args: Vec<&str> = vec!["run", &penny];
    args.extend(sets);
    args.extend([
        "--restart",
        c2.to_str().unwrap(),
        "--quiet",
        "--out",
        wrong.to_str().unwrap(),
    ]);
    let o = cli::run(&args);
    cli::assert_refused(&o, &["checkpoint", "2D run's checkpoint", "3D"]);
    assert!(!wrong.exists());
}
