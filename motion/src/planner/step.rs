//! One step of a branch (Kopp et al. 2019, §3.2, eq. 7): the largest velocity at the next node
//! for which the interval keeps every axis limit (eq. 7a–7d), found by safeguarded root searches
//! (regula falsi with the Illinois modification, falling back to bisection) on the one limit
//! term that bounds the step, checked against all of them at its root. The work per step is
//! bounded by `MAX_SEARCH_EVALS` evaluations of all terms and `MAX_TERM_EVALS` of one term per
//! term followed.

use super::check::{Term, VIOLATION_TOL, jerk_range, term_violation, violates, violation_term};
use super::falsi::Illinois;
use super::interval::Interval;
use super::limits::Limits;
use super::node::IntervalGeom;

/// Evaluations of the violation function per step, at most.
pub(super) const MAX_SEARCH_EVALS: u32 = 48;
/// The search stops when the bracket is this narrow relative to the velocity.
pub(super) const SEARCH_REL_TOL: f64 = 1e-5;
/// Fractions of the upper bound tried first when the jerk-free continuation is infeasible;
/// after them the probe halves down to `MIN_PROBE_FRACTION` (near a stop the feasible end
/// velocities can be many orders of magnitude below v̄).
const PROBE_FRACTIONS: [f64; 5] = [0.9, 0.75, 0.5, 0.97, 0.995];
const MIN_PROBE_FRACTION: f64 = 1e-15;
/// Jerks tried for an anchor, as fractions of the allowed range (negative: of its lower end).
const ANCHOR_JERK_FRACTIONS: [f64; 11] = [0.0, -0.5, 0.5, -0.9, 0.9, -0.99, 0.99, -0.25, 0.25, -0.97, 0.97];

/// Counts work for the per-section iteration log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Work {
    /// Evaluations of the violation function.
    pub evals: u64,
    /// Steps (one per node advanced, per branch).
    pub steps: u64,
    /// Evaluations of one term of the violation (`max_feasible`'s root search on it).
    pub term_evals: u64,
    /// Viability (ramp) simulations.
    pub ramps: u64,
    /// Joins of a forward branch onto a backward branch.
    pub joins: u64,
    /// Repairs after a branch found no viable next state.
    pub repairs: u64,
    /// Nodes simulated by viability ramps.
    pub ramp_nodes: u64,
    /// Greedy steps whose first choice was not viable (a bisection followed).
    pub bisections: u64,
    /// Capped runs tried (forward and backward branch under a common velocity).
    pub cap_tries: u64,
    /// Backward branches from a block end at rest retried under a cap (`branch::build_envelope`).
    pub end_caps: u64,
    /// Blocks planned under the relaxed (acceleration-only) ceiling first (see `block`).
    pub relaxed_tried: u64,
    /// Relaxed plans kept: faster than the plan under the flat ceiling (Kopp et al. 2019,
    /// eq. 6), or so fast that that plan was skipped (`flat_skipped`).
    pub relaxed_kept: u64,
    /// Blocks whose relaxed plan beat the acceleration-only time under the flat ceiling, so no
    /// plan under that ceiling was made (`interpd plan --json` reports it as `seed_skipped`).
    pub flat_skipped: u64,
}

impl Work {
    /// Evaluations of intervals of any kind (all terms, one term, a ramp's next node): the
    /// planner's unit of work, which a block's budget bounds (`Budget`). A count, so a bound on
    /// it holds on a loaded host as on an idle one.
    pub fn units(&self) -> u64 {
        self.evals + self.term_evals + self.ramp_nodes
    }

    pub(crate) fn add(&mut self, o: &Work) {
        *self = self.per_count(o, |a, b| a + b);
    }

    /// The work done since `earlier`, a copy of this count taken before.
    pub(crate) fn since(&self, earlier: &Work) -> Work {
        self.per_count(earlier, |a, b| a - b)
    }

