//! Scan an output folder for non-finite numbers: every `csv`, `json`, `vtu` and `pvd` file
//! (recursively) is split into tokens at anything but letters, digits, `.`, `_`, `+` and `-`,
//! and a token that is `inf`, `infinity`, `nan` or `null` (any case, any sign) is reported as
//! `file: token` (the first few per file).

use std::path::{Path, PathBuf};

const TEXT: [&str; 4] = ["csv", "json", "vtu", "pvd"];
const BAD: [&str; 4] = ["inf", "infinity", "nan", "null"];

/// The files of `dir` scanned (text outputs), recursively.
pub fn text_outputs(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().path()) {
            if e.is_dir() {
                stack.push(e);
            } else if e
                .extension()
                .and_then(|x| x.to_str())
                .is_some_and(|x| TEXT.contains(&x))
            {
                files.push(e);
            }
        }
    }
    files.sort();
    files
}

/// Every non-finite token in the text outputs of `dir` as `file: token`.
pub fn non_finite_tokens(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for f in text_outputs(dir) {
        let text = std::fs::read_to_string(&f).unwrap();
        let bad = text
            .split(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '+' | '-')))
            .filter(|t| {
                BAD.contains(
                    &t.trim_start_matches(['+', '-'])
                        .to_ascii_lowercase()
                        .as_str(),
                )
            })
            .take(3);
        for t in bad {
            found.push(format!("{}: {t}", f.display()));
        }
    }
    found
}
