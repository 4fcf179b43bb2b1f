//! Test support: a reader for the ASCII `.vtu` pieces and `.pvd` indexes that
//! `hydrofrac::output::vtk` writes, on the `roxmltree` XML parser. Integration tests pull it in
//! with `#[path = "support/vtu.rs"] mod vtu;`.
//!
//! It accepts only what the writer produces (one `Piece`, ascii `DataArray`s, Float64 point and
//! cell data) and checks the sizes against each other, so a test that reads a file back fails
//! when the writer writes the wrong number of points, cells or values. It returns an error,
//! never panics, on truncated, garbled or inconsistent input.

// Each test crate uses only part of this module.
#![allow(dead_code)]

use roxmltree::{Document, Node};
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

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

/// Error from [`read_vtu`] / [`read_pvd`].
#[derive(Debug)]
pub enum VtkError {
    Io { path: PathBuf, source: io::Error },
    Parse { path: PathBuf, message: String },
}

impl fmt::Display for VtkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VtkError::Io { path, source } => {
                write!(f, "cannot read VTK file {}: {source}", path.display())
            }
            VtkError::Parse { path, message } => {
                write!(f, "malformed VTK file {}: {message}", path.display())
            }
        }
    }
}

impl std::error::Error for VtkError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            VtkError::Io { source, .. } => Some(source),
            VtkError::Parse { .. } => None,
        }
    }
}

/// Read a `.vtu` written by `hydrofrac::output::vtk::write_vtu`.
pub fn read_vtu(path: &Path) -> Result<VtuData, VtkError> {
    let src = read_to_string(path)?;
    parse_vtu(&src).map_err(|message| VtkError::Parse {
        path: path.to_path_buf(),
        message,
    })
}

/// Read a `.pvd` written by `hydrofrac::output::vtk::PvdWriter`: `(timestep, file)` in file
/// order.
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, String)>, VtkError> {
    let src = read_to_string(path)?;
    parse_pvd(&src).map_err(|message| VtkError::Parse {
        path: path.to_path_buf(),
        message,
    })
}

fn read_to_string(path: &Path) -> Result<String, VtkError> {
    let bytes = std::fs::read(path).map_err(|source| VtkError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|_| VtkError::Parse {
        path: path.to_path_buf(),
        message: "not valid UTF-8".into(),
    })
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

fn required<'a>(node: Node<'a, '_>, key: &str) -> Result<&'a str, String> {
    node.attribute(key)
        .ok_or_else(|| format!("<{}> lacks {key}", node.tag_name().name()))
}

/// Parse `src` and check the root is `<VTKFile type="{root_type}">` and that no text other than
/// white space stands outside a `DataArray`.
fn parse_document<'a>(src: &'a str, root_type: &str) -> Result<Document<'a>, String> {
    let doc = Document::parse(src).map_err(|e| e.to_string())?;
    let root = doc.root_element();
    if root.tag_name().name() != "VTKFile" {
        return Err(format!(
            "unexpected root element <{}>",
            root.tag_name().name()
        ));
    }
    if root.attribute("type") != Some(root_type) {
        return Err(format!("VTKFile type is not {root_type}"));
    }
    for n in doc.descendants().filter(|n| n.is_text()) {
        let in_array = n.parent().is_some_and(|p| p.has_tag_name("DataArray"));
        let text = n.text().unwrap_or("").trim();
        if !in_array && !text.is_empty() {
            return Err(format!(
                "unexpected text '{}'",
                text.chars().take(20).collect::<String>()
            ));
        }
    }
    Ok(doc)
}

fn parse_vtu(src: &str) -> Result<VtuData, String> {
    let doc = parse_document(src, "UnstructuredGrid")?;
    let pieces: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("Piece"))
        .collect();
    if pieces.len() != 1 {
        return Err(format!("expected exactly 1 Piece, found {}", pieces.len()));
    }
    let np: usize = parse_num(required(pieces[0], "NumberOfPoints")?, "NumberOfPoints")?;
    let nc: usize = parse_num(required(pieces[0], "NumberOfCells")?, "NumberOfCells")?;

    let mut out = VtuData {
        points: Vec::new(),
        connectivity: Vec::new(),
        offsets: Vec::new(),
        types: Vec::new(),
        point_data: Vec::new(),
        cell_data: Vec::new(),
    };
    let (mut got_points, mut got_conn, mut got_off, mut got_types) = (false, false, false, false);
    for a in doc.descendants().filter(|n| n.has_tag_name("DataArray")) {
        if let Some(e) = a.children().find(|c| c.is_element()) {
            return Err(format!("<{}> inside DataArray", e.tag_name().name()));
        }
        if let Some(f) = a.attribute("format")
            && f != "ascii"
        {
            return Err(format!("unsupported DataArray format '{f}'"));
        }
        let components = match a.attribute("NumberOfComponents") {
            Some(c) => parse_num::<usize>(c, "NumberOfComponents")?,
            None => 1,
        };
        if components == 0 {
            return Err("NumberOfComponents is 0".into());
        }
        let section = a.parent_element().map_or("", |p| p.tag_name().name());
        let name = a.attribute("Name").unwrap_or("");
        let kind = a.attribute("type").unwrap_or("");
        let text: String = a.children().filter_map(|c| c.text()).collect();
        let what = format!("value in {section} array '{name}'");
        match section {
            "Points" => {
                if components != 3 {
                    return Err("Points array must have 3 components".into());
                }
                let v: Vec<f64> = parse_list(&text, &what)?;
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
            "Cells" => match name {
                "connectivity" => {
                    out.connectivity = parse_list(&text, &what)?;
                    got_conn = true;
                }
                "offsets" => {
                    out.offsets = parse_list(&text, &what)?;
                    got_off = true;
                }
                "types" => {
                    out.types = parse_list(&text, &what)?;
                    got_types = true;
                }
                other => return Err(format!("unknown Cells array '{other}'")),
            },
            "PointData" | "CellData" => {
                if kind != "Float64" {
                    return Err(format!("array '{name}' has type '{kind}'"));
                }
                let n = if section == "PointData" { np } else { nc };
                let v: Vec<f64> = parse_list(&text, &what)?;
                if v.len() != n * components {
                    return Err(format!(
                        "{section} array '{name}' has {} values, expected {n} x {components}",
                        v.len(),
                    ));
                }
                let entry = (name.to_string(), components, v);
                if section == "PointData" {
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

fn parse_pvd(src: &str) -> Result<Vec<(f64, String)>, String> {
    let doc = parse_document(src, "Collection")?;
    if doc.descendants().any(|n| n.has_tag_name("DataArray")) {
        return Err("unexpected DataArray in collection".into());
    }
    doc.descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|d| {
            Ok((
                parse_num(required(d, "timestep")?, "timestep")?,
                required(d, "file")?.to_string(),
            ))
        })
        .collect()
}
