//! interpd's motion library: from a part program to a jerk-limited path-velocity profile.
//!
//! ```text
//! program text ──► program ──► path ──► prep ──► planner ──► Vec<Segment>
//!                  parse,      A(s) …    tolerance  look-ahead   s(t): constant path jerk
//!                  errors with A‴(s)     smoothing  feedrate     per piece, every axis
//!                  line:col    per axis  (G64 P)    profile      limit kept
//! ```
//!
//! - [`program`] parses G-code (with G06 spline blocks, Huan) and path tables into a
//!   [`path::Path`]; errors keep line and column as data.
//! - [`path`] holds the geometry elements and evaluates, per axis k, A_k(s) … A‴_k(s) over
//!   the path length s.
//! - [`prep`] smooths G64 runs within their tolerance (per-axis QP over a sliding window,
//!   Haas 2012) and emits quintic pieces.
//! - [`planner`] plans the path velocity online under axis velocity, acceleration and jerk
//!   limits (Kopp et al. 2019) and hands on [`planner::Segment`]s; [`planner::brake`] gives
//!   the fastest stop from any planned state.
//! - [`law`] designs motion laws from interpolation conditions (Bewegungsdesign nach Maß,
//!   VDI 2143) and runs them as synchronised axis moves.
//!
//! The papers are cited by author and year with their own equation, section and table
//! numbers; `docs/references.md` lists them.
//!
//! Everything takes a [`Settings`]: the machine's axes with their limits and the planner and
//! smoothing settings, built from a machine file with [`Settings::from_config`] or by hand.
//! The crate does no I/O beyond reading a program file ([`program::load`]) and starts no
//! threads; the interpd daemon runs it in its look-ahead thread.
//!
//! ```no_run
//! use interpd_motion::{Settings, planner::Planner, program};
//!
//! let settings = Settings::default_machine();
//! let program = program::load(std::path::Path::new("examples/circle_r10.ngc"), &settings)
//!     .expect("the program parses");
//! let (segments, _stats) = Planner::plan_path(&settings, &program.path).expect("it plans");
//! println!("{:.4} s", interpd_motion::planner::profile::duration_s(&segments));
//! ```

#![warn(unreachable_pub)]

pub mod law;
pub mod path;
pub mod planner;
pub mod prep;
pub mod program;
mod settings;

pub use interpd_config as config;
pub use settings::Settings;
