//! The single-DoF motion: an optional brake pre-phase and seven constant-jerk phases, the states at
//! the phase boundaries, and the check that accepts a candidate only if it reaches the target and
//! respects every limit (Ruckig RSS 2021, Sec. IV: "each candidate profile is integrated and
//! checked").
//!
//! Candidates are produced by the step-1 / step-2 solvers in a normalised frame (see
//! [`crate::frame`]); here they are converted to real units, integrated exactly (piecewise cubic
//! polynomials) and accepted or rejected. A candidate that is right in shape but off target by
//! more than the tolerance (a root lost digits in a closed form) is polished by Newton iterations
//! on its free phase durations against the exact kinematic equations, then checked again.

use crate::brake::BrakeProfile;
use crate::{Limits, State};

/// Target tolerance, relative to the magnitude of the quantities the end state is made of
/// (positions and distances travelled for p, velocities and their changes for v, ...).
/// Rounding alone gives ~1e-15; the margin absorbs ill-conditioned but correct roots.
pub(crate) const TARGET_REL_TOL: f64 = 1e-10;
/// Tolerance on the velocity and acceleration limits, relative to the limit.
pub(crate) const LIMIT_REL_TOL: f64 = 1e-10;
/// Tolerance on the jerk limit, relative to the limit (reduced-jerk profiles are computed).
pub(crate) const JERK_REL_TOL: f64 = 1e-9;
/// Phase durations that come out negative by less than this fraction of the whole profile
/// duration are rounding noise of a zero-length phase and are clamped to zero.
pub(crate) const NEGATIVE_DURATION_REL_TOL: f64 = 1e-12;
/// Newton polishing: maximum iterations.
const POLISH_MAX_ITERATIONS: usize = 4;
/// Newton polishing stops once all scaled residuals are below this (well inside the tolerance).
const POLISH_GOAL_REL: f64 = 1e-14;

/// Which limits a profile reaches (for reports; the check does not depend on it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReachedLimits {
    /// Both acceleration limits and the velocity limit.
    Acc0Acc1Vel,
    /// Only the velocity limit.
    Vel,
    /// The acceleration limit while speeding up.
    Acc0,
    /// The acceleration limit while slowing down.
    Acc1,
    /// Both acceleration limits.
    Acc0Acc1,
    /// Acceleration limit while speeding up and the velocity limit.
    Acc0Vel,
    /// Acceleration limit while slowing down and the velocity limit.
    Acc1Vel,
    /// No limit.
    #[default]
    None,
}

/// Sign of the first jerk phase: motion towards the upper (`Up`) or the lower limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Direction {
    #[default]
    Up,
    Down,
}

/// Sign pattern of the four jerk phases (Ruckig's UDDU / UDUD).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum JerkSigns {
    /// up, down, down, up
    #[default]
    Uddu,
    /// up, down, up, down
    Udud,
}

/// One DoF's motion: a brake pre-phase (possibly empty) followed by seven constant-jerk phases.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Profile {
    /// Phase durations [s].
    pub t: [f64; 7],
    /// End time of each phase, measured from the end of the brake pre-phase [s].
    pub t_end: [f64; 7],
    /// Jerk of each phase.
    pub j: [f64; 7],
    /// Position at the phase boundaries (index 0: start of the main profile, 7: its end).
    pub p: [f64; 8],
    /// Velocity at the phase boundaries.
    pub v: [f64; 8],
    /// Acceleration at the phase boundaries.
    pub a: [f64; 8],
    /// Pre-phase that brings an out-of-limit initial state back inside the limits.
    pub brake: BrakeProfile,
    /// Limits reached (informational).
    pub limits: ReachedLimits,
    /// Direction of the first jerk phase (informational).
    pub direction: Direction,
    /// Jerk sign pattern (informational).
    pub signs: JerkSigns,
}

/// Why a candidate was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    Accepted,
    /// Negative duration, non-finite numbers or a violated limit: the candidate is wrong in shape.
    WrongShape,
    /// Right shape, but the end state misses the target by more than the tolerance.
    OffTarget,
}

/// What the check compares against.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Goal {
    pub target: State,
    /// Position interface: also the position must be reached and the velocity limits hold.
    pub position: bool,
    /// Step 2: the profile must last exactly this long (used only by polishing).
    pub duration: Option<f64>,
}

