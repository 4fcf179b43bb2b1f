//! Fracture systems. `fracture_criterion` (seed equation (7)): an internal edge is
//! fracture-ready when the normal stress across it, from the mean stress of its two elements,
//! reaches lambda*T0 (tension positive). It only marks edges; topology changes belong to the
//! split system. `contact` (joint penalty forces with Coulomb friction) and `fluid_pressure`
//! (the fracture fluid's pressure on the faces) add to the nodal forces; `contact_3d` is
//! `contact` on the sister triangles of a 3D fracture.

use hydrofrac_core::dim::Tet4;
use hydrofrac_core::model3::{JointFrame3, joint_frame_3d, joint_len0_3d};
pub use hydrofrac_core::params::JointParams;
use hydrofrac_core::tet4::dot;
use hydrofrac_core::view::SolidView;
use rayon::prelude::*;
use std::collections::BinaryHeap;

/// `fracture_criterion` in 3D (seed (7) on the faces of tetrahedra): the normal stress
/// n.sigma.n across every internal rock face ([`SolidView::face_normal`]), sigma the mean of
/// its two tetrahedra's stresses (Voigt `[xx, yy, zz, xy, yz, zx]`, Pa, tension positive);
/// a face is marked ready when it reaches `threshold` = lambda*T0 (Pa). Returns the number of
/// ready faces. In a uniform stress field the face stress is exact.
pub fn fracture_criterion_3d(v: &mut SolidView<Tet4>, threshold: f64) -> usize {
    let (stress, elems, normal) = (&v.stress, &v.edge_elems, &v.face_normal);
    v.edge_sigma_n
        .par_iter_mut()
        .zip(v.edge_ready.par_iter_mut())
        .enumerate()
        .with_min_len(4096)
        .for_each(|(k, (sn, ready))| {
            let [a, b] = elems[k].map(|e| stress[e as usize]);
            let s: [f64; 6] = std::array::from_fn(|i| 0.5 * (a[i] + b[i]));
            *sn = normal_stress_3d(s, normal[k]);
            *ready = *sn >= threshold;
        });
    v.edge_ready.iter().filter(|r| **r).count()
}

/// Normal stress n.sigma.n across a face with unit normal n, Pa, for sigma in Voigt order
/// `[xx, yy, zz, xy, yz, zx]`.
#[inline(always)]
pub fn normal_stress_3d(s: [f64; 6], n: [f64; 3]) -> f64 {
    s[0] * n[0] * n[0]
        + s[1] * n[1] * n[1]
        + s[2] * n[2] * n[2]
        + 2.0 * (s[3] * n[0] * n[1] + s[4] * n[1] * n[2] + s[5] * n[2] * n[0])
}

/// Normal stress n.sigma.n across a face with unit normal n, Pa, for sigma = [sxx, syy, sxy].
#[inline(always)]
pub fn normal_stress(s: [f64; 3], n: [f64; 2]) -> f64 {
    s[0] * n[0] * n[0] + s[1] * n[1] * n[1] + 2.0 * s[2] * n[0] * n[1]
}

/// The face stress of internal edge `k` that the criterion reads, [sxx, syy, sxy], Pa.
///
/// The face stress (`by_elements = false`, the default) is the area-weighted mean stress of the
/// edge's patch: the elements touching either end of the edge whose centroid lies alongside it
/// (projects onto the edge). In a uniform field it is exact, like any mean. At a crack tip it
/// also sees the tip's fan: on the seed's regular mesh the two elements beside the edge straight
/// ahead of a pressurised crack stay in compression while the element below/above the tip (where
/// the singular sigma_yy peaks, about 60 degrees off the crack line) turns tensile, so with the
/// mean of only the two elements beside the edge (`by_elements = true`) fractures branch off one
/// row beside the crack instead of running ahead (seen on Example I).
#[inline]
fn face_stress(v: &SolidView, k: usize, by_elements: bool) -> [f64; 3] {
    if by_elements {
        let [a, b] = v.edge_elems[k].map(|e| v.stress[e as usize]);
        [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]
    } else {
        let mut m = [0.0; 3];
        for &(e, w) in &v.patch[v.patch_ptr[k] as usize..v.patch_ptr[k + 1] as usize] {
            let s = v.stress[e as usize];
            m[0] += w * s[0];
            m[1] += w * s[1];
            m[2] += w * s[2];
        }
        m
    }
}

/// The normal stress n.sigma.n the strength test reads on internal edge `k`, Pa.
pub fn face_normal_stress(v: &SolidView, k: usize, by_elements: bool) -> f64 {
    normal_stress(face_stress(v, k, by_elements), v.edge_normal[k])
}

/// Work counts of the strength test.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct StrengthCounts {
    /// Face stresses evaluated, and faces passed over by the screen, summed over passes.
    pub evaluated: u64,
    pub screened: u64,
    /// Fracture-ready edges after the last pass.
    pub ready: usize,
}

