//! The fluid-driven frictional shear crack (issue 40, item 5; Bhattacharya and Viesca 2019,
//! Viesca 2021; `docs/shear_crack.md`): `shear_crack`.
//!
//! A closed planar joint in an infinite plane-strain rock, constant Coulomb friction f, uniform
//! effective normal stress sigma'_0 (compression positive) and shear stress tau_0 <
//! f sigma'_0, so it sticks everywhere at first. At t = 0 the fluid pressure at the joint's
//! centre is raised by dp and held; the joint stays closed at its residual aperture a_r, so the
//! pressure diffuses along it linearly, p(x, t) = dp erfc(|x| / sqrt(4 alpha t)), with the
//! diffusivity alpha = K a_r^2 / (12 mu) (m^2/s) of the engine's network flow (cubic law at
//! a_r, a closed cell's volume a_r L, the fluid's bulk modulus K). The sliding region grows
//! self-similarly, a(t) = lambda sqrt(4 alpha t), with lambda the root of
//!   T = (2/pi) int_0^{pi/2} erfc(lambda sin theta) d theta,   T = (f sigma'_0 - tau_0) / (f dp)
//! (the stress intensity at the slip front vanishes): [`lambda_exact`].
//!
//! The simulation: a straight crack at 45 degrees through the origin on a `MeshSpec::Conforming`
//! mesh, `Boundary::InSitu` principal stresses chosen so that the crack carries sigma'_0 and
//! tau_0, `initial_state: InSitu`, the quasi-static rock coupled with the network's
//! backward-Euler step, joint penalty stiffnesses 100 E and 100 G, the crack's cells full at
//! zero pressure and a `Pressure(dp)` boundary at the node at its centre.

use super::flow_cases::{diffusivity, erfc};
use super::{CaseResult, LinePlot, Row};
use crate::plot::Series;
use crate::scenario::{
    Boundary, Coords, Damping, End, FlowBcKind, FlowBoundary, FlowTarget, FractureSpec,
    InitialFluid, InitialState, LinearSolver, Material, MeshSpec, PreFracture, Scenario,
    SolidScheme,
};
use crate::sim::{Finish, Simulation};
use std::f64::consts::PI;
use std::time::Instant;

/// Friction coefficient f (the joints' friction angle is atan f).
pub const FRICTION: f64 = 0.6;
/// Initial effective normal stress on the crack, Pa (compression positive; the fluid starts at
/// zero pressure, so it is the total normal stress).
pub const SIGMA0: f64 = 20e6;
/// Pressure step at the crack's centre, Pa (below [`SIGMA0`]: the crack stays closed).
pub const DP: f64 = 10e6;
/// Residual (hydraulic) aperture of the closed crack, m.
pub const A_R: f64 = 1e-4;
/// Crack angle to the x axis, degrees.
pub const BETA_DEG: f64 = 45.0;
/// Final slip half-length of every run, m: the cell size is this over the faces asked for.
pub const A_END: f64 = 40.0;
/// Joint penalty stiffnesses over the rock's E and G (as `verify slip_inclined`: the contact's
/// compliance h / (100 E) is negligible against the crack's).
pub const STIFFNESS_FACTOR: f64 = 100.0;
/// Domain half-width over [`A_END`] (the solution is for an infinite plane; the boundary's
/// fixed normal displacements perturb the slip by about (a / R)^2).
pub const DOMAIN_FACTOR: f64 = 25.0;
/// The crack reaches past the final slip front by this factor (it ends stuck) and past the
/// pressure front to where erfc(x / sqrt(4 alpha t)) < 4.1e-4 ([`PRESSURE_REACH`] diffusion
/// lengths): the far end is closed to flow, so the pressure there is about twice that.
pub const CRACK_OVER_FRONT: f64 = 1.3;
/// Diffusion lengths sqrt(4 alpha t_end) the crack reaches on each side of its centre.
pub const PRESSURE_REACH: f64 = 2.5;

