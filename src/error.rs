//! Library error types. Every message names what was wrong and where, in one line.

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

/// A run that had to stop.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Numerical blow-up: the step, the entity and the quantity that went wrong.
    #[error(
        "blow-up at step {step} (t = {time:.6e} s): {entity} has {quantity} = {value:.6e}, {why}; \
         stopped before writing non-finite output (dt = {dt:.3e} s)"
    )]
    BlowUp {
        step: u64,
        time: f64,
        entity: String,
        quantity: &'static str,
        value: f64,
        why: String,
        dt: f64,
    },
    /// The implicit (backward-Euler) flow step failed: its Newton iteration did not converge.
    #[error("step {step} (t = {time:.6e} s): {source}")]
    ImplicitFlow {
        step: u64,
        time: f64,
        source: Box<crate::flow::implicit::ImplicitError>,
    },
    #[error("output: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Setup(#[from] SetupError),
}
