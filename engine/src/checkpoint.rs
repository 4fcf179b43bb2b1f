//! Restart checkpoints: the whole state of a run between two steps, written to a file from
//! which `hydrofrac run SCENARIO --restart FILE` continues bit for bit as if never stopped.
//!
//! What is saved is what carries state across steps, exactly as it is in memory (no sync first,
//! so writing a checkpoint never changes the run): every entity of the ECS world with all its
//! components under its own `hecs::Entity` handle (respawned at the same handles in the same
//! order, so the relations inside components stay valid and later spawns get the same
//! handles), the model's counters, the dense solid and flow views, the clock, the time-step
//! parameters the step changes (`dt`, the load factor, the adaptive aim), the flow part's
//! accumulators (boundary volumes and their Kahan compensations live in the flow view), the
//! coupling's mean pressures, the fracture state (criterion screen, tips, counters) and the
//! solver counters. What is rebuilt from the scenario instead: parameters, schedule, the
//! generated network's table, sparse factorisations (rebuilt for the same pattern, which gives
//! the same numbers).
//!
//! File layout (all integers little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `HFCKPT\0\n` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 8 | payload length n |
//! | n | payload: postcard of ([`Header`], [`State`]) |
//! | 8 | FNV-1a 64 hash of the payload |
//!
//! A file is refused with a one-line message when it is not a checkpoint, truncated or
//! corrupt (length or hash), of another format version or hydrofrac version, or written for
//! another scenario: the header carries a fingerprint of the scenario as parsed with its
//! `--set` overrides and `--disable` list (everything but `name`, `description` and the
//! `output` block, which do not change the physics).

use hecs::Entity;
use hydrofrac_components::*;

use crate::sim::Simulation;
use hydrofrac_core::dim::{Cst, Element};
pub use hydrofrac_core::flow::implicit::ImplicitCounters;
use hydrofrac_core::model::Model;
use hydrofrac_core::scenario::Scenario;
use hydrofrac_core::view::SolidView;
use hydrofrac_systems::flow::FlowPart;
use hydrofrac_systems::fracture::FractureState;
use hydrofrac_systems::monitor::{Clock, Effort};
use hydrofrac_systems::quasi_static::QsCounts;
use hydrofrac_systems::solid::StepStats;
use hydrofrac_systems::{RunError, SystemId};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// First bytes of every checkpoint file.
pub const MAGIC: &[u8; 8] = b"HFCKPT\0\n";
/// Version of the layout of [`State`]; bumped whenever a saved type changes.
pub const FORMAT_VERSION: u32 = 11;
/// The latest checkpoint in the output folder, and the one before it.
pub const FILE: &str = "checkpoint.ckpt";
pub const PREV_FILE: &str = "checkpoint.prev.ckpt";

/// Why a checkpoint cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("checkpoint {path}: {why}")]
    Refused { path: String, why: String },
    #[error("checkpoint {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
}

fn refused(path: &Path, why: impl Into<String>) -> CheckpointError {
    CheckpointError::Refused {
        path: path.display().to_string(),
        why: why.into(),
    }
}

/// Who wrote the checkpoint and where the run was.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Header {
    pub crate_version: String,
    /// 2 or 3: the element kind's dimension ([`hydrofrac_core::dim::Element::D`]).
    pub dimension: u8,
    pub scenario_name: String,
    pub fingerprint: u64,
    pub step: u64,
    pub time: f64,
}

/// Every entity of the world with its bundle, by handle.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct WorldRecords {
    pub nodes: Vec<(Entity, NodeBundle)>,
    pub elems: Vec<(Entity, ElemBundle)>,
    pub edges: Vec<(Entity, EdgeBundle)>,
    pub cells: Vec<(Entity, CellBundle)>,
    pub joints: Vec<(Entity, JointBundle)>,
    pub bcs: Vec<(Entity, FlowBcBundle)>,
    /// 3D: nodes, tetrahedra, faces and face joints (empty in 2D).
    pub nodes3: Vec<(Entity, Node3Bundle)>,
    pub tets: Vec<(Entity, Tet4Bundle)>,
    pub faces: Vec<(Entity, FaceBundle)>,
    pub face_joints: Vec<(Entity, FaceJointBundle)>,
    /// 3D flow cells (empty in 2D and in 3D runs without flow).
    pub face_cells: Vec<(Entity, FaceCellBundle)>,
}

