//! `seismicity`: the event catalogue of joint slip (`docs/seismicity.md`).
//!
//! Each step, every sliding joint's slip rate is the change of its tangential offset delta_t
//! (face q's centre from face p's along p's tangent, as `contact` last evaluated it) over the
//! step, divided by the step's length (m/s); a sticking or open joint's rate is zero (its
//! offset changes elastically, through the penalty spring, or without friction). Under the
//! explicit rock `contact` evaluates the offset at the step's start, so the rate is the
//! previous step's. Joints slipping at `v_stop` or faster are *hot*; hot joints that share a
//! node (along a fracture, or where two fractures cross) form connected sets. A set that touches
//! a running event's joints belongs to it (sets that touch two events merge them into the
//! older); a set that touches none opens a new event when its fastest joint reaches `v_start`
//! (its hypocentre: that joint). An event closes at the end of the first step in which none of
//! its joints is hot. Per event: the slip of each joint it involved (the sum of its offset
//! increments while the event ran, m), its shear traction when it joined and when the event
//! closed (Pa), from which
//! - the moment per unit thickness M0' = G sum_i |slip_i| L_i (N m/m, G the rock's shear
//!   modulus, L_i the joint's reference length),
//! - the moment M0 = W M0' with W the out-of-plane width (`seismicity.width`, default the
//!   ruptured length sum L_i), N m, and Mw = (2/3)(log10 M0 - 9.1),
//! - the stress drop sum L_i s_i (tau_start - tau_end) / sum L_i (s_i the sign of the slip),
//! - the slip-weighted centroid and the mean (length-weighted) and largest |slip|.
//!
//! The b-value of a catalogue ([`b_value`]) is Aki-Utsu's maximum-likelihood estimate with the
//! half-bin correction. The system is serial and reads the joints in view order (stable id), so
//! the catalogue is the same for any thread count. Cost: a pass over the joints' contact state
//! per step, and a search over the hot joints only.

use hecs::Entity;
use hydrofrac_core::view::{SolidView, joint_len0, joint_mid0};
use serde::{Deserialize, Serialize};

const NONE: u32 = u32::MAX;
/// History samples kept before every other one is dropped and the stride doubles.
const MAX_HISTORY: usize = 4096;
/// Magnitude bin of the b-value estimate and the frequency-magnitude figure.
pub const MAGNITUDE_BIN: f64 = 0.1;

/// One finished event. Times s, positions and lengths m, slips m, stresses Pa, M0' N (N m/m),
/// M0 N m.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    pub id: u64,
    pub t_start: f64,
    pub t_end: f64,
    /// Reference midpoint of the joint that opened the event (its fastest at onset).
    pub hypocentre: [f64; 2],
    pub centroid: [f64; 2],
    /// Joints involved and their total reference length.
    pub joints: usize,
    pub length: f64,
    pub mean_slip: f64,
    pub max_slip: f64,
    /// Largest slip rate of a joint during the event, m/s.
    pub peak_rate: f64,
    pub stress_drop: f64,
    pub moment_per_thickness: f64,
    pub width: f64,
    pub moment: f64,
    pub magnitude: f64,
    /// Fluid injected by the flow boundaries when the event closed, m^2 per m (0 without flow).
    pub injected: f64,
    /// Still slipping when the run ended (closed there).
    pub open_at_end: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Running {
    id: u32,
    t_start: f64,
    hypocentre: [f64; 2],
    peak_rate: f64,
    /// Whether a joint of it was hot in the step being processed.
    touched: bool,
}

/// One sample of the run's history for the figures: time (s), the injection pressure (Pa),
/// the injected volume (m^2/m) and the catalogue's cumulative M0' (N, running events included).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Sample {
    pub time: f64,
    pub pressure: f64,
    pub injected: f64,
    pub cumulative_moment: f64,
}

/// The catalogue's settings, SI (`seismicity:` in the scenario).
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Settings {
    pub v_start: f64,
    pub v_stop: f64,
    pub width: Option<f64>,
    /// The rock's shear modulus G, Pa.
    pub shear_modulus: f64,
}

