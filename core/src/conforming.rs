//! Conforming meshes (`mesh: Conforming(..)`): a triangle mesh of the rectangular domain whose
//! edges contain every pre-existing fracture, so a fracture at any orientation opens and slips
//! along straight edges instead of a zigzag of mesh edges (`docs/conforming.md`).
//!
//! The triangulation and its quality refinement are the `spade` crate's (a constrained Delaunay
//! triangulation refined by Ruppert's and Chew's method); this module prepares its input and
//! reads its output:
//! 1. each fracture is clipped to the domain; fracture ends near a domain side are moved onto
//!    it;
//! 2. the points where fractures cross, and the feet of fracture ends that stop just short of
//!    (or just past) another fracture, are added to both;
//! 3. points closer than `merge * h` are merged into one (a boundary point, else a crossing,
//!    else the lowest index is kept), so no fracture gets a segment shorter than that;
//! 4. every fracture becomes a chain of constraint edges of at most `h` between its points,
//!    the domain sides chains of at most `h_far`;
//! 5. `spade` triangulates and refines to the minimum angle `min_angle_deg` and the largest
//!    triangle area of an equilateral triangle of side `h_far`; the short constraint edges
//!    along the fractures make the mesh fine there and it grades towards `h_far` away from them.
//!
//! Everything is ordered by input index (no hashing in the output path), so the same input
//! gives the same mesh. All lengths in m, angles in degrees.

use crate::error::SetupError;
use crate::mesh::{TriMesh, signed_area};
use crate::snap::segment_foot as foot;
use crate::union_find::UnionFind;
use serde::Serialize;
use spade::Triangulation;
use spade::{AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters};

/// What a conforming mesh is asked to be (m, degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConformingParams {
    pub width: f64,
    pub height: f64,
    pub origin: [f64; 2],
    /// Edge length along the fractures, m.
    pub h: f64,
    /// Largest edge length away from the fractures, m (>= h).
    pub h_far: f64,
    /// Smallest triangle angle the refinement aims at, degrees (0 < angle <= 33).
    pub min_angle_deg: f64,
    /// Points closer than `merge * h` are merged (0 <= merge <= 0.5).
    pub merge: f64,
    /// Growth of the edge length with the distance d from the nearest fracture: edges up to
    /// h + grading * d (and h_far), 1 (m/m; e.g. 0.25).
    pub grading: f64,
    /// Most vertices the refinement may reach (the memory bound); it stops there and the mesh
    /// is reported as not fully refined.
    pub max_vertices: usize,
}

/// Mesh statistics for `summary.json` (every mesh kind): counts, angles and edge lengths.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MeshQuality {
    pub nodes: usize,
    pub triangles: usize,
    /// Smallest and largest triangle angle, degrees.
    pub min_angle_deg: f64,
    pub max_angle_deg: f64,
    /// Share of triangles with an angle below 20 degrees.
    pub below_20_deg: f64,
    /// Shortest, mean and longest edge, m.
    pub edge_min: f64,
    pub edge_mean: f64,
    pub edge_max: f64,
}

impl MeshQuality {
    /// The statistics of `mesh`.
    pub fn of(mesh: &TriMesh) -> Self {
        let (mut amin, mut amax, mut below) = (180.0f64, 0.0f64, 0usize);
        let (mut emin, mut emax, mut esum, mut en) = (f64::INFINITY, 0.0f64, 0.0, 0usize);
        for t in &mesh.triangles {
            let p = t.map(|n| mesh.nodes[n as usize]);
            let angles = triangle_angles(p);
            let lo = angles.iter().copied().fold(180.0, f64::min);
            amin = amin.min(lo);
            amax = amax.max(angles.iter().copied().fold(0.0, f64::max));
            if lo < 20.0 {
                below += 1;
            }
            for k in 0..3 {
                let l = dist(p[k], p[(k + 1) % 3]);
                emin = emin.min(l);
                emax = emax.max(l);
                esum += l;
                en += 1;
            }
        }
        let nt = mesh.triangles.len();
        MeshQuality {
            nodes: mesh.nodes.len(),
            triangles: nt,
            min_angle_deg: if nt > 0 { amin } else { 0.0 },
            max_angle_deg: amax,
            below_20_deg: below as f64 / nt.max(1) as f64,
            edge_min: if en > 0 { emin } else { 0.0 },
            // Each interior edge is counted twice, by both triangles: the mean is per
            // triangle side.
            edge_mean: esum / en.max(1) as f64,
            edge_max: emax,
        }
    }
}

