//! Discrete heat model: heat advected along the fracture cells of a [`NetworkFlow`] by its
//! steady flow, exchanging heat with conduction in impermeable rock (`docs/heat_discrete.md`).
//! SI units, everything per metre of thickness (plane strain).
//!
//! Unknowns: the fluid temperature `T_i` of every fracture cell and the temperature `T_k` of
//! every rock block of a tensor-product [`RockGrid`].
//!
//! - Fluid, cell `i` of length `L_i` and hydraulic aperture `b_i` (fluid volume `b_i L_i` per
//!   metre), upwind advection, no conduction in the fluid along the fracture:
//!
//!   ```text
//!   rho_w c_w b_i L_i dT_i/dt = rho_w c_w [ sum_in q T_up - sum_out q T_i
//!                                           + q_inj T_inj - |q_prod| T_i ]
//!                               + sum_pieces G_p (T_k(p) - T_i)
//!   ```
//!
//!   which, for the balanced steady flows the model requires ([`NetworkFlow::mass_imbalance`]
//!   at most [`MAX_MASS_IMBALANCE`]), is the advective form
//!   `sum_in q (T_up - T_i) + q_inj (T_inj - T_i)`; the conservative form is used so that the
//!   energy balance holds to round-off.
//! - Rock, block `k`: `rho_r c_r A_k dT_k/dt = sum_l G_kl (T_l - T_k) + sum_p G_p (T_i - T_k)`,
//!   two-point conductances `G_kl = K_r w_kl / (centre distance)` between neighbours (face
//!   width `w_kl`), insulated outer edges. Rock porosity is ignored (the fractures are the pore
//!   space) and the fluid volume is not removed from the blocks (b << block size).
//! - Fracture-rock exchange: every cell is cut by the grid lines into pieces. A piece of length
//!   `L_p` with unit tangent `t` is seen across its dominant normal axis `a` (y when
//!   `|t_x| >= |t_y|`, else x): in the column (row) of blocks containing its midpoint `m`, the
//!   two block centres `c_-` <= `m_a` < `c_+` that bracket it. The piece is a node on the rock
//!   connection between those two blocks: it covers the width `w_p = L_p |t_b|` of the face,
//!   the rock conductance of that connection keeps only the uncovered part,
//!   `K_r (w - sum w_p) / (c_+ - c_-)`, and the piece exchanges with each block through
//!   `G_p,± = K_r w_p / d_±`, `d_± = |c_± - m_a|` (at least 1e-3 of the centre spacing). A
//!   fracture on a grid line (a face) thus gets the exact half-block conductance
//!   `2 K_r w / h` to each side, and one through a block centre becomes the node of that block.
//!   A piece beyond the first or last centre exchanges with its block on the inner side only.
//!   Connections across the fracture along the other axis (oblique fractures) are not cut.
//! - Time: backward Euler on the coupled system (one sparse matrix, fluid rows first), solved
//!   in the shifted variable `T - T_0` by faer's sparse LU; the symbolic analysis is done once
//!   and the numeric factorisation only when the step changes.
//!
//! Energy balance, checked at the end to [`ENERGY_TOLERANCE`]: the change of stored heat
//! `sum C (T - T_0)` equals the advective heat injected `rho_w c_w q_inj (T_inj - T_0) dt`
//! minus that produced `rho_w c_w |q_prod| (T_i - T_0) dt`, summed over the steps.

use super::{HeatSeries, NetworkFlow, ReservoirError, Summation, ThermalProps};
use crate::sparse::SparsePattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu};
use faer::{Conj, MatMut, Par};
use serde::{Deserialize, Serialize};

/// Largest accepted [`NetworkFlow::mass_imbalance`].
pub const MAX_MASS_IMBALANCE: f64 = 1e-9;
/// Largest accepted relative energy-balance error of a run.
pub const ENERGY_TOLERANCE: f64 = 1e-9;
/// Smallest piece-to-centre distance, as a fraction of the centre spacing it lies in.
const MIN_DISTANCE_FRACTION: f64 = 1e-3;

/// A tensor-product grid of rock blocks: block `(i, j)` spans `[x[i], x[i+1]] x [y[j], y[j+1]]`
/// (m) and has index `i + nx * j` (as [`super::Grid2`]). Edges strictly increasing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RockGrid {
    /// Block edges in x, m (at least two).
    pub x: Vec<f64>,
    /// Block edges in y, m (at least two).
    pub y: Vec<f64>,
}