/// Per joint (view order): its entity, offset delta_t (m) and shear force (N/m) at the end of
/// the last step, the running event it belongs to, and its slip (m) and shear traction when it
/// joined (Pa) in that event.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct Joints {
    entity: Vec<Entity>,
    offset: Vec<f64>,
    force: Vec<f64>,
    event: Vec<u32>,
    slip: Vec<f64>,
    tau_start: Vec<f64>,
}

/// The catalogue's state: the joints' last offsets and event memberships, the running and
/// finished events, the history.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Catalogue {
    pub settings: Settings,
    generation: Option<u64>,
    joints: Joints,
    running: Vec<Running>,
    next_id: u32,
    pub events: Vec<Event>,
    /// Sum of M0' over finished events, N.
    pub cumulative_moment: f64,
    pub history: Vec<Sample>,
    stride: u64,
    calls: u64,
    /// Scratch of the step (not state).
    #[serde(skip)]
    scratch: Scratch,
}

/// A joint slipping at `v_stop` or faster in the step: its view index, signed offset
/// increment (m), slip rate (m/s) and shear force at the step's start (N/m).
#[derive(Clone, Copy, Debug)]
struct Hot {
    k: u32,
    inc: f64,
    rate: f64,
    force0: f64,
}

#[derive(Clone, Debug, Default)]
struct Scratch {
    hot: Vec<Hot>,
    /// Per joint, its place in `hot` (`NONE`: not hot); reset after each step.
    hot_at: Vec<u32>,
    seen: Vec<bool>,
    set: Vec<u32>,
    /// Reference lengths (m), joints by node (CSR over the view's nodes): rebuilt with the
    /// topology.
    len0: Vec<f64>,
    node_start: Vec<u32>,
    node_joints: Vec<u32>,
    adjacency_generation: Option<u64>,
}

/// What the step's flow shows the catalogue: injected volume (m^2/m) and injection pressure
/// (Pa; zeros without flow).
#[derive(Clone, Copy, Debug, Default)]
pub struct Injection {
    pub injected: f64,
    pub pressure: f64,
}

impl Catalogue {
    pub fn new(settings: Settings) -> Self {
        Catalogue {
            settings,
            generation: None,
            joints: Joints::default(),
            running: Vec::new(),
            next_id: 0,
            events: Vec::new(),
            cumulative_moment: 0.0,
            history: Vec::new(),
            stride: 1,
            calls: 0,
            scratch: Scratch::default(),
        }
    }

    /// Events still running.
    pub fn running(&self) -> usize {
        self.running.len()
    }

    /// Follow the view's joints (at setup, so the first step's slip counts, and after a
    /// topology change): each joint keeps its state by entity; a new joint starts at its
    /// current offset and force, in no event.
    pub fn follow(&mut self, v: &SolidView) {
        if self.generation == Some(v.generation) {
            return;
        }
        let j = &self.joints;
        let old: std::collections::HashMap<Entity, usize> =
            j.entity.iter().enumerate().map(|(k, &e)| (e, k)).collect();
        let n = v.joint_nodes.len();
        let mut new = Joints::default();
        for k in 0..n {
            let e = v.joint_entity[k];
            new.entity.push(e);
            match old.get(&e) {
                Some(&o) => {
                    new.offset.push(j.offset[o]);
                    new.force.push(j.force[o]);
                    new.event.push(j.event[o]);
                    new.slip.push(j.slip[o]);
                    new.tau_start.push(j.tau_start[o]);
                }
                None => {
                    new.offset.push(v.joint_state[k].last_shear_offset);
                    new.force.push(v.joint_state[k].shear_force);
                    new.event.push(NONE);
                    new.slip.push(0.0);
                    new.tau_start.push(0.0);
                }
            }
        }
        self.joints = new;
        self.generation = Some(v.generation);
    }

