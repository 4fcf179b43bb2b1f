//! Reader for Gmsh `.msh` files (ASCII format 4.1 and 2.2): 2D triangle meshes
//! ([`parse_msh`]) and 3D tetrahedral meshes with the surfaces they embed ([`parse_msh3`]).
//!
//! Only 3-node triangles (element type 2) are kept; points, lines and other element types are
//! skipped, except second-order triangles and quadrilaterals, which are rejected with a hint.
//! Node tags are mapped to compact 0-based indices in order of first appearance in `$Nodes`,
//! nodes not used by any triangle are dropped, and every triangle is made counter-clockwise.

use crate::mesh::signed_area;
use std::collections::HashMap;
use std::path::Path;
use std::str::FromStr;

/// Node coordinates (x, y; z ignored, must be ~0) and counter-clockwise triangles (0-based node
/// indices into `nodes`), plus the physical-group name of each triangle's group if any.
#[derive(Debug, Clone, PartialEq)]
pub struct GmshMesh {
    pub nodes: Vec<[f64; 2]>,
    pub triangles: Vec<[u32; 3]>,
    pub physical: Vec<Option<String>>,
}

/// Errors from reading a `.msh` file: one-line messages that start with the file path and,
/// where one applies, the 1-based line number (`path:line: ...`).
#[derive(Debug, thiserror::Error)]
pub enum GmshError {
    #[error("{path}: cannot read file: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    /// Binary files, format versions other than 2.2 and 4.1+, files without `$MeshFormat`.
    #[error("{path}:{line}: unsupported mesh format: {msg}")]
    UnsupportedFormat {
        path: String,
        line: usize,
        msg: String,
    },
    /// Malformed content: truncation, wrong counts, bad tokens, unknown or duplicate nodes.
    #[error("{path}:{line}: {msg}")]
    Parse {
        path: String,
        line: usize,
        msg: String,
    },
    /// Second-order triangles and quadrilaterals.
    #[error("{path}:{line}: {msg}")]
    UnsupportedElement {
        path: String,
        line: usize,
        msg: String,
    },
    #[error("{path}: no 3-node triangles (element type 2) in the mesh")]
    NoTriangles { path: String },
    #[error("{path}:{line}: element {tag}: degenerate triangle (area {area:e})")]
    BadTriangle {
        path: String,
        line: usize,
        tag: u64,
        area: f64,
    },
    /// Two triangles that cover the same ground (a surface meshed twice, a fold).
    #[error("{path}:{line}: element {tag} overlaps element {other} (line {other_line}): {why}")]
    Overlap {
        path: String,
        line: usize,
        tag: u64,
        other: u64,
        other_line: usize,
        why: &'static str,
    },
    #[error("{path}: no 4-node tetrahedra (element type 4) in the mesh")]
    NoTetrahedra { path: String },
    #[error("{path}:{line}: element {tag}: degenerate tetrahedron (volume {volume:e})")]
    BadTetrahedron {
        path: String,
        line: usize,
        tag: u64,
        volume: f64,
    },
    /// A surface triangle that is not a face of the tetrahedra (the surface was not embedded
    /// in the volume mesh, e.g. a fracture meshed on its own).
    #[error(
        "{path}:{line}: element {tag}: triangle is not a face of the tetrahedra (embed the surface in the volume: Gmsh's Surface{{..}} In Volume{{..}} or BooleanFragments)"
    )]
    NotEmbedded { path: String, line: usize, tag: u64 },
    #[error("{path}:{line}: node {tag}: z = {z:e}, but the mesh must lie in the plane z = 0")]
    NotPlanar {
        path: String,
        line: usize,
        tag: u64,
        z: f64,
    },
}

/// Reads and parses a `.msh` file (see [`parse_msh`]).
pub fn read_msh(path: &Path) -> Result<GmshMesh, GmshError> {
    read_with(path, parse_msh)
}

/// Read a file and hand its text and shown path to `parse`.
fn read_with<T>(
    path: &Path,
    parse: fn(&str, &str) -> Result<T, GmshError>,
) -> Result<T, GmshError> {
    let shown = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| GmshError::Io {
        path: shown.clone(),
        source,
    })?;
    // Lossy, so that a binary file still reaches the header check and gets a clear message.
    parse(&String::from_utf8_lossy(&bytes), &shown)
}

/// Parses the text of a `.msh` file; `path_for_messages` is only used in error messages.
pub fn parse_msh(text: &str, path_for_messages: &str) -> Result<GmshMesh, GmshError> {
    build(read_raw(text, path_for_messages, false)?, path_for_messages)
}

/// The sections of a `.msh` file into [`Raw`] (tetrahedra kept when `three_d`).
fn read_raw(text: &str, path: &str, three_d: bool) -> Result<Raw, GmshError> {
    let mut lines = Lines {
        path,
        iter: text.lines().enumerate(),
        last: 0,
    };
    let v4 = read_format(&mut lines)?;
    let mut raw = Raw {
        three_d,
        ..Raw::default()
    };
    while let Some((line, header)) = lines.next() {
        match header {
            "$PhysicalNames" => read_physical_names(&mut lines, &mut raw)?,
            "$Entities" if v4 => read_entities(&mut lines, &mut raw)?,
            "$Nodes" if v4 => read_nodes_v4(&mut lines, &mut raw)?,
            "$Nodes" => read_nodes_v2(&mut lines, &mut raw)?,
            "$Elements" if v4 => read_elements_v4(&mut lines, &mut raw)?,
            "$Elements" => read_elements_v2(&mut lines, &mut raw)?,
            h if h.starts_with('$') && !h.starts_with("$End") => lines.skip_section(&h[1..])?,
            h => return Err(parse_err(path, line, format!("unexpected '{h}'"))),
        }
    }
    Ok(raw)
}

