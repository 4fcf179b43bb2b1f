//! The 3D simulation: a [`Simulation`] of linear tetrahedra ([`Tet4`]). Setup builds the 3D
//! model (`hydrofrac_core::model3`), its TET4 view and the schedule from the same scenario
//! format (the dimension follows from the mesh: `Box`, `GradedBox`, `Gmsh3`); the step runs the same
//! systems in the same order through the same generic kernels (`systems/solid.rs`:
//! internal force, external load, damping, central-difference integration; `monitor`).
//!
//! What 3D has so far (issue 38): the rock with the explicit scheme or the quasi-static one
//! (`solve`: [`hydrofrac_systems::linear_static`], the stiffness factorised once), box
//! boundaries (`InSitu3`, `Sides3`), pins, gravity, the in-situ initial state, frames, series
//! rows and the summary, checkpoints and restarts; pre-existing disc fractures with their
//! joints' contact (`contact_3d`) and a prescribed face pressure, or the fluid in them: one
//! flow cell per disc triangle (`hydrofrac_core::flow::faces`), stepped by `flow_substeps`
//! and pushing the faces by `fluid_pressure_3d`, coupled to the explicit rock. The systems the
//! 3D scene has no data for (criterion, split, seismicity) are off in its schedule, as in any
//! 2D scene without them; the scenario's checks refuse what 3D cannot do yet
//! (`Scenario::check_3d`).

use crate::schedule::Status;
use crate::sim::Simulation;
use hydrofrac_core::dim::Tet4;
use hydrofrac_core::error::SetupError;
use hydrofrac_core::model::Model;
use hydrofrac_core::params::{Criterion, RunParams};
use hydrofrac_core::scenario::{
    Boundary, GrowIn, InitialFluid, InitialState, MeshSpec, Scenario, SolidScheme, schedule_factor,
};
use hydrofrac_core::tetmesh::TetMesh;
use hydrofrac_core::view::SolidView;
use hydrofrac_systems::coupling::Coupling;
use hydrofrac_systems::flow::FlowPart;
use hydrofrac_systems::fracture::FractureState;
use hydrofrac_systems::monitor::{Clock, Finish};
use hydrofrac_systems::solid::StepStats;
use hydrofrac_systems::state::SolidPart;
use hydrofrac_systems::{RunError, SystemId, flow, fracture, monitor, output, solid};

/// The tetrahedral mesh of a 3D mesh spec.
pub fn build_tet_mesh(spec: &MeshSpec) -> Result<TetMesh, SetupError> {
    match *spec {
        MeshSpec::Box { size, h, origin } => TetMesh::regular_box(origin, size, h),
        MeshSpec::GradedBox {
            size,
            h,
            origin,
            fine,
            ratio,
            round,
            tilt,
            ref refine,
        } => {
            let mut m = TetMesh::graded_box(origin, size, h, fine, ratio, refine)?;
            if let Some(r) = round {
                m.round_about(r.center, r.radius)?;
            }
            if let Some(t) = tilt {
                m.tilt(t);
            }
            Ok(m)
        }
        MeshSpec::Gmsh3 { ref file } => hydrofrac_core::gmsh::read_msh3(std::path::Path::new(file))
            .map(|g| g.mesh)
            .map_err(|e| SetupError::invalid("mesh.file", e.to_string())),
        _ => Err(SetupError::invalid("mesh", "not a 3D mesh")),
    }
}

