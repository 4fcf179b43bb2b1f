//! Setup: the rock model a scenario describes (mesh, material, pre-existing fractures,
//! boundary conditions, pins, initial state, body forces, face pressure), its fluid network and
//! the time step. Called by [`crate::sim::Simulation::new`].

use hydrofrac_core::error::SetupError;
use hydrofrac_core::flow::FlowView;
use hydrofrac_core::mesh::TriMesh;
use hydrofrac_core::model::Model;
use hydrofrac_core::network::CellNetwork;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::{
    Boundary, End, FlowScheme, InitialFluid, InitialState, MeshSpec, Scenario, SolidScheme,
    TimeControl,
};
use hydrofrac_systems::flow::FlowPart;

/// Flow sub-steps per step in flow-only scenes: the schedule, spans and monitoring run once per
/// step, so a step of several flow sub-steps keeps their cost small against the flow kernel.
pub const FLOW_ONLY_SUBSTEPS: u64 = 32;

/// Build the mesh a scenario describes (a conforming mesh around no fracture).
pub fn build_mesh(spec: &MeshSpec) -> Result<TriMesh, SetupError> {
    build_mesh_around(spec, &[]).map(|(m, _)| m)
}

/// How the rock's mesh came out, for `summary.json`: its kind, quality statistics, and for a
/// conforming mesh what meshing did to the fractures.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MeshInfo {
    pub kind: String,
    /// Triangle statistics (2D; not computed for tetrahedra yet).
    #[serde(skip_serializing_if = "no_triangles")]
    pub quality: hydrofrac_core::conforming::MeshQuality,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conforming: Option<hydrofrac_core::conforming::ConformingReport>,
    /// 3D: the tetrahedra's quality.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tetrahedra: Option<TetQuality>,
    /// 3D: each disc fracture as the mesh faces that make it up.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub discs: Vec<DiscReport>,
}

fn no_triangles(q: &hydrofrac_core::conforming::MeshQuality) -> bool {
    q.triangles == 0
}

/// The quality of a tetrahedral mesh (`summary.json` `mesh.tetrahedra`): the count, the
/// smallest and largest dihedral angle (degrees; a flat or needle-like tetrahedron has angles
/// near 0 or 180), and the largest over the smallest volume.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct TetQuality {
    pub count: usize,
    pub min_dihedral_deg: f64,
    pub max_dihedral_deg: f64,
    pub volume_ratio: f64,
}

impl TetQuality {
    /// Of every tetrahedron of `mesh` (those it cannot measure are left out; the model
    /// refuses them).
    pub fn of(mesh: &hydrofrac_core::tetmesh::TetMesh) -> Self {
        let mut q = TetQuality {
            min_dihedral_deg: 180.0,
            ..Default::default()
        };
        let (mut vmin, mut vmax) = (f64::INFINITY, 0.0f64);
        for t in 0..mesh.tets.len() {
            let Some(g) = hydrofrac_core::tet4::geometry(mesh.corners(t)) else {
                continue;
            };
            q.count += 1;
            for a in hydrofrac_core::tet4::dihedral_angles(&g) {
                q.min_dihedral_deg = q.min_dihedral_deg.min(a);
                q.max_dihedral_deg = q.max_dihedral_deg.max(a);
            }
            vmin = vmin.min(g.volume);
            vmax = vmax.max(g.volume);
        }
        q.volume_ratio = if q.count > 0 { vmax / vmin } else { 0.0 };
        q
    }
}

/// A 3D disc fracture on the mesh (`summary.json` `discs`): the faces it took, their area
/// (m^2) and that area over the disc's, pi R^2 (how well the faces cover it).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct DiscReport {
    pub faces: usize,
    pub area: f64,
    pub area_ratio: f64,
}

/// Build the mesh a scenario describes; a conforming mesh follows the fracture segments
/// `fractures` (m), the other kinds ignore them.
pub fn build_mesh_around(
    spec: &MeshSpec,
    fractures: &[([f64; 2], [f64; 2])],
) -> Result<
    (
        TriMesh,
        Option<hydrofrac_core::conforming::ConformingReport>,
    ),
    SetupError,
