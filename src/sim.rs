//! A simulation: the model, its dense views, the schedule, and the step loop.

use crate::error::{RunError, SetupError};
use crate::flow::implicit::{ImplicitError, ImplicitSolver, implicit_step};
use crate::flow::{FlowParams, FlowView};
use crate::mesh::TriMesh;
use crate::model::Model;
use crate::network::CellNetwork;
use crate::output::Outputs;
use crate::scenario::{Damping, End, FlowScheme, Material, MeshSpec, Scenario};
use crate::schedule::{Schedule, Status};
use crate::systems::SystemId;
use crate::systems::flow::{self as flowsys, FlowStats};
use crate::systems::fracture::{self, JointParams};
use crate::systems::solid::{self, SolidParams, StepStats};
use crate::view::SolidView;

/// A speed above this fraction of the P-wave speed implies strains of order 100 %: far outside
/// small-strain elasticity, so the run is treated as blown up.
pub const SPEED_LIMIT_FRACTION: f64 = 1.0;

/// Flow sub-steps per step in flow-only scenes: the schedule, spans and monitoring run once per
/// step, so a step of several flow sub-steps keeps their cost small against the flow kernel.
pub const FLOW_ONLY_SUBSTEPS: u64 = 32;

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Finish {
    /// Reached the end time.
    EndTime,
    /// Static (or steady) residual below tolerance.
    Converged,
    /// Hit `time.max_steps` first.
    MaxSteps,
}

/// The fracture-network flow part of a simulation.
pub struct FlowPart {
    pub view: FlowView,
    pub params: FlowParams,
    /// Flow sub-step, s, and sub-steps per step.
    pub dt: f64,
    pub substeps: u64,
    /// Explicit critical flow step, s.
    pub dt_crit: f64,
    pub stats: FlowStats,
    /// Fluid excess mass (above rho_r V) summed at the start, kg/m.
    pub initial_excess: f64,
    /// Steady residual ||net inflow per cell|| / sum |boundary rates|.
    pub residual: f64,
    /// Network volume sum a L at the start, m^2 (volumes change in coupled runs).
    pub initial_volume: f64,
    /// The fractures the network was cut from (written to the output; empty in coupled runs).
    pub network: CellNetwork,
    /// Coupled runs (the network is the rock's fractures): maps and exchange state.
    pub coupling: Option<crate::coupling::Coupling>,
    /// Coupled runs: a sub-step count above `time.max_substeps` the last step needed.
    pub too_many: Option<crate::coupling::TooManySubsteps>,
    /// `time.flow_scheme: Implicit`: the backward-Euler solver (one flow step per step).
    pub implicit: Option<ImplicitSolver>,
    /// A failed implicit step, reported by `monitor`.
    pub implicit_error: Option<ImplicitError>,
}

impl FlowPart {
    /// The flow part over the model's cells (a rigid network, or the rock's fractures when
    /// `coupled`): boundaries attached, the view built, the initial state recorded.
    fn new(
        model: &mut Model,
        scenario: &Scenario,
        params: FlowParams,
        network: CellNetwork,
        coupled: bool,
    ) -> Result<Self, SetupError> {
        model.add_flow_boundaries(&scenario.flow_boundaries)?;
        let mut view = FlowView::build(model, &params);
        view.set_bc_kinds(&scenario.flow_boundaries);
        Ok(FlowPart {
            dt_crit: view.critical_step(&params),
            initial_excess: view.excess.iter().sum(),
            initial_volume: view.volume.iter().sum(),
            view,
            params,
            dt: 0.0,
            substeps: 1,
            stats: FlowStats::default(),
            residual: f64::INFINITY,
            network,
            coupling: coupled.then(crate::coupling::Coupling::default),
            too_many: None,
            implicit: (scenario.time.flow_scheme == FlowScheme::Implicit).then(ImplicitSolver::new),
            implicit_error: None,
        })
    }
}

pub struct Simulation {
    pub scenario: Scenario,
    pub model: Model,
    pub view: SolidView,
    pub params: SolidParams,
    pub flow: Option<FlowPart>,
    pub schedule: Schedule,
    /// Critical solid step min altitude / c_p, s (infinite without a solid).
    pub dt_crit: f64,
    /// P-wave speed, m/s.
    pub c_p: f64,
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Statistics of the last solid step.
    pub stats: StepStats,
    /// Static residual after the last step (solid and flow, the larger).
    pub residual: f64,
    pub finish: Option<Finish>,
    pub output: Option<Outputs>,
    /// Internal edges marked fracture-ready so far.
    pub ready_edges: usize,
    /// Nodes split and edges opened by the split system so far.
    pub splits: usize,
    pub opened_edges: usize,
    /// Pre-existing fractures as placed on the mesh.
    pub placed: Vec<crate::fractures::Placed>,
    /// Joint contact constants.
    pub joint: JointParams,
    /// Steps to run for an `End::Time` scenario.
    steps_to_end: Option<u64>,
    /// (ready edges, topology generation) of the last split attempt that split nothing.
    last_idle_split: Option<(usize, u64)>,
}

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

