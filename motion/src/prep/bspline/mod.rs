//! The weighted B-spline method (Haas 2012, §4.6–4.8): instead of a quintic Hermite piece
//! between each pair of QP points, one quintic B-spline per window is fitted by weighted least
//! squares to the points' positions and parametric derivatives, and the spans of its committed
//! part become the emitted pieces.
//!
//! - **Knots** sit at the QP points (the breakpoints are the points' τ = s / point_spacing_mm),
//!   inner knots of multiplicity `bspline_knot_multiplicity` m: the spline is C^(5 − m) there
//!   (m = 1: C⁴, Haas's spline). With one knot span per pair of points, span j of the spline
//!   lies where Hermite piece j would, so the stage's check, refinement (a point inserted is a
//!   knot inserted) and fallbacks work on the spans unchanged. The point distribution is the
//!   stage's (`points.rs`): equidistant at ≤ `point_spacing_mm` as Haas 2012, §4.8 finally
//!   uses, denser only towards corners.
//! - **Weights** per derivative order (`bspline_weights`, Haas 2012, §4.6: x 1000, x′ 100,
//!   x″ 10, x‴ 1), applied to the derivatives in τ as the QP produces them; the data are the
//!   QP's levels (continuity degree + 1 of them).
//! - **Windows chain**: the left end's first 6 − m derivatives are fixed to the state the
//!   previous window's spline ends with at its committed point, so consecutive windows join
//!   C^(5 − m); the right end is fixed as the QP's (position, or the programmed state where a
//!   G61 element continues tangentially, C² there).
//! - **Solve**: the normal equations are banded (half-bandwidth 5) and solved by a banded
//!   Cholesky factorisation (`banded.rs`), factorised once per window and shared by the axes.
//! - **Pieces**: each span is a quintic polynomial, exactly the quintic Hermite piece of its
//!   own x, x′, x″ at both ends, so it becomes a [`QuinticSpan`] the planner already takes.

pub(crate) mod banded;
pub(crate) mod basis;
pub(crate) mod fit;

/// Gains on the position weight for a window whose spline leaves the band at the configured
/// weights after the refinements: the least-squares fit moves towards interpolating the QP's
/// points, which keep the band, before the window falls back to Hermite pieces.
pub(super) const TIGHTEN_GAINS: [f64; 2] = [1e2, 1e4];

use super::settings::StageSettings;
use super::window::{RightEnd, State};
use crate::path::{HermiteEnd, MAX_AXES, QuinticSpan};
pub(super) use fit::BasisCache;
use fit::{CachedPoints, Curve, Fit, FitError, LEVELS, PIECE_LEVELS};

/// Why a window has no B-spline pieces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SplineFailure {
    Fit(FitError),
    /// Span j is degenerate (a vanishing tangent).
    Span(usize),
}

/// The spline's spans between `u[0..=commit]` and its state at `u[commit]`.
pub(super) struct SplinePieces {
    pub pieces: Vec<QuinticSpan>,
    pub end: State,
    /// Levels of `end` that the next window keeps (the spline's continuity + 1).
    pub levels: usize,
}

/// One window's data for the spline: the QP solution `states` at breakpoints `u` (in τ), from
/// `left` (its first `left_levels` levels fixed) to the end `right` demands, committed up to
/// point `commit`.
pub(super) struct SplineWindow<'a> {
    pub u: &'a [f64],
    /// The points' s (mm): their names for the basis cache.
    pub s_mm: &'a [f64],
    pub states: &'a [State],
    pub left: &'a State,
    pub left_levels: usize,
    pub right: RightEnd,
    pub commit: usize,
}

/// The window's spline, fitted with `weights` per level, and its committed pieces; `cache`
/// holds the basis values of the last fit's points (see [`BasisCache`]).
pub(super) fn window_pieces(
    st: &StageSettings,
    w: &SplineWindow,
    weights: [f64; LEVELS],
    cache: &mut BasisCache,
) -> Result<SplinePieces, SplineFailure> {
    let SplineWindow { u, s_mm, states, left, left_levels, right, commit } = *w;
    let n = u.len();
    let m = st.bspline_multiplicity;
    let keep = (basis::DEGREE + 1 - m).min(LEVELS);
    let fixed_left = left_levels.min(keep);
    let fixed_right = match right {
        RightEnd::Position => 1,
        RightEnd::Band => 0,
        RightEnd::Join(_) => 3,
    };
    let cached = CachedPoints { keys: s_mm, cache };
    let fit = Fit::new(u, cached, m, st.levels, weights, fixed_left, fixed_right).map_err(SplineFailure::Fit)?;
    let mut curves: Vec<Option<Curve>> = Vec::with_capacity(MAX_AXES);
    let mut data = vec![[0.0; LEVELS]; n];
    for k in 0..MAX_AXES {
        // An axis that does not move in the window stays where it is (no solve).
        let x0 = states[0][k][0];
        let still = states.iter().all(|s| s[k][0] == x0 && s[k][1..].iter().all(|&v| v == 0.0))
            && left[k][0] == x0
            && left[k][1..].iter().all(|&v| v == 0.0);
        if still {
            curves.push(None);
            continue;
        }
        for (d, s) in data.iter_mut().zip(states) {
            *d = s[k];
        }
        let right_k = match right {
            RightEnd::Join(s) => s[k],
            _ => states[n - 1][k],
        };
        curves.push(Some(fit.solve(&data, &left[k], &right_k)));
    }
    // The spline's x, x′, x″ at each point up to the committed one, from the basis values the
    // fit holds there: the pieces' ends, which the spline has continuous at every breakpoint
    // (m ≤ 3).
    let at: Vec<[[f64; PIECE_LEVELS]; MAX_AXES]> = (0..=commit)
        .map(|j| {
            std::array::from_fn(|k| match &curves[k] {
                Some(c) => fit.piece_end(c, j),
                None => [states[0][k][0], 0.0, 0.0],
            })
        })
        .collect();
    // The state at the committed point, all levels (the next window keeps those up to the
    // continuity, which are the same from either side).
    let end = if commit == 0 {
        *left
    } else {
        let basis = fit.state_basis(commit);
        std::array::from_fn(|k| match &curves[k] {
            Some(c) => fit.state(c, &basis),
            None => {
                let mut v = [0.0; LEVELS];
                v[0] = states[0][k][0];
                v
            }
        })
    };
    fit.into_cache(cache);
    let mut pieces = Vec::with_capacity(commit);
    for j in 0..commit {
        let d = u[j + 1] - u[j];
        let end = |s: &[[f64; PIECE_LEVELS]; MAX_AXES]| {
            let mut e = HermiteEnd::default();
            for k in 0..MAX_AXES {
                e.pos[k] = s[k][0];
                e.d1[k] = d * s[k][1];
                e.d2[k] = d * d * s[k][2];
            }
            e
        };
        pieces.push(
            QuinticSpan::hermite(&end(&at[j]), &end(&at[j + 1]), &st.linear).map_err(|_| SplineFailure::Span(j))?,
        );
    }
    Ok(SplinePieces { pieces, end, levels: keep })
}