/// The 3D model of a validated scenario with a 3D mesh: the rock, its boundary conditions and
/// its initial state.
pub fn build_model_3d(
    sc: &hydrofrac_core::scenario::Scenario,
) -> Result<(Model, crate::setup::MeshInfo), SetupError> {
    let (Some(spec), Some(mat)) = (&sc.mesh, &sc.material) else {
        return Err(SetupError::invalid(
            "mesh",
            "a 3D run needs a mesh and a material",
        ));
    };
    let mut mesh = build_tet_mesh(spec)?;
    let discs = sc.fracture.as_ref().map_or(&[][..], |f| &f.discs[..]);
    let (split, reports) = open_discs(&mut mesh, discs)?;
    let mut m = Model::from_tet_mesh(&mesh, *mat)?;
    if let Some(split) = &split {
        m.add_face_joints(split);
    }
    // A coupled run (flow boundaries need the discs: `Scenario::check_flow_has_fractures`): a
    // flow cell on every joint at the residual aperture, filled or empty.
    if let (Some(f), false) = (&sc.fracture, sc.flow_boundaries.is_empty()) {
        let fill = match sc.initial_fluid {
            InitialFluid::Full(p0) => {
                Some(hydrofrac_core::flow::FlowParams::from(sc.fluid).density_at(p0))
            }
            InitialFluid::Empty => None,
        };
        m.add_face_cells(f.residual_aperture, fill);
        m.add_flow_boundaries3(&sc.flow_boundaries)?;
    }
    m.apply_boundary3(&sc.boundary);
    if let (InitialState::InSitu, Boundary::InSitu3 { sxx, syy, szz }) =
        (sc.initial_state, &sc.boundary)
    {
        m.set_insitu_displacement3([*sxx, *syy, *szz]);
    }
    if let Some(p) = sc.fracture.as_ref().and_then(|f| f.pressure) {
        m.apply_face_pressure3(p);
    }
    if let Some(g) = sc.gravity {
        let rho = mat.density;
        m.add_body_force3(g.v.map(|c| rho * c));
    }
    m.apply_pins3(&sc.pins, &mesh.local_size())?;
    let info = crate::setup::MeshInfo {
        kind: spec.kind().to_string(),
        tetrahedra: Some(crate::setup::TetQuality::of(&mesh)),
        discs: reports,
        ..Default::default()
    };
    Ok((m, info))
}

/// Open the disc fractures on the mesh before it becomes entities: each disc's faces
/// ([`TetMesh::faces_on_discs`]: on its plane, centroid inside), split together
/// ([`TetMesh::split_along`]) and oriented ([`TetMesh::orient_sisters`]). Errors name a disc
/// that lies on no mesh faces.
pub fn open_discs(
    mesh: &mut TetMesh,
    discs: &[hydrofrac_core::scenario::Disc],
) -> Result<
    (
        Option<hydrofrac_core::tetmesh::TetSplit>,
        Vec<crate::setup::DiscReport>,
    ),
    SetupError,
> {
    if discs.is_empty() {
        return Ok((None, Vec::new()));
    }
    let b = mesh.bbox;
    let extent = (0..3).map(|d| b[d + 3] - b[d]).fold(0.0, f64::max);
    let tol = 1e-9 * extent;
    let mut all: Vec<[u32; 3]> = Vec::new();
    let mut reports = Vec::new();
    let on_discs = mesh.faces_on_discs(discs, tol);
    for (i, (d, faces)) in discs.iter().zip(on_discs).enumerate() {
        if faces.is_empty() {
            return Err(SetupError::invalid(
                &format!("fracture.discs[{i}]"),
                "no interior mesh face lies on the disc's plane inside its radius: on a Box or \
                 GradedBox put the centre on a grid plane with the normal along an axis (and \
                 inside the box), or along the grid's turned z axis (`mesh.tilt`); on a Gmsh3 \
                 mesh embed the disc in the mesh",
            ));
        }
        let area: f64 = faces
            .iter()
            .map(|f| hydrofrac_core::tet4::triangle_area(f.map(|k| mesh.nodes[k as usize])))
            .sum();
        reports.push(crate::setup::DiscReport {
            faces: faces.len(),
            area,
            area_ratio: area / (std::f64::consts::PI * d.radius * d.radius),
        });
        all.extend(faces);
    }
    all.sort_unstable();
    all.dedup();
    let mut split = mesh.split_along(&all)?;
    mesh.orient_sisters(&mut split);
    Ok((Some(split), reports))
}