impl RockGrid {
    /// The blocks of a regular grid.
    pub fn from_grid2(g: &super::Grid2) -> Self {
        let d = g.dx();
        let axis = |k: usize| -> Vec<f64> {
            (0..=g.n[k])
                .map(|i| {
                    if i == g.n[k] {
                        g.origin[k] + g.size[k]
                    } else {
                        g.origin[k] + i as f64 * d[k]
                    }
                })
                .collect()
        };
        RockGrid {
            x: axis(0),
            y: axis(1),
        }
    }

    /// A grid graded towards lines: along each axis, edges lie exactly on every position in
    /// `lines_x` (resp. `lines_y`) and the spacing grows geometrically away from the nearest
    /// one, `h_min growth^k`, up to `h_max` (uniform `h_max` along an axis without lines).
    /// `lo`, `hi`: the corners, m.
    pub fn graded(
        lo: [f64; 2],
        hi: [f64; 2],
        lines_x: &[f64],
        lines_y: &[f64],
        h_min: f64,
        growth: f64,
        h_max: f64,
    ) -> Result<Self, ReservoirError> {
        if !(h_min.is_finite() && h_min > 0.0 && h_max.is_finite() && h_max >= h_min) {
            return Err(ReservoirError::invalid(
                "grid.h_min",
                format!("need 0 < h_min <= h_max, got {h_min} and {h_max}"),
            ));
        }
        if !(growth.is_finite() && growth >= 1.0) {
            return Err(ReservoirError::invalid(
                "grid.growth",
                format!("must be finite and >= 1, got {growth}"),
            ));
        }
        Ok(RockGrid {
            x: graded_axis(lo[0], hi[0], lines_x, h_min, growth, h_max, "grid.x")?,
            y: graded_axis(lo[1], hi[1], lines_y, h_min, growth, h_max, "grid.y")?,
        })
    }

    pub fn nx(&self) -> usize {
        self.x.len() - 1
    }
    pub fn ny(&self) -> usize {
        self.y.len() - 1
    }
    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.nx() * self.ny()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn index(&self, i: usize, j: usize) -> usize {
        i + self.nx() * j
    }
    /// Block area, m^2.
    pub fn area(&self, i: usize, j: usize) -> f64 {
        (self.x[i + 1] - self.x[i]) * (self.y[j + 1] - self.y[j])
    }
    /// Whether `p` lies in the grid (edges included).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        p[0] >= self.x[0]
            && p[0] <= self.x[self.nx()]
            && p[1] >= self.y[0]
            && p[1] <= self.y[self.ny()]
    }
    fn check(&self) -> Result<(), ReservoirError> {
        for (name, e) in [("grid.x", &self.x), ("grid.y", &self.y)] {
            if e.len() < 2 {
                return Err(ReservoirError::invalid(name, "needs at least two edges"));
            }
            if let Some(k) = e.iter().position(|v| !v.is_finite()) {
                return Err(ReservoirError::invalid(
                    name,
                    format!("edge {k} is {}", e[k]),
                ));
            }
            if let Some(k) = e.windows(2).position(|w| w[1] <= w[0]) {
                return Err(ReservoirError::invalid(
                    name,
                    format!("edges must increase strictly (edge {} <= edge {k})", k + 1),
                ));
            }
        }
        Ok(())
    }
}

/// Block index along one axis of edges `e` containing `v` (the far edge belongs to the last).
fn block_along(e: &[f64], v: f64) -> usize {
    e.partition_point(|&x| x <= v)
        .saturating_sub(1)
        .min(e.len() - 2)
}

