//! Circular and helical arcs (G2, G3 in the plane G17/G18/G19), parameterised by arc length.

use super::{AxisDerivs, AxisVec, MAX_AXES};

/// Circular arc in the plane of axes (p, q), optionally helical: every other axis moves
/// linearly with the swept angle. θ(s) = φ₀ + Δφ·s/L; positive Δφ turns counter-clockwise
/// (G3), negative clockwise (G2), seen from the positive third axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Helix {
    p: usize,
    q: usize,
    center: [f64; 2],
    radius_mm: f64,
    phi0_rad: f64,
    sweep_rad: f64,
    start: AxisVec,
    delta: AxisVec,
    length_mm: f64,
}

impl Helix {
    /// Arc from `start` turning `sweep_rad` about `center` in the plane (p, q). The other axes
    /// go from `start` to `end`. `linear[k]` tells which axes count for the path length.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        p: usize,
        q: usize,
        center: [f64; 2],
        sweep_rad: f64,
        start: AxisVec,
        end: AxisVec,
        linear: &[bool],
    ) -> Self {
        let radius_mm = (start[p] - center[0]).hypot(start[q] - center[1]);
        let phi0_rad = (start[q] - center[1]).atan2(start[p] - center[0]);
        let mut delta = [0.0; MAX_AXES];
        let mut helix_sq = 0.0;
        for k in 0..MAX_AXES {
            if k != p && k != q {
                delta[k] = end[k] - start[k];
                if linear.get(k).copied().unwrap_or(false) {
                    helix_sq += delta[k] * delta[k];
                }
            }
        }
        let arc = radius_mm * sweep_rad.abs();
        let length_mm = (arc * arc + helix_sq).sqrt();
        Self { p, q, center, radius_mm, phi0_rad, sweep_rad, start, delta, length_mm }
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.length_mm
    }

    pub(crate) fn radius_mm(&self) -> f64 {
        self.radius_mm
    }

    /// Signed swept angle: positive counter-clockwise (G3).
    pub fn sweep_rad(&self) -> f64 {
        self.sweep_rad
    }

    /// Centre in the arc plane, in the order of [`Helix::plane_axes`].
    pub fn center(&self) -> [f64; 2] {
        self.center
    }

    /// The axis indices (p, q) of the arc plane: X Y for G17, Z X for G18, Y Z for G19.
    pub fn plane_axes(&self) -> (usize, usize) {
        (self.p, self.q)
    }

    pub(crate) fn eval(&self, s: f64, out: &mut AxisDerivs) {
        let l = self.length_mm;
        let w = self.sweep_rad / l; // dθ/ds
        let theta = self.phi0_rad + w * s;
        let (sin, cos) = theta.sin_cos();
        let r = self.radius_mm;
        for k in 0..MAX_AXES {
            out.pos[k] = self.start[k] + self.delta[k] * s / l;
            out.d1[k] = self.delta[k] / l;
            out.d2[k] = 0.0;
            out.d3[k] = 0.0;
        }
        let (p, q) = (self.p, self.q);
        out.pos[p] = self.center[0] + r * cos;
        out.pos[q] = self.center[1] + r * sin;
        out.d1[p] = -r * w * sin;
        out.d1[q] = r * w * cos;
        out.d2[p] = -r * w * w * cos;
        out.d2[q] = -r * w * w * sin;
        out.d3[p] = r * w * w * w * sin;
        out.d3[q] = -r * w * w * w * cos;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Geometry, testutil::max_fd_error};
    use std::f64::consts::PI;

    fn helix(sweep: f64, dz: f64) -> Helix {
        let mut a = [0.0; MAX_AXES];
        let mut b = [0.0; MAX_AXES];
        a[0] = 10.0;
        b[0] = 10.0 * sweep.cos();
        b[1] = 10.0 * sweep.sin();
        b[2] = dz;
        b[3] = 45.0; // a rotary axis turning along
        Helix::new(0, 1, [0.0, 0.0], sweep, a, b, &[true, true, true, false])
    }

    #[test]
    fn arc_length_exact() {
        let h = helix(PI / 2.0, 0.0);
        assert!((h.length_mm() - 5.0 * PI).abs() < 1e-12);
        let h = helix(2.0 * PI, 3.0);
        assert!((h.length_mm() - ((20.0 * PI).powi(2) + 9.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn ends_where_programmed() {
        let h = helix(-1.3, 2.0);
        let mut d = AxisDerivs::default();
        h.eval(h.length_mm(), &mut d);
        assert!((d.pos[0] - 10.0 * 1.3f64.cos()).abs() < 1e-12);
        assert!((d.pos[1] + 10.0 * 1.3f64.sin()).abs() < 1e-12);
        assert!((d.pos[2] - 2.0).abs() < 1e-12);
        assert!((d.pos[3] - 45.0).abs() < 1e-12);
    }

    #[test]
    fn unit_speed_over_linear_axes() {
        let h = helix(2.5, 4.0);
        let mut d = AxisDerivs::default();
        for i in 0..10 {
            h.eval(h.length_mm() * i as f64 / 10.0, &mut d);
            let speed = (d.d1[0].powi(2) + d.d1[1].powi(2) + d.d1[2].powi(2)).sqrt();
            assert!((speed - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for (sweep, dz) in [(PI / 2.0, 0.0), (-3.0, 5.0), (2.0 * PI, 0.5)] {
            let e = max_fd_error(&Geometry::Helix(helix(sweep, dz)), 4, 50);
            assert!(e < 1e-6, "relative FD error {e}");
        }
    }
}
