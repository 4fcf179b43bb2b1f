//! Minimal ASCII XML VTK output for ParaView: `.vtu` unstructured-grid pieces
//! and a `.pvd` time-series index. (The tests read them back with `tests/support/vtu.rs`.)
//!
//! All files are written atomically (`crate::atomic`: a temporary file in the same folder, flushed,
//! synced, then renamed over the target). Floats are written in Rust's
//! shortest round-trip form, so reading back gives identical bits.
//! Non-finite values are written as `nan`, `inf`, `-inf` (as VTK itself
//! writes them; some older ParaView ASCII readers reject them). The engine
//! never writes frames containing NaN; this only keeps the file well-formed.

use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Cell type of a piece; every cell in a piece has the same type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellKind {
    /// 3-node triangle, VTK type 5.
    Triangle,
    /// 2-node line segment, VTK type 3.
    Line,
    /// 4-node quadrilateral (corners in order around it), VTK type 9.
    Quad,
    /// 4-node tetrahedron, VTK type 10.
    Tetra,
}

impl CellKind {
    /// Nodes per cell.
    pub fn nodes(self) -> usize {
        match self {
            CellKind::Triangle => 3,
            CellKind::Line => 2,
            CellKind::Quad | CellKind::Tetra => 4,
        }
    }

    /// VTK cell type id.
    pub fn vtk_type(self) -> u8 {
        match self {
            CellKind::Triangle => 5,
            CellKind::Line => 3,
            CellKind::Quad => 9,
            CellKind::Tetra => 10,
        }
    }
}

/// A named Float64 array with `components` values per point or cell.
#[derive(Debug, Clone, Copy)]
pub struct DataArray<'a> {
    pub name: &'a str,
    pub components: usize,
    pub values: &'a [f64],
}

/// One unstructured-grid piece.
#[derive(Debug, Clone)]
pub struct VtuPiece<'a> {
    pub points: &'a [[f64; 3]],
    pub kind: CellKind,
    /// `kind.nodes()` indices into `points` per cell.
    pub connectivity: &'a [u32],
    pub point_data: Vec<DataArray<'a>>,
    pub cell_data: Vec<DataArray<'a>>,
}

// ---------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------

/// Shortest round-trip float token: `{}` Display, except `{:?}` (exponent
/// form) for |v| < 1e-4 or >= 1e16 so e.g. 1e-300 is not 300 digits long.
/// Non-finite values become `nan`/`inf`/`-inf`.
struct F(f64);

impl fmt::Display for F {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            f.write_str("nan")
        } else if v.is_infinite() {
            f.write_str(if v > 0.0 { "inf" } else { "-inf" })
        } else if v == 0.0 || (1e-4..1e16).contains(&v.abs()) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:?}")
        }
    }
}

/// XML attribute escaping.
struct Esc<'a>(&'a str);

impl fmt::Display for Esc<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            match c {
                '&' => f.write_str("&amp;")?,
                '<' => f.write_str("&lt;")?,
                '>' => f.write_str("&gt;")?,
                '"' => f.write_str("&quot;")?,
                '\'' => f.write_str("&apos;")?,
                c => fmt::Write::write_char(f, c)?,
            }
        }
        Ok(())
    }
}

use crate::atomic::write_with as write_atomic;

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

fn check_array(a: &DataArray, n: usize, what: &str) -> io::Result<()> {
    if a.components == 0 || a.values.len() != a.components * n {
        return Err(invalid(format!(
            "{what} array '{}': {} values, expected {} x {} components",
            a.name,
            a.values.len(),
            n,
            a.components
        )));
    }
    if let Some(k) = a.values.iter().position(|v| !v.is_finite()) {
        return Err(invalid(format!(
            "{what} array '{}': value {} of {} is {} (a frame holds finite values only)",
            a.name,
            k,
            a.values.len(),
            a.values[k]
        )));
    }
    Ok(())
}

