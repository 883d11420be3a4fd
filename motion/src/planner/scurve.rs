//! Jerk-limited motions of the path position alone, under path limits that are constant along
//! the way: the time-optimal straight move from rest to rest (jerk +J, 0, −J, cruise, −J, 0, +J)
//! as constant-jerk intervals. The profile comes from the trajectory generator's closed form
//! ([`interpd_otg::scurve`], the one-DoF case of Berscheid & Kröger 2021).
//!
//! Blocks between two stops that are one straight line (CAM output in exact-stop mode, corners,
//! staircases) take the move instead of the branch search: exact, optimal and O(1).
//! [`brake_along`](super::brake::brake_along) takes the generator's brake to rest the same way.

use super::interval::Interval;

/// The time-optimal move of `length` from rest to rest under path limits `v_max`, `a_max`,
/// `j_max` (all > 0): up to seven constant-jerk intervals (zero-length phases omitted), the
/// last one ending exactly at `length`.
pub(super) fn rest_to_rest(length: f64, v_max: f64, a_max: f64, j_max: f64) -> Vec<Interval> {
    let mut out = Vec::with_capacity(7);
    let (mut vel, mut acc) = (0.0f64, 0.0f64);
    for (tk, jk) in interpd_otg::scurve::rest_to_rest(length, v_max, a_max, j_max) {
        if tk <= 0.0 {
            continue;
        }
        let ds = vel * tk + 0.5 * acc * tk * tk + jk * tk * tk * tk / 6.0;
        let iv = Interval { v0: vel, a0: acc, j: jk, t_s: tk, ds_mm: ds };
        vel = iv.v1();
        acc = iv.a1();
        out.push(iv);
    }
    // Rounding: make the pieces cover the length exactly and end at rest.
    let covered: f64 = out.iter().map(|iv| iv.ds_mm).sum();
    if let Some(last) = out.last_mut() {
        last.ds_mm += length - covered;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(l: f64, v: f64, a: f64, j: f64) -> f64 {
        let p = rest_to_rest(l, v, a, j);
        let total: f64 = p.iter().map(|iv| iv.ds_mm).sum();
        assert!((total - l).abs() < 1e-12 * l.max(1.0));
        let last = p.last().unwrap();
        assert!(last.v1().abs() < 1e-9 * v && last.a1().abs() < 1e-6 * a, "ends at rest");
        for iv in &p {
            assert!(iv.v0 <= v * (1.0 + 1e-12) && iv.a0.abs() <= a * (1.0 + 1e-12) && iv.j.abs() <= j);
            // Each piece's own distance agrees with its kinematics.
            let (s, _, _) = iv.state_at(iv.t_s);
            assert!((s - iv.ds_mm).abs() < 1e-9 * l.max(1.0));
        }
        p.iter().map(|iv| iv.t_s).sum()
    }

    #[test]
    fn long_move_reaches_v_max() {
        let t = check(100.0, 250.0, 2500.0, 50000.0);
        // L/V + V/A + A/J
        assert!((t - (100.0 / 250.0 + 250.0 / 2500.0 + 2500.0 / 50000.0)).abs() < 1e-12);
    }

    #[test]
    fn short_moves() {
        // Triangular: t = 4·(L/(2J))^(1/3)
        let t = check(0.02, 250.0, 2500.0, 50000.0);
        assert!((t - 4.0 * (0.02f64 / (2.0 * 50000.0)).cbrt()).abs() < 1e-12);
        check(5.0, 250.0, 2500.0, 50000.0); // trapezoidal, no cruise
        check(1e-6, 250.0, 2500.0, 50000.0);
    }
}
