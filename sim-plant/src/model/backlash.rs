//! Backlash as a dead zone with C¹ flanks, and the asymmetric transmission spring built on it.
//!
//! δ_e = δ − b/2 for δ > b/2, 0 inside, δ + b/2 below. The corners are rounded as Schneider
//! 2016 rounds the backlash zone of its joint compliance model with a cubic, "um
//! Diskontinuitäten … und damit Ruck in der Bewegung zu vermeiden" (§4.1.2, eq. 4.1).
//! The blend is the cubic Hermite piece matching value and slope at both ends of
//! [b/2 − w, b/2 + w]; with those four conditions it is the quadratic (δ − b/2 + w)²/(4w).
//! Outside the blends the characteristic is exactly the sharp dead zone, so the lost motion
//! measured between the straight flanks is exactly b.

/// The dead-zone characteristic δ ↦ δ_e.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadZone {
    /// b/2.
    half_gap: f64,
    /// Blend half-width w (0 ≤ w ≤ b/2).
    blend: f64,
}

impl DeadZone {
    /// Total width `backlash` b and blend half-width `blend` w (clamped to [0, b/2]).
    pub fn new(backlash: f64, blend: f64) -> Self {
        let half_gap = (backlash / 2.0).max(0.0);
        Self { half_gap, blend: blend.clamp(0.0, half_gap) }
    }

    /// Half the backlash, b/2.
    pub fn half_gap(&self) -> f64 {
        self.half_gap
    }

    /// δ_e and its slope dδ_e/dδ ∈ [0, 1].
    #[inline]
    pub fn eval(&self, delta: f64) -> (f64, f64) {
        if self.half_gap == 0.0 {
            return (delta, 1.0);
        }
        let s = delta.signum();
        let x = delta.abs();
        let a = self.half_gap - self.blend;
        if x <= a {
            (0.0, 0.0)
        } else if x >= self.half_gap + self.blend {
            (s * (x - self.half_gap), 1.0)
        } else {
            // The C¹ blend in the manner of Schneider 2016, eq. 4.1, written in the distance from
            // the blend's start so that value and slope match at both ends (eq. 4.1 as printed
            // has no constant term and is not centred on the zero-load point ω₀).
            let y = x - a;
            (s * y * y / (4.0 * self.blend), y / (2.0 * self.blend))
        }
    }

    /// ∫₀^δ δ_e dδ′ (potential of a unit spring through the dead zone).
    pub fn potential(&self, delta: f64) -> f64 {
        let x = delta.abs();
        let a = self.half_gap - self.blend;
        let w = self.blend;
        if x <= a {
            0.0
        } else if x >= self.half_gap + w {
            let u = x - self.half_gap;
            2.0 * w * w / 3.0 + (u * u - w * w) / 2.0
        } else {
            let y = x - a;
            y * y * y / (12.0 * w)
        }
    }
}

/// The transmission spring F_S = k± δ_e + c_s δ_e′ (v_M − v_L). The damper acts through the
/// contact: no damping force acts across an open gap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transmission {
    pub zone: DeadZone,
    /// k₊ for δ_e > 0.
    pub k_pos: f64,
    /// k₋ for δ_e < 0.
    pub k_neg: f64,
    /// c_s.
    pub damping: f64,
}

impl Transmission {
    /// Spring force and the contact slope δ_e′ for twist `delta` and twist rate `delta_dot`.
    #[inline]
    pub fn force(&self, delta: f64, delta_dot: f64) -> (f64, f64) {
        let (de, slope) = self.zone.eval(delta);
        let k = if de >= 0.0 { self.k_pos } else { self.k_neg };
        (k * de + self.damping * slope * delta_dot, slope)
    }

    /// Elastic energy stored at twist `delta`.
    pub fn energy(&self, delta: f64) -> f64 {
        let k = if delta >= 0.0 { self.k_pos } else { self.k_neg };
        k * self.zone.potential(delta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_zone_is_c1_and_exact_outside_blends() {
        let z = DeadZone::new(0.228e-3, 0.01e-3);
        let hg = 0.114e-3;
        assert_eq!(z.eval(0.0), (0.0, 0.0));
        assert_eq!(z.eval(hg - 0.0101e-3).0, 0.0);
        let (d, s) = z.eval(hg + 0.05e-3);
        assert!((d - 0.05e-3).abs() < 1e-18 && s == 1.0);
        let (d, s) = z.eval(-(hg + 0.05e-3));
        assert!((d + 0.05e-3).abs() < 1e-18 && s == 1.0);
        // Continuity of value and slope across both blend ends.
        for edge in [hg - 0.01e-3, hg + 0.01e-3] {
            let (a, sa) = z.eval(edge - 1e-12);
            let (b, sb) = z.eval(edge + 1e-12);
            assert!((a - b).abs() < 1e-11, "value jump at {edge}");
            assert!((sa - sb).abs() < 1e-6, "slope jump at {edge}");
        }
        // The potential is the integral of δ_e (numerical check).
        let n = 20000;
        let x_end = 0.2e-3;
        let mut integral = 0.0;
        for i in 0..n {
            let x = (i as f64 + 0.5) * x_end / n as f64;
            integral += z.eval(x).0 * x_end / n as f64;
        }
        assert!((integral - z.potential(x_end)).abs() < 1e-6 * z.potential(x_end));
    }

    #[test]
    fn no_backlash_is_linear() {
        let z = DeadZone::new(0.0, 0.0);
        assert_eq!(z.eval(1e-3), (1e-3, 1.0));
        assert_eq!(z.eval(-1e-3), (-1e-3, 1.0));
        let t = Transmission { zone: z, k_pos: 1.23e6, k_neg: 3.6e6, damping: 0.0 };
        assert_eq!(t.force(1e-4, 0.0).0, 123.0);
        assert!((t.force(-1e-4, 0.0).0 + 360.0).abs() < 1e-9);
    }
}
