//! `hydrofrac pipeline FILE`: stimulation -> doublet -> upscaling -> heat extraction, on the
//! fracture network before and after the stimulation, in one command (`docs/reservoir.md`).
//!
//! Stages, each timed (`summary.json` `stages`, and the table printed at the end):
//! 1. **stimulation**: the stimulation scenario runs as `hydrofrac run` would, into
//!    `<out>/stimulation/`; its network at the start is "before", at the end "after".
//! 2. **doublet**: the steady flow of each network between an injection and a production
//!    well held at pressures (`reservoir::doublet`), at each pressure drop, with the apertures
//!    at the end of the stimulation and with every cell closed to the residual aperture
//!    (`network_production.csv`, flow maps).
//! 3. **upscaling**: Oda's tensor and the flow-based permeability of each network on a grid of
//!    blocks over the stimulated block (`permeability.csv`, `permeability.vtu`, maps).
//! 4. **heat**: the discrete model on each network and the continuum model on a reservoir
//!    around the stimulated zones, for the years asked (`heat_*.csv`, `reservoir.csv`, plots).
//!
//! SI units: m, Pa, s, K, W, J; rates and powers per metre of thickness.

use crate::driver::{DriverError, RunOptions, RunReport, run_scenario};
use crate::flow::FlowView;
use crate::output::folder::{Folder, FolderError, Plan};
use crate::reservoir::continuum::{
    ContinuumRun, ContinuumSpec, Well, WellControl, WellIndex, run_continuum,
};
use crate::reservoir::discrete::{DiscreteRun, DiscreteSpec, RockGrid, TimeStep, run_discrete};
use crate::reservoir::doublet::{PressureWell, doublet_flow, doublet_wells};
use crate::reservoir::upscale::{BlockPermeability, upscale};
use crate::reservoir::{Grid2, NetworkFlow, ReservoirError, ThermalProps};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A pipeline file (RON).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSpec {
    pub name: String,
    /// The stimulation scenario, relative to this file.
    pub stimulation: PathBuf,
    /// `--set PATH=VALUE` overrides applied to the stimulation scenario.
    #[serde(default)]
    pub stimulation_set: Vec<String>,
    /// The doublet stage's wells and pressure drops (the heat stage's wells too).
    pub production: ProductionSpec,
    /// Apertures of the networks in the doublet, upscaling and heat stages (default:
    /// `Residual` after a stimulation; the given apertures for a flow-only scene).
    #[serde(default)]
    pub apertures: Option<Apertures>,
    /// The rock block `[x_min, x_max, y_min, y_max]` (m) that the upscaling grid and the
    /// discrete heat model's rock grid cover (default: the stimulation's mesh box). Needed
    /// when the stimulation scene has no rock mesh (a flow-only scene: the heat-only path).
    #[serde(default)]
    pub domain: Option<[f64; 4]>,
    pub upscaling: UpscalingSpec,
    pub heat: HeatSpec,
}

/// Which apertures the doublet, upscaling and heat stages give the fracture cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
pub enum Apertures {
    /// Every cell at the joints' residual aperture: the fractures closed after the pump
    /// stopped (the default after a stimulation; the stimulation adds connected length, not
    /// width).
    Residual,
    /// The hydraulic apertures at the end of the stimulation, with the pump still on (an
    /// upper bound: the fractures are held open by the injection pressure).
    EndOfStimulation,
    /// The apertures the flow-only scene gives its fractures (the default of the heat-only
    /// path; refused after a stimulation, whose apertures are not given).
    Given,
}

/// The heat-extraction stage: the same wells as the doublet stage, at one pressure drop.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HeatSpec {
    /// Rock and fluid properties (SI; see [`ThermalProps`]).
    pub props: ThermalProps,
    /// Initial temperature of rock and fluid, K.
    pub initial_temperature: f64,
    /// Injection temperature, K.
    pub injection_temperature: f64,
    /// Pressure drop between the wells, Pa.
    pub pressure_drop: f64,
    /// Years to simulate (1 year = 365.25 days).
    pub years: f64,
    /// Years at which the table reports temperature and power (default 1, 10, 30).
    #[serde(default = "default_report_years")]
    pub report_years: Vec<f64>,
    /// Breakthrough: the production temperature has fallen by this fraction of
    /// (initial - injection) (default 0.1).
    #[serde(default = "default_breakthrough")]
    pub breakthrough_fraction: f64,
    /// Years of the temperature field snapshots (default: the report years).
    #[serde(default)]
    pub snapshot_years: Option<Vec<f64>>,
    pub discrete: DiscreteHeatSpec,
    pub continuum: ContinuumHeatSpec,
}

fn default_report_years() -> Vec<f64> {
    vec![1.0, 10.0, 30.0]
}

fn default_breakthrough() -> f64 {
    0.1
}

/// The discrete model's rock grid over the stimulated block: graded towards the wells' lines.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DiscreteHeatSpec {
    /// Smallest block next to the fracture lines through the wells, m.
    pub h_min: f64,
    /// Growth of the block size away from them.
    pub growth: f64,
    /// Largest block, m.
    pub h_max: f64,
    /// Time steps.
    pub time_step: TimeStep,
}

/// The continuum reservoir: a rectangle of blocks the size of the upscaling blocks, with the
/// stimulated block's upscaled permeability placed at `zone_origin` and matrix elsewhere.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ContinuumHeatSpec {
    /// Reservoir extent, m (lower-left corner at 0, 0).
    pub size: [f64; 2],
    /// Where the stimulated block's lower-left corner lies in the reservoir, m (rounded to
    /// the nearest block line; the reservoir's blocks are the upscaling blocks, and its size
    /// is rounded to whole blocks).
    pub zone_origin: [f64; 2],
    /// Which upscaled permeability the zone gets.
    #[serde(default)]
    pub permeability: PermeabilityChoice,
    /// Time step, s.
    pub dt: f64,
    /// Well radius for Peaceman's index, m.
    #[serde(default = "default_well_radius")]
    pub well_radius: f64,
}

fn default_well_radius() -> f64 {
    0.1
}

/// The upscaled permeability the continuum model uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
pub enum PermeabilityChoice {
    /// The flow-based permeameter's diagonal (the default: only connected fractures count).
    #[default]
    FlowBased,
    /// Oda's tensor's diagonal (an upper bound).
    Oda,
}

/// The wells of the doublet stage (`production:` in a pipeline file), in the stimulated
/// block's coordinates.
pub use crate::scenario::ProductionSpec;

/// The grid the networks are upscaled onto.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct UpscalingSpec {
    /// Blocks in x and y over the stimulation's mesh (its bounding box).
    pub blocks: [usize; 2],
    /// Permeability of the intact rock, m^2 (granite: 1e-19 to 1e-16).
    pub matrix_permeability: f64,
    /// Fluid viscosity of the doublet and upscaling stages, Pa s.
    pub viscosity: f64,
}

