//! Bounded resources: the memory a scenario's mesh and network will take, estimated from the
//! scenario alone (before anything is generated or allocated) and refused above a limit, so a
//! `mesh.h` or `network.cell_length` a thousand times too small is a one-line error, not an
//! exhausted machine.
//!
//! The estimate counts nodes, triangles and edges of the mesh and cells of the network and
//! charges each a measured size (bytes): the model's components, the dense views, the frames
//! being written and, for the quasi-static scheme, the sparse factor. The sizes are rounded
//! up from peak resident sizes of release runs (explicit solid: about 1,000 bytes per triangle;
//! quasi-static: about 2,000; network cells: 850 explicit, 1,200 implicit), so the estimate is
//! meant to be on the high side by a few tens of percent, not exact.
//!
//! The limit is the machine's memory (`MemTotal` of `/proc/meminfo`; [`FALLBACK_LIMIT`] where
//! that cannot be read), or `hydrofrac run --max-memory SIZE` ([`parse_size`]).

use crate::error::SetupError;
pub use crate::network::MAX_FRACTURES;
pub use crate::scenario::MeshCounts;
use crate::scenario::{MeshSpec, Scenario, SolidScheme, ValidScenario};

/// The limit when the machine's memory cannot be read, bytes (16 GiB).
pub const FALLBACK_LIMIT: u64 = 16 << 30;

/// Bytes per mesh node (positions, displacements, velocities, forces, masses, boundary flags in
/// the components and the view).
pub const BYTES_PER_NODE: f64 = 500.0;
/// Bytes per triangle (connectivity, geometry, stresses, frame data).
pub const BYTES_PER_TRIANGLE: f64 = 800.0;
/// Bytes per mesh edge (the edge table, fracture criterion and split bookkeeping).
pub const BYTES_PER_EDGE: f64 = 250.0;
/// Extra bytes per node with the quasi-static scheme (the stiffness matrix and its sparse
/// Cholesky factor).
pub const BYTES_PER_NODE_QUASI_STATIC: f64 = 2500.0;
/// 3D quasi-static scheme: extra bytes per node are this times the cube root of the node
/// count. The sparse Cholesky factor of 3D elasticity fills in as about n^(4/3). Measured peaks
/// on Kuhn boxes (`insitu_block3d.ron`, commit c6bb4ef) were:
/// - 9,261 nodes: 241 MB, 26 kB per node;
/// - 35,937 nodes: 1.63 GB, 45 kB per node.
///
/// This coefficient bounds both: 1,400 x 21.0 = 29 kB and 1,400 x 33.0 = 46 kB per node, with
/// the tetrahedra's and faces' bytes on top.
pub const BYTES_PER_NODE_QUASI_STATIC_3D: f64 = 1400.0;
/// Bytes per network cell (cells, nodes, pairs, flow state, the implicit scheme's matrix).
pub const BYTES_PER_CELL: f64 = 1500.0;
pub use crate::scenario::GMSH_BYTES_PER_TRIANGLE;

/// The machine's memory, bytes: `MemTotal` of `/proc/meminfo` (Linux), `None` elsewhere.
pub fn machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line
        .trim_start_matches("MemTotal:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    kib.checked_mul(1024)
}

/// The default memory limit, bytes, and where it comes from and how to change it (for
/// messages): the smallest of the machine's memory, the process's address-space limit
/// (`ulimit -v`) less what the process maps already, and its control group's memory limit
/// (`memory.max` of cgroup v2, `memory.limit_in_bytes` of v1), so that a run under a cluster's
/// or a container's limit is refused with a message instead of being aborted by a failed
/// allocation.
pub fn default_limit() -> (u64, String) {
    let how = "set another with --max-memory";
    let mut best = match machine_memory() {
        Some(b) => (b, format!("the machine's memory; {how}")),
        None => (
            FALLBACK_LIMIT,
            format!("the default where the machine's memory is unknown; {how}"),
        ),
    };
    if let Some(b) = address_space_left()
        && b < best.0
    {
        best = (
            b,
            format!(
                "the process's address-space limit (ulimit -v) less what it maps already; {how}"
            ),
        );
    }
    if let Some(b) = cgroup_limit()
        && b < best.0
    {
        best = (b, format!("the control group's memory limit; {how}"));
    }
    best
}