/// Free phases and equations for Newton polishing of a candidate.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PolishSpec {
    /// Bit mask of the phases whose durations may change.
    pub free: u8,
    /// Bit set of [`PolishSpec::END_A`], [`PolishSpec::END_V`], [`PolishSpec::END_P`],
    /// [`PolishSpec::DURATION`]; the acceleration constraint below adds one more equation.
    pub rows: u8,
    /// Optional constraint: acceleration at the end of phase `.0` equals `.1` (real units).
    pub acc_at: Option<(usize, f64)>,
}

impl PolishSpec {
    /// End acceleration equals the target acceleration.
    pub(crate) const END_A: u8 = 1;
    /// End velocity equals the target velocity.
    pub(crate) const END_V: u8 = 2;
    /// End position equals the target position.
    pub(crate) const END_P: u8 = 4;
    /// Total duration equals the goal's duration (step 2).
    pub(crate) const DURATION: u8 = 8;

    pub(crate) const fn free(phases: &[usize]) -> PolishSpec {
        let mut mask = 0u8;
        let mut i = 0;
        while i < phases.len() {
            mask |= 1 << phases[i];
            i += 1;
        }
        PolishSpec { free: mask, rows: 0, acc_at: None }
    }
}

/// One equation of the Newton polishing system.
#[derive(Clone, Copy, Debug)]
enum PolishRow {
    EndA,
    EndV,
    EndP,
    Duration(f64),
    AccAt(usize, f64),
}

/// Integrate one constant-jerk phase: (p, v, a) after `t` seconds.
#[inline]
pub(crate) fn integrate(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    (p + t * (v + t * (0.5 * a + t * j / 6.0)), v + t * (a + 0.5 * t * j), a + t * j)
}

/// Magnitudes the rounding error of the integrated end state scales with.
#[derive(Clone, Copy, Debug, Default)]
struct ErrorScale {
    p: f64,
    v: f64,
    a: f64,
}

impl Profile {
    /// Duration of the brake pre-phase and the seven phases [s].
    #[inline]
    pub fn duration(&self) -> f64 {
        self.brake.duration + self.t_end[6]
    }

    /// Start state of the main profile (after the brake pre-phase).
    #[inline]
    pub(crate) fn set_start(&mut self, start: State) {
        self.p[0] = start.p;
        self.v[0] = start.v;
        self.a[0] = start.a;
    }

    /// Fill `t_end` and the boundary states from `t`, `j` and the start state; returns the error
    /// scale of the end state, or `None` for a negative or non-finite duration.
    fn integrate_phases(&mut self) -> Option<ErrorScale> {
        let mut total = 0.0;
        for &t in &self.t {
            total += t.abs();
        }
        if !total.is_finite() {
            return None;
        }
        let negative_floor = -NEGATIVE_DURATION_REL_TOL * total;
        let mut scale = ErrorScale { p: self.p[0].abs(), v: self.v[0].abs(), a: self.a[0].abs() };
        let mut t_sum = 0.0;
        for i in 0..7 {
            let mut t = self.t[i];
            if t < 0.0 {
                if t < negative_floor {
                    return None;
                }
                t = 0.0;
                self.t[i] = 0.0;
            }
            let j = self.j[i];
            let (p, v, a) = integrate(t, self.p[i], self.v[i], self.a[i], j);
            self.p[i + 1] = p;
            self.v[i + 1] = v;
            self.a[i + 1] = a;
            t_sum += t;
            self.t_end[i] = t_sum;
            let at = (self.a[i] * t).abs();
            let jt = (j * t).abs();
            scale.p = scale.p.max(p.abs()) + t * (self.v[i].abs() + 0.5 * at + jt * t / 6.0);
            scale.v = scale.v.max(v.abs()) + at + 0.5 * jt * t;
            scale.a = scale.a.max(a.abs()) + jt;
        }
        Some(scale)
    }

    /// Integrate and check the candidate against the goal and the limits.
    pub(crate) fn check(&mut self, goal: &Goal, limits: &Limits) -> Verdict {
        let Some(scale) = self.integrate_phases() else {
            return Verdict::WrongShape;
        };
        if !self.within_limits(goal.position, limits) {
            return Verdict::WrongShape;
        }
        if self.target_residual(goal, &scale) <= 1.0 { Verdict::Accepted } else { Verdict::OffTarget }
    }

