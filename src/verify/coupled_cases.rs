//! Coupled verification case (`docs/verification.md` R6): `kgd`, the shipped `scenarios/kgd.ron`
//! at several mesh sizes with both flow schemes, against the viscosity-dominated KGD similarity
//! solution:
//!   l(t) = 0.61524 (E' Q0^3 t^4 / mu')^(1/6),  w0(t) = 1.1233 (mu' Q0^3 t^2 / E')^(1/6),
//!   p0(t) = 0.5443 (mu' E'^2 / t)^(1/3),  mu' = 12 mu, Q0 = 2 x the half model's rate.
//!
//! The strength criterion on h-sized elements acts like a toughness that falls with h, so the
//! errors fall with refinement (README, "KGD"). Measured at h = 2 / 1 / 0.5 / 0.25 m (implicit;
//! explicit alike): length -28 / -12 / -2.3 / +1.8 %, opening +38 / +9 / +1.7 / -0.4 %,
//! pressure +80 / +20 / +6.7 / +3.8 %.
//!
//! Three schemes: the explicit rock with the explicit or the implicit flow step, and the
//! quasi-static rock coupled with backward-Euler flow (`_quasi_static`).
//! Checks: every run conserves mass to 1e-9; every error falls from the coarsest to the
//! finest mesh; the schemes give the same length to one cell; at h <= 1 m the quasi-static
//! errors are within 2 points of the explicit ones; and in the full run (not
//! `--quick`, which stops at h = 1 m) every error is within the 5 % target (`docs/verification.md` R6) at h = 0.25 m
//! (125 cells along the half-length). Metrics: `length_*`, `opening_*`, `pressure_*` (relative
//! errors at the end time, suffixed by scheme).

use super::{CaseResult, LinePlot, Row};
use crate::plot::Series;
use crate::scenario::{Boundary, Scenario};
use crate::sim::{Finish, Simulation};
use std::time::Instant;

const KGD_RON: &str = include_str!("../../scenarios/kgd.ron");
/// K_Ic of the `kgd` case's toughness-criterion runs, Pa sqrt(m).
pub const KGD_TOUGHNESS: f64 = 2.4e6;
const KGD_K_RON: &str = include_str!("../../scenarios/kgd_toughness.ron");
const KGD_M_RON: &str = include_str!("../../scenarios/kgd_m.ron");

/// One KGD run at the end time: half-length (m), well opening (m), net well pressure (Pa),
/// the similarity solution's (l, w0, p0), the mass-balance error, wall time (s), unknowns.
pub struct KgdRun {
    pub l: f64,
    /// Half-length to the tracked tip (`systems::toughness::Tips::tracked`), m; the mesh
    /// tip's without the toughness criterion.
    pub l_tracked: f64,
    pub w0: f64,
    pub p0: f64,
    /// Fluid lag, m: from the far end of the farthest full cell on the fracture line to the
    /// mesh tip (the similarity solutions have none; `docs/toughness.md`, "Limits").
    pub lag: f64,
    /// Half-length to the fluid front, m: the farthest full cell's far end plus, for each
    /// filling cell beyond it, its length times its filled fraction m / (rho_r V).
    pub l_front: f64,
    pub exact: [f64; 3],
    pub balance: f64,
    pub wall: f64,
    pub unknowns: usize,
    /// Toughness-dominated runs: the well's errors at every step (`Band`).
    pub band: Option<Band>,
}

/// The signed relative errors of the well pressure and opening at every step's end of a
/// toughness-dominated run, against the similarity solution at that time: the saw-tooth of
/// growth by whole edges.
#[derive(Clone, Debug, Default)]
pub struct Band {
    /// Every step: (time s, pressure error, opening error, whether it opened an edge).
    pub history: Vec<(f64, f64, f64, bool)>,
}

/// [`Band::range`]: over the steps from a time on, the ranges of the errors of the steps that
/// opened no edge, and, apart, the steps that did (they end on the split's zero-time re-solve:
/// the new cell empty, the pair behind the new tip closed), with their largest |pressure error|.
#[derive(Clone, Copy, Debug)]
pub struct Range {
    pub p: [f64; 2],
    pub w: [f64; 2],
    pub steps: usize,
    pub split_steps: usize,
    pub split_p: f64,
    /// Whether the run's last step opened an edge (its end state is then a split's).
    pub last_split: bool,
}

impl Band {
    /// The ranges over the steps ending at or after `from` (s).
    pub fn range(&self, from: f64) -> Range {
        let mut r = Range {
            p: [f64::INFINITY, f64::NEG_INFINITY],
            w: [f64::INFINITY, f64::NEG_INFINITY],
            steps: 0,
            split_steps: 0,
            split_p: 0.0,
            last_split: false,
        };
        for &(_, ep, ew, split) in self.history.iter().filter(|x| x.0 >= from) {
            r.last_split = split;
            if split {
                r.split_steps += 1;
                r.split_p = r.split_p.max(ep.abs());
            } else {
                r.steps += 1;
                r.p = [r.p[0].min(ep), r.p[1].max(ep)];
                r.w = [r.w[0].min(ew), r.w[1].max(ew)];
            }
        }
        r
    }
}

impl KgdRun {
    /// Signed relative errors of (l, w0, p0).
    pub fn errors(&self) -> [f64; 3] {
        [
            (self.l - self.exact[0]) / self.exact[0],
            (self.w0 - self.exact[1]) / self.exact[1],
            (self.p0 - self.exact[2]) / self.exact[2],
        ]
    }

