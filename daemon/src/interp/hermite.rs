//! Quintic Hermite interpolation in time: the polynomial through position, velocity and
//! acceleration at both ends of a piece. The fine stage evaluates it every cycle; it makes the
//! setpoints continuous in position, velocity and acceleration. Huan's fine interpolator
//! (Huan, §3, Fig. 4–5) moves linearly between coarse points; the quintic instead keeps the
//! acceleration continuous and reproduces the planner's constant-jerk pieces exactly.

/// Pieces shorter than this are evaluated by the Taylor polynomial of their start, s: the
/// quintic's acceleration divides the rounding of the end positions (≈ 1e-13 mm at 1 m) by h²,
/// which below about 1 µs exceeds 0.1 % of an acceleration limit, while over such a piece the
/// start's Taylor polynomial misses the end by j·h³/6 < 1e-13 mm at 500 m/s³. Stop tails,
/// split segments and sampled switches can begin or end with pieces of a few ulps.
pub const MIN_PIECE_S: f64 = 1e-6;

/// Position, velocity, acceleration of one coordinate at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Kinematic {
    pub p: f64,
    pub v: f64,
    pub a: f64,
}

/// The quintic on [0, h] through `k0` at 0 and `k1` at h, evaluated at τ: (p, v, a).
/// Written in u = τ/h so the coefficients stay of the size of the position change. A piece
/// shorter than [`MIN_PIECE_S`] is the start's Taylor polynomial, its acceleration moving
/// linearly from one end's to the other's.
#[inline]
pub fn eval(k0: Kinematic, k1: Kinematic, h_s: f64, tau_s: f64) -> Kinematic {
    if h_s <= 0.0 {
        return k1;
    }
    if h_s < MIN_PIECE_S {
        let tau = tau_s.clamp(0.0, h_s);
        return Kinematic {
            p: k0.p + tau * (k0.v + 0.5 * tau * k0.a),
            v: k0.v + tau * k0.a,
            a: k0.a + (k1.a - k0.a) * (tau / h_s),
        };
    }
    let u = (tau_s / h_s).clamp(0.0, 1.0);
    let dp = k1.p - k0.p;
    let (v0, v1) = (k0.v * h_s, k1.v * h_s);
    let (a0, a1) = (k0.a * h_s * h_s, k1.a * h_s * h_s);
    // Coefficients of u³, u⁴, u⁵ from the six end conditions.
    let c3 = 10.0 * dp - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1;
    let c4 = -15.0 * dp + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1;
    let c5 = 6.0 * dp - 3.0 * v0 - 3.0 * v1 - 0.5 * a0 + 0.5 * a1;
    let c2 = 0.5 * a0;
    let p = k0.p + u * (v0 + u * (c2 + u * (c3 + u * (c4 + u * c5))));
    let dp_du = v0 + u * (2.0 * c2 + u * (3.0 * c3 + u * (4.0 * c4 + u * 5.0 * c5)));
    let d2p_du2 = 2.0 * c2 + u * (6.0 * c3 + u * (12.0 * c4 + u * 20.0 * c5));
    Kinematic { p, v: dp_du / h_s, a: d2p_du2 / (h_s * h_s) }
}

/// The jerk of the same quintic at τ (third derivative).
#[inline]
pub fn jerk(k0: Kinematic, k1: Kinematic, h_s: f64, tau_s: f64) -> f64 {
    if h_s <= 0.0 {
        return 0.0;
    }
    let u = (tau_s / h_s).clamp(0.0, 1.0);
    let dp = k1.p - k0.p;
    let (v0, v1) = (k0.v * h_s, k1.v * h_s);
    let (a0, a1) = (k0.a * h_s * h_s, k1.a * h_s * h_s);
    let c3 = 10.0 * dp - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1;
    let c4 = -15.0 * dp + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1;
    let c5 = 6.0 * dp - 3.0 * v0 - 3.0 * v1 - 0.5 * a0 + 0.5 * a1;
    (6.0 * c3 + u * (24.0 * c4 + u * 60.0 * c5)) / (h_s * h_s * h_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_end_conditions() {
        let k0 = Kinematic { p: 1.0, v: -2.0, a: 30.0 };
        let k1 = Kinematic { p: 1.5, v: 4.0, a: -10.0 };
        let h = 0.013;
        let s = eval(k0, k1, h, 0.0);
        let e = eval(k0, k1, h, h);
        for (x, y) in [(s.p, k0.p), (s.v, k0.v), (s.a, k0.a), (e.p, k1.p), (e.v, k1.v), (e.a, k1.a)] {
            assert!((x - y).abs() < 1e-9 * (1.0 + y.abs()), "{x} vs {y}");
        }
    }

    /// A stop tail whose first braking phase lasts a few ulps: the piece from the chunk end
    /// to it is 1.4e-18 s long, and its ends differ in the last bit of the velocity.
    #[test]
    fn a_piece_of_a_few_ulps_reports_the_motion_not_its_rounding() {
        let k0 = Kinematic { p: 67.97156579835615, v: 12.444404610132574, a: -995.2761460853728 };
        let k1 = Kinematic { p: 67.97156579835615, v: 12.444404610132572, a: -995.2761460853728 };
        let h = 1.428226604542915e-18;
        for c in 0..=8 {
            let q = eval(k0, k1, h, h * c as f64 / 8.0);
            assert!((q.p - k0.p).abs() < 1e-12, "{q:?}");
            assert!((q.v - k0.v).abs() < 1e-9, "{q:?}");
            assert!((q.a - k0.a).abs() < 1e-9, "{q:?}");
        }
        // Just above the threshold the quintic itself is well conditioned.
        let h = 2.0 * MIN_PIECE_S;
        let k1 = Kinematic { p: k0.p + k0.v * h + 0.5 * k0.a * h * h, v: k0.v + k0.a * h, a: k0.a };
        for c in 0..=8 {
            let q = eval(k0, k1, h, h * c as f64 / 8.0);
            assert!((q.a - k0.a).abs() < 2.5, "{q:?}");
        }
    }

    #[test]
    fn reproduces_a_constant_jerk_piece() {
        let (p0, v0, a0, j) = (3.0, 120.0, -800.0, 40_000.0);
        let at = |t: f64| Kinematic {
            p: p0 + v0 * t + a0 * t * t / 2.0 + j * t * t * t / 6.0,
            v: v0 + a0 * t + j * t * t / 2.0,
            a: a0 + j * t,
        };
        let h = 0.02;
        for i in 0..=20 {
            let t = h * i as f64 / 20.0;
            let q = eval(at(0.0), at(h), h, t);
            let r = at(t);
            assert!((q.p - r.p).abs() < 1e-12 && (q.v - r.v).abs() < 1e-9 && (q.a - r.a).abs() < 1e-6);
        }
    }
}