fn write_f64_rows(w: &mut impl Write, values: &[f64], per_line: usize) -> io::Result<()> {
    for row in values.chunks(per_line) {
        let mut first = true;
        for &v in row {
            if first {
                first = false;
                write!(w, "{}", F(v))?;
            } else {
                write!(w, " {}", F(v))?;
            }
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

fn write_u32_rows(w: &mut impl Write, values: &[u32], per_line: usize) -> io::Result<()> {
    for row in values.chunks(per_line) {
        let mut first = true;
        for &v in row {
            if first {
                first = false;
                write!(w, "{v}")?;
            } else {
                write!(w, " {v}")?;
            }
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

fn write_data_array(w: &mut impl Write, a: &DataArray) -> io::Result<()> {
    writeln!(
        w,
        "        <DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">",
        Esc(a.name),
        a.components
    )?;
    let per_line = if a.components == 1 { 8 } else { a.components };
    write_f64_rows(w, a.values, per_line)?;
    writeln!(w, "        </DataArray>")
}

/// Write `piece` as an ASCII `.vtu` file (atomically).
///
/// Fails with `InvalidInput` if connectivity/array lengths are inconsistent,
/// an index is out of range, or sizes exceed Int32.
pub fn write_vtu(path: &Path, piece: &VtuPiece) -> io::Result<()> {
    let np = piece.points.len();
    let nv = piece.kind.nodes();
    if !piece.connectivity.len().is_multiple_of(nv) {
        return Err(invalid(format!(
            "connectivity length {} is not a multiple of {nv}",
            piece.connectivity.len()
        )));
    }
    let nc = piece.connectivity.len() / nv;
    if np > i32::MAX as usize || piece.connectivity.len() > i32::MAX as usize {
        return Err(invalid("piece too large for Int32 indices".into()));
    }
    if let Some(&bad) = piece.connectivity.iter().find(|&&i| i as usize >= np) {
        return Err(invalid(format!(
            "connectivity index {bad} out of range ({np} points)"
        )));
    }
    if let Some(k) = piece
        .points
        .iter()
        .position(|x| x.iter().any(|v| !v.is_finite()))
    {
        return Err(invalid(format!(
            "point {k} has a non-finite coordinate (a frame holds finite values only)"
        )));
    }
    for a in &piece.point_data {
        check_array(a, np, "point")?;
    }
    for a in &piece.cell_data {
        check_array(a, nc, "cell")?;
    }

    write_atomic(path, |w| {
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(
            w,
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
        )?;
        writeln!(w, "  <UnstructuredGrid>")?;
        writeln!(
            w,
            "    <Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">"
        )?;
        writeln!(w, "      <PointData>")?;
        for a in &piece.point_data {
            write_data_array(w, a)?;
        }
        writeln!(w, "      </PointData>")?;
        writeln!(w, "      <CellData>")?;
        for a in &piece.cell_data {
            write_data_array(w, a)?;
        }
        writeln!(w, "      </CellData>")?;

        writeln!(w, "      <Points>")?;
        writeln!(
            w,
            "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for p in piece.points {
            writeln!(w, "{} {} {}", F(p[0]), F(p[1]), F(p[2]))?;
        }
        writeln!(w, "        </DataArray>")?;
        writeln!(w, "      </Points>")?;

        writeln!(w, "      <Cells>")?;
        writeln!(
            w,
            "        <DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">"
        )?;
        write_u32_rows(w, piece.connectivity, nv)?;
        writeln!(w, "        </DataArray>")?;
        writeln!(
            w,
            "        <DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">"
        )?;
        for c in 1..=nc {
            let sep = if c.is_multiple_of(16) || c == nc {
                '\n'
            } else {
                ' '
            };
            write!(w, "{}{sep}", c * nv)?;
        }
        writeln!(w, "        </DataArray>")?;
        writeln!(
            w,
            "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
        )?;
        let t = piece.kind.vtk_type();
        for c in 1..=nc {
            let sep = if c.is_multiple_of(32) || c == nc {
                '\n'
            } else {
                ' '
            };
            write!(w, "{t}{sep}")?;
        }
        writeln!(w, "        </DataArray>")?;
        writeln!(w, "      </Cells>")?;
        w.write_all(b"    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n")
    })
}

/// Maintains a `.pvd` collection; the whole file is rewritten (atomically) on
/// every [`PvdWriter::add`], so it is always valid on disk.
#[derive(Debug, Clone)]
pub struct PvdWriter {
    path: PathBuf,
    entries: Vec<(f64, String)>,
}

impl PvdWriter {
    /// New, empty collection at `path`; nothing is written until `add`.
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            entries: Vec::new(),
        }
    }

    /// Append `(time, file)` and rewrite the `.pvd`. `file` is stored as given
    /// (ParaView resolves it relative to the `.pvd`'s folder). On error the
    /// entry is not kept.
    pub fn add(&mut self, time: f64, file: &str) -> io::Result<()> {
        self.entries.push((time, file.to_string()));
        let result = write_atomic(&self.path, |w| {
            writeln!(w, "<?xml version=\"1.0\"?>")?;
            writeln!(
                w,
                "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">"
            )?;
            writeln!(w, "  <Collection>")?;
            for (t, f) in &self.entries {
                writeln!(
                    w,
                    "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>",
                    F(*t),
                    Esc(f)
                )?;
            }
            w.write_all(b"  </Collection>\n</VTKFile>\n")
        });
        if result.is_err() {
            self.entries.pop();
        }
        result
    }

    /// Entries written so far, in order.
    pub fn entries(&self) -> &[(f64, String)] {
        &self.entries
    }

    /// Path of the `.pvd` file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    //! Writer-only checks; files written and read back are checked in `tests/vtk_output.rs`.
    use super::*;
    use std::fs;

    #[test]
    fn inconsistent_piece_is_rejected() {
        let dir = std::env::temp_dir().join(format!("vtk_test_{}_bad", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.vtu");
        let pts = [[0.0; 3], [1.0, 0.0, 0.0]];
        let mk = |conn: &'static [u32], vals: &'static [f64]| VtuPiece {
            points: &pts,
            kind: CellKind::Line,
            connectivity: conn,
            point_data: vec![DataArray {
                name: "a",
                components: 1,
                values: vals,
            }],
            cell_data: vec![],
        };
        for piece in [
            mk(&[0, 1, 1], &[1.0, 2.0]),
            mk(&[0, 2], &[1.0, 2.0]),
            mk(&[0, 1], &[1.0]),
        ] {
            let e = write_vtu(&path, &piece).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        }
        assert!(!path.exists());
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 0);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn float_tokens() {
        let t = |v: f64| F(v).to_string();
        assert_eq!(t(0.0), "0");
        assert_eq!(t(-0.0), "-0");
        assert_eq!(t(0.25), "0.25");
        assert_eq!(t(1e-300), "1e-300");
        assert_eq!(t(2.5e17), "2.5e17");
        assert_eq!(t(f64::NAN), "nan");
        assert_eq!(t(f64::NEG_INFINITY), "-inf");
        assert_eq!(Esc("a&<>\"'b").to_string(), "a&amp;&lt;&gt;&quot;&apos;b");
    }
}
