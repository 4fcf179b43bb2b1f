//! Scenario files (RON): what a user writes to describe a run, its parsing with precise error
//! positions, `--set PATH=VALUE` overrides, and the validation pass for physical sense.
//!
//! All quantities are SI: lengths m, moduli and stresses Pa (tension positive), density kg/m^3,
//! time s. The model is plane strain per unit thickness.
//!
//! One file per concern, each with its section's types and checks: `mesh`, `material` (the
//! rock, its boundary conditions, pins, damping, gravity), `fracture`, `flow` (the fluid and
//! its boundaries), `time`, `output` (the run name, outputs, systems), `production`, and
//! `parse` (reading RON and `--set`). This file holds the [`Scenario`], the checks that couple
//! sections, and [`Scenario::validate`], the one way to a [`ValidScenario`].

use crate::error::SetupError;
pub use crate::network::{Fracture, NetworkSpec, RandomNetwork};
use serde::{Deserialize, Serialize};

mod flow;
mod fracture;
mod material;
mod mesh;
mod output;
mod parse;
mod production;
mod seismicity;
#[cfg(test)]
mod tests;
mod time;

pub use flow::{
    Filling, FlowBcKind, FlowBoundary, FlowTarget, Fluid, InitialFluid, Transmissibility,
    schedule_factor,
};
pub use fracture::{
    CriterionSpec, DEFAULT_RESIDUAL_APERTURE, Disc, FaceStress, FractureSpec, GrowIn,
    MAX_ROCK_FRACTURES, PreFracture, RockNetwork, read_fracture_csv,
};
pub use material::{
    Boundary, Coords, Damping, Gravity, InitialState, MAX_DENSITY, MAX_YOUNG, Material, Pin, SideBc,
};
pub use mesh::{Axis, GMSH_BYTES_PER_TRIANGLE, MeshCounts, MeshSpec, Refine, Round};
pub use output::{CheckpointEvery, Field, MAX_NAME_LEN, OutputSpec, SystemsSpec, check_run_name};
pub use parse::parse_ron;
pub use production::{ProductionSpec, ProductionStage};
pub use seismicity::{DEFAULT_V_START, SeismicitySpec, SlipWeakening};
pub use time::{
    DEFAULT_NEWTON_EASY, DEFAULT_NEWTON_TOL, End, FlowScheme, Inertia, LinearSolver, SolidScheme,
    TimeControl,
};

/// A whole scenario. See `scenarios/*.ron` and the README's scenario reference.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name used for the default output folder and in `summary.json`.
    pub name: String,
    /// Free text shown nowhere but kept with the scenario.
    #[serde(default)]
    pub description: String,
    /// The solid mesh (absent in flow-only scenes).
    #[serde(default)]
    pub mesh: Option<MeshSpec>,
    /// The rock (required with a mesh).
    #[serde(default)]
    pub material: Option<Material>,
    #[serde(default)]
    pub boundary: Boundary,
    /// The solid's state at t = 0: at rest and undeformed (default), or `InSitu`: every node at
    /// the homogeneous displacement of the `boundary: InSitu` stress, so the unfractured rock
    /// starts in equilibrium instead of relaxing into it.
    #[serde(default)]
    pub initial_state: InitialState,
    /// Fracturing of the rock (the criterion, pre-existing fractures and node splitting).
    #[serde(default)]
    pub fracture: Option<FractureSpec>,
    /// A rigid fracture network (flow-only scenes).
    #[serde(default)]
    pub network: Option<NetworkSpec>,
    /// The fluid in the fractures (default: water at 25 C).
    #[serde(default)]
    pub fluid: Fluid,
    /// Initial state of the fluid in the cells.
    #[serde(default)]
    pub initial_fluid: InitialFluid,
    /// Flow boundary conditions (pump, rate, pressure) at network nodes or cells.
    #[serde(default)]
    pub flow_boundaries: Vec<FlowBoundary>,
    /// Gravity, m/s^2: a body force rho g on the rock; (0.0, -9.81) in 2D (y up),
    /// (0.0, 0.0, -9.81) in 3D (z up).
    #[serde(default)]
    pub gravity: Option<Gravity>,
    /// Piecewise-linear multiplier of every boundary load and prescribed displacement against
    /// time, [(t s, factor)], constant beyond the ends (a slow ramp from 0 gives quasi-static
    /// loading). Empty: 1.
    #[serde(default)]
    pub boundary_schedule: Vec<(f64, f64)>,
    /// Single nodes with prescribed displacement components (e.g. to remove rigid-body motion
    /// under pure traction loading).
    #[serde(default)]
    pub pins: Vec<Pin>,
    pub time: TimeControl,
    #[serde(default)]
    pub damping: Damping,
    #[serde(default)]
    pub systems: SystemsSpec,
    #[serde(default)]
    pub output: OutputSpec,
    /// Production before and after the run (`hydrofrac run` solves it after the run ends): the
    /// coupled hydro-mechanical steady state between two pressure wells on the network at setup
    /// and at the end (`src/production.rs`, `docs/production.md`). Needs a rock with
    /// fractures and flow boundaries (a coupled run).
    #[serde(default)]
    pub production: Option<ProductionStage>,
    /// The event catalogue of joint slip (`docs/seismicity.md`): needs a rock with fractures.
    #[serde(default)]
    pub seismicity: Option<SeismicitySpec>,
}

