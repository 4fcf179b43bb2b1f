//! Minimal ASCII XML VTK output for ParaView: `.vtu` unstructured-grid pieces
//! and a `.pvd` time-series index, plus a reader for files this writer produced.
//!
//! All files are written atomically (`crate::atomic`: a temporary file in the same folder, flushed,
//! synced, then renamed over the target). Floats are written in Rust's
//! shortest round-trip form, so reading back gives identical bits.
//! Non-finite values are written as `nan`, `inf`, `-inf` (as VTK itself
//! writes them; some older ParaView ASCII readers reject them). The engine
//! never writes frames containing NaN; this only keeps the file well-formed.

use std::fmt;
use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Cell type of a piece; every cell in a piece has the same type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellKind {
    /// 3-node triangle, VTK type 5.
    Triangle,
    /// 2-node line segment, VTK type 3.
    Line,
}

impl CellKind {
    /// Nodes per cell.
    pub fn nodes(self) -> usize {
        match self {
            CellKind::Triangle => 3,
            CellKind::Line => 2,
        }
    }

    /// VTK cell type id.
    pub fn vtk_type(self) -> u8 {
        match self {
            CellKind::Triangle => 5,
            CellKind::Line => 3,
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

/// Error from [`read_vtu`] / [`read_pvd`].
#[derive(Debug, thiserror::Error)]
pub enum VtkError {
    #[error("cannot read VTK file {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("malformed VTK file {path}: {message}")]
    Parse { path: PathBuf, message: String },
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

// ---------------------------------------------------------------------------
// Reading (only files produced by this writer)
// ---------------------------------------------------------------------------

/// Contents of a `.vtu` file as read by [`read_vtu`].
#[derive(Debug, Clone, PartialEq)]
pub struct VtuData {
    pub points: Vec<[f64; 3]>,
    pub connectivity: Vec<u32>,
    pub offsets: Vec<u32>,
    pub types: Vec<u8>,
    /// `(name, components, values)`
    pub point_data: Vec<(String, usize, Vec<f64>)>,
    /// `(name, components, values)`
    pub cell_data: Vec<(String, usize, Vec<f64>)>,
}

impl VtuData {
    /// Values of the named point array.
    pub fn point_array(&self, name: &str) -> Option<&[f64]> {
        find_array(&self.point_data, name)
    }

    /// Values of the named cell array.
    pub fn cell_array(&self, name: &str) -> Option<&[f64]> {
        find_array(&self.cell_data, name)
    }
}

fn find_array<'a>(arrays: &'a [(String, usize, Vec<f64>)], name: &str) -> Option<&'a [f64]> {
    arrays
        .iter()
        .find(|(n, _, _)| n == name)
        .map(|(_, _, v)| v.as_slice())
}

#[derive(Debug)]
enum Token<'a> {
    Open {
        name: &'a str,
        attrs: Vec<(&'a str, String)>,
        self_closing: bool,
    },
    Close(&'a str),
    Text(&'a str),
}

/// Tiny pull tokenizer for the subset of XML this module writes.
struct Tokenizer<'a> {
    src: &'a str,
    pos: usize,
}

impl<'a> Tokenizer<'a> {
    fn next(&mut self) -> Result<Option<Token<'a>>, String> {
        let (inner, at) = loop {
            let rest = &self.src[self.pos..];
            if rest.is_empty() {
                return Ok(None);
            }
            if !rest.starts_with('<') {
                let end = rest.find('<').unwrap_or(rest.len());
                self.pos += end;
                return Ok(Some(Token::Text(&rest[..end])));
            }
            let end = rest
                .find('>')
                .ok_or_else(|| format!("unterminated tag at byte {}", self.pos))?;
            let inner = &rest[1..end];
            let at = self.pos;
            self.pos += end + 1;
            match inner.strip_prefix('?') {
                Some(decl) if decl.ends_with('?') => continue,
                Some(_) => return Err(format!("bad XML declaration at byte {at}")),
                None => break (inner, at),
            }
        };
        if let Some(name) = inner.strip_prefix('/') {
            return Ok(Some(Token::Close(name.trim())));
        }
        let (inner, self_closing) = match inner.strip_suffix('/') {
            Some(s) => (s, true),
            None => (inner, false),
        };
        let name_end = inner
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(inner.len());
        let name = &inner[..name_end];
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(format!("bad tag name '{name}' at byte {at}"));
        }
        let attrs = parse_attrs(&inner[name_end..]).map_err(|e| format!("{e} at byte {at}"))?;
        Ok(Some(Token::Open {
            name,
            attrs,
            self_closing,
        }))
    }
}

fn parse_attrs(mut s: &str) -> Result<Vec<(&str, String)>, String> {
    let mut out = Vec::new();
    loop {
        s = s.trim_start();
        if s.is_empty() {
            return Ok(out);
        }
        let eq = s.find('=').ok_or("attribute without '='")?;
        let key = s[..eq].trim();
        let after = s[eq + 1..].trim_start();
        let q = after.chars().next().ok_or("missing attribute value")?;
        if q != '"' && q != '\'' {
            return Err(format!("unquoted attribute '{key}'"));
        }
        let close = after[1..]
            .find(q)
            .ok_or_else(|| format!("unterminated attribute '{key}'"))?;
        out.push((key, unescape(&after[1..1 + close])?));
        s = &after[close + 2..];
    }
}

fn unescape(s: &str) -> Result<String, String> {
    if !s.contains('&') {
        return Ok(s.to_string());
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        let semi = rest[i..]
            .find(';')
            .ok_or_else(|| format!("bad entity in '{s}'"))?;
        out.push(match &rest[i + 1..i + semi] {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            e => return Err(format!("unknown entity '&{e};'")),
        });
        rest = &rest[i + semi + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

fn attr<'t>(attrs: &'t [(&str, String)], key: &str) -> Option<&'t str> {
    attrs
        .iter()
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v.as_str())
}

fn parse_num<T: std::str::FromStr>(s: &str, what: &str) -> Result<T, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("invalid {what} '{s}'"))
}

