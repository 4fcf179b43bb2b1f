//! Run parameters: the scenario resolved once, at setup, into the typed constants the systems
//! read. Every default is applied here (or in the scenario's serde defaults it reads); nothing
//! in the step reads the raw scenario. SI units throughout.

use crate::element::SolidParams;
use crate::flow::FlowParams;
use crate::scenario::SolidScheme;
use crate::scenario::{
    CriterionSpec, DEFAULT_RESIDUAL_APERTURE, End, FaceStress, Field, FlowBoundary, FlowScheme,
    Material, MeshSpec, Scenario,
};

/// Joint constants: penalty stiffnesses K_n, K_t (Pa) and the friction coefficient tan(phi).
#[derive(Clone, Copy, Debug)]
pub struct JointParams {
    pub kn: f64,
    pub kt: f64,
    /// Friction coefficient (the peak one under slip weakening).
    pub mu: f64,
    /// Slip weakening (`fracture.slip_weakening`): the residual friction coefficient and the
    /// critical slip distance, m.
    pub weakening: Option<(f64, f64)>,
}

impl JointParams {
    /// The friction coefficient after the accumulated frictional slip `slip` (m): `mu`, or
    /// under slip weakening mu_r + (mu - mu_r) max(0, 1 - slip / d_c).
    pub fn mu_at(&self, slip: f64) -> f64 {
        match self.weakening {
            None => self.mu,
            Some((mu_r, dc)) => mu_r + (self.mu - mu_r) * (1.0 - slip / dc).max(0.0),
        }
    }

    /// The stiffer of K_n and K_t, Pa: what the stability bounds take per joint.
    pub fn k_max(&self) -> f64 {
        self.kn.max(self.kt)
    }
}

/// Which fracture criterion grows the fractures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Criterion {
    /// The seed's strength test (seed (7), `docs/seed-method.md`) on every face: a face opens
    /// when its normal stress reaches `threshold` = lambda*T0, Pa (tension positive).
    /// `tip_handover`: a ready far side of a tip triangle is handed to the tip
    /// (`fracture.tip_handover`; `systems::fracture::hand_over`).
    Strength { threshold: f64, tip_handover: bool },
    /// Linear elastic fracture mechanics at the tips (`systems::toughness`): a tip grows when
    /// K_eq reaches `k_ic`, Pa sqrt(m); faces away from the tips open by the strength test at
    /// `initiation`, Pa (`None`: no new fractures away from tips).
    Toughness { k_ic: f64, initiation: Option<f64> },
}

impl Criterion {
    /// The strength test's threshold, Pa: on every face (`Strength`) or away from the tips
    /// (`Toughness`' initiation).
    pub fn strength(&self) -> Option<f64> {
        match *self {
            Criterion::Strength { threshold, .. } => Some(threshold),
            Criterion::Toughness { initiation, .. } => initiation,
        }
    }

    /// K_Ic, Pa sqrt(m), under `Toughness`.
    pub fn k_ic(&self) -> Option<f64> {
        match *self {
            Criterion::Toughness { k_ic, .. } => Some(k_ic),
            Criterion::Strength { .. } => None,
        }
    }
}

/// The fracture criterion and the face stress it reads.
#[derive(Clone, Copy, Debug)]
pub struct CriterionParams {
    pub kind: Criterion,
    /// Face stress from the two elements beside the edge (`FaceStress::Elements`) instead of
    /// the edge's patch.
    pub by_elements: bool,
}

/// Selective mass scaling (`time.selective_mass_scaling`): the critical step its raised masses
/// guarantee and the scene's with the rock's masses at setup, s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectiveScaling {
    pub dt_crit: f64,
    pub dt_unscaled: f64,
}

/// Time control.
#[derive(Clone, Debug)]
pub struct TimeParams {
    pub end: End,
    /// Fraction of the critical step used.
    pub safety: f64,
    /// The user forced the step (`time.dt`): it is not shortened after splits.
    pub forced_dt: bool,
    pub flow_dt: Option<f64>,
    pub flow_scheme: FlowScheme,
    pub solid_scheme: SolidScheme,
    /// The quasi-static step's inertia (`time.inertia`).
    pub inertia: crate::scenario::Inertia,
    pub max_steps: u64,
    pub max_substeps: u64,
    pub mass_scaling: bool,
    /// `time.selective_mass_scaling`, resolved at setup (`Simulation::new`).
    pub selective: Option<SelectiveScaling>,
    /// Quasi-static coupled runs: the step adapts (see `time.solid_scheme`) within
    /// [dt_min, dt_max] (s); the step itself and the time it aims at are the clock's.
    pub adaptive: bool,
    pub dt_min: f64,
    pub dt_max: f64,
    /// Re-solves at the same time after splits, at most per step.
    pub max_resolves: u64,
    /// Newton iterations at or below which the adaptive step grows (`time.newton_easy`).
    pub newton_easy: u64,
}

/// What is written and when.
#[derive(Clone, Debug)]
pub struct OutputParams {
    /// A frame every this many steps (0: first and last only).
    pub frame_every: u64,
    /// A time-series row every this many steps.
    pub series_every: u64,
    /// Simulated times of the fracture-pressure figures, s.
    pub figure_times: Vec<f64>,
    pub fields: Vec<Field>,
    /// Restart checkpoints (`output.checkpoint_every`).
    pub checkpoint_every: Option<crate::scenario::CheckpointEvery>,
}

