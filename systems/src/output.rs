//! `output`: ParaView frames and `timeseries.csv` rows at the scenario's intervals, and the
//! fracture-pressure figures at `output.figure_times`. Frames of scenes with joints need the
//! joints' state in the components: the sync for them only writes the components
//! ([`crate::sync`]), so a run with frames takes the same steps, to the bit, as one
//! without.

use crate::RunError;
use crate::flow::FlowPart;
use crate::fracture::FractureState;
use crate::monitor::Clock;
use crate::state::SolidPart;
use crate::sync;
use hydrofrac_core::flow::FlowView;
use hydrofrac_core::model::Model;
use hydrofrac_core::output::Outputs;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::view::SolidView;
use std::path::Path;

/// Everything the output system reads.
pub struct Scene<'a> {
    pub solid: &'a SolidPart,
    pub clock: &'a Clock,
    pub fracture: &'a FractureState,
    pub params: &'a RunParams,
}

/// `output` after the step that started at `t0`: a frame and/or a series row when due, and a
/// fracture-pressure figure for every `figure_times` entry the step passed. Returns whether a
/// frame was written (the caller then clears the joints' slid-since-last-frame flags).
pub fn output(
    model: &mut Model,
    flow: Option<&mut FlowPart>,
    scene: &Scene,
    out: &mut Outputs,
    t0: f64,
) -> Result<bool, RunError> {
    let (clock, p) = (scene.clock, scene.params);
    let every = p.output.frame_every;
    let frame = clock.finish.is_some() || (every > 0 && clock.step.is_multiple_of(every));
    let row = clock.finish.is_some() || clock.step.is_multiple_of(p.output.series_every);
    let mut flow = flow;
    if frame || row {
        write(model, flow.as_deref_mut(), scene, out, frame, row)?;
    }
    if let Some(&tf) = p
        .output
        .figure_times
        .iter()
        .find(|&&tf| tf > t0 && tf <= clock.time)
        && flow.as_ref().is_some_and(|f| f.coupling.is_some())
    {
        // Listed in the manifest before it is drawn (only coupled runs draw it).
        let name = format!("fractures_pressure_t{tf}s.png");
        out.claim(&name)?;
        fracture_pressure_figure(
            model,
            &scene.solid.view,
            flow,
            p,
            &out.dir,
            &name,
            clock.time,
        );
    }
    Ok(frame)
}

/// Write a frame (solid, network) and/or a series row now.
pub fn write(
    model: &mut Model,
    flow: Option<&mut FlowPart>,
    scene: &Scene,
    out: &mut Outputs,
    frame: bool,
    row: bool,
) -> Result<(), RunError> {
    let (solid, p, time) = (&scene.solid.view, scene.params, scene.clock.time);
    if row {
        out.write_series(&series_values(scene, flow.as_deref()))?;
    }
    if !frame {
        return Ok(());
    }
    if solid.n_elems() > 0 {
        out.write_frame(solid, &p.solid, p.material.poisson, time)?;
    }
    match flow {
        Some(f) => {
            if !solid.joint_entity.is_empty() {
                // Joint stresses, sliding flags and positions for the frame (coupled runs).
                sync::write_back(model, solid, Some(f), p);
                f.view.attach_joints(model);
                f.view.refresh_positions(model);
            }
            out.write_network_frame(&f.view, time)?;
        }
        None if !solid.joint_entity.is_empty() => {
            sync::write_back(model, solid, None, p);
            if let Some(v) = fracture_view(model, solid, None, p) {
                out.write_network_frame(&v, time)?;
            }
        }
        None => {}
    }
    Ok(())
}

/// The rock's fractures (cells made by splitting) as a network view for output, when the
/// scene has joints but no flow network of its own (state as of the last sync).
pub fn fracture_view(
    model: &Model,
    solid: &SolidView,
    flow: Option<&FlowPart>,
    p: &RunParams,
) -> Option<FlowView> {
    if flow.is_some() || solid.joint_entity.is_empty() {
        return None;
    }
    let mut v = FlowView::build(model, &p.fluid);
    v.attach_joints(model);
    Some(v)
}

/// Coupled runs: write the figure of the seed's Fig. 7 (`docs/seed-method.md`, Example I: the
/// mesh, fractures with apertures magnified 20x, coloured by pressure) as `name` in `dir`. A
/// figure that cannot be drawn is a warning, not a failed run.
pub fn fracture_pressure_figure(
    model: &mut Model,
    solid: &SolidView,
    flow: Option<&mut FlowPart>,
    p: &RunParams,
    dir: &Path,
    name: &str,
    time: f64,
) {
    let Some(f) = flow.filter(|f| f.coupling.is_some()) else {
        return;
    };
    sync::write_back(model, solid, Some(f), p);
    f.view.refresh_positions(model);
    let title = format!("{}: fluid pressure, apertures x20, t = {time:.4} s", p.name);
    if let Err(e) = hydrofrac_core::output::plots::fracture_pressure_figure(
        &dir.join(name),
        &title,
        solid,
        &f.view,
        20.0,
        None,
    ) {
        tracing::warn!("figure {name} not written: {e}");
    }
}

