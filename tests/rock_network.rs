//! Random and mapped networks of pre-existing fractures in the rock (`fracture.random`,
//! `fracture.file`): snapped to mesh edges, opened as joints with flow cells, and connected
//! where they cross: the cell network's connected components are the geometric network's.

use hydrofrac::scenario::{PreFracture, Scenario};
use hydrofrac::sim::Simulation;
use hydrofrac::union_find::UnionFind;

fn scene(fracture_extra: &str) -> String {
    format!(
        r#"(
    name: "rock_network",
    mesh: Regular(width: 40.0, height: 40.0, h: 1.0),
    material: (young: 20e9, poisson: 0.2, density: 2700.0),
    boundary: InSitu(sxx: -20e6, syy: -10e6),
    initial_state: InSitu,
    fracture: Some((
        residual_aperture: 5e-4,
        {fracture_extra}
    )),
    time: (end: Time(1e-3)),
)"#
    )
}

/// Do segments ab and cd cross or touch?
fn cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let o = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    let (d1, d2) = (o(c, d, a), o(c, d, b));
    let (d3, d4) = (o(a, b, c), o(a, b, d));
    d1 * d2 <= 0.0 && d3 * d4 <= 0.0
}

fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if cross(a, b, c, d) {
        return 0.0;
    }
    let ps = |p: [f64; 2], u: [f64; 2], v: [f64; 2]| {
        let (dx, dy) = (v[0] - u[0], v[1] - u[1]);
        let t = (((p[0] - u[0]) * dx + (p[1] - u[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        (p[0] - u[0] - t * dx).hypot(p[1] - u[1] - t * dy)
    };
    ps(a, c, d)
        .min(ps(b, c, d))
        .min(ps(c, a, b))
        .min(ps(d, a, b))
}

/// Number of groups of fractures joined by crossings.
fn geometric_components(f: &[PreFracture]) -> usize {
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

#[test]
fn a_random_network_is_placed_and_connected_where_it_crosses() {
    // The first seed whose fractures either cross or stay 2 mesh edges apart (so snapping
    // cannot join fractures that do not cross: the comparison is then exact), with crossings.
    let spec = |seed: u64| {
        format!(
            "random: Some((seed: {seed}, count: 14, size: (40.0, 40.0), angles_deg: [60.0, 150.0], \
             jitter_deg: 15.0, length: (6.0, 18.0))),"
        )
    };
    let clean = |f: &[PreFracture]| {
        (0..f.len()).all(|i| {
            (i + 1..f.len()).all(|j| {
                let d = segment_distance(f[i].from, f[i].to, f[j].from, f[j].to);
                d == 0.0 || d > 2.0
            })
        })
    };
    let (sc, generated) = (1..500u64)
        .map(|seed| {
            let sc = Scenario::parse(&scene(&spec(seed)), "rock_network.ron").unwrap();
            let g = sc
                .fracture
                .as_ref()
                .unwrap()
                .random
                .as_ref()
                .unwrap()
                .generate();
            (sc, g)
        })
        .find(|(_, g)| g.len() == 14 && clean(g) && geometric_components(g) <= 10)
        .expect("a seed with crossings and no near misses");
    let sim = Simulation::new(sc, &[]).unwrap();
    // Every generated fracture is placed, within one edge of its segment.
    assert_eq!(sim.placed().len(), 14);
    for p in sim.placed() {
        assert!(p.edges >= 5 && p.snap_error < 1.0, "{p:?}");
    }
    // The cells' network (cells joined where they share a node) has the geometric network's
    // components: crossings connect (on a planar mesh two crossing edge paths share a node).
    let v = sim.fracture_view().unwrap();
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
    let rock = (0..v.n_cells()).filter(|&c| uf.find(c) == c).count();
    let geometric = geometric_components(&generated);
    assert_eq!(
        rock, geometric,
        "cell network components vs crossing groups"
    );
}

#[test]
fn a_mapped_network_comes_from_a_csv_file() {
    let dir = std::env::temp_dir().join(format!("hydrofrac-rocknet-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("mapped.csv"),
        "x0,y0,x1,y1\n5,20,30,20\n\n15,10,15,30\n",
    )
    .unwrap();
    let path = dir.join("scene.ron");
    std::fs::write(&path, scene("file: Some(\"mapped.csv\"),")).unwrap();
    let sc = Scenario::load(&path, &[]).unwrap();
    let sim = Simulation::new(sc, &[]).unwrap();
    assert_eq!(sim.placed().len(), 2);
    assert_eq!(sim.placed()[0].edges, 25);
    // A bad line is named with the file and line number.
    std::fs::write(dir.join("mapped.csv"), "x0,y0,x1,y1\n5,20,30\n").unwrap();
    let e = Scenario::load(&path, &[])
        .and_then(|sc| Simulation::new(sc, &[]).map(|_| ()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mapped.csv:2") && e.contains("x0,y0,x1,y1"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad random networks are refused at validation, naming the field.
#[test]
fn bad_random_networks_are_named() {
    for (extra, field) in [
        (
            "random: Some((seed: 1, count: 20000, size: (40.0, 40.0), angles_deg: [0.0], length: (5.0, 9.0))),",
            "fracture.random.count",
        ),
        (
            "random: Some((seed: 1, count: 5, size: (40.0, 40.0), angles_deg: [0.0], length: (9.0, 5.0))),",
            "fracture.random.length",
        ),
        (
            "random: Some((seed: 1, count: 5, size: (40.0, -4.0), angles_deg: [0.0], length: (5.0, 9.0))),",
            "fracture.random.size",
        ),
        (
            "random: Some((seed: 1, count: 5, size: (40.0, 40.0), angles_deg: [], length: (5.0, 9.0))),",
            "fracture.random.angles_deg",
        ),
    ] {
        let e = Scenario::parse(&scene(extra), "bad.ron")
            .and_then(|sc| sc.validate())
            .unwrap_err()
            .to_string();
        assert!(e.contains(field), "{extra}: {e}");
    }
}