    /// [`KgdRun::errors`] with the length to the fluid front (`l_front`): where the mesh tip
    /// runs ahead of the fluid into dry cells (the toughness criterion opens an edge as soon as
    /// K_Ic is reached), the zero-lag solution's length is the fluid's.
    pub fn errors_front(&self) -> [f64; 3] {
        let mut e = self.errors();
        e[0] = (self.l_front - self.exact[0]) / self.exact[0];
        e
    }
}

/// Run `scenarios/kgd.ron` (built into the binary) at mesh size `h` (m) with the flow scheme
/// `scheme` (`Explicit` or `Implicit` flow with the explicit rock, or `QuasiStatic`), with
/// further `--set` overrides `extra` applied after those.
pub fn kgd_run(h: f64, scheme: &str, extra: &[String]) -> anyhow::Result<KgdRun> {
    kgd_run_in(h, scheme, extra, Regime::Viscosity)
}

/// Which KGD similarity solution the run is compared with (`docs/verification.md` R6, R7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Regime {
    /// Viscosity-dominated (zero toughness).
    Viscosity,
    /// `scenarios/kgd_m.ron` (`kgd.ron` grown by the toughness criterion, with the
    /// `LinearOpening` transmissibility and a wider domain) at K_Ic (Pa sqrt(m)), against the
    /// viscosity-dominated solution.
    ViscosityToughness(f64),
    /// Toughness-dominated (zero viscosity) at K_Ic, Pa sqrt(m):
    /// l = 0.9324 (E' Q0 t / K')^(2/3), w0 = 0.6828 (K'^2 Q0 t / E'^2)^(1/3),
    /// p = 0.18317 (K'^4 / (E' Q0 t))^(1/3), K' = 4 sqrt(2/pi) K_Ic.
    Toughness(f64),
}

/// Dimensionless toughness of a KGD fracture, K' / (E'^3 mu' Q0)^(1/4) (below about 1:
/// viscosity-dominated; above about 4: toughness-dominated; Detournay 2004).
pub fn dimensionless_toughness(k_ic: f64, e_prime: f64, mu: f64, q0: f64) -> f64 {
    4.0 * (2.0 / std::f64::consts::PI).sqrt() * k_ic / (e_prime.powi(3) * 12.0 * mu * q0).powf(0.25)
}

/// The toughness-dominated KGD solution (l, w0, p0) at time t (s) for E' (Pa), Q0 (m^2/s),
/// K_Ic (Pa sqrt(m)) (`docs/verification.md` R7).
pub fn toughness_vertex(e_prime: f64, q0: f64, t: f64, k_ic: f64) -> [f64; 3] {
    let kp = 4.0 * (2.0 / std::f64::consts::PI).sqrt() * k_ic;
    [
        0.9324 * (e_prime * q0 * t / kp).powf(2.0 / 3.0),
        0.6828 * (kp * kp * q0 * t / (e_prime * e_prime)).powf(1.0 / 3.0),
        0.18317 * (kp.powi(4) / (e_prime * q0 * t)).powf(1.0 / 3.0),
    ]
}

/// The viscosity-dominated KGD solution (l, w0, p0) at time t (s) for E' (Pa), Q0 (m^2/s),
/// viscosity mu (Pa s) (`docs/verification.md` R6): l = 0.61524 (E' Q0^3 t^4 / mu')^(1/6),
/// w0 = 1.1233 (mu' Q0^3 t^2 / E')^(1/6), p0 = 0.5443 (mu' E'^2 / t)^(1/3), mu' = 12 mu.
pub fn viscosity_vertex(e_prime: f64, q0: f64, t: f64, mu: f64) -> [f64; 3] {
    let mu_prime = 12.0 * mu;
    [
        0.61524 * (e_prime * q0.powi(3) * t.powi(4) / mu_prime).powf(1.0 / 6.0),
        1.1233 * (mu_prime * q0.powi(3) * t.powi(2) / e_prime).powf(1.0 / 6.0),
        0.5443 * (mu_prime * e_prime * e_prime / t).powf(1.0 / 3.0),
    ]
}

