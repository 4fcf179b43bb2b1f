//! Solid systems: internal force of plane-strain constant-strain triangles, external loads,
//! damping, and central-difference integration with prescribed displacements.
//!
//! All run on the dense [`SolidView`]. Parallel loops write only their own element or node;
//! reductions are summed over fixed-size chunks in chunk order, so results are bit-identical
//! for any number of threads.

use hydrofrac_core::dim::Element;
pub use hydrofrac_core::element::{SolidParams, cst_forces, cst_strain, cst_stress, hooke};
use hydrofrac_core::scenario::Damping;
use hydrofrac_core::view::SolidView;
use rayon::prelude::*;

/// Elements per rayon task in element loops, nodes per task / reduction chunk in node loops.
pub const ELEM_GRAIN: usize = 4096;
pub const NODE_CHUNK: usize = 4096;

/// `internal_force`: element stresses and nodal forces (CST or TET4, [`Element`]), then a
/// gather by node (no atomics). Overwrites `force` with the internal force.
///
/// On one thread the element forces go straight into the nodes, element by element: each
/// node then receives its terms in ascending element order starting from 0.0, the order of
/// the gather's sums (the incidence lists each node's elements in ascending order), so the
/// bits are the same for any thread count; it skips the element-force array's write and
/// read.
pub fn internal_force<E: Element>(v: &mut SolidView<E>, p: &SolidParams) {
    if rayon::current_num_threads() == 1 {
        let (conn, geom, u) = (&v.conn[..], &v.geom[..], &v.u[..]);
        let (stress, force) = (&mut v.stress[..], &mut v.force[..]);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { scatter_avx2::<E>(conn, geom, u, stress, force, p) };
            return;
        }
        scatter::<E>(conn, geom, u, stress, force, p);
        return;
    }
    let (conn, geom, u) = (&v.conn, &v.geom, &v.u[..]);
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    v.stress
        .par_chunks_mut(ELEM_GRAIN)
        .zip(v.elem_force.par_chunks_mut(ELEM_GRAIN))
        .zip(conn.par_chunks(ELEM_GRAIN).zip(geom.par_chunks(ELEM_GRAIN)))
        .for_each(|((s, f), (c, g))| {
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the CPU has AVX2 (checked above).
                unsafe { element_forces_avx2::<E>(c, g, u, s, f, p) };
                return;
            }
            element_forces::<E>(c, g, u, s, f, p);
        });
    let ef = &v.elem_force;
    let per = E::D * E::NODES;
    let (ptr, inc) = (&v.inc_ptr, &v.inc);
    v.force
        .par_iter_mut()
        .enumerate()
        .with_min_len(NODE_CHUNK)
        .for_each(|(i, f)| {
            let mut acc = E::Vector::default();
            for &k in &inc[ptr[i] as usize..ptr[i + 1] as usize] {
                let (e, o) = (k as usize / per, k as usize % per);
                let fe = ef[e].as_ref();
                for d in 0..E::D {
                    acc[d] += fe[o + d];
                }
            }
            *f = acc;
        });
}

/// [`element_forces`] compiled for AVX2 (as [`scatter_avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn element_forces_avx2<E: Element>(
    conn: &[E::Conn],
    geom: &[E::Geom],
    u: &[E::Vector],
    stress: &mut [E::Stress],
    forces: &mut [E::Forces],
    p: &SolidParams,
) {
    element_forces::<E>(conn, geom, u, stress, forces, p)
}

/// Element stresses and forces of a block of elements (the several-thread internal force,
/// before the gather by node).
#[inline(always)]
fn element_forces<E: Element>(
    conn: &[E::Conn],
    geom: &[E::Geom],
    u: &[E::Vector],
    stress: &mut [E::Stress],
    forces: &mut [E::Forces],
    p: &SolidParams,
) {
    for (((s, f), c), g) in stress.iter_mut().zip(forces).zip(conn).zip(geom) {
        *s = E::stress(g, c, u, p);
        *f = E::forces(g, s);
    }
}

