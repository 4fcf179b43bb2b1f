//! Fractures in the rock at setup: pre-existing fractures snapped to mesh edges and opened by
//! node splitting, a prescribed pressure on fracture faces (as nodal loads), and joint openings
//! measured from the sister edges (seed equation (8)).

use crate::error::SetupError;
use crate::mesh::TriMesh;
use crate::model::Model;
use crate::scenario::FractureSpec;
use crate::snap::{adjacency, snap_segment};
use crate::split::open_edges;
use hecs::Entity;
use hydrofrac_components::*;
use std::collections::HashMap;

/// How a pre-existing fracture was placed: the requested segment, the largest distance of the
/// snapped path from it (m), and the number of mesh edges opened.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Placed {
    pub from: [f64; 2],
    pub to: [f64; 2],
    pub snap_error: f64,
    pub edges: usize,
    /// `snap_error` over the mean length of the path's edges.
    pub snap_error_h: f64,
    /// The largest angle between a path edge and the requested segment, degrees (0 when the
    /// mesh follows the fracture; 15-45 for a zigzag).
    pub zigzag_deg: f64,
    /// A listed fracture (not a generated one) with an end outside the domain: only the part
    /// inside is placed, and the run warns.
    pub clipped: bool,
}

/// Angles above this (degrees) between a snapped path's edges and its fracture make the
/// fracture a zigzag: the run warns (`Placed::zigzag_deg`).
pub const ZIGZAG_WARN_DEG: f64 = 1.0;

/// The mean edge length of a path and the largest angle (degrees, 0-90) between one of its
/// edges and the direction of `from`-`to`.
fn path_shape(mesh: &TriMesh, nodes: &[u32], from: [f64; 2], to: [f64; 2]) -> (f64, f64) {
    let d = [to[0] - from[0], to[1] - from[1]];
    let (mut len, mut worst) = (0.0, 0.0f64);
    for w in nodes.windows(2) {
        let (a, b) = (mesh.nodes[w[0] as usize], mesh.nodes[w[1] as usize]);
        let e = [b[0] - a[0], b[1] - a[1]];
        len += e[0].hypot(e[1]);
        let cross = (e[0] * d[1] - e[1] * d[0]).abs();
        let dot = (e[0] * d[0] + e[1] * d[1]).abs();
        worst = worst.max(cross.atan2(dot).to_degrees());
    }
    (len / (nodes.len().max(2) - 1) as f64, worst)
}

/// Snap and open the scenario's pre-existing fractures on a fresh model built from `mesh`
/// (node stable ids are mesh node indices).
pub fn open_preexisting(
    model: &mut Model,
    mesh: &TriMesh,
    spec: &FractureSpec,
) -> Result<Vec<Placed>, SetupError> {
    let preexisting = spec.all_preexisting()?;
    if preexisting.is_empty() {
        return Ok(Vec::new());
    }
    let adj = adjacency(mesh);
    let mut by_pair: HashMap<(u64, u64), Entity> = HashMap::new();
    for (e, en, st) in model
        .world
        .query::<(Entity, &EdgeNodes, &EdgeState)>()
        .iter()
    {
        if st.opened {
            continue;
        }
        let ids = en.0.map(|n| {
            model
                .world
                .get::<&StableId>(n)
                .map(|s| s.0)
                .unwrap_or(u64::MAX)
        });
        by_pair.insert((ids[0].min(ids[1]), ids[0].max(ids[1])), e);
    }
    let mut placed = Vec::new();
    let mut ready = Vec::new();
    let [x0, y0, x1, y1] = mesh.bbox;
    let tol = 1e-9 * (x1 - x0).abs().max((y1 - y0).abs());
    let domain = [x0 - tol, y0 - tol, x1 + tol, y1 + tol];
    let inside = |p: [f64; 2]| {
        p[0] >= domain[0] && p[0] <= domain[2] && p[1] >= domain[1] && p[1] <= domain[3]
    };
    for (pf, field) in &preexisting {
        // A generated fracture that cannot be placed (outside the mesh, shorter than an
        // edge, along the boundary) is left out; a listed one is an error.
        let generated = field.starts_with("fracture.random");
        let where_ = format!(
            "from {:?} to {:?} m, the domain is [{x0}, {x1}] x [{y0}, {y1}] m",
            pf.from, pf.to
        );
        let (mut a, mut b) = (pf.from, pf.to);
        if !crate::network::clip(&mut a, &mut b, domain) {
            if generated {
                continue;
            }
            return Err(SetupError::invalid(
                field,
                format!("lies outside the domain ({where_})"),
            ));
        }
        let Some(path) = snap_segment(mesh, &adj, pf.from, pf.to) else {
            if generated {
                continue;
            }
            let why = if inside(pf.from) && inside(pf.to) {
                "is shorter than one mesh edge (both ends snap to the same node)".to_string()
            } else {
                format!(
                    "has an end outside the domain and both ends snap to the same node \
                     ({where_})"
                )
            };
            return Err(SetupError::invalid(field, why));
        };
        let edges: Vec<Entity> = path
            .nodes
            .windows(2)
            .filter_map(|w| {
                let (a, b) = (w[0] as u64, w[1] as u64);
                by_pair.get(&(a.min(b), a.max(b))).copied()
            })
            .collect();
        let internal = edges.iter().any(|&e| {
            model
                .world
                .get::<&EdgeElems>(e)
                .is_ok_and(|l| !l.is_external())
        });
        if !edges.is_empty() && !internal {
            if generated {
                continue;
            }
            return Err(SetupError::invalid(
                field,
                format!(
                    "lies along the domain boundary ({where_}): its {} mesh edges are boundary \
                     edges, which cannot open",
                    edges.len()
                ),
            ));
        }
        let (mean_edge, zigzag_deg) = path_shape(mesh, &path.nodes, pf.from, pf.to);
        placed.push(Placed {
            from: pf.from,
            to: pf.to,
            snap_error: path.max_error,
            edges: edges.len(),
            snap_error_h: path.max_error / mean_edge,
            zigzag_deg,
            clipped: !(generated || inside(pf.from) && inside(pf.to)),
        });
        ready.extend(edges);
    }
    // Boundary edges of a fracture on the domain edge cannot open; open_edges ignores them.
    let report = open_edges(model, &ready, spec.residual_aperture, 0.0);
    for c in report.cells {
        if let Ok(mut o) = model.world.get::<&mut CellOrigin>(c) {
            o.kind = CellKind::Preexisting;
        }
    }
    Ok(placed)
}

