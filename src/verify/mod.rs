//! `hydrofrac verify`: verification cases run at several resolutions, each reporting error and
//! wall time side by side (`DIR/<case>.csv`, `DIR/<case>.png`), with stated tolerances.
//!
//! Cases: solid (`docs/verification.md` R1-R4) `patch`, `insitu`, `mms`, `stability`; flow
//! `cubic_law`, `diffusion`, `mass_balance`, `pump_curve`, `steady`, `flow_stability`; fracture
//! (R5, R7b, R8, R12b) `sneddon`, `sif`,
//! `friction`, `slip_inclined`; 3D `mms3d`, `penny3d`, `radial_m`, `radial_k`; coupled (R6) `kgd`, `kgd_k`, `kgd_mk`, `kgd_confinement`; the seed's
//! Example I (R9) `example1`, and with selective mass scaling `mass_scaling`; reservoir: upscaling `oda`, continuum heat (R17)
//! `heat_continuum`, discrete heat (R15, R16) `lauwerier`, `gringarten`, the two against each other
//! `heat_models`; reliability: `extreme` (corners of the parameter space: finite and bounded,
//! or refused naming the parameter).

pub mod conforming_cases;
pub mod contact_cases;
pub mod coupled_cases;
pub mod example_cases;
pub mod extreme_cases;
pub mod flow3d_cases;
pub mod flow_cases;
pub mod fracture_cases;
pub mod heat_continuum_cases;
pub mod heat_discrete_cases;
pub mod heat_models_cases;
pub mod inclined3d_cases;
pub mod radial_cases;
pub mod seismicity_cases;
pub mod shear_crack_cases;
pub mod sif_cases;
pub mod slip_cases;
pub mod solid3d_cases;
pub mod solid_cases;
pub mod upscale_cases;

use crate::plot::{Series, lines, loglog};
use std::io::Write;
use std::path::Path;

/// One measured error at one resolution.
#[derive(Clone, Debug)]
pub struct Row {
    pub case: &'static str,
    pub level: usize,
    /// Mesh size, m.
    pub h: f64,
    /// Degrees of freedom (2 per node).
    pub unknowns: usize,
    pub metric: String,
    pub error: f64,
    pub wall_s: f64,
}

/// A pass/fail check with the measured value and the limit.
#[derive(Clone, Debug)]
pub struct Check {
    pub what: String,
    pub value: f64,
    pub limit: String,
    pub pass: bool,
}

#[derive(Clone, Debug, Default)]
pub struct CaseResult {
    pub rows: Vec<Row>,
    pub checks: Vec<Check>,
    /// Lines printed after the table (figures that are not errors).
    pub notes: Vec<String>,
    /// Further files the case writes into the verification folder: (name, contents).
    pub files: Vec<(String, String)>,
    /// Further line plots (linear axes) the case writes into the verification folder.
    pub plots: Vec<LinePlot>,
}

/// A linear-axes line plot a case writes (`crate::plot::lines`): PNG file name, title, axis
/// labels and the series.
#[derive(Clone, Debug)]
pub struct LinePlot {
    pub file: String,
    pub title: String,
    pub xlabel: String,
    pub ylabel: String,
    pub series: Vec<Series>,
}

impl CaseResult {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.pass)
    }
    /// The failed checks, one line each (measured value and requirement); an error line when
    /// the case checked nothing, so an empty case cannot pass silently.
    pub fn failures(&self) -> Vec<String> {
        if self.checks.is_empty() {
            return vec!["the case checked nothing".into()];
        }
        self.checks
            .iter()
            .filter(|c| !c.pass)
            .map(|c| format!("{} = {:.4e} (required {})", c.what, c.value, c.limit))
            .collect()
    }
    /// Require `value <= limit`.
    pub fn check_max(&mut self, what: impl Into<String>, value: f64, limit: f64) {
        self.checks.push(Check {
            what: what.into(),
            value,
            limit: format!("<= {limit:.1e}"),
            pass: value <= limit,
        });
    }
    /// Require `lo <= value <= hi`.
    pub fn check_range(&mut self, what: impl Into<String>, value: f64, lo: f64, hi: f64) {
        self.checks.push(Check {
            what: what.into(),
            value,
            limit: format!("in [{lo}, {hi}]"),
            pass: (lo..=hi).contains(&value),
        });
    }
    /// Errors of one metric, by level.
    pub fn errors(&self, metric: &str) -> Vec<(f64, f64)> {
        self.rows
            .iter()
            .filter(|r| r.metric == metric)
            .map(|r| (r.h, r.error))
            .collect()
    }
}

