//! The lateral tolerance split over the axes (Haas 2012, §3.3.1, Alg. 3.2, eq. 3.12): each point
//! may move inside a box around its programmed position whose half-widths b_k satisfy
//! Σ b_k² ≤ tol², so the point stays within tol of the programmed position.
//!
//! In the plane, Haas gives axis k the share tol·|n_k| of the normal n. The same rule for any
//! number m of moving axes, written with the unit tangent t: b_k = tol·√(1 − t_k²)/√(m − 1)
//! (in 2D, √(1 − t_x²) = |n_x|). An axis along which the path runs exactly gets no constraint
//! (the point may slide along the path), and a tangent within 10° of an axis gets the even
//! split tol/√m, so the corner's other axis is not pinned. Alg. 3.2 applies the 10° rule after
//! setting the axis-parallel share to NaN, which would pin such an axis again; Fig. 3.3(b), an
//! axis-parallel start deviating by more than the even split allows, shows the unconstrained
//! axis taking precedence, as here. The normal's components are taken by magnitude.

use crate::path::{AxisVec, MAX_AXES};

/// Below this half-width an axis is taken as running along the path: no constraint on it
/// (Haas 2012, Alg. 3.2: TOL < 10⁻¹³ → NaN), mm.
pub(super) const AXIS_PARALLEL_TOL_MM: f64 = 1e-13;
/// Tangents closer than this to an axis get the even split (Haas 2012, Alg. 3.2: φ_krit = 10°).
pub(super) const CRITICAL_ANGLE_DEG: f64 = 10.0;

/// Half-widths of the box per axis (`f64::INFINITY` = unconstrained) for a point with unit
/// tangent `tangent` (over the `active` axes) and tolerance `tol_mm`. Inactive axes get 0.
pub(super) fn split(tangent: &AxisVec, active: &[bool; MAX_AXES], tol_mm: f64) -> AxisVec {
    let mut b = [0.0; MAX_AXES];
    let m = active.iter().filter(|a| **a).count();
    if m == 0 {
        return b;
    }
    if m == 1 {
        // The path runs along the only moving axis: no lateral direction to constrain.
        for k in 0..MAX_AXES {
            if active[k] {
                b[k] = f64::INFINITY;
            }
        }
        return b;
    }
    // Renormalise the tangent over the active axes.
    let norm = (0..MAX_AXES).filter(|&k| active[k]).map(|k| tangent[k] * tangent[k]).sum::<f64>().sqrt();
    let t = |k: usize| if norm > 0.0 { tangent[k] / norm } else { 0.0 };
    let share = |k: usize| (1.0 - t(k) * t(k)).max(0.0).sqrt();
    let scale = tol_mm / ((m - 1) as f64).sqrt();
    let parallel = (0..MAX_AXES).any(|k| active[k] && share(k) * scale < AXIS_PARALLEL_TOL_MM);
    let near_axis = (0..MAX_AXES).any(|k| active[k] && t(k).abs() > CRITICAL_ANGLE_DEG.to_radians().cos());
    for k in 0..MAX_AXES {
        if !active[k] {
            continue;
        }
        b[k] = if parallel {
            // NaN wins: the axis along the path is free, the others share tol (Σ b² = tol²).
            let bk = share(k) * scale;
            if bk < AXIS_PARALLEL_TOL_MM { f64::INFINITY } else { bk }
        } else if near_axis {
            tol_mm / (m as f64).sqrt() // Haas 2012, Alg. 3.2: TOL_x = TOL_y = tol/√2 below φ_krit
        } else {
            share(k) * scale // Haas 2012, Alg. 3.2: TOL_k = tol·|n_k|
        };
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn act(n: usize) -> [bool; MAX_AXES] {
        let mut a = [false; MAX_AXES];
        a[..n].iter_mut().for_each(|x| *x = true);
        a
    }

    fn t(x: f64, y: f64, z: f64) -> AxisVec {
        let n = (x * x + y * y + z * z).sqrt();
        let mut v = [0.0; MAX_AXES];
        v[0] = x / n;
        v[1] = y / n;
        v[2] = z / n;
        v
    }

    #[test]
    fn planar_split_follows_the_normal() {
        // 30° to x: n = (−sin 30°, cos 30°); TOL_x = tol/2, TOL_y = tol·cos 30°.
        let b = split(&t(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0), &act(2), 0.1);
        assert!((b[0] - 0.05).abs() < 1e-12 && (b[1] - 0.1 * 30f64.to_radians().cos()).abs() < 1e-12);
        assert!((b[0] * b[0] + b[1] * b[1] - 0.01).abs() < 1e-12);
    }

    #[test]
    fn axis_parallel_leaves_that_axis_free() {
        let b = split(&t(1.0, 0.0, 0.0), &act(2), 0.1);
        assert!(b[0].is_infinite() && (b[1] - 0.1).abs() < 1e-15);
        let b3 = split(&t(0.0, 0.0, 1.0), &act(3), 0.1);
        assert!(b3[2].is_infinite());
        assert!((b3[0] * b3[0] + b3[1] * b3[1] - 0.01).abs() < 1e-12);
    }

    #[test]
    fn near_axis_tangent_gets_the_even_split() {
        let b = split(&t(1.0, 5f64.to_radians().tan(), 0.0), &act(2), 0.1);
        assert!((b[0] - 0.1 / 2f64.sqrt()).abs() < 1e-15 && (b[1] - b[0]).abs() < 1e-15);
    }

    #[test]
    fn box_stays_within_tol_in_3d() {
        let b = split(&t(1.0, 2.0, 3.0), &act(3), 0.2);
        assert!((b.iter().map(|x| x * x).sum::<f64>() - 0.04).abs() < 1e-12);
        let single = split(&t(1.0, 0.0, 0.0), &act(1), 0.2);
        assert!(single[0].is_infinite() && single[1] == 0.0);
    }
}
