//! Fracture verification cases (`docs/verification.md` R5 and R8): `sneddon`, `friction`.

use super::{CaseResult, Row, observed_order};
use crate::scenario::{
    Boundary, Damping, End, FractureSpec, Material, MeshSpec, PreFracture, SideBc,
};
use crate::sim::{Finish, Simulation};
use crate::verify::solid_cases::scenario;
use std::time::Instant;

/// How the pressurised crack relaxes to its static state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Relax {
    /// True masses, local damping alpha = 0.8 (slow on graded meshes: the large outer elements
    /// are heavy and their modes slow).
    Local,
    /// Mass scaling (`time.mass_scaling`) and viscous damping c = k / (N dt), 1/s, with N the
    /// number of cells across the mesh and dt the step: after scaling every node has about the
    /// same mass, so the lowest mode is about (1/N) (2/dt) and c = 2/(N dt) damps it about
    /// critically (k = 2 was the fastest of k = 1, 2, 4 at a/h = 10 and 20).
    Scaled(f64),
    /// No relaxation: `time.solid_scheme: QuasiStatic`, one equilibrium solve.
    QuasiStatic,
}

/// One pressurised-crack run.
#[derive(Clone, Copy, Debug)]
pub struct CrackRun {
    /// Opened area (sum of joint opening x length), m^2 per m.
    pub area: f64,
    /// Largest joint opening, m.
    pub wmax: f64,
    pub wall_s: f64,
    /// Degrees of freedom (2 per node).
    pub unknowns: usize,
    pub steps: u64,
    /// K_I and K_II at the crack's tips (left, right), Pa sqrt(m), by the virtual crack
    /// closure technique (`systems/toughness.rs`).
    pub k1: [f64; 2],
    pub k2: [f64; 2],
}

/// Parity of the diagonal pattern of the graded mesh at the crack: the regular and graded
/// meshes alternate the quad diagonal with (i + j) mod 2, so the pattern around the crack
/// depends on how many graded cells lie to the left of and below the fine box. The two
/// patterns differ by up to 1.3 % in area at a/h = 10 (measured), so a domain-size study must
/// compare meshes of the same parity.
pub fn crack_parity(a: f64, h: f64, r: f64) -> anyhow::Result<usize> {
    mesh_parity(h, r, [-1.2 * a, -0.2 * a, 1.2 * a, 0.2 * a])
}

/// The diagonal parity at the corner of the fine box `fine` ([x0, y0, x1, y1], m) of the
/// graded mesh (growth 1.15) of fine size `h` in the square of half-width `r` (see
/// [`crack_parity`]).
pub fn mesh_parity(h: f64, r: f64, fine: [f64; 4]) -> anyhow::Result<usize> {
    let m = crate::mesh::TriMesh::graded(2.0 * r, 2.0 * r, [-r, -r], h, fine, 1.15)?;
    let row = m.nodes.iter().take_while(|x| x[1] == m.nodes[0][1]).count();
    let tol = 1e-9 * r;
    let k = m
        .nodes
        .iter()
        .position(|x| (x[0] - fine[0]).abs() < tol && (x[1] - fine[1]).abs() < tol)
        .ok_or_else(|| anyhow::anyhow!("no node at the fine box corner"))?;
    Ok((k % row + k / row) % 2)
}

/// One pre-existing straight crack from `from` to `to` (m), no criterion, under the uniform
/// face pressure `pressure` (Pa), joints with the default friction and stiffnesses.
pub fn crack_spec(from: [f64; 2], to: [f64; 2], pressure: Option<f64>) -> FractureSpec {
    let mut f = FractureSpec::joints(vec![PreFracture { from, to }], 30.0, 5e-4, None);
    f.pressure = pressure;
    f
}

