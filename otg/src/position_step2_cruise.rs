//! Step 2, position interface, fallback: a profile of exactly the given duration made of the
//! time-optimal velocity change from the start to a cruise velocity v_c (acceleration zero), a
//! cruise, and the time-optimal change from v_c to the target. It covers every profile with a
//! zero-acceleration phase (Ruckig's *_VEL cases, both directions, UDDU and UDUD) and is used
//! when the closed forms of [`crate::position_step2`] fail: for durations many orders of
//! magnitude longer than the ramps (the polynomials in the first ramp's length then carry
//! terms in tf⁵ and lose every digit).
//!
//! With T1, D1 (T2, D2) the duration and distance of the first (second) change, the cruise lasts
//! g = tf - T1 - T2 and the position residual is F(v_c) = D1 + D2 + v_c·g - Δp. Differentiating
//! the closed forms of the changes gives dD/dv_c - v_c·dT/dv_c = |peak acceleration|/(2 j) for
//! each, hence F'(v_c) = g + (|peak1| + |peak2|)/(2 j) > 0 wherever g ≥ 0: on each interval of
//! feasible cruise velocities F increases and has at most one root. T1 and T2 are V-shaped in
//! v_c with concave arms, so {g ≥ 0} is at most two intervals, found by bracketing. (Derived for
//! interpd; the structure is Berscheid & Kröger, RSS 2021, Sec. IV-C.)

use crate::phase::integrate;
use crate::profile::{ControlSigns, Profile, ReachedLimits};

/// Bracketing stops when the interval is this small relative to the cruise velocity scale.
const BRACKET_REL: f64 = 4.0 * f64::EPSILON;
/// A squared peak acceleration this many ulps (of its terms) below its lower bound is that bound.
const PEAK_ROUNDING_ULPS: f64 = 16.0;
/// Iteration cap of the bracketing (bisection alone needs ~64 for full precision).
const BRACKET_MAX_ITERATIONS: usize = 100;

/// The time-optimal change between a state with acceleration and the cruise (a = 0): three
/// phases with jerks (s·j, 0, -s·j).
#[derive(Clone, Copy, Debug)]
struct Change {
    t: [f64; 3],
    /// Sign of the first jerk (+1: the acceleration first rises).
    s: f64,
    /// Magnitude of the peak acceleration.
    peak: f64,
    dist: f64,
    dur: f64,
}

/// The limits of one DoF and its boundary (braked start, target) for a given duration.
struct Cruise {
    v0: f64,
    a0: f64,
    vf: f64,
    af: f64,
    pd: f64,
    tf: f64,
    a_max: f64,
    a_min: f64,
    j: f64,
}

/// Durations (ramp, hold, ramp) of the change of velocity by `dv` ≥ 0 (in the mirrored frame
/// where the acceleration first rises) from acceleration `a_start` to `a_end`, through a peak
/// limited to `a_hi`: peak² = j·dv + (a_start² + a_end²)/2. `v_scale` is the magnitude of the
/// velocities `dv` was computed from (its rounding).
fn ramps(dv: f64, v_scale: f64, a_start: f64, a_end: f64, a_hi: f64, j: f64) -> Option<([f64; 3], f64)> {
    let squares = (a_start * a_start + a_end * a_end) / 2.0;
    let mut peak_sq = j * dv + squares;
    // At the ends of the V (v_c at the stopping velocity) the peak is exactly max(a_start, a_end)
    // or zero; rounding may put it just below.
    let rounding = PEAK_ROUNDING_ULPS * f64::EPSILON * (j * (dv.abs() + v_scale) + squares);
    let floor = a_start.max(a_end).max(0.0);
    if peak_sq < floor * floor {
        if peak_sq < floor * floor - rounding {
            return None;
        }
        peak_sq = floor * floor;
    }
    if peak_sq > a_hi * a_hi {
        let hold = (dv - (2.0 * a_hi * a_hi - a_start * a_start - a_end * a_end) / (2.0 * j)) / a_hi;
        return Some(([(a_hi - a_start) / j, hold.max(0.0), (a_hi - a_end) / j], a_hi));
    }
    let peak = peak_sq.sqrt().max(floor);
    Some(([(peak - a_start) / j, 0.0, (peak - a_end) / j], peak))
}

impl Cruise {
    /// Upper acceleration limit in the mirrored frame of sign `s`.
    fn a_hi(&self, s: f64) -> f64 {
        if s > 0.0 { self.a_max } else { -self.a_min }
    }

