//! From interpolation conditions to polynomial coefficients (Bewegungsdesign nach Maß: "aus
//! diesem Satz von Interpolationsbedingungen ein lineares Gleichungssystem"), solved in the
//! shifted Chebyshev basis with row and column equilibration and an SVD, then refined with
//! residuals in double-double (mixed-precision iterative refinement: each round gains about
//! −log₁₀(ε·cond) digits until double-double precision).

use super::chebyshev;
use super::condition::{Condition, ConditionSet, LawError};
use super::ddouble::Dd;
use nalgebra::{DMatrix, DVector, SVD};

/// Below this reciprocal condition number (σ_min/σ_max of the equilibrated system) the
/// conditions are taken as not independent. The article's laws sit above 1e-8 (see the tests); at
/// 1e-12 the solution would carry errors of ~1e-4 and the residual check would fail anyway.
pub(super) const RCOND_MIN: f64 = 1e-12;

/// A singular system is contradictory, not just dependent, when the right-hand side has more
/// than this share (relative to its norm) outside the range of the matrix.
pub(super) const INCONSISTENCY_REL: f64 = 1e-8;

/// A condition counts as met when |f⁽ⁱ⁾(z) − F| (double-double coefficients, evaluated in
/// double-double) ≤ this × max(1, Σ|Chebyshev coefficients of f⁽ⁱ⁾|). After refinement the
/// residuals are ~1e-25 of that scale; this backstop only catches a refinement that failed.
pub(super) const ACCEPT_REL: f64 = 1e-12;

/// Most rounds of iterative refinement after the first solve. With σ_min/σ_max ≥ RCOND_MIN
/// each round gains ≥ 3 digits; the article's laws (rcond ≥ 1e-5) reach double-double precision
/// in 3.
const REFINEMENT_ROUNDS: usize = 6;

/// SVD sweeps allowed before giving up (nalgebra needs a few per singular value).
const SVD_MAX_ITER: usize = 10_000;

/// A left singular vector entry this large (relative to the largest) marks a condition as part
/// of a dependent or contradictory group.
const INVOLVED_REL: f64 = 0.1;

/// The solved coefficients with the system's reciprocal condition number.
pub(super) struct Solution {
    /// Chebyshev coefficients of f in φ_k(z) = T_k(2z − 1), in double-double.
    pub coeffs: Vec<Dd>,
    /// σ_min/σ_max of the equilibrated interpolation matrix.
    pub rcond: f64,
}

/// The interpolation matrix A (rows: conditions, columns: basis functions) in double-double.
fn system(conds: &[Condition]) -> Vec<Vec<Dd>> {
    let n = conds.len();
    conds
        .iter()
        .map(|c| {
            let mut row = vec![Dd::ZERO; n];
            chebyshev::basis_row(c.order as usize, c.z, &mut row);
            row
        })
        .collect()
}

/// F − A·c for every condition, in double-double, rounded to f64.
fn residual(a: &[Vec<Dd>], conds: &[Condition], c: &[Dd]) -> DVector<f64> {
    DVector::from_iterator(
        conds.len(),
        a.iter().zip(conds).map(|(row, cond)| {
            let ac = row.iter().zip(c).fold(Dd::ZERO, |s, (r, ck)| s + *r * *ck);
            (Dd::from(cond.value) - ac).to_f64()
        }),
    )
}

/// Row factors 1/max|row| (a derivative row of order i is ~n²ⁱ times larger than a position
/// row) and then column factors 1/‖column‖₂ of the row-scaled matrix.
fn equilibrate(a: &DMatrix<f64>) -> (DVector<f64>, DVector<f64>) {
    let n = a.nrows();
    let rows = DVector::from_iterator(n, a.row_iter().map(|r| inverse_or_one(r.amax())));
    let scaled = DMatrix::from_fn(n, n, |i, k| a[(i, k)] * rows[i]);
    let cols = DVector::from_iterator(n, scaled.column_iter().map(|c| inverse_or_one(c.norm())));
    (rows, cols)
}