/// What meshing did to the fractures, for `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ConformingReport {
    /// Fractures given, and those meshed (the others lie outside the domain or collapse to a
    /// point when their ends are merged).
    pub fractures: usize,
    pub fractures_meshed: usize,
    /// Fracture crossings, and fracture ends joined to a fracture they stopped short of.
    pub crossings: usize,
    pub near_misses_joined: usize,
    /// Points merged into another one closer than `merge * h`, and the largest distance a
    /// point moved when merged, m.
    pub points_merged: usize,
    pub largest_merge_shift: f64,
    /// Constraint edges along the fractures, and their mean length, m.
    pub fracture_edges: usize,
    pub fracture_edge_mean: f64,
    /// Constraint edges the triangulation could not insert (they crossed another one after
    /// merging); each leaves its fracture to be snapped along nearby edges.
    pub conflicts: usize,
    /// False when the refinement stopped at the vertex bound before reaching the angle.
    pub refinement_complete: bool,
    /// The grading: each triangle's size (the side of the equilateral triangle of its area,
    /// m) over the size asked at its centroid, h + grading d capped at h_far (d the distance
    /// to the nearest fracture, m); largest and mean. Grading inserts points while a
    /// triangle is above 1.2 (away from the domain's sides); the angle refinement then only
    /// shrinks triangles, so the mean is below 1 and the largest near 1.2 unless a triangle
    /// at a side (whose edges are h_far) is larger.
    pub size_ratio_max: f64,
    pub size_ratio_mean: f64,
    /// Wall time of meshing, s.
    pub seconds: f64,
}

/// The three angles of a triangle, degrees.
pub fn triangle_angles(p: [[f64; 2]; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        let u = [b[0] - a[0], b[1] - a[1]];
        let v = [c[0] - a[0], c[1] - a[1]];
        let cross = u[0] * v[1] - u[1] * v[0];
        let dot = u[0] * v[0] + u[1] * v[1];
        *o = cross.abs().atan2(dot).to_degrees();
    }
    out
}

/// The side of the equilateral triangle with the area of triangle `v`, m.
fn equal_area_side(v: [[f64; 2]; 3]) -> f64 {
    (4.0 / 3f64.sqrt() * signed_area(v[0], v[1], v[2]).abs()).sqrt()
}

fn centroid(v: [[f64; 2]; 3]) -> [f64; 2] {
    [
        (v[0][0] + v[1][0] + v[2][0]) / 3.0,
        (v[0][1] + v[1][1] + v[2][1]) / 3.0,
    ]
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// Where a point came from; the kind decides which member of a merged group is kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Boundary,
    Crossing,
    End,
    Foot,
}

/// Parameters t (along a-b) and s (along c-d) where two segments cross, inclusive of the ends;
/// `None` for parallel segments or no crossing.
fn crossing(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> Option<(f64, f64)> {
    let r = [b[0] - a[0], b[1] - a[1]];
    let s = [d[0] - c[0], d[1] - c[1]];
    let den = r[0] * s[1] - r[1] * s[0];
    let scale = (r[0].hypot(r[1])) * (s[0].hypot(s[1]));
    if den.abs() <= 1e-12 * scale {
        return None;
    }
    let q = [c[0] - a[0], c[1] - a[1]];
    let t = (q[0] * s[1] - q[1] * s[0]) / den;
    let u = (q[0] * r[1] - q[1] * r[0]) / den;
    const EPS: f64 = 1e-12;
    ((-EPS..=1.0 + EPS).contains(&t) && (-EPS..=1.0 + EPS).contains(&u))
        .then(|| (t.clamp(0.0, 1.0), u.clamp(0.0, 1.0)))
}

/// A bucket grid over segments inside a box, for the distance from a point to the nearest
/// segment (the size grading asks it of every triangle, pass by pass). Square cells of side
/// `cell` (m); each segment is listed in every cell it may touch.
struct SegmentGrid<'a> {
    segs: &'a [([f64; 2], [f64; 2])],
    origin: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    /// CSR lists: the segments of cell (i, j) are `ids[start[k]..start[k + 1]]`,
    /// k = j * dims[0] + i, in increasing segment order.
    start: Vec<usize>,
    ids: Vec<u32>,
}