/// [`scatter`] compiled for AVX2 (no FMA, so the same bits: every product and sum is the same
/// IEEE operation, three-operand and wider).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn scatter_avx2<E: Element>(
    conn: &[E::Conn],
    geom: &[E::Geom],
    u: &[E::Vector],
    stress: &mut [E::Stress],
    force: &mut [E::Vector],
    p: &SolidParams,
) {
    scatter::<E>(conn, geom, u, stress, force, p)
}

/// The one-thread internal force: each element's forces scattered into its nodes.
#[inline(always)]
fn scatter<E: Element>(
    conn: &[E::Conn],
    geom: &[E::Geom],
    u: &[E::Vector],
    stress: &mut [E::Stress],
    force: &mut [E::Vector],
    p: &SolidParams,
) {
    force.fill(E::Vector::default());
    for ((s, c), g) in stress.iter_mut().zip(conn).zip(geom) {
        *s = E::stress(g, c, u, p);
        let fe = E::forces(g, s);
        let fe = fe.as_ref();
        for (a, &n) in c.as_ref().iter().enumerate() {
            let f = &mut force[n as usize];
            for d in 0..E::D {
                f[d] += fe[E::D * a + d];
            }
        }
    }
}

/// Recompute element stresses from the current displacements (the stress kept by
/// `internal_force` lags the displacement by one step).
pub fn update_stress<E: Element>(v: &mut SolidView<E>, p: &SolidParams) {
    let (conn, geom, u) = (&v.conn, &v.geom, &v.u);
    v.stress
        .par_iter_mut()
        .zip(conn.par_iter().zip(geom.par_iter()))
        .with_min_len(ELEM_GRAIN)
        .for_each(|(s, (c, g))| *s = E::stress(g, c, u, p));
}

/// `external_load`: add the external loads (tractions, body forces) times the load factor.
pub fn external_load<E: Element>(v: &mut SolidView<E>, lf: f64) {
    v.force
        .par_iter_mut()
        .zip(v.load.par_iter())
        .with_min_len(NODE_CHUNK)
        .for_each(|(f, l)| {
            for d in 0..E::D {
                f[d] += lf * l[d];
            }
        });
}

/// Values below this magnitude are set to zero in the integrator (m, m/s). The numerical
/// precursor ahead of a wave front decays exponentially into subnormal numbers, which are 50-100x
/// slower to compute with; nothing physical happens at 1e-200.
pub const TINY: f64 = 1e-200;

/// `x`, or zero when |x| < [`TINY`] (branch-free select).
#[inline(always)]
pub fn flush_tiny(x: f64) -> f64 {
    if x.abs() < TINY { 0.0 } else { x }
}

/// Local damping force -alpha |f| sign(s), branch-free (the sign of a velocity is as good as
/// random from node to node, and a mispredicted branch per dof costs more than the kernel).
#[inline(always)]
pub fn local_damping(alpha: f64, f: f64, s: f64) -> f64 {
    let sign = ((s > 0.0) as u8 as f64) - ((s < 0.0) as u8 as f64);
    -alpha * f.abs() * sign
}

/// `damping`: damping force from the unbalanced force and the velocity.
/// Local (Cundall): -alpha |F| sign(v_new) per component, with v_new the undamped predictor;
/// viscous: -c m v.
pub fn damping<E: Element>(v: &mut SolidView<E>, p: &SolidParams, dt: f64) {
    let (force, vel, mass, inv_m) = (&v.force, &v.v, &v.mass, &v.inv_mass);
    match p.damping {
        Damping::None => v.f_damp.iter_mut().for_each(|f| *f = E::Vector::default()),
        Damping::Local(alpha) => v
            .f_damp
            .par_iter_mut()
            .enumerate()
            .with_min_len(NODE_CHUNK)
            .for_each(|(i, fd)| {
                for d in 0..E::D {
                    // Sign of the undamped predictor v + dt F/m, i.e. of the new velocity: with
                    // the sign of the old velocity the damping force feeds the highest mode
                    // (whose velocity flips every step) and the scheme is unstable near dt_crit.
                    let s = vel[i][d] + dt * force[i][d] * inv_m[i];
                    fd[d] = local_damping(alpha, force[i][d], s);
                }
            }),
        Damping::Viscous(c) => v
            .f_damp
            .par_iter_mut()
            .enumerate()
            .with_min_len(NODE_CHUNK)
            .for_each(|(i, fd)| {
                for d in 0..E::D {
                    fd[d] = -c * mass[i] * vel[i][d];
                }
            }),
    }
}

