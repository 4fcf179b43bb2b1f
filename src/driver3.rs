//! `hydrofrac run` of a 3D scenario (a `Box`, `GradedBox` or `Gmsh3` mesh): the same stages as 2D
//! ([`crate::driver`]: resources, the output folder and its manifest, the timed step loop
//! with its progress bar and trace, `summary.json`), on a [`Simulation<Tet4>`]. What 3D does
//! not have yet is refused by the scenario's checks (`docs/three_d.md`). Checkpoints and
//! `--restart` work as in 2D.

use crate::dim::Tet4;
use crate::driver::{
    DriverError, RunOptions, RunReport, Stepped, check_resources, open_folder, show_progress,
    systems_json, timed_loop,
};
use crate::output::{Outputs, write_atomic};
use crate::scenario::ValidScenario;
use crate::sim::Simulation;
use serde_json::json;
use std::path::{Path, PathBuf};

/// Run a validated 3D scenario into `out`.
pub fn run_scenario_3d(
    scenario: ValidScenario,
    opts: &RunOptions,
    out: PathBuf,
) -> Result<RunReport, DriverError> {
    check_resources(&scenario, opts)?;
    let mut sim = Simulation::new_3d(scenario, &opts.disable)?;
    // Read and checked before the output folder is touched, as in 2D.
    let restarted_from = match &opts.restart {
        Some(path) => {
            let (header, state) = crate::checkpoint::read_as::<Tet4>(path)?;
            crate::checkpoint::check_scenario(path, &header, sim.scenario(), &opts.disable)?;
            sim.restore(state)
                .map_err(|why| crate::checkpoint::CheckpointError::Refused {
                    path: path.display().to_string(),
                    why,
                })?;
            Some((path.display().to_string(), header.step, header.time))
        }
        None => None,
    };
    if let Some(stop) = &opts.stop {
        sim.set_stop(stop.clone());
    }
    if let Some(armed) = &opts.exit_until_output {
        armed.store(false, std::sync::atomic::Ordering::SeqCst);
    }
    let disk = check_disk(&sim, opts, &out)?;
    let (folder, trace) = open_folder(&out, opts)?;
    let outputs = Outputs::new(
        folder,
        &sim.params().output.fields,
        &sim.series_columns_3d(),
    )
    .map_err(DriverError::Output)?;
    sim.set_output(outputs);
    let stepped = timed_loop(trace, opts.quiet, |bar| {
        let result = sim.run(|s| show_progress(bar, s.params(), s.time(), s.residual()));
        (result, sim.schedule().clone())
    });
    let mut summary = summary_3d(&sim, &stepped);
    if sim.params().output.checkpoint_every.is_some() {
        summary["checkpoints"] = json!(sim.checkpoint_stats());
    }
    if let Some((path, step, time)) = &restarted_from {
        // As in 2D: the quasi-static solve factorises again at the restart.
        let exact = sim.linear_static().is_none();
        summary["restarted_from"] =
            json!({"file": path, "step": step, "time": time, "bit_identical": exact});
    }
    summary["output_estimate_bytes"] = json!(disk);
    if let (Some(f), Some(o)) = (sim.flow(), sim.output())
        && let Err(e) =
            crate::output::plots::flow_figures(&f.view, sim.params(), sim.time(), o.folder())
    {
        summary["warnings"] = json!([format!("figures not written: {e}")]);
    }
    if let Some(o) = sim.output()
        && let Err(e) = crate::output::plots::joint_figures(
            sim.solid(),
            &sim.params().name,
            sim.time(),
            o.folder(),
        )
    {
        summary["warnings"] = json!([format!("fracture figures not written: {e}")]);
    }
    crate::output::json::finite_summary(&mut summary);
    let o = sim.output().expect("outputs set");
    let path = o.claim("summary.json").map_err(DriverError::Output)?;
    let text = serde_json::to_string_pretty(&summary).expect("json");
    write_atomic(&path, text.as_bytes()).map_err(DriverError::Output)?;
    o.folder().remove_temporaries();
    if let Err(e) = stepped.result {
        return Err(DriverError::Run {
            error: e,
            out: out.display().to_string(),
        });
    }
    let b = sim.model().bbox;
    Ok(RunReport {
        out,
        summary,
        timing_table: stepped.timing_table,
        interrupted_by: sim.interrupted_by(),
        networks: None,
        mesh_box: [b[0], b[2], b[1], b[3]],
        residual_aperture: sim.params().residual_aperture,
    })
}