/// The elements' part of [`critical_step_3d`], s: the smallest element's exact critical step
/// with the lumped mass ([`hydrofrac_core::tet4::critical_step`]), which bounds the mesh's
/// from below (Irons' element eigenvalue theorem). A split changes no tetrahedron, so a run
/// computes it once (it was most of a rebuild's cost: 14 % of `radial_m.ron`'s run).
pub fn elements_critical_step_3d(view: &SolidView<Tet4>, p: &RunParams) -> f64 {
    (0..view.n_elems())
        .map(|k| hydrofrac_core::tet4::critical_step(&view.geom[k], &p.solid, p.material.density))
        .fold(f64::INFINITY, f64::min)
}

/// The critical step of central difference on the TET4 mesh, s: the elements' part `elements`
/// ([`elements_critical_step_3d`]) lowered by the joints' springs.
pub fn critical_step_3d(view: &SolidView<Tet4>, p: &RunParams, elements: f64) -> f64 {
    if view.joint_nodes.is_empty() {
        return elements;
    }
    // The joints' penalty springs stiffen the system: the highest frequency squared is at
    // most the elements' (2 / dt_e)^2 plus the largest row sum of the joints' stiffness
    // scaled by the masses, M^-1/2 K_j M^-1/2 (Gershgorin). Joint k couples each sister pair
    // with K l / 3 (normal or tangential, the stiffer; `contact_3d`), and its six nodes with
    // the fluid's K A0 / (9 a_r) between each two: a full cell at the residual aperture a_r
    // pushes back on an opening change with K A0 / a_r (N/m; K the fluid's bulk modulus in
    // coupled runs, else 0).
    let k_fluid = p.k_fluid() / p.residual_aperture;
    let mut row = vec![0.0; view.n_nodes()];
    let m = |a: u32| view.mass[a as usize];
    for j in 0..view.joint_nodes.len() {
        let nodes = view.joint_nodes[j];
        let l = hydrofrac_core::model3::joint_len0_3d(view, j);
        let w = k_fluid * hydrofrac_core::model3::joint_area0_3d(view, j) / 9.0;
        for &a in &nodes {
            for &b in &nodes {
                row[a as usize] += w / (m(a) * m(b)).sqrt();
            }
        }
        let wc = p.joint.k_max() * l / 3.0;
        for s in 0..3 {
            let (a, b) = (nodes[s], nodes[s + 3]);
            let cross = wc / (m(a) * m(b)).sqrt();
            row[a as usize] += wc / m(a) + cross;
            row[b as usize] += wc / m(b) + cross;
        }
    }
    let joints = row.iter().copied().fold(0.0, f64::max);
    let w2 = (2.0 / elements).powi(2) + joints;
    2.0 / w2.sqrt()
}

/// The fictitious masses a 3D run asks for (explicit rock), on the view just built, and the
/// critical step after them, s: `time.selective_mass_scaling = Some(f)` raises the nodes
/// whose Gershgorin bound is shorter than f times `dt_crit` (`solid::raise_masses`; the
/// step becomes f dt_crit, recorded in `p.time.selective`); `time.mass_scaling` gives every
/// node Underwood's mass for `dt_crit` (`solid::scale_masses`; the step is unchanged).
/// Body forces keep the true density (they are set from the model, not the view's masses).
fn scale_masses_3d(
    view: &mut SolidView<Tet4>,
    p: &mut RunParams,
    t: &hydrofrac_core::scenario::TimeControl,
    dt_crit: f64,
) -> f64 {
    let k_fluid = if p.coupled {
        p.k_fluid() / p.residual_aperture
    } else {
        0.0
    };
    let rows = solid::gershgorin_rows_3d(view, &p.solid, p.joint.k_max(), k_fluid);
    if let Some(f) = t.selective_mass_scaling {
        let s = hydrofrac_core::params::SelectiveScaling {
            dt_crit: f * dt_crit,
            dt_unscaled: dt_crit,
        };
        solid::raise_masses(view, &rows, s.dt_crit);
        p.time.selective = Some(s);
        return s.dt_crit;
    }
    solid::scale_masses(view, &rows, dt_crit);
    dt_crit
}

