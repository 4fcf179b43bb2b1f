//! Test support: the `hydrofrac` binary as a user runs it, what a run leaves in its folder, and
//! temporary folders. `tests/integration.rs` pulls it in once (a test file in its own binary
//! with `#[path = "support/cli.rs"] mod cli;`) and each test file uses what it needs. A temporary folder is named after the test binary, this process and
//! the name asked for, so two tests (or two test binaries) never share one.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `hydrofrac` binary of this build, to add arguments to.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hydrofrac"))
}

/// Run the binary with `args` and wait for it.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("binary runs")
}

/// `hydrofrac run SCENARIO --quiet --out OUT EXTRA...`, which must succeed; its `summary.json`.
pub fn run_ok(scenario: impl AsRef<Path>, out: &Path, extra: &[&str]) -> serde_json::Value {
    let o = bin()
        .arg("run")
        .arg(scenario.as_ref())
        .arg("--quiet")
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("binary runs");
    assert!(o.status.success(), "{}", stderr(&o));
    summary(out)
}

/// The run's standard error, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The `summary.json` a run wrote into `dir`.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// A refusal: a non-zero exit that is not a panic (101), one `error: ` line containing every
/// one of `needles`.
pub fn assert_refused(o: &Output, needles: &[&str]) {
    let e = stderr(o);
    assert!(!o.status.success(), "expected failure: {e}");
    assert_ne!(o.status.code(), Some(101), "panic: {e}");
    assert!(!e.contains("panicked"), "panic: {e}");
    let first = e.lines().next().unwrap_or("");
    assert!(first.starts_with("error: "), "{e}");
    for n in needles {
        assert!(first.contains(n), "`{n}` not in: {first}");
    }
}

/// Each scenario text of `cases`, written into `dir` and run, is refused with its needles
/// ([`assert_refused`]) and leaves no output folder.
pub fn assert_all_refused(dir: &Path, cases: &[(String, &[&str])]) {
    std::fs::create_dir_all(dir).unwrap();
    for (k, (text, needles)) in cases.iter().enumerate() {
        let path = dir.join(format!("case{k}.ron"));
        std::fs::write(&path, text).unwrap();
        let out = dir.join(format!("out{k}"));
        let o = run(&[
            "run",
            path.to_str().unwrap(),
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_refused(&o, needles);
        assert!(
            !out.exists(),
            "case {k}: a refused run wrote {}",
            out.display()
        );
    }
}

/// The repository's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The path of the shipped scenario `scenarios/<name>`, as an argument.
pub fn scenario(name: &str) -> String {
    root().join("scenarios").join(name).display().to_string()
}

/// A temporary path for `name` (a folder or a file), removed if it is there (not created):
/// `hydrofrac-<test binary>-<process>-<test>-<name>` in the system's temporary folder, the
/// test named by its thread (libtest names each test's thread after it), so tests of
/// different files in the one integration binary never share a path.
pub fn tmp(name: &str) -> PathBuf {
    static SWEPT: std::sync::Once = std::sync::Once::new();
    SWEPT.call_once(sweep_stale_tmp);
    let test: String = std::thread::current()
        .name()
        .unwrap_or("main")
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let d = std::env::temp_dir().join(format!(
        "hydrofrac-{}-{}-{test}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    let _ = std::fs::remove_file(&d);
    d
}

/// Remove what earlier runs of this test binary left in the temporary folder: the paths
/// `hydrofrac-<test binary>-<process>-...` of processes that no longer run (Linux: no
/// `/proc/<process>`; elsewhere nothing is removed). A run's own paths stay after it, for a
/// look at a failed test, until the next run of the binary.
fn sweep_stale_tmp() {
    if !std::path::Path::new("/proc/self").exists() {
        return;
    }
    let prefix = format!("hydrofrac-{}-", env!("CARGO_CRATE_NAME"));
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(&prefix) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if pid != std::process::id() && !std::path::Path::new(&format!("/proc/{pid}")).exists() {
            let p = e.path();
            let _ = std::fs::remove_dir_all(&p);
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// [`tmp`], created as an empty folder.
pub fn tmp_dir(name: &str) -> PathBuf {
    let d = tmp(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}
