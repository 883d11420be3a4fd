//! interpd's motion library: from a part program to a jerk-limited path-velocity profile.
//!
//! ```text
//!                ┌──────────────────────────── Feed ─────────────────────────────┐
//! program text ──► program ──► path ──► prep ──► planner ──► Segments in time order
//!                  parse,      A(s) …    tolerance  look-ahead   s(t): constant path jerk
//!                  errors with A‴(s)     smoothing  feedrate     per piece, every axis
//!                  line:col    per axis  (G64 P)    profile      limit kept
//! ```
//!
//! [`Feed`] is the front door: it reads a program (a file, text, text appended while it runs,
//! or a path made whole), smooths it and plans it ahead of the machine, hands out the planned
//! [`Segment`]s in time order and drops the path behind the machine, so memory grows with the
//! look-ahead, never with the program. It replans from any planned state (a feed override, a
//! restart from rest) and gives the fastest stop from any planned state. The interpd daemon's
//! look-ahead thread, `interpd plan` and `examples/plan_program.rs` all plan through it.
//!
//! A G64 program through smoothing and planning:
//!
//! ```
//! use interpd_motion::{Feed, Settings};
//!
//! let settings = Settings::default_machine();
//! let square = "G21 G90 G64 P0.01\nG1 X20 F3000\nY20\nX0\nY0\nM30\n";
//! let mut feed = Feed::builder(&settings).open_text("square.ngc", square)?;
//! let mut motion_s = 0.0;
//! while !feed.finished() {
//!     feed.plan(0.5)?; // at least 0.5 s of motion planned ahead
//!     while let Some(segment) = feed.pop_segment() {
//!         motion_s += segment.dt_s; // s(t) with constant path jerk: segment.at(τ)
//!     }
//! }
//! assert!(feed.stats().prep.pieces > 0, "the corners are smoothed, not stopped at");
//! println!("{motion_s:.3} s of motion");
//! # Ok::<(), interpd_motion::FeedError>(())
//! ```
//!
//! The stages behind it, each usable on its own:
//!
//! - [`program`] parses G-code (with G06 spline blocks, Huan) and path tables into a
//!   [`path::Path`]; errors keep file, line and column as data ([`program::ProgramErrors`]).
//! - [`path`] holds the geometry elements and evaluates, per axis k, A_k(s) … A‴_k(s) over
//!   the path length s.
//! - [`prep`] smooths G64 runs within their tolerance (per-axis QP over a sliding window,
//!   Haas 2012) and emits quintic pieces.
//! - [`planner`] plans the path velocity online under axis velocity, acceleration and jerk
//!   limits (Kopp et al. 2019); its [`planner::profile`] is the planned motion s(t).
//! - [`law`] designs motion laws from interpolation conditions (Bewegungsdesign nach Maß,
//!   VDI 2143) and runs them as synchronised axis moves.
//!
//! The papers are cited by author and year with their own equation, section and table
//! numbers; `docs/references.md` lists them.
//!
//! Everything takes a [`Settings`]: the machine's axes with their limits and the planner and
//! smoothing settings, built from a machine file with [`Settings::from_config`] or by hand.
//! The crate does no I/O beyond reading a program file and starts no threads; the interpd
//! daemon runs it in its look-ahead thread.

#![warn(unreachable_pub)]

pub mod feed;
pub mod law;
pub mod path;
pub mod planner;
pub mod prep;
pub mod program;
mod settings;

pub use feed::{Feed, FeedError};
pub use interpd_config as config;
pub use planner::{Planner, Segment};
pub use program::Program;
pub use settings::Settings;
