//! Slip of a closed inclined crack (`docs/verification.md` R12b): `slip_inclined`.
//!
//! A closed straight crack of half-length b through the origin at beta = 20 degrees to x, in a
//! square of half-width 20b under the remote biaxial compression sigma_xx = -40 MPa,
//! sigma_yy = -10 MPa (tension positive; `Boundary::InSitu` with `initial_state: InSitu`),
//! friction angle phi = 20 degrees, no fluid, no fracture criterion, solved to its static state
//! by the quasi-static scheme. On the crack plane (normal n = (-sin beta, cos beta), tangent
//! t = (cos beta, sin beta)): sigma_n = -13.509 MPa, tau = 9.642 MPa, friction
//! -sigma_n tan phi = 4.917 MPa < |tau|, so the crack slides everywhere under the driving
//! shear dtau = |tau| + sigma_n tan phi = 4.725 MPa; the slip is the mode-II analogue of
//! Sneddon, delta(s) = (4 dtau / E') sqrt(b^2 - s^2), max 4 dtau b / E'
//! (`docs/conforming.md`, "Slip of a closed inclined crack").
//!
//! Two meshes side by side: `MeshSpec::Conforming` (the crack is along mesh edges) and
//! `MeshSpec::Graded` (the crack snapped to a zigzag of mesh edges, which interlocks).

use super::{CaseResult, Row};
use crate::scenario::{
    Boundary, Damping, End, FractureSpec, InitialState, Material, MeshSpec, PreFracture,
    SolidScheme,
};
use crate::sim::{Finish, Simulation};
use crate::verify::solid_cases::scenario;
use std::time::Instant;

/// Crack half-length b, m.
pub const B: f64 = 1.0;
/// Crack angle to the x axis, degrees.
pub const BETA_DEG: f64 = 20.0;
/// Remote stresses, Pa (tension positive).
pub const SXX: f64 = -40e6;
pub const SYY: f64 = -10e6;
/// Joint friction angle, degrees.
pub const PHI_DEG: f64 = 20.0;
/// Domain half-width, m (20 b).
pub const R: f64 = 20.0 * B;
/// Joint penalty stiffnesses over the rock's E and G (`fracture.normal_stiffness`,
/// `fracture.shear_stiffness`). The joint force is K delta per unit thickness, so the contact
/// is a spring of K / L per unit area on an edge of length L ~ h. With the default K_n = E the
/// crack's faces interpenetrate by sigma_n h / E and the crack is a compliant interface of
/// stiffness E / h against the crack's own 4b k / E' ~ 4 b / h: the contact carries
/// 1 / (1 + 4 b K_n / (E' h)) less than sigma_n (1.3 % at b/h = 20), which lowers the friction
/// cap and raises the driving shear by mu 1.3 % |sigma_n| / dtau = 1.4 %, an error of the same
/// order as the discretisation's. 100 E (and 100 G) brings it to 0.01 %.
pub const STIFFNESS_FACTOR: f64 = 100.0;

/// The rock: E = 20 GPa, nu = 0.2.
pub fn material() -> Material {
    Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    }
}

/// The crack's unit tangent t and normal n = (-sin beta, cos beta).
pub fn axes() -> ([f64; 2], [f64; 2]) {
    let beta = BETA_DEG.to_radians();
    ([beta.cos(), beta.sin()], [-beta.sin(), beta.cos()])
}

/// The closed form: (sigma_n, tau, dtau, max slip 4 dtau b / E'), Pa and m.
pub fn closed_form() -> (f64, f64, f64, f64) {
    let (t, n) = axes();
    // Traction on the plane of normal n: sigma . n with sigma = diag(sxx, syy).
    let tr = [SXX * n[0], SYY * n[1]];
    let sigma_n = tr[0] * n[0] + tr[1] * n[1];
    let tau = tr[0] * t[0] + tr[1] * t[1];
    let dtau = tau.abs() + sigma_n * PHI_DEG.to_radians().tan();
    let mat = material();
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    (sigma_n, tau, dtau, 4.0 * dtau * B / e_prime)
}

