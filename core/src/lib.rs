//! hydrofrac-core: what the systems work on. The scenario (input, validated), meshes and
//! fracture networks, the ECS model and its topology operations (node splitting), the dense
//! views the hot loops run on, the element and flow numerics, the run parameters, the output
//! writers and the reservoir models. SI units throughout, tension positive, plane strain per
//! unit thickness.
//!
//! Layers inside this crate, lowest first (a module uses its own layer or below): utilities
//! (`atomic`, `union_find`, `error`, `timing`, `plot`); input (`scenario`, `mesh`, `gmsh`,
//! `network`, `snap`, `conforming`, `resources`); the model (`model`, `split`, `fractures`);
//! views and numerics (`view`, `element`, `stability`, `sparse`, `params`, `flow`, `output`,
//! `reservoir`). The crates above it are `hydrofrac-systems`, `hydrofrac-engine` and
//! `hydrofrac`; the compiler forbids this crate from using them.

// Index loops over the 2 components of a vector or the 3 nodes of a triangle read like the
// equations they implement.
#![allow(clippy::needless_range_loop)]

pub mod atomic;
pub mod conforming;
pub mod dim;
pub mod element;
pub mod error;
pub mod flow;
pub mod fractures;
pub mod gmsh;
pub mod mesh;
pub mod model;
pub mod model3;
pub mod network;
pub mod output;
pub mod params;
pub mod plot;
pub mod reservoir;
pub mod resources;
pub mod scenario;
pub mod snap;
pub mod sparse;
pub mod split;
pub mod split3;
pub mod stability;
pub mod static_lu;
pub mod tet4;
pub mod tetmesh;
pub mod timing;
pub mod union_find;
pub mod view;
