//! VDI 2143 characteristic values of a normalised motion law (as the motion-design article,
//! Bewegungsdesign nach Maß, uses them): C_v = max|f′|, C_a = max|f″|, C_j = max|f‴| over z ∈
//! [0, 1], with the z where they occur. The extrema are found exactly: an extremum of |f⁽ᵏ⁾|
//! lies at an end of the section or at a root of f⁽ᵏ⁺¹⁾, and the roots come from
//! [`super::roots`].

use super::chebyshev;
use super::polynomial::Law;
use super::roots;

/// Peaks whose magnitudes differ by less than this (relative) are ties; the smallest z wins,
/// so symmetric laws report their first peak deterministically.
const TIE_REL: f64 = 1e-12;

/// The largest |f⁽ᵏ⁾| on [0, 1] and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// max |f⁽ᵏ⁾(z)|.
    pub value: f64,
    /// The z of that maximum.
    pub z: f64,
    /// f⁽ᵏ⁾(z) with its sign.
    pub signed: f64,
}

/// The VDI 2143 characteristic values and the range of f itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Characteristics {
    /// C_v = max|f′|.
    pub cv: Peak,
    /// C_a = max|f″|.
    pub ca: Peak,
    /// C_j = max|f‴|.
    pub cj: Peak,
    /// Smallest f (below 0 when the law undershoots its start).
    pub f_min: Extreme,
    /// Largest f (above 1 when the law overshoots its end).
    pub f_max: Extreme,
}

/// An extreme value of f itself and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extreme {
    pub value: f64,
    pub z: f64,
}

impl Law {
    pub fn characteristics(&self) -> Characteristics {
        Characteristics {
            cv: self.peak_abs(1),
            ca: self.peak_abs(2),
            cj: self.peak_abs(3),
            f_min: self.extreme_of_f(|a, b| a < b),
            f_max: self.extreme_of_f(|a, b| a > b),
        }
    }

    /// Candidate places of extrema of f⁽ᵏ⁾: the ends and the roots of f⁽ᵏ⁺¹⁾.
    fn critical_points(&self, order: usize) -> Vec<f64> {
        let mut zs = vec![0.0, 1.0];
        zs.extend(roots::roots_in_unit(self.kept_series(order + 1)));
        zs
    }

    /// max |f⁽ᵒʳᵈᵉʳ⁾| over [0, 1] (order 1 … 3).
    fn peak_abs(&self, order: usize) -> Peak {
        let s = self.kept_series(order);
        let (z, v) = self.best(order, |z| chebyshev::eval(s, z), |a, b| a.abs() > b.abs() * (1.0 + TIE_REL));
        Peak { value: v.abs(), z, signed: v }
    }

    fn extreme_of_f(&self, better: impl Fn(f64, f64) -> bool) -> Extreme {
        let s = self.kept_series(0);
        let (z, value) =
            self.best(0, |z| chebyshev::eval(s, z), |a, b| better(a, b) && (a - b).abs() > TIE_REL * b.abs().max(1.0));
        Extreme { value, z }
    }

    /// The critical point (z, f⁽ᵒʳᵈᵉʳ⁾(z)) with the "best" value; on ties the smallest z.
    fn best(&self, order: usize, eval: impl Fn(f64) -> f64, better: impl Fn(f64, f64) -> bool) -> (f64, f64) {
        let mut zs = self.critical_points(order);
        zs.sort_by(f64::total_cmp);
        let mut best = (0.0, eval(0.0));
        for z in zs {
            let v = eval(z);
            if better(v, best.1) {
                best = (z, v);
            }
        }
        best
    }
}
