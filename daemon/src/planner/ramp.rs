//! The viability test that keeps a greedy branch out of dead ends without backtracking.
//!
//! A state (v, a) at a node is accepted only if a braking ramp from it flattens under the
//! ceiling: the ramp lowers the acceleration with the steepest jerk the axes allow that keeps
//! the interval feasible (holding it at the lowest allowed acceleration) until it is no longer
//! positive, checking the velocity at the nodes and its peak between them. Seed 001 steps
//! back when the interval for v₊ is empty ("Gehe zurück"), which can grow exponentially;
//! this test makes that case rare, and its work is bounded by `MAX_RAMP_NODES`.

use super::check::{VIOLATION_TOL, acc_range, jerk_range, violation};
use super::interval::Interval;
use super::limits::Limits;
use super::step::Work;
use super::view::View;

/// Jerks a braking ramp tries, steepest first, as fractions of the lowest allowed path jerk
/// (negative: of the highest). The ramp brakes with nearly the full jerk (keeping 1 % so a
/// state on a ramp still has room to move) while backward branches
/// brake with `BACKWARD_JERK_FRACTION` of it, so a ramp meets a branch tangentially from
/// below, where an exact join exists. The other entries cover curvature terms that leave
/// less jerk than the start node suggests, and the acceleration floor (from index 3 on: hold
/// or raise the acceleration).
pub const RAMP_JERK_STEPS: [f64; 7] = [0.99, 0.7, 0.4, 0.0, -0.1, -0.3, -0.6];
/// A ramp longer than this many nodes counts as not viable (bounded work).
pub const MAX_RAMP_NODES: usize = 20_000;
/// Relative tolerance on velocities compared with the ceiling.
pub const CEILING_REL_TOL: f64 = 1e-9;

/// What the ceiling says about a ramp state at a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Keep ramping.
    Continue,
    /// From here the branch can certainly go on: the ramp succeeded.
    Safe,
    /// Above the ceiling: the state the ramp started from is not viable.
    Violates,
}

/// The limit a branch must stay under, with its notion of a safe state.
pub trait Ceiling {
    /// Verdict for state (v, a) at traversal position `t`.
    fn verdict(&self, t: usize, v: f64, a: f64) -> Verdict;

    /// The ceiling velocity at traversal position `t` (for the velocity peak between nodes).
    fn velocity(&self, t: usize) -> f64;
}

/// Highest velocity inside an interval: v(τ) is a parabola, its vertex may lie inside.
pub fn peak_velocity(iv: &Interval) -> f64 {
    let mut peak = iv.v0.max(iv.v1());
    if iv.j < 0.0 {
        let tau = -iv.a0 / iv.j;
        if tau > 0.0 && tau < iv.t_s {
            peak = peak.max(iv.v0 - iv.a0 * iv.a0 / (2.0 * iv.j));
        }
    }
    peak
}

/// Outcome of a ramp: where it ended as safe, or that it crosses the ceiling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RampResult {
    /// Safe at traversal position `at`.
    Safe { at: usize },
    /// Crosses the ceiling at `at`.
    Violates { at: usize },
}

impl RampResult {
    pub fn is_safe(&self) -> bool {
        matches!(self, RampResult::Safe { .. })
    }
}

/// The ramp's interval from traversal position `t` with state (v, a): the steepest of
/// `RAMP_JERK_STEPS` (fractions of the lowest allowed jerk; negative entries are fractions of
/// the highest) whose interval keeps every axis limit, so a ramp is a real, feasible
/// continuation. `None` if none does.
pub fn ramp_interval(view: &View, t: usize, v: f64, a: f64, lim: &Limits) -> Option<Interval> {
    let g = view.start_geom(t);
    let (jlo, jhi) = jerk_range(g, view.sign(), v, a, lim);
    if jlo > jhi {
        return None;
    }
    let (alo, _) = acc_range(g, view.sign(), v, lim);
    let ig = view.interval_geom(t);
    let steps: &[f64] = if a > alo { &RAMP_JERK_STEPS } else { &RAMP_JERK_STEPS[3..] };
    for &frac in steps {
        let j = if frac >= 0.0 { frac * jlo.min(0.0) } else { -frac * jhi.max(0.0) };
        let j = j.clamp(jlo, jhi);
        // A jerk that brings the motion to rest before the next node is no continuation (it
        // would stop with a ≠ 0 and reverse): try a gentler one.
        if let Some(iv) = Interval::with_jerk(v, a, ig.ds_mm, j) {
            if violation(&iv, &ig, lim) <= VIOLATION_TOL {
                return Some(iv);
            }
        }
    }
    None
}

/// Runs the braking ramp from state (v, a) at traversal position `t0`.
pub fn ramp(
    view: &View,
    t0: usize,
    v0: f64,
    a0: f64,
    lim: &Limits,
    ceiling: &impl Ceiling,
    work: &mut Work,
) -> RampResult {
    work.ramps += 1;
    let last = view.len() - 1;
    let (mut v, mut a) = (v0, a0);
    let mut t = t0;
    for _ in 0..MAX_RAMP_NODES {
        match ceiling.verdict(t, v, a) {
            Verdict::Safe => return RampResult::Safe { at: t },
            Verdict::Violates => return RampResult::Violates { at: t },
            Verdict::Continue => {}
        }
        if t >= last {
            return RampResult::Violates { at: t };
        }
        match ramp_interval(view, t, v, a, lim) {
            None => return RampResult::Violates { at: t },
            Some(iv) => {
                // Between nodes the velocity must stay under the lower of the two ceilings too.
                let cap = ceiling.velocity(t).min(ceiling.velocity(t + 1));
                if peak_velocity(&iv) > cap * (1.0 + CEILING_REL_TOL) + f64::MIN_POSITIVE {
                    return RampResult::Violates { at: t + 1 };
                }
                v = iv.v1();
                a = iv.a1();
                t += 1;
            }
        }
    }
    RampResult::Violates { at: t }
}

/// The ceiling a branch runs under: the velocity bound v̄, capped at `cap`. The branch is
/// safe once its acceleration (in its own direction) is no longer positive, since then it has
/// flattened under the ceiling.
pub struct FlattenUnder<'a> {
    pub view: View<'a>,
    pub cap: f64,
}

impl Ceiling for FlattenUnder<'_> {
    fn velocity(&self, t: usize) -> f64 {
        self.view.node(t).vbar_mm_s.min(self.cap)
    }

    fn verdict(&self, t: usize, v: f64, a: f64) -> Verdict {
        let vbar = self.velocity(t);
        if v > vbar * (1.0 + CEILING_REL_TOL) + f64::MIN_POSITIVE {
            Verdict::Violates
        } else if a <= 0.0 {
            Verdict::Safe
        } else {
            Verdict::Continue
        }
    }
}
