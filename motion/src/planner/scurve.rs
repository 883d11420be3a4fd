//! Jerk-limited motions of the path position alone, under path limits that are constant along
//! the way: the time-optimal straight move from rest to rest (jerk +J, 0, −J, cruise, −J, 0, +J)
//! and the time-optimal brake from a state in motion to rest (jerk −J down to the deceleration
//! A, hold, +J up to rest). Both come from the online trajectory generator (interpd-otg,
//! Berscheid & Kröger 2021) for one degree of freedom: the position interface for the move,
//! the velocity interface for the brake.
//!
//! Blocks between two stops that are one straight line (CAM output in exact-stop mode, corners,
//! staircases) take the move instead of the branch search: exact, optimal and O(1).
//! [`brake_along`](super::brake::brake_along) tries brakes under several path limits.

use super::interval::Interval;
use interpd_otg::{ControlInterface, Input, Limits as OtgLimits, Otg, Profile, State, Trajectory};

/// Constant-jerk phases of a brake to rest, as (duration s, jerk): the generator's pre-phase
/// (where the state starts above the acceleration limit) and its seven phases, zero-length
/// phases included.
pub(super) type BrakePhases = [(f64, f64); 9];

/// The time-optimal move of `length` from rest to rest under path limits `v_max`, `a_max`,
/// `j_max` (all > 0): up to seven constant-jerk intervals (zero-length phases omitted), the
/// last one ending exactly at `length`. `None` if the generator finds no profile (limits not
/// finite).
pub(super) fn rest_to_rest(length: f64, v_max: f64, a_max: f64, j_max: f64) -> Option<Vec<Interval>> {
    let mut input = Input::new(1);
    input.target[0] = State { p: length, v: 0.0, a: 0.0 };
    input.limits[0] = OtgLimits::symmetric(v_max, a_max, j_max);
    let profile = one_dof(&input)?;
    let mut out = Vec::with_capacity(7);
    let (mut vel, mut acc) = (0.0f64, 0.0f64);
    for (tk, jk) in phases(&profile) {
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
    Some(out)
}

/// The time-optimal brake from path velocity `v0` ≥ 0 and acceleration `a0` to rest under
/// |a| ≤ `acc`, |j| ≤ `jerk` (the velocity itself unbounded). A state braking so hard that
/// releasing the deceleration at once would reverse the motion gets a profile through negative
/// velocities; callers that must not reverse exclude such states first. `None` if the generator
/// finds no profile (limits not finite and positive).
pub(super) fn brake_to_rest(v0: f64, a0: f64, acc: f64, jerk: f64) -> Option<BrakePhases> {
    let mut input = Input::new(1);
    input.control = ControlInterface::Velocity;
    input.current[0] = State { p: 0.0, v: v0, a: a0 };
    input.limits[0] = OtgLimits { v_max: f64::MAX, v_min: -f64::MAX, a_max: acc, a_min: -acc, j_max: jerk };
    let profile = one_dof(&input)?;
    let mut out = [(0.0, 0.0); 9];
    for (slot, phase) in out.iter_mut().zip(phases(&profile)) {
        *slot = phase;
    }
    Some(out)
}

/// The generator's profile for a one-DoF `input`.
fn one_dof(input: &Input) -> Option<Profile> {
    let mut trajectory = Trajectory::default();
    Otg::new().calculate(input, &mut trajectory).ok()?;
    trajectory.profiles().first().copied()
}

/// (duration, jerk) of a profile's phases in time order: the brake pre-phase (zero-length where
/// there is none), then the seven phases.
fn phases(p: &Profile) -> impl Iterator<Item = (f64, f64)> + '_ {
    let brake =
        p.brake.t.iter().zip(&p.brake.j).map(|(&t, &j)| if p.brake.duration > 0.0 { (t, j) } else { (0.0, 0.0) });
    brake.chain(p.t.iter().zip(&p.j).map(|(&t, &j)| (t, j)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(l: f64, v: f64, a: f64, j: f64) -> f64 {
        let p = rest_to_rest(l, v, a, j).expect("a profile");
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
