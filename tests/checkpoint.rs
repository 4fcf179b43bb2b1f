//! Checkpoint and restart (`output.checkpoint_every`, `hydrofrac run --restart`): a run
//! restarted from a checkpoint taken after fractures split continues bit for bit as the
//! uninterrupted run, for the explicit and the implicit flow scheme and a dry scene; bad
//! checkpoints (not one, truncated, corrupt, another version, another scenario or overrides)
//! are refused with a message that names the problem.

use hydrofrac::checkpoint;
use hydrofrac::scenario::Scenario;
use hydrofrac::sim::{Finish, Simulation};

use crate::support_cli as cli;
use crate::support_scenes as scenes;

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
    let mut whole = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    assert_eq!(whole.run(|_| {}).unwrap(), Finish::EndTime);
    let end = state_bits(&whole);

    let mut first = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
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

    let mut restarted = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    restarted.restore(state).unwrap();
    assert_eq!(restarted.step(), header.step);
    // Every saved field is restored: the restored simulation saves the same bytes (a state
    // field that a checkpoint captures and `restore` drops fails here).
    let (h, s) = restarted.checkpoint_state().unwrap();
    let again = checkpoint::encode(&h, &s).unwrap();
    assert!(
        again == bytes,
        "the restored state saves other bytes than the checkpoint"
    );
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

// ---------------------------------------------------------------------------------------------
// The binary: checkpoint files in the output folder, `--restart`, refusals.
// ---------------------------------------------------------------------------------------------

use cli::{run, stderr, summary, tmp};
use std::path::{Path, PathBuf};

