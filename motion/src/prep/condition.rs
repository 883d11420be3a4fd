//! Conditioning of CAM micro-segments before the QP: consecutive G64 lines whose inner vertices
//! lie close to one chord are merged into that chord.
//!
//! CAM output rounds its coordinates (to 0.1 µm at 4 decimals); on moves of a few µm that noise
//! turns every vertex by degrees, so the point placement sees a corner at each of them and the
//! windows fill with points. The conditioner looks only at the moves since the current chord's
//! start (at most `MAX_MERGED_MOVES`), so it runs online in bounded memory:
//!
//! while the chord is shorter than `SHORT_CHORD_PER_TOL` tolerances, the next move is merged
//! when every inner vertex stays within `SHORT_FRACTION` of the tolerance of the longer chord:
//! the rounding zig-zags, the duplicate and near-zero moves and the near-collinear runs of
//! micro-segments. Moves longer than that carry their direction well above the rounding noise
//! and come through unchanged; the point placement merges their straight runs (`points.rs`). A
//! chord over moves of such length would concentrate the turns of a curve at its ends, where
//! the placement sees corners.
//!
//! A merged chord keeps the band that is left, tolerance minus the largest distance of a merged
//! vertex to it, so the smoothed path stays within the tolerance of the programmed polyline;
//! the check after each window measures against the programmed moves themselves
//! (`verify.rs`). A single move comes through as it was.

use crate::path::{AxisDerivs, AxisVec, Element, Geometry, Line, MAX_AXES};

/// A chord shorter than this many tolerances is extended over rounding noise ...
const SHORT_CHORD_PER_TOL: f64 = 1.5;
/// ... as long as its inner vertices stay within this share of the tolerance (the rest of
/// the band is the QP's).
const SHORT_FRACTION: f64 = 0.25;
/// Most moves one chord merges (bounds the work per move and the memory).
const MAX_MERGED_MOVES: usize = 256;

/// A conditioned element and the programmed moves it stands for.
#[derive(Debug, Clone)]
pub(super) struct Conditioned {
    /// The chord (or the programmed element itself), `s_start_mm` on the conditioned path.
    pub element: Element,
    /// The programmed elements it replaces, in order (one when nothing was merged).
    pub programmed: Vec<Element>,
    /// Largest distance of a merged vertex to the chord, mm (0 when nothing was merged).
    pub deviation_mm: f64,
}

/// Merges the lines of a G64 run as they arrive.
#[derive(Debug)]
pub(super) struct Conditioner {
    n_axes: usize,
    /// The moves of the open chord, the chord's start and each move's end.
    moves: Vec<Element>,
    start: AxisVec,
    ends: Vec<AxisVec>,
    tol_mm: f64,
    /// Largest distance of an inner vertex to the open chord, mm.
    deviation_mm: f64,
    /// Programmed length the merges have removed so far in the run, mm: conditioned s is
    /// programmed s minus this.
    shortened_mm: f64,
}

impl Conditioner {
    pub(super) fn new(n_axes: usize) -> Self {
        Self {
            n_axes,
            moves: Vec::new(),
            start: [0.0; MAX_AXES],
            ends: Vec::new(),
            tol_mm: 0.0,
            deviation_mm: 0.0,
            shortened_mm: 0.0,
        }
    }

    /// Whether `e` can join a chord: a straight move with no dwell before it.
    pub(super) fn mergeable(e: &Element) -> bool {
        matches!(e.geometry, Geometry::Line(_)) && !e.holds()
    }

    /// Takes the next line of the run (`mergeable`, tolerance `tol_mm`); returns the chord it
    /// closes, if any.
    pub(super) fn push(&mut self, e: Element, tol_mm: f64) -> Option<Conditioned> {
        let Some(first) = self.moves.first() else {
            self.open(e, tol_mm);
            return None;
        };
        let same = first.feed == e.feed && self.tol_mm == tol_mm && self.moves.len() < MAX_MERGED_MOVES;
        if same {
            let (a, b) = (self.start, end_of(&e));
            let chord_mm = dist(&a, &b, self.n_axes);
            let held = dist(&a, self.ends.last().expect("open chord"), self.n_axes);
            if chord_mm > 0.0 && held < SHORT_CHORD_PER_TOL * tol_mm {
                let dev = self.ends.iter().map(|p| segment_distance(p, &a, &b, self.n_axes)).fold(0.0, f64::max);
                if dev <= SHORT_FRACTION * tol_mm {
                    self.deviation_mm = dev;
                    self.ends.push(b);
                    self.moves.push(e);
                    return None;
                }
            }
        }
        let out = self.close();
        self.open(e, tol_mm);
        out
    }

    /// The first move of the open chord.
    pub(super) fn first(&self) -> Option<&Element> {
        self.moves.first()
    }

    /// Closes the open chord (the run ends or a move that cannot join follows).
    pub(super) fn flush(&mut self) -> Option<Conditioned> {
        self.close()
    }

    /// An element that joins no chord (call `flush` first): only shifted to conditioned s.
    pub(super) fn pass(&self, e: Element) -> Conditioned {
        debug_assert!(self.moves.is_empty());
        let mut element = e.clone();
        element.s_start_mm = e.s_start_mm - self.shortened_mm;
        Conditioned { element, programmed: vec![e], deviation_mm: 0.0 }
    }

    fn open(&mut self, e: Element, tol_mm: f64) {
        self.start = start_of(&e);
        self.ends.clear();
        self.ends.push(end_of(&e));
        self.moves.push(e);
        self.tol_mm = tol_mm;
        self.deviation_mm = 0.0;
    }