/// Fill every cell with fluid of density `rho` (kg/m^3): mass rho a L (reference length).
pub fn fill_cells(model: &mut Model, rho: f64) {
    let cells: Vec<(Entity, [Entity; 2])> = model
        .world
        .query::<(Entity, &CellNodes)>()
        .iter()
        .map(|(e, n)| (e, n.0))
        .collect();
    for (c, ends) in cells {
        let [a, b] = ends.map(|n| model.world.get::<&NodeRef>(n).expect("node").0);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if let Ok(mut f) = model.world.get::<&mut CellFluid>(c) {
            f.mass = rho * f.aperture * len;
        }
    }
}

/// Outward unit normal of an external edge (away from its element), reference configuration.
pub fn outward_normal(model: &Model, edge: Entity) -> [f64; 2] {
    let w = &model.world;
    let en = w.get::<&EdgeNodes>(edge).expect("edge").0;
    let el = w.get::<&EdgeElems>(edge).expect("edge").0[0].expect("element");
    let tri = w.get::<&ElemNodes>(el).expect("element").0;
    let third = tri
        .iter()
        .find(|n| !en.contains(n))
        .copied()
        .expect("third node");
    let [a, b] = en.map(|n| w.get::<&NodeRef>(n).expect("node").0);
    let c = w.get::<&NodeRef>(third).expect("node").0;
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    let mut n = [(b[1] - a[1]) / len, -(b[0] - a[0]) / len];
    let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    if (c[0] - mid[0]) * n[0] + (c[1] - mid[1]) * n[1] > 0.0 {
        n = [-n[0], -n[1]];
    }
    n
}

/// Add the nodal loads of a uniform pressure p (Pa) on both faces of every joint: each face
/// node gets -p n_out L/2 (the fluid pushes the faces apart).
pub fn apply_face_pressure(model: &mut Model, p: f64) {
    for (node, f) in face_pressure_terms(model, p) {
        let mut bc = model.world.get::<&mut NodeBc>(node).expect("node");
        bc.load[0] += f[0];
        bc.load[1] += f[1];
    }
    model.topology_generation += 1;
}

/// Per node, the nodal loads of a uniform pressure p (Pa) on both faces of every joint (what
/// [`apply_face_pressure`] adds), N per metre.
pub fn face_pressure_loads(model: &Model, p: f64) -> HashMap<Entity, [f64; 2]> {
    let mut loads: HashMap<Entity, [f64; 2]> = HashMap::new();
    for (node, g) in face_pressure_terms(model, p) {
        let f = loads.entry(node).or_insert([0.0; 2]);
        f[0] += g[0];
        f[1] += g[1];
    }
    loads
}

/// The nodal loads of a uniform pressure p (Pa) on both faces of every joint, one term per
/// face node: -p n_out L/2 (the fluid pushes the faces apart), N per metre.
fn face_pressure_terms(model: &Model, p: f64) -> Vec<(Entity, [f64; 2])> {
    let joints: Vec<Joint> = model.world.query::<&Joint>().iter().copied().collect();
    let mut terms = Vec::new();
    for j in joints {
        for e in j.edges {
            let n = outward_normal(model, e);
            let en = model.world.get::<&EdgeNodes>(e).expect("edge").0;
            let [a, b] = en.map(|x| model.world.get::<&NodeRef>(x).expect("node").0);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            for node in en {
                terms.push((node, [-p * n[0] * 0.5 * len, -p * n[1] * 0.5 * len]));
            }
        }
    }
    terms
}