    /// `f` of each count of this and `o`: the one list of the counts that `add` and `since` go
    /// through.
    fn per_count(&self, o: &Work, f: impl Fn(u64, u64) -> u64) -> Work {
        Work {
            evals: f(self.evals, o.evals),
            steps: f(self.steps, o.steps),
            term_evals: f(self.term_evals, o.term_evals),
            ramps: f(self.ramps, o.ramps),
            joins: f(self.joins, o.joins),
            repairs: f(self.repairs, o.repairs),
            ramp_nodes: f(self.ramp_nodes, o.ramp_nodes),
            bisections: f(self.bisections, o.bisections),
            cap_tries: f(self.cap_tries, o.cap_tries),
            end_caps: f(self.end_caps, o.end_caps),
            relaxed_tried: f(self.relaxed_tried, o.relaxed_tried),
            relaxed_kept: f(self.relaxed_kept, o.relaxed_kept),
            flat_skipped: f(self.flat_skipped, o.flat_skipped),
        }
    }
}

/// The work a search may still take: the units (`Work::units`) at which it stops and reports
/// the node it is stuck at, so the planner stops there (`Planner::force_stop`) instead of
/// searching on. Checked between the searches' rounds (repairs, caps, start velocities), so a
/// search overshoots it by at most one round.
#[derive(Debug, Clone, Copy)]
pub(super) struct Budget {
    until_units: u64,
}

impl Budget {
    /// `units` more than `work` has taken.
    pub(super) fn after(work: &Work, units: u64) -> Self {
        Self { until_units: work.units().saturating_add(units) }
    }

    /// No bound (for searches outside a block plan).
    #[cfg(test)]
    pub(super) fn unlimited() -> Self {
        Self { until_units: u64::MAX }
    }

    pub(super) fn exhausted(&self, work: &Work) -> bool {
        work.units() >= self.until_units
    }
}

/// The interval from (v0, a0) ending at `v1` where it keeps every limit; `None` if v1 is
/// unreachable or a limit breaks. The check stops at the first check point that breaks one:
/// the probes for a feasible anchor mostly fail (some steps probe down to 1e-15 × v̄), and
/// most fail at the start node.
#[inline]
pub(super) fn feasible(v0: f64, a0: f64, v1: f64, g: &IntervalGeom, lim: &Limits, work: &mut Work) -> Option<Interval> {
    work.evals += 1;
    Interval::through(v0, a0, g.ds_mm, v1).filter(|iv| !violates(iv, g, lim))
}

/// The feasible interval from (v0, a0) with the largest end velocity not above `v_max`, or
/// `None` if no end velocity in [0, v_max] is feasible.
///
/// The violation is the largest of many terms (each limit of each axis at each check point),
/// and one of them bounds the step. A root search on the maximum crawls across its kinks; this
/// one follows the term that was worst at the infeasible end alone to its root ([`term_root`],
/// one axis at one point per evaluation), then checks every term there: feasible, the step is
/// found; else the term worst there bounds it, and is followed next.
pub(super) fn max_feasible(
    v0: f64,
    a0: f64,
    v_max: f64,
    g: &IntervalGeom,
    lim: &Limits,
    work: &mut Work,
) -> Option<Interval> {
    work.steps += 1;
    let mut term = None;
    if let Some((iv, f, t)) = evaluate_term(v0, a0, v_max, g, lim, work) {
        if f <= VIOLATION_TOL {
            return Some(iv);
        }
        term = t;
    }
    let mut lo = find_anchor(v0, a0, v_max, g, lim, work)?;
    // Bracket: lo feasible, hi infeasible (by `term` where that is known).
    let mut hi = v_max;
    let budget_end = work.evals + MAX_SEARCH_EVALS as u64;
    while hi - lo.v1() > SEARCH_REL_TOL * hi.max(1e-12) && work.evals < budget_end {
        let x = match term {
            Some(t) => {
                let (x_lo, x_hi) = term_root(v0, a0, (lo.v1(), hi), g, lim, t, work);
                hi = hi.min(x_hi);
                if x_lo <= lo.v1() {
                    // The term's root is at the feasible end (or its search ran out): bisect.
                    term = None;
                    continue;
                }
                x_lo
            }
            None => 0.5 * (lo.v1() + hi),
        };
        match evaluate_term(v0, a0, x, g, lim, work) {
            Some((iv, f, _)) if f <= VIOLATION_TOL => lo = iv,
            Some((_, _, t)) => (hi, term) = (x, t),
            None => (hi, term) = (x, None),
        }
    }
    Some(lo)
}

