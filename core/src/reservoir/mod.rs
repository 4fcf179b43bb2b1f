//! The reservoir half of the method (the seed's NUFT role): a fracture network's flow and heat
//! at the scale of a reservoir. SI units throughout: m, s, Pa, kg, J, K; everything per metre of
//! thickness (plane strain, as the rest of the engine).
//!
//! - [`upscale`]: the network onto a grid of blocks: Oda's crack tensor and flow-based block
//!   permeability.
//! - [`continuum`]: single-phase Darcy flow and heat advection-conduction with local thermal
//!   equilibrium on a block permeability field (implicit finite volumes).
//! - [`discrete`]: heat advected along the fracture cells by the network's steady flow,
//!   exchanging with conduction in the rock.
//! - [`doublet`]: that steady flow of a rigid network between wells held at pressures.
//!
//! The types here are the contract between them: a regular grid, the thermal properties, and a
//! network with its steady flow field.

pub mod continuum;
pub mod discrete;
pub mod doublet;
pub mod upscale;

use serde::{Deserialize, Serialize};

/// A regular grid of `n[0] x n[1]` rectangular blocks covering `[origin, origin + size]`, m.
/// Block `(i, j)` has index `i + n[0] * j` (x fastest).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid2 {
    /// Lower-left corner, m.
    pub origin: [f64; 2],
    /// Extent, m.
    pub size: [f64; 2],
    /// Blocks in x and y.
    pub n: [usize; 2],
}

impl Grid2 {
    pub fn len(&self) -> usize {
        self.n[0] * self.n[1]
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Block size, m.
    pub fn dx(&self) -> [f64; 2] {
        [
            self.size[0] / self.n[0] as f64,
            self.size[1] / self.n[1] as f64,
        ]
    }
    pub fn index(&self, i: usize, j: usize) -> usize {
        i + self.n[0] * j
    }
    /// Centre of block `(i, j)`, m.
    pub fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        let d = self.dx();
        [
            self.origin[0] + (i as f64 + 0.5) * d[0],
            self.origin[1] + (j as f64 + 0.5) * d[1],
        ]
    }
    /// The block containing point `p` (points on the far edges belong to the last block);
    /// `None` outside the grid.
    pub fn locate(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let d = self.dx();
        let mut ij = [0usize; 2];
        for k in 0..2 {
            let s = (p[k] - self.origin[k]) / d[k];
            if !(s >= 0.0 && s <= self.n[k] as f64) {
                return None;
            }
            ij[k] = (s.floor() as usize).min(self.n[k] - 1);
        }
        Some((ij[0], ij[1]))
    }
}

/// Rock and fluid properties for heat and flow. SI: kg/m^3, J/(kg K), W/(m K), Pa s.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalProps {
    /// Rock grain density, kg/m^3 (granite: 2650).
    pub rock_density: f64,
    /// Rock specific heat, J/(kg K) (granite: 800-1000).
    pub rock_heat_capacity: f64,
    /// Rock thermal conductivity, W/(m K) (granite: 2.5-3.5).
    pub rock_conductivity: f64,
    /// Porosity of the continuum (0 for intact rock in the discrete model).
    pub porosity: f64,
    /// Fluid density, kg/m^3 (water: 1000).
    pub fluid_density: f64,
    /// Fluid specific heat, J/(kg K) (water: 4180).
    pub fluid_heat_capacity: f64,
    /// Fluid thermal conductivity, W/(m K) (water: 0.6).
    pub fluid_conductivity: f64,
    /// Fluid dynamic viscosity, Pa s (water at 150 C: 1.8e-4; at 20 C: 1e-3).
    pub fluid_viscosity: f64,
}

impl ThermalProps {
    /// Water in granite.
    pub fn granite_water() -> Self {
        ThermalProps {
            rock_density: 2650.0,
            rock_heat_capacity: 900.0,
            rock_conductivity: 3.0,
            porosity: 0.01,
            fluid_density: 1000.0,
            fluid_heat_capacity: 4180.0,
            fluid_conductivity: 0.6,
            fluid_viscosity: 2.0e-4,
        }
    }
    /// Rock volumetric heat capacity, J/(m^3 K).
    pub fn rock_rho_c(&self) -> f64 {
        self.rock_density * self.rock_heat_capacity
    }
    /// Fluid volumetric heat capacity, J/(m^3 K).
    pub fn fluid_rho_c(&self) -> f64 {
        self.fluid_density * self.fluid_heat_capacity
    }
    /// Rock thermal diffusivity, m^2/s.
    pub fn rock_diffusivity(&self) -> f64 {
        self.rock_conductivity / self.rock_rho_c()
    }
}

/// A fracture network with its steady flow field, the input of the discrete heat model and of
/// the flow-based upscaling. Per metre of thickness.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NetworkFlow {
    /// Cell end points, m.
    pub nodes: Vec<[f64; 2]>,
    /// Cells: (node a, node b, hydraulic aperture in m).
    pub cells: Vec<(u32, u32, f64)>,
    /// Steady flux between neighbouring cells: (i, j, q), q > 0 from i to j, m^2/s. Each
    /// connected pair once.
    pub fluxes: Vec<(u32, u32, f64)>,
    /// Exchange with the outside: (cell, q), q > 0 injected into the cell (at the injection
    /// temperature), q < 0 produced from it, m^2/s. For every cell the fluxes and exchanges sum
    /// to zero (steady, incompressible).
    pub boundary: Vec<(u32, f64)>,
}