/// [`kgd_run`] against the similarity solution of `regime`.
pub fn kgd_run_in(
    h: f64,
    scheme: &str,
    extra: &[String],
    regime: Regime,
) -> anyhow::Result<KgdRun> {
    let mut sets = match scheme {
        "QuasiStatic" => vec![
            format!("mesh.h={h}"),
            "time.solid_scheme=QuasiStatic".into(),
        ],
        _ => vec![format!("mesh.h={h}"), format!("time.flow_scheme={scheme}")],
    };
    sets.extend_from_slice(extra);
    let sc = match regime {
        Regime::Viscosity => Scenario::parse(KGD_RON, "scenarios/kgd.ron")?,
        Regime::ViscosityToughness(k_ic) => {
            let from = "criterion: Some(Toughness(k_ic: 2.4e6)),";
            anyhow::ensure!(
                KGD_M_RON.contains(from),
                "kgd_m.ron: no `{from}` to replace"
            );
            let text = KGD_M_RON.replace(
                from,
                &format!("criterion: Some(Toughness(k_ic: {k_ic:e})),"),
            );
            Scenario::parse(&text, "scenarios/kgd_m.ron")?
        }
        Regime::Toughness(_) => Scenario::parse(KGD_K_RON, "scenarios/kgd_toughness.ron")?,
    }
    .with_overrides(&sets)?;
    let mat = sc.material.expect("kgd has a material");
    let s0 = match sc.boundary {
        Boundary::InSitu { syy, .. } => -syy,
        _ => anyhow::bail!("kgd.ron: expected an InSitu boundary"),
    };
    let mu = sc.fluid.viscosity;
    let q_half = match sc.flow_boundaries[0].kind {
        crate::scenario::FlowBcKind::Rate(q) => q,
        _ => anyhow::bail!("kgd.ron: expected a rate boundary"),
    };
    let t_end = match sc.time.end {
        crate::scenario::End::Time(t) => t,
        _ => anyhow::bail!("kgd.ron: expected an end time"),
    };
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let q0 = 2.0 * q_half;
    let mut band = None;
    let finish = match regime {
        // Step by step, to measure the saw-tooth over the last fifth of the run.
        Regime::Toughness(k_ic) => {
            let mut b = Band::default();
            let mut cells = on_line(&sim, h).len();
            while sim.finish().is_none() {
                sim.step_once()?;
                let t = sim.time();
                let line = on_line(&sim, h);
                let split = line.len() != cells;
                cells = line.len();
                if line.len() < 2 {
                    continue;
                }
                let ex = toughness_vertex(e_prime, q0, t, k_ic);
                let (w0, p0) = well_state(&sim, &line, s0);
                let (ep, ew) = ((p0 - ex[2]) / ex[2], (w0 - ex[1]) / ex[1]);
                b.history.push((t, ep, ew, split));
            }
            sim.sync();
            band = Some(b);
            sim.finish().expect("finished")
        }
        _ => sim.run(|_| {})?,
    };
    anyhow::ensure!(
        finish == Finish::EndTime,
        "kgd h = {h}: ended with {finish:?}"
    );
    let wall = t0.elapsed().as_secs_f64();
    let l_tracked = match sim.params().criterion.and_then(|c| c.kind.k_ic()) {
        Some(k_ic) => {
            sim.measure_tips();
            let fr = sim.fracture();
            fr.tips
                .tracked(sim.solid(), k_ic, e_prime)
                .iter()
                .filter(|(_, x)| x[1].abs() < 1e-6 * h)
                .map(|(_, x)| x[0])
                .fold(f64::NAN, f64::max)
        }
        None => f64::NAN,
    };
    let (_, _, _, balance) = sim.flow_balance().expect("flow");
    let on_line = on_line(&sim, h);
    anyhow::ensure!(on_line.len() >= 2, "kgd h = {h}: fewer than two cells");
    let l = on_line.iter().map(|c| c.1).fold(0.0, f64::max);
    let wet = on_line
        .iter()
        .filter(|c| c.3 >= 1.0)
        .map(|c| c.1)
        .fold(0.0, f64::max);
    let l_front = wet
        + on_line
            .iter()
            .filter(|c| c.0 >= wet)
            .map(|c| (c.1 - c.0) * c.3.max(0.0))
            .sum::<f64>();
    let l_tracked = if l_tracked.is_finite() { l_tracked } else { l };
    let (w0, p0) = well_state(&sim, &on_line, s0);
    let exact = if let Regime::Toughness(k_ic) = regime {
        toughness_vertex(e_prime, q0, t_end, k_ic)
    } else {
        viscosity_vertex(e_prime, q0, t_end, mu)
    };
    Ok(KgdRun {
        l,
        l_tracked,
        w0,
        p0,
        lag: l - wet,
        l_front,
        exact,
        balance,
        wall,
        unknowns: 2 * sim.solid().n_nodes(),
        band,
    })
}

/// (start, end, aperture, filled fraction) of the cells on the fracture line y = 0 (within
/// 1e-6 h), by their position along it.
fn on_line(sim: &Simulation, h: f64) -> Vec<(f64, f64, f64, f64)> {
    let v = &sim.flow().expect("flow").view;
    let rho_r = sim.scenario().fluid.density;
    let mut line: Vec<(f64, f64, f64, f64)> = (0..v.n_cells())
        .filter_map(|c| {
            let [a, b] = v.cell_nodes[c].map(|n| v.node_ref[n as usize]);
            (a[1].abs() < 1e-6 * h && b[1].abs() < 1e-6 * h).then(|| {
                let filled = (1.0 + v.excess[c] / (rho_r * v.volume[c])).min(1.0);
                (a[0].min(b[0]), a[0].max(b[0]), v.aperture[c], filled)
            })
        })
        .collect();
    line.sort_by(|p, q| p.0.total_cmp(&q.0));
    line
}

/// Well opening (m), the first two cells' apertures (at x = h/2, 3h/2) extrapolated to x = 0,
/// and net well pressure (Pa) above the confining stress `s0`.
fn well_state(sim: &Simulation, line: &[(f64, f64, f64, f64)], s0: f64) -> (f64, f64) {
    let v = &sim.flow().expect("flow").view;
    (
        line[0].2 + 0.5 * (line[0].2 - line[1].2),
        v.bcs[0].pressure - s0,
    )
}

