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
