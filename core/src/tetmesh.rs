//! Tetrahedral meshes (plain data, before they become entities): structured boxes split into
//! tetrahedra, uniform or graded towards a region. All lengths in m.
//!
//! Each hexahedral cell of the tensor grid is split into six tetrahedra around its diagonal
//! from the lowest to the highest corner (the Kuhn, or Freudenthal, split): every cell uses the
//! same diagonal direction, so each shared cell face is cut along the same face diagonal from
//! both sides and the mesh is conforming. Planes of the grid (x, y or z constant) are unions of
//! mesh faces, so a planar fracture on such a plane lies on faces.
//!
//! The engine's 3D meshes (`MeshSpec::Box`, `GradedBox`) are built here; the entities from them by
//! `Model::from_tet_mesh` (`crate::model3`).

use crate::error::SetupError;
use crate::mesh::graded_axis;
use crate::scenario::Refine;
use crate::tet4;
use std::collections::HashMap;

/// A 3D tetrahedral mesh: node coordinates and positively oriented tetrahedra.
#[derive(Clone, Debug)]
pub struct TetMesh {
    pub nodes: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    /// Domain bounding box `[xmin, ymin, zmin, xmax, ymax, zmax]`, m, in the grid's frame.
    pub bbox: [f64; 6],
    /// A turned grid's rotation ([`TetMesh::tilt`]): the columns are the grid's axes in the
    /// scene, so a node at grid coordinates g sits at R g. `None`: the grid's axes are the
    /// scene's.
    pub frame: Option<[[f64; 3]; 3]>,
}

/// The six Kuhn tetrahedra of a unit cube, as corner numbers `dx + 2 dy + 4 dz`: each is the path
/// 0 -> one axis -> two axes -> 7 for one order of the three axes.
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// A point's coordinates in a turned grid's frame ([`TetMesh::frame`]): R^T x; x itself
/// without a frame.
pub fn grid_coords(frame: Option<&[[f64; 3]; 3]>, x: [f64; 3]) -> [f64; 3] {
    match frame {
        Some(r) => std::array::from_fn(|j| (0..3).map(|i| r[i][j] * x[i]).sum()),
        None => x,
    }
}

/// A grid-frame vector in the scene (R g on a turned grid).
pub fn scene_coords(frame: Option<&[[f64; 3]; 3]>, g: [f64; 3]) -> [f64; 3] {
    match frame {
        Some(r) => std::array::from_fn(|i| (0..3).map(|j| r[i][j] * g[j]).sum()),
        None => g,
    }
}

/// The grid lines `line` (increasing, m) refined towards the line at `at` (m; one of them, to
/// 1e-9 of the span): on each side, with s the spacing of the first cell there, cells of
/// s / `factor` growing by `ratio` per cell while they are smaller than s, their run stretched
/// or shrunk to end on the old line nearest its end (a change of at most half an old cell over
/// the run), and the old lines inside it dropped. The cells next to the plane are then
/// `factor` times finer, and the old lines outside the run keep their exact values. The error
/// names the nearest lines when `at` is on none.
pub fn refine_axis(line: &[f64], at: f64, factor: f64, ratio: f64) -> Result<Vec<f64>, String> {
    let span = line[line.len() - 1] - line[0];
    let Some(i0) = line.iter().position(|&x| (x - at).abs() <= 1e-9 * span) else {
        let k = line.partition_point(|&x| x < at).clamp(1, line.len() - 1);
        return Err(format!(
            "the plane at {at} m is on no grid line of its axis (the nearest are {} and {} m): \
             put it on the fine region's lines, its edge plus a whole number of h",
            line[k - 1],
            line[k]
        ));
    };
    let at = line[i0];
    let mut out = vec![at];
    for dir in [-1.0f64, 1.0] {
        // The old lines on this side, nearest first, and their distances from the plane.
        let old: Vec<f64> = if dir < 0.0 {
            line[..i0].iter().rev().copied().collect()
        } else {
            line[i0 + 1..].to_vec()
        };
        let side: Vec<f64> = old.iter().map(|&x| (x - at).abs()).collect();
        let Some(&s) = side.first() else { continue };
        let mut offs = Vec::new();
        let (mut o, mut c) = (0.0, s / factor);
        while c < s * (1.0 - 1e-9) {
            o += c;
            offs.push(o);
            c *= ratio;
        }
        let mut keep = 0;
        if let Some(&t) = offs.last() {
            // The old line nearest the run's end (at least the first), where it now ends.
            let j = (0..side.len())
                .min_by(|&a, &b| (side[a] - t).abs().total_cmp(&(side[b] - t).abs()))
                .unwrap_or(0);
            let scale = side[j] / t;
            offs.pop();
            out.extend(offs.iter().map(|&o| at + dir * o * scale));
            keep = j;
        }
        out.extend(&old[keep..]);
    }
    out.sort_by(f64::total_cmp);
    Ok(out)
}