/// Edges on `[lo, hi]` graded towards `lines` (see [`RockGrid::graded`]).
fn graded_axis(
    lo: f64,
    hi: f64,
    lines: &[f64],
    h_min: f64,
    growth: f64,
    h_max: f64,
    field: &str,
) -> Result<Vec<f64>, ReservoirError> {
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Err(ReservoirError::invalid(
            field,
            format!("need lo < hi, got [{lo}, {hi}]"),
        ));
    }
    let mut pts: Vec<f64> = lines.to_vec();
    if let Some(p) = pts.iter().find(|p| !(**p >= lo && **p <= hi)) {
        return Err(ReservoirError::invalid(
            field,
            format!("refinement line {p} outside [{lo}, {hi}]"),
        ));
    }
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    // Breakpoints with a flag: refined (a line) or not (an end that is not a line).
    let mut bp: Vec<(f64, bool)> = Vec::new();
    if pts.first() != Some(&lo) {
        bp.push((lo, false));
    }
    bp.extend(pts.iter().map(|&p| (p, true)));
    if pts.last() != Some(&hi) {
        bp.push((hi, false));
    }
    // Sizes marching away from a refined end over `len`, scaled to fill it exactly.
    let march = |len: f64| -> Vec<f64> {
        let mut s = Vec::new();
        let (mut h, mut sum) = (h_min, 0.0);
        while sum < len {
            s.push(h.min(h_max));
            sum += h.min(h_max);
            h *= growth;
        }
        // Drop the last cell when that fits the length better.
        if s.len() > 1 {
            let without = sum - s[s.len() - 1];
            if (len - without).abs() < (sum - len).abs() {
                s.pop();
                sum = without;
            }
        }
        s.iter().map(|h| h * len / sum).collect()
    };
    let mut edges = vec![lo];
    for w in bp.windows(2) {
        let ((a, ra), (b, rb)) = (w[0], w[1]);
        let len = b - a;
        let sizes: Vec<f64> = match (ra, rb) {
            (false, false) => {
                let n = (len / h_max).ceil().max(1.0) as usize;
                vec![len / n as f64; n]
            }
            (true, false) => march(len),
            (false, true) => {
                let mut s = march(len);
                s.reverse();
                s
            }
            (true, true) => {
                let mut s = march(0.5 * len);
                let mut back = s.clone();
                back.reverse();
                s.extend(back);
                s
            }
        };
        let mut x = a;
        for h in &sizes[..sizes.len() - 1] {
            x += h;
            edges.push(x);
        }
        edges.push(b);
    }
    Ok(edges)
}

/// The time-step rule. Steps are shortened to land on the output times and the end time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum TimeStep {
    /// Constant step, s.
    Fixed {
        /// Step, s.
        dt: f64,
    },
    /// Growing steps `dt_k = min(first growth^k, max)`, s: small steps while the front in the
    /// rock is thin, long ones later. Each new step refactorises (numerically) the matrix.
    Geometric {
        /// First step, s.
        first: f64,
        /// Growth factor per step (>= 1).
        growth: f64,
        /// Largest step, s.
        max: f64,
    },
}

/// A discrete heat run. The flow field ([`NetworkFlow`]) is passed separately.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiscreteSpec {
    /// The rock blocks, m; must contain every fracture cell.
    pub grid: RockGrid,
    /// Rock and fluid properties (the porosity is not used: the fractures are the pore space).
    pub props: ThermalProps,
    /// Initial temperature of rock and fluid, uniform, K.
    pub initial_temperature: f64,
    /// Temperature of the injected fluid, K.
    pub injection_temperature: f64,
    /// End of the run, s.
    pub end_time: f64,
    /// Time-step rule, s.
    pub time_step: TimeStep,
    /// Times of the temperature snapshots, s: increasing, in (0, end_time].
    #[serde(default)]
    pub output_times: Vec<f64>,
}

/// Temperatures at one output time.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Snapshot {
    /// s.
    pub time: f64,
    /// Fluid temperature per fracture cell, K.
    pub cell_temperature: Vec<f64>,
    /// Rock temperature per block (index `i + nx j`), K.
    pub rock_temperature: Vec<f64>,
}

/// Heat accounts of a run, J per metre, relative to the initial temperature.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct EnergyBalance {
    /// Change of heat stored in fluid and rock, `sum C (T - T_0)`.
    pub stored: f64,
    /// Advective heat injected, `sum dt rho_w c_w q_inj (T_inj - T_0)`.
    pub injected: f64,
    /// Advective heat produced, `sum dt rho_w c_w |q_prod| (T_i - T_0)`.
    pub produced: f64,
    /// `|stored - (injected - produced)| / max(|stored|, |injected|, |produced|)`.
    pub relative_error: f64,
}

/// Result of [`run_discrete`]: one entry per step in the time series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiscreteRun {
    /// End time of each step, s.
    pub times: Vec<f64>,
    /// Flux-weighted fluid temperature over the producing cells, K.
    pub production_temperature: Vec<f64>,
    /// `rho_w c_w |Q_prod| (T_prod - T_inj)`, W per metre.
    pub thermal_power: Vec<f64>,
    /// Time integral of the thermal power (backward Euler), J per metre.
    pub cumulative_heat: Vec<f64>,
    /// Temperatures at the output times.
    pub snapshots: Vec<Snapshot>,
    pub energy_balance: EnergyBalance,
    /// Numeric LU factorisations done (one per distinct step length in sequence).
    pub factorisations: usize,
    /// Unknowns: cells + blocks.
    pub unknowns: usize,
}

