//! Reading scenarios: RON text with precise error positions ([`parse_ron`]), scenario files
//! ([`Scenario::load`]) and `--set PATH=VALUE` overrides ([`Scenario::with_overrides`]).

use super::{MeshSpec, Scenario, ValidScenario};
use crate::error::SetupError;
use std::path::Path;

/// Parse a RON file's text into `T` (a leading byte-order mark is skipped; `Option` fields may
/// be written without `Some`). Errors carry file, line, column and the field path; `what` names
/// the document in the trailing-text error ("unexpected text after the end of the `what`").
pub fn parse_ron<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &str,
    what: &str,
) -> Result<T, SetupError> {
    // A UTF-8 byte-order mark (some Windows editors write one) is not part of the RON.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let opts =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let syntax = |e: ron::error::SpannedError, field: String| SetupError::Syntax {
        file: file.to_string(),
        line: e.span.start.line,
        col: e.span.start.col,
        field,
        msg: e.code.to_string(),
    };
    let mut de = ron::Deserializer::from_str_with_options(text, &opts)
        .map_err(|e| syntax(e, String::new()))?;
    let doc: T = match serde_path_to_error::deserialize(&mut de) {
        Ok(doc) => doc,
        Err(e) => {
            let mut field = e.path().to_string();
            let spanned = de.span_error(e.into_inner());
            let mut err = syntax(spanned, field.clone());
            // A value that ends early ("Expected comma" after `max_steps: 1` of `1.5`) leaves
            // the path at the next, unknown field (`time.?`): name the field whose value it
            // was, and say what the parser stopped at.
            if let SetupError::Syntax { line, col, msg, .. } = &mut err
                && (field == "?" || field.ends_with(".?"))
                && let Some((key, at)) = value_before(text, *line, *col)
            {
                field.truncate(field.len() - 1);
                field.push_str(&key);
                if at.starts_with('.') && msg.contains("comma") {
                    *msg = format!("{msg}: `{key}` takes a whole number here, not a fraction");
                } else {
                    *msg = format!("{msg}: the value of `{key}` ends early, before `{at}`");
                }
            }
            if let SetupError::Syntax { field: f, .. } = &mut err {
                *f = field;
            }
            return Err(err);
        }
    };
    // Trailing garbage after the document.
    let rest = de.remainder();
    if let Some(pos) = rest.find(|c: char| !c.is_whitespace()) {
        let consumed = &text[..text.len() - rest.len() + pos];
        let line = consumed.matches('\n').count() + 1;
        let col = consumed.len() - consumed.rfind('\n').map_or(0, |i| i + 1) + 1;
        return Err(SetupError::Syntax {
            file: file.to_string(),
            line,
            col,
            field: String::new(),
            msg: format!("unexpected text after the end of the {what}"),
        });
    }
    Ok(doc)
}

/// The field whose value the text at 1-based `line`, `col` (characters) interrupts: the last
/// `name:` before it on that line, and up to 12 characters of the text from there on.
fn value_before(text: &str, line: usize, col: usize) -> Option<(String, String)> {
    let l = text.lines().nth(line.checked_sub(1)?)?;
    let split = l
        .char_indices()
        .nth(col.checked_sub(1)?)
        .map_or(l.len(), |c| c.0);
    let (before, after) = l.split_at(split);
    let colon = before.rfind(':')?;
    let key: String = before[..colon]
        .trim_end()
        .chars()
        .rev()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    if key.is_empty() {
        return None;
    }
    Some((key, after.chars().take(12).collect()))
}

