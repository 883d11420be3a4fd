//! Brake pre-phase: brings an initial state that is outside the limits (or that will inevitably
//! leave them, e.g. v below v_max but a > 0 so large that v overshoots) back inside, with at most
//! two phases (a jerk ramp and an acceleration plateau). The time-optimal profile then starts from
//! the braked state. This is Ruckig's strategy (Berscheid & Kröger, RSS 2021, Sec. V-A, "initial
//! states outside the kinematic limits"); the durations computed here equal Ruckig's, so the
//! overall durations can be compared directly.

use crate::profile::integrate;
use crate::{Limits, State};

/// Up to two phases of constant jerk that precede the main profile.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BrakeProfile {
    /// Total duration of the pre-phase [s] (0 when the initial state is already safe).
    pub duration: f64,
    /// Phase durations [s].
    pub t: [f64; 2],
    /// Jerk of each phase.
    pub j: [f64; 2],
    /// Position at the start of each phase.
    pub p: [f64; 2],
    /// Velocity at the start of each phase.
    pub v: [f64; 2],
    /// Acceleration at the start of each phase.
    pub a: [f64; 2],
}

/// Velocity reached when the acceleration is ramped to zero with jerk of magnitude `j_max`.
#[inline]
fn velocity_at_zero_acceleration(v0: f64, a0: f64, j_max: f64) -> f64 {
    v0 + a0 * a0.abs() / (2.0 * j_max)
}

impl BrakeProfile {
    /// Brake for the position interface: acceleration outside [a_min, a_max], or velocity outside
    /// [v_min, v_max] now or inevitably later.
    pub(crate) fn for_position(v0: f64, a0: f64, lim: &Limits) -> BrakeProfile {
        let j = lim.j_max;
        if a0 > lim.a_max {
            Self::from_upper(acceleration_brake(Upper::of(lim), v0, a0, j), 1.0)
        } else if a0 < lim.a_min {
            Self::from_upper(acceleration_brake(Upper::of(lim).mirrored(), -v0, -a0, j), -1.0)
        } else if (v0 > lim.v_max && v0 - a0 * a0 / (2.0 * j) > lim.v_min)
            || (a0 > 0.0 && velocity_at_zero_acceleration(v0, a0, j) > lim.v_max)
        {
            Self::from_upper(velocity_brake(Upper::of(lim), v0, a0, j), 1.0)
        } else if (v0 < lim.v_min && v0 + a0 * a0 / (2.0 * j) < lim.v_max)
            || (a0 < 0.0 && velocity_at_zero_acceleration(v0, a0, j) < lim.v_min)
        {
            Self::from_upper(velocity_brake(Upper::of(lim).mirrored(), -v0, -a0, j), -1.0)
        } else {
            BrakeProfile::default()
        }
    }

    /// Brake for the velocity interface: only the acceleration has limits.
    pub(crate) fn for_velocity(a0: f64, lim: &Limits) -> BrakeProfile {
        let mut brake = BrakeProfile::default();
        if a0 > lim.a_max {
            brake.j[0] = -lim.j_max;
            brake.t[0] = (a0 - lim.a_max) / lim.j_max;
        } else if a0 < lim.a_min {
            brake.j[0] = lim.j_max;
            brake.t[0] = (lim.a_min - a0) / lim.j_max;
        }
        brake
    }

    fn from_upper(phases: [(f64, f64); 2], sign: f64) -> BrakeProfile {
        let mut brake = BrakeProfile::default();
        for (k, (t, j)) in phases.into_iter().enumerate() {
            brake.t[k] = t.max(0.0);
            brake.j[k] = sign * j;
        }
        brake
    }

    /// Record the start states of the phases and return the state after braking.
    pub(crate) fn finalize(&mut self, start: State) -> State {
        self.duration = 0.0;
        let mut s = start;
        for k in 0..2 {
            self.p[k] = s.p;
            self.v[k] = s.v;
            self.a[k] = s.a;
            if self.t[k] > 0.0 {
                let (p, v, a) = integrate(self.t[k], s.p, s.v, s.a, self.j[k]);
                s = State { p, v, a };
                self.duration += self.t[k];
            } else {
                self.t[k] = 0.0;
            }
        }
        s
    }
}

/// Limits seen from the side that is violated ("upper": velocity/acceleration too high).
#[derive(Clone, Copy, Debug)]
struct Upper {
    v_hi: f64,
    v_lo: f64,
    a_hi: f64,
    a_lo: f64,
}

impl Upper {
    fn of(lim: &Limits) -> Upper {
        Upper { v_hi: lim.v_max, v_lo: lim.v_min, a_hi: lim.a_max, a_lo: lim.a_min }
    }

    /// The same limits for the mirrored motion (p, v, a negated).
    fn mirrored(self) -> Upper {
        Upper { v_hi: -self.v_lo, v_lo: -self.v_hi, a_hi: -self.a_lo, a_lo: -self.a_hi }
    }
}