impl<'a> SegmentGrid<'a> {
    /// The grid over `segs` (m) in the box `[x0, y0, x1, y1]` (m): about 16 cells per
    /// segment, no cell smaller than 1/256 of the box's larger side.
    fn new(segs: &'a [([f64; 2], [f64; 2])], bbox: [f64; 4]) -> Self {
        let (w, hgt) = (bbox[2] - bbox[0], bbox[3] - bbox[1]);
        let side = w.max(hgt);
        let cell = (0.25 * (w * hgt / segs.len().max(1) as f64).sqrt())
            .max(side / 256.0)
            .min(side)
            .max(f64::MIN_POSITIVE);
        let dims = [
            ((w / cell).ceil() as usize).max(1),
            ((hgt / cell).ceil() as usize).max(1),
        ];
        let origin = [bbox[0], bbox[1]];
        // A cell holds a segment when the segment comes within half the cell's diagonal (plus
        // a rounding margin) of the cell's centre: every cell the segment touches, and a few
        // more.
        let reach = cell * (0.5 * std::f64::consts::SQRT_2) * (1.0 + 1e-9);
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1]];
        for (s, &(a, b)) in segs.iter().enumerate() {
            let lo = Self::index_in(origin, cell, dims, [a[0].min(b[0]), a[1].min(b[1])]);
            let hi = Self::index_in(origin, cell, dims, [a[0].max(b[0]), a[1].max(b[1])]);
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    let c = [
                        origin[0] + (i as f64 + 0.5) * cell,
                        origin[1] + (j as f64 + 0.5) * cell,
                    ];
                    if foot(c, a, b).1 <= reach {
                        lists[j * dims[0] + i].push(s as u32);
                    }
                }
            }
        }
        let mut start = Vec::with_capacity(lists.len() + 1);
        let mut ids = Vec::new();
        start.push(0);
        for l in lists {
            ids.extend(l);
            start.push(ids.len());
        }
        SegmentGrid {
            segs,
            origin,
            cell,
            dims,
            start,
            ids,
        }
    }

    /// The cell holding `q`, clamped to the grid.
    fn index_in(origin: [f64; 2], cell: f64, dims: [usize; 2], q: [f64; 2]) -> [usize; 2] {
        let at = |c: usize| {
            let f = ((q[c] - origin[c]) / cell).floor();
            if f.is_nan() || f < 0.0 {
                0
            } else {
                (f as usize).min(dims[c] - 1)
            }
        };
        [at(0), at(1)]
    }

    /// The distance from `q` (inside the box) to the nearest segment, m; infinite with no
    /// segment. Exactly the smallest of `snap::segment_foot` over all segments: the rings of
    /// cells around q's cell are searched outwards until a ring cannot hold anything nearer.
    fn distance(&self, q: [f64; 2]) -> f64 {
        let [ci, cj] = Self::index_in(self.origin, self.cell, self.dims, q);
        let (ci, cj) = (ci as isize, cj as isize);
        let mut best = f64::INFINITY;
        let rings = self.dims[0].max(self.dims[1]) as isize;
        for k in 0..=rings {
            // Everything in ring k and beyond is at least (k - 1) cells from q.
            if (k - 1) as f64 * self.cell > best + 1e-9 * self.cell {
                break;
            }
            for j in cj - k..=cj + k {
                if j < 0 || j >= self.dims[1] as isize {
                    continue;
                }
                let edge_row = j == cj - k || j == cj + k;
                let step = if edge_row { 1 } else { (2 * k).max(1) };
                let mut i = ci - k;
                while i <= ci + k {
                    if i >= 0 && i < self.dims[0] as isize {
                        let c = j as usize * self.dims[0] + i as usize;
                        for &s in &self.ids[self.start[c]..self.start[c + 1]] {
                            let (a, b) = self.segs[s as usize];
                            best = best.min(foot(q, a, b).1);
                        }
                    }
                    i += step;
                }
            }
        }
        best
    }
}

