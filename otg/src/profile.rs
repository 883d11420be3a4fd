//! The single-DoF motion: an optional brake pre-phase and seven constant-jerk phases, the states
//! at the phase boundaries, and the check that accepts a candidate only if it reaches the target
//! and respects every limit (Berscheid & Kröger, RSS 2021, Sec. IV: every candidate profile of
//! step 1 and step 2 is integrated and checked).
//!
//! Ported from Ruckig's `profile.hpp` (MIT licence, <https://github.com/pantor/ruckig>): the
//! same phase bookkeeping and the same checks, so that candidates are accepted or rejected as in
//! Ruckig. Two deliberate differences: the limit margins are relative to the limits, and the
//! target precisions are relative to max(1, magnitude of the quantity along the profile)
//! (Ruckig's are absolute and tuned for SI units near 1; interpd's limits span six decades).
//! The profiles finally used are refined afterwards (module `refine`).

use crate::brake::BrakeProfile;
use crate::phase::integrate;

/// Margin on velocity and acceleration limits, relative to the limit (Ruckig: 1e-12 absolute).
const LIMIT_EPS_REL: f64 = 1e-12;
/// Margin on a reduced jerk, relative to the jerk limit (Ruckig: 1e-12 absolute).
pub(crate) const JERK_EPS_REL: f64 = 1e-12;
/// Target precision of the position, relative to max(1, |p| along the profile) (Ruckig: 1e-8).
const P_PRECISION: f64 = 1e-8;
/// Target precision of the velocity, relative to max(1, |v| along the profile) (Ruckig: 1e-8).
const V_PRECISION: f64 = 1e-8;
/// Target precision of the acceleration, relative to max(1, |a| along the profile) (Ruckig: 1e-10).
const A_PRECISION: f64 = 1e-10;
/// Profiles longer than this are rejected as numerically meaningless (s) (Ruckig: 1e12).
const T_MAX_S: f64 = 1e12;
/// Phases that must have a positive length (a plateau at a limit) must be longer than this (s).
const T_EPS_S: f64 = f64::EPSILON;
/// Products a_i·a_{i+1} below -this mark a zero crossing of the acceleration inside a phase.
const A_SIGN_CHANGE_EPS: f64 = f64::EPSILON;

/// Which limits a profile reaches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReachedLimits {
    /// Both acceleration limits and the velocity limit.
    Acc0Acc1Vel,
    /// Only the velocity limit.
    Vel,
    /// The acceleration limit while speeding up.
    Acc0,
    /// The acceleration limit while slowing down.
    Acc1,
    /// Both acceleration limits.
    Acc0Acc1,
    /// Acceleration limit while speeding up and the velocity limit.
    Acc0Vel,
    /// Acceleration limit while slowing down and the velocity limit.
    Acc1Vel,
    /// No limit.
    #[default]
    None,
}

impl ReachedLimits {
    /// Profiles with a cruise phase at the velocity limit.
    #[inline]
    const fn has_cruise(self) -> bool {
        matches!(
            self,
            ReachedLimits::Acc0Acc1Vel | ReachedLimits::Acc0Vel | ReachedLimits::Acc1Vel | ReachedLimits::Vel
        )
    }
}

/// Sign of the first jerk phase: motion towards the upper (`Up`) or the lower limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Direction {
    #[default]
    Up,
    Down,
}

/// Sign pattern of the four jerk phases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ControlSigns {
    /// up, down, down, up
    #[default]
    Uddu,
    /// up, down, up, down
    Udud,
}

