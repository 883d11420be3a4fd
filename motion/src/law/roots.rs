//! Real roots of a Chebyshev series on the section z ∈ [0, 1]: the eigenvalues of the
//! colleague matrix (all roots, also close pairs a grid would miss), joined with sign changes
//! on a grid refined by bisection (a safety net should the eigenvalue iteration fail), all
//! polished by Newton steps on the series itself.

use super::chebyshev;
use nalgebra::{DMatrix, Schur};

/// Trailing coefficients below this share of the largest are dropped before building the
/// colleague matrix (a tiny leading coefficient would put spurious roots far outside [-1, 1]).
const TRIM_REL: f64 = 1e-14;

/// Eigenvalues with |Im| up to this are taken as (perturbed) real roots. Generous on purpose:
/// a double root splits into a pair ±√ε·i, and an extra candidate costs only one evaluation.
const IMAG_TOL: f64 = 1e-6;

/// Eigenvalues up to this far outside [−1, 1] are kept and clamped (roots at the ends).
const EDGE_TOL: f64 = 1e-6;

/// Intervals of the sign-change grid on [0, 1].
const GRID: usize = 256;

/// Newton steps for polishing a candidate root.
const NEWTON_STEPS: usize = 4;

/// Schur iterations allowed (nalgebra counts them over the whole matrix).
const SCHUR_MAX_ITER: usize = 100_000;

/// Candidate roots z ∈ [0, 1] of Σ c_k T_k(2z − 1), unsorted duplicates removed. Every real root
/// in [0, 1] is among them (to rounding); a few near-roots may be too, which is harmless for
/// extremum search.
pub(super) fn roots_in_unit(c: &[f64]) -> Vec<f64> {
    let dc = chebyshev::derivative(c);
    let mut out: Vec<f64> = colleague_roots(c).into_iter().map(|z| polish(c, &dc, z)).collect();
    out.extend(sign_change_roots(c).into_iter().map(|z| snap_to_end(c, z)));
    out.sort_by(f64::total_cmp);
    out.dedup_by(|a, b| (*a - *b).abs() < 1e-14);
    out
}

/// Roots from the eigenvalues of the colleague matrix (the Chebyshev analogue of the companion
/// matrix; same scaled, symmetric-looking form as numpy's `chebcompanion`).
fn colleague_roots(c: &[f64]) -> Vec<f64> {
    let cmax = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut len = c.len();
    while len > 1 && c[len - 1].abs() <= TRIM_REL * cmax {
        len -= 1;
    }
    let m = len - 1; // degree after trimming
    let c = &c[..len];
    let xs: Vec<f64> = match m {
        0 => Vec::new(),
        1 => vec![-c[0] / c[1]],
        _ => {
            let half_sqrt = 0.5f64.sqrt();
            let scl = |k: usize| if k == 0 { 1.0 } else { half_sqrt };
            let mut mat = DMatrix::<f64>::zeros(m, m);
            for k in 0..m - 1 {
                let v = if k == 0 { half_sqrt } else { 0.5 };
                mat[(k, k + 1)] = v;
                mat[(k + 1, k)] = v;
            }
            for k in 0..m {
                mat[(k, m - 1)] -= c[k] / c[m] * (scl(k) / scl(m - 1)) * 0.5;
            }
            match Schur::try_new(mat, f64::EPSILON, SCHUR_MAX_ITER) {
                Some(s) => s.complex_eigenvalues().iter().filter(|e| e.im.abs() <= IMAG_TOL).map(|e| e.re).collect(),
                None => {
                    tracing::debug!("colleague matrix of degree {m}: Schur did not converge, using the grid only");
                    Vec::new()
                }
            }
        }
    };
    xs.into_iter()
        .filter(|x| x.is_finite() && x.abs() <= 1.0 + EDGE_TOL)
        .map(|x| ((x.clamp(-1.0, 1.0) + 1.0) * 0.5).clamp(0.0, 1.0))
        .collect()
}