> {
    if let MeshSpec::Conforming {
        width,
        height,
        origin,
        h,
        h_far,
        min_angle_deg,
        merge,
        grading,
        ref follow,
    } = *spec
    {
        // The node count of `MeshSpec::counts_around` the fractures caps the refinement:
        // memory was checked against it (`Scenario::mesh_counts`).
        let max_vertices = spec.counts_around(fractures).nodes.ceil() as usize;
        let p = hydrofrac_core::conforming::ConformingParams {
            width,
            height,
            origin,
            h,
            h_far: h_far.unwrap_or(4.0 * h).min(width.max(height)),
            min_angle_deg,
            merge,
            grading,
            max_vertices,
        };
        let mut all = fractures.to_vec();
        all.extend(follow.iter().map(|f| (f.from, f.to)));
        let (m, r) = hydrofrac_core::conforming::conforming_mesh(&p, &all)?;
        return Ok((m, Some(r)));
    }
    let mesh = match *spec {
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
            let g = hydrofrac_core::gmsh::read_msh(std::path::Path::new(file))
                .map_err(|e| SetupError::invalid("mesh.file", e.to_string()))?;
            Ok(TriMesh::from_triangles(g.nodes, g.triangles))
        }
        MeshSpec::Conforming { .. } => unreachable!("handled above"),
        MeshSpec::Box { .. } | MeshSpec::GradedBox { .. } | MeshSpec::Gmsh3 { .. } => {
            Err(SetupError::invalid(
                "mesh",
                "a 3D mesh (tetrahedra) is not a triangle mesh: it is built by the 3D setup",
            ))
        }
    }?;
    Ok((mesh, None))
}

/// The model of a validated scenario: the rock (when it has a mesh) with its fractures opened,
/// and the pre-existing fractures as placed on the mesh.
pub fn build_model(
    sc: &Scenario,
) -> Result<(Model, Vec<hydrofrac_core::fractures::Placed>, MeshInfo), SetupError> {
    let (Some(spec), Some(mat)) = (&sc.mesh, &sc.material) else {
        return Ok((Model::empty(), Vec::new(), MeshInfo::default()));
    };
    let segments: Vec<([f64; 2], [f64; 2])> = match (&sc.fracture, spec) {
        (Some(f), MeshSpec::Conforming { .. }) => f
            .all_preexisting()?
            .iter()
            .map(|(p, _)| (p.from, p.to))
            .collect(),
        _ => Vec::new(),
    };
    let (mesh, conforming) = build_mesh_around(spec, &segments)?;
    let info = MeshInfo {
        kind: spec.kind().to_string(),
        quality: hydrofrac_core::conforming::MeshQuality::of(&mesh),
        conforming,
        tetrahedra: None,
        discs: Vec::new(),
    };
    let mut m = Model::from_mesh(&mesh, *mat)?;
    let mut placed = Vec::new();
    if let Some(f) = &sc.fracture {
        placed = hydrofrac_core::fractures::open_preexisting(&mut m, &mesh, f)?;
    }
    m.apply_boundary(&sc.boundary);
    m.apply_pins(&sc.pins)?;
    if let (InitialState::InSitu, Boundary::InSitu { sxx, syy }) = (sc.initial_state, &sc.boundary)
    {
        m.set_insitu_displacement(*sxx, *syy);
    }
    if let Some(g) = sc.gravity.map(|g| g.xy()) {
        let rho = mat.density;
        m.add_body_force(|_| [rho * g[0], rho * g[1]]);
    }
    if let Some(p) = sc.fracture.as_ref().and_then(|f| f.pressure) {
        hydrofrac_core::fractures::apply_face_pressure(&mut m, p);
    }
    Ok((m, placed, info))
}

