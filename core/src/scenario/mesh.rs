//! The solid mesh (`mesh:`): its kinds, the counts a mesh will have before it is built, and
//! the mesh section's checks.

use super::{PreFracture, finite, positive};
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

/// The solid mesh.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum MeshSpec {
    /// Square cells of size `h` (m), each split into two triangles with alternating diagonals.
    Regular {
        width: f64,
        height: f64,
        h: f64,
        #[serde(default)]
        origin: [f64; 2],
    },
    /// The regular mesh with every node moved randomly by up to `fraction * h` (ChaCha8, `seed`).
    Perturbed {
        width: f64,
        height: f64,
        h: f64,
        #[serde(default)]
        origin: [f64; 2],
        fraction: f64,
        seed: u64,
    },
    /// Square cells of size `h` inside the box `fine` = (x0, y0, x1, y1), m, growing by `ratio`
    /// (> 1) per cell towards the domain edges: fine where the action is, coarse far away.
    Graded {
        width: f64,
        height: f64,
        #[serde(default)]
        origin: [f64; 2],
        h: f64,
        fine: [f64; 4],
        ratio: f64,
    },
    /// A 2D triangle mesh from a Gmsh `.msh` file (ASCII 2.2 or 4.1, first-order triangles),
    /// path relative to the scenario file. The domain sides are the bounding box's edges.
    Gmsh { file: String },
    /// A mesh that follows the fractures: a constrained Delaunay triangulation of the
    /// `width` x `height` rectangle (m) whose edges contain every pre-existing fracture
    /// (`fracture.preexisting`, `fracture.file`, `fracture.random`), with edges of `h` (m) along
    /// them, growing as h + `grading` d with the distance d from them to at most `h_far` (m,
    /// default 4 h), refined to a smallest
    /// angle of `min_angle_deg` (default 25). Points closer than `merge * h` (default 0.25) are
    /// merged: crossings and near misses that close leave no tiny segment. Seeded by nothing:
    /// the same input gives the same mesh (`src/conforming.rs`, `docs/conforming.md`).
    Conforming {
        width: f64,
        height: f64,
        #[serde(default)]
        origin: [f64; 2],
        h: f64,
        #[serde(default)]
        h_far: Option<f64>,
        #[serde(default = "default_min_angle")]
        min_angle_deg: f64,
        #[serde(default = "default_merge")]
        merge: f64,
        /// Edge length growth away from the fractures: up to h + grading * d at a distance d
        /// (m/m, default 0.1: Sneddon's crack within 0.3 % of the one on an exact
        /// regular mesh, `verify sneddon_inclined`), capped at h_far.
        #[serde(default = "default_grading")]
        grading: f64,
        /// Extra segments the mesh follows without opening them (m): planned paths, layer
        /// contacts, or lines to sample along.
        #[serde(default)]
        follow: Vec<PreFracture>,
    },
    /// 3D: a box of `size` = (x, y, z) (m, each a whole number of `h`) from `origin`, cubes of
    /// side `h` (m) each split into six tetrahedra (TET4) around the diagonal from the lowest
    /// to the highest corner. z is vertical. A 3D mesh makes the run 3D (`docs/three_d.md`).
    Box {
        size: [f64; 3],
        h: f64,
        #[serde(default)]
        origin: [f64; 3],
    },
    /// 3D: the box with cubes of side `h` inside `fine` = (x0, y0, z0, x1, y1, z1), m, growing
    /// by `ratio` (>= 1) per cell towards the domain's faces, each split into six tetrahedra.
    GradedBox {
        size: [f64; 3],
        h: f64,
        #[serde(default)]
        origin: [f64; 3],
        fine: [f64; 6],
        ratio: f64,
        /// For a disc fracture normal to z: the grid is bent, in every z plane, so that the
        /// square of half-side `radius` about `center` (x, y), m, becomes the circle of that
        /// radius (`TetMesh::round_about`); a disc of that radius at a grid plane z then has
        /// its front nodes on its circle instead of a staircase. Identity from twice the radius
        /// on; the box's x and y sides must lie there or pass through the centre.
        #[serde(default)]
        round: Option<Round>,
        /// For a disc fracture not normal to an axis: after `round`, the grid is turned about
        /// the point (0, 0, 0) by the smallest rotation that takes its z axis to this
        /// direction (normalised; dimensionless). A disc whose normal is this direction, on a
        /// turned grid plane, lies on mesh faces. The sides keep the grid's names (`bottom`
        /// and `top` are the grid's z = min and max) and are oblique: they take `Fixed`,
        /// `Free` and `Traction` (along their normal) and `InSitu3`, which then holds every
        /// boundary node at the in-situ displacement (all three components); `Normal` is
        /// refused.
        #[serde(default)]
        tilt: Option<[f64; 3]>,
        /// Grid planes towards which the cells shrink, in order (before `round` and `tilt`):
        /// for a disc, its plane and the lines its front lies on (`x`, `y` = the round centre
        /// plus or minus the radius), where the linear tetrahedra's error comes from. Each
        /// takes the first cells on both sides of its plane down to `factor` times smaller,
        /// growing back by `ratio` per cell (`TetMesh::refine_axis`).
        #[serde(default)]
        refine: Vec<Refine>,
    },
    /// 3D: a tetrahedral mesh from a Gmsh `.msh` file (ASCII 2.2 or 4.1, 4-node tetrahedra),
    /// path relative to the scenario file. The box's sides are the bounding box's faces: a
    /// boundary face on one of its planes takes that side's condition, the others are free.
    Gmsh3 { file: String },
}