fn manifest(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("hydrofrac-manifest.txt"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(String::from)
        .collect()
}

/// The coupled scene (implicit flow, 0.15 s: splits at about steps 4770, 5760, 6930, 7890 of
/// 8290) as a scenario file.
fn coupled_file(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let path = dir.join("coupled.ron");
    std::fs::write(
        &path,
        scenes::pumped_fracture(0.15, ", flow_scheme: Implicit"),
    )
    .unwrap();
    path
}

/// Summary values that describe the physics (timing, frames and checkpoint counts left out).
fn physics(s: &serde_json::Value) -> serde_json::Value {
    let mut s = s.clone();
    let o = s.as_object_mut().unwrap();
    for k in [
        "wall_s",
        "systems",
        "frames",
        "checkpoints",
        "restarted_from",
        // The output estimate of a restarted run counts the steps left.
        "output_estimate_bytes",
    ] {
        o.remove(k);
    }
    s
}

/// `checkpoint_every: Steps(2500)` writes checkpoint.ckpt (step 7500) and checkpoint.prev.ckpt
/// (step 5000), both in the manifest; `--restart` from the one at step 5000 (after the first
/// split) into another folder writes the uninterrupted run's series rows after step 5000
/// character for character (full-precision numbers), the same network.csv and the same summary
/// numbers.
#[test]
fn cli_restart_continues_series_and_summary_exactly() {
    let dir = tmp("restart");
    let sc = coupled_file(&dir);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = run(&[
        "run",
        sc.to_str().unwrap(),
        "--quiet",
        "--out",
        a.to_str().unwrap(),
        "--set",
        "output.checkpoint_every=Steps(2500)",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let listed = manifest(&a);
    for f in [checkpoint::FILE, checkpoint::PREV_FILE] {
        assert!(listed.iter().any(|l| l == f), "{f} not in the manifest");
    }
    let sa = summary(&a);
    assert_eq!(sa["checkpoints"]["written"], 3);
    assert!(sa["checkpoints"]["last_bytes"].as_u64().unwrap() > 1000);
    let (h, _) = checkpoint::read(&a.join(checkpoint::PREV_FILE)).unwrap();
    assert_eq!(h.step, 5000);
    let (h, _) = checkpoint::read(&a.join(checkpoint::FILE)).unwrap();
    assert_eq!(h.step, 7500);

    let ck = dir.join("at5000.ckpt");
    std::fs::copy(a.join(checkpoint::PREV_FILE), &ck).unwrap();
    let o = run(&[
        "run",
        sc.to_str().unwrap(),
        "--quiet",
        "--out",
        b.to_str().unwrap(),
        "--set",
        "output.checkpoint_every=Steps(2500)",
        "--restart",
        ck.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sb = summary(&b);
    assert_eq!(sb["restarted_from"]["step"], 5000);
    assert!(
        sb["splits"].as_u64().unwrap() > 1,
        "no split after the restart"
    );
    assert_eq!(physics(&sa), physics(&sb));
    let rows = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("timeseries.csv"))
            .unwrap()
            .lines()
            .map(String::from)
            .collect()
    };
    let (ra, rb) = (rows(&a), rows(&b));
    assert_eq!(ra[0], rb[0], "series header");
    let after: Vec<&String> = ra[1..]
        .iter()
        .filter(|r| r.split(',').next().unwrap().parse::<f64>().unwrap() > 5000.0)
        .collect();
    assert!(after.len() > 30);
    assert_eq!(after, rb[1..].iter().collect::<Vec<_>>());
    let net = |d: &Path| std::fs::read_to_string(d.join("network.csv")).unwrap();
    assert_eq!(net(&a), net(&b));
    // A second checkpoint cycle from the restarted run: step 7500 again, the same bytes but
    // for nothing (the state is the same state).
    let (ha, sa_) = checkpoint::read(&a.join(checkpoint::FILE)).unwrap();
    let (hb, sb_) = checkpoint::read(&b.join(checkpoint::FILE)).unwrap();
    assert_eq!(ha.step, hb.step);
    assert_eq!(
        checkpoint::encode(&ha, &sa_).unwrap(),
        checkpoint::encode(&hb, &sb_).unwrap(),
        "the restarted run's checkpoint at step 7500 differs from the first run's"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad checkpoints are refused with one line naming the problem and a non-zero exit, before
/// the output folder is touched.
#[test]
fn cli_refuses_bad_checkpoints() {
    let dir = tmp("refuse");
    let sc = coupled_file(&dir);
    let a = dir.join("a");
    let o = run(&[
        "run",
        sc.to_str().unwrap(),
        "--quiet",
        "--out",
        a.to_str().unwrap(),
        "--set",
        "time.end.Time=0.03",
        "--set",
        "output.checkpoint_every=Time(0.01)",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Time(0.01) over 0.03 s: at 0.01 and 0.02 s (not at the end).
    assert_eq!(summary(&a)["checkpoints"]["written"], 2);
    let good = std::fs::read(a.join(checkpoint::FILE)).unwrap();
    let (h, _) = checkpoint::decode(&good).unwrap();
    assert!(
        h.time >= 0.02 && h.time < 0.021,
        "checkpoint at t = {}",
        h.time
    );

    let bad = |name: &str, bytes: &[u8]| -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let mut flipped = good.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x40;
    let mut version = good.clone();
    version[8..12].copy_from_slice(&99u32.to_le_bytes());
    let cases: Vec<(PathBuf, Vec<&str>, &str)> = vec![
        (sc.clone(), vec![], "not a hydrofrac checkpoint"),
        (
            bad("truncated.ckpt", &good[..good.len() / 2]),
            vec![],
            "truncated",
        ),
        (bad("flipped.ckpt", &flipped), vec![], "corrupt"),
        (bad("version.ckpt", &version), vec![], "format version 99"),
        (
            a.join(checkpoint::FILE),
            vec!["--set", "material.young=3e10"],
            "written for scenario 'coupled'",
        ),
        (
            a.join(checkpoint::FILE),
            vec!["--disable", "damping"],
            "--disable list differ",
        ),
    ];
    let before = manifest(&a);
    for (file, extra, expect) in cases {
        let mut args = vec![
            "run",
            sc.to_str().unwrap(),
            "--quiet",
            "--out",
            a.to_str().unwrap(),
            "--set",
            "time.end.Time=0.03",
            "--restart",
            file.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = run(&args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{expect}: accepted");
        assert!(e.contains(expect), "expected '{expect}' in: {e}");
        assert!(!e.contains("panicked"), "{e}");
        assert_eq!(e.trim().lines().count(), 1, "not one line: {e}");
        assert_eq!(manifest(&a), before, "{expect}: the output folder changed");
    }
    // Another scenario altogether (the notched plate) is refused by name.
    let notch = dir.join("notch.ron");
    std::fs::write(&notch, scenes::notched_plate("Some(3e6)")).unwrap();
    let o = run(&[
        "run",
        notch.to_str().unwrap(),
        "--quiet",
        "--out",
        dir.join("n").to_str().unwrap(),
        "--restart",
        a.join(checkpoint::FILE).to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("written for scenario 'coupled'"),
        "{}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run stopped between steps (the SIGINT/SIGTERM path) with checkpointing on writes a
/// checkpoint of the step it reached; the run restarted from it ends bit for bit as the
/// uninterrupted one.
#[test]
fn interrupted_run_writes_a_checkpoint_to_resume_from() {
    use std::sync::atomic::Ordering;
    let sc = pumped(0.12, ", flow_scheme: Implicit")
        .with_overrides(&["output.checkpoint_every=Steps(1000000)".into()])
        .unwrap();
    let mut whole = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    whole.run(|_| {}).unwrap();
    let end = state_bits(&whole);

    let dir = tmp("interrupt");
    let mut first = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    let out = hydrofrac::output::Outputs::create(
        &dir,
        &first.params().output.fields,
        &first.series_columns(),
    )
    .unwrap();
    first.set_output(out);
    let stop = hydrofrac::sim::StopFlag::default();
    first.set_stop(stop.clone());
    while first.fracture().splits == 0 {
        first.step_once().unwrap();
    }
    let k = first.step();
    stop.store(15, Ordering::SeqCst);
    assert_eq!(first.run(|_| {}).unwrap(), Finish::Interrupted);
    assert_eq!(first.interrupted_by(), Some(15));
    assert!(manifest(&dir).iter().any(|l| l == checkpoint::FILE));
    let (h, state) = checkpoint::read(&dir.join(checkpoint::FILE)).unwrap();
    assert_eq!(h.step, k);
    checkpoint::check_scenario(&dir, &h, &sc, &[]).unwrap();

    let mut restarted = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    restarted.restore(state).unwrap();
    assert_eq!(restarted.run(|_| {}).unwrap(), Finish::EndTime);
    assert_same(
        &end,
        &state_bits(&restarted),
        "the run restarted after the interruption",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The quasi-static scheme restarts from the same state but not to the bit: its Cholesky
/// factor, the low-rank updates of W = K_T^-1 G and the joint geometry of the last
/// refactorisation are not in the checkpoint, so the restarted run refactorises at its first
/// step and its Newton iterates differ at round-off; both converge to the solver's tolerance
/// (1e-10). Checked here: the same steps and splits, displacements and pressures to 1e-9 of
/// their largest values (measured: 2e-12).
#[test]
fn quasi_static_restart_agrees_to_solver_tolerance() {
    let sc = Scenario::parse(
        &scenes::pumped_fracture(0.13, ", solid_scheme: QuasiStatic"),
        "qs.ron",
    )
    .unwrap();
    let mut whole = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    whole.run(|_| {}).unwrap();
    let mut first = Simulation::new(sc.clone().validate().unwrap(), &[]).unwrap();
    while first.fracture().splits == 0 {
        first.step_once().unwrap();
    }
    first.step_once().unwrap();
    let (h, state) = first.checkpoint_state().unwrap();
    let bytes = checkpoint::encode(&h, &state).unwrap();
    let (_, state) = checkpoint::decode(&bytes).unwrap();
    let mut restarted = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    restarted.restore(state).unwrap();
    restarted.run(|_| {}).unwrap();
    assert_eq!(restarted.step(), whole.step());
    assert_eq!(restarted.fracture().splits, whole.fracture().splits);
    assert!(whole.fracture().splits > first.fracture().splits);
    let rel = |a: &[f64], b: &[f64]| {
        let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    };
    let flat = |s: &Simulation| s.solid().u.iter().flatten().copied().collect::<Vec<f64>>();
    let du = rel(&flat(&whole), &flat(&restarted));
    let (pw, pr) = (&whole.flow().unwrap().view, &restarted.flow().unwrap().view);
    let dp = rel(&pw.pressure, &pr.pressure);
    println!("quasi-static restart: max |du| / max |u| = {du:.2e}, max |dP| / max P = {dp:.2e}");
    assert!(du < 1e-9 && dp < 1e-9, "du {du:.2e}, dP {dp:.2e}");
}

/// `output.checkpoint_every` must be a positive step count or a positive finite time; old
/// scenarios (without it) stay valid and write no checkpoint.
#[test]
fn checkpoint_every_is_validated() {
    let base = pumped(0.01, "");
    assert_eq!(base.output.checkpoint_every, None);
    base.clone().validate().unwrap();
    for (set, why) in [
        ("output.checkpoint_every=Steps(0)", "at least 1"),
        ("output.checkpoint_every=Time(0.0)", "> 0 s"),
        ("output.checkpoint_every=Time(-1.0)", "> 0 s"),
        (
            "output.checkpoint_every=Time(1e999)",
            "output.checkpoint_every",
        ),
    ] {
        let e = match base.clone().with_overrides(&[set.into()]) {
            Err(e) => e.to_string(),
            Ok(sc) => sc.validate().unwrap_err().to_string(),
        };
        assert!(
            e.contains("output.checkpoint_every") && e.contains(why),
            "{set}: {e}"
        );
    }
    let ok = base
        .with_overrides(&["output.checkpoint_every=Time(0.5)".into()])
        .unwrap();
    ok.validate().unwrap();
}