/// One DoF's motion: a brake pre-phase (possibly empty) followed by seven constant-jerk phases.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Profile {
    /// Phase durations (s).
    pub t: [f64; 7],
    /// End time of each phase, measured from the end of the brake pre-phase (s).
    pub t_sum: [f64; 7],
    /// Jerk of each phase.
    pub j: [f64; 7],
    /// Acceleration at the phase boundaries (index 0: start of the main profile, 7: its end).
    pub a: [f64; 8],
    /// Velocity at the phase boundaries.
    pub v: [f64; 8],
    /// Position at the phase boundaries.
    pub p: [f64; 8],
    /// Pre-phase that brings an out-of-limit initial state back inside the limits.
    pub brake: BrakeProfile,
    /// Target position.
    pub pf: f64,
    /// Target velocity.
    pub vf: f64,
    /// Target acceleration.
    pub af: f64,
    /// Limits reached.
    pub limits: ReachedLimits,
    /// Direction of the first jerk phase.
    pub direction: Direction,
    /// Jerk sign pattern.
    pub control_signs: ControlSigns,
}

/// What a candidate is checked against.
pub(crate) struct Candidate {
    pub signs: ControlSigns,
    pub limits: ReachedLimits,
    pub set_limits: bool,
    pub jf: f64,
    pub v_max: f64,
    pub v_min: f64,
    pub a_max: f64,
    pub a_min: f64,
}

/// max(1, |x_i|, |extra|).
#[inline]
pub(crate) fn magnitude(values: &[f64], extra: f64) -> f64 {
    values.iter().fold(extra.abs().max(1.0), |m, x| m.max(x.abs()))
}

/// max(|x_i|, |extra|), or 1 if all are zero.
#[inline]
pub(crate) fn magnitude_or_one(values: &[f64], extra: f64) -> f64 {
    let m = values.iter().fold(extra.abs(), |m, x| m.max(x.abs()));
    if m > 0.0 { m } else { 1.0 }
}

/// `|x - target| < precision · max(1, magnitude)`, the magnitude computed only when needed.
#[inline]
fn within_precision(x: f64, target: f64, precision: f64, along: &[f64]) -> bool {
    let err = (x - target).abs();
    err < precision || err < precision * magnitude(along, target)
}

impl Profile {
    /// Duration of the brake pre-phase and the seven phases (s).
    #[inline]
    pub fn duration(&self) -> f64 {
        self.brake.duration + self.t_sum[6]
    }

    /// The jerk of the first ramp direction (+j of a UDDU/UDUD profile going up), recovered from
    /// the phases that are not empty; `j` phases all have this magnitude.
    pub(crate) fn ramp_jerk(&self) -> f64 {
        let signs = match self.control_signs {
            ControlSigns::Uddu => [1.0, -1.0, -1.0, 1.0],
            ControlSigns::Udud => [1.0, -1.0, 1.0, -1.0],
        };
        for (k, sign) in signs.into_iter().enumerate() {
            if self.t[2 * k] > 0.0 && self.j[2 * k] != 0.0 {
                return sign * self.j[2 * k];
            }
        }
        0.0
    }

    /// Check phase durations ≥ 0 and fill `t_sum`; false for a negative duration.
    #[inline]
    fn fill_t_sum(&mut self) -> bool {
        if self.t[0] < 0.0 {
            return false;
        }
        self.t_sum[0] = self.t[0];
        for i in 0..6 {
            if self.t[i + 1] < 0.0 {
                return false;
            }
            self.t_sum[i + 1] = self.t_sum[i] + self.t[i + 1];
        }
        true
    }

    /// Jerks of the four ramps for the sign pattern (zero for empty phases).
    #[inline]
    fn set_jerks(&mut self, signs: ControlSigns, jf: f64) {
        let (s4, s6) = match signs {
            ControlSigns::Uddu => (-1.0, 1.0),
            ControlSigns::Udud => (1.0, -1.0),
        };
        let on = |t: f64, j: f64| if t > 0.0 { j } else { 0.0 };
        self.j = [on(self.t[0], jf), 0.0, on(self.t[2], -jf), 0.0, on(self.t[4], s4 * jf), 0.0, on(self.t[6], s6 * jf)];
    }

