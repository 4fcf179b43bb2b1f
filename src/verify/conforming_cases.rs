//! Conforming-mesh verification (`docs/verification.md` R12a, R12c; `docs/conforming.md`):
//! `sneddon_inclined` and `conforming_mesh`.
//!
//! `sneddon_inclined`: Sneddon's pressurised crack (plane strain, half-length a, pressure p;
//! w(s) = (4p/E') sqrt(a^2 - s^2) along the crack, area 2 pi p a^2 / E', w_max = 4 p a / E')
//! inclined at 30 degrees, which is not a direction of the regular or graded meshes, on a
//! conforming mesh and on the graded mesh (the crack snapped to a zigzag of its edges), side by
//! side at each a/h, with the horizontal crack on the graded mesh (exact on its edges) as the
//! reference a perfect mesh would match. Domain: a square of half-width 20a with fixed edges;
//! quasi-static solve. The fixed edges stiffen the crack by under 1 % (`sneddon` measures it),
//! so the errors here are against the infinite-medium formula.
//!
//! `conforming_mesh`: the mesher itself: the quality (smallest angle, sizes) and the cost of a
//! 100 m x 100 m mesh at h = 1 m around a seeded network of 100 fractures, every fracture on
//! mesh edges, the same mesh twice; and the patch test (a linear displacement field is
//! reproduced to round-off) on conforming meshes that follow segments at odd angles, with both
//! solid schemes.

use super::{CaseResult, Row, observed_order};
use crate::conforming::MeshQuality;
use crate::scenario::{
    Boundary, Damping, End, Material, MeshSpec, PreFracture, RockNetwork, SideBc, SolidScheme,
};
use crate::sim::{Finish, Simulation};
use crate::verify::sif_cases::CrackMesh;
use crate::verify::solid_cases::scenario;
use std::f64::consts::PI;
use std::time::Instant;

/// One pressurised crack solved to its static state.
#[derive(Clone, Debug)]
pub struct InclinedCrack {
    /// Opened area, m^2 per m.
    pub area: f64,
    /// Opening of the joint nearest the centre, m.
    pub w_centre: f64,
    /// Relative L2 error of the opening over |s| < 0.8 a (s from the centre along the crack,
    /// each joint at its mid-point's projection), against Sneddon's w(s).
    pub profile: f64,
    /// Largest distance of the crack's mesh path from the segment, m, and its zigzag, degrees.
    pub snap_error: f64,
    pub zigzag_deg: f64,
    pub triangles: usize,
    pub unknowns: usize,
    pub wall_s: f64,
}

/// The crack of half-length `a` (m) through the origin at `angle` (rad) under pressure `p`
/// (Pa) on `mesh` of size `h` (m) along the crack, in a square of half-width 20a with fixed
/// edges, E = 20 GPa, nu = 0.2, solved quasi-statically.
pub fn inclined_crack(
    a: f64,
    h: f64,
    angle: f64,
    p: f64,
    mesh: CrackMesh,
) -> anyhow::Result<InclinedCrack> {
    let r = 20.0 * a;
    let mat = Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    };
    let spec = mesh.spec(r, h, a, angle);
    let mut sc = scenario(
        "sneddon_inclined",
        spec,
        mat,
        Boundary::Sides {
            left: SideBc::Fixed,
            right: SideBc::Fixed,
            bottom: SideBc::Fixed,
            top: SideBc::Fixed,
        },
        End::Static {
            tol: 1e-8,
            min_steps: 10,
        },
        Damping::Local(0.8),
    );
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    let (c, s) = (a * angle.cos(), a * angle.sin());
    sc.fracture = Some(super::fracture_cases::crack_spec([-c, -s], [c, s], Some(p)));
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "sneddon_inclined: no static state (residual {:.3e})",
        sim.residual()
    );
    let wall_s = t0.elapsed().as_secs_f64();
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let dir = [angle.cos(), angle.sin()];
    let (mut area, mut centre, mut best) = (0.0, 0.0, f64::INFINITY);
    let (mut num, mut den) = (0.0, 0.0);
    for j in sim
        .model()
        .world
        .query::<&crate::components::Joint>()
        .iter()
    {
        let (mid, w, len) = crate::fractures::joint_opening(sim.model(), j);
        area += w * len;
        let sd = mid[0] * dir[0] + mid[1] * dir[1];
        if sd.abs() < best {
            best = sd.abs();
            centre = w;
        }
        if sd.abs() < 0.8 * a {
            let exact = 4.0 * p / e_prime * (a * a - sd * sd).sqrt();
            num += len * (w - exact).powi(2);
            den += len * exact * exact;
        }
    }
    let placed = sim.placed();
    Ok(InclinedCrack {
        area,
        w_centre: centre,
        profile: (num / den).sqrt(),
        snap_error: placed.iter().map(|p| p.snap_error).fold(0.0, f64::max),
        zigzag_deg: placed.iter().map(|p| p.zigzag_deg).fold(0.0, f64::max),
        triangles: sim.solid().n_elems(),
        unknowns: 2 * sim.solid().n_nodes(),
        wall_s,
    })
}

