//! Triangle mesh generation (plain data, before it becomes ECS entities).
//!
//! `regular`: a rectangle of square cells of size h, each split into two triangles with the
//! diagonal alternating like a chequerboard (the seed's Fig. 4a, `docs/seed-method.md`; a crack along edges can
//! turn by 45 or 90 degrees). `perturbed`: the same with seeded random nodal perturbation
//! (Fig. 4b) that keeps every triangle valid. All lengths in m.

use crate::error::SetupError;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A 2D triangle mesh: node coordinates and counter-clockwise triangles.
#[derive(Clone, Debug)]
pub struct TriMesh {
    pub nodes: Vec<[f64; 2]>,
    pub triangles: Vec<[u32; 3]>,
    /// Domain bounding box `[xmin, ymin, xmax, ymax]`, m.
    pub bbox: [f64; 4],
    /// Nominal cell size h, m.
    pub h: f64,
}

/// Signed area of triangle (a, b, c), positive when counter-clockwise, m^2.
pub fn signed_area(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
}

/// Number of cells along a length, requiring that h divides it (to 1e-9 relative).
fn cells_along(length: f64, h: f64, what: &str) -> Result<usize, SetupError> {
    let n = (length / h).round();
    if n < 1.0 || ((n * h - length) / length).abs() > 1e-9 {
        return Err(SetupError::Invalid {
            field: format!("mesh.{what}"),
            why: format!("{what} = {length} m is not a whole number of cells of h = {h} m"),
        });
    }
    Ok(n as usize)
}

/// Coordinate lines of a graded axis from `lo` to `hi` (m): cells of size `h` over the fine part
/// [f0, f1] (which `h` must divide; `what` names it in the error), growing by `ratio` per cell
/// towards each end; the outermost cell on each side absorbs the remainder. Shared by the 2D
/// [`TriMesh::graded`] and the 3D box ([`crate::tetmesh::TetMesh::graded_box`]).
pub fn graded_axis(
    lo: f64,
    hi: f64,
    f0: f64,
    f1: f64,
    h: f64,
    ratio: f64,
    what: &str,
) -> Result<Vec<f64>, SetupError> {
    let n = cells_along(f1 - f0, h, what)?;
    let mut line: Vec<f64> = (0..=n).map(|k| f0 + k as f64 * h).collect();
    for (dir, end) in [(1.0, hi), (-1.0, lo)] {
        let mut step = h;
        let mut x = if dir > 0.0 { f1 } else { f0 };
        let mut out = Vec::new();
        loop {
            step *= ratio;
            let next = x + dir * step;
            if (end - next) * dir <= 0.5 * step {
                out.push(end);
                break;
            }
            out.push(next);
            x = next;
        }
        if (end - if dir > 0.0 { f1 } else { f0 }).abs() < 1e-12 * h {
            out.clear();
        }
        if dir > 0.0 {
            line.extend(out);
        } else {
            out.reverse();
            out.extend(line);
            line = out;
        }
    }
    Ok(line)
}

impl TriMesh {
    /// Regular mesh of `width` x `height` (m) with square cells of size `h`, lower-left corner at `origin`.
    pub fn regular(width: f64, height: f64, h: f64, origin: [f64; 2]) -> Result<Self, SetupError> {
        let nx = cells_along(width, h, "width")?;
        let ny = cells_along(height, h, "height")?;
        let xs: Vec<f64> = (0..=nx).map(|i| origin[0] + i as f64 * h).collect();
        let ys: Vec<f64> = (0..=ny).map(|j| origin[1] + j as f64 * h).collect();
        let mut m = Self::tensor(&xs, &ys);
        // The nominal size and the exact domain, free of the last grid line's rounding.
        m.h = h;
        m.bbox = [origin[0], origin[1], origin[0] + width, origin[1] + height];
        Ok(m)
    }

