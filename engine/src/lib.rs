//! hydrofrac-engine: a simulation from a validated scenario. Setup builds the model, its views
//! and the schedule (`setup`, `schedule`); `sim::Simulation` owns the state and runs the step,
//! the literal list of `hydrofrac_systems::SystemId::ORDER`; `checkpoint` writes and reads the
//! state between steps. It uses `hydrofrac-core` and `hydrofrac-systems`, never the driver or
//! the CLI above it.

#![allow(clippy::needless_range_loop)]

pub mod checkpoint;
pub mod schedule;
pub mod setup;
pub mod sim;
pub mod sim3;