fn solid_params(mat: &Material, dt: f64, damping: Damping) -> SolidParams {
    SolidParams {
        lam2g: mat.lambda() + 2.0 * mat.shear(),
        lam: mat.lambda(),
        g: mat.shear(),
        dt,
        damping,
        load_factor: 1.0,
    }
}

impl Simulation {
    /// Set up a validated scenario; `extra_disable` adds system names to switch off.
    pub fn new(scenario: Scenario, extra_disable: &[String]) -> Result<Self, SetupError> {
        scenario.validate()?;
        let mut placed = Vec::new();
        let mut model = match (&scenario.mesh, &scenario.material) {
            (Some(spec), Some(mat)) => {
                let mesh = build_mesh(spec)?;
                let mut m = Model::from_mesh(&mesh, *mat)?;
                if let Some(f) = &scenario.fracture {
                    placed = crate::fractures::open_preexisting(&mut m, &mesh, f)?;
                }
                m.apply_boundary(&scenario.boundary);
                m.apply_pins(&scenario.pins)?;
                if let (
                    crate::scenario::InitialState::InSitu,
                    crate::scenario::Boundary::InSitu { sxx, syy },
                ) = (scenario.initial_state, &scenario.boundary)
                {
                    m.set_insitu_displacement(*sxx, *syy);
                }
                if let Some(g) = scenario.gravity {
                    let rho = mat.density;
                    m.add_body_force(|_| [rho * g[0], rho * g[1]]);
                }
                if let Some(p) = scenario.fracture.as_ref().and_then(|f| f.pressure) {
                    crate::fractures::apply_face_pressure(&mut m, p);
                }
                m
            }
            _ => Model::empty(),
        };
        let has_solid = scenario.mesh.is_some();
        let mat = model.material;
        let joint = JointParams {
            kn: scenario
                .fracture
                .as_ref()
                .and_then(|f| f.normal_stiffness)
                .unwrap_or(mat.young),
            kt: scenario
                .fracture
                .as_ref()
                .and_then(|f| f.shear_stiffness)
                .unwrap_or(mat.shear()),
            mu: scenario
                .fracture
                .as_ref()
                .map_or(0.0, |f| f.friction_deg.to_radians().tan()),
        };
        let coupled = has_solid && !scenario.flow_boundaries.is_empty();
        let a_r = scenario
            .fracture
            .as_ref()
            .map_or(5e-4, |f| f.residual_aperture);
        let (c_p, dt_crit) = if has_solid {
            let c = model.material.p_wave_speed();
            let dt = model.min_altitude / c;
            let k_fluid = if coupled {
                scenario.fluid.bulk_modulus
            } else {
                0.0
            };
            (
                c,
                crate::coupling::coupled_step_bound(
                    &model,
                    dt,
                    joint.kn.max(joint.kt),
                    k_fluid,
                    a_r,
                ),
            )
        } else {
            (0.0, f64::INFINITY)
        };
        // Flow.
        let flow = match &scenario.network {
            Some(spec) => {
                let fp = FlowParams::from(scenario.fluid);
                let net = spec.discretise();
                model.add_network(&net, scenario.initial_fluid, fp.rho_r, fp.k);
                Some(FlowPart::new(&mut model, &scenario, fp, net, false)?)
            }
            None if coupled => {
                let fp = FlowParams::from(scenario.fluid);
                if let crate::scenario::InitialFluid::Full(p0) = scenario.initial_fluid {
                    crate::fractures::fill_cells(&mut model, fp.rho_r * (1.0 + p0 / fp.k));
                }
                Some(FlowPart::new(
                    &mut model,
                    &scenario,
                    fp,
                    CellNetwork::default(),
                    true,
                )?)
            }
            None => None,
        };
        // Steps: the solid sets the step when there is one; flow sub-steps fill it.
        let t = &scenario.time;
        let flow_auto = flow.as_ref().map(|f| t.safety * f.dt_crit);
        // Implicit flow-only scenes take `time.flow_dt` as their (single) flow step.
        let per_flow_dt = match t.flow_scheme {
            FlowScheme::Explicit => FLOW_ONLY_SUBSTEPS as f64,
            FlowScheme::Implicit => 1.0,
        };
        let mut dt = match (t.dt, has_solid, flow_auto, t.flow_dt) {
            (Some(dt), _, _, _) => dt,
            (None, true, _, _) => t.safety * dt_crit,
            (None, false, _, Some(fdt)) => per_flow_dt * fdt,
            (None, false, Some(fa), None) => FLOW_ONLY_SUBSTEPS as f64 * fa,
            (None, false, None, None) => unreachable!("validated: a mesh or a network"),
        };
        let steps_to_end = match t.end {
            End::Time(te) => {
                let n = (te / dt - 1e-9).ceil().max(1.0);
                dt = te / n;
                Some(n as u64)
            }
            End::Static { .. } | End::SteadyDirect => None,
        };
        if t.dt.is_some() && dt > dt_crit {
            tracing::warn!(
                "time.dt = {dt:.3e} s is above the critical step {dt_crit:.3e} s; expect a blow-up"
            );
        }
        let mut flow = flow;
        if let Some(f) = flow.as_mut() {
            let target = t.flow_dt.unwrap_or(t.safety * f.dt_crit);
            f.substeps = match f.implicit {
                Some(_) => 1,
                None => ((dt / target) * (1.0 - 1e-12)).ceil().max(1.0) as u64,
            };
            f.dt = dt / f.substeps as f64;
        }
        let params = solid_params(&mat, dt, scenario.damping);
        let mut disabled = scenario.systems.disable.clone();
        disabled.extend(extra_disable.iter().cloned());
        let mut view = SolidView::build(&model);
        if scenario.time.mass_scaling {
            solid::scale_masses(&mut view, &params, joint.kn.max(joint.kt), dt_crit);
        }
        let has_load = view.load.iter().any(|l| l[0] != 0.0 || l[1] != 0.0);
        let damping_on = scenario.damping != Damping::None;
        let has_flow = flow.is_some();
        let has_fracture = has_solid
            && scenario
                .fracture
                .as_ref()
                .is_some_and(|f| f.strength.is_some());
        let has_joints = !view.joint_nodes.is_empty();
        if let Some(f) = flow.as_mut()
            && f.coupling.is_some()
        {
            f.coupling = Some(crate::coupling::Coupling::build(
                &model, &view, &f.view, &f.params, a_r,
            ));
        }
        let schedule = Schedule::new(&disabled, |s| match s {
            SystemId::Contact => has_joints,
            SystemId::FluidPressure => coupled,
            SystemId::InternalForce | SystemId::Integrate => has_solid,
            SystemId::ExternalLoad => has_load,
            SystemId::Damping => has_solid && damping_on,
            SystemId::FlowSubsteps => has_flow,
            SystemId::FractureCriterion | SystemId::Split => has_fracture,
            SystemId::Monitor | SystemId::Output => true,
        })?;
        Ok(Simulation {
            scenario,
            model,
            view,
            params,
            flow,
            schedule,
            dt_crit,
            c_p,
            step: 0,
            time: 0.0,
            stats: StepStats::default(),
            residual: f64::INFINITY,
            finish: None,
            output: None,
            ready_edges: 0,
            splits: 0,
            opened_edges: 0,
            placed,
            joint,
            steps_to_end,
            last_idle_split: None,
        })
    }

