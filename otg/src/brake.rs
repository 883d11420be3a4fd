//! Brake pre-phase: brings an initial state that is outside the limits, or that will inevitably
//! leave them (v below v_max but a > 0 so large that v overshoots), back inside with at most two
//! constant-jerk phases (a jerk ramp, then an acceleration plateau). The time-optimal profile then
//! starts from the braked state.
//!
//! This is Ruckig's strategy (Berscheid & Kröger, RSS 2021, Sec. V-A), ported from its
//! `brake.cpp` (MIT licence, <https://github.com/pantor/ruckig>) with the same case analysis, so
//! that the overall durations can be compared with Ruckig's directly. The limits are passed
//! mirrored (v_max ↔ v_min, a_max ↔ a_min, -j) for the lower side, as in Ruckig.

use crate::phase::integrate;

/// Safety margin added to brake phase durations so that the braked state lies strictly inside
/// the limits despite rounding (Ruckig: 2.2e-14 s), scaled up for phases much longer than 1 s.
const BRAKE_EPS_S: f64 = 2.2e-14;

/// Up to two phases of constant jerk that precede the main profile.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BrakeProfile {
    /// Total duration of the pre-phase (s) (0 when the initial state is already safe).
    pub duration: f64,
    /// Phase durations (s).
    pub t: [f64; 2],
    /// Jerk of each phase.
    pub j: [f64; 2],
    /// Acceleration at the start of each phase.
    pub a: [f64; 2],
    /// Velocity at the start of each phase.
    pub v: [f64; 2],
    /// Position at the start of each phase.
    pub p: [f64; 2],
}

/// Margin for a phase of duration `t`.
#[inline]
fn eps_for(t: f64) -> f64 {
    BRAKE_EPS_S * t.abs().max(1.0)
}

/// Velocity after `t` seconds with jerk `j`.
#[inline]
fn v_at_t(v0: f64, a0: f64, j: f64, t: f64) -> f64 {
    v0 + t * (a0 + j * t / 2.0)
}

/// Velocity reached when the acceleration is ramped to zero with jerk of magnitude |j|
/// (sign convention of Ruckig: `j` is the jerk that brings `a0` back to zero, negated).
#[inline]
fn v_at_a_zero(v0: f64, a0: f64, j: f64) -> f64 {
    v0 + (a0 * a0) / (2.0 * j)
}

impl BrakeProfile {
    /// Brake for the position interface (Ruckig `get_position_brake_trajectory`).
    pub(crate) fn position(v0: f64, a0: f64, v_max: f64, v_min: f64, a_max: f64, a_min: f64, j_max: f64) -> Self {
        let mut b = BrakeProfile::default();
        if a0 > a_max {
            b.acceleration_brake(v0, a0, v_max, v_min, a_max, a_min, j_max);
        } else if a0 < a_min {
            b.acceleration_brake(v0, a0, v_min, v_max, a_min, a_max, -j_max);
        } else if (v0 > v_max && v_at_a_zero(v0, a0, -j_max) > v_min)
            || (a0 > 0.0 && v_at_a_zero(v0, a0, j_max) > v_max)
        {
            b.velocity_brake(v0, a0, v_max, v_min, a_max, a_min, j_max);
        } else if (v0 < v_min && v_at_a_zero(v0, a0, j_max) < v_max)
            || (a0 < 0.0 && v_at_a_zero(v0, a0, -j_max) < v_min)
        {
            b.velocity_brake(v0, a0, v_min, v_max, a_min, a_max, -j_max);
        }
        b
    }

    /// Brake for the velocity interface: only the acceleration has limits.
    pub(crate) fn velocity(a0: f64, a_max: f64, a_min: f64, j_max: f64) -> Self {
        let mut b = BrakeProfile::default();
        if a0 > a_max {
            b.j[0] = -j_max;
            let t = (a0 - a_max) / j_max;
            b.t[0] = t + eps_for(t);
        } else if a0 < a_min {
            b.j[0] = j_max;
            let t = -(a0 - a_min) / j_max;
            b.t[0] = t + eps_for(t);
        }
        b
    }

    /// a0 beyond the acceleration limit: ramp it down; continue as a velocity brake if the
    /// velocity would still overshoot, or hold the limit if the velocity would undershoot.
    #[allow(clippy::too_many_arguments)]
    fn acceleration_brake(&mut self, v0: f64, a0: f64, v_max: f64, v_min: f64, a_max: f64, a_min: f64, j_max: f64) {
        self.j[0] = -j_max;
        let t_to_a_max = (a0 - a_max) / j_max;
        let t_to_a_zero = a0 / j_max;
        let v_at_a_max = v_at_t(v0, a0, -j_max, t_to_a_max);
        let v_at_a_zero = v_at_t(v0, a0, -j_max, t_to_a_zero);

        if (v_at_a_zero > v_max && j_max > 0.0) || (v_at_a_zero < v_max && j_max < 0.0) {
            self.velocity_brake(v0, a0, v_max, v_min, a_max, a_min, j_max);
        } else if (v_at_a_max < v_min && j_max > 0.0) || (v_at_a_max > v_min && j_max < 0.0) {
            let t_to_v_min = -(v_at_a_max - v_min) / a_max;
            let t_to_v_max = -a_max / (2.0 * j_max) - (v_at_a_max - v_max) / a_max;
            self.t[0] = t_to_a_max + eps_for(t_to_a_max);
            self.t[1] = t_to_v_min.min(t_to_v_max - eps_for(t_to_v_max)).max(0.0);
        } else {
            self.t[0] = t_to_a_max + eps_for(t_to_a_max);
        }
    }

