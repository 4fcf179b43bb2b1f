//! `seismicity:`: the event catalogue of joint slip (`systems/src/seismicity.rs`,
//! `docs/seismicity.md`), and `fracture.slip_weakening:`, friction that can make events run
//! dynamically.

use super::{SetupError, finite, positive};
use serde::{Deserialize, Serialize};

/// Default slip rate that opens an event, m/s: slow enough to catch the quasi-static slip of a
/// pressurised fault step by step, fast against the creep of an elastic joint under a slowly
/// changing load.
pub const DEFAULT_V_START: f64 = 1e-4;

/// The event catalogue (`seismicity:` in a scenario). Rates in m/s, lengths in m.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SeismicitySpec {
    /// An event opens when the largest slip rate of a connected set of slipping joints exceeds
    /// this, m/s (default [`DEFAULT_V_START`]).
    #[serde(default = "default_v_start")]
    pub v_start: f64,
    /// An event closes when all its joints slip slower than this, m/s (default v_start / 10;
    /// at most v_start: the hysteresis keeps an event from chattering).
    #[serde(default)]
    pub v_stop: Option<f64>,
    /// Out-of-plane width W of a rupture, m: M0 = W M0' (default: each event's ruptured
    /// length, a square rupture).
    #[serde(default)]
    pub width: Option<f64>,
    /// Completeness magnitude of the b-value estimate (default: the maximum-curvature
    /// estimate, the magnitude bin with the most events).
    #[serde(default)]
    pub completeness: Option<f64>,
}

fn default_v_start() -> f64 {
    DEFAULT_V_START
}

impl Default for SeismicitySpec {
    fn default() -> Self {
        SeismicitySpec {
            v_start: DEFAULT_V_START,
            v_stop: None,
            width: None,
            completeness: None,
        }
    }
}

impl SeismicitySpec {
    /// The closing rate, m/s.
    pub fn v_stop(&self) -> f64 {
        self.v_stop.unwrap_or(self.v_start / 10.0)
    }

    pub(super) fn validate(&self) -> Result<(), SetupError> {
        positive("seismicity.v_start", self.v_start, "the opening slip rate")?;
        if let Some(v) = self.v_stop {
            positive("seismicity.v_stop", v, "the closing slip rate")?;
            if v > self.v_start {
                return Err(SetupError::invalid(
                    "seismicity.v_stop",
                    format!(
                        "the closing slip rate {v} m/s is above the opening rate v_start = {} \
                         m/s: an event would close while it still opens",
                        self.v_start
                    ),
                ));
            }
        }
        if let Some(w) = self.width {
            positive("seismicity.width", w, "the rupture width")?;
        }
        if let Some(m) = self.completeness {
            finite("seismicity.completeness", m)?;
        }
        Ok(())
    }
}

/// Linear slip-weakening friction (`fracture.slip_weakening`): the friction coefficient falls
/// from the peak tan(`fracture.friction_deg`) to the residual tan(`residual_deg`) over the
/// joint's accumulated frictional slip `dc` (m), then stays there.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SlipWeakening {
    /// Residual friction angle, degrees (at most the peak `fracture.friction_deg`).
    pub residual_deg: f64,
    /// Critical slip distance, m.
    pub dc: f64,
}

impl SlipWeakening {
    pub(super) fn validate(&self, peak_deg: f64) -> Result<(), SetupError> {
        finite("fracture.slip_weakening.residual_deg", self.residual_deg)?;
        if !(0.0..=peak_deg).contains(&self.residual_deg) {
            return Err(SetupError::invalid(
                "fracture.slip_weakening.residual_deg",
                format!(
                    "the residual friction angle must be in [0, friction_deg = {peak_deg}] \
                     degrees, got {}",
                    self.residual_deg
                ),
            ));
        }
        positive(
            "fracture.slip_weakening.dc",
            self.dc,
            "the critical slip distance",
        )
    }
}