fn inverse_or_one(v: f64) -> f64 {
    if v > 0.0 && v.is_finite() { 1.0 / v } else { 1.0 }
}

/// Solves the conditions for the Chebyshev coefficients of the degree-(count − 1) polynomial.
pub(super) fn solve(set: &ConditionSet) -> Result<Solution, LawError> {
    let conds = set.conditions();
    let n = conds.len();
    let a_dd = system(conds);
    let a = DMatrix::from_fn(n, n, |i, k| a_dd[i][k].to_f64());
    let b = DVector::from_iterator(n, conds.iter().map(|c| c.value));
    let (rows, cols) = equilibrate(&a);
    let scaled = DMatrix::from_fn(n, n, |i, k| a[(i, k)] * rows[i] * cols[k]);
    let svd = SVD::try_new(scaled, true, true, f64::EPSILON, SVD_MAX_ITER)
        .ok_or_else(|| LawError::Numerical { what: format!("SVD of the {n}×{n} interpolation matrix") })?;
    let sigma = &svd.singular_values;
    let rcond = if sigma[0] > 0.0 { sigma[n - 1] / sigma[0] } else { 0.0 };
    let rb = b.component_mul(&rows);
    if rcond < RCOND_MIN {
        return Err(singular_error(&svd, &rb, conds, rcond, set.degree()));
    }
    let solve_scaled = |rhs: &DVector<f64>| -> Result<DVector<f64>, LawError> {
        let y = svd.solve(rhs, 0.0).map_err(|e| LawError::Numerical { what: format!("SVD back-substitution: {e}") })?;
        Ok(y.component_mul(&cols))
    };
    let mut c: Vec<Dd> = solve_scaled(&rb)?.iter().map(|&v| Dd::from(v)).collect();
    for _ in 0..REFINEMENT_ROUNDS {
        let r = residual(&a_dd, conds, &c);
        if r.iter().all(|v| *v == 0.0) {
            break;
        }
        let delta = solve_scaled(&r.component_mul(&rows))?;
        for (ck, d) in c.iter_mut().zip(delta.iter()) {
            *ck = *ck + Dd::from(*d);
        }
    }
    Ok(Solution { coeffs: c, rcond })
}

/// Tells a contradictory set (the values cannot all hold) from a merely dependent one (they
/// hold but do not fix the polynomial), and names the conditions involved: those with weight in
/// the left null space of the matrix.
fn singular_error(
    svd: &SVD<f64, nalgebra::Dyn, nalgebra::Dyn>,
    rb: &DVector<f64>,
    conds: &[Condition],
    rcond: f64,
    degree: usize,
) -> LawError {
    let Some(u) = svd.u.as_ref() else {
        return LawError::Numerical { what: String::from("SVD without left singular vectors") };
    };
    let sigma = &svd.singular_values;
    let n = conds.len();
    let tol = RCOND_MIN * sigma[0];
    let null: Vec<usize> = (0..n).filter(|&j| sigma[j] <= tol).collect();
    let mut weight = vec![0.0f64; n];
    let mut outside = 0.0f64;
    for &j in &null {
        let col = u.column(j);
        outside = outside.hypot(col.dot(rb));
        for (w, v) in weight.iter_mut().zip(col.iter()) {
            *w = w.max(v.abs());
        }
    }
    let wmax = weight.iter().copied().fold(0.0, f64::max);
    let indices: Vec<usize> = (0..n).filter(|&i| weight[i] >= INVOLVED_REL * wmax && wmax > 0.0).collect();
    if outside > INCONSISTENCY_REL * rb.norm().max(f64::MIN_POSITIVE) {
        let detail = indices.iter().map(|&i| conds[i].to_string()).collect::<Vec<_>>().join(", ");
        LawError::Contradictory { indices, detail: format!("no polynomial of degree {degree} meets {detail}") }
    } else {
        LawError::Dependent { indices, rcond, min: RCOND_MIN, degree }
    }
}