    /// Largest target error as a multiple of its tolerance (≤ 1 means on target).
    fn target_residual(&self, goal: &Goal, scale: &ErrorScale) -> f64 {
        let err_a = (self.a[7] - goal.target.a).abs() / (TARGET_REL_TOL * scale.a.max(goal.target.a.abs()));
        let err_v = (self.v[7] - goal.target.v).abs() / (TARGET_REL_TOL * scale.v.max(goal.target.v.abs()));
        let mut worst = err_a.max(err_v);
        if goal.position {
            let err_p = (self.p[7] - goal.target.p).abs() / (TARGET_REL_TOL * scale.p.max(goal.target.p.abs()));
            worst = worst.max(err_p);
        }
        // 0/0 (an exactly-zero scale and error) is a perfect hit.
        if worst.is_nan() {
            let exact = self.a[7] == goal.target.a
                && self.v[7] == goal.target.v
                && (!goal.position || self.p[7] == goal.target.p);
            return if exact { 0.0 } else { f64::INFINITY };
        }
        worst
    }

    /// Acceleration at the boundaries, velocity at the boundaries and at interior extrema.
    fn within_limits(&self, position: bool, limits: &Limits) -> bool {
        let a_hi = limits.a_max * (1.0 + LIMIT_REL_TOL);
        let a_lo = limits.a_min * (1.0 + LIMIT_REL_TOL);
        let j_hi = limits.j_max * (1.0 + JERK_REL_TOL);
        for i in 0..7 {
            if self.j[i].abs() > j_hi {
                return false;
            }
            let a = self.a[i + 1];
            if !(a <= a_hi && a >= a_lo) {
                return false;
            }
        }
        if !position {
            return self.v[7].is_finite() && self.p[7].is_finite();
        }
        let v_hi = limits.v_max * (1.0 + LIMIT_REL_TOL);
        let v_lo = limits.v_min * (1.0 + LIMIT_REL_TOL);
        // After a velocity brake the main profile may start above v_max (or below v_min) and
        // come back inside during its first phases (the brake stops as soon as ramping the
        // acceleration back to zero would not overshoot the opposite limit: Ruckig RSS 2021,
        // Sec. V-A). Until the velocity is back inside, only the opposite bound is checked.
        let mut above = self.v[0] > v_hi;
        let mut below = self.v[0] < v_lo;
        for i in 0..7 {
            let v = self.v[i + 1];
            // Velocity extremum inside the phase where the acceleration crosses zero.
            let (a0, a1) = (self.a[i], self.a[i + 1]);
            let v_ext = if a0 * a1 < 0.0 { self.v[i] - a0 * a0 / (2.0 * self.j[i]) } else { v };
            let (v_max_seen, v_min_seen) = (v.max(v_ext), v.min(v_ext));
            if (!above && v_max_seen > v_hi) || (!below && v_min_seen < v_lo) || !v.is_finite() {
                return false;
            }
            above &= v > v_hi;
            below &= v < v_lo;
        }
        self.p[7].is_finite()
    }

    /// Check, and if the candidate is right in shape but off target, polish its free durations by
    /// Newton iterations on the exact end-state equations and check again.
    pub(crate) fn check_or_polish(&mut self, goal: &Goal, limits: &Limits, spec: PolishSpec) -> bool {
        match self.check(goal, limits) {
            Verdict::Accepted => true,
            Verdict::WrongShape => false,
            Verdict::OffTarget => {
                spec.free != 0 && self.polish(goal, spec) && self.check(goal, limits) == Verdict::Accepted
            }
        }
    }