/// a0 > a_hi: ramp the acceleration down (jerk -j). If the velocity would still overshoot v_hi
/// when a reaches zero, keep braking as a velocity brake; if ramping to a_hi already leaves the
/// velocity below v_lo, hold a_hi until v is back inside.
fn acceleration_brake(lim: Upper, v0: f64, a0: f64, j: f64) -> [(f64, f64); 2] {
    let t_to_a_hi = (a0 - lim.a_hi) / j;
    let t_to_a_zero = a0 / j;
    let v_at_a_hi = v0 + t_to_a_hi * (a0 - 0.5 * j * t_to_a_hi);
    let v_at_a_zero = v0 + t_to_a_zero * (a0 - 0.5 * j * t_to_a_zero);
    if v_at_a_zero > lim.v_hi {
        velocity_brake(lim, v0, a0, j)
    } else if v_at_a_hi < lim.v_lo {
        let t_to_v_lo = -(v_at_a_hi - lim.v_lo) / lim.a_hi;
        let t_to_v_hi = -lim.a_hi / (2.0 * j) - (v_at_a_hi - lim.v_hi) / lim.a_hi;
        [(t_to_a_hi, -j), (t_to_v_lo.min(t_to_v_hi).max(0.0), 0.0)]
    } else {
        [(t_to_a_hi, -j), (0.0, 0.0)]
    }
}

/// The velocity is or will be above v_hi: ramp the acceleration down (jerk -j) until the velocity
/// can come back inside; if a_lo is reached first, hold it.
fn velocity_brake(lim: Upper, v0: f64, a0: f64, j: f64) -> [(f64, f64); 2] {
    let t_to_a_lo = (a0 - lim.a_lo) / j;
    // Time at which v, falling under jerk -j, crosses v_hi.
    let t_to_v_hi = a0 / j + (a0 * a0 + 2.0 * j * (v0 - lim.v_hi)).max(0.0).sqrt() / j;
    // Time after which ramping a back to zero (jerk +j) would end exactly at v_lo.
    let t_to_v_lo = a0 / j + (0.5 * a0 * a0 + j * (v0 - lim.v_lo)).max(0.0).sqrt() / j;
    let t_safe = t_to_v_hi.min(t_to_v_lo);
    if t_to_a_lo < t_safe {
        let v_at_a_lo = v0 + t_to_a_lo * (a0 - 0.5 * j * t_to_a_lo);
        let hold_to_v_hi = -(v_at_a_lo - lim.v_hi) / lim.a_lo;
        let hold_to_v_lo = lim.a_lo / (2.0 * j) - (v_at_a_lo - lim.v_lo) / lim.a_lo;
        [(t_to_a_lo.max(0.0), -j), (hold_to_v_hi.min(hold_to_v_lo).max(0.0), 0.0)]
    } else {
        [(t_safe.max(0.0), -j), (0.0, 0.0)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> Limits {
        Limits { v_max: 1.0, v_min: -1.0, a_max: 1.0, a_min: -1.0, j_max: 1.0 }
    }

    fn braked(v0: f64, a0: f64) -> (BrakeProfile, State) {
        let mut b = BrakeProfile::for_position(v0, a0, &lim());
        let s = b.finalize(State { p: 0.0, v: v0, a: a0 });
        (b, s)
    }

    #[test]
    fn no_brake_inside_limits() {
        let (b, s) = braked(0.5, 0.5);
        assert_eq!(b.duration, 0.0);
        assert_eq!(s, State { p: 0.0, v: 0.5, a: 0.5 });
    }

    #[test]
    fn acceleration_above_limit_is_ramped_down() {
        let (b, s) = braked(-0.5, 1.5);
        assert!((b.duration - 0.5).abs() < 1e-15);
        assert!((s.a - 1.0).abs() < 1e-15);
    }

    #[test]
    fn velocity_above_limit_is_braked_into_range() {
        let (b, s) = braked(2.0, 0.0);
        assert!(b.duration > 0.0);
        assert!(s.a >= -1.0 - 1e-12);
        // After braking, ramping a to zero does not leave the velocity band.
        let v_end = s.v + s.a * s.a.abs() / 2.0;
        assert!(v_end <= 1.0 + 1e-12 && v_end >= -1.0 - 1e-12, "{s:?}");
    }

    #[test]
    fn mirrored_cases_are_symmetric() {
        let (b1, s1) = braked(1.8, 0.7);
        let (b2, s2) = braked(-1.8, -0.7);
        assert!((b1.duration - b2.duration).abs() < 1e-15);
        assert!((s1.v + s2.v).abs() < 1e-14 && (s1.a + s2.a).abs() < 1e-14);
    }

    #[test]
    fn velocity_interface_brake() {
        let mut b = BrakeProfile::for_velocity(-3.0, &lim());
        let s = b.finalize(State { p: 0.0, v: 0.0, a: -3.0 });
        assert!((b.duration - 2.0).abs() < 1e-15 && (s.a + 1.0).abs() < 1e-15);
    }
}