/// The soft `RLIMIT_AS` less the process's virtual size now (`/proc/self/statm`), bytes;
/// `None` without a limit.
fn address_space_left() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        let mut r = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit fills the struct it is given.
        if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } != 0
            || r.rlim_cur == libc::RLIM_INFINITY
        {
            return None;
        }
        let pages: u64 = std::fs::read_to_string("/proc/self/statm")
            .ok()?
            .split_whitespace()
            .next()?
            .parse()
            .ok()?;
        // SAFETY: sysconf has no preconditions.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) }.max(4096) as u64;
        // rlim_t is u64 on Linux targets; the cast widens where it is not.
        #[allow(clippy::unnecessary_cast)]
        let cur = r.rlim_cur as u64;
        Some(cur.saturating_sub(pages * page))
    }
    #[cfg(not(target_os = "linux"))]
    None
}

/// The memory limit of the process's control group, bytes: `memory.max` (cgroup v2) or
/// `memory.limit_in_bytes` (v1) of the group `/proc/self/cgroup` names; `None` without one.
fn cgroup_limit() -> Option<u64> {
    let groups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    for line in groups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let file = if controllers.is_empty() {
            format!("/sys/fs/cgroup{path}/memory.max")
        } else if controllers.split(',').any(|c| c == "memory") {
            format!("/sys/fs/cgroup/memory{path}/memory.limit_in_bytes")
        } else {
            continue;
        };
        if let Ok(text) = std::fs::read_to_string(&file)
            && let Ok(b) = text.trim().parse::<u64>()
            // v1 writes "no limit" as a number near 2^63.
            && b < (1u64 << 60)
        {
            return Some(b);
        }
    }
    None
}

/// A size in bytes: a number (`2e9`, `17179869184`) optionally followed by `KiB`, `MiB`,
/// `GiB` or `TiB` (powers of 1024; `16GiB`, `0.5 TiB`).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let (num, unit) = match t.find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E') {
        Some(i) => (t[..i].trim(), t[i..].trim()),
        None => (t, ""),
    };
    let scale = match unit {
        "" | "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0f64.powi(2),
        "GiB" => 1024.0f64.powi(3),
        "TiB" => 1024.0f64.powi(4),
        u => {
            return Err(format!(
                "unknown unit `{u}` in `{text}`: give bytes, or KiB, MiB, GiB, TiB"
            ));
        }
    };
    let x: f64 = num
        .parse()
        .map_err(|_| format!("`{text}` is not a size (e.g. 8GiB, 512MiB, 2e9)"))?;
    let bytes = x * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < 2f64.powi(63)) {
        return Err(format!("`{text}` is not a size of at least one byte"));
    }
    Ok(bytes as u64)
}

/// A size for messages: `1.50 GiB`, `300.0 MiB`.
pub fn format_size(bytes: f64) -> String {
    const GIB: f64 = 1024.0 * 1024.0 * 1024.0;
    if bytes >= GIB {
        format!("{:.2} GiB", bytes / GIB)
    } else {
        format!("{:.1} MiB", bytes / (1024.0 * 1024.0))
    }
}

/// Estimated memory of a mesh, bytes. In 3D (`three_d`) `triangles` counts tetrahedra and
/// `edges` faces, at the same bytes each (measured: the explicit 48,000-tetrahedron block peaks
/// at 56 MB against 68 MB estimated); the quasi-static factor grows faster
/// ([`BYTES_PER_NODE_QUASI_STATIC_3D`]).
pub fn mesh_bytes(c: &MeshCounts, scheme: SolidScheme, three_d: bool) -> f64 {
    let qs = match (scheme, three_d) {
        (SolidScheme::QuasiStatic, false) => BYTES_PER_NODE_QUASI_STATIC,
        (SolidScheme::QuasiStatic, true) => BYTES_PER_NODE_QUASI_STATIC_3D * c.nodes.cbrt(),
        (SolidScheme::Explicit, _) => 0.0,
    };
    c.nodes * (BYTES_PER_NODE + qs) + c.triangles * BYTES_PER_TRIANGLE + c.edges * BYTES_PER_EDGE
}