pub fn kgd(quick: bool) -> anyhow::Result<CaseResult> {
    let sizes: &[f64] = if quick {
        &[2.0, 1.0]
    } else {
        &[2.0, 1.0, 0.5, 0.25]
    };
    let mut res = CaseResult::default();
    let mut lengths = Vec::new();
    // (scheme, h, errors, cells along the similarity half-length at the end time).
    let mut by_scheme: Vec<(&str, f64, [f64; 3], f64)> = Vec::new();
    for scheme in [
        "Explicit",
        "Implicit",
        "QuasiStatic",
        "QuasiStaticToughness",
    ] {
        let suffix = match scheme {
            "QuasiStatic" => "quasi_static".to_string(),
            "QuasiStaticToughness" => "quasi_static_toughness".to_string(),
            s => s.to_lowercase(),
        };
        let mut errs: Vec<[f64; 3]> = Vec::new();
        for (level, &h) in sizes.iter().enumerate() {
            let (e, l, cells) = kgd_level(&mut res, scheme, &suffix, level, h)?;
            lengths.push((scheme, h, l));
            by_scheme.push((scheme, h, e, cells));
            errs.push(e);
        }
        check_kgd_convergence(&mut res, scheme, &suffix, &errs, quick);
    }
    // The toughness criterion's runs at a second time, t = 1.6 s (l = 19.2 m), and the issue's
    // targets at both: 3 % at 15-20 cells along the half-length, 2 % from 30 (5 % below 15).
    // Measured (2026-12-03, `kgd_m.ron` with `filling: FrontInCell`): 15 cells (h = 2 m,
    // 3.25 s): front +0.6 %, opening +0.8 %, pressure +2.5 %; 19 cells: +1.3, -0.5, +0.4 %;
    // 31 cells: +1.1, -0.4, +0.5 %; from 38 cells every error within 1.9 % (README, "KGD with
    // the toughness criterion").
    for (level, &h) in sizes.iter().enumerate() {
        for t in [1.6, 3.25] {
            // The end time's run is the main loop's.
            let (e, cells) = if t == 3.25 {
                by_scheme
                    .iter()
                    .find(|x| x.0 == "QuasiStaticToughness" && x.1 == h)
                    .map(|x| (x.2, x.3))
                    .expect("the toughness run at the end time")
            } else {
                kgd_toughness_at(&mut res, level, h, t)?
            };
            check_kgd_toughness_targets(&mut res, h, t, e, cells);
        }
    }
    for &h in sizes {
        check_kgd_scheme_differences(&mut res, h, &lengths, &by_scheme);
    }
    Ok(res)
}

/// One KGD run of `scheme` (row and note suffix `suffix`) at mesh size `h` (m, refinement
/// `level`) against the similarity solution: adds its note, rows and mass-balance check and
/// returns its relative errors (length, opening, pressure; the fluid front's length with the
/// toughness criterion), half-length (m) and cells along the similarity half-length.
fn kgd_level(
    res: &mut CaseResult,
    scheme: &str,
    suffix: &str,
    level: usize,
    h: f64,
) -> anyhow::Result<([f64; 3], f64, f64)> {
    let r = match scheme {
        // The toughness criterion at a rock's K_Ic = 2.4 MPa sqrt(m): dimensionless
        // toughness 0.2, near the viscosity vertex.
        "QuasiStaticToughness" => kgd_run_in(
            h,
            "QuasiStatic",
            &[],
            Regime::ViscosityToughness(KGD_TOUGHNESS),
        )?,
        _ => kgd_run(h, scheme, &[])?,
    };
    let e = if scheme == "QuasiStaticToughness" {
        r.errors_front()
    } else {
        r.errors()
    };
    // The similarity solution has no fluid lag; the mesh tip runs ahead of the fluid
    // into the cell it is filling (docs/toughness.md, "The fluid at a viscous tip").
    res.notes.push(format!(
        "{suffix}, h = {h} m: l {:.2} m (fluid front {:.2}) / {:.2}, w0 {:.3} / {:.3} mm, p {:.4} / {:.4} MPa; errors {:+.2} % (front {:+.2} %), {:+.2} %, {:+.2} %; fluid lag {:.2} m ({:.1} cells)",
        r.l, r.l_front, r.exact[0], 1e3 * r.w0, 1e3 * r.exact[1], 1e-6 * r.p0, 1e-6 * r.exact[2],
        100.0 * r.errors()[0], 100.0 * (r.l_front / r.exact[0] - 1.0), 100.0 * e[1], 100.0 * e[2],
        r.lag,
        r.lag / h
    ));
    for (k, m) in ["length", "opening", "pressure"].iter().enumerate() {
        res.rows.push(Row {
            case: "kgd",
            level,
            h,
            unknowns: r.unknowns,
            metric: format!("{m}_{suffix}"),
            error: e[k].abs(),
            wall_s: r.wall,
        });
    }
    res.check_max(
        format!("mass balance, {suffix}, h = {h} m"),
        r.balance,
        1e-9,
    );
    Ok((e, r.l, r.exact[0] / h))
}

/// Checks that the errors `errs` of `scheme` (one per mesh, coarsest first) fall with the
/// mesh, and (full run) that the finest is within 5 %.
fn check_kgd_convergence(
    res: &mut CaseResult,
    scheme: &str,
    suffix: &str,
    errs: &[[f64; 3]],
    quick: bool,
) {
    let (first, last) = (errs[0], errs[errs.len() - 1]);
    for (k, m) in ["length", "opening", "pressure"].iter().enumerate() {
        if scheme == "QuasiStaticToughness" {
            // `kgd_m.ron` is within the targets from 15 cells on (checked per
            // level and time below), so its errors need not fall from there: the fluid
            // front is +0.6 % at 15 cells and +1.6 % at 123 (measured 2026-12-03).
            continue;
        }
        res.check_max(
            format!("{m} error finest / coarsest, {suffix}"),
            last[k].abs() / first[k].abs(),
            0.8,
        );
        // The 5 % target (`docs/verification.md` R6), at h = 0.25 m (125 cells along the half-length); the quick
        // run stops at h = 1 m, where the criterion's toughness still shows.
        if !quick {
            res.check_max(
                format!("{m} error at h = 0.25 m, {suffix}"),
                last[k].abs(),
                0.05,
            );
        }
    }
}