fn parse_list<T: std::str::FromStr>(text: &str, what: &str) -> Result<Vec<T>, String> {
    text.split_ascii_whitespace()
        .map(|t| parse_num(t, what))
        .collect()
}

/// Checks open/close nesting; returns the element stack.
struct Nesting<'a> {
    stack: Vec<&'a str>,
}

impl<'a> Nesting<'a> {
    fn close(&mut self, name: &str) -> Result<(), String> {
        match self.stack.pop() {
            Some(open) if open == name => Ok(()),
            Some(open) => Err(format!("</{name}> closes <{open}>")),
            None => Err(format!("unexpected </{name}>")),
        }
    }
}

struct RawArray {
    section: String,
    name: String,
    kind: String,
    components: usize,
    text: String,
}

/// Walk the document, collecting every DataArray with its parent element and
/// every empty element (with attributes) in `leaf_tags`.
#[allow(clippy::type_complexity)]
fn scan(
    src: &str,
    root_type: &str,
) -> Result<(Vec<RawArray>, Vec<(String, Vec<(String, String)>)>), String> {
    let mut tk = Tokenizer { src, pos: 0 };
    let mut nest = Nesting { stack: Vec::new() };
    let mut arrays = Vec::new();
    let mut leaves = Vec::new();
    let mut seen_root = false;
    let mut current: Option<RawArray> = None;
    while let Some(tok) = tk.next()? {
        match tok {
            Token::Open {
                name,
                attrs,
                self_closing,
            } => {
                if current.is_some() {
                    return Err(format!("<{name}> inside DataArray"));
                }
                if nest.stack.is_empty() {
                    if seen_root || name != "VTKFile" {
                        return Err(format!("unexpected root element <{name}>"));
                    }
                    if attr(&attrs, "type") != Some(root_type) {
                        return Err(format!("VTKFile type is not {root_type}"));
                    }
                    seen_root = true;
                }
                if name == "DataArray" {
                    if let Some(f) = attr(&attrs, "format")
                        && f != "ascii"
                    {
                        return Err(format!("unsupported DataArray format '{f}'"));
                    }
                    let components = match attr(&attrs, "NumberOfComponents") {
                        Some(c) => parse_num::<usize>(c, "NumberOfComponents")?,
                        None => 1,
                    };
                    if components == 0 {
                        return Err("NumberOfComponents is 0".into());
                    }
                    let a = RawArray {
                        section: nest.stack.last().unwrap_or(&"").to_string(),
                        name: attr(&attrs, "Name").unwrap_or("").to_string(),
                        kind: attr(&attrs, "type").unwrap_or("").to_string(),
                        components,
                        text: String::new(),
                    };
                    if self_closing {
                        arrays.push(a);
                    } else {
                        current = Some(a);
                        nest.stack.push(name);
                    }
                } else if self_closing {
                    if nest.stack.is_empty() {
                        return Err(format!("unexpected root element <{name}/>"));
                    }
                    leaves.push((
                        name.to_string(),
                        attrs.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
                    ));
                } else {
                    if name == "Piece" {
                        leaves.push((
                            name.to_string(),
                            attrs.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
                        ));
                    }
                    nest.stack.push(name);
                }
            }
            Token::Close(name) => {
                nest.close(name)?;
                if name == "DataArray" {
                    arrays.extend(current.take());
                }
            }
            Token::Text(t) => {
                if let Some(a) = current.as_mut() {
                    a.text.push_str(t);
                } else if !t.trim().is_empty() {
                    return Err(format!(
                        "unexpected text '{}'",
                        t.trim().chars().take(20).collect::<String>()
                    ));
                }
            }
        }
    }
    if !seen_root {
        return Err("no VTKFile element (empty or truncated file)".into());
    }
    if let Some(open) = nest.stack.last() {
        return Err(format!("truncated file: <{open}> is never closed"));
    }
    Ok((arrays, leaves))
}

