//! The doublet: the steady flow through a rigid fracture network between wells held at
//! pressures (an injection and a production well): the flow field the discrete heat model
//! advects heat with, and the production rate of a network state (the reservoir pipeline's
//! doublet stage). SI: m, Pa, Pa s, m^2/s per metre of thickness.
//!
//! The network is discretised as the engine's flow is (`crate::flow`): one pressure per cell,
//! every two cells meeting at a node exchange kappa_ij (p_i - p_j) with the two-half-cell
//! transmissibility kappa_ij = 1 / (6 mu (L_i/a_i^3 + L_j/a_j^3)), and a well at a node feeds
//! each cell at that node through its half cell, a^3 / (6 mu L).

use super::{NetworkFlow, ReservoirError};
use crate::flow::steady::{SteadyProblem, SteadySolver};
use crate::flow::{half_cell_kappa, pair_kappa};

/// A well held at a pressure, connected to the network node nearest its position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PressureWell {
    /// Position, m.
    pub position: [f64; 2],
    /// Bottom-hole pressure, Pa.
    pub pressure: f64,
}

/// The doublet of `spec` at pressure drop `dp` (Pa): the injection well at
/// `production_pressure + dp`, the production well at `production_pressure`.
pub fn doublet_wells(spec: &crate::scenario::ProductionSpec, dp: f64) -> [PressureWell; 2] {
    [
        PressureWell {
            position: spec.injection,
            pressure: spec.production_pressure + dp,
        },
        PressureWell {
            position: spec.production,
            pressure: spec.production_pressure,
        },
    ]
}

/// The steady flow of a network between pressure wells (a doublet).
#[derive(Clone, Debug, PartialEq)]
pub struct DoubletFlow {
    /// The network with its fluxes and well exchanges filled in.
    pub flow: NetworkFlow,
    /// Per well: the node it is connected to and the rate into the network, m^2/s (> 0
    /// injection).
    pub wells: Vec<(u32, f64)>,
    /// Cell pressures, Pa.
    pub pressure: Vec<f64>,
}

/// A discretised network's geometry and apertures, with no flow yet.
pub fn network_of(cells: &crate::network::CellNetwork) -> NetworkFlow {
    NetworkFlow {
        nodes: cells.nodes.clone(),
        cells: cells
            .cells
            .iter()
            .map(|&(a, b, ap, _)| (a, b, ap))
            .collect(),
        fluxes: Vec::new(),
        boundary: Vec::new(),
    }
}

/// The network node nearest `p` (lowest index on ties) and its distance, m.
pub fn nearest_node(net: &NetworkFlow, p: [f64; 2]) -> Option<(u32, f64)> {
    let mut best: Option<(f64, u32)> = None;
    for (k, q) in net.nodes.iter().enumerate() {
        let d = (q[0] - p[0]).hypot(q[1] - p[1]);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, k as u32));
        }
    }
    best.map(|(d, k)| (k, d))
}