/// Errors of a pipeline: its file, a stage, or the outputs.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("cannot read pipeline {}: {source}", .path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Malformed RON: file, line, column, field.
    #[error(transparent)]
    Syntax(#[from] crate::error::SetupError),
    #[error("invalid {field}: {why}")]
    Invalid { field: String, why: String },
    #[error("stimulation stage: {0}")]
    Stimulation(#[from] DriverError),
    #[error("{stage} stage: {error}")]
    Reservoir {
        stage: &'static str,
        error: ReservoirError,
    },
    #[error("interrupted by {} during the stimulation; its outputs are finished in {out}", crate::driver::signal_name(*.signal))]
    Interrupted { signal: usize, out: String },
    #[error(transparent)]
    Folder(#[from] FolderError),
    #[error("{0}")]
    Output(std::io::Error),
}

impl PipelineSpec {
    /// Read and validate a pipeline file; the stimulation path becomes relative to the
    /// current folder.
    pub fn load(path: &Path) -> Result<Self, PipelineError> {
        let text = std::fs::read_to_string(path).map_err(|source| PipelineError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut spec = Self::parse(&text, &path.display().to_string())?;
        if spec.stimulation.is_relative()
            && let Some(dir) = path.parent()
        {
            spec.stimulation = dir.join(&spec.stimulation);
        }
        spec.validate()?;
        Ok(spec)
    }

    /// Parse RON text; errors carry file, line, column and field
    /// ([`crate::scenario::parse_ron`], as for scenarios).
    pub fn parse(text: &str, file: &str) -> Result<Self, PipelineError> {
        Ok(crate::scenario::parse_ron(text, file, "pipeline")?)
    }

    /// Every field in range, stage by stage (the doublet's wells, the upscaling grid, the
    /// heat models, the viscosity); the error names the first field out of range.
    pub fn validate(&self) -> Result<(), PipelineError> {
        self.production.validate("production")?;
        if let Some(d) = self.domain {
            let p = &self.production;
            let inside = |q: [f64; 2]| q[0] >= d[0] && q[0] <= d[1] && q[1] >= d[2] && q[1] <= d[3];
            if !(d.iter().all(|x| x.is_finite()) && d[0] < d[1] && d[2] < d[3]) {
                return Err(invalid(
                    "domain",
                    format!("{d:?} is not a finite box [x_min, x_max, y_min, y_max] (m)"),
                ));
            }
            if !(inside(p.injection) && inside(p.production)) {
                return Err(invalid(
                    "domain",
                    format!(
                        "{d:?} does not contain both wells, {:?} and {:?}",
                        p.injection, p.production
                    ),
                ));
            }
        }
        self.upscaling.validate_grid()?;
        self.heat.validate()?;
        self.upscaling.validate_viscosity()
    }

    /// The apertures the later stages take, checked against the stimulation scene: after a
    /// stimulation (`has_rock`) `Residual` (the default) or `EndOfStimulation`; for a flow-only
    /// scene `Given` (the default), and a `domain`, which a scene without a mesh lacks.
    pub fn apertures_for(&self, has_rock: bool) -> Result<Apertures, PipelineError> {
        let scene = self.stimulation.display();
        match (self.apertures, has_rock) {
            (None, true) => Ok(Apertures::Residual),
            (Some(Apertures::Given), true) => Err(invalid(
                "apertures",
                format!(
                    "Given: {scene} stimulates the rock, so its apertures are computed, not \
                     given; choose Residual or EndOfStimulation"
                ),
            )),
            (Some(a), true) => Ok(a),
            (_, false) if self.domain.is_none() => Err(invalid(
                "domain",
                format!(
                    "{scene} has no rock mesh (a flow-only scene): give the rock block the \
                     heat models cover, domain: (x_min, x_max, y_min, y_max) in m"
                ),
            )),
            (None | Some(Apertures::Given), false) => Ok(Apertures::Given),
            (Some(Apertures::EndOfStimulation), false) => Err(invalid(
                "apertures",
                format!(
                    "EndOfStimulation: {scene} is a flow-only scene (nothing is stimulated); \
                     its apertures are Given"
                ),
            )),
            (Some(Apertures::Residual), false) => Ok(Apertures::Residual),
        }
    }
}

/// An out-of-range pipeline field.
fn invalid(field: &str, why: String) -> PipelineError {
    PipelineError::Invalid {
        field: field.to_string(),
        why,
    }
}

/// `v` (in `unit`) finite and positive, else an error naming `field`.
fn positive(field: &str, v: f64, unit: &str) -> Result<(), PipelineError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("{v} {unit} is not finite and positive"),
        ))
    }
}

impl UpscalingSpec {
    /// 1 to 10000 blocks each way, a finite non-negative matrix permeability.
    fn validate_grid(&self) -> Result<(), PipelineError> {
        if self.blocks.iter().any(|&n| n == 0 || n > 10_000) {
            return Err(invalid(
                "upscaling.blocks",
                format!("{:?}: each count must be in 1..=10000", self.blocks),
            ));
        }
        let k = self.matrix_permeability;
        if !(k.is_finite() && k >= 0.0) {
            return Err(invalid(
                "upscaling.matrix_permeability",
                format!("{k} m^2 is not finite and non-negative"),
            ));
        }
        Ok(())
    }

    /// A finite positive viscosity.
    fn validate_viscosity(&self) -> Result<(), PipelineError> {
        if !(self.viscosity.is_finite() && self.viscosity > 0.0) {
            return Err(invalid(
                "upscaling.viscosity",
                format!("{} Pa s is not finite and positive", self.viscosity),
            ));
        }
        Ok(())
    }
}

impl HeatSpec {
    /// Finite positive temperatures, pressure drop and years (at most 10000), report years in
    /// (0, years], a breakthrough fraction in (0, 1), then each model's grid and steps.
    fn validate(&self) -> Result<(), PipelineError> {
        positive("heat.initial_temperature", self.initial_temperature, "K")?;
        positive(
            "heat.injection_temperature",
            self.injection_temperature,
            "K",
        )?;
        positive("heat.pressure_drop", self.pressure_drop, "Pa")?;
        positive("heat.years", self.years, "years")?;
        if self.years > 1e4 {
            return Err(invalid(
                "heat.years",
                format!("{} years: at most 10000", self.years),
            ));
        }
        for (k, y) in self.report_years.iter().enumerate() {
            if !(y.is_finite() && *y > 0.0 && *y <= self.years) {
                return Err(invalid(
                    &format!("heat.report_years[{k}]"),
                    format!("{y} is not in (0, heat.years = {}]", self.years),
                ));
            }
        }
        let f = self.breakthrough_fraction;
        if !(f > 0.0 && f < 1.0) {
            return Err(invalid(
                "heat.breakthrough_fraction",
                format!("{f} is not in (0, 1)"),
            ));
        }
        self.discrete.validate()?;
        self.continuum.validate(self.years)
    }
}

impl DiscreteHeatSpec {
    /// Finite positive block sizes, a finite growth >= 1.
    fn validate(&self) -> Result<(), PipelineError> {
        positive("heat.discrete.h_min", self.h_min, "m")?;
        positive("heat.discrete.h_max", self.h_max, "m")?;
        if !(self.growth.is_finite() && self.growth >= 1.0) {
            return Err(invalid(
                "heat.discrete.growth",
                format!("{} is not finite and >= 1", self.growth),
            ));
        }
        Ok(())
    }
}

impl ContinuumHeatSpec {
    /// A finite positive size, step and well radius, a zone origin in the reservoir, and at
    /// most `continuum::MAX_STEPS` steps over `years`.
    fn validate(&self, years: f64) -> Result<(), PipelineError> {
        positive("heat.continuum.size[0]", self.size[0], "m")?;
        positive("heat.continuum.size[1]", self.size[1], "m")?;
        positive("heat.continuum.dt", self.dt, "s")?;
        positive("heat.continuum.well_radius", self.well_radius, "m")?;
        if !self.zone_origin.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(invalid(
                "heat.continuum.zone_origin",
                format!(
                    "{:?} is not a finite point in the reservoir",
                    self.zone_origin
                ),
            ));
        }
        let steps = years * YEAR / self.dt;
        let most = crate::reservoir::continuum::MAX_STEPS;
        if steps > most as f64 {
            return Err(invalid(
                "heat.continuum.dt",
                format!(
                    "{} s gives {steps:.0} steps over {years} years, more than {most}",
                    self.dt
                ),
            ));
        }
        Ok(())
    }
}

/// A network state of the pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Before,
    After,
    /// The network of a flow-only scene, apertures as given (the heat-only path).
    Given,
}

