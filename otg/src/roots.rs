//! Small polynomial solvers for the profile equations: real roots of quadratics, cubics and
//! quartics, each polished by Newton iterations on the original polynomial.
//!
//! The closed forms (Cardano / Ferrari with a resolvent cubic) lose digits when roots are close
//! together or coefficients cancel; every root is therefore polished on the polynomial itself,
//! and the callers polish once more on the exact kinematic equations before a candidate is
//! checked (Ruckig RSS 2021, Sec. IV-C: "closed-form solution plus Newton refinement").
//!
//! All functions are allocation-free: roots come back in a fixed-capacity [`Roots`] set.

/// Relative size below which a leading coefficient is treated as zero (degree drops).
const DEGENERATE_LEADING_REL: f64 = 1e-14;
/// Newton polishing stops once a step is below this fraction of the root's magnitude.
const POLISH_STEP_REL: f64 = 1e-15;
/// Upper bound of polishing iterations per root.
const POLISH_MAX_ITERATIONS: usize = 6;
/// Discriminants within this many ulps of the terms they are made of are treated as zero
/// (a double root), so that a tangent root is not lost to rounding.
const DISCRIMINANT_ULPS: f64 = 16.0;

/// Up to four real roots, in no particular order.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Roots {
    values: [f64; 4],
    len: usize,
}

impl Roots {
    #[inline]
    fn push(&mut self, x: f64) {
        if x.is_finite() && self.len < self.values.len() {
            self.values[self.len] = x;
            self.len += 1;
        }
    }

    /// The roots found.
    #[inline]
    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.values[..self.len]
    }

    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }
}

/// Evaluate a polynomial given by coefficients from the highest degree down (Horner).
#[inline]
pub(crate) fn poly_eval(coeffs: &[f64], x: f64) -> f64 {
    coeffs.iter().fold(0.0, |acc, &c| acc * x + c)
}

/// Value and derivative of a polynomial (coefficients from the highest degree down).
#[inline]
fn poly_eval_with_derivative(coeffs: &[f64], x: f64) -> (f64, f64) {
    let mut value = 0.0;
    let mut derivative = 0.0;
    for &c in coeffs {
        derivative = derivative * x + value;
        value = value * x + c;
    }
    (value, derivative)
}

/// Newton iterations on `coeffs` from `x`; keeps `x` if the iteration does not reduce |f|.
pub(crate) fn polish(coeffs: &[f64], mut x: f64) -> f64 {
    let (mut f, mut df) = poly_eval_with_derivative(coeffs, x);
    for _ in 0..POLISH_MAX_ITERATIONS {
        if f == 0.0 || df == 0.0 || !df.is_finite() {
            break;
        }
        let step = f / df;
        let candidate = x - step;
        let (f_new, df_new) = poly_eval_with_derivative(coeffs, candidate);
        if !(f_new.abs() < f.abs()) {
            break;
        }
        x = candidate;
        f = f_new;
        df = df_new;
        if step.abs() <= POLISH_STEP_REL * x.abs() {
            break;
        }
    }
    x
}

/// Real roots of `a x² + b x + c`, numerically stable (no cancellation in the larger root).
pub(crate) fn solve_quadratic(a: f64, b: f64, c: f64) -> Roots {
    let mut roots = Roots::default();
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 || !scale.is_finite() {
        return roots;
    }
    if a.abs() <= DEGENERATE_LEADING_REL * scale {
        if b != 0.0 {
            roots.push(-c / b);
        }
        return roots;
    }
    let discriminant = b * b - 4.0 * a * c;
    let magnitude = b * b + (4.0 * a * c).abs();
    if discriminant < 0.0 {
        if -discriminant <= DISCRIMINANT_ULPS * f64::EPSILON * magnitude {
            roots.push(-b / (2.0 * a));
        }
        return roots;
    }
    let sqrt_d = discriminant.sqrt();
    // q has the sign of b so that b + sign(b) sqrt(D) never cancels.
    let q = -0.5 * (b + sqrt_d.copysign(b));
    if q == 0.0 {
        roots.push(0.0);
        return roots;
    }
    roots.push(q / a);
    roots.push(c / q);
    roots
}