/// Mass scaling for static relaxation (`time.mass_scaling`, Underwood's fictitious masses):
/// node i gets m_i = R_i dt_crit^2 / 4 (kg/m in 2D, kg in 3D), with R_i its Gershgorin row sum
/// `rows[i]` ([`gershgorin_rows`], [`gershgorin_rows_3d`]). Then
/// lambda_max(M^-1 K) <= max_i R_i / m_i = 4 / dt_crit^2: any step up to `dt_crit` (s) is
/// stable, and every node relaxes at about the same rate, so large elements of a graded mesh
/// stop slowing the relaxation. Serial, fixed order: deterministic.
pub fn scale_masses<E: Element>(v: &mut SolidView<E>, rows: &[f64], dt_crit: f64) {
    for ((m, im), r) in v.mass.iter_mut().zip(&mut v.inv_mass).zip(rows) {
        let need = 0.25 * r * dt_crit * dt_crit;
        if need > 0.0 {
            *m = need;
            *im = 1.0 / need;
        }
    }
}

/// Raise each node's mass to what makes the step `dt_crit` (s) stable for it by Gershgorin's
/// bound: m_i = max(m_i, g_i dt_crit^2 / 4) (kg/m in 2D, kg in 3D), with g_i its row sum
/// `rows[i]` ([`gershgorin_rows`], [`gershgorin_rows_3d`]). Then
/// lambda_max(M^-1 K) <= max_i g_i / m_i <= 4 / dt_crit^2, so central difference is stable at
/// any step up to `dt_crit`, and nodes already that heavy keep their masses. Used by
/// `time.selective_mass_scaling` and by the production stage's relaxation
/// (`production::fictitious_masses`). Serial, in the view's order: deterministic.
pub fn raise_masses<E: Element>(v: &mut SolidView<E>, rows: &[f64], dt_crit: f64) {
    for ((m, im), r) in v.mass.iter_mut().zip(&mut v.inv_mass).zip(rows) {
        let need = r * dt_crit * dt_crit / 4.0;
        if *m > 0.0 && need > *m {
            *m = need;
            *im = 1.0 / need;
        }
    }
}

/// Each node's Gershgorin row sum sum_j |K_ij| of the stiffness, the larger of its two dofs'
/// (N/m per m): the elements' CST stiffness, plus `k_joint(L)` (Pa, L the joint's reference
/// length, m) per joint face at the node (the contact's row sum: its springs act on the faces'
/// mean displacements with coefficients +-1/2). The 2D home of the bound that
/// [`scale_masses`], [`raise_masses`] and the production stage's relaxation
/// (`production::fictitious_masses`) use.
pub fn gershgorin_rows(v: &SolidView, p: &SolidParams, k_joint: impl Fn(f64) -> f64) -> Vec<f64> {
    let mut row = vec![[0.0f64; 2]; v.n_nodes()];
    let d = [
        [p.lam2g, p.lam, 0.0],
        [p.lam, p.lam2g, 0.0],
        [0.0, 0.0, p.g],
    ];
    for (c, g) in v.conn.iter().zip(&v.geom) {
        // B columns of dof (node a, direction k): strain [exx, eyy, gxy] per unit displacement.
        let b = |a: usize, k: usize| -> [f64; 3] {
            let (bx, by) = (g[1 + a], g[4 + a]);
            if k == 0 { [bx, 0.0, by] } else { [0.0, by, bx] }
        };
        for a in 0..3 {
            for k in 0..2 {
                let ba = b(a, k);
                let dba = [0, 1, 2].map(|r| d[r][0] * ba[0] + d[r][1] * ba[1] + d[r][2] * ba[2]);
                let mut sum = 0.0;
                for bb in 0..3 {
                    for l in 0..2 {
                        let bv = b(bb, l);
                        sum += (g[0] * (bv[0] * dba[0] + bv[1] * dba[1] + bv[2] * dba[2])).abs();
                    }
                }
                row[c[a] as usize][k] += sum;
            }
        }
    }
    for j in &v.joint_nodes {
        let [a, b] = [j[0], j[1]].map(|n| v.x0[n as usize]);
        let k = k_joint((b[0] - a[0]).hypot(b[1] - a[1]));
        for &n in j {
            row[n as usize][0] += k;
            row[n as usize][1] += k;
        }
    }
    row.iter().map(|r| r[0].max(r[1])).collect()
}