/// The state of a simulation between steps, of element kind `E` (2D by default). A 3D state
/// has no fracture growth, quasi-static Newton or catalogue (their fields are empty).
#[derive(Clone, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct State<E: Element = Cst> {
    pub world: WorldRecords,
    pub topology_generation: u64,
    /// next_node_id, next_elem_id, next_edge_id, next_cell_id, next_joint_id.
    pub next_ids: [u64; 5],
    pub clock: Clock,
    pub solid_view: SolidView<E>,
    pub solid_stats: StepStats,
    pub dt_crit: f64,
    pub qs_counts: Option<QsCounts>,
    /// The flow part as it is (its network table and the implicit solver's caches are rebuilt,
    /// `FlowPart`, `ImplicitSolver`).
    pub flow: Option<FlowPart>,
    pub fracture: FractureState,
    pub effort: Effort,
    pub cells_at_start: usize,
    /// The next simulated time at which an `output.checkpoint_every: Time` checkpoint is due.
    pub next_checkpoint_time: f64,
    /// The event catalogue (`seismicity:`), running events included.
    pub seismicity: Option<hydrofrac_systems::seismicity::Catalogue>,
}

impl WorldRecords {
    /// Every entity of `model`'s world; fails on an entity outside the known bundles.
    pub fn capture(model: &Model) -> Result<Self, String> {
        let w = &model.world;
        let mut r = WorldRecords::default();
        for (e, a, b, c, d, f, g) in w
            .query::<(
                Entity,
                &StableId,
                &NodeRef,
                &NodeState,
                &NodeMass,
                &NodeBc,
                &NodeLink,
            )>()
            .iter()
        {
            r.nodes.push((e, (*a, *b, *c, *d, *f, *g)));
        }
        for (e, a, b, c, d) in w
            .query::<(Entity, &StableId, &ElemNodes, &ElemGeom, &ElemStress)>()
            .iter()
        {
            r.elems.push((e, (*a, *b, *c, *d)));
        }
        for (e, a, b, c, d) in w
            .query::<(Entity, &StableId, &EdgeNodes, &EdgeElems, &EdgeState)>()
            .iter()
        {
            r.edges.push((e, (*a, *b, *c, *d)));
        }
        for (e, a, b, c, d) in w
            .query::<(Entity, &StableId, &CellNodes, &CellFluid, &CellOrigin)>()
            .iter()
        {
            r.cells.push((e, (*a, *b, *c, *d)));
        }
        for (e, a, b, c) in w.query::<(Entity, &StableId, &Joint, &JointState)>().iter() {
            r.joints.push((e, (*a, *b, *c)));
        }
        for (e, a, b) in w.query::<(Entity, &StableId, &FlowBc)>().iter() {
            r.bcs.push((e, (*a, *b)));
        }
        type N3 = (
            Entity,
            &'static StableId,
            &'static NodeRef<[f64; 3]>,
            &'static NodeState<[f64; 3]>,
            &'static NodeMass,
            &'static NodeBc<[f64; 3], [Option<f64>; 3]>,
            &'static NodeLink,
        );
        for (e, a, b, c, d, f, g) in w.query::<N3>().iter() {
            r.nodes3.push((e, (*a, *b, *c, *d, *f, *g)));
        }
        for (e, a, b, c, d) in w
            .query::<(
                Entity,
                &StableId,
                &ElemNodes<[Entity; 4]>,
                &TetGeom,
                &ElemStress<[f64; 6]>,
            )>()
            .iter()
        {
            r.tets.push((e, (*a, *b, *c, *d)));
        }
        for (e, a, b, c, d) in w
            .query::<(Entity, &StableId, &FaceNodes, &EdgeElems, &EdgeState)>()
            .iter()
        {
            r.faces.push((e, (*a, *b, *c, *d)));
        }
        for (e, a, b, c) in w
            .query::<(Entity, &StableId, &FaceJoint, &JointState<CornerShear>)>()
            .iter()
        {
            r.face_joints.push((e, (*a, *b, *c)));
        }
        for (e, a, b, c, d) in w
            .query::<(Entity, &StableId, &FaceCell, &CellFluid, &CellOrigin)>()
            .iter()
        {
            r.face_cells.push((e, (*a, *b, *c, *d)));
        }
        r.check_bundles(w)?;
        let n = r.nodes.len()
            + r.elems.len()
            + r.edges.len()
            + r.cells.len()
            + r.joints.len()
            + r.bcs.len()
            + r.nodes3.len()
            + r.tets.len()
            + r.faces.len()
            + r.face_joints.len()
            + r.face_cells.len();
        if n != w.len() as usize {
            return Err(format!(
                "the world has {} entities, {n} of them in the known bundles",
                w.len()
            ));
        }
        Ok(r)
    }