    /// Copy the hot state into the ECS components.
    pub fn sync(&mut self) {
        solid::update_stress(&mut self.view, &self.params);
        self.view.write_back(&mut self.model);
        if let Some(f) = &self.flow {
            f.view.write_back(&mut self.model, &f.params);
        }
        if !self.view.joint_entity.is_empty() {
            let a_r = self
                .scenario
                .fracture
                .as_ref()
                .map_or(5e-4, |f| f.residual_aperture);
            let coupled = self.flow.as_ref().is_some_and(|f| f.coupling.is_some());
            crate::fractures::sync_fracture_geometry(&mut self.model, (!coupled).then_some(a_r));
        }
    }

    /// The rock's fractures (cells made by splitting) as a network view for output, when the
    /// scene has joints but no flow network of its own.
    pub fn fracture_view(&self) -> Option<FlowView> {
        if self.flow.is_some() || self.view.joint_entity.is_empty() {
            return None;
        }
        let mut v = FlowView::build(&self.model, &FlowParams::from(self.scenario.fluid));
        v.attach_joints(&self.model);
        Some(v)
    }

    /// Change the model (boundary conditions, loads, topology) between steps: the state is
    /// synced first and the views are rebuilt if the topology generation moved.
    pub fn edit_model(&mut self, f: impl FnOnce(&mut Model)) {
        self.sync();
        f(&mut self.model);
        self.rebuild_views_if_needed();
    }

