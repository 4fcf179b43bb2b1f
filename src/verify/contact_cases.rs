//! The stick-slip load cycle of `verify contact` (`docs/verification.md` R8c): a small joint
//! network on the quasi-static rock loaded and unloaded twice, its energy balance and the
//! contact Newton's iterations per step.

use crate::scenario::{End, PreFracture, SolidScheme};
use crate::sim::Simulation;
use crate::verify::fracture_cases::{BLOCK_JOINT_STIFFNESS, G, block_scenario};
use crate::view::{SolidView, joint_frame};
use std::time::Instant;

/// What [`load_cycle`] measured. Energies in J/m (per unit thickness).
#[derive(Clone, Debug)]
pub struct LoadCycle {
    /// Work of the applied loads (gravity and the side push) over the cycle.
    pub work: f64,
    /// Change of the stored energy over the cycle: the rock's strain energy and the joints'
    /// normal and tangential springs.
    pub stored: f64,
    /// Energy dissipated by friction on the joints over the cycle.
    pub dissipated: f64,
    /// The smallest dissipation of one joint in one step (negative would be friction that
    /// gives energy back).
    pub min_joint_step: f64,
    /// The most joints sliding at a step, and the steps at which some joint slides.
    pub sliding_max: usize,
    pub slipping_steps: usize,
    /// Steps at which no joint slides after one at which some did (stick again).
    pub restick: usize,
    /// Joints that were open (delta_n > 0) at some step (the balance assumes none).
    pub opened: usize,
    pub joints: usize,
    pub unknowns: usize,
    pub steps: u64,
    pub newton_iterations: u64,
    pub wall_s: f64,
}

impl LoadCycle {
    /// |work - stored - dissipated| over the work of the side push's cycle (the dissipated
    /// energy is a fraction of it).
    pub fn imbalance(&self) -> f64 {
        (self.work - self.stored - self.dissipated).abs() / self.dissipated.abs().max(1e-300)
    }
}

/// The push on the upper blocks' left side, N/m, at step `k` of `steps` per cycle: a
/// constant `f0` that keeps the vertical joint closed, plus a raised cosine to `f0 + amp`
/// and back, twice.
fn push(k: u64, steps: u64, f0: f64, amp: f64) -> f64 {
    let phase = 2.0 * std::f64::consts::PI * k as f64 / steps as f64;
    f0 + 0.5 * amp * (1.0 - phase.cos())
}

/// Stored energy of the joints (J/m): K_n delta_n^2 / 2 of closed faces plus F_t^2 / (2 K_t)
/// of the tangential spring (the elastic part of the shear offset).
fn joint_energy(v: &SolidView, k_n: f64, k_t: f64) -> f64 {
    v.joint_state
        .iter()
        .map(|s| {
            0.5 * s.normal_force * s.normal_force / k_n + 0.5 * s.shear_force * s.shear_force / k_t
        })
        .sum()
}