    /// Tensor-product mesh on the grid lines `xs` x `ys` (ascending, m): each rectangle split into
    /// two triangles with alternating diagonals, as the regular mesh.
    pub fn tensor(xs: &[f64], ys: &[f64]) -> Self {
        let (nx, ny) = (xs.len() - 1, ys.len() - 1);
        let mut nodes = Vec::with_capacity(xs.len() * ys.len());
        for &y in ys {
            for &x in xs {
                nodes.push([x, y]);
            }
        }
        let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
        let mut triangles = Vec::with_capacity(2 * nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if (i + j) % 2 == 0 {
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                } else {
                    triangles.push([a, b, d]);
                    triangles.push([b, c, d]);
                }
            }
        }
        let h = xs
            .windows(2)
            .chain(ys.windows(2))
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        TriMesh {
            nodes,
            triangles,
            bbox: [xs[0], ys[0], xs[nx], ys[ny]],
            h,
        }
    }

    /// Graded mesh: cells of size `h` inside the box `fine` = [x0, y0, x1, y1] (m), growing by
    /// `ratio` per cell towards the domain [origin, origin + (width, height)]. `h` must divide
    /// the fine box; the outermost cell on each side absorbs the remainder.
    pub fn graded(
        width: f64,
        height: f64,
        origin: [f64; 2],
        h: f64,
        fine: [f64; 4],
        ratio: f64,
    ) -> Result<Self, SetupError> {
        let axis = |lo, hi, f0, f1, what: &str| graded_axis(lo, hi, f0, f1, h, ratio, what);
        let xs = axis(origin[0], origin[0] + width, fine[0], fine[2], "fine width")?;
        let ys = axis(
            origin[1],
            origin[1] + height,
            fine[1],
            fine[3],
            "fine height",
        )?;
        Ok(Self::tensor(&xs, &ys))
    }

    /// Regular mesh with every node moved by a seeded random offset of up to `fraction * h` per
    /// coordinate (ChaCha8). Boundary nodes move only along their side and corners stay put, so
    /// the domain keeps its shape. A move that would leave any triangle around the node with less
    /// than a quarter of its original area is redrawn (up to 16 times, then the node stays), so
    /// every triangle stays valid.
    pub fn perturbed(
        width: f64,
        height: f64,
        h: f64,
        origin: [f64; 2],
        fraction: f64,
        seed: u64,
    ) -> Result<Self, SetupError> {
        let mut mesh = Self::regular(width, height, h, origin)?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let node_tris = mesh.node_triangles();
        let [x0, y0, x1, y1] = mesh.bbox;
        let tol = 1e-9 * h;
        let orig_area: Vec<f64> = mesh.triangles.iter().map(|t| mesh.area(t)).collect();
        for n in 0..mesh.nodes.len() {
            let p = mesh.nodes[n];
            let on_x = (p[0] - x0).abs() < tol || (p[0] - x1).abs() < tol;
            let on_y = (p[1] - y0).abs() < tol || (p[1] - y1).abs() < tol;
            for _ in 0..16 {
                let dx: f64 = rng.random_range(-1.0..=1.0) * fraction * h;
                let dy: f64 = rng.random_range(-1.0..=1.0) * fraction * h;
                let q = [
                    if on_x { p[0] } else { p[0] + dx },
                    if on_y { p[1] } else { p[1] + dy },
                ];
                mesh.nodes[n] = q;
                let ok = node_tris[n].iter().all(|&t| {
                    mesh.area(&mesh.triangles[t as usize]) > 0.25 * orig_area[t as usize]
                });
                if ok {
                    break;
                }
                mesh.nodes[n] = p;
            }
        }
        Ok(mesh)
    }

    /// A mesh from nodes and counter-clockwise triangles (e.g. imported); the bounding box is
    /// the domain and h the mean edge length.
    pub fn from_triangles(nodes: Vec<[f64; 2]>, triangles: Vec<[u32; 3]>) -> Self {
        let mut bbox = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in &nodes {
            bbox = [
                bbox[0].min(p[0]),
                bbox[1].min(p[1]),
                bbox[2].max(p[0]),
                bbox[3].max(p[1]),
            ];
        }
        let (mut sum, mut n) = (0.0, 0usize);
        for t in &triangles {
            for k in 0..3 {
                let (a, b) = (nodes[t[k] as usize], nodes[t[(k + 1) % 3] as usize]);
                sum += (b[0] - a[0]).hypot(b[1] - a[1]);
                n += 1;
            }
        }
        let h = if n > 0 { sum / n as f64 } else { 1.0 };
        TriMesh {
            nodes,
            triangles,
            bbox,
            h,
        }
    }

    /// Area of a triangle of this mesh, m^2.
    pub fn area(&self, t: &[u32; 3]) -> f64 {
        signed_area(
            self.nodes[t[0] as usize],
            self.nodes[t[1] as usize],
            self.nodes[t[2] as usize],
        )
    }

    /// For each node, the triangles that use it (ascending).
    pub fn node_triangles(&self) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.nodes.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            for &n in tri {
                out[n as usize].push(t as u32);
            }
        }
        out
    }

    /// Smallest triangle altitude, 2 A / (longest edge), m: the length scale of the explicit
    /// critical time step.
    pub fn min_altitude(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let p: Vec<[f64; 2]> = t.iter().map(|&n| self.nodes[n as usize]).collect();
                let longest = (0..3)
                    .map(|k| {
                        let (a, b) = (p[k], p[(k + 1) % 3]);
                        ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt()
                    })
                    .fold(0.0, f64::max);
                2.0 * self.area(t) / longest
            })
            .fold(f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_counts_and_orientation() {
        let m = TriMesh::regular(100.0, 100.0, 1.0, [0.0, 0.0]).unwrap();
        assert_eq!(m.triangles.len(), 20_000);
        assert_eq!(m.nodes.len(), 101 * 101);
        let total: f64 = m.triangles.iter().map(|t| m.area(t)).sum();
        assert!((total - 1e4).abs() < 1e-8, "total area {total}");
        assert!(m.triangles.iter().all(|t| m.area(t) > 0.0));
        assert!((m.min_altitude() - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn graded_mesh_is_fine_inside_and_covers_the_domain() {
        let m = TriMesh::graded(
            200.0,
            200.0,
            [-100.0, -100.0],
            0.5,
            [-6.0, -2.0, 6.0, 2.0],
            1.2,
        )
        .unwrap();
        let total: f64 = m.triangles.iter().map(|t| m.area(t)).sum();
        assert!((total - 4e4).abs() < 1e-6, "area {total}");
        assert!(m.triangles.iter().all(|t| m.area(t) > 0.0));
        assert_eq!(m.bbox, [-100.0, -100.0, 100.0, 100.0]);
        assert!((m.h - 0.5).abs() < 1e-12);
        // Far fewer cells than a uniform 0.5 m mesh (160,000 triangles).
        assert!(m.triangles.len() < 20_000, "{}", m.triangles.len());
    }

    #[test]
    fn h_must_divide_the_domain() {
        let e = TriMesh::regular(10.0, 10.0, 3.0, [0.0, 0.0]).unwrap_err();
        assert!(e.to_string().contains("mesh.width"), "{e}");
    }

    #[test]
    fn perturbed_is_valid_seeded_and_keeps_the_domain() {
        let a = TriMesh::perturbed(20.0, 10.0, 1.0, [0.0, 0.0], 0.3, 7).unwrap();
        let b = TriMesh::perturbed(20.0, 10.0, 1.0, [0.0, 0.0], 0.3, 7).unwrap();
        let c = TriMesh::perturbed(20.0, 10.0, 1.0, [0.0, 0.0], 0.3, 8).unwrap();
        assert_eq!(a.nodes, b.nodes);
        assert_ne!(a.nodes, c.nodes);
        assert!(a.triangles.iter().all(|t| a.area(t) > 0.1));
        let total: f64 = a.triangles.iter().map(|t| a.area(t)).sum();
        assert!((total - 200.0).abs() < 1e-9, "area {total}");
        let moved = a
            .nodes
            .iter()
            .zip(TriMesh::regular(20.0, 10.0, 1.0, [0.0, 0.0]).unwrap().nodes)
            .filter(|(p, q)| (p[0] - q[0]).abs() + (p[1] - q[1]).abs() > 1e-6)
            .count();
        assert!(moved > a.nodes.len() / 2, "only {moved} nodes moved");
    }
}
