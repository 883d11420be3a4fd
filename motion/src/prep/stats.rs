//! Counters and timings of the smoothing stage, for logs, `interpd plan --json` and the bench.

use serde::Serialize;

/// Totals over a preparation run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct PrepStats {
    /// Programmed elements taken.
    pub moves_in: u64,
    /// Programmed moves merged into a chord with their neighbours (rounding zig-zags,
    /// near-zero moves, near-collinear runs; `condition.rs`).
    pub moves_merged: u64,
    /// Chords that replace more than one programmed move.
    pub chords: u64,
    /// Largest distance of a merged vertex to its chord, mm.
    pub merge_deviation_mm: f64,
    /// Runs of G64 elements smoothed.
    pub runs: u64,
    /// Window solves that were committed (after any retries).
    pub windows: u64,
    /// Solve attempts, including retries and fallbacks.
    pub solves: u64,
    pub points: u64,
    /// Smoothed pieces emitted.
    pub pieces: u64,
    /// Programmed path length that went through the smoothing, mm.
    pub smoothed_mm: f64,
    /// Wall time in window solves (all axes, all attempts), s.
    pub solve_s_total: f64,
    /// Slowest single window solve (all axes), s.
    pub solve_s_max: f64,
    pub iterations: u64,
    /// Re-solves with a narrower band after the check found a piece outside the tolerance.
    pub verify_retries: u64,
    /// Re-solves with a point inserted halfway along a piece that left the band.
    pub refined: u64,
    /// Fallback: a smaller window.
    pub fallback_smaller: u64,
    /// Fallback: the window's end only kept in its band.
    pub fallback_looser: u64,
    /// Fallback: exact stop and the programmed path.
    pub fallback_exact: u64,
    /// Solver outcomes that caused a fallback.
    pub infeasible: u64,
    pub slow: u64,
    pub numerical: u64,
    /// Axis solves the banded QP method declined and Clarabel took (`prep.qp_solver`).
    pub qp_declined: u64,
    /// Axis solves Clarabel made no progress on with its fast settings and solved again with
    /// iterative refinement.
    pub qp_refined_steps: u64,
    /// Window solves that failed numerically and were solved again in a parameter scaled to
    /// the window's own point spacing.
    pub qp_rescaled: u64,
    /// B-spline method: windows committed as spline spans.
    pub bspline_windows: u64,
    /// B-spline method: windows whose spline could not be fitted or left the band after the
    /// refinements, committed as Hermite pieces instead.
    pub bspline_to_hermite: u64,
    /// B-spline method: windows whose spline at `bspline_weights` left the band after the
    /// refinements and kept it fitted with the positions weighted more.
    pub bspline_tightened: u64,
    /// Largest distance of a checked sample to the programmed path, mm.
    pub max_deviation_mm: f64,
    /// Largest (distance − tolerance) over the checked samples, mm (≤ 0: inside).
    pub max_excess_mm: f64,
}

impl PrepStats {
    /// Mean wall time per solve attempt, s.
    pub fn solve_s_mean(&self) -> f64 {
        if self.solves == 0 { 0.0 } else { self.solve_s_total / self.solves as f64 }
    }
}
