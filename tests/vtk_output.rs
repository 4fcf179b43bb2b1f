//! The ParaView writer (`hydrofrac::output::vtk`) read back with the test-support reader
//! (`support/vtu.rs`, on roxmltree): bit-exact floats, escaped names, the `.pvd` index, and
//! files the reader must refuse (truncated, garbled, or with sizes that do not agree).

use crate::support_cli as cli;
use crate::support_vtu as vtu;

use hydrofrac::output::vtk::{CellKind, DataArray, PvdWriter, VtuPiece, write_vtu};
use std::fs;
use std::path::{Path, PathBuf};
use vtu::{VtkError, read_pvd, read_vtu};

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn two_triangles(dir: &Path) -> (PathBuf, Vec<[f64; 3]>, Vec<f64>, Vec<f64>) {
    let points = vec![
        [0.0, 0.0, 0.0],
        [1.0 / 3.0, -0.0, 1e-300],
        [0.1 + 0.2, 2.5e17, -7.0],
        [f64::MIN_POSITIVE, f64::MAX, 123456.789],
    ];
    let disp: Vec<f64> = (0..12).map(|i| (i as f64).sqrt() * 1e-7 - 0.3).collect();
    let stress = vec![std::f64::consts::PI * 1e9, -2.0f64.powi(-40)];
    let path = dir.join("tri.vtu");
    write_vtu(
        &path,
        &VtuPiece {
            points: &points,
            kind: CellKind::Triangle,
            connectivity: &[0, 1, 2, 2, 1, 3],
            point_data: vec![DataArray {
                name: "displacement",
                components: 3,
                values: &disp,
            }],
            cell_data: vec![DataArray {
                name: "stress & <x>",
                components: 1,
                values: &stress,
            }],
        },
    )
    .unwrap();
    (path, points, disp, stress)
}

#[test]
fn triangle_round_trip_is_bit_exact() {
    let dir = cli::tmp_dir("tri");
    let (path, points, disp, stress) = two_triangles(&dir);
    let d = read_vtu(&path).unwrap();
    assert_eq!(d.points.len(), 4);
    for (a, b) in d.points.iter().zip(&points) {
        assert_eq!(bits(a), bits(b));
    }
    assert_eq!(d.connectivity, vec![0, 1, 2, 2, 1, 3]);
    assert_eq!(d.offsets, vec![3, 6]);
    assert_eq!(d.types, vec![5, 5]);
    assert_eq!(d.point_data[0].0, "displacement");
    assert_eq!(d.point_data[0].1, 3);
    assert_eq!(bits(d.point_array("displacement").unwrap()), bits(&disp));
    assert_eq!(d.cell_data[0].1, 1);
    // The name is escaped in the file and comes back as written.
    let text = fs::read_to_string(&path).unwrap();
    assert!(text.contains("Name=\"stress &amp; &lt;x&gt;\""));
    assert_eq!(bits(d.cell_array("stress & <x>").unwrap()), bits(&stress));
    assert!(d.point_array("nope").is_none());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn line_piece_round_trip() {
    let dir = cli::tmp_dir("line");
    let path = dir.join("lines.vtu");
    let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.5, 0.0]];
    let aperture = [1e-4, 2e-4];
    write_vtu(
        &path,
        &VtuPiece {
            points: &points,
            kind: CellKind::Line,
            connectivity: &[0, 1, 1, 2],
            point_data: vec![],
            cell_data: vec![DataArray {
                name: "aperture",
                components: 1,
                values: &aperture,
            }],
        },
    )
    .unwrap();
    let d = read_vtu(&path).unwrap();
    assert_eq!(d.points, points.to_vec());
    assert_eq!(d.connectivity, vec![0, 1, 1, 2]);
    assert_eq!(d.offsets, vec![2, 4]);
    assert_eq!(d.types, vec![3, 3]);
    assert!(d.point_data.is_empty());
    assert_eq!(bits(d.cell_array("aperture").unwrap()), bits(&aperture));
    fs::remove_dir_all(&dir).unwrap();
}

