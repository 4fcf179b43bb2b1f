//! Test support: plane segment geometry shared by the network tests (each test file pulls it
//! in with `#[path = "support/geometry.rs"] mod geometry;`). Lengths in m.
#![allow(dead_code)]

use hydrofrac::scenario::PreFracture;
use hydrofrac::union_find::UnionFind;

/// Do segments ab and cd cross or touch?
pub fn cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let o = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    let (d1, d2) = (o(c, d, a), o(c, d, b));
    let (d3, d4) = (o(a, b, c), o(a, b, d));
    d1 * d2 <= 0.0 && d3 * d4 <= 0.0
}

/// The distance between segments ab and cd (0 when they cross), m.
pub fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if cross(a, b, c, d) {
        return 0.0;
    }
    let ps = hydrofrac::snap::point_segment_distance;
    ps(a, c, d)
        .min(ps(b, c, d))
        .min(ps(c, a, b))
        .min(ps(d, a, b))
}

/// Number of groups of fractures joined by crossings.
pub fn geometric_components(f: &[PreFracture]) -> usize {
    let mut uf = UnionFind::new(f.len());
    for i in 0..f.len() {
        for j in i + 1..f.len() {
            if cross(f[i].from, f[i].to, f[j].from, f[j].to) {
                uf.union(i, j);
            }
        }
    }
    (0..f.len()).filter(|&i| uf.find(i) == i).count()
}

/// Fractures that either cross or stay more than `gap` apart (m): no near miss that meshing or
/// snapping could join.
pub fn clean(f: &[PreFracture], gap: f64) -> bool {
    (0..f.len()).all(|i| {
        (i + 1..f.len()).all(|j| {
            let d = segment_distance(f[i].from, f[i].to, f[j].from, f[j].to);
            d == 0.0 || d > gap
        })
    })
}

/// Number of groups of a fracture view's cells joined where they share a node.
pub fn cell_components(v: &hydrofrac::flow::FlowView) -> usize {
    let mut uf = UnionFind::new(v.n_cells());
    let mut first_at = vec![usize::MAX; v.node_pos.len()];
    for (c, n) in v.cell_nodes.iter().enumerate() {
        for &k in n {
            if first_at[k as usize] == usize::MAX {
                first_at[k as usize] = c;
            } else {
                uf.union(first_at[k as usize], c);
            }
        }
    }
    (0..v.n_cells()).filter(|&c| uf.find(c) == c).count()
}

/// The first seed (1-499) whose scenario `scene(seed)` generates a random network of `count`
/// fractures in the rock that either cross or stay more than `gap` apart (m), with crossings
/// (at most `count - 4` crossing groups): the scenario and its fractures.
pub fn clean_random_network(
    scene: impl Fn(u64) -> String,
    count: usize,
    gap: f64,
) -> (hydrofrac::scenario::Scenario, Vec<PreFracture>) {
    (1..500u64)
        .map(|seed| {
            let sc = hydrofrac::scenario::Scenario::parse(&scene(seed), "rock_network.ron")
                .expect("the scene parses");
            let g = sc
                .fracture
                .as_ref()
                .and_then(|f| f.random.as_ref())
                .expect("a random network")
                .generate();
            (sc, g)
        })
        .find(|(_, g)| g.len() == count && clean(g, gap) && geometric_components(g) + 4 <= count)
        .expect("a seed with crossings and no near misses")
}