impl State {
    pub fn name(self) -> &'static str {
        match self {
            State::Before => "before",
            State::After => "after",
            State::Given => "given",
        }
    }
}

pub use crate::reservoir::doublet::{network_of_view, reaches};

/// One row of `network_production.csv` (the doublet stage).
#[derive(Clone, Debug, PartialEq)]
pub struct DoubletRow {
    pub state: State,
    /// Pressure drop, Pa.
    pub dp: f64,
    /// Production rate with the apertures at the end of the stimulation, m^2/s per metre.
    pub rate: f64,
    /// The same with every cell at the residual aperture.
    pub rate_residual: f64,
}

/// What a pipeline run reports.
#[derive(Debug)]
pub struct PipelineReport {
    pub out: PathBuf,
    /// The doublet stage's rows.
    pub doublet: Vec<DoubletRow>,
    pub permeability: Vec<(State, BlockPermeability)>,
    /// (stage, wall seconds).
    pub stages: Vec<(&'static str, f64)>,
    /// One row per network state: `reservoir.csv`.
    pub reservoir: Vec<ReservoirRow>,
    pub summary: serde_json::Value,
}

/// Options of a pipeline run.
#[derive(Clone, Debug, Default)]
pub struct PipelineOptions {
    pub out: Option<PathBuf>,
    pub quiet: bool,
    pub force: bool,
    pub stop: Option<crate::sim::StopFlag>,
    /// Handed to the stimulation's run (`RunOptions::exit_until_output`): until it creates its
    /// folder (the stimulation's setup included) a signal ends the process at once, leaving
    /// at most the pipeline's folder and manifest.
    pub exit_until_output: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

/// Run a pipeline file, stage by stage: stimulation, doublet, upscaling, heat, then
/// `summary.json`. Each stage's wall time is in `stages`.
pub fn run_pipeline(path: &Path, opts: &PipelineOptions) -> Result<PipelineReport, PipelineError> {
    let spec = PipelineSpec::load(path)?;
    // The stimulation scene is read and checked against the file before anything runs: a
    // flow-only scene (no rock mesh) takes the heat-only path.
    let scenario = crate::scenario::Scenario::load(&spec.stimulation, &spec.stimulation_set)
        .map_err(|e| PipelineError::Stimulation(e.into()))?;
    let given = scenario.mesh.is_none();
    let apertures = spec.apertures_for(!given)?;
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&spec.name));
    let plan = Plan::check(&out, opts.force)?;
    plan.require_folder("stimulation")?;
    let folder = plan.open()?;
    let mut stages = Vec::new();
    let stim = timed(&mut stages, "stimulation", || {
        stimulation_stage(&spec, scenario, &out, opts)
    })?;
    let nets = Networks::of(&spec, &stim, apertures, given)?;
    let domain = spec.domain.unwrap_or(stim.mesh_box);
    let doublet = timed(&mut stages, "doublet", || {
        doublet_stage(&spec, &nets, &folder)
    })?;
    let permeability = timed(&mut stages, "upscaling", || {
        upscaling_stage(&spec, &nets, domain, &folder)
    })?;
    let heat = heat_stage(
        &spec,
        &nets.views(),
        nets.chosen,
        &permeability,
        domain,
        &mut stages,
    )?;
    write_heat(&folder, &spec, &heat)?;
    let summary = write_summary(&folder, &spec, &nets, stim.summary, &stages, &heat)?;
    Ok(PipelineReport {
        out,
        doublet,
        permeability,
        stages,
        reservoir: heat.rows,
        summary,
    })
}

