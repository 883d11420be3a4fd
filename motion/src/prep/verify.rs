//! The check after each window: the committed pieces, sampled, must stay within the
//! tolerance of the programmed elements (Haas 2012, §4.8: the interpolant, not only the QP
//! points, must keep the band).

use super::elements::RunElems;
use super::points::Point;
use super::programmed::ProgrammedMoves;
use crate::path::QuinticSpan;

/// Samples per piece (uniform in the piece parameter).
pub(super) const SAMPLES_PER_PIECE: usize = 32;

/// Largest distance of the sampled piece between points `a` and `b` to the programmed path,
/// and that distance minus the tolerance allowed there (> 0: outside). `elems` are the
/// conditioned elements the points lie on, `programmed` the programmed ones they stand for.
pub(super) fn piece_excess(
    piece: &QuinticSpan,
    a: &Point,
    b: &Point,
    elems: &RunElems,
    programmed: &ProgrammedMoves,
    spacing_mm: f64,
) -> (f64, f64) {
    // The piece stays near the programmed path between its ends, shifted along it by at most
    // how far its ends moved: only the elements there can be nearest.
    let tol = a.prog_tol_mm.min(b.prog_tol_mm);
    let p0 = piece.point_at_t(0.0);
    let p1 = piece.point_at_t(1.0);
    let moved = |p: &[f64], q: &Point| p.iter().zip(&q.pos).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt();
    let reach = (moved(&p0, a).max(moved(&p1, b)) + 2.0 * tol).min(2.0 * spacing_mm);
    // The programmed moves of the conditioned elements there (a chord: all of its moves).
    let (s_from, s_to) = (a.s_mm - reach, b.s_mm + reach);
    let (e_from, e_to) = (elems.get(elems.index_at(s_from, a.elem)), elems.get(elems.index_at(s_to, b.elem)));
    let from = programmed.index_at_bisect(if e_from.conditioned() { e_from.prog_s0_mm } else { s_from });
    let to = programmed.index_at_bisect(if e_to.conditioned() { e_to.prog_s1_mm } else { s_to });
    let mut worst: f64 = 0.0;
    if to - from < LOCAL_SEARCH_MIN_MOVES {
        for i in 1..SAMPLES_PER_PIECE {
            let p = piece.point_at_t(i as f64 / SAMPLES_PER_PIECE as f64);
            worst = worst.max(programmed.distance(&p, from, to));
        }
        return (worst, worst - tol);
    }
    // Many programmed moves (micro-segments): each sample is measured against those within a
    // few sample spacings and `reach` of where it lies proportionally along them. A subset can
    // only make a distance larger, so the check stays on the safe side.
    let (ps0, ps1) = (programmed.s0_mm(from), programmed.s1_mm(to));
    let window = reach + LOCAL_SEARCH_SAMPLES * (ps1 - ps0) / SAMPLES_PER_PIECE as f64;
    for i in 1..SAMPLES_PER_PIECE {
        let f = i as f64 / SAMPLES_PER_PIECE as f64;
        let p = piece.point_at_t(f);
        let s_c = ps0 + f * (ps1 - ps0);
        let lo = programmed.index_at_bisect(s_c - window).max(from);
        let hi = programmed.index_at_bisect(s_c + window).min(to);
        worst = worst.max(programmed.distance(&p, lo, hi));
    }
    (worst, worst - tol)
}

/// Pieces over at least this many programmed moves are checked sample by sample against the
/// moves near each sample (`piece_excess`) ...
const LOCAL_SEARCH_MIN_MOVES: usize = 64;
/// ... within this many sample spacings (and the reach) along them.
const LOCAL_SEARCH_SAMPLES: f64 = 2.0;