/// A grid axis of a box.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// One of [`MeshSpec::GradedBox`]'s `refine` planes: the grid plane `axis` = `at` (m, on one
/// of the grid's lines along that axis), next to which the cells are `factor` (>= 1,
/// dimensionless) times finer than the grid's spacing there, growing by `ratio` (> 1) per cell
/// until they reach it again.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Refine {
    pub axis: Axis,
    pub at: f64,
    pub factor: f64,
    #[serde(default = "default_refine_ratio")]
    pub ratio: f64,
}

fn default_refine_ratio() -> f64 {
    1.5
}

impl Refine {
    /// Grid lines the plane adds at most: on each side its run of ceil(ln(factor) / ln(ratio))
    /// cells, whose last line is an old one.
    pub fn extra_lines(&self) -> f64 {
        2.0 * (self.factor.ln() / self.ratio.ln()).ceil()
    }
}

/// [`MeshSpec::GradedBox`]'s `round`: the centre (x, y) and radius of the circle, m.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Round {
    pub center: [f64; 2],
    pub radius: f64,
}

/// Cells along an axis of length `l` (m) of a graded mesh: `fine` m of cells of `h`, then
/// cells growing by `ratio` from h each way, at most ln(1 + l (ratio - 1) / h) / ln(ratio) of
/// them each way (l / h for ratio 1); rounded up.
fn graded_cells(fine: f64, l: f64, h: f64, ratio: f64) -> f64 {
    let grow = if ratio > 1.0 {
        (1.0 + l * (ratio - 1.0) / h).ln() / ratio.ln()
    } else {
        l / h
    };
    (fine / h + 2.0 * grow).ceil()
}

fn default_grading() -> f64 {
    0.1
}

fn default_min_angle() -> f64 {
    25.0
}
fn default_merge() -> f64 {
    0.25
}