/// Evaluations of one term per [`term_root`], at most.
const MAX_TERM_EVALS: u32 = 48;
/// [`term_root`] narrows its bracket to this share of the velocity: well inside
/// `SEARCH_REL_TOL`, at little cost (one axis at one point per evaluation).
const TERM_REL_TOL: f64 = 1e-5;
/// [`term_root`]'s secant points keep this share of the bracket away from its ends: the term
/// is smooth, so its secant can come close to an end, unlike the maximum's.
const TERM_SECANT_MARGIN: f64 = 0.01;

/// The interval from (v0, a0) ending at `v1`, its largest normalised violation (≤ 0 is
/// feasible) and, where it is infeasible, the term worst there; `None` if v1 is unreachable.
#[inline]
fn evaluate_term(
    v0: f64,
    a0: f64,
    v1: f64,
    g: &IntervalGeom,
    lim: &Limits,
    work: &mut Work,
) -> Option<(Interval, f64, Option<Term>)> {
    work.evals += 1;
    let iv = Interval::through(v0, a0, g.ds_mm, v1)?;
    let (f, t) = violation_term(&iv, g, lim);
    Some((iv, f, t))
}

/// The end velocities around the root of term `t` alone in (lo, hi), where lo keeps every
/// limit and hi breaks `t`: (largest found at which `t` holds, smallest at which it breaks).
/// The second breaks a limit, so it bounds the step from above; the first is where every
/// term must be checked.
fn term_root(
    v0: f64,
    a0: f64,
    (mut lo, mut hi): (f64, f64),
    g: &IntervalGeom,
    lim: &Limits,
    t: Term,
    work: &mut Work,
) -> (f64, f64) {
    let mut value = |x: f64| {
        work.term_evals += 1;
        Interval::through(v0, a0, g.ds_mm, x).map(|iv| term_violation(&iv, g, lim, t) - VIOLATION_TOL)
    };
    let Some(mut f_lo) = value(lo).filter(|f| *f <= 0.0) else { return (lo, hi) };
    let mut f_hi = value(hi);
    let mut falsi = Illinois::default();
    for _ in 0..MAX_TERM_EVALS {
        if hi - lo <= TERM_REL_TOL * hi.max(1e-12) {
            break;
        }
        let x = falsi.next((lo, f_lo), (hi, f_hi), TERM_SECANT_MARGIN);
        match value(x) {
            Some(f) if f <= 0.0 => {
                (lo, f_lo) = (x, f);
                falsi.lower_moved();
            }
            Some(f) => {
                (hi, f_hi) = (x, Some(f));
                falsi.upper_moved();
            }
            None => {
                (hi, f_hi) = (x, None);
                falsi.upper_moved_unvalued();
            }
        }
    }
    (lo, hi)
}

