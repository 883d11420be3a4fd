//! The basis the solver works in: Chebyshev polynomials of the first kind shifted to the motion
//! section, φ_k(z) = T_k(2z − 1), z ∈ [0, 1]. Unlike the monomials zᵏ of the article's
//! f(z) = a₀ + a₁z + … + aₙzⁿ, they stay of size ≤ 1 on [0, 1] and are nearly orthogonal, so
//! the interpolation system stays well conditioned at high degree.

use super::ddouble::Dd;
use std::ops::{Add, Mul, Sub};

/// The arithmetic the basis code runs in: f64 at run time, [`Dd`] when solving.
pub(super) trait Scalar:
    Copy + From<f64> + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
}
impl Scalar for f64 {}
impl Scalar for Dd {}

/// x ∈ [−1, 1] for z ∈ [0, 1]. Exact at z = 0, ½, 1 in f64 and everywhere in [`Dd`].
pub(super) fn x_of_z<T: Scalar>(z: f64) -> T {
    T::from(2.0 * z) - T::from(1.0)
}

/// Fills `row[k]` = dⁱ/dzⁱ T_k(2z − 1) for k = 0 … row.len() − 1 (one row of the interpolation
/// matrix for the condition f⁽ⁱ⁾(z) = F).
pub(super) fn basis_row<T: Scalar>(order: usize, z: f64, row: &mut [T]) {
    let x: T = x_of_z(z);
    let two_x = T::from(2.0) * x;
    let (zero, one) = (T::from(0.0), T::from(1.0));
    let len = row.len();
    // T_k⁽ʲ⁾(x), built up order by order. Differentiating the three-term recurrence
    // T_{k+1} = 2x T_k − T_{k−1} j times (Leibniz) gives
    // T_{k+1}⁽ʲ⁾ = 2x T_k⁽ʲ⁾ + 2j T_k⁽ʲ⁻¹⁾ − T_{k−1}⁽ʲ⁾.
    let mut prev: Vec<T> = vec![zero; len]; // order j − 1
    let mut cur: Vec<T> = vec![zero; len]; // order j
    for j in 0..=order {
        let two_j = T::from(2.0 * j as f64);
        for k in 0..len {
            cur[k] = match (k, j) {
                (0, 0) | (1, 1) => one,
                (0, _) => zero,
                (1, 0) => x,
                (1, _) => zero,
                _ => two_x * cur[k - 1] + two_j * prev[k - 1] - cur[k - 2],
            };
        }
        if j < order {
            std::mem::swap(&mut prev, &mut cur);
        }
    }
    // Chain rule: d/dz = 2 d/dx (a power of two: exact).
    let scale = T::from(2f64.powi(order as i32));
    for (r, c) in row.iter_mut().zip(&cur) {
        *r = *c * scale;
    }
}

/// Chebyshev coefficients of d/dz of the series with coefficients `c` (one shorter; a constant
/// gives `[0]`). The standard backward recurrence c′_{k−1} = c′_{k+1} + 2k c_k with c′₀ halved,
/// times 2 for d/dz = 2 d/dx (Mason & Handscomb, Chebyshev Polynomials, eq. 2.49).
pub(super) fn derivative<T: Scalar>(c: &[T]) -> Vec<T> {
    let n = c.len();
    let zero = T::from(0.0);
    if n <= 1 {
        return vec![zero];
    }
    let mut d = vec![zero; n - 1];
    // d[k−1] = d[k+1] + 2k c[k], from k = n−1 down to 1, with d[n−1] = d[n] = 0.
    for k in (1..n).rev() {
        let above = if k + 1 < n - 1 { d[k + 1] } else { zero };
        d[k - 1] = above + T::from(2.0 * k as f64) * c[k];
    }
    // Halve d₀, then double all for d/dz: d₀ stays, the others double (exact scalings).
    for v in d.iter_mut().skip(1) {
        *v = *v * T::from(2.0);
    }
    d
}

/// Σ c_k T_k(2z − 1) by Clenshaw's recurrence: backward stable, no allocation.
pub(super) fn eval<T: Scalar>(c: &[T], z: f64) -> T {
    let x: T = x_of_z(z);
    let two_x = T::from(2.0) * x;
    let zero = T::from(0.0);
    let (mut b1, mut b2) = (zero, zero);
    for &ck in c.iter().skip(1).rev() {
        let b0 = ck + two_x * b1 - b2;
        b2 = b1;
        b1 = b0;
    }
    c.first().copied().unwrap_or(zero) + x * b1 - b2
}

