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
    let mut sim = Simulation::new(sc, &["fracture_criterion".into()]).unwrap();
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
    let mut sim = Simulation::new(sc, &["split".into()]).unwrap();
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
    let sim = Simulation::new(sc, &[]).unwrap();
    assert!(
        !sim.schedule()
            .is_enabled(hydrofrac::systems::SystemId::FractureCriterion)
    );
}

/// The screened strength test (each node's largest principal stress bounds the faces at it)
/// marks exactly the edges the full evaluation marks, on a field with a crack tip's
/// concentration (a pressurised crack in the plate), for thresholds from below the smallest
/// face stress to above the largest; and it does screen faces out.
#[test]
fn screened_strength_test_marks_what_the_full_evaluation_marks() {
    let sc = Scenario::parse(
        &PLATE
            .replace("right: Traction(normal: 5e6, shear: 0.0)", "right: Traction(normal: 1e6, shear: 0.0)")
            .replace(
                "fracture: Some((strength: 1e6)),",
                "fracture: Some((strength: 1e6, pressure: Some(4e6), preexisting: [(from: (6.0, 5.0), to: (14.0, 5.0))])),",
            ),
        "plate.ron",
    )
    .unwrap();
    let mut sim = Simulation::new(sc, &["fracture_criterion".into()]).unwrap();
    assert_eq!(sim.run(|_| {}).unwrap(), Finish::Converged);
    let sn: Vec<f64> = {
        let mut v = sim.solid().clone();
        let mut c = StrengthCounts::default();
        fracture_criterion(&mut v, f64::INFINITY, false, None, None, &mut c);
        v.edge_sigma_n.clone()
    };
    let (lo, hi) = sn
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    assert!(
        hi > 4e6,
        "the tip concentrates tension: largest face stress {hi:e}"
    );
    let mut screened_total = 0;
    for k in 0..=20 {
        let strength = lo + (hi - lo) * k as f64 / 20.0;
        for by_elements in [false, true] {
            let (mut full, mut fast) = (sim.solid().clone(), sim.solid().clone());
            let (mut c1, mut c2) = (StrengthCounts::default(), StrengthCounts::default());
            let n1 = fracture_criterion(&mut full, strength, by_elements, None, None, &mut c1);
            let mut scratch = Vec::new();
            let n2 = fracture_criterion(
                &mut fast,
                strength,
                by_elements,
                Some(&mut scratch),
                None,
                &mut c2,
            );
            assert_eq!(n1, n2, "strength {strength:e}");
            assert_eq!(full.edge_ready, fast.edge_ready, "strength {strength:e}");
            // Screened faces hold a bound of their stress, below the strength.
            for e in 0..sn.len() {
                assert!(fast.edge_sigma_n[e] >= full.edge_sigma_n[e] - 1e-6 * hi.abs());
            }
            screened_total += c2.screened;
        }
    }
    assert!(screened_total > 0, "the screen never skipped a face");
}