/// Opened area, largest opening, wall time and unknowns of a pressurised straight crack of
/// half-length `a` (m) under pressure `p` (Pa) on a graded mesh of fine size `h` (m) in a
/// square domain of half-width `r` (m) with fixed edges, relaxed to a residual of 1e-8.
pub fn pressurised_crack(
    a: f64,
    h: f64,
    r: f64,
    p: f64,
    mat: Material,
    relax: Relax,
) -> anyhow::Result<CrackRun> {
    let mut sc = scenario(
        "sneddon",
        MeshSpec::Graded {
            width: 2.0 * r,
            height: 2.0 * r,
            origin: [-r, -r],
            h,
            fine: [-1.2 * a, -0.2 * a, 1.2 * a, 0.2 * a],
            ratio: 1.15,
        },
        mat,
        Boundary::Sides {
            left: SideBc::Fixed,
            right: SideBc::Fixed,
            bottom: SideBc::Fixed,
            top: SideBc::Fixed,
        },
        End::Static {
            tol: 1e-8,
            min_steps: 10,
        },
        match relax {
            Relax::Local | Relax::QuasiStatic => Damping::Local(0.8),
            Relax::Scaled(_) => Damping::Viscous(1.0),
        },
    );
    sc.time.mass_scaling = matches!(relax, Relax::Scaled(_));
    if relax == Relax::QuasiStatic {
        sc.time.solid_scheme = crate::scenario::SolidScheme::QuasiStatic;
    }
    sc.time.max_steps = 20_000_000;
    sc.fracture = Some(crack_spec([-a, 0.0], [a, 0.0], Some(p)));
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    if let Relax::Scaled(k) = relax {
        let across = |d: usize| {
            let mut c: Vec<f64> = sim.solid().x0.iter().map(|x| x[d]).collect();
            c.sort_by(f64::total_cmp);
            c.dedup();
            c.len() - 1
        };
        let n = across(0).max(across(1)) as f64;
        sim = sim.with_damping(Damping::Viscous(k / (n * sim.dt())))?;
    }
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "sneddon: no static state (residual {:.3e})",
        sim.residual()
    );
    let (mut area, mut wmax) = (0.0, 0.0f64);
    for j in sim
        .model()
        .world
        .query::<&crate::components::Joint>()
        .iter()
    {
        let (_, w, len) = crate::fractures::joint_opening(sim.model(), j);
        area += w * len;
        wmax = wmax.max(w);
    }
    let wall_s = t0.elapsed().as_secs_f64();
    let mut tips = sim.measure_tips().to_vec();
    anyhow::ensure!(tips.len() == 2, "sneddon: {} crack tips, not 2", tips.len());
    let x = |t: &crate::systems::toughness::TipState| sim.solid().x0[t.node as usize][0];
    tips.sort_by(|a, b| x(a).total_cmp(&x(b)));
    Ok(CrackRun {
        area,
        wmax,
        k1: [tips[0].k1, tips[1].k1],
        k2: [tips[0].k2, tips[1].k2],
        wall_s,
        unknowns: 2 * sim.solid().n_nodes(),
        steps: sim.step(),
    })
}

/// Domain effect of the fixed-edge square of half-width 20a at one mesh size: runs at
/// r1 ~ 40a and r2 ~ 80a (the first of r(1 + 0.05k) with the crack's diagonal parity, see
/// [`crack_parity`]), extrapolated to r -> infinity with the 1/r^2 law of a fixed far boundary
/// (Richardson: X_inf = X2 + (X2 - X1) / ((r2/r1)^2 - 1)). Returns (area, w_max) at r -> infinity
/// divided by those at 20a, minus 1 (positive: the finite domain stiffens the crack), and the
/// extra wall time (s). `at_20a` should come from the quasi-static scheme, as the two runs here.
pub fn domain_effect(
    a: f64,
    h: f64,
    p: f64,
    mat: Material,
    at_20a: &CrackRun,
) -> anyhow::Result<(f64, f64, f64)> {
    let parity = crack_parity(a, h, 20.0 * a)?;
    let same = |base: f64| -> anyhow::Result<f64> {
        for k in 0..20 {
            let r = base * (1.0 + 0.05 * k as f64);
            if crack_parity(a, h, r)? == parity {
                return Ok(r);
            }
        }
        anyhow::bail!("no domain near {base} m with the crack's diagonal parity")
    };
    let (r1, r2) = (same(40.0 * a)?, same(80.0 * a)?);
    // Quasi-static: the same static answers as the relaxation (to 1e-8, checked by `sneddon`)
    // in a fraction of the time on these large domains.
    let c1 = pressurised_crack(a, h, r1, p, mat, Relax::QuasiStatic)?;
    let c2 = pressurised_crack(a, h, r2, p, mat, Relax::QuasiStatic)?;
    let q = (r2 / r1).powi(2) - 1.0;
    let area_inf = c2.area + (c2.area - c1.area) / q;
    let wmax_inf = c2.wmax + (c2.wmax - c1.wmax) / q;
    Ok((
        area_inf / at_20a.area - 1.0,
        wmax_inf / at_20a.wmax - 1.0,
        c1.wall_s + c2.wall_s,
    ))
}