/// The TET4 view of a 3D model, with the strength test's candidate faces when the run has a
/// criterion ([`SolidView::push_internal_faces`]; only those on the discs' planes with
/// `fracture.grow_in: DiscPlanes`).
fn view_3d(model: &Model, p: &RunParams, sc: &Scenario) -> SolidView<Tet4> {
    let mut view = SolidView::<Tet4>::build_3d(model);
    if p.criterion.is_some() {
        view.push_internal_faces(&model.world, &growth_planes(sc));
    }
    view
}

/// The planes fractures may grow in (`fracture.grow_in`): a point and the unit normal of each
/// disc with `DiscPlanes`, none (anywhere) otherwise.
fn growth_planes(sc: &Scenario) -> Vec<([f64; 3], [f64; 3])> {
    match &sc.fracture {
        Some(f) if f.grow_in == GrowIn::DiscPlanes => f
            .discs
            .iter()
            .map(|d| (d.center, d.unit_normal()))
            .collect(),
        _ => Vec::new(),
    }
}

impl Simulation<Tet4> {
    /// Set up a validated scenario with a 3D mesh; `extra_disable` adds system names to
    /// switch off.
    pub fn new_3d(
        scenario: hydrofrac_core::scenario::ValidScenario,
        extra_disable: &[String],
    ) -> Result<Self, SetupError> {
        let scenario = scenario.into_inner();
        let (model, mesh_info) = build_model_3d(&scenario)?;
        let mut p = RunParams::resolve(&scenario, model.material);
        let mut view = view_3d(&model, &p, &scenario);
        // The quasi-static scheme has no stability bound (and the element eigenvalues cost).
        let (dt_elements, mut dt_crit) = match scenario.time.solid_scheme {
            SolidScheme::Explicit => {
                let elements = elements_critical_step_3d(&view, &p);
                (elements, critical_step_3d(&view, &p, elements))
            }
            SolidScheme::QuasiStatic => (f64::INFINITY, f64::INFINITY),
        };
        if scenario.time.mass_scaling || scenario.time.selective_mass_scaling.is_some() {
            dt_crit = scale_masses_3d(&mut view, &mut p, &scenario.time, dt_crit);
        }
        let mut flow = p.coupled.then(|| {
            let fv = hydrofrac_core::flow::FlowView::build_3d(&model, &p.fluid);
            let mut f = FlowPart::new(fv, &p, Default::default(), true);
            f.coupling = Some(Coupling::build_3d(
                &model,
                &view.joint_entity,
                &f.view,
                &p.fluid,
                p.residual_aperture,
            ));
            f
        });
        let (dt, steps_to_end) =
            crate::setup::time_step(&p.time, &scenario.time, true, dt_crit, flow.as_mut())?;
        let mut disabled = scenario.systems.disable.clone();
        disabled.extend(extra_disable.iter().cloned());
        let schedule = crate::setup::schedule(&disabled, &view, &p, flow.is_some())?;
        let linear = if schedule.is_enabled(SystemId::Solve) {
            let mut l = hydrofrac_systems::linear_static::LinearStatic::build(&view, &p.solid)
                .map_err(|why| SetupError::invalid("boundary", why))?;
            l.tol = scenario.time.newton_tol;
            Some(l)
        } else {
            None
        };
        Ok(Simulation {
            scenario,
            model,
            params: p,
            solid: SolidPart {
                view,
                stats: StepStats::default(),
                dt_crit,
                dt_elements,
                quasi_static: None,
                linear,
            },
            flow,
            fracture: FractureState::default(),
            clock: Clock::start(dt, steps_to_end),
            schedule,
            output: None,
            placed: Vec::new(),
            mesh_info,
            effort: monitor::Effort::default(),
            cells_at_start: 0,
            stop: None,
            interrupted_by: None,
            extra_disable: extra_disable.to_vec(),
            next_checkpoint_time: f64::INFINITY,
            checkpoints: Default::default(),
            seismicity: None,
        })
    }