/// Everything the step needs, resolved from a validated scenario.
#[derive(Clone, Debug)]
pub struct RunParams {
    /// The scenario's name (figure titles).
    pub name: String,
    /// Solid kernel constants (the step and the load factor are the clock's).
    pub solid: SolidParams,
    pub material: Material,
    /// P-wave speed sqrt((lambda + 2G)/rho), m/s (0 without a solid).
    pub c_p: f64,
    /// Plane-strain modulus E' = E / (1 - nu^2), Pa (the tips' stress intensity).
    pub e_prime: f64,
    pub joint: JointParams,
    /// Residual hydraulic aperture a_r, m (seed (12)).
    pub residual_aperture: f64,
    pub criterion: Option<CriterionParams>,
    /// The scenario has a `fracture` block (pre-existing fractures and/or a criterion).
    pub has_fractures: bool,
    /// The event catalogue's settings (`seismicity:`; `None`: no catalogue).
    pub seismicity: Option<crate::scenario::SeismicitySpec>,
    /// A prescribed uniform pressure on every fracture face, Pa.
    pub face_pressure: Option<f64>,
    pub fluid: FlowParams,
    /// The rock's fractures carry the network flow (a mesh and flow boundaries).
    pub coupled: bool,
    pub flow_boundaries: Vec<FlowBoundary>,
    /// Label of each flow boundary (`bc<index>` when unnamed).
    pub bc_names: Vec<String>,
    /// Multiplier of all boundary loads against time, piecewise linear.
    pub boundary_schedule: Vec<(f64, f64)>,
    pub time: TimeParams,
    pub output: OutputParams,
}

impl RunParams {
    /// Resolve a validated scenario; `material` is the model's (a default without a mesh).
    pub fn resolve(sc: &Scenario, material: Material) -> Self {
        let f = sc.fracture.as_ref();
        let has_solid = sc.mesh.is_some();
        let t = &sc.time;
        let coupled = has_solid && !sc.flow_boundaries.is_empty();
        let (adaptive, end_time) = match t.end {
            End::Time(te) => (t.solid_scheme == SolidScheme::QuasiStatic && coupled, te),
            End::Static { .. } | End::SteadyDirect => (false, 1.0),
        };
        RunParams {
            name: sc.name.clone(),
            solid: SolidParams::of(&material, sc.damping),
            material,
            e_prime: material.young / (1.0 - material.poisson * material.poisson),
            c_p: if has_solid {
                material.p_wave_speed()
            } else {
                0.0
            },
            joint: JointParams {
                kn: f.and_then(|f| f.normal_stiffness).unwrap_or(material.young),
                kt: f
                    .and_then(|f| f.shear_stiffness)
                    .unwrap_or(material.shear()),
                mu: f.map_or(0.0, |f| f.friction_deg.to_radians().tan()),
                weakening: f
                    .and_then(|f| f.slip_weakening)
                    .map(|w| (w.residual_deg.to_radians().tan(), w.dc)),
            },
            residual_aperture: f.map_or(DEFAULT_RESIDUAL_APERTURE, |f| f.residual_aperture),
            criterion: f
                .and_then(|f| {
                    let kind = match (f.criterion, f.strength) {
                        (Some(CriterionSpec::Toughness { k_ic, initiation }), _) => {
                            Criterion::Toughness { k_ic, initiation }
                        }
                        (Some(CriterionSpec::Strength(threshold)), _) | (None, Some(threshold)) => {
                            Criterion::Strength {
                                threshold,
                                tip_handover: f.tip_handover.unwrap_or(matches!(
                                    sc.mesh,
                                    Some(MeshSpec::Conforming { .. } | MeshSpec::Gmsh { .. })
                                )),
                            }
                        }
                        (None, None) => return None,
                    };
                    Some(CriterionParams {
                        kind,
                        by_elements: f.face_stress == FaceStress::Elements,
                    })
                })
                .filter(|_| has_solid),
            has_fractures: f.is_some(),
            seismicity: sc.seismicity.clone(),
            face_pressure: f.and_then(|f| f.pressure),
            fluid: FlowParams::from(sc.fluid),
            coupled,
            flow_boundaries: sc.flow_boundaries.clone(),
            bc_names: sc
                .flow_boundaries
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    if b.name.is_empty() {
                        format!("bc{i}")
                    } else {
                        b.name.clone()
                    }
                })
                .collect(),
            boundary_schedule: sc.boundary_schedule.clone(),
            time: TimeParams {
                end: t.end,
                safety: t.safety,
                forced_dt: t.dt.is_some(),
                flow_dt: t.flow_dt,
                flow_scheme: t.flow_scheme,
                solid_scheme: t.solid_scheme,
                inertia: t.inertia,
                max_steps: t.max_steps,
                max_substeps: t.max_substeps,
                mass_scaling: t.mass_scaling,
                selective: None,
                adaptive,
                dt_min: t.dt_min.unwrap_or(end_time * 1e-9),
                dt_max: t.dt_max.unwrap_or(end_time / 100.0),
                max_resolves: t.max_resolves,
                newton_easy: t.newton_easy,
            },
            output: OutputParams {
                frame_every: sc.output.frame_every,
                series_every: sc.output.series_every,
                figure_times: sc.output.figure_times.clone(),
                fields: sc.output.fields.clone(),
                checkpoint_every: sc.output.checkpoint_every,
            },
        }
    }

    /// Fluid bulk modulus that stiffens the joints in the solid's stability bound, Pa: K of the
    /// fluid in coupled runs, 0 otherwise.
    pub fn k_fluid(&self) -> f64 {
        if self.coupled { self.fluid.k } else { 0.0 }
    }
}