/// The toughness criterion's run at mesh size `h` (m, refinement `level`) stopped at `t` (s):
/// adds its rows, note and mass-balance check and returns its relative errors (fluid front,
/// opening, pressure) and cells along the similarity half-length.
fn kgd_toughness_at(
    res: &mut CaseResult,
    level: usize,
    h: f64,
    t: f64,
) -> anyhow::Result<([f64; 3], f64)> {
    let r = kgd_run_in(
        h,
        "QuasiStatic",
        &[format!("time.end=Time({t})")],
        Regime::ViscosityToughness(KGD_TOUGHNESS),
    )?;
    let e = r.errors_front();
    for (k, m) in ["length", "opening", "pressure"].iter().enumerate() {
        res.rows.push(Row {
            case: "kgd",
            level,
            h,
            unknowns: r.unknowns,
            metric: format!("{m}_quasi_static_toughness_t{t}"),
            error: e[k].abs(),
            wall_s: r.wall,
        });
    }
    res.notes.push(format!(
        "quasi_static_toughness, h = {h} m, t = {t} s: l {:.2} m (fluid front {:.2}) / {:.2}, w0 {:.3} / {:.3} mm, p {:.4} / {:.4} MPa; errors (front) {:+.2} %, {:+.2} %, {:+.2} %; fluid lag {:.2} m",
        r.l, r.l_front, r.exact[0], 1e3 * r.w0, 1e3 * r.exact[1], 1e-6 * r.p0,
        1e-6 * r.exact[2], 100.0 * e[0], 100.0 * e[1], 100.0 * e[2], r.lag
    ));
    res.check_max(
        format!("mass balance, quasi_static_toughness, h = {h} m, t = {t} s"),
        r.balance,
        1e-9,
    );
    Ok((e, r.exact[0] / h))
}

/// Checks the toughness criterion's relative errors `e` at mesh size `h` (m) and time `t`
/// (s) against the targets for `cells` cells along the half-length: 2 % from 30
/// cells, 3 % from 15, 5 % below.
fn check_kgd_toughness_targets(res: &mut CaseResult, h: f64, t: f64, e: [f64; 3], cells: f64) {
    let limit = if cells >= 29.5 {
        0.02
    } else if cells >= 14.5 {
        0.03
    } else {
        0.05
    };
    for (k, m) in ["length (fluid front)", "opening", "pressure"]
        .iter()
        .enumerate()
    {
        res.check_max(
            format!("{m} error, toughness criterion, h = {h} m, t = {t} s ({cells:.0} cells)"),
            e[k].abs(),
            limit,
        );
    }
}

/// Checks, at mesh size `h` (m), the schemes against each other: half-lengths within a cell,
/// the toughness criterion's errors against the strength criterion's, the quasi-static
/// errors against the explicit ones.
fn check_kgd_scheme_differences(
    res: &mut CaseResult,
    h: f64,
    lengths: &[(&str, f64, f64)],
    by_scheme: &[(&str, f64, [f64; 3], f64)],
) {
    let l: Vec<f64> = lengths.iter().filter(|x| x.1 == h).map(|x| x.2).collect();
    res.check_max(
        format!("length explicit - implicit, h = {h} m (cells)"),
        (l[0] - l[1]).abs() / h,
        1.0,
    );
    res.check_max(
        format!("length explicit - quasi-static, h = {h} m (cells)"),
        (l[0] - l[2]).abs() / h,
        1.0,
    );
    let e: Vec<[f64; 3]> = by_scheme.iter().filter(|x| x.1 == h).map(|x| x.2).collect();
    // The toughness criterion at a small K_Ic removes most of the strength criterion's
    // mesh-dependent toughness: on coarse meshes (h >= 0.5 m) every error at or below the
    // strength criterion's; at h = 0.25 m, where both are within the 5 % target, within
    // one point of it (measured: pressure 2.93 % against 2.45 %).
    for (k, m) in ["length", "opening", "pressure"].iter().enumerate() {
        res.check_max(
            format!("{m} |error| toughness - strength criterion (quasi-static), h = {h} m"),
            e[3][k].abs() - e[2][k].abs(),
            if h >= 0.5 { 0.0 } else { 0.01 },
        );
    }
    // The quasi-static rock has no inertia (nor the explicit run's local damping 0.8):
    // its errors differ from the explicit scheme's by that, plus its first-order step
    // error (README, "Choosing the solid scheme"); 2 points of relative error at h <= 1 m.
    if h <= 1.0 {
        for (k, m) in ["length", "opening", "pressure"].iter().enumerate() {
            res.check_max(
                format!("{m} error quasi-static - explicit, h = {h} m"),
                (e[2][k] - e[0][k]).abs(),
                0.02,
            );
        }
    }
}

