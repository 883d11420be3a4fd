//! Step 2, velocity interface: reach the target velocity and acceleration in exactly a given
//! duration T. In the normalised frame (j_max = a_max = 1), with a ramp to a level a_p, a hold
//! and a ramp to a_f:
//!
//! - up then down: t0 = a_p - a0, t2 = a_p - a_f, hold T - t0 - t2; the velocity equation is
//!   a_p² - (T + a0 + a_f) a_p + (a0² + a_f²)/2 + Δv = 0;
//! - up then up (a0 ≤ a_p ≤ a_f): the hold is T - (a_f - a0) and a_p follows linearly;
//! - a single ramp with reduced jerk, before or after a hold at a0 or a_f:
//!   j = (a_f - a0)² / (2 (a_f T - Δv)) or (a_f - a0)² / (2 (Δv - a0 T)).
//!
//! Both directions by mirroring (Ruckig RSS 2021, Sec. V-B).

use crate::brake::BrakeProfile;
use crate::frame::{Candidate, Frame, Orientation, Polish};
use crate::position_step1::opposite;
use crate::position_step2::Step2;
use crate::profile::{JerkSigns, PolishSpec, Profile, ReachedLimits};
use crate::roots::solve_quadratic;
use crate::{Limits, State};

const ROWS: u8 = PolishSpec::END_A | PolishSpec::END_V | PolishSpec::DURATION;

/// A profile lasting exactly `duration` [s] from the braked start state.
pub(crate) fn calculate(
    duration: f64,
    start: &State,
    target: &State,
    limits: &Limits,
    brake: &BrakeProfile,
) -> Option<Profile> {
    if !(duration >= 0.0) {
        return None;
    }
    let mut s2 = Step2::new(duration, *start, *target, limits, *brake, false);
    let first = if target.v >= start.v { Orientation::Up } else { Orientation::Down };
    for orientation in [first, opposite(first)] {
        let f = Frame::new(orientation, start, target, limits);
        let tt = f.time_to_frame(duration);
        if up_down(&f, tt, &mut s2) || up_up(&f, tt, &mut s2) || reduced_jerk(&f, tt, &mut s2) {
            return Some(s2.profile);
        }
    }
    None
}

fn candidate(t: [f64; 3], j: [f64; 3], limits: ReachedLimits, polish: Polish) -> Candidate {
    Candidate {
        t: [t[0], t[1], t[2], 0.0, 0.0, 0.0, 0.0],
        j: [j[0], j[1], j[2], 0.0, 0.0, 0.0, 0.0],
        limits,
        signs: JerkSigns::Uddu,
        polish,
    }
}

fn up_down(f: &Frame, tt: f64, s2: &mut Step2) -> bool {
    let vd = f.vf - f.v0;
    let roots = solve_quadratic(1.0, -(tt + f.a0 + f.af), 0.5 * (f.a0 * f.a0 + f.af * f.af) + vd);
    for &peak in roots.as_slice() {
        let (t0, t2) = (peak - f.a0, peak - f.af);
        let hold = tt - t0 - t2;
        if t0 < 0.0 || t2 < 0.0 || hold < 0.0 || peak > 1.0 {
            continue;
        }
        let limits = if peak >= 1.0 { ReachedLimits::Acc0 } else { ReachedLimits::None };
        let c = candidate([t0, hold, t2], [1.0, 0.0, -1.0], limits, Polish::new(&[0, 1, 2], ROWS));
        if s2.try_candidate(f, &c) {
            return true;
        }
    }
    false
}

fn up_up(f: &Frame, tt: f64, s2: &mut Step2) -> bool {
    let hold = tt - (f.af - f.a0);
    if !(hold > 0.0) || f.af < f.a0 {
        return false;
    }
    let peak = (f.vf - f.v0 - 0.5 * (f.af * f.af - f.a0 * f.a0)) / hold;
    if peak < f.a0 || peak > f.af {
        return false;
    }
    let c = candidate([peak - f.a0, hold, f.af - peak], [1.0, 0.0, 1.0], ReachedLimits::None, Polish::NONE);
    s2.try_candidate(f, &c)
}

fn reduced_jerk(f: &Frame, tt: f64, s2: &mut Step2) -> bool {
    let vd = f.vf - f.v0;
    let ad = f.af - f.a0;
    if ad == 0.0 {
        // Hold the acceleration for the whole duration.
        let c = candidate([0.0, tt, 0.0], [0.0, 0.0, 0.0], ReachedLimits::None, Polish::NONE);
        return s2.try_candidate(f, &c);
    }
    // Ramp to a_f, then hold it.
    let jf = ad * ad / (2.0 * (f.af * tt - vd));
    if jf > 0.0 && jf <= 1.0 {
        let ramp = ad / jf;
        let c = candidate([ramp, tt - ramp, 0.0], [jf, 0.0, 0.0], ReachedLimits::None, Polish::NONE);
        if s2.try_candidate(f, &c) {
            return true;
        }
    }
    // Hold a0, then ramp to a_f.
    let jf = ad * ad / (2.0 * (vd - f.a0 * tt));
    if jf > 0.0 && jf <= 1.0 {
        let ramp = ad / jf;
        let c = candidate([0.0, tt - ramp, ramp], [0.0, 0.0, jf], ReachedLimits::None, Polish::NONE);
        if s2.try_candidate(f, &c) {
            return true;
        }
    }
    false
}
