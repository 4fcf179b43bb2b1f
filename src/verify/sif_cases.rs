//! Stress intensity verification (`docs/verification.md` R7b): `sif`.
//!
//! The toughness criterion's K_I and K_II (`systems/toughness.rs`: J by the domain integral,
//! split by the offsets behind the tip) on static cracks in plane strain, against
//! - a pressurised straight crack (Sneddon): K_I = p sqrt(pi a), K_II = 0, horizontal and at
//!   45 degrees (a mesh direction of the regular mesh, so the crack follows the mesh exactly);
//! - a crack at beta = 45 degrees to a remote uniaxial tension sigma:
//!   K_I = sigma sqrt(pi a) sin^2(beta), K_II = sigma sqrt(pi a) sin(beta) cos(beta),
//!   and the maximum hoop stress's growth angle, theta_c = 2 atan((K_I - sqrt(K_I^2 + 8 K_II^2))
//!   / (4 K_II)) = -53.13 degrees for K_I = K_II.
//!
//! Every crack sits in a square of half-width 20a (fixed edges under pressure; rollers on the
//! left and bottom and a traction on top under tension) on a graded mesh that is regular at
//! the crack, solved by the quasi-static scheme. The fixed edges stiffen the pressurised crack:
//! rerun at 40a and 80a, K is extrapolated to r -> infinity with the 1/r^2 law of a fixed far
//! boundary (as `sneddon` does for the area), and the corrected error is checked.

use super::{CaseResult, Row};
use crate::scenario::{Boundary, Damping, End, Material, MeshSpec, SideBc, SolidScheme};
use crate::sim::{Finish, Simulation};
use crate::verify::solid_cases::scenario;
use std::f64::consts::PI;
use std::time::Instant;

/// How the crack is loaded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CrackLoad {
    /// Pressure p on the faces, Pa; the domain's edges fixed.
    Pressure(f64),
    /// Remote uniaxial tension sigma_yy, Pa (top traction; rollers left and bottom).
    TensionY(f64),
}

/// K at the tips of one static crack, ordered by x.
#[derive(Clone, Debug)]
pub struct SifRun {
    pub k1: Vec<f64>,
    pub k2: Vec<f64>,
    /// Growth angle (rad) at each tip, measured from the fracture's direction there.
    pub theta: Vec<f64>,
    /// Largest distance of the snapped crack from the segment, m.
    pub snap_error: f64,
    pub wall_s: f64,
    pub unknowns: usize,
}

/// The crack of half-length `a` (m) through the origin at `angle` (rad, from the x axis) in a
/// square of half-width `r` (m), loaded by `load`, solved to its static state. `Snapped`: a
/// graded mesh of fine size `h` (m), with the angle 0 or pi/4 so that the ends sit on mesh
/// nodes and the crack on edges; `Conforming`: a mesh that follows the crack at any angle
/// ([`conforming_square`]).
pub fn crack_sif(
    a: f64,
    h: f64,
    r: f64,
    angle: f64,
    load: CrackLoad,
    mesh: CrackMesh,
) -> anyhow::Result<SifRun> {
    let (c, s) = (a * angle.cos(), a * angle.sin());
    let mat = Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    };
    let boundary = match load {
        CrackLoad::Pressure(_) => Boundary::Sides {
            left: SideBc::Fixed,
            right: SideBc::Fixed,
            bottom: SideBc::Fixed,
            top: SideBc::Fixed,
        },
        CrackLoad::TensionY(sigma) => Boundary::Sides {
            left: SideBc::Normal(0.0),
            right: SideBc::Free,
            bottom: SideBc::Normal(0.0),
            top: SideBc::Traction {
                normal: sigma,
                shear: 0.0,
            },
        },
    };
    let spec = mesh.spec(r, h, a, angle);
    let mut sc = scenario(
        "sif",
        spec,
        mat,
        boundary,
        End::Static {
            tol: 1e-8,
            min_steps: 10,
        },
        Damping::Local(0.8),
    );
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    sc.fracture = Some(super::fracture_cases::crack_spec(
        [-c, -s],
        [c, s],
        match load {
            CrackLoad::Pressure(p) => Some(p),
            CrackLoad::TensionY(_) => None,
        },
    ));
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "sif: no static state (residual {:.3e})",
        sim.residual()
    );
    let wall_s = t0.elapsed().as_secs_f64();
    let snap_error = sim
        .placed()
        .iter()
        .map(|p| p.snap_error)
        .fold(0.0, f64::max);
    let mut tips = sim.measure_tips().to_vec();
    anyhow::ensure!(tips.len() == 2, "sif: {} crack tips, not 2", tips.len());
    let x = |t: &crate::systems::toughness::TipState| sim.solid().x0[t.node as usize][0];
    tips.sort_by(|p, q| x(p).total_cmp(&x(q)));
    Ok(SifRun {
        k1: tips.iter().map(|t| t.k1).collect(),
        k2: tips.iter().map(|t| t.k2).collect(),
        theta: tips.iter().map(|t| t.theta).collect(),
        snap_error,
        wall_s,
        unknowns: 2 * sim.solid().n_nodes(),
    })
}

