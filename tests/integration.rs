//! Every integration test file in one test binary (`[[test]] integration` in Cargo.toml): one
//! link and one copy of the engine's generic code instead of one per file, and the test threads
//! share out the long tests (CI runs on 2 cores). Each file stays a module under its own name:
//! `cargo test --release --test integration friction::` runs one file's tests.
//!
//! Three files keep their own binaries: `heat_timing.rs` (tracing caches each callsite's interest
//! process-wide), `fuzz_scenarios.rs` (it replaces the process's panic hook while it runs) and
//! `memory_estimate.rs` (it reads the peak memory of every child the process waited for).

mod bad_inputs;
mod boundary_conditions;
mod checkpoint;
mod cli;
mod conforming;
mod coupled_poisson_limit;
mod coupling;
mod determinism;
mod doc_links;
mod example1;
mod example2;
mod flow3d;
mod flow_implicit;
mod flow_scenarios;
mod flow_substep_bound;
mod flow_verification;
mod fracture3d;
mod fracture_criterion;
mod fracturing;
mod friction;
mod gmsh_import;
mod heat_continuum;
mod heat_discrete;
mod kgd;
mod output_neutral;
mod pipeline;
mod production;
mod quasi_static;
mod quasi_static_coupled;
mod quasi_static_lu;
mod reference_kernel;
mod reliability;
mod reservoir_verification;
mod residuals;
mod rock_network;
mod seismicity;
mod shear_crack;
mod sneddon;
mod solid_verification;
mod split;
mod split3d;
mod sweep;
mod tet_solid;
mod three_d;
mod toughness;
mod vtk_output;

// The test support, once for every file (each file: `use crate::support_cli as cli;`).
#[path = "support/bits.rs"]
mod support_bits;
#[path = "support/cli.rs"]
mod support_cli;
#[path = "support/finite.rs"]
mod support_finite;
#[path = "support/geometry.rs"]
mod support_geometry;
#[path = "support/scenes.rs"]
mod support_scenes;
#[path = "support/vtu.rs"]
mod support_vtu;
