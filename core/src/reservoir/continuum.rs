//! Continuum heat model: single-phase incompressible Darcy flow and heat advection-conduction
//! with local thermal equilibrium on a block permeability field (the seed paper's NUFT role),
//! implicit finite volumes on a [`Grid2`]. Per metre of thickness, SI units.
//!
//! Flow (steady: incompressible fluid, rigid rock, constant properties), per block `i`,
//!
//! ```text
//! sum_f T_f (p_j - p_i) + sum_e T_e (p_e - p_i) + sum_w q_w = 0,
//! ```
//!
//! two-point fluxes with the harmonic face transmissibility `T_f = k_h A / (mu d)` (k_h the
//! harmonic mean of the two blocks' k_xx on an x face, k_yy on a y face, A the face length, d
//! the centre distance), `T_e = k A / (mu d / 2)` to an edge held at pressure `p_e`, and wells:
//! a rate well is a source `q` in its block, a pressure well exchanges `q = WI (p_w - p_i)`
//! with Peaceman's index per unit thickness `WI = 2 pi sqrt(k_xx k_yy) / (mu ln(r_o / r_w))`,
//! `r_o` his equivalent radius of an anisotropic block. Solved once with the sparse Cholesky of
//! [`crate::flow::steady`]. Without any pressure reference (no pressure well, no pressure edge)
//! the rates must balance and block 0 is tied to `initial_pressure` by a connection that
//! carries no flow (to round-off): the pressure level is then `initial_pressure` at block 0.
//!
//! Heat, with `C = phi rho_w c_w + (1 - phi) rho_r c_r` and
//! `lambda = phi lambda_w + (1 - phi) lambda_r` (local thermal equilibrium, arithmetic mixing):
//!
//! ```text
//! C dT/dt + rho_w c_w div(u T) - div(lambda grad T) = rho_w c_w q_inj T_inj + rho_w c_w q_prod T,
//! ```
//!
//! backward Euler in time, first-order upwind advection through each face, two-point
//! conduction. The matrix depends only on dt, so it is factorised once (faer sparse LU, COLAMD,
//! sequential: same bits for any thread count) and every step is one triangular solve. Upwind
//! and backward Euler add a numerical dispersion `v_T dx / 2 + v_T^2 dt / 2` to the thermal
//! diffusivity `lambda / C` (v_T = rho_w c_w u / C the thermal front speed): keep the grid
//! Peclet number `v_T dx / D_T` small where fronts matter.
//!
//! Edges: closed (no flow, insulated) by default, or held at a pressure and a temperature: the
//! edge is then a far field at (p_e, T_e) half a block beyond the edge blocks; inflow carries
//! T_e, outflow the block temperature, and heat conducts to T_e over the half block. Wells:
//! injection (q > 0) enters at `injection_temperature`, production takes the block temperature.
//!
//! Heat is measured relative to the initial temperature T0 (unknown `T - T0`): the stored heat
//! is `sum C V (T - T0)` and the enthalpy fluxes `rho_w c_w Q (T - T0)`. The energy balance of
//! the run compares the stored change with the time integral of the edge and well fluxes.

use super::{Grid2, HeatSeries, ReservoirError, Summation, ThermalProps};
use crate::flow::kahan_add;
use crate::flow::steady::{SteadyProblem, SteadySolver};
use crate::sparse::SparsePattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu};
use faer::{Conj, MatMut, Par};
use serde::{Deserialize, Serialize};

/// Most time steps a run may take.
pub const MAX_STEPS: usize = 10_000_000;
/// Relative tolerance on the sum of the well rates when nothing holds the pressure level.
pub const RATE_BALANCE_TOL: f64 = 1e-12;

/// A continuum heat-extraction problem.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContinuumSpec {
    /// The blocks (m).
    pub grid: Grid2,
    /// Per block `[k_xx, k_yy]`, m^2, in grid order (`i + n[0] j`).
    pub permeability: Vec<[f64; 2]>,
    /// Rock and fluid properties (porosity is the continuum's).
    pub props: ThermalProps,
    /// Uniform initial temperature, K.
    pub initial_temperature: f64,
    /// Pressure level, Pa: the pressure of block 0 when no well or edge holds a pressure (the
    /// flow is steady and incompressible, so it only sets the level).
    #[serde(default)]
    pub initial_pressure: f64,
    /// Injection and production wells (at most one per block).
    #[serde(default)]
    pub wells: Vec<Well>,
    /// The four edges: closed and insulated unless held at a pressure.
    #[serde(default)]
    pub edges: Edges,
    /// Run length, s.
    pub end_time: f64,
    /// Time step, s (the last step is shortened to end at `end_time`).
    pub dt: f64,
    /// Times of the temperature snapshots, s, ascending in [0, end_time]; each is taken at the
    /// first step end at or after it.
    #[serde(default)]
    pub output_times: Vec<f64>,
}

/// A well: a source or sink in the block that contains it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Well {
    /// Label in results and errors.
    pub name: String,
    /// Location, m (inside the grid).
    pub position: [f64; 2],
    /// Rate or pressure control.
    pub control: WellControl,
    /// Temperature of the injected fluid, K (unused while the well produces).
    pub injection_temperature: f64,
    /// Well radius, m, for Peaceman's well index (default 0.1 m); must be below the block's
    /// equivalent radius (about 0.2 dx).
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// How the well index is computed (default: Peaceman's, anisotropic).
    #[serde(default)]
    pub index: WellIndex,
}

/// The well index of a pressure well.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum WellIndex {
    /// Peaceman's anisotropic index, `2 pi sqrt(k_xx k_yy) / (mu ln(r_o / r_w))`: a well in a
    /// homogeneous anisotropic block.
    #[default]
    Peaceman,
    /// A well that intersects the block's fractures: the fractures take the flow to it along
    /// their own direction, so the index is Peaceman's isotropic one with the block's larger
    /// principal permeability. (With the anisotropic index, a block whose fractures all run one
    /// way, k_yy at the matrix value, would choke the well by sqrt(k_xx / k_yy).)
    Fractured,
}

