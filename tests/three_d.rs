//! 3D through the engine (issue 38): a scenario with a tetrahedral mesh runs from the CLI on
//! the same systems as 2D (`engine/src/sim3.rs`), writes VTK tetrahedra that read back, and is
//! checked against closed forms.
//! - the shipped in-situ block (`scenarios/insitu_block3d.ron`) relaxes to the prescribed
//!   principal stresses in every element;
//! - the patch test through the engine, with both solid schemes: a graded box under a normal
//!   traction on its top and rollers on three sides carries the uniform uniaxial stress, and
//!   its displacement is the linear closed form (TET4 holds linear fields exactly; the
//!   explicit relaxation's tolerance is set by its static tolerance, the quasi-static solve's
//!   by round-off); a quasi-static body free to move is refused with the reason;
//! - the explicit step is stable at 0.9 of the element bound and a step three times the bound
//!   blows up with the step, the node and the quantity named, the outputs so far kept;
//! - what 3D cannot do yet, and boundaries of the wrong dimension, are refused by field.

use crate::support_cli as cli;
use crate::support_vtu as vtu;

const YOUNG: f64 = 20e9;
const NU: f64 = 0.2;

/// The last solid frame of a run in `dir`.
fn last_frame(dir: &std::path::Path) -> vtu::VtuData {
    let frames = vtu::read_pvd(&dir.join("solid.pvd")).expect("solid.pvd");
    let (_, last) = frames.last().expect("a frame");
    vtu::read_vtu(&dir.join(last)).expect("frame reads back")
}

#[test]
fn the_insitu_block_relaxes_to_the_prescribed_stress_everywhere() {
    let out = cli::tmp("block");
    let s = cli::run_ok(cli::scenario("insitu_block3d.ron"), &out, &[]);
    assert_eq!(s["status"], "ok");
    assert_eq!(s["finish"], "converged");
    assert_eq!(s["dimension"], 3);
    assert_eq!(s["elements"], 48_000);
    assert_eq!(s["nodes"], 9_261);
    // Kuhn cubes: dihedral angles of 45, 60 and 90 degrees, all of one volume.
    let q = &s["mesh"]["tetrahedra"];
    assert_eq!(q["count"], 48_000);
    assert!(
        (q["min_dihedral_deg"].as_f64().unwrap() - 45.0).abs() < 1e-9,
        "{q}"
    );
    assert!(
        (q["max_dihedral_deg"].as_f64().unwrap() - 90.0).abs() < 1e-9,
        "{q}"
    );
    assert!(
        (q["volume_ratio"].as_f64().unwrap() - 1.0).abs() < 1e-9,
        "{q}"
    );
    let f = last_frame(&out);
    assert_eq!(f.points.len(), 9_261);
    assert_eq!(f.types.len(), 48_000);
    assert!(f.types.iter().all(|&t| t == 10), "VTK tetrahedra");
    assert_eq!(f.connectivity.len(), 4 * 48_000);
    // Every element at the in-situ stress: the static tolerance 1e-8 on the force residual
    // leaves a few 1e-8 of the stress (measured 0.94 Pa of 30 MPa at the worst element); the
    // bound is five times that.
    for (name, want) in [
        ("stress_xx", -20e6),
        ("stress_yy", -10e6),
        ("stress_zz", -30e6),
        ("stress_xy", 0.0),
        ("stress_yz", 0.0),
        ("stress_zx", 0.0),
    ] {
        let v = f.cell_array(name).expect(name);
        let worst = v.iter().fold(0.0f64, |m, x| m.max((x - want).abs()));
        assert!(worst < 5.0, "{name}: worst deviation {worst:.3e} Pa");
    }
    // The systems a 3D rock without fractures runs, and those it has no data for.
    let systems = s["systems"].as_array().expect("systems");
    let enabled = |n: &str| {
        systems
            .iter()
            .find(|x| x["name"] == n)
            .map(|x| x["enabled"].as_bool().unwrap())
    };
    for n in [
        "internal_force",
        "damping",
        "integrate",
        "monitor",
        "output",
    ] {
        assert_eq!(enabled(n), Some(true), "{n}");
    }
    for n in ["contact", "flow_substeps", "split", "solve"] {
        assert_eq!(enabled(n), Some(false), "{n}");
    }
}