/// A face's due point in one region's heap: evaluate it again once that region's
/// accumulated displacement bound reaches `at` (m); `version` tells stale entries.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
struct Due {
    at: f64,
    edge: u32,
    version: u32,
}
impl Eq for Due {}
impl Ord for Due {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        // Reversed: the standard max-heap then pops the earliest due point first.
        o.at.total_cmp(&self.at)
            .then(o.edge.cmp(&self.edge))
            .then(o.version.cmp(&self.version))
    }
}
impl PartialOrd for Due {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

/// Regions of the screen: square cells of this many median edge lengths.
const REGION_EDGES: f64 = 8.0;
/// A face whose stress reads nodes in more regions than this uses the whole mesh's bound.
const MAX_REGIONS: usize = 6;

/// The strength test's screen: which faces can have reached the strength since they were last
/// evaluated.
///
/// A CST's stress is D B u, so between two passes every stress component of element e changes
/// by at most (2 lambda + 3 G) S_e du, with S_e = sum over its nodes of |dN/dx| + |dN/dy| and
/// du the largest change of its nodes' displacements (either component); a face's normal
/// stress, a convex combination of such stresses projected on a unit normal, by the same
/// bound with S = max S_e over the elements its stress reads (per face, so small elements
/// elsewhere do not tighten it) and du over the nodes it reads. The mesh is cut into square
/// regions (`REGION_EDGES` median edges wide); each keeps the sum over passes of its nodes'
/// largest displacement change. A face reads nodes in a few regions R(F); its stress can have
/// changed by at most (2 lambda + 3 G) S times the sum over R(F) of those sums' growth since
/// its evaluation, so it cannot reach the strength (margin m) before one of its regions has
/// grown by m / ((2 lambda + 3 G) S |R(F)|). The face waits in each of its regions' heaps at
/// that point and is evaluated when the first comes due (the others' entries go stale). Far
/// from a moving fracture the regions barely move and their faces sleep. A topology change
/// (split) evaluates every face again. The marks are exactly those of the full evaluation
/// (`tests/fracture_criterion.rs`).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct StrengthScreen {
    generation: Option<u64>,
    /// Displacements at the last pass, m (the quasi-static scheme's; empty when `integrate`
    /// tracks the motion).
    u_ref: Vec<[f64; 2]>,
    /// Region of each node (the last region index is the whole mesh).
    node_region: Vec<u32>,
    /// Runs of consecutive nodes in one region: (first node, end, region).
    runs: Vec<(u32, u32, u32)>,
    /// Regions of each face, CSR.
    face_ptr: Vec<u32>,
    face_regions: Vec<u32>,
    /// Per region: the accumulated largest displacement change after the last pass and
    /// before it, m, and its heap.
    acc: Vec<f64>,
    acc_before: Vec<f64>,
    due: Vec<BinaryHeap<Due>>,
    /// Per face: the version of its current heap entries.
    version: Vec<u32>,
    /// Stress change per metre of displacement change per unit S, Pa: 2 lambda + 3 G.
    rate: f64,
    /// Per face, the largest S_e of the elements its stress reads, 1/m (a function of the
    /// view; not in checkpoints, found again when missing).
    #[serde(skip)]
    face_s: Vec<f64>,
    /// Faces to evaluate at the next pass whatever their bound (marks taken back, faces near
    /// a tip), and the scratch of the pass (due faces, per-region displacement change).
    recheck: Vec<u32>,
    todo: Vec<u32>,
    du: Vec<f64>,
}

impl StrengthScreen {
    /// Evaluate face `k` again at the next pass (a mark that was taken back).
    pub fn recheck(&mut self, k: u32) {
        self.recheck.push(k);
    }

    /// Let `integrate` track each region's displacement change from now on (`SolidView`'s
    /// motion fields; after a rebuild, and after a restore, which does not carry them).
    pub fn track_motion(&self, v: &mut SolidView) {
        if self.generation != Some(v.generation) || self.node_region.len() != v.u.len() {
            return;
        }
        v.motion_runs.clone_from(&self.runs);
        v.motion_du.clear();
        v.motion_du.resize(self.acc.len(), 0.0);
        v.motion_steps = 0;
    }

