//! `hydrofrac sweep` (issue 37, docs/sweep.md), through the binary as a user runs it: a plan
//! is reproducible and validated before anything runs; the local runner runs every member in
//! its own folder, records a failed one and goes on, skips finished members and continues an
//! interrupted one from its checkpoint; collect tabulates inputs and quantities; a Slurm job
//! array gives the same table as the local runner; bad sweep files and folders are refused in
//! one line. The members are `scenarios/flow_single_fracture.ron` (0.05 s each).

use crate::support_cli as cli;

use cli::{assert_refused, bin, root, stderr, tmp, tmp_dir};
use std::path::{Path, PathBuf};
use std::process::Output;

/// A sweep file `sweep.ron` in a fresh folder `name`, over `scenarios/flow_single_fracture.ron`
/// with `vary` (RON, inside `vary: [...]`) and `extra` fields.
fn sweep_file(name: &str, vary: &str, extra: &str) -> PathBuf {
    let dir = tmp_dir(name);
    let base = root().join("scenarios/flow_single_fracture.ron");
    let text = format!(
        "// a test sweep\nSweep(\n    base: {:?},\n    vary: [\n{vary}\n    ],\n{extra}\n)\n",
        base.display().to_string()
    );
    let path = dir.join("sweep.ron");
    std::fs::write(&path, text).unwrap();
    path
}

/// Four members: two viscosities times two cell lengths; the outlet's rate and the steps.
const FOUR: &str = r#"        (path: "fluid.viscosity", values: List([8.9e-4, 1.2e-3])),
        (path: "network.cell_length", values: Range(start: 0.5, end: 1.0, count: 2)),"#;
const COLLECT: &str = r#"    collect: ["flow.boundaries[name=outlet].rate", "steps"],"#;

fn sweep(args: &[&str], dir: &Path) -> Output {
    bin().arg("sweep").args(args).arg(dir).output().unwrap()
}

