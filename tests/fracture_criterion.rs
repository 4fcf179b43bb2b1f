//! The fracture criterion (seed equation (7)) marks exactly the internal edges whose normal
//! stress reaches lambda*T0. Uniaxial tension sxx = 5 MPa on the regular mesh gives sigma_n =
//! 5 MPa on vertical edges, 2.5 MPa on the 45-degree diagonals and 0 on horizontal edges, so the
//! marked set is known exactly for any strength.

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};
use hydrofrac::systems::fracture::{StrengthCounts, fracture_criterion};

const PLATE: &str = r#"(
    name: "criterion",
    mesh: Regular(width: 20.0, height: 10.0, h: 1.0),
    material: (young: 20e9, poisson: 0.25, density: 2700.0),
    boundary: Sides(left: Normal(0.0), right: Traction(normal: 5e6, shear: 0.0)),
    pins: [(at: (0.0, 0.0), uy: 0.0)],
    fracture: Some((strength: 1e6)),
    time: (end: Static(tol: 1e-10)),
)"#;

fn relaxed() -> Simulation {
    let sc = Scenario::parse(PLATE, "plate.ron").unwrap();
    // Relax without the criterion: the transient overshoots the static stress.
    let mut sim = Simulation::new(sc.validate().unwrap(), &["fracture_criterion".into()]).unwrap();
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    sim
}

#[test]
fn marks_exactly_the_edges_at_or_above_the_strength() {
    let (nx, ny) = (20, 10);
    let vertical = (nx - 1) * ny;
    let diagonal = nx * ny;
    for (strength, expect, by_elements) in [(6e6, 0), (4e6, vertical), (2e6, vertical + diagonal)]
        .into_iter()
        .flat_map(|(s, e)| [(s, e, false), (s, e, true)])
    {
        let mut sim = relaxed();
        assert_eq!(
            sim.solid().edge_entity.len(),
            vertical + diagonal + nx * (ny - 1)
        );
        let mut counts = StrengthCounts::default();
        let n = fracture_criterion(
            sim.solid_mut(),
            strength,
            by_elements,
            None,
            None,
            &mut counts,
            &mut Vec::new(),
        );
        assert_eq!(counts.evaluated as usize, sim.solid().edge_entity.len());
        assert_eq!(n, expect, "strength {strength:e}");
        for k in 0..sim.solid().edge_entity.len() {
            let nrm = sim.solid().edge_normal[k];
            let expected_sn = 5e6 * nrm[0] * nrm[0];
            let err = (sim.solid().edge_sigma_n[k] - expected_sn).abs();
            assert!(
                err < 1e-6 * 5e6,
                "edge {k}: sigma_n off by {err} Pa (relaxation tolerance 1e-6)"
            );
        }
    }
}

#[test]
fn criterion_runs_every_step_and_marks_persist_in_the_components() {
    let sc = Scenario::parse(PLATE, "plate.ron").unwrap();
    // Marks only: with `split` on, a 1 MPa rock under 5 MPa tension shatters (tests/fracturing.rs).
    let mut sim = Simulation::new(sc.validate().unwrap(), &["split".into()]).unwrap();
    sim.run(|_| {}).unwrap();
    assert!(
        sim.schedule()
            .is_enabled(hydrofrac::systems::SystemId::FractureCriterion)
    );
    assert!(sim.fracture().ready_edges > 0);
    let marked = sim
        .model()
        .world
        .query::<&hydrofrac::components::EdgeState>()
        .iter()
        .filter(|s| s.fracture_ready)
        .count();
    assert_eq!(marked, sim.fracture().ready_edges);
    // Without `fracture` the system has no data and is not scheduled.
    let sc = Scenario::parse(
        &PLATE.replace("fracture: Some((strength: 1e6)),", ""),
        "plate.ron",
    )
    .unwrap();
    let sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    assert!(
        !sim.schedule()
            .is_enabled(hydrofrac::systems::SystemId::FractureCriterion)
    );
}

/// The screened strength test (`StrengthScreen`: a face is evaluated again only once the
/// displacement change since its last evaluation could have closed its margin) marks exactly
/// what the full evaluation would: along the seed's crossing run (explicit, through its first
/// splits), after every step no unmarked face has a stress at or above the strength. And it
/// does skip work: under 0.5 % of the faces per step (measured 28 of 29,778, 0.09 %).
#[test]
fn screened_strength_test_misses_no_face() {
    screen_run("example1_cross.ron", 0.34, 1, 0.005);
}

/// The same on the seed's crossing case on a mesh that follows the fractures (edges from
/// 0.05 to 1.4 m, the hand-over on), where each face's bound uses the elements its stress
/// reads and the regions are 8 median edges wide (a bound from the smallest element anywhere
/// and regions 8 of the shortest edges wide made the criterion 82 % of a conforming Example
/// II's run): checked every 4th step, through the first splits; under 0.15 % of the faces
/// evaluated per step (measured 40 of 56,320, 0.07 %; with one bound from the smallest
/// element 128, 0.23 %, so this fails if the per-face bound is lost).
#[test]
fn screened_strength_test_misses_no_face_on_a_conforming_mesh() {
    screen_run("example1_cross_conforming.ron", 0.3, 4, 0.0015);
}

/// Run `scenarios/NAME` to `end` (s), checking after every `every`-th step (and not after a
/// split) that no unmarked face is at or above the strength (1 MPa); the run must split and
/// be checked over 1000 times, and evaluate fewer than `max_fraction` of the faces per step.
fn screen_run(name: &str, end: f64, every: u64, max_fraction: f64) {
    let src = std::fs::read_to_string(format!("scenarios/{name}")).unwrap();
    let sc = Scenario::parse(&src, name)
        .unwrap()
        .with_overrides(&[format!("time.end=Time({end})")])
        .unwrap();
    let strength = 1e6;
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let (mut checked, mut splits) = (0, 0);
    while sim.clock().finish.is_none() {
        let generation = sim.solid().generation;
        sim.step_once().unwrap();
        let v = sim.solid();
        if v.generation != generation {
            splits += 1;
            continue;
        }
        if !sim.clock().step.is_multiple_of(every) {
            continue;
        }
        for k in 0..v.edge_nodes.len() {
            if !v.edge_ready[k] {
                let sn = hydrofrac::systems::fracture::face_normal_stress(v, k, false);
                assert!(
                    sn < strength,
                    "{name}, step {}: edge {k} at {sn:e} Pa not marked",
                    sim.clock().step
                );
            }
        }
        checked += 1;
    }
    assert!(
        splits > 0 && checked > 1000,
        "{name}: {splits} splits, {checked} steps checked"
    );
    let per_step = sim.fracture().strength_counts.evaluated as f64 / sim.clock().step as f64;
    let faces = sim.solid().edge_nodes.len();
    eprintln!("{name}: {per_step:.0} faces evaluated per step of {faces}");
    assert!(
        per_step < max_fraction * faces as f64,
        "{name}: {per_step:.0} faces evaluated per step of {faces}"
    );
}