/// The fictitious masses a run asks for, on a view just built from the model:
/// `time.mass_scaling`'s (static relaxation, for the critical step `dt_crit`, s) or
/// `time.selective_mass_scaling`'s.
pub fn scale_masses(view: &mut hydrofrac_core::view::SolidView, p: &RunParams, dt_crit: f64) {
    use hydrofrac_systems::solid;
    if p.time.mass_scaling {
        let k = p.joint.k_max();
        let rows = solid::gershgorin_rows(view, &p.solid, |_| k);
        solid::scale_masses(view, &rows, dt_crit);
    }
    if let Some(s) = &p.time.selective {
        let k = hydrofrac_core::stability::joint_spring(
            p.joint.k_max(),
            p.k_fluid(),
            p.residual_aperture,
        );
        let rows = solid::gershgorin_rows(view, &p.solid, k);
        solid::raise_masses(view, &rows, s.dt_crit);
    }
}

/// The rock's view (masses scaled by [`scale_masses`]), and the coupling maps of a coupled
/// flow part, which need it.
pub fn solid_view(
    model: &Model,
    p: &RunParams,
    dt_crit: f64,
    flow: Option<&mut FlowPart>,
) -> hydrofrac_core::view::SolidView {
    let mut view = hydrofrac_core::view::SolidView::build(model);
    scale_masses(&mut view, p, dt_crit);
    if let Some(f) = flow
        && f.coupling.is_some()
    {
        let a_r = p.residual_aperture;
        let c = hydrofrac_systems::coupling::Coupling::build(model, &view, &f.view, &p.fluid, a_r);
        f.coupling = Some(c);
    }
    view
}

/// The quasi-static solver when the schedule runs `solve`, its residual made of the force
/// systems the user did not switch off.
pub fn quasi_static(
    schedule: &crate::schedule::Schedule,
) -> Option<hydrofrac_systems::quasi_static::QuasiStatic> {
    use crate::schedule::Status;
    use hydrofrac_systems::SystemId;
    use hydrofrac_systems::quasi_static::{QuasiStatic, Systems};
    let user_on = |s| schedule.status(s) != Status::DisabledByUser;
    schedule.is_enabled(SystemId::Solve).then(|| {
        QuasiStatic::new(Systems {
            load: user_on(SystemId::ExternalLoad),
            contact: user_on(SystemId::Contact),
            fluid: user_on(SystemId::FluidPressure),
        })
    })
}

/// The schedule of a scene: the literal order minus the systems in `disabled` and those whose
/// data the scene lacks.
pub fn schedule<E: hydrofrac_core::dim::Element>(
    disabled: &[String],
    view: &hydrofrac_core::view::SolidView<E>,
    p: &RunParams,
    has_flow: bool,
) -> Result<crate::schedule::Schedule, SetupError> {
    let solid = view.n_nodes() > 0;
    let data = crate::schedule::SceneData {
        solid,
        joints: !view.joint_nodes.is_empty(),
        load: view.has_load(),
        damping: p.solid.damping != hydrofrac_core::scenario::Damping::None,
        flow: has_flow,
        coupled: p.coupled,
        criterion: p.criterion.is_some(),
        quasi_static: solid && p.time.solid_scheme == SolidScheme::QuasiStatic,
        seismicity: p.seismicity.is_some(),
    };
    crate::schedule::Schedule::new(disabled, |s| data.has(s))
}

/// The flow part: a rigid network of its own (`network`), or the rock's fractures when the
/// scene has a mesh and flow boundaries (coupled; the cells are filled at the initial fluid
/// pressure unless the start is empty); `None` without either.
pub fn build_flow(
    model: &mut Model,
    sc: &Scenario,
    p: &RunParams,
) -> Result<Option<FlowPart>, SetupError> {
    let net = match &sc.network {
        Some(spec) => {
            let net = spec.discretise();
            model.add_network(&net, sc.initial_fluid, p.fluid.rho_r, p.fluid.k);
            net
        }
        None if p.coupled => {
            if let InitialFluid::Full(p0) = sc.initial_fluid {
                hydrofrac_core::fractures::fill_cells(model, p.fluid.density_at(p0));
            }
            CellNetwork::default()
        }
        None => return Ok(None),
    };
    model.add_flow_boundaries(&p.flow_boundaries)?;
    let view = FlowView::build(model, &p.fluid);
    Ok(Some(FlowPart::new(view, p, net, p.coupled)))
}