/// Sneddon's pressurised crack (plane strain, uniform pressure p on a crack of half-length a):
/// w(x) = (4p/E') sqrt(a^2 - x^2), opened area 2 pi p a^2 / E', w_max = 4 p a / E'. Graded mesh
/// refined around the crack, domain 40a x 40a with fixed edges, relaxed with mass scaling
/// ([`Relax::Scaled`]; the static answer is that of the true masses, `tests/sneddon.rs`).
/// Errors: relative error of the opened area and of the largest opening (at the centre; the
/// sampled maximum is the joint nearest x = 0), raw (against the infinite-medium formula) and
/// corrected for the domain: the fixed edges at 20a stiffen the crack by a factor measured at
/// each level with [`domain_effect`], and the corrected error is
/// (1 + raw) (1 + domain effect) - 1, i.e. against the formula reduced to the finite domain.
/// Rows: `area`, `area_corrected`, `max_opening`, `max_opening_corrected` (wall time: the 20a
/// run), and `domain_effect_area` (the correction, wall time: both extra runs).
/// Targets (`docs/verification.md`, sneddon): corrected area error within 5 % at a/h = 20 and 1.5 % at a/h = 80
/// (measured -3.9 % and -1.1 %); the raw error is also required within 5 % at a/h = 20 and
/// reported at 80 (measured -1.48 %, too close to 1.5 % to be a robust check);
/// observed order of the corrected area error about 1 (linear elements, crack-tip
/// singularity), required in [0.7, 1.5]; the domain effect at 20a below 1 %
/// (`docs/verification.md`, sneddon: keep the domain >= 20a or correct for it).
pub fn sneddon(quick: bool) -> anyhow::Result<CaseResult> {
    let ratios: &[f64] = if quick {
        &[10.0, 20.0]
    } else {
        &[10.0, 20.0, 40.0, 80.0]
    };
    let (a, p) = (1.0, 1e6);
    let mat = Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    };
    let e_prime = mat.young / (1.0 - mat.poisson * mat.poisson);
    let area_exact = 2.0 * std::f64::consts::PI * p * a * a / e_prime;
    let wmax_exact = 4.0 * p * a / e_prime;
    let mut res = CaseResult::default();
    for (level, &ah) in ratios.iter().enumerate() {
        let h = a / ah;
        let c = pressurised_crack(a, h, 20.0 * a, p, mat, Relax::Scaled(2.0))?;
        let q = pressurised_crack(a, h, 20.0 * a, p, mat, Relax::QuasiStatic)?;
        let (d_area, d_wmax, d_wall) = domain_effect(a, h, p, mat, &q)?;
        let area_raw = (c.area - area_exact) / area_exact;
        let wmax_raw = (c.wmax - wmax_exact) / wmax_exact;
        let area_cor = (1.0 + area_raw) * (1.0 + d_area) - 1.0;
        let wmax_cor = (1.0 + wmax_raw) * (1.0 + d_wmax) - 1.0;
        for (metric, err, wall) in [
            ("area", area_raw, c.wall_s),
            ("area_corrected", area_cor, c.wall_s),
            ("max_opening", wmax_raw, c.wall_s),
            ("max_opening_corrected", wmax_cor, c.wall_s),
            ("domain_effect_area", d_area, d_wall),
        ] {
            res.rows.push(Row {
                case: "sneddon",
                level,
                h,
                unknowns: c.unknowns,
                metric: metric.into(),
                error: err.abs(),
                wall_s: wall,
            });
        }
        // The quasi-static scheme side by side: its own errors, and its distance from the
        // explicit scheme's static answer (the same physics: within 1e-6, the explicit
        // relaxation's residual of 1e-8 times the mesh's conditioning).
        let q_area = (q.area - area_exact) / area_exact;
        let q_wmax = (q.wmax - wmax_exact) / wmax_exact;
        let schemes = (q.area - c.area).abs() / c.area;
        for (metric, err) in [
            ("area_quasi_static", q_area),
            ("max_opening_quasi_static", q_wmax),
            ("area_quasi_static_vs_explicit", schemes),
        ] {
            res.rows.push(Row {
                case: "sneddon",
                level,
                h,
                unknowns: q.unknowns,
                metric: metric.into(),
                error: err.abs(),
                wall_s: q.wall_s,
            });
        }
        res.check_max(
            format!("quasi-static vs explicit area, a/h = {ah}"),
            schemes,
            1e-6,
        );
        res.check_range(
            format!("domain effect on the area at 20a, a/h = {ah}"),
            d_area,
            0.0,
            0.01,
        );
        let target = if (ah - 20.0).abs() < 1e-9 {
            Some(0.05)
        } else if (ah - 80.0).abs() < 1e-9 {
            Some(0.015)
        } else {
            None
        };
        if let Some(t) = target {
            res.check_max(
                format!("corrected area error at a/h = {ah}"),
                area_cor.abs(),
                t,
            );
        }
        if (ah - 20.0).abs() < 1e-9 {
            res.check_max("raw area error at a/h = 20", area_raw.abs(), 0.05);
        }
    }
    let order = observed_order(&res.errors("area_corrected"));
    res.check_range("corrected area observed order", order, 0.7, 1.5);
    Ok(res)
}