impl MeshSpec {
    /// Nodes, triangles and edges a mesh will have: exact for regular and perturbed meshes, an
    /// upper bound for graded ones, from the file size for Gmsh files (`None` when the file
    /// cannot be read: reading it reports that). Reads the scenario's (finite, positive) sizes;
    /// non-finite ones give infinite counts.
    pub fn counts(&self) -> Option<MeshCounts> {
        match *self {
            MeshSpec::Regular {
                width, height, h, ..
            }
            | MeshSpec::Perturbed {
                width, height, h, ..
            } => Some(MeshCounts::from_grid(
                (width / h).round(),
                (height / h).round(),
            )),
            MeshSpec::Graded {
                width,
                height,
                h,
                fine,
                ratio,
                ..
            } => {
                let nx = graded_cells(fine[2] - fine[0], width, h, ratio);
                let ny = graded_cells(fine[3] - fine[1], height, h, ratio);
                Some(MeshCounts::from_grid(nx, ny))
            }
            MeshSpec::Gmsh { ref file } => {
                let len = std::fs::metadata(file).ok()?.len() as f64;
                Some(MeshCounts::from_triangles(len / GMSH_BYTES_PER_TRIANGLE))
            }
            MeshSpec::Conforming { .. } => Some(self.counts_around(&[])),
            MeshSpec::Gmsh3 { ref file } => {
                // A tetrahedron takes 20 or more bytes of text with its share of the nodes.
                let tets = std::fs::metadata(file).ok()?.len() as f64 / GMSH_BYTES_PER_TRIANGLE;
                Some(MeshCounts {
                    nodes: 0.25 * tets + 4.0,
                    triangles: tets,
                    edges: 2.0 * tets + 4.0,
                })
            }
            MeshSpec::Box { size, h, .. } | MeshSpec::GradedBox { size, h, .. } => {
                // Graded: the 2D `Graded` bound on each axis (at most the uniform box's).
                // Refined: each plane's added lines on its axis.
                let n: [f64; 3] = match *self {
                    MeshSpec::GradedBox {
                        fine,
                        ratio,
                        ref refine,
                        ..
                    } => std::array::from_fn(|d| {
                        graded_cells(fine[d + 3] - fine[d], size[d], h, ratio)
                            .min((size[d] / h).ceil())
                            + refine
                                .iter()
                                .filter(|r| r.axis.index() == d)
                                .map(Refine::extra_lines)
                                .sum::<f64>()
                    }),
                    _ => size.map(|l| (l / h).ceil()),
                };
                let cells = n[0] * n[1] * n[2];
                Some(MeshCounts {
                    nodes: (n[0] + 1.0) * (n[1] + 1.0) * (n[2] + 1.0),
                    triangles: 6.0 * cells,
                    edges: 12.0 * cells + 2.0 * (n[0] * n[1] + n[1] * n[2] + n[2] * n[0]),
                })
            }
        }
    }

    /// [`MeshSpec::counts`] of a mesh that follows the fracture segments `fractures` (m) as
    /// well as its own `follow` lines: for a conforming mesh, the triangles its sizing field
    /// asks for, h + grading d capped at h_far at a distance d from the nearest segment, each
    /// of area sqrt(3)/8 s^2 at size s (half an equilateral triangle's: the quality
    /// refinement and the short edges near crossings add triangles, so the count is meant to
    /// be on the high side), times 1.5. The area within d of the segments is bounded by
    /// sum (2 L_i d + pi d^2) and by the domain's. The refinement is capped at this many nodes.
    /// Other kinds: their counts.
    pub fn counts_around(&self, fractures: &[([f64; 2], [f64; 2])]) -> MeshCounts {
        let MeshSpec::Conforming {
            width,
            height,
            h,
            h_far,
            grading,
            ref follow,
            ..
        } = *self
        else {
            return self.counts().unwrap_or(MeshCounts::from_triangles(0.0));
        };
        let h_far = h_far.unwrap_or(4.0 * h).min(width.max(height)).max(h);
        let lengths = fractures
            .iter()
            .copied()
            .chain(follow.iter().map(|f| (f.from, f.to)))
            .map(|(a, b)| (b[0] - a[0]).hypot(b[1] - a[1]));
        let (n, total): (f64, f64) = lengths.fold((0.0, 0.0), |(n, l), x| (n + 1.0, l + x));
        let per = |s: f64| 3f64.sqrt() / 8.0 * s * s;
        let domain = width * height;
        let near = |d: f64| (2.0 * total * d + n * std::f64::consts::PI * d * d).min(domain);
        // Over the size s = h + grading d from h to h_far, in equal steps of ln s:
        // dN = (dA/dd) dd / per(s), with dA/dd from the bound above.
        let mut triangles = 0.0;
        let mut covered = 0.0;
        if n > 0.0 && grading > 0.0 && h_far > h {
            const STEPS: usize = 400;
            let ratio = (h_far / h).ln() / STEPS as f64;
            let mut d0 = 0.0;
            for k in 1..=STEPS {
                let s1 = h * (ratio * k as f64).exp();
                let d1 = (s1 - h) / grading;
                let s_mid = h + grading * 0.5 * (d0 + d1);
                let a1 = near(d1);
                triangles += (a1 - covered) / per(s_mid);
                covered = a1;
                d0 = d1;
            }
        } else if n > 0.0 {
            covered = domain;
            triangles = domain / per(h);
        }
        triangles += (domain - covered).max(0.0) / per(h_far);
        // Measured on one crack to a 30-fracture network (tests/memory_estimate.rs): the
        // meshes have 0.71 to 0.93 of the triangles above; half as many again keeps the
        // refinement clear of the cap.
        MeshCounts::from_triangles((1.5 * triangles).ceil() + 4.0)
    }

