//! Closed forms of two one-DoF problems under constant symmetric limits: the time-optimal move
//! from rest to rest, and the time-optimal brake from a state in motion to rest.
//!
//! Both are special cases of [`Otg::calculate`](crate::Otg::calculate) (the position interface
//! from rest to a target at rest, and the velocity interface to v = 0), and give the same
//! durations (`tests/scurve.rs` checks it on random problems). They exist for callers that
//! solve very many of them in path space: the planner's straight blocks between two stops (one
//! per segment of a CAM program in exact-stop mode) and its stops along the path (dozens of
//! candidate limits per stop). There the general solver's case analysis costs some thirty
//! times the closed form.
//!
//! Phases come as (duration s, jerk), in time order, zero-length phases included.

/// The time-optimal move over `length` ≥ 0 from rest to rest under |v| ≤ `v_max`,
/// |a| ≤ `a_max`, |j| ≤ `j_max` (all > 0): jerk +J, 0, −J, cruise, −J, 0, +J.
pub fn rest_to_rest(length: f64, v_max: f64, a_max: f64, j_max: f64) -> [(f64, f64); 7] {
    let (v, a, j) = (v_max, a_max, j_max);
    // Acceleration phase to peak velocity vp: jerk time tj and constant-acceleration time ta.
    let phases =
        |vp: f64| -> (f64, f64) { if vp * j >= a * a { (a / j, vp / a - a / j) } else { ((vp / j).sqrt(), 0.0) } };
    // Distance to accelerate from rest to vp and back to rest: vp · (2tj + ta).
    let dist = |vp: f64| {
        let (tj, ta) = phases(vp);
        vp * (2.0 * tj + ta)
    };
    let vp = if dist(v) <= length {
        v
    } else if dist(a * a / j) >= length {
        // Triangular acceleration: vp · 2√(vp/J) = L.
        (0.5 * length * j.sqrt()).powf(2.0 / 3.0)
    } else {
        // Trapezoidal acceleration without cruise: vp²/A + vp·A/J = L.
        let b = a / j;
        0.5 * a * (-b + (b * b + 4.0 * length / a).sqrt())
    };
    let (tj, ta) = phases(vp);
    let cruise = (length - dist(vp)).max(0.0) / vp;
    [(tj, j), (ta, 0.0), (tj, -j), (cruise, 0.0), (tj, -j), (ta, 0.0), (tj, j)]
}

/// The time-optimal brake from velocity `v0` ≥ 0 and acceleration `a0` to rest under
/// |a| ≤ `acc`, |j| ≤ `jerk` (both > 0; a0 ≥ −`acc`): jerk −J down to the deceleration, hold,
/// +J up to rest. A state braking so hard that releasing the deceleration at once reaches rest
/// or would reverse gets that release alone; a caller that must not reverse excludes such
/// states first.
pub fn brake_to_rest(v0: f64, a0: f64, acc: f64, jerk: f64) -> [(f64, f64); 3] {
    if a0 < 0.0 && v0 <= a0 * a0 / (2.0 * jerk) {
        return [(-a0 / jerk, jerk), (0.0, 0.0), (0.0, 0.0)];
    }
    // Without a hold the lowest acceleration a₁ satisfies v₀ + (a₀² − a₁²)/2J − a₁²/2J = 0.
    let a1 = -(jerk * v0 + 0.5 * a0 * a0).sqrt();
    if a1 >= -acc {
        return [((a0 - a1) / jerk, -jerk), (0.0, 0.0), (-a1 / jerk, jerk)];
    }
    // Ramp to −A, hold, release.
    let t1 = (a0 + acc) / jerk;
    let v1 = v0 + (a0 * a0 - acc * acc) / (2.0 * jerk);
    let t2 = ((v1 - acc * acc / (2.0 * jerk)) / acc).max(0.0);
    [(t1, -jerk), (t2, 0.0), (acc / jerk, jerk)]
}
