//! Setup errors: a scenario that cannot be read or makes no physical sense. Every message names
//! what was wrong and where, in one line. (Errors of a running step are
//! [`crate::systems::RunError`].)

use std::path::PathBuf;

/// A scenario that cannot be read or makes no physical sense.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("cannot read scenario {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Malformed RON, an unknown field, a missing field or a wrong type: file, line, column, field.
    #[error("{file}:{line}:{col}: {msg}{}", field_suffix(.field))]
    Syntax {
        file: String,
        line: usize,
        col: usize,
        field: String,
        msg: String,
    },
    /// A value that parses but is not physical or not consistent.
    #[error("invalid {field}: {why}")]
    Invalid { field: String, why: String },
    /// A `--set PATH=VALUE` override that does not apply.
    #[error("--set {spec}: {why}")]
    Override { spec: String, why: String },
    #[error("unknown system `{name}`; valid systems: {valid}")]
    UnknownSystem { name: String, valid: String },
}

fn field_suffix(field: &str) -> String {
    if field.is_empty() || field == "." {
        String::new()
    } else {
        format!(" (field `{field}`)")
    }
}

impl SetupError {
    pub fn invalid(field: &str, why: impl Into<String>) -> Self {
        SetupError::Invalid {
            field: field.to_string(),
            why: why.into(),
        }
    }
}
