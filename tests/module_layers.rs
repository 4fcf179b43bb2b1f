//! The crate's modules depend one way: input -> model -> views -> systems -> simulation ->
//! outputs, verification and CLI (`docs/architecture.md`, "Layers"). This test reads every
//! source file of the library, collects the `crate::...` paths its code uses (comments and
//! `#[cfg(test)]` modules are not dependencies), and fails on an import from a higher layer or
//! on any cycle between modules, naming the files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layer of each module (a module path below `crate`). A module may use modules of its own
/// layer or below; within a layer, no cycles.
const LAYERS: &[(&str, u8)] = &[
    // 0: leaf utilities.
    ("atomic", 0),
    ("union_find", 0),
    ("error", 0),
    ("timing", 0),
    ("plot", 0),
    // 1: input.
    ("scenario", 1),
    ("mesh", 1),
    ("gmsh", 1),
    ("network", 1),
    ("snap", 1),
    ("conforming", 1),
    ("resources", 1),
    // 2: the model (ECS) and its topology operations.
    ("components", 2),
    ("model", 2),
    ("split", 2),
    ("fractures", 2),
    // 3: dense views, per-element and per-cell numerics, run parameters, output writers.
    ("view", 3),
    ("element", 3),
    ("stability", 3),
    ("sparse", 3),
    ("params", 3),
    ("flow", 3),
    ("output", 3),
    ("reservoir", 3),
    // 4: the systems of the step.
    ("systems", 4),
    // 5: the simulation.
    ("schedule", 5),
    ("setup", 5),
    ("sim", 5),
    ("checkpoint", 5),
    // 6: driver, verification, reference kernels.
    ("driver", 6),
    ("pipeline", 6),
    ("production", 6),
    ("verify", 6),
    ("reference", 6),
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Module path of a source file: `src/flow/implicit.rs` -> `flow::implicit`,
/// `systems/mod.rs` -> `systems`.
fn module_of(rel: &Path) -> String {
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts[0] == "src" {
        parts.remove(0);
    }
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" {
        parts.push(stem.to_string());
    }
    parts.join("::")
}

fn sources() -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    for dir in ["src", "systems", "components"] {
        let mut stack = vec![root().join(dir)];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let rel = p.strip_prefix(root()).unwrap().to_path_buf();
                    if rel != Path::new("src/main.rs") && rel != Path::new("src/lib.rs") {
                        out.push((module_of(&rel), rel));
                    }
                }
            }
        }
    }
    out.sort();
    out
}

/// The code of a file without comments and without its `#[cfg(test)]` modules.
fn code(text: &str) -> String {
    let mut out = String::new();
    let mut skip_depth: Option<i32> = None;
    let mut depth = 0i32;
    let mut pending_cfg_test = false;
    for line in text.lines() {
        let l = line.split("//").next().unwrap_or("");
        let t = l.trim();
        if skip_depth.is_none() {
            if t.starts_with("#[cfg(test)]") {
                pending_cfg_test = true;
                continue;
            }
            if pending_cfg_test && t.starts_with("mod ") && t.ends_with('{') {
                skip_depth = Some(depth);
            }
            pending_cfg_test = false;
        }
        for ch in l.chars() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ => {}
            }
        }
        match skip_depth {
            Some(d) if depth <= d => skip_depth = None,
            Some(_) => {}
            None => {
                out.push_str(l);
                out.push('\n');
            }
        }
    }
    out
}

/// The modules a file's code names through `crate::...` paths (`use crate::{a, b::c}` too),
/// resolved to the longest known module.
fn uses(code: &str, known: &BTreeSet<String>) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let bytes = code.as_bytes();
    let mut i = 0;
    while let Some(k) = code[i..].find("crate::") {
        let start = i + k + "crate::".len();
        i = start;
        if start > "crate::".len() && bytes[start - "crate::".len() - 1].is_ascii_alphanumeric() {
            continue;
        }
        let rest = &code[start..];
        let paths: Vec<String> = if let Some(inner) = rest.strip_prefix('{') {
            // `crate::{a, b::c, ...}`: the first segment of each item.
            let end = inner.find('}').unwrap_or(inner.len());
            inner[..end]
                .split(',')
                .map(|s| s.trim().to_string())
                .collect()
        } else {
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(rest.len());
            vec![rest[..end].to_string()]
        };
        for p in paths {
            let segs: Vec<&str> = p.split("::").filter(|s| !s.is_empty()).collect();
            for n in (1..=segs.len()).rev() {
                let m = segs[..n].join("::");
                if known.contains(&m) {
                    found.insert(m);
                    break;
                }
            }
        }
    }
    found
}

fn layer(module: &str) -> u8 {
    let top = module.split("::").next().unwrap();
    LAYERS
        .iter()
        .find(|(m, _)| *m == top)
        .unwrap_or_else(|| panic!("module `{module}` has no layer in LAYERS: add it"))
        .1
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let files = sources();
    let known: BTreeSet<String> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut g = BTreeMap::new();
    for (m, rel) in &files {
        let text = std::fs::read_to_string(root().join(rel)).unwrap();
        let mut deps = uses(&code(&text), &known);
        deps.remove(m);
        g.insert(m.clone(), deps);
    }
    g
}

#[test]
fn no_module_imports_from_a_higher_layer() {
    let g = graph();
    assert!(g.len() > 30, "only {} modules found", g.len());
    let mut bad = Vec::new();
    for (m, deps) in &g {
        for d in deps {
            if layer(d) > layer(m) {
                bad.push(format!(
                    "{m} (layer {}) uses {d} (layer {})",
                    layer(m),
                    layer(d)
                ));
            }
        }
    }
    assert!(bad.is_empty(), "upward imports:\n{}", bad.join("\n"));
}

#[test]
fn module_graph_has_no_cycle() {
    let g = graph();
    // Depth-first search with colours; a grey successor closes a cycle.
    fn visit(
        m: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        colour: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        colour.insert(m.to_string(), 1);
        path.push(m.to_string());
        for d in &g[m] {
            match colour.get(d.as_str()).copied().unwrap_or(0) {
                1 => {
                    let from = path.iter().position(|x| x == d).unwrap();
                    let mut cycle = path[from..].to_vec();
                    cycle.push(d.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(d, g, colour, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        colour.insert(m.to_string(), 2);
        None
    }
    let mut colour = BTreeMap::new();
    for m in g.keys() {
        if colour.get(m.as_str()).copied().unwrap_or(0) == 0
            && let Some(c) = visit(m, &g, &mut colour, &mut Vec::new())
        {
            panic!("module cycle: {}", c.join(" -> "));
        }
    }
}

/// The checker itself: it sees `use crate::{a, b::c}` lists and ignores comments and test
/// modules, so the layer test can fail.
#[test]
fn the_checker_sees_imports_and_skips_comments_and_tests() {
    let known: BTreeSet<String> = ["sim", "flow", "flow::implicit", "view", "driver"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let text = "use crate::{view::SolidView, flow::implicit::X};\n\
                // crate::driver in a comment\n\
                fn f() { crate::flow::pressure_of(); }\n\
                #[cfg(test)]\nmod tests {\n    use crate::sim::Simulation;\n}\n";
    let u = uses(&code(text), &known);
    let want: BTreeSet<String> = ["view", "flow::implicit", "flow"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(u, want);
    assert!(layer("sim") > layer("view"));
}