    /// Regions and their face lists for a new topology.
    fn rebuild(&mut self, v: &SolidView, by_elements: bool) {
        // The median edge (the shortest on the seed's grids): on a mesh graded to tiny edges
        // at fracture intersections the shortest made millions of regions, each looked at
        // every pass (a conforming Example II: 870,000, 10 ms a step).
        let mut lengths: Vec<f64> = v
            .edge_nodes
            .iter()
            .map(|e| {
                let (a, b) = (v.x0[e[0] as usize], v.x0[e[1] as usize]);
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .collect();
        let h_typical = if lengths.is_empty() {
            1.0
        } else {
            let mid = lengths.len() / 2;
            *lengths.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for x in &v.x0 {
            for d in 0..2 {
                lo[d] = lo[d].min(x[d]);
                hi[d] = hi[d].max(x[d]);
            }
        }
        let size = REGION_EDGES * h_typical;
        let cells = |d: usize| (((hi[d] - lo[d]) / size).floor() as usize + 1).clamp(1, 4096);
        let (nx, ny) = (cells(0), cells(1));
        let whole = (nx * ny) as u32;
        self.node_region =
            v.x0.iter()
                .map(|x| {
                    let i = (((x[0] - lo[0]) / size) as usize).min(nx - 1);
                    let j = (((x[1] - lo[1]) / size) as usize).min(ny - 1);
                    (j * nx + i) as u32
                })
                .collect();
        self.face_ptr = vec![0];
        self.face_regions.clear();
        let mut rs: Vec<u32> = Vec::new();
        for k in 0..v.edge_nodes.len() {
            rs.clear();
            for e in face_elements(v, k, by_elements) {
                for n in v.conn[e as usize] {
                    rs.push(self.node_region[n as usize]);
                }
            }
            rs.sort_unstable();
            rs.dedup();
            if rs.len() > MAX_REGIONS {
                rs.clear();
                rs.push(whole);
            }
            self.face_regions.extend_from_slice(&rs);
            self.face_ptr.push(self.face_regions.len() as u32);
        }
        let n = nx * ny + 1;
        self.runs.clear();
        for (i, &r) in self.node_region.iter().enumerate() {
            match self.runs.last_mut() {
                Some(run) if run.2 == r => run.1 = i as u32 + 1,
                _ => self.runs.push((i as u32, i as u32 + 1, r)),
            }
        }
        self.acc = vec![0.0; n];
        self.acc_before = vec![0.0; n];
        self.due = vec![BinaryHeap::new(); n];
        self.version = vec![0; v.edge_nodes.len()];
        self.recheck.clear();
    }

    /// Each face's largest S_e over the elements its stress reads, S_e = sum over the
    /// element's nodes of |dN/dx| + |dN/dy|.
    fn find_face_s(&mut self, v: &SolidView, by_elements: bool) {
        let s_e = |e: u32| v.geom[e as usize][1..].iter().map(|x| x.abs()).sum::<f64>();
        self.face_s = (0..v.edge_nodes.len())
            .map(|k| {
                face_elements(v, k, by_elements)
                    .map(s_e)
                    .fold(0.0, f64::max)
            })
            .collect();
    }

    /// Queue face `k` (margin `margin`, Pa) in each of its regions' heaps.
    fn wait(&mut self, k: u32, margin: f64, stress_lags: bool) {
        let (s, e) = (
            self.face_ptr[k as usize] as usize,
            self.face_ptr[k as usize + 1] as usize,
        );
        let share = margin / (self.rate * self.face_s[k as usize] * (e - s) as f64);
        self.version[k as usize] = self.version[k as usize].wrapping_add(1);
        let version = self.version[k as usize];
        for &r in &self.face_regions[s..e] {
            let now = if stress_lags {
                self.acc_before[r as usize]
            } else {
                self.acc[r as usize]
            };
            self.due[r as usize].push(Due {
                at: now + share,
                edge: k,
                version,
            });
        }
    }
}

/// The elements whose stresses face `k`'s stress reads: its patch and the two beside it, or
/// with `by_elements` only those two (an element may come twice).
fn face_elements(v: &SolidView, k: usize, by_elements: bool) -> impl Iterator<Item = u32> + '_ {
    let patch: &[(u32, f64)] = if by_elements {
        &[]
    } else {
        &v.patch[v.patch_ptr[k] as usize..v.patch_ptr[k + 1] as usize]
    };
    patch
        .iter()
        .map(|&(e, _)| e)
        .chain(v.edge_elems[k].iter().copied())
}

/// `fracture_criterion`'s strength test: sigma_n of internal edges, marking edges with
/// sigma_n >= `strength` (lambda*T0, Pa; seed (7)). Marks stay once set. Returns the number of
/// fracture-ready edges.
///
/// `screen = None` evaluates every face (`edge_sigma_n` then holds every face's stress);
/// with a screen only the faces that can have reached the strength are evaluated
/// ([`StrengthScreen`]; `edge_sigma_n` holds each face's value at its last evaluation).
/// `stress_lags`: the element stresses were computed from the displacements of the previous
/// pass (the explicit scheme's `internal_force` runs before `integrate`), so the bound is the
/// one accumulated up to that pass. `skip_node`: faces touching a node marked there are not
/// tested (the toughness criterion's tip neighbourhoods).
#[allow(clippy::too_many_arguments)]
pub fn fracture_criterion(
    v: &mut SolidView,
    strength: f64,
    by_elements: bool,
    screen: Option<(
        &mut StrengthScreen,
        &hydrofrac_core::element::SolidParams,
        bool,
    )>,
    skip_node: Option<&[bool]>,
    counts: &mut StrengthCounts,
    new_marks: &mut Vec<u32>,
) -> usize {
    new_marks.clear();
    let skipped = |v: &SolidView, k: usize| {
        let [a, b] = v.edge_nodes[k];
        skip_node.is_some_and(|s| s[a as usize] || s[b as usize])
    };
    let Some((sc, p, stress_lags)) = screen else {
        counts.evaluated += evaluate_all(v, strength, by_elements, &skipped, new_marks);
        counts.ready = v.edge_ready.iter().filter(|r| **r).count();
        return counts.ready;
    };
    // `integrate` tracked the motion since the last pass (the explicit scheme: every change
    // of the displacements between passes is its), or the displacements are compared with
    // those of the last pass (the quasi-static solve).
    let tracked = stress_lags
        && sc.generation == Some(v.generation)
        && v.motion_steps > 0
        && v.motion_du.len() == sc.acc.len()
        && v.motion_runs.len() == sc.runs.len();
    if sc.generation != Some(v.generation) || (!tracked && sc.u_ref.len() != v.u.len()) {
        // Every face again (new topology, or the first pass).
        sc.generation = Some(v.generation);
        sc.rebuild(v, by_elements);
        if stress_lags {
            sc.u_ref.clear();
            sc.track_motion(v);
        } else {
            sc.u_ref.clone_from(&v.u);
        }
        sc.rate = 2.0 * p.lam + 3.0 * p.g;
        sc.find_face_s(v, by_elements);
        counts.evaluated += evaluate_all(v, strength, by_elements, &skipped, new_marks);
        for k in 0..v.edge_nodes.len() {
            if v.edge_ready[k] {
                continue;
            }
            if skipped(v, k) {
                // Skipped now (near an open tip): looked at again every pass.
                sc.recheck.push(k as u32);
            } else {
                sc.wait(k as u32, strength - v.edge_sigma_n[k], stress_lags);
            }
        }
        counts.ready = v.edge_ready.iter().filter(|r| **r).count();
        return counts.ready;
    }
    if sc.face_s.len() != v.edge_nodes.len() {
        // After a restore.
        sc.find_face_s(v, by_elements);
    }
    // Each region's largest displacement change since the last pass.
    let n_regions = sc.acc.len();
    let mut du = std::mem::take(&mut sc.du);
    du.clear();
    if tracked {
        // Summed over the steps since the last pass.
        du.extend_from_slice(&v.motion_du);
        v.motion_du.fill(0.0);
        v.motion_steps = 0;
    } else {
        du.resize(n_regions, 0.0);
        for &(a, b, r) in &sc.runs {
            let (a, b) = (a as usize, b as usize);
            let (now, before) = (v.u[a..b].as_flattened(), sc.u_ref[a..b].as_flattened());
            let d = now
                .iter()
                .zip(before)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            du[r as usize] = du[r as usize].max(d);
        }
        sc.u_ref.copy_from_slice(&v.u);
    }
    du[n_regions - 1] = du.iter().fold(0.0, |m: f64, &x| m.max(x));
    for r in 0..n_regions {
        sc.acc_before[r] = sc.acc[r];
        sc.acc[r] += du[r];
    }
    sc.du = du;
    // The faces due in any of their regions (each once), and the marks taken back (the two
    // lists swap, so neither allocates once grown).
    let mut todo = std::mem::take(&mut sc.todo);
    todo.clear();
    std::mem::swap(&mut todo, &mut sc.recheck);
    for r in 0..n_regions {
        let now = if stress_lags {
            sc.acc_before[r]
        } else {
            sc.acc[r]
        };
        while let Some(d) = sc.due[r].peek().copied() {
            if d.at > now {
                break;
            }
            sc.due[r].pop();
            if d.version == sc.version[d.edge as usize] {
                // Its other entries go stale.
                sc.version[d.edge as usize] = sc.version[d.edge as usize].wrapping_add(1);
                todo.push(d.edge);
            }
        }
    }
    todo.sort_unstable();
    todo.dedup();
    let mut evaluated = 0;
    for &k in &todo {
        let ku = k as usize;
        if v.edge_ready[ku] {
            continue;
        }
        if skipped(v, ku) {
            sc.recheck.push(k);
            continue;
        }
        let sn = normal_stress(face_stress(v, ku, by_elements), v.edge_normal[ku]);
        v.edge_sigma_n[ku] = sn;
        evaluated += 1;
        if sn >= strength {
            v.edge_ready[ku] = true;
            new_marks.push(k);
            counts.ready += 1;
        } else {
            sc.wait(k, strength - sn, stress_lags);
        }
    }
    sc.todo = todo;
    counts.evaluated += evaluated;
    counts.screened += (v.edge_nodes.len() as u64).saturating_sub(evaluated);
    counts.ready
}

/// Evaluate every face not skipped, in parallel; returns (evaluated, skipped).
fn evaluate_all(
    v: &mut SolidView,
    strength: f64,
    by_elements: bool,
    skipped: &(dyn Fn(&SolidView, usize) -> bool + Sync),
    new_marks: &mut Vec<u32>,
) -> u64 {
    let mut sn = std::mem::take(&mut v.edge_sigma_n);
    let mut ready = std::mem::take(&mut v.edge_ready);
    let view = &*v;
    let marks: Vec<Option<u32>> = sn
        .par_iter_mut()
        .zip(ready.par_iter_mut())
        .enumerate()
        .with_min_len(4096)
        .map(|(k, (sn, ready))| {
            if skipped(view, k) {
                return None;
            }
            *sn = normal_stress(face_stress(view, k, by_elements), view.edge_normal[k]);
            let new = !*ready && *sn >= strength;
            *ready |= new;
            Some(if new { k as u32 } else { u32::MAX })
        })
        .collect();
    v.edge_sigma_n = sn;
    v.edge_ready = ready;
    new_marks.extend(marks.iter().flatten().filter(|&&k| k != u32::MAX));
    marks.iter().flatten().count() as u64
}

pub use hydrofrac_core::view::{JointFrame, joint_frame, joint_len0};

/// `fluid_pressure`: the fluid in each fracture cell pushes its two faces apart. Joint k carries
/// cell `joint_cell[k]` (u32::MAX: none) at pressure `pressure[cell]` (Pa, the mean over the last
/// step's flow sub-steps): face q gets p L0 n (N/m; the current normal of face p, its
/// reference length L0, `joint_len0`), face p the opposite, half to each node. Adds to
/// `force`. Serial, fixed scatter order.
pub fn fluid_pressure(v: &mut SolidView, joint_cell: &[u32], pressure: &[f64]) {
    for k in 0..v.joint_nodes.len() {
        let c = joint_cell[k];
        if c == u32::MAX {
            continue;
        }
        let p = pressure[c as usize];
        if p == 0.0 {
            continue;
        }
        let n = joint_frame(v, k).n;
        let len0 = joint_len0(v, k);
        let fq = [p * len0 * n[0], p * len0 * n[1]];
        let nodes = v.joint_nodes[k];
        for (j, sgn) in [(0, -0.5), (1, -0.5), (2, 0.5), (3, 0.5)] {
            let i = nodes[j] as usize;
            v.force[i][0] += sgn * fq[0];
            v.force[i][1] += sgn * fq[1];
        }
    }
}

/// `contact` (seed (8)-(11)): for each joint, the offsets of face q's centre from face p's in
/// p's outward normal and tangent, delta_n and delta_t (current geometry). In contact
/// (delta_n < 0): F_n = -K_n delta_n; F_t += -K_t (change of delta_t), capped at mu F_n
/// (sliding; under slip weakening mu follows the joint's accumulated frictional slip,
/// `JointParams::mu_at`, which grows by the cap's excess over K_t at each sliding step).
/// Open: both zero. Face q gets F_n n + F_t t, face p the opposite, half to each node. Adds
/// to `force` (after `internal_force` and `external_load`). Serial: joints are few against
/// elements and the scatter order is then fixed.
pub fn contact(v: &mut SolidView, p: &JointParams) {
    for k in 0..v.joint_nodes.len() {
        let nodes = v.joint_nodes[k];
        let JointFrame { n, t, dn, dt, .. } = joint_frame(v, k);
        let st = &mut v.joint_state[k];
        st.opening = dn;
        if dn < 0.0 {
            st.normal_force = -p.kn * dn;
            let mut ft = st.shear_force - p.kt * (dt - st.last_shear_offset);
            let cap = p.mu_at(st.slip) * st.normal_force;
            st.sliding = ft.abs() > cap;
            st.slid |= st.sliding;
            if st.sliding {
                if p.weakening.is_some() {
                    st.slip += (ft.abs() - cap) / p.kt;
                }
                ft = cap.copysign(ft);
            }
            st.shear_force = ft;
        } else {
            st.normal_force = 0.0;
            st.shear_force = 0.0;
            st.sliding = false;
        }
        st.last_shear_offset = dt;
        let fq = [
            st.normal_force * n[0] + st.shear_force * t[0],
            st.normal_force * n[1] + st.shear_force * t[1],
        ];
        for (j, sgn) in [(0, -0.5), (1, -0.5), (2, 0.5), (3, 0.5)] {
            let i = nodes[j] as usize;
            v.force[i][0] += sgn * fq[0];
            v.force[i][1] += sgn * fq[1];
        }
    }
}

/// `fluid_pressure` in 3D: joint k carries cell `joint_cell[k]` (u32::MAX: none) at pressure
/// `pressure[cell]` (Pa): face q gets p A0 n (N; n the current unit normal of face p, A0 its
/// reference area, `joint_area0_3d`), face p the opposite, a third to each node. Adds to
/// `force`. Serial, fixed scatter order.
pub fn fluid_pressure_3d(v: &mut SolidView<Tet4>, joint_cell: &[u32], pressure: &[f64]) {
    for k in 0..v.joint_nodes.len() {
        let c = joint_cell[k];
        if c == u32::MAX || pressure[c as usize] == 0.0 {
            continue;
        }
        let n = joint_frame_3d(v, k).n;
        let f = pressure[c as usize] * hydrofrac_core::model3::joint_area0_3d(v, k) / 3.0;
        let nodes = v.joint_nodes[k];
        for (j, &i) in nodes.iter().enumerate() {
            let sgn = if j < 3 { -f } else { f };
            for d in 0..3 {
                v.force[i as usize][d] += sgn * n[d];
            }
        }
    }
}

/// `contact` in 3D: the 2D joint model ([`contact`]) on sister triangles, taken node pair by
/// node pair. Joint k's frame is face p's current normal n and tangents t1, t2
/// (`joint_frame_3d`); each sister pair a (face p's node a, face q's node a) has the offset
/// x_q,a - x_p,a (`corner_offsets_3d`), with normal part delta_a and tangential parts
/// delta_t,a. A pair that interpenetrates (delta_a < 0) is in contact:
/// F_n,a = -K_n (l / 3) delta_a, and F_t,a (two components) += -K_t (l / 3) (change of
/// delta_t,a), scaled back onto the Coulomb disc |F_t,a| <= mu F_n,a where it lies outside
/// (sliding); l = sqrt(A0 / 2) (`joint_len0_3d`), forces in N. A pair apart carries nothing.
/// Node a of face q gets F_n,a n + F_t,a, node a of face p the opposite. The joint's normal
/// force is the pairs' sum, and it slides when one of its pairs does. Adds to `force`.
/// Serial, fixed scatter order.
///
/// Why pairs: a force from the faces' centroid offset, one per triangle, is about twice as
/// many constraints as there are node pairs. Pair by pair (node-to-node contact on the split
/// mesh), each node pair's normal force is what the rock delivers to it, and its friction mu
/// times that (`docs/three_d.md`, "Why pairs", for what was measured).
pub fn contact_3d(v: &mut SolidView<Tet4>, p: &JointParams) {
    for k in 0..v.joint_nodes.len() {
        let nodes = v.joint_nodes[k];
        let JointFrame3 { n, t, dn, .. } = joint_frame_3d(v, k);
        let lc = joint_len0_3d(v, k) / 3.0;
        let off = hydrofrac_core::model3::corner_offsets_3d(v, k);
        let st = &mut v.joint_state[k];
        st.opening = dn;
        let mu = p.mu_at(st.slip);
        let mut f = [[0.0; 3]; 3];
        let (mut f_normal, mut sliding, mut excess) = (0.0, false, 0.0);
        for a in 0..3 {
            let gn = dot(off[a], n);
            let gt = [dot(off[a], t[0]), dot(off[a], t[1])];
            if gn < 0.0 {
                let fna = -p.kn * lc * gn;
                let last = st.last_shear_offset[a];
                let mut ft = [0, 1].map(|i| st.shear_force[a][i] - p.kt * lc * (gt[i] - last[i]));
                let (cap, mag) = (mu * fna, ft[0].hypot(ft[1]));
                if mag > cap {
                    sliding = true;
                    excess += (mag - cap) / (p.kt * lc);
                    ft = ft.map(|c| c * cap / mag);
                }
                st.shear_force[a] = ft;
                f_normal += fna;
                f[a] = [0, 1, 2].map(|d| fna * n[d] + ft[0] * t[0][d] + ft[1] * t[1][d]);
            } else {
                st.shear_force[a] = [0.0; 2];
            }
            st.last_shear_offset[a] = gt;
        }
        st.normal_force = f_normal;
        st.sliding = sliding;
        st.slid |= sliding;
        if p.weakening.is_some() {
            // The pairs' mean excess over the cap (slip weakening is 2D so far).
            st.slip += excess / 3.0;
        }
        for (j, &i) in nodes.iter().enumerate() {
            let (sgn, a) = if j < 3 { (-1.0, j) } else { (1.0, j - 3) };
            for d in 0..3 {
                v.force[i as usize][d] += sgn * f[a][d];
            }
        }
    }
}

/// Joint k's stiffness for the quasi-static matrix, from the state [`contact_3d`] left: for
/// each sister pair in contact, the block (l / 3) (K_n n n^T + K_t S) between its two nodes,
/// S = I - n n^T while it sticks, s s^T while it slides (s the tangent across the slip: the
/// shear stiffness along the slip, which the Coulomb cap holds, left out, so that the tangent
/// stays symmetric), none sliding without friction (F_t = 0 gives no direction, and nothing
/// holds the pair in shear). l = sqrt(A0 / 2), N/m.
pub fn contact_tangent_3d(
    v: &SolidView<Tet4>,
    k: usize,
    p: &JointParams,
) -> crate::linear_static::JointTangent {
    let JointFrame3 { n, t, .. } = joint_frame_3d(v, k);
    let lc = joint_len0_3d(v, k) / 3.0;
    let off = hydrofrac_core::model3::corner_offsets_3d(v, k);
    let st = &v.joint_state[k];
    let mut corner = [[[0.0; 3]; 3]; 3];
    let mut code = 0u8;
    for a in 0..3 {
        let gn = dot(off[a], n);
        if gn >= 0.0 {
            continue;
        }
        // A pair slides when its shear force sits on its cap (always without friction).
        let f = st.shear_force[a];
        let m = f[0].hypot(f[1]);
        let cap = p.mu_at(st.slip) * (-p.kn * lc * gn);
        let slides = cap == 0.0 || (m > 0.0 && m >= cap * (1.0 - 1e-12));
        let shear: [[f64; 3]; 2] = if cap == 0.0 {
            [[0.0; 3]; 2]
        } else if slides {
            let e = [0, 1, 2].map(|d| (f[0] * t[0][d] + f[1] * t[1][d]) / m);
            [hydrofrac_core::tet4::cross(n, e), [0.0; 3]]
        } else {
            t
        };
        corner[a] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                lc * (p.kn * n[i] * n[j]
                    + p.kt * (shear[0][i] * shear[0][j] + shear[1][i] * shear[1][j]))
            })
        });
        code |= (if slides { 2 } else { 1 }) << (2 * a);
    }
    if code == 0 {
        return crate::linear_static::JointTangent::OPEN;
    }
    crate::linear_static::JointTangent { corner, code }
}