/// Observed order of convergence between the last two levels of (h, error) pairs.
pub fn observed_order(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len();
    if n < 2 {
        return f64::NAN;
    }
    let (h1, e1) = pairs[n - 2];
    let (h2, e2) = pairs[n - 1];
    (e1 / e2).ln() / (h1 / h2).ln()
}

/// A verification case: name, what it checks, and how to run it.
pub struct Case {
    pub name: &'static str,
    pub about: &'static str,
    pub run: fn(quick: bool) -> anyhow::Result<CaseResult>,
}

pub fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "patch",
            about: "distorted patch, linear displacement field on the boundary: exact to round-off",
            run: solid_cases::patch,
        },
        Case {
            name: "insitu",
            about: "uniform in-situ stress (-20/-10 MPa) on regular and perturbed meshes",
            run: solid_cases::insitu,
        },
        Case {
            name: "mms",
            about: "manufactured solution: displacement O(h^2), stress O(h)",
            run: solid_cases::mms,
        },
        Case {
            name: "stability",
            about: "1e5 undamped steps with no energy growth; a step above the limit is caught",
            run: solid_cases::stability,
        },
        Case {
            name: "cubic_law",
            about: "steady flow through one fracture and X/T junctions against Q = a^3 dp/(12 mu L)",
            run: flow_cases::cubic_law,
        },
        Case {
            name: "diffusion",
            about: "pressure diffusion in a rigid fracture against the closed-end series and erfc; explicit and implicit, h and dt refinement",
            run: flow_cases::diffusion,
        },
        Case {
            name: "mass_balance",
            about: "injected = stored + produced at every step, with the pump switched off and on",
            run: flow_cases::mass_balance,
        },
        Case {
            name: "pump_curve",
            about: "pump operating point against a fracture of known resistance",
            run: flow_cases::pump_curve,
        },
        Case {
            name: "steady",
            about: "explicit and implicit runs to steady state against the direct sparse solve, random network",
            run: flow_cases::steady,
        },
        Case {
            name: "flow_stability",
            about: "automatic flow step stable for a = 1e-6..1e-2 m, K = 1e8..1e10 Pa; over-limit caught",
            run: flow_cases::flow_stability,
        },
        Case {
            name: "sneddon",
            about: "pressurised pre-existing crack on a graded mesh against Sneddon's opening",
            run: fracture_cases::sneddon,
        },
        Case {
            name: "mms3d",
            about: "3D: TET4 on Kuhn cubes against a manufactured smooth displacement (body force in closed form), h = 1/4 to 1/32: O(h^2) displacement",
            run: solid3d_cases::mms3d,
        },
        Case {
            name: "insitu3d",
            about: "3D engine: a box of tetrahedra under the principal in-situ stress (-20/-10/-30 MPa), explicit relaxation and quasi-static solve side by side, h = 2 to 0.5 m",
            run: solid3d_cases::insitu3d,
        },
        Case {
            name: "penny",
            about: "3D engine: scenarios/penny.ron (a quarter penny crack opened by node splitting, front on the circle), its mesh graded towards the front (R/h = 4 to 20) beside the uniform one (R/h = 4 to 16, quasi-static and explicit side by side): opened volume and centre opening (first order)",
            run: solid3d_cases::penny_engine,
        },
        Case {
            name: "penny_inclined",
            about: "3D engine: scenarios/penny_inclined.ron (a disc dipping 45 degrees on a turned grid), R/h = 3 to 6: under 1 MPa beside the horizontal disc (Sneddon's volume; the same to round-off), and slipping under the in-situ stress without and with friction against a penny's slip under a uniform stress drop (potency, friction's ratio, direction)",
            run: inclined3d_cases::penny_inclined,
        },
        Case {
            name: "radial3d",
            about: "3D flow: constant-rate injection into a rigid disc fracture (a quarter, one cell per triangle) against the line source p = Q E1(r^2/4Dt) / (4 pi T), 10 to 40 cells per radius: pressure L2 error, mass balance",
            run: flow3d_cases::radial3d,
        },
        Case {
            name: "penny_flow",
            about: "3D coupled: scenarios/penny_injection.ron (water pumped into the quarter penny, explicit TET4 and flow on the triangles) at rest against the static penny on the same mesh: rest pressure from the fluid's mass, pressure spread, opened volume, R/h = 4 and 6",
            run: flow3d_cases::penny_flow,
        },
        Case {
            name: "radial_m",
            about: "3D growth: scenarios/radial_m.ron (water pumped into a quarter disc, explicit TET4, strength test on the disc's plane, node splitting) against the viscosity-dominated radial vertex (Savitski and Detournay 2002), 8 and 16 elements per radius: radius, well opening and net pressure at 0.1 and 0.2 s, front spread",
            run: radial_cases::radial_m,
        },
        Case {
            name: "radial_k",
            about: "3D growth: scenarios/radial_k.ron (as radial_m with water's viscosity, grown by the toughness criterion on the front: displacement correlation at the front nodes) against the toughness-dominated radial vertex, 8 and 16 elements per radius",
            run: radial_cases::radial_k,
        },
        Case {
            name: "penny3d",
            about: "3D: Sneddon's penny-shaped crack under pressure, TET4 on a graded box (static, faer Cholesky), a/h = 4 to 20: centre opening, opened volume (2.5 % at 20)",
            run: solid3d_cases::penny3d,
        },
        Case {
            name: "sneddon_inclined",
            about: "Sneddon's crack at 30 degrees: conforming mesh vs snapped (graded) mesh vs the horizontal crack, a/h = 10 to 80 (3 % at 80)",
            run: conforming_cases::sneddon_inclined,
        },
        Case {
            name: "conforming_mesh",
            about: "conforming mesher: quality and cost around 100 random fractures (h = 1 to 0.25 m), every fracture on mesh edges, patch test on conforming meshes",
            run: conforming_cases::conforming_mesh,
        },
        Case {
            name: "sif",
            about: "K_I, K_II of static cracks (J domain integral): pressurised horizontal and 45-degree cracks, a 45-degree crack under remote tension, a/h = 10 to 40",
            run: sif_cases::sif,
        },
        Case {
            name: "slip_inclined",
            about: "closed crack at 20 degrees under remote compression (-40/-10 MPa), sliding against friction (20 degrees): slip against the mode-II Sneddon closed form on a conforming and a snapped graded mesh, b/h = 20 and 40",
            run: slip_cases::slip_inclined,
        },
        Case {
            name: "shear_crack",
            about: "fluid-driven frictional shear crack (Bhattacharya and Viesca 2019): a closed joint under a held pressure step at its centre, slip front a = lambda sqrt(4 alpha t) against lambda(T), T = 0.1 and 0.8, 10 to 40 faces (3 % at 40); pressure against erfc, moment ~ V^2",
            run: shear_crack_cases::shear_crack,
        },
        Case {
            name: "seismicity",
            about: "event catalogue: prescribed slip on two fractures (M0', Mw, stress drop, hypocentre, a sub-threshold set, exact to round-off); synthetic Gutenberg-Richter catalogues of 200 to 20,000 events drawn with b = 1 (Aki-Utsu within 2 sigma)",
            run: seismicity_cases::seismicity_case,
        },
        Case {
            name: "slip_weakening",
            about: "a crack whose friction weakens from 29 to 15 degrees slides dynamically on the explicit rock and arrests: the event's M0' against the residual-friction static crack, b/h = 10 and 20",
            run: seismicity_cases::slip_weakening_case,
        },
        Case {
            name: "kgd",
            about: "KGD fracture under constant injection against the viscosity-dominated solution, explicit (both flow schemes) and quasi-static, h = 2 to 0.25 m (5 % at 0.25 m)",
            run: coupled_cases::kgd,
        },
        Case {
            name: "kgd_k",
            about: "toughness-dominated KGD grown by the toughness criterion (quasi-static rock), h = 2 to 0.5 m, two times, against the similarity solution",
            run: coupled_cases::kgd_k,
        },
        Case {
            name: "kgd_mk",
            about: "KGD between the viscosity and toughness vertices (dimensionless toughness 0.2 to 8, toughness criterion): bounded by both vertices, the M-K trend",
            run: coupled_cases::kgd_mk,
        },
        Case {
            name: "kgd_confinement",
            about: "viscous KGD (toughness criterion, 31 cells) under a confining stress of 3.4 to 40 times the net pressure, residual aperture 0.5 to 5 % of the well opening: errors against the fill number",
            run: coupled_cases::kgd_confinement,
        },
        Case {
            name: "example1",
            about: "the seed's Example I, cross and offset, explicit and quasi-static side by side: Fig. 7's outcome, the same cells, creation times and injected volume",
            run: example_cases::example1,
        },
        Case {
            name: "mass_scaling",
            about: "Example I with time.selective_mass_scaling 2, 4, 8 against the unscaled rock: volume, creation times, wall",
            run: example_cases::mass_scaling,
        },
        Case {
            name: "oda",
            about: "upscaling: Oda's crack tensor and the flow-based permeameter on parallel fractures (b^3/(12 s), round-off) and on sparse random networks (Oda bounds the flow from above)",
            run: upscale_cases::oda_case,
        },
        Case {
            name: "friction",
            about: "block on a joint inclined at psi under gravity: slides at g (sin psi - cos psi tan phi) or sticks",
            run: fracture_cases::friction,
        },
        Case {
            name: "contact",
            about: "frictional contact on the quasi-static rock with implicit dynamics (time.inertia: BackwardEuler): the inclined block slides at g (sin psi - cos psi tan phi) within 1 % or sticks, three step lengths beside the explicit scheme, Newton iterations per step",
            run: fracture_cases::contact,
        },
        Case {
            name: "heat_continuum",
            about: "continuum heat model: 1D thermal front against Ogata-Banks, 100 to 800 blocks (1 % at 800, order 1), energy and mass balance 1e-9; doublet breakthrough and symmetry",
            run: heat_continuum_cases::heat_continuum,
        },
        Case {
            name: "lauwerier",
            about: "discrete heat model, one fracture in conducting rock against Lauwerier's outlet temperature, 4 levels (2 % at the finest), energy balance 1e-9",
            run: heat_discrete_cases::lauwerier_case,
        },
        Case {
            name: "gringarten",
            about: "discrete heat model, parallel fractures 5 m apart against Gringarten-Witherspoon-Ohnishi (Stehfest), 4 levels (2 %), Lauwerier and local-equilibrium limits",
            run: heat_discrete_cases::gringarten_case,
        },
        Case {
            name: "heat_models",
            about: "discrete against continuum heat model on the same parallel fractures, spacing 0.5 to 32 m: where local thermal equilibrium holds (Fourier number of the slab)",
            run: heat_models_cases::heat_models,
        },
        Case {
            name: "extreme",
            about: "coupled and dry runs at the corners of the parameter space (K 1e8-1e10 Pa x a_r 1e-6-1e-2 m, nu 0-0.499, joint stiffness 1e12, p_max 100 MPa, E 1e9-1e12, mu 1e-6-1e3, h 1 % of the domain): finite and bounded, or refused naming the parameter",
            run: extreme_cases::extreme,
        },
    ]
}

