//! The deflection model of Schneider 2016, eq. 4.1, for one axis: linear above and below a
//! backlash zone about the zero-load point, joined inside the zone by a cubic that matches
//! value and slope at both ends, "to avoid discontinuities and thus jerk" (§4.1.2). Written in
//! u = F − F₀ about the zero-load point F₀ (the thesis's cubic, as printed, is not centred on
//! it), with the lines u/k₊ + g/2 and u/k₋ − g/2 (stiffnesses k±, backlash g) and the whole
//! characteristic shifted so that δ(F₀) = 0: no load, no correction.
//!
//! Near the zero-load point the load rests anywhere in the backlash, held by friction, and the
//! force signal there is mostly its own drift: within a deadband d about F₀ the model gives no
//! correction, and between d and 2d it is faded in by a smoothstep (value and slope continuous),
//! so an unloaded axis is not moved by the sensor's drift.

use interpd_config::compensation::AxisCompensation;

/// δ(F): the tool's displacement along the axis under the force F on the load, mm per N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deflection {
    f0_n: f64,
    eps_n: f64,
    /// Compliances above and below, mm/N.
    c_pos: f64,
    c_neg: f64,
    half_gap_mm: f64,
    /// Cubic coefficients in u on [−ε, ε].
    k: [f64; 4],
    /// δ at F₀ before the shift.
    offset: f64,
    /// Deadband about F₀, N.
    deadband_n: f64,
}

impl Deflection {
    pub fn new(a: &AxisCompensation) -> Self {
        Self::from_parts(a.stiffness_pos_n_per_mm, a.stiffness_neg_n_per_mm, a.gap_mm, a.zero_load_n, a.blend_n)
            .with_deadband(a.deadband_n)
    }

    /// The same model with a deadband of `d_n` about the zero-load point.
    pub fn with_deadband(mut self, d_n: f64) -> Self {
        self.deadband_n = d_n.max(0.0);
        self
    }

    /// From stiffnesses (N/mm), backlash (mm), zero-load point and zone half-width (N).
    pub fn from_parts(k_pos: f64, k_neg: f64, gap_mm: f64, f0_n: f64, eps_n: f64) -> Self {
        let (c_pos, c_neg, h) = (1.0 / k_pos, 1.0 / k_neg, gap_mm / 2.0);
        let e = eps_n;
        // Value and slope at both ends of the zone.
        let (p, dp) = (e * c_pos + h, c_pos);
        let (q, dq) = (-e * c_neg - h, c_neg);
        let c3 = ((dp + dq) / 2.0 - (p - q) / (2.0 * e)) / (2.0 * e * e);
        let c1 = (p - q) / (2.0 * e) - c3 * e * e;
        let c2 = (dp - dq) / (4.0 * e);
        let c0 = (p + q) / 2.0 - c2 * e * e;
        Self { f0_n, eps_n, c_pos, c_neg, half_gap_mm: h, k: [c0, c1, c2, c3], offset: c0, deadband_n: 0.0 }
    }

    /// The zero-load point F₀, N.
    pub fn zero_load_n(&self) -> f64 {
        self.f0_n
    }

    /// The displacement under the force `f_n` (along the axis, positive towards positive
    /// positions), mm.
    #[inline]
    pub fn displacement_mm(&self, f_n: f64) -> f64 {
        let u = f_n - self.f0_n;
        let d = if u >= self.eps_n {
            u * self.c_pos + self.half_gap_mm
        } else if u <= -self.eps_n {
            u * self.c_neg - self.half_gap_mm
        } else {
            let [c0, c1, c2, c3] = self.k;
            c0 + u * (c1 + u * (c2 + u * c3))
        };
        let gate = if self.deadband_n > 0.0 {
            let w = ((u.abs() - self.deadband_n) / self.deadband_n).clamp(0.0, 1.0);
            w * w * (3.0 - 2.0 * w)
        } else {
            1.0
        };
        gate * (d - self.offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deadband_leaves_small_forces_alone_and_large_ones_exact() {
        let plain = Deflection::from_parts(545.0, 545.0, 0.228, 2.0, 5.0);
        let m = plain.with_deadband(5.0);
        for f in [-3.0, 0.0, 2.0, 6.9] {
            assert_eq!(m.displacement_mm(f), 0.0, "{f} N");
        }
        for f in [-100.0, 12.0, 12.1, 200.0] {
            assert_eq!(m.displacement_mm(f), plain.displacement_mm(f), "{f} N");
        }
        let mut last = m.displacement_mm(7.0);
        for i in 1..=300 {
            let d = m.displacement_mm(7.0 + 5.0 * i as f64 / 300.0);
            assert!(d >= last && d - last < 0.01, "a step at {i}");
            last = d;
        }
    }

    #[test]
    fn continuous_with_continuous_slope_and_zero_at_zero_load() {
        let m = Deflection::from_parts(545.0, 1580.0, 0.228, 3.0, 5.0);
        assert_eq!(m.displacement_mm(3.0), 0.0);
        let h = 1e-6;
        for f in [3.0 - 5.0, 3.0 + 5.0] {
            let (a, b) = (m.displacement_mm(f - h), m.displacement_mm(f + h));
            assert!((a - b).abs() < 1e-8, "value jumps at {f}: {a} {b}");
            let sa = (m.displacement_mm(f - h) - m.displacement_mm(f - 2.0 * h)) / h;
            let sb = (m.displacement_mm(f + 2.0 * h) - m.displacement_mm(f + h)) / h;
            assert!((sa - sb).abs() < 1e-4, "slope jumps at {f}: {sa} {sb}");
        }
        // Outside the zone: the lines, the gap between them.
        let up = m.displacement_mm(203.0) - m.displacement_mm(103.0);
        assert!((up - 100.0 / 545.0).abs() < 1e-12);
        let across = m.displacement_mm(13.0) - m.displacement_mm(-7.0);
        assert!((across - (10.0 / 545.0 + 10.0 / 1580.0 + 0.228)).abs() < 1e-12);
        // Monotone through the zone.
        let mut last = f64::NEG_INFINITY;
        for i in 0..=1000 {
            let d = m.displacement_mm(-2.0 + 10.0 * i as f64 / 1000.0);
            assert!(d > last);
            last = d;
        }
    }
}