/// A scenario that passed [`Scenario::validate`], the only way to make one: what takes a
/// `ValidScenario` (`Simulation::new`, `driver::run_scenario`, [`crate::resources::check`])
/// does not check again. It reads as a [`Scenario`] (`Deref`); to change it, take it apart
/// with [`ValidScenario::into_inner`], edit, and validate again.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidScenario(Scenario);

impl ValidScenario {
    /// The scenario, to edit (and validate again before it runs).
    pub fn into_inner(self) -> Scenario {
        self.0
    }
}

impl std::ops::Deref for ValidScenario {
    type Target = Scenario;
    fn deref(&self) -> &Scenario {
        &self.0
    }
}

/// Largest Poisson's ratio of a coupled run (a mesh with flow boundaries acting on its
/// fractures). The seed's fluid volume of a cell, L max(delta_n, a_r) (m^2 per m, seed (12)),
/// does not follow a closed joint's opening (delta_n < a_r), so the faces of a filled closed
/// joint move under the pressure with no change of fluid volume; in rock held at its sides that
/// free opening Delta A (m^2) compresses the rock, whose mean stress, and the fluid pressure
/// with it, rises by about M Delta A / A, M = E / (2 (1 + nu) (1 - 2 nu)) the plane-strain area
/// modulus (Pa): 8.5 E at nu = 0.48, 16.8 E at 0.49, 167 E at 0.499. Measured on the
/// `verify extreme` coupled block (20 m, pump p_max = 18 MPa, to 0.06 s): the largest fracture
/// pressure over the run stays within p_max + 5 % + 0.1 MPa (19.0 MPa) up to nu = 0.48 with
/// both solid schemes (17.7 MPa explicit, 17.9 MPa quasi-static; also at E = 30 GPa and a
/// joint normal stiffness of 5 GPa/m: 17.8 and 18.4 MPa) and leaves it from 0.485 (19.4 MPa at
/// E = 30 GPa, 20.2 MPa at 5 GPa/m), 0.49 (19.4 MPa) to 0.499 (34.9 MPa explicit, 29.1 MPa
/// quasi-static at the end). README "Reliability".
pub const MAX_COUPLED_POISSON: f64 = 0.48;