    /// Run to the end. `progress` is called every 256 steps.
    pub fn run(&mut self, mut progress: impl FnMut(&Self)) -> Result<Finish, RunError> {
        if self.clock.step == 0 && self.schedule.is_enabled(SystemId::Output) {
            self.write(true, true)?;
        }
        while self.clock.finish.is_none() {
            if let Some(sig) = self.stop_signal() {
                self.interrupted_by = Some(sig);
                // The state to resume from, unless the step just taken wrote it.
                if self.params.output.checkpoint_every.is_some()
                    && self.clock.step > 0
                    && self.checkpoints.last_step != Some(self.clock.step)
                {
                    self.write_checkpoint()?;
                }
                self.clock.finish = Some(Finish::Interrupted);
                if self.schedule.is_enabled(SystemId::Output) {
                    self.write(true, true)?;
                }
                break;
            }
            self.step_once()?;
            if self.clock.finish.is_none() && self.checkpoint_due() {
                self.write_checkpoint()?;
            }
            if self.clock.step.is_multiple_of(256) {
                progress(self);
            }
        }
        self.sync();
        Ok(self.clock.finish.expect("loop ends with a finish"))
    }

    /// One step: every enabled system of the schedule in order, each in its span.
    pub fn step_once(&mut self) -> Result<(), RunError> {
        let t0 = self.clock.time;
        self.clock.load_factor =
            schedule_factor(&self.params.boundary_schedule, t0 + self.clock.dt);
        for k in 0..self.schedule.entries.len() {
            let (sys, status) = self.schedule.entries[k];
            if status != Status::Enabled {
                continue;
            }
            let _span = sys.span().entered();
            let (p, v, clock) = (&self.params, &mut self.solid.view, &mut self.clock);
            match sys {
                SystemId::InternalForce => solid::internal_force(v, &p.solid),
                SystemId::ExternalLoad => solid::external_load(v, clock.load_factor),
                SystemId::Damping => solid::damping(v, &p.solid, clock.dt),
                SystemId::Integrate => {
                    self.solid.stats = solid::integrate(v, clock.dt, clock.load_factor)
                }
                SystemId::Solve => {
                    if let Some(l) = self.solid.linear.as_mut() {
                        // The joints' forces from the step's start state at every residual.
                        let start = v.joint_state.clone();
                        let contact = self.schedule.is_enabled(SystemId::Contact);
                        self.solid.stats = l
                            .solve_with(
                                v,
                                &p.solid,
                                clock.load_factor,
                                |v| {
                                    if contact {
                                        v.joint_state.copy_from_slice(&start);
                                        fracture::contact_3d(v, &p.joint);
                                    }
                                },
                                |v, k| fracture::contact_tangent_3d(v, k, &p.joint),
                            )
                            .map_err(|why| RunError::QuasiStatic {
                                step: clock.step + 1,
                                time: t0,
                                why,
                            })?;
                    }
                }
                // Under the quasi-static scheme the solve runs the joints' contact itself.
                SystemId::Contact if self.solid.linear.is_none() => {
                    fracture::contact_3d(v, &p.joint)
                }
                SystemId::Contact => {}
                SystemId::FluidPressure => {
                    if let Some(c) = self.flow.as_ref().and_then(|f| f.coupling.as_ref()) {
                        fracture::fluid_pressure_3d(v, &c.joint_cell, &c.p_mean);
                    }
                }
                SystemId::FlowSubsteps => {
                    if let Some(f) = self.flow.as_mut() {
                        let opening = |k| hydrofrac_core::model3::joint_frame_3d(v, k).dn;
                        flow::flow_substeps(f, opening, p, t0, clock.dt, clock.step + 1)?;
                    }
                }
                SystemId::Monitor => {
                    monitor::monitor(clock, t0, &self.solid, self.flow.as_ref(), p)?
                }
                SystemId::Output => {
                    let every = p.output.frame_every;
                    let finished = clock.finish.is_some();
                    let frame = finished || (every > 0 && clock.step.is_multiple_of(every));
                    let row = finished || clock.step.is_multiple_of(p.output.series_every);
                    if frame || row {
                        self.write(frame, row)?;
                    }
                }
                SystemId::FractureCriterion => match p.criterion.map(|c| c.kind) {
                    // On the fronts, in the discs' planes (`Scenario::check_3d`).
                    Some(Criterion::Toughness { k_ic, .. }) => {
                        self.fracture.ready_edges =
                            hydrofrac_systems::toughness3d::toughness_criterion_3d(
                                v, p.e_prime, k_ic,
                            );
                    }
                    Some(Criterion::Strength { threshold, .. }) => {
                        self.fracture.ready_edges = fracture::fracture_criterion_3d(v, threshold);
                    }
                    None => {}
                },
                SystemId::Split => {
                    let t1 = monitor::step_end(t0, clock);
                    self.split_3d(t1);
                }
                // Not in a 3D scene's schedule (no data): `Scenario::check_3d`.
                SystemId::Seismicity => {}
            }
        }
        Ok(())
    }