impl Well {
    /// The well's index in a block of permeability `k` and size `dx`, m^2/(Pa s) per metre.
    pub fn index_in(&self, k: [f64; 2], dx: [f64; 2], mu: f64) -> Option<f64> {
        match self.index {
            WellIndex::Peaceman => peaceman_index(k, dx, mu, self.radius),
            WellIndex::Fractured => {
                let m = k[0].max(k[1]);
                peaceman_index([m, m], dx, mu, self.radius)
            }
        }
    }
}

fn default_radius() -> f64 {
    0.1
}

/// How a well is driven.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum WellControl {
    /// Volumetric rate per metre of thickness, m^2/s: > 0 injection, < 0 production.
    Rate(f64),
    /// Bottom-hole pressure, Pa: exchanges `WI (p_w - p_block)` with its block.
    Pressure(f64),
}

/// The condition on one edge of the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum EdgeCondition {
    /// No flow, no conduction.
    #[default]
    Closed,
    /// A far field half a block beyond the edge at `pressure` (Pa) and `temperature` (K):
    /// inflow arrives at `temperature`, heat conducts to it.
    Held { pressure: f64, temperature: f64 },
}

/// The edges of the grid: x = x0 (`left`), x = x1 (`right`), y = y0 (`bottom`), y = y1 (`top`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Edges {
    #[serde(default)]
    pub left: EdgeCondition,
    #[serde(default)]
    pub right: EdgeCondition,
    #[serde(default)]
    pub bottom: EdgeCondition,
    #[serde(default)]
    pub top: EdgeCondition,
}

impl Edges {
    /// The edges in the order left, right, bottom, top with their names.
    pub fn sides(&self) -> [(&'static str, EdgeCondition); 4] {
        [
            ("left", self.left),
            ("right", self.right),
            ("bottom", self.bottom),
            ("top", self.top),
        ]
    }
}

/// Bulk volumetric heat capacity `phi rho_w c_w + (1 - phi) rho_r c_r`, J/(m^3 K).
pub fn bulk_heat_capacity(p: &ThermalProps) -> f64 {
    p.porosity * p.fluid_rho_c() + (1.0 - p.porosity) * p.rock_rho_c()
}

/// Bulk conductivity `phi lambda_w + (1 - phi) lambda_r`, W/(m K).
pub fn bulk_conductivity(p: &ThermalProps) -> f64 {
    p.porosity * p.fluid_conductivity + (1.0 - p.porosity) * p.rock_conductivity
}

/// Peaceman's well index per unit thickness, m^2/(Pa s), of a well of radius `r_w` in a block
/// `dx` with permeability `k` and viscosity `mu`; `None` when `r_w` is not below the
/// equivalent radius `r_o`.
pub fn peaceman_index(k: [f64; 2], dx: [f64; 2], mu: f64, r_w: f64) -> Option<f64> {
    let (a, b) = ((k[1] / k[0]).sqrt(), (k[0] / k[1]).sqrt());
    let r_o = 0.28 * (a * dx[0] * dx[0] + b * dx[1] * dx[1]).sqrt() / (a.sqrt() + b.sqrt());
    (r_w < r_o).then(|| 2.0 * std::f64::consts::PI * (k[0] * k[1]).sqrt() / (mu * (r_o / r_w).ln()))
}

/// The steady Darcy field.
#[derive(Clone, Debug, PartialEq)]
pub struct DarcyField {
    /// Block pressures, Pa.
    pub pressure: Vec<f64>,
    /// Darcy velocity through the x faces, m/s (+x): `(n[0] + 1) * n[1]` faces, face `(i, j)`
    /// (left of block (i, j)) at `i + (n[0] + 1) j`; edge faces included (0 when closed).
    pub velocity_x: Vec<f64>,
    /// Darcy velocity through the y faces, m/s (+y): `n[0] * (n[1] + 1)`, face `(i, j)` (below
    /// block (i, j)) at `i + n[0] j`.
    pub velocity_y: Vec<f64>,
    /// Per well, in spec order.
    pub wells: Vec<WellFlow>,
    /// Largest |net volumetric inflow| of a block over the largest face, edge or well flow:
    /// the steady mass balance.
    pub mass_balance: f64,
}

/// One well's steady flow.
#[derive(Clone, Debug, PartialEq)]
pub struct WellFlow {
    pub name: String,
    /// Block index.
    pub block: usize,
    /// Rate into the reservoir, m^2/s (> 0 injects).
    pub rate: f64,
    /// Bottom-hole pressure, Pa (Peaceman's index for rate wells).
    pub bottom_hole_pressure: f64,
}

impl DarcyField {
    /// Block-centred Darcy velocity (mean of the two opposite faces), m/s.
    pub fn block_velocity(&self, grid: &Grid2, i: usize, j: usize) -> [f64; 2] {
        let nx = grid.n[0];
        let fx = i + (nx + 1) * j;
        let fy = i + nx * j;
        [
            0.5 * (self.velocity_x[fx] + self.velocity_x[fx + 1]),
            0.5 * (self.velocity_y[fy] + self.velocity_y[fy + nx]),
        ]
    }
}

/// Result of [`run_continuum`].
#[derive(Clone, Debug, PartialEq)]
pub struct ContinuumRun {
    /// Time of each record, s: 0 and every step end.
    pub times: Vec<f64>,
    /// Flux-weighted temperature of the producing wells, K, per time (empty when no well
    /// produces).
    pub production_temperature: Vec<f64>,
    /// `rho_w c_w sum |q_prod| (T_prod - T_ref)`, W per metre, per time; `T_ref` the
    /// flux-weighted injection temperature of the injecting wells (the initial temperature when
    /// none injects).
    pub thermal_power: Vec<f64>,
    /// Time integral of `thermal_power` (end-of-step values, as the implicit step), J per metre.
    pub cumulative_heat: Vec<f64>,
    /// Reference temperature of `thermal_power`, K.
    pub reference_temperature: f64,
    /// The steady flow field.
    pub flow: DarcyField,
    /// Temperature snapshots `(t, T per block)` at the requested output times, K.
    pub snapshots: Vec<(f64, Vec<f64>)>,
    /// Final block temperatures, K.
    pub temperature: Vec<f64>,
    /// Change of stored heat over the run, J per metre (relative to the initial temperature).
    pub stored_heat_change: f64,
    /// Net heat into the reservoir through edges and wells over the run, J per metre.
    pub net_heat_in: f64,
    /// `|stored change - net in| / max(|stored change|, heat in, heat out)`.
    pub energy_balance: f64,
    /// The Darcy field's mass balance (see [`DarcyField::mass_balance`]).
    pub mass_balance: f64,
    /// Steps taken.
    pub steps: usize,
    /// Numeric LU factorisations of the heat matrix (1, or 2 with a shortened last step).
    pub factorisations: usize,
}

fn finite(field: &str, v: f64) -> Result<(), ReservoirError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ReservoirError::invalid(field, format!("{v} is not finite")))
    }
}