impl Scenario {
    /// Check physical sense, section by section, with the checks that couple sections where
    /// their fields are first complete; the first problem is reported with the field and the
    /// reason (the order decides which, and is kept: tests/bad_inputs.rs).
    pub fn validate(self) -> Result<ValidScenario, SetupError> {
        check_run_name(&self.name)?;
        if let Some(mesh) = &self.mesh {
            mesh.validate()?;
        }
        self.check_parts()?;
        if let Some(m) = &self.material {
            m.validate()?;
            self.check_coupled_poisson(m)?;
        }
        self.boundary.validate()?;
        for (i, pin) in self.pins.iter().enumerate() {
            pin.validate(&format!("pins[{i}]"))?;
        }
        self.time
            .validate(self.mesh.is_some(), self.network.is_some())?;
        self.check_steady_direct()?;
        self.damping.validate()?;
        material::validate_gravity(self.gravity)?;
        flow::validate_schedule("boundary_schedule", &self.boundary_schedule)?;
        if let Some(f) = &self.fracture {
            f.validate()?;
            self.check_fracture_has_mesh()?;
        }
        self.check_conforming_size()?;
        if let Some(n) = &self.network {
            n.validate()?;
        }
        self.fluid.validate()?;
        self.initial_fluid.validate()?;
        self.check_flow_has_fractures()?;
        if let Some(prod) = &self.production {
            prod.validate()?;
            self.check_production_is_coupled()?;
        }
        self.check_network_without_mesh()?;
        self.check_seismicity()?;
        self.check_initial_state()?;
        self.check_3d()?;
        self.time.validate_max_substeps()?;
        flow::validate_flow_boundaries(&self.flow_boundaries)?;
        self.output.validate()?;
        Ok(ValidScenario(self))
    }

    /// The counts of the scenario's mesh ([`MeshSpec::counts_around`] its pre-existing
    /// fractures: a conforming mesh is fine only near them); `None` without a mesh or for a
    /// Gmsh file that cannot be read. Fractures that cannot be read count as none (setup
    /// reports them).
    pub fn mesh_counts(&self) -> Option<MeshCounts> {
        let mesh = self.mesh.as_ref()?;
        if !matches!(mesh, MeshSpec::Conforming { .. }) {
            return mesh.counts();
        }
        let segments: Vec<([f64; 2], [f64; 2])> = self
            .fracture
            .as_ref()
            .and_then(|f| f.all_preexisting().ok())
            .unwrap_or_default()
            .iter()
            .map(|(p, _)| (p.from, p.to))
            .collect();
        Some(mesh.counts_around(&segments))
    }

    /// A conforming mesh's triangles around its fractures within the engine's limit.
    fn check_conforming_size(&self) -> Result<(), SetupError> {
        if !matches!(self.mesh, Some(MeshSpec::Conforming { .. })) {
            return Ok(());
        }
        let cells = self.mesh_counts().map_or(0.0, |c| c.triangles);
        if cells > mesh::MAX_TRIANGLES {
            return Err(SetupError::invalid(
                "mesh.h",
                format!(
                    "{cells:.3e} triangles around the fractures is more than this engine's \
                     5e7 limit"
                ),
            ));
        }
        Ok(())
    }

    /// A mesh comes with a material, and a scene has a mesh or a network.
    fn check_parts(&self) -> Result<(), SetupError> {
        if self.mesh.is_some() && self.material.is_none() {
            return Err(SetupError::invalid(
                "material",
                "a scene with a mesh needs a material",
            ));
        }
        if self.mesh.is_none() && self.network.is_none() {
            return Err(SetupError::invalid(
                "mesh",
                "a scene needs a mesh, a network, or both",
            ));
        }
        Ok(())
    }

    /// A coupled run (a mesh with flow boundaries) takes Poisson's ratio up to
    /// [`MAX_COUPLED_POISSON`] only.
    fn check_coupled_poisson(&self, m: &Material) -> Result<(), SetupError> {
        if self.mesh.is_some()
            && !self.flow_boundaries.is_empty()
            && m.poisson > MAX_COUPLED_POISSON
        {
            let nu = m.poisson;
            let area_modulus = m.young / (2.0 * (1.0 + nu) * (1.0 - 2.0 * nu));
            return Err(SetupError::invalid(
                "material.poisson",
                format!(
                    "{nu} is above {MAX_COUPLED_POISSON} for a coupled run (flow boundaries \
                     on the rock's fractures): the seed's fluid volume L max(delta_n, a_r) \
                     does not follow a closed joint's opening, and in nearly incompressible \
                     rock (area modulus E / (2 (1 + nu)(1 - 2 nu)) = {area_modulus:.2e} Pa, \
                     {:.0} E) that free opening compresses the rock and drives the fracture \
                     pressure past the pump's p_max (measured: 1.08 x p_max at nu 0.49, 1.9 x \
                     at 0.499; docs/reliability.md); use material.poisson <= \
                     {MAX_COUPLED_POISSON} (runs without flow take up to 0.5)",
                    area_modulus / m.young
                ),
            ));
        }
        Ok(())
    }