/// The closed-form slip at the distance `s` (m) along the crack from its centre.
pub fn slip_exact(s: f64) -> f64 {
    let (_, tau, _, dmax) = closed_form();
    tau.signum() * dmax * (1.0 - (s / B).powi(2)).max(0.0).sqrt()
}

/// The mesh around the crack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlipMesh {
    /// `MeshSpec::Conforming`: the crack along mesh edges of `h`, growing to 2b far away.
    Conforming,
    /// `MeshSpec::Graded`: cells of `h` in a box around the crack (ratio 1.15 outside); the
    /// crack snapped to a zigzag of mesh edges.
    Snapped,
}

/// One joint of the solved crack.
#[derive(Clone, Copy, Debug)]
pub struct JointSample {
    /// Distance of the joint's midpoint along the crack from its centre, m.
    pub s: f64,
    /// Reference length, m.
    pub len: f64,
    /// Relative displacement of the upper (+n) face over the lower along t (slip) and n
    /// (opening), m.
    pub slip: f64,
    pub opening: f64,
    /// Contact traction: normal force over length, Pa (compression positive), and shear force
    /// over length, Pa.
    pub normal_stress: f64,
    pub shear_stress: f64,
    pub sliding: bool,
}

/// One solved crack.
#[derive(Clone, Debug)]
pub struct SlipRun {
    pub joints: Vec<JointSample>,
    /// Largest distance of the crack's mesh path from the segment, m.
    pub snap_error: f64,
    pub unknowns: usize,
    pub wall_s: f64,
}

impl SlipRun {
    /// Relative error of the slip at the joint nearest the centre against the closed form
    /// there (4 dtau / E') sqrt(b^2 - s^2).
    pub fn max_slip_error(&self) -> f64 {
        let j = self
            .joints
            .iter()
            .min_by(|a, b| a.s.abs().total_cmp(&b.s.abs()))
            .expect("joints");
        j.slip / slip_exact(j.s) - 1.0
    }
    /// Relative L2 error of the slip profile over |s| < 0.8 b (joints weighted by length).
    pub fn profile_error(&self) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for j in self.joints.iter().filter(|j| j.s.abs() < 0.8 * B) {
            let e = slip_exact(j.s);
            num += j.len * (j.slip - e).powi(2);
            den += j.len * e * e;
        }
        (num / den).sqrt()
    }
    /// Largest |opening| over the closed-form max slip.
    pub fn opening_ratio(&self) -> f64 {
        let dmax = closed_form().3;
        self.joints
            .iter()
            .map(|j| j.opening.abs())
            .fold(0.0, f64::max)
            / dmax
    }
    /// Largest contact normal stress over |sigma_n| (1: the remote stress; on asperities of a
    /// zigzag, more).
    pub fn peak_normal_ratio(&self) -> f64 {
        let sigma_n = closed_form().0;
        self.joints
            .iter()
            .map(|j| j.normal_stress)
            .fold(0.0, f64::max)
            / sigma_n.abs()
    }
    /// Length-weighted mean contact normal stress over |sigma_n| - 1 over |s| < 0.8 b.
    pub fn mean_normal_error(&self) -> f64 {
        let sigma_n = closed_form().0;
        let (mut f, mut l) = (0.0, 0.0);
        for j in self.joints.iter().filter(|j| j.s.abs() < 0.8 * B) {
            f += j.normal_stress * j.len;
            l += j.len;
        }
        f / l / sigma_n.abs() - 1.0
    }
    /// Fraction of the crack's length that slides.
    pub fn sliding_fraction(&self) -> f64 {
        let total: f64 = self.joints.iter().map(|j| j.len).sum();
        let slid: f64 = self
            .joints
            .iter()
            .filter(|j| j.sliding)
            .map(|j| j.len)
            .sum();
        slid / total
    }
}