    /// A frame and/or a series row of the current state.
    fn write(&mut self, frame: bool, row: bool) -> Result<(), RunError> {
        let Some(out) = self.output.as_mut() else {
            return Ok(());
        };
        if row {
            let mut values = vec![self.clock.step as f64, self.clock.time];
            values.extend(output::solid_values(&self.solid.stats));
            if let Some(f) = &self.flow {
                values.extend(output::flow_values(f, &self.params));
            }
            out.write_series(&values)?;
        }
        if frame {
            out.write_frame_3d(&self.solid.view, &self.params.solid, self.clock.time)?;
            let v = &self.solid.view;
            if !v.joint_nodes.is_empty() {
                // Per joint: its cell's pressure and hydraulic aperture, or the prescribed
                // pressure (no aperture column without flow).
                let fluid = self
                    .flow
                    .as_ref()
                    .and_then(|f| Some((f, f.coupling.as_ref()?)));
                let (pressure, aperture): (Vec<f64>, Vec<f64>) = match fluid {
                    Some((f, c)) => c
                        .joint_cell
                        .iter()
                        .map(|&k| match k {
                            u32::MAX => (0.0, 0.0),
                            k => (f.view.pressure[k as usize], f.view.aperture[k as usize]),
                        })
                        .unzip(),
                    None => {
                        let p = self.scenario.fracture.as_ref().and_then(|f| f.pressure);
                        (vec![p.unwrap_or(0.0); v.joint_nodes.len()], Vec::new())
                    }
                };
                out.write_fracture_3d(v, &pressure, &aperture, self.clock.time)?;
            }
        }
        Ok(())
    }

    /// The state between steps as a checkpoint ([`crate::checkpoint`]): the world's 3D
    /// entities, the clock and the TET4 view (the 2D-only parts empty). Nothing is synced.
    pub fn checkpoint_state(
        &self,
    ) -> Result<(crate::checkpoint::Header, crate::checkpoint::State<Tet4>), String> {
        let m = &self.model;
        let header = crate::checkpoint::Header {
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            dimension: 3,
            scenario_name: self.scenario.name.clone(),
            fingerprint: crate::checkpoint::fingerprint(&self.scenario, &self.extra_disable),
            step: self.clock.step,
            time: self.clock.time,
        };
        let state = crate::checkpoint::State {
            world: crate::checkpoint::WorldRecords::capture(m)?,
            topology_generation: m.topology_generation,
            next_ids: crate::checkpoint::next_ids(m),
            clock: self.clock.clone(),
            solid_view: self.solid.view.clone(),
            solid_stats: self.solid.stats,
            dt_crit: self.solid.dt_crit,
            qs_counts: None,
            flow: self.flow.clone(),
            fracture: self.fracture.clone(),
            effort: self.effort,
            cells_at_start: 0,
            next_checkpoint_time: self.next_checkpoint_time,
            seismicity: None,
        };
        Ok((header, state))
    }

