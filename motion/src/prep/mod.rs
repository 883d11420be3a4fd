//! Tolerance-band path smoothing after Haas 2012: the prep stage between path and planner.
//!
//! `G64 P`*tol* elements are smoothed so that corners and the breaks of short CAM segments are
//! passed without stopping, within *tol* of the programmed path: `points` places points along
//! the path (§3.5, §4.8) → `window` solves, per axis, the QP of `qp` (positions and parametric
//! derivatives, trapezoid coupling, the band of `band`; §3.3, eq. 3.8–3.12) over a window of
//! segments (windowing III, §3.6.3) → `pieces` joins the committed points by quintic Hermite
//! pieces (C², §4.5) → `verify` checks them against the programmed path → [`Prep`] emits them
//! as path elements. The stage is a plain object that the planner thread (or a thread of its
//! own) feeds element by element; it never touches the interpolation thread. See
//! `docs/smoothing.md`.

// Axis loops index several per-axis arrays at once; an index reads clearer than zips there.
#![allow(clippy::needless_range_loop)]

mod band;
mod bspline;
mod condition;
mod elements;
mod pieces;
mod points;
mod programmed;
mod qp;
mod qp_banded;
mod qp_shape;
mod run;
mod settings;
mod simplify;
mod stage;
mod stats;
mod verify;
mod window;

pub(crate) use stage::Prep;
pub use stage::{PrepError, PrepFailure};
pub use stats::PrepStats;

use crate::Settings;
use crate::path::Path;
use std::time::Instant;

/// A whole path after the stage.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub path: Path,
    pub stats: PrepStats,
    /// Wall time spent in the stage, s.
    pub wall_s: f64,
}

/// Streams a whole path through the stage (a path made whole, such as MDI blocks; a program
/// of any length goes through it in a [`crate::Feed`]). A path without G64 elements comes back
/// unchanged.
pub fn prepare_path(settings: &Settings, path: &Path) -> Result<Prepared, PrepError> {
    let t0 = Instant::now();
    if !path.elements.iter().any(|e| matches!(e.blend, crate::path::Blend::Tolerance { .. })) {
        return Ok(Prepared { path: path.clone(), stats: PrepStats::default(), wall_s: 0.0 });
    }
    let mut prep = Prep::new(settings);
    let mut out = Path::new(path.axis_names.clone(), path.start);
    out.final_dwell_s = path.final_dwell_s;
    for e in &path.elements {
        prep.push(e.clone())?;
        while let Some(x) = prep.pop() {
            out.elements.push(x);
        }
    }
    prep.finish()?;
    while let Some(x) = prep.pop() {
        out.elements.push(x);
    }
    Ok(Prepared { path: out, stats: prep.stats, wall_s: t0.elapsed().as_secs_f64() })
}