fn parse_err(path: &str, line: usize, msg: String) -> GmshError {
    GmshError::Parse {
        path: path.to_string(),
        line: line.max(1),
        msg,
    }
}

/// Non-blank, trimmed lines with their 1-based numbers.
struct Lines<'a> {
    path: &'a str,
    iter: std::iter::Enumerate<std::str::Lines<'a>>,
    /// Number of the last line read (blank or not), for end-of-file messages.
    last: usize,
}

impl<'a> Lines<'a> {
    fn next(&mut self) -> Option<(usize, &'a str)> {
        for (i, text) in self.iter.by_ref() {
            self.last = i + 1;
            if !text.trim().is_empty() {
                return Some((i + 1, text.trim()));
            }
        }
        None
    }

    fn eof(&self, what: &str) -> GmshError {
        parse_err(
            self.path,
            self.last,
            format!("unexpected end of file, expected {what}"),
        )
    }

    /// The next line split into tokens; `what` describes the expected content for messages.
    fn record(&mut self, what: &str) -> Result<Record<'a>, GmshError> {
        let (line, text) = self.next().ok_or_else(|| self.eof(what))?;
        if text.starts_with('$') {
            let msg = format!("expected {what}, found '{text}' (fewer entries than declared)");
            return Err(parse_err(self.path, line, msg));
        }
        let toks = text.split_whitespace().collect();
        Ok(Record {
            path: self.path,
            line,
            text,
            toks,
        })
    }

    /// A line holding a single count.
    fn count(&mut self, what: &str) -> Result<usize, GmshError> {
        let rec = self.record(what)?;
        rec.len(1)?;
        rec.get(0, what)
    }

    fn expect_end(&mut self, section: &str) -> Result<(), GmshError> {
        let want = format!("$End{section}");
        match self.next() {
            Some((_, text)) if text == want => Ok(()),
            Some((line, text)) => {
                let msg = format!("expected {want}, found '{text}' (more entries than declared?)");
                Err(parse_err(self.path, line, msg))
            }
            None => Err(self.eof(&want)),
        }
    }

    fn skip_section(&mut self, section: &str) -> Result<(), GmshError> {
        let want = format!("$End{section}");
        while let Some((_, text)) = self.next() {
            if text == want {
                return Ok(());
            }
        }
        Err(self.eof(&want))
    }
}

/// One line of whitespace-separated tokens.
struct Record<'a> {
    path: &'a str,
    line: usize,
    text: &'a str,
    toks: Vec<&'a str>,
}

impl Record<'_> {
    fn err(&self, msg: String) -> GmshError {
        parse_err(self.path, self.line, msg)
    }

    fn len(&self, n: usize) -> Result<(), GmshError> {
        match self.toks.len() {
            len if len == n => Ok(()),
            len => Err(self.err(format!("expected {n} values, found {len}: '{}'", self.text))),
        }
    }

    fn get<T: FromStr>(&self, i: usize, what: &str) -> Result<T, GmshError> {
        let missing = || self.err(format!("missing {what}: '{}'", self.text));
        let tok = self.toks.get(i).ok_or_else(missing)?;
        tok.parse()
            .map_err(|_| self.err(format!("invalid {what} '{tok}'")))
    }

    /// `N` consecutive values starting at token `first`.
    fn array<T: FromStr + Copy + Default, const N: usize>(
        &self,
        first: usize,
        what: &str,
    ) -> Result<[T; N], GmshError> {
        let mut out = [T::default(); N];
        for (k, v) in out.iter_mut().enumerate() {
            *v = self.get(first + k, what)?;
        }
        Ok(out)
    }

    fn xyz(&self, first: usize) -> Result<[f64; 3], GmshError> {
        let xyz: [f64; 3] = self.array(first, "coordinate")?;
        match xyz.iter().find(|v| !v.is_finite()) {
            Some(v) => Err(self.err(format!("non-finite coordinate '{v}'"))),
            None => Ok(xyz),
        }
    }
}

/// Tag, line number and x y z of a node.
type RawNode = (u64, usize, [f64; 3]);

struct RawTri {
    tag: u64,
    line: usize,
    nodes: [u64; 3],
    physical: Option<String>,
}

struct RawTet {
    tag: u64,
    line: usize,
    nodes: [u64; 4],
    physical: Option<String>,
}

/// What the reader keeps of an element type.
#[derive(PartialEq)]
enum Kind {
    Triangle,
    Tetrahedron,
    Skip,
}

#[derive(Default)]
struct Raw {
    /// Names of 2D physical groups by physical tag.
    names: HashMap<i64, String>,
    /// Physical tags of each surface entity (format 4.1).
    surfaces: HashMap<i64, Vec<i64>>,
    /// Node tag -> index into `nodes` (order of first appearance).
    node_index: HashMap<u64, usize>,
    nodes: Vec<RawNode>,
    tris: Vec<RawTri>,
    /// 3D reading ([`parse_msh3`]): tetrahedra kept, volumes' physical names and tags.
    three_d: bool,
    names3: HashMap<i64, String>,
    volumes: HashMap<i64, Vec<i64>>,
    tets: Vec<RawTet>,
}

