//! hydrofrac: explicit FEM rock mass, fracture-network flow and hydraulic fracturing in hard
//! rock, after Fu, Johnson and Carrigan (LLNL). SI units throughout, tension positive,
//! plane strain per unit thickness.
//!
//! The workspace's crates are its layers, lowest first; each may use only those below it:
//! - `hydrofrac-components` (`components/`): the ECS components;
//! - `hydrofrac-core` (`core/`): scenario input, meshes, the model, views, numerics, output
//!   writers, the reservoir models;
//! - `hydrofrac-systems` (`systems/`): the step's systems and their order;
//! - `hydrofrac-engine` (`engine/`): setup, the schedule, the step loop, checkpoints;
//! - this crate (`src/`): the driver of `hydrofrac run` and its production stage, the
//!   reservoir pipeline, ensembles (`hydrofrac sweep`), verification, reference kernels and
//!   the CLI.
//!
//! This crate re-exports the modules of the crates below under one name, so a user (and the
//! tests) write `hydrofrac::scenario::Scenario` whatever crate holds it.

#![allow(clippy::needless_range_loop)]

pub use hydrofrac_components as components;
pub use hydrofrac_core::{
    atomic, conforming, dim, element, error, flow, fractures, gmsh, mesh, model, model3, network,
    output, params, plot, reservoir, resources, scenario, snap, sparse, split, split3, stability,
    static_lu, tet4, tetmesh, timing, union_find, view,
};
pub use hydrofrac_engine::{checkpoint, schedule, setup, sim, sim3};
pub use hydrofrac_systems as systems;

pub mod catalogue;
pub mod driver;
pub mod driver3;
pub mod pipeline;
pub mod production_stage;
pub mod reference;
pub mod sweep;
pub mod verify;
