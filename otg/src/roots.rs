//! Real roots of the polynomials of the profile equations: cubics, monic quartics (Ferrari with a
//! resolvent cubic) and a safeguarded Newton/bisection for higher degrees.
//!
//! Ported from Ruckig's `roots.hpp` (L. Berscheid, MIT licence, <https://github.com/pantor/ruckig>)
//! including its thresholds: the step-1/step-2 equations were derived with exactly these solvers
//! and their branch decisions, and every root found is refined afterwards by a Newton step on the
//! kinematic equation itself (in the step files) and checked by integration (in `profile`).
//!
//! Only non-negative roots are kept (they are phase durations); results come back sorted in a
//! fixed-capacity [`Roots`] set, so nothing here allocates.

/// Coefficients or discriminants below this are treated as zero (Ruckig: `DBL_EPSILON`).
const EPS: f64 = f64::EPSILON;
/// Discriminant threshold of the two quadratic factors of a quartic (Ruckig: 16 ε).
const QUARTIC_FACTOR_EPS: f64 = 16.0 * f64::EPSILON;
/// Step size below which the safeguarded Newton iteration stops (Ruckig: `roots::tolerance`).
pub(crate) const TOLERANCE: f64 = 1e-14;
/// Iteration cap of the safeguarded Newton iteration.
const SHRINK_MAX_ITERATIONS: usize = 128;

const COS_120: f64 = -0.50;
const SIN_120: f64 = 0.866_025_403_784_438_6;

/// Iterations of Halley's method in [`cbrt`]: from the ≤ 25 % of the exponent-bit guess, the
/// error goes 25 % → 5e-3 → 4e-8 → rounding (cubic convergence).
const CBRT_ITERATIONS: usize = 3;

/// Cube root: an initial guess from dividing the exponent bits by 3, refined by Halley's method
/// (within 2 ulps of `f64::cbrt`, about twice as fast: the solvers call it in every quartic).
#[inline]
pub(crate) fn cbrt(x: f64) -> f64 {
    let ax = x.abs();
    if !(ax >= f64::MIN_POSITIVE && ax.is_finite()) {
        return x.cbrt();
    }
    // About (1023 - 1023/3)·2⁵²: the exponent bias divided by three, with a mantissa offset that
    // centres the guess's error.
    const EXPONENT_BIAS_THIRDS: u64 = 0x2A9F_7893_782D_A1CE;
    let mut y = f64::from_bits(ax.to_bits() / 3 + EXPONENT_BIAS_THIRDS);
    for _ in 0..CBRT_ITERATIONS {
        let y3 = y * y * y;
        // The ratio first: y·(y³ + 2x) alone would underflow or overflow at the ends of the range.
        y *= (y3 + 2.0 * ax) / (2.0 * y3 + ax);
    }
    y.copysign(x)
}

/// Up to `N` non-negative roots, sorted ascending.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Roots<const N: usize> {
    data: [f64; N],
    len: usize,
}

impl<const N: usize> Roots<N> {
    fn new() -> Self {
        Roots { data: [0.0; N], len: 0 }
    }

    /// Insert `value` if it is non-negative (NaN is dropped too).
    #[inline]
    fn insert(&mut self, value: f64) {
        if value >= 0.0 && self.len < N {
            self.data[self.len] = value;
            self.len += 1;
        }
    }

    /// Sort ascending (insertion sort: at most four values).
    fn sorted(mut self) -> Self {
        for i in 1..self.len {
            let mut k = i;
            while k > 0 && self.data[k - 1] > self.data[k] {
                self.data.swap(k - 1, k);
                k -= 1;
            }
        }
        self
    }

    /// The roots, ascending.
    #[inline]
    pub(crate) fn as_slice(&self) -> &[f64] {
        &self.data[..self.len]
    }
}

