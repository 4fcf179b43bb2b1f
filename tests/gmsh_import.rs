//! A mesh imported from a Gmsh file (a 2 m x 2 m patch with a displaced interior node) passes
//! the patch test: u = c0 + G x on the boundary is reproduced inside to round-off (1e-9), and a
//! scenario names it relative to its own folder.

use crate::support_cli as cli;

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};

#[test]
fn imported_mesh_passes_the_patch_test() {
    let text = r#"(
        name: "gmsh_patch",
        mesh: Gmsh(file: "meshes/patch.msh"),
        material: (young: 10e9, poisson: 0.3, density: 2500.0),
        time: (end: Static(tol: 1e-13)),
    )"#;
    // A scenario folder with the mesh in meshes/, as a user would lay it out.
    let dir = cli::tmp("patch");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::copy("scenarios/meshes/patch.msh", dir.join("meshes/patch.msh")).unwrap();
    std::fs::write(dir.join("patch.ron"), text).unwrap();
    let sc = Scenario::load(&dir.join("patch.ron"), &[]).unwrap();
    let mut sim = Simulation::new(sc, &[]).unwrap();
    assert_eq!(sim.solid().n_elems(), 8);
    assert_eq!(sim.solid().n_nodes(), 9);
    let exact = |x: [f64; 2]| {
        [
            1e-4 + 1e-3 * x[0] + 2e-4 * x[1],
            -2e-4 - 5e-4 * x[0] + 3e-4 * x[1],
        ]
    };
    sim.edit_model(|m| m.prescribe_boundary_field(exact));
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let i = sim
        .solid()
        .x0
        .iter()
        .position(|&x| x == [1.13, 0.91])
        .unwrap();
    let (u, e) = (sim.solid().u[i], exact(sim.solid().x0[i]));
    let err = ((u[0] - e[0]).powi(2) + (u[1] - e[1]).powi(2)).sqrt() / 2.2e-3;
    assert!(err < 1e-9, "interior node off by {err:.3e}");
}

#[test]
fn missing_mesh_file_is_a_clear_error() {
    let text = r#"(
        name: "gmsh_missing",
        mesh: Gmsh(file: "no_such.msh"),
        material: (young: 10e9, poisson: 0.3, density: 2500.0),
        time: (end: Static(tol: 1e-13)),
    )"#;
    let sc = Scenario::parse(text, "x.ron").unwrap();
    let e = Simulation::new(sc.validate().unwrap(), &[])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("mesh.file") && e.contains("no_such.msh"), "{e}");
}
