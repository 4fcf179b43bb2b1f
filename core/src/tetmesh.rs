//! Tetrahedral meshes (plain data, before they become entities): structured boxes split into
//! tetrahedra, uniform or graded towards a region. All lengths in m.
//!
//! Each hexahedral cell of the tensor grid is split into six tetrahedra around its diagonal
//! from the lowest to the highest corner (the Kuhn, or Freudenthal, split): every cell uses the
//! same diagonal direction, so each shared cell face is cut along the same face diagonal from
//! both sides and the mesh is conforming. Planes of the grid (x, y or z constant) are unions of
//! mesh faces, so a planar fracture on such a plane lies on faces.
//!
//! Not yet part of the engine (issue 38, first part): see [`crate::tet4`].

use crate::error::SetupError;
use crate::mesh::graded_axis;
use crate::tet4;
use std::collections::HashMap;

/// A 3D tetrahedral mesh: node coordinates and positively oriented tetrahedra.
#[derive(Clone, Debug)]
pub struct TetMesh {
    pub nodes: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    /// Domain bounding box `[xmin, ymin, zmin, xmax, ymax, zmax]`, m.
    pub bbox: [f64; 6],
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

impl TetMesh {
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
    /// on each axis, [`graded_axis`]).
    pub fn graded_box(
        origin: [f64; 3],
        size: [f64; 3],
        h: f64,
        fine: [f64; 6],
        ratio: f64,
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
        Self::tensor(
            &line(0, "fine x")?,
            &line(1, "fine y")?,
            &line(2, "fine z")?,
        )
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
            for skip in 0..4 {
                let mut f = [0u32; 3];
                let mut m = 0;
                for (a, &n) in tet.iter().enumerate() {
                    if a != skip {
                        f[m] = n;
                        m += 1;
                    }
                }
                f.sort_unstable();
                faces.entry(f).or_default().push(t as u32);
            }
        }
        faces
    }
}