    /// Continue from a 3D checkpoint's state: this simulation must be freshly set up from the
    /// scenario it was written for ([`crate::checkpoint::check_scenario`]). The explicit scheme
    /// continues bit for bit; the quasi-static solve factorises its matrix again for the joints'
    /// states, so it continues to its tolerance.
    pub fn restore(&mut self, state: crate::checkpoint::State<Tet4>) -> Result<(), String> {
        // A growing fracture adds nodes, joints and cells; the tetrahedra stay.
        let growing = self.params.criterion.is_some();
        if state.solid_view.n_elems() != self.solid.view.n_elems()
            || (!growing
                && (state.solid_view.n_nodes() != self.solid.view.n_nodes()
                    || state.solid_view.joint_nodes != self.solid.view.joint_nodes))
        {
            return Err("its mesh or fractures differ from this scenario's".into());
        }
        crate::checkpoint::take_world(
            &mut self.model,
            state.world,
            state.topology_generation,
            state.next_ids,
        )?;
        let cells = |f: Option<&FlowPart>| f.map(|f| (!growing).then(|| f.view.n_cells()));
        if cells(state.flow.as_ref()) != cells(self.flow.as_ref()) {
            return Err("its fracture flow cells differ from this scenario's".into());
        }
        self.clock = state.clock;
        self.solid.view = state.solid_view;
        self.flow = state.flow;
        self.solid.stats = state.solid_stats;
        self.solid.dt_crit = state.dt_crit;
        self.effort = state.effort;
        self.next_checkpoint_time = state.next_checkpoint_time;
        self.fracture = state.fracture;
        let has_load = self.solid.view.has_load();
        self.schedule.set_data(SystemId::ExternalLoad, has_load);
        Ok(())
    }

    /// Write a checkpoint of the state now into the output folder, as 2D runs do
    /// (`Simulation::write_checkpoint`).
    pub fn write_checkpoint(&mut self) -> Result<Option<std::path::PathBuf>, RunError> {
        if self.output.is_none() {
            return Ok(None);
        }
        let t = std::time::Instant::now();
        let io = |e: String| RunError::Io(std::io::Error::other(format!("checkpoint: {e}")));
        let (header, state) = self.checkpoint_state().map_err(io)?;
        let bytes = crate::checkpoint::encode(&header, &state).map_err(io)?;
        self.write_checkpoint_bytes(&bytes, t)
    }

    /// The quasi-static scheme's factorised stiffness (`time.solid_scheme: QuasiStatic`).
    pub fn linear_static(&self) -> Option<&hydrofrac_systems::linear_static::LinearStatic> {
        self.solid.linear.as_ref()
    }

    /// The time-series columns of the 3D scene.
    pub fn series_columns_3d(&self) -> Vec<String> {
        let mut c: Vec<String> = vec!["step".into(), "time".into()];
        c.extend(output::SOLID_COLUMNS.iter().map(|s| s.to_string()));
        if let Some(f) = &self.flow {
            c.extend(output::flow_columns(f, &self.params));
        }
        c
    }

