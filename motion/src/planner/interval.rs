//! One interval of the path-velocity profile: constant path jerk j between two nodes
//! (Kopp et al. 2019, eq. 2), parameterised by the velocity at its end (eq. 3).

/// 1/6, the factor of the jerk term of Kopp et al. 2019, eq. 2: multiplied by rather than
/// divided by, since a division's latency sits on the critical path of every time solve and
/// check point.
const SIXTH: f64 = 1.0 / 6.0;
/// Relative tolerance when solving s(T) = Δs for T.
const TIME_SOLVE_REL_TOL: f64 = 1e-13;
/// Newton steps before the solve for T gives up (it converges in a handful).
const TIME_SOLVE_MAX_ITER: usize = 100;
/// Halley steps before the unbracketed solve for T hands over to the bracketed one (from the
/// series estimate it converges in one or two where the motion keeps moving).
const TIME_HALLEY_MAX_ITER: usize = 6;

/// A constant-jerk piece: starts with velocity `v0` and acceleration `a0`, applies jerk `j`
/// for `t_s` seconds and covers `ds_mm` of path.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Interval {
    pub v0: f64,
    pub a0: f64,
    pub j: f64,
    pub t_s: f64,
    pub ds_mm: f64,
}

impl Interval {
    /// The forward branch's interval of Kopp et al. 2019, eq. 3: from (v0, a0) over `ds`
    /// ending with velocity `v1`. Eq. 3 gives T = [−(2v₀ + v₁) + √((2v₀ + v₁)² + 6a₀Δs)] / a₀,
    /// which cancels for small a₀ and is undefined at a₀ = 0; the same root in the form
    /// T = 6Δs / [(2v₀ + v₁) + √((2v₀ + v₁)² + 6a₀Δs)] covers both. `None` when v₁ cannot be
    /// reached (negative discriminant), the duration is not positive and finite, or the
    /// velocity would turn negative inside.
    pub(super) fn through(v0: f64, a0: f64, ds: f64, v1: f64) -> Option<Interval> {
        let q = 2.0 * v0 + v1;
        let disc = q * q + 6.0 * a0 * ds; // eq. 3, discriminant
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let den = q + disc.sqrt();
        if den.is_nan() || den <= 0.0 {
            return None;
        }
        let t = 6.0 * ds / den; // eq. 3, cancellation-free T
        if t.is_nan() || t <= 0.0 || t.is_infinite() {
            return None;
        }
        let j = 2.0 * (v1 - v0 - a0 * t) / (t * t); // eq. 3, j_i
        let iv = Interval { v0, a0, j, t_s: t, ds_mm: ds };
        iv.velocity_stays_non_negative().then_some(iv)
    }

    /// The interval from (v0, a0) with constant jerk `j` over `ds`. `None` if the motion comes
    /// to rest before covering `ds`.
    pub(super) fn with_jerk(v0: f64, a0: f64, ds: f64, j: f64) -> Option<Interval> {
        Self::with_jerk_moving(v0, a0, ds, j).or_else(|| Self::with_jerk_bracketed(v0, a0, ds, j))
    }

    /// [`Interval::with_jerk`] where the motion keeps moving: Halley steps on s(T) = Δs from a
    /// series estimate, accepted only if v stays positive over [0, T], so that s rises strictly
    /// and T is the one crossing the bracketed solve finds. Most intervals are short against
    /// their velocity change, so one step converges: two divisions in a row instead of the
    /// bracket's square root and four or five Newton divisions, whose latency would make this
    /// solve a large share of the planner's time.
    #[inline]
    fn with_jerk_moving(v0: f64, a0: f64, ds: f64, j: f64) -> Option<Interval> {
        if v0.is_nan() || v0 <= 0.0 {
            return None;
        }
        // Series inversion of s(T) in x = Δs/v₀: T = x(1 − αx/2 + (α²/2 − β/6)x²) with
        // α = a₀/v₀, β = j/v₀, so the first Halley step usually lands within the tolerance.
        let inv_v0 = 1.0 / v0;
        let (x, alpha, beta) = (ds * inv_v0, a0 * inv_v0, j * inv_v0);
        let mut t = x * (1.0 - 0.5 * alpha * x + (0.5 * alpha * alpha - beta * SIXTH) * x * x);
        for _ in 0..TIME_HALLEY_MAX_ITER {
            let f = v0 * t + 0.5 * a0 * t * t + j * t * t * t * SIXTH - ds; // eq. 2: s(τ) − Δs
            let v = v0 + a0 * t + 0.5 * j * t * t;
            if f.abs() <= TIME_SOLVE_REL_TOL * ds {
                let iv = Interval { v0, a0, j, t_s: t, ds_mm: ds };
                return (t > 0.0 && t.is_finite() && v > 0.0 && iv.stays_moving()).then_some(iv);
            }
            let acc = a0 + j * t;
            // Halley: T − 2fv / (2v² − f·a), with s′ = v and s″ = a.
            t -= 2.0 * f * v / (2.0 * v * v - f * acc);
        }
        None
    }