/// One inclined-block run (see [`inclined_block`]).
#[derive(Clone, Copy, Debug)]
pub struct InclinedBlock {
    /// Mean rigid acceleration of the upper block along the joint over the measuring window:
    /// the change of its centre-of-mass velocity over the window's duration, m/s^2.
    pub accel: f64,
    /// g (sin psi - cos psi tan phi) when positive (the block slides), else 0, m/s^2.
    pub expected: f64,
    /// Displacement of the upper block's centre of mass along the joint from the end of the
    /// relaxation to the end of the run, m.
    pub slip: f64,
    /// Fewest and most joints sliding at one step of the measuring window, and the most sliding
    /// at any step after the relaxation (ramp, delay and window).
    pub sliding_min: usize,
    pub sliding_max: usize,
    pub sliding_ever: usize,
    pub joints: usize,
    /// Degrees of freedom (2 per node).
    pub unknowns: usize,
    /// Over the measuring window: the mean summed joint normal force over the block's normal
    /// weight M g cos psi, and the mean summed joint shear force over tan phi times the mean
    /// summed normal force (1 when every joint slides all the time).
    pub normal_ratio: f64,
    pub shear_ratio: f64,
    /// Steps and Newton iterations of the quasi-static scheme (0 with the explicit one).
    pub steps: u64,
    pub newton_iterations: u64,
    pub wall_s: f64,
}

/// Gravity g, m/s^2.
pub const G: f64 = 9.81;

/// The rock of [`inclined_block`]: 4 m x 2 m, cell size `h`, base fixed, cut along y = 1 m,
/// friction `phi_deg`, joints at [`BLOCK_JOINT_STIFFNESS`], body force `gravity` (m/s^2),
/// relaxed to a static residual of 1e-9 with local damping.
pub(super) fn block_scenario(phi_deg: f64, h: f64, gravity: [f64; 2]) -> crate::scenario::Scenario {
    let mut sc = scenario(
        "inclined_block",
        MeshSpec::Regular {
            width: 4.0,
            height: 2.0,
            h,
            origin: [0.0, 0.0],
        },
        Material {
            young: 20e9,
            poisson: 0.2,
            density: 2700.0,
        },
        Boundary::Sides {
            left: SideBc::Free,
            right: SideBc::Free,
            bottom: SideBc::Fixed,
            top: SideBc::Free,
        },
        End::Static {
            tol: 1e-9,
            min_steps: 10,
        },
        Damping::Local(0.8),
    );
    sc.gravity = Some(crate::scenario::Gravity::two(gravity));
    sc.fracture = Some(FractureSpec::joints(
        vec![PreFracture {
            from: [0.0, 1.0],
            to: [4.0, 1.0],
        }],
        phi_deg,
        5e-4,
        Some((BLOCK_JOINT_STIFFNESS, BLOCK_JOINT_STIFFNESS)),
    ));
    sc
}

/// The sticking block of [`inclined_block`] solved by the quasi-static scheme in one step,
/// with the full rotated gravity. Statics of the upper block (mass M = rho 4 m x 1 m): the
/// joints carry its weight, summed normal force M g cos psi and summed shear force
/// M g sin psi. Returns (summed normal / M g cos psi - 1, summed |shear| / M g sin psi - 1,
/// joints sliding, unknowns, wall s).
pub fn inclined_block_quasi_static(
    psi_deg: f64,
    phi_deg: f64,
    h: f64,
) -> anyhow::Result<(f64, f64, usize, usize, f64)> {
    let psi = psi_deg.to_radians();
    let mut sc = block_scenario(phi_deg, h, [G * psi.sin(), -G * psi.cos()]);
    sc.time.solid_scheme = crate::scenario::SolidScheme::QuasiStatic;
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    sim.run(|_| {})?;
    let wall = t0.elapsed().as_secs_f64();
    let v = sim.solid();
    let weight = 2700.0 * 4.0 * 1.0 * G;
    let fnorm: f64 = v.joint_state.iter().map(|s| s.normal_force).sum();
    let fshear: f64 = v.joint_state.iter().map(|s| s.shear_force).sum();
    let sliding = v.joint_state.iter().filter(|s| s.sliding).count();
    Ok((
        fnorm / (weight * psi.cos()) - 1.0,
        fshear.abs() / (weight * psi.sin()) - 1.0,
        sliding,
        2 * v.n_nodes(),
        wall,
    ))
}