/// Write `DIR/<case>.csv` with columns `case,level,h,unknowns,metric,error,wall_s`.
pub fn write_csv(dir: &Path, name: &str, res: &CaseResult) -> std::io::Result<()> {
    let mut s = String::from("case,level,h,unknowns,metric,error,wall_s\n");
    for r in &res.rows {
        s += &format!(
            "{},{},{},{},{},{:e},{}\n",
            r.case, r.level, r.h, r.unknowns, r.metric, r.error, r.wall_s
        );
    }
    crate::output::write_atomic(&dir.join(format!("{name}.csv")), s.as_bytes())
}

/// Plot error against wall time, one series per metric.
pub fn write_plot(dir: &Path, name: &str, res: &CaseResult) -> anyhow::Result<()> {
    let mut metrics: Vec<&str> = res.rows.iter().map(|r| r.metric.as_str()).collect();
    metrics.dedup();
    metrics.sort();
    metrics.dedup();
    let series: Vec<Series> = metrics
        .iter()
        .map(|m| Series {
            label: m.to_string(),
            points: res
                .rows
                .iter()
                .filter(|r| r.metric == *m)
                .map(|r| (r.wall_s.max(1e-6), r.error))
                .collect(),
        })
        .collect();
    loglog(
        &dir.join(format!("{name}.png")),
        &format!("{name}: error against run time"),
        "wall time [s]",
        "error (relative)",
        &series,
    )?;
    Ok(())
}