    fn adjacency(&mut self, v: &SolidView) {
        let s = &mut self.scratch;
        if s.adjacency_generation == Some(v.generation) {
            return;
        }
        let nn = v.n_nodes();
        s.node_start = vec![0; nn + 1];
        for nodes in &v.joint_nodes {
            for &i in nodes {
                s.node_start[i as usize + 1] += 1;
            }
        }
        for i in 0..nn {
            s.node_start[i + 1] += s.node_start[i];
        }
        let mut fill = s.node_start.clone();
        s.node_joints = vec![0; s.node_start[nn] as usize];
        for (k, nodes) in v.joint_nodes.iter().enumerate() {
            for &i in nodes {
                s.node_joints[fill[i as usize] as usize] = k as u32;
                fill[i as usize] += 1;
            }
        }
        s.len0 = (0..v.joint_nodes.len()).map(|k| joint_len0(v, k)).collect();
        s.hot_at = vec![NONE; v.joint_nodes.len()];
        s.adjacency_generation = Some(v.generation);
    }

    /// Close every running event (the run ends at `t`, s).
    pub fn finish(&mut self, v: &SolidView, t: f64, inj: Injection) {
        self.follow(v);
        for r in std::mem::take(&mut self.running) {
            self.close(v, r, t, inj, true);
        }
    }

    /// Close running event `r` at `t` (s): its joints leave it.
    fn close(&mut self, v: &SolidView, r: Running, t: f64, inj: Injection, open_at_end: bool) {
        let g = self.settings.shear_modulus;
        let (mut n, mut length, mut m0, mut drop) = (0, 0.0, 0.0, 0.0);
        let (mut wx, mut wy, mut max_slip) = (0.0, 0.0, 0.0f64);
        let j = &mut self.joints;
        for k in 0..j.entity.len() {
            if j.event[k] != r.id {
                continue;
            }
            j.event[k] = NONE;
            let len = joint_len0(v, k);
            let tau_end = v.joint_state[k].shear_force / len;
            let (s, a) = (j.slip[k], j.slip[k].abs());
            let x = joint_mid0(v, k);
            n += 1;
            length += len;
            m0 += a * len;
            drop += len * s.signum() * (j.tau_start[k] - tau_end);
            wx += a * len * x[0];
            wy += a * len * x[1];
            max_slip = max_slip.max(a);
        }
        let centroid = if m0 > 0.0 {
            [wx / m0, wy / m0]
        } else {
            r.hypocentre
        };
        let moment_per_thickness = g * m0;
        let width = self.settings.width.unwrap_or(length);
        let moment = moment_per_thickness * width;
        self.cumulative_moment += moment_per_thickness;
        let (length_or_1, mean) = if length > 0.0 {
            (length, m0 / length)
        } else {
            (1.0, 0.0)
        };
        self.events.push(Event {
            id: r.id as u64,
            t_start: r.t_start,
            t_end: t,
            hypocentre: r.hypocentre,
            centroid,
            joints: n,
            length,
            mean_slip: mean,
            max_slip,
            peak_rate: r.peak_rate,
            stress_drop: drop / length_or_1,
            moment_per_thickness,
            width,
            moment,
            magnitude: moment_magnitude(moment),
            injected: inj.injected,
            open_at_end,
        });
    }

    fn sample(&mut self, t: f64, inj: Injection) {
        self.calls += 1;
        if !(self.calls - 1).is_multiple_of(self.stride) {
            return;
        }
        let cumulative_moment = self.cumulative_moment + self.running_moment();
        self.history.push(Sample {
            time: t,
            pressure: inj.pressure,
            injected: inj.injected,
            cumulative_moment,
        });
        if self.history.len() >= MAX_HISTORY {
            let kept: Vec<Sample> = self.history.iter().step_by(2).copied().collect();
            self.history = kept;
            self.stride *= 2;
        }
    }

    /// M0' of the running events so far, N (needs the view the joints follow).
    fn running_moment(&self) -> f64 {
        if self.running.is_empty() {
            return 0.0;
        }
        let j = &self.joints;
        let lens = self.scratch.len0.as_slice();
        let m: f64 = (0..j.entity.len())
            .filter(|&k| j.event[k] != NONE)
            .map(|k| j.slip[k].abs() * lens[k])
            .sum();
        self.settings.shear_modulus * m
    }
}