    fn close(&mut self) -> Option<Conditioned> {
        if self.moves.is_empty() {
            return None;
        }
        let moves = std::mem::take(&mut self.moves);
        let first = &moves[0];
        let mut element = first.clone();
        element.s_start_mm = first.s_start_mm - self.shortened_mm;
        if moves.len() > 1 {
            let (a, b) = (self.start, *self.ends.last().expect("not empty"));
            let chord_mm = dist(&a, &b, self.n_axes);
            let programmed_mm: f64 = moves.iter().map(|m| m.geometry.length_mm()).sum();
            element.geometry = Geometry::Line(Line::new(a, b, chord_mm));
            self.shortened_mm += programmed_mm - chord_mm;
        }
        Some(Conditioned { element, programmed: moves, deviation_mm: self.deviation_mm })
    }
}

fn start_of(e: &Element) -> AxisVec {
    let mut d = AxisDerivs::default();
    e.geometry.eval(0.0, &mut d);
    d.pos
}

fn end_of(e: &Element) -> AxisVec {
    let mut d = AxisDerivs::default();
    e.geometry.eval(e.geometry.length_mm(), &mut d);
    d.pos
}

fn dist(a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    (0..n).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Distance of `p` to the segment from `a` to `b` (of positive length), over `n` axes.
fn segment_distance(p: &AxisVec, a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    let ab2: f64 = (0..n).map(|k| (b[k] - a[k]).powi(2)).sum();
    let t = ((0..n).map(|k| (p[k] - a[k]) * (b[k] - a[k])).sum::<f64>() / ab2).clamp(0.0, 1.0);
    (0..n).map(|k| (p[k] - a[k] - t * (b[k] - a[k])).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Blend, Feed, JointKind, Source};

    fn line(a: [f64; 2], b: [f64; 2], s0: f64) -> Element {
        let (mut p, mut q) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
        p[..2].copy_from_slice(&a);
        q[..2].copy_from_slice(&b);
        let len = dist(&p, &q, 2);
        Element {
            geometry: Geometry::Line(Line::new(p, q, len)),
            s_start_mm: s0,
            feed: Feed::Programmed { mm_per_s: 50.0 },
            source: Source::default(),
            joint: JointKind::Smooth,
            dwell_before_s: 0.0,
            pause_before: None,
            blend: Blend::Tolerance { tol_mm: 0.01, method: interpd_config::PrepMethod::Hermite },
        }
    }

    /// Moves of `step` along x with a ±`noise` zig-zag in y, through the conditioner.
    fn zigzag(step: f64, noise: f64, n: usize) -> (Vec<Conditioned>, f64) {
        let mut c = Conditioner::new(2);
        let mut out = Vec::new();
        let (mut s, mut prev) = (0.0, [0.0, 0.0]);
        for i in 1..=n {
            let p = [i as f64 * step, if i % 2 == 1 { noise } else { -noise }];
            let e = line(prev, p, s);
            s += e.geometry.length_mm();
            out.extend(c.push(e, 0.01));
            prev = p;
        }
        out.extend(c.flush());
        (out, s)
    }

    #[test]
    fn rounding_zigzags_of_micro_segments_merge_into_chords_within_a_quarter_tolerance() {
        let (out, _) = zigzag(0.002, 0.0001, 1000);
        let merged: usize = out.iter().map(|c| c.programmed.len()).sum();
        assert_eq!(merged, 1000, "every programmed move is accounted for");
        assert!(out.len() < 1000 / 5, "{} chords", out.len());
        for c in &out {
            assert!(c.deviation_mm <= SHORT_FRACTION * 0.01);
            // Chords end where the next starts, back to back in conditioned s.
            assert!(c.element.geometry.length_mm() < 2.0 * SHORT_CHORD_PER_TOL * 0.01);
        }
        for w in out.windows(2) {
            assert!((w[0].element.s_end_mm() - w[1].element.s_start_mm).abs() < 1e-12);
            assert_eq!(end_of(&w[0].element), start_of(&w[1].element));
        }
    }

    #[test]
    fn moves_longer_than_the_short_chord_and_real_corners_come_through_unchanged() {
        let (out, s_end) = zigzag(0.02, 0.0001, 50);
        assert_eq!(out.len(), 50);
        assert!(out.iter().all(|c| c.programmed.len() == 1 && c.programmed[0] == c.element));
        assert!((out.last().unwrap().element.s_end_mm() - s_end).abs() < 1e-15);
        // A zig-zag of a full tolerance is geometry, not noise.
        let (out, _) = zigzag(0.002, 0.01, 100);
        assert_eq!(out.len(), 100);
    }

    #[test]
    fn near_zero_moves_merge_into_the_next_move_and_the_following_elements_shift_in_s() {
        let mut c = Conditioner::new(2);
        let a = line([0.0, 0.0], [0.0001, 0.0], 0.0);
        let b = line([0.0001, 0.0], [0.0001, 0.0001], 0.0001);
        let d = line([0.0001, 0.0001], [0.5, 0.0001], 0.0002);
        let e = line([0.5, 0.0001], [0.5, 0.5], d.s_end_mm());
        assert!(c.push(a, 0.01).is_none() && c.push(b, 0.01).is_none() && c.push(d, 0.01).is_none());
        let chord = c.push(e.clone(), 0.01).expect("the corner closes the chord");
        assert_eq!(chord.programmed.len(), 3);
        let shortened = e.s_start_mm - chord.element.geometry.length_mm();
        assert!(shortened > 0.0);
        let rest = c.flush().expect("the move after the corner");
        assert_eq!(rest.programmed.len(), 1);
        assert!((rest.element.s_start_mm - (e.s_start_mm - shortened)).abs() < 1e-15);
        assert!((rest.element.s_start_mm - chord.element.s_end_mm()).abs() < 1e-15);
    }
}