/// A feasible end velocity to start the search from: the jerk-free continuation, else probes.
fn find_anchor(v0: f64, a0: f64, v_max: f64, g: &IntervalGeom, lim: &Limits, work: &mut Work) -> Option<Interval> {
    let mut feasible_at = |v1: f64| feasible(v0, a0, v1, g, lim, work);
    // Constant-jerk continuations across the jerk range the axes allow at the start node:
    // the feasible end velocities are mostly bounded by jerk, so these land inside them.
    let (jlo, jhi) = jerk_range(g.start, g.sign, v0, a0, lim);
    if jlo <= jhi {
        for frac in ANCHOR_JERK_FRACTIONS {
            let j = if frac >= 0.0 { frac * jhi.max(0.0) } else { -frac * jlo.min(0.0) };
            // Where the range lies on one side of zero, the other side's fractions all give
            // the jerk-free continuation again.
            if j == 0.0 && frac != 0.0 {
                continue;
            }
            let Some(cont) = Interval::with_jerk(v0, a0, g.ds_mm, j) else { continue };
            if cont.v1() <= v_max {
                if let Some(iv) = feasible_at(cont.v1()) {
                    return Some(iv);
                }
            }
        }
    }
    let halvings = std::iter::successors(Some(0.25), |f| (*f > MIN_PROBE_FRACTION).then_some(f * 0.5));
    PROBE_FRACTIONS.into_iter().chain(halvings).find_map(|frac| feasible_at(frac * v_max))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::MAX_AXES;
    use crate::planner::node::NodeGeom;

    fn setup() -> (Limits, NodeGeom) {
        let mut l = Limits {
            n_axes: 1,
            vel: [f64::INFINITY; MAX_AXES],
            acc_max: [f64::INFINITY; MAX_AXES],
            acc_min: [f64::NEG_INFINITY; MAX_AXES],
            jerk: [f64::INFINITY; MAX_AXES],
            inv_vel: [0.0; MAX_AXES],
            inv_acc_max: [0.0; MAX_AXES],
            inv_acc_min: [0.0; MAX_AXES],
            inv_jerk: [0.0; MAX_AXES],
            configured_vel: [1.0; MAX_AXES],
            configured_acc: [1.0; MAX_AXES],
            configured_jerk: [1.0; MAX_AXES],
            curvature_jump_s: 2e-6,
        };
        l.vel[0] = 100.0;
        l.acc_max[0] = 1000.0;
        l.acc_min[0] = -1000.0;
        l.jerk[0] = 10000.0;
        l.refresh();
        let mut g = NodeGeom::default();
        g.d1[0] = 1.0;
        (l, g)
    }

    /// [`max_feasible`] from (v0, a0) over `ds_mm` of the one-axis line of [`setup`], with the
    /// work it took.
    fn solve(v0: f64, a0: f64, v_max: f64, ds_mm: f64) -> (Interval, Work) {
        let (l, g) = setup();
        let ig = IntervalGeom { start: &g, end: &g, ds_mm, sign: 1.0, span: None, quintic: false };
        let mut w = Work::default();
        let iv = max_feasible(v0, a0, v_max, &ig, &l, &mut w).unwrap();
        (iv, w)
    }

    #[test]
    fn from_rest_the_jerk_limit_binds() {
        let (iv, w) = solve(0.0, 0.0, 100.0, 0.01);
        // From rest: j = 2v³/(9Δs²) ≤ J → v = (4.5 J Δs²)^(1/3)
        let expect = (4.5 * 10000.0 * 0.01f64.powi(2)).cbrt();
        assert!((iv.v1() - expect).abs() < 1e-6 * expect, "{} vs {expect}", iv.v1());
        assert!(w.evals <= 14, "evaluations {w:?}");
    }

    /// Near the velocity limit the largest violation is the velocity term, nearly flat in v₊,
    /// until the jerk term overtakes it steeply, where regula falsi on the maximum keeps
    /// landing just above the feasible end. Following the jerk term alone, the search checks
    /// every term at most four times.
    #[test]
    fn a_flat_violation_under_a_steep_jerk_term_converges_quickly() {
        let (iv, w) = solve(98.4, 0.0, 99.9, 1.0);
        // The jerk limit binds (to the search's resolution in v₊).
        assert!((iv.j.abs() - 10000.0).abs() < 1e-2 * 10000.0, "j {} v1 {}", iv.j, iv.v1());
        assert!(w.evals <= 4 && w.term_evals <= 12, "evaluations {w:?}");
    }

    #[test]
    fn cruise_at_the_velocity_limit() {
        let (iv, _) = solve(99.0, 0.0, 99.0, 1.0);
        assert!((iv.v1() - 99.0).abs() < 1e-12 && iv.j.abs() < 1e-9);
    }
}
