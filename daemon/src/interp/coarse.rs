//! Stage 1 of the two-stage interpolation (Huan, §3), run in the planner thread: the planned
//! path-velocity profile and the exact geometry become coarse points (time, path state, axis
//! positions and their time derivatives), spaced so that the quintic through neighbouring
//! points (stage 2, [`super::hermite`]) stays within [`TOLERANCE_MM`] of the exact geometry.
//!
//! Coarse points sit at the planner's segment ends (where the path jerk switches) and, where
//! segments are short, several segments share one piece; a piece that misses the tolerance
//! is split until it meets it. Every piece is checked against A(s(t)) at interior points, so
//! the promise (≤ 1 µm between setpoints and geometry) is measured, not assumed.

use super::hermite::{self, Kinematic};
use interpd_motion::path::{AxisDerivs, AxisVec, Path};
use interpd_motion::planner::Segment;

/// Largest deviation of the interpolated axis positions from the exact geometry that a piece
/// may have, mm: a tenth of the 1 µm the daemon promises.
pub const TOLERANCE_MM: f64 = 1e-4;
/// Largest deviation of the interpolated axis jerk from the exact one, as a share of the axis
/// jerk limit: position alone would let a 0.1 µm wiggle over 4 ms show as ~3 % of a typical
/// jerk limit in the setpoints' third differences.
pub const JERK_TOLERANCE: f64 = 0.005;
/// Pieces shorter than this are checked for position only (see `split_segment`), s.
const MIN_JERK_CHECK_S: f64 = 2.5e-4;
/// Interior check points per segment of a piece (at k/(N+1) of each segment).
const CHECKS_PER_SEGMENT: usize = 3;
/// Bisections of one segment before a piece is accepted as it is (reached only by geometry
/// that no polynomial in time follows, which the path layer rejects).
const MAX_SPLIT_DEPTH: usize = 24;

/// One coarse point: where the motion is at time `t_s` (relative to the start of the sequence
/// it belongs to), on the path and per axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CoarsePoint {
    pub t_s: f64,
    /// Path position, velocity, acceleration (mm, mm/s, mm/s²).
    pub s_mm: f64,
    pub v_mm_s: f64,
    pub a_mm_s2: f64,
    /// Program line of the motion from here on.
    pub line: u32,
    /// Axis positions, velocities, accelerations (axis units per s, s²).
    pub pos: AxisVec,
    pub vel: AxisVec,
    pub acc: AxisVec,
}

impl CoarsePoint {
    /// The path coordinate as a kinematic triple.
    pub fn path(&self) -> Kinematic {
        Kinematic { p: self.s_mm, v: self.v_mm_s, a: self.a_mm_s2 }
    }

    /// Axis `k` as a kinematic triple.
    pub fn axis(&self, k: usize) -> Kinematic {
        Kinematic { p: self.pos[k], v: self.vel[k], a: self.acc[k] }
    }

    /// A point at rest at `pos` (v = a = 0).
    pub fn at_rest(t_s: f64, s_mm: f64, line: u32, pos: AxisVec) -> Self {
        CoarsePoint { t_s, s_mm, line, pos, ..CoarsePoint::default() }
    }
}

/// Builds coarse points from segments along one path.
pub struct CoarseBuilder<'a> {
    path: &'a Path,
    n_axes: usize,
    max_piece_s: f64,
    /// Jerk tolerance per axis (axis units/s³).
    jerk_tol: AxisVec,
    /// Largest deviation at the check points of the accepted pieces, mm.
    pub max_error_mm: f64,
    /// Pieces split because they missed the tolerance.
    pub splits: u64,
}

impl<'a> CoarseBuilder<'a> {
    /// `max_piece_s` bounds the duration of one piece (a few interpolation cycles);
    /// `max_jerk` per axis scales the jerk check ([`JERK_TOLERANCE`]).
    pub fn new(path: &'a Path, max_piece_s: f64, max_jerk: &AxisVec) -> Self {
        let mut jerk_tol = [f64::INFINITY; interpd_motion::path::MAX_AXES];
        for (t, j) in jerk_tol.iter_mut().zip(max_jerk.iter()).take(path.n_axes) {
            *t = JERK_TOLERANCE * j;
        }
        Self { path, n_axes: path.n_axes, max_piece_s, jerk_tol, max_error_mm: 0.0, splits: 0 }
    }

