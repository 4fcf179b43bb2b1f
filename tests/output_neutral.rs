//! Writing outputs never changes the physics: the same scenario run without an output folder
//! and with a frame (solid, network, joint state: each one a sync into the components) after
//! every step takes the same number of steps and ends in the same state, to the bit. Four
//! scenes that sync for frames: a frictional joint relaxing to static equilibrium, an inclined
//! crack on a graded mesh (daughters of unequal mass), a notched plate that cracks (splits,
//! view rebuilds), and a coupled pump-driven fracture (flow view, joint stresses, positions
//! refreshed for the frames, the fracture-pressure figure).

use hydrofrac::output::Outputs;
use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;

use crate::support_cli as cli;
use crate::support_scenes as scenes;

/// Steps, displacement and velocity bits, fluid excess-mass bits and the split count of a run.
type Fingerprint = (u64, Vec<u64>, Vec<u64>, Vec<u64>, usize);

fn run(text: &str, frames: bool, tag: &str) -> Fingerprint {
    let mut sc = Scenario::parse(text, "neutral.ron").unwrap();
    let dir = cli::tmp(tag);
    if frames {
        sc.output.frame_every = 1;
        sc.output.series_every = 1;
        sc.output.figure_times = vec![0.004];
    }
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    if frames {
        let out = Outputs::create(
            &dir,
            &sim.params().output.fields.clone(),
            &sim.series_columns(),
        )
        .unwrap();
        sim.set_output(out);
    }
    sim.run(|_| {}).unwrap();
    if frames {
        let o = sim.output().unwrap();
        assert!(o.frames as u64 >= sim.step(), "{} frames", o.frames);
        let _ = std::fs::remove_dir_all(&dir);
    }
    let bits = |v: &[[f64; 2]]| v.iter().flat_map(|x| x.map(f64::to_bits)).collect();
    let flow = sim
        .flow()
        .map(|f| f.view.excess.iter().map(|e| e.to_bits()).collect())
        .unwrap_or_default();
    (
        sim.step(),
        bits(&sim.solid().u),
        bits(&sim.solid().v),
        flow,
        sim.fracture().splits,
    )
}

fn same_with_and_without_frames(text: &str, tag: &str) -> Fingerprint {
    let a = run(text, false, tag);
    let b = run(text, true, tag);
    assert_eq!(a.0, b.0, "{tag}: steps without / with frames");
    assert!(
        a.1 == b.1 && a.2 == b.2,
        "{tag}: solid state differs with frames"
    );
    assert!(a.3 == b.3, "{tag}: fluid state differs with frames");
    assert_eq!(a.4, b.4, "{tag}: splits");
    a
}

#[test]
fn frictional_static_run_is_the_same_with_frames() {
    let text = &scenes::friction_block(4.6e6, "Static(tol: 1e-9)");
    let (steps, ..) = same_with_and_without_frames(text, "friction");
    assert!(steps > 100, "{steps} steps");
}

/// The case that showed the drift (145,263 vs 144,158 steps on a longer run): a closed crack
/// inclined on a graded mesh, split at setup into daughters of unequal mass, relaxing under
/// compression with friction.
#[test]
fn inclined_crack_on_a_graded_mesh_is_the_same_with_frames() {
    let text = scenes::INCLINED_CRACK;
    same_with_and_without_frames(text, "inclined");
}

#[test]
fn cracking_plate_is_the_same_with_frames() {
    let text = &scenes::notched_plate("Some(4e6)");
    let (.., splits) = same_with_and_without_frames(text, "notch");
    assert!(splits > 0, "the plate should crack");
}

#[test]
fn coupled_fracture_is_the_same_with_frames() {
    let text = &scenes::pumped_fracture(0.01, ", flow_scheme: Implicit");
    let (_, _, _, excess, _) = same_with_and_without_frames(text, "coupled");
    assert!(!excess.is_empty());
}