impl TetMesh {
    /// The longest edge of the tetrahedra at each node, m (0 for a node in none).
    pub fn local_size(&self) -> Vec<f64> {
        let mut out = vec![0.0f64; self.nodes.len()];
        for t in &self.tets {
            for a in 0..4 {
                for b in a + 1..4 {
                    let (i, j) = (t[a] as usize, t[b] as usize);
                    let l = tet4::norm(tet4::sub(self.nodes[i], self.nodes[j]));
                    out[i] = out[i].max(l);
                    out[j] = out[j].max(l);
                }
            }
        }
        out
    }

    /// The box spanned by the coordinate lines `xs`, `ys`, `zs` (each strictly increasing, at
    /// least two values), every cell split into six tetrahedra.
    pub fn tensor(xs: &[f64], ys: &[f64], zs: &[f64]) -> Result<Self, SetupError> {
        for (line, what) in [(xs, "x"), (ys, "y"), (zs, "z")] {
            if line.len() < 2
                || line.iter().any(|x| !x.is_finite())
                || line.windows(2).any(|w| w[1] <= w[0])
            {
                return Err(SetupError::Invalid {
                    field: format!("mesh.{what}"),
                    why: format!(
                        "the {what} coordinate lines must be finite, increasing and at least two"
                    ),
                });
            }
        }
        let (nx, ny, nz) = (xs.len(), ys.len(), zs.len());
        let id = |i: usize, j: usize, k: usize| (i + nx * (j + ny * k)) as u32;
        let mut nodes = Vec::with_capacity(nx * ny * nz);
        for &z in zs {
            for &y in ys {
                for &x in xs {
                    nodes.push([x, y, z]);
                }
            }
        }
        let mut tets = Vec::with_capacity(6 * (nx - 1) * (ny - 1) * (nz - 1));
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let corner = |c: usize| id(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
                    for t in KUHN {
                        let mut tet = t.map(corner);
                        let x = tet.map(|n| nodes[n as usize]);
                        if tet4::signed_volume(x[0], x[1], x[2], x[3]) < 0.0 {
                            tet.swap(2, 3);
                        }
                        tets.push(tet);
                    }
                }
            }
        }
        Ok(Self {
            nodes,
            tets,
            bbox: [xs[0], ys[0], zs[0], xs[nx - 1], ys[ny - 1], zs[nz - 1]],
            frame: None,
        })
    }

    /// Uniform box of cubes of side `h` from `origin` over `size` (each a whole number of h).
    pub fn regular_box(origin: [f64; 3], size: [f64; 3], h: f64) -> Result<Self, SetupError> {
        let line = |d: usize, what: &str| {
            graded_axis(
                origin[d],
                origin[d] + size[d],
                origin[d],
                origin[d] + size[d],
                h,
                1.0,
                what,
            )
        };
        Self::tensor(
            &line(0, "size x")?,
            &line(1, "size y")?,
            &line(2, "size z")?,
        )
    }

    /// Graded box: cells of side `h` inside `fine` = [x0, y0, z0, x1, y1, z1] (m), growing by
    /// `ratio` per cell towards the domain [origin, origin + size] (the 2D `Graded` mesh's rule
    /// on each axis, [`graded_axis`]), then refined towards the planes `refine`, in order
    /// ([`refine_axis`]).
    pub fn graded_box(
        origin: [f64; 3],
        size: [f64; 3],
        h: f64,
        fine: [f64; 6],
        ratio: f64,
        refine: &[Refine],
    ) -> Result<Self, SetupError> {
        let line = |d: usize, what: &str| {
            graded_axis(
                origin[d],
                origin[d] + size[d],
                fine[d],
                fine[d + 3],
                h,
                ratio,
                what,
            )
        };
        let mut ls = [line(0, "fine x")?, line(1, "fine y")?, line(2, "fine z")?];
        for (i, r) in refine.iter().enumerate() {
            let d = r.axis.index();
            ls[d] = refine_axis(&ls[d], r.at, r.factor, r.ratio)
                .map_err(|why| SetupError::invalid(&format!("mesh.refine[{i}].at"), why))?;
        }
        Self::tensor(&ls[0], &ls[1], &ls[2])
    }

    /// Turn the mesh about the point (0, 0, 0) by the smallest rotation that takes the z axis
    /// to `dir` (normalised; Rodrigues' formula about z x dir, a half turn about x for
    /// dir = -z). Rotations keep every tetrahedron's orientation. The box keeps its grid-frame
    /// bounds; [`TetMesh::frame`] records the rotation.
    pub fn tilt(&mut self, dir: [f64; 3]) {
        let n = dir.map(|c| c / tet4::norm(dir));
        let k = [-n[1], n[0], 0.0];
        let s2 = k[0] * k[0] + k[1] * k[1];
        let r: [[f64; 3]; 3] = if s2 < 1e-30 {
            if n[2] > 0.0 {
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            } else {
                [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
            }
        } else {
            // R = I + [k]x + [k]x^2 (1 - cos) / sin^2, with sin^2 = |k|^2 and cos = n_z.
            let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
            let f = (1.0 - n[2]) / s2;
            std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let kk: f64 = (0..3).map(|m| kx[i][m] * kx[m][j]).sum();
                    f64::from(u8::from(i == j)) + kx[i][j] + f * kk
                })
            })
        };
        for q in &mut self.nodes {
            *q = std::array::from_fn(|i| (0..3).map(|j| r[i][j] * q[j]).sum());
        }
        self.frame = Some(r);
    }

    /// A point's coordinates in the grid's frame (R^T x on a turned grid), m.
    pub fn grid_coords(&self, x: [f64; 3]) -> [f64; 3] {
        grid_coords(self.frame.as_ref(), x)
    }

    /// The corner coordinates of tetrahedron `t`.
    pub fn corners(&self, t: usize) -> [[f64; 3]; 4] {
        self.tets[t].map(|n| self.nodes[n as usize])
    }

    /// Every triangular face with the tetrahedra on its sides: key the sorted node triple,
    /// value the tetrahedra (one on the boundary, two inside).
    pub fn faces(&self) -> HashMap<[u32; 3], Vec<u32>> {
        let mut faces: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
        for (t, tet) in self.tets.iter().enumerate() {
            for f in tet4::sorted_sides(*tet) {
                faces.entry(f).or_default().push(t as u32);
            }
        }
        faces
    }
}