/// A graded box (4 x 3 x 2 m) with rollers on its left, front and bottom sides and a normal
/// traction `sigma` (Pa) on its top.
fn uniaxial_scene(sigma: f64, extra: &str) -> String {
    format!(
        "(name: \"uniaxial3d\",
          mesh: GradedBox(size: (4.0, 3.0, 2.0), h: 0.25, fine: (1.5, 1.0, 0.5, 2.5, 2.0, 1.5), ratio: 1.3),
          material: (young: {YOUNG:e}, poisson: {NU}, density: 2700.0),
          boundary: Sides3(left: Normal(0.0), front: Normal(0.0), bottom: Normal(0.0),
                           top: Traction(normal: {sigma:e}, shear: 0.0)),
          time: (end: Static(tol: 1e-10), safety: 0.9, max_steps: 200000 {extra}),
          damping: Local(0.8),
          output: (frame_every: 0, series_every: 100, fields: [Displacement, Stress]))"
    )
}

/// The patch test of one solid scheme (`extra`: the scheme's `time` entries): stress and
/// displacement against the closed form, relative; returns the run's `summary.json`.
fn patch_test(name: &str, extra: &str, stress_tol: f64, disp_tol: f64) -> serde_json::Value {
    let sigma = -10e6;
    let dir = cli::tmp_dir(name);
    let path = dir.join("uniaxial3d.ron");
    std::fs::write(&path, uniaxial_scene(sigma, extra)).unwrap();
    let out = dir.join("out");
    let s = cli::run_ok(&path, &out, &[]);
    assert_eq!(s["finish"], "converged", "{s}");
    let f = last_frame(&out);
    // Stress: sigma_zz = sigma, the others zero.
    for (name, want) in [
        ("stress_xx", 0.0),
        ("stress_yy", 0.0),
        ("stress_zz", sigma),
        ("stress_xy", 0.0),
        ("stress_yz", 0.0),
        ("stress_zx", 0.0),
    ] {
        let v = f.cell_array(name).expect(name);
        let worst = v.iter().fold(0.0f64, |m, x| m.max((x - want).abs()));
        assert!(
            worst < stress_tol * sigma.abs(),
            "{name}: worst {worst:.3e} Pa"
        );
    }
    // Displacement: u = (-nu e x, -nu e y, e z) with e = sigma / E, about the rollers' corner.
    let e = sigma / YOUNG;
    let u = f.point_array("displacement").expect("displacement");
    let umax = (e * 2.0_f64).abs();
    let mut worst = 0.0f64;
    for (i, x) in f.points.iter().enumerate() {
        let want = [-NU * e * x[0], -NU * e * x[1], e * x[2]];
        for d in 0..3 {
            worst = worst.max((u[3 * i + d] - want[d]).abs());
        }
    }
    assert!(
        worst < disp_tol * umax,
        "displacement off the closed form by {worst:.3e} m (of {umax:.3e} m)"
    );
    s
}