/// The outputs' size against `--max-disk` (or the disk's free space), bytes.
fn check_disk(sim: &Simulation<Tet4>, opts: &RunOptions, out: &Path) -> Result<f64, DriverError> {
    crate::resources::check_output_place(out).map_err(|why| {
        DriverError::Output(std::io::Error::other(format!(
            "cannot create output folder {}: {why}",
            out.display()
        )))
    })?;
    let (limit, source) = match opts.max_disk {
        Some(b) => (b, "set by --max-disk".to_string()),
        None => crate::resources::default_disk_limit(out),
    };
    let p = sim.params();
    let end = match p.time.end {
        crate::scenario::End::Time(te) => Some(te - sim.time()),
        _ => None,
    };
    let left = p.time.max_steps.saturating_sub(sim.step());
    let (steps, steps_from) = crate::resources::planned_steps(end, sim.dt(), left);
    let plan = crate::resources::OutputPlan {
        nodes: sim.solid().n_nodes() as f64,
        // A tetrahedron writes six stress components where a triangle writes four.
        triangles: 1.5 * sim.solid().n_elems() as f64,
        // The fracture surfaces' frames: one triangle per joint.
        cells: sim.solid().joint_nodes.len() as f64,
        fields: p.output.fields.clone(),
        frame_every: p.output.frame_every,
        series_every: p.output.series_every,
        series_columns: sim.series_columns_3d().len(),
        figures: 0,
        steps,
        steps_from,
    };
    Ok(crate::resources::check_disk(&plan, limit, &source)?.total)
}

/// `summary.json` of a 3D run: its outcome, the mesh, the steps, the stress range (six
/// components, Pa, tension positive) and the systems' timing.
fn summary_3d(sim: &Simulation<Tet4>, stepped: &Stepped) -> serde_json::Value {
    let (mean, min, max) = sim.solid().stress_summary(&sim.params().solid);
    let (status, finish, error) = match &stepped.result {
        Ok(f) => ("ok", Some(*f), None),
        Err(e) => ("failed", None, Some(e.to_string())),
    };
    let stress = |s: [f64; 6]| json!({"xx": s[0], "yy": s[1], "zz": s[2], "xy": s[3], "yz": s[4], "zx": s[5]});
    let mut s = json!({
        "scenario": sim.params().name,
        "dimension": 3,
        "solid_scheme": if sim.solid().n_nodes() > 0 && sim.schedule().is_enabled(crate::systems::SystemId::Solve) { "quasi_static" } else { "explicit" },
        "status": status,
        "finish": finish,
        "elements": sim.solid().n_elems(),
        "nodes": sim.solid().n_nodes(),
        "faces": sim.model().next_edge_id,
        "steps": sim.step(),
        "time": sim.time(),
        "dt": sim.dt(),
        "dt_critical": sim.dt_crit().is_finite().then_some(sim.dt_crit()),
        "quasi_static": sim.linear_static().map(|l| json!({
            "factorisations": l.factorisations,
            "solves": l.solves,
        })),
        "wall_s": stepped.wall,
        "residual": sim.residual(),
        "kinetic_energy": sim.stats().kinetic,
        "frames": sim.output().map_or(0, |o| o.frames),
        "mesh": sim.mesh_info(),
        "fracture": fracture_3d(sim),
        "mass_scaling": crate::driver::mass_scaling_json(sim),
        "flow": crate::driver::flow_json(sim),
        "stress_mean": stress(mean),
        "stress_min": stress(min),
        "stress_max": stress(max),
        "systems": systems_json(sim.schedule(), &stepped.rows),
    });
    for key in [
        "dt_critical",
        "quasi_static",
        "fracture",
        "flow",
        "mass_scaling",
    ] {
        if s[key].is_null() {
            s.as_object_mut().expect("object").remove(key);
        }
    }
    if let Some(e) = error {
        s["error"] = json!(e);
    }
    if let Some(sig) = sim.interrupted_by() {
        s["status"] = json!("interrupted");
        s["interrupted_by"] = json!(crate::driver::signal_name(sig));
    }
    s
}

