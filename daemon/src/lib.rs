//! interpd: a real-time interpolator daemon.
//!
//! Data flow (see DESIGN.md): part program → [`program`] (parse) → [`path`] (geometry A(s) …
//! A‴(s)) → prep (tolerance smoothing) → planner (look-ahead feedrate profile) → interp (fine
//! interpolation every cycle) → sinks (shared memory, CAN) → drives / sim-plant.

pub mod control;
pub mod interp;
pub mod record;
pub mod rt;
pub mod service;
pub mod sinks;

pub use interpd_config as config;
pub use interpd_otg as otg;