/// The scenario of the slipping crack on `mesh` at cell size `h` (m) along the crack, in a
/// square of half-width `r` (m), joint stiffnesses `k_factor` times E and G.
pub fn slip_scenario(mesh: SlipMesh, h: f64, r: f64, k_factor: f64) -> crate::scenario::Scenario {
    let spec = match mesh {
        SlipMesh::Conforming => MeshSpec::Conforming {
            width: 2.0 * r,
            height: 2.0 * r,
            origin: [-r, -r],
            h,
            h_far: Some(2.0 * B),
            min_angle_deg: 25.0,
            merge: 0.25,
            grading: 0.25,
            follow: Vec::new(),
        },
        SlipMesh::Snapped => MeshSpec::Graded {
            width: 2.0 * r,
            height: 2.0 * r,
            origin: [-r, -r],
            h,
            fine: super::sif_cases::fine_box(B, h, axes().0[1].atan2(axes().0[0])),
            ratio: 1.15,
        },
    };
    let mat = material();
    let mut sc = scenario(
        "slip_inclined",
        spec,
        mat,
        Boundary::InSitu { sxx: SXX, syy: SYY },
        End::Static {
            tol: 1e-8,
            min_steps: 2,
        },
        Damping::Local(0.8),
    );
    sc.initial_state = InitialState::InSitu;
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    sc.time.max_steps = 100;
    let (t, _) = axes();
    sc.fracture = Some(FractureSpec::joints(
        vec![PreFracture {
            from: [-B * t[0], -B * t[1]],
            to: [B * t[0], B * t[1]],
        }],
        PHI_DEG,
        5e-4,
        Some((k_factor * mat.young, k_factor * mat.shear())),
    ));
    sc
}

/// Solve the crack on `mesh` at b/h = `b_over_h` in a square of half-width `r` (m) with the
/// joint stiffnesses [`STIFFNESS_FACTOR`] times E and G, and sample its joints.
pub fn slip_run(mesh: SlipMesh, b_over_h: f64, r: f64) -> anyhow::Result<SlipRun> {
    slip_run_with(mesh, b_over_h, r, STIFFNESS_FACTOR)
}

/// [`slip_run`] with the joint stiffnesses `k_factor` times E and G.
pub fn slip_run_with(
    mesh: SlipMesh,
    b_over_h: f64,
    r: f64,
    k_factor: f64,
) -> anyhow::Result<SlipRun> {
    let sc = slip_scenario(mesh, B / b_over_h, r, k_factor);
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "slip_inclined: no static state (residual {:.3e})",
        sim.residual()
    );
    let wall_s = t0.elapsed().as_secs_f64();
    let (t, n) = axes();
    let v = sim.solid();
    let mut joints = Vec::with_capacity(v.joint_nodes.len());
    for (k, nodes) in v.joint_nodes.iter().enumerate() {
        let x = nodes.map(|i| v.x0[i as usize]);
        let u = nodes.map(|i| v.u[i as usize]);
        // Face p: nodes 0, 1; face q: nodes 2, 3. Face p's outward normal (towards q) in the
        // reference geometry, as `view::joint_frame` builds it.
        let e = [x[1][0] - x[0][0], x[1][1] - x[0][1]];
        let len = e[0].hypot(e[1]);
        let s = v.joint_sign[k];
        let np = [s * e[1] / len, -s * e[0] / len];
        // q - p; p below the crack (its outward normal along +n) gives upper - lower.
        let mut d = [
            0.5 * (u[2][0] + u[3][0] - u[0][0] - u[1][0]),
            0.5 * (u[2][1] + u[3][1] - u[0][1] - u[1][1]),
        ];
        if np[0] * n[0] + np[1] * n[1] < 0.0 {
            d = [-d[0], -d[1]];
        }
        let mid = [
            0.25 * (x[0][0] + x[1][0] + x[2][0] + x[3][0]),
            0.25 * (x[0][1] + x[1][1] + x[2][1] + x[3][1]),
        ];
        let st = v.joint_state[k];
        joints.push(JointSample {
            s: mid[0] * t[0] + mid[1] * t[1],
            len,
            slip: d[0] * t[0] + d[1] * t[1],
            opening: d[0] * n[0] + d[1] * n[1],
            normal_stress: st.normal_force / len,
            shear_stress: st.shear_force / len,
            sliding: st.sliding,
        });
    }
    anyhow::ensure!(!joints.is_empty(), "slip_inclined: no joints");
    let snap_error = sim
        .placed()
        .iter()
        .map(|p| p.snap_error)
        .fold(0.0, f64::max);
    Ok(SlipRun {
        joints,
        snap_error,
        unknowns: 2 * v.n_nodes(),
        wall_s,
    })
}

