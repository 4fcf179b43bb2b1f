//! Figures written at the end of a run (PNG): the network coloured by pressure and by flow rate,
//! and the boundary pressures and rates against time.

use crate::plot::{ColourScale, Segment, Series, lines, network};
use crate::sim::Simulation;
use std::path::Path;

/// `network_pressure.png`, `network_flow.png` and `boundaries.png` for a scene with a network.
pub fn flow_figures(sim: &Simulation, dir: &Path) -> anyhow::Result<()> {
    let Some(f) = &sim.flow else { return Ok(()) };
    network_figures(sim, dir)?;
    // Boundary pressures and rates from the time series.
    let text = std::fs::read_to_string(dir.join("timeseries.csv"))?;
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap_or("").split(',').collect();
    let data: Vec<Vec<f64>> = rows
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let t = col("time").unwrap_or(1);
    let mut pressure = Vec::new();
    let mut rate = Vec::new();
    for b in &f.view.bcs {
        let name = sim.bc_name(b.index);
        if let Some(c) = col(&format!("{name}_pressure")) {
            pressure.push(Series {
                label: name.clone(),
                points: data.iter().map(|r| (r[t], r[c] / 1e6)).collect(),
            });
        }
        if let Some(c) = col(&format!("{name}_rate")) {
            rate.push(Series {
                label: name,
                points: data.iter().map(|r| (r[t], r[c])).collect(),
            });
        }
    }
    if !pressure.is_empty() {
        lines(
            &dir.join("boundary_pressure.png"),
            "Boundary pressure",
            "time [s]",
            "pressure [MPa]",
            &pressure,
        )?;
        lines(
            &dir.join("boundary_rate.png"),
            "Boundary rate into the network",
            "time [s]",
            "rate [m^2/s]",
            &rate,
        )?;
    }
    Ok(())
}

/// The network coloured by pressure (linear, MPa) and by flow rate (log, m^2/s), line width
/// growing with aperture, boundaries marked.
fn network_figures(sim: &Simulation, dir: &Path) -> anyhow::Result<()> {
    let Some(f) = &sim.flow else { return Ok(()) };
    let v = &f.view;
    let segments: Vec<Segment> = v
        .cell_nodes
        .iter()
        .map(|n| Segment {
            a: v.node_pos[n[0] as usize],
            b: v.node_pos[n[1] as usize],
        })
        .collect();
    // Width 1.5 to 6 px, growing with log aperture across the network's range.
    let (amin, amax) = v
        .aperture
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &a| {
            (lo.min(a), hi.max(a))
        });
    let widths: Vec<f64> = v
        .aperture
        .iter()
        .map(|&a| {
            let s = if amax > amin {
                (a / amin).ln() / (amax / amin).ln()
            } else {
                0.5
            };
            1.5 + 4.5 * s
        })
        .collect();
    let names: Vec<String> = v.bcs.iter().map(|b| sim.bc_name(b.index)).collect();
    let markers: Vec<([f64; 2], &str)> = v
        .bcs
        .iter()
        .zip(&names)
        .map(|(b, name)| {
            let pos = match sim.scenario.flow_boundaries[b.index].at {
                crate::scenario::FlowTarget::Node(p) | crate::scenario::FlowTarget::Cell(p) => p,
            };
            (pos, name.as_str())
        })
        .collect();
    let mpa: Vec<f64> = v.pressure.iter().map(|p| p / 1e6).collect();
    let t = sim.time;
    network(
        &dir.join("network_pressure.png"),
        &format!("{}: fluid pressure at t = {t:.4e} s", sim.scenario.name),
        &segments,
        &mpa,
        "pressure [MPa]",
        ColourScale::Linear,
        Some(&widths),
        &markers,
    )?;
    network(
        &dir.join("network_flow.png"),
        &format!("{}: flow rate at t = {t:.4e} s", sim.scenario.name),
        &segments,
        &v.flow_rate,
        "flow rate [m^2/s]",
        ColourScale::Log,
        Some(&widths),
        &markers,
    )?;
    Ok(())
}

/// `fractures.png` for a rock scene with fractures: the fracture cells drawn with line width
/// growing with the hydraulic aperture and coloured by it (mm), like the seed's Fig. 7 (which
/// magnifies apertures 20x in the mesh instead).
pub fn fracture_figure(
    sim: &Simulation,
    view: &crate::flow::FlowView,
    dir: &Path,
) -> anyhow::Result<()> {
    let segments: Vec<Segment> = view
        .cell_nodes
        .iter()
        .map(|n| Segment {
            a: view.node_pos[n[0] as usize],
            b: view.node_pos[n[1] as usize],
        })
        .collect();
    let amax = view.aperture.iter().fold(0.0f64, |a, &b| a.max(b));
    let widths: Vec<f64> = view
        .aperture
        .iter()
        .map(|&a| 1.5 + 6.0 * a / amax.max(1e-300))
        .collect();
    let mm: Vec<f64> = view.aperture.iter().map(|a| a * 1e3).collect();
    network(
        &dir.join("fractures.png"),
        &format!(
            "{}: fracture apertures at t = {:.4e} s",
            sim.scenario.name, sim.time
        ),
        &segments,
        &mm,
        "hydraulic aperture [mm]",
        ColourScale::Linear,
        Some(&widths),
        &[],
    )?;
    Ok(())
}