/// Run `stage`, and on success add its wall time to `stages` as `name`.
fn timed<T>(
    stages: &mut Vec<(&'static str, f64)>,
    name: &'static str,
    stage: impl FnOnce() -> Result<T, PipelineError>,
) -> Result<T, PipelineError> {
    let t0 = Instant::now();
    let r = stage()?;
    stages.push((name, t0.elapsed().as_secs_f64()));
    Ok(r)
}

/// 1. The stimulation stage: the stimulation scenario as `hydrofrac run` runs it, into
///    `<out>/stimulation/`.
fn stimulation_stage(
    spec: &PipelineSpec,
    scenario: crate::scenario::ValidScenario,
    out: &Path,
    opts: &PipelineOptions,
) -> Result<RunReport, PipelineError> {
    let opts = RunOptions {
        out: Some(out.join("stimulation")),
        set: spec.stimulation_set.clone(),
        quiet: opts.quiet,
        force: opts.force,
        stop: opts.stop.clone(),
        exit_until_output: opts.exit_until_output.clone(),
        ..Default::default()
    };
    Ok(run_scenario(scenario, &opts)?)
}

/// The stimulation's networks as the later stages take them: before and after (or the one
/// given network of a flow-only scene), the residual aperture, and the apertures the pipeline
/// file chose (`Some(residual)`, or `None`: the networks' own).
struct Networks {
    start: FlowView,
    end: FlowView,
    /// A flow-only scene: one network, `State::Given`, its apertures as given.
    given: bool,
    residual: f64,
    chosen: Option<f64>,
    apertures: Apertures,
}

impl Networks {
    /// The networks of a finished stimulation (`given`: of a flow-only scene): refused when a
    /// signal stopped it, or when it has no fractures.
    fn of(
        spec: &PipelineSpec,
        stim: &RunReport,
        apertures: Apertures,
        given: bool,
    ) -> Result<Self, PipelineError> {
        if let Some(signal) = stim.interrupted_by {
            return Err(PipelineError::Interrupted {
                signal,
                out: stim.out.display().to_string(),
            });
        }
        let Some([start, end]) = stim.networks.clone() else {
            return Err(PipelineError::Invalid {
                field: "stimulation".into(),
                why: format!("{} has no fractures", spec.stimulation.display()),
            });
        };
        let residual = stim.residual_aperture;
        let chosen = match apertures {
            Apertures::Residual => Some(residual),
            Apertures::EndOfStimulation | Apertures::Given => None,
        };
        Ok(Networks {
            start,
            end,
            given,
            residual,
            chosen,
            apertures,
        })
    }

    /// Before and after a stimulation; the one given network of a flow-only scene.
    fn views(&self) -> Vec<(State, &FlowView)> {
        if self.given {
            vec![(State::Given, &self.start)]
        } else {
            vec![(State::Before, &self.start), (State::After, &self.end)]
        }
    }
}

/// 2. The doublet stage: the steady flow of each network between the wells at each pressure
///    drop, with the apertures at the end of the stimulation and every cell at the residual
///    aperture (`network_production.csv`); the flow over the networks at the middle drop, with
///    the chosen apertures (`production_flow_{state}.png`, the seed's Fig. 10).
fn doublet_stage(
    spec: &PipelineSpec,
    nets: &Networks,
    folder: &Folder,
) -> Result<Vec<DoubletRow>, PipelineError> {
    let p = &spec.production;
    let mut rows = Vec::new();
    for (state, v) in nets.views() {
        for &dp in &p.pressure_drops {
            let wells = doublet_wells(p, dp);
            rows.push(DoubletRow {
                state,
                dp,
                rate: doublet_rate(spec, state, v, &wells, None)?,
                rate_residual: doublet_rate(spec, state, v, &wells, Some(nets.residual))?,
            });
        }
    }
    write_doublet(folder, &rows)?;
    let dp = p.pressure_drops[p.pressure_drops.len() / 2];
    let wells = doublet_wells(p, dp);
    for (state, v) in nets.views() {
        let net = network_of_view(v, nets.chosen);
        let flow = doublet_flow(&net, &wells, spec.upscaling.viscosity, p.reach)
            .map(|d| d.flow)
            .unwrap_or(net);
        flow_png(
            folder,
            &format!("production_flow_{}.png", state.name()),
            &format!(
                "{}: production flow, {}, dp = {:.0} MPa, {:?} apertures",
                spec.name,
                state.name(),
                dp / 1e6,
                nets.apertures
            ),
            &flow,
            &[(p.injection, "injection"), (p.production, "production")],
        )?;
    }
    Ok(rows)
}

/// The production rate of network `v` between `wells` (m^2/s per metre), with every cell at
/// the aperture `residual`, else with its own. Before the stimulation a well no fracture
/// reaches produces nothing through the network (the continuum model gives it the matrix's
/// flow).
fn doublet_rate(
    spec: &PipelineSpec,
    state: State,
    v: &FlowView,
    wells: &[PressureWell; 2],
    residual: Option<f64>,
) -> Result<f64, PipelineError> {
    let p = &spec.production;
    let net = network_of_view(v, residual);
    if state != State::After && !reaches(&net, wells, p.reach) {
        return Ok(0.0);
    }
    let flow = doublet_flow(&net, wells, spec.upscaling.viscosity, p.reach)
        .map_err(reservoir_error("doublet"))?;
    Ok(-flow.wells[1].1)
}

/// 3. The upscaling stage: Oda's tensor and the flow-based permeability of each network, with
///    the chosen apertures, on `upscaling.blocks` over the rock block (`domain`: the mesh box
///    unless the file gives one): `permeability.csv`, `permeability.vtu` and the maps `permeability_{flow,oda}_{state}.png`.
fn upscaling_stage(
    spec: &PipelineSpec,
    nets: &Networks,
    domain: [f64; 4],
    folder: &Folder,
) -> Result<Vec<(State, BlockPermeability)>, PipelineError> {
    let b = domain;
    let grid = Grid2 {
        origin: [b[0], b[2]],
        size: [b[1] - b[0], b[3] - b[2]],
        n: spec.upscaling.blocks,
    };
    let mut permeability = Vec::new();
    for (state, v) in nets.views() {
        let k = upscale(
            &grid,
            &network_of_view(v, nets.chosen),
            spec.upscaling.viscosity,
            spec.upscaling.matrix_permeability,
        )
        .map_err(reservoir_error("upscaling"))?;
        permeability.push((state, k));
    }
    write_permeability(folder, &permeability)?;
    permeability_maps(folder, spec, &permeability)?;
    Ok(permeability)
}

/// `permeability_{flow,oda}_{state}.png`: max(k_xx, k_yy) per block, log scale, with the wells.
fn permeability_maps(
    folder: &Folder,
    spec: &PipelineSpec,
    permeability: &[(State, BlockPermeability)],
) -> Result<(), PipelineError> {
    let p = &spec.production;
    let wells = [(p.injection, "injection"), (p.production, "production")];
    for (state, k) in permeability {
        for (label, values) in [
            (
                "flow",
                k.flow.iter().map(|x| x[0].max(x[1])).collect::<Vec<_>>(),
            ),
            ("oda", k.oda.iter().map(|x| x[0].max(x[1])).collect()),
        ] {
            let name = format!("permeability_{label}_{}.png", state.name());
            let title = format!(
                "{}: {} permeability max(k_xx, k_yy), {}",
                spec.name,
                if label == "flow" { "flow-based" } else { "Oda" },
                state.name()
            );
            field_png(
                folder,
                &name,
                &title,
                &k.grid,
                &values,
                "log10 k [m^2]",
                &wells,
            )?;
        }
    }
    Ok(())
}

/// `summary.json`: the pipeline, its apertures, the stimulation's summary, the stages' wall
/// times, the heat systems' timing, the reservoir table and the largest energy-balance error.
fn write_summary(
    folder: &Folder,
    spec: &PipelineSpec,
    nets: &Networks,
    stimulation: serde_json::Value,
    stages: &[(&'static str, f64)],
    heat: &HeatResult,
) -> Result<serde_json::Value, PipelineError> {
    use serde_json::json;
    let mut summary = json!({
        "pipeline": spec.name,
        "apertures": format!("{:?}", nets.apertures),
        "stimulated": !nets.given,
        "stimulation": stimulation,
        "stages": stages.iter().map(|(s, t)| json!({"stage": s, "wall_s": t})).collect::<Vec<_>>(),
        "systems": heat.timing.iter().map(|(s, calls, t)| json!({"system": s, "calls": calls, "total_s": t})).collect::<Vec<_>>(),
        "reservoir": heat.rows.iter().map(|r| r.json()).collect::<Vec<_>>(),
        "gains": gains_json(&heat.rows),
        "energy_balance": heat.energy_balance,
    });
    crate::output::json::finite_summary(&mut summary);
    crate::output::write_atomic(
        &folder
            .claim("summary.json")
            .map_err(PipelineError::Output)?,
        serde_json::to_string_pretty(&summary)
            .expect("json")
            .as_bytes(),
    )
    .map_err(PipelineError::Output)?;
    Ok(summary)
}

/// `summary.json` `gains`: what the stimulation gave, after / before, per heat model: the
/// production rate (`rate`) and the heat extracted over the run (`heat_total`). A ratio whose
/// "before" is zero (wells not connected before) is left out, never infinite; without both
/// states the object is empty.
fn gains_json(rows: &[ReservoirRow]) -> serde_json::Value {
    let find = |s: State| rows.iter().find(|r| r.state == s);
    let mut m = serde_json::Map::new();
    if let (Some(b), Some(a)) = (find(State::Before), find(State::After)) {
        for (k, name) in MODELS.iter().enumerate() {
            let (fb, fa) = (&b.models[k], &a.models[k]);
            let mut v = serde_json::Map::new();
            for (key, before, after) in
                [("rate", fb.rate, fa.rate), ("heat_total", fb.heat, fa.heat)]
            {
                if before > 0.0 {
                    v.insert(key.into(), (after / before).into());
                }
            }
            m.insert((*name).into(), v.into());
        }
    }
    m.into()
}

/// `network_production.csv`: `state,dp,rate,rate_residual` (Pa, m^2/s per metre).
fn write_doublet(folder: &Folder, rows: &[DoubletRow]) -> Result<(), PipelineError> {
    let mut s = String::from("state,dp,rate,rate_residual\n");
    for r in rows {
        s += &format!(
            "{},{},{:e},{:e}\n",
            r.state.name(),
            r.dp,
            r.rate,
            r.rate_residual
        );
    }
    let path = folder
        .claim("network_production.csv")
        .map_err(PipelineError::Output)?;
    crate::output::write_atomic(&path, s.as_bytes()).map_err(PipelineError::Output)
}

/// `permeability.csv` (`state,block,x,y` and both estimates, m^2) and `permeability.vtu`.
fn write_permeability(
    folder: &Folder,
    k: &[(State, BlockPermeability)],
) -> Result<(), PipelineError> {
    let mut s = String::from("state,block,x,y,k_oda_xx,k_oda_yy,k_oda_xy,k_flow_xx,k_flow_yy\n");
    for (state, b) in k {
        let g = &b.grid;
        for j in 0..g.n[1] {
            for i in 0..g.n[0] {
                let c = g.index(i, j);
                let [x, y] = g.centre(i, j);
                let (o, f) = (b.oda[c], b.flow[c]);
                s += &format!(
                    "{},{c},{x},{y},{:e},{:e},{:e},{:e},{:e}\n",
                    state.name(),
                    o[0],
                    o[1],
                    o[2],
                    f[0],
                    f[1]
                );
            }
        }
    }
    let path = folder
        .claim("permeability.csv")
        .map_err(PipelineError::Output)?;
    crate::output::write_atomic(&path, s.as_bytes()).map_err(PipelineError::Output)?;
    write_permeability_vtu(folder, k)
}

/// `permeability.vtu` (ParaView): the blocks as quads, both estimates of both states as cell
/// data.
fn write_permeability_vtu(
    folder: &Folder,
    k: &[(State, BlockPermeability)],
) -> Result<(), PipelineError> {
    let g = &k[0].1.grid;
    let d = g.dx();
    let mut points = Vec::new();
    for j in 0..=g.n[1] {
        for i in 0..=g.n[0] {
            points.push([
                g.origin[0] + i as f64 * d[0],
                g.origin[1] + j as f64 * d[1],
                0.0,
            ]);
        }
    }
    let corner = |i: usize, j: usize| (i + (g.n[0] + 1) * j) as u32;
    let mut connectivity = Vec::new();
    for j in 0..g.n[1] {
        for i in 0..g.n[0] {
            connectivity.extend([
                corner(i, j),
                corner(i + 1, j),
                corner(i + 1, j + 1),
                corner(i, j + 1),
            ]);
        }
    }
    let mut arrays: Vec<(String, Vec<f64>)> = Vec::new();
    for (state, b) in k {
        for (c, name) in ["k_oda_xx", "k_oda_yy", "k_oda_xy"].iter().enumerate() {
            arrays.push((
                format!("{}_{name}", state.name()),
                b.oda.iter().map(|x| x[c]).collect(),
            ));
        }
        for (c, name) in ["k_flow_xx", "k_flow_yy"].iter().enumerate() {
            arrays.push((
                format!("{}_{name}", state.name()),
                b.flow.iter().map(|x| x[c]).collect(),
            ));
        }
    }
    let piece = crate::output::vtk::VtuPiece {
        points: &points,
        kind: crate::output::vtk::CellKind::Quad,
        connectivity: &connectivity,
        point_data: Vec::new(),
        cell_data: arrays
            .iter()
            .map(|(n, v)| crate::output::vtk::DataArray {
                name: n,
                components: 1,
                values: v,
            })
            .collect(),
    };
    let path = folder
        .claim("permeability.vtu")
        .map_err(PipelineError::Output)?;
    crate::output::vtk::write_vtu(&path, &piece).map_err(PipelineError::Output)
}

/// The tables a pipeline prints: the doublet's rates, the heat extraction, the stage times and
/// the heat systems' timing.
pub fn report_text(r: &PipelineReport) -> String {
    let mut s = String::from("doublet: production rate through the network (m^2/s per metre):\n");
    s += &format!(
        "{:<8} {:>10} {:>14} {:>16}\n",
        "state", "dp [Pa]", "rate", "rate (residual)"
    );
    for p in &r.doublet {
        s += &format!(
            "{:<8} {:>10.3e} {:>14.4e} {:>16.4e}\n",
            p.state.name(),
            p.dp,
            p.rate,
            p.rate_residual
        );
    }
    s += "\nheat extraction (rate m^2/s per metre; temperatures K; power W/m):\n";
    for row in &r.reservoir {
        for (name, f) in MODELS.iter().zip(&row.models) {
            s += &format!(
                "{:<7} {:<10} rate {:.3e}  breakthrough {}",
                row.state.name(),
                name,
                f.rate,
                f.breakthrough
                    .map_or("none".to_string(), |t| format!("{:.3e} years", t / YEAR))
            );
            for (k, y) in row.years.iter().enumerate() {
                s += &format!(
                    "  T({y}y) {:.1}  P({y}y) {:.3e}",
                    f.temperature[k], f.power[k]
                );
            }
            s += "\n";
        }
    }
    s += "\nstage          wall [s]\n";
    for (stage, t) in &r.stages {
        s += &format!("{stage:<14} {t:>8.2}\n");
    }
    if let Some(systems) = r.summary["systems"].as_array() {
        s += "\nheat system       calls    total [s]\n";
        for x in systems {
            s += &format!(
                "{:<16} {:>6} {:>12.4}\n",
                x["system"].as_str().unwrap_or(""),
                x["calls"],
                x["total_s"].as_f64().unwrap_or(0.0)
            );
        }
    }
    s += &format!("outputs in {}\n", r.out.display());
    s
}

/// A block field as a PNG map: each block filled with the colour of log10 of its value.
fn field_png(
    folder: &Folder,
    name: &str,
    title: &str,
    grid: &Grid2,
    values: &[f64],
    label: &str,
    markers: &[([f64; 2], &str)],
) -> Result<(), PipelineError> {
    let d = grid.dx();
    let mut quads = Vec::with_capacity(grid.len());
    let mut v = Vec::with_capacity(grid.len());
    for j in 0..grid.n[1] {
        for i in 0..grid.n[0] {
            let x0 = grid.origin[0] + i as f64 * d[0];
            let y0 = grid.origin[1] + j as f64 * d[1];
            quads.push([
                [x0, y0],
                [x0 + d[0], y0],
                [x0 + d[0], y0 + d[1]],
                [x0, y0 + d[1]],
            ]);
            v.push(values[grid.index(i, j)].max(1e-300).log10());
        }
    }
    let path = folder.claim(name).map_err(PipelineError::Output)?;
    crate::plot::fracture_map(&path, title, &[], &quads, &v, label, None, markers)
        .map_err(|e| PipelineError::Output(std::io::Error::other(e.to_string())))
}

/// The network coloured by each cell's throughput (log scale; cells without flow grey).
fn flow_png(
    folder: &Folder,
    name: &str,
    title: &str,
    net: &NetworkFlow,
    markers: &[([f64; 2], &str)],
) -> Result<(), PipelineError> {
    let path = folder.claim(name).map_err(PipelineError::Output)?;
    crate::reservoir::doublet::flow_map(&path, title, net, markers)
        .map_err(|e| PipelineError::Output(std::io::Error::other(e.to_string())))
}

/// Seconds per year (365.25 days).
pub const YEAR: f64 = 365.25 * 86400.0;

/// One model's heat extraction from one network state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeatSeries {
    /// s.
    pub times: Vec<f64>,
    /// K.
    pub production_temperature: Vec<f64>,
    /// W per metre.
    pub thermal_power: Vec<f64>,
    /// J per metre.
    pub cumulative_heat: Vec<f64>,
    /// Production rate, m^2/s per metre (0: the wells are not connected).
    pub rate: f64,
}

impl HeatSeries {
    /// Linear interpolation of `y` at time `t` (clamped to the run).
    fn at(&self, y: &[f64], t: f64) -> f64 {
        if self.times.is_empty() {
            return 0.0;
        }
        let k = self.times.partition_point(|&x| x < t);
        if k == 0 {
            return y[0];
        }
        if k >= self.times.len() {
            return *y.last().expect("non-empty");
        }
        let (t0, t1) = (self.times[k - 1], self.times[k]);
        let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
        y[k - 1] + w * (y[k] - y[k - 1])
    }
    /// First time the production temperature falls to `threshold` (K), by interpolation.
    fn first_below(&self, threshold: f64) -> Option<f64> {
        let (t, y) = (&self.times, &self.production_temperature);
        (0..y.len()).find(|&k| y[k] <= threshold).map(|k| {
            if k == 0 {
                t[0]
            } else {
                let w = (y[k - 1] - threshold) / (y[k - 1] - y[k]);
                t[k - 1] + w * (t[k] - t[k - 1])
            }
        })
    }
}

/// One row of `reservoir.csv`: a network state, both heat models.
#[derive(Clone, Debug, PartialEq)]
pub struct ReservoirRow {
    pub state: State,
    /// Report times, years.
    pub years: Vec<f64>,
    /// Per model (discrete, continuum): rate (m^2/s per metre), breakthrough (s, `None` when
    /// not within the run), temperatures (K) and powers (W/m) at the report times, heat over
    /// the run (J/m).
    pub models: [ModelFigures; 2],
}

/// The figures of one model in a [`ReservoirRow`].
#[derive(Clone, Debug, PartialEq)]
pub struct ModelFigures {
    pub rate: f64,
    pub breakthrough: Option<f64>,
    pub temperature: Vec<f64>,
    pub power: Vec<f64>,
    pub heat: f64,
}

const MODELS: [&str; 2] = ["discrete", "continuum"];

impl ReservoirRow {
    fn json(&self) -> serde_json::Value {
        let mut m = serde_json::Map::new();
        m.insert("state".into(), self.state.name().into());
        for (name, f) in MODELS.iter().zip(&self.models) {
            let mut v = serde_json::json!({
                "rate": f.rate,
                "report_years": self.years,
                "production_temperature": f.temperature,
                "thermal_power": f.power,
                "heat_total": f.heat,
            });
            // No breakthrough within the run: the key is left out (never a null).
            if let Some(t) = f.breakthrough {
                v["breakthrough_years"] = (t / YEAR).into();
            }
            m.insert((*name).into(), v);
        }
        serde_json::Value::Object(m)
    }
}

/// A temperature field at one time: (state, model, time s, grid quads, values K).
pub type Snapshot = (State, &'static str, f64, Vec<[[f64; 2]; 4]>, Vec<f64>);

/// What the heat stage produced.
pub struct HeatResult {
    /// Per state (before, after): the discrete and continuum series.
    pub series: Vec<(State, [HeatSeries; 2])>,
    pub rows: Vec<ReservoirRow>,
    /// Temperature snapshots: (state, model, time s, grid quads, values K).
    pub snapshots: Vec<Snapshot>,
    /// Per-system timing of the heat stage: (system, calls, seconds).
    pub timing: Vec<(String, u64, f64)>,
    /// Largest relative energy-balance error of the runs.
    pub energy_balance: f64,
}

fn reservoir_error(stage: &'static str) -> impl Fn(ReservoirError) -> PipelineError {
    move |error| PipelineError::Reservoir { stage, error }
}

/// Quads of a tensor-product grid (block order i + nx j).
fn rock_quads(g: &RockGrid) -> Vec<[[f64; 2]; 4]> {
    let mut q = Vec::new();
    for j in 0..g.y.len() - 1 {
        for i in 0..g.x.len() - 1 {
            let (x0, x1, y0, y1) = (g.x[i], g.x[i + 1], g.y[j], g.y[j + 1]);
            q.push([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]);
        }
    }
    q
}

/// 4. The heat stage: per network state (apertures as chosen), the discrete model on the
///    network and the continuum model on a reservoir around the upscaled zone, `heat.years` at
///    `heat.pressure_drop`, with their systems timed; each model's wall time in `stages`.
fn heat_stage(
    spec: &PipelineSpec,
    views: &[(State, &FlowView)],
    apertures: Option<f64>,
    permeability: &[(State, BlockPermeability)],
    domain: [f64; 4],
    stages: &mut Vec<(&'static str, f64)>,
) -> Result<HeatResult, PipelineError> {
    let heat = HeatRun::new(spec, domain);
    let timing = crate::timing::TimingLayer::default();
    let table = timing.table.clone();
    let subscriber =
        tracing_subscriber::layer::SubscriberExt::with(tracing_subscriber::registry(), timing);
    let mut series = Vec::new();
    let mut got = Collected::default();
    let (mut t_discrete, mut t_continuum) = (0.0, 0.0);
    tracing::subscriber::with_default(subscriber, || -> Result<(), PipelineError> {
        for &(state, v) in views {
            let t0 = Instant::now();
            let discrete = heat.discrete(state, v, apertures, &mut got)?;
            t_discrete += t0.elapsed().as_secs_f64();
            let t0 = Instant::now();
            let k = &permeability
                .iter()
                .find(|(s, _)| *s == state)
                .expect("both states upscaled")
                .1;
            let continuum = heat.continuum(state, k, &mut got)?;
            t_continuum += t0.elapsed().as_secs_f64();
            series.push((state, [discrete, continuum]));
        }
        Ok(())
    })?;
    stages.push(("heat (discrete)", t_discrete));
    stages.push(("heat (continuum)", t_continuum));
    let rows = series
        .iter()
        .map(|(state, m)| reservoir_row(&spec.heat, *state, m))
        .collect();
    let timing = table
        .lock()
        .expect("timing table")
        .iter()
        .map(|(k, v)| (k.to_string(), v.calls, v.total.as_secs_f64()))
        .collect();
    Ok(HeatResult {
        series,
        rows,
        snapshots: got.snapshots,
        timing,
        energy_balance: got.energy_balance,
    })
}

/// What the heat models' runs collect besides their series: the temperature snapshots and the
/// largest relative energy-balance error.
#[derive(Default)]
struct Collected {
    snapshots: Vec<Snapshot>,
    energy_balance: f64,
}

/// What both heat models share: the pipeline file, the end and snapshot times (s), the wells
/// at `heat.pressure_drop` and the stimulation's mesh box.
struct HeatRun<'a> {
    spec: &'a PipelineSpec,
    end_time: f64,
    snap_times: Vec<f64>,
    wells: [PressureWell; 2],
    domain: [f64; 4],
}

impl<'a> HeatRun<'a> {
    fn new(spec: &'a PipelineSpec, domain: [f64; 4]) -> Self {
        let h = &spec.heat;
        let snap_times: Vec<f64> = h
            .snapshot_years
            .clone()
            .unwrap_or_else(|| h.report_years.clone())
            .iter()
            .filter(|&&y| y > 0.0 && y <= h.years)
            .map(|y| y * YEAR)
            .collect();
        HeatRun {
            spec,
            end_time: h.years * YEAR,
            snap_times,
            wells: doublet_wells(&spec.production, h.pressure_drop),
            domain,
        }
    }

    /// The discrete model on network `v` (with the apertures `apertures`, else its own): the
    /// network's steady flow between the wells advects heat along it, exchanging with
    /// conduction in the rock ([`Self::rock_grid`]). Wells on fractures that do not connect
    /// produce nothing (no run: an empty series).
    fn discrete(
        &self,
        state: State,
        v: &FlowView,
        apertures: Option<f64>,
        got: &mut Collected,
    ) -> Result<HeatSeries, PipelineError> {
        let (h, p) = (&self.spec.heat, &self.spec.production);
        let net = network_of_view(v, apertures);
        if !reaches(&net, &self.wells, p.reach) {
            return Ok(HeatSeries::default());
        }
        let flow = doublet_flow(&net, &self.wells, h.props.fluid_viscosity, p.reach)
            .map_err(reservoir_error("heat (discrete)"))?;
        let q = flow.wells[1].1;
        if q.is_nan() || q >= 0.0 {
            return Ok(HeatSeries::default());
        }
        let grid = self.rock_grid()?;
        let ds = DiscreteSpec {
            grid: grid.clone(),
            props: h.props,
            initial_temperature: h.initial_temperature,
            injection_temperature: h.injection_temperature,
            end_time: self.end_time,
            time_step: h.discrete.time_step,
            output_times: self.snap_times.clone(),
        };
        let run: DiscreteRun =
            run_discrete(&ds, &flow.flow).map_err(reservoir_error("heat (discrete)"))?;
        got.energy_balance = got.energy_balance.max(run.energy_balance.relative_error);
        let quads = rock_quads(&grid);
        for s in &run.snapshots {
            got.snapshots.push((
                state,
                "discrete",
                s.time,
                quads.clone(),
                s.rock_temperature.clone(),
            ));
        }
        Ok(HeatSeries {
            times: run.times,
            production_temperature: run.production_temperature,
            thermal_power: run.thermal_power,
            cumulative_heat: run.cumulative_heat,
            rate: -q,
        })
    }

    /// The discrete model's rock grid over the stimulated block (`domain`), graded from
    /// `h_min` at the lines through the wells to `h_max`.
    fn rock_grid(&self) -> Result<RockGrid, PipelineError> {
        let (d, b) = (&self.spec.heat.discrete, self.domain);
        let lines_x: Vec<f64> = Vec::new();
        let mut lines_y: Vec<f64> = self.wells.iter().map(|w| w.position[1]).collect();
        lines_y.sort_by(f64::total_cmp);
        lines_y.dedup();
        RockGrid::graded(
            [b[0], b[2]],
            [b[1], b[3]],
            &lines_x,
            &lines_y,
            d.h_min,
            d.growth,
            d.h_max,
        )
        .map_err(reservoir_error("heat (discrete)"))
    }

    /// The continuum model: Darcy flow and heat on the reservoir of [`Self::continuum_spec`]
    /// around the upscaled zone `k`.
    fn continuum(
        &self,
        state: State,
        k: &BlockPermeability,
        got: &mut Collected,
    ) -> Result<HeatSeries, PipelineError> {
        let cs = self.continuum_spec(k)?;
        let run: ContinuumRun = run_continuum(&cs).map_err(reservoir_error("heat (continuum)"))?;
        got.energy_balance = got.energy_balance.max(run.energy_balance);
        let quads = block_quads(cs.grid.n, k.grid.dx());
        for (t, temp) in &run.snapshots {
            got.snapshots
                .push((state, "continuum", *t, quads.clone(), temp.clone()));
        }
        Ok(HeatSeries {
            rate: -run.flow.wells[1].rate,
            times: run.times,
            production_temperature: run.production_temperature,
            thermal_power: run.thermal_power,
            cumulative_heat: run.cumulative_heat,
        })
    }

    /// The continuum reservoir: `continuum.size` in blocks of the upscaling blocks, the zone's
    /// upscaled permeability at `zone_origin` ([`zone_permeability`]), matrix elsewhere; the
    /// wells at the same pressures, moved with the zone, with the fractured-block well index.
    fn continuum_spec(&self, k: &BlockPermeability) -> Result<ContinuumSpec, PipelineError> {
        let (h, p) = (&self.spec.heat, &self.spec.production);
        let c = &h.continuum;
        let (grid, off) = reservoir_grid(c, k)?;
        let well = |name: &str, position: [f64; 2], pressure: f64| Well {
            name: name.into(),
            position: well_in_zone(c, k, position),
            control: WellControl::Pressure(pressure),
            injection_temperature: h.injection_temperature,
            radius: c.well_radius,
            index: WellIndex::Fractured,
        };
        Ok(ContinuumSpec {
            grid,
            permeability: zone_permeability(c, k, &grid, off),
            props: h.props,
            initial_temperature: h.initial_temperature,
            initial_pressure: p.production_pressure,
            wells: vec![
                well(
                    "injection",
                    p.injection,
                    p.production_pressure + h.pressure_drop,
                ),
                well("production", p.production, p.production_pressure),
            ],
            edges: Default::default(),
            end_time: self.end_time,
            dt: c.dt,
            output_times: self.snap_times.clone(),
        })
    }
}

/// The continuum reservoir's grid (origin 0, `c.size` rounded to whole blocks of the zone
/// `k`) and the zone's offset in it, blocks; refused when the zone does not fit.
fn reservoir_grid(
    c: &ContinuumHeatSpec,
    k: &BlockPermeability,
) -> Result<(Grid2, [usize; 2]), PipelineError> {
    let d = k.grid.dx();
    let n = [
        (c.size[0] / d[0]).round() as usize,
        (c.size[1] / d[1]).round() as usize,
    ];
    let grid = Grid2 {
        origin: [0.0; 2],
        size: [n[0] as f64 * d[0], n[1] as f64 * d[1]],
        n,
    };
    let off = [
        (c.zone_origin[0] / d[0]).round() as usize,
        (c.zone_origin[1] / d[1]).round() as usize,
    ];
    if off[0] + k.grid.n[0] > n[0] || off[1] + k.grid.n[1] > n[1] {
        return Err(PipelineError::Invalid {
            field: "heat.continuum".into(),
            why: format!(
                "the stimulated zone ({} x {} m at zone_origin {:?}, in blocks of {} x {} m) does not fit in the reservoir of size {:?} m",
                k.grid.size[0], k.grid.size[1], c.zone_origin, d[0], d[1], c.size
            ),
        });
    }
    Ok((grid, off))
}

/// The reservoir's permeability per block: the matrix's, and the zone's upscaled diagonal
/// (`c.permeability`: flow-based or Oda) at its offset `off`.
fn zone_permeability(
    c: &ContinuumHeatSpec,
    k: &BlockPermeability,
    grid: &Grid2,
    off: [usize; 2],
) -> Vec<[f64; 2]> {
    let mut perm = vec![[k.matrix; 2]; grid.len()];
    for j in 0..k.grid.n[1] {
        for i in 0..k.grid.n[0] {
            let b = k.grid.index(i, j);
            let kb = match c.permeability {
                PermeabilityChoice::FlowBased => k.flow[b],
                PermeabilityChoice::Oda => [k.oda[b][0], k.oda[b][1]],
            };
            perm[grid.index(off[0] + i, off[1] + j)] = kb;
        }
    }
    perm
}

/// A well at `q` in the stimulated block's coordinates, moved with the zone to `zone_origin`.
/// A well on the zone's lower or left edge lies in the block beside it; it is nudged a
/// thousandth of a block inside the stimulated zone.
fn well_in_zone(c: &ContinuumHeatSpec, k: &BlockPermeability, q: [f64; 2]) -> [f64; 2] {
    let d = k.grid.dx();
    let shift = [
        c.zone_origin[0] - k.grid.origin[0],
        c.zone_origin[1] - k.grid.origin[1],
    ];
    let x = [q[0] + shift[0], q[1] + shift[1]];
    [
        x[0].clamp(
            c.zone_origin[0] + 1e-3 * d[0],
            c.zone_origin[0] + k.grid.size[0] - 1e-3 * d[0],
        ),
        x[1].clamp(
            c.zone_origin[1] + 1e-3 * d[1],
            c.zone_origin[1] + k.grid.size[1] - 1e-3 * d[1],
        ),
    ]
}

/// Quads of `n` blocks of size `d` from the origin (block order i + n[0] j).
fn block_quads(n: [usize; 2], d: [f64; 2]) -> Vec<[[f64; 2]; 4]> {
    (0..n[1])
        .flat_map(|j| (0..n[0]).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (x0, y0) = (i as f64 * d[0], j as f64 * d[1]);
            [
                [x0, y0],
                [x0 + d[0], y0],
                [x0 + d[0], y0 + d[1]],
                [x0, y0 + d[1]],
            ]
        })
        .collect()
}

/// One row of `reservoir.csv` from a state's two series: the rate, the breakthrough, the
/// production temperature and power at the report years, the heat over the run.
fn reservoir_row(h: &HeatSpec, state: State, m: &[HeatSeries; 2]) -> ReservoirRow {
    let threshold = h.initial_temperature
        - h.breakthrough_fraction * (h.initial_temperature - h.injection_temperature);
    ReservoirRow {
        state,
        years: h.report_years.clone(),
        models: [0, 1].map(|k| {
            let s = &m[k];
            ModelFigures {
                rate: s.rate,
                breakthrough: s.first_below(threshold),
                temperature: h
                    .report_years
                    .iter()
                    .map(|y| {
                        if s.times.is_empty() {
                            h.initial_temperature
                        } else {
                            s.at(&s.production_temperature, y * YEAR)
                        }
                    })
                    .collect(),
                power: h
                    .report_years
                    .iter()
                    .map(|y| s.at(&s.thermal_power, y * YEAR))
                    .collect(),
                heat: s.cumulative_heat.last().copied().unwrap_or(0.0),
            }
        }),
    }
}

/// A number for a CSV cell: finite values as they are; a missing breakthrough as `none`.
fn cell(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:e}"),
        _ => "none".into(),
    }
}