/// Mesh the domain of `p` around the fracture segments `fractures` (m). Errors name the
/// `mesh` fields; an empty list gives a quality mesh of the rectangle. The steps are the
/// module documentation's.
pub fn conforming_mesh(
    p: &ConformingParams,
    fractures: &[([f64; 2], [f64; 2])],
) -> Result<(TriMesh, ConformingReport), SetupError> {
    let started = std::time::Instant::now();
    let [x0, y0] = p.origin;
    let bbox = [x0, y0, x0 + p.width, y0 + p.height];
    let tol = p.merge * p.h;
    let mut report = ConformingReport {
        fractures: fractures.len(),
        refinement_complete: true,
        ..Default::default()
    };
    let segs = clip_to_domain(p, bbox, fractures);
    let (pts, on) = fracture_points(&segs, tol, &mut report);
    let rep = merge_points(&pts, tol, &mut report);
    let (mut verts, mut edges) = fracture_chains(p.h, &pts, on, &rep, &mut report);
    side_chains(p.h_far, bbox, &mut verts, &mut edges);
    if verts.len() > p.max_vertices {
        return Err(SetupError::invalid(
            "mesh.h",
            format!(
                "the fractures alone need {} mesh nodes at h = {} m, more than the memory bound \
                 allows ({}); use a larger h or fewer fractures",
                verts.len(),
                p.h,
                p.max_vertices
            ),
        ));
    }

    // 5. Triangulate, grade and refine.
    let mut cdt = constrained_triangulation(&verts, edges, &mut report)?;
    // Size grading: triangles larger than h + grading * (distance to the nearest fracture)
    // (at most h_far) get a vertex at their centroid, pass by pass; the quality refinement
    // then restores the angles. Ruppert's refinement alone grades as fast as the angle bound
    // allows, too fast for the stress field around a crack.
    let lines: Vec<([f64; 2], [f64; 2])> = segs.iter().map(|&(a, b, _)| (a, b)).collect();
    let grid = SegmentGrid::new(&lines, bbox);
    let size_at = |q: [f64; 2]| (p.h + p.grading * grid.distance(q)).min(p.h_far);
    if !segs.is_empty() && p.grading.is_finite() {
        grade(&mut cdt, p, bbox, &size_at, &mut report)?;
    }
    refine(&mut cdt, p, &mut report);
    let (nodes, triangles) = triangles_of(&cdt)?;
    if !segs.is_empty() {
        size_ratios(&nodes, &triangles, &size_at, &mut report);
    }
    let mut mesh = TriMesh::from_triangles(nodes, triangles);
    mesh.h = p.h;
    mesh.bbox = bbox;
    report.seconds = started.elapsed().as_secs_f64();
    Ok((mesh, report))
}

/// A fracture clipped to the domain: its ends, and whether each lies on a domain side.
type Segment = ([f64; 2], [f64; 2], [bool; 2]);

/// Step 1: each fracture clipped to `bbox` (x0, y0, x1, y1; m); ends within the merge
/// distance of a side go onto it; a fracture along a side or shorter than that is dropped
/// (the side's own edges are the fracture; placement reports it).
fn clip_to_domain(
    p: &ConformingParams,
    bbox: [f64; 4],
    fractures: &[([f64; 2], [f64; 2])],
) -> Vec<Segment> {
    let [x0, y0, x1, y1] = bbox;
    let tol = p.merge * p.h;
    let onto_side = |q: [f64; 2]| -> ([f64; 2], bool) {
        let mut q = q;
        let mut on = false;
        for (c, lo, hi) in [(0, x0, x1), (1, y0, y1)] {
            if (q[c] - lo).abs() <= tol.max(1e-12 * p.width.max(p.height)) {
                q[c] = lo;
                on = true;
            } else if (q[c] - hi).abs() <= tol.max(1e-12 * p.width.max(p.height)) {
                q[c] = hi;
                on = true;
            }
        }
        (q, on)
    };
    let on_same_side = |a: [f64; 2], b: [f64; 2]| {
        (a[0] == x0 && b[0] == x0)
            || (a[0] == x1 && b[0] == x1)
            || (a[1] == y0 && b[1] == y0)
            || (a[1] == y1 && b[1] == y1)
    };
    let mut segs = Vec::new();
    for &(a, b) in fractures {
        let (mut a, mut b) = (a, b);
        if !crate::network::clip(&mut a, &mut b, bbox) {
            continue;
        }
        let ((a, ba), (b, bb)) = (onto_side(a), onto_side(b));
        if dist(a, b) <= tol.max(1e-12 * p.h) || on_same_side(a, b) {
            continue;
        }
        segs.push((a, b, [ba, bb]));
    }
    segs
}

/// Step 2: the points on each fracture, as (t along it, point index): its ends, its crossings
/// with the others and the feet of the ends of others that stop within `tol` (m) of it.
#[allow(clippy::type_complexity)]
fn fracture_points(
    segs: &[Segment],
    tol: f64,
    report: &mut ConformingReport,
) -> (Vec<([f64; 2], Kind)>, Vec<Vec<(f64, usize)>>) {
    let mut pts: Vec<([f64; 2], Kind)> = Vec::new();
    let mut on: Vec<Vec<(f64, usize)>> = vec![Vec::new(); segs.len()];
    for (i, &(a, b, bnd)) in segs.iter().enumerate() {
        for (t, q, is_b) in [(0.0, a, bnd[0]), (1.0, b, bnd[1])] {
            on[i].push((t, pts.len()));
            pts.push((q, if is_b { Kind::Boundary } else { Kind::End }));
        }
    }
    for i in 0..segs.len() {
        for j in i + 1..segs.len() {
            let ((a, b, _), (c, d, _)) = (segs[i], segs[j]);
            if let Some((t, u)) = crossing(a, b, c, d) {
                let q = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                on[i].push((t, pts.len()));
                on[j].push((u, pts.len()));
                pts.push((q, Kind::Crossing));
                report.crossings += 1;
            }
        }
    }
    // Near misses: an end within `tol` of another fracture (and not already on it).
    if tol > 0.0 {
        for i in 0..segs.len() {
            for q in [segs[i].0, segs[i].1] {
                for j in 0..segs.len() {
                    if i == j {
                        continue;
                    }
                    let (c, d, _) = segs[j];
                    let (u, gap) = foot(q, c, d);
                    let touching = on[j]
                        .iter()
                        .any(|&(_, k)| dist(pts[k].0, q) <= tol && on[i].iter().any(|x| x.1 == k));
                    if gap <= tol && !touching {
                        let f = [c[0] + u * (d[0] - c[0]), c[1] + u * (d[1] - c[1])];
                        on[j].push((u, pts.len()));
                        pts.push((f, Kind::Foot));
                        report.near_misses_joined += 1;
                    }
                }
            }
        }
    }
    (pts, on)
}