    /// Whether v > 0 inside the interval, given v > 0 at both ends: only a minimum of the
    /// parabola v(τ) inside can reach zero.
    #[inline]
    fn stays_moving(&self) -> bool {
        let tau = -self.a0 / self.j;
        let dips_inside = self.j > 0.0 && tau > 0.0 && tau < self.t_s;
        !dips_inside || self.v0 - self.a0 * self.a0 / (2.0 * self.j) > 0.0
    }

    /// [`Interval::with_jerk`] for any state: bracketed by the time v reaches zero.
    fn with_jerk_bracketed(v0: f64, a0: f64, ds: f64, j: f64) -> Option<Interval> {
        // Time at which v would reach zero, if it does.
        let t_stop = first_positive_root(0.5 * j, a0, v0);
        let s_at = |t: f64| v0 * t + 0.5 * a0 * t * t + j * t * t * t / 6.0;
        let mut hi = match t_stop {
            Some(ts) => {
                if s_at(ts) < ds {
                    return None;
                }
                ts
            }
            None => {
                // v stays positive: grow an upper bound.
                let mut hi = ds / v0.clamp(1e-300, f64::MAX);
                if !hi.is_finite() || hi <= 0.0 {
                    hi = 1.0;
                }
                let mut n = 0;
                while s_at(hi) < ds {
                    hi *= 2.0;
                    n += 1;
                    if n > 2000 {
                        return None;
                    }
                }
                hi
            }
        };
        let mut lo = 0.0;
        let mut t = if v0 > 0.0 { (ds / v0).min(hi) } else { 0.5 * hi };
        for _ in 0..TIME_SOLVE_MAX_ITER {
            let f = s_at(t) - ds;
            if f.abs() <= TIME_SOLVE_REL_TOL * ds {
                break;
            }
            if f > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let v = v0 + a0 * t + 0.5 * j * t * t;
            let newton = t - f / v;
            t = if v > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if hi - lo <= f64::EPSILON * hi {
                break;
            }
        }
        (t > 0.0 && t.is_finite()).then_some(Interval { v0, a0, j, t_s: t, ds_mm: ds })
    }

    /// The interval from (v0, a0) over `ds` that ends with acceleration `a1`: j = (a1 − a0)/T
    /// and Δs = v₀T + (2a₀ + a₁)T²/6 (Kopp et al. 2019, eq. 2 at τ = T), solved in the
    /// cancellation-free form T = 2Δs / (v₀ + √(v₀² + 2(2a₀ + a₁)Δs/3)). `None` if no such
    /// interval moves forward.
    pub(super) fn landing(v0: f64, a0: f64, ds: f64, a1: f64) -> Option<Interval> {
        let disc = v0 * v0 + 2.0 * (2.0 * a0 + a1) * ds / 3.0;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let den = v0 + disc.sqrt();
        let t = 2.0 * ds / den;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let iv = Interval { v0, a0, j: (a1 - a0) / t, t_s: t, ds_mm: ds };
        iv.velocity_stays_non_negative().then_some(iv)
    }

    pub(super) fn v1(&self) -> f64 {
        self.v0 + self.a0 * self.t_s + 0.5 * self.j * self.t_s * self.t_s
    }

    pub(super) fn a1(&self) -> f64 {
        self.a0 + self.j * self.t_s
    }

    /// (s − s₀, v, a) at local time τ (Kopp et al. 2019, eq. 2).
    pub(super) fn state_at(&self, tau: f64) -> (f64, f64, f64) {
        let (v0, a0, j) = (self.v0, self.a0, self.j);
        let s = v0 * tau + 0.5 * a0 * tau * tau + j * tau * tau * tau * SIXTH;
        let v = v0 + a0 * tau + 0.5 * j * tau * tau;
        let a = a0 + j * tau;
        (s, v, a)
    }

    /// The same motion seen backwards in time (for branches computed from the end): starts
    /// at this interval's end state with the acceleration negated; jerk is unchanged.
    pub(super) fn reversed(&self) -> Interval {
        Interval { v0: self.v1(), a0: -self.a1(), j: self.j, t_s: self.t_s, ds_mm: self.ds_mm }
    }

    fn velocity_stays_non_negative(&self) -> bool {
        // v(τ) is a parabola; only an interior minimum can go below zero.
        if self.j > 0.0 {
            let tau = -self.a0 / self.j;
            if tau > 0.0 && tau < self.t_s {
                return self.v0 - self.a0 * self.a0 / (2.0 * self.j)
                    >= -V_NEGATIVE_TOL * self.v0.abs().max(self.v1().abs());
            }
        }
        self.v1() >= -V_NEGATIVE_TOL * self.v0.abs().max(1.0)
    }
}

/// Velocities this far below zero (relative) count as rounding, not reversal.
const V_NEGATIVE_TOL: f64 = 1e-12;

