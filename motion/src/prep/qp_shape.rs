//! The shape of a window QP (Haas 2012, §3.3, eq. 3.8–3.12): its point count, levels and
//! fixed ends, the variables' numbering and the layout of the right-hand side, shared by the
//! two solvers (`qp.rs` with Clarabel, `qp_banded.rs`).

/// Gap and feasibility tolerance both solvers stop at, relative to the data: positions to
/// ~1e-7 of the window's scale are far inside the micrometre budget, and each further digit
/// costs interior-point steps.
pub(super) const SOLVER_TOL: f64 = 1e-7;

/// The structure of a window problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) struct Shape {
    pub n_points: usize,
    /// Values per point: position and `levels − 1` derivatives.
    pub levels: usize,
    /// Leading levels fixed at the first point (1 = position only).
    pub left_fixed: usize,
    /// Leading levels fixed at the last point; 0 = the last point only keeps its band.
    pub right_fixed: usize,
}

impl Shape {
    pub(super) fn n_vars(&self) -> usize {
        self.n_points * self.levels
    }

    pub(super) fn var(&self, j: usize, k: usize) -> usize {
        j * self.levels + k
    }

    /// Trapezoid rows: (n − 1) per coupled level pair.
    pub(super) fn n_trapezoid(&self) -> usize {
        (self.n_points - 1) * (self.levels - 1)
    }

    pub(super) fn n_eq(&self) -> usize {
        self.n_trapezoid() + self.left_fixed + self.right_fixed
    }

    /// Points whose position is bounded by the band (all but fixed ends).
    pub(super) fn bounded(&self) -> std::ops::Range<usize> {
        1..if self.right_fixed == 0 { self.n_points } else { self.n_points - 1 }
    }

    pub(super) fn n_rows(&self) -> usize {
        self.n_eq() + 2 * self.bounded().len()
    }
}

/// Right-hand side rows for one axis.
pub(super) struct Rhs<'a> {
    pub left: &'a [f64],
    pub right: &'a [f64],
    /// (lower, upper) per bounded point, in `Shape::bounded` order.
    pub bands: &'a [(f64, f64)],
}

impl Shape {
    /// Fills `b` (length `n_rows`) from the boundary values and bands.
    pub(super) fn rhs(&self, rhs: &Rhs<'_>, b: &mut Vec<f64>) {
        b.clear();
        b.resize(self.n_trapezoid(), 0.0);
        b.extend_from_slice(&rhs.left[..self.left_fixed]);
        b.extend_from_slice(&rhs.right[..self.right_fixed]);
        for &(lo, hi) in rhs.bands {
            b.push(hi);
            b.push(-lo);
        }
        debug_assert_eq!(b.len(), self.n_rows());
    }
}

/// Trapezoid quadrature weight of point j for spacings `deltas`.
pub(super) fn quadrature_weight(deltas: &[f64], j: usize) -> f64 {
    let left = if j > 0 { deltas[j - 1] } else { 0.0 };
    let right = deltas.get(j).copied().unwrap_or(0.0);
    0.5 * (left + right)
}

/// The entries of A in a fixed order: (row, column) and value; the trapezoid rows first
/// (`Shape::n_trapezoid` of them), then the fixed ends, then the bands.
pub(super) fn a_entries(s: &Shape, deltas: &[f64]) -> (Vec<(usize, usize)>, Vec<f64>) {
    let mut idx = Vec::new();
    let mut val = Vec::new();
    let r = s.levels - 1;
    // The trapezoid coupling of Haas 2012, eq. 3.11, at every level k < r. Eq. 3.11 prints
    // the difference (x′_{i+1} − x′_i); the trapezoid rule, as in its expanded form, takes the
    // sum: z_{j+1,k} − z_{j,k} − (Δ_j/2)(z_{j,k+1} + z_{j+1,k+1}) = 0.
    for j in 0..s.n_points - 1 {
        for k in 0..r {
            let row = j * r + k;
            let half = 0.5 * deltas[j];
            idx.extend([
                (row, s.var(j + 1, k)),
                (row, s.var(j, k)),
                (row, s.var(j, k + 1)),
                (row, s.var(j + 1, k + 1)),
            ]);
            val.extend([1.0, -1.0, -half, -half]);
            if k + 2 <= r {
                // Euler–Maclaurin end correction of the trapezoid rule, + (Δ²/12)(z_{j+1,k+2} −
                // z_{j,k+2}): the rule becomes exact for quartic z and the points' data
                // consistent with a smooth curve to O(Δ⁵) instead of O(Δ³).
                let c = deltas[j] * deltas[j] / 12.0;
                idx.extend([(row, s.var(j + 1, k + 2)), (row, s.var(j, k + 2))]);
                val.extend([c, -c]);
            }
        }
    }
    let mut row = s.n_trapezoid();
    for k in 0..s.left_fixed {
        idx.push((row, s.var(0, k)));
        val.push(1.0);
        row += 1;
    }
    for k in 0..s.right_fixed {
        idx.push((row, s.var(s.n_points - 1, k)));
        val.push(1.0);
        row += 1;
    }
    for j in s.bounded() {
        // z ≤ upper, −z ≤ −lower
        idx.extend([(row, s.var(j, 0)), (row + 1, s.var(j, 0))]);
        val.extend([1.0, -1.0]);
        row += 2;
    }
    (idx, val)
}
