//! Step 1, velocity interface: reach a target velocity and acceleration (position free) in
//! minimum time; used for feed-override ramps and jogging (Berscheid & Kröger, RSS 2021,
//! Sec. V-B). At most three phases: ramp, hold at the acceleration limit (ACC0), ramp; or two
//! ramps through a peak (NONE, two solutions). With a target acceleration other than zero there
//! can be a blocked interval.
//!
//! Ported from Ruckig's `velocity-third-step1.cpp` (L. Berscheid, MIT licence,
//! <https://github.com/pantor/ruckig>); the lower direction passes the mirrored limits.

use crate::block::Block;
use crate::position_step1::MAX_PROFILES;
use crate::profile::{ControlSigns, Profile, ReachedLimits};

/// Inputs below this count as zero (Ruckig: ε).
const ZERO: f64 = f64::EPSILON;

struct Step1<'a> {
    a0: f64,
    af: f64,
    vd: f64,
    profiles: &'a mut [Profile; MAX_PROFILES],
    n: usize,
}

impl Step1<'_> {
    /// Check the current candidate (phase durations `t`); keep it if valid.
    fn accept(&mut self, t: [f64; 7], limits: ReachedLimits, a_max: f64, a_min: f64, j_max: f64) -> bool {
        let p = &mut self.profiles[self.n];
        p.t = t;
        let ok = p.check_for_velocity(ControlSigns::Uddu, limits, j_max, a_max, a_min);
        if ok && self.n + 1 < MAX_PROFILES {
            self.n += 1;
            let (done, next) = self.profiles.split_at_mut(self.n);
            next[0].set_boundary_from(&done[self.n - 1]);
        }
        ok
    }

    /// Ramp to the acceleration limit, hold, ramp to a_f.
    fn time_acc0(&mut self, a_max: f64, a_min: f64, j_max: f64) {
        let (a0, af, vd) = (self.a0, self.af, self.vd);
        let t = [
            (-a0 + a_max) / j_max,
            (a0 * a0 + af * af) / (2.0 * a_max * j_max) - a_max / j_max + vd / a_max,
            (-af + a_max) / j_max,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        self.accept(t, ReachedLimits::Acc0, a_max, a_min, j_max);
    }

    /// Ramp to a peak and back to a_f (both roots of the peak).
    fn time_none(&mut self, a_max: f64, a_min: f64, j_max: f64, return_after_found: bool) {
        let (a0, af, vd) = (self.a0, self.af, self.vd);
        let h1 = (a0 * a0 + af * af) / 2.0 + j_max * vd;
        if h1.is_nan() || h1 < 0.0 {
            return;
        }
        let h1 = h1.sqrt();
        let t = [-(a0 + h1) / j_max, 0.0, -(af + h1) / j_max, 0.0, 0.0, 0.0, 0.0];
        if self.accept(t, ReachedLimits::None, a_max, a_min, j_max) && return_after_found {
            return;
        }
        let t = [(-a0 + h1) / j_max, 0.0, (-af + h1) / j_max, 0.0, 0.0, 0.0, 0.0];
        self.accept(t, ReachedLimits::None, a_max, a_min, j_max);
    }
}

/// Step 1 for one DoF: `profiles[0]` carries the boundary (braked start state, target, brake).
/// Fills `block`; false if no valid profile exists.
pub(crate) fn calculate(
    profiles: &mut [Profile; MAX_PROFILES],
    block: &mut Block,
    a_max: f64,
    a_min: f64,
    j_max: f64,
) -> bool {
    let first = &profiles[0];
    let (a0, af, vd) = (first.a[0], first.af, first.vf - first.v[0]);
    let mut s = Step1 { a0, af, vd, profiles, n: 0 };
    if af.abs() < ZERO {
        // No blocked interval when a_f = 0: the first valid profile, in the direction of the
        // target velocity first.
        let (hi, lo, j) = if vd >= 0.0 { (a_max, a_min, j_max) } else { (a_min, a_max, -j_max) };
        s.time_none(hi, lo, j, true);
        if s.n == 0 {
            s.time_acc0(hi, lo, j);
        }
        if s.n == 0 {
            s.time_none(lo, hi, -j, true);
        }
        if s.n == 0 {
            s.time_acc0(lo, hi, -j);
        }
    } else {
        s.time_none(a_max, a_min, j_max, false);
        s.time_none(a_min, a_max, -j_max, false);
        s.time_acc0(a_max, a_min, j_max);
        s.time_acc0(a_min, a_max, -j_max);
    }
    let n = s.n;
    block.calculate(&mut profiles[..], n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_change_triangle_and_trapezoid() {
        let mut profiles = [Profile::default(); MAX_PROFILES];
        let mut block = Block::default();
        // Δv = 0.5 with unit limits: triangle with peak sqrt(0.5).
        profiles[0].v[0] = 0.0;
        profiles[0].vf = 0.5;
        assert!(calculate(&mut profiles, &mut block, 1.0, -1.0, 1.0));
        assert!((block.t_min - 2.0 * 0.5f64.sqrt()).abs() < 1e-12);
        // Δv = -3: trapezoid, 1 s ramps and 2 s hold.
        let mut profiles = [Profile::default(); MAX_PROFILES];
        profiles[0].vf = -3.0;
        assert!(calculate(&mut profiles, &mut block, 1.0, -1.0, 1.0));
        assert!((block.t_min - 4.0).abs() < 1e-12);
    }
}
