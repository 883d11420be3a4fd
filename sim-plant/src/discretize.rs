//! Exact (zero-order-hold) discretisation of a linear system ẋ = A x + B u.
//!
//! Φ = e^{Ah}, Γ = ∫₀ʰ e^{As} ds · B, both from one exponential of the augmented matrix
//! `[[A, B], [0, 0]]·h` (Van Loan), in the notation x_{k+1} = Φ x_k + Γ u_k of Schneider 2016,
//! eq. 2.23.
//! The augmented matrix is balanced with a diagonal power-of-two similarity first, so entries
//! of very different size (positions in m, forces in kN) keep their relative accuracy.

use crate::PlantError;
use nalgebra::{DMatrix, SMatrix};

/// The discrete system: x⁺ = Φ x + Γ u with u held over the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discrete<const N: usize, const M: usize> {
    pub phi: SMatrix<f64, N, N>,
    pub gamma: SMatrix<f64, N, M>,
}

/// Φ and Γ of (A, B) for the step `h_s`.
pub fn discretize<const N: usize, const M: usize>(
    a: &SMatrix<f64, N, N>,
    b: &SMatrix<f64, N, M>,
    h_s: f64,
) -> Result<Discrete<N, M>, PlantError> {
    if !(h_s.is_finite() && h_s > 0.0) || a.iter().chain(b.iter()).any(|x| !x.is_finite()) {
        return Err(PlantError::Model("system matrices and step must be finite".into()));
    }
    let n = N + M;
    let mut aug = DMatrix::<f64>::zeros(n, n);
    aug.view_mut((0, 0), (N, N)).copy_from(&(a * h_s));
    aug.view_mut((0, N), (N, M)).copy_from(&(b * h_s));
    let d = balance(&mut aug);
    let e = aug.exp();
    // exp(D⁻¹ M D) = D⁻¹ exp(M) D  ⇒  exp(M)_ij = d_i · exp(M̃)_ij / d_j.
    let mut phi = SMatrix::<f64, N, N>::zeros();
    let mut gamma = SMatrix::<f64, N, M>::zeros();
    for i in 0..N {
        for j in 0..N {
            phi[(i, j)] = d[i] * e[(i, j)] / d[j];
        }
        for j in 0..M {
            gamma[(i, j)] = d[i] * e[(i, N + j)] / d[N + j];
        }
    }
    if phi.iter().chain(gamma.iter()).any(|x| !x.is_finite()) {
        return Err(PlantError::Model("matrix exponential is not finite".into()));
    }
    Ok(Discrete { phi, gamma })
}

/// Osborne balancing with powers of two: replaces `m` by D⁻¹ m D and returns diag(D).
fn balance(m: &mut DMatrix<f64>) -> Vec<f64> {
    let n = m.nrows();
    let mut d = vec![1.0; n];
    for _ in 0..100 {
        let mut changed = false;
        for i in 0..n {
            let mut c = 0.0;
            let mut r = 0.0;
            for j in 0..n {
                if j != i {
                    c += m[(j, i)].abs();
                    r += m[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / 2.0 {
                cc *= 2.0;
                rr /= 2.0;
                f *= 2.0;
            }
            while cc >= rr * 2.0 {
                cc /= 2.0;
                rr *= 2.0;
                f /= 2.0;
            }
            if (cc + rr) < 0.95 * s {
                changed = true;
                d[i] *= f;
                // Column i times f, row i divided by f.
                for j in 0..n {
                    m[(j, i)] *= f;
                    m[(i, j)] /= f;
                }
            }
        }
        if !changed {
            break;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn double_integrator_is_exact() {
        let m_kg = 250.0;
        let a = Matrix2::new(0.0, 1.0, 0.0, 0.0);
        let b = Vector2::new(0.0, 1.0 / m_kg);
        let h = 1e-4;
        let d = discretize(&a, &b, h).unwrap();
        assert!((d.gamma[0] - h * h / (2.0 * m_kg)).abs() < 1e-12 * h * h / m_kg);
        assert!((d.gamma[1] - h / m_kg).abs() < 1e-12 * h / m_kg);
        assert_eq!(d.phi[(0, 1)], h);
    }

    #[test]
    fn oscillator_matches_closed_form() {
        // m ẍ = −k x + u: Φ = [[cos, sin/ω], [−ω sin, cos]], Γ = [(1−cos)/k, sin/(mω)].
        let (m, k) = (200.0_f64, 3.5e7);
        let w = (k / m).sqrt();
        let a = Matrix2::new(0.0, 1.0, -k / m, 0.0);
        let b = Vector2::new(0.0, 1.0 / m);
        let h = 1e-4;
        let d = discretize(&a, &b, h).unwrap();
        let (s, c) = (w * h).sin_cos();
        let rel = |x: f64, y: f64| ((x - y) / y).abs();
        assert!(rel(d.phi[(0, 0)], c) < 1e-12);
        assert!(rel(d.phi[(0, 1)], s / w) < 1e-12);
        assert!(rel(d.phi[(1, 0)], -w * s) < 1e-12);
        assert!(rel(d.gamma[0], (1.0 - c) / k) < 1e-9, "{} vs {}", d.gamma[0], (1.0 - c) / k);
        assert!(rel(d.gamma[1], s / (m * w)) < 1e-12);
    }

    #[test]
    fn rejects_non_finite() {
        let a = Matrix2::new(0.0, f64::NAN, 0.0, 0.0);
        let b = Vector2::new(0.0, 1.0);
        assert!(discretize(&a, &b, 1e-4).is_err());
        assert!(discretize(&Matrix2::zeros(), &b, 0.0).is_err());
    }
}