    /// Step 1, position interface: integrate the candidate (durations in `t`) with jerk `jf` and
    /// accept it if it reaches the target and respects the limits. The limits are given in the
    /// direction of the profile (mirrored for `Down`). `set_limits` pins the plateau
    /// accelerations to the limits they are known to equal (removes rounding).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check(
        &mut self,
        signs: ControlSigns,
        limits: ReachedLimits,
        set_limits: bool,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits, jf, v_max, v_min, a_max, a_min };
        self.check_position(&c)
    }

    /// Step 2, position interface: like [`Profile::check`] for a profile that must last `tf`.
    /// The duration itself is not checked (as in Ruckig): every step-2 family computes one phase
    /// as tf minus the others; the parameter keeps the call sites readable.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_with_timing(
        &mut self,
        _tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max, v_min, a_max, a_min };
        self.check_position(&c)
    }

    /// [`Profile::check_with_timing`] with a jerk `jf` that may be below the limit `j_max`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_with_timing_and_jerk(
        &mut self,
        tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
        j_max: f64,
    ) -> bool {
        jf.abs() < j_max.abs() * (1.0 + JERK_EPS_REL)
            && self.check_with_timing(tf, signs, limits, jf, v_max, v_min, a_max, a_min)
    }

    /// The check of the position interface (Ruckig's `Profile::check`), followed by the
    /// refinement of an accepted candidate whose end state or pinned plateaus are off by more
    /// than rounding.
    pub(crate) fn check_position(&mut self, c: &Candidate) -> bool {
        if !self.fill_t_sum() {
            return false;
        }
        let limits = c.limits;
        if limits.has_cruise() && self.t[3] < T_EPS_S {
            return false;
        }
        if matches!(limits, ReachedLimits::Acc0 | ReachedLimits::Acc0Acc1) && self.t[1] < T_EPS_S {
            return false;
        }
        if matches!(limits, ReachedLimits::Acc1 | ReachedLimits::Acc0Acc1) && self.t[5] < T_EPS_S {
            return false;
        }
        if self.t_sum[6] > T_MAX_S {
            return false;
        }
        self.set_jerks(c.signs, c.jf);

        let up = c.v_max > 0.0;
        self.direction = if up { Direction::Up } else { Direction::Down };
        let v_eps = LIMIT_EPS_REL * c.v_max.abs().max(c.v_min.abs());
        let v_upp = if up { c.v_max } else { c.v_min } + v_eps;
        let v_low = if up { c.v_min } else { c.v_max } - v_eps;
        let zero_at_3 = limits.has_cruise() || limits == ReachedLimits::Acc0Acc1;

        for i in 0..7 {
            let (t, j) = (self.t[i], self.j[i]);
            self.a[i + 1] = self.a[i] + t * j;
            self.v[i + 1] = self.v[i] + t * (self.a[i] + t * j / 2.0);
            self.p[i + 1] = self.p[i] + t * (self.v[i] + t * (self.a[i] / 2.0 + t * j / 6.0));

            let pin = if zero_at_3 && i == 2 {
                Some(0.0)
            } else if c.set_limits && limits == ReachedLimits::Acc1 && i == 2 {
                Some(c.a_min)
            } else if c.set_limits && limits == ReachedLimits::Acc0Acc1 && i == 0 {
                Some(c.a_max)
            } else if c.set_limits && limits == ReachedLimits::Acc0Acc1 && i == 4 {
                Some(c.a_min)
            } else {
                None
            };
            if let Some(value) = pin {
                self.a[i + 1] = value;
            }
            // Velocity extremum inside a phase where the acceleration changes sign.
            if i > 1 && self.a[i + 1] * self.a[i] < -A_SIGN_CHANGE_EPS {
                let v_a_zero = self.v[i] - (self.a[i] * self.a[i]) / (2.0 * self.j[i]);
                if v_a_zero > v_upp || v_a_zero < v_low {
                    return false;
                }
            }
        }
        self.control_signs = c.signs;
        self.limits = limits;

        let a_eps = LIMIT_EPS_REL * c.a_max.abs().max(c.a_min.abs());
        let a_upp = if up { c.a_max } else { c.a_min } + a_eps;
        let a_low = if up { c.a_min } else { c.a_max } - a_eps;
        let (a, v) = (&self.a, &self.v);
        within_precision(self.p[7], self.pf, P_PRECISION, &self.p)
            && within_precision(v[7], self.vf, V_PRECISION, v)
            && within_precision(a[7], self.af, A_PRECISION, a)
            && a[1] >= a_low
            && a[3] >= a_low
            && a[5] >= a_low
            && a[1] <= a_upp
            && a[3] <= a_upp
            && a[5] <= a_upp
            && v[3] <= v_upp
            && v[4] <= v_upp
            && v[5] <= v_upp
            && v[6] <= v_upp
            && v[3] >= v_low
            && v[4] >= v_low
            && v[5] >= v_low
            && v[6] >= v_low
    }

    /// Velocity interface, step 1: like [`Profile::check`] without position and velocity limits.
    #[inline]
    pub(crate) fn check_for_velocity(
        &mut self,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max: 0.0, v_min: 0.0, a_max, a_min };
        self.check_velocity(&c)
    }

    /// Velocity interface, step 2: a profile that must last `tf` (not checked, see
    /// [`Profile::check_with_timing`]), with a jerk `jf` that may be below the limit `j_max`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_for_velocity_with_timing_and_jerk(
        &mut self,
        _tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        a_max: f64,
        a_min: f64,
        j_max: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max: 0.0, v_min: 0.0, a_max, a_min };
        jf.abs() < j_max.abs() * (1.0 + JERK_EPS_REL) && self.check_velocity(&c)
    }

    /// Ruckig's `check_for_velocity`, followed by the refinement of an accepted candidate.
    pub(crate) fn check_velocity(&mut self, c: &Candidate) -> bool {
        if !self.fill_t_sum() {
            return false;
        }
        if c.limits == ReachedLimits::Acc0 && self.t[1] < T_EPS_S {
            return false;
        }
        if self.t_sum[6] > T_MAX_S {
            return false;
        }
        self.set_jerks(c.signs, c.jf);
        for i in 0..7 {
            let (t, j) = (self.t[i], self.j[i]);
            self.a[i + 1] = self.a[i] + t * j;
            self.v[i + 1] = self.v[i] + t * (self.a[i] + t * j / 2.0);
            self.p[i + 1] = self.p[i] + t * (self.v[i] + t * (self.a[i] / 2.0 + t * j / 6.0));
        }
        self.control_signs = c.signs;
        self.limits = c.limits;
        let up = c.a_max > 0.0;
        self.direction = if up { Direction::Up } else { Direction::Down };
        let a_eps = LIMIT_EPS_REL * c.a_max.abs().max(c.a_min.abs());
        let a_upp = if up { c.a_max } else { c.a_min } + a_eps;
        let a_low = if up { c.a_min } else { c.a_max } - a_eps;
        let a = &self.a;
        within_precision(self.v[7], self.vf, V_PRECISION, &self.v)
            && within_precision(a[7], self.af, A_PRECISION, a)
            && a[1] >= a_low
            && a[3] >= a_low
            && a[5] >= a_low
            && a[1] <= a_upp
            && a[3] <= a_upp
            && a[5] <= a_upp
    }

    /// Whether the velocity stays within [v_min, v_max] over the whole profile, including the
    /// first phases and the extrema inside phases (the checks above skip the first phases,
    /// which the step-1/2 families never take beyond the limits; a phase-synchronised copy of
    /// another DoF's timing can).
    pub(crate) fn velocity_within(&self, v_max: f64, v_min: f64) -> bool {
        let v_eps = LIMIT_EPS_REL * v_max.abs().max(v_min.abs());
        let (hi, lo) = (v_max + v_eps, v_min - v_eps);
        (0..7).all(|i| {
            let v_end = self.v[i + 1];
            let inside = v_end <= hi && v_end >= lo;
            let (a0, a1) = (self.a[i], self.a[i + 1]);
            let extremum_inside = if self.j[i] != 0.0 && a0 * a1 < 0.0 {
                let v_ext = self.v[i] - a0 * a0 / (2.0 * self.j[i]);
                v_ext <= hi && v_ext >= lo
            } else {
                true
            };
            inside && extremum_inside
        })
    }

    /// Start state (after the brake) and target of the position interface.
    #[inline]
    pub(crate) fn set_boundary(&mut self, p0: f64, v0: f64, a0: f64, pf: f64, vf: f64, af: f64) {
        self.a[0] = a0;
        self.v[0] = v0;
        self.p[0] = p0;
        self.af = af;
        self.vf = vf;
        self.pf = pf;
    }

    /// Copy start state, target and brake of another profile.
    #[inline]
    pub(crate) fn set_boundary_from(&mut self, other: &Profile) {
        self.a[0] = other.a[0];
        self.v[0] = other.v[0];
        self.p[0] = other.p[0];
        self.af = other.af;
        self.vf = other.vf;
        self.pf = other.pf;
        self.brake = other.brake;
    }

    /// Kinematic state (p, v, a, j) at time `t` measured from the start of the brake pre-phase.
    /// After the end the motion continues with the final acceleration and zero jerk.
    pub fn state_at(&self, t: f64) -> (f64, f64, f64, f64) {
        let mut t = t;
        if self.brake.duration > 0.0 {
            if t < self.brake.duration {
                let idx = if t < self.brake.t[0] { 0 } else { 1 };
                if idx > 0 {
                    t -= self.brake.t[0];
                }
                let (p, v, a) =
                    integrate(t, self.brake.p[idx], self.brake.v[idx], self.brake.a[idx], self.brake.j[idx]);
                return (p, v, a, self.brake.j[idx]);
            }
            t -= self.brake.duration;
        }
        // First phase whose end lies after t (upper bound; phases are few: linear scan).
        let mut idx = 0;
        while idx < 7 && self.t_sum[idx] <= t {
            idx += 1;
        }
        if idx >= 7 {
            let (p, v, a) = integrate(t - self.t_sum[6], self.p[7], self.v[7], self.a[7], 0.0);
            return (p, v, a, 0.0);
        }
        let t_start = if idx == 0 { 0.0 } else { self.t_sum[idx - 1] };
        let (p, v, a) = integrate(t - t_start, self.p[idx], self.v[idx], self.a[idx], self.j[idx]);
        (p, v, a, self.j[idx])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rest to rest over distance 2 with unit limits: ramp up 1 s, ramp down 2 s, ramp up 1 s.
    fn none_profile(pf: f64) -> Profile {
        let mut p = Profile::default();
        p.set_boundary(0.0, 0.0, 0.0, pf, 0.0, 0.0);
        p.t = [1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
        p
    }

    #[test]
    fn accepts_exact_profile_and_integrates_boundaries() {
        let mut p = none_profile(2.0);
        assert!(p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
        assert_eq!(p.t_sum[6], 4.0);
        let (pos, vel, acc, _) = p.state_at(2.0);
        assert!((pos - 1.0).abs() < 1e-15 && (vel - 1.0).abs() < 1e-15 && acc.abs() < 1e-15);
        let (pos, vel, _, jerk) = p.state_at(10.0);
        assert_eq!((pos, vel, jerk), (2.0, 0.0, 0.0));
    }

    #[test]
    fn rejects_limit_violation_missed_target_and_negative_durations() {
        let mut p = none_profile(2.0);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 0.9, -0.9, 1.0, -1.0));
        let mut p = none_profile(2.1);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
        let mut p = none_profile(2.0);
        p.t[1] = -1e-3;
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
    }

    #[test]
    fn precision_is_relative_to_the_magnitude() {
        // The same profile a million times larger in position (jerk 1e6): an error that is
        // rounding-size relative to the positions is accepted.
        let mut p = none_profile(2e6 + 1e-4);
        assert!(p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1e6, 1e6, -1e6, 1e6, -1e6));
        let mut p = none_profile(2e6 + 1.0);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1e6, 1e6, -1e6, 1e6, -1e6));
    }
}
