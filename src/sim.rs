//! A simulation: the model, its dense view, the schedule, and the step loop.

use crate::error::{RunError, SetupError};
use crate::mesh::TriMesh;
use crate::model::Model;
use crate::output::{Outputs, SeriesRow};
use crate::scenario::{Damping, End, MeshSpec, Scenario};
use crate::schedule::Schedule;
use crate::systems::SystemId;
use crate::systems::solid::{self, SolidParams, StepStats};
use crate::view::SolidView;

/// A speed above this fraction of the P-wave speed implies strains of order 100 %: far outside
/// small-strain elasticity, so the run is treated as blown up.
pub const SPEED_LIMIT_FRACTION: f64 = 1.0;

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Finish {
    /// Reached the end time.
    EndTime,
    /// Static residual below tolerance.
    Converged,
    /// Hit `time.max_steps` first.
    MaxSteps,
}

pub struct Simulation {
    pub scenario: Scenario,
    pub model: Model,
    pub view: SolidView,
    pub params: SolidParams,
    pub schedule: Schedule,
    /// Critical step min altitude / c_p, s.
    pub dt_crit: f64,
    /// P-wave speed, m/s.
    pub c_p: f64,
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Statistics of the last step.
    pub stats: StepStats,
    /// Static residual after the last step.
    pub residual: f64,
    pub finish: Option<Finish>,
    pub output: Option<Outputs>,
    /// Steps to run for an `End::Time` scenario.
    steps_to_end: Option<u64>,
}

/// Build the mesh a scenario describes.
pub fn build_mesh(spec: &MeshSpec) -> Result<TriMesh, SetupError> {
    match *spec {
        MeshSpec::Regular {
            width,
            height,
            h,
            origin,
        } => TriMesh::regular(width, height, h, origin),
        MeshSpec::Perturbed {
            width,
            height,
            h,
            origin,
            fraction,
            seed,
        } => TriMesh::perturbed(width, height, h, origin, fraction, seed),
    }
}

impl Simulation {
    /// Set up a validated scenario; `extra_disable` adds system names to switch off.
    pub fn new(scenario: Scenario, extra_disable: &[String]) -> Result<Self, SetupError> {
        scenario.validate()?;
        let mesh = build_mesh(&scenario.mesh)?;
        let mut model = Model::from_mesh(&mesh, scenario.material)?;
        model.apply_boundary(&scenario.boundary);
        model.apply_pins(&scenario.pins)?;
        let mat = scenario.material;
        let c_p = mat.p_wave_speed();
        let dt_crit = model.min_altitude / c_p;
        let mut dt = scenario.time.dt.unwrap_or(scenario.time.safety * dt_crit);
        let steps_to_end = match scenario.time.end {
            End::Time(te) => {
                let n = (te / dt - 1e-9).ceil().max(1.0);
                dt = te / n;
                Some(n as u64)
            }
            End::Static { .. } => None,
        };
        if scenario.time.dt.is_some() && dt > dt_crit {
            tracing::warn!(
                "time.dt = {dt:.3e} s is above the critical step {dt_crit:.3e} s; expect a blow-up"
            );
        }
        let params = SolidParams {
            lam2g: mat.lambda() + 2.0 * mat.shear(),
            lam: mat.lambda(),
            g: mat.shear(),
            dt,
            damping: scenario.damping,
        };
        let mut disabled = scenario.systems.disable.clone();
        disabled.extend(extra_disable.iter().cloned());
        let view = SolidView::build(&model);
        let has_load = view.load.iter().any(|l| l[0] != 0.0 || l[1] != 0.0);
        let damping_on = scenario.damping != Damping::None;
        let schedule = Schedule::new(&disabled, |s| match s {
            SystemId::ExternalLoad => has_load,
            SystemId::Damping => damping_on,
            _ => true,
        })?;
        Ok(Simulation {
            scenario,
            model,
            view,
            params,
            schedule,
            dt_crit,
            c_p,
            step: 0,
            time: 0.0,
            stats: StepStats::default(),
            residual: f64::INFINITY,
            finish: None,
            output: None,
            steps_to_end,
        })
    }

    /// Copy the hot state into the ECS components.
    pub fn sync(&mut self) {
        solid::update_stress(&mut self.view, &self.params);
        self.view.write_back(&mut self.model);
    }