    /// From the start (v0, a0) to (vc, 0).
    fn reach_cruise(&self, vc: f64) -> Option<Change> {
        let v_stop = self.v0 + self.a0 * self.a0.abs() / (2.0 * self.j);
        let s = if vc >= v_stop { 1.0 } else { -1.0 };
        let v_scale = vc.abs().max(self.v0.abs());
        let (t, peak) = ramps(s * (vc - self.v0), v_scale, s * self.a0, 0.0, self.a_hi(s), self.j)?;
        let mut state = (0.0, self.v0, self.a0);
        for (k, &tk) in t.iter().enumerate() {
            let jk = [s * self.j, 0.0, -s * self.j][k];
            state = integrate(tk, state.0, state.1, state.2, jk);
        }
        Some(Change { t, s, peak, dist: state.0, dur: t[0] + t[1] + t[2] })
    }

    /// From (vc, 0) to the target (vf, af).
    fn leave_cruise(&self, vc: f64) -> Option<Change> {
        let v_pre = self.vf - self.af * self.af.abs() / (2.0 * self.j);
        let s = if vc <= v_pre { 1.0 } else { -1.0 };
        let v_scale = vc.abs().max(self.vf.abs());
        let (t, peak) = ramps(s * (self.vf - vc), v_scale, 0.0, s * self.af, self.a_hi(s), self.j)?;
        let mut state = (0.0, vc, 0.0);
        for (k, &tk) in t.iter().enumerate() {
            let jk = [s * self.j, 0.0, -s * self.j][k];
            state = integrate(tk, state.0, state.1, state.2, jk);
        }
        Some(Change { t, s, peak, dist: state.0, dur: t[0] + t[1] + t[2] })
    }

    /// The cruise time g and the position residual F at cruise velocity `vc`.
    fn eval(&self, vc: f64) -> Option<(f64, f64, Change, Change)> {
        let first = self.reach_cruise(vc)?;
        let second = self.leave_cruise(vc)?;
        let g = self.tf - first.dur - second.dur;
        Some((g, first.dist + second.dist + vc * g - self.pd, first, second))
    }

    fn g(&self, vc: f64) -> f64 {
        self.eval(vc).map_or(f64::NEG_INFINITY, |e| e.0)
    }

    /// d(T1 + T2)/dv_c.
    fn slope_of_changes(&self, vc: f64) -> f64 {
        match self.eval(vc) {
            Some((_, _, first, second)) => first.s / first.peak - second.s / second.peak,
            None => 0.0,
        }
    }
}

/// A root of `f` on [lo, hi] where f(lo) and f(hi) have opposite signs (or one is zero):
/// bisection with Illinois-modified regula falsi steps.
fn bracket_root(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (mut f_lo, mut f_hi) = (f(lo), f(hi));
    if f_lo == 0.0 {
        return lo;
    }
    if f_hi == 0.0 {
        return hi;
    }
    let scale = lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE);
    let mut side = 0;
    for k in 0..BRACKET_MAX_ITERATIONS {
        if hi - lo <= BRACKET_REL * scale {
            break;
        }
        // Alternate secant and bisection steps so that the bracket always shrinks.
        let secant = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        let x = if k % 2 == 0 && secant > lo && secant < hi { secant } else { 0.5 * (lo + hi) };
        let fx = f(x);
        if fx == 0.0 {
            return x;
        }
        if (fx > 0.0) == (f_hi > 0.0) {
            hi = x;
            f_hi = fx;
            if side == 1 {
                f_lo /= 2.0;
            }
            side = 1;
        } else {
            lo = x;
            f_lo = fx;
            if side == -1 {
                f_hi /= 2.0;
            }
            side = -1;
        }
    }
    0.5 * (lo + hi)
}