/// Each node's Gershgorin row sum sum_j |K_ij| of a 3D scene's stiffness, the largest of its
/// three dofs (N/m): the elements' TET4 stiffness; per joint sister pair a bound of its
/// springs, k_max I between the two nodes (N/m; `k_max` = max(K_n, K_t) l / 3 per pair as
/// `contact_3d` sets it, which bounds every contact state in the Loewner order), so 2 k_max
/// on each; and, with `k_fluid` > 0 (Pa/m: the fluid's bulk modulus over the residual
/// aperture, coupled runs), a full cell's k_fluid A0 acting on the opening along face p's
/// reference normal n, whose matrix has entries k_fluid A0 n_d n_e / 9 between every two of
/// the joint's six nodes. The 3D home of the bound that [`scale_masses`] and
/// [`raise_masses`] use (2D: [`gershgorin_rows`]).
pub fn gershgorin_rows_3d(
    v: &SolidView<hydrofrac_core::dim::Tet4>,
    p: &SolidParams,
    k_max: f64,
    k_fluid: f64,
) -> Vec<f64> {
    use hydrofrac_core::model3::{joint_area0_3d, joint_len0_3d};
    use hydrofrac_core::tet4;
    let mut row = vec![[0.0f64; 3]; v.n_nodes()];
    for (c, g) in v.conn.iter().zip(&v.geom) {
        let k = tet4::stiffness(g, p);
        for a in 0..4 {
            for d in 0..3 {
                let r: f64 = (0..12).map(|j| k[(3 * a + d, j)].abs()).sum();
                row[c[a] as usize][d] += r;
            }
        }
    }
    for (j, nodes) in v.joint_nodes.iter().enumerate() {
        let kp = 2.0 * k_max * joint_len0_3d(v, j) / 3.0;
        for &n in nodes {
            for r in &mut row[n as usize] {
                *r += kp;
            }
        }
        if k_fluid > 0.0 {
            let x = [0, 1, 2].map(|a| v.x0[nodes[a] as usize]);
            let nn = tet4::cross(tet4::sub(x[1], x[0]), tet4::sub(x[2], x[0]));
            let n = nn.map(|c| c / tet4::norm(nn));
            let l1 = n[0].abs() + n[1].abs() + n[2].abs();
            let w = k_fluid * joint_area0_3d(v, j) / 9.0 * 6.0 * l1;
            for &m in nodes {
                for d in 0..3 {
                    row[m as usize][d] += w * n[d].abs();
                }
            }
        }
    }
    row.iter().map(|r| r[0].max(r[1]).max(r[2])).collect()
}

/// Quantities reduced over the nodes during integration.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct StepStats {
    /// Kinetic energy at the new half step, J/m.
    pub kinetic: f64,
    /// Leapfrog kinetic energy 1/2 sum m v(n-1/2).v(n+1/2), J/m: with `strain` it forms the
    /// energy that central difference conserves exactly for undamped linear elasticity.
    pub kinetic_mid: f64,
    /// Strain energy at the start of the step, -1/2 sum u(n).f_int(u(n)), J/m.
    pub strain: f64,
    /// Sum of squared unbalanced force on free dofs, (N/m)^2.
    pub res2: f64,
    /// Sum of squared reactions on prescribed dofs plus squared loads, (N/m)^2.
    pub ref2: f64,
    /// Largest speed and the dense node index where it occurs.
    pub vmax: f64,
    pub vmax_node: usize,
    /// First node (dense index) with a non-finite displacement or velocity.
    pub non_finite: Option<usize>,
}