/// One fracture-rock exchange: (cell, block, conductance W/(m K)).
pub type Exchange = (usize, usize, f64);

/// The assembled model: geometry, conductances and the matrix pattern.
pub struct DiscreteModel {
    spec: DiscreteSpec,
    n_cells: usize,
    n_blocks: usize,
    /// Heat capacity per unknown, J/(m K).
    cap: Vec<f64>,
    /// Fracture-rock exchanges.
    exchanges: Vec<Exchange>,
    /// Matrix values without the capacity term.
    base: Vec<f64>,
    diag: Vec<usize>,
    pattern: SparsePattern,
    symbolic: SymbolicLu<usize>,
    mem: MemBuffer,
    /// rho_w c_w q_inj per injecting entry: (cell, W/(m K)).
    inject: Vec<(usize, f64)>,
    /// rho_w c_w |q_prod| per producing entry: (cell, W/(m K)).
    produce: Vec<(usize, f64)>,
}

impl std::fmt::Debug for DiscreteModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DiscreteModel")
            .field("n_cells", &self.n_cells)
            .field("n_blocks", &self.n_blocks)
            .field("exchanges", &self.exchanges.len())
            .finish_non_exhaustive()
    }
}

fn positive(field: &str, v: f64) -> Result<(), ReservoirError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ReservoirError::invalid(
            field,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}

fn check_spec(spec: &DiscreteSpec) -> Result<(), ReservoirError> {
    spec.grid.check()?;
    let p = &spec.props;
    for (name, v) in [
        ("props.rock_density", p.rock_density),
        ("props.rock_heat_capacity", p.rock_heat_capacity),
        ("props.rock_conductivity", p.rock_conductivity),
        ("props.fluid_density", p.fluid_density),
        ("props.fluid_heat_capacity", p.fluid_heat_capacity),
        ("initial_temperature", spec.initial_temperature),
        ("injection_temperature", spec.injection_temperature),
        ("end_time", spec.end_time),
    ] {
        positive(name, v)?;
    }
    let steps = match spec.time_step {
        TimeStep::Fixed { dt } => {
            positive("time_step.dt", dt)?;
            spec.end_time / dt
        }
        TimeStep::Geometric { first, growth, max } => {
            positive("time_step.first", first)?;
            positive("time_step.max", max)?;
            if !(growth.is_finite() && growth >= 1.0) {
                return Err(ReservoirError::invalid(
                    "time_step.growth",
                    format!("must be finite and >= 1, got {growth}"),
                ));
            }
            if max < first {
                return Err(ReservoirError::invalid(
                    "time_step.max",
                    format!("{max} is below the first step {first}"),
                ));
            }
            spec.end_time / max
        }
    };
    if steps > 1e7 {
        return Err(ReservoirError::invalid(
            "time_step",
            format!("{steps:.3e} steps to the end time (at most 1e7)"),
        ));
    }
    let mut last = 0.0;
    for (k, &t) in spec.output_times.iter().enumerate() {
        if !(t.is_finite() && t > last && t <= spec.end_time) {
            return Err(ReservoirError::invalid(
                "output_times",
                format!(
                    "entry {k} = {t} must be finite, after the previous one and in (0, end_time = {}]",
                    spec.end_time
                ),
            ));
        }
        last = t;
    }
    Ok(())
}