/// The inclined block of [`inclined_block`] on the quasi-static rock with implicit dynamics
/// (`time.solid_scheme: QuasiStatic`, `time.inertia: BackwardEuler`): the rotated gravity
/// ramped in from rest over the first quarter of the run (`boundary_schedule`; a sudden load
/// would let the block slip before the joints carry its weight), steps of `dt` (s) for `steps`
/// steps, no damping but the scheme's own.
/// The acceleration is the change of the upper block's centre-of-mass velocity over the last
/// half of the run over its duration (backward Euler conserves momentum: M (v_{n+1} - v_n) /
/// dt is the step's net force, so vibration inside the block does not enter it). Returns the
/// result as [`InclinedBlock`] (`slip` from the start; the ratios over the last half).
pub fn inclined_block_implicit(
    psi_deg: f64,
    phi_deg: f64,
    h: f64,
    dt: f64,
    steps: u64,
) -> anyhow::Result<InclinedBlock> {
    use crate::scenario::{Inertia, SolidScheme};
    let (psi, phi) = (psi_deg.to_radians(), phi_deg.to_radians());
    let mut sc = block_scenario(phi_deg, h, [G * psi.sin(), -G * psi.cos()]);
    sc.damping = Damping::None;
    sc.time.solid_scheme = SolidScheme::QuasiStatic;
    sc.time.inertia = Inertia::BackwardEuler;
    sc.time.end = End::Time(dt * steps as f64);
    sc.time.dt = Some(dt);
    sc.boundary_schedule = vec![(0.0, 0.0), (0.25 * dt * steps as f64, 1.0)];
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let block = UpperBlock::of(&sim);
    let com = |sim: &Simulation| block.com(sim);
    let x_start = com(&sim).0;
    let mut sliding_ever = 0;
    for _ in 0..steps / 2 {
        sim.step_once()?;
        sliding_ever = sliding_ever.max(sliding(&sim));
    }
    let mut w = Window::start(&sim, com(&sim).1, x_start, sliding_ever);
    while sim.finish().is_none() {
        sim.step_once()?;
        w.record(&sim);
    }
    Ok(w.result(&sim, &block, psi, phi, t0))
}

/// Joint stiffness K_n = K_t of the inclined-block case, Pa: E/100. The rigid-block answer does
/// not depend on it. With the seed's K_n = E the block's weight presses each joint by only
/// sigma h / K_n ~ 0.3 um, less than the elastic vibration the load change excites in the block
/// (~1 um), so the contacts chatter and the mean friction drops (measured: up to +130 % error
/// in the acceleration at psi = 30, phi = 27 deg, and a block at psi = 29 < phi = 30 deg that
/// crept). E/100 makes the static closure ~30 um and the contacts stay closed.
pub const BLOCK_JOINT_STIFFNESS: f64 = 2e8;

/// A block on a joint inclined at `psi_deg` with friction angle `phi_deg` under gravity
/// (`docs/verification.md` R8). Instead of tilting the mesh, gravity is rotated:
/// g = 9.81 (sin psi, -cos psi) m/s^2 on a 4 m x 2 m rectangle (cell size `h`, m) cut by a
/// pre-existing fracture along y = 1 m across its whole width into two 4 m x 1 m blocks; the
/// lower block's base is fixed, everything else is free; E = 20 GPa, nu = 0.2,
/// rho = 2700 kg/m^3, K_n = K_t = [`BLOCK_JOINT_STIFFNESS`].
///
/// 1. Relax with the normal component only (-g cos psi along y) under local damping
///    (alpha = 0.8) to a residual of 1e-9: the joints close under the block's weight with no
///    shear load and start at rest (an undamped drop onto penalty contacts rattles).
/// 2. Switch damping off and ramp the tangential component g sin psi along x linearly over
///    0.05 s (about 20 periods of the block's lowest shear mode, ~2.5 ms, so the dynamic
///    overshoot of the shear load is ~1 %), then run 0.05 s more at the full load.
/// 3. Measure over the next 0.1 s the mean acceleration of the upper block's centre of mass,
///    (V(t_end) - V(t_start)) / 0.1 s. Central difference conserves momentum exactly, so this
///    is (gravity + summed joint forces) / mass averaged over the window: elastic vibration
///    inside the block does not enter it, only the joint forces do.
pub fn inclined_block(psi_deg: f64, phi_deg: f64, h: f64) -> anyhow::Result<InclinedBlock> {
    let (psi, phi) = (psi_deg.to_radians(), phi_deg.to_radians());
    let (ramp, delay, window) = (0.05, 0.05, 0.1);
    let sc = block_scenario(phi_deg, h, [0.0, -G * psi.cos()]);
    let t0 = Instant::now();
    let mut sim = Simulation::new(sc.validate()?, &[])?;
    let finish = sim.run(|_| {})?;
    anyhow::ensure!(
        finish == Finish::Converged,
        "inclined block: no static state under the normal load (residual {:.3e})",
        sim.residual()
    );
    // The upper block: nodes of elements whose centroid lies above the fracture.
    let block = UpperBlock::of(&sim);
    let com = |sim: &Simulation| block.com(sim);
    let base = sim.solid().load.clone();
    let gt = G * psi.sin();
    let mut sim = sim.with_damping(Damping::None)?;
    let (x_start, t_start) = (com(&sim).0, sim.time());
    let mut sliding_ever = 0;
    // Ramp, then hold: the tangential body force m_i g sin psi (the body force is lumped like
    // the mass, rho g A / 3 per element node) grows linearly to its full value.
    while sim.time() - t_start < ramp + delay {
        let f = ((sim.time() + sim.dt() - t_start) / ramp).min(1.0);
        let v = sim.solid_mut();
        for i in 0..v.load.len() {
            v.load[i][0] = base[i][0] + f * v.mass[i] * gt;
        }
        sim.step_once()?;
        sliding_ever = sliding_ever.max(sliding(&sim));
    }
    let mut w = Window::start(&sim, com(&sim).1, x_start, sliding_ever);
    while sim.time() - w.t1 < window {
        sim.step_once()?;
        w.record(&sim);
    }
    Ok(w.result(&sim, &block, psi, phi, t0))
}

