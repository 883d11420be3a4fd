//! Path-table intervals: degree-7 Hermite polynomials through the rows' A … A‴ (the data form
//! of the five-axis example in Kopp et al. 2019, §2 and §4).

use super::{AxisDerivs, MAX_AXES};

/// One interval of a path table: per axis the degree-7 Hermite polynomial that matches
/// A, A′, A″ and A‴ at both rows, so the path reproduces the table's derivatives exactly at
/// every row and is C³ across rows.
#[derive(Debug, Clone, PartialEq)]
pub struct SepticSpan {
    /// Coefficients in the normalised variable t = (s − s₀)/h ∈ [0, 1].
    b: [[f64; 8]; MAX_AXES],
    h: f64,
    /// The axes `b` holds (the first `axes`): the others' coefficients are all zero, and the
    /// sampling and the limit checks evaluate the table at every node and between, so they
    /// loop over the table's axes only, not `MAX_AXES`.
    axes: usize,
}

/// Inverse of the end-condition matrix of the degree-7 Hermite problem: rows of
/// `[[1,1,1,1],[4,5,6,7],[12,20,30,42],[24,60,120,210]]⁻¹` (exact fractions).
const END_INV: [[f64; 4]; 4] = [
    [35.0, -15.0, 2.5, -1.0 / 6.0],
    [-84.0, 39.0, -7.0, 0.5],
    [70.0, -34.0, 6.5, -0.5],
    [-20.0, 10.0, -2.0, 1.0 / 6.0],
];

impl SepticSpan {
    /// Interval of length `h` (> 0) between table rows `a` and `b` (A, A′, A″, A‴ each).
    pub(crate) fn new(a: &AxisDerivs, b: &AxisDerivs, h: f64) -> Self {
        let mut coef = [[0.0; 8]; MAX_AXES];
        let (h2, h3) = (h * h, h * h * h);
        for (k, c) in coef.iter_mut().enumerate() {
            c[0] = a.pos[k];
            c[1] = h * a.d1[k];
            c[2] = h2 * a.d2[k] / 2.0;
            c[3] = h3 * a.d3[k] / 6.0;
            let r = [
                b.pos[k] - (c[0] + c[1] + c[2] + c[3]),
                h * b.d1[k] - (c[1] + 2.0 * c[2] + 3.0 * c[3]),
                h2 * b.d2[k] - (2.0 * c[2] + 6.0 * c[3]),
                h3 * b.d3[k] - 6.0 * c[3],
            ];
            for (i, row) in END_INV.iter().enumerate() {
                c[4 + i] = row.iter().zip(r.iter()).map(|(m, r)| m * r).sum();
            }
        }
        let axes = coef.iter().rposition(|c| c.iter().any(|&x| x != 0.0)).map_or(0, |k| k + 1);
        Self { b: coef, h, axes }
    }

    /// The axes the span holds: every axis from this index on is zero throughout.
    pub(crate) fn axes(&self) -> usize {
        self.axes
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.h
    }

    /// Whether A … A‴ evaluate finite everywhere on the span: the sum Σ i³·|bᵢ| bounds every
    /// Horner partial sum, and scaled by 1/h³ it bounds A″ and A‴ (so A and A′ too).
    pub(crate) fn is_bounded(&self) -> bool {
        let scale = 1.0f64.max(1.0 / (self.h * self.h * self.h));
        self.b.iter().all(|c| {
            let sum: f64 = c.iter().enumerate().map(|(i, ci)| (i * i * i).max(1) as f64 * ci.abs()).sum();
            (sum * scale).is_finite()
        })
    }

    /// The span between local positions `s0_mm` and `s0_mm + ds_mm` as polynomials in σ ∈ [0, 1]:
    /// per axis the coefficients of A(s0 + σ·ds). A piece of a degree-7 polynomial is one
    /// itself, so the planner's limit checks can evaluate the exact geometry between its
    /// nodes. By Taylor shift and scaling (no cancellation, unlike re-solving the Hermite
    /// problem from the piece's ends, whose end conditions divide by ds³).
    pub(crate) fn piece(&self, s0_mm: f64, ds_mm: f64) -> [[f64; 8]; MAX_AXES] {
        let (t0, r) = (s0_mm / self.h, ds_mm / self.h);
        let mut out = self.b;
        for c in out.iter_mut().take(self.axes) {
            // Coefficients of p(t0 + u) by repeated synthetic division.
            for i in 0..7 {
                for j in (i..7).rev() {
                    c[j] += t0 * c[j + 1];
                }
            }
            let mut scale = 1.0;
            for ci in c.iter_mut() {
                *ci *= scale;
                scale *= r;
            }
        }
        out
    }