fn check_flow(flow: &NetworkFlow, grid: &RockGrid) -> Result<(), ReservoirError> {
    let (nn, nc) = (flow.nodes.len(), flow.cells.len());
    if nc == 0 {
        return Err(ReservoirError::invalid("flow.cells", "no fracture cells"));
    }
    if let Some(k) = flow
        .nodes
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(ReservoirError::invalid(
            "flow.nodes",
            format!("node {k} is not finite: {:?}", flow.nodes[k]),
        ));
    }
    for (c, &(a, b, ap)) in flow.cells.iter().enumerate() {
        if a as usize >= nn || b as usize >= nn {
            return Err(ReservoirError::invalid(
                "flow.cells",
                format!("cell {c} names node {} of {nn}", a.max(b)),
            ));
        }
        if !(ap.is_finite() && ap > 0.0) {
            return Err(ReservoirError::invalid(
                "flow.cells",
                format!("cell {c}: aperture {ap} must be finite and > 0"),
            ));
        }
        let len = flow.cell_length(c);
        if len.is_nan() || len <= 0.0 {
            return Err(ReservoirError::invalid(
                "flow.cells",
                format!("cell {c} has zero length"),
            ));
        }
        for n in [a, b] {
            let p = flow.nodes[n as usize];
            if !grid.contains(p) {
                return Err(ReservoirError::invalid(
                    "flow.cells",
                    format!(
                        "cell {c}: node {n} at ({}, {}) lies outside the rock grid [{}, {}] x [{}, {}]",
                        p[0],
                        p[1],
                        grid.x[0],
                        grid.x[grid.nx()],
                        grid.y[0],
                        grid.y[grid.ny()]
                    ),
                ));
            }
        }
    }
    for (k, &(i, j, q)) in flow.fluxes.iter().enumerate() {
        if i as usize >= nc || j as usize >= nc || i == j {
            return Err(ReservoirError::invalid(
                "flow.fluxes",
                format!("entry {k}: cells ({i}, {j}) must be two distinct cells of {nc}"),
            ));
        }
        if !q.is_finite() {
            return Err(ReservoirError::invalid(
                "flow.fluxes",
                format!("entry {k}: flux {q} is not finite"),
            ));
        }
    }
    for (k, &(c, q)) in flow.boundary.iter().enumerate() {
        if c as usize >= nc {
            return Err(ReservoirError::invalid(
                "flow.boundary",
                format!("entry {k}: cell {c} of {nc}"),
            ));
        }
        if !q.is_finite() {
            return Err(ReservoirError::invalid(
                "flow.boundary",
                format!("entry {k}: rate {q} is not finite"),
            ));
        }
    }
    if !flow.boundary.iter().any(|&(_, q)| q < 0.0) {
        return Err(ReservoirError::invalid(
            "flow.boundary",
            "no producing cell (q < 0): the production temperature is undefined",
        ));
    }
    let imb = flow.mass_imbalance();
    if imb.is_nan() || imb > MAX_MASS_IMBALANCE {
        return Err(ReservoirError::invalid(
            "flow.fluxes",
            format!(
                "the steady flow is not balanced: mass imbalance {imb:.3e} of the largest flux (at most {MAX_MASS_IMBALANCE:e})"
            ),
        ));
    }
    Ok(())
}