/// Mw of a moment `m0` (N m): (2/3)(log10 M0 - 9.1); a moment of zero gives the smallest
/// finite magnitude instead of minus infinity.
pub fn moment_magnitude(m0: f64) -> f64 {
    (2.0 / 3.0) * (m0.max(f64::MIN_POSITIVE).log10() - 9.1)
}

/// `seismicity`: the slip rates of the step [t0, t1] (s) and the events they open, extend and
/// close (see the module documentation). `inj`: the flow's injection at t1.
pub fn seismicity(cat: &mut Catalogue, v: &SolidView, t0: f64, t1: f64, inj: Injection) {
    cat.follow(v);
    cat.adjacency(v);
    let dt = t1 - t0;
    let n = v.joint_nodes.len();
    let v_stop = cat.settings.v_stop;
    let mut sc = std::mem::take(&mut cat.scratch);
    sc.hot.clear();
    let j = &mut cat.joints;
    for k in 0..n {
        let st = &v.joint_state[k];
        let d = st.last_shear_offset - j.offset[k];
        j.offset[k] = st.last_shear_offset;
        let force0 = std::mem::replace(&mut j.force[k], st.shear_force);
        if j.event[k] != NONE {
            // A member's slip counts every increment while its event runs, hot or not.
            j.slip[k] += d;
        }
        // Frictional slip only: a sticking joint's offset follows its shear force through the
        // penalty spring, and an open joint has no friction to release.
        if st.sliding && dt > 0.0 {
            let rate = d.abs() / dt;
            if rate >= v_stop {
                sc.hot_at[k] = sc.hot.len() as u32;
                sc.hot.push(Hot {
                    k: k as u32,
                    inc: d,
                    rate,
                    force0,
                });
            }
        }
    }
    for r in &mut cat.running {
        r.touched = false;
    }
    // Connected sets of hot joints (sharing a node), in order of their first joint.
    sc.seen.clear();
    sc.seen.resize(sc.hot.len(), false);
    let mut set = std::mem::take(&mut sc.set);
    for h0 in 0..sc.hot.len() {
        if sc.seen[h0] {
            continue;
        }
        set.clear();
        set.push(h0 as u32);
        sc.seen[h0] = true;
        let mut head = 0;
        while head < set.len() {
            let k = sc.hot[set[head] as usize].k as usize;
            head += 1;
            for &i in &v.joint_nodes[k] {
                let i = i as usize;
                let (a, b) = (sc.node_start[i] as usize, sc.node_start[i + 1] as usize);
                for &q in &sc.node_joints[a..b] {
                    let h = sc.hot_at[q as usize];
                    if h != NONE && !sc.seen[h as usize] {
                        sc.seen[h as usize] = true;
                        set.push(h);
                    }
                }
            }
        }
        set.sort_unstable();
        absorb(cat, v, &set, &sc, t0);
    }
    for h in &sc.hot {
        sc.hot_at[h.k as usize] = NONE;
    }
    sc.set = set;
    cat.scratch = sc;
    // Events none of whose joints was hot close at t1.
    let (done, still): (Vec<Running>, Vec<Running>) = std::mem::take(&mut cat.running)
        .into_iter()
        .partition(|r| !r.touched);
    cat.running = still;
    for r in done {
        cat.close(v, r, t1, inj, false);
    }
    cat.sample(t1, inj);
}