/// Estimated memory of a scenario's mesh and network, bytes (0 for a part it does not have, or
/// a Gmsh file that cannot be read).
pub fn estimate(sc: &Scenario) -> (f64, f64) {
    let mesh = sc
        .mesh_counts()
        .map_or(0.0, |c| mesh_bytes(&c, sc.time.solid_scheme, sc.is_3d()));
    let network = sc
        .network
        .as_ref()
        .map_or(0.0, |n| n.cell_estimate() * BYTES_PER_CELL);
    (mesh, network)
}

/// Refuse a scenario whose mesh or network would need more than `limit` bytes (`source`: where
/// the limit comes from and how to change it, for the message). Nothing is allocated. Validated
/// first: the estimate reads the mesh's sizes, which are then finite and positive.
pub fn check(sc: &ValidScenario, limit: u64, source: &str) -> Result<(), SetupError> {
    let refuse = |field: &str, what: String, bytes: f64| {
        SetupError::invalid(
            field,
            format!(
                "{what} need an estimated {} of memory, more than the limit of {} ({source})",
                format_size(bytes),
                format_size(limit as f64)
            ),
        )
    };
    if let Some(mesh) = &sc.mesh
        && let Some(c) = sc.mesh_counts()
    {
        let bytes = mesh_bytes(&c, sc.time.solid_scheme, sc.is_3d());
        if bytes.is_nan() || bytes > limit as f64 {
            let field = if matches!(mesh, MeshSpec::Gmsh { .. } | MeshSpec::Gmsh3 { .. }) {
                "mesh.file"
            } else {
                "mesh.h"
            };
            let what = format!(
                "{:.3e} nodes, {:.3e} triangles and {:.3e} edges",
                c.nodes, c.triangles, c.edges
            );
            return Err(refuse(field, what, bytes));
        }
    }
    if let Some(n) = &sc.network {
        let cells = n.cell_estimate();
        let bytes = cells * BYTES_PER_CELL;
        if bytes.is_nan() || bytes > limit as f64 {
            return Err(refuse(
                "network.cell_length",
                format!(
                    "{cells:.3e} cells (fracture length / cell_length {} m, and intersections)",
                    n.cell_length
                ),
                bytes,
            ));
        }
    }
    Ok(())
}

/// Bytes of one number in the text outputs at most: Rust's shortest round-trip form of an f64
/// with sign and exponent (`-1.2345678901234567e-100`, 24 characters) and a separator.
pub const BYTES_PER_NUMBER: f64 = 25.0;
/// Bytes of one node index in a frame's connectivity at most (8 digits and a separator).
pub const BYTES_PER_INDEX: f64 = 9.0;
/// Bytes of one frame's XML around its numbers, and of its line in the `.pvd` index.
pub const BYTES_PER_FRAME_HEADER: f64 = 3000.0;
/// Bytes of the files written once at the end (figures: PNG of at most about 300 kB each,
/// measured 60-140 kB; tables, `summary.json`, the manifest).
pub const BYTES_FIXED: f64 = 8.0 * 300e3;

/// What decides a run's output size, gathered after setup (before anything is written).
#[derive(Clone, Debug)]
pub struct OutputPlan {
    /// Mesh nodes and triangles (0 without a mesh), network cells (0 without one).
    pub nodes: f64,
    pub triangles: f64,
    pub cells: f64,
    /// Displacement and velocity: 3 numbers per node each; stress: 4 per triangle.
    pub fields: Vec<crate::scenario::Field>,
    /// `output.frame_every` (0: the first and last frame only), `output.series_every`, the
    /// time-series columns and `output.figure_times`.
    pub frame_every: u64,
    pub series_every: u64,
    pub series_columns: usize,
    pub figures: usize,
    /// The steps the run is expected to take, and how that was found (for the message).
    pub steps: f64,
    pub steps_from: String,
}

/// A run's estimated output, bytes (see [`output_estimate`]).
#[derive(Clone, Debug)]
pub struct OutputEstimate {
    pub frames: f64,
    /// One solid frame plus one network frame, bytes.
    pub frame_bytes: f64,
    pub series_rows: f64,
    pub series_bytes: f64,
    pub total: f64,
}