/// The fallback of step 2: `p` carries the boundary (braked start state, target, brake) and
/// receives the profile lasting exactly `tf`. False if there is none of this shape.
#[allow(clippy::too_many_arguments)]
pub(crate) fn calculate(p: &mut Profile, tf: f64, v_max: f64, v_min: f64, a_max: f64, a_min: f64, j_max: f64) -> bool {
    let c = Cruise { v0: p.v[0], a0: p.a[0], vf: p.vf, af: p.af, pd: p.pf - p.p[0], tf, a_max, a_min, j: j_max };
    let m1 = (c.v0 + c.a0 * c.a0.abs() / (2.0 * c.j)).clamp(v_min, v_max);
    let m2 = (c.vf - c.af * c.af.abs() / (2.0 * c.j)).clamp(v_min, v_max);
    let (lo, hi) = if m1 <= m2 { (m1, m2) } else { (m2, m1) };
    let (g_lo, g_hi) = (c.g(lo), c.g(hi));
    let g = |v: f64| c.g(v);

    // Feasible cruise velocities {g ≥ 0}: g increases on [v_min, lo], is convex on [lo, hi],
    // decreases on [hi, v_max].
    let left = (g_lo >= 0.0).then(|| if g(v_min) >= 0.0 { v_min } else { bracket_root(v_min, lo, g) });
    let right = (g_hi >= 0.0).then(|| if g(v_max) >= 0.0 { v_max } else { bracket_root(hi, v_max, g) });
    let mut intervals = [(0.0, 0.0); 2];
    let n = match (left, right) {
        (Some(l), Some(r)) => {
            // The minimum of g on [lo, hi], where d(T1 + T2)/dv_c changes sign.
            let v_peak = if hi > lo { bracket_root(lo, hi, |v| c.slope_of_changes(v)) } else { lo };
            if g(v_peak) >= 0.0 {
                intervals[0] = (l, r);
                1
            } else {
                intervals[0] = (l, bracket_root(lo, v_peak, g));
                intervals[1] = (bracket_root(v_peak, hi, g), r);
                2
            }
        }
        (Some(l), None) => {
            intervals[0] = (l, bracket_root(lo, hi, g));
            1
        }
        (None, Some(r)) => {
            intervals[0] = (bracket_root(lo, hi, g), r);
            1
        }
        (None, None) => 0,
    };

    let residual = |v: f64| c.eval(v).map_or(f64::NAN, |e| e.1);
    for &(a, b) in &intervals[..n] {
        let (fa, fb) = (residual(a), residual(b));
        if !(fa <= 0.0 && fb >= 0.0) {
            continue;
        }
        let vc = bracket_root(a, b, residual);
        let Some((g, _, first, second)) = c.eval(vc) else {
            continue;
        };
        p.t = [first.t[0], first.t[1], first.t[2], g.max(0.0), second.t[0], second.t[1], second.t[2]];
        let jf = first.s * j_max;
        let signs = if first.s == second.s { ControlSigns::Udud } else { ControlSigns::Uddu };
        let accepted = if first.s > 0.0 {
            p.check_with_timing(tf, signs, ReachedLimits::Vel, jf, v_max, v_min, a_max, a_min)
        } else {
            p.check_with_timing(tf, signs, ReachedLimits::Vel, jf, v_min, v_max, a_min, a_max)
        };
        if accepted {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boundary(v0: f64, a0: f64, pd: f64, vf: f64, af: f64) -> Profile {
        let mut p = Profile::default();
        p.set_boundary(0.0, v0, a0, pd, vf, af);
        p
    }

    #[test]
    fn very_long_duration_is_a_slow_cruise() {
        // 1 unit in 1e6 s from a moving start: decelerate, creep at ~1e-6, stop.
        let mut p = boundary(0.5, 0.1, 1.0, 0.0, 0.0);
        assert!(calculate(&mut p, 1e6, 1.0, -1.0, 1.0, -1.0, 1.0));
        assert!((p.duration() - 1e6).abs() < 1e-6);
        assert!((p.p[7] - 1.0).abs() < 1e-9 && p.v[7].abs() < 1e-12);
        assert!(p.v[3].abs() < 1e-5, "cruise at {}", p.v[3]);
    }

    #[test]
    fn residual_slope_matches_the_closed_form() {
        let c = Cruise { v0: 0.3, a0: -0.2, vf: -0.1, af: 0.4, pd: 2.0, tf: 30.0, a_max: 0.5, a_min: -0.7, j: 0.9 };
        for vc in [-0.8, -0.2, 0.05, 0.6, 0.95] {
            let h = 1e-6;
            let (g, _, first, second) = c.eval(vc).unwrap();
            let numeric = (c.eval(vc + h).unwrap().1 - c.eval(vc - h).unwrap().1) / (2.0 * h);
            let analytic = g + (first.peak + second.peak) / (2.0 * c.j);
            assert!((numeric - analytic).abs() < 1e-6 * analytic.abs().max(1.0), "{vc}: {numeric} vs {analytic}");
        }
    }
}
