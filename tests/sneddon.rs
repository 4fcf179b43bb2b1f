//! Sneddon's pressurised crack on graded meshes at a/h = 10 and 20: the opened area converges at
//! about first order (crack-tip singularity, linear elements) and is within 5 % at a/h = 20 (the
//! issue's target; measured -4.2 %). Also: the shipped scenario parses and its crack snaps exactly.

use hydrofrac::verify::fracture_cases;

#[test]
fn sneddon_area_within_five_percent_at_a_over_h_20() {
    let res = fracture_cases::sneddon(true).unwrap();
    let failed = res.failures();
    assert!(failed.is_empty(), "sneddon failed:\n{}", failed.join("\n"));
    let e = res.errors("area");
    assert!(e[1].1 < e[0].1, "area error does not fall with h: {e:?}");
}

#[test]
fn shipped_scenario_places_the_crack_exactly() {
    let sc =
        hydrofrac::scenario::Scenario::load(std::path::Path::new("scenarios/sneddon.ron"), &[])
            .unwrap();
    let sim = hydrofrac::sim::Simulation::new(sc, &[]).unwrap();
    assert_eq!(sim.placed.len(), 1);
    assert_eq!(sim.placed[0].snap_error, 0.0);
    assert_eq!(sim.placed[0].edges, 40);
    let joints = sim
        .model
        .world
        .query::<&hydrofrac::components::Joint>()
        .iter()
        .count();
    assert_eq!(joints, 40);
    hydrofrac::split::check_invariants(&sim.model).unwrap();
}
