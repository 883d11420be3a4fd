//! Where the QP points sit on the programmed path (Haas 2012, §3.5, §4.8, Table 4.7:
//! equidistant, at least 0.926 points/mm, denser near corners).
//!
//! Points are spaced at most `point_spacing_mm` apart. On curves the tangent turns at most
//! `max_turn_deg` between points; on polylines a point is set on the vertex where the turn
//! since the last point would exceed it, so short CAM segments are kept where they bend and
//! merged where they run straight. A vertex that turns by more than `corner_deg` is a corner:
//! a point sits on it and the spacing halves towards it down to a few tolerances, so the QP
//! can place the blend within the band. Every ~`segment_mm` a point closes a window segment.

use super::elements::{RunElems, cos_between};
use super::settings::{CORNER_FIRST_STEP_PER_TOL, StageSettings};
use crate::path::{AxisDerivs, AxisVec, MAX_AXES};
use interpd_config::PointDistribution;

/// One QP point: a place on the programmed path.
#[derive(Debug, Clone, Copy)]
pub(super) struct Point {
    /// Position on the programmed path.
    pub s_mm: f64,
    pub pos: AxisVec,
    /// Unit tangent (at a vertex: the bisector of both sides).
    pub tangent: AxisVec,
    pub tol_mm: f64,
    /// The programmed tolerance there (the check measures against the programmed path).
    pub prog_tol_mm: f64,
    /// Element containing the point (the later one at a vertex).
    pub elem: usize,
    /// On a vertex between two elements.
    pub vertex: bool,
    /// Closes a window segment.
    pub seg_end: bool,
    /// How far the programmed path runs on along the point's tangent as a straight line,
    /// behind and ahead of it (mm, at most `SLIDE_SPACINGS` point spacings; ahead only over
    /// the elements known): an axis along which the path runs exactly may slide that far and
    /// no farther.
    pub straight_mm: (f64, f64),
}

/// A point slides along a straight axis-parallel path by at most this many point spacings: as
/// far as the check after the solve looks for the programmed path around a piece
/// (`verify::piece_excess`, two spacings), so a piece slid farther is not measured against
/// the wrong elements; more freedom than a spacing changes nothing a window needs.
const SLIDE_SPACINGS: f64 = 1.0;
/// Elements of a straight extent followed at most on each side (CAM output has thousands of
/// collinear micro-segments only where the conditioner merged them into chords already).
const STRAIGHT_MAX_ELEMS: usize = 256;
/// Tangents whose cosine is at least this are one straight line.
const STRAIGHT_COS: f64 = 1.0 - 1e-12;

/// Places points along a run as its elements become known.
#[derive(Debug)]
pub(super) struct Placer {
    s_mm: f64,
    elem: usize,
    tangent: AxisVec,
    last_corner_s_mm: f64,
    seg_start_s_mm: f64,
    /// Points placed since the last segment end.
    seg_points: usize,
    started: bool,
    /// The next point, found final but waiting for more of the run behind it (see `place`).
    waiting_s_mm: Option<f64>,
}

/// Steps shorter than this fraction of the nominal step are merged into the previous one.
const SLIVER_FRACTION: f64 = 0.3;
/// Segments do not end within this many point spacings of a corner ...
const CALM_SPACINGS: f64 = 2.0;
/// ... unless the segment has grown to this many `segment_mm`.
const CALM_GIVE_UP: f64 = 2.0;
/// A segment ends after this many points where the path is calm, and after twice as many
/// anywhere: on tight geometry (loops, reversals, a wandering polyline) points come every few
/// micrometres, and a window of `segment_mm` would hold thousands of them and solve too slowly.
const SEGMENT_POINTS: usize = 40;
/// A corner closer than this many first steps is reached in one step.
const CORNER_LAND_FACTOR: f64 = 1.5;

impl Placer {
    pub(super) fn new() -> Self {
        Self {
            s_mm: 0.0,
            elem: 0,
            tangent: [0.0; MAX_AXES],
            last_corner_s_mm: f64::NEG_INFINITY,
            seg_start_s_mm: 0.0,
            seg_points: 0,
            started: false,
            waiting_s_mm: None,
        }
    }

