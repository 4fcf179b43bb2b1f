//! Which systems a scene runs: the literal order of [`SystemId::ORDER`], minus those the user
//! switched off and those whose data the scene does not have.

use hydrofrac_core::error::SetupError;
use hydrofrac_systems::SystemId;
use serde::Serialize;

/// Why a system is or is not in the schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Enabled,
    DisabledByUser,
    NoData,
}

/// What a scene has, which decides the systems that have data to work on.
#[derive(Clone, Copy, Debug)]
pub struct SceneData {
    pub solid: bool,
    pub joints: bool,
    /// External loads (tractions, body forces).
    pub load: bool,
    pub damping: bool,
    pub flow: bool,
    /// The rock's fractures carry the flow.
    pub coupled: bool,
    pub criterion: bool,
    /// The rock is solved quasi-statically (`solve` replaces `damping` and `integrate`).
    pub quasi_static: bool,
    /// The scenario asks for the event catalogue (`seismicity:`).
    pub seismicity: bool,
}

impl SceneData {
    /// Whether system `s` has data in this scene.
    pub fn has(&self, s: SystemId) -> bool {
        match s {
            SystemId::Contact => self.joints,
            SystemId::FluidPressure => self.coupled,
            SystemId::InternalForce => self.solid,
            SystemId::Integrate => self.solid && !self.quasi_static,
            SystemId::ExternalLoad => self.load,
            SystemId::Damping => self.solid && self.damping && !self.quasi_static,
            SystemId::Solve => self.solid && self.quasi_static,
            SystemId::FlowSubsteps => self.flow,
            SystemId::FractureCriterion | SystemId::Split => self.criterion,
            SystemId::Seismicity => self.solid && self.seismicity,
            SystemId::Monitor | SystemId::Output => true,
        }
    }
}

#[derive(Clone, Debug)]
pub struct Schedule {
    pub entries: Vec<(SystemId, Status)>,
}

impl Schedule {
    /// Build the schedule. `disabled` are names from the scenario and the command line;
    /// `has_data` says whether the scene has what a system works on.
    pub fn new(
        disabled: &[String],
        has_data: impl Fn(SystemId) -> bool,
    ) -> Result<Self, SetupError> {
        for name in disabled {
            match SystemId::from_name(name) {
                None => {
                    let valid: Vec<&str> = SystemId::ORDER.iter().map(|s| s.name()).collect();
                    return Err(SetupError::UnknownSystem {
                        name: name.clone(),
                        valid: valid.join(", "),
                    });
                }
                Some(s) if s.required() => {
                    return Err(SetupError::invalid(
                        "systems.disable",
                        format!("`{name}` cannot be switched off: {}", s.doc()),
                    ));
                }
                Some(_) => {}
            }
        }
        let entries = SystemId::ORDER
            .into_iter()
            .map(|s| {
                let status = if disabled.iter().any(|d| d == s.name()) {
                    Status::DisabledByUser
                } else if !has_data(s) {
                    Status::NoData
                } else {
                    Status::Enabled
                };
                (s, status)
            })
            .collect();
        Ok(Schedule { entries })
    }

    /// Enabled systems in step order.
    pub fn enabled(&self) -> impl Iterator<Item = SystemId> + '_ {
        self.entries
            .iter()
            .filter(|(_, st)| *st == Status::Enabled)
            .map(|(s, _)| *s)
    }

    /// Whether the scene (still) has data for `s`: switches it between enabled and `NoData`
    /// (a system the user disabled stays disabled).
    pub fn set_data(&mut self, s: SystemId, has_data: bool) {
        for (t, st) in &mut self.entries {
            if *t == s && *st != Status::DisabledByUser {
                *st = if has_data {
                    Status::Enabled
                } else {
                    Status::NoData
                };
            }
        }
    }

    /// The status of system `s`.
    pub fn status(&self, s: SystemId) -> Status {
        self.entries
            .iter()
            .find(|(t, _)| *t == s)
            .map_or(Status::NoData, |e| e.1)
    }

    pub fn is_enabled(&self, s: SystemId) -> bool {
        self.entries
            .iter()
            .any(|&(t, st)| t == s && st == Status::Enabled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let e = Schedule::new(&["contactt".into()], |_| true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("contactt") && e.contains("internal_force") && e.contains("damping"),
            "{e}"
        );
    }

    #[test]
    fn disabled_and_dataless_systems_are_not_run() {
        let s = Schedule::new(&["damping".into()], |s| s != SystemId::ExternalLoad).unwrap();
        let on: Vec<SystemId> = s.enabled().collect();
        assert!(!on.contains(&SystemId::Damping));
        assert!(!on.contains(&SystemId::ExternalLoad));
        assert_eq!(on[0], SystemId::InternalForce);
        assert!(Schedule::new(&["monitor".into()], |_| true).is_err());
    }
}