/// The load cycle (`docs/verification.md` R8c). The rock of the inclined-block cases
/// (4 m x 2 m, cell size `h`, base fixed, E = 20 GPa, nu = 0.2, K_n = K_t = 2e8 Pa,
/// friction 30 deg) cut along y = 1 m and, in the upper half, along x = 2 m: two blocks
/// resting on the lower one, pressed by gravity, one against the other. The quasi-static
/// rock (no inertia) carries gravity and a push on the left block's left side (a constant
/// 0.1 and a raised cosine of amplitude 0.45 times the upper blocks' friction capacity
/// mu M g, spread over the side's nodes by their tributary lengths) over two cycles of
/// `steps` steps. The push tilts the blocks: the joints near the pushed side carry less
/// normal force and slip first; unloading brings them back to stick.
///
/// Energy accounting, step by step between converged states n and n+1 (trapezoid rule):
/// work W += (f_n + f_{n+1}) . (u_{n+1} - u_n) / 2 over every node's applied load f; stored
/// energy U = the rock's strain energy + the joints' springs; friction dissipation, per
/// joint, D -= (F_t,n + F_t,n+1) / 2 (delta_t,{n+1} - delta_t,n + (F_t,n+1 - F_t,n) / K_t),
/// the shear force (F_t = -K_t times the elastic part of the offset, resisting it) on the
/// slip part of the tangential offset. For linear springs and an
/// exact equilibrium at every state the trapezoid rule makes W = Delta U + D exact, so the
/// balance tests the equilibrium, the forces' consistency with the energies (element,
/// normal and tangential springs, the Coulomb cap) and the sign of every joint's
/// dissipation. Left over: the Newton tolerance (1e-10 on the residual; 1e-11 gives the
/// same imbalance to 4 digits) and the joint force's frame: each face carries F_n n + F_t t
/// split equally over its two nodes, while the gradient of K_n delta_n^2 / 2 has a couple
/// -K_n delta_n delta_t b as well (`systems/src/quasi_static_lu.rs`: delta_n turns with the
/// face), so the joint force is conservative only to a relative O(delta_t / L). The
/// imbalance is therefore proportional to the load: `load_scale` multiplies gravity and the
/// push (1: the block's own weight; measured imbalance 2.7e-6 at 1 and 2.8e-7 at 0.1).
pub fn load_cycle(h: f64, steps: u64, load_scale: f64) -> anyhow::Result<LoadCycle> {
    let phi = 30.0_f64;
    let mut sc = block_scenario(phi, h, [0.0, -G * load_scale]);
    if let Some(f) = sc.fracture.as_mut() {
        f.preexisting.push(PreFracture {
            from: [2.0, 1.0],
            to: [2.0, 2.0],
        });
    }
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    sc.time.dt = Some(1.0);
    sc.time.end = End::Time(2.0 * steps as f64);
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let (k_n, k_t) = (BLOCK_JOINT_STIFFNESS, BLOCK_JOINT_STIFFNESS);
    let v = sim.solid();
    let gravity = v.load.clone();
    // The left block's left side: nodes at x = 0 above the cut, weighted by tributary length.
    let mut side: Vec<(usize, f64)> = (0..v.n_nodes())
        .filter(|&i| v.x0[i][0] == 0.0 && v.x0[i][1] >= 1.0)
        .filter(|&i| upper_node(v, i))
        .map(|i| (i, v.x0[i][1]))
        .collect();
    side.sort_by(|a, b| a.1.total_cmp(&b.1));
    let ys: Vec<f64> = side.iter().map(|s| s.1).collect();
    let weights: Vec<(usize, f64)> = side
        .iter()
        .enumerate()
        .map(|(k, &(i, y))| {
            let lo = if k == 0 { y } else { 0.5 * (y + ys[k - 1]) };
            let hi = if k + 1 == ys.len() {
                y
            } else {
                0.5 * (y + ys[k + 1])
            };
            (i, hi - lo)
        })
        .collect();
    let length: f64 = weights.iter().map(|w| w.1).sum();
    anyhow::ensure!(
        (length - 1.0).abs() < 1e-12,
        "load cycle: the pushed side is {length} m long, not 1 m"
    );
    let capacity = phi.to_radians().tan() * 2700.0 * 4.0 * 1.0 * G * load_scale;
    let (f0, amp) = (0.1 * capacity, 0.45 * capacity);
    let apply = |sim: &mut Simulation, k: u64| {
        let f = push(k, steps, f0, amp);
        let v = sim.solid_mut();
        v.load.clone_from(&gravity);
        for &(i, w) in &weights {
            v.load[i][0] += f * w;
        }
    };
    // The start: gravity and the constant push, in one static step.
    apply(&mut sim, 0);
    sim.step_once()?;
    let mut prev = State::of(&sim, k_n, k_t);
    let mut out = LoadCycle {
        work: 0.0,
        stored: 0.0,
        dissipated: 0.0,
        min_joint_step: f64::INFINITY,
        sliding_max: 0,
        slipping_steps: 0,
        restick: 0,
        opened: 0,
        joints: sim.solid().joint_nodes.len(),
        unknowns: 2 * sim.solid().n_nodes(),
        steps: 0,
        newton_iterations: 0,
        wall_s: 0.0,
    };
    let counts0 = sim.quasi_static_counts().unwrap_or_default();
    let mut opened = vec![false; out.joints];
    let stored0 = prev.stored;
    let mut slid_before = false;
    for k in 1..=2 * steps {
        apply(&mut sim, k);
        sim.step_once()?;
        let next = State::of(&sim, k_n, k_t);
        let v = sim.solid();
        for (i, (a, b)) in prev.u.iter().zip(&next.u).enumerate() {
            for d in 0..2 {
                out.work += 0.5 * (prev.load[i][d] + next.load[i][d]) * (b[d] - a[d]);
            }
        }
        let mut sliding = 0;
        for (j, s) in v.joint_state.iter().enumerate() {
            let (fa, fb) = (prev.shear[j], s.shear_force);
            // F_t = -K_t (delta_t - slip): the shear force resists the faces' tangential
            // offset; what the spring does not take is slip.
            let slip = next.offset[j] - prev.offset[j] + (fb - fa) / k_t;
            let d = -0.5 * (fa + fb) * slip;
            out.dissipated += d;
            out.min_joint_step = out.min_joint_step.min(d);
            opened[j] |= s.opening > 0.0;
            sliding += s.sliding as usize;
        }
        out.sliding_max = out.sliding_max.max(sliding);
        if sliding > 0 {
            out.slipping_steps += 1;
        } else if slid_before {
            out.restick += 1;
        }
        slid_before = sliding > 0;
        prev = next;
    }
    out.stored = prev.stored - stored0;
    out.opened = opened.iter().filter(|&&o| o).count();
    let counts = sim.quasi_static_counts().unwrap_or_default();
    out.steps = counts.steps - counts0.steps;
    out.newton_iterations = counts.newton_iterations - counts0.newton_iterations;
    out.wall_s = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Whether node `i` belongs to an element above the cut at y = 1 m.
fn upper_node(v: &SolidView, i: usize) -> bool {
    v.conn.iter().any(|c| {
        c.contains(&(i as u32)) && c.iter().map(|&a| v.x0[a as usize][1]).sum::<f64>() > 3.0
    })
}

/// A converged state of the load cycle: displacements, applied loads, each joint's shear
/// force and tangential offset, the stored energy.
struct State {
    u: Vec<[f64; 2]>,
    load: Vec<[f64; 2]>,
    shear: Vec<f64>,
    offset: Vec<f64>,
    stored: f64,
}

impl State {
    fn of(sim: &Simulation, k_n: f64, k_t: f64) -> State {
        let v = sim.solid();
        let lf = sim.clock().load_factor;
        State {
            u: v.u.clone(),
            load: v.load.iter().map(|l| [lf * l[0], lf * l[1]]).collect(),
            shear: v.joint_state.iter().map(|s| s.shear_force).collect(),
            offset: (0..v.joint_nodes.len())
                .map(|j| joint_frame(v, j).dt)
                .collect(),
            stored: sim.stats().strain + joint_energy(v, k_n, k_t),
        }
    }
}