impl Raw {
    fn add_node(&mut self, rec: &Record, tag: u64, xyz: [f64; 3]) -> Result<(), GmshError> {
        if self.node_index.insert(tag, self.nodes.len()).is_some() {
            return Err(rec.err(format!("duplicate node tag {tag}")));
        }
        self.nodes.push((tag, rec.line, xyz));
        Ok(())
    }

    /// A tetrahedron whose four node tags start at token `first` and end the line.
    fn add_tet(
        &mut self,
        rec: &Record,
        first: usize,
        physical: Option<String>,
    ) -> Result<(), GmshError> {
        rec.len(first.saturating_add(4))?;
        let tag = rec.get(0, "element tag")?;
        let nodes = rec.array(first, "node tag")?;
        self.tets.push(RawTet {
            tag,
            line: rec.line,
            nodes,
            physical,
        });
        Ok(())
    }

    /// A triangle whose three node tags start at token `first` and end the line.
    fn add_tri(
        &mut self,
        rec: &Record,
        first: usize,
        physical: Option<String>,
    ) -> Result<(), GmshError> {
        rec.len(first.saturating_add(3))?;
        let tag = rec.get(0, "element tag")?;
        let nodes = rec.array(first, "node tag")?;
        self.tris.push(RawTri {
            tag,
            line: rec.line,
            nodes,
            physical,
        });
        Ok(())
    }
}

/// Reads `$MeshFormat`; returns true for format 4.x (x >= 1), false for 2.2.
fn read_format(lines: &mut Lines) -> Result<bool, GmshError> {
    let path = lines.path.to_string();
    let unsupported = |line: usize, msg: String| GmshError::UnsupportedFormat { path, line, msg };
    match lines.next() {
        Some((_, "$MeshFormat")) => {}
        Some((line, _)) => return Err(unsupported(line, "no $MeshFormat header".into())),
        None => return Err(unsupported(1, "empty file".into())),
    }
    let rec = lines.record("'version file-type data-size'")?;
    rec.len(3)?;
    let version: f64 = rec.get(0, "format version")?;
    if rec.get::<u32>(1, "file type")? != 0 {
        return Err(unsupported(
            rec.line,
            "binary file: export with Mesh.Binary = 0".into(),
        ));
    }
    let v4 = if (version - 2.2).abs() < 1e-9 {
        false
    } else if (4.1 - 1e-9..5.0).contains(&version) {
        true
    } else {
        let msg = format!(
            "version {}: export with Mesh.MshFileVersion = 4.1 or 2.2",
            rec.toks[0]
        );
        return Err(unsupported(rec.line, msg));
    };
    lines.expect_end("MeshFormat")?;
    Ok(v4)
}

/// `$PhysicalNames`: count, then `dim tag "name"` lines; keeps the 2D ones.
fn read_physical_names(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    for _ in 0..lines.count("number of physical names")? {
        let rec = lines.record("physical name 'dim tag \"name\"'")?;
        let (dim, tag): (i32, i64) = (rec.get(0, "dimension")?, rec.get(1, "physical tag")?);
        let name = match (rec.text.find('"'), rec.text.rfind('"')) {
            (Some(a), Some(b)) if b > a => rec.text[a + 1..b].to_string(),
            _ => return Err(rec.err(format!("missing quoted name: '{}'", rec.text))),
        };
        if dim == 2 {
            raw.names.insert(tag, name);
        } else if dim == 3 {
            raw.names3.insert(tag, name);
        }
    }
    lines.expect_end("PhysicalNames")
}

/// `$Entities` (4.1): only the physical tags of surfaces are needed.
fn read_entities(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    let rec = lines.record("'numPoints numCurves numSurfaces numVolumes'")?;
    rec.len(4)?;
    let counts: [usize; 4] = rec.array(0, "entity count")?;
    for (dim, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            let rec = lines.record("entity line")?;
            if dim >= 2 {
                // tag minX minY minZ maxX maxY maxZ numPhysicalTags physicalTag... bounding...
                let nphys: usize = rec.get(7, "number of physical tags")?;
                let phys = (0..nphys).map(|k| rec.get(8 + k, "physical tag"));
                let phys = phys.collect::<Result<Vec<i64>, _>>()?;
                let map = if dim == 2 {
                    &mut raw.surfaces
                } else {
                    &mut raw.volumes
                };
                map.insert(rec.get(0, "entity tag")?, phys);
            }
        }
    }
    lines.expect_end("Entities")
}

/// `$Nodes` (2.2): count, then `tag x y z` lines.
fn read_nodes_v2(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    for _ in 0..lines.count("number of nodes")? {
        let rec = lines.record("node line 'tag x y z'")?;
        rec.len(4)?;
        raw.add_node(&rec, rec.get(0, "node tag")?, rec.xyz(1)?)?;
    }
    lines.expect_end("Nodes")
}

/// `$Nodes` (4.1): blocks of `dim entity parametric n`, n tag lines, n coordinate lines.
fn read_nodes_v4(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    let header = lines.record("'numEntityBlocks numNodes minNodeTag maxNodeTag'")?;
    header.len(4)?;
    let [blocks, declared]: [usize; 2] = header.array(0, "count")?;
    let mut total = 0usize;
    for _ in 0..blocks {
        let rec = lines.record("node block 'entityDim entityTag parametric numNodes'")?;
        rec.len(4)?;
        let n: usize = rec.get(3, "number of nodes in block")?;
        let mut tags = Vec::new();
        for _ in 0..n {
            let rec = lines.record("node tag")?;
            rec.len(1)?;
            tags.push(rec.get::<u64>(0, "node tag")?);
        }
        for tag in tags {
            // Parametric blocks append u (v) after x y z; they are ignored.
            let rec = lines.record("node coordinates 'x y z'")?;
            raw.add_node(&rec, tag, rec.xyz(0)?)?;
        }
        total = total.saturating_add(n);
    }
    if total != declared {
        return Err(header.err(format!("header says {declared} nodes, blocks hold {total}")));
    }
    lines.expect_end("Nodes")
}