    /// The velocity is or will be beyond v_max: ramp the acceleration towards a_min until the
    /// velocity can come back; hold a_min if it is reached first.
    #[allow(clippy::too_many_arguments)]
    fn velocity_brake(&mut self, v0: f64, a0: f64, v_max: f64, v_min: f64, _a_max: f64, a_min: f64, j_max: f64) {
        self.j[0] = -j_max;
        let t_to_a_min = (a0 - a_min) / j_max;
        let t_to_v_max = a0 / j_max + (a0 * a0 + 2.0 * j_max * (v0 - v_max)).sqrt() / j_max.abs();
        let t_to_v_min = a0 / j_max + (a0 * a0 / 2.0 + j_max * (v0 - v_min)).sqrt() / j_max.abs();
        let t_min_to_v_max = t_to_v_max.min(t_to_v_min);

        if t_to_a_min < t_min_to_v_max {
            let v_at_a_min = v_at_t(v0, a0, -j_max, t_to_a_min);
            let t_to_v_max_with_constant = -(v_at_a_min - v_max) / a_min;
            let t_to_v_min_with_constant = a_min / (2.0 * j_max) - (v_at_a_min - v_min) / a_min;
            self.t[0] = (t_to_a_min - eps_for(t_to_a_min)).max(0.0);
            self.t[1] = t_to_v_max_with_constant.min(t_to_v_min_with_constant).max(0.0);
        } else {
            self.t[0] = (t_min_to_v_max - eps_for(t_min_to_v_max)).max(0.0);
        }
    }

    /// Record the start states of the phases and advance `(p, v, a)` to the braked state.
    pub(crate) fn finalize(&mut self, p: &mut f64, v: &mut f64, a: &mut f64) {
        if self.t[0] <= 0.0 && self.t[1] <= 0.0 {
            self.duration = 0.0;
            return;
        }
        self.duration = self.t[0];
        self.p[0] = *p;
        self.v[0] = *v;
        self.a[0] = *a;
        (*p, *v, *a) = integrate(self.t[0], *p, *v, *a, self.j[0]);
        if self.t[1] > 0.0 {
            self.duration += self.t[1];
            self.p[1] = *p;
            self.v[1] = *v;
            self.a[1] = *a;
            (*p, *v, *a) = integrate(self.t[1], *p, *v, *a, self.j[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn braked(v0: f64, a0: f64) -> (BrakeProfile, (f64, f64, f64)) {
        let mut b = BrakeProfile::position(v0, a0, 1.0, -1.0, 1.0, -1.0, 1.0);
        let (mut p, mut v, mut a) = (0.0, v0, a0);
        b.finalize(&mut p, &mut v, &mut a);
        (b, (p, v, a))
    }

    #[test]
    fn no_brake_inside_limits() {
        let (b, s) = braked(0.5, 0.5);
        assert_eq!(b.duration, 0.0);
        assert_eq!(s, (0.0, 0.5, 0.5));
    }

    #[test]
    fn acceleration_above_limit_is_ramped_down() {
        let (b, (_, _, a)) = braked(-0.5, 1.5);
        assert!((b.duration - 0.5).abs() < 1e-13);
        assert!(a <= 1.0 && a > 1.0 - 1e-12);
    }

    #[test]
    fn velocity_above_limit_is_braked_into_range() {
        let (b, (_, v, a)) = braked(2.0, 0.0);
        assert!(b.duration > 0.0);
        assert!(a >= -1.0 - 1e-12);
        // After braking, ramping a to zero does not leave the velocity band.
        let v_end = v + a * a.abs() / 2.0;
        assert!((-1.0 - 1e-12..=1.0 + 1e-12).contains(&v_end), "{v} {a}");
    }

    #[test]
    fn mirrored_cases_are_symmetric() {
        let (b1, s1) = braked(1.8, 0.7);
        let (b2, s2) = braked(-1.8, -0.7);
        assert!((b1.duration - b2.duration).abs() < 1e-15);
        assert!((s1.1 + s2.1).abs() < 1e-14 && (s1.2 + s2.2).abs() < 1e-14);
    }

    #[test]
    fn velocity_interface_brake() {
        let mut b = BrakeProfile::velocity(-3.0, 1.0, -1.0, 1.0);
        let (mut p, mut v, mut a) = (0.0, 0.0, -3.0);
        b.finalize(&mut p, &mut v, &mut a);
        assert!((b.duration - 2.0).abs() < 1e-13 && (a + 1.0).abs() < 1e-12);
    }
}
