//! Continuum heat verification (`heat_continuum`): a 1D thermal front against Ogata and Banks
//! at several resolutions, and a doublet sanity check (breakthrough, mass conservation,
//! mirror symmetry). See `docs/heat_continuum.md`.

use super::{CaseResult, Row, observed_order};
use crate::reservoir::continuum::{
    ContinuumRun, ContinuumSpec, EdgeCondition, Edges, Well, WellControl, bulk_conductivity,
    bulk_heat_capacity, run_continuum,
};
use crate::reservoir::{Grid2, ThermalProps};
use std::time::Instant;

/// Initial (reservoir) temperature of the set-ups, K (150 C).
pub const T_RESERVOIR: f64 = 423.15;
/// Injection temperature of the set-ups, K (50 C).
pub const T_INJECTION: f64 = 323.15;

/// `exp(x^2) erfc(x)` for `x >= 0` (Numerical Recipes' Chebyshev fit, relative error below
/// 1.2e-7), so that `exp(a) erfc(x)` can be formed without overflow.
fn erfc_scaled(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    t * (-1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
        .exp()
}

fn erfc(x: f64) -> f64 {
    if x >= 0.0 {
        erfc_scaled(x) * (-x * x).exp()
    } else {
        2.0 - erfc_scaled(-x) * (-x * x).exp()
    }
}

/// Ogata-Banks: the normalised temperature `(T - T0) / (T_inj - T0)` at `x` (m) and `t` (s) of
/// a semi-infinite medium with a step to `T_inj` at x = 0, front speed `v` (m/s) and
/// diffusivity `d` (m^2/s):
/// `0.5 [erfc((x - v t) / (2 sqrt(d t))) + exp(v x / d) erfc((x + v t) / (2 sqrt(d t)))]`.
pub fn ogata_banks(x: f64, t: f64, v: f64, d: f64) -> f64 {
    let s = 2.0 * (d * t).sqrt();
    let b = (x + v * t) / s;
    // exp(v x / d) erfc(b) = exp(v x / d - b^2) erfcx(b).
    0.5 * (erfc((x - v * t) / s) + (v * x / d - b * b).exp() * erfc_scaled(b))
}

/// The 1D front set-up: length, evaluation time, thermal front speed and diffusivity.
#[derive(Clone, Copy, Debug)]
pub struct Front {
    /// Domain length, m.
    pub length: f64,
    /// Time of the comparison, s.
    pub time: f64,
    /// Thermal front speed `rho_w c_w u / C`, m/s.
    pub speed: f64,
    /// Thermal diffusivity `lambda / C`, m^2/s.
    pub diffusivity: f64,
    /// Darcy velocity, m/s.
    pub darcy: f64,
}

/// Granite and water with 10 % porosity (so the fluid carries a visible share of the heat).
pub fn front_props() -> ThermalProps {
    ThermalProps {
        porosity: 0.1,
        ..ThermalProps::granite_water()
    }
}

/// The front: L = 100 m; at the comparison time the front has moved 0.4 L and spread over
/// `sqrt(D_T t) = 0.1 L` (global Peclet number `v_T t / sqrt(D_T t)` = 4; about 3 years).
pub fn front() -> Front {
    let p = front_props();
    let (cap, lambda) = (bulk_heat_capacity(&p), bulk_conductivity(&p));
    let length: f64 = 100.0;
    let diffusivity = lambda / cap;
    let time = (0.1 * length).powi(2) / diffusivity;
    let speed = 0.4 * length / time;
    Front {
        length,
        time,
        speed,
        diffusivity,
        darcy: speed * cap / p.fluid_rho_c(),
    }
}

/// The front on `n x 1` blocks with the step `courant dx / v_T` (rounded so that the steps end
/// at the comparison time): left edge held at the injection temperature and the higher
/// pressure, right edge at the reservoir temperature.
pub fn front_spec(n: usize, courant: f64) -> ContinuumSpec {
    let f = front();
    let props = front_props();
    let k = 1e-15;
    let dp = f.darcy * props.fluid_viscosity * f.length / k;
    let dx = f.length / n as f64;
    let steps = (f.time * f.speed / (courant * dx)).ceil();
    let p0 = 1e7;
    ContinuumSpec {
        grid: Grid2 {
            origin: [0.0, 0.0],
            size: [f.length, 1.0],
            n: [n, 1],
        },
        permeability: vec![[k, k]; n],
        props,
        initial_temperature: T_RESERVOIR,
        initial_pressure: p0,
        wells: Vec::new(),
        edges: Edges {
            left: EdgeCondition::Held {
                pressure: p0 + dp,
                temperature: T_INJECTION,
            },
            right: EdgeCondition::Held {
                pressure: p0,
                temperature: T_RESERVOIR,
            },
            ..Edges::default()
        },
        end_time: f.time,
        dt: f.time / steps,
        output_times: vec![f.time],
    }
}

/// Errors of a front run against Ogata-Banks at the comparison time, in the normalised
/// temperature: (largest over the blocks, L2 over the domain `sqrt(sum e^2 dx / L)`).
pub fn front_errors(spec: &ContinuumSpec, run: &ContinuumRun) -> (f64, f64) {
    let f = front();
    let n = spec.grid.n[0];
    let (mut max, mut sq) = (0.0f64, 0.0);
    for i in 0..n {
        let x = spec.grid.centre(i, 0)[0];
        let num = (run.temperature[i] - T_RESERVOIR) / (T_INJECTION - T_RESERVOIR);
        let e = num - ogata_banks(x, f.time, f.speed, f.diffusivity);
        max = max.max(e.abs());
        sq += e * e;
    }
    (max, (sq / n as f64).sqrt())
}

/// A doublet in a uniform field: `n x n` blocks of 10 m (n > 20 so that the wells are inside;
/// odd for a middle row), injector and producer 200 m apart on the middle row at `rate`
/// (m^2/s), closed edges, monthly steps for `years`.
pub fn doublet_spec(n: usize, rate: f64, years: f64) -> ContinuumSpec {
    let h = 10.0;
    let size = n as f64 * h;
    let mid = 0.5 * size;
    let year = 365.25 * 86400.0;
    let well = |name: &str, x: f64, q: f64| Well {
        name: name.into(),
        position: [x, mid],
        control: WellControl::Rate(q),
        injection_temperature: T_INJECTION,
        radius: 0.1,
        index: Default::default(),
    };
    ContinuumSpec {
        grid: Grid2 {
            origin: [0.0, 0.0],
            size: [size, size],
            n: [n, n],
        },
        permeability: vec![[1e-13, 1e-13]; n * n],
        props: ThermalProps::granite_water(),
        initial_temperature: T_RESERVOIR,
        initial_pressure: 2e7,
        wells: vec![
            well("injector", mid - 100.0, rate),
            well("producer", mid + 100.0, -rate),
        ],
        edges: Edges::default(),
        end_time: years * year,
        dt: year / 12.0,
        output_times: Vec::new(),
    }
}

/// Largest |f(i, j) - f(i, n1 - 1 - j)| over the blocks: mirror asymmetry about the middle row.
pub fn mirror_asymmetry(grid: &Grid2, f: &[f64]) -> f64 {
    let (nx, ny) = (grid.n[0], grid.n[1]);
    let mut worst = 0.0f64;
    for j in 0..ny {
        for i in 0..nx {
            worst = worst.max((f[grid.index(i, j)] - f[grid.index(i, ny - 1 - j)]).abs());
        }
    }
    worst
}

/// The `heat_continuum` case.
pub fn heat_continuum(quick: bool) -> anyhow::Result<CaseResult> {
    let mut res = CaseResult::default();
    let levels: &[usize] = if quick {
        &[50, 100, 200]
    } else {
        &[100, 200, 400, 800]
    };
    let f = front();
    let mut worst_energy = 0.0f64;
    let mut worst_mass = 0.0f64;
    for (level, &n) in levels.iter().enumerate() {
        let spec = front_spec(n, 0.5);
        let t0 = Instant::now();
        let run = run_continuum(&spec)?;
        let wall = t0.elapsed().as_secs_f64();
        let (max, l2) = front_errors(&spec, &run);
        worst_energy = worst_energy.max(run.energy_balance);
        worst_mass = worst_mass.max(run.mass_balance);
        for (metric, e) in [("front max |dT|/dT0", max), ("front L2 dT/dT0", l2)] {
            res.rows.push(Row {
                case: "heat_continuum",
                level,
                h: spec.grid.dx()[0],
                unknowns: spec.grid.len(),
                metric: metric.into(),
                error: e,
                wall_s: wall,
            });
        }
        if level + 1 == levels.len() {
            res.notes.push(format!(
                "front: L = {} m, t = {:.3e} s, v_T = {:.3e} m/s, D_T = {:.3e} m^2/s, Darcy u = \
                 {:.3e} m/s; finest grid Peclet v_T dx / D_T = {:.3}, Courant v_T dt / dx = 0.5, \
                 {} steps",
                f.length,
                f.time,
                f.speed,
                f.diffusivity,
                f.darcy,
                f.speed * spec.grid.dx()[0] / f.diffusivity,
                run.steps
            ));
        }
    }
    let max_errors = res.errors("front max |dT|/dT0");
    let finest = max_errors.last().map_or(f64::NAN, |e| e.1);
    // Upwind and backward Euler add v_T dx / 2 + v_T^2 dt / 2 to D_T: at the finest level
    // (800 blocks, grid Peclet 0.05; quick: 200 blocks, Peclet 0.2) that is 3.75 % (quick 15 %)
    // of D_T, measured as 0.5 % (quick 1.9 %) of the step in the profile.
    let tol = if quick { 0.03 } else { 0.01 };
    res.check_max("front max error at the finest level", finest, tol);
    res.check_range(
        "front observed order (upwind, backward Euler: 1)",
        observed_order(&max_errors),
        0.8,
        1.2,
    );
    res.check_max("front energy balance (worst level)", worst_energy, 1e-9);
    res.check_max("front mass balance (worst level)", worst_mass, 1e-9);

    // Doublet: 41 x 41 blocks of 10 m, wells 200 m apart, 1e-3 m^2/s, 5 years monthly.
    let spec = doublet_spec(41, 1e-3, 5.0);
    let t0 = Instant::now();
    let run = run_continuum(&spec)?;
    let wall = t0.elapsed().as_secs_f64();
    let tp = &run.production_temperature;
    let dt0 = T_RESERVOIR - T_INJECTION;
    let first_drop = tp
        .iter()
        .position(|&t| t < T_RESERVOIR - 0.01 * dt0)
        .map_or(f64::NAN, |k| run.times[k]);
    let cap = bulk_heat_capacity(&spec.props) / spec.props.fluid_rho_c();
    let t_th = std::f64::consts::PI * 200.0f64.powi(2) * cap / (3.0 * 1e-3);
    let year = 365.25 * 86400.0;
    res.notes.push(format!(
        "doublet 41 x 41, 5 years monthly: {:.3} s; production temperature {:.2} K -> {:.2} K, \
         1 % drop at {:.2} years (streamline estimate of the thermal breakthrough \
         pi d^2 C / (3 rho_w c_w q) = {:.2} years); power {:.3e} -> {:.3e} W/m",
        wall,
        tp[0],
        tp[tp.len() - 1],
        first_drop / year,
        t_th / year,
        run.thermal_power[0],
        run.thermal_power[run.thermal_power.len() - 1],
    ));
    res.check_max(
        "doublet initial production temperature - T0 (K)",
        (tp[0] - T_RESERVOIR).abs(),
        1e-9,
    );
    res.check_max(
        "doublet final production temperature drop / (T0 - T_inj), must exceed 0.1: 1 - drop",
        1.0 - (T_RESERVOIR - tp[tp.len() - 1]) / dt0,
        0.9,
    );
    let rises = tp.windows(2).map(|w| w[1] - w[0]).fold(0.0f64, f64::max);
    res.check_max(
        "doublet largest rise of the production temperature (K)",
        rises,
        1e-9,
    );
    res.check_max("doublet mass balance", run.mass_balance, 1e-9);
    res.check_max("doublet energy balance", run.energy_balance, 1e-9);
    let asym = mirror_asymmetry(&spec.grid, &run.temperature) / dt0;
    res.check_max("doublet mirror asymmetry of T / (T0 - T_inj)", asym, 1e-10);
    Ok(res)
}