    /// Places the points that the known elements determine; with `closed`, up to the run's
    /// end (which closes the last segment).
    pub(super) fn place(&mut self, elems: &RunElems, st: &StageSettings, closed: bool, out: &mut Vec<Point>) {
        let Some(last) = elems.last() else { return };
        let run_end = last.s1_mm();
        if !self.started {
            let first = elems.get(elems.first_index());
            self.s_mm = first.s0_mm;
            self.elem = elems.first_index();
            self.tangent = first.t_start;
            self.seg_start_s_mm = first.s0_mm;
            self.started = true;
            out.push(point(elems, st, self.s_mm, self.elem, false, false));
        }
        // Without the run's end, stay far enough back that a corner at the end of the last
        // element would still be approached with shrinking steps.
        let limit = if closed { run_end } else { run_end - 2.0 * st.spacing_mm };
        // A CAM run brings an element every few micrometres and a point every few hundred
        // of them: the next point, once no element to come can change it, only waits for the
        // run to reach far enough behind it, and is not searched again for every element.
        if let Some(s_next) = self.waiting_s_mm {
            if !closed && s_next > limit {
                return;
            }
            self.waiting_s_mm = None;
        }
        while self.s_mm < limit {
            let (s_next, elem, vertex, settled) = self.next(elems, st, closed, run_end);
            if !closed && s_next > limit && s_next < run_end {
                if settled {
                    self.waiting_s_mm = Some(s_next);
                }
                break;
            }
            let end = closed && s_next >= run_end;
            // Segments end where the path is calm (a window that starts inside a corner blend
            // inherits its steep derivatives), unless corners follow each other closely.
            let run_len = s_next - self.seg_start_s_mm;
            let calm = !self.near_corner(elems, s_next, elem, st);
            self.seg_points += 1;
            let long = run_len >= st.segment_mm || self.seg_points >= SEGMENT_POINTS;
            let seg_end = end
                || (long && calm)
                || run_len >= CALM_GIVE_UP * st.segment_mm
                || self.seg_points >= 2 * SEGMENT_POINTS;
            let p = point(elems, st, s_next, elem, vertex, seg_end);
            if seg_end {
                self.seg_start_s_mm = s_next;
                self.seg_points = 0;
            }
            if vertex && elems.get(elem).turn_in_rad > st.corner_rad {
                self.last_corner_s_mm = s_next;
            }
            self.tangent = if vertex { elems.get(elem).t_start } else { p.tangent };
            self.s_mm = s_next;
            self.elem = elem;
            out.push(p);
            if end {
                break;
            }
        }
    }

    /// The next point: (s, element, on a vertex, settled). Settled: the elements it depends on
    /// are all known (the search ahead ended before the last known element), so elements
    /// appended later cannot move it.
    fn next(&self, elems: &RunElems, st: &StageSettings, closed: bool, run_end: f64) -> (f64, usize, bool, bool) {
        let n = st.n_axes;
        let here = elems.get(self.elem);
        let tol = here.tol_mm;
        let first_step = CORNER_FIRST_STEP_PER_TOL * tol;
        let mut h = st.spacing_mm;
        // Grow away from the last corner: steps of first_step, then doubling.
        h = h.min((self.s_mm - self.last_corner_s_mm).max(first_step));
        if st.distribution == PointDistribution::Cumulative {
            h = h.min(cumulative_step(here.s0_mm, here.s1_mm(), self.s_mm, st.spacing_mm).max(first_step));
        }
        // Curvature of a curved element: at most max_turn between points.
        let mut d = AxisDerivs::default();
        here.eval(self.s_mm, &mut d);
        let curv = (0..n).filter(|&k| st.linear[k]).map(|k| d.d2[k] * d.d2[k]).sum::<f64>().sqrt();
        if curv > 0.0 {
            h = h.min(st.max_turn_rad / curv);
        }
        // Vertices ahead within h: stop on a corner (approaching it with halving steps) or on
        // the vertex where the turn since this point would exceed max_turn.
        let mut i = self.elem + 1;
        while i < elems.end() {
            let e = elems.get(i);
            let dist = e.s0_mm - self.s_mm;
            if dist > 2.0 * h {
                break;
            }
            if e.turn_in_rad > st.corner_rad {
                // Halve the steps towards the corner until one tolerance-sized step is left.
                if dist <= CORNER_LAND_FACTOR * first_step {
                    return (e.s0_mm, i, true, true);
                }
                h = h.min(0.5 * dist);
                break;
            }
            if dist <= h && cos_between(&self.tangent, &e.t_start, n) < st.max_turn_rad.cos() {
                return (e.s0_mm, i, true, true);
            }
            i += 1;
        }
        let settled = i < elems.end();
        let mut s = self.s_mm + h;
        if closed && run_end - s < SLIVER_FRACTION * h {
            s = run_end;
        }
        let s = s.min(run_end);
        let elem = elems.index_at(s, self.elem);
        let vertex = elem > self.elem && (elems.get(elem).s0_mm - s).abs() <= f64::EPSILON * s.abs().max(1.0);
        (s, elem, vertex, settled)
    }