    /// Every entity carries exactly the components of one of the bundles: a component added
    /// to an entity but not to its bundle (`hydrofrac_components`) would not be saved, and a
    /// restart would silently lose it.
    fn check_bundles(&self, w: &hecs::World) -> Result<(), String> {
        fn ids<B: hecs::Bundle>() -> Vec<std::any::TypeId> {
            B::with_static_ids(|ids| {
                let mut v = ids.to_vec();
                v.sort_unstable();
                v
            })
        }
        let bundles = [
            ids::<NodeBundle>(),
            ids::<ElemBundle>(),
            ids::<EdgeBundle>(),
            ids::<CellBundle>(),
            ids::<JointBundle>(),
            ids::<FlowBcBundle>(),
            ids::<Node3Bundle>(),
            ids::<Tet4Bundle>(),
            ids::<FaceBundle>(),
            ids::<FaceJointBundle>(),
            ids::<FaceCellBundle>(),
        ];
        for a in w.archetypes().filter(|a| !a.is_empty()) {
            let mut types: Vec<std::any::TypeId> = a.component_types().collect();
            types.sort_unstable();
            if !bundles.contains(&types) {
                return Err(format!(
                    "{} entities carry a set of {} components that is not a checkpoint bundle                      (a component added to an entity must be added to its bundle)",
                    a.len(),
                    types.len()
                ));
            }
        }
        Ok(())
    }

    /// A world with every entity respawned at its handle, in handle order (the order they were
    /// spawned in: nothing is ever despawned), so archetype order and later handles match.
    pub fn restore(self) -> Result<hecs::World, String> {
        enum Rec {
            N(NodeBundle),
            E(ElemBundle),
            D(EdgeBundle),
            C(CellBundle),
            J(JointBundle),
            B(FlowBcBundle),
            N3(Node3Bundle),
            T(Tet4Bundle),
            F(FaceBundle),
            FJ(FaceJointBundle),
            FC(FaceCellBundle),
        }
        let mut all: Vec<(Entity, Rec)> = Vec::new();
        all.extend(self.nodes.into_iter().map(|(e, b)| (e, Rec::N(b))));
        all.extend(self.elems.into_iter().map(|(e, b)| (e, Rec::E(b))));
        all.extend(self.edges.into_iter().map(|(e, b)| (e, Rec::D(b))));
        all.extend(self.cells.into_iter().map(|(e, b)| (e, Rec::C(b))));
        all.extend(self.joints.into_iter().map(|(e, b)| (e, Rec::J(b))));
        all.extend(self.bcs.into_iter().map(|(e, b)| (e, Rec::B(b))));
        all.extend(self.nodes3.into_iter().map(|(e, b)| (e, Rec::N3(b))));
        all.extend(self.tets.into_iter().map(|(e, b)| (e, Rec::T(b))));
        all.extend(self.faces.into_iter().map(|(e, b)| (e, Rec::F(b))));
        all.extend(self.face_joints.into_iter().map(|(e, b)| (e, Rec::FJ(b))));
        all.extend(self.face_cells.into_iter().map(|(e, b)| (e, Rec::FC(b))));
        all.sort_by_key(|(e, _)| e.id());
        if all.windows(2).any(|w| w[0].0.id() == w[1].0.id()) {
            return Err("two entities share a handle".into());
        }
        let mut world = hecs::World::new();
        for (e, rec) in all {
            match rec {
                Rec::N(b) => world.spawn_at(e, b),
                Rec::E(b) => world.spawn_at(e, b),
                Rec::D(b) => world.spawn_at(e, b),
                Rec::C(b) => world.spawn_at(e, b),
                Rec::J(b) => world.spawn_at(e, b),
                Rec::B(b) => world.spawn_at(e, b),
                Rec::N3(b) => world.spawn_at(e, b),
                Rec::T(b) => world.spawn_at(e, b),
                Rec::F(b) => world.spawn_at(e, b),
                Rec::FJ(b) => world.spawn_at(e, b),
                Rec::FC(b) => world.spawn_at(e, b),
            }
        }
        Ok(world)
    }
}

/// The model's id counters as a checkpoint keeps them: next node, element, edge (face), cell
/// and joint id.
pub fn next_ids(m: &Model) -> [u64; 5] {
    [
        m.next_node_id,
        m.next_elem_id,
        m.next_edge_id,
        m.next_cell_id,
        m.next_joint_id,
    ]
}