/// Candidates this close to an end of the section are moved onto it when the end is a root to
/// working precision: a multiple root at an end (f‴(1) = f⁗(1) = 0 makes z = 1 a double root of
/// f‴) comes out of the eigenvalues or the bisection only to ~√ε, and the end is the exact place.
const END_SNAP: f64 = 1e-6;

/// "A root to working precision": |p| ≤ this × Σ|c_k| (evaluation rounding is ~ε·Σ|c_k|).
const ROOT_NOISE_REL: f64 = 1e-12;

/// Newton on the series, then the snap to the ends.
fn polish(c: &[f64], dc: &[f64], z: f64) -> f64 {
    snap_to_end(c, newton(c, dc, z))
}

fn snap_to_end(c: &[f64], z: f64) -> f64 {
    let noise = chebyshev::eval(c, z).abs().max(ROOT_NOISE_REL * chebyshev::abs_sum(c));
    for end in [0.0, 1.0] {
        if (z - end).abs() < END_SNAP && chebyshev::eval(c, end).abs() <= noise {
            return end;
        }
    }
    z
}

/// Newton steps; keeps the last point when a step leaves [0, 1] or makes |p| larger.
fn newton(c: &[f64], dc: &[f64], mut z: f64) -> f64 {
    let mut pz = chebyshev::eval(c, z).abs();
    for _ in 0..NEWTON_STEPS {
        let d = chebyshev::eval(dc, z);
        if d == 0.0 || !d.is_finite() {
            break;
        }
        let next = z - chebyshev::eval(c, z) / d;
        if !(0.0..=1.0).contains(&next) {
            break;
        }
        let pn = chebyshev::eval(c, next).abs();
        if pn > pz {
            break;
        }
        (z, pz) = (next, pn);
    }
    z
}

/// Sign changes between grid points, each bisected to adjacent floats.
fn sign_change_roots(c: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    let mut z0 = 0.0;
    let mut p0 = chebyshev::eval(c, z0);
    for k in 1..=GRID {
        let z1 = k as f64 / GRID as f64;
        let p1 = chebyshev::eval(c, z1);
        if p0 == 0.0 {
            out.push(z0);
        } else if p0.signum() != p1.signum() && p1 != 0.0 {
            out.push(bisect(c, z0, z1, p0));
        }
        (z0, p0) = (z1, p1);
    }
    if p0 == 0.0 {
        out.push(z0);
    }
    out
}

fn bisect(c: &[f64], mut lo: f64, mut hi: f64, p_lo: f64) -> f64 {
    let s_lo = p_lo.signum();
    loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            return mid;
        }
        let pm = chebyshev::eval(c, mid);
        if pm == 0.0 {
            return mid;
        }
        if pm.signum() == s_lo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_close_and_edge_roots() {
        // p(z) = z(z − 1)(z − 0.3)(z − 0.3001): roots at both ends and a pair closer than the
        // grid spacing (1/256), which only the eigenvalues can separate.
        let roots = [0.0, 1.0, 0.3, 0.3001];
        let p = |z: f64| roots.iter().map(|r| z - r).product::<f64>();
        // Chebyshev coefficients by interpolation at the 5 Chebyshev points (exact for degree 4).
        let n = 5;
        let xs: Vec<f64> = (0..n).map(|j| (std::f64::consts::PI * (j as f64 + 0.5) / n as f64).cos()).collect();
        let mut c = vec![0.0; n];
        for (k, ck) in c.iter_mut().enumerate() {
            let s: f64 =
                xs.iter().map(|&x| p((x + 1.0) / 2.0) * (k as f64 * x.acos()).cos()).sum::<f64>() * 2.0 / n as f64;
            *ck = if k == 0 { s / 2.0 } else { s };
        }
        let found = roots_in_unit(&c);
        for r in roots {
            assert!(found.iter().any(|f| (f - r).abs() < 1e-9), "root {r} not in {found:?}");
        }
    }
}
