//! hydrofrac: explicit FEM rock mass, fracture-network flow and hydraulic fracturing in hard
//! rock, after Fu, Johnson and Carrigan (LLNL). SI units throughout, tension positive,
//! plane strain per unit thickness.
//!
//! Layout: `components/` holds the ECS components, `systems/` the step's systems and their
//! order; `src/` the mesh, model, dense views, scenario files, outputs, verification and CLI.

// Index loops over the 2 components of a vector or the 3 nodes of a triangle read like the
// equations they implement.
#![allow(clippy::needless_range_loop)]

#[path = "../components/mod.rs"]
pub mod components;
#[path = "../systems/mod.rs"]
pub mod systems;

pub mod atomic;
pub mod checkpoint;
pub mod conforming;
pub mod driver;
pub mod element;
pub mod error;
pub mod flow;
pub mod fractures;
pub mod gmsh;
pub mod mesh;
pub mod model;
pub mod network;
pub mod output;
pub mod params;
pub mod pipeline;
pub mod plot;
pub mod production;
pub mod reference;
pub mod reservoir;
pub mod resources;
pub mod scenario;
pub mod schedule;
pub mod setup;
pub mod sim;
pub mod snap;
pub mod sparse;
pub mod split;
pub mod stability;
pub mod timing;
pub mod union_find;
pub mod verify;
pub mod view;