/// Put the connected hot set `set` (view indices, sorted) into its event: the oldest running
/// event it touches (the younger ones it touches merge into it), else a new one if its
/// fastest joint reaches `v_start`, with that joint (the first in stable order at the peak
/// rate) as the hypocentre.
fn absorb(cat: &mut Catalogue, v: &SolidView, set: &[u32], step: &Scratch, t0: f64) {
    let hot = |h: &u32| step.hot[*h as usize];
    let j = &mut cat.joints;
    let mut ids: Vec<u32> = set
        .iter()
        .map(|h| j.event[hot(h).k as usize])
        .filter(|&e| e != NONE)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let peak = set.iter().map(|h| hot(h).rate).fold(0.0, f64::max);
    let target = match ids.first() {
        Some(&id) => {
            for &other in &ids[1..] {
                for e in j.event.iter_mut().filter(|e| **e == other) {
                    *e = id;
                }
                if let Some(p) = cat.running.iter().position(|r| r.id == other) {
                    let r = cat.running.remove(p);
                    if let Some(into) = cat.running.iter_mut().find(|x| x.id == id) {
                        into.peak_rate = into.peak_rate.max(r.peak_rate);
                        into.t_start = into.t_start.min(r.t_start);
                    }
                }
            }
            id
        }
        None if peak >= cat.settings.v_start => {
            let first = set
                .iter()
                .map(hot)
                .find(|h| h.rate == peak)
                .map_or(hot(&set[0]).k, |h| h.k) as usize;
            let id = cat.next_id;
            cat.next_id += 1;
            cat.running.push(Running {
                id,
                t_start: t0,
                hypocentre: joint_mid0(v, first),
                peak_rate: 0.0,
                touched: true,
            });
            id
        }
        None => return,
    };
    if let Some(r) = cat.running.iter_mut().find(|r| r.id == target) {
        r.touched = true;
        r.peak_rate = r.peak_rate.max(peak);
    }
    for h in set.iter().map(hot) {
        let k = h.k as usize;
        if j.event[k] == target {
            continue;
        }
        // The joint joins now: its slip starts with the step's increment, its traction is the
        // one at the step's start.
        j.event[k] = target;
        j.slip[k] = h.inc;
        j.tau_start[k] = h.force0 / step.len0[k];
    }
}

/// Events at or above the completeness a run's catalogue needs for its b-value (with fewer it
/// is not reported: Aki's relative error 1 / sqrt(N) is over 30 %).
pub const MIN_B_EVENTS: usize = 10;

/// Aki-Utsu maximum-likelihood b-value of the magnitudes at or above the completeness `mc`,
/// binned to `bin` (half-bin correction): b = log10(e) / (mean M - (mc - bin / 2)), with Aki's
/// standard error b / sqrt(N). `None` with fewer than `min` (and two) events above `mc`, or no
/// spread.
pub fn b_value(magnitudes: &[f64], mc: f64, bin: f64, min: usize) -> Option<(f64, f64, usize)> {
    let binned: Vec<f64> = magnitudes
        .iter()
        .map(|m| (m / bin).round() * bin)
        .filter(|&m| m >= mc - 1e-9)
        .collect();
    let n = binned.len();
    if n < min.max(2) {
        return None;
    }
    let mean = binned.iter().sum::<f64>() / n as f64;
    let spread = mean - (mc - bin / 2.0);
    if spread <= 0.0 {
        return None;
    }
    let b = std::f64::consts::LOG10_E / spread;
    Some((b, b / (n as f64).sqrt(), n))
}

/// Maximum-curvature completeness: the centre of the `bin`-wide magnitude bin with the most
/// events (the lowest such bin on ties). `None` for an empty catalogue.
pub fn completeness_max_curvature(magnitudes: &[f64], bin: f64) -> Option<f64> {
    let mut bins: Vec<i64> = magnitudes
        .iter()
        .map(|m| (m / bin).round() as i64)
        .collect();
    bins.sort_unstable();
    let mut best: Option<(i64, usize)> = None;
    let mut i = 0;
    while i < bins.len() {
        let j = bins[i..].iter().take_while(|&&b| b == bins[i]).count();
        if best.is_none_or(|(_, c)| j > c) {
            best = Some((bins[i], j));
        }
        i += j;
    }
    best.map(|(b, _)| b as f64 * bin)
}

/// The flow's injection now: the volume the boundaries injected (m^2/m) and the highest
/// pressure of a boundary that has injected (Pa); zeros without flow.
pub fn injection(f: Option<&crate::flow::FlowPart>) -> Injection {
    let Some(f) = f else {
        return Injection::default();
    };
    let bcs = &f.view.bcs;
    Injection {
        injected: bcs.iter().map(|b| b.volume_in).sum(),
        pressure: bcs
            .iter()
            .filter(|b| b.volume_in > 0.0)
            .map(|b| b.pressure)
            .fold(0.0, f64::max),
    }
}
