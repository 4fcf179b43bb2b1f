//! Scenario files (RON): what a user writes to describe a run, its parsing with precise error
//! positions, `--set PATH=VALUE` overrides, and the validation pass for physical sense.
//!
//! All quantities are SI: lengths m, moduli and stresses Pa (tension positive), density kg/m^3,
//! time s. The model is plane strain per unit thickness.

use crate::error::SetupError;
pub use crate::network::{Fracture, NetworkSpec, RandomNetwork};
use serde::{Deserialize, Serialize};
use std::path::Path;

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
    /// Gravity, m/s^2 (e.g. (0.0, -9.81)): a body force rho g on the rock.
    #[serde(default)]
    pub gravity: Option<[f64; 2]>,
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
}

/// Two wells held at pressures on a fracture network, at several pressure drops (the seed's
/// Table 1: 9, 12 and 15 MPa). Positions m, pressures Pa.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProductionSpec {
    /// Injection well position, m (connected to the nearest fracture node).
    pub injection: [f64; 2],
    /// Production well position, m.
    pub production: [f64; 2],
    /// Production well pressure, Pa.
    pub production_pressure: f64,
    /// Pressure drops from the injection to the production well, Pa (the seed's Table 1: 9, 12
    /// and 15 MPa).
    pub pressure_drops: Vec<f64>,
    /// Largest distance from a well to the fracture node it connects to, m.
    pub reach: f64,
}

impl ProductionSpec {
    /// Finite positions and pressure, at least one finite positive drop, a positive reach;
    /// errors name `field.<field>`.
    pub fn validate(&self, field: &str) -> Result<(), SetupError> {
        let bad = |f: &str, why: String| SetupError::invalid(&format!("{field}.{f}"), why);
        for (f, v) in [
            ("injection", self.injection),
            ("production", self.production),
        ] {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(bad(f, format!("{v:?} is not a finite position")));
            }
        }
        if !self.production_pressure.is_finite() {
            return Err(bad(
                "production_pressure",
                format!("{} Pa is not finite", self.production_pressure),
            ));
        }
        if self.pressure_drops.is_empty() {
            return Err(bad(
                "pressure_drops",
                "give at least one pressure drop".into(),
            ));
        }
        for (k, dp) in self.pressure_drops.iter().enumerate() {
            if !(dp.is_finite() && *dp > 0.0) {
                return Err(bad(
                    &format!("pressure_drops[{k}]"),
                    format!("{dp} Pa is not finite and positive"),
                ));
            }
        }
        if !(self.reach.is_finite() && self.reach > 0.0) {
            return Err(bad(
                "reach",
                format!("{} m is not finite and positive", self.reach),
            ));
        }
        Ok(())
    }
}

/// The production stage of a run (`production:`): the wells and the coupled steady state's
/// iteration (`src/production.rs`). Each state is solved by a fixed-point iteration between
/// the rock's equilibrium under the cells' fluid pressures (dynamic relaxation) and the
/// network's steady flow through the apertures of that equilibrium.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProductionStage {
    pub wells: ProductionSpec,
    /// The iteration ends when the production rate and every cell pressure change by less
    /// than this, relative to the rate and to the pressure drop (default 1e-3).
    #[serde(default = "default_production_tol")]
    pub tolerance: f64,
    /// Under-relaxation of the cell pressures between iterations, in (0, 1] (default 0.7).
    #[serde(default = "default_production_relaxation")]
    pub relaxation: f64,
    /// Most iterations per state (default 40); not converged is reported, not an error.
    #[serde(default = "default_production_iterations")]
    pub max_iterations: usize,
    /// The rock is in equilibrium when the unbalanced force over the internal force (the
    /// quasi-static solve: over the reactions and loads) is below this (default 1e-6).
    #[serde(default = "default_production_static_tol")]
    pub static_tol: f64,
    /// Most relaxation steps per equilibrium (default 200000; `rock: Explicit`).
    #[serde(default = "default_production_steps")]
    pub max_steps: u64,
    /// How the rock's equilibria are found: `QuasiStatic` (default: one Newton solve of the
    /// quasi-static scheme per equilibrium, to `static_tol`) or `Explicit` (dynamic
    /// relaxation with the explicit scheme and local damping 0.8, to `static_tol`). The same
    /// static answer; see docs/production.md.
    #[serde(default = "default_production_rock")]
    pub rock: SolidScheme,
}

fn default_production_rock() -> SolidScheme {
    SolidScheme::QuasiStatic
}

fn default_production_tol() -> f64 {
    1e-3
}
fn default_production_relaxation() -> f64 {
    0.7
}
fn default_production_iterations() -> usize {
    40
}
fn default_production_static_tol() -> f64 {
    1e-6
}
fn default_production_steps() -> u64 {
    200_000
}

impl ProductionStage {
    /// The wells' checks and the iteration's; errors name `production.<field>`.
    pub fn validate(&self) -> Result<(), SetupError> {
        self.wells.validate("production.wells")?;
        let bad = |f: &str, why: String| SetupError::invalid(&format!("production.{f}"), why);
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(bad(
                "tolerance",
                format!("{} is not in (0, 1)", self.tolerance),
            ));
        }
        if !(self.relaxation > 0.0 && self.relaxation <= 1.0) {
            return Err(bad(
                "relaxation",
                format!("{} is not in (0, 1]", self.relaxation),
            ));
        }
        if !(1..=10_000).contains(&self.max_iterations) {
            return Err(bad(
                "max_iterations",
                format!("{} is not in 1..=10000", self.max_iterations),
            ));
        }
        if !(self.static_tol.is_finite() && self.static_tol > 0.0 && self.static_tol < 1.0) {
            return Err(bad(
                "static_tol",
                format!("{} is not in (0, 1)", self.static_tol),
            ));
        }
        if self.max_steps == 0 {
            return Err(bad("max_steps", "must be at least 1".into()));
        }
        Ok(())
    }
}

/// The solid mesh.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum MeshSpec {
    /// Square cells of size `h` (m), each split into two triangles with alternating diagonals.
    Regular {
        width: f64,
        height: f64,
        h: f64,
        #[serde(default)]
        origin: [f64; 2],
    },
    /// The regular mesh with every node moved randomly by up to `fraction * h` (ChaCha8, `seed`).
    Perturbed {
        width: f64,
        height: f64,
        h: f64,
        #[serde(default)]
        origin: [f64; 2],
        fraction: f64,
        seed: u64,
    },
    /// Square cells of size `h` inside the box `fine` = (x0, y0, x1, y1), m, growing by `ratio`
    /// (> 1) per cell towards the domain edges: fine where the action is, coarse far away.
    Graded {
        width: f64,
        height: f64,
        #[serde(default)]
        origin: [f64; 2],
        h: f64,
        fine: [f64; 4],
        ratio: f64,
    },
    /// A 2D triangle mesh from a Gmsh `.msh` file (ASCII 2.2 or 4.1, first-order triangles),
    /// path relative to the scenario file. The domain sides are the bounding box's edges.
    Gmsh { file: String },
    /// A mesh that follows the fractures: a constrained Delaunay triangulation of the
    /// `width` x `height` rectangle (m) whose edges contain every pre-existing fracture
    /// (`fracture.preexisting`, `fracture.file`, `fracture.random`), with edges of `h` (m) along
    /// them, growing as h + `grading` d with the distance d from them to at most `h_far` (m,
    /// default 4 h), refined to a smallest
    /// angle of `min_angle_deg` (default 25). Points closer than `merge * h` (default 0.25) are
    /// merged: crossings and near misses that close leave no tiny segment. Seeded by nothing:
    /// the same input gives the same mesh (`src/conforming.rs`, `docs/conforming.md`).
    Conforming {
        width: f64,
        height: f64,
        #[serde(default)]
        origin: [f64; 2],
        h: f64,
        #[serde(default)]
        h_far: Option<f64>,
        #[serde(default = "default_min_angle")]
        min_angle_deg: f64,
        #[serde(default = "default_merge")]
        merge: f64,
        /// Edge length growth away from the fractures: up to h + grading * d at a distance d
        /// (m/m, default 0.1: Sneddon's crack within 0.3 % of the one on an exact
        /// regular mesh, `verify sneddon_inclined`), capped at h_far.
        #[serde(default = "default_grading")]
        grading: f64,
        /// Extra segments the mesh follows without opening them (m): planned paths, layer
        /// contacts, or lines to sample along.
        #[serde(default)]
        follow: Vec<PreFracture>,
    },
}

fn default_grading() -> f64 {
    0.1
}

fn default_min_angle() -> f64 {
    25.0
}
fn default_merge() -> f64 {
    0.25
}

impl MeshSpec {
    /// Nodes, triangles and edges a mesh will have: exact for regular and perturbed meshes, an
    /// upper bound for graded ones, from the file size for Gmsh files (`None` when the file
    /// cannot be read: reading it reports that). Reads the scenario's (finite, positive) sizes;
    /// non-finite ones give infinite counts.
    pub fn counts(&self) -> Option<MeshCounts> {
        match *self {
            MeshSpec::Regular {
                width, height, h, ..
            }
            | MeshSpec::Perturbed {
                width, height, h, ..
            } => Some(MeshCounts::from_grid(
                (width / h).round(),
                (height / h).round(),
            )),
            MeshSpec::Graded {
                width,
                height,
                h,
                fine,
                ratio,
                ..
            } => {
                // Cells that grow by `ratio` from h across a length l: at most
                // ln(1 + l (ratio - 1) / h) / ln(ratio) (l / h for ratio 1).
                let grow = |l: f64| {
                    if ratio > 1.0 {
                        (1.0 + l * (ratio - 1.0) / h).ln() / ratio.ln()
                    } else {
                        l / h
                    }
                };
                let nx = ((fine[2] - fine[0]) / h + 2.0 * grow(width)).ceil();
                let ny = ((fine[3] - fine[1]) / h + 2.0 * grow(height)).ceil();
                Some(MeshCounts::from_grid(nx, ny))
            }
            MeshSpec::Gmsh { ref file } => {
                let len = std::fs::metadata(file).ok()?.len() as f64;
                Some(MeshCounts::from_triangles(len / GMSH_BYTES_PER_TRIANGLE))
            }
            MeshSpec::Conforming {
                width, height, h, ..
            } => {
                // A bound: the whole domain at h / sqrt(2) in equilateral triangles (area
                // sqrt(3)/8 h^2; edges shorter than h appear only near crossings and merged
                // points, and the mesh coarsens away from the fractures), and the refinement
                // is capped at this many nodes.
                Some(MeshCounts::from_triangles(
                    (width * height / (3f64.sqrt() / 8.0 * h * h)).ceil() + 4.0,
                ))
            }
        }
    }