fn read_to_string(path: &Path) -> Result<String, VtkError> {
    let bytes = fs::read(path).map_err(|source| VtkError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|_| VtkError::Parse {
        path: path.to_path_buf(),
        message: "not valid UTF-8".into(),
    })
}

fn parse_vtu(src: &str) -> Result<VtuData, String> {
    let (arrays, leaves) = scan(src, "UnstructuredGrid")?;
    let pieces: Vec<_> = leaves.iter().filter(|(n, _)| n == "Piece").collect();
    if pieces.len() != 1 {
        return Err(format!("expected exactly 1 Piece, found {}", pieces.len()));
    }
    let pattrs = &pieces[0].1;
    let get = |k: &str| -> Result<usize, String> {
        let v = pattrs
            .iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.as_str())
            .ok_or_else(|| format!("Piece lacks {k}"))?;
        parse_num(v, k)
    };
    let np = get("NumberOfPoints")?;
    let nc = get("NumberOfCells")?;

    let mut out = VtuData {
        points: Vec::new(),
        connectivity: Vec::new(),
        offsets: Vec::new(),
        types: Vec::new(),
        point_data: Vec::new(),
        cell_data: Vec::new(),
    };
    let (mut got_points, mut got_conn, mut got_off, mut got_types) = (false, false, false, false);
    for a in arrays {
        let what = format!("value in {} array '{}'", a.section, a.name);
        match a.section.as_str() {
            "Points" => {
                if a.components != 3 {
                    return Err("Points array must have 3 components".into());
                }
                let v: Vec<f64> = parse_list(&a.text, &what)?;
                if v.len() != 3 * np {
                    return Err(format!(
                        "Points has {} values, expected {}",
                        v.len(),
                        3 * np
                    ));
                }
                out.points = v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                got_points = true;
            }
            "Cells" => match a.name.as_str() {
                "connectivity" => {
                    out.connectivity = parse_list(&a.text, &what)?;
                    got_conn = true;
                }
                "offsets" => {
                    out.offsets = parse_list(&a.text, &what)?;
                    got_off = true;
                }
                "types" => {
                    out.types = parse_list(&a.text, &what)?;
                    got_types = true;
                }
                other => return Err(format!("unknown Cells array '{other}'")),
            },
            "PointData" | "CellData" => {
                if a.kind != "Float64" {
                    return Err(format!("array '{}' has type '{}'", a.name, a.kind));
                }
                let n = if a.section == "PointData" { np } else { nc };
                let v: Vec<f64> = parse_list(&a.text, &what)?;
                if v.len() != n * a.components {
                    return Err(format!(
                        "{} array '{}' has {} values, expected {} x {}",
                        a.section,
                        a.name,
                        v.len(),
                        n,
                        a.components
                    ));
                }
                let entry = (a.name, a.components, v);
                if a.section == "PointData" {
                    out.point_data.push(entry);
                } else {
                    out.cell_data.push(entry);
                }
            }
            other => return Err(format!("DataArray in unexpected element <{other}>")),
        }
    }
    if !(got_points && got_conn && got_off && got_types) {
        return Err("missing Points or Cells arrays".into());
    }
    if out.offsets.len() != nc || out.types.len() != nc {
        return Err(format!(
            "{} offsets / {} types for {nc} cells",
            out.offsets.len(),
            out.types.len()
        ));
    }
    let mut prev = 0u32;
    for &o in &out.offsets {
        if o < prev {
            return Err("offsets are not non-decreasing".into());
        }
        prev = o;
    }
    if prev as usize != out.connectivity.len() {
        return Err(format!(
            "last offset {prev} != connectivity length {}",
            out.connectivity.len()
        ));
    }
    if let Some(&bad) = out.connectivity.iter().find(|&&i| i as usize >= np) {
        return Err(format!("connectivity index {bad} >= {np} points"));
    }
    Ok(out)
}