/// `sneddon_inclined`: the 30-degree crack on both meshes and the horizontal one on the graded
/// mesh at a/h = 10, 20, 40, 80 (quick: 10, 20). Targets: conforming area and centre opening
/// within 3 % at the finest level (the target; the horizontal crack on its exact mesh
/// is -1.5 % at a/h = 80, `sneddon`; quick: 5 % at a/h = 20, `sneddon`'s target there), within 1 % of the horizontal crack's at a/h >= 20 (the
/// conforming mesh is as good as an exact one; at a/h = 10 its finer surroundings make it
/// 2 % better), observed order of the conforming area error within 0.3 of the horizontal
/// crack's (measured 0.60 and 0.67; full run only). The snapped crack's errors
/// are reported beside them, and checked to stay worse than the conforming ones at a/h >= 20,
/// which is why the conforming mesh exists.
pub fn sneddon_inclined(quick: bool) -> anyhow::Result<CaseResult> {
    let ratios: &[f64] = if quick {
        &[10.0, 20.0]
    } else {
        &[10.0, 20.0, 40.0, 80.0]
    };
    let (a, p, angle) = (1.0, 1e6, 30f64.to_radians());
    let e_prime = 20e9 / (1.0 - 0.04);
    let area_exact = 2.0 * PI * p * a * a / e_prime;
    let w_exact = 4.0 * p * a / e_prime;
    let mut res = CaseResult::default();
    let n = ratios.len();
    for (level, &ah) in ratios.iter().enumerate() {
        let h = a / ah;
        let conf = inclined_crack(a, h, angle, p, CrackMesh::Conforming)?;
        let snap = inclined_crack(a, h, angle, p, CrackMesh::Snapped)?;
        let flat = inclined_crack(a, h, 0.0, p, CrackMesh::Snapped)?;
        let rel = |x: f64, e: f64| (x - e) / e;
        let mut rows = Vec::new();
        for (tag, run) in [
            ("conforming", &conf),
            ("snapped", &snap),
            ("horizontal", &flat),
        ] {
            rows.push((format!("area_{tag}"), rel(run.area, area_exact), run));
            rows.push((
                format!("centre_opening_{tag}"),
                rel(run.w_centre, w_exact),
                run,
            ));
            rows.push((format!("opening_profile_{tag}"), run.profile, run));
        }
        for (metric, err, run) in rows {
            res.rows.push(Row {
                case: "sneddon_inclined",
                level,
                h,
                unknowns: run.unknowns,
                metric,
                error: err.abs(),
                wall_s: run.wall_s,
            });
        }
        res.notes.push(format!(
            "a/h = {ah}: conforming {} triangles, snapping error {:.1e} m, zigzag {:.1e} deg, \
             area {:+.2} %; snapped {} triangles, snapping error {:.3} m ({:.2} h), zigzag {:.0} \
             deg, area {:+.2} %, profile {:.1} %; horizontal area {:+.2} %",
            conf.triangles,
            conf.snap_error,
            conf.zigzag_deg,
            100.0 * rel(conf.area, area_exact),
            snap.triangles,
            snap.snap_error,
            snap.snap_error / h,
            snap.zigzag_deg,
            100.0 * rel(snap.area, area_exact),
            100.0 * snap.profile,
            100.0 * rel(flat.area, area_exact),
        ));
        res.check_max(
            format!("conforming snapping error at a/h = {ah}, m"),
            conf.snap_error,
            1e-9 * a,
        );
        if ah >= 20.0 {
            res.check_max(
                format!("conforming vs horizontal crack area at a/h = {ah}"),
                (conf.area / flat.area - 1.0).abs(),
                0.01,
            );
        }
        if level + 1 == n {
            // The 3 % at a/h = 80; `--quick` ends at a/h = 20, where the straight
            // crack's own target is 5 % (`sneddon`; it measures -4.20 % there).
            let tol = if quick { 0.05 } else { 0.03 };
            res.check_max(
                format!("conforming area error at a/h = {ah}"),
                rel(conf.area, area_exact).abs(),
                tol,
            );
            res.check_max(
                format!("conforming centre opening error at a/h = {ah}"),
                rel(conf.w_centre, w_exact).abs(),
                tol,
            );
        }
        if ah >= 20.0 {
            res.check_range(
                format!("snapped profile error over conforming at a/h = {ah}"),
                snap.profile / conf.profile,
                1.0,
                f64::INFINITY,
            );
        }
    }
    // The fixed edges' stiffening (about 0.4 % at 20a, `sneddon`) flattens the finest levels
    // of both cracks alike: the conforming order is checked against the horizontal crack's on
    // its exact mesh in the same run.
    let order = observed_order(&res.errors("area_conforming"));
    let flat_order = observed_order(&res.errors("area_horizontal"));
    res.notes.push(format!(
        "observed order of the area error: conforming {order:.2}, horizontal {flat_order:.2}"
    ));
    // Between a/h = 10 and 20 (`--quick`) both are pre-asymptotic (0.73 and 1.11): the order
    // is compared on the full run's last two levels only.
    if !quick {
        res.check_max(
            "conforming vs horizontal observed order of the area error",
            (order - flat_order).abs(),
            0.3,
        );
    }
    Ok(res)
}