/// The upper block of the inclined-block scenes: the nodes of the elements whose centroid lies
/// above the fracture (y = 1 m), and their mass, kg/m.
struct UpperBlock {
    upper: Vec<bool>,
    mass: f64,
}

impl UpperBlock {
    fn of(sim: &Simulation) -> Self {
        let v = sim.solid();
        let mut upper = vec![false; v.n_nodes()];
        for c in &v.conn {
            let yc = c.iter().map(|&a| v.x0[a as usize][1]).sum::<f64>() / 3.0;
            if yc > 1.0 {
                c.iter().for_each(|&a| upper[a as usize] = true);
            }
        }
        let mass = (0..v.n_nodes())
            .filter(|&i| upper[i])
            .map(|i| v.mass[i])
            .sum();
        UpperBlock { upper, mass }
    }

    /// Its centre of mass's displacement (m) and velocity (m/s) along the joint (x).
    fn com(&self, sim: &Simulation) -> (f64, f64) {
        let v = sim.solid();
        let (mut x, mut vel) = (0.0, 0.0);
        for i in (0..v.n_nodes()).filter(|&i| self.upper[i]) {
            x += v.mass[i] * v.u[i][0];
            vel += v.mass[i] * v.v[i][0];
        }
        (x / self.mass, vel / self.mass)
    }
}

/// Joints sliding now.
fn sliding(sim: &Simulation) -> usize {
    sim.solid().joint_state.iter().filter(|s| s.sliding).count()
}

/// The measuring window of the inclined-block runs: from its start (time `t1`, s; the block's
/// velocity `v1`, m/s) the fewest and most joints sliding at a step and the summed joint
/// forces (N/m) per step.
struct Window {
    t1: f64,
    v1: f64,
    x_start: f64,
    sliding_ever: usize,
    smin: usize,
    smax: usize,
    sum_n: f64,
    sum_t: f64,
    steps: usize,
}

impl Window {
    fn start(sim: &Simulation, v1: f64, x_start: f64, sliding_ever: usize) -> Self {
        Window {
            t1: sim.time(),
            v1,
            x_start,
            sliding_ever,
            smin: usize::MAX,
            smax: 0,
            sum_n: 0.0,
            sum_t: 0.0,
            steps: 0,
        }
    }

    fn record(&mut self, sim: &Simulation) {
        let s = sliding(sim);
        (self.smin, self.smax) = (self.smin.min(s), self.smax.max(s));
        let js = &sim.solid().joint_state;
        self.sum_n += js.iter().map(|s| s.normal_force).sum::<f64>();
        self.sum_t += js.iter().map(|s| s.shear_force).sum::<f64>();
        self.steps += 1;
    }

    /// The run's figures at the window's end (angles in radians; `t0` the run's start).
    fn result(
        self,
        sim: &Simulation,
        block: &UpperBlock,
        psi: f64,
        phi: f64,
        t0: Instant,
    ) -> InclinedBlock {
        let n = self.steps as f64;
        let (mean_n, mean_t) = (self.sum_n / n, self.sum_t / n);
        let (x_end, v2) = block.com(sim);
        let counts = sim.quasi_static_counts().unwrap_or_default();
        InclinedBlock {
            accel: (v2 - self.v1) / (sim.time() - self.t1),
            expected: (G * (psi.sin() - psi.cos() * phi.tan())).max(0.0),
            slip: x_end - self.x_start,
            sliding_min: self.smin,
            sliding_max: self.smax,
            sliding_ever: self.sliding_ever.max(self.smax),
            joints: sim.solid().joint_nodes.len(),
            unknowns: 2 * sim.solid().n_nodes(),
            normal_ratio: mean_n / (block.mass * G * psi.cos()),
            shear_ratio: mean_t.abs() / (phi.tan() * mean_n),
            steps: counts.steps,
            newton_iterations: counts.newton_iterations,
            wall_s: t0.elapsed().as_secs_f64(),
        }
    }
}

