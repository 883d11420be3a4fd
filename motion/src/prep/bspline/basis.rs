//! Quintic B-spline basis on a clamped knot vector (Haas 2012, §4.6: f = Σ N_{i,p} P_i by the
//! Cox–de Boor recursion, p = 5, knots of multiplicity p + 1 at both ends), with the
//! derivatives of the basis functions (Piegl and Tiller 1997, algorithm A2.3).

/// Degree of the spline: quintic, the highest NC polynomial degree Haas 2012 could emit, and
/// what the planner's pieces are.
pub(crate) const DEGREE: usize = 5;
/// Basis functions that are not zero on one knot span.
pub(crate) const ORDER: usize = DEGREE + 1;
/// Highest derivative evaluated (x⁗ at continuity degree 4).
pub(crate) const MAX_DERIV: usize = 4;

/// A clamped knot vector over the breakpoints `u[0] < u[1] < … < u[n−1]`: the ends repeated
/// p + 1 times and every inner breakpoint `multiplicity` times, so the spline is C^(p −
/// multiplicity) there.
#[derive(Debug, Clone)]
pub(crate) struct Knots {
    pub knots: Vec<f64>,
    /// First knot index of each breakpoint interval [u_j, u_{j+1}) (the span index of A2.1).
    span_of: Vec<usize>,
}

impl Knots {
    /// `None` when the breakpoints do not increase strictly or there are fewer than two, or
    /// the multiplicity is outside 1..=p.
    pub(crate) fn clamped(u: &[f64], multiplicity: usize) -> Option<Self> {
        if u.len() < 2 || !(1..=DEGREE).contains(&multiplicity) || u.windows(2).any(|w| w[1] <= w[0]) {
            return None;
        }
        let mut knots = Vec::with_capacity(2 * ORDER + multiplicity * (u.len() - 2));
        let mut span_of = Vec::with_capacity(u.len() - 1);
        knots.extend(std::iter::repeat_n(u[0], ORDER));
        span_of.push(DEGREE);
        for &x in &u[1..u.len() - 1] {
            knots.extend(std::iter::repeat_n(x, multiplicity));
            span_of.push(knots.len() - 1);
        }
        knots.extend(std::iter::repeat_n(u[u.len() - 1], ORDER));
        Some(Self { knots, span_of })
    }

    /// Number of basis functions (control points).
    pub(crate) fn n_basis(&self) -> usize {
        self.knots.len() - ORDER
    }

    /// Knot span index of breakpoint interval `j` (0 ≤ j < n − 1): the basis functions
    /// `span − p ..= span` are the ones not zero on it.
    pub(crate) fn span(&self, j: usize) -> usize {
        self.span_of[j]
    }

    /// The knots that the basis functions on `span` depend on (`span − p + 1 ..= span + p`),
    /// relative to `x`: two points with the same offsets have the same basis values.
    pub(crate) fn offsets(&self, span: usize, x: f64) -> [f64; 2 * DEGREE] {
        std::array::from_fn(|i| self.knots[span + 1 + i - DEGREE] - x)
    }

    /// Values and derivatives 0..=MAX_DERIV of the p + 1 basis functions not zero on `span`,
    /// at `x` (evaluated with that span's polynomials, also at its ends): `out[k][i]` is the
    /// k-th derivative of N_{span − p + i}.
    pub(crate) fn derivs(&self, span: usize, x: f64, out: &mut [[f64; ORDER]; MAX_DERIV + 1]) {
        self.derivs_upto(span, x, MAX_DERIV, out);
    }

    /// [`Self::derivs`] up to derivative `n_deriv` (≤ MAX_DERIV) only; `out[k]` for k above it
    /// is left as it is. The work of A2.3's derivative loop grows with the order (the k-th
    /// derivative takes k coefficient updates per function), so a fit that needs x … x‴ at a
    /// point saves about 40 % of it by not computing x⁗ there. The levels computed are the
    /// same, bit for bit, as those of a call with a higher `n_deriv`.
    pub(crate) fn derivs_upto(&self, span: usize, x: f64, n_deriv: usize, out: &mut [[f64; ORDER]; MAX_DERIV + 1]) {
        // One instance per derivative count: the loops' bounds are constants, so they unroll
        // and the indices need no range checks.
        match n_deriv {
            0 => self.derivs_n::<0>(span, x, out),
            1 => self.derivs_n::<1>(span, x, out),
            2 => self.derivs_n::<2>(span, x, out),
            3 => self.derivs_n::<3>(span, x, out),
            _ => self.derivs_n::<MAX_DERIV>(span, x, out),
        }
    }