/// Step 3: points closer than `tol` (m) merged (a sweep in x; groups by union-find); the
/// representative of each point, the lowest (kind, index) of its group.
fn merge_points(pts: &[([f64; 2], Kind)], tol: f64, report: &mut ConformingReport) -> Vec<usize> {
    let mut uf = UnionFind::new(pts.len());
    if tol > 0.0 {
        let mut order: Vec<usize> = (0..pts.len()).collect();
        order.sort_by(|&i, &j| pts[i].0[0].total_cmp(&pts[j].0[0]).then(i.cmp(&j)));
        for (k, &i) in order.iter().enumerate() {
            for &j in &order[k + 1..] {
                if pts[j].0[0] - pts[i].0[0] > tol {
                    break;
                }
                if dist(pts[i].0, pts[j].0) <= tol {
                    uf.union(i, j);
                }
            }
        }
    }
    let mut keep: Vec<usize> = (0..pts.len()).collect();
    for i in 0..pts.len() {
        let r = uf.find(i);
        let k = keep[r];
        if (pts[i].1, i) < (pts[k].1, k) {
            keep[r] = i;
        }
    }
    let rep: Vec<usize> = (0..pts.len()).map(|i| keep[uf.find(i)]).collect();
    for (i, &r) in rep.iter().enumerate() {
        if r != i {
            report.points_merged += 1;
            report.largest_merge_shift = report.largest_merge_shift.max(dist(pts[i].0, pts[r].0));
        }
    }
    rep
}

/// Step 4, the fractures: vertices and constraint edges of at most `h` (m) along each
/// fracture's chain of merged points. Vertex ids: merged point representatives first come
/// first served, then the points subdividing the chains.
#[allow(clippy::type_complexity)]
fn fracture_chains(
    h: f64,
    pts: &[([f64; 2], Kind)],
    mut on: Vec<Vec<(f64, usize)>>,
    rep: &[usize],
    report: &mut ConformingReport,
) -> (Vec<[f64; 2]>, Vec<[usize; 2]>) {
    let mut verts: Vec<[f64; 2]> = Vec::new();
    let mut vid: Vec<Option<usize>> = vec![None; pts.len()];
    let mut edges: Vec<[usize; 2]> = Vec::new();
    let mut frac_len = 0.0;
    for list in &mut on {
        list.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut chain: Vec<usize> = Vec::new();
        for &(_, k) in list.iter() {
            let r = rep[k];
            let v = *vid[r].get_or_insert_with(|| {
                verts.push(pts[r].0);
                verts.len() - 1
            });
            if chain.last() != Some(&v) {
                chain.push(v);
            }
        }
        if chain.len() < 2 {
            continue;
        }
        report.fractures_meshed += 1;
        for w in chain.windows(2) {
            subdivide(&mut verts, &mut edges, w[0], w[1], h, |a, b| {
                frac_len += dist(a, b)
            });
        }
    }
    edges.sort_unstable();
    edges.dedup();
    report.fracture_edges = edges.len();
    report.fracture_edge_mean = if edges.is_empty() {
        0.0
    } else {
        frac_len / edges.len() as f64
    };
    (verts, edges)
}

/// Constraint edges of at most `h` (m) from vertex `a` to vertex `b`, the points between
/// added to `verts`; `each` sees every edge's ends.
fn subdivide(
    verts: &mut Vec<[f64; 2]>,
    edges: &mut Vec<[usize; 2]>,
    a: usize,
    b: usize,
    h: f64,
    mut each: impl FnMut([f64; 2], [f64; 2]),
) {
    let (pa, pb) = (verts[a], verts[b]);
    let n = ((dist(pa, pb) / h) - 1e-9).ceil().max(1.0) as usize;
    let mut prev = a;
    for k in 1..=n {
        let v = if k == n {
            b
        } else {
            let f = k as f64 / n as f64;
            verts.push([pa[0] + f * (pb[0] - pa[0]), pa[1] + f * (pb[1] - pa[1])]);
            verts.len() - 1
        };
        edges.push([prev.min(v), prev.max(v)]);
        each(verts[prev], verts[v]);
        prev = v;
    }
}