/// The strength test's hand-over at fracture tips (`fracture.tip_handover`).
///
/// A node splits when two of its edges are fracture-ready, or one is and two are external
/// (`hydrofrac_core::split`); a fracture's tip node has the two external sister edges behind it, so it
/// splits as soon as one of its edges ahead is marked. On the seed's grids the edge straight
/// ahead of a tip carries the tip's tension and is marked. On an unstructured mesh the face
/// that reaches the strength is often the far side a-b of a triangle (T, a, b) at the tip T:
/// it touches no tip, neither a nor b can split, and the fracture stops (seen on Example I on a
/// conforming mesh). The hand-over marks, for such a triangle, its edge at the tip, T-a or
/// T-b, whose direction from T is closest to the fracture's direction at T (and ahead of it):
/// T splits along it, a (or b) becomes the new tip with a-b ready and splits in the same batch,
/// so the fracture runs along the face that reached the strength. It only adds marks next to
/// faces the strength test marked, and the faces it marks touch a tip.
#[derive(Clone, Debug, Default)]
pub struct HandOver {
    generation: Option<u64>,
    /// Tip nodes (dense) and the unit direction of the fracture there (reference geometry,
    /// from the daughter pair behind to the tip).
    tips: Vec<(u32, [f64; 2])>,
    /// The internal edges of every element (view indices; `u32::MAX` for a side that is on the
    /// boundary or opened).
    elem_edges: Vec<[u32; 3]>,
}

