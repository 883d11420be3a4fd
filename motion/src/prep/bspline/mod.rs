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

/// Points past the committed one that a window's fit takes; the rest of the window is left
/// out. A weighted least-squares spline's value at a knot depends on the data k knots away by
/// a factor that falls geometrically with k (on average 10× every 5 knots at Haas's weights
/// and C⁴, faster with more multiple knots or the positions weighted more), so the spans up
/// to the committed point of a fit over this many points more differ from those of the fit
/// over the whole window by about 1e-6 of the data's misfit (`fit.rs`, test
/// `committed_spans_do_not_see_the_data_beyond_the_margin`: at most 1.2e-8 on a misfit of
/// 0.01), a fraction of a nanometre at the tolerances the band check resolves (µm). The
/// fit's cost is then that of the committed part and the margin, not of the whole window:
/// on windows that commit 10 of 50 points (1 point/mm) the fit takes about 31 points, not
/// 50. The next window fits the points past the margin.
pub(super) const FIT_MARGIN_POINTS: usize = 20;

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
    // The points the fit takes: up to the margin past the committed one; a window cut there
    // has a free right end (its own end conditions act on points the fit leaves out).
    let n = u.len().min(commit + 1 + FIT_MARGIN_POINTS);
    let (u, s_mm, states) = (&u[..n], &s_mm[..n], &states[..n]);
    let cut = n < w.u.len();
    let m = st.bspline_multiplicity;
    let keep = (basis::DEGREE + 1 - m).min(LEVELS);
    let fixed_left = left_levels.min(keep);
    let fixed_right = match right {
        _ if cut => 0,
        RightEnd::Position => 1,
        RightEnd::Band => 0,
        RightEnd::Join(_) => 3,
    };
    let cached = CachedPoints { keys: s_mm, cache };
    let fit = Fit::new(u, cached, m, st.levels, weights, fixed_left, fixed_right).map_err(SplineFailure::Fit)?;
    // An axis that does not move in the window stays where it is (no solve).
    let moving: Vec<usize> = (0..MAX_AXES)
        .filter(|&k| {
            let x0 = states[0][k][0];
            let still = |s: &State| s[k][0] == x0 && s[k][1..].iter().all(|&v| v == 0.0);
            !(still(left) && states.iter().all(still))
        })
        .collect();
    let right_state = match right {
        RightEnd::Join(s) if !cut => s,
        _ => states[n - 1],
    };
    let mut solved = fit.solve(states, &moving, left, &right_state).into_iter();
    let mut curves: [Option<Curve>; MAX_AXES] = Default::default();
    for &k in &moving {
        curves[k] = solved.next();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Settings;

    /// A window of `n` points 1 apart in τ (`h` mm) on a circle of radius 40 h in X–Y, with
    /// x … x⁗ in τ of the circle at each point.
    fn circle_states(n: usize, h: f64) -> (Vec<f64>, Vec<State>) {
        let u: Vec<f64> = (0..n).map(|j| j as f64).collect();
        let r = 40.0 * h;
        let states = u
            .iter()
            .map(|&t| {
                let (sin, cos) = (t * h / r).sin_cos();
                let (h2, h3, h4) = (h * h / r, h.powi(3) / (r * r), h.powi(4) / r.powi(3));
                let mut s = [[0.0; LEVELS]; MAX_AXES];
                s[0] = [r * cos, -h * sin, -h2 * cos, h3 * sin, h4 * cos];
                s[1] = [r * sin, h * cos, -h2 * sin, -h3 * cos, h4 * sin];
                s
            })
            .collect();
        (u, states)
    }

    #[test]
    fn a_window_is_fitted_up_to_the_margin_past_its_committed_point() {
        let machine = include_str!("../../../../config/machines/xyz.toml");
        let settings = Settings::from_toml_str(&format!("{machine}\n[prep]\nmethod = \"bspline\"\n"), "xyz.toml")
            .expect("machine file");
        let st = StageSettings::new(&settings);
        let (n, commit) = (200, 42);
        let (u, states) = circle_states(n, st.spacing_mm);
        let s_mm: Vec<f64> = u.iter().map(|t| t * st.spacing_mm).collect();
        let window = SplineWindow {
            u: &u,
            s_mm: &s_mm,
            states: &states,
            left: &states[0],
            left_levels: LEVELS,
            right: RightEnd::Position,
            commit,
        };
        let mut cache = BasisCache::default();
        let sp = window_pieces(&st, &window, st.bspline_weights, &mut cache).expect("a spline");
        assert_eq!(sp.pieces.len(), commit);
        // The cache holds the fit's points: the committed ones and the margin, not the window.
        assert_eq!(cache.len(), commit + 1 + FIT_MARGIN_POINTS);
        // The circle is a smooth curve, so the spline reproduces it closely at every point.
        for (j, p) in sp.pieces.iter().enumerate() {
            let len = p.length_mm();
            let want = (u[j + 1] - u[j]) * st.spacing_mm;
            assert!((len - want).abs() < 1e-4 * want, "piece {j}: {len} mm against {want} mm");
        }
        // The window's end conditions act only where the fit reaches them: a whole-window
        // fit (commit at the end) still takes all points.
        let whole = SplineWindow { commit: n - 1, ..window };
        let mut cache = BasisCache::default();
        window_pieces(&st, &whole, st.bspline_weights, &mut cache).expect("a spline");
        assert_eq!(cache.len(), n);
    }
}