/// Step 4, the domain sides: chains of at most `h_far` (m) through the corners and the
/// fracture points that lie on the sides of `bbox`.
fn side_chains(h_far: f64, bbox: [f64; 4], verts: &mut Vec<[f64; 2]>, edges: &mut Vec<[usize; 2]>) {
    let [x0, y0, x1, y1] = bbox;
    let mut side_points: [Vec<usize>; 4] = Default::default();
    for (v, q) in verts.iter().enumerate() {
        for (s, on_side) in [q[1] == y0, q[0] == x1, q[1] == y1, q[0] == x0]
            .into_iter()
            .enumerate()
        {
            if on_side {
                side_points[s].push(v);
            }
        }
    }
    let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    let mut corner_v = [0usize; 4];
    for (c, q) in corners.iter().enumerate() {
        corner_v[c] = match verts.iter().position(|v| v == q) {
            Some(v) => v,
            None => {
                verts.push(*q);
                verts.len() - 1
            }
        };
    }
    for s in 0..4 {
        let a = corners[s];
        let mut list: Vec<usize> = side_points[s].clone();
        list.push(corner_v[s]);
        list.push(corner_v[(s + 1) % 4]);
        list.sort_by(|&i, &j| {
            dist(a, verts[i])
                .total_cmp(&dist(a, verts[j]))
                .then(i.cmp(&j))
        });
        list.dedup();
        for w in list.windows(2) {
            subdivide(verts, edges, w[0], w[1], h_far, |_, _| {});
        }
    }
}

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

fn triangulation_failed(e: impl std::fmt::Debug) -> SetupError {
    SetupError::invalid("mesh", format!("the triangulation failed: {e:?}"))
}

/// Step 5: the constrained Delaunay triangulation of `verts` (m) with the constraint `edges`;
/// edges that cross an inserted one are counted as conflicts. Points and then constraints one
/// by one, in input order: spade's bulk loader re-inserts the vertices it skips and their
/// constraints from a hash set, whose order (and so the mesh, where points are co-circular)
/// changes from process to process.
fn constrained_triangulation(
    verts: &[[f64; 2]],
    edges: Vec<[usize; 2]>,
    report: &mut ConformingReport,
) -> Result<Cdt, SetupError> {
    let mut cdt = Cdt::new();
    let mut handles = Vec::with_capacity(verts.len());
    for q in verts {
        handles.push(
            cdt.insert(Point2::new(q[0], q[1]))
                .map_err(triangulation_failed)?,
        );
    }
    for [a, b] in edges {
        if cdt.try_add_constraint(handles[a], handles[b]).is_empty() {
            report.conflicts += 1;
        }
    }
    Ok(cdt)
}

/// Step 5, grading: a vertex at the centroid of every triangle larger than 1.2 times the size
/// asked at its centroid (`size_at`, m) and not at a side of `bbox`, pass by pass, within the
/// vertex bound.
fn grade(
    cdt: &mut Cdt,
    p: &ConformingParams,
    bbox: [f64; 4],
    size_at: &impl Fn([f64; 2]) -> f64,
    report: &mut ConformingReport,
) -> Result<(), SetupError> {
    let [x0, y0, x1, y1] = bbox;
    // The faces found fine enough, by face index: their vertices, in spade's order. A face
    // whose vertices have not changed since is fine again (the same arithmetic on the same
    // points), so a pass looks only at the faces the last one's insertions made.
    let mut fine: Vec<[usize; 3]> = Vec::new();
    for _pass in 0..64 {
        let mut centroids: Vec<Point2<f64>> = Vec::new();
        fine.resize(cdt.num_all_faces(), [usize::MAX; 3]);
        for f in cdt.inner_faces() {
            let ids = f.vertices().map(|v| v.fix().index());
            let slot = &mut fine[f.fix().index()];
            if *slot == ids {
                continue;
            }
            let v = f.vertices().map(|v| {
                let q = v.position();
                [q.x, q.y]
            });
            // The side of the equilateral triangle of the same area: a thin triangle along a
            // long fixed edge is left to the quality refinement.
            let side = equal_area_side(v);
            let c = centroid(v);
            let size = size_at(c);
            let to_side = (c[0] - x0).min(x1 - c[0]).min(c[1] - y0).min(y1 - c[1]);
            if side > 1.2 * size && to_side > 0.5 * size {
                centroids.push(Point2::new(c[0], c[1]));
            } else {
                *slot = ids;
            }
        }
        if centroids.is_empty() {
            break;
        }
        if cdt.num_vertices() + centroids.len() > p.max_vertices {
            report.refinement_complete = false;
            break;
        }
        for c in centroids {
            cdt.insert(c).map_err(triangulation_failed)?;
        }
    }
    Ok(())
}