/// Non-negative real roots of `a x³ + b x² + c x + d`.
pub(crate) fn solve_cubic(a: f64, b: f64, c: f64, d: f64) -> Roots<3> {
    let mut roots = Roots::new();
    let (mut a, mut b, mut c, mut d) = (a, b, c, d);
    if d.abs() < EPS {
        // x = 0 is a root; the rest solve a quadratic.
        roots.insert(0.0);
        d = c;
        c = b;
        b = a;
        a = 0.0;
    }

    if a.abs() < EPS {
        if b.abs() < EPS {
            if c.abs() > EPS {
                roots.insert(-d / c);
            }
        } else {
            let discriminant = c * c - 4.0 * b * d;
            if discriminant >= 0.0 {
                let inv2b = 1.0 / (2.0 * b);
                let y = discriminant.sqrt();
                roots.insert((-c + y) * inv2b);
                roots.insert((-c - y) * inv2b);
            }
        }
        return roots.sorted();
    }

    let inva = 1.0 / a;
    let invaa = inva * inva;
    let bb = b * b;
    let bover3a = b * inva / 3.0;
    let p = (a * c - bb / 3.0) * invaa;
    let halfq = (2.0 * bb * b - 9.0 * a * b * c + 27.0 * a * a * d) / 54.0 * invaa * inva;
    let yy = p * p * p / 27.0 + halfq * halfq;

    if yy > EPS {
        // One real root (Cardano), the larger cube root first to avoid cancellation.
        let y = yy.sqrt();
        let uuu = -halfq + y;
        let vvv = -halfq - y;
        let www = if uuu.abs() > vvv.abs() { uuu } else { vvv };
        let w = cbrt(www);
        roots.insert(w - p / (3.0 * w) - bover3a);
    } else if yy < -EPS {
        // Three real roots: cube root in polar form.
        let x = -halfq;
        let y = (-yy).sqrt();
        let (mut theta, mut r);
        if x.abs() > EPS {
            theta = if x > 0.0 { (y / x).atan() } else { (y / x).atan() + std::f64::consts::PI };
            r = (x * x - yy).sqrt();
        } else {
            theta = std::f64::consts::FRAC_PI_2;
            r = y;
        }
        theta /= 3.0;
        r = 2.0 * cbrt(r);
        let ux = theta.cos() * r;
        let uyi = theta.sin() * r;
        roots.insert(ux - bover3a);
        roots.insert(ux * COS_120 - uyi * SIN_120 - bover3a);
        roots.insert(ux * COS_120 + uyi * SIN_120 - bover3a);
    } else {
        // Double root.
        let w = 2.0 * cbrt(-halfq);
        roots.insert(w - bover3a);
        roots.insert(w * COS_120 - bover3a);
    }
    roots.sorted()
}

/// Roots of the resolvent cubic `x³ + a x² + b x + c` of a quartic; returns how many are real
/// (1, 2 or 3) in `x`.
fn solve_resolvent(x: &mut [f64; 3], a: f64, b: f64, c: f64) -> usize {
    let a = a / 3.0;
    let a2 = a * a;
    let mut q = a2 - b / 3.0;
    let r = (a * (2.0 * a2 - b) + c) / 2.0;
    let r2 = r * r;
    let q3 = q * q * q;

    if r2 < q3 {
        let qsqrt = q.sqrt();
        let t = (r / (q * qsqrt)).clamp(-1.0, 1.0);
        q = -2.0 * qsqrt;
        let theta = t.acos() / 3.0;
        let ux = theta.cos() * q;
        let uyi = theta.sin() * q;
        x[0] = ux - a;
        x[1] = ux * COS_120 - uyi * SIN_120 - a;
        x[2] = ux * COS_120 + uyi * SIN_120 - a;
        3
    } else {
        let mut big_a = -cbrt(r.abs() + (r2 - q3).sqrt());
        if r < 0.0 {
            big_a = -big_a;
        }
        let big_b = if big_a == 0.0 { 0.0 } else { q / big_a };
        x[0] = (big_a + big_b) - a;
        x[1] = -(big_a + big_b) / 2.0 - a;
        x[2] = 3.0f64.sqrt() * (big_a - big_b) / 2.0;
        if x[2].abs() < EPS {
            x[2] = x[1];
            return 2;
        }
        1
    }
}