#[test]
fn a_graded_box_under_uniaxial_stress_passes_the_patch_test_with_both_schemes() {
    // Explicit relaxation to the static tolerance 1e-10: measured stress 4.9e-4 Pa of 10 MPa
    // (5e-11), displacement 5.9e-13 m of 1e-3 m (6e-10).
    let s = patch_test("explicit", "", 1e-8, 1e-8);
    assert!(
        s["steps"].as_u64().unwrap() > 100,
        "relaxation takes many steps: {s}"
    );
    assert!(s["dt_critical"].as_f64().unwrap() > 0.0, "{s}");
    // Quasi-static: one step, one factorisation; measured stress 1e-7 Pa (1e-14), the
    // residual 1e-14 (round-off).
    let s = patch_test("quasi_static", ", solid_scheme: QuasiStatic", 1e-12, 1e-10);
    assert_eq!(s["steps"], 1, "a static quasi-static run is one step");
    // One factorisation; the first solve is at round-off or one refinement takes it there.
    assert_eq!(s["quasi_static"]["factorisations"], 1, "{s}");
    let solves = s["quasi_static"]["solves"].as_u64().unwrap();
    assert!((1..=2).contains(&solves), "{s}");
    assert!(s.get("dt_critical").is_none(), "no stability bound: {s}");
}