/// What [`TetMesh::split_along`] did: each new node with the node it was copied from, and each
/// fracture face as its two sister faces (the same positions, one per side; node order as
/// given, on the side the tetrahedron's copy took).
#[derive(Clone, Debug, Default)]
pub struct TetSplit {
    /// (mother, daughter) node pairs, daughters numbered from the old node count on.
    pub daughters: Vec<(u32, u32)>,
    /// Per fracture face: its nodes on each side.
    pub sisters: Vec<[[u32; 3]; 2]>,
}

impl TetMesh {
    /// Open the fracture made of `faces` (node triples, each a face shared by two tetrahedra):
    /// the seed's splitting condition in 3D. At every node of the fracture, the tetrahedra
    /// around it are grouped by the faces they share that are not fracture faces; a node whose
    /// tetrahedra fall into two or more groups gets one copy per further group (the group
    /// holding the lowest-numbered tetrahedron keeps the node), and those tetrahedra are
    /// relinked to it. Nodes on the fracture's front inside the rock keep one group and stay
    /// shared, so the fracture closes there; where it reaches the domain's surface it opens.
    /// Deterministic: groups and copies follow tetrahedron and node order. Errors name a face
    /// that is not an interior face of the mesh.
    pub fn split_along(&mut self, faces: &[[u32; 3]]) -> Result<TetSplit, SetupError> {
        let all = self.faces();
        let key = |f: [u32; 3]| {
            let mut k = f;
            k.sort_unstable();
            k
        };
        let mut cut = std::collections::HashSet::new();
        for &f in faces {
            match all.get(&key(f)) {
                Some(ts) if ts.len() == 2 => {
                    cut.insert(key(f));
                }
                _ => {
                    return Err(SetupError::Invalid {
                        field: "fracture".into(),
                        why: format!("face {f:?} is not an interior face of the tetrahedra"),
                    });
                }
            }
        }
        // The tetrahedra around each fracture node, in order.
        let mut nodes: Vec<u32> = faces.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        let mut around: HashMap<u32, Vec<u32>> = nodes.iter().map(|&n| (n, Vec::new())).collect();
        for (t, tet) in self.tets.iter().enumerate() {
            for n in tet {
                if let Some(v) = around.get_mut(n) {
                    v.push(t as u32);
                }
            }
        }
        let mut out = TetSplit::default();
        for &n in &nodes {
            let ts = &around[&n];
            // Union the tetrahedra around n across shared faces through n that are not cut.
            let mut group = crate::union_find::UnionFind::new(ts.len());
            for a in 0..ts.len() {
                for b in a + 1..ts.len() {
                    let (ta, tb) = (self.tets[ts[a] as usize], self.tets[ts[b] as usize]);
                    let shared: Vec<u32> = ta.iter().copied().filter(|x| tb.contains(x)).collect();
                    if shared.len() == 3 && !cut.contains(&key([shared[0], shared[1], shared[2]])) {
                        group.union(a, b);
                    }
                }
            }
            let roots: Vec<usize> = (0..ts.len()).map(|i| group.find(i)).collect();
            let mut firsts: Vec<usize> = roots.clone();
            firsts.sort_unstable();
            firsts.dedup();
            for &r in firsts.iter().skip(1) {
                let d = self.nodes.len() as u32;
                self.nodes.push(self.nodes[n as usize]);
                out.daughters.push((n, d));
                for (i, &t) in ts.iter().enumerate() {
                    if roots[i] == r {
                        for x in self.tets[t as usize].iter_mut().filter(|x| **x == n) {
                            *x = d;
                        }
                    }
                }
            }
        }
        // Each fracture face on its two sides: the nodes of each of its two tetrahedra that
        // sit where the face's nodes do (a mother or one of its daughters).
        let mut copies: HashMap<u32, Vec<u32>> = HashMap::new();
        for &(m, d) in &out.daughters {
            copies.entry(m).or_default().push(d);
        }
        let family = |m: u32, x: u32| x == m || copies.get(&m).is_some_and(|v| v.contains(&x));
        for &f in faces {
            let ts = &all[&key(f)];
            let side = |t: u32| {
                let tet = self.tets[t as usize];
                f.map(|m| {
                    *tet.iter()
                        .find(|&&x| family(m, x))
                        .expect("face node in its tet")
                })
            };
            out.sisters.push([side(ts[0]), side(ts[1])]);
        }
        Ok(out)
    }
}