/// The heat stage's outputs: `reservoir.csv`, the time series `heat_{model}_{state}.csv`, the
/// plots `heat_temperature.png` and `heat_power.png`, and the rock temperature fields
/// (`temperature_{model}_{state}.pvd` and frames, `temperature_{model}_{state}_{N}y.png`).
fn write_heat(
    folder: &Folder,
    spec: &PipelineSpec,
    heat: &HeatResult,
) -> Result<(), PipelineError> {
    write_reservoir_csv(folder, spec, &heat.rows)?;
    write_heat_series(folder, &heat.series)?;
    heat_plots(folder, spec, &heat.series)?;
    write_temperature_frames(folder, &heat.snapshots)?;
    temperature_maps(folder, spec, &heat.snapshots)
}

/// A plot that could not be drawn, as an output error.
fn plot_err(e: crate::plot::PlotError) -> PipelineError {
    PipelineError::Output(std::io::Error::other(e.to_string()))
}

/// `reservoir.csv`: one row per state; per model the rate, the breakthrough (years), the
/// production temperature and power at the report years, the heat over the run.
fn write_reservoir_csv(
    folder: &Folder,
    spec: &PipelineSpec,
    rows: &[ReservoirRow],
) -> Result<(), PipelineError> {
    let io = PipelineError::Output;
    let mut head = String::from("state");
    for m in MODELS {
        head += &format!(",rate_{m},breakthrough_years_{m}");
        for y in &spec.heat.report_years {
            head += &format!(",t_prod_{y}y_{m}");
        }
        for y in &spec.heat.report_years {
            head += &format!(",power_{y}y_{m}");
        }
        head += &format!(",heat_total_{m}");
    }
    let mut s = head + "\n";
    for r in rows {
        s += r.state.name();
        for f in &r.models {
            s += &format!(",{:e},{}", f.rate, cell(f.breakthrough.map(|t| t / YEAR)));
            for t in &f.temperature {
                s += &format!(",{t}");
            }
            for p in &f.power {
                s += &format!(",{p:e}");
            }
            s += &format!(",{:e}", f.heat);
        }
        s += "\n";
    }
    crate::output::write_atomic(&folder.claim("reservoir.csv").map_err(io)?, s.as_bytes())
        .map_err(io)
}

