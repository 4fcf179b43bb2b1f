//! A fracture network onto a grid of blocks: block permeabilities for the continuum model.
//!
//! Two estimates, side by side (`docs/upscaling.md`):
//! - **Oda's crack tensor**: k = (1 / (12 A)) sum_s b_s^3 L_s (I - n_s n_s^T) over the pieces s
//!   of fracture cell in the block (area A, aperture b, length L, unit normal n). It counts every
//!   fracture as if it were connected across the block, so it is an upper bound of the flow a
//!   block can carry.
//! - **Flow-based** (a permeameter on each block): pressures P0 + dp and P0 held on two opposite
//!   faces of the block, no flow through the other two, the network inside the block solved
//!   for its steady (Kirchhoff) flow; k = mu Q L / (W dp), with Q the flow per metre of
//!   thickness through the block, L its length along the drop and W its width across. Only the
//!   pieces connected from one face to the other carry flow.
//!
//! Both are floored at the intact rock's matrix permeability. SI: m, m^2, Pa, Pa s; per metre
//! of thickness.

use super::{Grid2, NetworkFlow, ReservoirError};
use crate::flow::steady::{SteadyProblem, SteadySolver};

/// One straight piece of a fracture cell inside one block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Block index (`Grid2::index`).
    pub block: usize,
    /// Fracture cell the piece belongs to.
    pub cell: u32,
    /// Cell parameters of the piece's ends, 0 <= s0 < s1 <= 1 from node a to node b.
    pub s: [f64; 2],
    /// Length, m.
    pub length: f64,
}