/// Total reference length of the joints whose faces are apart (delta_n > 0), m, and the
/// largest opening delta_n, m (0 without joints).
pub fn opened_length(v: &SolidView) -> (f64, f64) {
    let mut length = 0.0;
    let mut max_opening = 0.0f64;
    for (k, st) in v.joint_state.iter().enumerate() {
        if st.opening > 0.0 {
            length += hydrofrac_core::view::joint_len0(v, k);
        }
        max_opening = max_opening.max(st.opening);
    }
    (length, max_opening)
}

/// Opening delta_n (m) of the joint under the first cell of the first flow boundary (the well
/// of a coupled run), 0 when there is none.
pub fn well_opening(v: &SolidView, f: &FlowPart, c: &crate::coupling::Coupling) -> f64 {
    f.view
        .bcs
        .first()
        .and_then(|b| b.cells.first())
        .map(|&cell| c.cell_joint[cell as usize])
        .filter(|&k| k != u32::MAX)
        .map_or(0.0, |k| v.joint_state[k as usize].opening)
}

/// Whether the time series has the `resolves` column: quasi-static runs whose fractures can
/// grow. A row with `resolves` > 0 holds the state right after the step's splits, solved again
/// at the same time with no flow time passed (`Simulation::propagate`): the new cells are
/// still empty and closed, and the state is off the smooth history (on `kgd_toughness.ron`
/// the net well pressure is 0.6 to 2 times its neighbours'). The history to sample at fixed
/// times is the rows with `resolves` = 0 (docs/outputs.md).
fn resolves_column(p: &RunParams) -> bool {
    p.criterion.is_some()
        && p.time.solid_scheme == hydrofrac_core::scenario::SolidScheme::QuasiStatic
}

/// The rock's time-series columns (2D and 3D): kinetic and strain energy (J/m in 2D, J in
/// 3D), the static residual, the largest speed (m/s). Values: [`solid_values`].
pub const SOLID_COLUMNS: [&str; 4] = ["kinetic_energy", "strain_energy", "residual", "max_speed"];

/// The values of [`SOLID_COLUMNS`] after the step of `st`.
pub fn solid_values(st: &crate::solid::StepStats) -> [f64; 4] {
    [st.kinetic, st.strain, st.residual(), st.vmax]
}

/// Names of the time-series columns of a scene.
pub fn series_columns(solid: &SolidView, flow: Option<&FlowPart>, p: &RunParams) -> Vec<String> {
    let mut c: Vec<String> = vec!["step".into(), "time".into()];
    if solid.n_nodes() > 0 {
        for n in SOLID_COLUMNS {
            c.push(n.into());
        }
    }
    if p.has_fractures {
        c.push("fracture_ready_edges".into());
        c.push("fracture_length".into());
        c.push("max_opening".into());
    }
    if resolves_column(p) {
        c.push("resolves".into());
    }
    if flow.is_some_and(|f| f.coupling.is_some()) {
        c.push("well_opening".into());
    }
    if let Some(f) = flow {
        c.extend(flow_columns(f, p));
    }
    c
}

/// The flow's time-series columns: each boundary's pressure and rate, the volumes, the mass
/// balance and the steady residual (2D and 3D scenes).
pub fn flow_columns(f: &FlowPart, p: &RunParams) -> Vec<String> {
    let mut c = Vec::new();
    for b in &f.view.bcs {
        let name = &p.bc_names[b.index];
        c.push(format!("{name}_pressure"));
        c.push(format!("{name}_rate"));
    }
    for n in [
        "injected_volume",
        "produced_volume",
        "stored_volume",
        "mass_balance_error",
        "flow_residual",
    ] {
        c.push(n.into());
    }
    c
}

/// The values of [`flow_columns`] now.
pub fn flow_values(f: &FlowPart, p: &RunParams) -> Vec<f64> {
    let mut v = Vec::new();
    for b in &f.view.bcs {
        v.push(b.pressure);
        v.push(b.rate);
    }
    let (inj, prod, stored, err) = f.balance(&p.fluid);
    v.extend([inj, prod, stored, err, f.residual]);
    v
}

/// Values of the time-series columns now.
pub fn series_values(scene: &Scene, flow: Option<&FlowPart>) -> Vec<f64> {
    let (st, clock) = (&scene.solid.stats, scene.clock);
    let mut v = vec![clock.step as f64, clock.time];
    if scene.solid.view.n_nodes() > 0 {
        v.extend(solid_values(st));
    }
    let view = &scene.solid.view;
    if scene.params.has_fractures {
        let (length, max_opening) = opened_length(view);
        v.extend([scene.fracture.ready_edges as f64, length, max_opening]);
    }
    if resolves_column(scene.params) {
        let qs = scene.solid.quasi_static.as_ref();
        v.push(qs.map_or(0, |q| q.step_resolves) as f64);
    }
    if let Some(c) = flow.and_then(|f| f.coupling.as_ref().map(|c| (f, c))) {
        v.push(well_opening(view, c.0, c.1));
    }
    if let Some(f) = flow {
        v.extend(flow_values(f, scene.params));
    }
    v
}
