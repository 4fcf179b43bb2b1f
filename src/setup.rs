//! Setup: the rock model a scenario describes (mesh, material, pre-existing fractures,
//! boundary conditions, pins, initial state, body forces, face pressure) and its fluid network.

use crate::error::SetupError;
use crate::mesh::TriMesh;
use crate::model::Model;
use crate::scenario::{Boundary, InitialFluid, InitialState, MeshSpec, Scenario};

/// Build the mesh a scenario describes.
pub fn build_mesh(spec: &MeshSpec) -> Result<TriMesh, SetupError> {
    match *spec {
        MeshSpec::Regular {
            width,
            height,
            h,
            origin,
        } => TriMesh::regular(width, height, h, origin),
        MeshSpec::Perturbed {
            width,
            height,
            h,
            origin,
            fraction,
            seed,
        } => TriMesh::perturbed(width, height, h, origin, fraction, seed),
        MeshSpec::Graded {
            width,
            height,
            origin,
            h,
            fine,
            ratio,
        } => TriMesh::graded(width, height, origin, h, fine, ratio),
        MeshSpec::Gmsh { ref file } => {
            let g = crate::gmsh::read_msh(std::path::Path::new(file))
                .map_err(|e| SetupError::invalid("mesh.file", e.to_string()))?;
            Ok(TriMesh::from_triangles(g.nodes, g.triangles))
        }
    }
}

/// The model of a validated scenario: the rock (when it has a mesh) with its fractures opened,
/// and the pre-existing fractures as placed on the mesh.
pub fn build_model(sc: &Scenario) -> Result<(Model, Vec<crate::fractures::Placed>), SetupError> {
    let (Some(spec), Some(mat)) = (&sc.mesh, &sc.material) else {
        return Ok((Model::empty(), Vec::new()));
    };
    let mesh = build_mesh(spec)?;
    let mut m = Model::from_mesh(&mesh, *mat)?;
    let mut placed = Vec::new();
    if let Some(f) = &sc.fracture {
        placed = crate::fractures::open_preexisting(&mut m, &mesh, f)?;
    }
    m.apply_boundary(&sc.boundary);
    m.apply_pins(&sc.pins)?;
    if let (InitialState::InSitu, Boundary::InSitu { sxx, syy }) = (sc.initial_state, &sc.boundary)
    {
        m.set_insitu_displacement(*sxx, *syy);
    }
    if let Some(g) = sc.gravity {
        let rho = mat.density;
        m.add_body_force(|_| [rho * g[0], rho * g[1]]);
    }
    if let Some(p) = sc.fracture.as_ref().and_then(|f| f.pressure) {
        crate::fractures::apply_face_pressure(&mut m, p);
    }
    Ok((m, placed))
}

/// Coupled runs: fill the rock's fracture cells at the initial fluid pressure (an empty start
/// leaves them empty).
pub fn fill_fractures(model: &mut Model, initial: InitialFluid, rho_r: f64, k: f64) {
    if let InitialFluid::Full(p0) = initial {
        crate::fractures::fill_cells(model, rho_r * (1.0 + p0 / k));
    }
}