/// T of lambda: (2/pi) int_0^{pi/2} erfc(lambda sin theta) d theta, by the midpoint rule on
/// `n` points (dimensionless).
pub fn stress_injection_parameter(lambda: f64, n: usize) -> f64 {
    let d = 0.5 * PI / n as f64;
    let s: f64 = (0..n)
        .map(|k| erfc(lambda * ((k as f64 + 0.5) * d).sin()))
        .sum();
    2.0 / PI * s * d
}

/// lambda(T), 0 < T < 1: the root of [`stress_injection_parameter`] = T by bisection (the
/// integral falls monotonically from 1 at lambda = 0 to 0), the integral on 20,000 midpoints
/// (dimensionless). NaN outside (0, 1).
pub fn lambda_exact(t: f64) -> f64 {
    if !(t > 0.0 && t < 1.0) {
        return f64::NAN;
    }
    const N: usize = 20_000;
    let (mut lo, mut hi) = (0.0, 1.0);
    while stress_injection_parameter(hi, N) > t {
        lo = hi;
        hi *= 2.0;
        if hi > 1e6 {
            return f64::NAN;
        }
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if stress_injection_parameter(mid, N) > t {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-13 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The critically stressed limit (T << 1): lambda = 2 / (pi^{3/2} T).
pub fn lambda_critically_stressed(t: f64) -> f64 {
    2.0 / (PI.powf(1.5) * t)
}

/// The marginally pressurised limit (T near 1): lambda = (pi^{3/2} / 4) (1 - T).
pub fn lambda_marginally_pressurised(t: f64) -> f64 {
    PI.powf(1.5) / 4.0 * (1.0 - t)
}

/// The asymptote that applies at T: [`lambda_critically_stressed`] below 1/2, else
/// [`lambda_marginally_pressurised`].
pub fn lambda_asymptote(t: f64) -> f64 {
    if t < 0.5 {
        lambda_critically_stressed(t)
    } else {
        lambda_marginally_pressurised(t)
    }
}

/// The shear stress on the crack for the stress-injection parameter T, Pa:
/// tau_0 = f sigma'_0 - T f dp.
pub fn tau0(t: f64) -> f64 {
    FRICTION * SIGMA0 - t * FRICTION * DP
}

/// The crack's unit tangent t and normal n = (-sin beta, cos beta).
pub fn axes() -> ([f64; 2], [f64; 2]) {
    let b = BETA_DEG.to_radians();
    ([b.cos(), b.sin()], [-b.sin(), b.cos()])
}

/// Principal remote stresses (sxx, syy), Pa, tension positive, that put the normal stress
/// -[`SIGMA0`] and the shear stress [`tau0`] on the crack at [`BETA_DEG`]: with
/// n = (-sin b, cos b), sigma_n = sxx sin^2 b + syy cos^2 b and
/// tau = (syy - sxx) sin b cos b.
pub fn remote_stresses(t: f64) -> (f64, f64) {
    let b = BETA_DEG.to_radians();
    let (s, c) = (b.sin(), b.cos());
    // Solve [s^2 c^2; -sc sc] [sxx syy]^T = [-SIGMA0, tau0].
    let (a11, a12, a21, a22) = (s * s, c * c, -s * c, s * c);
    let (r1, r2) = (-SIGMA0, tau0(t));
    let det = a11 * a22 - a12 * a21;
    ((r1 * a22 - a12 * r2) / det, (a11 * r2 - a21 * r1) / det)
}

/// The rock: E = 20 GPa, nu = 0.2.
pub fn material() -> Material {
    Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    }
}

/// The pressure diffusivity alpha of the closed crack, m^2/s: the engine's cell is a_r L in
/// volume (closed: max(delta_n, a_r) = a_r), its pressure K (m / (rho_r V) - 1) and the flow
/// between equal cells a_r^3 / (12 mu) dP/ds, so V/K dP/dt = a_r^3/(12 mu) d2P/ds2 L.
pub fn alpha() -> f64 {
    diffusivity(A_R, &crate::scenario::Fluid::default())
}

/// One run's geometry: T, the faces the slip half-length spans at the end, and what follows.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    /// Stress-injection parameter T.
    pub t: f64,
    /// Faces along the final slip half-length.
    pub faces: usize,
    /// Edge length along the crack, m.
    pub h: f64,
    /// End time, s: lambda sqrt(4 alpha t_end) = [`A_END`].
    pub t_end: f64,
    /// Crack half-length, m (a whole number of faces, so a node sits at the centre).
    pub c: f64,
    /// Domain half-width, m.
    pub r: f64,
}

impl Setup {
    /// The run at T (0 < T < 1; outside, the times and lengths are NaN) with `faces` faces
    /// along the final slip half-length [`A_END`].
    pub fn new(t: f64, faces: usize) -> Self {
        let lambda = lambda_exact(t);
        let h = A_END / faces as f64;
        let d_end = A_END / lambda;
        let t_end = d_end * d_end / (4.0 * alpha());
        let reach = (CRACK_OVER_FRONT * A_END).max(PRESSURE_REACH * d_end);
        let c = (reach / h).ceil() * h;
        let r = (DOMAIN_FACTOR * A_END).max(2.0 * c);
        Setup {
            t,
            faces,
            h,
            t_end,
            c,
            r,
        }
    }

    /// The scenario.
    pub fn scenario(&self) -> Scenario {
        let mat = material();
        let (sxx, syy) = remote_stresses(self.t);
        let spec = MeshSpec::Conforming {
            width: 2.0 * self.r,
            height: 2.0 * self.r,
            origin: [-self.r, -self.r],
            h: self.h,
            h_far: Some(self.r / 8.0),
            min_angle_deg: 25.0,
            merge: 0.25,
            grading: 0.25,
            follow: Vec::new(),
        };
        let mut sc = super::solid_cases::scenario(
            "shear_crack",
            spec,
            mat,
            Boundary::InSitu { sxx, syy },
            End::Time(self.t_end),
            Damping::None,
        );
        sc.initial_state = InitialState::InSitu;
        sc.time.solid_scheme = SolidScheme::QuasiStatic;
        // The first step is short (D = 1e-3 of the final diffusion length, below a face): its
        // slips are the joints' penalty offsets under the in-situ load, the reference of the
        // moment. The adaptive step then grows by 1.5 per easy step up to t_end / 100.
        sc.time.dt = Some(1e-6 * self.t_end);
        sc.time.max_steps = 100_000;
        // The full Newton matrix by sparse LU (the exact joint tangent): with the default
        // Cholesky tangent (the Coulomb term by Sherman-Morrison-Woodbury) Newton failed at
        // every step once the front joints began to slide (T = 0.1, 10 faces: the step halved
        // to 1e-5 t_end and stayed there, 140 cutbacks in 340 steps); with LU none failed.
        sc.time.linear_solver = LinearSolver::Lu;
        let (t, _) = axes();
        sc.fracture = Some(FractureSpec::joints(
            vec![PreFracture {
                from: [-self.c * t[0], -self.c * t[1]],
                to: [self.c * t[0], self.c * t[1]],
            }],
            FRICTION.atan().to_degrees(),
            A_R,
            Some((STIFFNESS_FACTOR * mat.young, STIFFNESS_FACTOR * mat.shear())),
        ));
        sc.initial_fluid = InitialFluid::Full(0.0);
        sc.flow_boundaries = vec![FlowBoundary {
            name: "well".into(),
            at: FlowTarget::Node(Coords::two([0.0, 0.0])),
            kind: FlowBcKind::Pressure(DP),
            schedule: Vec::new(),
        }];
        sc
    }
}

/// A joint of the crack: its midpoint's distance along the crack (m), reference length (m),
/// slip (m, upper face over lower along t) and sliding flag.
#[derive(Clone, Copy, Debug)]
struct Joint {
    s: f64,
    len: f64,
    slip: f64,
    sliding: bool,
}

fn joints(sim: &Simulation) -> Vec<Joint> {
    let (t, n) = axes();
    let v = sim.solid();
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    v.joint_nodes
        .iter()
        .zip(&v.joint_state)
        .zip(&v.joint_sign)
        .map(|((nodes, st), &sign)| {
            let x = nodes.map(|i| v.x0[i as usize]);
            let u = nodes.map(|i| v.u[i as usize]);
            let e = [x[1][0] - x[0][0], x[1][1] - x[0][1]];
            let len = e[0].hypot(e[1]);
            // Face p (nodes 0, 1) has the outward normal sign (e_y, -e_x) / len, towards q.
            let np = [sign * e[1] / len, -sign * e[0] / len];
            let q_minus_p = [
                0.5 * (u[2][0] + u[3][0] - u[0][0] - u[1][0]),
                0.5 * (u[2][1] + u[3][1] - u[0][1] - u[1][1]),
            ];
            let up = if dot(np, n) >= 0.0 { 1.0 } else { -1.0 };
            let mid = [0.5 * (x[0][0] + x[1][0]), 0.5 * (x[0][1] + x[1][1])];
            Joint {
                s: dot(mid, t),
                len,
                slip: up * dot(q_minus_p, t),
                sliding: st.sliding,
            }
        })
        .collect()
}

/// The slip front on each side: the outer end of the outermost sliding joint (the front lies
/// between that joint's midpoint and the next's, so its outer end is the unbiased estimate),
/// m; 0 on a side without sliding joints.
fn fronts(js: &[Joint]) -> (f64, f64) {
    let mut f = (0.0f64, 0.0f64);
    for j in js.iter().filter(|j| j.sliding) {
        if j.s >= 0.0 {
            f.0 = f.0.max(j.s + 0.5 * j.len);
        } else {
            f.1 = f.1.max(-j.s + 0.5 * j.len);
        }
    }
    f
}

/// One step's record: time (s), slip half-lengths on the + and - sides (m), the slip moment
/// per unit thickness M0' = G sum |slip - slip_0| L (N m / m = N), the injected volume per
/// unit thickness (m^2).
#[derive(Clone, Copy, Debug)]
pub struct StepRecord {
    pub time: f64,
    pub a_plus: f64,
    pub a_minus: f64,
    pub moment: f64,
    pub injected: f64,
}

/// One run of the shear crack.
#[derive(Clone, Debug)]
pub struct ShearRun {
    pub setup: Setup,
    pub history: Vec<StepRecord>,
    /// lambda by the least-squares fit of a = lambda sqrt(4 alpha t) through the origin over
    /// the steps where a spans at least [`ShearRun::min_faces`] faces.
    pub lambda: f64,
    /// The same fit with an intercept: (lambda, intercept m).
    pub lambda_affine: (f64, f64),
    /// Steps in the fit.
    pub fit_steps: usize,
    /// Log-log slope of M0' against the injected volume over the same steps.
    pub moment_slope: f64,
    /// Largest |p - dp erfc(|x| / sqrt(4 alpha t))| / dp over the cells at the end.
    pub pressure_error: f64,
    /// Relative L2 error of the cell pressures at the end (weighted by cell length).
    pub pressure_l2: f64,
    /// The mass-balance error at the end.
    pub balance: f64,
    /// Largest |a_plus - a_minus| over the fit's steps, m (the symmetry of the two fronts).
    pub asymmetry: f64,
    pub steps: u64,
    pub unknowns: usize,
    pub cells: usize,
    pub wall_s: f64,
}

impl ShearRun {
    /// The fronts the fit uses span at least this many faces: 10, or half the final
    /// half-length on coarser runs (so a 10-face run fits its last three quarters of time).
    pub fn min_faces(faces: usize) -> f64 {
        (0.5 * faces as f64).min(10.0)
    }
}

/// Least squares y = b x through the origin: b.
fn fit_origin(pts: &[(f64, f64)]) -> f64 {
    let sxy: f64 = pts.iter().map(|p| p.0 * p.1).sum();
    let sxx: f64 = pts.iter().map(|p| p.0 * p.0).sum();
    sxy / sxx
}

/// Least squares y = b x + c: (b, c).
fn fit_affine(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let b = sxy / sxx;
    (b, my - b * mx)
}

/// Run the shear crack at T = `t` with `faces` faces along the final slip half-length.
pub fn shear_run(t: f64, faces: usize) -> anyhow::Result<ShearRun> {
    anyhow::ensure!(
        t > 0.0 && t < 1.0 && faces > 0,
        "shear_crack: T = {t} is not in (0, 1) or no faces ({faces})"
    );
    let setup = Setup::new(t, faces);
    let sc = setup.scenario();
    let g = material().shear();
    let alpha = alpha();
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let mut slip0: Option<Vec<f64>> = None;
    let mut history = Vec::new();
    while sim.finish().is_none() {
        sim.step_once()?;
        let js = joints(&sim);
        let base = slip0.get_or_insert_with(|| js.iter().map(|j| j.slip).collect());
        anyhow::ensure!(
            base.len() == js.len(),
            "shear_crack: the joints changed during the run"
        );
        let moment = g * js
            .iter()
            .zip(base.iter())
            .map(|(j, s0)| (j.slip - s0).abs() * j.len)
            .sum::<f64>();
        let (a_plus, a_minus) = fronts(&js);
        let injected = sim.flow_balance().map_or(f64::NAN, |b| b.0);
        history.push(StepRecord {
            time: sim.time(),
            a_plus,
            a_minus,
            moment,
            injected,
        });
    }
    anyhow::ensure!(
        sim.finish() == Some(Finish::EndTime),
        "shear_crack T = {t}, {faces} faces: ended with {:?}",
        sim.finish()
    );
    let wall_s = t0.elapsed().as_secs_f64();
    let min_a = ShearRun::min_faces(faces) * setup.h;
    let fit: Vec<&StepRecord> = history
        .iter()
        .filter(|r| 0.5 * (r.a_plus + r.a_minus) >= min_a)
        .collect();
    anyhow::ensure!(
        fit.len() >= 3,
        "shear_crack T = {t}, {faces} faces: {} steps with a >= {min_a} m to fit",
        fit.len()
    );
    let pts: Vec<(f64, f64)> = fit
        .iter()
        .map(|r| ((4.0 * alpha * r.time).sqrt(), 0.5 * (r.a_plus + r.a_minus)))
        .collect();
    let lambda = fit_origin(&pts);
    let lambda_affine = fit_affine(&pts);
    let asymmetry = fit
        .iter()
        .map(|r| (r.a_plus - r.a_minus).abs())
        .fold(0.0, f64::max);
    let log_pts: Vec<(f64, f64)> = fit
        .iter()
        .map(|r| (r.injected.ln(), r.moment.ln()))
        .collect();
    let moment_slope = fit_affine(&log_pts).0;
    // The pressure along the crack at the end against dp erfc(|s| / sqrt(4 alpha t)).
    let (tv, _) = axes();
    let flow = sim
        .flow()
        .ok_or_else(|| anyhow::anyhow!("shear_crack: no flow part"))?;
    let fv = &flow.view;
    let d = (4.0 * alpha * sim.time()).sqrt();
    let (mut emax, mut num, mut den) = (0.0f64, 0.0, 0.0);
    for c in 0..fv.n_cells() {
        let [p, q] = fv.cell_nodes[c].map(|k| fv.node_ref[k as usize]);
        let mid = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
        let s = mid[0] * tv[0] + mid[1] * tv[1];
        let exact = DP * erfc(s.abs() / d);
        let e = fv.pressure[c] - exact;
        emax = emax.max(e.abs() / DP);
        num += fv.length[c] * e * e;
        den += fv.length[c] * exact * exact;
    }
    let balance = sim.flow_balance().map_or(f64::NAN, |b| b.3);
    Ok(ShearRun {
        setup,
        fit_steps: fit.len(),
        history,
        lambda,
        lambda_affine,
        moment_slope,
        pressure_error: emax,
        pressure_l2: (num / den).sqrt(),
        balance,
        asymmetry,
        steps: sim.step(),
        unknowns: 2 * sim.solid().n_nodes(),
        cells: fv.n_cells(),
        wall_s,
    })
}

/// `shear_crack`: T = 0.1 and 0.8, each at 10, 20 and 40 faces along the final slip
/// half-length (`quick`: 10 faces). Rows per T (`_t0.1`, `_t0.8`): `lambda` (|lambda / lambda
/// exact - 1|), `pressure` (largest |p - dp erfc| / dp along the crack at the end),
/// `moment_slope` (|d ln M0' / d ln V - 2|). Checks: lambda within 3 % at 40 faces (the
/// issue's target), [`COARSE_LAMBDA_TOL`] below; the pressure, the moment's slope and the mass
/// balance at every level.
pub fn shear_crack(quick: bool) -> anyhow::Result<CaseResult> {
    // `--quick` (CI): only the 10-face level, about 30 s on 2 cores (the 40-face level at
    // T = 0.8, 706 cells and 38,000 unknowns, takes minutes). Its lambda tolerance is the
    // coarse levels' 5 %, not the 3 % of 40 faces: at 10 faces the front moves by steps of
    // 10 % of the final half-length (measured +1.6 % and +3.3 %).
    let levels: &[usize] = if quick { &[10] } else { &[10, 20, 40] };
    let mut res = CaseResult::default();
    let alpha = alpha();
    res.notes.push(format!(
        "f = {FRICTION}, sigma'_0 = {} MPa, dp = {} MPa, a_r = {A_R} m, alpha = K a_r^2 / \
         (12 mu) = {alpha:.5e} m^2/s, crack at {BETA_DEG} degrees, final slip half-length \
         {A_END} m",
        SIGMA0 / 1e6,
        DP / 1e6
    ));
    for &t in &[0.1, 0.8] {
        let exact = lambda_exact(t);
        let (sxx, syy) = remote_stresses(t);
        res.notes.push(format!(
            "T = {t}: lambda = {exact:.5} (asymptote {:.5}), tau_0 = {:.3} MPa, sxx = {:.3} \
             MPa, syy = {:.3} MPa",
            lambda_asymptote(t),
            tau0(t) / 1e6,
            sxx / 1e6,
            syy / 1e6
        ));
        let mut plot_series = Vec::new();
        for (level, &faces) in levels.iter().enumerate() {
            let run = shear_run(t, faces)?;
            let err = run.lambda / exact - 1.0;
            for (metric, e) in [
                ("lambda", err.abs()),
                ("pressure", run.pressure_error),
                ("moment_slope", (run.moment_slope - 2.0).abs()),
            ] {
                res.rows.push(Row {
                    case: "shear_crack",
                    level,
                    h: run.setup.h,
                    unknowns: run.unknowns,
                    metric: format!("{metric}_t{t}"),
                    error: e,
                    wall_s: run.wall_s,
                });
            }
            res.notes.push(format!(
                "T = {t}, {faces} faces (h = {:.3} m, crack half-length {:.1} m, {} cells, \
                 domain half-width {:.0} m): lambda {:.5} ({:+.3} %; with an intercept {:.5}, \
                 {:+.3} m), {} steps fitted of {}; fronts differ by at most {:.3} m; moment \
                 slope {:.4}; pressure max {:.3e} dp, L2 {:.3e}; mass balance {:.1e}; {:.1} s",
                run.setup.h,
                run.setup.c,
                run.cells,
                run.setup.r,
                run.lambda,
                100.0 * err,
                run.lambda_affine.0,
                run.lambda_affine.1,
                run.fit_steps,
                run.steps,
                run.asymmetry,
                run.moment_slope,
                run.pressure_error,
                run.pressure_l2,
                run.balance,
                run.wall_s
            ));
            plot_series.push(Series {
                label: format!("{faces} faces"),
                points: run
                    .history
                    .iter()
                    .map(|r| ((4.0 * alpha * r.time).sqrt(), 0.5 * (r.a_plus + r.a_minus)))
                    .collect(),
            });
            let finest = level + 1 == levels.len() && !quick;
            let lambda_tol = if finest {
                FINE_LAMBDA_TOL
            } else {
                COARSE_LAMBDA_TOL
            };
            let (pressure_tol, slope) = if faces >= 20 {
                (FINE_PRESSURE_TOL, MOMENT_SLOPE)
            } else {
                (PRESSURE_TOL, COARSE_MOMENT_SLOPE)
            };
            res.check_max(
                format!("|lambda error| at T = {t}, {faces} faces"),
                err.abs(),
                lambda_tol,
            );
            res.check_max(
                format!("pressure error at T = {t}, {faces} faces"),
                run.pressure_error,
                pressure_tol,
            );
            res.check_range(
                format!("moment slope d ln M0' / d ln V at T = {t}, {faces} faces"),
                run.moment_slope,
                slope.0,
                slope.1,
            );
            res.check_max(
                format!("mass balance at T = {t}, {faces} faces"),
                run.balance,
                1e-9,
            );
        }
        let d_end = A_END / exact;
        plot_series.push(Series {
            label: format!("lambda = {exact:.4}"),
            points: vec![(0.0, 0.0), (d_end, A_END)],
        });
        res.plots.push(LinePlot {
            file: format!("shear_crack_front_t{t}.png"),
            title: format!("Slip half-length, T = {t}"),
            xlabel: "sqrt(4 alpha t), m".into(),
            ylabel: "a, m".into(),
            series: plot_series,
        });
    }
    Ok(res)
}

/// The lambda tolerance below the finest level (10 and 20 faces, also `--quick`'s 10): the
/// front moves by whole faces, 10 % of the final half-length at 10 faces, and the fit over
/// about 80 steps averages that staircase to about a third of a face (measured at 10 faces
/// +1.6 % at T = 0.1 and +3.3 % at T = 0.8, at 20 faces +2.4 % and +1.0 %).
pub const COARSE_LAMBDA_TOL: f64 = 0.05;
/// The lambda tolerance at the finest level of the full run (40 faces): the 3 %.
pub const FINE_LAMBDA_TOL: f64 = 0.03;
/// The pressure tolerance (largest |p - dp erfc| / dp along the crack at the end) at 10 faces:
/// at T = 0.1 the final diffusion length sqrt(4 alpha t) is only 2.7 faces there (measured
/// 2.0 %).
pub const PRESSURE_TOL: f64 = 0.05;
/// The pressure tolerance at 20 faces and more (measured at most 0.55 %).
pub const FINE_PRESSURE_TOL: f64 = 0.01;
/// The accepted range of the moment's log-log slope against the injected volume at 20 faces
/// and more (theory 2; measured 2.004 to 2.041).
pub const MOMENT_SLOPE: (f64, f64) = (1.9, 2.1);
/// The same at 10 faces: M0' ~ a^2 grows by whole faces' steps, which bias the slope up
/// (measured 2.077 and 2.105).
pub const COARSE_MOMENT_SLOPE: (f64, f64) = (1.85, 2.15);