    /// The mesh kind's name as the scenario writes it (`Regular`, ..., `Conforming`).
    pub fn kind(&self) -> &'static str {
        match self {
            MeshSpec::Regular { .. } => "Regular",
            MeshSpec::Perturbed { .. } => "Perturbed",
            MeshSpec::Graded { .. } => "Graded",
            MeshSpec::Gmsh { .. } => "Gmsh",
            MeshSpec::Conforming { .. } => "Conforming",
            MeshSpec::Box { .. } => "Box",
            MeshSpec::GradedBox { .. } => "GradedBox",
            MeshSpec::Gmsh3 { .. } => "Gmsh3",
        }
    }

    /// Nominal cell size, m (`None` for an imported mesh).
    pub fn h(&self) -> Option<f64> {
        match self {
            MeshSpec::Regular { h, .. }
            | MeshSpec::Perturbed { h, .. }
            | MeshSpec::Graded { h, .. }
            | MeshSpec::Conforming { h, .. }
            | MeshSpec::Box { h, .. }
            | MeshSpec::GradedBox { h, .. } => Some(*h),
            MeshSpec::Gmsh { .. } | MeshSpec::Gmsh3 { .. } => None,
        }
    }
    /// A 2D domain's size, m (`None` for an imported or a 3D mesh).
    pub fn size(&self) -> Option<(f64, f64)> {
        match self {
            MeshSpec::Regular { width, height, .. }
            | MeshSpec::Perturbed { width, height, .. }
            | MeshSpec::Graded { width, height, .. }
            | MeshSpec::Conforming { width, height, .. } => Some((*width, *height)),
            MeshSpec::Gmsh { .. }
            | MeshSpec::Gmsh3 { .. }
            | MeshSpec::Box { .. }
            | MeshSpec::GradedBox { .. } => None,
        }
    }

    /// Whether the mesh is 3D (tetrahedra): the run's dimension follows from it.
    pub fn is_3d(&self) -> bool {
        matches!(
            self,
            MeshSpec::Box { .. } | MeshSpec::GradedBox { .. } | MeshSpec::Gmsh3 { .. }
        )
    }

    /// A 3D box's sizes, cell size, origin and grading: positive and finite, a whole number of
    /// cells of `h` per side of a uniform box, the fine box inside the domain, the count within
    /// the engine's limit; errors name `mesh.<field>`.
    fn validate_3d(&self) -> Result<(), SetupError> {
        let (MeshSpec::Box { size, h, origin }
        | MeshSpec::GradedBox {
            size, h, origin, ..
        }) = *self
        else {
            return Ok(());
        };
        for (d, l) in size.iter().enumerate() {
            positive(&format!("mesh.size[{d}]"), *l, "the box's side")?;
            finite(&format!("mesh.origin[{d}]"), origin[d])?;
            finite(&format!("mesh.origin[{d}]"), origin[d] + l)?;
        }
        positive("mesh.h", h, "the cell size")?;
        let smallest = size.iter().fold(f64::INFINITY, |m, &l| m.min(l));
        if h >= smallest {
            return Err(SetupError::invalid(
                "mesh.h",
                format!("the cell size {h} m must be smaller than the box ({size:?} m)"),
            ));
        }
        if let MeshSpec::GradedBox { fine, ratio, .. } = *self {
            finite("mesh.ratio", ratio)?;
            if !(1.0..=10.0).contains(&ratio) {
                return Err(SetupError::invalid(
                    "mesh.ratio",
                    format!("the growth ratio must be in [1, 10] (1: uniform), got {ratio}"),
                ));
            }
            for d in 0..3 {
                let (lo, hi) = (origin[d], origin[d] + size[d]);
                let tol = 1e-9 * size[d];
                finite("mesh.fine", fine[d])?;
                finite("mesh.fine", fine[d + 3])?;
                if !(fine[d] < fine[d + 3] && fine[d] >= lo - tol && fine[d + 3] <= hi + tol) {
                    return Err(SetupError::invalid(
                        "mesh.fine",
                        format!(
                            "the fine box (x0, y0, z0, x1, y1, z1) = {fine:?} m must lie inside \
                             the domain with x0 < x1, y0 < y1 and z0 < z1"
                        ),
                    ));
                }
            }
        }
        if let MeshSpec::GradedBox { tilt: Some(t), .. } = *self {
            for c in t {
                finite("mesh.tilt", c)?;
            }
            if t.iter().map(|c| c * c).sum::<f64>() == 0.0 {
                return Err(SetupError::invalid(
                    "mesh.tilt",
                    "the direction the grid's z axis turns to must not be (0, 0, 0)",
                ));
            }
        }
        if let MeshSpec::GradedBox { ref refine, .. } = *self {
            for (i, r) in refine.iter().enumerate() {
                let d = r.axis.index();
                let field = |f: &str| format!("mesh.refine[{i}].{f}");
                finite(&field("at"), r.at)?;
                let tol = 1e-9 * size[d];
                if r.at < origin[d] - tol || r.at > origin[d] + size[d] + tol {
                    return Err(SetupError::invalid(
                        &field("at"),
                        format!(
                            "the plane {:?} = {} m is outside the box ({} to {} m)",
                            r.axis,
                            r.at,
                            origin[d],
                            origin[d] + size[d]
                        ),
                    ));
                }
                finite(&field("factor"), r.factor)?;
                if !(1.0..=1000.0).contains(&r.factor) {
                    return Err(SetupError::invalid(
                        &field("factor"),
                        format!(
                            "how many times finer the cells next to the plane are must be in \
                             [1, 1000], got {}",
                            r.factor
                        ),
                    ));
                }
                finite(&field("ratio"), r.ratio)?;
                if !(r.ratio > 1.0 && r.ratio <= 10.0) {
                    return Err(SetupError::invalid(
                        &field("ratio"),
                        format!(
                            "the growth ratio away from the plane must be in (1, 10], got {}",
                            r.ratio
                        ),
                    ));
                }
            }
        }
        if let MeshSpec::GradedBox { round: Some(r), .. } = *self {
            finite("mesh.round.center", r.center[0])?;
            finite("mesh.round.center", r.center[1])?;
            positive("mesh.round.radius", r.radius, "the rounded region's radius")?;
            for d in 0..2 {
                for side in [origin[d], origin[d] + size[d]] {
                    let off = (side - r.center[d]).abs();
                    if off > 1e-9 * size[d] && off < 2.0 * r.radius {
                        return Err(SetupError::invalid(
                            "mesh.round",
                            format!(
                                "the box's side at {} = {side} m is {off} m from the centre: it \
                                 must pass through it or lie at least twice the radius ({} m) \
                                 away, where the grid is not bent",
                                ["x", "y"][d],
                                2.0 * r.radius
                            ),
                        ));
                    }
                }
            }
        }
        let cells = self.counts().map_or(0.0, |c| c.triangles);
        if cells > MAX_TRIANGLES {
            return Err(SetupError::invalid(
                "mesh.h",
                format!("{cells:.3e} tetrahedra is more than this engine's 5e7 limit"),
            ));
        }
        Ok(())
    }
}

