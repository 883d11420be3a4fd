//! Quintic Hermite interpolation in time: the polynomial through position, velocity and
//! acceleration at both ends of a piece. The fine stage evaluates it every cycle; it makes the
//! setpoints continuous in position, velocity and acceleration. Huan's fine interpolator
//! (Huan, §3, Fig. 4–5) moves linearly between coarse points; the quintic instead keeps the
//! acceleration continuous and reproduces the planner's constant-jerk pieces exactly.

/// Position, velocity, acceleration of one coordinate at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Kinematic {
    pub p: f64,
    pub v: f64,
    pub a: f64,
}

/// The quintic on [0, h] through `k0` at 0 and `k1` at h, evaluated at τ: (p, v, a).
/// Written in u = τ/h so the coefficients stay of the size of the position change.
#[inline]
pub fn eval(k0: Kinematic, k1: Kinematic, h_s: f64, tau_s: f64) -> Kinematic {
    if h_s <= 0.0 {
        return k1;
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