/// The seeded network of the mesh-quality check: 100 fractures of 15-40 m at 60 and 150
/// (+-15) degrees in 100 m x 100 m (Example II's statistics).
pub fn network_100() -> RockNetwork {
    RockNetwork {
        seed: 7,
        count: 100,
        origin: [0.0, 0.0],
        size: [100.0, 100.0],
        angles_deg: vec![60.0, 150.0],
        jitter_deg: 15.0,
        length: [15.0, 40.0],
    }
}

/// `conforming_mesh`: quality and cost of the 100-fracture mesh at h = 1, 0.5, 0.25 m (quick:
/// 1, 0.5) with every fracture on mesh edges and the same mesh twice; the patch test on
/// conforming unit squares (h = 1/4 ... 1/16) following three segments at odd angles, both
/// solid schemes, to 1e-9. Targets: smallest angle >= 20 degrees (25 asked; fracture
/// crossings at small angles can pin smaller ones, so the share below 20 is reported), mesh
/// edges along fractures exactly h or shorter, meshing at h = 1 m within 1 s (reported, and
/// measured by `benches/conforming.rs`).
pub fn conforming_mesh(quick: bool) -> anyhow::Result<CaseResult> {
    let mut res = CaseResult::default();
    let hs: &[f64] = if quick {
        &[1.0, 0.5]
    } else {
        &[1.0, 0.5, 0.25]
    };
    let net = network_100();
    let segs: Vec<([f64; 2], [f64; 2])> = net.generate().iter().map(|f| (f.from, f.to)).collect();
    for (level, &h) in hs.iter().enumerate() {
        let spec = MeshSpec::Conforming {
            width: 100.0,
            height: 100.0,
            origin: [0.0, 0.0],
            h,
            h_far: Some(8.0 * h),
            min_angle_deg: 25.0,
            merge: 0.25,
            grading: 0.1,
            follow: Vec::new(),
        };
        let t0 = Instant::now();
        let (mesh, rep) = crate::setup::build_mesh_around(&spec, &segs)?;
        let wall = t0.elapsed().as_secs_f64();
        let rep = rep.expect("a conforming report");
        let (again, _) = crate::setup::build_mesh_around(&spec, &segs)?;
        let q = MeshQuality::of(&mesh);
        // Every fracture on mesh edges: the snapped path's distance from the segment is at
        // most the merge shift (0 for a fracture with no merged point).
        let adj = crate::snap::adjacency(&mesh);
        let (mut worst, mut exact, mut all) = (0.0f64, 0usize, 0usize);
        for &(a, b) in &segs {
            let (mut a, mut b) = (a, b);
            if !crate::network::clip(&mut a, &mut b, [0.0, 0.0, 100.0, 100.0]) {
                continue;
            }
            if let Some(path) = crate::snap::snap_segment(&mesh, &adj, a, b) {
                worst = worst.max(path.max_error);
                all += 1;
                exact += (path.max_error < 1e-9 * h) as usize;
            }
        }
        res.rows.push(Row {
            case: "conforming_mesh",
            level,
            h,
            unknowns: 2 * q.nodes,
            metric: "below_20_deg_share".into(),
            error: q.below_20_deg,
            wall_s: wall,
        });
        res.notes.push(format!(
            "h = {h} m: {} fractures ({} crossings, {} near misses joined, {} points merged by \
             up to {:.3} m), {} nodes, {} triangles, angles {:.1}-{:.1} deg ({:.2} % below 20), \
             edges {:.3}-{:.2} m (mean along fractures {:.3} m), meshed in {:.3} s",
            rep.fractures_meshed,
            rep.crossings,
            rep.near_misses_joined,
            rep.points_merged,
            rep.largest_merge_shift,
            q.nodes,
            q.triangles,
            q.min_angle_deg,
            q.max_angle_deg,
            100.0 * q.below_20_deg,
            q.edge_min,
            q.edge_max,
            rep.fracture_edge_mean,
            wall
        ));
        // A fracture's path strays from it only where one of its points was merged into a
        // neighbour's (groups chain, so by up to about 1.2 merge * h): most fractures are
        // exact, none strays by more than 1.5 merge * h (snapped: up to 0.7 h).
        res.notes.push(format!(
            "h = {h} m: {exact} of {all} fractures exactly on mesh edges, the others within \
             {worst:.3} m"
        ));
        res.check_max(
            format!("largest distance of a fracture's mesh path from it over merge * h, h = {h}"),
            worst / (0.25 * h),
            1.5,
        );
        res.check_range(
            format!("share of fractures exactly on mesh edges, h = {h}"),
            exact as f64 / all.max(1) as f64,
            0.8,
            1.0,
        );
        res.check_max(
            format!("mean fracture edge over h, h = {h}"),
            rep.fracture_edge_mean / h,
            1.0 + 1e-9,
        );
        res.check_max(
            format!("share of triangles with an angle below 20 degrees, h = {h}"),
            q.below_20_deg,
            0.01,
        );
        res.check_max(
            format!("constraint conflicts, h = {h}"),
            rep.conflicts as f64,
            0.0,
        );
        res.check_max(
            format!("the same mesh twice (differing nodes), h = {h}"),
            (mesh.nodes != again.nodes || mesh.triangles != again.triangles) as u8 as f64,
            0.0,
        );
    }
    // Patch test.
    let levels: &[usize] = if quick { &[4, 8] } else { &[4, 8, 16] };
    let follow = vec![
        PreFracture {
            from: [0.13, 0.21],
            to: [0.87, 0.64],
        },
        PreFracture {
            from: [0.3, 0.9],
            to: [0.55, 0.05],
        },
        PreFracture {
            from: [0.6, 0.95],
            to: [0.95, 0.7],
        },
    ];
    crate::verify::solid_cases::patch_test(
        "conforming_mesh",
        "patch_",
        levels,
        |n| {
            let h = 1.0 / n as f64;
            MeshSpec::Conforming {
                width: 1.0,
                height: 1.0,
                origin: [0.0, 0.0],
                h,
                h_far: Some(4.0 * h),
                min_angle_deg: 25.0,
                merge: 0.25,
                grading: 0.5,
                follow: follow.clone(),
            }
        },
        &mut res,
    )?;
    Ok(res)
}
