//! Random and mapped networks of pre-existing fractures in the rock (`fracture.random`,
//! `fracture.file`): snapped to mesh edges, opened as joints with flow cells, and connected
//! where they cross: the cell network's connected components are the geometric network's.

use crate::support_cli as cli;
use crate::support_geometry as geometry;

use geometry::{cell_components, clean_random_network, geometric_components};
use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;

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
    let (sc, generated) = clean_random_network(|seed| scene(&spec(seed)), 14, 2.0);
    let sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    // Every generated fracture is placed, within one edge of its segment.
    assert_eq!(sim.placed().len(), 14);
    for p in sim.placed() {
        assert!(p.edges >= 5 && p.snap_error < 1.0, "{p:?}");
    }
    // The cells' network (cells joined where they share a node) has the geometric network's
    // components: crossings connect (on a planar mesh two crossing edge paths share a node).
    let rock = cell_components(&sim.fracture_view().unwrap());
    let geometric = geometric_components(&generated);
    assert_eq!(
        rock, geometric,
        "cell network components vs crossing groups"
    );
}

#[test]
fn a_mapped_network_comes_from_a_csv_file() {
    let dir = cli::tmp("mapped");
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