#[test]
fn a_quasi_static_body_free_to_move_is_refused_clearly() {
    let dir = cli::tmp_dir("floating");
    let path = dir.join("floating.ron");
    let text = uniaxial_scene(-1e6, ", solid_scheme: QuasiStatic")
        .replace("left: Normal(0.0), front: Normal(0.0), ", "");
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out");
    let o = cli::run(&[
        "run",
        path.to_str().unwrap(),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    cli::assert_refused(&o, &["boundary", "not positive definite", "rigid motion"]);
}

#[test]
fn the_explicit_3d_step_is_stable_below_its_bound_and_blows_up_clearly_above_it() {
    let dir = cli::tmp_dir("stability");
    // Undamped, loaded suddenly, for a fixed time.
    let scene = |dt: &str| {
        uniaxial_scene(-10e6, dt)
            .replace("Static(tol: 1e-10)", "Time(2e-3)")
            .replace("damping: Local(0.8),", "damping: None,")
    };
    let stable = dir.join("stable.ron");
    std::fs::write(&stable, scene("")).unwrap();
    let out = dir.join("stable");
    let s = cli::run_ok(&stable, &out, &[]);
    assert_eq!(s["finish"], "end_time");
    let dt_crit = s["dt_critical"].as_f64().unwrap();
    // 0.9 of the bound, shortened so that whole steps reach the end.
    let ratio = s["dt"].as_f64().unwrap() / dt_crit;
    assert!(ratio <= 0.9 && ratio > 0.85, "dt / dt_crit = {ratio}");
    let e = s["kinetic_energy"].as_f64().unwrap();
    assert!(
        e > 0.0 && e.is_finite(),
        "the load sets the block moving: {e}"
    );
    // Three times the element bound: above the mesh's (within a factor 2 of the element bound,
    // tests/tet_solid.rs).
    let unstable = dir.join("unstable.ron");
    std::fs::write(
        &unstable,
        scene(&format!(", dt: Some({:e})", 3.0 * dt_crit)),
    )
    .unwrap();
    let out = dir.join("unstable");
    let o = cli::bin()
        .args(["run", unstable.to_str().unwrap(), "--quiet", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let e = cli::stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert_ne!(o.status.code(), Some(101), "panic: {e}");
    for needle in ["blow-up at step", "node", "m/s"] {
        assert!(e.contains(needle), "`{needle}` not in: {e}");
    }
    let s = cli::summary(&out);
    assert_eq!(s["status"], "failed");
    assert!(out.join("timeseries.csv").exists());
}

#[test]
fn what_3d_lacks_and_boundaries_of_the_wrong_dimension_are_refused_by_field() {
    let dir = cli::tmp_dir("refused");
    let base = uniaxial_scene(-1e6, "");
    let cases: Vec<(String, &[&str])> = vec![
        (
            base.replace("boundary: Sides3(", "boundary: Sides(")
                .replace("front: Normal(0.0), ", ""),
            &["boundary", "InSitu3"],
        ),
        // Mass scaling runs in 3D; its own checks apply.
        (
            base.replace("time: (", "time: (selective_mass_scaling: Some(0.5), "),
            &["time.selective_mass_scaling", "at least 1"],
        ),
        (
            base.replace("damping:", "fracture: (strength: 5e6), damping:"),
            &["fracture.face_stress", "Elements"],
        ),
        // Growth in 3D: the toughness criterion only in the discs' planes, the explicit rock
        // only, so far.
        (
            base.replace(
                "damping:",
                "fracture: (criterion: Some(Toughness(k_ic: 1e6)), face_stress: Elements), \
                 damping:",
            ),
            &["fracture.criterion", "toughness", "not in 3D yet"],
        ),
        (
            base.replace(
                "damping:",
                "fracture: (strength: 5e6, face_stress: Elements), damping:",
            )
            .replace("time: (", "time: (solid_scheme: QuasiStatic, "),
            &["time.solid_scheme", "quasi-static", "not in 3D yet"],
        ),
        (
            base.replace(
                "fine: (1.5, 1.0, 0.5, 2.5, 2.0, 1.5)",
                "fine: (1.5, 1.0, 0.5, 5.5, 2.0, 1.5)",
            ),
            &["mesh.fine"],
        ),
        (
            "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
              material: (young: 2e10, poisson: 0.2, density: 2700.0),
              boundary: InSitu3(sxx: -1e6, syy: -1e6, szz: -1e6),
              time: (end: Static(tol: 1e-6)))"
                .to_string(),
            &["boundary", "this mesh is 2D"],
        ),
        (
            base.replace("damping:", "gravity: Some((0.0, -9.81)), damping:"),
            &["gravity", "three components"],
        ),
        (
            base.replace(
                "damping:",
                "pins: [(at: (0.0, 0.0), ux: Some(0.0))], damping:",
            ),
            &["pins[0].at", "(x, y, z)"],
        ),
        (
            base.replace(
                "damping:",
                "pins: [(at: (50.0, 50.0, 50.0), ux: Some(0.0))], damping:",
            ),
            &["pins[0].at", "from the nearest node"],
        ),
        (
            "(name: \"flat\", mesh: Regular(width: 4.0, height: 4.0, h: 1.0),
              material: (young: 2e10, poisson: 0.2, density: 2700.0),
              boundary: Sides(bottom: Fixed), gravity: Some((0.0, -9.81, 0.0)),
              time: (end: Static(tol: 1e-6)))"
                .to_string(),
            &["gravity", "two components"],
        ),
    ];
    cli::assert_all_refused(&dir, &cases);
}

/// Pins in 3D: a box with no displacement held anywhere, squeezed by equal tractions on its
/// top and bottom, is a body free to move (refused by the quasi-static solve); three pins in
/// the 3-2-1 pattern (a corner held in x, y, z, a second in y and z, a third in z) stop the six
/// rigid motions without loading it, so the stress is the uniaxial -1 MPa everywhere, to
/// round-off, and the pinned corner stays put.
#[test]
fn three_pins_hold_a_free_box_without_stressing_it() {
    use hydrofrac::scenario::Scenario;
    use hydrofrac::sim::{Finish, Simulation};
    let text = r#"(
        name: "pinned3d",
        mesh: Box(size: (2.0, 2.0, 2.0), h: 0.5),
        material: (young: 20e9, poisson: 0.25, density: 2700.0),
        boundary: Sides3(bottom: Traction(normal: -1e6, shear: 0.0),
                         top: Traction(normal: -1e6, shear: 0.0)),
        pins: [(at: (0.0, 0.0, 0.0), ux: Some(0.0), uy: Some(0.0), uz: Some(0.0)),
               (at: (2.0, 0.0, 0.0), uy: Some(0.0), uz: Some(0.0)),
               (at: (0.0, 2.0, 0.0), uz: Some(0.0))],
        time: (end: Static(tol: 1e-10), solid_scheme: QuasiStatic, max_steps: 10),
    )"#;
    let sc = Scenario::parse(text, "pinned3d.ron")
        .unwrap()
        .validate()
        .unwrap();
    let mut sim = Simulation::new_3d(sc, &[]).unwrap();
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let v = sim.solid();
    for (k, s) in v.stress.iter().enumerate() {
        let want = [0.0, 0.0, -1e6, 0.0, 0.0, 0.0];
        for d in 0..6 {
            assert!((s[d] - want[d]).abs() < 1e-3, "element {k}: {s:?}");
        }
    }
    let corner = (0..v.n_nodes()).find(|&i| v.x0[i] == [0.0; 3]).unwrap();
    assert_eq!(v.u[corner], [0.0; 3]);
}

/// Gravity in 3D (`gravity: Some((0, 0, -g))`, z up) on a 2 x 2 x 10 m column of tetrahedra,
/// fixed at its base and on rollers at its sides, solved quasi-statically: uniaxial strain.
/// - The volume average of sigma_zz is -rho g H / 2 to round-off: for linear elements in
///   equilibrium sum V_e sigma_e = sum over nodes of x (f_ext + reaction), the base's
///   reactions act at z = 0 and the consistent loads rho g V / 4 sum to rho g V z_centroid.
/// - Each element's sigma_zz is the weight above it, -rho g (H - z), within one layer's weight
///   rho g h (the linear tetrahedra take the strain over a layer's height, not at the centroid).
/// - The volume averages of sigma_xx and sigma_yy are nu / (1 - nu) of sigma_zz's to round-off
///   (the rollers make the average lateral strain, the boundary integral of u n, zero); each element's within 1e-2 rho g H: the Kuhn tetrahedra are not
///   mirror-symmetric, so the nodes move sideways a little, most under the free top (shear
///   stresses of 4e-4 of the mean appear too).
#[test]
fn gravity_loads_the_3d_column_with_its_weight() {
    use hydrofrac::scenario::Scenario;
    use hydrofrac::sim::{Finish, Simulation};
    let text = r#"(
        name: "column3d",
        mesh: Box(size: (2.0, 2.0, 10.0), h: 0.5),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: Sides3(left: Normal(0.0), right: Normal(0.0), front: Normal(0.0),
                         back: Normal(0.0), bottom: Fixed, top: Free),
        gravity: Some((0.0, 0.0, -9.81)),
        time: (end: Static(tol: 1e-10), solid_scheme: QuasiStatic, max_steps: 10),
    )"#;
    let sc = Scenario::parse(text, "column3d.ron")
        .unwrap()
        .validate()
        .unwrap();
    let mut sim = Simulation::new_3d(sc, &[]).unwrap();
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let (rho_g, height, h) = (2700.0 * 9.81, 10.0, 0.5);
    let v = sim.solid();
    let mut mean = [0.0; 3];
    for (k, c) in v.conn.iter().enumerate() {
        let zc = c.iter().map(|&a| v.x0[a as usize][2]).sum::<f64>() / 4.0;
        let s = v.stress[k];
        for d in 0..3 {
            mean[d] += s[d] / v.n_elems() as f64;
        }
        let exact = -rho_g * (height - zc);
        assert!(
            (s[2] - exact).abs() <= rho_g * h,
            "element {k}: szz {} vs {exact}",
            s[2]
        );
        for lateral in [s[0], s[1]] {
            assert!(
                (lateral - 0.25 * s[2]).abs() < 1e-2 * rho_g * height,
                "element {k}: {lateral} vs nu/(1-nu) szz = {}",
                0.25 * s[2]
            );
        }
    }
    // Equal volumes: the element mean is the volume average.
    let want = -rho_g * height / 2.0;
    assert!(
        (mean[2] / want - 1.0).abs() < 1e-9,
        "mean szz {} vs {want}",
        mean[2]
    );
    for lateral in &mean[..2] {
        assert!(
            (lateral / (0.25 * want) - 1.0).abs() < 1e-9,
            "mean lateral {lateral}"
        );
    }
}