fn positive(field: &str, v: f64) -> Result<(), ReservoirError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ReservoirError::invalid(
            field,
            format!("{v} must be finite and positive"),
        ))
    }
}

impl ContinuumSpec {
    /// Checks every input; the error names the field and why.
    pub fn validate(&self) -> Result<(), ReservoirError> {
        self.validate_grid()?;
        self.validate_props()?;
        self.validate_edges()?;
        self.validate_wells()?;
        self.validate_rate_balance()?;
        self.validate_time()
    }

    /// The grid (origin and size in m, block counts) and one positive permeability pair
    /// (m^2) per block.
    fn validate_grid(&self) -> Result<(), ReservoirError> {
        let g = &self.grid;
        for k in 0..2 {
            finite(&format!("grid.origin[{k}]"), g.origin[k])?;
            positive(&format!("grid.size[{k}]"), g.size[k])?;
            if g.n[k] == 0 {
                return Err(ReservoirError::invalid(
                    &format!("grid.n[{k}]"),
                    "needs at least one block",
                ));
            }
        }
        let len = g.n[0]
            .checked_mul(g.n[1])
            .filter(|&l| l < u32::MAX as usize)
            .ok_or_else(|| ReservoirError::invalid("grid.n", "too many blocks"))?;
        if self.permeability.len() != len {
            return Err(ReservoirError::invalid(
                "permeability",
                format!(
                    "has {} entries, the grid has {len} blocks",
                    self.permeability.len()
                ),
            ));
        }
        for (b, k) in self.permeability.iter().enumerate() {
            for (c, name) in ["k_xx", "k_yy"].iter().enumerate() {
                positive(&format!("permeability[{b}].{name}"), k[c])?;
            }
        }
        Ok(())
    }

    /// The rock and fluid properties (positive; porosity in [0, 1]), the initial temperature
    /// (K, positive) and pressure (Pa, finite).
    fn validate_props(&self) -> Result<(), ReservoirError> {
        let p = &self.props;
        for (name, v) in [
            ("props.rock_density", p.rock_density),
            ("props.rock_heat_capacity", p.rock_heat_capacity),
            ("props.rock_conductivity", p.rock_conductivity),
            ("props.fluid_density", p.fluid_density),
            ("props.fluid_heat_capacity", p.fluid_heat_capacity),
            ("props.fluid_conductivity", p.fluid_conductivity),
            ("props.fluid_viscosity", p.fluid_viscosity),
        ] {
            positive(name, v)?;
        }
        if !(0.0..=1.0).contains(&p.porosity) {
            return Err(ReservoirError::invalid(
                "props.porosity",
                format!("{} must be in [0, 1]", p.porosity),
            ));
        }
        positive("initial_temperature", self.initial_temperature)?;
        finite("initial_pressure", self.initial_pressure)?;
        Ok(())
    }

    /// The held edges: finite pressure (Pa), positive temperature (K).
    fn validate_edges(&self) -> Result<(), ReservoirError> {
        for (name, e) in self.edges.sides() {
            if let EdgeCondition::Held {
                pressure,
                temperature,
            } = e
            {
                finite(&format!("edges.{name}.pressure"), pressure)?;
                positive(&format!("edges.{name}.temperature"), temperature)?;
            }
        }
        Ok(())
    }