/// The mesh of an inclined-crack run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CrackMesh {
    /// `Conforming` with edges of h along the crack, at most 2a far away.
    Conforming,
    /// `Graded` (h in a box around the crack, growing by 15 % per cell): the crack snapped.
    Snapped,
}

impl CrackMesh {
    /// The mesh of the square of half-width `r` (m) around the crack of half-length `a` (m)
    /// through the origin at `angle` (rad), with edges of `h` (m) along it.
    pub fn spec(self, r: f64, h: f64, a: f64, angle: f64) -> MeshSpec {
        match self {
            CrackMesh::Conforming => conforming_square(r, h, a),
            CrackMesh::Snapped => MeshSpec::Graded {
                width: 2.0 * r,
                height: 2.0 * r,
                origin: [-r, -r],
                h,
                fine: fine_box(a, h, angle),
                ratio: 1.15,
            },
        }
    }
}

/// A conforming mesh of the square of half-width `r` (m) around a crack of half-length `a`
/// (m): edges of `h` (m) along the crack, graded to at most 2a away from it, angles of at least
/// 25 degrees.
fn conforming_square(r: f64, h: f64, a: f64) -> MeshSpec {
    MeshSpec::Conforming {
        width: 2.0 * r,
        height: 2.0 * r,
        origin: [-r, -r],
        h,
        h_far: Some(2.0 * a),
        min_angle_deg: 25.0,
        merge: 0.25,
        grading: 0.1,
        follow: Vec::new(),
    }
}

/// The fine box of the graded mesh around the crack of half-length `a` at `angle`: the crack
/// with 0.2a to spare, in whole cells of `h`.
pub(crate) fn fine_box(a: f64, h: f64, angle: f64) -> [f64; 4] {
    let cells = |len: f64| ((len + 0.2 * a) / h - 1e-9).ceil() * h;
    let (fx, fy) = (
        cells((a * angle.cos()).abs()),
        cells((a * angle.sin()).abs()),
    );
    [-fx, -fy, fx, fy]
}

/// Domain correction of K_I for the pressurised crack at 20a on the graded mesh: runs at about
/// 40a and 80a with the same diagonal parity as the 20a mesh (`fracture_cases::mesh_parity`),
/// extrapolated with the 1/r^2 law; returns K_inf / K(20a) - 1 and the extra wall time (s).
fn domain_effect(a: f64, h: f64, angle: f64, p: f64, at_20a: f64) -> anyhow::Result<(f64, f64)> {
    let fine = fine_box(a, h, angle);
    let parity = super::fracture_cases::mesh_parity(h, 20.0 * a, fine)?;
    let same = |base: f64| -> anyhow::Result<f64> {
        for k in 0..20 {
            let r = base * (1.0 + 0.05 * k as f64);
            if super::fracture_cases::mesh_parity(h, r, fine)? == parity {
                return Ok(r);
            }
        }
        anyhow::bail!("no domain near {base} m with the crack's diagonal parity")
    };
    let (r1, r2) = (same(40.0 * a)?, same(80.0 * a)?);
    let load = CrackLoad::Pressure(p);
    let c1 = crack_sif(a, h, r1, angle, load, CrackMesh::Snapped)?;
    let c2 = crack_sif(a, h, r2, angle, load, CrackMesh::Snapped)?;
    let (k1, k2) = (c1.k1[1], c2.k1[1]);
    let k_inf = k2 + (k2 - k1) / ((r2 / r1).powi(2) - 1.0);
    Ok((k_inf / at_20a - 1.0, c1.wall_s + c2.wall_s))
}

