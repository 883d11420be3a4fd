//! The weighted least-squares B-spline of one window (Haas 2012, §4.6–4.7): control points
//! such that the spline's values and parametric derivatives at the QP's points match the
//! optimised ones in the weighted least-squares sense (`lscov` with weights per derivative
//! order), with the leading derivatives at the window's ends fixed so that windows chain
//! continuously.

use super::banded::{BandedSpd, NotPositiveDefinite};
use super::basis::{DEGREE, Knots, MAX_DERIV, ORDER};

/// Values per point: position and derivatives up to x⁗.
pub(crate) const LEVELS: usize = MAX_DERIV + 1;

/// Why a window has no B-spline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FitError {
    /// The breakpoints do not increase strictly.
    Knots,
    /// The fixed end derivatives need more control points than the window has.
    TooFewControlPoints,
    /// The normal equations are singular (a control point no data row determines).
    Singular,
}

impl From<NotPositiveDefinite> for FitError {
    fn from(_: NotPositiveDefinite) -> Self {
        FitError::Singular
    }
}

/// The fit's structure for one window (knots, weights, fixed ends), factorised once and
/// solved per axis.
pub(crate) struct Fit {
    pub knots: Knots,
    u: Vec<f64>,
    levels: usize,
    weights: [f64; LEVELS],
    fixed_left: usize,
    fixed_right: usize,
    /// Basis derivatives at each point (from the interval starting there; the last point from
    /// the last interval) and their span.
    at_points: Vec<(usize, [[f64; ORDER]; LEVELS])>,
    normal: BandedSpd,
}

/// A fitted spline for one axis: its control points.
pub(crate) struct Curve {
    pub ctrl: Vec<f64>,
}

/// Relative pivot below which the normal equations count as singular.
const PIVOT_REL_TOL: f64 = 1e-13;

impl Fit {
    /// The fit over breakpoints `u` (one per QP point, strictly increasing), inner knots of
    /// `multiplicity`, data `levels` (x … x^(levels − 1)) per point weighted by `weights`,
    /// `fixed_left` / `fixed_right` leading derivatives fixed at the ends.
    pub(crate) fn new(
        u: &[f64],
        multiplicity: usize,
        levels: usize,
        weights: [f64; LEVELS],
        fixed_left: usize,
        fixed_right: usize,
    ) -> Result<Self, FitError> {
        let knots = Knots::clamped(u, multiplicity).ok_or(FitError::Knots)?;
        let n_ctrl = knots.n_basis();
        // A clamped end's k-th derivative depends on the first (last) k + 1 control points only;
        // both ends' fixed points must not overlap.
        if fixed_left > ORDER || fixed_right > ORDER || fixed_left + fixed_right > n_ctrl {
            return Err(FitError::TooFewControlPoints);
        }
        let n = u.len();
        let mut at_points = Vec::with_capacity(n);
        for j in 0..n {
            let span = knots.span(j.min(n - 2));
            let mut d = [[0.0; ORDER]; LEVELS];
            knots.derivs(span, u[j], &mut d);
            at_points.push((span, d));
        }
        let free = fixed_left..n_ctrl - fixed_right;
        let mut normal = BandedSpd::zeros(free.len());
        for (span, d) in &at_points {
            let first = span - DEGREE;
            for l in 0..levels {
                for a in 0..ORDER {
                    let ia = first + a;
                    if !free.contains(&ia) {
                        continue;
                    }
                    for b in 0..=a {
                        let ib = first + b;
                        if free.contains(&ib) {
                            normal.add(ia - free.start, ib - free.start, weights[l] * d[l][a] * d[l][b]);
                        }
                    }
                }
            }
        }
        if !normal.is_empty() {
            normal.cholesky(PIVOT_REL_TOL)?;
        }
        Ok(Self { knots, u: u.to_vec(), levels, weights, fixed_left, fixed_right, at_points, normal })
    }

    /// The control points for one axis: `data[j][l]` is the l-th derivative wanted at point j,
    /// `left` / `right` the fixed end derivatives (at least `fixed_left` / `fixed_right` of them).
    pub(crate) fn solve(&self, data: &[[f64; LEVELS]], left: &[f64; LEVELS], right: &[f64; LEVELS]) -> Curve {
        let n_ctrl = self.knots.n_basis();
        let n = self.u.len();
        let mut ctrl = vec![0.0; n_ctrl];
        // Left end: derivative k at u₀ is Σ_{i ≤ k} N_i^(k)(u₀) P_i, triangular.
        let d0 = &self.at_points[0].1;
        for k in 0..self.fixed_left {
            let s: f64 = (0..k).map(|i| d0[k][i] * ctrl[i]).sum();
            ctrl[k] = (left[k] - s) / d0[k][k];
        }
        // Right end: derivative k at u_{n−1} involves the last k + 1 control points.
        let d1 = &self.at_points[n - 1].1;
        for k in 0..self.fixed_right {
            let s: f64 = (0..k).map(|i| d1[k][ORDER - 1 - i] * ctrl[n_ctrl - 1 - i]).sum();
            ctrl[n_ctrl - 1 - k] = (right[k] - s) / d1[k][ORDER - 1 - k];
        }
        let free = self.fixed_left..n_ctrl - self.fixed_right;
        let mut rhs = vec![0.0; free.len()];
        for (j, (span, d)) in self.at_points.iter().enumerate() {
            let first = span - DEGREE;
            for l in 0..self.levels {
                // Residual of the data against the fixed control points' share.
                let fixed: f64 =
                    (0..ORDER).filter(|a| !free.contains(&(first + a))).map(|a| d[l][a] * ctrl[first + a]).sum();
                let r = self.weights[l] * (data[j][l] - fixed);
                for a in 0..ORDER {
                    if free.contains(&(first + a)) {
                        rhs[first + a - free.start] += d[l][a] * r;
                    }
                }
            }
        }
        if !rhs.is_empty() {
            self.normal.solve(&mut rhs);
        }
        ctrl[free.clone()].copy_from_slice(&rhs);
        Curve { ctrl }
    }