/// The steps a run is expected to take: `end / dt` for a time end (dt the step after setup,
/// s; the adaptive quasi-static step starts there), at most `max_steps`; `max_steps` for a
/// run that ends on convergence (its only bound known before the run). Returns the steps
/// and how they were found.
pub fn planned_steps(end_time: Option<f64>, dt: f64, max_steps: u64) -> (f64, String) {
    let cap = max_steps as f64;
    match end_time {
        Some(te) if dt > 0.0 && (te / dt).is_finite() => {
            let n = (te / dt).ceil().max(1.0);
            if n <= cap {
                (n, format!("time.end / dt = {te:e} / {dt:.3e} s"))
            } else {
                (cap, format!("time.max_steps = {max_steps}"))
            }
        }
        _ => (
            cap,
            format!("time.max_steps = {max_steps}, the bound of a run that ends on convergence"),
        ),
    }
}

/// Estimated size of a run's outputs: frames (the first, one every `frame_every` steps and
/// the last) of the mesh (points, connectivity, ids and the chosen fields) and of the network
/// (2 points, a connection and 11 numbers per cell), the time series (a row every
/// `series_every` steps) and the files written once. Numbers are charged at their longest
/// text form ([`BYTES_PER_NUMBER`]), so the estimate is on the high side; a run whose
/// fractures grow writes larger network frames than those of its setup.
pub fn output_estimate(p: &OutputPlan) -> OutputEstimate {
    use crate::scenario::Field;
    let b = BYTES_PER_NUMBER;
    let per_node = 4.0
        + p.fields
            .iter()
            .map(|f| match f {
                Field::Displacement | Field::Velocity => 3.0,
                Field::Stress => 0.0,
            })
            .sum::<f64>();
    let per_triangle = 1.0
        + if p.fields.contains(&Field::Stress) {
            4.0
        } else {
            0.0
        };
    let solid = if p.nodes > 0.0 {
        p.nodes * per_node * b
            + p.triangles * (per_triangle * b + 4.0 * BYTES_PER_INDEX + 2.0)
            + BYTES_PER_FRAME_HEADER
    } else {
        0.0
    };
    let network = if p.cells > 0.0 {
        p.cells * ((6.0 + 11.0) * b + 3.0 * BYTES_PER_INDEX + 2.0) + BYTES_PER_FRAME_HEADER
    } else {
        0.0
    };
    let frames = 2.0
        + if p.frame_every > 0 {
            (p.steps / p.frame_every as f64).floor()
        } else {
            0.0
        };
    let series_rows = 2.0 + (p.steps / p.series_every.max(1) as f64).floor();
    let series_bytes = series_rows * p.series_columns as f64 * b;
    let frame_bytes = solid + network;
    let total = frames * frame_bytes + series_bytes + BYTES_FIXED + p.figures as f64 * 300e3;
    OutputEstimate {
        frames,
        frame_bytes,
        series_rows,
        series_bytes,
        total,
    }
}