/// Step 5, quality: spade's refinement to the angle `min_angle_deg` and the area of an
/// equilateral triangle of side `h_far`, within the vertex bound.
fn refine(cdt: &mut Cdt, p: &ConformingParams, report: &mut ConformingReport) {
    let max_area = 3f64.sqrt() / 4.0 * p.h_far * p.h_far;
    // Faces below this are left as they are: a small angle between two fractures cannot be
    // refined away and would otherwise take the whole vertex budget.
    let min_area = 3f64.sqrt() / 4.0 * (0.05 * p.h).powi(2);
    let params = RefinementParameters::<f64>::new()
        .with_angle_limit(AngleLimit::from_deg(p.min_angle_deg))
        .with_max_allowed_area(max_area)
        .with_min_required_area(min_area)
        .with_max_additional_vertices(p.max_vertices.saturating_sub(cdt.num_vertices()));
    let result = cdt.refine(params);
    report.refinement_complete &= result.refinement_complete;
}

/// The triangulation's nodes (m) and its triangles, counter-clockwise; a triangle of zero
/// area is an error.
#[allow(clippy::type_complexity)]
fn triangles_of(cdt: &Cdt) -> Result<(Vec<[f64; 2]>, Vec<[u32; 3]>), SetupError> {
    let nodes: Vec<[f64; 2]> = cdt
        .vertices()
        .map(|v| {
            let q = v.position();
            [q.x, q.y]
        })
        .collect();
    let mut triangles = Vec::with_capacity(cdt.num_inner_faces());
    for f in cdt.inner_faces() {
        let [a, b, c] = f.vertices().map(|v| v.fix().index() as u32);
        let area = signed_area(nodes[a as usize], nodes[b as usize], nodes[c as usize]);
        if area > 0.0 {
            triangles.push([a, b, c]);
        } else if area < 0.0 {
            triangles.push([a, c, b]);
        } else {
            return Err(SetupError::invalid(
                "mesh",
                format!(
                    "the triangulation has a triangle of zero area at ({}, {}) m; try a larger \
                     mesh.merge",
                    nodes[a as usize][0], nodes[a as usize][1]
                ),
            ));
        }
    }
    Ok((nodes, triangles))
}