/// Non-negative real roots of the monic quartic `x⁴ + a x³ + b x² + c x + d`.
pub(crate) fn solve_quart_monic(a: f64, b: f64, c: f64, d: f64) -> Roots<4> {
    let mut roots = Roots::new();

    if d.abs() < EPS {
        if c.abs() < EPS {
            roots.insert(0.0);
            let disc = a * a - 4.0 * b;
            if disc.abs() < EPS {
                roots.insert(-a / 2.0);
            } else if disc > 0.0 {
                let sqrt_d = disc.sqrt();
                roots.insert((-a - sqrt_d) / 2.0);
                roots.insert((-a + sqrt_d) / 2.0);
            }
            return roots.sorted();
        }
        if a.abs() < EPS && b.abs() < EPS {
            roots.insert(0.0);
            roots.insert(-cbrt(c));
            return roots.sorted();
        }
    }

    let a3 = -b;
    let b3 = a * c - 4.0 * d;
    let c3 = -a * a * d - c * c + 4.0 * b * d;

    let mut x3 = [0.0; 3];
    let number_zeroes = solve_resolvent(&mut x3, a3, b3, c3);

    // The resolvent root with the largest magnitude.
    let mut y = x3[0];
    if number_zeroes != 1 {
        if x3[1].abs() > y.abs() {
            y = x3[1];
        }
        if x3[2].abs() > y.abs() {
            y = x3[2];
        }
    }

    let (q1, q2, p1, p2);
    let disc = y * y - 4.0 * d;
    if disc.abs() < EPS {
        q1 = y / 2.0;
        q2 = q1;
        let disc2 = a * a - 4.0 * (b - y);
        if disc2.abs() < EPS {
            p1 = a / 2.0;
            p2 = p1;
        } else {
            let sqrt_d = disc2.sqrt();
            p1 = (a + sqrt_d) / 2.0;
            p2 = (a - sqrt_d) / 2.0;
        }
    } else {
        let sqrt_d = disc.sqrt();
        q1 = (y + sqrt_d) / 2.0;
        q2 = (y - sqrt_d) / 2.0;
        p1 = (a * q1 - c) / (q1 - q2);
        p2 = (c - a * q2) / (q1 - q2);
    }

    for (p, q) in [(p1, q1), (p2, q2)] {
        let disc = p * p - 4.0 * q;
        if disc.abs() < QUARTIC_FACTOR_EPS {
            roots.insert(-p / 2.0);
        } else if disc > 0.0 {
            let sqrt_d = disc.sqrt();
            roots.insert((-p - sqrt_d) / 2.0);
            roots.insert((-p + sqrt_d) / 2.0);
        }
    }
    roots.sorted()
}

/// Monic quartic from the four lower coefficients `[a, b, c, d]`.
#[inline]
pub(crate) fn solve_quart_monic_arr(p: &[f64; 4]) -> Roots<4> {
    solve_quart_monic(p[0], p[1], p[2], p[3])
}

/// Evaluate a polynomial given by its coefficients from the highest degree down (Ruckig's
/// summation order, which the thresholds of the callers were tuned with).
pub(crate) fn poly_eval(p: &[f64], x: f64) -> f64 {
    let n = p.len();
    if n == 0 {
        return 0.0;
    }
    if x.abs() < EPS {
        return p[n - 1];
    }
    if x == 1.0 {
        return p.iter().rev().sum();
    }
    let mut value = 0.0;
    let mut xn = 1.0;
    for &c in p.iter().rev() {
        value += c * xn;
        xn *= x;
    }
    value
}

/// Coefficients of the derivative of `p` into `out` (`out.len() == p.len() - 1`).
pub(crate) fn poly_derivative(p: &[f64], out: &mut [f64]) {
    let n = p.len();
    for (i, o) in out.iter_mut().enumerate().take(n - 1) {
        *o = (n - 1 - i) as f64 * p[i];
    }
}

/// The derivative of a monic polynomial, divided by its degree so that it is monic again.
pub(crate) fn poly_monic_derivative(p: &[f64], out: &mut [f64]) {
    let n = p.len();
    out[0] = 1.0;
    for i in 1..n - 1 {
        out[i] = (n - 1 - i) as f64 * p[i] / (n - 1) as f64;
    }
}