impl HandOver {
    /// Tips and element sides of the view's topology (once per generation): O(joints + edges).
    fn refresh(&mut self, v: &SolidView) {
        if self.generation == Some(v.generation) {
            return;
        }
        self.generation = Some(v.generation);
        // A node where one joint ends is a tip; where two end, it joins two fracture pieces.
        self.tips.clear();
        let ends = v.joint_ends();
        for group in ends.chunk_by(|a, b| a.0 == b.0) {
            let [(tip, _, [behind, _])] = group[..] else {
                continue;
            };
            let (x, xb) = (v.x0[tip as usize], v.x0[behind as usize]);
            let d = [x[0] - xb[0], x[1] - xb[1]];
            let l = d[0].hypot(d[1]);
            if l > 0.0 {
                self.tips.push((tip, [d[0] / l, d[1] / l]));
            }
        }
        self.elem_edges.clear();
        if self.tips.is_empty() {
            return;
        }
        self.elem_edges.resize(v.conn.len(), [u32::MAX; 3]);
        for (k, els) in v.edge_elems.iter().enumerate() {
            for &e in els {
                if let Some(slot) = self.elem_edges[e as usize]
                    .iter_mut()
                    .find(|s| **s == u32::MAX)
                {
                    *slot = k as u32;
                }
            }
        }
    }
}

