//! interpd-sim: the simulated plant (`sim-plant`) in-process with interpd's planning, so that
//! the daemon binary links no simulator. `interpd` hands it the commands that need it, with
//! their arguments as they are: `plan --plant` and `demo --scenario milling-circle`.
//!
//! - [`plant_run`]: the plant as the observer of `interpd::plan`'s samples (`plan --plant`);
//! - [`scenario`]: the `[compensation]` section the milling scenario runs per strategy, on the
//!   deflection model a static load test on the plant identified.
//!
//! The command line is `main.rs` with `cli/`.

pub mod plant_run;
pub mod scenario;