/// Frictional sliding (`docs/verification.md` R8) with [`inclined_block`] at cell sizes 0.5,
/// 0.25, 0.125 m (0.5, 0.25 with `quick`). Sliding, psi = 30 deg > phi = 20 deg: the relative
/// error of the mean acceleration against g (sin psi - cos psi tan phi) = 1.8128 m/s^2 is at
/// most 2 % at every level (the target in `docs/verification.md` R8; measured below 1e-3: the rigid-block
/// answer is exact for the discrete momentum balance once every joint slides, and what is left
/// is the ~1 % residual vibration from the ramp averaged over 40 periods). Sticking, psi = 20
/// deg < phi = 30 deg: no joint ever slides, and the block's centre of mass moves by at most
/// 1e-4 m (elastic: measured 1e-5 to 3e-5 m; a block sliding at even 1 % of the psi = 30 deg
/// acceleration, 0.018 m/s^2, would move 2e-4 m in the 0.15 s after the ramp).
pub fn friction(quick: bool) -> anyhow::Result<CaseResult> {
    let hs: &[f64] = if quick {
        &[0.5, 0.25]
    } else {
        &[0.5, 0.25, 0.125]
    };
    let mut res = CaseResult::default();
    for (level, &h) in hs.iter().enumerate() {
        let s = inclined_block(30.0, 20.0, h)?;
        let rel = (s.accel - s.expected) / s.expected;
        let k = inclined_block(20.0, 30.0, h)?;
        for (metric, err, wall) in [
            ("slide_acceleration", rel.abs(), s.wall_s),
            ("stick_displacement_m", k.slip.abs(), k.wall_s),
        ] {
            res.rows.push(Row {
                case: "friction",
                level,
                h,
                unknowns: s.unknowns,
                metric: metric.into(),
                error: err,
                wall_s: wall,
            });
        }
        res.check_max(
            format!("slide acceleration error, h = {h} m"),
            rel.abs(),
            0.02,
        );
        res.check_max(
            format!("stick: joints ever sliding, h = {h} m"),
            k.sliding_ever as f64,
            0.0,
        );
        res.check_max(
            format!("stick: block displacement (m), h = {h} m"),
            k.slip.abs(),
            1e-4,
        );
        // The quasi-static scheme side by side (sticking only: past the friction limit there
        // is no static state, and the solve says so): the joints carry the block's weight.
        // Tolerance 1e-5: the joint forces act along the joints' current normals and tangents,
        // which turn with the deforming block by O(strain) ~ 1e-6 rad (measured 2e-7 normal,
        // 1.9e-6 shear), so their sums differ from the global balance by that much.
        let (en, et, sliding, unknowns, wall) = inclined_block_quasi_static(20.0, 30.0, h)?;
        for (metric, err) in [
            ("stick_normal_force_quasi_static", en.abs()),
            ("stick_shear_force_quasi_static", et.abs()),
        ] {
            res.rows.push(Row {
                case: "friction",
                level,
                h,
                unknowns,
                metric: metric.into(),
                error: err,
                wall_s: wall,
            });
            res.check_max(format!("{metric}, h = {h} m"), err, 1e-5);
        }
        res.check_max(
            format!("quasi-static stick: joints sliding, h = {h} m"),
            sliding as f64,
            0.0,
        );
    }
    Ok(res)
}

