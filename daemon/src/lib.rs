//! interpd: a real-time interpolator daemon. A part program comes in over the control socket;
//! jerk-limited axis setpoints go out every cycle, to shared memory and CAN drives.
//!
//! - [`service`]: the running service: its threads, the state machine the control API drives,
//!   the planner thread that feeds the real-time thread;
//! - [`interp`]: the two-stage fine interpolation and the real-time contract between the
//!   planner thread and the executor;
//! - [`control`]: the JSON-RPC control socket;
//! - [`sinks`]: where setpoints go: iceoryx2 shared memory, the CANopen master;
//! - [`record`]: recording the streams to MCAP and replaying them;
//! - [`rt`]: the real-time loop, clock, scheduling and timing statistics;
//! - [`plan`]: a program planned offline and sampled in simulated time (`plan`), with an
//!   in-process observer of the samples (`interpd-sim` runs the simulated plant on them);
//! - [`demo`]: the daemon and the simulated plant as two processes on one program (`demo`);
//! - [`cmdline`]: what the command lines of `interpd` and `interpd-sim` share.
//!
//! The motion mathematics (programs, paths, smoothing, the look-ahead planner, motion laws) is
//! the crate `interpd-motion`; the configuration is `interpd-config`; the wire formats are
//! `interpd-protocol`. docs/architecture.md shows how they fit together.

pub mod cmdline;
pub mod comp;
pub mod control;
pub mod demo;
pub mod interp;
pub mod plan;
pub mod record;
pub mod rt;
pub mod service;
pub mod sinks;

pub use interpd_config as config;
pub use interpd_otg as otg;