impl StepStats {
    fn merge(mut self, o: StepStats) -> StepStats {
        self.kinetic += o.kinetic;
        self.kinetic_mid += o.kinetic_mid;
        self.strain += o.strain;
        self.res2 += o.res2;
        self.ref2 += o.ref2;
        if o.vmax > self.vmax {
            self.vmax = o.vmax;
            self.vmax_node = o.vmax_node;
        }
        if self.non_finite.is_none() {
            self.non_finite = o.non_finite;
        }
        self
    }

    /// Static residual: ||unbalanced force on free dofs|| / ||reactions and loads||; 1 when
    /// there is an unbalanced force but no reaction or load to measure it against (a rock
    /// without internal force, `--disable internal_force`), as the flow's steady residual.
    /// Non-finite only when the forces themselves overflow (a blow-up, `monitor`).
    pub fn residual(&self) -> f64 {
        if self.ref2 > 0.0 {
            (self.res2 / self.ref2).sqrt()
        } else if self.res2 == 0.0 {
            0.0
        } else {
            1.0
        }
    }
}

/// `integrate`'s data for one node's update.
struct NodeStep<'a, E: Element> {
    dt: f64,
    lf: f64,
    force: &'a [E::Vector],
    fdamp: &'a [E::Vector],
    inv_m: &'a [f64],
    mass: &'a [f64],
    fixed: &'a [u8],
    presc: &'a [E::Vector],
    load: &'a [E::Vector],
}

/// a . b, summed from the first component on (as the 2D kernels always did: no 0.0 + a).
#[inline(always)]
fn dot<V: hydrofrac_core::dim::Numbers>(a: &V, b: &V) -> f64 {
    let (a, b) = (a.as_ref(), b.as_ref());
    let mut s = a[0] * b[0];
    for d in 1..a.len() {
        s += a[d] * b[d];
    }
    s
}

impl<E: Element> NodeStep<'_, E> {
    /// Node i's central-difference update, adding to the step statistics; returns the
    /// largest change of its displacement components, m.
    #[inline(always)]
    fn node(&self, i: usize, u: &mut E::Vector, vel: &mut E::Vector, st: &mut StepStats) -> f64 {
        let (dt, lf) = (self.dt, self.lf);
        let v_old = *vel;
        let u_old = *u;
        for d in 0..E::D {
            let f = self.force[i][d];
            let l = lf * self.load[i][d];
            st.strain -= 0.5 * u[d] * (f - l);
            st.ref2 += l * l;
            if self.fixed[i] & (1 << d) != 0 {
                st.ref2 += f * f;
                u[d] = lf * self.presc[i][d];
                vel[d] = 0.0;
            } else {
                st.res2 += f * f;
                vel[d] = flush_tiny(vel[d] + dt * (f + self.fdamp[i][d]) * self.inv_m[i]);
                u[d] = flush_tiny(u[d] + dt * vel[d]);
            }
        }
        let s2 = dot(vel, vel);
        st.kinetic += 0.5 * self.mass[i] * s2;
        st.kinetic_mid += 0.5 * self.mass[i] * dot(&v_old, vel);
        if !(s2.is_finite() && u.as_ref().iter().all(|x| x.is_finite())) {
            st.non_finite.get_or_insert(i);
        } else if s2 > st.vmax * st.vmax {
            st.vmax = s2.sqrt();
            st.vmax_node = i;
        }
        let mut change = (u[0] - u_old[0]).abs();
        for d in 1..E::D {
            let c = (u[d] - u_old[d]).abs();
            if c > change {
                change = c;
            }
        }
        change
    }
}