    /// The mesh kind's name as the scenario writes it (`Regular`, ..., `Conforming`).
    pub fn kind(&self) -> &'static str {
        match self {
            MeshSpec::Regular { .. } => "Regular",
            MeshSpec::Perturbed { .. } => "Perturbed",
            MeshSpec::Graded { .. } => "Graded",
            MeshSpec::Gmsh { .. } => "Gmsh",
            MeshSpec::Conforming { .. } => "Conforming",
        }
    }

    /// Nominal cell size, m (`None` for an imported mesh).
    pub fn h(&self) -> Option<f64> {
        match self {
            MeshSpec::Regular { h, .. }
            | MeshSpec::Perturbed { h, .. }
            | MeshSpec::Graded { h, .. }
            | MeshSpec::Conforming { h, .. } => Some(*h),
            MeshSpec::Gmsh { .. } => None,
        }
    }
    /// Domain size, m (`None` for an imported mesh).
    pub fn size(&self) -> Option<(f64, f64)> {
        match self {
            MeshSpec::Regular { width, height, .. }
            | MeshSpec::Perturbed { width, height, .. }
            | MeshSpec::Graded { width, height, .. }
            | MeshSpec::Conforming { width, height, .. } => Some((*width, *height)),
            MeshSpec::Gmsh { .. } => None,
        }
    }
}

/// Counts of a mesh before it is built (estimates for graded and imported meshes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshCounts {
    pub nodes: f64,
    pub triangles: f64,
    pub edges: f64,
}

impl MeshCounts {
    fn from_grid(nx: f64, ny: f64) -> Self {
        MeshCounts {
            nodes: (nx + 1.0) * (ny + 1.0),
            triangles: 2.0 * nx * ny,
            edges: nx * (ny + 1.0) + ny * (nx + 1.0) + nx * ny,
        }
    }
    fn from_triangles(t: f64) -> Self {
        MeshCounts {
            nodes: 0.5 * t + 1.0,
            triangles: t,
            edges: 1.5 * t + 1.0,
        }
    }
}

/// Bytes of an imported Gmsh file per triangle, at least: a triangle takes 20 or more bytes of
/// text (with its share of the nodes), so a file has at most `size / 20` triangles.
pub const GMSH_BYTES_PER_TRIANGLE: f64 = 20.0;

/// Linear elastic rock.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub young: f64,
    /// Poisson's ratio nu, 0 <= nu < 0.5.
    pub poisson: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
}

impl Material {
    /// Lame's first parameter lambda, Pa.
    pub fn lambda(&self) -> f64 {
        self.young * self.poisson / ((1.0 + self.poisson) * (1.0 - 2.0 * self.poisson))
    }
    /// Shear modulus G, Pa.
    pub fn shear(&self) -> f64 {
        self.young / (2.0 * (1.0 + self.poisson))
    }
    /// P-wave speed c_p = sqrt((lambda + 2G)/rho), m/s.
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lambda() + 2.0 * self.shear()) / self.density).sqrt()
    }
    /// Plane-strain strains (exx, eyy) that give the stresses (sxx, syy) with sxy = 0:
    /// exx = ((1-nu^2) sxx - nu(1+nu) syy)/E, and symmetrically.
    pub fn plane_strain_strain(&self, sxx: f64, syy: f64) -> (f64, f64) {
        let (e, nu) = (self.young, self.poisson);
        (
            ((1.0 - nu * nu) * sxx - nu * (1.0 + nu) * syy) / e,
            ((1.0 - nu * nu) * syy - nu * (1.0 + nu) * sxx) / e,
        )
    }
}

/// Boundary conditions on the four sides of the rectangular domain.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Boundary {
    /// Normal displacements on all four sides computed by plane-strain Hooke's law so that the
    /// unfractured body carries the uniform stress (sxx, syy), Pa, tension positive. The domain
    /// centre stays put; tangential motion along the sides is free.
    InSitu { sxx: f64, syy: f64 },
    /// One condition per side.
    Sides {
        #[serde(default)]
        left: SideBc,
        #[serde(default)]
        right: SideBc,
        #[serde(default)]
        bottom: SideBc,
        #[serde(default)]
        top: SideBc,
    },
}

impl Default for Boundary {
    fn default() -> Self {
        Boundary::Sides {
            left: SideBc::Free,
            right: SideBc::Free,
            bottom: SideBc::Free,
            top: SideBc::Free,
        }
    }
}

/// The solid's state at t = 0.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum InitialState {
    /// Undeformed, at rest.
    #[default]
    Rest,
    /// The homogeneous plane-strain displacement of the in-situ stress, u = (exx (x - xc),
    /// eyy (y - yc)) about the domain centre, at rest.
    InSitu,
}

/// Condition on one side.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum SideBc {
    /// Traction-free.
    #[default]
    Free,
    /// Prescribed displacement along the outward normal, m (negative = pushed inwards);
    /// tangential motion free.
    Normal(f64),
    /// Both displacement components zero.
    Fixed,
    /// Traction, Pa: `normal` along the outward normal (tension positive, so a confining
    /// pressure p is `normal: -p`), `shear` along the side's counter-clockwise tangent.
    Traction { normal: f64, shear: f64 },
}

/// Fracture criterion parameters.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FractureSpec {
    /// lambda * T0, Pa: an internal edge is fracture-ready when the normal stress across it
    /// (tension positive) reaches this (seed equation (7); the seed uses 1 MPa at h = 1 m).
    /// lambda is a mesh-size calibration; the value may be negative when the criterion is
    /// calibrated under confinement (the near-zero-toughness KGD case uses -s0 + 0.5 MPa).
    /// `None`: no criterion, only the pre-existing fractures.
    #[serde(default)]
    pub strength: Option<f64>,
    /// The criterion by name: `Some(Strength(lambda_t0))` is the same as `strength`;
    /// `Some(Toughness(k_ic: ..., initiation: ...))` grows fractures at their tips when the
    /// equivalent stress intensity reaches K_Ic (Pa sqrt(m)), with the strength test (Pa,
    /// optional) starting new fractures away from the tips (`systems::toughness`). Give either
    /// this or `strength`, not both.
    #[serde(default)]
    pub criterion: Option<CriterionSpec>,
    /// Which stress the criterion reads on a face: `Patch` (default), the area-weighted mean of
    /// the elements touching the edge's ends that lie alongside it, or `Elements`, the mean of
    /// the two elements beside the edge. See `systems::fracture::fracture_criterion`.
    #[serde(default)]
    pub face_stress: FaceStress,
    /// The strength test's hand-over at fracture tips: a fracture-ready face that is the far
    /// side of a triangle at a tip node touches no tip, so no node can split and the fracture
    /// stops; with the hand-over its mark also goes to the edge of that triangle at the tip
    /// that best continues the fracture (`systems::fracture::hand_over`). `None` (default): on
    /// for meshes that are not the seed's grids (`Conforming`, `Gmsh`), where tips meet such
    /// triangles; off on `Regular`, `Perturbed` and `Graded`, where the seed's rule runs as
    /// written. No effect under `Toughness`, which marks edges at the tips itself.
    #[serde(default)]
    pub tip_handover: Option<bool>,
    /// Residual hydraulic aperture a_r, m (seed: 0.5 mm).
    #[serde(default = "default_residual_aperture")]
    pub residual_aperture: f64,
    /// Fractures present at the start, snapped to mesh edges and opened by node splitting.
    #[serde(default)]
    pub preexisting: Vec<PreFracture>,
    /// A seeded random network of pre-existing fractures (added to `preexisting`), snapped and
    /// opened as they are; written to `preexisting_fractures.csv` with each one's snapping
    /// error.
    #[serde(default)]
    pub random: Option<RockNetwork>,
    /// Pre-existing fractures from a CSV file (relative to the scenario file) with a header
    /// line and columns `x0,y0,x1,y1` (m), e.g. a mapped network (added to `preexisting`).
    #[serde(default)]
    pub file: Option<String>,
    /// A uniform pressure on the faces of every fracture, Pa (prescribed; in coupled runs the
    /// flow solver supplies the face pressures instead).
    #[serde(default)]
    pub pressure: Option<f64>,
    /// Joint friction angle phi, degrees (Coulomb: |F_t| <= F_n tan phi). Default 30.
    #[serde(default = "default_friction")]
    pub friction_deg: f64,
    /// Joint normal and shear penalty stiffness K_n, K_t, Pa (force per unit thickness per unit
    /// offset). Default: the rock's E and G, as in the seed.
    #[serde(default)]
    pub normal_stiffness: Option<f64>,
    #[serde(default)]
    pub shear_stiffness: Option<f64>,
}

/// The fracture criterion (`fracture.criterion`).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum CriterionSpec {
    /// The seed's: a face opens when its normal stress reaches lambda*T0, Pa (tension
    /// positive; as `fracture.strength`).
    Strength(f64),
    /// Linear elastic fracture mechanics at the tips: a tip grows by one edge, in the direction
    /// of the maximum hoop stress, when K_eq >= `k_ic` (Pa sqrt(m)). `initiation` (Pa, tension
    /// positive): the strength test on faces away from every tip, so fractures can also start
    /// where there is no tip; `None`: only tips grow.
    #[serde(rename_all = "snake_case")]
    Toughness {
        k_ic: f64,
        #[serde(default)]
        initiation: Option<f64>,
    },
}

/// The stress the fracture criterion reads on a face.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum FaceStress {
    #[default]
    Patch,
    Elements,
}

fn default_friction() -> f64 {
    30.0
}

/// Residual hydraulic aperture a_r when a scenario gives none, m (the seed's 0.5 mm).
pub const DEFAULT_RESIDUAL_APERTURE: f64 = 5e-4;

fn default_residual_aperture() -> f64 {
    DEFAULT_RESIDUAL_APERTURE
}

/// A pre-existing fracture: a straight segment, m.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PreFracture {
    pub from: [f64; 2],
    pub to: [f64; 2],
}

/// Largest Young's modulus accepted, Pa, and largest density, kg/m^3 (see `validate`).
pub const MAX_YOUNG: f64 = 1e14;
pub const MAX_DENSITY: f64 = 1e9;

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