/// `kgd_k`: `scenarios/kgd_toughness.ron` (toughness-dominated, dimensionless toughness 4.9)
/// grown by the toughness criterion on the quasi-static rock at h = 2, 1, 0.5 m (15, 30, 60
/// cells along the final half-length), compared at two times (76 s, l = 20 m, and 140 s,
/// l = 30 m) with the toughness-dominated similarity solution: half-length to the mesh tip and
/// to the tracked tip, well opening, net well pressure.
pub fn kgd_k(quick: bool) -> anyhow::Result<CaseResult> {
    let sizes: &[f64] = if quick { &[2.0, 1.0] } else { &[2.0, 1.0, 0.5] };
    let k_ic = 5e6;
    let mut res = CaseResult::default();
    let sc = Scenario::parse(KGD_K_RON, "scenarios/kgd_toughness.ron")?;
    let mat = sc.material.expect("kgd_toughness has a material");
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let kd = dimensionless_toughness(k_ic, e_prime, sc.fluid.viscosity, 1e-3);
    res.notes.push(format!(
        "dimensionless toughness K' / (E'^3 mu' Q0)^(1/4) = {kd:.2} (toughness vertex above about 4)"
    ));
    let (mut sum_tracked, mut sum_mesh) = (0.0, 0.0);
    let mut csv = String::from("h_m,t_end_s,time_s,pressure_error,opening_error,opened_edge\n");
    let mut pressure = Vec::new();
    for (level, &h) in sizes.iter().enumerate() {
        for t in [76.0, 140.0] {
            let r = kgd_run_in(
                h,
                "QuasiStatic",
                &[format!("time.end=Time({t})")],
                Regime::Toughness(k_ic),
            )?;
            let e = r.errors();
            let tracked = (r.l_tracked - r.exact[0]) / r.exact[0];
            sum_tracked += tracked.abs();
            sum_mesh += e[0].abs();
            for (m, err) in [
                ("length", e[0]),
                ("length_tracked", tracked),
                ("opening", e[1]),
                ("pressure", e[2]),
            ] {
                res.rows.push(Row {
                    case: "kgd_k",
                    level,
                    h,
                    unknowns: r.unknowns,
                    metric: format!("{m}_t{t:.0}"),
                    error: err.abs(),
                    wall_s: r.wall,
                });
            }
            res.notes.push(format!(
                "h = {h} m, t = {t} s: l {:.2} m (tracked {:.2}) / {:.2}, w0 {:.3} / {:.3} mm, p {:.3} / {:.3} MPa; errors {:+.1} % (tracked {:+.1} %), {:+.1} %, {:+.1} %; fluid lag {:.2} m",
                r.l, r.l_tracked, r.exact[0], 1e3 * r.w0, 1e3 * r.exact[1], 1e-6 * r.p0, 1e-6 * r.exact[2],
                100.0 * e[0], 100.0 * tracked, 100.0 * e[1], 100.0 * e[2], r.lag
            ));
            if let Some(b) = r.band.as_ref().filter(|_| t == 140.0) {
                for &(ts, ep, ew, split) in &b.history {
                    csv.push_str(&format!("{h},{t},{ts},{ep:.6e},{ew:.6e},{}\n", split as u8));
                }
                pressure.push(Series {
                    label: format!("h = {h} m ({:.0} cells at {t} s)", r.exact[0] / h),
                    points: b
                        .history
                        .iter()
                        .filter(|x| !x.3 && x.0 >= 0.25 * t)
                        .map(|x| (x.0, 100.0 * x.1))
                        .collect(),
                });
            }
            let last_fifth = r.band.as_ref().map(|b| b.range(0.8 * t));
            if let Some(b) = last_fifth.filter(|b| b.steps > 0) {
                res.notes.push(format!(
                    "  saw-tooth over {:.0}-{t} s ({} steps): pressure {:+.1} to {:+.1} %, opening {:+.1} to {:+.1} %; {} steps that opened an edge: |pressure| up to {:.1} %{}",
                    0.8 * t, b.steps, 100.0 * b.p[0], 100.0 * b.p[1], 100.0 * b.w[0], 100.0 * b.w[1], b.split_steps, 100.0 * b.split_p,
                    if b.last_split { " (the last step opened one)" } else { "" }
                ));
            }
            res.check_max(
                format!("mass balance, h = {h} m, t = {t} s"),
                r.balance,
                1e-9,
            );
            // Measured (this build, 800 m x 1600 m domain): tracked length, opening and
            // pressure 3.0-5.0 % at 15-20 cells along the half-length (the pressure -5.0 and
            // -4.7 %), within 2.2 % at 30, 1.8 % at 40 and 0.9 % at 60, where they are points
            // of the saw-tooth below. The targets, 3 % at 15-20 cells and 2 % at 30, are not
            // met at 15-20 cells (README, "KGD with the toughness criterion").
            let cells = r.exact[0] / h;
            // The saw-tooth between splits (measured: |pressure| up to 8.9 % and |opening| up
            // to 5.5 % over the last fifth of the run at 15 cells, 7.4 % at 20, 3.4 % at 30;
            // 14.8 % at 10 cells).
            if let Some(b) = last_fifth.filter(|b| cells >= 14.0 && b.steps > 0) {
                let worst = [b.p[0], b.p[1], b.w[0], b.w[1]]
                    .iter()
                    .fold(0.0_f64, |m, e| m.max(e.abs()));
                res.check_max(
                    format!(
                        "saw-tooth |pressure|, |opening| error over {:.0}-{t} s, h = {h} m",
                        0.8 * t
                    ),
                    worst,
                    0.11,
                );
            }
            if cells >= 14.0 {
                let limit = if cells >= 29.0 { 0.03 } else { 0.06 };
                for (m, err) in [
                    ("tracked length", tracked),
                    ("opening", e[1]),
                    ("pressure", e[2]),
                ] {
                    res.check_max(
                        format!("{m} error, h = {h} m, t = {t} s ({cells:.0} cells)"),
                        err.abs(),
                        limit,
                    );
                }
            }
        }
    }
    res.files.push(("kgd_k_sawtooth.csv".into(), csv));
    res.plots.push(LinePlot {
        file: "kgd_k_sawtooth.png".into(),
        title: "kgd_k: well pressure against the toughness-dominated solution".into(),
        xlabel: "time [s] (steps that opened an edge left out)".into(),
        ylabel: "net pressure error [%]".into(),
        series: pressure,
    });
    // The tracked tip is the better length: the mesh tip runs up to one edge ahead.
    res.check_max(
        "mean |length error|, tracked tip / mesh tip",
        sum_tracked / sum_mesh,
        0.8,
    );
    Ok(res)
}