    /// Whether `s_mm` lies within `CALM_SPACINGS` point spacings of a corner.
    fn near_corner(&self, elems: &RunElems, s_mm: f64, elem: usize, st: &StageSettings) -> bool {
        let reach = CALM_SPACINGS * st.spacing_mm;
        if s_mm - self.last_corner_s_mm < reach {
            return true;
        }
        let mut i = elem;
        while i < elems.end() && elems.get(i).s0_mm <= s_mm + reach {
            let e = elems.get(i);
            if e.s0_mm >= s_mm - reach && e.turn_in_rad > st.corner_rad {
                return true;
            }
            i += 1;
        }
        false
    }

    /// A point halfway along the programmed path between `a` and `b`: where a piece between
    /// them left the band, one more point holds the QP to the path there.
    pub(super) fn midpoint(elems: &RunElems, st: &StageSettings, a: &Point, b: &Point) -> Point {
        let s_mm = 0.5 * (a.s_mm + b.s_mm);
        let elem = elems.index_at(s_mm, a.elem);
        point(elems, st, s_mm, elem, false, false)
    }
}

/// The step from `s_mm` to the next point of the cumulative density over the block
/// [`s0_mm`, `s1_mm`] (Haas 2012, eq. 3.13): n = ⌈L / spacing⌉ points per block at
/// s = s0 + L·F(i / n), F(u) = (1 − cos πu) / 2, the cumulative sum of sin-shaped increments
/// normalised to the block. As printed, eq. 3.13 takes the sine over [0, 1], which crowds the
/// points at the block's start only; over [0, π] it crowds them at both ends, as the thesis
/// describes the density. A block no longer than two spacings keeps the spacing.
fn cumulative_step(s0_mm: f64, s1_mm: f64, s_mm: f64, spacing_mm: f64) -> f64 {
    let len = s1_mm - s0_mm;
    if len <= 2.0 * spacing_mm {
        return spacing_mm;
    }
    let n = (len / spacing_mm).ceil();
    let t = ((s_mm - s0_mm) / len).clamp(0.0, 1.0);
    // The index of the point at s (F⁻¹), rounded to the nearest whole one so that rounding does
    // not add a sliver step.
    let i = ((1.0 - 2.0 * t).clamp(-1.0, 1.0).acos() / std::f64::consts::PI * n + 1e-9).floor();
    let f = |u: f64| 0.5 * (1.0 - (std::f64::consts::PI * u.min(1.0)).cos());
    let next = s0_mm + len * f((i + 1.0) / n);
    (next - s_mm).max(f64::EPSILON * s1_mm.abs().max(1.0))
}