    pub(crate) fn eval(&self, s: f64, out: &mut AxisDerivs) {
        let t = s / self.h;
        let (ih, ih2, ih3) = (1.0 / self.h, 1.0 / (self.h * self.h), 1.0 / (self.h * self.h * self.h));
        for k in 0..self.axes {
            let c = &self.b[k];
            let (mut p, mut d1, mut d2, mut d3) = (0.0, 0.0, 0.0, 0.0);
            for i in (0..8).rev() {
                let fi = i as f64;
                p = p * t + c[i];
                if i >= 1 {
                    d1 = d1 * t + fi * c[i];
                }
                if i >= 2 {
                    d2 = d2 * t + fi * (fi - 1.0) * c[i];
                }
                if i >= 3 {
                    d3 = d3 * t + fi * (fi - 1.0) * (fi - 2.0) * c[i];
                }
            }
            out.pos[k] = p;
            out.d1[k] = d1 * ih;
            out.d2[k] = d2 * ih2;
            out.d3[k] = d3 * ih3;
        }
        for k in self.axes..MAX_AXES {
            (out.pos[k], out.d1[k], out.d2[k], out.d3[k]) = (0.0, 0.0, 0.0, 0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Geometry, testutil::max_fd_error};

    fn sample(s: f64) -> AxisDerivs {
        // A smooth test curve: x = sin s, y = s³/10, z = e^{s/5}
        let mut d = AxisDerivs::default();
        d.pos[0] = s.sin();
        d.d1[0] = s.cos();
        d.d2[0] = -s.sin();
        d.d3[0] = -s.cos();
        d.pos[1] = s.powi(3) / 10.0;
        d.d1[1] = 0.3 * s * s;
        d.d2[1] = 0.6 * s;
        d.d3[1] = 0.6;
        d.pos[2] = (s / 5.0).exp();
        d.d1[2] = (s / 5.0).exp() / 5.0;
        d.d2[2] = (s / 5.0).exp() / 25.0;
        d.d3[2] = (s / 5.0).exp() / 125.0;
        d
    }

    #[test]
    fn matches_rows_at_both_ends() {
        let (a, b) = (sample(1.0), sample(1.7));
        let sp = SepticSpan::new(&a, &b, 0.7);
        let mut d = AxisDerivs::default();
        sp.eval(0.0, &mut d);
        for k in 0..3 {
            assert!((d.pos[k] - a.pos[k]).abs() < 1e-12 && (d.d1[k] - a.d1[k]).abs() < 1e-12);
            assert!((d.d2[k] - a.d2[k]).abs() < 1e-10 && (d.d3[k] - a.d3[k]).abs() < 1e-9);
        }
        sp.eval(0.7, &mut d);
        for k in 0..3 {
            assert!((d.pos[k] - b.pos[k]).abs() < 1e-12 && (d.d1[k] - b.d1[k]).abs() < 1e-11);
            assert!((d.d2[k] - b.d2[k]).abs() < 1e-9 && (d.d3[k] - b.d3[k]).abs() < 1e-8);
        }
        // Interior error of the interpolation of a smooth function is small.
        sp.eval(0.35, &mut d);
        assert!((d.pos[0] - 1.35f64.sin()).abs() < 1e-8);
    }

    /// A piece evaluates like the span over the same stretch, position and derivatives.
    #[test]
    fn a_piece_is_the_span_over_its_stretch() {
        let sp = SepticSpan::new(&sample(0.2), &sample(1.4), 1.2);
        let mut d = AxisDerivs::default();
        for (s0, ds) in [(0.37, 0.011), (1.1899, 0.0101), (0.0, 1.2)] {
            let piece = sp.piece(s0, ds);
            for sigma in [0.0, 0.3, 0.5, 1.0] {
                sp.eval(s0 + sigma * ds, &mut d);
                for (k, c) in piece.iter().enumerate().take(3) {
                    // The m-th derivative in σ, scaled to s by 1/dsᵐ.
                    let deriv = |m: usize| {
                        let fall = |i: usize| ((i + 1 - m)..=i).map(|x| x as f64).product::<f64>();
                        (m..8).rev().fold(0.0, |acc, i| acc * sigma + fall(i) * c[i]) / ds.powi(m as i32)
                    };
                    let want = [d.pos[k], d.d1[k], d.d2[k], d.d3[k]];
                    for (m, w) in want.into_iter().enumerate() {
                        let got = deriv(m);
                        assert!(
                            (got - w).abs() < 1e-9 * (1.0 + w.abs()),
                            "derivative {m} of axis {k} at {s0}+{sigma}·{ds}: {got} vs {w}"
                        );
                    }
                }
            }
        }
    }

    /// The span evaluates only the axes it holds, and sets the others to zero even where the
    /// output held something else.
    #[test]
    fn axes_past_the_last_one_held_are_zero() {
        let sp = SepticSpan::new(&sample(0.2), &sample(1.4), 1.2);
        assert_eq!(sp.axes(), 3);
        let mut d = AxisDerivs { pos: [f64::NAN; MAX_AXES], ..AxisDerivs::default() };
        d.d3 = [7.0; MAX_AXES];
        sp.eval(0.5, &mut d);
        assert!(d.pos[2] > 0.0 && d.d3[0] != 0.0);
        for k in 3..MAX_AXES {
            assert_eq!((d.pos[k], d.d1[k], d.d2[k], d.d3[k]), (0.0, 0.0, 0.0, 0.0), "axis {k}");
        }
        assert!(sp.piece(0.1, 0.3)[3..].iter().all(|c| c.iter().all(|&x| x == 0.0)));
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let sp = SepticSpan::new(&sample(0.2), &sample(1.4), 1.2);
        let e = max_fd_error(&Geometry::Septic(Box::new(sp)), 3, 40);
        assert!(e < 1e-6, "relative FD error {e}");
    }
}
