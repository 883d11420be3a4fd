//! A symmetric positive definite banded system: the normal equations of the B-spline
//! least-squares fit (Haas 2012, §4.6–4.7: the sparse weighted solve). Every data row touches
//! p + 1 consecutive control points, so KᵀWK has half-bandwidth p and a banded Cholesky
//! factorisation costs O(n p²) time and O(n p) memory, against O(n³) for a dense solve; the
//! windows are small, but the dense solve would be cubic in the point count of a window near
//! a corner, where points crowd.

use super::basis::DEGREE;

/// Half-bandwidth: entries (i, j) with |i − j| ≤ BAND may be non-zero.
pub(crate) const BAND: usize = DEGREE;

/// Lower band of a symmetric matrix: `rows[i][d]` is entry (i, i − d).
#[derive(Debug, Clone, Default)]
pub(crate) struct BandedSpd {
    rows: Vec<[f64; BAND + 1]>,
}

/// The matrix is not positive definite (a control point no data row determines).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NotPositiveDefinite;

impl BandedSpd {
    /// An n × n zero matrix.
    pub(crate) fn zeros(n: usize) -> Self {
        Self { rows: vec![[0.0; BAND + 1]; n] }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Adds `v` to entry (i, j) and (j, i); |i − j| ≤ BAND.
    pub(crate) fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= BAND);
        self.rows[i][i - j] += v;
    }

    /// Adds the symmetric block `block` (lower triangle: `block[a][b]`, b ≤ a) at rows and
    /// columns `first ..= first + BAND`, which must lie in the matrix.
    pub(crate) fn add_block(&mut self, first: usize, block: &[[f64; BAND + 1]; BAND + 1]) {
        for (a, row) in self.rows[first..=first + BAND].iter_mut().enumerate() {
            for b in 0..=a {
                row[a - b] += block[a][b];
            }
        }
    }

    /// Factorises in place into L with L Lᵀ = the matrix (L in the same band). A pivot below
    /// `rel_tol` times the largest diagonal entry counts as not positive definite.
    pub(crate) fn cholesky(&mut self, rel_tol: f64) -> Result<(), NotPositiveDefinite> {
        let n = self.rows.len();
        let max_diag = self.rows.iter().map(|r| r[0]).fold(0.0, f64::max);
        for i in 0..n {
            // Row i holds columns i − w ..= i; column j = i − w + c is entry ri[w − c].
            let w = i.min(BAND);
            let mut ri = self.rows[i];
            for c in 0..w {
                let rj = &self.rows[i - w + c];
                // s = A(i, j) − Σ_k L(i, k) L(j, k), k from i − w to j − 1 (ascending).
                let mut s = ri[w - c];
                for q in 0..c {
                    s -= ri[w - q] * rj[c - q];
                }
                ri[w - c] = s / rj[0];
            }
            let mut s = ri[0];
            for q in 0..w {
                s -= ri[w - q] * ri[w - q];
            }
            // NaN fails too.
            if s.is_nan() || s <= rel_tol * max_diag {
                return Err(NotPositiveDefinite);
            }
            ri[0] = s.sqrt();
            self.rows[i] = ri;
        }
        Ok(())
    }

    /// Solves L Lᵀ x = b in place for `NA` right-hand sides at once (`b[i][g]` is entry i of
    /// right-hand side g), after [`Self::cholesky`]: one pass over the band for all of them,
    /// each with the operations, in the order, of a solve of its own.
    pub(crate) fn solve<const NA: usize>(&self, b: &mut [[f64; NA]]) {
        let n = self.rows.len();
        for i in 0..n {
            let w = i.min(BAND);
            let r = &self.rows[i];
            let mut s = b[i];
            // k = i − w … i − 1, ascending: L(i, k) = r[i − k].
            for (l, x) in r[1..=w].iter().rev().zip(&b[i - w..i]) {
                for g in 0..NA {
                    s[g] -= l * x[g];
                }
            }
            b[i] = s.map(|v| v / r[0]);
        }
        for i in (0..n).rev() {
            let w = (n - 1 - i).min(BAND);
            let mut s = b[i];
            // k = i + 1 … i + w, ascending: L(k, i) = rows[k][k − i].
            for (q, (row, x)) in self.rows[i + 1..=i + w].iter().zip(&b[i + 1..=i + w]).enumerate() {
                for g in 0..NA {
                    s[g] -= row[q + 1] * x[g];
                }
            }
            b[i] = s.map(|v| v / self.rows[i][0]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A deterministic pseudo-random sequence (no dependency for a test).
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    }

    #[test]
    fn matches_a_dense_solve() {
        let mut seed = 7;
        for n in [1, 3, 6, 7, 20, 57] {
            // M = KᵀK + I with K banded rows of width BAND + 1: SPD and banded.
            let mut dense = DMatrix::<f64>::identity(n, n);
            let mut band = BandedSpd::zeros(n);
            for i in 0..n {
                band.add(i, i, 1.0);
            }
            for _ in 0..3 * n {
                let start = ((lcg(&mut seed) + 0.5) * n as f64) as usize % n;
                let row: Vec<f64> = (0..=BAND).map(|_| lcg(&mut seed) * 10.0).collect();
                for a in 0..=BAND {
                    for b in 0..=BAND {
                        let (i, j) = (start + a, start + b);
                        if i < n && j < n {
                            dense[(i, j)] += row[a] * row[b];
                            if i >= j {
                                band.add(i, j, row[a] * row[b]);
                            }
                        }
                    }
                }
            }
            let rhs: Vec<f64> = (0..n).map(|_| lcg(&mut seed)).collect();
            let x_dense = dense.clone().cholesky().unwrap().solve(&DVector::from_vec(rhs.clone()));
            band.cholesky(1e-14).unwrap();
            // The right-hand side alone and beside two others: the same solution, bit for bit.
            let mut x: Vec<[f64; 1]> = rhs.iter().map(|&v| [v]).collect();
            band.solve(&mut x);
            let mut x3: Vec<[f64; 3]> = rhs.iter().map(|&v| [2.0 * v, v, -v]).collect();
            band.solve(&mut x3);
            for i in 0..n {
                assert!((x[i][0] - x_dense[i]).abs() < 1e-10 * (1.0 + x_dense[i].abs()), "n {n} i {i}");
                // Scaling by a power of two or the sign is exact in floating point.
                assert_eq!(x3[i], [2.0 * x[i][0], x[i][0], -x[i][0]], "n {n} i {i}");
            }
        }
    }

    #[test]
    fn a_singular_matrix_is_refused() {
        let mut m = BandedSpd::zeros(3);
        m.add(0, 0, 1.0);
        m.add(2, 2, 1.0);
        assert_eq!(m.cholesky(1e-14), Err(NotPositiveDefinite));
    }
}