impl TetMesh {
    /// For each disc, the interior faces that make it up: all three nodes on its plane
    /// (within `tol`, m) and the centroid inside its radius, in sorted-triple order. Empty
    /// where a disc does not lie on mesh faces.
    pub fn faces_on_discs(&self, discs: &[crate::scenario::Disc], tol: f64) -> Vec<Vec<[u32; 3]>> {
        use tet4::{dot, sub};
        let interior: Vec<[u32; 3]> = self
            .faces()
            .into_iter()
            .filter(|(_, ts)| ts.len() == 2)
            .map(|(f, _)| f)
            .collect();
        discs
            .iter()
            .map(|disc| {
                let n = disc.unit_normal();
                let mut out: Vec<[u32; 3]> = interior
                    .iter()
                    .copied()
                    .filter(|f| {
                        let p = f.map(|k| sub(self.nodes[k as usize], disc.center));
                        if p.iter().any(|q| dot(*q, n).abs() > tol) {
                            return false;
                        }
                        let g = [0, 1, 2].map(|d| (p[0][d] + p[1][d] + p[2][d]) / 3.0);
                        let along = dot(g, n);
                        dot(g, g) - along * along < disc.radius * disc.radius
                    })
                    .collect();
                out.sort_unstable();
                out
            })
            .collect()
    }

    /// Turn each sister pair of a split so that face p's (x1 - x0) x (x2 - x0) points out of
    /// its tetrahedron `ts[0]` (towards face q), keeping sister nodes in matching places.
    pub fn orient_sisters(&self, split: &mut TetSplit) {
        let faces = self.faces();
        for s in &mut split.sisters {
            let mut key = s[0];
            key.sort_unstable();
            let Some(ts) = faces.get(&key) else { continue };
            let tet = self.tets[ts[0] as usize];
            let Some(&opp) = tet.iter().find(|x| !s[0].contains(x)) else {
                continue;
            };
            // (x1 - x0) x (x2 - x0) points at the opposite node: p's tetrahedron's side.
            let x = s[0].map(|k| self.nodes[k as usize]);
            if tet4::signed_volume(x[0], x[1], x[2], self.nodes[opp as usize]) > 0.0 {
                s[0].swap(1, 2);
                s[1].swap(1, 2);
            }
        }
    }