/// Most fractures of a random network in the rock (each is snapped by a shortest-path search
/// over the mesh).
pub const MAX_ROCK_FRACTURES: usize = 10_000;

/// A seeded (ChaCha8) random network of fractures in the rock: `count` fractures with centres
/// uniform in the box `origin`..`origin + size` (m), orientation `angles_deg[k] +- jitter_deg`
/// (degrees from the x axis, a family chosen uniformly per fracture), length uniform in
/// `length` (m); clipped to the box. Their apertures come from the joints (residual aperture
/// when closed).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RockNetwork {
    pub seed: u64,
    pub count: usize,
    #[serde(default)]
    pub origin: [f64; 2],
    pub size: [f64; 2],
    pub angles_deg: Vec<f64>,
    #[serde(default)]
    pub jitter_deg: f64,
    pub length: [f64; 2],
}

impl RockNetwork {
    /// As the rigid network's generator sees it (apertures unused).
    fn as_random(&self) -> RandomNetwork {
        RandomNetwork {
            seed: self.seed,
            count: self.count,
            origin: self.origin,
            size: self.size,
            angles_deg: self.angles_deg.clone(),
            jitter_deg: self.jitter_deg,
            length: self.length,
            aperture: [1.0, 1.0],
        }
    }

    /// The fractures, generated by [`RandomNetwork::generate`] (the same seed gives the same
    /// fractures).
    pub fn generate(&self) -> Vec<PreFracture> {
        self.as_random()
            .generate()
            .into_iter()
            .map(|f| PreFracture {
                from: f.from,
                to: f.to,
            })
            .collect()
    }

    /// [`RandomNetwork::validate_geometry`] and the count limit; errors name `field.<field>`.
    pub fn validate(&self, field: &str) -> Result<(), SetupError> {
        if self.count > MAX_ROCK_FRACTURES {
            return Err(SetupError::invalid(
                &format!("{field}.count"),
                format!("{} fractures: at most {MAX_ROCK_FRACTURES}", self.count),
            ));
        }
        self.as_random().validate_geometry(field)
    }
}

/// Read pre-existing fractures from CSV text (header line, then `x0,y0,x1,y1` per line, m;
/// blank lines skipped). Errors name the file and line.
pub fn read_fracture_csv(text: &str, file: &str) -> Result<Vec<PreFracture>, SetupError> {
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let v: Vec<&str> = line.split(',').map(str::trim).collect();
        let nums: Option<Vec<f64>> = v.iter().map(|x| x.parse::<f64>().ok()).collect();
        match nums {
            Some(n) if n.len() == 4 && n.iter().all(|x| x.is_finite()) => out.push(PreFracture {
                from: [n[0], n[1]],
                to: [n[2], n[3]],
            }),
            _ => {
                return Err(SetupError::invalid(
                    "fracture.file",
                    format!(
                        "{file}:{}: `{line}` is not four finite numbers x0,y0,x1,y1 (m)",
                        k + 1
                    ),
                ));
            }
        }
        if out.len() > MAX_ROCK_FRACTURES {
            return Err(SetupError::invalid(
                "fracture.file",
                format!("{file}: more than {MAX_ROCK_FRACTURES} fractures"),
            ));
        }
    }
    Ok(out)
}

impl FractureSpec {
    /// Every pre-existing fracture with the field it comes from: the listed ones
    /// (`fracture.preexisting[i]`), then the file's (`fracture.file[i]`), then the random
    /// network's (`fracture.random[i]`).
    pub fn all_preexisting(&self) -> Result<Vec<(PreFracture, String)>, SetupError> {
        let mut all: Vec<(PreFracture, String)> = self
            .preexisting
            .iter()
            .enumerate()
            .map(|(i, f)| (*f, format!("fracture.preexisting[{i}]")))
            .collect();
        if let Some(f) = &self.file {
            let text = std::fs::read_to_string(f).map_err(|e| {
                SetupError::invalid("fracture.file", format!("cannot read {f}: {e}"))
            })?;
            let list = read_fracture_csv(&text, f)?;
            all.extend(
                list.into_iter()
                    .enumerate()
                    .map(|(i, p)| (p, format!("fracture.file[{i}]"))),
            );
        }
        if let Some(r) = &self.random {
            r.validate("fracture.random")?;
            all.extend(
                r.generate()
                    .into_iter()
                    .enumerate()
                    .map(|(i, p)| (p, format!("fracture.random[{i}]"))),
            );
        }
        Ok(all)
    }
}

/// Fluid properties (defaults: water at 25 C, the seed's values).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    /// Dynamic viscosity mu, Pa s.
    #[serde(default = "default_viscosity")]
    pub viscosity: f64,
    /// Bulk modulus K, Pa.
    #[serde(default = "default_bulk")]
    pub bulk_modulus: f64,
    /// Reference density rho_r (density at zero pressure), kg/m^3.
    #[serde(default = "default_rho_f")]
    pub density: f64,
    /// How the cubic law joins two cells: `CellMean` (default, the seed's equations (1)-(2)) or
    /// `LinearOpening` (the opening varies linearly between cell centres). See
    /// [`Transmissibility`].
    #[serde(default)]
    pub transmissibility: Transmissibility,
    /// The face load of a cell the fluid is still filling: `Dry` (default, the seed's: zero,
    /// the fluid's cavitated pressure, on the whole face) or `FrontInCell` (the filled part
    /// carries the fluid's pressure). See [`Filling`].
    #[serde(default)]
    pub filling: Filling,
}

/// The rock's load from a cell that the fluid is still filling (its mass m below rho_r V, so
/// its pressure is zero: the fluid has not reached the cell's far end). Both apply to the
/// coupled runs (explicit and quasi-static rock); the flow itself is the same.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum Filling {
    /// The whole face carries the cell's pressure, zero (absolute): a fluid lag of the whole
    /// cell, whose closing load (the confining stress) the fracture behind must overcome.
    #[default]
    Dry,
    /// A fluid front inside the cell: the filled fraction f = m / (rho_r V), next to the cell's
    /// wettest neighbour, carries a pressure falling linearly from that neighbour's pressure
    /// P_u to zero at the front; the rest is dry. The face carries the mean, f P_u / 2 (Pa).
    /// With the quasi-static rock it is taken at the start of each step. On the
    /// viscosity-dominated KGD with the toughness criterion it takes the well pressure's
    /// error at 15 cells from +5.1 to +2.5 % (`docs/toughness.md`, "The fluid at a viscous
    /// tip").
    FrontInCell,
}

/// The transmissibility between two cells i and j that share a node (lengths L, apertures a,
/// viscosity mu; m^2/(Pa s)). Both are the cubic law q = a^3/(12 mu) dP/ds integrated from one
/// cell's centre to the other's; they differ in the opening assumed along the way
/// (`crate::flow::pair_kappa`, `crate::flow::pair_kappa_linear`). The choice applies to the
/// run's network flow (explicit, implicit and coupled quasi-static) and to everything built on
/// its flow view; the reservoir pipeline's frozen-network solves (`crate::reservoir`) use
/// `CellMean`.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum Transmissibility {
    /// Each half-cell at its cell's mean aperture: 1 / (6 mu (L_i/a_i^3 + L_j/a_j^3)) (seed
    /// (1)-(2), a harmonic mean). Where the aperture falls steeply, at a fracture tip, the
    /// smaller cell's a^3 dominates: the tip cell, half as open on average as at its entry,
    /// gets 8 times the resistance of its entry's opening.
    #[default]
    CellMean,
    /// The opening varies linearly from each cell's centre to the shared node, where it is the
    /// centres' linear interpolation a_n = (a_i L_j + a_j L_i) / (L_i + L_j) (the rock's
    /// elements open linearly along a fracture); the integral of 12 mu / a^3 over a half-cell
    /// from a to a_n is 3 mu L (a + a_n) / (a^2 a_n^2). Equal apertures give `CellMean`'s value.
    /// On the viscosity-dominated KGD with the toughness criterion it takes the well
    /// pressure's error from +9.8 % to +4.6 % at 27 cells (`docs/toughness.md`, "Limits").
    LinearOpening,
}

fn default_viscosity() -> f64 {
    8.9e-4
}
fn default_bulk() -> f64 {
    2.2e9
}
fn default_rho_f() -> f64 {
    1000.0
}

impl Default for Fluid {
    fn default() -> Self {
        Fluid {
            viscosity: default_viscosity(),
            bulk_modulus: default_bulk(),
            density: default_rho_f(),
            transmissibility: Transmissibility::CellMean,
            filling: Filling::Dry,
        }
    }
}

/// Fluid in the cells at t = 0.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum InitialFluid {
    /// No fluid (cells fill first; pressure is zero until a cell is full).
    #[default]
    Empty,
    /// Every cell full at this pressure, Pa.
    Full(f64),
}

/// Where a flow boundary acts.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub enum FlowTarget {
    /// The network node nearest to this point, m: every cell meeting there connects to the
    /// boundary through half its length.
    Node([f64; 2]),
    /// The cell whose centre is nearest to this point, m: it connects through half its length.
    Cell([f64; 2]),
}

/// What a flow boundary imposes.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum FlowBcKind {
    /// Fixed pressure, Pa.
    Pressure(f64),
    /// Fixed volumetric rate into the network, m^2/s (per metre of thickness; negative = out).
    Rate(f64),
    /// Pump characteristic P = p_max (1 - (2/pi) atan(q / q_half)), Pa and m^2/s, solved with
    /// the network every flow step; a check valve stops backflow (q >= 0).
    Pump { p_max: f64, q_half: f64 },
}

/// A flow boundary condition.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FlowBoundary {
    /// Label used in outputs (default "bc<k>").
    #[serde(default)]
    pub name: String,
    pub at: FlowTarget,
    pub kind: FlowBcKind,
    /// Piecewise-linear multiplier against time, [(t s, factor)], constant beyond the ends:
    /// scales the pressure, the rate or the pump's p_max (0 = off, e.g. shut-in).
    #[serde(default)]
    pub schedule: Vec<(f64, f64)>,
}