/// Free space of the disk holding `dir` (or its nearest existing ancestor), bytes: statvfs's
/// blocks available to an unprivileged user. `None` where it cannot be read.
pub fn free_space(dir: &std::path::Path) -> Option<u64> {
    #[cfg(unix)]
    {
        let st = statvfs(&existing_ancestor(dir).ok()??)?;
        // The fields' widths differ between platforms (u32 on some): the casts widen.
        #[allow(clippy::unnecessary_cast)]
        (st.f_bavail as u64).checked_mul(st.f_frsize as u64)
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// The nearest existing ancestor of `dir` (itself included), made absolute against the
/// working folder; `Ok(None)` when none exists, `Err` when the working folder cannot be read.
fn existing_ancestor(dir: &std::path::Path) -> std::io::Result<Option<std::path::PathBuf>> {
    let abs = if dir.is_absolute() {
        dir.to_path_buf()
    } else {
        std::env::current_dir()?.join(dir)
    };
    Ok(abs
        .ancestors()
        .find(|a| a.exists())
        .map(|a| a.to_path_buf()))
}

/// `statvfs(3)` of an existing `path`; `None` where it cannot be read.
#[cfg(unix)]
fn statvfs(path: &std::path::Path) -> Option<libc::statvfs> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a NUL-terminated path and `st` a buffer statvfs(3) fills on success.
    if unsafe { libc::statvfs(c.as_ptr(), st.as_mut_ptr()) } != 0 {
        return None;
    }
    // SAFETY: statvfs returned 0, so it filled `st`.
    Some(unsafe { st.assume_init() })
}

/// Whether an output folder can be made at `dir` at all, checked before any estimate (whose
/// "free space" would otherwise read 0 on a virtual filesystem such as `/proc`): its nearest
/// existing ancestor must be a folder on a writable filesystem that is not one of the kernel's
/// pseudo filesystems. `Err`: why not, in words. Where the filesystem cannot be read, the
/// creation itself will tell.
pub fn check_output_place(dir: &std::path::Path) -> Result<(), String> {
    let existing =
        existing_ancestor(dir).map_err(|e| format!("the working folder cannot be read: {e}"))?;
    let Some(existing) = existing else {
        return Ok(());
    };
    if !existing.is_dir() {
        return Err(format!("{} is not a folder", existing.display()));
    }
    #[cfg(unix)]
    {
        if statvfs(&existing).is_some_and(|st| st.f_flag & libc::ST_RDONLY != 0) {
            return Err(format!(
                "{} is on a read-only filesystem",
                existing.display()
            ));
        }
        if pseudo_filesystem(&existing) {
            return Err(format!(
                "{} is on a virtual filesystem with no disk to write to",
                existing.display()
            ));
        }
    }
    Ok(())
}

/// Whether `path` lies on one of the kernel's pseudo filesystems (proc, sysfs, cgroup,
/// debugfs, ...; `statfs`'s magic numbers), where nothing can be stored. Only these: a
/// filesystem that reports no blocks (some FUSE mounts) may still take files.
#[cfg(unix)]
fn pseudo_filesystem(path: &std::path::Path) -> bool {
    #[cfg(target_os = "linux")]
    {
        const PSEUDO: [i64; 12] = [
            0x9fa0,     // proc
            0x62656572, // sysfs
            0x0027e0eb, // cgroup
            0x63677270, // cgroup2
            0x64626720, // debugfs
            0x73636673, // securityfs
            0x74726163, // tracefs
            0x1cd1,     // devpts
            0xcafe4a11, // bpf
            0x6165676c, // pstore
            0x62656570, // configfs
            0x19800202, // mqueue
        ];
        use std::os::unix::ffi::OsStrExt;
        let Ok(c) = std::ffi::CString::new(path.as_os_str().as_bytes()) else {
            return false;
        };
        let mut st = std::mem::MaybeUninit::<libc::statfs>::uninit();
        // SAFETY: `c` is a NUL-terminated path and `st` a buffer statfs(2) fills on success.
        if unsafe { libc::statfs(c.as_ptr(), st.as_mut_ptr()) } != 0 {
            return false;
        }
        // SAFETY: statfs returned 0, so it filled `st`.
        let kind = unsafe { st.assume_init() }.f_type;
        // The field's type differs between architectures: the cast widens.
        #[allow(clippy::unnecessary_cast)]
        PSEUDO.contains(&(kind as i64))
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = path;
        false
    }
}

/// The default disk limit for outputs into `out`, bytes, and where it comes from (for
/// messages): the free space of its disk, else no limit (`u64::MAX`).
pub fn default_disk_limit(out: &std::path::Path) -> (u64, String) {
    match free_space(out) {
        Some(b) => (
            b,
            format!(
                "the free space of the disk holding {}; set another with --max-disk",
                crate::error::one_line(&out.display().to_string())
            ),
        ),
        None => (
            u64::MAX,
            "no limit: the free space of the output folder's disk cannot be read; set one with \
             --max-disk"
                .into(),
        ),
    }
}

/// Refuse a run whose outputs would take more than `limit` bytes (`source`: where the limit
/// comes from, for the message), naming `output.frame_every` when frames are most of it, else
/// `output.series_every`. Nothing is written.
pub fn check_disk(p: &OutputPlan, limit: u64, source: &str) -> Result<OutputEstimate, SetupError> {
    let e = output_estimate(p);
    if e.total.is_nan() || e.total > limit as f64 {
        let frames = e.frames * e.frame_bytes;
        let field = if frames >= e.series_bytes {
            "output.frame_every"
        } else {
            "output.series_every"
        };
        return Err(SetupError::invalid(
            field,
            format!(
                "the outputs need an estimated {} of disk ({:.0} frames of {} ({}) and \
                 {:.0} time-series rows of {} columns, over {:.0} steps from {}), more \
                 than the limit of {} ({source}); write fewer frames or rows, or shorten the run",
                format_size(e.total),
                e.frames,
                format_size(e.frame_bytes),
                if p.frame_every > 0 {
                    format!("one every {} steps", p.frame_every)
                } else {
                    "the first and the last".to_string()
                },
                e.series_rows,
                p.series_columns,
                p.steps,
                p.steps_from,
                format_size(limit as f64)
            ),
        ));
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("1024").unwrap(), 1024);
        assert_eq!(parse_size("2e9").unwrap(), 2_000_000_000);
        assert_eq!(parse_size("16GiB").unwrap(), 16 << 30);
        assert_eq!(parse_size("0.5 GiB").unwrap(), 512 << 20);
        assert_eq!(parse_size("512MiB").unwrap(), 512 << 20);
        for bad in [
            "",
            "GiB",
            "-1GiB",
            "0",
            "1GB",
            "nan",
            "inf",
            "1e30TiB",
            "12 apples",
        ] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_machine_memory_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let b = machine_memory().expect("MemTotal");
            assert!(b > 64 << 20, "{b}");
        }
    }

    /// Steps: end / dt rounded up, capped by max_steps; max_steps for a convergence end.
    #[test]
    fn planned_steps_follow_the_end_and_the_cap() {
        assert_eq!(planned_steps(Some(1.0), 0.3, 100).0, 4.0);
        let (n, why) = planned_steps(Some(1.0), 1e-6, 100);
        assert_eq!(n, 100.0);
        assert!(why.contains("time.max_steps = 100"), "{why}");
        assert_eq!(planned_steps(None, 1e-3, 5000).0, 5000.0);
        assert_eq!(planned_steps(Some(1.0), 0.0, 70).0, 70.0);
    }

    /// Frames: the first, one every frame_every steps, the last; rows likewise; the sizes
    /// count every number at its longest form.
    #[test]
    fn output_estimate_counts_frames_rows_and_numbers() {
        use crate::scenario::Field;
        let plan = OutputPlan {
            nodes: 100.0,
            triangles: 150.0,
            cells: 0.0,
            fields: vec![Field::Displacement],
            frame_every: 10,
            series_every: 4,
            series_columns: 3,
            figures: 0,
            steps: 95.0,
            steps_from: String::new(),
        };
        let e = output_estimate(&plan);
        assert_eq!(e.frames, 2.0 + 9.0);
        assert_eq!(e.series_rows, 2.0 + 23.0);
        assert_eq!(e.series_bytes, 25.0 * 3.0 * BYTES_PER_NUMBER);
        let frame = 100.0 * 7.0 * BYTES_PER_NUMBER
            + 150.0 * (BYTES_PER_NUMBER + 4.0 * BYTES_PER_INDEX + 2.0)
            + BYTES_PER_FRAME_HEADER;
        assert_eq!(e.frame_bytes, frame);
        assert_eq!(e.total, 11.0 * frame + e.series_bytes + BYTES_FIXED);
        // Refused above the limit, naming the frames and both sizes.
        let err = check_disk(&plan, 1000, "test").unwrap_err().to_string();
        assert!(
            err.contains("output.frame_every") && err.contains("limit of"),
            "{err}"
        );
        assert!(check_disk(&plan, u64::MAX, "test").is_ok());
        // A series-heavy run names output.series_every.
        let rows = OutputPlan {
            nodes: 0.0,
            triangles: 0.0,
            frame_every: 0,
            series_every: 1,
            series_columns: 20,
            steps: 1e7,
            ..plan
        };
        let err = check_disk(&rows, 1 << 20, "test").unwrap_err().to_string();
        assert!(err.contains("output.series_every"), "{err}");
    }

    #[test]
    fn free_space_is_read_through_a_missing_folder() {
        if cfg!(unix) {
            let tmp = std::env::temp_dir();
            let b = free_space(&tmp.join("no/such/folder/yet")).expect("statvfs");
            assert!(b > 0, "{b}");
            // (The free space moves while other processes write: only the source is compared.)
            assert!(default_disk_limit(&tmp).1.contains("free space"));
        }
    }
}