/// How closely the mesh follows the grading: each triangle's equal-area side over the size
/// asked at its centroid, largest and mean.
fn size_ratios(
    nodes: &[[f64; 2]],
    triangles: &[[u32; 3]],
    size_at: &impl Fn([f64; 2]) -> f64,
    report: &mut ConformingReport,
) {
    let (mut max, mut sum) = (0.0f64, 0.0);
    for t in triangles {
        let v = t.map(|n| nodes[n as usize]);
        let r = equal_area_side(v) / size_at(centroid(v));
        max = max.max(r);
        sum += r;
    }
    report.size_ratio_max = max;
    report.size_ratio_mean = sum / triangles.len().max(1) as f64;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(h: f64) -> ConformingParams {
        ConformingParams {
            width: 10.0,
            height: 8.0,
            origin: [0.0, 0.0],
            h,
            h_far: 4.0 * h,
            min_angle_deg: 25.0,
            merge: 0.25,
            grading: 0.25,
            max_vertices: 1_000_000,
        }
    }

    /// Is segment a-b a union of mesh edges? (every mesh node near the line lies on it and
    /// consecutive ones are joined by edges).
    fn covered(mesh: &TriMesh, a: [f64; 2], b: [f64; 2]) -> bool {
        let adj = crate::snap::adjacency(mesh);
        let path = crate::snap::snap_segment(mesh, &adj, a, b).unwrap();
        path.max_error < 1e-9
    }

    #[test]
    fn an_inclined_fracture_lies_on_mesh_edges() {
        let f = ([2.0, 1.5], [7.3, 6.1]);
        let (mesh, rep) = conforming_mesh(&params(0.5), &[f]).unwrap();
        assert!(covered(&mesh, f.0, f.1));
        let q = MeshQuality::of(&mesh);
        assert!(q.min_angle_deg >= 24.0, "{q:?}");
        assert!(rep.refinement_complete);
        assert!(
            (rep.fracture_edge_mean - 0.5).abs() < 0.05,
            "{}",
            rep.fracture_edge_mean
        );
        // The domain is tiled: areas sum to the rectangle.
        let area: f64 = mesh.triangles.iter().map(|t| mesh.area(t)).sum();
        assert!((area - 80.0).abs() < 1e-9, "{area}");
    }

    #[test]
    fn crossings_are_shared_nodes_and_near_misses_join() {
        let a = ([1.0, 1.0], [9.0, 7.0]);
        let b = ([1.0, 7.0], [9.0, 1.0]);
        // Stops 0.05 m short of a (tol = 0.125 m).
        let c = ([5.0, 0.2], [5.0, 3.95]);
        let (mesh, rep) = conforming_mesh(&params(0.5), &[a, b, c]).unwrap();
        assert_eq!(rep.crossings, 1, "{rep:?}");
        // Its end is near both a and b (they cross right there).
        assert_eq!(rep.near_misses_joined, 2);
        assert!(covered(&mesh, a.0, a.1) && covered(&mesh, b.0, b.1));
        // The crossing point (5, 4) is a mesh node.
        assert!(
            mesh.nodes
                .iter()
                .any(|q| (q[0] - 5.0).abs() < 1e-9 && (q[1] - 4.0).abs() < 1e-9)
        );
        // c's end moved onto a: at the foot (5, 4) merged with the crossing.
        assert!(rep.points_merged >= 1 && rep.largest_merge_shift < 0.125);
    }

    #[test]
    fn the_same_input_gives_the_same_mesh() {
        let f = [([0.5, 0.5], [9.5, 7.0]), ([3.0, 7.5], [6.0, 0.2])];
        let (m1, _) = conforming_mesh(&params(0.3), &f).unwrap();
        let (m2, _) = conforming_mesh(&params(0.3), &f).unwrap();
        assert_eq!(m1.nodes, m2.nodes);
        assert_eq!(m1.triangles, m2.triangles);
    }

    #[test]
    fn the_mesh_grades_away_from_the_fracture() {
        let f = ([4.0, 4.0], [6.0, 4.0]);
        let mut p = params(0.1);
        p.h_far = 2.0;
        let (mesh, _) = conforming_mesh(&p, &[f]).unwrap();
        let q = MeshQuality::of(&mesh);
        // Far fewer triangles than a uniform mesh of h (about 2 * 80 / 0.01 = 16000).
        assert!(q.triangles < 3000, "{q:?}");
        assert!(q.edge_max > 1.0 && q.edge_max <= 2.0 * 1.2, "{q:?}");
        assert!(q.min_angle_deg >= 24.0, "{q:?}");
    }

    /// The grid's nearest distance is the brute-force one to the bit (so the mesh is the same
    /// as with the brute-force search), at points all over the box, for seeded random
    /// segments, one segment, and segments along the box's sides and through its corners.
    #[test]
    fn the_segment_grid_finds_the_nearest_segment_exactly() {
        use rand::{RngExt, SeedableRng};
        let bbox = [-3.0, 2.0, 47.0, 32.0];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let pt = |rng: &mut rand_chacha::ChaCha8Rng| {
            [
                rng.random_range(bbox[0]..=bbox[2]),
                rng.random_range(bbox[1]..=bbox[3]),
            ]
        };
        let random: Vec<_> = (0..60).map(|_| (pt(&mut rng), pt(&mut rng))).collect();
        let edges = vec![
            ([bbox[0], bbox[1]], [bbox[2], bbox[1]]),
            ([bbox[2], bbox[3]], [bbox[0], bbox[1]]),
            ([10.0, 2.0], [10.0, 32.0]),
        ];
        for segs in [random, vec![([1.0, 5.0], [2.0, 5.5])], edges] {
            let grid = SegmentGrid::new(&segs, bbox);
            for _ in 0..20_000 {
                let q = pt(&mut rng);
                let brute = segs
                    .iter()
                    .map(|&(a, b)| foot(q, a, b).1)
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(grid.distance(q).to_bits(), brute.to_bits(), "{q:?}");
            }
        }
    }

    #[test]
    fn a_fracture_to_the_boundary_ends_on_it() {
        let f = ([-1.0, 2.0], [5.0, 5.0]);
        let (mesh, rep) = conforming_mesh(&params(0.5), &[f]).unwrap();
        assert_eq!(rep.fractures_meshed, 1);
        assert!(
            mesh.nodes
                .iter()
                .any(|q| q[0] == 0.0 && (q[1] - 2.5).abs() < 1e-9)
        );
    }
}
