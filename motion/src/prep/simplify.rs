//! The polyline the exact-stop fallback follows where the programmed path is a run of lines:
//! the Ramer–Douglas–Peucker simplification of its vertices (Douglas and Peucker 1973), so
//! the motion stops at the corners the path really has, not at every micro-segment of CAM
//! output (a run of 7 µm moves that wander by 17° each would otherwise stop every 7 µm).

use crate::path::AxisVec;

/// Indices of the vertices of `points` that the simplification keeps (always the first and
/// the last): every dropped vertex lies within `tol_mm` of the line kept over it.
pub(super) fn douglas_peucker(points: &[AxisVec], n_axes: usize, tol_mm: f64) -> Vec<usize> {
    let n = points.len();
    if n <= 2 {
        return (0..n).collect();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    // An explicit stack: a fallback over thousands of micro-segments must not recurse that deep.
    let mut stack = vec![(0, n - 1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (mut worst, mut at) = (-1.0, a);
        for i in a + 1..b {
            let d = segment_distance(&points[i], &points[a], &points[b], n_axes);
            if d > worst {
                worst = d;
                at = i;
            }
        }
        if worst > tol_mm {
            keep[at] = true;
            stack.push((a, at));
            stack.push((at, b));
        }
    }
    (0..n).filter(|&i| keep[i]).collect()
}

/// Distance of `p` to the segment from `a` to `b` over `n` axes (to `a` where they coincide).
fn segment_distance(p: &AxisVec, a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    let ab2: f64 = (0..n).map(|k| (b[k] - a[k]).powi(2)).sum();
    let t = if ab2 > 0.0 {
        ((0..n).map(|k| (p[k] - a[k]) * (b[k] - a[k])).sum::<f64>() / ab2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (0..n).map(|k| (p[k] - a[k] - t * (b[k] - a[k])).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::MAX_AXES;

    fn pt(x: f64, y: f64) -> AxisVec {
        let mut p = [0.0; MAX_AXES];
        p[0] = x;
        p[1] = y;
        p
    }

    #[test]
    fn a_noisy_line_keeps_its_ends_and_a_real_corner_stays() {
        // 100 micro-segments along x with ±2 µm noise, then a corner and 100 along y.
        let mut pts: Vec<AxisVec> =
            (0..=100).map(|i| pt(i as f64 * 0.007, if i % 2 == 1 { 0.002 } else { 0.0 })).collect();
        pts.extend((1..=100).map(|i| pt(0.7, i as f64 * 0.007)));
        let kept = douglas_peucker(&pts, 2, 0.005);
        assert_eq!(kept, vec![0, 100, 200], "the noise goes, the corner stays");
    }

    #[test]
    fn every_dropped_vertex_lies_within_the_tolerance_of_its_kept_line() {
        // A deterministic wandering walk: 500 steps of 7 µm turning by up to ±17°.
        let (mut x, mut y, mut h, mut seed) = (0.0, 0.0, 0.0f64, 12345u64);
        let mut pts = vec![pt(0.0, 0.0)];
        for _ in 0..500 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            h += ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 2.0 * 17f64.to_radians();
            x += 0.007 * h.cos();
            y += 0.007 * h.sin();
            pts.push(pt(x, y));
        }
        let tol = 0.005;
        let kept = douglas_peucker(&pts, 2, tol);
        assert!(kept.len() < pts.len() / 2, "{} of {} kept", kept.len(), pts.len());
        for w in kept.windows(2) {
            for p in &pts[w[0]..=w[1]] {
                assert!(segment_distance(p, &pts[w[0]], &pts[w[1]], 2) <= tol + 1e-15);
            }
        }
    }
}