/// `verify contact`: the block on an inclined joint (`docs/verification.md` R8b) on the
/// quasi-static rock with implicit dynamics (`time.inertia: BackwardEuler`, h = 0.25 m, the
/// run 0.1 s) at three step lengths, beside the explicit scheme at the same mesh: the sliding
/// block's acceleration error (psi = 30, phi = 20 deg) against wall time, the Newton
/// iterations per step, and a block 1 deg below the friction angle (psi = 29, phi = 30 deg)
/// that must stay put. Tolerances: 1 % on the acceleration (backward Euler conserves momentum;
/// what is left is the joints' damped contact vibration, measured below 0.1 %), 1e-4 m on the
/// sticking block's motion (elastic motion is 3e-5 m; sliding at 1 % of the psi = 30 deg
/// rate would move 2e-4 m), at most 5 Newton iterations per step on average (measured 3.7 at
/// dt = 1 ms and 4.2 at 2 ms: a step is converged when the residual is below 1e-10 and no
/// joint changed state in its last iteration, so a sliding step takes at least two; a
/// regression of the contact Newton shows here first).
pub fn contact(quick: bool) -> anyhow::Result<CaseResult> {
    const H: f64 = 0.25;
    let dts: &[f64] = if quick {
        &[2e-3, 1e-3]
    } else {
        &[2e-3, 1e-3, 5e-4]
    };
    let mut res = CaseResult::default();
    let push = |res: &mut CaseResult, level, unknowns, metric: &str, error, wall_s| {
        res.rows.push(Row {
            case: "contact",
            level,
            h: H,
            unknowns,
            metric: metric.into(),
            error,
            wall_s,
        })
    };
    for (level, &dt) in dts.iter().enumerate() {
        let steps = (0.1 / dt).round() as u64;
        let s = inclined_block_implicit(30.0, 20.0, H, dt, steps)?;
        let rel = (s.accel - s.expected) / s.expected;
        let per_step = s.newton_iterations as f64 / s.steps.max(1) as f64;
        let k = inclined_block_implicit(29.0, 30.0, H, dt, steps)?;
        let tag = format!("dt = {dt:.0e} s");
        let key = format!("dt_{dt:.0e}");
        push(
            &mut res,
            level,
            s.unknowns,
            &format!("implicit_slide_acceleration_{key}"),
            rel.abs(),
            s.wall_s,
        );
        push(
            &mut res,
            level,
            s.unknowns,
            &format!("implicit_newton_per_step_{key}"),
            per_step,
            s.wall_s,
        );
        push(
            &mut res,
            level,
            k.unknowns,
            &format!("implicit_stick_displacement_m_{key}"),
            k.slip.abs(),
            k.wall_s,
        );
        res.check_max(
            format!("implicit slide acceleration error, {tag}"),
            rel.abs(),
            0.01,
        );
        res.check_max(
            format!("implicit slide: joints sliding at the end, {tag}"),
            (s.joints - s.sliding_min) as f64,
            0.0,
        );
        res.check_max(
            format!("implicit Newton iterations per step, {tag}"),
            per_step,
            5.0,
        );
        res.check_max(
            format!("implicit stick: block displacement (m), {tag}"),
            k.slip.abs(),
            1e-4,
        );
    }
    // The stick-slip load cycle on a joint network (R8c): two step counts per cycle at a
    // tenth of the block's weight (target 1e-6), and the full weight (the joint force's
    // O(delta_t / L) couple: 1e-5).
    let cycles: &[(u64, f64, f64)] = if quick {
        &[(20, 0.1, 1e-6), (20, 1.0, 1e-5)]
    } else {
        &[(20, 0.1, 1e-6), (40, 0.1, 1e-6), (20, 1.0, 1e-5)]
    };
    for (level, &(steps, scale, bound)) in cycles.iter().enumerate() {
        let c = crate::verify::contact_cases::load_cycle(H, steps, scale)?;
        let per_step = c.newton_iterations as f64 / c.steps.max(1) as f64;
        let tag = format!("{steps} steps per cycle, load x {scale}");
        let key = format!("{steps}_x{scale}");
        for (metric, err) in [
            ("load_cycle_energy_imbalance", c.imbalance()),
            ("load_cycle_newton_per_step", per_step),
        ] {
            push(
                &mut res,
                level,
                c.unknowns,
                &format!("{metric}_{key}"),
                err,
                c.wall_s,
            );
        }
        res.check_max(
            format!("load cycle energy imbalance, {tag}"),
            c.imbalance(),
            bound,
        );
        res.check_max(
            format!("load cycle: most negative dissipation of a joint in a step (J/m), {tag}"),
            -c.min_joint_step,
            1e-9 * c.dissipated,
        );
        res.check_max(
            format!("load cycle: joints opened, {tag}"),
            c.opened as f64,
            0.0,
        );
        res.check_max(
            format!("load cycle Newton iterations per step, {tag}"),
            per_step,
            5.0,
        );
        for (what, n) in [
            ("steps with slip", c.slipping_steps),
            ("steps that stick again after slip", c.restick),
        ] {
            // At least one of each: the cycle passes from stick to slip and back.
            let all = (2 * steps) as f64;
            res.check_range(format!("load cycle: {what}, {tag}"), n as f64, 1.0, all);
        }
    }
    // The explicit scheme on the same mesh, side by side.
    let e = inclined_block(30.0, 20.0, H)?;
    let rel = (e.accel - e.expected) / e.expected;
    push(
        &mut res,
        dts.len(),
        e.unknowns,
        "explicit_slide_acceleration",
        rel.abs(),
        e.wall_s,
    );
    res.check_max(
        "explicit slide acceleration error".to_string(),
        rel.abs(),
        0.02,
    );
    Ok(res)
}