/// The fracture-rock exchanges and the cut widths of the rock connections (module doc).
/// Returns (exchanges, cut widths of x-connections `i + (nx-1) j`, of y-connections `i + nx j`).
fn exchanges(flow: &NetworkFlow, g: &RockGrid, k_r: f64) -> (Vec<Exchange>, Vec<f64>, Vec<f64>) {
    let (nx, ny) = (g.nx(), g.ny());
    let centres = |e: &[f64]| -> Vec<f64> { e.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect() };
    let (cx, cy) = (centres(&g.x), centres(&g.y));
    let mut cut_x = vec![0.0; (nx - 1) * ny];
    let mut cut_y = vec![0.0; nx * (ny - 1)];
    let mut out = Vec::new();
    let mut ts = Vec::new();
    for (c, &(a, b, _)) in flow.cells.iter().enumerate() {
        let (pa, pb) = (flow.nodes[a as usize], flow.nodes[b as usize]);
        let d = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = d[0].hypot(d[1]);
        let t = [d[0] / len, d[1] / len];
        ts.clear();
        ts.push(0.0);
        ts.push(1.0);
        for (k, e) in [&g.x, &g.y].into_iter().enumerate() {
            if d[k] == 0.0 {
                continue;
            }
            let (lo, hi) = (pa[k].min(pb[k]), pa[k].max(pb[k]));
            let start = e.partition_point(|&v| v <= lo);
            for &v in &e[start..] {
                if v >= hi {
                    break;
                }
                ts.push((v - pa[k]) / d[k]);
            }
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup_by(|x, y| (*x - *y).abs() <= 1e-12);
        for w in ts.windows(2) {
            let lp = len * (w[1] - w[0]);
            if lp <= 0.0 {
                continue;
            }
            let tm = 0.5 * (w[0] + w[1]);
            let m = [pa[0] + tm * d[0], pa[1] + tm * d[1]];
            // Dominant normal axis `ax`, the other `bx`.
            let (ax, bx) = if t[0].abs() >= t[1].abs() {
                (1, 0)
            } else {
                (0, 1)
            };
            let wp = lp * t[bx].abs();
            let (ce, eb) = if ax == 1 { (&cy, &g.x) } else { (&cx, &g.y) };
            let ib = block_along(eb, m[bx]);
            let n_a = ce.len();
            // Last centre <= m_a.
            let jm = ce.partition_point(|&v| v <= m[ax]);
            let block = |ja: usize| {
                if ax == 1 {
                    g.index(ib, ja)
                } else {
                    g.index(ja, ib)
                }
            };
            if jm == 0 || jm == n_a {
                // Beyond the first or last centre: the inner side only.
                let ja = if jm == 0 { 0 } else { n_a - 1 };
                let ea = if ax == 1 { &g.y } else { &g.x };
                let spacing = ea[ja + 1] - ea[ja];
                let dist = (ce[ja] - m[ax]).abs().max(MIN_DISTANCE_FRACTION * spacing);
                out.push((c, block(ja), k_r * wp / dist));
                continue;
            }
            let (j0, j1) = (jm - 1, jm);
            let spacing = ce[j1] - ce[j0];
            let floor = MIN_DISTANCE_FRACTION * spacing;
            let d0 = (m[ax] - ce[j0]).max(floor);
            let d1 = (ce[j1] - m[ax]).max(floor);
            out.push((c, block(j0), k_r * wp / d0));
            out.push((c, block(j1), k_r * wp / d1));
            if ax == 1 {
                cut_y[ib + nx * j0] += wp;
            } else {
                cut_x[j0 + (nx - 1) * ib] += wp;
            }
        }
    }
    (out, cut_x, cut_y)
}

impl DiscreteModel {
    /// Validates the inputs and assembles the model (geometry, conductances, matrix pattern,
    /// symbolic LU).
    pub fn new(spec: &DiscreteSpec, flow: &NetworkFlow) -> Result<Self, ReservoirError> {
        check_spec(spec)?;
        check_flow(flow, &spec.grid)?;
        let g = &spec.grid;
        let p = &spec.props;
        let (nc, nb) = (flow.cells.len(), g.len());
        let n = nc + nb;
        let (nx, ny) = (g.nx(), g.ny());
        let rwcw = p.fluid_rho_c();
        let kr = p.rock_conductivity;
        let (ex, cut_x, cut_y) = exchanges(flow, g, kr);

        // Capacities.
        let mut cap = Vec::with_capacity(n);
        for (c, &(_, _, ap)) in flow.cells.iter().enumerate() {
            cap.push(rwcw * ap * flow.cell_length(c));
        }
        for j in 0..ny {
            for i in 0..nx {
                cap.push(p.rock_rho_c() * g.area(i, j));
            }
        }

        // Rock connections (k, l, G), unknown indices.
        let mut rock = Vec::with_capacity(2 * nb);
        let cx: Vec<f64> = g.x.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        let cy: Vec<f64> = g.y.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        for j in 0..ny {
            let w = g.y[j + 1] - g.y[j];
            for i in 0..nx.saturating_sub(1) {
                let open = (w - cut_x[i + (nx - 1) * j]).max(0.0);
                rock.push((
                    nc + g.index(i, j),
                    nc + g.index(i + 1, j),
                    kr * open / (cx[i + 1] - cx[i]),
                ));
            }
        }
        for j in 0..ny.saturating_sub(1) {
            for i in 0..nx {
                let w = g.x[i + 1] - g.x[i];
                let open = (w - cut_y[i + nx * j]).max(0.0);
                rock.push((
                    nc + g.index(i, j),
                    nc + g.index(i, j + 1),
                    kr * open / (cy[j + 1] - cy[j]),
                ));
            }
        }

        // Pattern.
        let mut entries: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        let mut adv = Vec::with_capacity(flow.fluxes.len());
        for &(i, j, q) in &flow.fluxes {
            // (upstream, downstream, |q|)
            let (u, d) = if q >= 0.0 { (i, j) } else { (j, i) };
            adv.push((u as usize, d as usize, q.abs()));
            entries.push((d as usize, u as usize));
        }
        for &(c, k, _) in &ex {
            entries.push((c, nc + k));
            entries.push((nc + k, c));
        }
        for &(k, l, _) in &rock {
            entries.push((k, l));
            entries.push((l, k));
        }
        let pattern =
            SparsePattern::from_entries(n, entries).map_err(|why| ReservoirError::Solve {
                what: "heat_discrete pattern".into(),
                why,
            })?;
        let slot = |r: usize, c: usize| pattern.slot(r, c).expect("entry is in the pattern");
        let diag: Vec<usize> = (0..n).map(|i| slot(i, i)).collect();
        let mut base = vec![0.0; pattern.nnz()];
        for &(u, d, q) in &adv {
            base[diag[u]] += rwcw * q;
            base[slot(d, u)] -= rwcw * q;
        }
        let mut inject = Vec::new();
        let mut produce = Vec::new();
        for &(c, q) in &flow.boundary {
            let c = c as usize;
            if q > 0.0 {
                inject.push((c, rwcw * q));
            } else if q < 0.0 {
                base[diag[c]] += rwcw * -q;
                produce.push((c, rwcw * -q));
            }
        }
        for &(c, k, gk) in &ex {
            base[diag[c]] += gk;
            base[diag[nc + k]] += gk;
            base[slot(c, nc + k)] -= gk;
            base[slot(nc + k, c)] -= gk;
        }
        for &(k, l, gk) in &rock {
            base[diag[k]] += gk;
            base[diag[l]] += gk;
            base[slot(k, l)] -= gk;
            base[slot(l, k)] -= gk;
        }
        let (symbolic, mem) = pattern.symbolic_lu().map_err(|why| ReservoirError::Solve {
            what: "heat_discrete".into(),
            why,
        })?;
        Ok(DiscreteModel {
            spec: spec.clone(),
            n_cells: nc,
            n_blocks: nb,
            cap,
            exchanges: ex,
            base,
            diag,
            pattern,
            symbolic,
            mem,
            inject,
            produce,
        })
    }

    /// Fracture-rock exchanges: (cell, block, conductance in W/(m K)).
    pub fn exchanges(&self) -> &[Exchange] {
        &self.exchanges
    }

    /// Unknowns: cells, then blocks.
    pub fn unknowns(&self) -> usize {
        self.n_cells + self.n_blocks
    }

    /// Heat capacity per unknown (cells, then blocks), J/(m K).
    pub fn capacities(&self) -> &[f64] {
        &self.cap
    }

    /// The spec the model was built from.
    pub fn spec(&self) -> &DiscreteSpec {
        &self.spec
    }

    /// Runs the model from the uniform initial temperature to the end time (each call starts
    /// afresh from the initial state).
    pub fn run(&mut self) -> Result<DiscreteRun, ReservoirError> {
        let spec = self.spec.clone();
        let spec = &spec;
        let span = tracing::info_span!(target: "hydrofrac::system", "heat_discrete");
        let n = self.unknowns();
        let nc = self.n_cells;
        let t0 = spec.initial_temperature;
        let du_inj = spec.injection_temperature - t0;
        let rwcw = spec.props.fluid_rho_c();
        let q_prod: f64 = self.produce.iter().map(|p| p.1).sum::<f64>() / rwcw;
        let inj_power: f64 = self.inject.iter().map(|p| p.1).sum::<f64>() * du_inj;

        let mut u = vec![0.0; n];
        let mut rhs = vec![0.0; n];
        let mut values = vec![0.0; self.base.len()];
        let mut numeric = NumericLu::<usize, f64>::new();
        let mut factored_dt = f64::NAN;
        let mut factorisations = 0;

        let mut series = HeatSeries::new(Summation::Plain, 0);
        let mut snapshots = Vec::new();
        let (mut injected, mut produced) = (0.0f64, 0.0f64);
        let mut t = 0.0f64;
        let mut next_out = 0;
        let mut k_step = 0i32;
        while t < spec.end_time {
            let _enter = span.enter();
            let (dt, t1) = step_to(spec, k_step, t, next_out);
            k_step = k_step.saturating_add(1);
            if dt != factored_dt {
                self.factorise(&mut values, &mut numeric, dt)?;
                factored_dt = dt;
                factorisations += 1;
            }
            for ((r, &c), &x) in rhs.iter_mut().zip(&self.cap).zip(&u) {
                *r = c / dt * x;
            }
            for &(c, w) in &self.inject {
                rhs[c] += w * du_inj;
            }
            // `numeric` was produced by `factorize_numeric_lu` with this symbolic analysis.
            let lu = LuRef::new_unchecked(&self.symbolic, &numeric);
            lu.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut rhs, n, 1),
                Par::Seq,
                MemStack::new(&mut self.mem),
            );
            check_finite(&rhs, nc, t1)?;
            std::mem::swap(&mut u, &mut rhs);
            t = t1;

            let prod_heat: f64 = self.produce.iter().map(|&(c, w)| w * u[c]).sum();
            injected += dt * inj_power;
            produced += dt * prod_heat;
            // T_prod - T_0, flux-weighted.
            let du_prod = prod_heat / (rwcw * q_prod);
            let power = rwcw * q_prod * (du_prod - du_inj);
            series.record(t, dt, Some(t0 + du_prod), power);
            if next_out < spec.output_times.len() && t == spec.output_times[next_out] {
                snapshots.push(Snapshot {
                    time: t,
                    cell_temperature: u[..nc].iter().map(|x| t0 + x).collect(),
                    rock_temperature: u[nc..].iter().map(|x| t0 + x).collect(),
                });
                next_out += 1;
            }
        }
        let stored: f64 = self.cap.iter().zip(&u).map(|(c, x)| c * x).sum();
        let energy_balance = EnergyBalance::checked(stored, injected, produced)?;
        let HeatSeries {
            times,
            production_temperature,
            thermal_power,
            cumulative_heat,
            ..
        } = series;
        Ok(DiscreteRun {
            times,
            production_temperature,
            thermal_power,
            cumulative_heat,
            snapshots,
            energy_balance,
            factorisations,
            unknowns: n,
        })
    }
}

