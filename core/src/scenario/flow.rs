//! The fluid and its boundaries (`fluid:`, `initial_fluid:`, `flow_boundaries:`), the
//! piecewise-linear schedules, and those sections' checks.

use super::{Coords, finite, positive};
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

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
    /// The network node nearest to this point, m, `(x, y)` in 2D or `(x, y, z)` in 3D: every
    /// cell meeting there connects to the boundary through half its length (in 3D every
    /// fracture triangle with a corner there; see `FlowView::build_3d`; rates are then m^3/s).
    Node(Coords),
    /// The cell whose centre (in 3D the triangle whose centroid) is nearest to this point, m:
    /// it connects through half its length.
    Cell(Coords),
}

impl FlowTarget {
    /// The point, m (two or three coordinates).
    pub fn point(&self) -> &[f64] {
        match self {
            FlowTarget::Node(p) | FlowTarget::Cell(p) => p.given(),
        }
    }

    /// Whether the point has three coordinates.
    pub fn is_3d(&self) -> bool {
        self.point().len() == 3
    }
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

impl Fluid {
    /// Viscosity, bulk modulus and density positive; errors name `fluid.<field>`.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        positive("fluid.viscosity", self.viscosity, "the viscosity")?;
        positive("fluid.bulk_modulus", self.bulk_modulus, "the bulk modulus")?;
        positive("fluid.density", self.density, "the reference density")
    }
}

impl InitialFluid {
    /// A full start's pressure finite and >= 0; errors name `initial_fluid`.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        if let InitialFluid::Full(p) = *self {
            finite("initial_fluid", p)?;
            if p < 0.0 {
                return Err(SetupError::invalid(
                    "initial_fluid",
                    format!("pressure must be >= 0, got {p}"),
                ));
            }
        }
        Ok(())
    }
}

impl FlowBoundary {
    /// Finite position and value, a pump's positive parameters, a valid schedule; errors name
    /// `field.<field>` (`field`: `flow_boundaries[i]`).
    fn validate(&self, field: &str) -> Result<(), SetupError> {
        for &x in self.at.point() {
            finite(&format!("{field}.at"), x)?;
        }
        match self.kind {
            FlowBcKind::Rate(v) => finite(&format!("{field}.kind"), v)?,
            FlowBcKind::Pressure(v) => {
                finite(&format!("{field}.kind"), v)?;
                if !(0.0..=MAX_BOUNDARY_PRESSURE).contains(&v) {
                    return Err(SetupError::invalid(
                        &format!("{field}.kind"),
                        format!(
                            "a boundary pressure of {v:e} Pa is not in [0, \
                             {MAX_BOUNDARY_PRESSURE:e}] Pa (the fluid's pressure is absolute \
                             and a liquid holds no tension; above 10 GPa no rock holds it)"
                        ),
                    ));
                }
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
        validate_schedule(&format!("{field}.schedule"), &self.schedule)?;
        if !matches!(self.kind, FlowBcKind::Rate(_))
            && let Some(k) = self.schedule.iter().position(|s| s.1 < 0.0)
        {
            return Err(SetupError::invalid(
                &format!("{field}.schedule[{k}]"),
                format!(
                    "factor {} is negative: it multiplies a pressure, which must stay >= 0 \
                     (only a Rate boundary's factor may change sign: injection to withdrawal)",
                    self.schedule[k].1
                ),
            ));
        }
        Ok(())
    }
}

/// Every flow boundary valid, then their names (unnamed ones are `bc<index>`) all different;
/// errors name `flow_boundaries[i]...`.
pub(super) fn validate_flow_boundaries(boundaries: &[FlowBoundary]) -> Result<(), SetupError> {
    for (i, b) in boundaries.iter().enumerate() {
        b.validate(&format!("flow_boundaries[{i}]"))?;
    }
    let mut names: Vec<(String, usize)> = Vec::new();
    for (i, b) in boundaries.iter().enumerate() {
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
    Ok(())
}

/// Largest pressure a `Pressure` boundary may hold, Pa.
pub const MAX_BOUNDARY_PRESSURE: f64 = 1e10;

/// A schedule [(t s, factor)]: times that do not decrease and start at or after 0 (the first
/// offending entry is named `field[k]`), then every number finite (named `field`).
pub(super) fn validate_schedule(field: &str, s: &[(f64, f64)]) -> Result<(), SetupError> {
    if let Some(k) = s.iter().position(|p| p.0 < 0.0) {
        return Err(SetupError::invalid(
            &format!("{field}[{k}]"),
            format!("time {} s is negative: a run starts at t = 0 s", s[k].0),
        ));
    }
    for (k, w) in s.windows(2).enumerate() {
        if w[1].0 < w[0].0 || w[1].0.is_nan() {
            return Err(SetupError::invalid(
                &format!("{field}[{}]", k + 1),
                "times must not decrease",
            ));
        }
    }
    for (t, f) in s {
        finite(field, *t)?;
        finite(field, *f)?;
    }
    Ok(())
}
