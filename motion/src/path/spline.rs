//! Natural cubic spline through support points: the tangent system of Huan, eq. 3.

/// Tangents T₁ … T_n (per unit span parameter) of the natural cubic spline through the points
/// `p` (one coordinate), solving the tridiagonal system of Huan, eq. 3 by the Thomas
/// algorithm:
///   2T₁ + T₂ = 3(P₂ − P₁)
///   T_{i−1} + 4T_i + T_{i+1} = 3(P_{i+1} − P_{i−1}),  i = 2 … n−1
///   T_{n−1} + 2T_n = 3(P_n − P_{n−1})
/// The system is strictly diagonally dominant except in its first and last row, where the
/// elimination stays stable (pivots ≥ 2 − 1/2).
pub(crate) fn natural_tangents(p: &[f64]) -> Vec<f64> {
    let n = p.len();
    match n {
        0 => return Vec::new(),
        1 => return vec![0.0],
        2 => return vec![p[1] - p[0]; 2],
        _ => {}
    }
    let mut diag = vec![4.0; n];
    let mut rhs = vec![0.0; n];
    diag[0] = 2.0;
    diag[n - 1] = 2.0;
    rhs[0] = 3.0 * (p[1] - p[0]);
    rhs[n - 1] = 3.0 * (p[n - 1] - p[n - 2]);
    for i in 1..n - 1 {
        rhs[i] = 3.0 * (p[i + 1] - p[i - 1]);
    }
    // Off-diagonals are all 1: forward elimination, then back substitution.
    for i in 1..n {
        let m = 1.0 / diag[i - 1];
        diag[i] -= m;
        rhs[i] -= m * rhs[i - 1];
    }
    let mut t = vec![0.0; n];
    t[n - 1] = rhs[n - 1] / diag[n - 1];
    for i in (0..n - 1).rev() {
        t[i] = (rhs[i] - t[i + 1]) / diag[i];
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hermite(p0: f64, p1: f64, t0: f64, t1: f64, u: f64) -> (f64, f64, f64) {
        let r2 = 3.0 * (p1 - p0) - 2.0 * t0 - t1;
        let r3 = 2.0 * (p0 - p1) + t0 + t1;
        (r3 * u.powi(3) + r2 * u * u + t0 * u + p0, 3.0 * r3 * u * u + 2.0 * r2 * u + t0, 6.0 * r3 * u + 2.0 * r2)
    }

    #[test]
    fn spline_is_c2_and_natural() {
        let p = [0.0, 2.0, -1.0, 3.0, 3.5, 0.0, 1.0];
        let t = natural_tangents(&p);
        for i in 0..p.len() - 1 {
            let (a, _, _) = hermite(p[i], p[i + 1], t[i], t[i + 1], 0.0);
            let (b, _, _) = hermite(p[i], p[i + 1], t[i], t[i + 1], 1.0);
            assert!((a - p[i]).abs() < 1e-12 && (b - p[i + 1]).abs() < 1e-12, "passes through points");
        }
        for i in 1..p.len() - 1 {
            let (_, d1l, d2l) = hermite(p[i - 1], p[i], t[i - 1], t[i], 1.0);
            let (_, d1r, d2r) = hermite(p[i], p[i + 1], t[i], t[i + 1], 0.0);
            assert!((d1l - d1r).abs() < 1e-12);
            assert!((d2l - d2r).abs() < 1e-10, "C² at point {i}: {d2l} vs {d2r}");
        }
        let (_, _, d2start) = hermite(p[0], p[1], t[0], t[1], 0.0);
        let n = p.len();
        let (_, _, d2end) = hermite(p[n - 2], p[n - 1], t[n - 2], t[n - 1], 1.0);
        assert!(d2start.abs() < 1e-10 && d2end.abs() < 1e-10, "natural ends");
    }

    #[test]
    fn straight_points_give_constant_tangent() {
        let p: Vec<f64> = (0..10).map(|i| 2.0 * i as f64).collect();
        for t in natural_tangents(&p) {
            assert!((t - 2.0).abs() < 1e-12);
        }
    }
}
