//! The memory estimate of `src/resources.rs` against the peak resident size of real runs (README
//! "Reliability", bounded resources): for an explicit mesh, a quasi-static mesh and a network
//! on the implicit scheme, the estimate is at least the measured peak and, for the first, at most
//! three times it. One test in its own binary: the peak is read with `getrusage` for all the
//! children this process waited for, so the runs go one after the other, in increasing order of
//! their estimates (then the largest peak so far is at most the latest estimate when every
//! estimate bounds its own run).

#[path = "support/cli.rs"]
mod cli;

use cli::{bin, root};
use hydrofrac::scenario::{MeshSpec, Scenario};
use hydrofrac::setup::build_mesh;

/// Largest peak resident size of the waited-for children, bytes.
#[cfg(target_os = "linux")]
fn children_peak() -> f64 {
    // SAFETY: getrusage fills the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    assert_eq!(unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) }, 0);
    u.ru_maxrss as f64 * 1024.0
}

#[cfg(target_os = "linux")]
#[test]
fn the_estimate_bounds_the_peak_memory_of_real_runs() {
    let cases: [(&str, &[&str]); 3] = [
        (
            "insitu_stress.ron",
            &["mesh.h=0.5", "time.max_steps=2", "time.end.min_steps=1"],
        ),
        (
            "insitu_stress.ron",
            &["mesh.h=0.5", "time.solid_scheme=\"QuasiStatic\""],
        ),
        (
            "flow_network.ron",
            &[
                "network.cell_length=0.0025",
                "time.max_steps=2",
                "time.flow_scheme=\"Implicit\"",
                "time.end.min_steps=1",
            ],
        ),
    ];
    let mut last = 0.0;
    for (k, (file, sets)) in cases.iter().enumerate() {
        let path = root().join("scenarios").join(file);
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let sc = Scenario::load(&path, &sets).unwrap();
        let (mesh, network) = hydrofrac::resources::estimate(&sc);
        let est = mesh + network;
        assert!(
            est > last,
            "case {k}: estimates must increase ({est} after {last})"
        );
        last = est;
        let out = cli::tmp(&k.to_string());
        let mut cmd = bin();
        cmd.arg("run")
            .arg(&path)
            .arg("--out")
            .arg(&out)
            .arg("--quiet");
        for s in &sets {
            cmd.arg("--set").arg(s);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let peak = children_peak();
        assert!(
            est >= peak,
            "case {k} {file} {sets:?}: estimate {est:.3e} B < peak {peak:.3e} B"
        );
        if k == 0 {
            assert!(
                est <= 3.0 * peak,
                "case 0: estimate {est:.3e} B > 3 x peak {peak:.3e} B"
            );
        }
        let _ = std::fs::remove_dir_all(&out);
    }
}

/// The regular mesh's counts are exact.
#[test]
fn regular_mesh_counts_are_exact() {
    let spec = MeshSpec::Regular {
        width: 10.0,
        height: 5.0,
        h: 1.0,
        origin: [0.0, 0.0],
    };
    let c = spec.counts().unwrap();
    let m = build_mesh(&spec).unwrap();
    assert_eq!(c.nodes, m.nodes.len() as f64);
    assert_eq!(c.triangles, m.triangles.len() as f64);
    // Edges of a triangulated grid: horizontal, vertical and one diagonal per square.
    assert_eq!(c.edges, 10.0 * 6.0 + 5.0 * 11.0 + 50.0);
}

/// The graded estimate bounds the built mesh.
#[test]
fn graded_mesh_counts_bound_the_mesh() {
    let spec = MeshSpec::Graded {
        width: 200.0,
        height: 200.0,
        origin: [-100.0, -100.0],
        h: 0.5,
        fine: [-6.0, -2.0, 6.0, 2.0],
        ratio: 1.2,
    };
    let c = spec.counts().unwrap();
    let m = build_mesh(&spec).unwrap();
    let t = m.triangles.len() as f64;
    assert!(
        c.triangles >= t && c.triangles < 2.0 * t,
        "{} vs {t}",
        c.triangles
    );
}