impl DiscreteModel {
    /// The numeric LU of the matrix of a step `dt` (s), `base` plus the capacities over dt
    /// (W/(m K)) on the diagonal, assembled in `values`, into `numeric`.
    fn factorise(
        &mut self,
        values: &mut [f64],
        numeric: &mut NumericLu<usize, f64>,
        dt: f64,
    ) -> Result<(), ReservoirError> {
        values.copy_from_slice(&self.base);
        for (i, &c) in self.cap.iter().enumerate() {
            values[self.diag[i]] += c / dt;
        }
        let a = SparseColMatRef::new(self.pattern.as_ref(), values);
        self.symbolic
            .factorize_numeric_lu(
                numeric,
                a,
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| ReservoirError::Solve {
                what: "heat_discrete LU".into(),
                why: format!("{e:?}"),
            })?;
        Ok(())
    }
}

/// The length (s) and end (s) of step `k_step` from `t` (s): the rule's step, shortened to
/// land on the next output time (from `next_out`) or the end time, and stretched to it
/// rather than leave a sliver under 1e-6 of the rule's step.
fn step_to(spec: &DiscreteSpec, k_step: i32, t: f64, next_out: usize) -> (f64, f64) {
    let rule = match spec.time_step {
        TimeStep::Fixed { dt } => dt,
        TimeStep::Geometric { first, growth, max } => {
            (first * growth.powi(k_step.min(100_000))).min(max)
        }
    };
    let target = spec
        .output_times
        .get(next_out)
        .copied()
        .unwrap_or(spec.end_time)
        .min(spec.end_time);
    let mut dt = rule.min(target - t);
    // Avoid a sliver step before the target.
    if target - (t + dt) < 1e-6 * rule {
        dt = target - t;
    }
    let t1 = if dt == target - t { target } else { t + dt };
    (dt, t1)
}

