//! Snapping a requested fracture segment to a path of mesh edges (fractures can only run along
//! element edges). The path is the cheapest route through the edge graph between the nodes
//! nearest the two end points, an edge costing its length plus a penalty that grows with the
//! distance of its end and middle from the requested segment, so the route follows the segment
//! and takes the mesh's 45- or 90-degree steps where it must. The snapping error reported is the
//! largest distance of any path node from the requested segment, m.

use crate::mesh::TriMesh;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A snapped fracture: mesh node indices along the path (start to end) and the snapping error.
#[derive(Clone, Debug, PartialEq)]
pub struct SnappedPath {
    pub nodes: Vec<u32>,
    /// Largest distance of a path node from the requested segment, m.
    pub max_error: f64,
}

/// The foot of p on the segment a-b: its parameter t in [0, 1] along a-b and the distance
/// from p to it, m.
pub fn segment_foot(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, f64) {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (t, (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1]))
}

/// Distance from p to the segment a-b, m.
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    segment_foot(p, a, b).1
}

/// Node adjacency of a triangle mesh (sorted, no duplicates).
pub fn adjacency(mesh: &TriMesh) -> Vec<Vec<u32>> {
    let mut adj = vec![Vec::new(); mesh.nodes.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    adj
}

/// Snap the segment `from`-`to` (m) to mesh edges. `None` when the end points snap to the same
/// node (the segment is shorter than the mesh) or no route exists.
pub fn snap_segment(
    mesh: &TriMesh,
    adj: &[Vec<u32>],
    from: [f64; 2],
    to: [f64; 2],
) -> Option<SnappedPath> {
    let nearest = |p: [f64; 2]| {
        (0..mesh.nodes.len())
            .min_by(|&i, &j| {
                let (a, b) = (mesh.nodes[i], mesh.nodes[j]);
                (a[0] - p[0])
                    .hypot(a[1] - p[1])
                    .total_cmp(&(b[0] - p[0]).hypot(b[1] - p[1]))
                    .then(i.cmp(&j))
            })
            .map(|i| i as u32)
    };
    let (s, e) = (nearest(from)?, nearest(to)?);
    if s == e {
        return None;
    }
    // Dijkstra; costs scaled to integers would lose nothing here, but f64 with total order and
    // a node-index tie-break keeps the route deterministic.
    let h = mesh.h;
    let cost = |a: u32, b: u32| {
        let (pa, pb) = (mesh.nodes[a as usize], mesh.nodes[b as usize]);
        let mid = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])];
        let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
        let off = point_segment_distance(pb, from, to) + point_segment_distance(mid, from, to);
        len * (1.0 + 10.0 * (off / h).powi(2))
    };
    let n = mesh.nodes.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut prev = vec![u32::MAX; n];
    let mut heap = BinaryHeap::new();
    dist[s as usize] = 0.0;
    heap.push(Reverse((Ordered(0.0), s)));
    while let Some(Reverse((Ordered(d), a))) = heap.pop() {
        if a == e {
            break;
        }
        if d > dist[a as usize] {
            continue;
        }
        for &b in &adj[a as usize] {
            let nd = d + cost(a, b);
            if nd < dist[b as usize] {
                dist[b as usize] = nd;
                prev[b as usize] = a;
                heap.push(Reverse((Ordered(nd), b)));
            }
        }
    }
    if prev[e as usize] == u32::MAX {
        return None;
    }
    let mut nodes = vec![e];
    while *nodes.last()? != s {
        nodes.push(prev[*nodes.last()? as usize]);
    }
    nodes.reverse();
    let max_error = nodes
        .iter()
        .map(|&k| point_segment_distance(mesh.nodes[k as usize], from, to))
        .fold(0.0, f64::max);
    Some(SnappedPath { nodes, max_error })
}

/// f64 with a total order for the heap.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ordered(f64);
impl Eq for Ordered {}
impl PartialOrd for Ordered {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Ordered {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_example_fractures_snap_exactly_on_the_regular_mesh() {
        let mesh = TriMesh::regular(100.0, 100.0, 1.0, [0.0, 0.0]).unwrap();
        let adj = adjacency(&mesh);
        // Example I: horizontal (0,50)-(10,50) and vertical (16,46)-(16,54).
        let hpath = snap_segment(&mesh, &adj, [0.0, 50.0], [10.0, 50.0]).unwrap();
        assert_eq!(hpath.nodes.len(), 11);
        assert_eq!(hpath.max_error, 0.0);
        let vpath = snap_segment(&mesh, &adj, [16.0, 46.0], [16.0, 54.0]).unwrap();
        assert_eq!(vpath.nodes.len(), 9);
        assert_eq!(vpath.max_error, 0.0);
        // 45 degrees follows diagonals where the mesh has them.
        let d = snap_segment(&mesh, &adj, [20.0, 20.0], [30.0, 30.0]).unwrap();
        assert!(d.max_error < 1e-12 && d.nodes.len() == 11, "{d:?}");
    }

    #[test]
    fn oblique_and_perturbed_paths_stay_within_a_cell() {
        for mesh in [
            TriMesh::regular(40.0, 40.0, 1.0, [0.0, 0.0]).unwrap(),
            TriMesh::perturbed(40.0, 40.0, 1.0, [0.0, 0.0], 0.25, 3).unwrap(),
        ] {
            let adj = adjacency(&mesh);
            let p = snap_segment(&mesh, &adj, [3.2, 5.1], [33.7, 21.4]).unwrap();
            assert!(p.max_error < mesh.h, "error {} m", p.max_error);
            // Consecutive path nodes are mesh neighbours.
            for w in p.nodes.windows(2) {
                assert!(adj[w[0] as usize].contains(&w[1]));
            }
        }
    }

    #[test]
    fn too_short_is_none() {
        let mesh = TriMesh::regular(10.0, 10.0, 1.0, [0.0, 0.0]).unwrap();
        let adj = adjacency(&mesh);
        assert!(snap_segment(&mesh, &adj, [5.0, 5.0], [5.2, 5.1]).is_none());
    }
}