/// Put a checkpoint's world, topology generation and id counters into `m`.
pub fn take_world(
    m: &mut Model,
    world: WorldRecords,
    generation: u64,
    ids: [u64; 5],
) -> Result<(), String> {
    m.world = world.restore()?;
    m.topology_generation = generation;
    [
        m.next_node_id,
        m.next_elem_id,
        m.next_edge_id,
        m.next_cell_id,
        m.next_joint_id,
    ] = ids;
    Ok(())
}

/// FNV-1a, 64 bit.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Fingerprint of what determines the physics of a run: the scenario as parsed with its
/// overrides, less `name`, `description` and `output`, and the systems switched off on the
/// command line.
pub fn fingerprint(scenario: &Scenario, extra_disable: &[String]) -> u64 {
    let mut s = scenario.clone();
    s.name.clear();
    s.description.clear();
    s.output = Default::default();
    let text = serde_json::to_string(&(s, extra_disable)).expect("a scenario serialises");
    // Fields added since checkpoints existed leave the fingerprint of a scenario that does not
    // use them as it was, so its checkpoints stay readable.
    let text = text
        .replace(",\"selective_mass_scaling\":null", "")
        .replace(",\"transmissibility\":\"CellMean\"", "")
        .replace(",\"filling\":\"Dry\"", "")
        .replace(",\"inertia\":\"Off\"", "");
    fnv1a(text.as_bytes())
}

/// The file's bytes for `header` and `state`.
pub fn encode<E: Element>(header: &Header, state: &State<E>) -> Result<Vec<u8>, String> {
    let payload = postcard::to_stdvec(&(header, state)).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(payload.len() + 28);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    out.extend_from_slice(&fnv1a(&payload).to_le_bytes());
    Ok(out)
}

/// Read and check a checkpoint file (layout, version, hash); the scenario is checked by
/// [`check_scenario`].
pub fn read(path: &Path) -> Result<(Header, State), CheckpointError> {
    read_as::<Cst>(path)
}

/// [`read`] of a checkpoint of element kind `E` (a checkpoint of the other dimension is
/// refused).
pub fn read_as<E: Element>(path: &Path) -> Result<(Header, State<E>), CheckpointError> {
    let bytes = std::fs::read(path).map_err(|source| CheckpointError::Io {
        path: path.display().to_string(),
        source,
    })?;
    decode_as(&bytes).map_err(|why| refused(path, why))
}

/// [`read`] on bytes.
pub fn decode(bytes: &[u8]) -> Result<(Header, State), String> {
    decode_as::<Cst>(bytes)
}

/// [`read_as`] on bytes.
pub fn decode_as<E: Element>(bytes: &[u8]) -> Result<(Header, State<E>), String> {
    if bytes.len() < 8 || &bytes[..8] != MAGIC {
        return Err("not a hydrofrac checkpoint (no checkpoint header)".into());
    }
    if bytes.len() < 20 {
        return Err("truncated (the header is incomplete)".into());
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != FORMAT_VERSION {
        return Err(format!(
            "checkpoint format version {version}, this hydrofrac ({}) reads version \
             {FORMAT_VERSION} only",
            env!("CARGO_PKG_VERSION")
        ));
    }
    let n = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let have = bytes.len() as u64 - 20;
    if have != n.saturating_add(8) {
        return Err(format!(
            "truncated or corrupt: {have} bytes after the header, {} expected",
            n.saturating_add(8)
        ));
    }
    let n = n as usize;
    let payload = &bytes[20..20 + n];
    let hash = u64::from_le_bytes(bytes[20 + n..].try_into().expect("8 bytes"));
    if fnv1a(payload) != hash {
        return Err("corrupt: the content does not match its hash".into());
    }
    let (header, rest): (Header, &[u8]) =
        postcard::take_from_bytes(payload).map_err(|e| format!("corrupt: cannot decode ({e})"))?;
    if header.crate_version != env!("CARGO_PKG_VERSION") {
        return Err(format!(
            "written by hydrofrac {}, this is hydrofrac {}",
            header.crate_version,
            env!("CARGO_PKG_VERSION")
        ));
    }
    if header.dimension as usize != E::D {
        return Err(format!(
            "a {}D run's checkpoint; this scenario is {}D",
            header.dimension,
            E::D
        ));
    }
    let state: State<E> =
        postcard::from_bytes(rest).map_err(|e| format!("corrupt: cannot decode ({e})"))?;
    Ok((header, state))
}

/// Refuse a checkpoint written for another scenario (or other overrides or disabled systems).
pub fn check_scenario(
    path: &Path,
    header: &Header,
    scenario: &Scenario,
    extra_disable: &[String],
) -> Result<(), CheckpointError> {
    let fp = fingerprint(scenario, extra_disable);
    if header.fingerprint != fp {
        return Err(refused(
            path,
            format!(
                "written for scenario '{}' (fingerprint {:016x}), not for this one '{}' \
                 ({fp:016x}): the scenario, its --set overrides or its --disable list differ",
                header.scenario_name, header.fingerprint, scenario.name
            ),
        ));
    }
    Ok(())
}

/// What writing checkpoints cost this process.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct CheckpointStats {
    /// Checkpoints written, the step of the last one, its size (bytes) and the wall time of
    /// all of them (state capture, encoding and the atomic write), s.
    pub written: u64,
    pub last_step: Option<u64>,
    pub last_bytes: u64,
    pub seconds: f64,
}