/// Steady flow of `net` (geometry and apertures; its fluxes are ignored) between `wells`. Each
/// well connects to the nearest network node, which must lie within `reach` (m) of it.
/// Cells no well reaches carry no flow.
pub fn doublet_flow(
    net: &NetworkFlow,
    wells: &[PressureWell],
    viscosity: f64,
    reach: f64,
) -> Result<DoubletFlow, ReservoirError> {
    if !(viscosity.is_finite() && viscosity > 0.0) {
        return Err(ReservoirError::invalid(
            "viscosity",
            format!("{viscosity} Pa s is not finite and positive"),
        ));
    }
    if wells.len() < 2 {
        return Err(ReservoirError::invalid(
            "wells",
            "a production needs at least two wells",
        ));
    }
    for (c, &(a, b, ap)) in net.cells.iter().enumerate() {
        if !(ap.is_finite() && ap > 0.0) {
            return Err(ReservoirError::invalid(
                &format!("cells[{c}].aperture"),
                format!("{ap} m is not finite and positive"),
            ));
        }
        if a as usize >= net.nodes.len() || b as usize >= net.nodes.len() {
            return Err(ReservoirError::invalid(
                &format!("cells[{c}]"),
                "node index out of range",
            ));
        }
        if net.cell_length(c) <= 0.0 {
            return Err(ReservoirError::invalid(
                &format!("cells[{c}]"),
                "zero length",
            ));
        }
    }
    let nn = net.nodes.len();
    // Node -> cells, CSR.
    let mut start = vec![0usize; nn + 1];
    for &(a, b, _) in &net.cells {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for k in 0..nn {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut at = vec![0u32; start[nn]];
    for (c, &(a, b, _)) in net.cells.iter().enumerate() {
        for n in [a, b] {
            at[fill[n as usize]] = c as u32;
            fill[n as usize] += 1;
        }
    }
    let len: Vec<f64> = (0..net.cells.len()).map(|c| net.cell_length(c)).collect();
    let ap = |c: u32| net.cells[c as usize].2;
    let mut pairs = Vec::new();
    for n in 0..nn {
        let cs = &at[start[n]..start[n + 1]];
        for (x, &i) in cs.iter().enumerate() {
            for &j in &cs[x + 1..] {
                let k = pair_kappa(len[i as usize], ap(i), len[j as usize], ap(j), viscosity);
                pairs.push((i.min(j), i.max(j), k));
            }
        }
    }
    let mut dirichlet = Vec::new();
    let mut well_node = Vec::with_capacity(wells.len());
    for (w, well) in wells.iter().enumerate() {
        if !(well.pressure.is_finite() && well.position.iter().all(|x| x.is_finite())) {
            return Err(ReservoirError::invalid(
                &format!("wells[{w}]"),
                "position and pressure must be finite",
            ));
        }
        let Some((node, d)) = nearest_node(net, well.position) else {
            return Err(ReservoirError::invalid("wells", "the network has no nodes"));
        };
        if d > reach {
            return Err(ReservoirError::invalid(
                &format!("wells[{w}].position"),
                format!(
                    "({}, {}) m is {d:.3} m from the nearest fracture node, more than {reach} m",
                    well.position[0], well.position[1]
                ),
            ));
        }
        if well_node.contains(&node) {
            return Err(ReservoirError::invalid(
                &format!("wells[{w}].position"),
                format!("connects to node {node}, as an earlier well does"),
            ));
        }
        well_node.push(node);
        for &c in &at[start[node as usize]..start[node as usize + 1]] {
            dirichlet.push((
                c,
                half_cell_kappa(len[c as usize], ap(c), viscosity),
                well.pressure,
            ));
        }
    }
    let sol = SteadySolver::new()
        .solve(&SteadyProblem {
            n_cells: net.cells.len(),
            pairs: &pairs,
            dirichlet: &dirichlet,
            sources: &[],
        })
        .map_err(|e| ReservoirError::Solve {
            what: "steady production".into(),
            why: e.to_string(),
        })?;
    let p = &sol.pressure;
    let mut flow = NetworkFlow {
        nodes: net.nodes.clone(),
        cells: net.cells.clone(),
        fluxes: Vec::with_capacity(pairs.len()),
        boundary: Vec::new(),
    };
    for &(i, j, k) in &pairs {
        let q = k * (p[i as usize] - p[j as usize]);
        if q >= 0.0 {
            flow.fluxes.push((i, j, q));
        } else {
            flow.fluxes.push((j, i, -q));
        }
    }
    let mut rates = vec![0.0; wells.len()];
    let mut d = 0;
    for (w, &node) in well_node.iter().enumerate() {
        for &c in &at[start[node as usize]..start[node as usize + 1]] {
            let q = sol.dirichlet_flow[d];
            d += 1;
            flow.boundary.push((c, q));
            rates[w] += q;
        }
    }
    Ok(DoubletFlow {
        flow,
        wells: well_node.into_iter().zip(rates).collect(),
        pressure: sol.pressure,
    })
}

/// Every well has a fracture node within `reach` (m).
pub fn reaches(net: &NetworkFlow, wells: &[PressureWell], reach: f64) -> bool {
    wells
        .iter()
        .all(|w| nearest_node(net, w.position).is_some_and(|(_, d)| d <= reach))
}

/// The network of a flow view: reference node positions and the cells' hydraulic apertures
/// (`residual`: every cell at that aperture instead).
pub fn network_of_view(v: &crate::flow::FlowView, residual: Option<f64>) -> NetworkFlow {
    NetworkFlow {
        nodes: v.node_ref.clone(),
        cells: v
            .cell_nodes
            .iter()
            .zip(&v.aperture)
            .map(|(n, &a)| (n[0], n[1], residual.unwrap_or(a)))
            .collect(),
        fluxes: Vec::new(),
        boundary: Vec::new(),
    }
}

/// Cell throughput of a network flow: half the summed |flux| of its pairs plus its exchange
/// with the wells, m^2/s.
pub fn cell_throughput(net: &NetworkFlow) -> Vec<f64> {
    let mut t = vec![0.0; net.cells.len()];
    for &(i, j, q) in &net.fluxes {
        t[i as usize] += 0.5 * q.abs();
        t[j as usize] += 0.5 * q.abs();
    }
    for &(c, q) in &net.boundary {
        t[c as usize] += 0.5 * q.abs();
    }
    t
}

/// The seed's Fig. 10: the network at `path` (PNG) coloured by each cell's throughput
/// ([`cell_throughput`], log scale; cells without flow grey), with labelled `markers` (wells).
pub fn flow_map(
    path: &std::path::Path,
    title: &str,
    net: &NetworkFlow,
    markers: &[([f64; 2], &str)],
) -> Result<(), crate::plot::PlotError> {
    let segments: Vec<crate::plot::Segment> = net
        .cells
        .iter()
        .map(|&(a, b, _)| crate::plot::Segment {
            a: net.nodes[a as usize],
            b: net.nodes[b as usize],
        })
        .collect();
    crate::plot::network(
        path,
        title,
        &segments,
        &cell_throughput(net),
        "flow rate [m^2/s]",
        crate::plot::ColourScale::Log,
        None,
        markers,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight fracture of n equal cells between two wells at its ends carries the cubic
    /// law's rate a^3 dp / (12 mu L) (each end's half cell plus n - 1 pair links make n cell
    /// resistances), and the fluxes balance in every cell.
    #[test]
    fn a_straight_fracture_follows_the_cubic_law() {
        let (n, l, a, mu, dp) = (10, 30.0, 2e-4, 1e-3, 3e6);
        let mut net = NetworkFlow::default();
        for k in 0..=n {
            net.nodes.push([l * k as f64 / n as f64, 1.0]);
        }
        for k in 0..n as u32 {
            net.cells.push((k, k + 1, a));
        }
        let wells = [
            PressureWell {
                position: [0.0, 1.2],
                pressure: dp,
            },
            PressureWell {
                position: [l, 1.0],
                pressure: 0.0,
            },
        ];
        let prod = doublet_flow(&net, &wells, mu, 0.5).unwrap();
        let exact = a.powi(3) * dp / (12.0 * mu * l);
        assert!((prod.wells[0].1 - exact).abs() < 1e-10 * exact);
        assert!((prod.wells[1].1 + exact).abs() < 1e-10 * exact);
        assert!(prod.flow.mass_imbalance() < 1e-10);
        let far = [PressureWell {
            position: [0.0, 5.0],
            pressure: 0.0,
        }; 2];
        assert!(doublet_flow(&net, &far, mu, 0.5).is_err());
    }
}