/// Counts of a mesh before it is built (estimates for graded and imported meshes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshCounts {
    pub nodes: f64,
    pub triangles: f64,
    pub edges: f64,
}

impl MeshCounts {
    fn from_grid(nx: f64, ny: f64) -> Self {
        MeshCounts {
            nodes: (nx + 1.0) * (ny + 1.0),
            triangles: 2.0 * nx * ny,
            edges: nx * (ny + 1.0) + ny * (nx + 1.0) + nx * ny,
        }
    }
    fn from_triangles(t: f64) -> Self {
        MeshCounts {
            nodes: 0.5 * t + 1.0,
            triangles: t,
            edges: 1.5 * t + 1.0,
        }
    }
}

/// Bytes of an imported Gmsh file per triangle, at least: a triangle takes 20 or more bytes of
/// text (with its share of the nodes), so a file has at most `size / 20` triangles.
pub const GMSH_BYTES_PER_TRIANGLE: f64 = 20.0;

/// Most triangles a mesh may have.
pub(super) const MAX_TRIANGLES: f64 = 5.0e7;

impl MeshSpec {
    /// The sizes, the origin, the kind's own parameters and the size limit; errors name
    /// `mesh.<field>`. An imported (Gmsh) mesh has none of these to check.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        if self.is_3d() {
            return self.validate_3d();
        }
        let (Some((w, hgt)), Some(h)) = (self.size(), self.h()) else {
            return Ok(());
        };
        let origin = self.validate_box(w, hgt, h)?;
        if let MeshSpec::Graded { fine, ratio, .. } = *self {
            validate_graded(fine, ratio, origin, (w, hgt))?;
        }
        let cells = self.counts().map_or(0.0, |c| c.triangles);
        if cells > MAX_TRIANGLES {
            return Err(SetupError::invalid(
                "mesh.h",
                format!("{cells:.3e} triangles is more than this engine's 5e7 limit"),
            ));
        }
        if let MeshSpec::Conforming { .. } = self {
            self.validate_conforming(w.max(hgt))?;
        }
        if let MeshSpec::Perturbed { fraction, .. } = *self {
            finite("mesh.fraction", fraction)?;
            if !(0.0..=0.3).contains(&fraction) {
                return Err(SetupError::invalid(
                    "mesh.fraction",
                    format!("the perturbation must be in [0, 0.3] of h, got {fraction}"),
                ));
            }
        }
        Ok(())
    }

    /// The domain `w` x `hgt` (m) and the cell size `h` (m): positive, the cells smaller than
    /// the domain, the origin finite and near enough to 0 to resolve the cells. Returns the
    /// origin.
    fn validate_box(&self, w: f64, hgt: f64, h: f64) -> Result<[f64; 2], SetupError> {
        positive("mesh.width", w, "the domain width")?;
        positive("mesh.height", hgt, "the domain height")?;
        positive("mesh.h", h, "the cell size")?;
        if h >= w.min(hgt) {
            return Err(SetupError::invalid(
                "mesh.h",
                format!("the cell size {h} m must be smaller than the domain ({w} m x {hgt} m)"),
            ));
        }
        let origin = match *self {
            MeshSpec::Regular { origin, .. }
            | MeshSpec::Perturbed { origin, .. }
            | MeshSpec::Graded { origin, .. }
            | MeshSpec::Conforming { origin, .. } => origin,
            MeshSpec::Gmsh { .. }
            | MeshSpec::Gmsh3 { .. }
            | MeshSpec::Box { .. }
            | MeshSpec::GradedBox { .. } => [0.0; 2],
        };
        finite("mesh.origin", origin[0])?;
        finite("mesh.origin", origin[1])?;
        finite("mesh.origin", origin[0] + w)?;
        finite("mesh.origin", origin[1] + hgt)?;
        // Node coordinates must resolve the cells: far from 0 (1e308, or 1e12 with h = 1 mm)
        // neighbouring nodes round to the same position.
        let far = [origin[0], origin[1], origin[0] + w, origin[1] + hgt]
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        if far * 1e-10 > h {
            return Err(SetupError::invalid(
                "mesh.origin",
                format!(
                    "coordinates up to {far:e} m cannot resolve cells of h = {h} m in double \
                     precision; move the origin nearer 0"
                ),
            ));
        }
        Ok(origin)
    }

    /// A conforming mesh's followed segments, grading, far size (at most `larger`, the
    /// domain's larger side, m), smallest angle and merge distance.
    fn validate_conforming(&self, larger: f64) -> Result<(), SetupError> {
        let MeshSpec::Conforming {
            h,
            h_far,
            min_angle_deg,
            merge,
            grading,
            ref follow,
            ..
        } = *self
        else {
            return Ok(());
        };
        for (i, f) in follow.iter().enumerate() {
            for v in [f.from[0], f.from[1], f.to[0], f.to[1]] {
                finite(&format!("mesh.follow[{i}]"), v)?;
            }
        }
        finite("mesh.grading", grading)?;
        if !(0.01..=2.0).contains(&grading) {
            return Err(SetupError::invalid(
                "mesh.grading",
                format!(
                    "the growth of the cell size with the distance from the fractures \
                     must be in [0.01, 2] (m per m), got {grading}"
                ),
            ));
        }
        if let Some(hf) = h_far {
            finite("mesh.h_far", hf)?;
            if hf < h || hf > larger {
                return Err(SetupError::invalid(
                    "mesh.h_far",
                    format!(
                        "the far cell size must be between h = {h} m and the domain's \
                         larger side ({larger} m), got {hf} m"
                    ),
                ));
            }
        }
        finite("mesh.min_angle_deg", min_angle_deg)?;
        if !(min_angle_deg > 0.0 && min_angle_deg <= 33.0) {
            return Err(SetupError::invalid(
                "mesh.min_angle_deg",
                format!(
                    "the smallest angle asked of the refinement must be in (0, 33] \
                     degrees (above about 30 Delaunay refinement need not end), got \
                     {min_angle_deg}"
                ),
            ));
        }
        finite("mesh.merge", merge)?;
        if !(0.0..=0.5).contains(&merge) {
            return Err(SetupError::invalid(
                "mesh.merge",
                format!(
                    "the merge distance must be in [0, 0.5] of h (points closer than \
                     merge * h become one), got {merge}"
                ),
            ));
        }
        Ok(())
    }
}