/// The pieces of every cell (of a valid network on a valid grid), cut by the grid lines: each cell's pieces in order along it, cells
/// in order. Cells or parts of cells outside the grid are left out.
pub fn pieces(grid: &Grid2, net: &NetworkFlow) -> Vec<Piece> {
    let d = grid.dx();
    let mut out = Vec::new();
    let mut cuts: Vec<f64> = Vec::new();
    for (c, &(a, b, _)) in net.cells.iter().enumerate() {
        let (pa, pb) = (net.nodes[a as usize], net.nodes[b as usize]);
        let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
        if len == 0.0 {
            continue;
        }
        cuts.clear();
        cuts.extend([0.0, 1.0]);
        for k in 0..2 {
            let (u, v) = (pa[k], pb[k]);
            if u == v {
                continue;
            }
            let (lo, hi) = (u.min(v), u.max(v));
            let first = ((lo - grid.origin[k]) / d[k]).ceil().max(0.0) as usize;
            for line in first..=grid.n[k] {
                let x = grid.origin[k] + line as f64 * d[k];
                if x > hi {
                    break;
                }
                let s = (x - u) / (v - u);
                if s > 0.0 && s < 1.0 {
                    cuts.push(s);
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|x, y| (*x - *y).abs() <= 1e-12);
        for w in cuts.windows(2) {
            let (s0, s1) = (w[0], w[1]);
            if s1 - s0 <= 1e-12 {
                continue;
            }
            let sm = 0.5 * (s0 + s1);
            let mid = [pa[0] + sm * (pb[0] - pa[0]), pa[1] + sm * (pb[1] - pa[1])];
            if let Some((i, j)) = grid.locate(mid) {
                out.push(Piece {
                    block: grid.index(i, j),
                    cell: c as u32,
                    s: [s0, s1],
                    length: (s1 - s0) * len,
                });
            }
        }
    }
    out
}

/// Oda's crack tensor per block, `[k_xx, k_yy, k_xy]` in m^2 (no matrix floor). The grid and
/// network must be valid ([`Grid2::validate`], [`NetworkFlow::validate_geometry`]; [`upscale`]
/// checks both).
pub fn oda(grid: &Grid2, net: &NetworkFlow) -> Vec<[f64; 3]> {
    let d = grid.dx();
    let area = d[0] * d[1];
    let mut k = vec![[0.0; 3]; grid.len()];
    for p in pieces(grid, net) {
        let (a, b, aperture) = net.cells[p.cell as usize];
        let (pa, pb) = (net.nodes[a as usize], net.nodes[b as usize]);
        let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
        // Unit tangent t; I - n n^T = t t^T in 2D.
        let t = [(pb[0] - pa[0]) / len, (pb[1] - pa[1]) / len];
        let w = aperture.powi(3) * p.length / (12.0 * area);
        k[p.block][0] += w * t[0] * t[0];
        k[p.block][1] += w * t[1] * t[1];
        k[p.block][2] += w * t[0] * t[1];
    }
    k
}

/// Flow-based block permeability `[k_xx, k_yy]` (m^2, no matrix floor): for each block and
/// each direction, the permeameter of the module docs. The network inside a block is solved as
/// a Kirchhoff network (each piece a conductance b^3 / (12 mu L) between its end points; pieces
/// of different cells join where they share a network node). A block without connected pieces
/// gets 0.
pub fn flow_based(
    grid: &Grid2,
    net: &NetworkFlow,
    viscosity: f64,
) -> Result<Vec<[f64; 2]>, ReservoirError> {
    if !(viscosity.is_finite() && viscosity > 0.0) {
        return Err(ReservoirError::invalid(
            "viscosity",
            format!("{viscosity} Pa s is not finite and positive"),
        ));
    }
    grid.validate("grid")?;
    net.validate_geometry()?;
    let all = pieces(grid, net);
    let mut by_block: Vec<Vec<usize>> = vec![Vec::new(); grid.len()];
    for (k, p) in all.iter().enumerate() {
        by_block[p.block].push(k);
    }
    let mut solver = SteadySolver::new();
    let mut out = vec![[0.0; 2]; grid.len()];
    let d = grid.dx();
    for j in 0..grid.n[1] {
        for i in 0..grid.n[0] {
            let b = grid.index(i, j);
            if by_block[b].is_empty() {
                continue;
            }
            let lo = [
                grid.origin[0] + i as f64 * d[0],
                grid.origin[1] + j as f64 * d[1],
            ];
            let hi = [lo[0] + d[0], lo[1] + d[1]];
            let pcs: Vec<&Piece> = by_block[b].iter().map(|&k| &all[k]).collect();
            for dir in 0..2 {
                let q = permeameter(net, &pcs, lo, hi, dir, viscosity, &mut solver)?;
                // k = mu Q L / (W dp) with dp = 1 Pa.
                let (l, w) = if dir == 0 { (d[0], d[1]) } else { (d[1], d[0]) };
                out[b][dir] = viscosity * q * l / w;
            }
        }
    }
    Ok(out)
}

/// Flow (m^2/s) through the box `[lo, hi]` along axis `dir` under a unit pressure drop, for the
/// given pieces.
fn permeameter(
    net: &NetworkFlow,
    pieces: &[&Piece],
    lo: [f64; 2],
    hi: [f64; 2],
    dir: usize,
    viscosity: f64,
    solver: &mut SteadySolver,
) -> Result<f64, ReservoirError> {
    // End points: a network node (piece end at s = 0 or 1) or a cut point of one cell.
    #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
    enum Key {
        Node(u32),
        Cut(u32, u64),
    }
    let tol = 1e-9 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let mut keys: Vec<Key> = Vec::new();
    let mut ends: Vec<([Key; 2], f64)> = Vec::with_capacity(pieces.len());
    for p in pieces {
        let (a, b, aperture) = net.cells[p.cell as usize];
        let key = |s: f64| {
            if s <= 1e-12 {
                Key::Node(a)
            } else if s >= 1.0 - 1e-12 {
                Key::Node(b)
            } else {
                Key::Cut(p.cell, s.to_bits())
            }
        };
        let ke = [key(p.s[0]), key(p.s[1])];
        keys.extend(ke);
        ends.push((ke, aperture.powi(3) / (12.0 * viscosity * p.length)));
    }
    keys.sort();
    keys.dedup();
    let pos_of = |k: Key| -> [f64; 2] {
        match k {
            Key::Node(n) => net.nodes[n as usize],
            Key::Cut(c, bits) => {
                let s = f64::from_bits(bits);
                let (a, b, _) = net.cells[c as usize];
                let (pa, pb) = (net.nodes[a as usize], net.nodes[b as usize]);
                [pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1])]
            }
        }
    };
    // Face of each point: 1 on the inlet (pressure 1 Pa), 0 on the outlet, none inside.
    let face: Vec<Option<f64>> = keys
        .iter()
        .map(|&k| {
            let x = pos_of(k)[dir];
            if (x - lo[dir]).abs() <= tol {
                Some(1.0)
            } else if (x - hi[dir]).abs() <= tol {
                Some(0.0)
            } else {
                None
            }
        })
        .collect();
    let index = |k: Key| keys.binary_search(&k).expect("key listed");
    // Free points get consecutive unknowns.
    let mut unknown = vec![u32::MAX; keys.len()];
    let mut n = 0u32;
    for (k, f) in face.iter().enumerate() {
        if f.is_none() {
            unknown[k] = n;
            n += 1;
        }
    }
    let mut pairs = Vec::new();
    let mut dirichlet = Vec::new();
    let mut direct = 0.0;
    for (ke, c) in &ends {
        let (u, v) = (index(ke[0]), index(ke[1]));
        match (face[u], face[v]) {
            (None, None) => pairs.push((unknown[u], unknown[v], *c)),
            (None, Some(p)) => dirichlet.push((unknown[u], *c, p)),
            (Some(p), None) => dirichlet.push((unknown[v], *c, p)),
            (Some(p), Some(q)) => direct += c * (p - q),
        }
    }
    if dirichlet.is_empty() {
        return Ok(direct.abs());
    }
    let sol = solver
        .solve(&SteadyProblem {
            n_cells: n as usize,
            pairs: &pairs,
            dirichlet: &dirichlet,
            sources: &[],
        })
        .map_err(|e| ReservoirError::Solve {
            what: "flow-based upscaling".into(),
            why: e.to_string(),
        })?;
    // Flow in through the inlet face.
    let inflow: f64 = dirichlet
        .iter()
        .zip(&sol.dirichlet_flow)
        .filter(|(d, _)| d.2 == 1.0)
        .map(|(_, q)| q)
        .sum();
    Ok(inflow + direct)
}