/// A piecewise-linear schedule [(t, factor)] at time t (1 when empty, constant beyond the ends).
pub fn schedule_factor(s: &[(f64, f64)], t: f64) -> f64 {
    match s.len() {
        0 => 1.0,
        _ if t <= s[0].0 => s[0].1,
        _ if t >= s[s.len() - 1].0 => s[s.len() - 1].1,
        _ => {
            let k = s.partition_point(|p| p.0 <= t);
            let ((t0, f0), (t1, f1)) = (s[k - 1], s[k]);
            if t1 > t0 {
                f0 + (f1 - f0) * (t - t0) / (t1 - t0)
            } else {
                f1
            }
        }
    }
}

impl FlowBoundary {
    /// The schedule factor at time t (1 without a schedule).
    pub fn factor(&self, t: f64) -> f64 {
        schedule_factor(&self.schedule, t)
    }
}

/// A prescribed displacement on the node nearest to `at` (within half a cell diagonal).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Pin {
    /// Position, m.
    pub at: [f64; 2],
    /// Prescribed x displacement, m (`None`: free).
    #[serde(default)]
    pub ux: Option<f64>,
    /// Prescribed y displacement, m (`None`: free).
    #[serde(default)]
    pub uy: Option<f64>,
}

/// Time control.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeControl {
    pub end: End,
    /// Fraction of the critical step used, in (0, 1]. The critical step is the smallest
    /// triangle altitude over the P-wave speed; lumped-mass CST meshes are stable up to about
    /// 0.98 of it, so the default 0.9 keeps a margin.
    #[serde(default = "default_safety")]
    pub safety: f64,
    /// Force this time step, s, instead of `safety` times the critical one. A step above the
    /// stability limit is allowed (for studies) and is caught as a blow-up.
    #[serde(default)]
    pub dt: Option<f64>,
    /// Force the flow sub-step, s (studies; above the flow stability limit it is caught as a
    /// blow-up). Default: `safety` times the flow critical step.
    #[serde(default)]
    pub flow_dt: Option<f64>,
    /// Time integration of the fracture-network flow (default `Explicit`). `Explicit`: N
    /// forward-Euler sub-steps per step, each below the stability bound V/(K sum kappa) (s),
    /// which shrinks with the aperture squared. `Implicit`: one backward-Euler step (Newton,
    /// sparse LU) per step, stable for any length: in a scene with a rock mesh it is the solid
    /// step; in a flow-only scene it is `time.dt`, else `time.flow_dt`, else the explicit
    /// flow-only step (32 x `safety` x the explicit bound). Backward Euler is first order in
    /// time: choose the step for the accuracy wanted, not for stability.
    #[serde(default)]
    pub flow_scheme: FlowScheme,
    /// Time integration of the rock (default `Explicit`, the seed's central difference).
    /// `QuasiStatic`: equilibrium at the end of every step (Newton, sparse Cholesky) with the
    /// same forces, joints and friction; no inertia, no stability limit. `end: Static` is then
    /// one solve. With fracture flow (flow boundaries on the rock's fractures) each step solves
    /// the rock and the network's backward-Euler step together (one Newton iteration;
    /// `time.flow_scheme` is then not used), and the step adapts: it starts at `time.dt`
    /// (default: the end time / 1000), grows with easy steps, shrinks with hard ones or fast
    /// pressure change or fracture growth, stays within [`time.dt_min`, `time.dt_max`], is
    /// halved and retried when Newton fails, and lands on the end time and every
    /// `output.figure_times`. After a split the step is solved again at the same time until
    /// nothing more opens (at most `time.max_resolves` times). Without flow a timed run takes
    /// `time.dt` steps (default: the end time in 100 steps).
    #[serde(default)]
    pub solid_scheme: SolidScheme,
    /// Quasi-static scheme: the linear algebra of the Newton direction (default `Auto`; see
    /// [`LinearSolver`]). The converged answers agree to the solver's tolerance.
    #[serde(default)]
    pub linear_solver: LinearSolver,
    /// Adaptive quasi-static step: the longest step, s (default: the end time / 100).
    #[serde(default)]
    pub dt_max: Option<f64>,
    /// Adaptive quasi-static step: the shortest step a failing step may be halved to, s
    /// (default: the end time x 1e-9).
    #[serde(default)]
    pub dt_min: Option<f64>,
    /// Adaptive quasi-static step: a step whose Newton solve took at most this many iterations
    /// is followed by one 1.5 times longer; above three times this many the next is halved;
    /// between, it is kept (default 4; 1 to 20). Where many joints slide every step takes
    /// several iterations whatever its length (contact states settle, the coupled line
    /// search), so a larger value lets the step grow there; the pressure-change and
    /// new-cell limits still bound each step.
    #[serde(default = "default_newton_easy")]
    pub newton_easy: u64,
    /// Quasi-static scheme: a step is in equilibrium when the free degrees of freedom's
    /// unbalanced force is below this times the reactions and loads (or the step's first
    /// unbalanced force), N/m over N/m (default 1e-10; 1e-14 to 1e-3). On a network where
    /// hundreds of joints slide the iteration can stall at round-off near 1e-9.
    #[serde(default = "default_newton_tol")]
    pub newton_tol: f64,
    /// Quasi-static scheme: the most re-solves at the same time after splits in one step
    /// (default 200); reaching it is counted in `summary.json` (`resolve_cap_hits`).
    #[serde(default = "default_max_resolves")]
    pub max_resolves: u64,
    /// Hard cap on the number of steps.
    #[serde(default = "default_max_steps")]
    pub max_steps: u64,
    /// Coupled runs: the most explicit flow sub-steps allowed in one solid step. The flow step
    /// shrinks with the square of the largest aperture; past this cap the run stops with a
    /// message instead of crawling.
    #[serde(default = "default_max_substeps")]
    pub max_substeps: u64,
    /// Nodal mass scaling for static relaxation (only with `end: Static`; default off): each
    /// node's mass becomes R_i dt_crit^2 / 4 with R_i its Gershgorin row sum of the stiffness
    /// (elements and joints), Underwood's fictitious masses for dynamic relaxation, so every
    /// node relaxes at about the rate of the stiffest and the large elements of a graded mesh
    /// stop slowing the relaxation. The step is unchanged and stays stable. The dynamics
    /// change; the static answer (K u = f) does not, since body forces use the true density.
    #[serde(default)]
    pub mass_scaling: bool,
    /// Selective mass scaling for the explicit rock (default off): `Some(f)` lengthens the
    /// critical step f times (f >= 1) by raising the mass of each node whose own Gershgorin
    /// bound 2 sqrt(m_i / g_i) is shorter, to m_i = g_i T^2 / 4 (T the new critical step, s;
    /// g_i the node's row sum of |K|: its elements, and per joint face max(K_n, K_t) plus, in
    /// coupled runs, the fluid's K L / a_r of a full cell at the residual aperture;
    /// `systems::solid::raise_masses`). Other nodes keep their masses. The joints' and the
    /// fluid's springs set the step of a coupled run (on Example II 6x below the elements'),
    /// so up to a factor of about 16 there only the nodes on fracture faces get heavier. The rock's response
    /// to pumping is quasi-static, so added inertia changes it little; how little is measured
    /// on Example II in the README. Body forces keep the true density. `summary.json`
    /// `mass_scaling` reports the nodes raised and the mass added.
    #[serde(default)]
    pub selective_mass_scaling: Option<f64>,
}

/// Default of `time.newton_tol` (the quasi-static solver's `DEFAULT_TOL`).
pub const DEFAULT_NEWTON_TOL: f64 = 1e-10;
/// Default of `time.newton_easy` (the adaptive step's `NEWTON_EASY`).
pub const DEFAULT_NEWTON_EASY: u64 = 4;

fn default_newton_tol() -> f64 {
    DEFAULT_NEWTON_TOL
}
fn default_newton_easy() -> u64 {
    DEFAULT_NEWTON_EASY
}
fn default_max_resolves() -> u64 {
    200
}

fn default_max_substeps() -> u64 {
    100_000
}

/// Time integration of the network flow (see [`TimeControl::flow_scheme`]).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum FlowScheme {
    /// Forward Euler sub-steps below the explicit stability bound.
    #[default]
    Explicit,
    /// One backward-Euler step per step (unconditionally stable, first order in time).
    Implicit,
}

/// The quasi-static Newton direction's linear algebra (`time.linear_solver`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum LinearSolver {
    /// `Lu` when more than 32 joints slide or more than 200 fracture cells load the rock
    /// (`systems::quasi_static::LU_MIN_SLIDING`, `LU_MIN_CELLS`), else `Cholesky`.
    #[default]
    Auto,
    /// The symmetric tangent by sparse Cholesky (kept while the contact states are), the
    /// sliding joints' Coulomb term by Sherman-Morrison-Woodbury (one solve per sliding
    /// joint), coupled steps reduced to the cells through W = K_T^-1 G (one solve per cell
    /// and factor, a dense cells x cells LU).
    Cholesky,
    /// The full unsymmetric Newton matrix, rock and cells together, with the exact joint
    /// tangent, by sparse LU every iteration (`systems::quasi_static_lu`).
    Lu,
}

/// Time integration of the rock (see [`TimeControl::solid_scheme`]).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum SolidScheme {
    /// Central difference, damped for pseudo-static response (the seed's).
    #[default]
    Explicit,
    /// Static equilibrium per step.
    QuasiStatic,
}

fn default_safety() -> f64 {
    0.9
}
fn default_max_steps() -> u64 {
    10_000_000
}

/// When a run ends.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum End {
    /// After this simulated time, s.
    Time(f64),
    /// When the static residual ||unbalanced force on free dofs|| / ||internal force|| drops
    /// below `tol` (checked after at least `min_steps` steps).
    Static {
        tol: f64,
        #[serde(default = "default_min_steps")]
        min_steps: u64,
    },
    /// Flow-only scenes: solve the incompressible steady state of the network directly (sparse
    /// Cholesky), no time stepping. Pressure and rate boundaries only.
    SteadyDirect,
}

fn default_min_steps() -> u64 {
    10
}

/// Damping for pseudo-static response.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Damping {
    /// Undamped central difference (energy-conserving dynamics).
    None,
    /// Local non-viscous damping (Cundall): each force component is reduced by
    /// `alpha * |F| * sign(v)`, 0 <= alpha < 1. Does not change the static solution and needs
    /// no frequency; the usual choice for dynamic relaxation. Default 0.8.
    Local(f64),
    /// Mass-proportional viscous damping with coefficient c, 1/s (force -c m v).
    Viscous(f64),
}

impl Default for Damping {
    fn default() -> Self {
        Damping::Local(0.8)
    }
}