/// A frame holds finite values only (README "Reliability"): a non-finite value or coordinate
/// is refused with `InvalidInput` naming the array and the value's index, and no file is
/// written (it wrote `nan inf -inf`, and a run with a subnormal Young's modulus wrote
/// infinite displacements into its frames).
#[test]
fn non_finite_values_are_refused() {
    let dir = cli::tmp_dir("nonfinite");
    let path = dir.join("nf.vtu");
    for (k, bad) in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        let mut vals = [1.0, 2.0, 3.0];
        vals[k] = bad;
        let e = write_vtu(
            &path,
            &VtuPiece {
                points: &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                kind: CellKind::Triangle,
                connectivity: &[0, 1, 2],
                point_data: vec![DataArray {
                    name: "f",
                    components: 1,
                    values: &vals,
                }],
                cell_data: vec![],
            },
        )
        .unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(
            e.to_string().contains(&format!("'f': value {k} of 3")),
            "{e}"
        );
        let e = write_vtu(
            &path,
            &VtuPiece {
                points: &[[0.0; 3], [bad, 0.0, 0.0], [0.0, 1.0, 0.0]],
                kind: CellKind::Triangle,
                connectivity: &[0, 1, 2],
                point_data: vec![],
                cell_data: vec![],
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("point 1"), "{e}");
        assert!(!path.exists());
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pvd_lists_entries_in_order() {
    let dir = cli::tmp_dir("pvd");
    let path = dir.join("run.pvd");
    let mut pvd = PvdWriter::new(&path);
    assert!(!path.exists());
    let times = [0.0, 0.1, 0.2 + 0.1, 1e-9];
    for (i, &t) in times.iter().enumerate() {
        pvd.add(t, &format!("frames/frame_{i:04}.vtu")).unwrap();
        let read = read_pvd(&path).unwrap();
        assert_eq!(read.len(), i + 1);
    }
    pvd.add(2.0, "odd \"name\" & <more>.vtu").unwrap();
    let read = read_pvd(&path).unwrap();
    assert_eq!(read.len(), 5);
    for (i, &t) in times.iter().enumerate() {
        assert_eq!(read[i].0.to_bits(), t.to_bits());
        assert_eq!(read[i].1, format!("frames/frame_{i:04}.vtu"));
    }
    assert_eq!(read[4], (2.0, "odd \"name\" & <more>.vtu".to_string()));
    assert_eq!(pvd.entries(), read.as_slice());
    assert!(!dir.join("run.tmp.pvd").exists());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn truncated_or_garbled_input_is_an_error() {
    let dir = cli::tmp_dir("trunc");
    let (path, _, _, _) = two_triangles(&dir);
    let full = fs::read(&path).unwrap();
    let cut = dir.join("cut.vtu");
    // Every truncation point must give Err, never a panic or Ok.
    for len in 0..full.len() - 1 {
        fs::write(&cut, &full[..len]).unwrap();
        assert!(read_vtu(&cut).is_err(), "truncated at {len} accepted");
    }
    // Garbled: corrupt single bytes; must not panic.
    for i in (0..full.len()).step_by(7) {
        let mut g = full.clone();
        g[i] = b'#';
        fs::write(&cut, &g).unwrap();
        let _ = read_vtu(&cut);
    }
    let e = read_vtu(&dir.join("missing.vtu")).unwrap_err();
    assert!(matches!(e, VtkError::Io { .. }));
    fs::write(&cut, b"<VTKFile type=\"UnstructuredGrid\"><Piece").unwrap();
    let e = read_vtu(&cut).unwrap_err();
    assert!(matches!(e, VtkError::Parse { .. }), "{e}");
    assert!(e.to_string().contains("cut.vtu"));

    let pvd = dir.join("a.pvd");
    let mut w = PvdWriter::new(&pvd);
    w.add(0.0, "a.vtu").unwrap();
    let full = fs::read(&pvd).unwrap();
    for len in 0..full.len() - 1 {
        fs::write(&pvd, &full[..len]).unwrap();
        assert!(read_pvd(&pvd).is_err(), "pvd truncated at {len} accepted");
    }
    fs::remove_dir_all(&dir).unwrap();
}

/// The reader checks sizes against each other, so a writer that wrote the wrong number of
/// points, values or cells, or a broken escape, would fail the round-trip tests above.
#[test]
fn inconsistent_files_are_refused() {
    let dir = cli::tmp_dir("inconsistent");
    let (path, _, _, _) = two_triangles(&dir);
    let good = fs::read_to_string(&path).unwrap();
    let bad = dir.join("bad.vtu");
    let edits = [
        (
            "NumberOfPoints=\"4\"",
            "NumberOfPoints=\"5\"",
            "expected 5 x 3",
        ),
        (
            "NumberOfCells=\"2\"",
            "NumberOfCells=\"3\"",
            "expected 3 x 1",
        ),
        ("stress &amp; &lt;x&gt;", "stress & <x>", ""),
        ("format=\"ascii\"", "format=\"binary\"", "unsupported"),
        (
            "\n0 1 2\n2 1 3\n",
            "\n0 1 2\n2 1 4\n",
            "connectivity index 4",
        ),
        ("\n3 6\n", "\n3 5\n", "last offset 5"),
        ("</Cells>", "</Cells>stray", "unexpected text"),
    ];
    for (from, to, why) in edits {
        assert!(good.contains(from), "{from}");
        fs::write(&bad, good.replacen(from, to, 1)).unwrap();
        let e = read_vtu(&bad).expect_err(to);
        assert!(matches!(e, VtkError::Parse { .. }));
        assert!(e.to_string().contains(why), "{to}: {e}");
    }
    // A piece with a missing value row.
    let mut lines: Vec<&str> = good.lines().collect();
    let row = lines
        .iter()
        .position(|l| l.contains("Name=\"displacement\""))
        .unwrap()
        + 1;
    lines.remove(row);
    fs::write(&bad, lines.join("\n")).unwrap();
    let e = read_vtu(&bad).unwrap_err();
    assert!(e.to_string().contains("expected 4 x 3"), "{e}");

    let pvd = dir.join("a.pvd");
    PvdWriter::new(&pvd).add(0.5, "a.vtu").unwrap();
    let good = fs::read_to_string(&pvd).unwrap();
    for (from, to) in [
        ("timestep=\"0.5\"", "timestep=\"x\""),
        (" file=\"a.vtu\"", ""),
        ("type=\"Collection\"", "type=\"UnstructuredGrid\""),
    ] {
        fs::write(&pvd, good.replacen(from, to, 1)).unwrap();
        assert!(read_pvd(&pvd).is_err(), "{to}");
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn no_tmp_file_remains() {
    let dir = cli::tmp_dir("tmp");
    let (path, _, _, _) = two_triangles(&dir);
    assert!(path.exists());
    assert!(!dir.join("tri.tmp.vtu").exists());
    // Overwriting an existing file also works and leaves no tmp.
    two_triangles(&dir);
    let names: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("tri.vtu")]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn large_piece_writes_quickly() {
    // ~200k triangles; guards against per-value allocation.
    let dir = cli::tmp_dir("large");
    let n = 300usize;
    let mut points = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            points.push([i as f64 / n as f64, j as f64 / n as f64 * 0.7, 0.0]);
        }
    }
    let mut conn = Vec::with_capacity(6 * n * n);
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * (n as u32 + 1) + i;
            let b = a + 1;
            let c = a + n as u32 + 1;
            conn.extend_from_slice(&[a, b, c, b, c + 1, c]);
        }
    }
    let u: Vec<f64> = points.iter().flat_map(|p| [p[0], p[1], 0.0]).collect();
    let s: Vec<f64> = (0..2 * n * n).map(|i| i as f64 * 1.5e-3).collect();
    let path = dir.join("big.vtu");
    let t0 = std::time::Instant::now();
    write_vtu(
        &path,
        &VtuPiece {
            points: &points,
            kind: CellKind::Triangle,
            connectivity: &conn,
            point_data: vec![DataArray {
                name: "u",
                components: 3,
                values: &u,
            }],
            cell_data: vec![DataArray {
                name: "s",
                components: 1,
                values: &s,
            }],
        },
    )
    .unwrap();
    let dt = t0.elapsed();
    assert!(dt.as_secs_f64() < 20.0, "write took {dt:?}");
    let d = read_vtu(&path).unwrap();
    assert_eq!(d.types.len(), 2 * n * n);
    assert_eq!(bits(d.cell_array("s").unwrap()), bits(&s));
    fs::remove_dir_all(&dir).unwrap();
}
