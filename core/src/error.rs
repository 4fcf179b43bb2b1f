//! Setup errors: a scenario that cannot be read or makes no physical sense. Every message names
//! what was wrong and where, in one line: text of the user's (a file name, a system name, a
//! quoted value) is shown with its control characters escaped ([`one_line`]), so a newline in a
//! string of the scenario does not break the message. (Errors of a running step are
//! [`crate::systems::RunError`].)

use std::path::PathBuf;

/// A scenario that cannot be read or makes no physical sense.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("cannot read scenario {}: {source}", one_line(&.path.display().to_string()))]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Malformed RON, an unknown field, a missing field or a wrong type: file, line, column, field.
    #[error("{}:{line}:{col}: {}{}", one_line(.file), one_line(.msg), field_suffix(.field))]
    Syntax {
        file: String,
        line: usize,
        col: usize,
        field: String,
        msg: String,
    },
    /// A value that parses but is not physical or not consistent.
    #[error("invalid {}: {}", one_line(.field), one_line(.why))]
    Invalid { field: String, why: String },
    /// A `--set PATH=VALUE` override that does not apply.
    #[error("--set {}: {}", one_line(.spec), one_line(.why))]
    Override { spec: String, why: String },
    #[error("unknown system `{}`; valid systems: {valid}", one_line(.name))]
    UnknownSystem { name: String, valid: String },
}

fn field_suffix(field: &str) -> String {
    if field.is_empty() || field == "." {
        String::new()
    } else {
        format!(" (field `{}`)", one_line(field))
    }
}

/// `s` with its control characters (newline, carriage return, tab, NUL, ...) written as escapes
/// (`\n`, `\u{0}`), everything else as it is: a message holding it stays one line.
pub fn one_line(s: &str) -> std::borrow::Cow<'_, str> {
    if !s.chars().any(char::is_control) {
        return s.into();
    }
    s.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

impl SetupError {
    pub fn invalid(field: &str, why: impl Into<String>) -> Self {
        SetupError::Invalid {
            field: field.to_string(),
            why: why.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A newline in a user's string (here a system name) stays escaped: the message is one
    /// line (found by `tests/fuzz_scenarios.rs`).
    #[test]
    fn user_text_with_a_newline_is_one_line() {
        let e = SetupError::UnknownSystem {
            name: "fl\now".into(),
            valid: "flow".into(),
        };
        assert_eq!(
            e.to_string(),
            "unknown system `fl\\now`; valid systems: flow"
        );
        let e = SetupError::invalid("mesh.file", "a\r\nb\u{0}: é");
        assert_eq!(e.to_string(), "invalid mesh.file: a\\r\\nb\\u{0}: é");
    }
}