/// Smallest positive root of c2 τ² + c1 τ + c0 = 0, if any.
fn first_positive_root(c2: f64, c1: f64, c0: f64) -> Option<f64> {
    if c2 == 0.0 {
        if c1 < 0.0 {
            return Some(-c0 / c1).filter(|t| *t > 0.0);
        }
        return None;
    }
    let disc = c1 * c1 - 4.0 * c2 * c0;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    // Stable pair of roots.
    let q = -0.5 * (c1 + c1.signum() * sq);
    let (r1, r2) = if q != 0.0 { (q / c2, c0 / q) } else { (-c1 / (2.0 * c2), -c1 / (2.0 * c2)) };
    let mut best: Option<f64> = None;
    for r in [r1, r2] {
        if r > 0.0 && best.is_none_or(|b| r < b) {
            best = Some(r);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq3_reaches_the_end_state() {
        for &(v0, a0, ds, v1) in
            &[(10.0, 0.0, 1.0, 12.0), (10.0, 50.0, 0.5, 9.0), (0.0, 0.0, 0.01, 3.0), (5.0, -20.0, 0.2, 4.0)]
        {
            let iv = Interval::through(v0, a0, ds, v1).expect("feasible");
            let (s, v, _) = iv.state_at(iv.t_s);
            assert!((s - ds).abs() < 1e-12 * ds.max(1.0), "s {s} vs {ds}");
            assert!((v - v1).abs() < 1e-10 * v1.max(1.0), "v {v} vs {v1}");
        }
    }

    #[test]
    fn eq3_rejects_unreachable() {
        // Strong deceleration cannot end at a velocity this low within the distance.
        assert!(Interval::through(10.0, -1000.0, 1.0, 0.0).is_none());
        // From rest with no acceleration nothing moves.
        assert!(Interval::through(0.0, 0.0, 1.0, 0.0).is_none());
    }

    #[test]
    fn with_jerk_matches_through() {
        let iv = Interval::through(8.0, 30.0, 0.7, 11.0).unwrap();
        let back = Interval::with_jerk(8.0, 30.0, 0.7, iv.j).unwrap();
        assert!((back.t_s - iv.t_s).abs() < 1e-12);
        assert!(Interval::with_jerk(1.0, -10.0, 5.0, 0.0).is_none(), "stops before the end");
    }

    /// The unbracketed solve finds the crossing the bracketed one finds, declines where the
    /// motion stops or turns, and carries most moving intervals (else it saves nothing).
    #[test]
    fn the_moving_solve_agrees_with_the_bracketed_one() {
        use proptest::prelude::RngCore;
        use proptest::test_runner::{RngAlgorithm, TestRng};
        let mut rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
        // Uniform in [0, 1).
        let mut next = || (rng.next_u64() >> 11) as f64 * 2f64.powi(-53);
        let (mut fast, mut moving) = (0, 0);
        for i in 0..50_000 {
            // From tiny to long intervals against the braking time, both signs of a and j.
            let v0 = if i % 11 == 0 { 0.0 } else { 100.0 * next() };
            let a0 = 4000.0 * (next() - 0.5);
            let j = 1e5 * (next() - 0.5);
            let ds = 10f64.powf(-4.0 + 4.0 * next());
            let reference = Interval::with_jerk_bracketed(v0, a0, ds, j);
            let quick = Interval::with_jerk_moving(v0, a0, ds, j);
            let got = Interval::with_jerk(v0, a0, ds, j);
            match (reference, got) {
                (Some(r), Some(g)) => {
                    assert!((r.t_s - g.t_s).abs() <= 1e-9 * r.t_s, "T {} vs {} at {v0} {a0} {ds} {j}", g.t_s, r.t_s);
                    moving += 1;
                    fast += usize::from(quick.is_some());
                }
                (None, None) => assert!(quick.is_none()),
                (r, g) => panic!("bracketed {r:?}, with_jerk {g:?} at {v0} {a0} {ds} {j}"),
            }
        }
        assert!(moving > 10_000 && fast * 10 > moving * 9, "{fast} of {moving} moving intervals solved unbracketed");
        // v dips below zero and recovers (j > 0): s(T) = Δs has a later root, which is no
        // continuation (the motion would stop first).
        assert!(Interval::with_jerk_moving(1.0, -10.0, 5.0, 30.0).is_none());
        assert!(Interval::with_jerk(1.0, -10.0, 5.0, 30.0).is_none());
    }

    #[test]
    fn landing_ends_flat() {
        for &(v0, a0, ds) in &[(10.0, 500.0, 0.02), (3.0, -200.0, 0.01), (0.0, 1000.0, 0.001)] {
            let iv = Interval::landing(v0, a0, ds, 0.0).expect("lands");
            let (s, _, a) = iv.state_at(iv.t_s);
            assert!((s - ds).abs() < 1e-12 && a.abs() < 1e-9 * a0.abs(), "s {s} a {a}");
        }
    }

    #[test]
    fn reversed_is_the_same_motion_backwards() {
        let iv = Interval::through(8.0, 30.0, 0.7, 11.0).unwrap();
        let r = iv.reversed();
        let (s, v, a) = r.state_at(r.t_s);
        assert!((s - 0.7).abs() < 1e-12);
        assert!((v - 8.0).abs() < 1e-10);
        assert!((a + 30.0).abs() < 1e-9);
    }
}