/// A root of `p` inside `[l, h]` where `p(l)·p(h) < 0`: Newton steps safeguarded by bisection
/// (Numerical Recipes' `rtsafe`, as in Ruckig). Degree at most 6.
pub(crate) fn shrink_interval(p: &[f64], l: f64, h: f64) -> f64 {
    let (mut l, mut h) = (l, h);
    let fl = poly_eval(p, l);
    let fh = poly_eval(p, h);
    if fl == 0.0 {
        return l;
    }
    if fh == 0.0 {
        return h;
    }
    if fl > 0.0 {
        std::mem::swap(&mut l, &mut h);
    }

    let mut deriv_buf = [0.0; 6];
    let deriv = &mut deriv_buf[..p.len() - 1];
    poly_derivative(p, deriv);

    let mut rts = (l + h) / 2.0;
    let mut dxold = (h - l).abs();
    let mut dx = dxold;
    let mut f = poly_eval(p, rts);
    let mut df = poly_eval(deriv, rts);
    for _ in 0..SHRINK_MAX_ITERATIONS {
        if ((rts - h) * df - f) * ((rts - l) * df - f) > 0.0 || (2.0 * f).abs() > (dxold * df).abs() {
            dxold = dx;
            dx = (h - l) / 2.0;
            rts = l + dx;
            if l == rts {
                break;
            }
        } else {
            dxold = dx;
            dx = f / df;
            let temp = rts;
            rts -= dx;
            if temp == rts {
                break;
            }
        }
        // Relative for roots above 1 (Ruckig: absolute), which an absolute 1e-14 cannot resolve:
        // the iteration would otherwise run into the cap on long durations.
        if dx.abs() < TOLERANCE * rts.abs().max(1.0) {
            break;
        }
        f = poly_eval(p, rts);
        df = poly_eval(deriv, rts);
        if f < 0.0 {
            l = rts;
        } else {
            h = rts;
        }
    }
    rts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(got: &[f64], want: &[f64], tol: f64) -> bool {
        got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g - w).abs() <= tol * w.abs().max(1.0))
    }

    #[test]
    fn cubic_roots_are_sorted_and_non_negative() {
        // (x-1)(x-2)(x-3)
        let r = solve_cubic(1.0, -6.0, 11.0, -6.0);
        assert!(close(r.as_slice(), &[1.0, 2.0, 3.0], 1e-12), "{:?}", r.as_slice());
        // (x+1)(x-2)(x-3): the negative root is dropped.
        let r = solve_cubic(1.0, -4.0, 1.0, 6.0);
        assert!(close(r.as_slice(), &[2.0, 3.0], 1e-12), "{:?}", r.as_slice());
        // One real root: 2x³ - 16.
        let r = solve_cubic(2.0, 0.0, 0.0, -16.0);
        assert!(close(r.as_slice(), &[2.0], 1e-14));
        // Degenerate to a quadratic: x² - 3x + 2.
        let r = solve_cubic(0.0, 1.0, -3.0, 2.0);
        assert!(close(r.as_slice(), &[1.0, 2.0], 1e-14));
    }

    #[test]
    fn cube_root_within_two_ulps() {
        for k in 0..20_000 {
            let x = ((k as f64) * 0.731).sin() * 10f64.powi(k % 600 - 300);
            let (ours, std) = (cbrt(x), x.cbrt());
            assert!((ours - std).abs() <= 2.0 * f64::EPSILON * std.abs(), "{x}: {ours} vs {std}");
        }
        assert_eq!(cbrt(0.0), 0.0);
        assert_eq!(cbrt(-8.0), -2.0);
        assert!(cbrt(f64::NAN).is_nan() && cbrt(f64::INFINITY) == f64::INFINITY);
        assert!((cbrt(1e-310) - 1e-310f64.cbrt()).abs() <= 2.0 * f64::EPSILON * 1e-310f64.cbrt());
    }

    #[test]
    fn quartic_roots() {
        // (x-1)(x-2)(x-3)(x-4) = x⁴ - 10x³ + 35x² - 50x + 24
        let r = solve_quart_monic(-10.0, 35.0, -50.0, 24.0);
        assert!(close(r.as_slice(), &[1.0, 2.0, 3.0, 4.0], 1e-10), "{:?}", r.as_slice());
        // (x² + 1)(x - 1)(x + 3) = x⁴ + 2x³ - 2x² + 2x - 3: one non-negative real root.
        let r = solve_quart_monic(2.0, -2.0, 2.0, -3.0);
        assert!(close(r.as_slice(), &[1.0], 1e-12), "{:?}", r.as_slice());
        // x⁴ - 5x² + 4: roots ±1, ±2.
        let r = solve_quart_monic(0.0, -5.0, 0.0, 4.0);
        assert!(close(r.as_slice(), &[1.0, 2.0], 1e-12), "{:?}", r.as_slice());
    }

    #[test]
    fn shrink_interval_finds_bracketed_root_of_a_sextic() {
        // (x - 0.5)(x - 1.5)(x² + 1)(x² + 2)
        let mut p = [0.0f64; 7];
        // Multiply out numerically.
        let factors: [&[f64]; 4] = [&[1.0, -0.5], &[1.0, -1.5], &[1.0, 0.0, 1.0], &[1.0, 0.0, 2.0]];
        let mut acc = vec![1.0];
        for f in factors {
            let mut next = vec![0.0; acc.len() + f.len() - 1];
            for (i, a) in acc.iter().enumerate() {
                for (k, b) in f.iter().enumerate() {
                    next[i + k] += a * b;
                }
            }
            acc = next;
        }
        p.copy_from_slice(&acc);
        let root = shrink_interval(&p, 1.0, 2.0);
        assert!((root - 1.5).abs() < 1e-13, "{root}");
        assert!((poly_eval(&p, 0.5)).abs() < 1e-14);
    }
}