    /// `split` in 3D at time `t1` (the step's end): the faces the criterion marked open by node
    /// splitting ([`hydrofrac_core::split3::open_faces`]); the state is synced into the
    /// components first and the views are rebuilt after, with the critical step of the new
    /// topology (the step shortened when it needs to be, as in 2D). A prescribed face pressure
    /// (`fracture.pressure`) acts on the new faces too.
    fn split_3d(&mut self, t1: f64) {
        let v = &self.solid.view;
        let ready: Vec<hecs::Entity> = (0..v.edge_entity.len())
            .filter(|&k| v.edge_ready[k])
            .map(|k| v.edge_entity[k])
            .collect();
        let key = (ready.len(), self.model.topology_generation);
        if ready.is_empty() || self.fracture.last_idle_split == Some(key) {
            return;
        }
        {
            use hydrofrac_core::view::ModelView;
            Tet4::write_back(&self.solid.view, &mut self.model, &self.params.solid);
        }
        if let Some(f) = &self.flow {
            f.view.write_back(&mut self.model, &self.params.fluid);
        }
        // A prescribed face pressure: its loads before the split, which `open_faces` shares
        // among a split node's daughters by volume (not where a pressure acts); they are taken
        // off again after a split and the pressure put on every face as it is then.
        let pressure = self
            .params
            .face_pressure
            .map(|fp| (fp, self.model.face_pressure_loads3(fp)));
        let r = hydrofrac_core::split3::open_faces(
            &mut self.model,
            &ready,
            self.params.residual_aperture,
            t1,
        );
        self.fracture.splits += r.split_nodes;
        self.fracture.opened_edges += r.opened_edges;
        if r.split_nodes == 0 {
            // Nothing changed (the ready faces wait for the fracture to reach them): not
            // tried again until the marks change.
            self.fracture.last_idle_split = Some(key);
            return;
        }
        if let Some((fp, before)) = pressure {
            let share: std::collections::HashMap<hecs::Entity, &[(hecs::Entity, f64)]> =
                r.daughters_of.iter().map(|(m, ds)| (*m, &ds[..])).collect();
            let mut off: Vec<(hecs::Entity, [f64; 3])> = Vec::with_capacity(before.len());
            for (n, f) in before {
                match share.get(&n) {
                    Some(ds) => off.extend(ds.iter().map(|&(d, s)| (d, f.map(|c| c * s)))),
                    None => off.push((n, f)),
                }
            }
            self.model.add_loads3(&off, -1.0);
            let now = self.model.face_pressure_loads3(fp);
            self.model.add_loads3(&now, 1.0);
        }
        self.rebuild_views_3d(t1);
    }

    /// Rebuild the 3D views from the components after a topology change, the explicit
    /// scheme's critical step with them (the step shortened when the new joints need it,
    /// unless the user forced `time.dt`).
    fn rebuild_views_3d(&mut self, t1: f64) {
        let p = &self.params;
        self.solid.view = view_3d(&self.model, p, &self.scenario);
        let has_load = self.solid.view.has_load();
        self.schedule.set_data(SystemId::ExternalLoad, has_load);
        if let Some(f) = self.flow.as_mut() {
            f.view = hydrofrac_core::flow::FlowView::build_3d(&self.model, &p.fluid);
            f.view.set_bc_kinds(&p.flow_boundaries);
            f.dt_crit = f.view.critical_step(&p.fluid);
            if let Some(c) = f.coupling.as_mut() {
                *c = Coupling::build_3d(
                    &self.model,
                    &self.solid.view.joint_entity,
                    &f.view,
                    &p.fluid,
                    c.a_r,
                );
            }
        }
        if self.solid.linear.is_none() {
            let bound = critical_step_3d(&self.solid.view, p, self.solid.dt_elements);
            self.solid.dt_crit = bound;
            hydrofrac_systems::split::shorten_to(&mut self.clock, p, bound, t1);
        }
    }

    /// Copy the hot state into the ECS components, and bring the view's element stresses to
    /// the current displacements.
    pub fn sync(&mut self) {
        use hydrofrac_core::view::ModelView;
        Tet4::write_back(&self.solid.view, &mut self.model, &self.params.solid);
        solid::update_stress(&mut self.solid.view, &self.params.solid);
    }
}