/// Σ|c_k|: bounds |Σ c_k T_k| on [0, 1] (|T_k| ≤ 1 there), so rounding in an evaluation is
/// about ε times this. Used to judge residuals.
pub(super) fn abs_sum(c: &[f64]) -> f64 {
    c.iter().map(|v| v.abs()).sum()
}

/// Monomial coefficients a_k of f(z) = Σ a_k zᵏ (the article's form) for the Chebyshev series c.
/// For reporting only: at high degree the a_k are large and alternate, and summing them loses
/// digits (that is why the solver does not use them).
pub(super) fn to_monomial(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    let mut out = vec![0.0; n];
    // Monomial coefficients (in z) of T_{k−1}(2z−1) and T_k(2z−1), advanced by
    // T_{k+1} = (4z − 2) T_k − T_{k−1}.
    let mut t_prev = vec![0.0; n + 1];
    let mut t_cur = vec![0.0; n + 1];
    t_prev[0] = 1.0; // T_0
    if n > 0 {
        out[0] += c[0];
    }
    if n > 1 {
        t_cur[0] = -1.0; // T_1 = 2z − 1
        t_cur[1] = 2.0;
        out[0] += c[1] * t_cur[0];
        out[1] += c[1] * t_cur[1];
    }
    for ck in c.iter().skip(2) {
        let mut next = vec![0.0; n + 1];
        for m in 0..n {
            next[m + 1] += 4.0 * t_cur[m];
            next[m] += -2.0 * t_cur[m] - t_prev[m];
        }
        for (o, t) in out.iter_mut().zip(&next) {
            *o += ck * t;
        }
        t_prev = std::mem::replace(&mut t_cur, next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(z) = z³ in Chebyshev form: z = (x+1)/2, x³ = (3T₁ + T₃)/4.
    fn cube() -> Vec<f64> {
        // z³ = (x+1)³/8 = (x³ + 3x² + 3x + 1)/8 with x² = (T₀+T₂)/2, x³ = (3T₁+T₃)/4.
        vec![(1.0 + 1.5) / 8.0, (3.0 + 0.75) / 8.0, 1.5 / 8.0, 0.25 / 8.0]
    }

    #[test]
    fn eval_and_derivatives_of_a_cube() {
        let c = cube();
        for &z in &[0.0, 0.3, 0.5, 1.0] {
            assert!((eval(&c, z) - z * z * z).abs() < 1e-15);
            let d1 = derivative(&c);
            assert!((eval(&d1, z) - 3.0 * z * z).abs() < 1e-14);
            let d2 = derivative(&d1);
            assert!((eval(&d2, z) - 6.0 * z).abs() < 1e-14);
            let d3 = derivative(&d2);
            assert!((eval(&d3, z) - 6.0).abs() < 1e-14);
            assert_eq!(derivative(&derivative(&d3)), vec![0.0]);
        }
        let m = to_monomial(&c);
        for (k, want) in [0.0, 0.0, 0.0, 1.0].iter().enumerate() {
            assert!((m[k] - want).abs() < 1e-15, "{m:?}");
        }
    }

    #[test]
    fn basis_rows_match_derivatives_of_the_series() {
        // Row · c must equal the derivative series evaluated by Clenshaw, for any c.
        let c: Vec<f64> = (0..12).map(|k| ((k * 7 + 3) % 5) as f64 - 2.0).collect();
        let mut deriv = c.clone();
        for order in 0..6 {
            for &z in &[0.0, 0.17, 0.5, 0.82, 1.0] {
                let mut row = vec![0.0; c.len()];
                basis_row(order, z, &mut row);
                let dot: f64 = row.iter().zip(&c).map(|(r, c)| r * c).sum();
                let want = eval(&deriv, z);
                assert!((dot - want).abs() <= 1e-12 * want.abs().max(1.0), "order {order} z {z}: {dot} vs {want}");
            }
            deriv = derivative(&deriv);
        }
    }
}
