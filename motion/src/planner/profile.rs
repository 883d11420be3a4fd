//! The planner's output: the path-velocity profile as constant-jerk segments in time
//! (Kopp et al. 2019, eq. 2), the contract between the look-ahead planner and the interpolator.
//!
//! Segments are back to back in time and path position; within a segment
//! s(τ) = s₀ + v₀τ + a₀τ²/2 + jτ³/6 for τ ∈ [0, dt]. A dwell is a segment with v = a = j = 0.

use crate::Settings;
use crate::path::{AxisDerivs, Path};

/// One piece of the planned motion.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Segment {
    /// Path position at the start, mm.
    pub s0_mm: f64,
    /// Time at the start, s (0 at the start of the program).
    pub t0_s: f64,
    /// Path velocity at the start, mm/s.
    pub v0: f64,
    /// Path acceleration at the start, mm/s².
    pub a0: f64,
    /// Path jerk, mm/s³.
    pub j: f64,
    /// Duration, s.
    pub dt_s: f64,
    /// Path length covered, mm (0 for a dwell).
    pub ds_mm: f64,
    /// Program line the segment belongs to.
    pub line: u32,
}

/// Path state at a time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathState {
    pub s_mm: f64,
    pub v: f64,
    pub a: f64,
    pub j: f64,
}

impl Segment {
    pub fn t1_s(&self) -> f64 {
        self.t0_s + self.dt_s
    }

    pub fn s1_mm(&self) -> f64 {
        self.s0_mm + self.ds_mm
    }

    /// State at local time τ (clamped to the segment), Kopp et al. 2019, eq. 2.
    #[inline]
    pub fn at(&self, tau: f64) -> PathState {
        let tau = tau.clamp(0.0, self.dt_s);
        let (v0, a0, j) = (self.v0, self.a0, self.j);
        let ds = v0 * tau + 0.5 * a0 * tau * tau + j * tau * tau * tau / 6.0;
        // Never step past the segment's end through rounding.
        let s = if self.ds_mm > 0.0 { self.s0_mm + ds.min(self.ds_mm) } else { self.s0_mm };
        PathState { s_mm: s, v: v0 + a0 * tau + 0.5 * j * tau * tau, a: a0 + j * tau, j }
    }

    /// The state at absolute time `t_s` (clamped to the segment), with the segment's line and
    /// whether the state lies at the segment's start.
    pub fn sample(&self, t_s: f64) -> Sample {
        let state = self.at(t_s - self.t0_s);
        // Decided by position, not time: just after a stop at a corner the path has moved less
        // than one ulp of s, so s still equals the joint while the motion is already on the
        // element after it (its jerk belongs to that element's direction).
        Sample { state, line: self.line, at_start: state.s_mm <= self.s0_mm }
    }

    /// The segment split at local time `tau_s` (clamped to it): the part before and the part
    /// after, which starts in the state there.
    pub fn split_at(&self, tau_s: f64) -> (Segment, Segment) {
        let tau = tau_s.clamp(0.0, self.dt_s);
        let st = self.at(tau);
        let ds_before = if self.ds_mm > 0.0 { (st.s_mm - self.s0_mm).clamp(0.0, self.ds_mm) } else { 0.0 };
        let before = Segment { dt_s: tau, ds_mm: ds_before, ..*self };
        let after = Segment {
            s0_mm: self.s0_mm + ds_before,
            t0_s: self.t0_s + tau,
            v0: st.v,
            a0: st.a,
            j: self.j,
            dt_s: self.dt_s - tau,
            ds_mm: self.ds_mm - ds_before,
            line: self.line,
        };
        (before, after)
    }
}

/// Walks a time-ordered segment list with a cursor (for sampling in increasing time).
#[derive(Debug, Default)]
pub struct Cursor {
    index: usize,
}

impl Cursor {
    /// State at absolute time `t` with the segment's line and whether the state lies at the
    /// segment's start (so a caller evaluating the geometry at a joint picks the right side).
    pub fn sample(&mut self, segments: &[Segment], t: f64) -> Option<Sample> {
        if segments.is_empty() {
            return None;
        }
        while self.index + 1 < segments.len() && segments[self.index].t1_s() <= t {
            self.index += 1;
        }
        Some(segments[self.index].sample(t))
    }
}

/// A sampled path state (see [`Cursor::sample`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub state: PathState,
    pub line: u32,
    /// The state lies at the segment's start position (s = s₀, also when time has moved on
    /// by less than s can resolve): at a joint, the geometry after it applies.
    pub at_start: bool,
}

/// Total duration of a profile.
pub fn duration_s(segments: &[Segment]) -> f64 {
    segments.last().map_or(0.0, Segment::t1_s)
}

/// The largest |velocity|, |acceleration| and |jerk| of any axis over its limit, sampled every
/// `dt_s` along the exact geometry of `path` (chain rule: A′v, A″v² + A′a,
/// A‴v³ + 3A″va + A′j): the independent check of a profile against the axis limits. At a
/// joint, a sample at the start of a segment sees the element that starts there, any other
/// the element that ends there.
pub fn limit_ratios(path: &Path, segments: &[Segment], settings: &Settings, dt_s: f64) -> [f64; 3] {
    let mut worst = [0.0f64; 3];
    let mut cursor = Cursor::default();
    let mut d = AxisDerivs::default();
    let n = (duration_s(segments) / dt_s) as usize + 1;
    for k in 0..=n {
        let Some(sample) = cursor.sample(segments, k as f64 * dt_s) else { break };
        let st = sample.state;
        if sample.at_start {
            path.eval(st.s_mm, &mut d)
        } else {
            path.eval_left(st.s_mm, &mut d)
        }
        for (i, ax) in settings.axes.iter().enumerate() {
            let [vel, acc, jerk] = d.axis_rates(i, st.v, st.a, st.j);
            worst[0] = worst[0].max(vel.abs() / ax.max_vel_per_s);
            worst[1] = worst[1].max(acc.abs() / ax.max_acc_per_s2);
            worst[2] = worst[2].max(jerk.abs() / ax.max_jerk_per_s3);
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_keeps_the_state() {
        let seg = Segment { s0_mm: 1.0, t0_s: 2.0, v0: 10.0, a0: 100.0, j: -3000.0, dt_s: 0.05, ds_mm: 0.0, line: 3 };
        let seg = Segment { ds_mm: seg.at(0.05).s_mm - 1.0, ..seg };
        let (a, b) = seg.split_at(0.02);
        let e = a.at(a.dt_s);
        assert!((e.s_mm - b.s0_mm).abs() < 1e-12 && (e.v - b.v0).abs() < 1e-12 && (e.a - b.a0).abs() < 1e-12);
        assert!((b.at(b.dt_s).s_mm - seg.at(seg.dt_s).s_mm).abs() < 1e-12);
        assert_eq!((a.t0_s, b.t0_s, b.line), (2.0, 2.02, 3));
    }
}