/// The point at `s_mm` on element `elem`.
fn point(elems: &RunElems, st: &StageSettings, s_mm: f64, elem: usize, vertex: bool, seg_end: bool) -> Point {
    let e = elems.get(elem);
    let mut d = AxisDerivs::default();
    e.eval(s_mm, &mut d);
    let mut tangent = d.d1;
    if vertex && elem > elems.first_index() {
        let prev = elems.get(elem - 1);
        let mut sum = [0.0; MAX_AXES];
        for k in 0..MAX_AXES {
            sum[k] = prev.t_end[k] + e.t_start[k];
        }
        let norm = sum.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-9 {
            tangent = sum.map(|x| x / norm);
        }
    }
    let straight_mm = straight_extent(elems, s_mm, elem, &tangent, st.spacing_mm * SLIDE_SPACINGS);
    Point {
        s_mm,
        pos: d.pos,
        tangent,
        tol_mm: e.tol_mm,
        prog_tol_mm: e.prog_tol_mm,
        elem,
        vertex,
        seg_end,
        straight_mm,
    }
}

/// The straight extent (behind, ahead) of the path through `s_mm` along `tangent`, up to
/// `reach_mm` each way: the lines around it that run exactly along the tangent. Zero on a
/// curve or a vertex that turns.
fn straight_extent(elems: &RunElems, s_mm: f64, elem: usize, tangent: &AxisVec, reach_mm: f64) -> (f64, f64) {
    let along = |i: usize| {
        let e = elems.get(i);
        matches!(e.element.geometry, crate::path::Geometry::Line(_))
            && (0..MAX_AXES).map(|k| e.t_start[k] * tangent[k]).sum::<f64>() >= STRAIGHT_COS
    };
    if !along(elem) {
        return (0.0, 0.0);
    }
    let (mut lo, mut hi) = (elem, elem);
    while lo > elems.first_index()
        && elem - lo < STRAIGHT_MAX_ELEMS
        && s_mm - elems.get(lo).s0_mm < reach_mm
        && along(lo - 1)
    {
        lo -= 1;
    }
    while hi + 1 < elems.end()
        && hi - elem < STRAIGHT_MAX_ELEMS
        && elems.get(hi).s1_mm() - s_mm < reach_mm
        && along(hi + 1)
    {
        hi += 1;
    }
    let back = (s_mm - elems.get(lo).s0_mm).clamp(0.0, reach_mm);
    let ahead = (elems.get(hi).s1_mm() - s_mm).clamp(0.0, reach_mm);
    (back, ahead)
}

impl Default for Placer {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::cumulative_step;

    /// Steps from the block start to its end.
    fn walk(s0: f64, s1: f64, spacing: f64) -> Vec<f64> {
        let mut s = vec![s0];
        while *s.last().unwrap() < s1 - 1e-12 {
            let x = *s.last().unwrap();
            s.push(x + cumulative_step(s0, s1, x, spacing));
            assert!(s.len() < 1000, "no end");
        }
        s
    }

    #[test]
    fn the_cumulative_density_keeps_the_point_count_and_crowds_both_block_ends() {
        let (s0, s1, spacing) = (3.0, 23.0, 1.0);
        let s = walk(s0, s1, spacing);
        // ⌈20 / 1⌉ = 20 steps, ending on the block end.
        assert_eq!(s.len(), 21, "{s:?}");
        assert!((s[20] - s1).abs() < 1e-12);
        let steps: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
        // Symmetric, shortest at both ends, longest in the middle (π/2 × the spacing).
        for i in 0..10 {
            assert!((steps[i] - steps[19 - i]).abs() < 1e-9, "{steps:?}");
        }
        assert!(steps[0] < 0.15 && steps[9] > 1.5 && steps[9] < 1.6, "{steps:?}");
        assert!(steps.windows(2).take(9).all(|w| w[1] > w[0]));
        // From a place between two points (another rule took a shorter step) to the next one.
        let mid = 0.5 * (s[4] + s[5]);
        assert!((mid + cumulative_step(s0, s1, mid, spacing) - s[5]).abs() < 1e-9);
        // A short block keeps the spacing.
        assert_eq!(cumulative_step(0.0, 1.5, 0.2, 1.0), 1.0);
    }
}