    /// The wells: inside the grid, one per block, a finite non-zero rate (m^2/s) or finite
    /// pressure (Pa), positive injection temperature (K) and a radius (m) below the block's
    /// Peaceman equivalent radius.
    fn validate_wells(&self) -> Result<(), ReservoirError> {
        let g = &self.grid;
        let p = &self.props;
        let mut blocks: Vec<(usize, usize)> = Vec::with_capacity(self.wells.len());
        for (w, well) in self.wells.iter().enumerate() {
            let f = |s: &str| format!("wells[{w}] ({}).{s}", well.name);
            finite(&f("position[0]"), well.position[0])?;
            finite(&f("position[1]"), well.position[1])?;
            let (i, j) = g.locate(well.position).ok_or_else(|| {
                ReservoirError::invalid(
                    &f("position"),
                    format!(
                        "{:?} is outside the grid [{:?}, {:?}]",
                        well.position,
                        g.origin,
                        [g.origin[0] + g.size[0], g.origin[1] + g.size[1]]
                    ),
                )
            })?;
            let b = g.index(i, j);
            if let Some(other) = blocks.iter().position(|&(ob, _)| ob == b) {
                return Err(ReservoirError::invalid(
                    &f("position"),
                    format!(
                        "block ({i}, {j}) already holds wells[{other}] ({})",
                        self.wells[other].name
                    ),
                ));
            }
            blocks.push((b, w));
            match well.control {
                WellControl::Rate(q) => {
                    if !(q.is_finite() && q != 0.0) {
                        return Err(ReservoirError::invalid(
                            &f("control"),
                            format!("rate {q} must be finite and non-zero"),
                        ));
                    }
                }
                WellControl::Pressure(pw) => finite(&f("control"), pw)?,
            }
            positive(&f("injection_temperature"), well.injection_temperature)?;
            positive(&f("radius"), well.radius)?;
            if well
                .index_in(self.permeability[b], g.dx(), p.fluid_viscosity)
                .is_none()
            {
                return Err(ReservoirError::invalid(
                    &f("radius"),
                    format!(
                        "{} m is not below the block's Peaceman equivalent radius (about 0.2 dx)",
                        well.radius
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Without a pressure well or held edge, the well rates must sum to zero (to
    /// [`RATE_BALANCE_TOL`] of their gross).
    fn validate_rate_balance(&self) -> Result<(), ReservoirError> {
        let referenced = self
            .wells
            .iter()
            .any(|w| matches!(w.control, WellControl::Pressure(_)))
            || self
                .edges
                .sides()
                .iter()
                .any(|(_, e)| matches!(e, EdgeCondition::Held { .. }));
        if !referenced {
            let (mut sum, mut gross) = (0.0, 0.0);
            for w in &self.wells {
                if let WellControl::Rate(q) = w.control {
                    sum += q;
                    gross += q.abs();
                }
            }
            if sum.abs() > RATE_BALANCE_TOL * gross {
                return Err(ReservoirError::invalid(
                    "wells",
                    format!(
                        "no pressure well or held edge and the rates sum to {sum:e} m^2/s: \
                         no steady flow (balance the rates or hold a pressure)"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The run length and step (s, positive, at most [`MAX_STEPS`] steps) and the output
    /// times (s, ascending in [0, end_time]).
    fn validate_time(&self) -> Result<(), ReservoirError> {
        positive("end_time", self.end_time)?;
        positive("dt", self.dt)?;
        if self.end_time / self.dt > MAX_STEPS as f64 {
            return Err(ReservoirError::invalid(
                "dt",
                format!(
                    "{} s gives more than {MAX_STEPS} steps to {} s",
                    self.dt, self.end_time
                ),
            ));
        }
        let mut last = f64::NEG_INFINITY;
        for (k, &t) in self.output_times.iter().enumerate() {
            if !(t.is_finite() && (0.0..=self.end_time).contains(&t) && t > last) {
                return Err(ReservoirError::invalid(
                    &format!("output_times[{k}]"),
                    format!(
                        "{t} must be ascending and in [0, end_time = {}]",
                        self.end_time
                    ),
                ));
            }
            last = t;
        }
        Ok(())
    }
}

/// The connection of an edge block to a held edge: transmissibility m^2/(Pa s), conductance
/// W/K per metre, the edge's pressure (Pa) and temperature (K).
struct EdgeLink {
    block: usize,
    trans: f64,
    cond: f64,
    pressure: f64,
    temperature: f64,
}

/// Interior faces (a, b, transmissibility m^2/(Pa s), conductance W/K per metre, face length
/// m): x faces first (a left of b), then y faces (a below b).
struct Faces {
    list: Vec<(usize, usize, f64, f64, f64)>,
    /// Number of x faces in `list`.
    nx_faces: usize,
}

fn harmonic(a: f64, b: f64) -> f64 {
    2.0 * a * b / (a + b)
}

fn interior_faces(spec: &ContinuumSpec, lambda: f64) -> Faces {
    let g = &spec.grid;
    let (nx, ny) = (g.n[0], g.n[1]);
    let d = g.dx();
    let mu = spec.props.fluid_viscosity;
    let k = &spec.permeability;
    let mut list = Vec::with_capacity(2 * g.len());
    for j in 0..ny {
        for i in 0..nx.saturating_sub(1) {
            let (a, b) = (g.index(i, j), g.index(i + 1, j));
            let t = harmonic(k[a][0], k[b][0]) * d[1] / (mu * d[0]);
            list.push((a, b, t, lambda * d[1] / d[0], d[1]));
        }
    }
    let nx_faces = list.len();
    for j in 0..ny.saturating_sub(1) {
        for i in 0..nx {
            let (a, b) = (g.index(i, j), g.index(i, j + 1));
            let t = harmonic(k[a][1], k[b][1]) * d[0] / (mu * d[1]);
            list.push((a, b, t, lambda * d[0] / d[1], d[0]));
        }
    }
    Faces { list, nx_faces }
}

/// Edge links of the held edges, each with: on an x face, the face slot its velocity goes to,
/// and the factor from inflow (m^2/s) to the +axis Darcy velocity (m/s).
fn edge_links(spec: &ContinuumSpec, lambda: f64) -> Vec<(EdgeLink, bool, usize, f64)> {
    let g = &spec.grid;
    let (nx, ny) = (g.n[0], g.n[1]);
    let d = g.dx();
    let mu = spec.props.fluid_viscosity;
    let k = &spec.permeability;
    let mut out = Vec::new();
    for (name, e) in spec.edges.sides() {
        let EdgeCondition::Held {
            pressure,
            temperature,
        } = e
        else {
            continue;
        };
        // (block, is an x face, face slot, sign of the +axis velocity for inflow).
        let blocks: Vec<(usize, bool, usize, f64)> = match name {
            "left" => (0..ny)
                .map(|j| (g.index(0, j), true, (nx + 1) * j, 1.0))
                .collect(),
            "right" => (0..ny)
                .map(|j| (g.index(nx - 1, j), true, nx + (nx + 1) * j, -1.0))
                .collect(),
            "bottom" => (0..nx).map(|i| (g.index(i, 0), false, i, 1.0)).collect(),
            _ => (0..nx)
                .map(|i| (g.index(i, ny - 1), false, i + nx * ny, -1.0))
                .collect(),
        };
        for (b, is_x, slot, sign) in blocks {
            let (c, area, dist) = if is_x {
                (0, d[1], d[0])
            } else {
                (1, d[0], d[1])
            };
            out.push((
                EdgeLink {
                    block: b,
                    trans: k[b][c] * area / (mu * 0.5 * dist),
                    cond: lambda * area / (0.5 * dist),
                    pressure,
                    temperature,
                },
                is_x,
                slot,
                sign / area,
            ));
        }
    }
    out
}

/// The steady Darcy field of `spec` (validated here).
pub fn darcy_flow(spec: &ContinuumSpec) -> Result<DarcyField, ReservoirError> {
    spec.validate()?;
    let _span = tracing::info_span!(target: "hydrofrac::system", "darcy_continuum").entered();
    let lambda = bulk_conductivity(&spec.props);
    let faces = interior_faces(spec, lambda);
    let edges = edge_links(spec, lambda);
    Ok(solve_darcy(spec, &faces, &edges)?.0)
}

fn solve_darcy(
    spec: &ContinuumSpec,
    faces: &Faces,
    edges: &[(EdgeLink, bool, usize, f64)],
) -> Result<(DarcyField, Vec<f64>, Vec<f64>), ReservoirError> {
    let g = &spec.grid;
    let n = g.len();
    let (nx, ny) = (g.n[0], g.n[1]);
    let mu = spec.props.fluid_viscosity;
    let pairs: Vec<(u32, u32, f64)> = faces
        .list
        .iter()
        .map(|&(a, b, t, _, _)| (a as u32, b as u32, t))
        .collect();
    let mut dirichlet: Vec<(u32, f64, f64)> = edges
        .iter()
        .map(|(e, ..)| (e.block as u32, e.trans, e.pressure))
        .collect();
    let mut sources = Vec::new();
    let mut well_blocks = Vec::with_capacity(spec.wells.len());
    let mut well_index = Vec::with_capacity(spec.wells.len());
    for w in &spec.wells {
        let (i, j) = g.locate(w.position).expect("validated");
        let b = g.index(i, j);
        let wi = w
            .index_in(spec.permeability[b], g.dx(), mu)
            .expect("validated");
        well_blocks.push(b);
        well_index.push(wi);
        match w.control {
            WellControl::Rate(q) => sources.push((b as u32, q)),
            WellControl::Pressure(pw) => dirichlet.push((b as u32, wi, pw)),
        }
    }
    if dirichlet.is_empty() {
        // Rates balance (validated): tie block 0 to the pressure level; it carries no flow.
        let t0 = faces
            .list
            .iter()
            .filter(|f| f.0 == 0 || f.1 == 0)
            .map(|f| f.2)
            .fold(0.0f64, f64::max);
        let t0 = if t0 > 0.0 {
            t0
        } else {
            spec.permeability[0][0] / mu
        };
        dirichlet.push((0, t0, spec.initial_pressure));
    }
    // Solve for p - p_ref (p_ref the midpoint of the held pressures) so that the face fluxes
    // are differences of small numbers, not of absolute pressures (a few Pa across a block
    // against tens of MPa would cost the mass balance about 1e-10).
    let (lo, hi) = dirichlet
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
            (lo.min(d.2), hi.max(d.2))
        });
    let p_ref = 0.5 * lo + 0.5 * hi;
    for d in &mut dirichlet {
        d.2 -= p_ref;
    }
    let problem = SteadyProblem {
        n_cells: n,
        pairs: &pairs,
        dirichlet: &dirichlet,
        sources: &sources,
    };
    let sol = SteadySolver::new()
        .solve(&problem)
        .map_err(|e| ReservoirError::Solve {
            what: "continuum Darcy solve".into(),
            why: e.to_string(),
        })?;
    let p = sol.pressure;
    if let Some(b) = p.iter().position(|v| !v.is_finite()) {
        return Err(ReservoirError::Solve {
            what: "continuum Darcy solve".into(),
            why: format!("pressure of block {b} is {}", p[b]),
        });
    }
    let mut vx = vec![0.0; (nx + 1) * ny];
    let mut vy = vec![0.0; nx * (ny + 1)];
    let mut net = vec![0.0; n];
    let mut scale: f64 = 0.0;
    let mut face_q = Vec::with_capacity(faces.list.len());
    let mut edge_q = Vec::with_capacity(edges.len());
    for (f, &(a, b, t, _, area)) in faces.list.iter().enumerate() {
        let q = t * (p[a] - p[b]);
        face_q.push(q);
        net[a] -= q;
        net[b] += q;
        scale = scale.max(q.abs());
        if f < faces.nx_faces {
            let (i, j) = (a % nx, a / nx);
            vx[i + 1 + (nx + 1) * j] = q / area;
        } else {
            vy[a + nx] = q / area;
        }
    }
    for (e, is_x, slot, sign) in edges {
        let q = e.trans * (e.pressure - p_ref - p[e.block]);
        edge_q.push(q);
        net[e.block] += q;
        scale = scale.max(q.abs());
        if *is_x {
            vx[*slot] = sign * q;
        } else {
            vy[*slot] = sign * q;
        }
    }
    let mut wells = Vec::with_capacity(spec.wells.len());
    for (k, w) in spec.wells.iter().enumerate() {
        let b = well_blocks[k];
        let (rate, bhp) = match w.control {
            WellControl::Rate(q) => (q, p_ref + p[b] + q / well_index[k]),
            WellControl::Pressure(pw) => (well_index[k] * (pw - p_ref - p[b]), pw),
        };
        net[b] += rate;
        scale = scale.max(rate.abs());
        wells.push(WellFlow {
            name: w.name.clone(),
            block: b,
            rate,
            bottom_hole_pressure: bhp,
        });
    }
    let worst = net.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mass_balance = if scale > 0.0 { worst / scale } else { 0.0 };
    let all_finite = vx.iter().chain(&vy).all(|v| v.is_finite())
        && wells
            .iter()
            .all(|w| w.rate.is_finite() && w.bottom_hole_pressure.is_finite())
        && mass_balance.is_finite();
    if !all_finite {
        return Err(ReservoirError::Solve {
            what: "continuum Darcy solve".into(),
            why: "non-finite velocity or well rate".into(),
        });
    }
    let field = DarcyField {
        pressure: p.iter().map(|u| u + p_ref).collect(),
        velocity_x: vx,
        velocity_y: vy,
        wells,
        mass_balance,
    };
    Ok((field, face_q, edge_q))
}

/// Per block, the heat terms of the held edges and the wells (relative to T0), and the
/// producing wells: what the heat step adds to the capacity and the faces.
struct HeatSources {
    /// Constant inflow source per block, W/m.
    src: Vec<f64>,
    /// Outflow coefficient per block, W/(m K).
    out_coef: Vec<f64>,
    /// The producing wells: (block, |rate| m^2/s).
    producers: Vec<(usize, f64)>,
    /// Total production rate, m^2/s.
    q_prod: f64,
    /// Flux-weighted injection temperature of the injecting wells (T0 when none injects), K.
    reference_temperature: f64,
}

impl HeatSources {
    /// The sources of the held edges (steady inflows `edge_q`, m^2/s) and of the wells of
    /// `flow`.
    fn new(
        spec: &ContinuumSpec,
        edges: &[(EdgeLink, bool, usize, f64)],
        edge_q: &[f64],
        flow: &DarcyField,
    ) -> Self {
        let n = spec.grid.len();
        let t0 = spec.initial_temperature;
        let rc_w = spec.props.fluid_rho_c();
        let mut src = vec![0.0; n];
        let mut out_coef = vec![0.0; n];
        let (mut q_inj, mut qt_inj) = (0.0, 0.0);
        let mut producers: Vec<(usize, f64)> = Vec::new();
        for ((e, ..), &q) in edges.iter().zip(edge_q) {
            let th = e.temperature - t0;
            src[e.block] += e.cond * th;
            out_coef[e.block] += e.cond;
            if q > 0.0 {
                src[e.block] += rc_w * q * th;
            } else {
                out_coef[e.block] += rc_w * (-q);
            }
        }
        for (k, w) in flow.wells.iter().enumerate() {
            if w.rate > 0.0 {
                let ti = spec.wells[k].injection_temperature;
                src[w.block] += rc_w * w.rate * (ti - t0);
                q_inj += w.rate;
                qt_inj += w.rate * ti;
            } else if w.rate < 0.0 {
                out_coef[w.block] += rc_w * (-w.rate);
                producers.push((w.block, -w.rate));
            }
        }
        let reference_temperature = if q_inj > 0.0 { qt_inj / q_inj } else { t0 };
        let q_prod: f64 = producers.iter().map(|p| p.1).sum();
        HeatSources {
            src,
            out_coef,
            producers,
            q_prod,
            reference_temperature,
        }
    }

    /// The flux-weighted production temperature (K; `None` when nothing produces) and the
    /// thermal power `rho_w c_w q_prod (T_prod - T_ref)` (W/m) of the block temperatures
    /// `theta` (relative to `t0`, K); `rc_w` is `rho_w c_w`, J/(m^3 K).
    fn production(&self, t0: f64, rc_w: f64, theta: &[f64]) -> (Option<f64>, f64) {
        if self.q_prod > 0.0 {
            let tp = t0
                + self
                    .producers
                    .iter()
                    .map(|&(b, q)| q * theta[b])
                    .sum::<f64>()
                    / self.q_prod;
            (
                Some(tp),
                rc_w * self.q_prod * (tp - self.reference_temperature),
            )
        } else {
            (None, 0.0)
        }
    }
}

/// The constant parts of the heat matrix: the bulk capacity of a block (J/(m K)), the
/// outflow coefficients (W/(m K)), the interior faces with their steady flows (m^2/s) and
/// `rho_w c_w` (J/(m^3 K)).
struct HeatTerms<'a> {
    block_capacity: f64,
    out_coef: &'a [f64],
    faces: &'a Faces,
    face_q: &'a [f64],
    rc_w: f64,
}

/// The heat matrix (pattern, values, diagonal and face slots) with its sparse LU: the
/// symbolic analysis once, the numeric factorisation whenever the step length changes.
struct HeatSolver {
    pattern: SparsePattern,
    values: Vec<f64>,
    diag: Vec<usize>,
    face_slots: Vec<[usize; 2]>,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    mem: MemBuffer,
    /// The step length (s) the numeric factors are those of (NaN before the first).
    factored_dt: f64,
    /// Numeric factorisations done.
    factorisations: usize,
}

impl HeatSolver {
    /// The matrix pattern of `n` blocks (the diagonal and both directions of every interior
    /// face), its symbolic LU and the LU workspace.
    fn new(n: usize, faces: &Faces) -> Result<Self, ReservoirError> {
        let mut entries: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        for &(a, b, ..) in &faces.list {
            entries.push((a, b));
            entries.push((b, a));
        }
        let pattern =
            SparsePattern::from_entries(n, entries).map_err(|why| ReservoirError::Solve {
                what: "continuum heat matrix".into(),
                why,
            })?;
        let slot = |r: usize, c: usize| pattern.slot(r, c).expect("entry is in the pattern");
        let diag: Vec<usize> = (0..n).map(|i| slot(i, i)).collect();
        let face_slots: Vec<[usize; 2]> = faces
            .list
            .iter()
            .map(|&(a, b, ..)| [slot(a, b), slot(b, a)])
            .collect();
        let (symbolic, mem) = pattern.symbolic_lu().map_err(|why| ReservoirError::Solve {
            what: "continuum heat matrix".into(),
            why,
        })?;
        Ok(HeatSolver {
            values: vec![0.0; pattern.nnz()],
            pattern,
            diag,
            face_slots,
            symbolic,
            numeric: NumericLu::<usize, f64>::new(),
            mem,
            factored_dt: f64::NAN,
            factorisations: 0,
        })
    }

    /// The matrix values of a step `dt` (s): capacity over dt and outflow on the diagonal,
    /// conduction and upwind advection through every interior face.
    fn assemble(&mut self, terms: &HeatTerms, dt: f64) {
        let (diag, values) = (&self.diag, &mut self.values);
        values.iter_mut().for_each(|v| *v = 0.0);
        for (i, &d) in diag.iter().enumerate() {
            values[d] += terms.block_capacity / dt + terms.out_coef[i];
        }
        let rc_w = terms.rc_w;
        for (f, &(a, b, _, cond, _)) in terms.faces.list.iter().enumerate() {
            let q = terms.face_q[f];
            let [ab, ba] = self.face_slots[f];
            values[diag[a]] += cond;
            values[diag[b]] += cond;
            values[ab] -= cond;
            values[ba] -= cond;
            if q > 0.0 {
                values[diag[a]] += rc_w * q;
                values[ba] -= rc_w * q;
            } else if q < 0.0 {
                values[diag[b]] += rc_w * (-q);
                values[ab] -= rc_w * (-q);
            }
        }
    }

    /// Makes the numeric factors those of a step `dt` (s): assembles and factorises when `dt`
    /// is not the step already factorised.
    fn factor_for(&mut self, terms: &HeatTerms, dt: f64) -> Result<(), ReservoirError> {
        if dt == self.factored_dt {
            return Ok(());
        }
        self.assemble(terms, dt);
        let a = SparseColMatRef::new(self.pattern.as_ref(), &self.values);
        self.symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                a,
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| ReservoirError::Solve {
                what: "continuum heat LU".into(),
                why: format!("{e:?}"),
            })?;
        self.factored_dt = dt;
        self.factorisations += 1;
        Ok(())
    }

    /// Solves in place with the current factors (those of [`HeatSolver::factor_for`]'s last
    /// step).
    fn solve_in_place(&mut self, rhs: &mut [f64]) {
        let n = rhs.len();
        // The factors are those of `factored_dt`: `factor_for` rebuilt them when it changed.
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        lu.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
    }
}

/// Heat through the edges and wells over the run, J per metre (Kahan sums): net into the
/// reservoir, gross in and gross out, from the constant sources and the outflows at
/// end-of-step temperatures.
struct HeatAccounts {
    net_in: (f64, f64),
    heat_in: (f64, f64),
    heat_out: (f64, f64),
    /// Sum, positive and negative parts of the constant sources, W/m.
    src_total: f64,
    src_pos: f64,
    src_neg: f64,
}

impl HeatAccounts {
    /// Empty accounts for the constant sources `src` (W/m per block).
    fn new(src: &[f64]) -> Self {
        HeatAccounts {
            net_in: (0.0, 0.0),
            heat_in: (0.0, 0.0),
            heat_out: (0.0, 0.0),
            src_total: src.iter().sum(),
            src_pos: src.iter().filter(|&&s| s > 0.0).sum(),
            src_neg: src.iter().filter(|&&s| s < 0.0).sum(),
        }
    }

    /// Adds a step of `dt` (s) ending at the block temperatures `theta` (relative to T0, K),
    /// with the outflow coefficients `out_coef` (W/(m K)).
    fn add_step(&mut self, dt: f64, out_coef: &[f64], theta: &[f64]) {
        let outflow: f64 = out_coef.iter().zip(theta).map(|(c, th)| c * th).sum();
        let (s, c) = &mut self.net_in;
        kahan_add(s, c, dt * (self.src_total - outflow));
        let (mut o_pos, mut o_neg) = (0.0, 0.0);
        for (c, th) in out_coef.iter().zip(theta) {
            let h = c * th;
            if h > 0.0 {
                o_pos += h;
            } else {
                o_neg += h;
            }
        }
        let (s, c) = &mut self.heat_in;
        kahan_add(s, c, dt * (self.src_pos - o_neg));
        let (s, c) = &mut self.heat_out;
        kahan_add(s, c, dt * (o_pos - self.src_neg));
    }

    /// `|stored - net in| / max(|stored|, heat in, heat out)` for the stored heat change
    /// `stored` (J/m); 0 when nothing moved.
    fn energy_balance(&self, stored: f64) -> f64 {
        let denom = stored.abs().max(self.heat_in.0).max(self.heat_out.0);
        if denom > 0.0 {
            (stored - self.net_in.0).abs() / denom
        } else {
            0.0
        }
    }
}

/// Number of steps to `end_time`: all of length dt but the last, shortened to end at
/// `end_time` (a last step shorter than 1e-9 dt is merged into the one before).
fn step_count(spec: &ContinuumSpec) -> usize {
    let mut n_steps = (spec.end_time / spec.dt).ceil() as usize;
    if n_steps == 0 {
        n_steps = 1;
    }
    if spec.end_time - (n_steps - 1) as f64 * spec.dt <= 1e-9 * spec.dt && n_steps > 1 {
        n_steps -= 1;
    }
    n_steps
}

/// The end (s) and length (s) of step `step` of `n_steps` that starts at `t` (s). Every step
/// has length dt but a shortened last one (`t1 - t` differs from dt by round-off, which must
/// not trigger a refactorisation).
fn step_end(spec: &ContinuumSpec, step: usize, n_steps: usize, t: f64) -> (f64, f64) {
    let t1 = if step + 1 == n_steps {
        spec.end_time
    } else {
        (step + 1) as f64 * spec.dt
    };
    let dt = if (t1 - t - spec.dt).abs() <= 1e-9 * spec.dt {
        spec.dt
    } else {
        t1 - t
    };
    (t1, dt)
}

/// Takes the snapshots `(t, T per block in K)` of the output times from `*next_out` on that are
/// at or before `until` (s), from the block temperatures `theta` (relative to `t0`, K).
fn take_snapshots(
    output_times: &[f64],
    next_out: &mut usize,
    until: f64,
    (t, t0, theta): (f64, f64, &[f64]),
    snapshots: &mut Vec<(f64, Vec<f64>)>,
) {
    while *next_out < output_times.len() && output_times[*next_out] <= until {
        snapshots.push((t, theta.iter().map(|th| t0 + th).collect()));
        *next_out += 1;
    }
}

/// Heat stored relative to T0 in blocks of capacity `block_capacity` (J/(m K)) at the block
/// temperatures `theta` (relative to T0, K), J per metre (Kahan sum).
fn stored_heat(block_capacity: f64, theta: &[f64]) -> f64 {
    let (mut s, mut c) = (0.0, 0.0);
    for th in theta {
        kahan_add(&mut s, &mut c, block_capacity * th);
    }
    s
}

/// An error unless the energy balance, the time series and the final temperatures (K) of a
/// run are all finite.
fn check_run_finite(
    energy_balance: f64,
    series: &HeatSeries,
    temperature: &[f64],
) -> Result<(), ReservoirError> {
    let all_finite = energy_balance.is_finite()
        && series.all_finite()
        && temperature.iter().all(|v| v.is_finite());
    if !all_finite {
        return Err(ReservoirError::Solve {
            what: "continuum heat run".into(),
            why: "non-finite production temperature, power or balance".into(),
        });
    }
    Ok(())
}

/// Runs the flow and then the heat extraction to `end_time`.
pub fn run_continuum(spec: &ContinuumSpec) -> Result<ContinuumRun, ReservoirError> {
    spec.validate()?;
    let n = spec.grid.len();
    let lambda = bulk_conductivity(&spec.props);
    let d = spec.grid.dx();
    let block_capacity = bulk_heat_capacity(&spec.props) * (d[0] * d[1]);
    let rc_w = spec.props.fluid_rho_c();
    let t0 = spec.initial_temperature;

    let faces = interior_faces(spec, lambda);
    let edges = edge_links(spec, lambda);
    let (flow, face_q, edge_q) = {
        let _span = tracing::info_span!(target: "hydrofrac::system", "darcy_continuum").entered();
        solve_darcy(spec, &faces, &edges)?
    };

    let heat_span = tracing::info_span!(target: "hydrofrac::system", "heat_continuum");
    let entered = heat_span.enter();
    let sources = HeatSources::new(spec, &edges, &edge_q, &flow);
    let terms = HeatTerms {
        block_capacity,
        out_coef: &sources.out_coef,
        faces: &faces,
        face_q: &face_q,
        rc_w,
    };
    let mut solver = HeatSolver::new(n, &faces)?;
    drop(entered);

    let n_steps = step_count(spec);
    let mut theta = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    let mut series = HeatSeries::new(Summation::Compensated, n_steps + 1);
    let mut snapshots = Vec::with_capacity(spec.output_times.len());
    let mut next_out = 0;
    let mut accounts = HeatAccounts::new(&sources.src);
    let (tp, power) = sources.production(t0, rc_w, &theta);
    series.start(0.0, tp, power);
    let outs = &spec.output_times;
    take_snapshots(outs, &mut next_out, 0.0, (0.0, t0, &theta), &mut snapshots);

    let mut t = 0.0;
    for step in 0..n_steps {
        let _span = heat_span.enter();
        let (t1, dt) = step_end(spec, step, n_steps, t);
        solver.factor_for(&terms, dt)?;
        let c = block_capacity / dt;
        for i in 0..n {
            rhs[i] = c * theta[i] + sources.src[i];
        }
        solver.solve_in_place(&mut rhs);
        if let Some(b) = rhs.iter().position(|v| !v.is_finite()) {
            return Err(ReservoirError::Solve {
                what: "continuum heat step".into(),
                why: format!("temperature of block {b} is {} at t = {t1:e} s", rhs[b]),
            });
        }
        std::mem::swap(&mut theta, &mut rhs);
        accounts.add_step(dt, &sources.out_coef, &theta);
        t = t1;
        let (tp, power) = sources.production(t0, rc_w, &theta);
        series.record(t, dt, tp, power);
        let until = t + 1e-9 * spec.dt;
        take_snapshots(outs, &mut next_out, until, (t, t0, &theta), &mut snapshots);
    }
    let stored = stored_heat(block_capacity, &theta);
    let energy_balance = accounts.energy_balance(stored);
    let temperature: Vec<f64> = theta.iter().map(|th| t0 + th).collect();
    check_run_finite(energy_balance, &series, &temperature)?;
    let HeatSeries {
        times,
        production_temperature,
        thermal_power,
        cumulative_heat,
        ..
    } = series;
    Ok(ContinuumRun {
        times,
        production_temperature,
        thermal_power,
        cumulative_heat,
        reference_temperature: sources.reference_temperature,
        mass_balance: flow.mass_balance,
        flow,
        snapshots,
        temperature,
        stored_heat_change: stored,
        net_heat_in: accounts.net_in.0,
        energy_balance,
        steps: n_steps,
        factorisations: solver.factorisations,
    })
}