    /// `end: SteadyDirect` solves a rigid network (no mesh) with pressure and rate boundaries.
    fn check_steady_direct(&self) -> Result<(), SetupError> {
        if !matches!(self.time.end, End::SteadyDirect) {
            return Ok(());
        }
        if self.mesh.is_some() || self.network.is_none() {
            return Err(SetupError::invalid(
                "time.end",
                "SteadyDirect solves a rigid network: it needs a network and no mesh",
            ));
        }
        if let Some(i) = self
            .flow_boundaries
            .iter()
            .position(|b| matches!(b.kind, FlowBcKind::Pump { .. }))
        {
            return Err(SetupError::invalid(
                &format!("flow_boundaries[{i}].kind"),
                "SteadyDirect takes pressure and rate boundaries, not a pump",
            ));
        }
        Ok(())
    }

    /// Fracturing needs a solid mesh.
    fn check_fracture_has_mesh(&self) -> Result<(), SetupError> {
        if self.mesh.is_none() {
            return Err(SetupError::invalid(
                "fracture",
                "the fracture criterion needs a solid mesh",
            ));
        }
        Ok(())
    }

    /// Whether the rock has pre-existing fractures (listed, from a file or random) for the
    /// fluid: a coupled run.
    fn has_rock_fractures(&self) -> bool {
        self.mesh.is_some()
            && self.fracture.as_ref().is_some_and(|f| {
                !f.preexisting.is_empty()
                    || f.random.is_some()
                    || f.file.is_some()
                    || !f.discs.is_empty()
            })
    }

    /// Flow boundaries act on a network or on the rock's pre-existing fractures.
    fn check_flow_has_fractures(&self) -> Result<(), SetupError> {
        if !self.flow_boundaries.is_empty() && self.network.is_none() && !self.has_rock_fractures()
        {
            return Err(SetupError::invalid(
                "flow_boundaries",
                "there is no fracture network to act on (give a `network`, or a mesh with \
                 `fracture.preexisting` fractures for a coupled run)",
            ));
        }
        Ok(())
    }

    /// The production stage needs a coupled run: rock fractures and flow boundaries.
    fn check_production_is_coupled(&self) -> Result<(), SetupError> {
        if !self.has_rock_fractures() || self.flow_boundaries.is_empty() {
            return Err(SetupError::invalid(
                "production",
                "production needs a coupled run: a mesh with pre-existing fractures \
                 (`fracture.preexisting`, `fracture.random` or `fracture.file`) and flow \
                 boundaries",
            ));
        }
        Ok(())
    }

    /// `seismicity` needs joints (a rock with a `fracture` section); slip-weakening friction
    /// needs the explicit rock (a quasi-static step has no unique equilibrium while the
    /// friction weakens with the slip it solves for).
    fn check_seismicity(&self) -> Result<(), SetupError> {
        if let Some(s) = &self.seismicity {
            s.validate()?;
            if self.mesh.is_none() || self.fracture.is_none() {
                return Err(SetupError::invalid(
                    "seismicity",
                    "the event catalogue is made of joint slip: it needs a mesh with a \
                     `fracture` section (pre-existing fractures or a criterion that opens some)",
                ));
            }
        }
        let weakening = self.fracture.as_ref().and_then(|f| f.slip_weakening);
        if weakening.is_some() && self.time.solid_scheme == SolidScheme::QuasiStatic {
            return Err(SetupError::invalid(
                "fracture.slip_weakening",
                "slip-weakening friction needs the explicit rock (`time.solid_scheme: \
                 Explicit`): an event it nucleates runs dynamically, which the quasi-static \
                 step cannot follow",
            ));
        }
        Ok(())
    }

    /// A rigid network is for flow-only scenes: with a mesh the network is the rock's own.
    fn check_network_without_mesh(&self) -> Result<(), SetupError> {
        if self.mesh.is_some() && self.network.is_some() {
            return Err(SetupError::invalid(
                "network",
                "a rigid network cannot be combined with a mesh: in a coupled run the network is \
                 the rock's fractures (`fracture.preexisting` and those the run opens)",
            ));
        }
        Ok(())
    }