    /// The point at local time `tau_s` of `seg`, stamped with time `t_s`.
    pub fn point(&self, seg: &Segment, tau_s: f64, t_s: f64) -> CoarsePoint {
        let st = seg.at(tau_s);
        let (mut right, mut left) = (AxisDerivs::default(), AxisDerivs::default());
        self.path.eval(st.s_mm, &mut right);
        self.path.eval_left(st.s_mm, &mut left);
        let mut p =
            CoarsePoint { t_s, s_mm: st.s_mm, v_mm_s: st.v, a_mm_s2: st.a, line: seg.line, ..Default::default() };
        for k in 0..self.n_axes {
            p.pos[k] = right.pos[k];
            p.vel[k] = right.d1[k] * st.v;
            // At a curvature jump the exact acceleration steps; the setpoints stay C² by
            // taking the mean, and the check below bounds what that costs in position.
            let acc_r = right.d2[k] * st.v * st.v + right.d1[k] * st.a;
            let acc_l = left.d2[k] * st.v * st.v + left.d1[k] * st.a;
            p.acc[k] = 0.5 * (acc_r + acc_l);
        }
        p
    }

    /// Appends the coarse points of `segments` (back to back in time) to `out`, times from
    /// `t0_s` at the first segment's start. The first point is pushed only if `out` is empty
    /// (otherwise the last point of `out` is taken to be it).
    pub fn build(&mut self, segments: &[Segment], t0_s: f64, out: &mut Vec<CoarsePoint>) {
        let Some(first) = segments.first() else { return };
        if out.is_empty() {
            out.push(self.point(first, 0.0, t0_s));
        }
        let mut t = t0_s;
        let mut i = 0;
        while i < segments.len() {
            let mut k = i + 1;
            let mut dur = segments[i].dt_s;
            let dwell = is_dwell(&segments[i]);
            while k < segments.len() && !dwell && !is_dwell(&segments[k]) && dur + segments[k].dt_s <= self.max_piece_s
            {
                dur += segments[k].dt_s;
                k += 1;
            }
            loop {
                let start = *out.last().expect("a start point");
                let group = &segments[i..k];
                let end = self.point(&group[group.len() - 1], group[group.len() - 1].dt_s, t + dur);
                if dwell || self.fits(group, t, &start, &end) {
                    out.push(end);
                    break;
                }
                self.splits += 1;
                if k - i > 1 {
                    k = i + (k - i) / 2;
                    dur = segments[i..k].iter().map(|s| s.dt_s).sum();
                } else {
                    self.split_segment(&segments[i], 0.0, segments[i].dt_s, t, 0, out);
                    break;
                }
            }
            t += dur;
            i = k;
        }
    }

    /// Bisects `seg` on [τa, τb] until each half fits; pushes the points after the start.
    fn split_segment(
        &mut self,
        seg: &Segment,
        ta: f64,
        tb: f64,
        t_base: f64,
        depth: usize,
        out: &mut Vec<CoarsePoint>,
    ) {
        let mid = 0.5 * (ta + tb);
        for (a, b) in [(ta, mid), (mid, tb)] {
            let start = *out.last().expect("a start point");
            let end = self.point(seg, b, t_base + b);
            // A piece this short is checked for position only: the exact jerk steps where a
            // piece crosses a curvature jump (A″ steps), which no split can follow.
            let check_jerk = (b - a) > MIN_JERK_CHECK_S;
            let (err, jerk_ok) = self.error_between(&start, &end, check_jerk, |tau| (seg, a + tau));
            if (err <= TOLERANCE_MM && jerk_ok) || depth >= MAX_SPLIT_DEPTH {
                self.max_error_mm = self.max_error_mm.max(err);
                out.push(end);
            } else {
                self.split_segment(seg, a, b, t_base, depth + 1, out);
            }
        }
    }

    /// Whether the piece over `group` (starting at time `t_s`) stays within the tolerance.
    fn fits(&mut self, group: &[Segment], t_s: f64, start: &CoarsePoint, end: &CoarsePoint) -> bool {
        let h = end.t_s - start.t_s;
        let mut worst: f64 = 0.0;
        let mut jerk_ok = true;
        let mut offset = 0.0;
        let mut exact = AxisDerivs::default();
        for seg in group {
            for c in 1..=CHECKS_PER_SEGMENT + 1 {
                // Interior points and, but for the last segment, the segment end.
                let tau = seg.dt_s * c as f64 / (CHECKS_PER_SEGMENT + 1) as f64;
                let at = offset + tau;
                if at >= h {
                    continue;
                }
                let st = seg.at(tau);
                self.path.eval(st.s_mm, &mut exact);
                worst = worst.max(self.deviation(start, end, at, &exact));
                jerk_ok &= self.jerk_fits(start, end, at, &st, &exact);
            }
            offset += seg.dt_s;
        }
        let _ = t_s;
        let fits = worst <= TOLERANCE_MM && jerk_ok;
        if fits {
            self.max_error_mm = self.max_error_mm.max(worst);
        }
        fits
    }