/// Longest run name, characters: a folder name every file system takes.
pub const MAX_NAME_LEN: usize = 100;

/// The run name is the default output folder `out/<name>`, so it must be one safe folder name:
/// 1 to [`MAX_NAME_LEN`] ASCII letters, digits, `-`, `_` or `.`, not starting with `.` (no
/// `..`, no hidden folder), no path separator, not absolute. Another folder is chosen with
/// `--out`, not through the name.
pub fn check_run_name(name: &str) -> Result<(), SetupError> {
    let why = if name.is_empty() {
        Some("it is empty".to_string())
    } else if name.len() > MAX_NAME_LEN {
        Some(format!("it is longer than {MAX_NAME_LEN} characters"))
    } else if name.starts_with('.') {
        Some("it starts with `.` (`..` and hidden folders are not allowed)".to_string())
    } else {
        name.chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
            .map(|c| {
                if c == '/' || c == '\\' {
                    format!("it contains the path separator {c:?}")
                } else {
                    format!("it contains {c:?}")
                }
            })
    };
    match why {
        None => Ok(()),
        Some(why) => Err(SetupError::invalid(
            "name",
            format!(
                "{name:?} is the default output folder out/<name>, so it must be a plain folder \
                 name of ASCII letters, digits, `-`, `_` or `.` (not starting with `.`, at most \
                 {MAX_NAME_LEN} characters), but {why}; choose another folder with --out"
            ),
        )),
    }
}

/// Systems switched off for an ablation run (names as in the README's system table).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SystemsSpec {
    #[serde(default)]
    pub disable: Vec<String>,
}

/// What is written and how often.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// A ParaView frame every this many steps (0: only the first and last frames).
    #[serde(default)]
    pub frame_every: u64,
    /// A `timeseries.csv` row every this many steps (>= 1).
    #[serde(default = "default_series_every")]
    pub series_every: u64,
    /// Nodal and element fields written to the frames.
    #[serde(default = "default_fields")]
    pub fields: Vec<Field>,
    /// Coupled runs: simulated times, s, at which `fractures_pressure_t<time>s.png` is written
    /// (the mesh with the fractures' apertures magnified 20x, coloured by fluid pressure, like
    /// the seed's Fig. 7). The same figure is always written at the end of the run.
    #[serde(default)]
    pub figure_times: Vec<f64>,
    /// Write a restart checkpoint (`checkpoint.ckpt` in the output folder, the one before kept
    /// as `checkpoint.prev.ckpt`) every this many steps or simulated seconds; `None`: never.
    /// A run stopped by SIGINT/SIGTERM writes one too when this is set. `hydrofrac run
    /// SCENARIO --restart FILE` continues from it ([`crate::checkpoint`]).
    #[serde(default)]
    pub checkpoint_every: Option<CheckpointEvery>,
}

/// How often a checkpoint is written.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub enum CheckpointEvery {
    /// Every this many steps (>= 1).
    Steps(u64),
    /// At the end of the first step that reaches each multiple of this simulated time, s (> 0).
    Time(f64),
}

fn default_series_every() -> u64 {
    100
}
fn default_fields() -> Vec<Field> {
    vec![Field::Displacement, Field::Velocity, Field::Stress]
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            frame_every: 0,
            series_every: default_series_every(),
            fields: default_fields(),
            figure_times: Vec::new(),
            checkpoint_every: None,
        }
    }
}

/// A field in the ParaView frames.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum Field {
    /// Nodal displacement, m.
    Displacement,
    /// Nodal velocity, m/s.
    Velocity,
    /// Element stress sxx, syy, sxy, szz, Pa (tension positive).
    Stress,
}

/// Parse a RON file's text into `T` (a leading byte-order mark is skipped; `Option` fields may
/// be written without `Some`). Errors carry file, line, column and the field path; `what` names
/// the document in the trailing-text error ("unexpected text after the end of the `what`").
pub fn parse_ron<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &str,
    what: &str,
) -> Result<T, SetupError> {
    // A UTF-8 byte-order mark (some Windows editors write one) is not part of the RON.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let opts =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let syntax = |e: ron::error::SpannedError, field: String| SetupError::Syntax {
        file: file.to_string(),
        line: e.span.start.line,
        col: e.span.start.col,
        field,
        msg: e.code.to_string(),
    };
    let mut de = ron::Deserializer::from_str_with_options(text, &opts)
        .map_err(|e| syntax(e, String::new()))?;
    let doc: T = match serde_path_to_error::deserialize(&mut de) {
        Ok(doc) => doc,
        Err(e) => {
            let field = e.path().to_string();
            let spanned = de.span_error(e.into_inner());
            return Err(syntax(spanned, field));
        }
    };
    // Trailing garbage after the document.
    let rest = de.remainder();
    if let Some(pos) = rest.find(|c: char| !c.is_whitespace()) {
        let consumed = &text[..text.len() - rest.len() + pos];
        let line = consumed.matches('\n').count() + 1;
        let col = consumed.len() - consumed.rfind('\n').map_or(0, |i| i + 1) + 1;
        return Err(SetupError::Syntax {
            file: file.to_string(),
            line,
            col,
            field: String::new(),
            msg: format!("unexpected text after the end of the {what}"),
        });
    }
    Ok(doc)
}

impl Scenario {
    /// Read and parse a scenario file, apply `--set` overrides, then validate.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Self, SetupError> {
        let text = std::fs::read_to_string(path).map_err(|source| SetupError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut sc = Self::parse(&text, &path.display().to_string())?;
        // Mesh files are relative to the scenario file.
        if let Some(MeshSpec::Gmsh { file }) = &mut sc.mesh
            && Path::new(file.as_str()).is_relative()
            && let Some(dir) = path.parent()
        {
            *file = dir.join(file.as_str()).display().to_string();
        }
        // So are fracture files.
        if let Some(file) = sc.fracture.as_mut().and_then(|f| f.file.as_mut())
            && Path::new(file.as_str()).is_relative()
            && let Some(dir) = path.parent()
        {
            *file = dir.join(file.as_str()).display().to_string();
        }
        if !overrides.is_empty() {
            sc = sc.with_overrides(overrides)?;
        }
        sc.validate()?;
        Ok(sc)
    }

    /// Parse RON text (a leading byte-order mark is skipped). Errors carry file, line, column
    /// and the field path.
    pub fn parse(text: &str, file: &str) -> Result<Self, SetupError> {
        parse_ron(text, file, "scenario")
    }

    /// Apply `PATH=VALUE` overrides (e.g. `material.young=3e10`, `mesh.h=2`, `damping=None`).
    /// A path steps through enum variants on its own (`mesh.h` reaches `mesh.Regular.h`).
    /// VALUE is read as JSON (numbers, `true`, `null`, `[1, 2]`) and otherwise as a string
    /// (so unit variants such as `None` work).
    pub fn with_overrides(&self, overrides: &[String]) -> Result<Self, SetupError> {
        let mut root = serde_json::to_value(self).map_err(|e| SetupError::Override {
            spec: String::new(),
            why: e.to_string(),
        })?;
        let original = root.clone();
        // The `None` values set: (the path as messages name it, its JSON pointer in `root`).
        let mut nones: Vec<(String, String)> = Vec::new();
        for spec in overrides {
            let err = |why: String| SetupError::Override {
                spec: spec.clone(),
                why,
            };
            let (path, value) = spec
                .split_once('=')
                .ok_or_else(|| err("expected PATH=VALUE".into()))?;
            let value = override_value(value.trim());
            let mut node = &mut root;
            let mut pointer = String::new();
            let keys: Vec<&str> = path.trim().split('.').collect();
            for (k, key) in keys.iter().enumerate() {
                // Step into an enum variant wrapper ({"Regular": {...}}) when the key is not here.
                loop {
                    let obj = node
                        .as_object()
                        .ok_or_else(|| err(format!("`{}` is not a table", keys[..k].join("."))))?;
                    if obj.contains_key(*key) || obj.len() != 1 {
                        break;
                    }
                    let only = obj.keys().next().cloned().unwrap_or_default();
                    if !only.starts_with(|c: char| c.is_ascii_uppercase())
                        || !node[&only].is_object()
                    {
                        break;
                    }
                    pointer = format!("{pointer}/{only}");
                    node = node.get_mut(&only).expect("key exists");
                }
                let obj = node
                    .as_object_mut()
                    .ok_or_else(|| err(format!("`{}` is not a table", keys[..k].join("."))))?;
                if !obj.contains_key(*key) {
                    let mut valid: Vec<&String> = obj.keys().collect();
                    valid.sort();
                    let valid: Vec<String> = valid.into_iter().cloned().collect();
                    return Err(err(format!(
                        "no field `{key}` here; fields: {}",
                        valid.join(", ")
                    )));
                }
                pointer = format!("{pointer}/{key}");
                node = obj.get_mut(*key).expect("key exists");
            }
            *node = value;
            if node.as_str() == Some("None") {
                nones.push((keys.join("."), pointer));
            }
        }
        // `None` is a unit variant for an enum (`damping=None`) and null for an optional
        // field (`production=None`, as RON writes it): a `None` the reading fails at is read
        // again as null.
        let first = serde_path_to_error::deserialize::<_, Scenario>(root.clone());
        let mut at = first
            .as_ref()
            .err()
            .map(|e| display_path(&e.path().to_string()));
        let mut retry = root;
        while let Some(path) = at.take() {
            let Some(k) = nones.iter().position(|(p, _)| *p == path) else {
                break;
            };
            if let Some(n) = retry.pointer_mut(&nones.swap_remove(k).1) {
                *n = serde_json::Value::Null;
            }
            match serde_path_to_error::deserialize::<_, Scenario>(retry.clone()) {
                Ok(sc) => return Ok(sc),
                Err(e) => at = Some(display_path(&e.path().to_string())),
            }
        }
        first.map_err(|e| {
            // The overrides travel through JSON, which has no NaN or infinity: a non-finite
            // number of the file comes back as `null` and fails here, though no override is to
            // blame. When the file's own values fail at the same field, say so.
            let path = e.path().to_string();
            let from_file = serde_path_to_error::deserialize::<_, Scenario>(original)
                .err()
                .is_some_and(|o| o.path().to_string() == path);
            if from_file {
                SetupError::invalid(
                    &display_path(&path),
                    "is not a finite number (NaN or inf in the scenario file)",
                )
            } else {
                SetupError::Override {
                    spec: overrides.join(" "),
                    why: format!("field `{path}`: {}", e.inner()),
                }
            }
        })
    }

