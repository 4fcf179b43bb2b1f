//! What a run writes and where (`name`, `output:`, `systems:`) and those sections' checks.

use super::finite;
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

/// Longest run name, characters: a folder name every file system takes.
pub const MAX_NAME_LEN: usize = 100;

/// The run name is the default output folder `out/<name>`, so it must be one safe folder name:
/// 1 to [`MAX_NAME_LEN`] ASCII letters, digits, `-`, `_` or `.`, not starting with `.` (no
/// `..`, no hidden folder), no path separator, not absolute. Another folder is chosen with
/// `--out`, not through the name.
pub fn check_run_name(name: &str) -> Result<(), SetupError> {
    let why = if name.is_empty() {
        Some("it is empty".to_string())
    } else if name.len() > MAX_NAME_LEN {
        Some(format!("it is longer than {MAX_NAME_LEN} characters"))
    } else if name.starts_with('.') {
        Some("it starts with `.` (`..` and hidden folders are not allowed)".to_string())
    } else {
        name.chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
            .map(|c| {
                if c == '/' || c == '\\' {
                    format!("it contains the path separator {c:?}")
                } else {
                    format!("it contains {c:?}")
                }
            })
    };
    match why {
        None => Ok(()),
        Some(why) => Err(SetupError::invalid(
            "name",
            format!(
                "{name:?} is the default output folder out/<name>, so it must be a plain folder \
                 name of ASCII letters, digits, `-`, `_` or `.` (not starting with `.`, at most \
                 {MAX_NAME_LEN} characters), but {why}; choose another folder with --out"
            ),
        )),
    }
}

/// Systems switched off for an ablation run (names as in the README's system table).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SystemsSpec {
    #[serde(default)]
    pub disable: Vec<String>,
}

/// What is written and how often.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// A ParaView frame every this many steps (0: only the first and last frames).
    #[serde(default)]
    pub frame_every: u64,
    /// A `timeseries.csv` row every this many steps (>= 1).
    #[serde(default = "default_series_every")]
    pub series_every: u64,
    /// Nodal and element fields written to the frames.
    #[serde(default = "default_fields")]
    pub fields: Vec<Field>,
    /// Coupled runs: simulated times, s, at which `fractures_pressure_t<time>s.png` is written
    /// (the mesh with the fractures' apertures magnified 20x, coloured by fluid pressure, like
    /// the seed's Fig. 7). The same figure is always written at the end of the run.
    #[serde(default)]
    pub figure_times: Vec<f64>,
    /// Write a restart checkpoint (`checkpoint.ckpt` in the output folder, the one before kept
    /// as `checkpoint.prev.ckpt`) every this many steps or simulated seconds; `None`: never.
    /// A run stopped by SIGINT/SIGTERM writes one too when this is set. `hydrofrac run
    /// SCENARIO --restart FILE` continues from it ([`crate::checkpoint`]).
    #[serde(default)]
    pub checkpoint_every: Option<CheckpointEvery>,
}

/// How often a checkpoint is written.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub enum CheckpointEvery {
    /// Every this many steps (>= 1).
    Steps(u64),
    /// At the end of the first step that reaches each multiple of this simulated time, s (> 0).
    Time(f64),
}

fn default_series_every() -> u64 {
    100
}
fn default_fields() -> Vec<Field> {
    vec![Field::Displacement, Field::Velocity, Field::Stress]
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            frame_every: 0,
            series_every: default_series_every(),
            fields: default_fields(),
            figure_times: Vec::new(),
            checkpoint_every: None,
        }
    }
}

/// A field in the ParaView frames.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub enum Field {
    /// Nodal displacement, m.
    Displacement,
    /// Nodal velocity, m/s.
    Velocity,
    /// Element stress sxx, syy, sxy, szz, Pa (tension positive).
    Stress,
}

impl OutputSpec {
    /// Figure times finite and >= 0, a time-series row every step or more, a checkpoint every
    /// step or more or every positive time; errors name `output.<field>`.
    pub(super) fn validate(&self) -> Result<(), SetupError> {
        for (k, &tf) in self.figure_times.iter().enumerate() {
            let field = format!("output.figure_times[{k}]");
            finite(&field, tf)?;
            if tf < 0.0 {
                return Err(SetupError::invalid(
                    &field,
                    format!("a figure time must be >= 0 s, got {tf}"),
                ));
            }
        }
        if self.series_every == 0 {
            return Err(SetupError::invalid(
                "output.series_every",
                "must be at least 1",
            ));
        }
        match self.checkpoint_every {
            Some(CheckpointEvery::Steps(0)) => Err(SetupError::invalid(
                "output.checkpoint_every",
                "Steps must be at least 1",
            )),
            Some(CheckpointEvery::Time(t)) => {
                finite("output.checkpoint_every", t)?;
                if t <= 0.0 {
                    return Err(SetupError::invalid(
                        "output.checkpoint_every",
                        format!("Time must be > 0 s, got {t}"),
                    ));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}