/// What to keep of an element type: 3-node triangles, and in 3D 4-node tetrahedra; rejects
/// second-order elements, quadrilaterals and, in 3D, hexahedra, prisms and pyramids.
fn kind(etype: u32, rec: &Record, three_d: bool) -> Result<Kind, GmshError> {
    let msg = match etype {
        2 => return Ok(Kind::Triangle),
        4 if three_d => return Ok(Kind::Tetrahedron),
        9 | 20..=25 => "second-order mesh: export with Mesh.ElementOrder = 1",
        11 | 29 | 30 if three_d => "second-order mesh: export with Mesh.ElementOrder = 1",
        3 | 10 | 16 => "quadrilaterals: use triangles",
        5..=7 | 12..=14 | 17..=19 if three_d => {
            "hexahedra, prisms or pyramids: mesh the volume with tetrahedra"
        }
        _ => return Ok(Kind::Skip),
    };
    let (path, line) = (rec.path.to_string(), rec.line);
    let msg = format!("element type {etype}: {msg}");
    Err(GmshError::UnsupportedElement { path, line, msg })
}

/// `$Elements` (2.2): count, then `tag type ntags tags... nodes...` lines.
fn read_elements_v2(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    for _ in 0..lines.count("number of elements")? {
        let rec = lines.record("element line 'tag type ntags tags... nodes...'")?;
        let k = kind(rec.get(1, "element type")?, &rec, raw.three_d)?;
        if k != Kind::Skip {
            let ntags: usize = rec.get(2, "number of tags")?;
            let names = if k == Kind::Triangle {
                &raw.names
            } else {
                &raw.names3
            };
            let physical = match ntags {
                0 => None,
                _ => names.get(&rec.get(3, "physical tag")?).cloned(),
            };
            if k == Kind::Triangle {
                raw.add_tri(&rec, ntags.saturating_add(3), physical)?;
            } else {
                raw.add_tet(&rec, ntags.saturating_add(3), physical)?;
            }
        }
    }
    lines.expect_end("Elements")
}

/// `$Elements` (4.1): blocks of `dim entity type n`, then n `tag nodes...` lines.
fn read_elements_v4(lines: &mut Lines, raw: &mut Raw) -> Result<(), GmshError> {
    let header = lines.record("'numEntityBlocks numElements minElementTag maxElementTag'")?;
    header.len(4)?;
    let [blocks, declared]: [usize; 2] = header.array(0, "count")?;
    let mut total = 0usize;
    for _ in 0..blocks {
        let rec = lines.record("element block 'entityDim entityTag elementType numElements'")?;
        rec.len(4)?;
        // Gmsh writes $PhysicalNames and $Entities before $Elements.
        let k = kind(rec.get(2, "element type")?, &rec, raw.three_d)?;
        let (entities, names) = if k == Kind::Tetrahedron {
            (&raw.volumes, &raw.names3)
        } else {
            (&raw.surfaces, &raw.names)
        };
        let phys = entities.get(&rec.get::<i64>(1, "entity tag")?);
        let physical = phys.and_then(|ps| ps.iter().find_map(|p| names.get(p).cloned()));
        let n: usize = rec.get(3, "number of elements in block")?;
        for _ in 0..n {
            let rec = lines.record("element line 'tag nodes...'")?;
            match k {
                Kind::Triangle => raw.add_tri(&rec, 1, physical.clone())?,
                Kind::Tetrahedron => raw.add_tet(&rec, 1, physical.clone())?,
                Kind::Skip => {}
            }
        }
        total = total.saturating_add(n);
    }
    if total != declared {
        let msg = format!("header says {declared} elements, blocks hold {total}");
        return Err(header.err(msg));
    }
    lines.expect_end("Elements")
}

/// A 3D mesh read from Gmsh: the tetrahedra (positively oriented, as [`crate::tetmesh`]
/// keeps them), each one's volume physical group, and the surface triangles the file holds
/// (fractures and boundaries embedded in the volume mesh) with their surface physical group.
/// Every surface triangle is a face of the tetrahedra.
#[derive(Debug, Clone)]
pub struct GmshMesh3 {
    pub mesh: crate::tetmesh::TetMesh,
    pub tet_physical: Vec<Option<String>>,
    pub surfaces: Vec<[u32; 3]>,
    pub surface_physical: Vec<Option<String>>,
}

/// Reads and parses a 3D `.msh` file (see [`parse_msh3`]).
pub fn read_msh3(path: &Path) -> Result<GmshMesh3, GmshError> {
    read_with(path, parse_msh3)
}

