//! The viability test that keeps a greedy branch out of dead ends without backtracking.
//!
//! A state (v, a) at a node is viable if a braking ramp from it flattens (a ≤ 0) without
//! rising above the ceiling (v̄, or a cap): the ramp lowers the acceleration with the steepest
//! jerk the axes allow that keeps each interval feasible (holding the acceleration at the
//! lowest allowed), and its margin is how far it rises above the ceiling, at the nodes and at
//! the velocity peak between them. The margin is continuous in the state, so the largest
//! viable next velocity is found by a root search rather than by trial. Seed 001 instead
//! steps back when the interval for v₊ is empty ("Gehe zurück"), which can grow
//! exponentially; here the work per ramp is bounded by `MAX_RAMP_NODES`.

use super::check::{acc_range, jerk_range, violates};
use super::interval::Interval;
use super::limits::Limits;
use super::step::Work;
use super::view::View;

/// Jerks a braking ramp tries, steepest first, as fractions of the lowest allowed path jerk
/// (negative: of the highest). The first keeps 1 % in reserve so a state on a ramp still has
/// room to move; the others cover curvature terms that leave less jerk than the start node
/// suggests, and the acceleration floor (from index 3 on: hold or raise the acceleration).
pub const RAMP_JERK_STEPS: [f64; 7] = [0.99, 0.7, 0.4, 0.0, -0.1, -0.3, -0.6];
/// Corrections of a ramp interval's jerk by the end node's limits before falling back.
const RAMP_END_CORRECTIONS: usize = 3;
/// A ramp longer than this many nodes counts as not viable (bounded work).
pub const MAX_RAMP_NODES: usize = 20_000;
/// Relative tolerance on velocities compared with the ceiling.
pub const CEILING_REL_TOL: f64 = 1e-9;
/// A ramp rising this far (relative) above the ceiling is stopped early: clearly not viable.
const MARGIN_GIVE_UP: f64 = 0.05;

/// The ceiling a branch runs under: the velocity bound v̄, capped at `cap`.
#[derive(Clone, Copy)]
pub struct FlattenUnder<'a> {
    pub view: View<'a>,
    pub cap: f64,
}

impl FlattenUnder<'_> {
    /// Ceiling velocity at traversal position `t`.
    #[inline]
    pub fn velocity(&self, t: usize) -> f64 {
        self.view.node(t).vbar_mm_s.min(self.cap)
    }
}

/// How thoroughly a ramp interval is checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// The whole interval (check points inside): for intervals that become motion.
    Full,
    /// The jerk and acceleration ranges at both nodes, with the full check only where one is
    /// binding: for the viability margin, which is an estimate the real steps re-check.
    Nodes,
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

/// The ramp's interval from traversal position `t` with state (v, a): braking with the
/// steepest jerk the axes allow at both ends of the interval (and not below the lowest
/// allowed acceleration), checked over the whole interval. If that fails (curvature taking
/// jerk inside the interval), the gentler `RAMP_JERK_STEPS` are tried. `None` if none keeps
/// every limit.
///
/// An interval that becomes part of the motion needs `Check::Full`; for the viability margin
/// `Check::Nodes` suffices where both nodes' ranges hold with room (see below).
pub fn ramp_interval(view: &View, t: usize, v: f64, a: f64, lim: &Limits, check: Check) -> Option<Interval> {
    let g = view.start_geom(t);
    let sign = view.sign();
    let (jlo, jhi) = jerk_range(g, sign, v, a, lim);
    if jlo > jhi {
        return None;
    }
    let (alo, _) = acc_range(g, sign, v, lim);
    let ig = view.interval_geom(t);
    let feasible = |iv: &Interval| !violates(iv, &ig, lim);
    if a > alo && jlo < 0.0 {
        // Steepest braking at the start, then corrected by what the end node allows.
        let mut j = RAMP_JERK_STEPS[0] * jlo;
        for _ in 0..RAMP_END_CORRECTIONS {
            let Some(iv) = Interval::with_jerk(v, a, ig.ds_mm, j) else { break };
            let (v1, a1) = (iv.v1(), iv.a1());
            let g1 = view.end_geom(t + 1);
            let (jlo1, jhi1) = jerk_range(g1, sign, v1, a1, lim);
            let (alo1, _) = acc_range(g1, sign, v1, lim);
            let mut j_next = j;
            if jlo1 <= jhi1 && j < jlo1 {
                j_next = RAMP_JERK_STEPS[0] * jlo1;
            }
            if a1 < alo1 {
                j_next = j_next.max((alo1 - a) / iv.t_s);
            }
            if j_next == j {
                // Jerk and acceleration are inside both nodes' ranges; the peak velocity is
                // checked against the ceiling by the caller. Between the nodes only the
                // interpolated geometry changes, second order over one interval, so the full
                // check runs only where a node range was binding.
                let (_, ahi0) = acc_range(g, sign, v, lim);
                let (_, ahi1) = acc_range(g1, sign, v1, lim);
                let nodes_ok = jlo1 <= jhi1
                    && j <= jhi1
                    && j > jlo1 * RAMP_JERK_STEPS[0] * (1.0 - 1e-9)
                    && a1 > alo1
                    && a <= ahi0
                    && a1 <= ahi1;
                if (check == Check::Nodes && nodes_ok) || feasible(&iv) {
                    return Some(iv);
                }
                break;
            }
            j = j_next.clamp(jlo, jhi);
        }
    }
    let steps: &[f64] = if a > alo { &RAMP_JERK_STEPS[1..] } else { &RAMP_JERK_STEPS[3..] };
    for &frac in steps {
        let j = if frac >= 0.0 { frac * jlo.min(0.0) } else { -frac * jhi.max(0.0) };
        let j = j.clamp(jlo, jhi);
        // A jerk that brings the motion to rest before the next node is no continuation (it
        // would stop with a ≠ 0 and reverse): try a gentler one.
        if let Some(iv) = Interval::with_jerk(v, a, ig.ds_mm, j) {
            if feasible(&iv) {
                return Some(iv);
            }
        }
    }
    None
}

/// How far a braking ramp from (v0, a0) at traversal position `t0` rises above the ceiling
/// before it has flattened: the largest v / ceiling − 1 at its nodes and velocity peaks.
/// ≤ `CEILING_REL_TOL` means viable. `None` if the axes allow no braking on the way or the
/// block ends first.
pub fn ramp_margin(
    view: &View,
    t0: usize,
    v0: f64,
    a0: f64,
    lim: &Limits,
    ceiling: &FlattenUnder,
    work: &mut Work,
) -> Option<f64> {
    work.ramps += 1;
    let last = view.len() - 1;
    let (mut v, mut a) = (v0, a0);
    let mut margin = v / ceiling.velocity(t0) - 1.0;
    for t in (t0..).take(MAX_RAMP_NODES) {
        if a <= 0.0 || margin > MARGIN_GIVE_UP {
            return Some(margin);
        }
        if t >= last {
            return None;
        }
        let iv = ramp_interval(view, t, v, a, lim, Check::Nodes)?;
        work.ramp_nodes += 1;
        let cap = ceiling.velocity(t).min(ceiling.velocity(t + 1));
        margin = margin.max(peak_velocity(&iv) / cap - 1.0).max(iv.v1() / ceiling.velocity(t + 1) - 1.0);
        v = iv.v1();
        a = iv.a1();
    }
    None
}