/// Read a `.vtu` written by [`write_vtu`]. Errors (never panics) on
/// truncated, garbled or inconsistent input.
pub fn read_vtu(path: &Path) -> Result<VtuData, VtkError> {
    let src = read_to_string(path)?;
    parse_vtu(&src).map_err(|message| VtkError::Parse {
        path: path.to_path_buf(),
        message,
    })
}

fn parse_pvd(src: &str) -> Result<Vec<(f64, String)>, String> {
    let (arrays, leaves) = scan(src, "Collection")?;
    if !arrays.is_empty() {
        return Err("unexpected DataArray in collection".into());
    }
    leaves
        .iter()
        .filter(|(n, _)| n == "DataSet")
        .map(|(_, attrs)| {
            let get = |k: &str| {
                attrs
                    .iter()
                    .find(|(key, _)| key == k)
                    .map(|(_, v)| v.as_str())
                    .ok_or_else(|| format!("DataSet lacks {k}"))
            };
            Ok((
                parse_num(get("timestep")?, "timestep")?,
                get("file")?.to_string(),
            ))
        })
        .collect()
}

/// Read a `.pvd` written by [`PvdWriter`]: `(timestep, file)` in file order.
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, String)>, VtkError> {
    let src = read_to_string(path)?;
    parse_pvd(&src).map_err(|message| VtkError::Parse {
        path: path.to_path_buf(),
        message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("vtk_test_{}_{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

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
        let dir = tmp_dir("tri");
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
        assert_eq!(bits(d.cell_array("stress & <x>").unwrap()), bits(&stress));
        assert!(d.point_array("nope").is_none());
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn line_piece_round_trip() {
        let dir = tmp_dir("line");
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

    #[test]
    fn non_finite_values_are_written_as_tokens() {
        let dir = tmp_dir("nonfinite");
        let path = dir.join("nf.vtu");
        let vals = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        write_vtu(
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
        .unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.contains("nan inf -inf"));
        let d = read_vtu(&path).unwrap();
        let f = d.point_array("f").unwrap();
        assert!(f[0].is_nan());
        assert_eq!(f[1], f64::INFINITY);
        assert_eq!(f[2], f64::NEG_INFINITY);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn inconsistent_piece_is_rejected() {
        let dir = tmp_dir("bad");
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
    fn pvd_lists_entries_in_order() {
        let dir = tmp_dir("pvd");
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
        let dir = tmp_dir("trunc");
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

    #[test]
    fn no_tmp_file_remains() {
        let dir = tmp_dir("tmp");
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
        // ~200k triangles in a debug build; guards against per-value allocation.
        let dir = tmp_dir("large");
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
}