/// The step, s, and for timed runs the number of steps to the end (the step is shortened so a
/// whole number of steps reaches it). The solid sets the step when there is one (`safety`
/// times its critical step `dt_crit`, unless `time.dt` forces one); flow sub-steps fill it.
/// Flow-only scenes take [`FLOW_ONLY_SUBSTEPS`] explicit sub-steps per step, or one implicit
/// step of `time.flow_dt`. An adaptive run (`resolved.adaptive`: quasi-static and coupled)
/// starts at `time.dt` or a thousandth of the end time and has no step count. Sets the flow's
/// sub-step count and length. A step that is zero, subnormal or not finite (a density so
/// small that the P-wave speed overflows, say) is refused, naming what set it.
pub fn time_step(
    resolved: &hydrofrac_core::params::TimeParams,
    t: &TimeControl,
    has_solid: bool,
    dt_crit: f64,
    flow: Option<&mut FlowPart>,
) -> Result<(f64, Option<u64>), SetupError> {
    let flow_auto = flow.as_ref().map(|f| t.safety * f.dt_crit);
    let per_flow_dt = match t.flow_scheme {
        FlowScheme::Explicit => FLOW_ONLY_SUBSTEPS as f64,
        FlowScheme::Implicit => 1.0,
    };
    let quasi_static = has_solid && t.solid_scheme == SolidScheme::QuasiStatic;
    let adaptive = resolved.adaptive;
    let mut dt = match (t.dt, has_solid, flow_auto, t.flow_dt) {
        (Some(dt), _, _, _) => dt,
        // Quasi-static: no stability limit; a static run is one step, a timed one 100.
        // Adaptive (coupled) runs start at a thousandth of the end time.
        (None, true, _, _) if quasi_static => match t.end {
            End::Time(te) if adaptive => te / 1000.0,
            End::Time(te) => te / 100.0,
            End::Static { .. } | End::SteadyDirect => 1.0,
        },
        (None, true, _, _) => t.safety * dt_crit,
        (None, false, _, Some(fdt)) => per_flow_dt * fdt,
        (None, false, Some(fa), None) => FLOW_ONLY_SUBSTEPS as f64 * fa,
        (None, false, None, None) => unreachable!("validated: a mesh or a network"),
    };
    let steps_to_end = match t.end {
        End::Time(te) if adaptive => {
            dt = dt.min(te);
            None
        }
        End::Time(te) => {
            let n = (te / dt - 1e-9).ceil().max(1.0);
            dt = te / n;
            Some(n as u64)
        }
        End::Static { .. } | End::SteadyDirect => None,
    };
    if !(dt.is_finite() && dt >= f64::MIN_POSITIVE) {
        let (field, why) = if t.dt.is_some() {
            ("time.dt", String::from("the step"))
        } else if has_solid {
            (
                "material.density",
                format!(
                    "the critical step (smallest triangle altitude / P-wave speed \
                     sqrt((lambda + 2G) / density)) is {dt_crit:e} s, so the step"
                ),
            )
        } else if t.flow_dt.is_some() {
            ("time.flow_dt", String::from("the step"))
        } else {
            (
                "network",
                String::from("the flow's critical step, and so the step,"),
            )
        };
        return Err(SetupError::invalid(
            field,
            format!("{why} is {dt:e} s: zero, too small to represent or not finite"),
        ));
    }
    if t.dt.is_some() && dt > dt_crit && !quasi_static {
        tracing::warn!(
            "time.dt = {dt:.3e} s is above the critical step {dt_crit:.3e} s; expect a blow-up"
        );
    }
    if let Some(f) = flow {
        let target = t.flow_dt.unwrap_or(t.safety * f.dt_crit);
        f.substeps = match f.implicit {
            Some(_) => 1,
            None => ((dt / target) * (1.0 - 1e-12)).ceil().max(1.0) as u64,
        };
        f.dt = dt / f.substeps as f64;
    }
    Ok((dt, steps_to_end))
}