/// When a checkpoint is due and its file written, for either element kind.
impl<E: Element> Simulation<E> {
    /// Whether `output.checkpoint_every` asks for a checkpoint after the step just taken (and
    /// moves the next due time on).
    pub(crate) fn checkpoint_due(&mut self) -> bool {
        use hydrofrac_core::scenario::CheckpointEvery;
        match self.params.output.checkpoint_every {
            None => false,
            Some(CheckpointEvery::Steps(n)) => self.clock.step.is_multiple_of(n),
            Some(CheckpointEvery::Time(t)) => {
                if self.clock.time < self.next_checkpoint_time {
                    return false;
                }
                self.next_checkpoint_time = ((self.clock.time / t).floor() + 1.0) * t;
                true
            }
        }
    }

    /// Write the checkpoint `bytes` into the output folder (`checkpoint.ckpt`, the one before
    /// renamed to `checkpoint.prev.ckpt`; both listed in the folder's manifest; each written
    /// atomically), counting the wall time since `t`. Without an output folder nothing is
    /// written. Returns the file.
    pub(crate) fn write_checkpoint_bytes(
        &mut self,
        bytes: &[u8],
        t: std::time::Instant,
    ) -> Result<Option<std::path::PathBuf>, RunError> {
        let Some(out) = self.output.as_ref() else {
            return Ok(None);
        };
        let path = out.claim(crate::checkpoint::FILE)?;
        let prev = out.claim(crate::checkpoint::PREV_FILE)?;
        if path.exists() {
            std::fs::rename(&path, &prev)?;
        }
        hydrofrac_core::output::write_atomic(&path, bytes)?;
        let c = &mut self.checkpoints;
        c.written += 1;
        c.last_step = Some(self.clock.step);
        c.last_bytes = bytes.len() as u64;
        c.seconds += t.elapsed().as_secs_f64();
        Ok(Some(path))
    }

    /// What writing checkpoints cost so far.
    pub fn checkpoint_stats(&self) -> CheckpointStats {
        self.checkpoints
    }
}

/// Checkpoints of a 2D simulation: the state taken and written, and a state taken over.
impl Simulation {
    /// The state between steps as a checkpoint ([`crate::checkpoint`]), read as it is in
    /// memory: nothing is synced, so taking it does not change the run.
    pub fn checkpoint_state(&self) -> Result<(Header, State), String> {
        let m = &self.model;
        let header = Header {
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            dimension: 2,
            scenario_name: self.scenario.name.clone(),
            fingerprint: crate::checkpoint::fingerprint(&self.scenario, &self.extra_disable),
            step: self.clock.step,
            time: self.clock.time,
        };
        let flow = self.flow.clone();
        let state = State {
            world: WorldRecords::capture(m)?,
            topology_generation: m.topology_generation,
            next_ids: next_ids(m),
            clock: self.clock.clone(),
            solid_view: self.solid.view.clone(),
            solid_stats: self.solid.stats,
            dt_crit: self.solid.dt_crit,
            qs_counts: self.solid.quasi_static.as_ref().map(|q| q.counts),
            flow,
            fracture: self.fracture.clone(),
            effort: self.effort,
            cells_at_start: self.cells_at_start,
            next_checkpoint_time: self.next_checkpoint_time,
            seismicity: self.seismicity.clone(),
        };
        Ok((header, state))
    }