pub fn sif(quick: bool) -> anyhow::Result<CaseResult> {
    // Cells along the crack's half-length: horizontal n, diagonal n / sqrt(2) (rounded; the
    // diagonal crack's ends sit on nodes, so its a/h is n_d sqrt(2)).
    let levels: &[f64] = if quick {
        &[10.0, 20.0]
    } else {
        &[10.0, 20.0, 40.0]
    };
    let mut res = CaseResult::default();
    // The far boundary's effect on K_I of the horizontal crack, per level.
    let mut horizontal_domain = Vec::new();
    for case in sif_cases() {
        for (level, &n) in levels.iter().enumerate() {
            sif_level(&mut res, case, (level, n), &mut horizontal_domain)?;
        }
    }
    Ok(res)
}

/// A SIF case: (name, crack angle from the x axis in rad, load, mesh).
type SifCase = (&'static str, f64, CrackLoad, CrackMesh);

/// The SIF cases: a pressurised crack (1 MPa) at 0 and 45 degrees on the graded mesh, one
/// under remote tension (1 MPa) at 45 degrees, and both loads at 30 degrees on the conforming
/// mesh.
fn sif_cases() -> [SifCase; 5] {
    let (p, sigma) = (1e6, 1e6);
    let quarter = 0.25 * PI;
    let (snapped, conforming) = (CrackMesh::Snapped, CrackMesh::Conforming);
    [
        ("pressure_0deg", 0.0, CrackLoad::Pressure(p), snapped),
        ("pressure_45deg", quarter, CrackLoad::Pressure(p), snapped),
        (
            "tension_45deg",
            quarter,
            CrackLoad::TensionY(sigma),
            snapped,
        ),
        // 30 degrees is no direction of the graded mesh: the mesh follows the crack.
        (
            "pressure_30deg_conforming",
            PI / 6.0,
            CrackLoad::Pressure(p),
            conforming,
        ),
        (
            "tension_30deg_conforming",
            PI / 6.0,
            CrackLoad::TensionY(sigma),
            conforming,
        ),
    ]
}

/// One SIF run at a level: its case, the crack's half-length `a` and mesh size `h` (m), the
/// refinement `level` with `n` cells along the half-length, `k0 = load sqrt(pi a)`
/// (Pa sqrt(m)), the relative K_I error `e1` at the upper tip, and the run.
struct SifLevel<'a> {
    case: &'a str,
    angle: f64,
    mesh: CrackMesh,
    level: usize,
    n: f64,
    a: f64,
    h: f64,
    k0: f64,
    e1: f64,
    run: &'a SifRun,
}

/// One SIF case at `n` cells along the half-length (refinement `level`): the run, its checks
/// (snapping, both tips alike, the load's own below) and its rows; the horizontal pressure
/// case records its domain effect per level in `horizontal_domain`.
fn sif_level(
    res: &mut CaseResult,
    (case, angle, load, mesh): SifCase,
    (level, n): (usize, f64),
    horizontal_domain: &mut Vec<f64>,
) -> anyhow::Result<()> {
    let conforming = CrackMesh::Conforming;
    let (a, h) = if angle == 0.0 || mesh == conforming {
        (1.0, 1.0 / n)
    } else {
        let nd = (n / 2f64.sqrt()).round();
        (1.0, 1.0 / (nd * 2f64.sqrt()))
    };
    let ah = a / h;
    let run = crack_sif(a, h, 20.0 * a, angle, load, mesh)?;
    let k0 = match load {
        CrackLoad::Pressure(p) => p * (PI * a).sqrt(),
        CrackLoad::TensionY(s) => s * (PI * a).sqrt(),
    };
    let (k1_exact, k2_exact) = match load {
        CrackLoad::Pressure(_) => (k0, 0.0),
        // The remote sigma_yy resolved on the crack at `angle` from the x axis:
        // sigma_nn = sigma cos^2, tau = sigma sin cos.
        CrackLoad::TensionY(_) => (k0 * angle.cos().powi(2), k0 * angle.sin() * angle.cos()),
    };
    res.check_max(
        format!("{case}: snapping error, a/h = {ah:.1} (m)"),
        run.snap_error,
        1e-9,
    );
    // Both tips alike: the problem is symmetric under a half turn, the mesh nearly
    // (its diagonal pattern and, under tension, the rollers on two sides only; the
    // conforming mesh's refinement is not exactly symmetric: measured up to 8.4e-5).
    res.check_max(
        format!("{case}: K_I tips differ, a/h = {ah:.1}"),
        (run.k1[0] - run.k1[1]).abs() / k0,
        if mesh == conforming { 5e-4 } else { 1e-4 },
    );
    let e1 = (run.k1[1] - k1_exact) / k1_exact;
    let mut rows = vec![("k1".to_string(), e1, run.wall_s)];
    let lv = SifLevel {
        case,
        angle,
        mesh,
        level,
        n,
        a,
        h,
        k0,
        e1,
        run: &run,
    };
    match load {
        CrackLoad::Pressure(p) => sif_pressure_checks(res, &lv, p, horizontal_domain, &mut rows)?,
        CrackLoad::TensionY(_) => sif_tension_checks(res, &lv, (k1_exact, k2_exact), &mut rows),
    }
    for (metric, err, wall) in rows {
        res.rows.push(Row {
            case: "sif",
            level,
            h,
            unknowns: run.unknowns,
            metric: format!("{metric}_{case}"),
            error: err.abs(),
            wall_s: wall,
        });
    }
    Ok(())
}