/// Parses the text of a 3D `.msh` file: 4-node tetrahedra (element type 4) and 3-node
/// triangles; second-order elements, hexahedra, prisms and pyramids are refused with a hint.
/// Node tags map to compact indices in order of first appearance, nodes used by no
/// tetrahedron are dropped (a triangle that uses one is not embedded), tetrahedra are
/// reoriented to a positive volume, and degenerate ones are refused.
pub fn parse_msh3(text: &str, path_for_messages: &str) -> Result<GmshMesh3, GmshError> {
    let path = path_for_messages;
    let raw = read_raw(text, path, true)?;
    if raw.tets.is_empty() {
        return Err(GmshError::NoTetrahedra {
            path: path.to_string(),
        });
    }
    let resolve = |node: u64, tag: u64, line: usize| {
        let msg = || format!("element {tag} refers to node {node}, not in $Nodes");
        raw.node_index
            .get(&node)
            .copied()
            .ok_or_else(|| parse_err(path, line, msg()))
    };
    let mut used = vec![false; raw.nodes.len()];
    let mut tets = Vec::with_capacity(raw.tets.len());
    for t in &raw.tets {
        let mut idx = [0usize; 4];
        for (i, &node) in idx.iter_mut().zip(&t.nodes) {
            *i = resolve(node, t.tag, t.line)?;
            used[*i] = true;
        }
        tets.push(idx);
    }
    let mut new_index = vec![u32::MAX; raw.nodes.len()];
    let mut nodes = Vec::new();
    for (i, node) in raw.nodes.iter().enumerate().filter(|&(i, _)| used[i]) {
        let too_many = |_| parse_err(path, node.1, "more than 2^32 nodes".into());
        new_index[i] = u32::try_from(nodes.len()).map_err(too_many)?;
        nodes.push(node.2);
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for q in &nodes {
        for d in 0..3 {
            lo[d] = lo[d].min(q[d]);
            hi[d] = hi[d].max(q[d]);
        }
    }
    let diag = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    let mut out = Vec::with_capacity(tets.len());
    let mut tet_physical = Vec::with_capacity(tets.len());
    for (t, idx) in raw.tets.iter().zip(tets) {
        let mut v = idx.map(|i| new_index[i]);
        let x = v.map(|k| nodes[k as usize]);
        let volume = crate::tet4::signed_volume(x[0], x[1], x[2], x[3]);
        if volume.is_nan() || volume.abs() <= 1e-15 * diag * diag * diag {
            return Err(GmshError::BadTetrahedron {
                path: path.to_string(),
                line: t.line,
                tag: t.tag,
                volume,
            });
        }
        if volume < 0.0 {
            v.swap(2, 3);
        }
        out.push(v);
        tet_physical.push(t.physical.clone());
    }
    let mesh = crate::tetmesh::TetMesh {
        nodes,
        tets: out,
        bbox: [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]],
        frame: None,
    };
    let faces = mesh.faces();
    let (mut surfaces, mut surface_physical) = (Vec::new(), Vec::new());
    for t in &raw.tris {
        let mut f = [0u32; 3];
        for (k, &node) in f.iter_mut().zip(&t.nodes) {
            let i = resolve(node, t.tag, t.line)?;
            *k = new_index[i];
        }
        let mut key = f;
        key.sort_unstable();
        if f.contains(&u32::MAX) || !faces.contains_key(&key) {
            return Err(GmshError::NotEmbedded {
                path: path.to_string(),
                line: t.line,
                tag: t.tag,
            });
        }
        surfaces.push(f);
        surface_physical.push(t.physical.clone());
    }
    Ok(GmshMesh3 {
        mesh,
        tet_physical,
        surfaces,
        surface_physical,
    })
}