/// `summary.json` `fracture` of a 3D run with joints (null without): the joints, the node
/// copies, face p's area (m^2), the opened volume sum A0 max(delta_n, 0) (m^3), the largest
/// opening and the largest interpenetration of closed joints (m, the penalty's), and the
/// joints in contact and sliding at the end; the slip's potency sum A0 |delta_t| (m^3), its
/// area-weighted vector sum A0 delta_t (m^3, x, y, z) and the largest slip (m).
fn fracture_3d(sim: &Simulation<Tet4>) -> Option<serde_json::Value> {
    let v = sim.solid();
    if v.joint_nodes.is_empty() {
        return None;
    }
    let o = crate::model3::opening_3d(v);
    let closed = v
        .joint_state
        .iter()
        .filter(|s| s.normal_force > 0.0)
        .count();
    let sliding = v.joint_state.iter().filter(|s| s.sliding).count();
    let daughters = v
        .node_entity
        .iter()
        .filter(|&&e| {
            sim.model()
                .world
                .get::<&crate::components::NodeLink>(e)
                .is_ok_and(|l| l.mother.is_some())
        })
        .count();
    let mut out = json!({
        "joints": v.joint_nodes.len(),
        "daughters": daughters,
        "area": o.area,
        "opened_volume": o.volume,
        "max_opening": o.max,
        "max_interpenetration": if o.min < 0.0 { -o.min } else { 0.0 },
        "slip_potency": o.potency,
        "slip_vector": o.slip_vector,
        "max_slip": o.max_slip,
        "joints_closed": closed,
        "joints_sliding": sliding,
        "front": front_json(sim),
    });
    // Growth (a criterion): the faces ready at the last check, the nodes split and the faces
    // opened during the run.
    if sim.params().criterion.is_some() {
        let fr = sim.fracture();
        out["ready_faces"] = json!(fr.ready_edges);
        out["splits"] = json!(fr.splits);
        out["opened_faces"] = json!(fr.opened_edges);
        // A grown front is no longer the discs' circles: K_I at its front nodes instead
        // (`systems::toughness3d::front_sif_nodes`, the toughness criterion's estimate).
        out["front"] = json!([]);
        let nodes =
            hydrofrac_systems::toughness3d::front_sif_nodes(sim.solid(), sim.params().e_prime);
        if !nodes.is_empty() {
            let k: Vec<f64> = nodes.iter().map(|n| n.k).collect();
            let (lo, hi) = k
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            out["front_nodes"] = json!({
                "count": k.len(),
                "k_i_min": lo,
                "k_i_mean": k.iter().sum::<f64>() / k.len() as f64,
                "k_i_max": hi,
            });
        }
    }
    Some(out)
}

/// `summary.json` `fracture.front`: per disc, K_I along its front (Pa m^1/2) by displacement
/// correlation (`model3::front_sif_3d`) in stretches of about 15 degrees, fitted over the
/// node pairs 2 to 5 cells behind the front (h: the mesh's cell size, or on a Gmsh mesh
/// sqrt(2 A) with A the disc's mean face area); the fitting window, the least and largest
/// K_I, and the stretches. A disc without two distances in any stretch is left out.
fn front_json(sim: &Simulation<Tet4>) -> Vec<serde_json::Value> {
    let v = sim.solid();
    let sc = sim.scenario();
    let Some(f) = &sc.fracture else {
        return Vec::new();
    };
    let h = sc.mesh.as_ref().and_then(|m| m.h()).unwrap_or_else(|| {
        let o = crate::model3::opening_3d(v);
        (2.0 * o.area / v.joint_nodes.len().max(1) as f64).sqrt()
    });
    let e_prime = sim.params().e_prime;
    let window = [2.0 * h, 5.0 * h];
    let mut out = Vec::new();
    for (i, d) in f.discs.iter().enumerate() {
        let sif = crate::model3::front_sif_3d(v, d, e_prime, window, 15.0);
        if sif.is_empty() {
            continue;
        }
        let (lo, hi) = sif
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
                (a.min(s.k), b.max(s.k))
            });
        let stretches: Vec<serde_json::Value> = sif
            .iter()
            .map(|s| json!({"from_deg": s.from_deg, "to_deg": s.to_deg, "k_i": s.k, "pairs": s.nodes}))
            .collect();
        out.push(
            json!({"disc": i, "window": window, "k_i_min": lo, "k_i_max": hi,
                        "stretches": stretches}),
        );
    }
    out
}