    /// Newton iterations on the free phase durations. Equations: end acceleration, end velocity,
    /// end position (position interface), total duration (step 2), and an optional acceleration
    /// constraint at a phase boundary (a plateau at a limit). Returns false when the system is
    /// not square or singular.
    fn polish(&mut self, goal: &Goal, spec: PolishSpec) -> bool {
        let mut free = [0usize; 5];
        let mut n = 0;
        for i in 0..7 {
            if spec.free & (1 << i) != 0 {
                if n == free.len() {
                    return false;
                }
                free[n] = i;
                n += 1;
            }
        }
        let mut rows = [PolishRow::EndA; 5];
        let mut n_rows = 0;
        let mut add = |row: PolishRow| {
            if n_rows < rows.len() {
                rows[n_rows] = row;
            }
            n_rows += 1;
        };
        if spec.rows & PolishSpec::END_A != 0 {
            add(PolishRow::EndA);
        }
        if spec.rows & PolishSpec::END_V != 0 {
            add(PolishRow::EndV);
        }
        if spec.rows & PolishSpec::END_P != 0 {
            add(PolishRow::EndP);
        }
        if spec.rows & PolishSpec::DURATION != 0 {
            let Some(duration) = goal.duration else {
                return false;
            };
            add(PolishRow::Duration(duration));
        }
        if let Some((phase, acc)) = spec.acc_at {
            add(PolishRow::AccAt(phase, acc));
        }
        if n_rows != n {
            return false;
        }
        for _ in 0..POLISH_MAX_ITERATIONS {
            let Some(scale) = self.integrate_phases() else {
                return false;
            };
            let total = self.t_end[6];
            // Residuals and Jacobian rows, each row scaled by its tolerance magnitude so that
            // partial pivoting compares like with like. Derivatives of the end state with respect
            // to the duration of phase i: lengthening phase i by dt shifts the state at its end by
            // (v, a, j)·dt, which then propagates through the remaining time r.
            let mut jac = [[0.0f64; 5]; 5];
            let mut rhs = [0.0f64; 5];
            let mut worst = 0.0f64;
            for (r, row) in rows[..n].iter().enumerate() {
                let (residual, s) = match *row {
                    PolishRow::EndA => (self.a[7] - goal.target.a, scale.a),
                    PolishRow::EndV => (self.v[7] - goal.target.v, scale.v),
                    PolishRow::EndP => (self.p[7] - goal.target.p, scale.p),
                    PolishRow::Duration(d) => (total - d, d),
                    PolishRow::AccAt(phase, acc) => (self.a[phase + 1] - acc, scale.a),
                };
                let s = if s > 0.0 && s.is_finite() { s } else { 1.0 };
                for (c, &i) in free[..n].iter().enumerate() {
                    let rem = total - self.t_end[i];
                    let d = match *row {
                        PolishRow::EndA => self.j[i],
                        PolishRow::EndV => self.a[i + 1] + self.j[i] * rem,
                        PolishRow::EndP => self.v[i + 1] + rem * (self.a[i + 1] + 0.5 * self.j[i] * rem),
                        PolishRow::Duration(_) => 1.0,
                        PolishRow::AccAt(phase, _) => {
                            if i <= phase {
                                self.j[i]
                            } else {
                                0.0
                            }
                        }
                    };
                    jac[r][c] = d / s;
                }
                rhs[r] = -residual / s;
                worst = worst.max((residual / s).abs());
            }
            if worst <= POLISH_GOAL_REL {
                return true;
            }
            let Some(delta) = solve_linear(&mut jac, &mut rhs, n) else {
                return false;
            };
            for (c, &i) in free[..n].iter().enumerate() {
                self.t[i] = (self.t[i] + delta[c]).max(0.0);
            }
        }
        true
    }

    /// Kinematic state (p, v, a, j) at time `t` measured from the start of the brake pre-phase.
    /// After the end the motion continues with the final acceleration and zero jerk.
    pub fn state_at(&self, t: f64) -> (f64, f64, f64, f64) {
        let mut t = t;
        if self.brake.duration > 0.0 {
            if t < self.brake.duration {
                let (t_rel, idx) = if t < self.brake.t[0] { (t, 0) } else { (t - self.brake.t[0], 1) };
                let (p, v, a) =
                    integrate(t_rel, self.brake.p[idx], self.brake.v[idx], self.brake.a[idx], self.brake.j[idx]);
                return (p, v, a, self.brake.j[idx]);
            }
            t -= self.brake.duration;
        }
        if t >= self.t_end[6] {
            let (p, v, a) = integrate(t - self.t_end[6], self.p[7], self.v[7], self.a[7], 0.0);
            return (p, v, a, 0.0);
        }
        // First phase whose end lies after t (phases are few: a linear scan is fastest).
        let mut idx = 0;
        while idx < 6 && self.t_end[idx] <= t {
            idx += 1;
        }
        let t_start = if idx == 0 { 0.0 } else { self.t_end[idx - 1] };
        let (p, v, a) = integrate(t - t_start, self.p[idx], self.v[idx], self.a[idx], self.j[idx]);
        (p, v, a, self.j[idx])
    }
}