impl Grid2 {
    /// At least one block each way, a finite positive extent, a finite origin.
    pub fn validate(&self, field: &str) -> Result<(), ReservoirError> {
        if self.n[0] == 0 || self.n[1] == 0 {
            return Err(ReservoirError::invalid(
                field,
                format!("{:?} blocks: need at least one each way", self.n),
            ));
        }
        if !(self.size.iter().all(|x| x.is_finite() && *x > 0.0)
            && self.origin.iter().all(|x| x.is_finite()))
        {
            return Err(ReservoirError::invalid(
                field,
                format!(
                    "origin {:?} m, size {:?} m: need a finite origin and a finite positive size",
                    self.origin, self.size
                ),
            ));
        }
        Ok(())
    }
}

impl NetworkFlow {
    /// Node positions finite, cell node indices in range, apertures finite and positive.
    pub fn validate_geometry(&self) -> Result<(), ReservoirError> {
        if let Some(k) = self
            .nodes
            .iter()
            .position(|p| !p.iter().all(|x| x.is_finite()))
        {
            return Err(ReservoirError::invalid(
                &format!("nodes[{k}]"),
                format!("{:?} m is not a finite point", self.nodes[k]),
            ));
        }
        for (c, &(a, b, ap)) in self.cells.iter().enumerate() {
            if a as usize >= self.nodes.len() || b as usize >= self.nodes.len() {
                return Err(ReservoirError::invalid(
                    &format!("cells[{c}]"),
                    format!("node index out of range ({} nodes)", self.nodes.len()),
                ));
            }
            if !(ap.is_finite() && ap > 0.0) {
                return Err(ReservoirError::invalid(
                    &format!("cells[{c}].aperture"),
                    format!("{ap} m is not finite and positive"),
                ));
            }
        }
        Ok(())
    }

    /// Length of cell `c`, m.
    pub fn cell_length(&self, c: usize) -> f64 {
        let (a, b, _) = self.cells[c];
        let (pa, pb) = (self.nodes[a as usize], self.nodes[b as usize]);
        (pb[0] - pa[0]).hypot(pb[1] - pa[1])
    }
    /// Largest |sum of in- and out-flows| over the cells, relative to the largest flux: the
    /// steady mass balance the heat models rely on.
    pub fn mass_imbalance(&self) -> f64 {
        let mut net = vec![0.0; self.cells.len()];
        let mut scale: f64 = 0.0;
        for &(i, j, q) in &self.fluxes {
            net[i as usize] -= q;
            net[j as usize] += q;
            scale = scale.max(q.abs());
        }
        for &(c, q) in &self.boundary {
            net[c as usize] += q;
            scale = scale.max(q.abs());
        }
        if scale == 0.0 {
            return 0.0;
        }
        net.iter().fold(0.0f64, |m, x| m.max(x.abs())) / scale
    }
}

/// Errors of the reservoir models: a value that is not physical, or a solve that failed.
#[derive(Debug, thiserror::Error)]
pub enum ReservoirError {
    #[error("invalid {field}: {why}")]
    Invalid { field: String, why: String },
    #[error("{what} failed: {why}")]
    Solve { what: String, why: String },
}

impl ReservoirError {
    pub fn invalid(field: &str, why: impl Into<String>) -> Self {
        ReservoirError::Invalid {
            field: field.to_string(),
            why: why.into(),
        }
    }
}

/// How [`HeatSeries`] sums the step energies into the cumulative heat.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Summation {
    /// `sum += x`.
    Plain,
    /// Kahan-compensated ([`crate::flow::kahan_add`]).
    Compensated,
}

/// The time series of a heat-extraction run, recorded step by step: the time (s), the
/// flux-weighted production temperature (K), the thermal power (W per metre) and its time
/// integral with end-of-step values (backward Euler), the cumulative heat (J per metre). Each
/// model computes its own temperature and power; this is where both record them.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatSeries {
    /// s.
    pub times: Vec<f64>,
    /// K (no entry for a record taken while nothing produces).
    pub production_temperature: Vec<f64>,
    /// W per metre.
    pub thermal_power: Vec<f64>,
    /// J per metre.
    pub cumulative_heat: Vec<f64>,
    summation: Summation,
    /// The running cumulative heat, J per metre, and its Kahan compensation.
    sum: f64,
    carry: f64,
}

impl HeatSeries {
    /// An empty series with room for `records` records.
    pub fn new(summation: Summation, records: usize) -> Self {
        HeatSeries {
            times: Vec::with_capacity(records),
            production_temperature: Vec::new(),
            thermal_power: Vec::with_capacity(records),
            cumulative_heat: Vec::with_capacity(records),
            summation,
            sum: 0.0,
            carry: 0.0,
        }
    }

    /// Records the initial state at `t` (s): production temperature (K, `None` when nothing
    /// produces), thermal power (W/m) and a cumulative heat of zero.
    pub fn start(&mut self, t: f64, production_temperature: Option<f64>, power: f64) {
        self.times.push(t);
        self.production_temperature.extend(production_temperature);
        self.thermal_power.push(power);
        self.cumulative_heat.push(0.0);
    }

    /// Records the end of a step of `dt` (s) at `t` (s): production temperature (K, `None`
    /// when nothing produces) and thermal power (W/m); the cumulative heat grows by
    /// `dt * power` (J/m).
    pub fn record(&mut self, t: f64, dt: f64, production_temperature: Option<f64>, power: f64) {
        match self.summation {
            Summation::Plain => self.sum += dt * power,
            Summation::Compensated => {
                crate::flow::kahan_add(&mut self.sum, &mut self.carry, dt * power)
            }
        }
        self.times.push(t);
        self.production_temperature.extend(production_temperature);
        self.thermal_power.push(power);
        self.cumulative_heat.push(self.sum);
    }

    /// Whether every production temperature, power and cumulative heat is finite.
    pub fn all_finite(&self) -> bool {
        self.production_temperature
            .iter()
            .chain(&self.thermal_power)
            .chain(&self.cumulative_heat)
            .all(|v| v.is_finite())
    }
}
