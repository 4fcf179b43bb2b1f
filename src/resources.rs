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
use crate::scenario::{MeshSpec, Scenario, SolidScheme};

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
/// messages).
pub fn default_limit() -> (u64, &'static str) {
    match machine_memory() {
        Some(b) => (b, "the machine's memory; set another with --max-memory"),
        None => (
            FALLBACK_LIMIT,
            "the default where the machine's memory is unknown; set another with --max-memory",
        ),
    }
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

/// Estimated memory of a mesh, bytes.
pub fn mesh_bytes(c: &MeshCounts, scheme: SolidScheme) -> f64 {
    let qs = match scheme {
        SolidScheme::QuasiStatic => BYTES_PER_NODE_QUASI_STATIC,
        SolidScheme::Explicit => 0.0,
    };
    c.nodes * (BYTES_PER_NODE + qs) + c.triangles * BYTES_PER_TRIANGLE + c.edges * BYTES_PER_EDGE
}

/// Estimated memory of a scenario's mesh and network, bytes (0 for a part it does not have, or
/// a Gmsh file that cannot be read).
pub fn estimate(sc: &Scenario) -> (f64, f64) {
    let mesh = sc
        .mesh
        .as_ref()
        .and_then(MeshSpec::counts)
        .map_or(0.0, |c| mesh_bytes(&c, sc.time.solid_scheme));
    let network = sc
        .network
        .as_ref()
        .map_or(0.0, |n| n.cell_estimate() * BYTES_PER_CELL);
    (mesh, network)
}

/// Refuse a scenario whose mesh or network would need more than `limit` bytes (`source`: where
/// the limit comes from and how to change it, for the message). Nothing is allocated.
pub fn check(sc: &Scenario, limit: u64, source: &str) -> Result<(), SetupError> {
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
        && let Some(c) = mesh.counts()
    {
        let bytes = mesh_bytes(&c, sc.time.solid_scheme);
        if bytes.is_nan() || bytes > limit as f64 {
            let field = if matches!(mesh, MeshSpec::Gmsh { .. }) {
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
        let m = crate::setup::build_mesh(&spec).unwrap();
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
        let m = crate::setup::build_mesh(&spec).unwrap();
        let t = m.triangles.len() as f64;
        assert!(
            c.triangles >= t && c.triangles < 2.0 * t,
            "{} vs {t}",
            c.triangles
        );
    }
}