/// `integrate`: central difference, v += dt (F + F_damp)/m, u += dt v; prescribed components
/// are held at their value with zero velocity. Returns the step statistics.
pub fn integrate<E: Element>(v: &mut SolidView<E>, dt: f64, lf: f64) -> StepStats {
    let step = NodeStep::<E> {
        dt,
        lf,
        force: &v.force,
        fdamp: &v.f_damp,
        inv_m: &v.inv_mass,
        mass: &v.mass,
        fixed: &v.fixed,
        presc: &v.presc,
        load: &v.load,
    };
    // Motion regions (the strength screen's runs of consecutive nodes in one region): each
    // run's largest displacement change this step, from the nodes' changes in `motion_node`.
    let runs = (!v.motion_du.is_empty()
        && v.motion_runs
            .last()
            .is_some_and(|r| r.1 as usize == v.u.len()))
    .then_some(&v.motion_runs[..]);
    let mut dnode = std::mem::take(&mut v.motion_node);
    dnode.resize(if runs.is_some() { v.u.len() } else { 0 }, 0.0);
    let partials: Vec<(StepStats, Vec<(u32, f64)>)> = match runs {
        None => {
            v.u.par_chunks_mut(NODE_CHUNK)
                .zip(v.v.par_chunks_mut(NODE_CHUNK))
                .enumerate()
                .map(|(c, (uc, vc))| {
                    let mut st = StepStats::default();
                    for (k, (u, vel)) in uc.iter_mut().zip(vc.iter_mut()).enumerate() {
                        step.node(c * NODE_CHUNK + k, u, vel, &mut st);
                    }
                    (st, Vec::new())
                })
                .collect()
        }
        Some(runs) => v
            .u
            .par_chunks_mut(NODE_CHUNK)
            .zip(v.v.par_chunks_mut(NODE_CHUNK))
            .zip(dnode.par_chunks_mut(NODE_CHUNK))
            .enumerate()
            .map(|(c, ((uc, vc), dc))| {
                let mut st = StepStats::default();
                let base = c * NODE_CHUNK;
                for (k, ((u, vel), d)) in uc
                    .iter_mut()
                    .zip(vc.iter_mut())
                    .zip(dc.iter_mut())
                    .enumerate()
                {
                    *d = step.node(base + k, u, vel, &mut st);
                }
                let end = base + uc.len();
                let first = runs.partition_point(|r| (r.1 as usize) <= base);
                let moved = runs[first..]
                    .iter()
                    .take_while(|r| (r.0 as usize) < end)
                    .map(|&(a, b, r)| {
                        let (a, b) = ((a as usize).max(base) - base, (b as usize).min(end) - base);
                        // As f64::max (a NaN change is passed over).
                        let m = dc[a..b]
                            .iter()
                            .fold(0.0f64, |m, &d| if d > m { d } else { m });
                        (r, m)
                    })
                    .collect();
                (st, moved)
            })
            .collect(),
    };
    v.motion_node = dnode;
    let mut stats = StepStats::default();
    if runs.is_some() {
        let mut this = std::mem::take(&mut v.motion_scratch);
        this.clear();
        this.resize(v.motion_du.len(), 0.0);
        for &(r, d) in partials.iter().flat_map(|p| &p.1) {
            this[r as usize] = this[r as usize].max(d);
        }
        for (acc, d) in v.motion_du.iter_mut().zip(&this) {
            *acc += d;
        }
        v.motion_scratch = this;
        v.motion_steps += 1;
    }
    for (st, _) in partials {
        stats = stats.merge(st);
    }
    stats
}

/// Strain energy 1/2 sum_e measure sigma:epsilon (J/m in plane strain, where the zz term
/// vanishes because eps_zz = 0; J in 3D), from the current displacements.
pub fn strain_energy<E: Element>(v: &SolidView<E>, p: &SolidParams) -> f64 {
    let partial: Vec<f64> = v
        .conn
        .par_chunks(ELEM_GRAIN)
        .zip(v.geom.par_chunks(ELEM_GRAIN))
        .map(|(cc, gc)| {
            let mut e = 0.0;
            for (c, g) in cc.iter().zip(gc) {
                e += E::strain_energy(g, c, &v.u, p);
            }
            e
        })
        .collect();
    partial.into_iter().sum()
}