    /// Continue from a checkpoint's state: this simulation must be freshly set up from the
    /// scenario the checkpoint was written for ([`crate::checkpoint::check_scenario`]).
    pub fn restore(&mut self, state: State) -> Result<(), String> {
        let qs = (state.qs_counts.is_some(), self.solid.quasi_static.is_some());
        if qs.0 != qs.1 {
            return Err("its flow network or solid scheme differs from this scenario's".into());
        }
        self.take_state(state)
    }

    /// Take over the model and the state of another run of the same model (the production
    /// stage starts from the end of a stimulation, `crate::production`): as
    /// [`Simulation::restore`], but the other run's solid scheme may differ from this one's;
    /// its step length and adaptive-step state are taken too and are for the caller to set.
    pub fn adopt(&mut self, state: State) -> Result<(), String> {
        self.take_state(state)
    }

    fn take_state(&mut self, state: State) -> Result<(), String> {
        let parts = (state.flow.is_some(), self.flow.is_some());
        if parts.0 != parts.1 {
            return Err("its flow network or solid scheme differs from this scenario's".into());
        }
        take_world(
            &mut self.model,
            state.world,
            state.topology_generation,
            state.next_ids,
        )?;
        self.clock = state.clock;
        self.solid.view = state.solid_view;
        self.solid.stats = state.solid_stats;
        self.solid.dt_crit = state.dt_crit;
        if let (Some(q), Some(c)) = (self.solid.quasi_static.as_mut(), state.qs_counts) {
            q.counts = c;
        }
        if let (Some(f), Some(mut s)) = (self.flow.as_mut(), state.flow) {
            if f.coupling.is_some() != s.coupling.is_some() {
                return Err("its coupling differs from this scenario's".into());
            }
            if f.implicit.is_some() != s.implicit.is_some() {
                return Err("its flow scheme differs from this scenario's".into());
            }
            // The network table is setup's, not saved.
            s.network = std::mem::take(&mut f.network);
            *f = s;
        }
        self.fracture = state.fracture;
        self.fracture.tips.invalidate();
        if self.solid.quasi_static.is_none() {
            self.fracture.screen.track_motion(&mut self.solid.view);
        }
        self.effort = state.effort;
        self.cells_at_start = state.cells_at_start;
        self.next_checkpoint_time = state.next_checkpoint_time;
        self.seismicity = state.seismicity;
        let has_load = self.solid.view.has_load();
        self.schedule.set_data(SystemId::ExternalLoad, has_load);
        Ok(())
    }

    /// Write a checkpoint of the state now into the output folder (`checkpoint.ckpt`, the one
    /// before renamed to `checkpoint.prev.ckpt`; both listed in the folder's manifest; each
    /// written atomically). Without an output folder nothing is written. Returns the file.
    pub fn write_checkpoint(&mut self) -> Result<Option<std::path::PathBuf>, RunError> {
        if self.output.is_none() {
            return Ok(None);
        }
        let t = std::time::Instant::now();
        let (header, state) = self
            .checkpoint_state()
            .map_err(|e| RunError::Io(std::io::Error::other(format!("checkpoint: {e}"))))?;
        let bytes = crate::checkpoint::encode(&header, &state)
            .map_err(|e| RunError::Io(std::io::Error::other(format!("checkpoint: {e}"))))?;
        self.write_checkpoint_bytes(&bytes, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hydrofrac_core::mesh::TriMesh;
    use hydrofrac_core::scenario::Material;

    /// A component given to an entity but missing from its bundle would not be saved: capture
    /// refuses the world, so a new state component cannot be lost silently on restart.
    #[test]
    fn a_component_outside_the_bundles_is_refused() {
        let mesh = TriMesh::regular(2.0, 2.0, 1.0, [0.0, 0.0]).unwrap();
        let rock = Material {
            young: 20e9,
            poisson: 0.2,
            density: 2700.0,
        };
        let mut m = Model::from_mesh(&mesh, rock).unwrap();
        let r = WorldRecords::capture(&m).unwrap();
        assert_eq!(r.nodes.len(), m.node_count());
        let world = r.restore().unwrap();
        assert_eq!(world.len(), m.world.len());
        struct NewField(#[allow(dead_code)] f64);
        let node = m
            .world
            .query::<(Entity, &NodeState)>()
            .iter()
            .next()
            .unwrap()
            .0;
        m.world.insert_one(node, NewField(1.0)).unwrap();
        let err = WorldRecords::capture(&m).unwrap_err();
        assert!(err.contains("not a checkpoint bundle"), "{err}");
    }
}