fn plan(file: &Path, out: &Path) -> Output {
    bin()
        .args(["sweep", "plan"])
        .arg(file)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

fn ok(o: &Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Every file under `dir` (relative path, bytes), sorted.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

fn read(p: impl AsRef<Path>) -> String {
    std::fs::read_to_string(p.as_ref()).unwrap_or_else(|e| panic!("{}: {e}", p.as_ref().display()))
}

#[test]
fn planning_twice_gives_the_same_bytes_and_members_run_as_planned() {
    let file = sweep_file("plan", FOUR, COLLECT);
    let (a, b) = (tmp("plan-a"), tmp("plan-b"));
    ok(&plan(&file, &a));
    ok(&plan(&file, &b));
    let (fa, fb) = (files(&a), files(&b));
    assert!(
        fa.len() >= 6,
        "{:?}",
        fa.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert_eq!(fa, fb, "two plans of one sweep differ");
    // The shipped example (seeded random draws, enum values as text): the same bytes too.
    let example = root().join("scenarios/sweep_example.ron");
    let (c, d) = (tmp("plan-c"), tmp("plan-d"));
    assert!(ok(&plan(&example, &c)).contains("planned 12 members"));
    ok(&plan(&example, &d));
    assert_eq!(
        files(&c),
        files(&d),
        "two plans of sweep_example.ron differ"
    );
    // Planning again into the same folder: allowed (it has the plan's manifest), same bytes.
    ok(&plan(&file, &a));
    assert_eq!(files(&a), fb);
    let p: serde_json::Value = serde_json::from_str(&read(a.join("plan.json"))).unwrap();
    let m = p["members"].as_array().unwrap();
    assert_eq!(m.len(), 4);
    // Product: the last entry changes fastest.
    assert_eq!(m[1]["set"][0], "fluid.viscosity=0.00089");
    assert_eq!(m[1]["set"][1], "network.cell_length=1.0");
    assert_eq!(m[2]["values"], serde_json::json!([1.2e-3, 0.5]));
    assert_eq!(m[3]["fingerprint"].as_str().unwrap().len(), 16);
    // The member's scenario is an ordinary scenario: `hydrofrac run` runs it as it is.
    let scenario = a.join("members/0003/scenario.ron");
    let s = cli::run_ok(&scenario, &tmp("plan-run"), &[]);
    assert_eq!(s["status"], "ok");
}

#[test]
fn local_runner_records_a_failure_goes_on_and_skips_finished_members() {
    let file = sweep_file("local", FOUR, COLLECT);
    let dir = tmp("local-dir");
    ok(&plan(&file, &dir));
    // Member 2's scenario is broken after the plan: it fails when it runs.
    std::fs::write(dir.join("members/0002/scenario.ron"), "(name: ").unwrap();
    let o = bin()
        .args(["sweep", "run", "--jobs", "2", "--quiet"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_refused(&o, &["1 of 4 members failed", "members 2"]);
    for id in [0, 1, 3] {
        let s = read(dir.join(format!("members/000{id}/status.json")));
        assert!(s.contains("\"status\": \"ok\""), "{s}");
        assert!(
            dir.join(format!("members/000{id}/run/summary.json"))
                .is_file()
        );
    }
    let s = read(dir.join("members/0002/status.json"));
    assert!(s.contains("\"status\": \"failed\""), "{s}");
    // Again: nothing finished runs again, the failed member is not retried.
    let t0 = std::fs::metadata(dir.join("members/0000/run/summary.json"))
        .unwrap()
        .modified()
        .unwrap();
    let out = ok(&bin()
        .args(["sweep", "run", "--quiet"])
        .arg(&dir)
        .output()
        .unwrap());
    assert!(
        out.contains("0 run now, 3 finished before, 0 failed now, 1 failed before"),
        "{out}"
    );
    let t1 = std::fs::metadata(dir.join("members/0000/run/summary.json"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(t0, t1, "a finished member ran again");
    // Collect: three rows of values, the failed member with its error, and the figures.
    let out = ok(&sweep(&["collect"], &dir));
    assert!(
        out.contains("4 members: 3 ok, 1 failed, 0 not run"),
        "{out}"
    );
    let csv = read(dir.join("collect/table.csv"));
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "member,status,fluid.viscosity,network.cell_length,flow.boundaries[name=outlet].rate,steps,error"
    );
    assert_eq!(lines.len(), 5, "{csv}");
    assert!(lines[1].starts_with("0,ok,0.00089,0.5,"), "{csv}");
    assert!(lines[3].starts_with("2,failed,0.0012,0.5,,,"), "{csv}");
    assert!(lines[3].contains("scenario.ron"), "{csv}");
    // The outlet's rate is the cubic law's: a^3 dp / (12 mu L) with a = 1e-4 m, dp = 2 MPa,
    // L = 10 m (to the steady tolerance).
    let rate: f64 = lines[1].split(',').nth(4).unwrap().parse().unwrap();
    let exact = 1e-12 * 2e6 / (12.0 * 8.9e-4 * 10.0);
    assert!(
        (rate.abs() - exact).abs() < 1e-6 * exact,
        "rate {rate}, cubic law {exact}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&read(dir.join("collect/table.json"))).unwrap();
    assert_eq!(json["failed"][0]["member"], 2);
    assert!(!read(dir.join("collect/table.json")).contains("null"));
    assert!(read(dir.join("collect/timing.csv")).starts_with("member,status,wall_s\n"));
    for f in [
        "hist_steps.png",
        "hist_flow_boundaries_name_outlet__rate.png",
        "scatter_steps_vs_network_cell_length.png",
        "scatter_flow_boundaries_name_outlet__rate_vs_fluid_viscosity.png",
    ] {
        assert!(dir.join("collect").join(f).is_file(), "{f} not drawn");
    }
}

#[test]
fn selected_members_run_in_the_order_given_each_on_its_share_of_threads() {
    let file = sweep_file("members", FOUR, COLLECT);
    let dir = tmp("members-dir");
    ok(&plan(&file, &dir));
    // `--members 3-1`: members 3, 2, 1 in that order (one line each without a terminal),
    // member 0 left as it is.
    let o = bin()
        .args(["sweep", "run", "--jobs", "1", "--members", "3-1"])
        .arg(&dir)
        .output()
        .unwrap();
    let out = ok(&o);
    assert!(
        out.contains("3 run now, 0 finished before, 0 failed now, 0 failed before (not retried), 0 not run (1 not selected by --members)"),
        "{out}"
    );
    let err = stderr(&o);
    let order: Vec<&str> = err
        .lines()
        .filter_map(|l| l.strip_prefix("member ")?.split(':').next())
        .collect();
    assert_eq!(order, ["3", "2", "1"], "{err}");
    assert!(!dir.join("members/0000/status.json").exists());
    // Bad lists are refused before anything runs.
    for (spec, needle) in [
        ("4", "member 4 does not exist (the plan has members 0 to 3)"),
        ("1-2,2", "member 2 is listed twice"),
        ("a", "`a` in `a` is not a member id"),
        ("1,,2", "an empty entry"),
    ] {
        let o = bin()
            .args(["sweep", "run", "--members", spec])
            .arg(&dir)
            .output()
            .unwrap();
        assert_refused(&o, &[needle]);
        assert!(!dir.join("members/0000/status.json").exists());
    }
    let o = bin()
        .args(["sweep", "run", "--threads", "0"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_refused(&o, &["--threads 0: at least 1"]);
    // Each member's process gets its share of the threads: a stand-in executable records
    // the RAYON_NUM_THREADS it was given (and fails, so nothing is recorded as done).
    let exe = dir.join("stand-in.sh");
    std::fs::write(
        &exe,
        "#!/bin/sh\necho \"$4 ${RAYON_NUM_THREADS:-unset}\" >> \"$3/threads.txt\"\nexit 1\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
    let opts = hydrofrac::sweep::LocalOptions {
        jobs: 1,
        retry_failed: false,
        quiet: true,
        stop: None,
        exe: exe.clone(),
        members: Some("0".into()),
        threads: Some(3),
    };
    let s = hydrofrac::sweep::run_local(&dir, &opts).unwrap();
    assert_eq!((s.failed.len(), s.not_selected), (1, 3));
    assert_eq!(read(dir.join("threads.txt")), "0 3\n");
}

/// `scripts/study-record.sh` (docs/study.md, "The record"): finished members saved from one
/// sweep folder and restored into a fresh plan are skipped there, and the record itself
/// collects to the same table rows.
#[test]
fn a_study_record_carries_finished_members_to_a_fresh_plan() {
    let file = sweep_file("record", FOUR, COLLECT);
    let (a, rec, b) = (tmp("record-a"), tmp("record-rec"), tmp("record-b"));
    ok(&plan(&file, &a));
    ok(&bin()
        .args(["sweep", "run", "--quiet", "--members", "0,2"])
        .arg(&a)
        .output()
        .unwrap());
    let script = root().join("scripts/study-record.sh");
    let run = |args: &[&std::ffi::OsStr]| {
        let o = std::process::Command::new("bash")
            .arg(&script)
            .args(args)
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o),
        )
    };
    let (good, out) = run(&[
        "save".as_ref(),
        a.as_os_str(),
        rec.as_os_str(),
        "abc1234".as_ref(),
    ]);
    assert!(good && out.contains("recorded 2 finished members"), "{out}");
    assert_eq!(
        read(rec.join("members.txt")),
        "0000 abc1234\n0002 abc1234\n"
    );
    // A fresh plan of the same sweep takes the record; the next run runs only the others.
    ok(&plan(&file, &b));
    let (good, out) = run(&["restore".as_ref(), rec.as_os_str(), b.as_os_str()]);
    assert!(good && out.contains("restored 2 members"), "{out}");
    let out = ok(&sweep(&["run", "--quiet"], &b));
    assert!(out.contains("2 run now, 2 finished before"), "{out}");
    // The record collects as the folder it came from (same rows for its members).
    ok(&sweep(&["collect", "--no-figures"], &rec));
    ok(&sweep(&["collect", "--no-figures"], &a));
    let (ra, rr) = (
        read(a.join("collect/table.csv")),
        read(rec.join("collect/table.csv")),
    );
    assert_eq!(ra, rr);
    assert_eq!(ra.lines().filter(|l| l.contains(",ok,")).count(), 2, "{ra}");
    // A record of another plan is refused.
    let other = sweep_file(
        "record-other",
        FOUR.replace("8.9e-4", "9e-4").as_str(),
        COLLECT,
    );
    let c = tmp("record-c");
    ok(&plan(&other, &c));
    let (good, out) = run(&["restore".as_ref(), rec.as_os_str(), c.as_os_str()]);
    assert!(!good && out.contains("planned from other files"), "{out}");
}

#[test]
fn pooled_members_are_summarised_by_group() {
    // Pooled over the cell length, the four members make two groups, one per viscosity; the
    // steady rate does not depend on the cell length, so each group's min, median and max
    // are its viscosity's cubic-law rate.
    let extra = format!("{COLLECT}\n    pool: [\"network.cell_length\"],");
    let file = sweep_file("pool", FOUR, &extra);
    let dir = tmp("pool-dir");
    ok(&plan(&file, &dir));
    let p: serde_json::Value = serde_json::from_str(&read(dir.join("plan.json"))).unwrap();
    assert_eq!(p["pool"], serde_json::json!(["network.cell_length"]));
    // Not --quiet, and stderr is not a terminal: one line per member instead of a bar.
    let o = bin()
        .args(["sweep", "run", "--jobs", "2"])
        .arg(&dir)
        .output()
        .unwrap();
    ok(&o);
    let err = stderr(&o);
    assert_eq!(err.matches(": ok in ").count(), 4, "{err}");
    assert!(
        err.contains("member 3: ok in") && err.contains("(4 of 4 members done)"),
        "{err}"
    );
    ok(&sweep(&["collect"], &dir));
    let csv = read(dir.join("collect/groups.csv"));
    let lines: Vec<&str> = csv.lines().collect();
    let q = "flow.boundaries[name=outlet].rate";
    let head = format!(
        "fluid.viscosity,members,ok,{q}:n,{q}:nonzero,{q}:min,{q}:median,{q}:max,\
         steps:n,steps:nonzero,steps:min,steps:median,steps:max"
    );
    assert_eq!(lines[0], head);
    assert_eq!(lines.len(), 3, "{csv}");
    for (line, mu) in lines[1..].iter().zip([8.9e-4, 1.2e-3]) {
        let c: Vec<&str> = line.split(',').collect();
        assert_eq!(c[0].parse::<f64>().unwrap(), mu, "{line}");
        assert_eq!(&c[1..5], ["2", "2", "2", "1"], "{line}");
        let exact = 1e-12 * 2e6 / (12.0 * mu * 10.0);
        for cell in &c[5..8] {
            let r: f64 = cell.parse().unwrap();
            assert!(
                (r.abs() - exact).abs() < 1e-6 * exact,
                "{line}: {r} vs {exact}"
            );
        }
        let (lo, mid, hi): (f64, f64, f64) = (
            c[10].parse().unwrap(),
            c[11].parse().unwrap(),
            c[12].parse().unwrap(),
        );
        assert!(lo <= mid && mid <= hi && lo > 0.0, "{line}");
    }
    assert!(dir.join("collect/groups_steps.png").is_file());
    // A pooled path that is not varied is refused before anything is written.
    refused_plan(
        "pool-bad",
        FOUR,
        &format!("{COLLECT}\n    pool: [\"fluid.density\"],"),
        &["pool[0] (fluid.density)", "not a varied path"],
    );
}

#[test]
fn a_value_every_member_leaves_out_is_a_warning_a_misspelt_path_an_error() {
    // `flow.boundaries[name=outlet].ratio` is not in any summary, but its parent is: the runs
    // left the value out (as a ratio against a zero rate is), so collect warns and goes on;
    // `flow.boundarys.0.rate` leaves the document at its first key: a misspelt path, refused.
    let run = |name: &str, q: &str| {
        let extra = format!("    collect: [\"steps\", \"{q}\"],");
        let file = sweep_file(name, FOUR, &extra);
        let dir = tmp(&format!("{name}-dir"));
        ok(&plan(&file, &dir));
        ok(&bin()
            .args(["sweep", "run", "--jobs", "2", "--quiet"])
            .arg(&dir)
            .output()
            .unwrap());
        (sweep(&["collect"], &dir), dir)
    };
    let (o, dir) = run("leaf", "flow.boundaries[name=outlet].ratio");
    let out = ok(&o);
    assert!(out.contains("4 members: 4 ok"), "{out}");
    let err = stderr(&o);
    assert!(
        err.contains("flow.boundaries[name=outlet].ratio` is missing in 4 of 4"),
        "{err}"
    );
    let csv = read(dir.join("collect/table.csv"));
    assert!(csv.lines().nth(1).unwrap().ends_with(",,"), "{csv}");
    let (o, _) = run("typo", "flow.boundarys.0.rate");
    assert_refused(
        &o,
        &["flow.boundarys.0.rate", "is in no member's summary.json"],
    );
}

#[test]
fn an_interrupted_member_continues_from_its_checkpoint() {
    let vary = r#"        (path: "output.checkpoint_every", values: List(["Steps(100)"])),"#;
    let file = sweep_file("ckpt", vary, COLLECT);
    let dir = tmp("ckpt-dir");
    ok(&plan(&file, &dir));
    let member = |quiet: &str| {
        bin()
            .args(["sweep", "member"])
            .arg(&dir)
            .args(["0", quiet])
            .output()
            .unwrap()
    };
    assert!(ok(&member("--quiet")).is_empty());
    let run = dir.join("members/0000/run");
    let first: serde_json::Value = serde_json::from_str(&read(run.join("summary.json"))).unwrap();
    assert!(
        run.join("checkpoint.ckpt").is_file(),
        "no checkpoint written"
    );
    // Finished: not run again.
    let again = bin()
        .args(["sweep", "member"])
        .arg(&dir)
        .arg("0")
        .output()
        .unwrap();
    assert!(ok(&again).contains("member 0: finished before"));
    // Killed before it recorded its outcome: the runner continues it from its checkpoint.
    std::fs::remove_file(dir.join("members/0000/status.json")).unwrap();
    ok(&bin()
        .args(["sweep", "run", "--quiet"])
        .arg(&dir)
        .output()
        .unwrap());
    let status = read(dir.join("members/0000/status.json"));
    assert!(status.contains("\"restarted\": true"), "{status}");
    let second: serde_json::Value = serde_json::from_str(&read(run.join("summary.json"))).unwrap();
    assert!(
        second["restarted_from"]["bit_identical"] == true,
        "{second}"
    );
    for k in ["steps", "time", "residual"] {
        assert_eq!(first[k], second[k], "{k}");
    }
    assert_eq!(first["flow"]["boundaries"], second["flow"]["boundaries"]);
}

/// The error line of a refused `sweep plan` of a sweep file with `vary` and `extra`; the
/// folder is not created.
fn refused_plan(name: &str, vary: &str, extra: &str, needles: &[&str]) {
    let file = sweep_file(name, vary, extra);
    let out = tmp(&format!("{name}-out"));
    let o = plan(&file, &out);
    assert_refused(&o, needles);
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    assert!(!out.exists(), "{name}: the folder was created");
}

#[test]
fn bad_sweeps_are_refused_in_one_line_before_anything_runs() {
    // An unknown path: the entry's line and column, the fields there.
    refused_plan(
        "bad-path",
        r#"        (path: "fluid.viscosty", values: List([1e-3])),"#,
        "",
        &[
            "sweep.ron:5:16",
            "member 0",
            "no field `viscosty`",
            "viscosity",
        ],
    );
    // A value of the wrong type.
    refused_plan(
        "bad-type",
        r#"        (path: "network.cell_length", values: List(["long"])),"#,
        "",
        &[
            "member 0",
            "network.cell_length=long",
            "cell_length",
            "invalid type: string",
        ],
    );
    // A value out of its range (the scenario's own validation).
    refused_plan(
        "bad-range",
        r#"        (path: "fluid.viscosity", values: List([1e-3, -1.0])),"#,
        "",
        &["member 1", "fluid.viscosity=-1.0", "viscosity"],
    );
    // Empty sweeps.
    refused_plan("empty", "", "", &["sweep.ron:", "vary", "an empty sweep"]);
    refused_plan(
        "empty-list",
        r#"        (path: "fluid.viscosity", values: List([])),"#,
        "",
        &[
            "sweep.ron:5:16",
            "vary[0] (fluid.viscosity)",
            "an empty sweep",
        ],
    );
    // Bad values of the sweep itself.
    refused_plan(
        "bad-range-spec",
        r#"        (path: "fluid.viscosity", values: Uniform(low: 2e-3, high: 1e-3, count: 3, seed: 1)),"#,
        "",
        &["vary[0] (fluid.viscosity)", "low < high"],
    );
    refused_plan(
        "zip",
        FOUR,
        "    combine: Zip,\n    collect: [\"steps\"],\n    plot_against: [\"a..b\"],",
        &["plot_against[0] (a..b)", "segment ``"],
    );
    refused_plan(
        "zip-counts",
        r#"        (path: "fluid.viscosity", values: List([1e-3, 2e-3])),
        (path: "network.cell_length", values: Integers(start: 1, end: 3)),"#,
        "    combine: Zip,",
        &[
            "Zip needs every entry to have the same count",
            "vary[1] (network.cell_length) has 3",
        ],
    );
    // Over the stated limit: counted, not built.
    refused_plan(
        "too-many",
        r#"        (path: "fluid.viscosity", values: Range(start: 1e-3, end: 2e-3, count: 1000)),
        (path: "network.cell_length", values: Range(start: 0.5, end: 1.0, count: 1000)),"#,
        "    max_members: 10000,",
        &["the sweep has 1000000 members, over max_members = 10000"],
    );
    // A malformed sweep file: file, line, column and field.
    refused_plan(
        "syntax",
        r#"        (path: "fluid.viscosity", valuez: List([1e-3])),"#,
        "",
        &["sweep.ron:5:", "valuez"],
    );
    // A base that is not there.
    let file = sweep_file("no-base", FOUR, "");
    let text = read(&file).replace("flow_single_fracture.ron", "nothing-here.ron");
    std::fs::write(&file, text).unwrap();
    let o = plan(&file, &tmp("no-base-out"));
    assert_refused(&o, &["sweep.ron:3:5", "base", "nothing-here.ron"]);
}

#[test]
fn foreign_folders_and_unplanned_folders_are_refused() {
    let file = sweep_file("foreign", FOUR, COLLECT);
    let dir = tmp_dir("foreign-dir");
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let o = plan(&file, &dir);
    assert_refused(
        &o,
        &["not empty and has no hydrofrac-manifest.txt", "notes.txt"],
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    assert_eq!(read(dir.join("notes.txt")), "mine");
    for cmd in [&["run"][..], &["collect"], &["slurm"]] {
        let o = sweep(cmd, &dir);
        assert_refused(&o, &["is not a planned sweep folder", "plan.json"]);
    }
    let empty = tmp_dir("not-planned");
    ok(&plan(&file, &empty));
    let o = bin()
        .args(["sweep", "member"])
        .arg(&empty)
        .arg("4")
        .output()
        .unwrap();
    assert_refused(&o, &["member 4", "has 4 members (0 to 3)"]);
}

#[test]
fn slurm_script_is_a_job_array_of_members() {
    let file = sweep_file("sbatch", FOUR, COLLECT);
    let dir = tmp("sbatch-dir");
    ok(&plan(&file, &dir));
    let o = bin()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args([
            "--partition",
            "debug",
            "--time",
            "00:05:00",
            "--max-parallel",
            "2",
        ])
        .output()
        .unwrap();
    ok(&o);
    let s = read(dir.join("slurm/sweep.sbatch"));
    for needle in [
        "#!/bin/bash\n",
        "#SBATCH --array=0-3%2\n",
        "#SBATCH --partition=debug\n",
        "#SBATCH --time=00:05:00\n",
        "sweep member",
        "\"$((SLURM_ARRAY_TASK_ID + 0))\" --quiet",
    ] {
        assert!(s.contains(needle), "`{needle}` not in:\n{s}");
    }
    // More members than an array holds: one script per block.
    let o = bin()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args(["--max-array-size", "3"])
        .output()
        .unwrap();
    ok(&o);
    assert!(read(dir.join("slurm/sweep-1.sbatch")).contains("--array=0-0\n"));
    assert!(read(dir.join("slurm/sweep-1.sbatch")).contains("SLURM_ARRAY_TASK_ID + 3"));
    assert!(
        !dir.join("slurm/sweep.sbatch").exists(),
        "the previous script stayed"
    );
    let o = bin()
        .args(["sweep", "slurm"])
        .arg(&dir)
        .args(["--partition", "a b"])
        .output()
        .unwrap();
    assert_refused(&o, &["--partition \"a b\""]);
}

/// The Slurm job array (`sweep slurm --submit --wait`) and the local runner give the same
/// collected table, byte for byte. Needs `sbatch` and a cluster (scripts/slurm-single-node.sh
/// starts one on this machine); without `sbatch` the test says so and passes, unless
/// HYDROFRAC_REQUIRE_SLURM=1.
#[test]
fn slurm_array_collects_the_same_table_as_the_local_runner() {
    let has_sbatch = std::process::Command::new("sbatch")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_sbatch {
        assert!(
            std::env::var("HYDROFRAC_REQUIRE_SLURM").as_deref() != Ok("1"),
            "HYDROFRAC_REQUIRE_SLURM=1 but sbatch is not on PATH (scripts/slurm-single-node.sh)"
        );
        eprintln!("notice: sbatch is not on PATH: the Slurm runner is not tested");
        return;
    }
    let file = sweep_file("slurm", FOUR, COLLECT);
    let (local, array) = (tmp("slurm-local"), tmp("slurm-array"));
    ok(&plan(&file, &local));
    ok(&plan(&file, &array));
    ok(&bin()
        .args(["sweep", "run", "--quiet"])
        .arg(&local)
        .output()
        .unwrap());
    let o = bin()
        .args(["sweep", "slurm"])
        .arg(&array)
        .args(["--submit", "--wait", "--time", "00:10:00"])
        .output()
        .unwrap();
    ok(&o);
    for d in [&local, &array] {
        let out = ok(&bin()
            .args(["sweep", "collect", "--no-figures"])
            .arg(d)
            .output()
            .unwrap());
        assert!(
            out.contains("4 members: 4 ok, 0 failed, 0 not run"),
            "{out}"
        );
    }
    for f in ["table.csv", "table.json"] {
        let (a, b) = (
            read(local.join("collect").join(f)),
            read(array.join("collect").join(f)),
        );
        assert_eq!(a, b, "{f}: the local runner's and the Slurm array's differ");
    }
}

/// SIGTERM to `sweep run` while its member is still in setup (Example I cross at h = 0.2 m:
/// about 4 s of meshing and set-up before its first step): the member ends at once (it exits
/// during setup as `run` does, before its run folder exists), the runner records it as
/// interrupted and ends within 2 s of the signal (measured 0.1 s; before, the member finished
/// its setup first). Its run folder was not created; a later `sweep run` runs it.
#[test]
fn a_signal_during_a_members_setup_ends_the_sweep_at_once() {
    use std::time::{Duration, Instant};
    let dir = tmp_dir("setup-signal");
    let base = root().join("scenarios/example1_cross.ron");
    let text = format!(
        "Sweep(\n    base: {:?},\n    vary: [\n        (path: \"mesh.h\", values: List([0.2])),\n    ],\n)\n",
        base.display().to_string()
    );
    let file = dir.join("sweep.ron");
    std::fs::write(&file, text).unwrap();
    let out = dir.join("sweep");
    ok(&plan(&file, &out));
    let mut runner = bin()
        .args(["sweep", "run", "--quiet"])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let status = out.join("members/0000/status.json");
    let t0 = Instant::now();
    while !std::fs::read_to_string(&status).is_ok_and(|s| s.contains("\"running\"")) {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "the member did not start"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        runner.try_wait().unwrap().is_none(),
        "ended before the signal"
    );
    let t1 = Instant::now();
    // SAFETY: kill(2) on the runner's pid, which has not been waited for (so not reused).
    assert_eq!(unsafe { libc::kill(runner.id() as i32, libc::SIGTERM) }, 0);
    let exit = loop {
        if let Some(e) = runner.try_wait().unwrap() {
            break e;
        }
        assert!(
            t1.elapsed() < Duration::from_secs(30),
            "the runner did not end"
        );
        std::thread::sleep(Duration::from_millis(10));
    };
    let dt = t1.elapsed();
    assert!(dt < Duration::from_secs(2), "the runner took {dt:?}");
    assert!(!exit.success(), "an interrupted sweep exited 0");
    let s = read(&status);
    assert!(s.contains("\"interrupted\""), "{s}");
    assert!(s.contains("during its setup"), "{s}");
    assert!(
        !out.join("members/0000/run").exists(),
        "the member's run folder was created"
    );
}