    /// Bend the grid about a vertical axis so that squares become circles: in every z plane a
    /// node at (dx, dy) from `center` with square radius s = max(|dx|, |dy|) and radius
    /// rho = |(dx, dy)| moves along its ray to radius s while s <= R (the square of half-side
    /// R becomes the circle of radius R, and every smaller square a circle), and by the blend
    /// t s + (1 - t) rho, t = (2R - s) / R, for R < s < 2R; nodes at s >= 2R stay. The radius
    /// after the map grows strictly along each ray, so no cell folds. Errors name a
    /// tetrahedron the map inverted.
    pub fn round_about(&mut self, center: [f64; 2], radius: f64) -> Result<(), SetupError> {
        for q in &mut self.nodes {
            let (dx, dy) = (q[0] - center[0], q[1] - center[1]);
            let s = dx.abs().max(dy.abs());
            if s == 0.0 || s >= 2.0 * radius {
                continue;
            }
            let rho = dx.hypot(dy);
            let f = if s <= radius {
                s / rho
            } else {
                let t = (2.0 * radius - s) / radius;
                t * s / rho + (1.0 - t)
            };
            q[0] = center[0] + dx * f;
            q[1] = center[1] + dy * f;
        }
        for t in 0..self.tets.len() {
            let x = self.corners(t);
            if tet4::signed_volume(x[0], x[1], x[2], x[3]) <= 0.0 {
                return Err(SetupError::invalid(
                    "mesh.round",
                    format!("bending the grid inverted tetrahedron {t}: use a finer grid"),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::refine_axis;

    #[test]
    fn refine_axis_grades_towards_the_plane_and_keeps_the_grid_elsewhere() {
        // Lines every 0.1 m on [0, 1.5], then growing: refine at 1.0 by 8, ratio 1.5.
        let mut line: Vec<f64> = (0..=15).map(|k| k as f64 * 0.1).collect();
        line.extend([1.65, 1.85, 2.1]);
        let out = refine_axis(&line, 1.0, 8.0, 1.5).unwrap();
        // Increasing, the plane and both ends kept exactly.
        assert!(out.windows(2).all(|w| w[1] > w[0]), "{out:?}");
        assert!(out.contains(&line[10]));
        assert_eq!((out[0], *out.last().unwrap()), (0.0, 2.1));
        let i = out.iter().position(|&x| x == line[10]).unwrap();
        // Next to the plane the cells are h / 8 times the run's stretch: the six cells of
        // 0.0125 (1 + 1.5 + ... + 1.5^5) = 0.260 m end on the old line nearest, 0.3 m away.
        let scale = 0.3 / (0.0125 * (1.5f64.powi(6) - 1.0) / 0.5);
        for side in [-1i64, 1] {
            let mut prev = out[i];
            for m in 0..6 {
                let x = out[(i as i64 + side * (m + 1)) as usize];
                let want = 0.0125 * 1.5f64.powi(m as i32) * scale;
                assert!(
                    ((x - prev).abs() - want).abs() < 1e-12,
                    "cell {m}: {x} {prev}"
                );
                prev = x;
            }
            // Then the old grid, untouched.
            assert!((prev - (1.0 + side as f64 * 0.3)).abs() < 1e-12);
        }
        for &x in line.iter().filter(|&&x| (x - 1.0).abs() > 0.3 - 1e-9) {
            assert!(out.contains(&x), "old line {x} lost");
        }
        // At the end of the axis: one side only.
        let end = refine_axis(&line, 0.0, 4.0, 2.0).unwrap();
        assert_eq!(end[0], 0.0);
        assert!((end[1] - 0.025 * 0.1 / 0.075).abs() < 1e-12, "{end:?}");
        // A factor at or under the ratio changes nothing; off a line is refused, naming the
        // nearest lines.
        assert_eq!(refine_axis(&line, 0.5, 1.2, 1.5).unwrap(), line);
        let e = refine_axis(&line, 0.55, 8.0, 1.5).unwrap_err();
        assert!(e.contains("0.5 and 0.6"), "{e}");
    }
}