impl Scenario {
    /// Read and parse a scenario file, apply `--set` overrides, then validate (a caller that
    /// edits it further takes it apart with [`ValidScenario::into_inner`] and validates again).
    pub fn load(path: &Path, overrides: &[String]) -> Result<ValidScenario, SetupError> {
        let text = std::fs::read_to_string(path).map_err(|source| SetupError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut sc = Self::parse(&text, &path.display().to_string())?;
        // Mesh files are relative to the scenario file.
        if let Some(MeshSpec::Gmsh { file } | MeshSpec::Gmsh3 { file }) = &mut sc.mesh
            && Path::new(file.as_str()).is_relative()
            && let Some(dir) = path.parent()
        {
            *file = dir.join(file.as_str()).display().to_string();
        }
        // So are fracture files.
        if let Some(file) = sc.fracture.as_mut().and_then(|f| f.file.as_mut())
            && Path::new(file.as_str()).is_relative()
            && let Some(dir) = path.parent()
        {
            *file = dir.join(file.as_str()).display().to_string();
        }
        if !overrides.is_empty() {
            sc = sc.with_overrides(overrides)?;
        }
        sc.validate()
    }

    /// Parse RON text (a leading byte-order mark is skipped). Errors carry file, line, column
    /// and the field path. Not validated: callers edit it, then [`Scenario::validate`] it.
    pub fn parse(text: &str, file: &str) -> Result<Self, SetupError> {
        parse_ron(text, file, "scenario")
    }

    /// Apply `PATH=VALUE` overrides (e.g. `material.young=3e10`, `mesh.h=2`, `damping=None`).
    /// A path steps through enum variants on its own (`mesh.h` reaches `mesh.Regular.h`).
    /// VALUE is read as JSON (numbers, `true`, `null`, `[1, 2]`) and otherwise as a string
    /// (so unit variants such as `None` work). The result is not validated.
    pub fn with_overrides(&self, overrides: &[String]) -> Result<Self, SetupError> {
        let mut root = serde_json::to_value(self).map_err(|e| SetupError::Override {
            spec: String::new(),
            why: e.to_string(),
        })?;
        let original = root.clone();
        // The `None` values set: (the path as messages name it, its JSON pointer in `root`).
        let mut nones: Vec<(String, String)> = Vec::new();
        for spec in overrides {
            nones.extend(set_override(&mut root, spec)?);
        }
        read_overridden(root, original, nones, overrides)
    }
}

/// Apply one `PATH=VALUE` override to the scenario as JSON; returns the path and the JSON
/// pointer of a `None` it set (read back as a unit variant or as null).
fn set_override(
    root: &mut serde_json::Value,
    spec: &str,
) -> Result<Option<(String, String)>, SetupError> {
    let err = |why: String| SetupError::Override {
        spec: spec.to_string(),
        why,
    };
    let (path, value) = spec
        .split_once('=')
        .ok_or_else(|| err("expected PATH=VALUE".into()))?;
    let value = override_value(value.trim());
    let mut node = root;
    let mut pointer = String::new();
    let keys: Vec<&str> = path.trim().split('.').collect();
    for (k, key) in keys.iter().enumerate() {
        // Step into an enum variant wrapper ({"Regular": {...}}) when the key is not here.
        loop {
            let obj = node
                .as_object()
                .ok_or_else(|| err(format!("`{}` is not a table", keys[..k].join("."))))?;
            if obj.contains_key(*key) || obj.len() != 1 {
                break;
            }
            let only = obj.keys().next().cloned().unwrap_or_default();
            if !only.starts_with(|c: char| c.is_ascii_uppercase()) || !node[&only].is_object() {
                break;
            }
            pointer = format!("{pointer}/{only}");
            node = node.get_mut(&only).expect("key exists");
        }
        let obj = node
            .as_object_mut()
            .ok_or_else(|| err(format!("`{}` is not a table", keys[..k].join("."))))?;
        if !obj.contains_key(*key) {
            let mut valid: Vec<&String> = obj.keys().collect();
            valid.sort();
            let valid: Vec<String> = valid.into_iter().cloned().collect();
            return Err(err(format!(
                "no field `{key}` here; fields: {}",
                valid.join(", ")
            )));
        }
        pointer = format!("{pointer}/{key}");
        node = obj.get_mut(*key).expect("key exists");
    }
    *node = value;
    Ok((node.as_str() == Some("None")).then(|| (keys.join("."), pointer)))
}

/// Read the overridden scenario `root` back (`original`: before the overrides; `nones`: the
/// `None`s set, from [`set_override`]).
fn read_overridden(
    root: serde_json::Value,
    original: serde_json::Value,
    mut nones: Vec<(String, String)>,
    overrides: &[String],
) -> Result<Scenario, SetupError> {
    // `None` is a unit variant for an enum (`damping=None`) and null for an optional
    // field (`production=None`, as RON writes it): a `None` the reading fails at is read
    // again as null.
    let first = serde_path_to_error::deserialize::<_, Scenario>(root.clone());
    let mut at = first
        .as_ref()
        .err()
        .map(|e| display_path(&e.path().to_string()));
    let mut retry = root;
    while let Some(path) = at.take() {
        let Some(k) = nones.iter().position(|(p, _)| *p == path) else {
            break;
        };
        if let Some(n) = retry.pointer_mut(&nones.swap_remove(k).1) {
            *n = serde_json::Value::Null;
        }
        match serde_path_to_error::deserialize::<_, Scenario>(retry.clone()) {
            Ok(sc) => return Ok(sc),
            Err(e) => at = Some(display_path(&e.path().to_string())),
        }
    }
    first.map_err(|e| {
        // The overrides travel through JSON, which has no NaN or infinity: a non-finite
        // number of the file comes back as `null` and fails here, though no override is to
        // blame. When the file's own values fail at the same field, say so.
        let path = e.path().to_string();
        let from_file = serde_path_to_error::deserialize::<_, Scenario>(original)
            .err()
            .is_some_and(|o| o.path().to_string() == path);
        if from_file {
            SetupError::invalid(
                &display_path(&path),
                "is not a finite number (NaN or inf in the scenario file)",
            )
        } else {
            SetupError::Override {
                spec: overrides.join(" "),
                why: format!("field `{path}`: {}", e.inner()),
            }
        }
    })
}

/// The fields `key: value, ...` of a RON struct's inside as a JSON table, each value read by
/// [`override_value`]; `None` unless there is one and every top-level piece is an identifier,
/// a colon and a value.
fn ron_fields(inner: &str) -> Option<serde_json::Value> {
    let fields = split_top(inner)
        .into_iter()
        .map(|f| {
            let (k, v) = f.split_once(':')?;
            let k = k.trim();
            let ident = k.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
                && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            ident.then(|| (k.to_string(), override_value(v.trim())))
        })
        .collect::<Option<serde_json::Map<_, _>>>()?;
    (!fields.is_empty()).then_some(serde_json::Value::Object(fields))
}

/// `text` cut at its top-level commas (not those inside brackets, parentheses or quotes);
/// empty pieces (a trailing comma) left out.
fn split_top(text: &str) -> Vec<&str> {
    let (mut out, mut depth, mut start, mut quoted) = (Vec::new(), 0i32, 0, false);
    for (i, c) in text.char_indices() {
        match c {
            '"' => quoted = !quoted,
            _ if quoted => {}
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&text[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&text[start..]);
    out.retain(|p| !p.trim().is_empty());
    out
}

/// A serde path as the scenario's fields are named in messages: enum variant wrappers left out
/// (`mesh.Graded.ratio` is `mesh.ratio`, as `--set` and the validation name it).
fn display_path(path: &str) -> String {
    path.split('.')
        .filter(|k| !k.starts_with(|c: char| c.is_ascii_uppercase()))
        .collect::<Vec<_>>()
        .join(".")
}

/// Read an override VALUE: JSON (`3e10`, `true`, `[1, 2]`, `{"Time": 5.0}`), a newtype or
/// struct variant written as in RON (`Local(0.5)`, `Time(5.0)`, `Regular(width: 10.0, height:
/// 10.0, h: 1.0)`), an optional value (`Some(6.0)`, `Some(Local(0.5))`), a RON list or
/// struct of these (`[(axis: X, at: 1.0, factor: 8.0)]`), or else a plain string (unit
/// variants: `None`, `X`).
fn override_value(text: &str) -> serde_json::Value {
    if let Ok(v) = serde_json::from_str(text) {
        return v;
    }
    // A RON list: its items read one by one.
    if let Some(inner) = text.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
        return serde_json::Value::Array(
            split_top(inner)
                .into_iter()
                .map(|item| override_value(item.trim()))
                .collect(),
        );
    }
    // A RON struct `(key: value, ...)`: a table; a RON tuple `(1.0, 2.0)`: a list.
    if let Some(inner) = text.strip_prefix('(').and_then(|t| t.strip_suffix(')')) {
        if let Some(obj) = ron_fields(inner) {
            return obj;
        }
        let items = split_top(inner);
        if !items.is_empty() && items.iter().all(|f| !f.contains(':')) {
            return serde_json::Value::Array(
                items.iter().map(|f| override_value(f.trim())).collect(),
            );
        }
    }
    if let Some((name, rest)) = text.split_once('(')
        && let Some(inner) = rest.strip_suffix(')')
        && name.starts_with(|c: char| c.is_ascii_uppercase())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    {
        // An optional value as RON writes it (`Some(6.0)`): JSON has no wrapper.
        if name == "Some" {
            return override_value(inner.trim());
        }
        // A struct variant's fields (`Conforming(width: 100.0, h: 2.0, ...)`) as a table, or
        // a newtype variant's value (`Local(0.5)`).
        let mut obj = serde_json::Map::new();
        obj.insert(
            name.to_string(),
            ron_fields(inner).unwrap_or_else(|| override_value(inner.trim())),
        );
        return serde_json::Value::Object(obj);
    }
    serde_json::Value::String(text.to_string())
}