/// `slip_inclined`: the crack above at b/h = 10, 20, 40, 80 (10, 20 with `quick`) on both
/// meshes.
/// Rows per mesh (`_conforming`, `_snapped`): `max_slip` (the slip at the joint nearest the
/// centre against the closed form there), `slip_profile` (relative L2 over |s| < 0.8 b),
/// `opening` (largest |opening| over the closed-form max slip), `mean_normal_stress` (mean
/// contact normal stress over |sigma_n| - 1: the crack keeps the remote normal stress),
/// `peak_normal_stress` (largest contact normal stress over |sigma_n|, not an error: the
/// asperities of a zigzag).
pub fn slip_inclined(quick: bool) -> anyhow::Result<CaseResult> {
    // The quasi-static Newton iteration on the snapped zigzag cycled at b/h = 10 and 80 (a
    // joint opening and closing at every iteration, the residual stalled at 1e-3 with the
    // states fixed): the solid Newton's line search after `SOLID_LINE_SEARCH_AFTER`
    // iterations breaks the cycle (`systems/quasi_static.rs`), so all four levels run.
    let ratios: &[f64] = if quick {
        &[10.0, 20.0]
    } else {
        &[10.0, 20.0, 40.0, 80.0]
    };
    let (sigma_n, tau, dtau, dmax) = closed_form();
    let mut res = CaseResult::default();
    res.notes.push(format!(
        "closed form: sigma_n = {:.4} MPa, tau = {:.4} MPa, dtau = {:.4} MPa, max slip = {:.4e} m",
        sigma_n / 1e6,
        tau / 1e6,
        dtau / 1e6,
        dmax
    ));
    for (level, &bh) in ratios.iter().enumerate() {
        let h = B / bh;
        for (mesh, tag) in [
            (SlipMesh::Conforming, "conforming"),
            (SlipMesh::Snapped, "snapped"),
        ] {
            let run = slip_run(mesh, bh, R)?;
            let max_slip = run.max_slip_error();
            for (metric, err) in [
                ("max_slip", max_slip.abs()),
                ("slip_profile", run.profile_error()),
                ("opening", run.opening_ratio()),
                ("mean_normal_stress", run.mean_normal_error().abs()),
                ("peak_normal_stress", run.peak_normal_ratio()),
            ] {
                res.rows.push(Row {
                    case: "slip_inclined",
                    level,
                    h,
                    unknowns: run.unknowns,
                    metric: format!("{metric}_{tag}"),
                    error: err,
                    wall_s: run.wall_s,
                });
            }
            // Targets: the conforming mesh's max slip within 9 % at b/h = 10, 5 % at 20 and
            // 40, and 3 % at the finest level, b/h = 80 (the target; measured -7.9,
            // -4.6, -3.2 and -2.45 %: linear elements converging at about first order, the
            // error halving from 10 to 40 and slowing above); the snapped crack's slip short by
            // more than 20 % at every level (the zigzag interlocks: the defect the conforming
            // mesh fixes, measured -99 % at every level).
            match mesh {
                SlipMesh::Conforming => {
                    let limit = if level + 1 == ratios.len() && !quick {
                        0.03
                    } else if bh < 15.0 {
                        0.09
                    } else {
                        0.05
                    };
                    res.check_max(
                        format!("conforming max slip error at b/h = {bh}"),
                        max_slip.abs(),
                        limit,
                    );
                }
                SlipMesh::Snapped => res.check_range(
                    format!("snapped max slip shortfall at b/h = {bh}"),
                    -max_slip,
                    0.2,
                    1.0,
                ),
            }
            res.notes.push(format!(
                "b/h = {bh}, {tag}: max slip error {:+.4} %, profile L2 {:.4} %, snapping error \
                 {:.4} m, sliding {:.1} % of the length, peak contact stress {:.1} MPa, \
                 {} joints, {:.2} s",
                100.0 * max_slip,
                100.0 * run.profile_error(),
                run.snap_error,
                100.0 * run.sliding_fraction(),
                run.peak_normal_ratio() * sigma_n.abs() / 1e6,
                run.joints.len(),
                run.wall_s
            ));
        }
    }
    Ok(res)
}