/// A Gmsh 2.2 file of `m` (4-node tetrahedra in physical volume 1).
fn msh22(m: &hydrofrac_core::tetmesh::TetMesh) -> String {
    let mut s = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
    s += &format!("$Nodes\n{}\n", m.nodes.len());
    for (i, q) in m.nodes.iter().enumerate() {
        s += &format!("{} {:e} {:e} {:e}\n", i + 1, q[0], q[1], q[2]);
    }
    s += &format!("$EndNodes\n$Elements\n{}\n", m.tets.len());
    for (k, t) in m.tets.iter().enumerate() {
        let n = t.map(|a| (a + 1).to_string()).join(" ");
        s += &format!("{} 4 2 1 1 {n}\n", k + 1);
    }
    s + "$EndElements\n"
}

#[test]
fn a_distorted_gmsh_tetrahedral_mesh_passes_the_patch_test() {
    use rand::{RngExt, SeedableRng};
    // The graded box with its interior nodes moved by up to 15 % of the local cell size
    // (ChaCha8, seed 7): no two elements alike, as a mesher's would be.
    let mut m = hydrofrac_core::tetmesh::TetMesh::graded_box(
        [0.0; 3],
        [4.0, 3.0, 2.0],
        0.25,
        [1.5, 1.0, 0.5, 2.5, 2.0, 1.5],
        1.3,
        &[],
    )
    .unwrap();
    let b = m.bbox;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for q in &mut m.nodes {
        let inside = (0..3).all(|d| q[d] > b[d] + 1e-9 && q[d] < b[d + 3] - 1e-9);
        if inside {
            for c in q.iter_mut() {
                *c += 0.15 * 0.25 * rng.random_range(-1.0..1.0);
            }
        }
    }
    let dir = cli::tmp_dir("gmsh3");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::write(dir.join("meshes/box.msh"), msh22(&m)).unwrap();
    let text = uniaxial_scene(-10e6, ", solid_scheme: QuasiStatic").replace(
        "GradedBox(size: (4.0, 3.0, 2.0), h: 0.25, fine: (1.5, 1.0, 0.5, 2.5, 2.0, 1.5), ratio: 1.3)",
        "Gmsh3(file: \"meshes/box.msh\")",
    );
    assert!(text.contains("Gmsh3"));
    let path = dir.join("gmsh3.ron");
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out");
    let s = cli::run_ok(&path, &out, &[]);
    assert_eq!(s["finish"], "converged", "{s}");
    assert_eq!(s["mesh"]["kind"], "Gmsh3");
    assert_eq!(s["elements"].as_u64().unwrap() as usize, m.tets.len());
    let f = last_frame(&out);
    let szz = f.cell_array("stress_zz").unwrap();
    let sxx = f.cell_array("stress_xx").unwrap();
    let worst = szz
        .iter()
        .map(|x| (x + 10e6).abs())
        .chain(sxx.iter().map(|x| x.abs()))
        .fold(0.0f64, f64::max);
    // TET4 holds the linear field on any tetrahedra: round-off (measured 1.3e-7 Pa, 1.3e-14).
    assert!(worst < 1e-9 * 10e6, "worst stress deviation {worst:.3e} Pa");
    // A file that is not there, and one without tetrahedra, are refused by field and file.
    std::fs::write(dir.join("meshes/flat.msh"), "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n").unwrap();
    for (file, needle) in [
        ("meshes/none.msh", "none.msh"),
        ("meshes/flat.msh", "no 4-node tetrahedra"),
    ] {
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("meshes/box.msh", file);
        let bad = dir.join("bad.ron");
        std::fs::write(&bad, text).unwrap();
        let o = cli::run(&[
            "run",
            bad.to_str().unwrap(),
            "--quiet",
            "--out",
            dir.join("bad_out").to_str().unwrap(),
        ]);
        cli::assert_refused(&o, &["mesh.file", needle]);
    }
}