/// `kgd_mk`: the M-K transition. `scenarios/kgd_m.ron` grown by the toughness criterion at the
/// K_Ic that gives dimensionless toughness K = 0.2, 1, 2, 4, 8 (h = 1 m), and K = 2 at
/// h = 2, 1, 0.5 m, against both vertex solutions. Viscosity and toughness both take energy,
/// so a fracture between the vertices is shorter than either vertex's and needs more pressure
/// than either (checked at K = 2 within 3 %, the coarse-mesh error of each vertex); as K
/// grows the solution leaves the viscosity vertex and approaches the toughness one, the trend
/// of the universal (M-K) solution (Garagash & Detournay 2005; checked: l / l_M falls and
/// p / p_K falls with K).
pub fn kgd_mk(quick: bool) -> anyhow::Result<CaseResult> {
    let sc = Scenario::parse(KGD_RON, "scenarios/kgd.ron")?;
    let mat = sc.material.expect("kgd has a material");
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let mu = sc.fluid.viscosity;
    let (q0, t_end) = (0.2, 3.25);
    let scale = (e_prime.powi(3) * 12.0 * mu * q0).powf(0.25);
    let k_ic_of = |kd: f64| kd * scale / (4.0 * (2.0 / std::f64::consts::PI).sqrt());
    let mut res = CaseResult::default();
    let ks: &[f64] = if quick {
        &[0.2, 2.0, 8.0]
    } else {
        &[0.2, 1.0, 2.0, 4.0, 8.0]
    };
    let mut sweep = Vec::new();
    for &kd in ks {
        let k_ic = k_ic_of(kd);
        let r = kgd_run_in(1.0, "QuasiStatic", &[], Regime::ViscosityToughness(k_ic))?;
        let tv = toughness_vertex(e_prime, q0, t_end, k_ic);
        // Lengths to the fluid front: near the viscosity vertex the mesh tip runs 1-2 dry cells
        // ahead of it (`KgdRun::l_front`).
        let (l_m, l_k, p_m, p_k) = (
            r.l_front / r.exact[0],
            r.l_front / tv[0],
            r.p0 / r.exact[2],
            r.p0 / tv[2],
        );
        res.notes.push(format!(
            "K = {kd}: K_Ic = {:.2} MPa sqrt(m); l / l_M = {l_m:.3}, l / l_K = {l_k:.3}, p / p_M = {p_m:.3}, p / p_K = {p_k:.3}, w0 / w_M = {:.3}, w0 / w_K = {:.3} ({:.1} s)",
            1e-6 * k_ic, r.w0 / r.exact[1], r.w0 / tv[1], r.wall
        ));
        res.check_max(format!("mass balance, K = {kd}"), r.balance, 1e-9);
        sweep.push((kd, l_m, p_k));
    }
    for w in sweep.windows(2) {
        res.check_max(
            format!("l / l_M from K = {} to {}: rises by", w[0].0, w[1].0),
            w[1].1 - w[0].1,
            0.0,
        );
        if w[0].0 >= 1.0 {
            res.check_max(
                format!("p / p_K from K = {} to {}: rises by", w[0].0, w[1].0),
                w[1].2 - w[0].2,
                0.0,
            );
        }
    }
    let sizes: &[f64] = if quick { &[2.0, 1.0] } else { &[2.0, 1.0, 0.5] };
    let k_ic = k_ic_of(2.0);
    for (level, &h) in sizes.iter().enumerate() {
        let r = kgd_run_in(h, "QuasiStatic", &[], Regime::ViscosityToughness(k_ic))?;
        let tv = toughness_vertex(e_prime, q0, t_end, k_ic);
        let l_min = r.exact[0].min(tv[0]);
        let p_max = r.exact[2].max(tv[2]);
        for (m, v) in [
            ("length_vs_viscosity_vertex", r.l_front / r.exact[0] - 1.0),
            ("length_vs_toughness_vertex", r.l_front / tv[0] - 1.0),
            ("pressure_vs_viscosity_vertex", r.p0 / r.exact[2] - 1.0),
            ("pressure_vs_toughness_vertex", r.p0 / tv[2] - 1.0),
        ] {
            res.rows.push(Row {
                case: "kgd_mk",
                level,
                h,
                unknowns: r.unknowns,
                metric: m.into(),
                error: v.abs(),
                wall_s: r.wall,
            });
        }
        res.check_max(
            format!("K = 2, h = {h} m: l (fluid front) / min(l_M, l_K)"),
            r.l_front / l_min,
            1.03,
        );
        res.check_range(
            format!("K = 2, h = {h} m: p / max(p_M, p_K)"),
            r.p0 / p_max,
            0.97,
            10.0,
        );
    }
    Ok(res)
}