/// The hand-over takes a ready far side only when it is within 45 degrees of the fracture's
/// direction at the tip (the face opens along its own line, so a face across the fracture's
/// path would turn it by more than that in one edge).
pub const HANDOVER_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// ... and an edge at the tip only within 63 degrees of that direction: on a mesh of angles
/// from 25 degrees the edges at a node are up to 60-odd degrees apart, so this leaves a tip
/// at least one way forward while never turning it back.
pub const HANDOVER_TIP_COS: f64 = 0.45;

/// The hand-over ([`HandOver`]): at every tip T, among the triangles (T, a, b) whose far side
/// a-b is fracture-ready while neither T-a nor T-b is, the edge T-a or T-b whose direction
/// from T is closest to the fracture's direction there (and ahead of it) is marked: one edge
/// per tip and pass, so a tip whose fan of triangles reaches the strength on several far sides
/// still grows one way. Returns the number of edges marked; they are appended to `new_marks`.
///
/// `new_marks` holds the strength test's marks of this pass: with none and the topology
/// unchanged since the last call, nothing can have changed and the pass is skipped.
pub fn hand_over(v: &mut SolidView, h: &mut HandOver, new_marks: &mut Vec<u32>) -> usize {
    if new_marks.is_empty() && h.generation == Some(v.generation) {
        return 0;
    }
    h.refresh(v);
    let mut marked = 0;
    for &(t, d) in &h.tips {
        let touches_t = |k: u32| v.edge_nodes[k as usize].contains(&t);
        let x = v.x0[t as usize];
        let mut best: Option<(f64, u32)> = None;
        for (el, _) in v.elements_at(t) {
            let sides = h.elem_edges[el as usize];
            let Some(&far) = sides.iter().find(|&&k| k != u32::MAX && !touches_t(k)) else {
                continue;
            };
            if !v.edge_ready[far as usize] {
                continue;
            }
            // The far side opens along itself: only one that continues the fracture's line.
            let [f0, f1] = v.edge_nodes[far as usize].map(|n| v.x0[n as usize]);
            let (fx, fy) = (f1[0] - f0[0], f1[1] - f0[1]);
            if (fx * d[0] + fy * d[1]).abs() < HANDOVER_COS * fx.hypot(fy) {
                continue;
            }
            let at_tip = sides.iter().filter(|&&k| k != u32::MAX && touches_t(k));
            if at_tip.clone().any(|&k| v.edge_ready[k as usize]) {
                continue;
            }
            for &k in at_tip {
                let [n0, n1] = v.edge_nodes[k as usize];
                let o = v.x0[if n0 == t { n1 } else { n0 } as usize];
                let (dx, dy) = (o[0] - x[0], o[1] - x[1]);
                let cos = (dx * d[0] + dy * d[1]) / dx.hypot(dy);
                if cos >= HANDOVER_TIP_COS
                    && best.is_none_or(|(c, j)| cos > c || (cos == c && k < j))
                {
                    best = Some((cos, k));
                }
            }
        }
        if let Some((_, k)) = best {
            let [a, b] = v.edge_nodes[k as usize].map(|n| v.x0[n as usize]);
            tracing::debug!("hand-over at tip {t}: edge {a:?}-{b:?}, fracture direction {d:?}");
            v.edge_ready[k as usize] = true;
            new_marks.push(k);
            marked += 1;
        }
    }
    marked
}

/// Counters of the fracture systems.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct FractureState {
    /// Internal edges marked fracture-ready so far (`fracture_criterion`).
    pub ready_edges: usize,
    /// Nodes split and edges opened so far (`split`).
    pub splits: usize,
    pub opened_edges: usize,
    /// (ready edges, topology generation) of the last split attempt that split nothing: a
    /// ready edge with both ends interior waits for the fracture to reach it, so `split` retries
    /// only when the ready set or the topology changed.
    pub last_idle_split: Option<(usize, u64)>,
    /// The toughness criterion's tips (`systems::toughness`).
    pub tips: crate::toughness::Tips,
    /// The strength test's screen, its counts and its last pass's new marks.
    pub screen: StrengthScreen,
    pub new_marks: Vec<u32>,
    pub strength_counts: StrengthCounts,
    /// The hand-over's tips and element sides (rebuilt from the view; not in checkpoints).
    #[serde(skip)]
    pub handover: HandOver,
    /// Edges marked by the hand-over by this process (a diagnostic, not in checkpoints).
    #[serde(skip)]
    pub handed_over: usize,
}