    /// Whether the scene is 3D: its mesh is (`Box`, `GradedBox`, `Gmsh3`).
    pub fn is_3d(&self) -> bool {
        self.mesh.as_ref().is_some_and(MeshSpec::is_3d)
    }

    /// The boundary's, gravity's, pins' and flow boundaries' dimension is the mesh's, and a 3D
    /// scene asks only for what 3D has so far (`docs/three_d.md`, "What runs"): everything else
    /// is refused by name.
    fn check_3d(&self) -> Result<(), SetupError> {
        let three = self.is_3d();
        if self.mesh.is_some() && self.boundary.is_3d() != three {
            return Err(SetupError::invalid(
                "boundary",
                if three {
                    "a 3D mesh (Box, GradedBox, Gmsh3) takes a 3D box's boundary: `InSitu3(sxx: .., \
                     syy: .., szz: ..)` or `Sides3(left: .., right: .., front: .., back: .., \
                     bottom: .., top: ..)`"
                } else {
                    "`InSitu3` and `Sides3` hold a 3D box: this mesh is 2D (use `InSitu` or \
                     `Sides`)"
                },
            ));
        }
        let turned = matches!(self.mesh, Some(MeshSpec::GradedBox { tilt: Some(_), .. }));
        let sides = self.boundary.sides3().into_iter().flatten();
        if let Some((name, _)) = sides
            .filter(|_| turned)
            .find(|s| matches!(s.1, SideBc::Normal(_)))
        {
            return Err(SetupError::invalid(
                &format!("boundary.{name}"),
                "a turned grid's sides are oblique and take no roller (`Normal`): hold them \
                 `Fixed`, load them by `Traction`, leave them `Free`, or use `InSitu3`",
            ));
        }
        if !three {
            if self.fracture.as_ref().is_some_and(|f| !f.discs.is_empty()) {
                return Err(SetupError::invalid(
                    "fracture.discs",
                    "discs are 3D fractures: this mesh is 2D (use `preexisting` segments)",
                ));
            }
            if self
                .fracture
                .as_ref()
                .is_some_and(|f| f.grow_in != GrowIn::Anywhere)
            {
                return Err(SetupError::invalid(
                    "fracture.grow_in",
                    "`DiscPlanes` keeps 3D growth on the discs' planes: this mesh is 2D",
                ));
            }
            if let Some(i) = self
                .pins
                .iter()
                .position(|p| p.at.components != 2 || p.uz.is_some())
            {
                return Err(SetupError::invalid(
                    &format!("pins[{i}]"),
                    "a 2D mesh takes a point (x, y), m, and no uz",
                ));
            }
            if self.mesh.is_some() && self.gravity.is_some_and(|g| g.components != 2) {
                return Err(SetupError::invalid(
                    "gravity",
                    "a 2D mesh takes two components, (gx, gy) in m/s^2 with y up",
                ));
            }
            if let Some(i) = self.flow_boundaries.iter().position(|b| b.at.is_3d()) {
                return Err(SetupError::invalid(
                    &format!("flow_boundaries[{i}].at"),
                    "this mesh is 2D: give the point as (x, y), m",
                ));
            }
            return Ok(());
        }
        let not_yet = |field: &str, what: &str| {
            Err(SetupError::invalid(
                field,
                format!("{what} is not in 3D yet (issues 38 and 39)"),
            ))
        };
        if let Some(f) = &self.fracture {
            // The 3D fracture so far: pre-existing discs under a prescribed pressure or the
            // fluid, with the joints' contact; growth by the strength test on the faces with
            // the explicit rock; no segments, no networks.
            let refuse = |field: &str, what: &str| not_yet(&format!("fracture.{field}"), what);
            if let Some(CriterionSpec::Toughness { initiation, .. }) = f.criterion {
                if f.grow_in != GrowIn::DiscPlanes {
                    return refuse(
                        "criterion",
                        "the toughness criterion off the discs' planes (it grows fronts in \
                         their planes: set `grow_in: DiscPlanes`)",
                    );
                }
                if initiation.is_some() {
                    return refuse(
                        "criterion.initiation",
                        "the strength test away from the fronts with the toughness criterion",
                    );
                }
            }
            if f.strength.is_some() || f.criterion.is_some() {
                // The strength test reads a face stress; the toughness criterion reads the
                // openings behind the fronts.
                let strength = !matches!(f.criterion, Some(CriterionSpec::Toughness { .. }));
                if strength && f.face_stress == FaceStress::Patch {
                    return refuse(
                        "face_stress",
                        "the patch face stress (the default; 3D reads the mean of the face's \
                         two tetrahedra: set `face_stress: Elements`)",
                    );
                }
                if f.tip_handover == Some(true) {
                    return refuse("tip_handover", "the tip hand-over");
                }
                if self.time.solid_scheme == SolidScheme::QuasiStatic {
                    return not_yet(
                        "time.solid_scheme",
                        "fracture growth with the quasi-static rock (use the explicit rock)",
                    );
                }
                if self.time.mass_scaling || self.time.selective_mass_scaling.is_some() {
                    return not_yet("time.mass_scaling", "mass scaling with fracture growth");
                }
            }
            if !f.preexisting.is_empty() || f.file.is_some() || f.random.is_some() {
                return Err(SetupError::invalid(
                    "fracture.preexisting",
                    "segments, fracture files and random networks are 2D; a 3D fracture is a \
                     disc: `discs: [(center: (x, y, z), normal: (nx, ny, nz), radius: r)]`",
                ));
            }
            if f.slip_weakening.is_some() {
                return refuse("slip_weakening", "slip-weakening friction");
            }
            if f.discs.is_empty() {
                return Err(SetupError::invalid(
                    "fracture.discs",
                    "a 3D fracture block needs at least one disc",
                ));
            }
        }
        if let Some(i) = self.flow_boundaries.iter().position(|b| !b.at.is_3d()) {
            return Err(SetupError::invalid(
                &format!("flow_boundaries[{i}].at"),
                "this mesh is 3D: give the point as (x, y, z), m",
            ));
        }
        if !self.flow_boundaries.is_empty()
            && self.fracture.as_ref().is_some_and(|f| f.pressure.is_some())
        {
            return Err(SetupError::invalid(
                "fracture.pressure",
                "with flow boundaries the fluid in the fracture sets its face pressure: leave \
                 out the prescribed pressure",
            ));
        }
        if !self.flow_boundaries.is_empty() && self.time.solid_scheme == SolidScheme::QuasiStatic {
            return not_yet(
                "time.solid_scheme",
                "the quasi-static rock coupled to fracture flow (use the explicit rock, the \
                 seed's scheme)",
            );
        }
        if self.production.is_some() {
            return not_yet("production", "the production stage");
        }
        if self.seismicity.is_some() {
            return not_yet("seismicity", "the event catalogue");
        }
        if let Some(i) = self.pins.iter().position(|p| p.at.components != 3) {
            return Err(SetupError::invalid(
                &format!("pins[{i}].at"),
                "a 3D mesh takes a point (x, y, z), m",
            ));
        }
        if self.gravity.is_some_and(|g| g.components != 3) {
            return Err(SetupError::invalid(
                "gravity",
                "a 3D mesh takes three components, (gx, gy, gz) in m/s^2 with z up",
            ));
        }
        Ok(())
    }

    /// `initial_state: InSitu` needs `boundary: InSitu` (`InSitu3` in 3D).
    fn check_initial_state(&self) -> Result<(), SetupError> {
        if self.initial_state == InitialState::InSitu
            && !matches!(
                self.boundary,
                Boundary::InSitu { .. } | Boundary::InSitu3 { .. }
            )
        {
            return Err(SetupError::invalid(
                "initial_state",
                "InSitu starts from the homogeneous in-situ field: it needs `boundary: InSitu(..)`",
            ));
        }
        Ok(())
    }
}

/// `v` is a finite number (errors name `field`).
fn finite(field: &str, v: f64) -> Result<(), SetupError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SetupError::invalid(
            field,
            format!("{v} is not a finite number"),
        ))
    }
}

/// `v` is a finite number > 0 (`what`: its name in the message).
fn positive(field: &str, v: f64, what: &str) -> Result<(), SetupError> {
    finite(field, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(SetupError::invalid(
            field,
            format!("{what} must be > 0, got {v}"),
        ))
    }
}
