//! Checkpoint and restart (`output.checkpoint_every`, `hydrofrac run --restart`): a run
//! restarted from a checkpoint taken after fractures split continues bit for bit as the
//! uninterrupted run, for the explicit and the implicit flow scheme and a dry scene; bad
//! checkpoints (not one, truncated, corrupt, another version, another scenario or overrides)
//! are refused with a message that names the problem.

use hydrofrac::checkpoint;
use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};

#[path = "support/scenes.rs"]
mod scenes;

/// Everything a restart must reproduce, as bits: node displacements and velocities, joint
/// contact state, element stresses, cell pressures, apertures, excess masses and their Kahan
/// compensations, boundary volumes, the clock, the split count and the series row.
fn state_bits(sim: &Simulation) -> Vec<(&'static str, Vec<u64>)> {
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let pairs = |x: &[[f64; 2]]| x.iter().flat_map(|v| v.map(f64::to_bits)).collect();
    let s = sim.solid();
    let mut out = vec![
        ("u", pairs(&s.u)),
        ("v", pairs(&s.v)),
        (
            "stress",
            s.stress.iter().flat_map(|v| v.map(f64::to_bits)).collect(),
        ),
        (
            "joints",
            s.joint_state
                .iter()
                .flat_map(|j| {
                    [
                        j.normal_force.to_bits(),
                        j.shear_force.to_bits(),
                        j.last_shear_offset.to_bits(),
                        j.opening.to_bits(),
                        j.sliding as u64,
                    ]
                })
                .collect(),
        ),
        (
            "clock",
            vec![
                sim.step(),
                sim.time().to_bits(),
                sim.dt().to_bits(),
                sim.fracture().splits as u64,
                sim.fracture().opened_edges as u64,
            ],
        ),
        ("series", bits(&sim.series_values())),
    ];
    if let Some(f) = sim.flow() {
        let v = &f.view;
        out.push(("pressure", bits(&v.pressure)));
        out.push(("aperture", bits(&v.aperture)));
        out.push(("excess", bits(&v.excess)));
        out.push(("excess_comp", bits(&v.excess_comp)));
        out.push((
            "bc volumes",
            v.bcs
                .iter()
                .flat_map(|b| [b.volume_in, b.volume_out, b.comp_in, b.comp_out])
                .map(f64::to_bits)
                .collect(),
        ));
    }
    out
}

fn assert_same(a: &[(&str, Vec<u64>)], b: &[(&str, Vec<u64>)], what: &str) {
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(b) {
        assert_eq!(x.len(), y.len(), "{what}: {name}: lengths differ");
        let first = x.iter().zip(y).position(|(p, q)| p != q);
        assert!(
            first.is_none(),
            "{what}: {name} differs from the uninterrupted run at index {first:?} of {}",
            x.len()
        );
    }
}

/// Run `sc` uninterrupted; run it again, take a checkpoint (through the file format's bytes)
/// at the first step after `after_splits` splits plus `extra` steps, restore it into a fresh
/// simulation and run that to the end: every state bit must match. Returns (checkpoint step,
/// splits at it, splits at the end, checkpoint bytes).
fn restart_matches(sc: &Scenario, after_splits: usize, extra: u64) -> (u64, usize, usize, usize) {
    let mut whole = Simulation::new(sc.clone(), &[]).unwrap();
    assert_eq!(whole.run(|_| {}).unwrap(), Finish::EndTime);
    let end = state_bits(&whole);

    let mut first = Simulation::new(sc.clone(), &[]).unwrap();
    while first.fracture().splits < after_splits {
        first.step_once().unwrap();
        assert!(first.finish().is_none(), "no split before the end");
    }
    for _ in 0..extra {
        first.step_once().unwrap();
    }
    assert!(first.finish().is_none(), "checkpoint step past the end");
    let (header, state) = first.checkpoint_state().unwrap();
    let bytes = checkpoint::encode(&header, &state).unwrap();
    let (header, state) = checkpoint::decode(&bytes).unwrap();
    assert_eq!(header.step, first.step());
    let splits_at = first.fracture().splits;
    // The checkpointed run itself goes on unchanged by the checkpoint.
    assert_eq!(first.run(|_| {}).unwrap(), Finish::EndTime);
    assert_same(&end, &state_bits(&first), "the checkpointed run");

    let mut restarted = Simulation::new(sc.clone(), &[]).unwrap();
    restarted.restore(state).unwrap();
    assert_eq!(restarted.step(), header.step);
    assert_eq!(restarted.run(|_| {}).unwrap(), Finish::EndTime);
    assert_same(&end, &state_bits(&restarted), "the restarted run");
    (header.step, splits_at, whole.fracture().splits, bytes.len())
}

/// The notched plate pulled apart (no flow network), for 40 ms.
fn notch() -> Scenario {
    Scenario::parse(&scenes::notched_plate("Some(3e6)"), "notch.ron")
        .unwrap()
        .with_overrides(&["time.end=Time(0.04)".into()])
        .unwrap()
}

fn pumped(end: f64, extra: &str) -> Scenario {
    Scenario::parse(&scenes::pumped_fracture(end, extra), "coupled.ron").unwrap()
}

#[test]
fn restart_is_bit_identical_across_splits_explicit_flow() {
    // Splits at about 0.086 s and 0.104 s.
    let sc = pumped(0.11, ", flow_scheme: Explicit");
    let (k, at, total, bytes) = restart_matches(&sc, 1, 50);
    println!("explicit: checkpoint at step {k} after {at} splits, {total} at the end, {bytes} B");
    assert!(
        total > at,
        "no split after the checkpoint ({at} before, {total} at the end)"
    );
}

#[test]
fn restart_is_bit_identical_across_splits_implicit_flow() {
    // Splits at about 0.086, 0.104, 0.125 and 0.143 s.
    let sc = pumped(0.15, ", flow_scheme: Implicit");
    let (k, at, total, bytes) = restart_matches(&sc, 2, 50);
    println!("implicit: checkpoint at step {k} after {at} splits, {total} at the end, {bytes} B");
    assert!(
        total > at,
        "no split after the checkpoint ({at} before, {total} at the end)"
    );
}

#[test]
fn restart_is_bit_identical_dry_notched_plate() {
    let (k, at, total, bytes) = restart_matches(&notch(), 3, 5);
    println!("dry: checkpoint at step {k} after {at} splits, {total} at the end, {bytes} B");
    assert!(
        total > at,
        "no split after the checkpoint ({at} before, {total} at the end)"
    );
}