/// Real roots of the monic cubic `x³ + b x² + c x + d`.
pub(crate) fn solve_cubic_monic(b: f64, c: f64, d: f64) -> Roots {
    let mut roots = Roots::default();
    // Depressed cubic y³ + p y + q with x = y - b/3.
    let shift = b / 3.0;
    let p = c - b * shift;
    let q = d - c * shift + 2.0 * shift * shift * shift;
    let coeffs = [1.0, b, c, d];
    let half_q = 0.5 * q;
    let third_p = p / 3.0;
    let discriminant = half_q * half_q + third_p * third_p * third_p;
    let magnitude = half_q * half_q + (third_p * third_p * third_p).abs();
    if discriminant.abs() <= DISCRIMINANT_ULPS * f64::EPSILON * magnitude {
        // A double root (or a triple root at p = q = 0).
        let u = (-half_q).cbrt();
        roots.push(polish(&coeffs, 2.0 * u - shift));
        roots.push(polish(&coeffs, -u - shift));
    } else if discriminant > 0.0 {
        // One real root (Cardano), the larger cube root taken first to avoid cancellation.
        let sqrt_d = discriminant.sqrt();
        let w = (-half_q - sqrt_d.copysign(half_q)).cbrt();
        let y = if w == 0.0 { 0.0 } else { w - third_p / w };
        roots.push(polish(&coeffs, y - shift));
    } else {
        // Three real roots (trigonometric form), p < 0 here.
        let r = (-third_p).sqrt();
        let cos_arg = (-half_q / (r * r * r)).clamp(-1.0, 1.0);
        let phi = cos_arg.acos() / 3.0;
        let two_r = 2.0 * r;
        const TWO_PI_3: f64 = 2.0 * std::f64::consts::PI / 3.0;
        roots.push(polish(&coeffs, two_r * phi.cos() - shift));
        roots.push(polish(&coeffs, two_r * (phi + TWO_PI_3).cos() - shift));
        roots.push(polish(&coeffs, two_r * (phi - TWO_PI_3).cos() - shift));
    }
    roots
}

/// Real roots of `a x³ + b x² + c x + d`, falling back to lower degrees when `a` vanishes.
pub(crate) fn solve_cubic(a: f64, b: f64, c: f64, d: f64) -> Roots {
    let scale = a.abs().max(b.abs()).max(c.abs()).max(d.abs());
    if scale == 0.0 || !scale.is_finite() {
        return Roots::default();
    }
    if a.abs() <= DEGENERATE_LEADING_REL * scale {
        return solve_quadratic(b, c, d);
    }
    solve_cubic_monic(b / a, c / a, d / a)
}