/// A graded mesh's growth ratio and fine box (x0, y0, x1, y1), m, inside the domain of size
/// `(w, hgt)` at `origin`, m.
fn validate_graded(
    fine: [f64; 4],
    ratio: f64,
    origin: [f64; 2],
    (w, hgt): (f64, f64),
) -> Result<(), SetupError> {
    finite("mesh.ratio", ratio)?;
    if !(1.0..=10.0).contains(&ratio) {
        return Err(SetupError::invalid(
            "mesh.ratio",
            format!("the growth ratio of the cells must be in [1, 10] (1: uniform), got {ratio}"),
        ));
    }
    for v in fine {
        finite("mesh.fine", v)?;
    }
    let (x1, y1) = (origin[0] + w, origin[1] + hgt);
    let tol = 1e-9 * w.max(hgt);
    if !(fine[0] < fine[2] && fine[1] < fine[3]) {
        return Err(SetupError::invalid(
            "mesh.fine",
            format!("the fine box (x0, y0, x1, y1) = {fine:?} m needs x0 < x1 and y0 < y1"),
        ));
    }
    if fine[0] < origin[0] - tol
        || fine[1] < origin[1] - tol
        || fine[2] > x1 + tol
        || fine[3] > y1 + tol
    {
        return Err(SetupError::invalid(
            "mesh.fine",
            format!(
                "the fine box {fine:?} m is not inside the domain [{}, {}, {x1}, {y1}] m",
                origin[0], origin[1]
            ),
        ));
    }
    Ok(())
}