/// Resolves node tags, drops orphan nodes, checks planarity and orientation.
fn build(raw: Raw, path: &str) -> Result<GmshMesh, GmshError> {
    if raw.tris.is_empty() {
        return Err(GmshError::NoTriangles {
            path: path.to_string(),
        });
    }
    // Raw node indices of each triangle, and which nodes are used.
    let mut used = vec![false; raw.nodes.len()];
    let mut tris = Vec::with_capacity(raw.tris.len());
    for t in &raw.tris {
        let mut idx = [0usize; 3];
        for (i, node) in idx.iter_mut().zip(t.nodes) {
            let msg = || format!("element {} refers to node {node}, not in $Nodes", t.tag);
            let found = raw.node_index.get(&node);
            *i = *found.ok_or_else(|| parse_err(path, t.line, msg()))?;
            used[*i] = true;
        }
        tris.push(idx);
    }

    // Compact numbering of the used nodes, in order of first appearance.
    let mut new_index = vec![0u32; raw.nodes.len()];
    let mut kept: Vec<&RawNode> = Vec::new();
    for (i, node) in raw.nodes.iter().enumerate().filter(|&(i, _)| used[i]) {
        let too_many = |_| parse_err(path, node.1, "more than 2^32 nodes".into());
        new_index[i] = u32::try_from(kept.len()).map_err(too_many)?;
        kept.push(node);
    }

    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &&(_, _, xyz) in &kept {
        for d in 0..2 {
            lo[d] = lo[d].min(xyz[d]);
            hi[d] = hi[d].max(xyz[d]);
        }
    }
    let diag = (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
    if let Some(&&(tag, line, [_, _, z])) = kept.iter().find(|n| n.2[2].abs() > 1e-9 * diag) {
        return Err(GmshError::NotPlanar {
            path: path.to_string(),
            line,
            tag,
            z,
        });
    }

    let nodes = kept.iter().map(|&&(_, _, [x, y, _])| [x, y]).collect();
    let mut mesh = GmshMesh {
        nodes,
        triangles: Vec::new(),
        physical: Vec::new(),
    };
    let lines: Vec<(u64, usize)> = raw.tris.iter().map(|t| (t.tag, t.line)).collect();
    for (t, idx) in raw.tris.into_iter().zip(tris) {
        let [a, b, c] = idx.map(|i| new_index[i]);
        let area = triangle_area(&mesh.nodes, [a, b, c]);
        if area.is_nan() || area.abs() <= 1e-14 * diag * diag {
            let (line, tag) = (t.line, t.tag);
            return Err(GmshError::BadTriangle {
                path: path.to_string(),
                line,
                tag,
                area,
            });
        }
        let ccw = if area < 0.0 { [a, c, b] } else { [a, b, c] };
        mesh.triangles.push(ccw);
        mesh.physical.push(t.physical);
    }
    if let Some((i, j, why)) = overlap(&mesh) {
        let ((tag, line), (other, other_line)) = (lines[i], lines[j]);
        return Err(GmshError::Overlap {
            path: path.to_string(),
            line,
            tag,
            other,
            other_line,
            why,
        });
    }
    Ok(mesh)
}

/// Two triangles of `mesh` (counter-clockwise) that overlap, and how: an edge shared by more
/// than two triangles or by two on the same side of it, or a triangle whose centroid lies
/// inside another (a surface meshed twice over its own nodes). `None` for a conforming mesh.
/// A bucket grid of the triangles' boxes (cells of the mean box size) keeps it near linear.
fn overlap(mesh: &GmshMesh) -> Option<(usize, usize, &'static str)> {
    let mut edges: HashMap<(u32, u32), (usize, bool)> = HashMap::new();
    for (k, t) in mesh.triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            let key = (a.min(b), a.max(b));
            match edges.insert(key, (k, a < b)) {
                None => {}
                Some((usize::MAX, _)) => {
                    let j = edges_owner(mesh, key, k);
                    return Some((k, j, "an edge shared by three triangles"));
                }
                Some((_, forward)) if forward != (a < b) => {
                    // The second use, from the other side: the key now marks the edge full.
                    edges.insert(key, (usize::MAX, forward));
                }
                Some((j, _)) => {
                    return Some((k, j, "both lie on the same side of a shared edge"));
                }
            }
        }
    }
    let boxes: Vec<[f64; 4]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.nodes[i as usize]);
            [
                p[0][0].min(p[1][0]).min(p[2][0]),
                p[0][1].min(p[1][1]).min(p[2][1]),
                p[0][0].max(p[1][0]).max(p[2][0]),
                p[0][1].max(p[1][1]).max(p[2][1]),
            ]
        })
        .collect();
    let n = boxes.len() as f64;
    let size = boxes
        .iter()
        .map(|b| (b[2] - b[0]).max(b[3] - b[1]))
        .sum::<f64>()
        / n;
    let cell = |x: f64, y: f64| ((x / size).floor() as i64, (y / size).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (k, b) in boxes.iter().enumerate() {
        let (lo, hi) = (cell(b[0], b[1]), cell(b[2], b[3]));
        for i in lo.0..=hi.0 {
            for j in lo.1..=hi.1 {
                grid.entry((i, j)).or_default().push(k);
            }
        }
    }
    for (k, t) in mesh.triangles.iter().enumerate() {
        let p = t.map(|i| mesh.nodes[i as usize]);
        let c = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
        ];
        for &j in &grid[&cell(c[0], c[1])] {
            if j != k && strictly_inside(mesh, mesh.triangles[j], c) {
                return Some((
                    k.max(j),
                    k.min(j),
                    "the centroid of one lies inside the other",
                ));
            }
        }
    }
    None
}

/// A triangle that uses the edge `key`, other than `k` (for the message).
fn edges_owner(mesh: &GmshMesh, key: (u32, u32), k: usize) -> usize {
    mesh.triangles
        .iter()
        .enumerate()
        .find(|(j, t)| {
            *j != k
                && (0..3).any(|e| {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    (a.min(b), a.max(b)) == key
                })
        })
        .map_or(k, |(j, _)| j)
}

/// Whether `c` lies inside the counter-clockwise triangle `t`, away from its edges by more
/// than 1e-9 of its area (a centroid on a shared edge is not an overlap).
fn strictly_inside(mesh: &GmshMesh, t: [u32; 3], c: [f64; 2]) -> bool {
    let p = t.map(|i| mesh.nodes[i as usize]);
    let area = signed_area(p[0], p[1], p[2]);
    let tol = 1e-9 * area.abs();
    (0..3).all(|e| signed_area(p[e], p[(e + 1) % 3], c) > tol)
}