/// `heat_{model}_{state}.csv`: each model's time series per state.
fn write_heat_series(
    folder: &Folder,
    series: &[(State, [HeatSeries; 2])],
) -> Result<(), PipelineError> {
    let io = PipelineError::Output;
    for (state, m) in series {
        for (name, sr) in MODELS.iter().zip(m) {
            let mut s = String::from(
                "time_s,time_years,production_temperature,thermal_power,cumulative_heat\n",
            );
            for k in 0..sr.times.len() {
                s += &format!(
                    "{},{},{},{:e},{:e}\n",
                    sr.times[k],
                    sr.times[k] / YEAR,
                    sr.production_temperature[k],
                    sr.thermal_power[k],
                    sr.cumulative_heat[k]
                );
            }
            let path = folder
                .claim(&format!("heat_{name}_{}.csv", state.name()))
                .map_err(io)?;
            crate::output::write_atomic(&path, s.as_bytes()).map_err(io)?;
        }
    }
    Ok(())
}

/// Production temperature and power against time, both models and both states on one plot
/// each (`heat_temperature.png`, `heat_power.png`). Log-log: the short-circuit of a single
/// fracture happens in hours, the decline of a network over years. Non-positive values (a
/// state that produces nothing) are left out.
fn heat_plots(
    folder: &Folder,
    spec: &PipelineSpec,
    series: &[(State, [HeatSeries; 2])],
) -> Result<(), PipelineError> {
    let t_inj = spec.heat.injection_temperature;
    for (file, what, unit, pick) in [
        (
            "heat_temperature.png",
            "production temperature - injection",
            "T_prod - T_inj [K]",
            0usize,
        ),
        ("heat_power.png", "thermal power", "power [W/m]", 1),
    ] {
        let mut lines = Vec::new();
        for (state, m) in series {
            for (name, sr) in MODELS.iter().zip(m) {
                let y: Vec<f64> = if pick == 0 {
                    sr.production_temperature
                        .iter()
                        .map(|t| t - t_inj)
                        .collect()
                } else {
                    sr.thermal_power.clone()
                };
                let points: Vec<(f64, f64)> = sr
                    .times
                    .iter()
                    .zip(&y)
                    .filter(|(t, v)| **t > 0.0 && **v > 0.0)
                    .map(|(t, v)| (t / YEAR, *v))
                    .collect();
                if points.is_empty() {
                    continue;
                }
                lines.push(crate::plot::Series {
                    label: format!("{name}, {}", state.name()),
                    points,
                });
            }
        }
        crate::plot::loglog(
            &folder.claim(file).map_err(PipelineError::Output)?,
            &format!("{}: {what}", spec.name),
            "time [years]",
            unit,
            &lines,
        )
        .map_err(plot_err)?;
    }
    Ok(())
}