    fn rebuild_views_if_needed(&mut self) {
        if self.view.generation != self.model.topology_generation {
            self.view = SolidView::build(&self.model);
            if self.scenario.time.mass_scaling {
                let k = self.joint.kn.max(self.joint.kt);
                solid::scale_masses(&mut self.view, &self.params, k, self.dt_crit);
            }
            let has_load = self.view.load.iter().any(|l| l[0] != 0.0 || l[1] != 0.0);
            for (s, st) in &mut self.schedule.entries {
                if *s == SystemId::ExternalLoad && *st != Status::DisabledByUser {
                    *st = if has_load {
                        Status::Enabled
                    } else {
                        Status::NoData
                    };
                }
            }
        }
        if let Some(f) = self.flow.as_mut()
            && f.view.generation != self.model.topology_generation
        {
            f.view = FlowView::build(&self.model, &f.params);
            f.view.set_bc_kinds(&self.scenario.flow_boundaries);
            f.dt_crit = f.view.critical_step(&f.params);
            if let Some(c) = f.coupling.as_mut() {
                *c = crate::coupling::Coupling::build(
                    &self.model,
                    &self.view,
                    &f.view,
                    &f.params,
                    c.a_r,
                );
            }
        }
    }

    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.params.dt
    }

    /// One step: every enabled system in order, each in its span.
    pub fn step_once(&mut self) -> Result<(), RunError> {
        self.rebuild_views_if_needed();
        let t0 = self.time;
        self.params.load_factor =
            crate::scenario::schedule_factor(&self.scenario.boundary_schedule, t0 + self.params.dt);
        // By index, not through an iterator over the schedule: the systems borrow `self`
        // mutably, and a collected list would allocate every step.
        for k in 0..self.schedule.entries.len() {
            let (sys, status) = self.schedule.entries[k];
            if status != Status::Enabled {
                continue;
            }
            let _span = sys.span().entered();
            match sys {
                SystemId::InternalForce => solid::internal_force(&mut self.view, &self.params),
                SystemId::ExternalLoad => solid::external_load(&mut self.view, &self.params),
                SystemId::Contact => fracture::contact(&mut self.view, &self.joint),
                SystemId::FluidPressure => {
                    if let Some(c) = self.flow.as_ref().and_then(|f| f.coupling.as_ref()) {
                        fracture::fluid_pressure(&mut self.view, &c.joint_cell, &c.p_mean);
                    }
                }
                SystemId::Damping => solid::damping(&mut self.view, &self.params),
                SystemId::Integrate => self.stats = solid::integrate(&mut self.view, &self.params),
                SystemId::FlowSubsteps => self.flow_substeps(t0),
                SystemId::Split => self.split_ready(t0 + self.params.dt),
                SystemId::FractureCriterion => {
                    let strength = self
                        .scenario
                        .fracture
                        .as_ref()
                        .and_then(|f| f.strength)
                        .unwrap_or(f64::INFINITY);
                    let by_elements =
                        self.scenario.fracture.as_ref().is_some_and(|f| {
                            f.face_stress == crate::scenario::FaceStress::Elements
                        });
                    self.ready_edges =
                        fracture::fracture_criterion(&mut self.view, strength, by_elements);
                }
                SystemId::Monitor => {
                    self.step += 1;
                    self.time = t0 + self.params.dt;
                    self.monitor()?;
                }
                SystemId::Output => {
                    let frame = self.frame_due();
                    let row = self.series_due();
                    if frame || row {
                        self.write_outputs(frame, row)?;
                    }
                    let t1 = self.time;
                    if let Some(&tf) = self
                        .scenario
                        .output
                        .figure_times
                        .iter()
                        .find(|&&tf| tf > t0 && tf <= t1)
                    {
                        self.fracture_pressure_figure(&format!("fractures_pressure_t{tf}s.png"));
                    }
                }
            }
        }
        Ok(())
    }

    /// `split`: open the fracture-ready edges by node splitting (all in one batch), then rebuild
    /// the views and, because joints add contact stiffness, shorten the step if the new bound
    /// requires it.
    fn split_ready(&mut self, t: f64) {
        let ready: Vec<hecs::Entity> = (0..self.view.edge_entity.len())
            .filter(|&k| self.view.edge_ready[k])
            .map(|k| self.view.edge_entity[k])
            .collect();
        // A ready edge with both ends interior waits for the fracture to reach it: retry only
        // when the ready set or the topology changed since the last attempt that split nothing.
        let key = (ready.len(), self.model.topology_generation);
        if ready.is_empty() || self.last_idle_split == Some(key) {
            return;
        }
        let aperture = self
            .scenario
            .fracture
            .as_ref()
            .map_or(5e-4, |f| f.residual_aperture);
        self.sync();
        let r = crate::split::open_edges(&mut self.model, &ready, aperture, t);
        self.splits += r.split_nodes;
        self.opened_edges += r.opened_edges;
        if r.split_nodes == 0 {
            self.last_idle_split = Some(key);
            return;
        }
        self.rebuild_views_if_needed();
        let base = self.model.min_altitude / self.c_p;
        let coupled = self.flow.as_ref().is_some_and(|f| f.coupling.is_some());
        let k_fluid = if coupled {
            self.scenario.fluid.bulk_modulus
        } else {
            0.0
        };
        let bound = crate::coupling::coupled_step_bound(
            &self.model,
            base,
            self.joint.kn.max(self.joint.kt),
            k_fluid,
            aperture,
        );
        self.dt_crit = bound;
        let safe = self.scenario.time.safety * bound;
        if self.scenario.time.dt.is_none() && safe < self.params.dt {
            self.params.dt = safe;
            if let End::Time(te) = self.scenario.time.end {
                let left = ((te - t) / safe - 1e-9).ceil().max(0.0) as u64;
                self.steps_to_end = Some(self.step + 1 + left);
            }
        }
    }

    /// `flow_substeps`: N explicit flow steps covering the solid step, stopping at the first
    /// cell with negative or non-finite mass (reported by `monitor`); with the implicit scheme
    /// one backward-Euler step of the whole step.
    fn flow_substeps(&mut self, t0: f64) {
        let specs = &self.scenario.flow_boundaries;
        let dt = self.params.dt;
        let Some(f) = self.flow.as_mut() else { return };
        if let Some(c) = f.coupling.as_mut() {
            let tc = &self.scenario.time;
            let r = match f.implicit.as_mut() {
                Some(solver) => c
                    .step_implicit(&self.view, &mut f.view, &f.params, specs, t0, dt, solver)
                    .map_err(Some),
                None => c
                    .step(
                        &self.view,
                        &mut f.view,
                        &f.params,
                        specs,
                        t0,
                        dt,
                        tc.safety,
                        tc.max_substeps,
                    )
                    .map_err(|e| {
                        f.too_many = Some(e);
                        None
                    }),
            };
            match r {
                Ok(r) => {
                    f.stats = r.stats;
                    f.substeps = r.substeps;
                    f.dt = r.dt;
                    f.dt_crit = r.dt_crit;
                    f.too_many = None;
                }
                Err(Some(e)) => f.implicit_error = Some(e),
                Err(None) => {}
            }
        } else {
            if let Some(solver) = f.implicit.as_mut() {
                // One backward-Euler step over the whole step (failures reported by `monitor`).
                f.dt = dt;
                match implicit_step(&mut f.view, &f.params, specs, dt, t0, solver) {
                    Ok(st) => f.stats = st,
                    Err(e) => f.implicit_error = Some(e),
                }
            }
            // Explicit: N sub-steps (none with the implicit scheme).
            let explicit_substeps = if f.implicit.is_some() { 0 } else { f.substeps };
            for k in 0..explicit_substeps {
                f.stats =
                    flowsys::flow_step(&mut f.view, &f.params, specs, f.dt, t0 + k as f64 * f.dt);
                if f.stats.bad_cell.is_some() {
                    break;
                }
            }
        }
        let bc: f64 = f.view.bcs.iter().map(|b| b.rate.abs()).sum();
        let net = f.stats.net2.sqrt();
        f.residual = if bc > 0.0 {
            net / bc
        } else if net == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
    }

    /// `monitor`: stop on non-finite or runaway state, update the residual and the end state.
    fn monitor(&mut self) -> Result<(), RunError> {
        let st = self.stats;
        let blow = |entity: String, quantity: &'static str, value: f64, why: String, dt: f64| {
            RunError::BlowUp {
                step: self.step,
                time: self.time,
                entity,
                quantity,
                value,
                why,
                dt,
            }
        };
        let node = |i: usize| {
            let x = self.view.x0[i];
            format!(
                "node {} at ({:.4}, {:.4}) m",
                self.view.node_id[i], x[0], x[1]
            )
        };
        if let Some(i) = st.non_finite {
            let v = self.view.v[i];
            let value = if v[0].is_finite() { v[1] } else { v[0] };
            return Err(blow(
                node(i),
                "velocity",
                value,
                "a non-finite value".into(),
                self.params.dt,
            ));
        }
        let limit = SPEED_LIMIT_FRACTION * self.c_p;
        if self.view.n_nodes() > 0 && st.vmax > limit {
            return Err(blow(
                node(st.vmax_node),
                "speed",
                st.vmax,
                format!(
                    "above {SPEED_LIMIT_FRACTION} c_p = {limit:.4e} m/s (strain of order 100 %: the step \
                     exceeds the stability limit {:.3e} s or the loading is not physical)",
                    self.dt_crit
                ),
                self.params.dt,
            ));
        }
        let mut residual = if self.view.n_nodes() > 0 {
            st.residual()
        } else {
            0.0
        };
        if let Some(f) = &self.flow
            && let Some(e) = f.too_many
        {
            return Err(blow(
                f.view.cell_label(e.cell),
                "flow sub-steps per solid step",
                e.needed as f64,
                format!(
                    "above time.max_substeps = {}: the apertures make the explicit flow step {:.3e} s \
                     against a solid step of {:.3e} s (use time.flow_scheme: Implicit, or raise time.max_substeps)",
                    self.scenario.time.max_substeps, e.dt_crit, self.params.dt
                ),
                self.params.dt,
            ));
        }
        if let Some(source) = self.flow.as_mut().and_then(|f| f.implicit_error.take()) {
            return Err(RunError::ImplicitFlow {
                step: self.step,
                time: self.time,
                source: Box::new(source),
            });
        }
        if let Some(f) = &self.flow {
            // The explicit flow step must respect the stability bound (a forced `time.flow_dt`
            // may not): above it the scheme oscillates, and the P = 0 floor of unfilled cells can
            // hold the oscillation bounded, so it would not show up as a blow-up by itself.
            if f.implicit.is_none()
                && f.dt > f.dt_crit * (1.0 + 1e-9)
                && let Some((c, bound)) = f.view.critical_cell(&f.params)
            {
                return Err(blow(
                    f.view.cell_label(c),
                    "flow step",
                    f.dt,
                    format!(
                        "above the cell's stability bound V/(K sum kappa) = {bound:.4e} s: unstable"
                    ),
                    f.dt,
                ));
            }
            if let Some(c) = f.stats.bad_cell {
                return Err(blow(
                    f.view.cell_label(c),
                    "fluid mass",
                    f.view.excess[c] + f.params.rho_r * f.view.volume[c],
                    match f.implicit {
                        None => format!(
                            "negative or non-finite: the flow step exceeds its stability limit {:.3e} s",
                            f.dt_crit
                        ),
                        Some(_) => {
                            "negative or non-finite: more fluid withdrawn than the cell holds"
                                .into()
                        }
                    },
                    f.dt,
                ));
            }
            residual = residual.max(f.residual);
        }
        self.residual = residual;
        if let End::Static { tol, min_steps } = self.scenario.time.end
            && self.step >= min_steps
            && self.residual < tol
        {
            self.finish = Some(Finish::Converged);
        }
        if let Some(n) = self.steps_to_end
            && self.step >= n
        {
            self.finish = Some(Finish::EndTime);
        }
        if self.finish.is_none() && self.step >= self.scenario.time.max_steps {
            self.finish = Some(Finish::MaxSteps);
        }
        Ok(())
    }

    fn frame_due(&self) -> bool {
        let every = self.scenario.output.frame_every;
        self.finish.is_some() || (every > 0 && self.step.is_multiple_of(every))
    }

    fn series_due(&self) -> bool {
        self.finish.is_some() || self.step.is_multiple_of(self.scenario.output.series_every)
    }

    /// Names of the time-series columns of this scene.
    pub fn series_columns(&self) -> Vec<String> {
        let mut c: Vec<String> = vec!["step".into(), "time".into()];
        if self.view.n_nodes() > 0 {
            for n in ["kinetic_energy", "strain_energy", "residual", "max_speed"] {
                c.push(n.into());
            }
        }
        if self.scenario.fracture.is_some() {
            c.push("fracture_ready_edges".into());
        }
        if let Some(f) = &self.flow {
            for b in &f.view.bcs {
                let name = self.bc_name(b.index);
                c.push(format!("{name}_pressure"));
                c.push(format!("{name}_rate"));
            }
            for n in [
                "injected_volume",
                "produced_volume",
                "stored_volume",
                "mass_balance_error",
                "flow_residual",
            ] {
                c.push(n.into());
            }
        }
        c
    }

    /// Label of flow boundary `index`.
    pub fn bc_name(&self, index: usize) -> String {
        let n = &self.scenario.flow_boundaries[index].name;
        if n.is_empty() {
            format!("bc{index}")
        } else {
            n.clone()
        }
    }

    /// Values of the time-series columns now.
    pub fn series_values(&self) -> Vec<f64> {
        let mut v = vec![self.step as f64, self.time];
        if self.view.n_nodes() > 0 {
            v.extend([
                self.stats.kinetic,
                self.stats.strain,
                self.stats.residual(),
                self.stats.vmax,
            ]);
        }
        if self.scenario.fracture.is_some() {
            v.push(self.ready_edges as f64);
        }
        if let Some(f) = &self.flow {
            for b in &f.view.bcs {
                v.push(b.pressure);
                v.push(b.rate);
            }
            let (inj, prod, stored, err) = self.flow_balance().expect("flow");
            v.extend([inj, prod, stored, err, f.residual]);
        }
        v
    }

    /// Flow volumes (m^2 at reference density): injected, produced, stored change, and the
    /// relative mass-balance error |stored change - (injected - produced)| / max(injected,
    /// produced, |stored change|, network volume). The network volume (sum of a L) is in the
    /// scale because the cell masses carry round-off of eps times the mass they can hold.
    pub fn flow_balance(&self) -> Option<(f64, f64, f64, f64)> {
        let f = self.flow.as_ref()?;
        let inj: f64 = f.view.bcs.iter().map(|b| b.volume_in).sum();
        let prod: f64 = f.view.bcs.iter().map(|b| b.volume_out).sum();
        // Mass = excess + rho_r V: the stored volume is the change of both (volumes change in
        // coupled runs, and cells created by splits arrive empty: e = -rho_r V).
        let stored = (f.view.excess.iter().sum::<f64>() - f.initial_excess) / f.params.rho_r
            + (f.view.volume.iter().sum::<f64>() - f.initial_volume);
        let scale = inj
            .max(prod)
            .max(stored.abs())
            .max(f.view.volume.iter().sum::<f64>());
        let err = if scale > 0.0 {
            (stored - (inj - prod)).abs() / scale
        } else {
            0.0
        };
        Some((inj, prod, stored, err))
    }

    fn write_outputs(&mut self, frame: bool, row: bool) -> Result<(), RunError> {
        if self.output.is_none() {
            return Ok(());
        }
        let values = self.series_values();
        let poisson = self.model.material.poisson;
        let time = self.time;
        let out = self.output.as_mut().expect("checked");
        if row {
            out.write_series(&values)?;
        }
        if frame {
            if self.view.n_elems() > 0 {
                out.write_frame(&self.view, &self.params, poisson, time)?;
            }
            if self.flow.is_some() {
                if !self.view.joint_entity.is_empty() {
                    // Joint stresses and sliding flags for the frame (coupled runs).
                    self.sync();
                    let f = self.flow.as_mut().expect("checked");
                    f.view.attach_joints(&self.model);
                    f.view.refresh_positions(&self.model);
                }
                let (Some(f), Some(out)) = (self.flow.as_ref(), self.output.as_mut()) else {
                    return Ok(());
                };
                out.write_network_frame(&f.view, time)?;
            }
        }
        if frame && self.flow.is_none() && !self.view.joint_entity.is_empty() {
            self.sync();
            if let (Some(v), Some(out)) = (self.fracture_view(), self.output.as_mut()) {
                out.write_network_frame(&v, time)?;
            }
        }
        Ok(())
    }

    /// Coupled runs with an output folder: write the Fig. 7-like figure (mesh, fractures with
    /// apertures magnified 20x, coloured by pressure) as `name` there. A figure that cannot be
    /// drawn is a warning, not a failed run.
    pub fn fracture_pressure_figure(&mut self, name: &str) {
        let coupled = self.flow.as_ref().is_some_and(|f| f.coupling.is_some());
        if !coupled || self.output.is_none() {
            return;
        }
        self.sync();
        let (Some(f), Some(out)) = (self.flow.as_mut(), self.output.as_ref()) else {
            return;
        };
        f.view.refresh_positions(&self.model);
        let title = format!(
            "{}: fluid pressure, apertures x20, t = {:.4} s",
            self.scenario.name, self.time
        );
        if let Err(e) = crate::output::plots::fracture_pressure_figure(
            &out.dir.join(name),
            &title,
            &self.view,
            &f.view,
            20.0,
            None,
        ) {
            tracing::warn!("figure {name} not written: {e}");
        }
    }

    /// Solve the network's steady state directly and store it as the current state (cell
    /// pressures, masses at those pressures, throughputs, boundary pressures and rates).
    pub fn solve_steady_direct(&mut self) -> Result<(), SetupError> {
        let names: Vec<String> = (0..self.scenario.flow_boundaries.len())
            .map(|i| self.bc_name(i))
            .collect();
        let specs = &self.scenario.flow_boundaries;
        let t = self.time;
        let Some(f) = self.flow.as_mut() else {
            return Err(SetupError::invalid(
                "time.end",
                "SteadyDirect needs a network",
            ));
        };
        let mut solver = crate::flow::steady::SteadySolver::new();
        let sol = f
            .view
            .solve_steady(&mut solver, specs, |i| names[i].clone(), t)
            .map_err(|e| SetupError::invalid("flow", e.to_string()))?;
        let v = &mut f.view;
        for c in 0..v.n_cells() {
            v.pressure[c] = sol.pressure[c];
            v.excess[c] = f.params.rho_r * sol.pressure[c] / f.params.k * v.volume[c];
        }
        // Throughput per cell from the pair flows and the boundary flows of the solution.
        for (k, pr) in v.pairs.iter().enumerate() {
            v.pair_q[k] =
                v.kappa[k] * (sol.pressure[pr[0] as usize] - sol.pressure[pr[1] as usize]);
        }
        v.bc_in.iter_mut().for_each(|q| *q = 0.0);
        for (b, &(pb, rate)) in v.bcs.iter_mut().zip(&sol.boundaries) {
            for (k, &c) in b.cells.iter().enumerate() {
                b.q_cells[k] = b.kappa[k] * (pb - sol.pressure[c as usize]);
                v.bc_in[c as usize] += b.q_cells[k];
            }
            b.pressure = pb;
            b.rate = rate;
        }
        for c in 0..v.n_cells() {
            let through: f64 = v.inc[v.inc_ptr[c] as usize..v.inc_ptr[c + 1] as usize]
                .iter()
                .map(|&e| v.pair_q[(e >> 1) as usize].abs())
                .sum();
            v.flow_rate[c] = 0.5 * (through + v.bc_in[c].abs());
        }
        f.residual = sol.residual;
        // No time passes: the solved state is the reference for the mass balance.
        f.initial_excess = v.excess.iter().sum();
        Ok(())
    }

    /// Run to the end. `progress` is called every few hundred steps.
    pub fn run(&mut self, mut progress: impl FnMut(&Simulation)) -> Result<Finish, RunError> {
        self.rebuild_views_if_needed();
        if self.scenario.time.end == End::SteadyDirect {
            self.solve_steady_direct()?;
            self.residual = self.flow.as_ref().map_or(0.0, |f| f.residual);
            self.finish = Some(Finish::Converged);
            if self.output.is_some() {
                self.write_outputs(true, true)?;
            }
            self.sync();
            return Ok(Finish::Converged);
        }
        if self.step == 0 && self.output.is_some() && self.schedule.is_enabled(SystemId::Output) {
            if let Some(f) = self.flow.as_mut() {
                // Pressures and boundary state at t = 0 for the first frame and row.
                f.view.pressure = (0..f.view.n_cells())
                    .map(|c| {
                        crate::flow::pressure_of(f.view.excess[c], f.view.volume[c], &f.params)
                    })
                    .collect();
            }
            self.write_outputs(true, true)?;
        }
        while self.finish.is_none() {
            self.step_once()?;
            if self.step.is_multiple_of(256) {
                progress(self);
            }
        }
        self.sync();
        Ok(self.finish.expect("loop ends with a finish"))
    }

    /// Mean element stress [sxx, syy, sxy] weighted by area, Pa, with the element minimum and maximum.
    pub fn stress_summary(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let mut mean = [0.0; 3];
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        let mut area = 0.0;
        for (s, g) in self.view.stress.iter().zip(&self.view.geom) {
            for k in 0..3 {
                mean[k] += g[0] * s[k];
                min[k] = min[k].min(s[k]);
                max[k] = max[k].max(s[k]);
            }
            area += g[0];
        }
        if area == 0.0 {
            return ([0.0; 3], [0.0; 3], [0.0; 3]);
        }
        (mean.map(|m| m / area), min, max)
    }
}
