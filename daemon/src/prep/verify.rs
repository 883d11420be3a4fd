//! The check after each window: the committed pieces, sampled, must stay within the
//! tolerance of the programmed elements (seed 000 §4.8: the interpolant, not only the QP
//! points, must keep the band).

use super::elements::RunElems;
use super::points::Point;
use crate::path::QuinticSpan;

/// Samples per piece (uniform in the piece parameter).
pub const SAMPLES_PER_PIECE: usize = 32;

/// Largest distance of the sampled piece between points `a` and `b` to the programmed path,
/// and that distance minus the tolerance allowed there (> 0: outside).
pub fn piece_excess(piece: &QuinticSpan, a: &Point, b: &Point, elems: &RunElems, spacing_mm: f64) -> (f64, f64) {
    let from = elems.index_at(a.s_mm - 2.0 * spacing_mm, a.elem);
    let to = elems.index_at(b.s_mm + 2.0 * spacing_mm, b.elem);
    let tol = a.tol_mm.min(b.tol_mm);
    let mut worst: f64 = 0.0;
    for i in 1..SAMPLES_PER_PIECE {
        let p = piece.point_at_t(i as f64 / SAMPLES_PER_PIECE as f64);
        worst = worst.max(elems.distance(&p, from, to));
    }
    (worst, worst - tol)
}
