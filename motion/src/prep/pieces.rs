//! Quintic Hermite pieces from the smoothed points (Haas 2012, §4.5, eq. 4.17–4.21: one quintic
//! per pair of consecutive points from position, first and second derivative at both ends), and
//! the exact re-interpolation of programmed elements that the exact-stop fallback emits. The
//! pieces use the closed-form Hermite basis on the local t ∈ [0, 1] with the derivatives scaled
//! by the interval, which avoids the ill-conditioned monomial solve of eq. 4.21.

use super::elements::RunElem;
use super::window::{STATE_LEVELS, State};
use crate::path::{AxisDerivs, Geometry, HermiteEnd, Line, MAX_AXES, QuinticSpan, SpanError};

/// The piece between two smoothed points `delta_tau` apart in τ: derivatives per τ become
/// derivatives per t by the factors Δ, Δ², ….
pub(super) fn smoothed(a: &State, b: &State, delta_tau: f64, linear: &[bool]) -> Result<QuinticSpan, SpanError> {
    smoothed_levels(a, b, delta_tau, 3, linear)
}

/// The Hermite piece matching the first `levels` of each state (3: quintic, C²; 4: degree 7,
/// C³; 5: degree 9, C⁴).
pub(super) fn smoothed_levels(
    a: &State,
    b: &State,
    delta_tau: f64,
    levels: usize,
    linear: &[bool],
) -> Result<QuinticSpan, SpanError> {
    let end = |s: &State| {
        let mut e = HermiteEnd::default();
        for k in 0..MAX_AXES {
            e.pos[k] = s[k][0];
            e.d1[k] = delta_tau * s[k][1];
            e.d2[k] = delta_tau * delta_tau * s[k][2];
            if levels > 3 {
                e.d3[k] = delta_tau.powi(3) * s[k][3];
                e.d4[k] = delta_tau.powi(4) * s[k][4];
            }
        }
        e
    };
    QuinticSpan::hermite_levels(&end(a), &end(b), levels, linear)
}

/// State in τ of the programmed path at `s_mm` of `e` (position, A′h, A″h², A‴h³).
pub(super) fn programmed_state(e: &RunElem, s_mm: f64, spacing_mm: f64) -> State {
    let mut d = AxisDerivs::default();
    e.eval(s_mm, &mut d);
    let mut st = [[0.0; STATE_LEVELS]; MAX_AXES];
    for k in 0..MAX_AXES {
        // x⁗ of the programmed path is not evaluated: 0 (only x … x″ of it are ever fixed).
        st[k] = [d.pos[k], d.d1[k] * spacing_mm, d.d2[k] * spacing_mm.powi(2), d.d3[k] * spacing_mm.powi(3), 0.0];
    }
    st
}

/// Longest piece when re-interpolating a curved programmed element, mm: with exact A, A′, A″
/// at both ends the quintic's error is O(h⁶κ⁵), far below a micrometre at this length on
/// any radius above 0.1 mm.
const EXACT_PIECE_MM: f64 = 0.25;

/// The programmed element `e` between global `s_a` and `s_b` as geometry: a cut line, or
/// quintic pieces with the exact derivatives at their ends.
pub(super) fn exact_part(e: &RunElem, s_a: f64, s_b: f64, linear: &[bool]) -> Result<Vec<Geometry>, SpanError> {
    let len = s_b - s_a;
    if len <= 0.0 {
        return Ok(Vec::new());
    }
    if let Geometry::Line(_) = e.element.geometry {
        return Ok(vec![Geometry::Line(Line::new(e.pos(s_a), e.pos(s_b), len))]);
    }
    let n = (len / EXACT_PIECE_MM).ceil().max(1.0) as usize;
    let h = len / n as f64;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (a, b) = (s_a + h * i as f64, if i + 1 == n { s_b } else { s_a + h * (i + 1) as f64 });
        // τ with h as the unit: derivatives per t directly.
        let sa = programmed_state(e, a, b - a);
        let sb = programmed_state(e, b, b - a);
        out.push(Geometry::Quintic(Box::new(smoothed(&sa, &sb, 1.0, linear)?)));
    }
    Ok(out)
}
