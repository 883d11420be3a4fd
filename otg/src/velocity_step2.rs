//! Step 2, velocity interface: reach the target velocity and acceleration in exactly a given
//! duration (Berscheid & Kröger, RSS 2021, Sec. V-B): a hold at an acceleration level between
//! two ramps (ACC0: up-down or up-up), or a single ramp with the jerk reduced below the limit
//! before or after a hold (NONE).
//!
//! Ported from Ruckig's `velocity-third-step2.cpp` (L. Berscheid, MIT licence,
//! <https://github.com/pantor/ruckig>); the lower direction passes the mirrored limits.

use crate::profile::{ControlSigns, Profile, ReachedLimits};

/// Inputs below this count as zero (Ruckig: ε).
const ZERO: f64 = f64::EPSILON;

struct Step2 {
    a0: f64,
    af: f64,
    tf: f64,
    vd: f64,
    ad: f64,
}

impl Step2 {
    fn try_acc0(&self, p: &mut Profile, t: [f64; 7], a_max: f64, a_min: f64, j_max: f64) -> bool {
        p.t = t;
        if p.check_for_velocity_with_timing_and_jerk(
            self.tf,
            ControlSigns::Uddu,
            ReachedLimits::Acc0,
            j_max,
            a_max,
            a_min,
            j_max,
        ) {
            p.pf = p.p[7];
            return true;
        }
        false
    }

    fn time_acc0(&self, p: &mut Profile, a_max: f64, a_min: f64, j_max: f64) -> bool {
        let Step2 { a0, af, tf, vd, ad } = *self;
        // Up, hold, down.
        let h1 = ((-ad * ad + 2.0 * j_max * ((a0 + af) * tf - 2.0 * vd)) / (j_max * j_max) + tf * tf).sqrt();
        let t0 = ad / (2.0 * j_max) + (tf - h1) / 2.0;
        if self.try_acc0(p, [t0, h1, tf - (t0 + h1), 0.0, 0.0, 0.0, 0.0], a_max, a_min, j_max) {
            return true;
        }
        // Up, hold, up.
        let h1 = -ad + j_max * tf;
        let t0 = -ad * ad / (2.0 * j_max * h1) + (vd - a0 * tf) / h1;
        let t1 = -ad / j_max + tf;
        if self.try_acc0(p, [t0, t1, 0.0, 0.0, 0.0, 0.0, tf - (t0 + t1)], a_max, a_min, j_max) {
            return true;
        }
        // Hold, up (two steps).
        self.try_acc0(p, [0.0, -ad / j_max + tf, 0.0, 0.0, 0.0, 0.0, ad / j_max], a_max, a_min, j_max)
    }

    fn time_none(&self, p: &mut Profile, a_max: f64, a_min: f64, j_max: f64) -> bool {
        let Step2 { a0, af, tf, vd, ad } = *self;
        if a0.abs() < ZERO && af.abs() < ZERO && vd.abs() < ZERO {
            p.t = [0.0, tf, 0.0, 0.0, 0.0, 0.0, 0.0];
            if p.check_for_velocity_with_timing_and_jerk(
                tf,
                ControlSigns::Uddu,
                ReachedLimits::None,
                j_max,
                a_max,
                a_min,
                j_max,
            ) {
                p.pf = p.p[7];
                return true;
            }
        }
        // A single ramp with reduced jerk, then a hold.
        let h1 = 2.0 * (af * tf - vd);
        let t0 = h1 / ad;
        p.t = [t0, tf - t0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let jf = ad * ad / h1;
        if p.check_for_velocity_with_timing_and_jerk(
            tf,
            ControlSigns::Uddu,
            ReachedLimits::None,
            jf,
            a_max,
            a_min,
            j_max,
        ) {
            p.pf = p.p[7];
            return true;
        }
        false
    }

    fn check_all(&self, p: &mut Profile, a_max: f64, a_min: f64, j_max: f64) -> bool {
        self.time_acc0(p, a_max, a_min, j_max) || self.time_none(p, a_max, a_min, j_max)
    }
}

/// A profile lasting exactly `tf` (s); `p` carries the boundary and receives the profile.
pub(crate) fn calculate(p: &mut Profile, tf: f64, a_max: f64, a_min: f64, j_max: f64) -> bool {
    let (a0, af) = (p.a[0], p.af);
    let s = Step2 { a0, af, tf, vd: p.vf - p.v[0], ad: af - a0 };
    // The direction of the velocity change first.
    let up = (a_max, a_min, j_max);
    let down = (a_min, a_max, -j_max);
    let (first, second) = if s.vd > 0.0 { (up, down) } else { (down, up) };
    s.check_all(p, first.0, first.1, first.2) || s.check_all(p, second.0, second.1, second.2)
}