/// ParaView: one collection per model and state (`temperature_{model}_{state}.pvd`), a frame
/// per snapshot (quads, cell data `temperature` in K).
fn write_temperature_frames(folder: &Folder, snapshots: &[Snapshot]) -> Result<(), PipelineError> {
    let io = PipelineError::Output;
    let mut pvds: Vec<(String, crate::output::vtk::PvdWriter)> = Vec::new();
    for (k, (state, model, t, quads, values)) in snapshots.iter().enumerate() {
        let stem = format!("temperature_{model}_{}", state.name());
        let frame = format!("{stem}_{k:03}.vtu");
        let mut points = Vec::with_capacity(4 * quads.len());
        let mut connectivity = Vec::with_capacity(4 * quads.len());
        for q in quads {
            for c in q {
                connectivity.push(points.len() as u32);
                points.push([c[0], c[1], 0.0]);
            }
        }
        let piece = crate::output::vtk::VtuPiece {
            points: &points,
            kind: crate::output::vtk::CellKind::Quad,
            connectivity: &connectivity,
            point_data: Vec::new(),
            cell_data: vec![crate::output::vtk::DataArray {
                name: "temperature",
                components: 1,
                values,
            }],
        };
        crate::output::vtk::write_vtu(&folder.claim(&frame).map_err(io)?, &piece).map_err(io)?;
        let pos = match pvds.iter().position(|(s, _)| *s == stem) {
            Some(p) => p,
            None => {
                let path = folder.claim(&format!("{stem}.pvd")).map_err(io)?;
                pvds.push((stem.clone(), crate::output::vtk::PvdWriter::new(&path)));
                pvds.len() - 1
            }
        };
        pvds[pos].1.add(*t, &frame).map_err(io)?;
    }
    Ok(())
}

/// `temperature_{model}_{state}_{N}y.png`: the rock temperature field of each snapshot.
fn temperature_maps(
    folder: &Folder,
    spec: &PipelineSpec,
    snapshots: &[Snapshot],
) -> Result<(), PipelineError> {
    for (state, model, t, quads, values) in snapshots {
        let name = format!("temperature_{model}_{}_{:.0}y.png", state.name(), t / YEAR);
        let title = format!(
            "{}: {model} model, {}, rock temperature at {:.1} years",
            spec.name,
            state.name(),
            t / YEAR
        );
        crate::plot::fracture_map(
            &folder.claim(&name).map_err(PipelineError::Output)?,
            &title,
            &[],
            quads,
            values,
            "temperature [K]",
            None,
            &[],
        )
        .map_err(plot_err)?;
    }
    Ok(())
}