    /// Change the model (boundary conditions, loads, topology) between steps: the state is
    /// synced first and the view is rebuilt if the topology generation moved.
    pub fn edit_model(&mut self, f: impl FnOnce(&mut Model)) {
        self.sync();
        f(&mut self.model);
        if self.view.generation != self.model.topology_generation {
            self.view = SolidView::build(&self.model);
            let has_load = self.view.load.iter().any(|l| l[0] != 0.0 || l[1] != 0.0);
            for (s, st) in &mut self.schedule.entries {
                if *s == SystemId::ExternalLoad && *st != crate::schedule::Status::DisabledByUser {
                    *st = if has_load {
                        crate::schedule::Status::Enabled
                    } else {
                        crate::schedule::Status::NoData
                    };
                }
            }
        }
    }

    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.params.dt
    }

    /// One step: every enabled system in order, each in its span.
    pub fn step_once(&mut self) -> Result<(), RunError> {
        if self.view.generation != self.model.topology_generation {
            self.view = SolidView::build(&self.model);
        }
        let next_step = self.step + 1;
        let next_time = self.time + self.params.dt;
        let systems: Vec<SystemId> = self.schedule.enabled().collect();
        for sys in systems {
            let _span = sys.span().entered();
            match sys {
                SystemId::InternalForce => solid::internal_force(&mut self.view, &self.params),
                SystemId::ExternalLoad => solid::external_load(&mut self.view),
                SystemId::Damping => solid::damping(&mut self.view, &self.params),
                SystemId::Integrate => {
                    self.stats = solid::integrate(&mut self.view, &self.params);
                    self.step = next_step;
                    self.time = next_time;
                }
                SystemId::Monitor => self.monitor()?,
                SystemId::Output => {
                    let frame = self.frame_due();
                    let row = self.series_due();
                    if frame || row {
                        self.write_outputs(frame, row)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// `monitor`: stop on non-finite or runaway state, update the residual and the end state.
    fn monitor(&mut self) -> Result<(), RunError> {
        let st = self.stats;
        let blow = |i: usize, quantity: &'static str, value: f64, why: String| {
            let x = self.view.x0[i];
            RunError::BlowUp {
                step: self.step,
                time: self.time,
                entity: format!(
                    "node {} at ({:.4}, {:.4}) m",
                    self.view.node_id[i], x[0], x[1]
                ),
                quantity,
                value,
                why,
                dt: self.params.dt,
            }
        };
        if let Some(i) = st.non_finite {
            let v = self.view.v[i];
            let value = if v[0].is_finite() { v[1] } else { v[0] };
            return Err(blow(i, "velocity", value, "a non-finite value".into()));
        }
        let limit = SPEED_LIMIT_FRACTION * self.c_p;
        if st.vmax > limit {
            return Err(blow(
                st.vmax_node,
                "speed",
                st.vmax,
                format!(
                    "above {SPEED_LIMIT_FRACTION} c_p = {limit:.4e} m/s (strain of order 100 %: the step \
                     exceeds the stability limit {:.3e} s or the loading is not physical)",
                    self.dt_crit
                ),
            ));
        }
        self.residual = st.residual();
        if let End::Static { tol, min_steps } = self.scenario.time.end
            && self.step >= min_steps
            && self.residual < tol
        {
            self.finish = Some(Finish::Converged);
        }
        if let Some(n) = self.steps_to_end
            && self.step >= n
        {
            self.finish = Some(Finish::EndTime);
        }
        if self.finish.is_none() && self.step >= self.scenario.time.max_steps {
            self.finish = Some(Finish::MaxSteps);
        }
        Ok(())
    }

    fn frame_due(&self) -> bool {
        let every = self.scenario.output.frame_every;
        self.finish.is_some() || (every > 0 && self.step.is_multiple_of(every))
    }

    fn series_due(&self) -> bool {
        self.finish.is_some() || self.step.is_multiple_of(self.scenario.output.series_every)
    }

    /// The current time-series row.
    pub fn series_row(&self) -> SeriesRow {
        SeriesRow {
            step: self.step,
            time: self.time,
            kinetic_energy: self.stats.kinetic,
            strain_energy: self.stats.strain,
            residual: self.residual,
            max_speed: self.stats.vmax,
        }
    }

    fn write_outputs(&mut self, frame: bool, row: bool) -> Result<(), RunError> {
        if self.output.is_none() {
            return Ok(());
        }
        let r = self.series_row();
        let poisson = self.scenario.material.poisson;
        let out = self.output.as_mut().expect("checked");
        if row {
            out.write_series(&r)?;
        }
        if frame {
            out.write_frame(&self.view, &self.params, poisson, self.time)?;
        }
        Ok(())
    }

    /// Run to the end. `progress` is called every few hundred steps with (step, time, residual).
    pub fn run(&mut self, mut progress: impl FnMut(&Simulation)) -> Result<Finish, RunError> {
        if self.step == 0 && self.output.is_some() && self.schedule.is_enabled(SystemId::Output) {
            self.write_outputs(true, true)?;
        }
        while self.finish.is_none() {
            self.step_once()?;
            if self.step.is_multiple_of(256) {
                progress(self);
            }
        }
        self.sync();
        Ok(self.finish.expect("loop ends with a finish"))
    }

    /// Mean element stress [sxx, syy, sxy] weighted by area, Pa, and the largest relative
    /// deviation of any element from it.
    pub fn stress_summary(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let mut mean = [0.0; 3];
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        let mut area = 0.0;
        for (s, g) in self.view.stress.iter().zip(&self.view.geom) {
            for k in 0..3 {
                mean[k] += g[0] * s[k];
                min[k] = min[k].min(s[k]);
                max[k] = max[k].max(s[k]);
            }
            area += g[0];
        }
        (mean.map(|m| m / area), min, max)
    }
}