/// The pressurised crack's checks and rows: K_I corrected by the far boundary's effect
/// (`p`, Pa, the pressure), the domain effect itself, and K_II zero by symmetry.
fn sif_pressure_checks(
    res: &mut CaseResult,
    lv: &SifLevel,
    p: f64,
    horizontal_domain: &mut Vec<f64>,
    rows: &mut Vec<(String, f64, f64)>,
) -> anyhow::Result<()> {
    let SifLevel {
        case,
        angle,
        mesh,
        level,
        n,
        a,
        h,
        k0,
        e1,
        run,
    } = *lv;
    let conforming = CrackMesh::Conforming;
    let ah = a / h;
    // On the conforming mesh, larger squares also change the mesh near the
    // crack (measured: +0.93 % at a/h = 10, -0.19 % at 20), so the far
    // boundary's effect is taken from the horizontal crack on the graded mesh
    // at the same a/h (0.34-0.37 %; 0.31-0.33 % at 45 degrees: it hardly
    // depends on the angle).
    let (d, wall) = match mesh {
        CrackMesh::Conforming => (
            *horizontal_domain.get(level).ok_or_else(|| {
                anyhow::anyhow!("sif: no horizontal domain effect at level {level}")
            })?,
            0.0,
        ),
        CrackMesh::Snapped => domain_effect(a, h, angle, p, run.k1[1])?,
    };
    if case == "pressure_0deg" {
        horizontal_domain.push(d);
    }
    let corrected = (1.0 + e1) * (1.0 + d) - 1.0;
    rows.push(("k1_corrected".into(), corrected, run.wall_s + wall));
    rows.push(("domain_effect".into(), d, wall));
    // Zero by symmetry about the crack line; the diagonal pattern is not
    // mirror-symmetric about it (measured 1.2e-4 to 1.4e-4), nor is the
    // conforming mesh (measured 2.0e-3 to 3.2e-3).
    res.check_max(
        format!("{case}: |K_II| / p sqrt(pi a), a/h = {ah:.1}"),
        run.k2[1].abs() / k0,
        if mesh == conforming { 5e-3 } else { 1e-3 },
    );
    res.check_range(
        format!("{case}: domain effect on K_I at 20a, a/h = {ah:.1}"),
        d,
        0.0,
        0.01,
    );
    if n >= 20.0 {
        res.check_max(
            format!("{case}: corrected K_I error, a/h = {ah:.1}"),
            corrected.abs(),
            0.02,
        );
    }
    Ok(())
}

/// The crack under remote tension: K_II's error against `exact` (K_I, K_II in Pa sqrt(m))
/// and the growth angle's against the maximum hoop stress criterion.
fn sif_tension_checks(
    res: &mut CaseResult,
    lv: &SifLevel,
    (k1_exact, k2_exact): (f64, f64),
    rows: &mut Vec<(String, f64, f64)>,
) {
    let (case, n, run, e1) = (lv.case, lv.n, lv.run, lv.e1);
    let ah = lv.a / lv.h;
    let e2 = (run.k2[1].abs() - k2_exact) / k2_exact;
    rows.push(("k2".into(), e2, run.wall_s));
    let exact_theta = crate::systems::toughness::max_hoop_stress(k1_exact, k2_exact).0;
    // The growth angle at the upper tip, against the maximum hoop stress's
    // (-53.13 degrees for K_I = K_II; the sign of K_II follows the slip).
    let theta = run.theta[1].abs();
    rows.push((
        "theta".into(),
        (theta - exact_theta.abs()) / exact_theta.abs(),
        run.wall_s,
    ));
    if n >= 20.0 {
        res.check_max(format!("{case}: K_I error, a/h = {ah:.1}"), e1.abs(), 0.03);
        res.check_max(format!("{case}: K_II error, a/h = {ah:.1}"), e2.abs(), 0.03);
    }
}