/// How a verification ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Verdict {
    /// Every check of the cases that ran passed.
    pub passed: bool,
    /// The cases that ran to the end (their CSV and PNG written), of `total` asked for.
    pub finished: Vec<&'static str>,
    pub total: usize,
    /// The signal that stopped the verification after a case, if one did.
    pub interrupted_by: Option<usize>,
}

/// Run the named cases (all when empty), print tables, write CSVs and plots. Returns whether
/// every check passed.
pub fn run_cases(names: &[String], out: &Path, quick: bool) -> anyhow::Result<bool> {
    Ok(run_cases_until(names, out, quick, None)?.passed)
}

/// [`run_cases`], stopping after the case in progress once `stop` holds a signal number (the
/// binary's SIGINT/SIGTERM handlers, [`crate::sim::StopFlag`]): the finished cases' CSV and
/// PNG are written, the last line says `verification interrupted by SIGINT after K of N
/// cases` and the cases not run.
pub fn run_cases_until(
    names: &[String],
    out: &Path,
    quick: bool,
    stop: Option<&crate::sim::StopFlag>,
) -> anyhow::Result<Verdict> {
    let all = cases();
    for n in names {
        if !all.iter().any(|c| c.name == n) {
            let valid: Vec<&str> = all.iter().map(|c| c.name).collect();
            anyhow::bail!(
                "unknown verification case `{n}`; cases: {}",
                valid.join(", ")
            );
        }
    }
    std::fs::create_dir_all(out)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
    let mut ok = true;
    let mut stdout = std::io::stdout();
    let chosen: Vec<&Case> = all
        .iter()
        .filter(|c| names.is_empty() || names.iter().any(|n| n == c.name))
        .collect();
    let signal = || {
        stop.map(|s| s.load(std::sync::atomic::Ordering::SeqCst))
            .filter(|&s| s != 0)
    };
    let mut finished = Vec::new();
    for case in &chosen {
        if let Some(sig) = signal() {
            let rest: Vec<&str> = chosen[finished.len()..].iter().map(|c| c.name).collect();
            writeln!(
                stdout,
                "verification interrupted by {} after {} of {} cases (CSV and PNG of those in \
                 {}; not run: {}); checks of the finished cases {}",
                crate::driver::signal_name(sig),
                finished.len(),
                chosen.len(),
                out.display(),
                rest.join(", "),
                if ok { "passed" } else { "FAILED" }
            )?;
            return Ok(Verdict {
                passed: ok,
                finished,
                total: chosen.len(),
                interrupted_by: Some(sig),
            });
        }
        writeln!(stdout, "== {}: {}", case.name, case.about)?;
        let res = (case.run)(quick)?;
        writeln!(
            stdout,
            "{:>5} {:>10} {:>10} {:<32} {:>12} {:>10}",
            "level", "h [m]", "unknowns", "metric", "error", "wall [s]"
        )?;
        for r in &res.rows {
            writeln!(
                stdout,
                "{:>5} {:>10.4} {:>10} {:<32} {:>12.3e} {:>10.3}",
                r.level, r.h, r.unknowns, r.metric, r.error, r.wall_s
            )?;
        }
        for c in &res.checks {
            writeln!(
                stdout,
                "  [{}] {} = {:.4e} ({})",
                if c.pass { "pass" } else { "FAIL" },
                c.what,
                c.value,
                c.limit
            )?;
        }
        for n in &res.notes {
            writeln!(stdout, "  {n}")?;
        }
        write_csv(out, case.name, &res)?;
        for (name, text) in &res.files {
            crate::output::write_atomic(&out.join(name), text.as_bytes())?;
        }
        write_plot(out, case.name, &res)?;
        for lp in &res.plots {
            lines(
                &out.join(&lp.file),
                &lp.title,
                &lp.xlabel,
                &lp.ylabel,
                &lp.series,
            )?;
        }
        ok &= res.passed();
        finished.push(case.name);
    }
    // A signal during the last case: it finished, nothing was left out.
    let interrupted_by = signal();
    writeln!(
        stdout,
        "verification {} (CSV and PNG in {})",
        if ok { "passed" } else { "FAILED" },
        out.display()
    )?;
    Ok(Verdict {
        passed: ok,
        finished,
        total: chosen.len(),
        interrupted_by,
    })
}