/// An error naming the first unknown of `u` (K relative to T0; `nc` cells, then blocks) that
/// is not finite at `t1` (s), if any.
fn check_finite(u: &[f64], nc: usize, t1: f64) -> Result<(), ReservoirError> {
    if let Some(k) = u.iter().position(|v| !v.is_finite()) {
        return Err(ReservoirError::Solve {
            what: "heat_discrete step".into(),
            why: format!(
                "non-finite temperature at t = {t1:e} s in {}",
                if k < nc {
                    format!("cell {k}")
                } else {
                    format!("block {}", k - nc)
                }
            ),
        });
    }
    Ok(())
}

impl EnergyBalance {
    /// The accounts of a run (J per metre: heat stored, injected and produced) with their
    /// relative error; an error when that exceeds [`ENERGY_TOLERANCE`] (or is NaN).
    fn checked(stored: f64, injected: f64, produced: f64) -> Result<Self, ReservoirError> {
        let scale = stored.abs().max(injected.abs()).max(produced.abs());
        let relative_error = if scale > 0.0 {
            (stored - (injected - produced)).abs() / scale
        } else {
            0.0
        };
        if relative_error.is_nan() || relative_error > ENERGY_TOLERANCE {
            return Err(ReservoirError::Solve {
                what: "heat_discrete energy balance".into(),
                why: format!(
                    "relative error {relative_error:.3e} (stored {stored:.6e}, injected {injected:.6e}, produced {produced:.6e} J/m) exceeds {ENERGY_TOLERANCE:e}"
                ),
            });
        }
        Ok(EnergyBalance {
            stored,
            injected,
            produced,
            relative_error,
        })
    }
}

/// Validates the inputs, assembles the model and runs it (see the module documentation).
pub fn run_discrete(
    spec: &DiscreteSpec,
    flow: &NetworkFlow,
) -> Result<DiscreteRun, ReservoirError> {
    DiscreteModel::new(spec, flow)?.run()
}
