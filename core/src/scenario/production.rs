//! The production stage (`production:`): the wells, the coupled steady state's iteration, and
//! their checks.

use super::SolidScheme;
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

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