/// Signed area of triangle `t` of `nodes` ([`signed_area`]), m^2.
fn triangle_area(nodes: &[[f64; 2]], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| nodes[i as usize]);
    signed_area(a, b, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit square split into 4 triangles around a centre node, as Gmsh 4.1 writes it
    /// (with a point element, a boundary line and physical groups "left" (curve) and "rock").
    const SQUARE_41: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
1 2 "left"
2 1 "rock"
$EndPhysicalNames
$Entities
4 4 1 0
1 0 0 0 0
2 1 0 0 0
3 1 1 0 0
4 0 1 0 0
1 0 0 0 1 0 0 0 2 1 -2
2 1 0 0 1 1 0 0 2 2 -3
3 0 1 0 1 1 0 0 2 3 -4
4 0 0 0 0 1 0 1 2 2 4 -1
1 0 0 0 1 1 0 1 1 4 1 2 3 4
$EndEntities
$Nodes
6 5 1 5
0 1 0 1
1
0 0 0
0 2 0 1
2
1 0 0
0 3 0 1
3
1 1 0
0 4 0 1
4
0 1 0
1 1 0 0
2 1 0 1
5
0.5 0.5 0
$EndNodes
$Elements
3 6 1 6
0 1 15 1
1 1
1 4 1 1
2 4 1
2 1 2 4
3 1 2 5
4 2 3 5
5 3 4 5
6 4 1 5
$EndElements
"#;

    /// The same square in format 2.2; two triangles are in "rock", two in unnamed group 7.
    const SQUARE_22: &str = r#"$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
1 2 "left"
2 1 "rock"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
5 0.5 0.5 0
$EndNodes
$Elements
6
1 15 2 0 1 1
2 1 2 2 4 4 1
3 2 2 1 1 1 2 5
4 2 2 1 1 2 3 5
5 2 2 7 1 3 4 5
6 2 2 7 1 4 1 5
$EndElements
"#;

    /// 5 nodes, 4 CCW triangles of area 1/4 each, every node used.
    fn check_square(m: &GmshMesh) {
        assert_eq!(
            (m.nodes.len(), m.triangles.len(), m.physical.len()),
            (5, 4, 4)
        );
        let areas: Vec<f64> = m
            .triangles
            .iter()
            .map(|&t| triangle_area(&m.nodes, t))
            .collect();
        assert!(areas.iter().all(|a| (a - 0.25).abs() < 1e-12), "{areas:?}");
        let mut used = vec![false; m.nodes.len()];
        m.triangles
            .iter()
            .flatten()
            .for_each(|&i| used[i as usize] = true);
        assert!(used.iter().all(|&u| u));
    }

    /// Parsing `text` fails with a message containing `want` (path, line and kind).
    fn fails(text: &str, want: &str) -> GmshError {
        let e = parse_msh(text, "t.msh").expect_err(want);
        assert!(e.to_string().contains(want), "expected '{want}' in: {e}");
        e
    }

    #[test]
    fn square_41() {
        let m = parse_msh(SQUARE_41, "square.msh").unwrap();
        check_square(&m);
        assert_eq!((m.nodes[4], m.triangles[0]), ([0.5, 0.5], [0, 1, 4]));
        assert!(m.physical.iter().all(|p| p.as_deref() == Some("rock")));
    }

    #[test]
    fn square_22() {
        let m = parse_msh(SQUARE_22, "square.msh").unwrap();
        check_square(&m);
        assert_eq!((m.nodes[4], m.triangles[0]), ([0.5, 0.5], [0, 1, 4]));
        let names: Vec<_> = m.physical.iter().map(|p| p.as_deref()).collect();
        assert_eq!(names, [Some("rock"), Some("rock"), None, None]);
    }

    #[test]
    fn read_file_with_crlf() {
        let path = std::env::temp_dir().join(format!("gmsh_test_{}.msh", std::process::id()));
        std::fs::write(&path, SQUARE_41.replace('\n', "\r\n")).unwrap();
        let m = read_msh(&path);
        std::fs::remove_file(&path).unwrap();
        check_square(&m.unwrap());
        let e = read_msh(Path::new("/nonexistent/x.msh")).unwrap_err();
        assert!(
            matches!(e, GmshError::Io { .. }) && e.to_string().starts_with("/nonexistent/x.msh: ")
        );
    }

    #[test]
    fn clockwise_triangles_are_fixed() {
        let text = SQUARE_22
            .replace("1 1 1 2 5", "1 1 1 5 2")
            .replace("7 1 3 4 5", "7 1 4 3 5");
        assert_ne!(text, SQUARE_22);
        check_square(&parse_msh(&text, "cw.msh").unwrap());
    }

    #[test]
    fn non_contiguous_tags_and_orphan_nodes() {
        // Node 99 comes first but no triangle uses it; no $Entities, so no physical names.
        let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n2 6 10 500\n0 7 0 1\n99\n5 5 0\n\
                    2 1 0 5\n10\n20\n30\n40\n500\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 0\n$EndNodes\n\
                    $Elements\n1 4 1 4\n2 1 2 4\n1 10 20 500\n2 20 30 500\n3 30 40 500\n4 40 10 500\n\
                    $EndElements\n";
        let m = parse_msh(text, "nc.msh").unwrap();
        check_square(&m);
        assert_eq!(
            m.nodes,
            [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]]
        );
        assert_eq!(m.triangles, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]);
        assert!(m.physical.iter().all(Option::is_none));
    }

    #[test]
    fn truncated_file_is_parse_error_at_last_line() {
        for cut in [2, 21, 30, 44] {
            let text: String = SQUARE_41
                .lines()
                .take(cut)
                .map(|l| format!("{l}\n"))
                .collect();
            let e = fails(&text, &format!("t.msh:{cut}: unexpected end of file"));
            assert!(matches!(e, GmshError::Parse { line, .. } if line == cut));
        }
    }

    #[test]
    fn bad_counts_and_tokens_are_parse_errors() {
        let cases = [
            (
                SQUARE_22.replace("$Nodes\n5", "$Nodes\n6"),
                "t.msh:16: expected node line",
            ),
            (
                SQUARE_22.replace("$Nodes\n5", "$Nodes\n4"),
                "t.msh:15: expected $EndNodes",
            ),
            (
                SQUARE_22.replace("5 0.5 0.5 0", "5 0.5 abc 0"),
                "t.msh:15: invalid coordinate 'abc'",
            ),
            (
                SQUARE_22.replace("7 1 4 1 5", "7 1 4 1"),
                "t.msh:24: expected 8 values, found 7",
            ),
            (
                SQUARE_22.replace("7 1 4 1 5", "7 1 4 1 8"),
                "t.msh:24: element 6 refers to node 8",
            ),
            (
                SQUARE_22.replace("4 0 1 0\n", "4 0 1 0\n4 0 1 0\n"),
                "duplicate node tag 4",
            ),
            (
                SQUARE_41.replace("6 5 1 5", "6 4 1 5"),
                "t.msh:22: header says 4 nodes",
            ),
        ];
        for (text, want) in cases {
            assert!(matches!(fails(&text, want), GmshError::Parse { .. }));
        }
    }

    #[test]
    fn unsupported_formats() {
        let mut binary = b"$MeshFormat\n4.1 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n".to_vec();
        binary.extend([0xff, 0xfe, 0x00, 0x80]);
        let cases = [
            (
                String::from_utf8_lossy(&binary).into_owned(),
                "t.msh:2: unsupported mesh format: binary",
            ),
            (
                SQUARE_22.replace("2.2 0 8", "2.2 1 8"),
                "t.msh:2: unsupported mesh format: binary",
            ),
            (
                SQUARE_22.replace("2.2 0 8", "3.0 0 8"),
                "t.msh:2: unsupported mesh format: version 3.0",
            ),
            (
                SQUARE_41.replace("4.1 0 8", "4.0 0 8"),
                "t.msh:2: unsupported mesh format: version 4.0",
            ),
            (
                "$NOD\n1\n1 0 0 0\n$ENDNOD\n".to_string(),
                "t.msh:1: unsupported mesh format",
            ),
            (
                String::new(),
                "t.msh:1: unsupported mesh format: empty file",
            ),
        ];
        for (text, want) in cases {
            assert!(matches!(
                fails(&text, want),
                GmshError::UnsupportedFormat { .. }
            ));
        }
    }

    #[test]
    fn second_order_and_quads_rejected() {
        let order2 = "second-order mesh: export with Mesh.ElementOrder = 1";
        fails(
            &SQUARE_22
                .replace("1 1 1 2 5", "1 1 1 2 5 6 7 8")
                .replace("3 2 2", "3 9 2"),
            order2,
        );
        fails(
            &SQUARE_41.replace("2 1 2 4", "2 1 9 4"),
            &format!("t.msh:46: element type 9: {order2}"),
        );
        fails(
            &SQUARE_22.replace("3 2 2 1 1 1 2 5", "3 3 2 1 1 1 2 3 4"),
            "t.msh:21: element type 3: quadrilaterals: use triangles",
        );
    }

    /// A square meshed twice (issue 41: it ran): as a second copy over the same nodes (an
    /// edge shared by three or more triangles, or from the same side), and as a copy over
    /// its own nodes (centroids inside the other copy's triangles). A fold of one triangle
    /// over its neighbour is refused too.
    #[test]
    fn overlapping_triangles_are_refused() {
        let twice = SQUARE_22
            .replace("$Elements\n6\n", "$Elements\n10\n")
            .replace(
                "6 2 2 7 1 4 1 5\n",
                "6 2 2 7 1 4 1 5\n7 2 2 1 1 1 2 5\n8 2 2 1 1 2 3 5\n9 2 2 1 1 3 4 5\n\
                 10 2 2 1 1 4 1 5\n",
            );
        let e = fails(&twice, "t.msh:");
        assert!(
            matches!(
                e,
                GmshError::Overlap {
                    tag: 7,
                    other: 3,
                    ..
                }
            ),
            "{e}"
        );
        let copy = SQUARE_22
            .replace("$Nodes\n5\n", "$Nodes\n10\n")
            .replace(
                "5 0.5 0.5 0\n",
                "5 0.5 0.5 0\n6 0 0 0\n7 1 0 0\n8 1 1 0\n9 0 1 0\n10 0.5 0.5 0\n",
            )
            .replace("$Elements\n6\n", "$Elements\n10\n")
            .replace(
                "6 2 2 7 1 4 1 5\n",
                "6 2 2 7 1 4 1 5\n7 2 2 1 1 6 7 10\n8 2 2 1 1 7 8 10\n9 2 2 1 1 8 9 10\n\
                 10 2 2 1 1 9 6 10\n",
            );
        let e = fails(&copy, "the centroid of one lies inside the other");
        assert!(matches!(e, GmshError::Overlap { .. }), "{e}");
        // Node 5 moved outside the square past the edge 2-3: triangle 4 (2 3 5) flips and
        // folds over triangle 3 (1 2 5).
        let fold = SQUARE_22.replace("5 0.5 0.5 0", "5 1.5 0.5 0");
        let e = fails(&fold, "t.msh:");
        assert!(matches!(e, GmshError::Overlap { .. }), "{e}");
        check_square(&parse_msh(SQUARE_22, "t.msh").unwrap());
    }

    #[test]
    fn degenerate_nonplanar_and_empty_meshes() {
        // Centre node moved onto the bottom edge: element 3 (nodes 1 2 5) has zero area.
        let e = fails(
            &SQUARE_22.replace("5 0.5 0.5 0", "5 0.5 0 0"),
            "t.msh:21: element 3: degenerate",
        );
        assert!(matches!(e, GmshError::BadTriangle { tag: 3, .. }));
        fails(
            &SQUARE_22.replace("5 0.5 0.5 0", "5 0.5 0.5 0.1"),
            "t.msh:15: node 5: z = 1e-1",
        );
        let only_lines = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n\
                          $Elements\n1\n1 1 2 0 0 1 2\n$EndElements\n";
        assert!(matches!(
            fails(only_lines, "no 3-node triangles"),
            GmshError::NoTriangles { .. }
        ));
    }
}