    /// Check physical sense; the first problem is reported with the field and the reason.
    pub fn validate(&self) -> Result<(), SetupError> {
        let finite = |field: &str, v: f64| -> Result<(), SetupError> {
            if v.is_finite() {
                Ok(())
            } else {
                Err(SetupError::invalid(
                    field,
                    format!("{v} is not a finite number"),
                ))
            }
        };
        let positive = |field: &str, v: f64, what: &str| -> Result<(), SetupError> {
            finite(field, v)?;
            if v > 0.0 {
                Ok(())
            } else {
                Err(SetupError::invalid(
                    field,
                    format!("{what} must be > 0, got {v}"),
                ))
            }
        };
        check_run_name(&self.name)?;
        // Mesh.
        if let Some(mesh) = &self.mesh
            && let (Some((w, hgt)), Some(h)) = (mesh.size(), mesh.h())
        {
            positive("mesh.width", w, "the domain width")?;
            positive("mesh.height", hgt, "the domain height")?;
            positive("mesh.h", h, "the cell size")?;
            if h >= w.min(hgt) {
                return Err(SetupError::invalid(
                    "mesh.h",
                    format!(
                        "the cell size {h} m must be smaller than the domain ({w} m x {hgt} m)"
                    ),
                ));
            }
            let origin = match *mesh {
                MeshSpec::Regular { origin, .. }
                | MeshSpec::Perturbed { origin, .. }
                | MeshSpec::Graded { origin, .. }
                | MeshSpec::Conforming { origin, .. } => origin,
                MeshSpec::Gmsh { .. } => [0.0; 2],
            };
            finite("mesh.origin", origin[0])?;
            finite("mesh.origin", origin[1])?;
            finite("mesh.origin", origin[0] + w)?;
            finite("mesh.origin", origin[1] + hgt)?;
            // Node coordinates must resolve the cells: far from 0 (1e308, or 1e12 with h = 1 mm)
            // neighbouring nodes round to the same position.
            let far = [origin[0], origin[1], origin[0] + w, origin[1] + hgt]
                .iter()
                .fold(0.0f64, |m, x| m.max(x.abs()));
            if far * 1e-10 > h {
                return Err(SetupError::invalid(
                    "mesh.origin",
                    format!(
                        "coordinates up to {far:e} m cannot resolve cells of h = {h} m in double \
                         precision; move the origin nearer 0"
                    ),
                ));
            }
            if let MeshSpec::Graded { fine, ratio, .. } = *mesh {
                finite("mesh.ratio", ratio)?;
                if !(1.0..=10.0).contains(&ratio) {
                    return Err(SetupError::invalid(
                        "mesh.ratio",
                        format!(
                            "the growth ratio of the cells must be in [1, 10] (1: uniform), \
                             got {ratio}"
                        ),
                    ));
                }
                for v in fine {
                    finite("mesh.fine", v)?;
                }
                let (x1, y1) = (origin[0] + w, origin[1] + hgt);
                let tol = 1e-9 * w.max(hgt);
                if !(fine[0] < fine[2] && fine[1] < fine[3]) {
                    return Err(SetupError::invalid(
                        "mesh.fine",
                        format!(
                            "the fine box (x0, y0, x1, y1) = {fine:?} m needs x0 < x1 and y0 < y1"
                        ),
                    ));
                }
                if fine[0] < origin[0] - tol
                    || fine[1] < origin[1] - tol
                    || fine[2] > x1 + tol
                    || fine[3] > y1 + tol
                {
                    return Err(SetupError::invalid(
                        "mesh.fine",
                        format!(
                            "the fine box {fine:?} m is not inside the domain [{}, {}, {x1}, {y1}] m",
                            origin[0], origin[1]
                        ),
                    ));
                }
            }
            let cells = mesh.counts().map_or(0.0, |c| c.triangles);
            if cells > 5.0e7 {
                return Err(SetupError::invalid(
                    "mesh.h",
                    format!("{cells:.3e} triangles is more than this engine's 5e7 limit"),
                ));
            }
            if let MeshSpec::Conforming {
                h,
                h_far,
                min_angle_deg,
                merge,
                grading,
                ..
            } = *mesh
            {
                if let MeshSpec::Conforming { follow, .. } = mesh {
                    for (i, f) in follow.iter().enumerate() {
                        for v in [f.from[0], f.from[1], f.to[0], f.to[1]] {
                            finite(&format!("mesh.follow[{i}]"), v)?;
                        }
                    }
                }
                finite("mesh.grading", grading)?;
                if !(0.01..=2.0).contains(&grading) {
                    return Err(SetupError::invalid(
                        "mesh.grading",
                        format!(
                            "the growth of the cell size with the distance from the fractures \
                             must be in [0.01, 2] (m per m), got {grading}"
                        ),
                    ));
                }
                if let Some(hf) = h_far {
                    finite("mesh.h_far", hf)?;
                    if hf < h || hf > w.max(hgt) {
                        return Err(SetupError::invalid(
                            "mesh.h_far",
                            format!(
                                "the far cell size must be between h = {h} m and the domain's \
                                 larger side ({} m), got {hf} m",
                                w.max(hgt)
                            ),
                        ));
                    }
                }
                finite("mesh.min_angle_deg", min_angle_deg)?;
                if !(min_angle_deg > 0.0 && min_angle_deg <= 33.0) {
                    return Err(SetupError::invalid(
                        "mesh.min_angle_deg",
                        format!(
                            "the smallest angle asked of the refinement must be in (0, 33] \
                             degrees (above about 30 Delaunay refinement need not end), got \
                             {min_angle_deg}"
                        ),
                    ));
                }
                finite("mesh.merge", merge)?;
                if !(0.0..=0.5).contains(&merge) {
                    return Err(SetupError::invalid(
                        "mesh.merge",
                        format!(
                            "the merge distance must be in [0, 0.5] of h (points closer than \
                             merge * h become one), got {merge}"
                        ),
                    ));
                }
            }
            if let MeshSpec::Perturbed { fraction, .. } = *mesh {
                finite("mesh.fraction", fraction)?;
                if !(0.0..=0.3).contains(&fraction) {
                    return Err(SetupError::invalid(
                        "mesh.fraction",
                        format!("the perturbation must be in [0, 0.3] of h, got {fraction}"),
                    ));
                }
            }
        }
        // Material.
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
        if let Some(m) = &self.material {
            positive("material.young", m.young, "Young's modulus")?;
            positive("material.density", m.density, "the density")?;
            // Upper bounds far above any rock (diamond: E 1.2e12 Pa; osmium: 22,600 kg/m^3),
            // so the energies and stresses (E u, rho v^2 A) stay finite: a density of 1e308
            // made the kinetic energy inf * 0 = NaN (the fuzzer's finding, kept in
            // tests/fuzz_regressions/).
            if m.young > MAX_YOUNG {
                return Err(SetupError::invalid(
                    "material.young",
                    format!(
                        "{:e} Pa is above {MAX_YOUNG:e} Pa (diamond is 1.2e12 Pa): energies \
                         and stresses would overflow",
                        m.young
                    ),
                ));
            }
            if m.density > MAX_DENSITY {
                return Err(SetupError::invalid(
                    "material.density",
                    format!(
                        "{:e} kg/m^3 is above {MAX_DENSITY:e} kg/m^3 (rock is 2,000-3,500; \
                         room is left for mass scaling): the kinetic energy would overflow",
                        m.density
                    ),
                ));
            }
            finite("material.poisson", m.poisson)?;
            if !(0.0..0.5).contains(&m.poisson) {
                return Err(SetupError::invalid(
                    "material.poisson",
                    format!(
                        "Poisson's ratio must be in [0, 0.5) (0.5 is incompressible and not representable \
                     by plane-strain CST), got {}",
                        m.poisson
                    ),
                ));
            }
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
        }
        // Boundary.
        match &self.boundary {
            Boundary::InSitu { sxx, syy } => {
                finite("boundary.sxx", *sxx)?;
                finite("boundary.syy", *syy)?;
            }
            Boundary::Sides {
                left,
                right,
                bottom,
                top,
            } => {
                for (name, bc) in [
                    ("left", left),
                    ("right", right),
                    ("bottom", bottom),
                    ("top", top),
                ] {
                    match bc {
                        SideBc::Normal(d) => finite(&format!("boundary.{name}"), *d)?,
                        SideBc::Traction { normal, shear } => {
                            finite(&format!("boundary.{name}.normal"), *normal)?;
                            finite(&format!("boundary.{name}.shear"), *shear)?;
                        }
                        SideBc::Free | SideBc::Fixed => {}
                    }
                }
            }
        }
        for (i, pin) in self.pins.iter().enumerate() {
            let field = format!("pins[{i}]");
            for v in [
                pin.at[0],
                pin.at[1],
                pin.ux.unwrap_or(0.0),
                pin.uy.unwrap_or(0.0),
            ] {
                finite(&field, v)?;
            }
            if pin.ux.is_none() && pin.uy.is_none() {
                return Err(SetupError::invalid(&field, "prescribes neither ux nor uy"));
            }
        }
        // Time.
        let t = &self.time;
        finite("time.safety", t.safety)?;
        if !(t.safety > 0.0 && t.safety <= 1.0) {
            return Err(SetupError::invalid(
                "time.safety",
                format!("the safety factor must be in (0, 1], got {}", t.safety),
            ));
        }
        if let Some(dt) = t.dt {
            positive("time.dt", dt, "the time step")?;
        }
        if let Some(dt) = t.dt_max {
            positive("time.dt_max", dt, "the longest adaptive step")?;
        }
        if let Some(dt) = t.dt_min {
            positive("time.dt_min", dt, "the shortest adaptive step")?;
            if t.dt_max.is_some_and(|m| m < dt) {
                return Err(SetupError::invalid(
                    "time.dt_min",
                    "must not exceed time.dt_max",
                ));
            }
        }
        if t.max_resolves == 0 {
            return Err(SetupError::invalid("time.max_resolves", "must be >= 1"));
        }
        if !(t.newton_tol >= 1e-14 && t.newton_tol <= 1e-3) {
            return Err(SetupError::invalid(
                "time.newton_tol",
                format!(
                    "{} is not in [1e-14, 1e-3] (a relative residual: below 1e-14 round-off \
                     cannot reach it, above 1e-3 the rock is not in equilibrium)",
                    t.newton_tol
                ),
            ));
        }
        if !(1..=20).contains(&t.newton_easy) {
            return Err(SetupError::invalid(
                "time.newton_easy",
                format!(
                    "{} is not in 1..=20 (three times it must stay below the cap on Newton \
                     iterations of a step)",
                    t.newton_easy
                ),
            ));
        }
        if let Some(dt) = t.flow_dt {
            positive("time.flow_dt", dt, "the flow step")?;
            if t.flow_scheme == FlowScheme::Implicit && self.mesh.is_some() {
                return Err(SetupError::invalid(
                    "time.flow_dt",
                    "the implicit flow scheme takes one flow step per solid step; \
                     set time.dt instead",
                ));
            }
        }
        if t.max_steps == 0 {
            return Err(SetupError::invalid("time.max_steps", "must be at least 1"));
        }
        if t.solid_scheme == SolidScheme::QuasiStatic {
            let why = if self.mesh.is_none() {
                Some("needs a rock mesh")
            } else if self.network.is_some() {
                Some("couples with the rock's own fractures, not with a separate network")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(SetupError::invalid(
                    "time.solid_scheme",
                    format!("QuasiStatic {why}"),
                ));
            }
        }
        if let Some(f) = t.selective_mass_scaling {
            if !(f.is_finite() && f >= 1.0) {
                return Err(SetupError::invalid(
                    "time.selective_mass_scaling",
                    format!("{f} is not a factor of at least 1 on the critical step"),
                ));
            }
            let why = if t.mass_scaling {
                Some("and time.mass_scaling both set the masses: choose one")
            } else if t.solid_scheme == SolidScheme::QuasiStatic {
                Some("lengthens the explicit step: the quasi-static scheme has no masses")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(SetupError::invalid("time.selective_mass_scaling", why));
            }
        }
        if t.mass_scaling && !matches!(t.end, End::Static { .. }) {
            return Err(SetupError::invalid(
                "time.mass_scaling",
                "changes the dynamics: only for static relaxation (end: Static)",
            ));
        }
        match t.end {
            End::Time(te) => positive("time.end", te, "the end time")?,
            End::Static { tol, min_steps } => {
                positive("time.end.tol", tol, "the residual tolerance")?;
                if min_steps > t.max_steps {
                    return Err(SetupError::invalid(
                        "time.end.min_steps",
                        format!(
                            "{min_steps} steps before the residual is checked (default 10) is \
                             more than time.max_steps = {}: the run could never converge; lower \
                             time.end.min_steps or raise time.max_steps",
                            t.max_steps
                        ),
                    ));
                }
            }
            End::SteadyDirect => {
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
            }
        }
        // Damping.
        match self.damping {
            Damping::Local(a) => {
                finite("damping", a)?;
                if !(0.0..1.0).contains(&a) {
                    return Err(SetupError::invalid(
                        "damping",
                        format!("local damping must be in [0, 1), got {a}"),
                    ));
                }
            }
            Damping::Viscous(c) => {
                finite("damping", c)?;
                if c < 0.0 {
                    return Err(SetupError::invalid(
                        "damping",
                        format!("viscous damping must be >= 0, got {c}"),
                    ));
                }
            }
            Damping::None => {}
        }
        if let Some(g) = self.gravity {
            finite("gravity", g[0])?;
            finite("gravity", g[1])?;
        }
        for (k, w) in self.boundary_schedule.windows(2).enumerate() {
            if w[1].0 < w[0].0 || w[1].0.is_nan() {
                return Err(SetupError::invalid(
                    &format!("boundary_schedule[{}]", k + 1),
                    "times must not decrease",
                ));
            }
        }
        for (t, f) in &self.boundary_schedule {
            finite("boundary_schedule", *t)?;
            finite("boundary_schedule", *f)?;
        }
        if let Some(f) = &self.fracture {
            if let Some(st) = f.strength {
                // May be negative: a criterion calibrated at mesh size h under a confining
                // stress s0 is lambda*T0 = c K_Ic / sqrt(h) - s0 (see scenarios/kgd.ron).
                finite("fracture.strength", st)?;
            }
            match f.criterion {
                Some(_) if f.strength.is_some() => {
                    return Err(SetupError::invalid(
                        "fracture.criterion",
                        "give either fracture.strength or fracture.criterion, not both",
                    ));
                }
                Some(CriterionSpec::Strength(st)) => finite("fracture.criterion", st)?,
                Some(CriterionSpec::Toughness { k_ic, initiation }) => {
                    finite("fracture.criterion.k_ic", k_ic)?;
                    if k_ic < 0.0 {
                        return Err(SetupError::invalid(
                            "fracture.criterion.k_ic",
                            format!("the fracture toughness must be >= 0 Pa sqrt(m), got {k_ic}"),
                        ));
                    }
                    if let Some(st) = initiation {
                        finite("fracture.criterion.initiation", st)?;
                    }
                }
                None => {}
            }
            positive(
                "fracture.residual_aperture",
                f.residual_aperture,
                "the residual aperture",
            )?;
            if let Some(p) = f.pressure {
                finite("fracture.pressure", p)?;
            }
            finite("fracture.friction_deg", f.friction_deg)?;
            if !(0.0..90.0).contains(&f.friction_deg) {
                return Err(SetupError::invalid(
                    "fracture.friction_deg",
                    format!(
                        "the joint friction angle must be in [0, 90) degrees, got {}",
                        f.friction_deg
                    ),
                ));
            }
            if let Some(k) = f.normal_stiffness {
                positive("fracture.normal_stiffness", k, "the joint normal stiffness")?;
            }
            if let Some(k) = f.shear_stiffness {
                positive("fracture.shear_stiffness", k, "the joint shear stiffness")?;
            }
            for (i, pf) in f.preexisting.iter().enumerate() {
                for v in [pf.from[0], pf.from[1], pf.to[0], pf.to[1]] {
                    finite(&format!("fracture.preexisting[{i}]"), v)?;
                }
            }
            if let Some(r) = &f.random {
                r.validate("fracture.random")?;
            }
            if self.mesh.is_none() {
                return Err(SetupError::invalid(
                    "fracture",
                    "the fracture criterion needs a solid mesh",
                ));
            }
        }
        // Network and fluid.
        if let Some(n) = &self.network {
            n.validate()?;
        }
        let fl = &self.fluid;
        positive("fluid.viscosity", fl.viscosity, "the viscosity")?;
        positive("fluid.bulk_modulus", fl.bulk_modulus, "the bulk modulus")?;
        positive("fluid.density", fl.density, "the reference density")?;
        if let InitialFluid::Full(p) = self.initial_fluid {
            finite("initial_fluid", p)?;
            if p < 0.0 {
                return Err(SetupError::invalid(
                    "initial_fluid",
                    format!("pressure must be >= 0, got {p}"),
                ));
            }
        }
        let rock_fractures = self.mesh.is_some()
            && self.fracture.as_ref().is_some_and(|f| {
                !f.preexisting.is_empty() || f.random.is_some() || f.file.is_some()
            });
        if !self.flow_boundaries.is_empty() && self.network.is_none() && !rock_fractures {
            return Err(SetupError::invalid(
                "flow_boundaries",
                "there is no fracture network to act on (give a `network`, or a mesh with \
                 `fracture.preexisting` fractures for a coupled run)",
            ));
        }
        if let Some(prod) = &self.production {
            prod.validate()?;
            if !rock_fractures || self.flow_boundaries.is_empty() {
                return Err(SetupError::invalid(
                    "production",
                    "production needs a coupled run: a mesh with pre-existing fractures \
                     (`fracture.preexisting`, `fracture.random` or `fracture.file`) and flow \
                     boundaries",
                ));
            }
        }
        if self.mesh.is_some() && self.network.is_some() {
            return Err(SetupError::invalid(
                "network",
                "a rigid network cannot be combined with a mesh: in a coupled run the network is \
                 the rock's fractures (`fracture.preexisting` and those the run opens)",
            ));
        }
        if self.initial_state == InitialState::InSitu
            && !matches!(self.boundary, Boundary::InSitu { .. })
        {
            return Err(SetupError::invalid(
                "initial_state",
                "InSitu starts from the homogeneous in-situ field: it needs `boundary: InSitu(..)`",
            ));
        }
        if self.time.max_substeps == 0 {
            return Err(SetupError::invalid("time.max_substeps", "must be >= 1"));
        }
        for (i, b) in self.flow_boundaries.iter().enumerate() {
            let field = format!("flow_boundaries[{i}]");
            let (FlowTarget::Node(p) | FlowTarget::Cell(p)) = b.at;
            finite(&format!("{field}.at"), p[0])?;
            finite(&format!("{field}.at"), p[1])?;
            match b.kind {
                FlowBcKind::Pressure(v) | FlowBcKind::Rate(v) => {
                    finite(&format!("{field}.kind"), v)?
                }
                FlowBcKind::Pump { p_max, q_half } => {
                    positive(
                        &format!("{field}.kind.p_max"),
                        p_max,
                        "the pump's maximum pressure",
                    )?;
                    positive(
                        &format!("{field}.kind.q_half"),
                        q_half,
                        "the pump's half-pressure rate",
                    )?;
                }
            }
            for (k, w) in b.schedule.windows(2).enumerate() {
                if w[1].0 < w[0].0 || w[1].0.is_nan() {
                    return Err(SetupError::invalid(
                        &format!("{field}.schedule[{}]", k + 1),
                        "times must not decrease",
                    ));
                }
            }
            for (t, f) in &b.schedule {
                finite(&format!("{field}.schedule"), *t)?;
                finite(&format!("{field}.schedule"), *f)?;
            }
        }
        let mut names: Vec<(String, usize)> = Vec::new();
        for (i, b) in self.flow_boundaries.iter().enumerate() {
            let name = if b.name.is_empty() {
                format!("bc{i}")
            } else {
                b.name.clone()
            };
            if let Some((_, j)) = names.iter().find(|(n, _)| *n == name) {
                return Err(SetupError::invalid(
                    &format!("flow_boundaries[{i}].name"),
                    format!(
                        "{name:?} is also the name of flow_boundaries[{j}] (unnamed ones are \
                         bc<index>); names label the outputs and must differ"
                    ),
                ));
            }
            names.push((name, i));
        }
        for (k, &tf) in self.output.figure_times.iter().enumerate() {
            let field = format!("output.figure_times[{k}]");
            finite(&field, tf)?;
            if tf < 0.0 {
                return Err(SetupError::invalid(
                    &field,
                    format!("a figure time must be >= 0 s, got {tf}"),
                ));
            }
        }
        if self.output.series_every == 0 {
            return Err(SetupError::invalid(
                "output.series_every",
                "must be at least 1",
            ));
        }
        match self.output.checkpoint_every {
            Some(CheckpointEvery::Steps(0)) => {
                return Err(SetupError::invalid(
                    "output.checkpoint_every",
                    "Steps must be at least 1",
                ));
            }
            Some(CheckpointEvery::Time(t)) => {
                finite("output.checkpoint_every", t)?;
                if t <= 0.0 {
                    return Err(SetupError::invalid(
                        "output.checkpoint_every",
                        format!("Time must be > 0 s, got {t}"),
                    ));
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// A serde path as the scenario's fields are named in messages: enum variant wrappers left out
/// (`mesh.Graded.ratio` is `mesh.ratio`, as `--set` and the validation name it).
fn display_path(path: &str) -> String {
    path.split('.')
        .filter(|k| !k.starts_with(|c: char| c.is_ascii_uppercase()))
        .collect::<Vec<_>>()
        .join(".")
}

/// Read an override VALUE: JSON (`3e10`, `true`, `[1, 2]`, `{"Time": 5.0}`), a newtype or
/// struct variant written as in RON (`Local(0.5)`, `Time(5.0)`, `Regular(width: 10.0, height:
/// 10.0, h: 1.0)`), an optional value (`Some(6.0)`, `Some(Local(0.5))`), or else a plain
/// string (unit variants: `None`).
fn override_value(text: &str) -> serde_json::Value {
    if let Ok(v) = serde_json::from_str(text) {
        return v;
    }
    if let Some((name, rest)) = text.split_once('(')
        && let Some(inner) = rest.strip_suffix(')')
        && name.starts_with(|c: char| c.is_ascii_uppercase())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    {
        // An optional value as RON writes it (`Some(6.0)`): JSON has no wrapper.
        if name == "Some" {
            return override_value(inner.trim());
        }
        // A struct variant's fields (`Conforming(width: 100.0, h: 2.0, ...)`) as a table.
        let fields = match ron::from_str::<ron::Value>(&format!("({inner})")) {
            Ok(v @ ron::Value::Map(_)) if inner.contains(':') => serde_json::to_value(v).ok(),
            _ => None,
        };
        let mut obj = serde_json::Map::new();
        obj.insert(
            name.to_string(),
            fields.unwrap_or_else(|| override_value(inner.trim())),
        );
        return serde_json::Value::Object(obj);
    }
    serde_json::Value::String(text.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"(
        name: "t",
        mesh: Regular(width: 10.0, height: 10.0, h: 1.0),
        material: (young: 20e9, poisson: 0.2, density: 2700.0),
        boundary: InSitu(sxx: -20e6, syy: -10e6),
        time: (end: Static(tol: 1e-8)),
    )"#;

    #[test]
    fn parses_and_validates() {
        let sc = Scenario::parse(GOOD, "good.ron").unwrap();
        sc.validate().unwrap();
        assert_eq!(sc.time.safety, 0.9);
        assert_eq!(sc.damping, Damping::Local(0.8));
    }

    #[test]
    fn unknown_field_names_line_column_and_field() {
        let bad = GOOD.replace("density: 2700.0", "density: 2700.0, colour: 1.0");
        let e = Scenario::parse(&bad, "bad.ron").unwrap_err().to_string();
        assert!(e.starts_with("bad.ron:4:"), "{e}");
        assert!(e.contains("colour"), "{e}");
    }

    #[test]
    fn wrong_type_names_the_field() {
        let bad = GOOD.replace("poisson: 0.2", "poisson: \"x\"");
        let e = Scenario::parse(&bad, "bad.ron").unwrap_err().to_string();
        assert!(e.starts_with("bad.ron:4:"), "{e}");
        assert!(e.contains("material.poisson"), "{e}");
    }

    #[test]
    fn non_physical_values_are_named() {
        for (from, to, field) in [
            ("poisson: 0.2", "poisson: 0.5", "material.poisson"),
            ("young: 20e9", "young: -1.0", "material.young"),
            ("young: 20e9", "young: 1e15", "material.young"),
            ("density: 2700.0", "density: 1e308", "material.density"),
            (
                "tol: 1e-8)",
                "tol: 1e-8), newton_easy: 0",
                "time.newton_easy",
            ),
            (
                "tol: 1e-8)",
                "tol: 1e-8), newton_easy: 21",
                "time.newton_easy",
            ),
            (
                "tol: 1e-8)",
                "tol: 1e-8), newton_tol: 1e-2",
                "time.newton_tol",
            ),
            (
                "tol: 1e-8)",
                "tol: 1e-8), newton_tol: NaN",
                "time.newton_tol",
            ),
            ("h: 1.0", "h: 20.0", "mesh.h"),
        ] {
            let sc = Scenario::parse(&GOOD.replace(from, to), "x.ron").unwrap();
            let e = sc.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }

    /// Poisson's ratio above `MAX_COUPLED_POISSON` is refused for a coupled run only (the
    /// seed's fluid volume does not bound its pressure there; README "Reliability"), naming the
    /// field, the limit and the reason; the same rock without flow is accepted up to 0.5.
    #[test]
    fn coupled_runs_refuse_a_nearly_incompressible_rock() {
        let coupled = GOOD.replace(
            "time: (end",
            "fracture: Some((preexisting: [(from: (0.0, 5.0), to: (3.0, 5.0))])),\n        \
             flow_boundaries: [(name: \"pump\", at: Node((0.0, 5.0)), \
             kind: Pump(p_max: 18e6, q_half: 2.0))],\n        time: (end",
        );
        let sc = Scenario::parse(&coupled, "coupled.ron").unwrap();
        sc.validate().unwrap();
        for nu in ["0.48", "0.45", "0"] {
            let o = sc
                .with_overrides(&[format!("material.poisson={nu}")])
                .unwrap();
            o.validate().unwrap();
        }
        for nu in ["0.481", "0.49", "0.499"] {
            let o = sc
                .with_overrides(&[format!("material.poisson={nu}")])
                .unwrap();
            let e = o.validate().unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("invalid material.poisson: {nu} is above 0.48")),
                "{e}"
            );
            assert!(
                e.contains("L max(delta_n, a_r)") && e.contains("p_max") && !e.contains('\n'),
                "{e}"
            );
        }
        // Without flow boundaries (the same fracture, dry) and without fractures: accepted.
        let dry = Scenario::parse(&coupled, "dry.ron")
            .unwrap()
            .with_overrides(&["flow_boundaries=[]".into(), "material.poisson=0.499".into()])
            .unwrap();
        dry.validate().unwrap();
        let plain = Scenario::parse(&GOOD.replace("poisson: 0.2", "poisson: 0.499"), "x.ron");
        plain.unwrap().validate().unwrap();
    }

    /// A byte-order mark before the scenario is skipped (it failed at 1:1).
    #[test]
    fn a_byte_order_mark_is_accepted() {
        let sc = Scenario::parse(&format!("\u{feff}{GOOD}"), "bom.ron").unwrap();
        assert_eq!(sc, Scenario::parse(GOOD, "good.ron").unwrap());
    }

    /// A NaN of the file is reported as the file's value when an override touches another
    /// field (the JSON the overrides go through turns it into `null`), and an override of that
    /// very field replaces it.
    #[test]
    fn a_non_finite_value_of_the_file_is_not_blamed_on_an_override() {
        let sc = Scenario::parse(&GOOD.replace("young: 20e9", "young: NaN"), "nan.ron").unwrap();
        let e = sc
            .with_overrides(&["damping=None".into()])
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("invalid material.young:"), "{e}");
        assert!(e.contains("scenario file"), "{e}");
        let o = sc.with_overrides(&["material.young=3e10".into()]).unwrap();
        assert_eq!(o.material.unwrap().young, 3e10);
        // A bad override (of a field read before: the JSON fields are read in alphabetical
        // order) is still the override's.
        let e = sc
            .with_overrides(&["damping=Wild".into()])
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--set"), "{e}");
    }

    #[test]
    fn overrides_reach_into_variants_and_validate() {
        let sc = Scenario::parse(GOOD, "good.ron").unwrap();
        let o = sc
            .with_overrides(&[
                "material.young=3e10".into(),
                "mesh.h=0.5".into(),
                "damping=None".into(),
            ])
            .unwrap();
        assert_eq!(o.material.unwrap().young, 3e10);
        assert_eq!(o.mesh.as_ref().unwrap().h(), Some(0.5));
        assert_eq!(o.damping, Damping::None);
        let o = sc
            .with_overrides(&["damping=Local(0.5)".into(), "time.end=Time(2.5)".into()])
            .unwrap();
        assert_eq!(o.damping, Damping::Local(0.5));
        assert_eq!(o.time.end, End::Time(2.5));
        // An optional number as RON writes it.
        let o = sc
            .with_overrides(&["time.selective_mass_scaling=Some(4.0)".into()])
            .unwrap();
        assert_eq!(o.time.selective_mass_scaling, Some(4.0));
        // A struct variant in RON's words: the whole mesh replaced.
        let o = sc
            .with_overrides(&[
                "mesh=Conforming(width: 8.0, height: 6.0, h: 0.5, h_far: 2.0)".into(),
            ])
            .unwrap();
        let m = o.mesh.as_ref().unwrap();
        assert_eq!((m.h(), m.kind()), (Some(0.5), "Conforming"));
        // `None` for an optional field, as RON writes it, beside a unit variant `None`.
        let with = Scenario::parse(
            &GOOD.replace(
                "time:",
                "production: Some((wells: (injection: (0.0, 5.0), production: (10.0, 5.0), \
                 production_pressure: 0.0, pressure_drops: [1e6], reach: 1.0))), time:",
            ),
            "p.ron",
        )
        .unwrap();
        assert!(with.production.is_some());
        let o = with
            .with_overrides(&["production=None".into(), "damping=None".into()])
            .unwrap();
        assert!(o.production.is_none());
        assert_eq!(o.damping, Damping::None);
        let e = sc
            .with_overrides(&["material.colour=1".into()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("density") && e.contains("young"), "{e}");
        let e = sc
            .with_overrides(&["material.young=abc".into()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("material.young"), "{e}");
    }
}