    /// Value and derivatives 0..LEVELS of `curve` at `x` on breakpoint interval `j`.
    pub(crate) fn eval(&self, curve: &Curve, j: usize, x: f64) -> [f64; LEVELS] {
        let span = self.knots.span(j);
        let mut d = [[0.0; ORDER]; LEVELS];
        self.knots.derivs(span, x, &mut d);
        let first = span - DEGREE;
        std::array::from_fn(|l| (0..ORDER).map(|a| d[l][a] * curve.ctrl[first + a]).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    fn sample(x: f64) -> [f64; LEVELS] {
        // sin(x) and its derivatives.
        [x.sin(), x.cos(), -x.sin(), -x.cos(), x.sin()]
    }

    #[test]
    fn matches_a_dense_weighted_least_squares_solve() {
        let u = [0.0, 0.4, 1.0, 1.3, 2.2, 2.5, 3.0, 3.9];
        let w = [1000.0, 100.0, 10.0, 1.0, 0.1];
        for (m, levels) in [(1, 5), (1, 3), (2, 4), (3, 3)] {
            let fit = Fit::new(&u, m, levels, w, 0, 0).unwrap();
            // Noisy data so that the fit does not reproduce it exactly.
            let data: Vec<[f64; LEVELS]> =
                u.iter().enumerate().map(|(j, &x)| sample(x).map(|v| v + 0.01 * ((j * 7 % 5) as f64 - 2.0))).collect();
            let c = fit.solve(&data, &[0.0; LEVELS], &[0.0; LEVELS]);
            // Dense: rows √w_l N^(l)(u_j), solved by SVD.
            let nb = fit.knots.n_basis();
            let mut k = DMatrix::zeros(u.len() * levels, nb);
            let mut y = DVector::zeros(u.len() * levels);
            for (j, (span, d)) in fit.at_points.iter().enumerate() {
                for l in 0..levels {
                    for a in 0..ORDER {
                        k[(j * levels + l, span - DEGREE + a)] = w[l].sqrt() * d[l][a];
                    }
                    y[j * levels + l] = w[l].sqrt() * data[j][l];
                }
            }
            let x = k.svd(true, true).solve(&y, 1e-12).unwrap();
            for i in 0..nb {
                assert!((c.ctrl[i] - x[i]).abs() < 1e-8 * (1.0 + x[i].abs()), "m {m} i {i}: {} vs {}", c.ctrl[i], x[i]);
            }
        }
    }

    #[test]
    fn fixed_ends_are_met_and_a_quintic_is_reproduced() {
        let u = [0.0, 0.5, 1.5, 2.0, 3.0, 3.2, 4.0];
        let q = |x: f64| -> [f64; LEVELS] {
            [
                1.0 + x - 0.5 * x * x + 0.1 * x.powi(5),
                1.0 - x + 0.5 * x.powi(4),
                -1.0 + 2.0 * x.powi(3),
                6.0 * x * x,
                12.0 * x,
            ]
        };
        let data: Vec<[f64; LEVELS]> = u.iter().map(|&x| q(x)).collect();
        let fit = Fit::new(&u, 1, 5, [1000.0, 100.0, 10.0, 1.0, 0.1], 5, 3).unwrap();
        let c = fit.solve(&data, &q(0.0), &q(4.0));
        for j in 0..u.len() - 1 {
            for i in 0..=4 {
                let x = u[j] + (u[j + 1] - u[j]) * i as f64 / 4.0;
                let (got, want) = (fit.eval(&c, j, x), q(x));
                for l in 0..LEVELS {
                    assert!((got[l] - want[l]).abs() < 1e-8 * (1.0 + want[l].abs()), "x {x} l {l}");
                }
            }
        }
    }

    #[test]
    fn too_many_fixed_levels_are_refused() {
        assert_eq!(Fit::new(&[0.0, 1.0], 1, 3, [1.0; LEVELS], 5, 3).err(), Some(FitError::TooFewControlPoints));
        assert_eq!(Fit::new(&[0.0, 1.0, 1.0], 1, 3, [1.0; LEVELS], 1, 1).err(), Some(FitError::Knots));
    }
}