/// Both estimates floored at the matrix permeability.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockPermeability {
    pub grid: Grid2,
    /// Oda's tensor `[k_xx, k_yy, k_xy]` plus the matrix permeability on the diagonal, m^2.
    pub oda: Vec<[f64; 3]>,
    /// Flow-based `[k_xx, k_yy]` plus the matrix permeability, m^2.
    pub flow: Vec<[f64; 2]>,
    /// Intact rock permeability, m^2.
    pub matrix: f64,
}

/// Oda and flow-based permeability of every block, each plus the matrix permeability
/// (fractures and matrix in parallel).
pub fn upscale(
    grid: &Grid2,
    net: &NetworkFlow,
    viscosity: f64,
    matrix: f64,
) -> Result<BlockPermeability, ReservoirError> {
    if !(matrix.is_finite() && matrix >= 0.0) {
        return Err(ReservoirError::invalid(
            "matrix_permeability",
            format!("{matrix} m^2 is not finite and non-negative"),
        ));
    }
    let mut flow = flow_based(grid, net, viscosity)?;
    let mut oda = oda(grid, net);
    for k in &mut oda {
        k[0] += matrix;
        k[1] += matrix;
    }
    for k in &mut flow {
        k[0] += matrix;
        k[1] += matrix;
    }
    Ok(BlockPermeability {
        grid: *grid,
        oda,
        flow,
        matrix,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `m` horizontal fractures of aperture `b` at spacing `s` across a square of side `m s`,
    /// each cut into cells of length `cell`.
    fn parallel(m: usize, s: f64, b: f64, cell: usize) -> NetworkFlow {
        let side = m as f64 * s;
        let mut net = NetworkFlow::default();
        for f in 0..m {
            let y = (f as f64 + 0.5) * s;
            let first = net.nodes.len() as u32;
            for k in 0..=cell {
                net.nodes.push([side * k as f64 / cell as f64, y]);
            }
            for k in 0..cell as u32 {
                net.cells.push((first + k, first + k + 1, b));
            }
        }
        net
    }

    /// Oda on parallel fractures: k_xx = b^3 / (12 s), k_yy = k_xy = 0, to round-off, and the
    /// flow-based permeameter gives the same k_xx (every fracture spans the block).
    #[test]
    fn parallel_fractures_give_b3_over_12s() {
        let (m, s, b) = (8, 2.5, 3e-4);
        let net = parallel(m, s, b, 7);
        let side = m as f64 * s;
        let grid = Grid2 {
            origin: [0.0; 2],
            size: [side; 2],
            n: [2, 4],
        };
        let exact = b.powi(3) / (12.0 * s);
        for k in oda(&grid, &net) {
            assert!((k[0] - exact).abs() <= 1e-12 * exact, "{} vs {exact}", k[0]);
            assert!(k[1].abs() <= 1e-12 * exact && k[2].abs() <= 1e-12 * exact);
        }
        for k in flow_based(&grid, &net, 1e-3).unwrap() {
            assert!((k[0] - exact).abs() <= 1e-9 * exact, "{} vs {exact}", k[0]);
            assert_eq!(k[1], 0.0);
        }
    }

    /// Bad grids and networks are named, not a panic.
    #[test]
    fn bad_inputs_are_named() {
        let grid = Grid2 {
            origin: [0.0; 2],
            size: [1.0; 2],
            n: [1, 1],
        };
        let mut net = NetworkFlow {
            nodes: vec![[0.0, 0.5], [1.0, 0.5]],
            cells: vec![(0, 2, 1e-3)],
            ..Default::default()
        };
        let e = upscale(&grid, &net, 1e-3, 0.0).unwrap_err().to_string();
        assert!(e.contains("cells[0]"), "{e}");
        net.cells = vec![(0, 1, f64::NAN)];
        let e = upscale(&grid, &net, 1e-3, 0.0).unwrap_err().to_string();
        assert!(e.contains("cells[0].aperture"), "{e}");
        net.cells = vec![(0, 1, 1e-3)];
        let bad = Grid2 { n: [0, 1], ..grid };
        let e = upscale(&bad, &net, 1e-3, 0.0).unwrap_err().to_string();
        assert!(e.contains("grid"), "{e}");
    }

    /// A fracture that does not reach the outlet face carries no flow; Oda still counts it.
    #[test]
    fn a_dead_end_carries_no_flow() {
        let net = NetworkFlow {
            nodes: vec![[0.0, 0.5], [0.6, 0.5]],
            cells: vec![(0, 1, 1e-3)],
            ..Default::default()
        };
        let grid = Grid2 {
            origin: [0.0; 2],
            size: [1.0; 2],
            n: [1, 1],
        };
        assert!(oda(&grid, &net)[0][0] > 0.0);
        assert_eq!(flow_based(&grid, &net, 1e-3).unwrap()[0], [0.0, 0.0]);
    }
}