/// After a split under a uniform face pressure p (Pa): each daughter of a split node had its
/// mass share of the mother's load, including the mother's face-pressure load (zero at a
/// fracture tip, where the two faces' loads cancel). It now carries the load of the faces it
/// has instead: the new joints' faces and its own side of the old ones. `before`:
/// [`face_pressure_loads`] before the split; `daughters_of`: the split's mothers and their
/// daughters with their shares (`SplitReport::daughters_of`). Without this, faces opened
/// after setup carry no pressure.
pub fn reload_face_pressure(
    model: &mut Model,
    p: f64,
    before: &HashMap<Entity, [f64; 2]>,
    daughters_of: &[(Entity, Vec<(Entity, f64)>)],
) {
    let after = face_pressure_loads(model, p);
    for (m, ds) in daughters_of {
        let fm = before.get(m).copied().unwrap_or([0.0; 2]);
        for &(d, share) in ds {
            let fd = after.get(&d).copied().unwrap_or([0.0; 2]);
            let mut bc = model.world.get::<&mut NodeBc>(d).expect("node");
            for k in 0..2 {
                bc.load[k] += fd[k] - share * fm[k];
            }
        }
    }
}

/// Opening of a joint, m: (x_q - x_p) . n_p with x the current edge centres and n_p the outward
/// normal of face p (seed (8)); positive when the faces separate. Also the centre (m) and length.
pub fn joint_opening(model: &Model, j: &Joint) -> ([f64; 2], f64, f64) {
    let w = &model.world;
    let centre = |e: Entity| {
        let en = w.get::<&EdgeNodes>(e).expect("edge").0;
        let p = en.map(|n| {
            let x = w.get::<&NodeRef>(n).expect("node").0;
            let u = w.get::<&NodeState>(n).expect("node").u;
            [x[0] + u[0], x[1] + u[1]]
        });
        let r = en.map(|n| w.get::<&NodeRef>(n).expect("node").0);
        (
            [0.5 * (p[0][0] + p[1][0]), 0.5 * (p[0][1] + p[1][1])],
            [0.5 * (r[0][0] + r[1][0]), 0.5 * (r[0][1] + r[1][1])],
            (r[1][0] - r[0][0]).hypot(r[1][1] - r[0][1]),
        )
    };
    let (xp, rp, len) = centre(j.edges[0]);
    let (xq, _, _) = centre(j.edges[1]);
    let n = outward_normal(model, j.edges[0]);
    (rp, (xq[0] - xp[0]) * n[0] + (xq[1] - xp[1]) * n[1], len)
}

/// Hydraulic aperture of a joint, m: its normal opening delta_n, but never below the residual
/// aperture a_r that closed, rough faces keep open (seed (12), `docs/seed-method.md`).
#[inline]
pub fn hydraulic_aperture(opening: f64, residual_aperture: f64) -> f64 {
    opening.max(residual_aperture)
}

/// Bring the fracture geometry in the components up to date: every mother node (left the solid)
/// moves with the mean displacement of its daughters, and, with `residual_aperture` given,
/// every joint's cell gets the hydraulic aperture max(delta_n, a_r) (seed (12)) from the
/// joint's current opening (coupled runs pass `None`: their flow view owns the apertures).
pub fn sync_fracture_geometry(model: &mut Model, residual_aperture: Option<f64>) {
    let mut sum: HashMap<Entity, ([f64; 2], usize)> = HashMap::new();
    for (link, st) in model.world.query::<(&NodeLink, &NodeState)>().iter() {
        if let (true, Some(m)) = (link.in_solid, link.mother) {
            let e = sum.entry(m).or_insert(([0.0; 2], 0));
            e.0[0] += st.u[0];
            e.0[1] += st.u[1];
            e.1 += 1;
        }
    }
    for (m, (u, n)) in sum {
        if let Ok(mut st) = model.world.get::<&mut NodeState>(m) {
            st.u = [u[0] / n as f64, u[1] / n as f64];
        }
    }
    let Some(residual_aperture) = residual_aperture else {
        return;
    };
    let joints: Vec<(Joint, f64)> = model
        .world
        .query::<(&Joint, &JointState)>()
        .iter()
        .map(|(j, s)| (*j, s.opening))
        .collect();
    for (j, opening) in joints {
        if let Ok(mut c) = model.world.get::<&mut CellFluid>(j.cell) {
            c.aperture = hydraulic_aperture(opening, residual_aperture);
        }
    }
}