    /// Largest deviation at the interior check points of the piece start → end, where
    /// `at(τ)` gives the segment and local time of piece time τ.
    fn error_between<'s>(
        &mut self,
        start: &CoarsePoint,
        end: &CoarsePoint,
        check_jerk: bool,
        at: impl Fn(f64) -> (&'s Segment, f64),
    ) -> (f64, bool) {
        let h = end.t_s - start.t_s;
        let mut worst: f64 = 0.0;
        let mut jerk_ok = true;
        let mut exact = AxisDerivs::default();
        for c in 1..=CHECKS_PER_SEGMENT {
            let tau = h * c as f64 / (CHECKS_PER_SEGMENT + 1) as f64;
            let (seg, local) = at(tau);
            let st = seg.at(local);
            self.path.eval(st.s_mm, &mut exact);
            worst = worst.max(self.deviation(start, end, tau, &exact));
            jerk_ok &= !check_jerk || self.jerk_fits(start, end, tau, &st, &exact);
        }
        (worst, jerk_ok)
    }

    /// The quintic's jerk at piece time τ is within the tolerance of the exact axis jerk
    /// A‴v³ + 3A″va + A′j.
    fn jerk_fits(
        &self,
        start: &CoarsePoint,
        end: &CoarsePoint,
        tau: f64,
        st: &interpd_motion::planner::PathState,
        exact: &AxisDerivs,
    ) -> bool {
        let h = end.t_s - start.t_s;
        (0..self.n_axes).all(|k| {
            let want = exact.d3[k] * st.v * st.v * st.v + 3.0 * exact.d2[k] * st.v * st.a + exact.d1[k] * st.j;
            (hermite::jerk(start.axis(k), end.axis(k), h, tau) - want).abs() <= self.jerk_tol[k]
        })
    }

    /// Largest axis deviation of the quintic at piece time τ from the exact positions.
    fn deviation(&self, start: &CoarsePoint, end: &CoarsePoint, tau: f64, exact: &AxisDerivs) -> f64 {
        let h = end.t_s - start.t_s;
        (0..self.n_axes)
            .map(|k| (hermite::eval(start.axis(k), end.axis(k), h, tau).p - exact.pos[k]).abs())
            .fold(0.0, f64::max)
    }
}

/// A dwell: time passes, the path stands.
fn is_dwell(seg: &Segment) -> bool {
    seg.ds_mm == 0.0 && seg.v0 == 0.0 && seg.a0 == 0.0 && seg.j == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_config::Config;
    use interpd_motion::Settings;
    use interpd_motion::planner::Planner;
    use interpd_motion::program;

    fn check_dense(text: &str) -> (f64, usize, usize) {
        let cfg = Config::default_machine();
        let p = program::parse(text, "t.ngc", &Settings::from(&cfg)).unwrap();
        let (segs, _) = Planner::plan_path(&Settings::from(&cfg), &p.path).unwrap();
        let mut b = CoarseBuilder::new(&p.path, 0.008, &[50_000.0; interpd_motion::path::MAX_AXES]);
        let mut pts = Vec::new();
        b.build(&segs, 0.0, &mut pts);
        // Independent check: every 0.1 ms, quintic vs exact geometry.
        let mut cursor = interpd_motion::planner::profile::Cursor::default();
        let mut worst: f64 = 0.0;
        let mut exact = AxisDerivs::default();
        let end = pts.last().unwrap().t_s;
        let mut piece = 0;
        let mut t = 0.0;
        while t < end {
            while pts[piece + 1].t_s < t {
                piece += 1;
            }
            let (a, b2) = (&pts[piece], &pts[piece + 1]);
            let st = cursor.sample(&segs, t).unwrap().state;
            p.path.eval(st.s_mm, &mut exact);
            for k in 0..3 {
                let q = hermite::eval(a.axis(k), b2.axis(k), b2.t_s - a.t_s, t - a.t_s);
                worst = worst.max((q.p - exact.pos[k]).abs());
            }
            t += 1e-4;
        }
        assert!((end - interpd_motion::planner::profile::duration_s(&segs)).abs() < 1e-9);
        (worst, pts.len(), segs.len())
    }

    #[test]
    fn circle_points_stay_within_a_micrometre() {
        let (err, points, segs) = check_dense("G1 X10 F3000\nG2 X10 Y0 I-10 J0\nG1 X0");
        assert!(err <= 1e-3, "deviation {err} mm");
        assert!(points < segs, "{points} points for {segs} segments: no grouping");
    }

    #[test]
    fn fast_tight_arc_is_split_until_it_fits() {
        let (err, _, _) = check_dense("G1 X1 F30000\nG3 X1 Y2 I0 J1\nG3 X1 Y0 I0 J-1");
        assert!(err <= 1e-3, "deviation {err} mm");
    }
}
