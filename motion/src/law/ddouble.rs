//! Double-double arithmetic (an unevaluated sum hi + lo of two f64, ~32 significant digits):
//! Dekker's and Knuth's error-free transformations, as in Hida, Li & Bailey's QD library.
//!
//! Why: a condition on a high derivative (the article's asymmetric law asks f⁽⁸⁾(0.25) = 0) is
//! met by f64 coefficients only to ~ε·|f⁽⁸⁾| ≈ 1e-6, because rounding each coefficient to f64
//! already moves f⁽⁸⁾ that much. The solver therefore refines the coefficients in double-double
//! and measures residuals in it; execution evaluates the f64 rounding (see `polynomial`).

use std::ops::{Add, Mul, Neg, Sub};

/// hi + lo with |lo| ≤ ulp(hi)/2.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Dd {
    pub hi: f64,
    pub lo: f64,
}

/// a + b = s + e exactly (Knuth's TwoSum).
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// a + b = s + e exactly when |a| ≥ |b| (Dekker's FastTwoSum).
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// a · b = p + e exactly (with a fused multiply-add).
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    pub(super) const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };

    fn renorm(hi: f64, lo: f64) -> Dd {
        let (hi, lo) = quick_two_sum(hi, lo);
        Dd { hi, lo }
    }

    pub(super) fn abs(self) -> Dd {
        if self.hi < 0.0 { -self } else { self }
    }

    /// The nearest f64.
    pub(super) fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
}

impl From<f64> for Dd {
    fn from(v: f64) -> Self {
        Dd { hi: v, lo: 0.0 }
    }
}

impl Add for Dd {
    type Output = Dd;
    /// The accurate ("IEEE") double-double addition.
    fn add(self, b: Dd) -> Dd {
        let (s1, s2) = two_sum(self.hi, b.hi);
        let (t1, t2) = two_sum(self.lo, b.lo);
        let (s1, s2) = quick_two_sum(s1, s2 + t1);
        Dd::renorm(s1, s2 + t2)
    }
}

impl Neg for Dd {
    type Output = Dd;
    fn neg(self) -> Dd {
        Dd { hi: -self.hi, lo: -self.lo }
    }
}

impl Sub for Dd {
    type Output = Dd;
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}

impl Mul for Dd {
    type Output = Dd;
    fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        Dd::renorm(p, e + (self.hi * b.lo + self.lo * b.hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_what_f64_loses() {
        let third = Dd::from(1.0) * Dd::from(1.0 / 3.0);
        // (1 + 2⁻⁶⁰) − 1 = 2⁻⁶⁰, which f64 rounds away.
        let tiny = 2f64.powi(-60);
        let s = Dd::from(1.0) + Dd::from(tiny) - Dd::from(1.0);
        assert_eq!(s.to_f64(), tiny);
        // 0.1 · 3 − 0.3 in double-double is the exact rounding error of the f64 literals.
        let d = Dd::from(0.1) * Dd::from(3.0) - Dd::from(0.3);
        let exact = 0.1f64.mul_add(3.0, -0.3);
        assert_eq!(d.to_f64(), exact);
        assert_eq!(third.hi, 1.0 / 3.0);
    }
}