/// Real roots of the monic quartic `x⁴ + b x³ + c x² + d x + e` (Ferrari via the resolvent cubic),
/// each polished on the quartic.
pub(crate) fn solve_quartic_monic(b: f64, c: f64, d: f64, e: f64) -> Roots {
    let mut roots = Roots::default();
    let coeffs = [1.0, b, c, d, e];
    // Depressed quartic y⁴ + p y² + q y + r with x = y - b/4.
    let shift = 0.25 * b;
    let shift2 = shift * shift;
    let p = c - 6.0 * shift2;
    let q = d - 2.0 * c * shift + 8.0 * shift * shift2;
    let r = e - d * shift + c * shift2 - 3.0 * shift2 * shift2;

    let mut push_quadratic = |qa: f64, qb: f64, roots: &mut Roots| {
        for &y in solve_quadratic(1.0, qa, qb).as_slice() {
            roots.push(polish(&coeffs, y - shift));
        }
    };

    let q_scale = p.abs().max(r.abs().sqrt()).max(1e-300);
    if q.abs() <= 1e-14 * q_scale * q_scale.sqrt() {
        // Biquadratic: y⁴ + p y² + r = 0.
        for &z in solve_quadratic(1.0, p, r).as_slice() {
            if z >= 0.0 {
                let y = z.sqrt();
                roots.push(polish(&coeffs, y - shift));
                if y > 0.0 {
                    roots.push(polish(&coeffs, -y - shift));
                }
            } else if z > -1e-14 * q_scale {
                roots.push(polish(&coeffs, -shift));
            }
        }
        return roots;
    }

    // Resolvent cubic in m: (y² + p/2 + m)² = 2m (y - q/(4m))², i.e.
    // 8m³ + 8p m² + (2p² - 8r) m - q² = 0. Its largest root is positive because q ≠ 0.
    let resolvent = solve_cubic_monic(p, 0.25 * p * p - r, -0.125 * q * q);
    let mut m = f64::NEG_INFINITY;
    for &root in resolvent.as_slice() {
        m = m.max(root);
    }
    if !(m > 0.0) {
        return roots;
    }
    let sqrt_2m = (2.0 * m).sqrt();
    let half_p_plus_m = 0.5 * p + m;
    let q_term = q / (2.0 * sqrt_2m);
    push_quadratic(-sqrt_2m, half_p_plus_m + q_term, &mut roots);
    push_quadratic(sqrt_2m, half_p_plus_m - q_term, &mut roots);
    roots
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sorted(r: Roots) -> Vec<f64> {
        let mut v = r.as_slice().to_vec();
        v.sort_by(f64::total_cmp);
        v
    }

    #[test]
    fn quadratic_roots_and_degenerate_cases() {
        assert_eq!(sorted(solve_quadratic(1.0, -3.0, 2.0)), vec![1.0, 2.0]);
        assert_eq!(sorted(solve_quadratic(0.0, 2.0, -4.0)), vec![2.0]);
        assert_eq!(solve_quadratic(1.0, 0.0, 1.0).len(), 0);
        // Large spread: the small root must not cancel.
        let r = sorted(solve_quadratic(1.0, -1e8, 1.0));
        assert!((r[0] - 1e-8).abs() < 1e-22);
        // Double root.
        assert_eq!(solve_quadratic(1.0, -2.0, 1.0).len(), 2);
    }

    #[test]
    fn cubic_three_and_one_real_roots() {
        let r = sorted(solve_cubic(1.0, -6.0, 11.0, -6.0));
        for (got, want) in r.iter().zip([1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-12, "{r:?}");
        }
        let r = sorted(solve_cubic(2.0, 0.0, 0.0, -16.0));
        assert_eq!(r.len(), 1);
        assert!((r[0] - 2.0).abs() < 1e-14);
        // Double root at 1, single at -2: (x-1)²(x+2) = x³ - 3x + 2.
        let r = sorted(solve_cubic(1.0, 0.0, -3.0, 2.0));
        assert!(r.iter().any(|x| (x + 2.0).abs() < 1e-12));
        assert!(r.iter().any(|x| (x - 1.0).abs() < 1e-6));
    }

    #[test]
    fn quartic_four_real_roots_and_biquadratic() {
        // (x-1)(x-2)(x-3)(x-4) = x⁴ - 10x³ + 35x² - 50x + 24
        let r = sorted(solve_quartic_monic(-10.0, 35.0, -50.0, 24.0));
        assert_eq!(r.len(), 4);
        for (got, want) in r.iter().zip([1.0, 2.0, 3.0, 4.0]) {
            assert!((got - want).abs() < 1e-12, "{r:?}");
        }
        // x⁴ - 5x² + 4 = (x²-1)(x²-4)
        let r = sorted(solve_quartic_monic(0.0, -5.0, 0.0, 4.0));
        assert_eq!(r.len(), 4);
        assert!((r[0] + 2.0).abs() < 1e-14 && (r[3] - 2.0).abs() < 1e-14);
        // Two real, two complex: (x² + 1)(x - 1)(x + 3) = x⁴ + 2x³ - 2x² + 2x - 3
        let r = sorted(solve_quartic_monic(2.0, -2.0, 2.0, -3.0));
        assert_eq!(r.len(), 2, "{r:?}");
        assert!((r[0] + 3.0).abs() < 1e-12 && (r[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn quartic_with_widely_spread_roots() {
        // Roots 1e-3, 1, 10, 1e3.
        let roots = [1e-3, 1.0, 10.0, 1e3];
        let b = -(roots.iter().sum::<f64>());
        let c = roots[0] * roots[1]
            + roots[0] * roots[2]
            + roots[0] * roots[3]
            + roots[1] * roots[2]
            + roots[1] * roots[3]
            + roots[2] * roots[3];
        let d = -(roots[0] * roots[1] * roots[2]
            + roots[0] * roots[1] * roots[3]
            + roots[0] * roots[2] * roots[3]
            + roots[1] * roots[2] * roots[3]);
        let e = roots.iter().product::<f64>();
        let r = sorted(solve_quartic_monic(b, c, d, e));
        assert_eq!(r.len(), 4, "{r:?}");
        for (got, want) in r.iter().zip(roots) {
            assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        }
    }
}