    /// [`Self::derivs_upto`] with `N` derivatives.
    fn derivs_n<const N: usize>(&self, span: usize, x: f64, out: &mut [[f64; ORDER]; MAX_DERIV + 1]) {
        let p = DEGREE;
        // The knots span − p + 1 ..= span + p, the only ones the basis on `span` reads:
        // knots[span + 1 − j] is u[p − j], knots[span + j] is u[p − 1 + j].
        let u: &[f64; 2 * DEGREE] = self.knots[span + 1 - p..=span + p].try_into().expect("2p knots around a span");
        // ndu: basis functions (upper triangle incl. diagonal) and knot differences (lower).
        let mut ndu = [[0.0; ORDER]; ORDER];
        let (mut left, mut right) = ([0.0; ORDER], [0.0; ORDER]);
        ndu[0][0] = 1.0;
        for j in 1..=p {
            left[j] = x - u[p - j];
            right[j] = u[p - 1 + j] - x;
            let mut saved = 0.0;
            for r in 0..j {
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        for j in 0..=p {
            out[0][j] = ndu[j][p];
        }
        // One instance per basis function: the bounds of the coefficient loops are then
        // constants too (the same operations in the same order as one loop over r).
        derivs_of::<N, 0>(&ndu, out);
        derivs_of::<N, 1>(&ndu, out);
        derivs_of::<N, 2>(&ndu, out);
        derivs_of::<N, 3>(&ndu, out);
        derivs_of::<N, 4>(&ndu, out);
        derivs_of::<N, 5>(&ndu, out);
        let mut f = p as f64;
        for (k, row) in out.iter_mut().enumerate().take(N + 1).skip(1) {
            for v in row.iter_mut() {
                *v *= f;
            }
            f *= (p - k) as f64;
        }
    }
}

/// Derivatives 1 ..= N of basis function `R` (of the p + 1 on the span) from the triangle
/// `ndu` (A2.3's loop body for r = R), unscaled by p!/(p − k)!.
#[inline(always)]
fn derivs_of<const N: usize, const R: usize>(ndu: &[[f64; ORDER]; ORDER], out: &mut [[f64; ORDER]; MAX_DERIV + 1]) {
    let (p, r) = (DEGREE, R);
    // The coefficients of the previous and the current derivative (A2.3's a[s1], a[s2]).
    let (mut prev, mut cur) = ([0.0; ORDER], [0.0; ORDER]);
    prev[0] = 1.0;
    for k in 1..=N {
        let mut d = 0.0;
        let pk = p - k;
        if r >= k {
            cur[0] = prev[0] / ndu[pk + 1][r - k];
            d = cur[0] * ndu[r - k][pk];
        }
        // j from max(1, k − r) to (k − 1 if r ≤ pk + 1, else p − r); the knot index
        // r − k + j is then 0 or more.
        let j1 = if r + 1 >= k { 1 } else { k - r };
        let j2 = if r <= pk + 1 { k - 1 } else { p - r };
        for j in j1..=j2 {
            let idx = r + j - k;
            cur[j] = (prev[j] - prev[j - 1]) / ndu[pk + 1][idx];
            d += cur[j] * ndu[idx][pk];
        }
        if r <= pk {
            cur[k] = -prev[k - 1] / ndu[pk + 1][r];
            d += cur[k] * ndu[r][pk];
        }
        out[k][r] = d;
        std::mem::swap(&mut prev, &mut cur);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn knots(m: usize) -> Knots {
        Knots::clamped(&[0.0, 0.7, 1.0, 2.5, 2.6, 4.0], m).unwrap()
    }

    #[test]
    fn counts_and_spans() {
        for m in 1..=3 {
            let k = knots(m);
            assert_eq!(k.n_basis(), ORDER + m * 4);
            for j in 0..5 {
                let s = k.span(j);
                assert!(k.knots[s] < k.knots[s + 1], "span {s} of interval {j} is not empty");
            }
        }
        assert!(Knots::clamped(&[0.0, 1.0, 1.0], 1).is_none());
        assert!(Knots::clamped(&[0.0], 1).is_none());
        assert!(Knots::clamped(&[0.0, 1.0], 6).is_none());
    }

    #[test]
    fn partition_of_unity_and_derivatives_sum_to_zero() {
        for m in 1..=3 {
            let k = knots(m);
            let u = [0.0, 0.7, 1.0, 2.5, 2.6, 4.0];
            let mut out = [[0.0; ORDER]; MAX_DERIV + 1];
            for j in 0..5 {
                for i in 0..=10 {
                    let x = u[j] + (u[j + 1] - u[j]) * i as f64 / 10.0;
                    k.derivs(k.span(j), x, &mut out);
                    assert!((out[0].iter().sum::<f64>() - 1.0).abs() < 1e-13);
                    assert!(out[0].iter().all(|&v| v >= -1e-15));
                    for d in 1..=MAX_DERIV {
                        let scale = out[d].iter().map(|v| v.abs()).fold(1.0, f64::max);
                        assert!(out[d].iter().sum::<f64>().abs() < 1e-10 * scale, "m {m} d {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn fewer_derivatives_are_the_same_values() {
        let k = knots(1);
        let mut all = [[0.0; ORDER]; MAX_DERIV + 1];
        for j in 0..5 {
            let x = k.knots[k.span(j)] + 0.3;
            k.derivs(k.span(j), x, &mut all);
            for n in 0..=MAX_DERIV {
                let mut some = [[f64::NAN; ORDER]; MAX_DERIV + 1];
                k.derivs_upto(k.span(j), x, n, &mut some);
                assert_eq!(some[..=n], all[..=n], "interval {j} up to {n}");
                assert!(some[n + 1..].iter().flatten().all(|v| v.is_nan()), "levels above {n} untouched");
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let k = knots(1);
        let u = [0.0, 0.7, 1.0, 2.5, 2.6, 4.0];
        let h = 1e-5;
        let (mut a, mut b, mut c) = ([[0.0; ORDER]; MAX_DERIV + 1], [[0.0; ORDER]; MAX_DERIV + 1], [[0.0; ORDER]; 5]);
        for j in 0..5 {
            let span = k.span(j);
            let x = 0.5 * (u[j] + u[j + 1]);
            k.derivs(span, x - h, &mut a);
            k.derivs(span, x + h, &mut b);
            k.derivs(span, x, &mut c);
            for d in 0..MAX_DERIV {
                for i in 0..ORDER {
                    let fd = (b[d][i] - a[d][i]) / (2.0 * h);
                    let scale = c[d + 1][i].abs().max(1.0);
                    assert!(
                        (fd - c[d + 1][i]).abs() < 1e-5 * scale,
                        "interval {j} d {d} i {i}: {fd} vs {}",
                        c[d + 1][i]
                    );
                }
            }
        }
    }

    #[test]
    fn continuity_follows_the_multiplicity() {
        // At an inner breakpoint the derivatives up to p − m agree from both sides; p − m + 1 not.
        let u = [0.0, 0.7, 1.0, 2.5, 2.6, 4.0];
        for m in 1..=3 {
            let k = knots(m);
            let (mut l, mut r) = ([[0.0; ORDER]; MAX_DERIV + 1], [[0.0; ORDER]; MAX_DERIV + 1]);
            k.derivs(k.span(1), u[2], &mut l);
            k.derivs(k.span(2), u[2], &mut r);
            // Full coefficient vectors over all basis functions.
            let full = |span: usize, v: &[f64; ORDER]| {
                let mut f = vec![0.0; k.n_basis()];
                f[span - DEGREE..=span].copy_from_slice(v);
                f
            };
            for d in 0..=MAX_DERIV {
                let (a, b) = (full(k.span(1), &l[d]), full(k.span(2), &r[d]));
                let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                if d <= DEGREE - m {
                    assert!(diff < 1e-9, "m {m} d {d}: {diff}");
                } else {
                    assert!(diff > 1e-3, "m {m} d {d} should jump");
                }
            }
        }
    }
}