/// Solve the n×n system (n ≤ 5) in place by Gaussian elimination with partial pivoting.
fn solve_linear(m: &mut [[f64; 5]; 5], rhs: &mut [f64; 5], n: usize) -> Option<[f64; 5]> {
    for col in 0..n {
        let mut pivot = col;
        for r in col + 1..n {
            if m[r][col].abs() > m[pivot][col].abs() {
                pivot = r;
            }
        }
        if !(m[pivot][col].abs() > 0.0) {
            return None;
        }
        m.swap(col, pivot);
        rhs.swap(col, pivot);
        for r in col + 1..n {
            let factor = m[r][col] / m[col][col];
            for c in col..n {
                m[r][c] -= factor * m[col][c];
            }
            rhs[r] -= factor * rhs[col];
        }
    }
    let mut x = [0.0; 5];
    for r in (0..n).rev() {
        let mut s = rhs[r];
        for c in r + 1..n {
            s -= m[r][c] * x[c];
        }
        x[r] = s / m[r][r];
        if !x[r].is_finite() {
            return None;
        }
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Limits {
        Limits { v_max: 1.0, v_min: -1.0, a_max: 1.0, a_min: -1.0, j_max: 1.0 }
    }

    fn goal(p: f64, v: f64, a: f64) -> Goal {
        Goal { target: State { p, v, a }, position: true, duration: None }
    }

    /// Rest to rest over distance 2 with limits 1: ramp up 1 s, ramp down 1 s, ... (NONE profile).
    fn none_profile() -> Profile {
        let mut p = Profile::default();
        p.t = [1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
        p.j = [1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0];
        p
    }

    #[test]
    fn accepts_exact_profile_and_integrates_boundaries() {
        let mut p = none_profile();
        assert_eq!(p.check(&goal(2.0, 0.0, 0.0), &limits()), Verdict::Accepted);
        assert_eq!(p.t_end[6], 4.0);
        let (pos, vel, acc, _) = p.state_at(2.0);
        assert!((pos - 1.0).abs() < 1e-15 && (vel - 1.0).abs() < 1e-15 && acc.abs() < 1e-15);
        // Beyond the end: hold.
        let (pos, vel, _, jerk) = p.state_at(10.0);
        assert_eq!((pos, vel, jerk), (2.0, 0.0, 0.0));
    }

    #[test]
    fn rejects_limit_violation_and_negative_durations() {
        let mut p = none_profile();
        let tight = Limits { v_max: 0.9, ..limits() };
        assert_eq!(p.check(&goal(2.0, 0.0, 0.0), &tight), Verdict::WrongShape);
        let mut p = none_profile();
        p.t[1] = -1e-3;
        assert_eq!(p.check(&goal(2.0, 0.0, 0.0), &limits()), Verdict::WrongShape);
        // Rounding-size negative durations are clamped.
        let mut p = none_profile();
        p.t[1] = -1e-16;
        assert_eq!(p.check(&goal(2.0, 0.0, 0.0), &limits()), Verdict::Accepted);
        assert_eq!(p.t[1], 0.0);
    }

    #[test]
    fn off_target_candidate_is_polished() {
        let mut p = none_profile();
        p.t = [1.0 - 1e-6, 0.0, 2.0 - 1.5e-6, 0.0, 0.0, 0.0, 1.0 - 5e-7];
        let g = goal(2.0, 0.0, 0.0);
        assert_eq!(p.check(&g, &limits()), Verdict::OffTarget);
        let spec = PolishSpec {
            rows: PolishSpec::END_A | PolishSpec::END_V | PolishSpec::END_P,
            ..PolishSpec::free(&[0, 2, 6])
        };
        assert!(p.check_or_polish(&g, &limits(), spec));
        assert!((p.t[0] - 1.0).abs() < 1e-12 && (p.t[2] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn velocity_extremum_inside_a_phase_is_checked() {
        // Start with a = -1 and v = -0.4 and jerk +1 for 2 s: v dips to -0.9 at t = 1.
        let mut p = Profile::default();
        p.set_start(State { p: 0.0, v: -0.4, a: -1.0 });
        p.t = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        p.j = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let lim = Limits { v_min: -0.8, ..limits() };
        let (pe, ve, ae) = integrate(2.0, 0.0, -0.4, -1.0, 1.0);
        assert_eq!(p.check(&goal(pe, ve, ae), &lim), Verdict::WrongShape);
        let mut p2 = p;
        assert_eq!(p2.check(&goal(pe, ve, ae), &limits()), Verdict::Accepted);
    }
}