/// `kgd_confinement`: `scenarios/kgd_m.ron` (the viscous KGD grown by the toughness criterion,
/// h = 1 m, 31 cells along the similarity half-length at 3.25 s) under a confining stress s0 of
/// 10, 40 and 120 MPa (s0 / p0 = 3.4, 13.5 and 40.6, p0 the similarity net well pressure) with a
/// residual aperture a_r of 0.5, 1 and 5 % of the similarity well opening w0, against the
/// viscosity-dominated solution, which none of them changes (`docs/toughness.md`, "High
/// confinement"). Each row's fill number R = a_r^2 s0 / (12 mu h v_tip), v_tip = 2 l / (3 t)
/// the similarity tip speed: a new tip cell, dry at zero pressure (a closing load s0 over
/// it), fills through its residual aperture in 12 mu h^2 / (a_r^2 s0), 1 / R of the time the
/// tip takes to cross it.
///
/// Checks (measured at b742cdb: `docs/toughness.md`, "High confinement"): every run conserves
/// mass to 1e-9; at s0 / p0 = 3.4 every a_r within 3 % (measured 2.7 %: the dry cell's load
/// does not close it there); where R >= 2.5 within 5 % (measured 4.2 % at R = 2.8 and 8.5);
/// below R = 1 at s0 / p0 = 13.5 and 40.6 the errors are 7 to 56 % (the table), the 3 %
/// everywhere is not met.
pub fn kgd_confinement(quick: bool) -> anyhow::Result<CaseResult> {
    let sc = Scenario::parse(KGD_M_RON, "scenarios/kgd_m.ron")?;
    let mat = sc.material.expect("kgd_m has a material");
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let mu = sc.fluid.viscosity;
    let (q0, t_end, h) = (0.2, 3.25, 1.0);
    let mu_prime = 12.0 * mu;
    let [l, w0, p0] = viscosity_vertex(e_prime, q0, t_end, mu);
    let v_tip = 2.0 * l / (3.0 * t_end);
    let (confinements, fractions): (&[f64], &[f64]) = if quick {
        (&[10e6, 120e6], &[0.005, 0.05])
    } else {
        (&[10e6, 40e6, 120e6], &[0.005, 0.01, 0.05])
    };
    let mut res = CaseResult::default();
    let mut csv = String::from(
        "s0_pa,s0_over_p0,a_r_m,a_r_over_w0,fill_number,length_error,opening_error,pressure_error,wall_s\n",
    );
    let mut series = Vec::new();
    let mut level = 0;
    for &s0 in confinements {
        let mut points = Vec::new();
        for &f in fractions {
            let a_r = f * w0;
            let r = kgd_run_in(
                h,
                "QuasiStatic",
                &[
                    format!("boundary=InSitu(sxx: -{s0:e}, syy: -{s0:e})"),
                    format!("fracture.residual_aperture={a_r:e}"),
                ],
                Regime::ViscosityToughness(KGD_TOUGHNESS),
            )?;
            let e = r.errors_front();
            let fill = a_r * a_r * s0 / (mu_prime * h * v_tip);
            let worst = e.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
            let tag = format!("s0 / p0 = {:.1}, a_r = {:.1} % of w0", s0 / p0, 100.0 * f);
            res.notes.push(format!(
                "{tag} (R = {fill:.2}): front {:+.2} %, opening {:+.2} %, pressure {:+.2} % ({:.1} s)",
                100.0 * e[0],
                100.0 * e[1],
                100.0 * e[2],
                r.wall
            ));
            csv.push_str(&format!(
                "{s0:e},{:.4},{a_r:.6e},{f},{fill:.6e},{:.6e},{:.6e},{:.6e},{:.3}\n",
                s0 / p0,
                e[0],
                e[1],
                e[2],
                r.wall
            ));
            for (m, err) in [("length", e[0]), ("opening", e[1]), ("pressure", e[2])] {
                res.rows.push(Row {
                    case: "kgd_confinement",
                    level,
                    h,
                    unknowns: r.unknowns,
                    metric: format!("{m}_s0_{:.0}_ar_{:.1}pct", s0 / p0, 100.0 * f),
                    error: err.abs(),
                    wall_s: r.wall,
                });
            }
            level += 1;
            res.check_max(format!("mass balance, {tag}"), r.balance, 1e-9);
            if s0 / p0 < 4.0 {
                res.check_max(format!("worst error, {tag}"), worst, 0.03);
            } else if fill >= 2.5 {
                res.check_max(format!("worst error, {tag} (R >= 2.5)"), worst, 0.05);
            }
            points.push((fill.log10(), 100.0 * worst));
        }
        series.push(Series {
            label: format!("s0 / p0 = {:.1}", s0 / p0),
            points,
        });
    }
    res.files.push(("kgd_confinement.csv".into(), csv));
    res.plots.push(LinePlot {
        file: "kgd_confinement.png".into(),
        title: "kgd_confinement: viscous KGD (31 cells) under confinement".into(),
        xlabel: "log10 fill number R = a_r^2 s0 / (12 mu h v_tip)".into(),
        ylabel: "worst |error| of front, opening, pressure [%]".into(),
        series,
    });
    Ok(res)
}
