//! The viability test that keeps a greedy branch out of dead ends without backtracking.
//!
//! A state (v, a) at a node is viable if a braking ramp from it flattens (a ≤ 0) without
//! rising above the ceiling (v̄, or a cap): the ramp lowers the acceleration with the steepest
//! jerk the axes allow that keeps each interval feasible (holding the acceleration at the
//! lowest allowed), and its margin is how far it rises above the ceiling, at the nodes and at
//! the velocity peak between them. The margin is continuous in the state, so the largest
//! viable next velocity is found by a root search rather than by trial. Kopp et al. 2019, §3.2
//! instead step back when the interval for v₊ is empty ("Gehe zurück"), which can grow
//! exponentially; here the work per ramp is bounded by `MAX_RAMP_NODES`.

use super::check::{acc_range, jerk_range, violates, violates_inside};
use super::interval::Interval;
use super::limits::Limits;
use super::node::NodeGeom;
use super::step::Work;
use super::view::View;

/// Jerks a braking ramp tries, steepest first, as fractions of the lowest allowed path jerk
/// (negative: of the highest). The first keeps 1 % in reserve so a state on a ramp still has
/// room to move; the others cover curvature terms that leave less jerk than the start node
/// suggests, and the acceleration floor (from index 3 on: hold or raise the acceleration).
pub(super) const RAMP_JERK_STEPS: [f64; 7] = [0.99, 0.7, 0.4, 0.0, -0.1, -0.3, -0.6];
/// Corrections of a ramp interval's jerk by the end node's limits before falling back.
const RAMP_END_CORRECTIONS: usize = 3;
/// A ramp interval whose end would fall below the end node's lowest allowed acceleration is
/// corrected to end this share of that node's acceleration range above it, as the jerk keeps
/// 1 % in reserve from its bound. The floor moves with the end velocity, which the corrected
/// jerk changes: aimed at the floor itself, the corrections chase it and often run out, and
/// the ramp falls back to the gentler jerks, each with a full check. A larger reserve brakes
/// less and makes the ramps longer.
const RAMP_FLOOR_RESERVE: f64 = 0.01;
/// A ramp longer than this many nodes counts as not viable (bounded work).
pub(super) const MAX_RAMP_NODES: usize = 20_000;
/// Relative tolerance on velocities compared with the ceiling.
pub(super) const CEILING_REL_TOL: f64 = 1e-9;
/// Accelerations within this fraction of their allowed range from a bound count as binding
/// for the node-only ramp check (the full interval check runs there).
const ACC_NEAR_BOUND_FRACTION: f64 = 0.05;
/// A forced-window ramp step whose jerk lies within this fraction of the end node's allowed
/// range from its edges counts as binding (the full interval check runs there).
const JERK_NEAR_BOUND_FRACTION: f64 = 0.05;
/// A ramp rising this far (relative) above the ceiling is stopped early: clearly not viable.
/// Ten times the viable search's touch band (`branch::VIABLE_TOUCH_MARGIN`): the search needs
/// the value of a trial above the ceiling only for its secant, and one this far above is a
/// clear upper end; running such a ramp on until it flattens costs nodes and tells nothing.
const MARGIN_GIVE_UP: f64 = 0.003;

/// Shares of a forced jerk window (one not containing zero) a ramp tries, from the edge the
/// fallback jerks clamp to inwards, when that edge breaks a limit inside the interval.
const FORCED_WINDOW_FRACTIONS: [f64; 4] = [0.1, 0.25, 0.5, 0.75];

/// What a caller needs of a ramp's margin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Wanted {
    /// Its value (up to `MARGIN_GIVE_UP`): a search interpolates on it.
    Margin,
    /// Only whether it is viable: the ramp stops as soon as it rises above the ceiling, so a
    /// margin above `CEILING_REL_TOL` is only a lower bound of the full one (the verdict is
    /// the same: below the tolerance the ramp runs as with `Margin`).
    Verdict,
}

/// The ceiling a branch runs under: the velocity bound v̄, capped at `cap`.
#[derive(Clone, Copy)]
pub(super) struct FlattenUnder<'a> {
    pub view: View<'a>,
    pub cap: f64,
    /// The limits the branch runs under (for [`FlattenUnder::flat_acc`]).
    pub lim: &'a Limits,
}

impl FlattenUnder<'_> {
    /// Ceiling velocity at traversal position `t`.
    #[inline]
    pub(super) fn velocity(&self, t: usize) -> f64 {
        self.view.node(t).vbar_mm_s.min(self.cap)
    }

    /// The acceleration at or below which a state (v, ·) at traversal position `t` has
    /// flattened: a ≤ 0 (v̄ of Kopp et al. 2019, eq. 5, with a = 0), or the lowest acceleration
    /// the axes allow at v where that is above zero. The acceleration-only ceiling passes a dip
    /// with A′a offsetting A″v², where a = 0 does not keep the limits: a state braked as far as
    /// the axes allow is as flat as the motion can be there. Where the ceiling falls into a dip
    /// the passes made (`Node::reach_bound`), following its slope (dv/ds = Δc/Δs, so a =
    /// v·dv/ds, scaled to v) counts as flat, as long as the axes allow it.
    #[inline]
    pub(super) fn flat_acc(&self, t: usize, v: f64) -> f64 {
        self.flat_acc_in(t, v, None)
    }

    /// Whether [`FlattenUnder::flat_acc`] at (t, v) depends on the accelerations the axes allow
    /// there; if not, it is 0. Up to the flat v̄ (Kopp et al. 2019, eq. 6) the axes allow a =
    /// 0, so the lowest allowed acceleration is ≤ 0: the common case, without the per-axis
    /// ranges.
    #[inline]
    fn needs_acc_range(&self, t: usize, v: f64) -> bool {
        if t + 1 >= self.view.len() {
            return false;
        }
        let node = self.view.node(t);
        node.reach_bound || v > node.vbar_flat_mm_s
    }

    /// [`FlattenUnder::flat_acc`] with the accelerations the axes allow at (t, v) when they are
    /// known already (a ramp carries them from one interval into the next).
    #[inline]
    fn flat_acc_in(&self, t: usize, v: f64, acc: Option<(f64, f64)>) -> f64 {
        if !self.needs_acc_range(t, v) {
            return 0.0;
        }
        let node = self.view.node(t);
        let (lo, hi) = acc.unwrap_or_else(|| acc_range(self.view.start_geom(t), self.view.sign(), v, self.lim));
        let lo = if lo <= hi { lo } else { f64::NEG_INFINITY };
        let (c0, c1) = (self.velocity(t), self.velocity(t + 1));
        if node.reach_bound && c1 < c0 && c0 > 0.0 {
            // Into a dip of the passes' ceiling: flat means following its slope.
            let follow = v * v * (c1 - c0) / (self.view.ds(t) * c0);
            follow.max(lo).min(0.0)
        } else {
            lo.max(0.0)
        }
    }
}

/// How thoroughly a ramp interval is checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Check {
    /// The whole interval (check points inside): for intervals that become motion.
    Full,
    /// The jerk and acceleration ranges at both nodes, with the full check only where one is
    /// binding: for the viability margin, which is an estimate the real steps re-check.
    Nodes,
}

/// Highest velocity inside an interval: v(τ) is a parabola, its vertex may lie inside.
pub(super) fn peak_velocity(iv: &Interval) -> f64 {
    let mut peak = iv.v0.max(iv.v1());
    if iv.j < 0.0 {
        let tau = -iv.a0 / iv.j;
        if tau > 0.0 && tau < iv.t_s {
            peak = peak.max(iv.v0 - iv.a0 * iv.a0 / (2.0 * iv.j));
        }
    }
    peak
}

/// The path jerks and accelerations the axes allow at one node for one state (eq. 1b–1c):
/// computed at the end of one ramp interval and reused as the start of the next, where the
/// node's geometry on both sides is the same (everywhere but at element joints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct NodeRanges {
    pub jerk: (f64, f64),
    pub acc: (f64, f64),
}

impl NodeRanges {
    #[inline]
    fn at(g: &NodeGeom, sign: f64, v: f64, a: f64, lim: &Limits) -> Self {
        NodeRanges { jerk: jerk_range(g, sign, v, a, lim), acc: acc_range(g, sign, v, lim) }
    }

    /// Whether the state these ranges were computed for (acceleration `a`) keeps the limits
    /// leaving the node: some jerk is allowed, and `a` is inside its range.
    #[inline]
    fn allow_leaving(&self, a: f64) -> bool {
        let ((jlo, jhi), (alo, ahi)) = (self.jerk, self.acc);
        jlo <= jhi && a >= alo && a <= ahi
    }
}

/// The ramp's interval from traversal position `t` with state (v, a): braking with the
/// steepest jerk the axes allow at both ends of the interval (and not below the lowest
/// allowed acceleration), checked over the whole interval. If that fails (curvature taking
/// jerk inside the interval), the gentler `RAMP_JERK_STEPS` are tried, and where the geometry
/// forces the jerk's sign, jerks inside that window (`FORCED_WINDOW_FRACTIONS`). `None` if
/// none keeps every limit.
///
/// An interval that becomes part of the motion needs `Check::Full`; for the viability margin
/// `Check::Nodes` suffices where both nodes' ranges hold with room (see below).
pub(super) fn ramp_interval(view: &View, t: usize, v: f64, a: f64, lim: &Limits, check: Check) -> Option<Interval> {
    ramp_interval_from(view, t, v, a, lim, check, None).map(|(iv, _)| iv)
}

/// [`ramp_interval`] with the start node's ranges for (v, a) when already known, returning
/// the end node's ranges for the interval's end state when they hold for the next interval
/// too (the node is no element joint).
fn ramp_interval_from(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    lim: &Limits,
    check: Check,
    start: Option<NodeRanges>,
) -> Option<(Interval, Option<NodeRanges>)> {
    let sign = view.sign();
    let r0 = start.unwrap_or_else(|| NodeRanges::at(view.start_geom(t), sign, v, a, lim));
    let (jlo, jhi) = r0.jerk;
    if jlo > jhi {
        return None;
    }
    let alo = r0.acc.0;
    let ig = view.interval_geom(t);
    let feasible = |iv: &Interval| !violates(iv, &ig, lim);
    // The node ranges stand for the interval only where the geometry interpolated from the
    // nodes is close to the real one: the sampling makes it so except on a path table, whose
    // intervals (its rows, split by time only) can bulge between the nodes. Only there do
    // the ramp's intervals get the full check; elsewhere it would cost much and change nothing.
    let requested = check;
    let check = if ig.fine_checks() { Check::Full } else { check };
    if a > alo && jlo < 0.0 {
        // Steepest braking, where the end node allows it.
        if let Some((iv, r1)) = steepest_braking(view, t, (v, a), ig.ds_mm, (jlo, jhi), lim) {
            let (j, a1, jlo1) = (iv.j, iv.a1(), r1.jerk.0);
            // Jerk and acceleration are inside both nodes' ranges; the peak velocity is
            // checked against the ceiling by the caller. Between the nodes the geometry
            // changes only to second order over one interval where the nodes interpolate
            // it well (`check` is `Full` elsewhere, see above), so the full check runs
            // only where a node range was binding. An acceleration close to
            // its bound at either node counts as binding: the axis acceleration bulges
            // between the nodes (a state on the bound whose axis jerk points outwards
            // passes both node checks and breaks the bound inside), and a viability
            // estimate that misses this leads a branch into a dead end. Where the nodes
            // do not interpolate the interval (`check` forced to `Full`), their ranges
            // still stand for the nodes themselves: a viability ramp checks only the points
            // between them there.
            let nodes_ok = clear_of_reserve(j, jlo1) && holds_at_nodes(j, (a, &r0), (a1, &r1));
            let keeps = match (requested, check) {
                (Check::Nodes, Check::Nodes) if nodes_ok => true,
                (Check::Nodes, Check::Full) if nodes_ok => !violates_inside(&iv, &ig, lim),
                _ => feasible(&iv),
            };
            if keeps {
                return Some((iv, carried(view, t, view.end_geom(t + 1), r1)));
            }
        }
    }
    // The geometry forces the jerk's sign (the window excludes zero): see below.
    let forced = jlo > 0.0 || jhi < 0.0;
    let steps: &[f64] = if a > alo { &RAMP_JERK_STEPS[1..] } else { &RAMP_JERK_STEPS[3..] };
    let mut tried = f64::NAN;
    for &frac in steps {
        let j = if frac >= 0.0 { frac * jlo.min(0.0) } else { -frac * jhi.max(0.0) };
        let j = j.clamp(jlo, jhi);
        if j == tried {
            continue;
        }
        tried = j;
        // A jerk that brings the motion to rest before the next node is no continuation (it
        // would stop with a ≠ 0 and reverse): try a gentler one.
        if let Some(iv) = Interval::with_jerk(v, a, ig.ds_mm, j) {
            // As above, the viability margin takes the nodes' ranges where they hold with
            // room, but only in a forced window: most of these steps run there (orientation
            // swings), and elsewhere the extra ranges cost more than the checks they save. The
            // window moves along the interval, so the jerk must also keep clear of the end
            // node's window edges.
            if check == Check::Nodes && forced {
                let g1 = view.end_geom(t + 1);
                let r1 = NodeRanges::at(g1, sign, iv.v1(), iv.a1(), lim);
                let band = JERK_NEAR_BOUND_FRACTION * (r1.jerk.1 - r1.jerk.0);
                let clear = j > r1.jerk.0 + band && j < r1.jerk.1 - band;
                if clear && holds_at_nodes(j, (a, &r0), (iv.a1(), &r1)) {
                    return Some((iv, carried(view, t, g1, r1)));
                }
            }
            if feasible(&iv) {
                return Some((iv, None));
            }
        }
    }
    // Where the geometry forces the sign of the jerk (A‴v³ dominating eq. 1c, e.g. a rotary
    // axis held at its velocity limit through a sharp swing), the window does not contain
    // zero, every step above clamps to its edge, and the edge at the start node may leave it
    // inside the interval: go into the window.
    if forced {
        for frac in FORCED_WINDOW_FRACTIONS {
            let j = if jlo > 0.0 { jlo + frac * (jhi - jlo) } else { jhi - frac * (jhi - jlo) };
            if let Some(iv) = Interval::with_jerk(v, a, ig.ds_mm, j) {
                if feasible(&iv) {
                    return Some((iv, None));
                }
            }
        }
    }
    None
}

/// The steepest braking interval from (v, a) at traversal position `t` (`ds_mm` long, the
/// start node allowing jerks `jlo..=jhi`) that the end node allows too: `RAMP_JERK_STEPS[0]`
/// of the start's braking bound, corrected until the end's jerk range (with the same reserve)
/// and acceleration floor (with `RAMP_FLOOR_RESERVE`) hold. With the end node's ranges for its
/// end state; `None` if the corrections do not settle within `RAMP_END_CORRECTIONS`.
fn steepest_braking(
    view: &View,
    t: usize,
    (v, a): (f64, f64),
    ds_mm: f64,
    (jlo, jhi): (f64, f64),
    lim: &Limits,
) -> Option<(Interval, NodeRanges)> {
    // Clamped: where the geometry forces braking (jhi < 0), the window can be narrower than
    // the reserve.
    let mut j = with_reserve_above(jlo).clamp(jlo, jhi);
    for _ in 0..RAMP_END_CORRECTIONS {
        let iv = Interval::with_jerk(v, a, ds_mm, j)?;
        let a1 = iv.a1();
        let r1 = NodeRanges::at(view.end_geom(t + 1), view.sign(), iv.v1(), a1, lim);
        let ((jlo1, jhi1), (alo1, ahi1)) = (r1.jerk, r1.acc);
        let mut j_next = j;
        if jlo1 <= jhi1 && j < jlo1 {
            j_next = with_reserve_above(jlo1);
        }
        if a1 < alo1 {
            // The floor moves with the end velocity, which the new jerk changes: aimed at the
            // floor itself, the corrections chased it (see `RAMP_FLOOR_RESERVE`).
            let aim = alo1 + RAMP_FLOOR_RESERVE * (ahi1 - alo1).max(0.0);
            j_next = j_next.max((aim - a) / iv.t_s);
        }
        if j_next == j {
            return Some((iv, r1));
        }
        j = j_next.clamp(jlo, jhi);
    }
    None
}

/// A jerk `RAMP_JERK_STEPS[0]` of the way from zero to the bound `lo` where that bound is a
/// braking one, else as far above it (a bound above zero, where the geometry forces the jerk
/// up: 0.99 × it would lie below it, and the corrections would chase it without end).
#[inline]
fn with_reserve_above(lo: f64) -> f64 {
    if lo < 0.0 { RAMP_JERK_STEPS[0] * lo } else { (2.0 - RAMP_JERK_STEPS[0]) * lo }
}

/// Whether jerk `j` lies beyond the reserve [`with_reserve_above`] keeps from the bound `lo`
/// (up to rounding): where it does not, the bound was binding.
#[inline]
fn clear_of_reserve(j: f64, lo: f64) -> bool {
    let edge = with_reserve_above(lo);
    if lo < 0.0 { j > edge * (1.0 - 1e-9) } else { j > edge * (1.0 + 1e-9) }
}

/// The end node's ranges `r1` (geometry `g1`) as the start of the next interval, where they
/// hold there too: everywhere but at element joints, where A″ and A‴ jump.
fn carried(view: &View, t: usize, g1: &NodeGeom, r1: NodeRanges) -> Option<NodeRanges> {
    (t + 1 < view.len() && view.start_geom(t + 1) == g1).then_some(r1)
}

/// Whether jerk `j` keeps the end node's jerk range and both nodes' accelerations (a with its
/// node's ranges) keep clear of their bounds by `ACC_NEAR_BOUND_FRACTION` (see
/// [`ramp_interval_from`]).
fn holds_at_nodes(j: f64, start: (f64, &NodeRanges), end: (f64, &NodeRanges)) -> bool {
    let inside = |x: f64, (lo, hi): (f64, f64)| {
        let band = ACC_NEAR_BOUND_FRACTION * (hi - lo);
        x > lo + band && x < hi - band
    };
    let (jlo1, jhi1) = end.1.jerk;
    jlo1 <= j && j <= jhi1 && inside(start.0, start.1.acc) && inside(end.0, end.1.acc)
}

/// The viability ramp's interval: the braking ramp's, except where that would take the
/// acceleration below zero within the interval; then the interval that lands exactly at a = 0
/// at the next node, if it keeps the limits. A state counts as viable only if it can flatten
/// *smoothly* under the ceiling: a greedy branch that reaches the ceiling by overshooting into
/// braking would chatter along it (Kopp et al. 2019, §3.2: α = 1 alone makes the jerk
/// bang-bang), and near stops, where nodes are few, get stuck. Returns the interval and whether
/// it landed (ends flat). Also returns the end node's ranges when they carry over (see
/// [`ramp_interval_from`]).
fn landing_ramp_interval(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    lim: &Limits,
    ceiling: &FlattenUnder,
    start: Option<NodeRanges>,
) -> Option<(Interval, bool, Option<NodeRanges>)> {
    let (steep, r1) = ramp_interval_from(view, t, v, a, lim, Check::Nodes, start)?;
    // The next node's flat acceleration at the current speed (the ramp slows on the way, and
    // a slower state is flat at a lower relative slope: landing there errs on the safe side).
    let target = ceiling.flat_acc(t + 1, v);
    // The steep interval either brakes past the target (land instead), or does not brake at
    // all although the state is above it: where every braking jerk of `RAMP_JERK_STEPS` comes
    // to rest inside the interval (a slow feed on nodes a few µm apart, against the jerk
    // limit of a fast machine: braking at 0.4 J from 1 mm/s stops within 1 µm), the ramp
    // falls back to j = 0 and would run on at constant acceleration, above the ceiling,
    // until the block ends. The landing interval is the gentle braking jerk there.
    if a <= target || (steep.a1() >= target && steep.j < 0.0) {
        return Some((steep, false, r1));
    }
    let ig = view.interval_geom(t);
    match Interval::landing(v, a, ig.ds_mm, target) {
        Some(land) if !violates(&land, &ig, lim) => Some((land, true, None)),
        _ => Some((steep, false, r1)),
    }
}

/// Whether the state (v, a) at traversal position `t` keeps the limits on the side of the
/// interval it leaves into: some jerk keeps every axis within its jerk limit there, and the
/// acceleration is inside its range (eq. 1b–1c). At an element joint A″ and A‴ jump, so a
/// state that kept the limits arriving may have none left for the next side.
pub(super) fn can_leave(view: &View, t: usize, v: f64, a: f64, lim: &Limits) -> bool {
    NodeRanges::at(view.start_geom(t), view.sign(), v, a, lim).allow_leaving(a)
}

/// Nodes a viability ramp simulates interval by interval; beyond them (dense nodes, where an
/// interval lasts a tiny fraction of the braking time) the rest of the ramp is taken in
/// closed form, so the work per ramp is bounded whatever the node density. The tail errs on
/// the slow side (it brakes at a share of the last jerk, where the axes often allow more
/// further on), so its verdict should come late: a shorter simulated part judges more states
/// wrongly not viable, which slows the motion and costs searches around them.
pub(super) const RAMP_SIMULATED_NODES: usize = 96;
/// The closed-form tail brakes with this share of the jerk the simulated ramp reached last: it
/// overestimates the peak (errs on the slow side) unless later nodes allow less than this share.
const RAMP_TAIL_JERK_SHARE: f64 = 0.8;

/// The rest of a braking ramp from (v, a) at traversal position `t`, with constant jerk
/// `RAMP_TAIL_JERK_SHARE · j_last` until a = 0: its peak velocity v + a²/(2|j|) against the
/// lowest ceiling over the distance it covers (Kopp et al. 2019, eq. 2 with τ = a/|j|). `None`
/// if the ramp was not braking or the block ends first.
fn ramp_tail_margin(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    j_last: f64,
    ceiling: &FlattenUnder,
    work: &mut Work,
) -> Option<f64> {
    let j = RAMP_TAIL_JERK_SHARE * j_last;
    if j >= 0.0 {
        return None;
    }
    let tau = -a / j;
    let dist = v * tau + 0.5 * a * tau * tau + j * tau * tau * tau / 6.0;
    let peak = v - a * a / (2.0 * j);
    let s0 = view.node(t).s_mm;
    let mut lowest = ceiling.velocity(t);
    let mut k = t + 1;
    while k < view.len() && (view.node(k).s_mm - s0).abs() <= dist {
        lowest = lowest.min(ceiling.velocity(k));
        k += 1;
    }
    work.ramp_nodes += 1;
    if k >= view.len() {
        return None;
    }
    // The node after the distance bounds the interval the ramp flattens in.
    lowest = lowest.min(ceiling.velocity(k));
    Some(peak / lowest - 1.0)
}

/// The states a viability ramp passed after its start node, with the margin of the ramp from
/// each. A ramp is a function of its start state (for one view, ceiling and limits), so the
/// ramp from a state it passed is its own rest: a greedy step that searches tries the braking
/// ramp's next state first, and where a branch rides its braking ramp the state the step
/// before accepted ramps through exactly that state (`branch::greedy_step`).
#[derive(Debug, Clone, Default)]
pub(super) struct RampTrace {
    /// Traversal position of `states[0]`.
    first: usize,
    states: Vec<(f64, f64)>,
    /// Per state, the margin of a ramp started there (while the ramp runs: two terms per
    /// state, its interval's end and peak; [`RampTrace::finish`] folds them).
    margins: Vec<f64>,
}

impl RampTrace {
    /// The margin of the ramp from (v, a) at traversal position `node`, if this trace passed
    /// exactly that state.
    #[inline]
    pub(super) fn margin_from(&self, node: usize, v: f64, a: f64) -> Option<f64> {
        let i = node.checked_sub(self.first)?;
        let &(tv, ta) = self.states.get(i)?;
        (tv == v && ta == a).then(|| self.margins[i])
    }

    fn start(&mut self, first: usize) {
        self.first = first;
        self.states.clear();
        self.margins.clear();
    }

    /// Turns the per-interval terms (end, peak) into the margin of the ramp from each state:
    /// its own end term and every later interval's terms, folded with `f64::max` as the ramp
    /// folds them (from NaN, which `max` skips: a ramp whose terms are all NaN returns NaN).
    fn finish(&mut self) {
        let n = self.states.len();
        let mut later = f64::NAN;
        for i in (0..n).rev() {
            let (at_end, at_peak) = (self.margins[2 * i], self.margins[2 * i + 1]);
            self.margins[2 * i + 1] = at_end.max(later);
            later = self.margins[2 * i + 1].max(at_peak);
        }
        for i in 0..n {
            self.margins[i] = self.margins[2 * i + 1];
        }
        self.margins.truncate(n);
    }
}

/// How far a braking ramp from (v0, a0) at traversal position `t0` rises above the ceiling
/// before it has flattened: the largest v / ceiling − 1 at its nodes and velocity peaks.
/// ≤ `CEILING_REL_TOL` means viable. `None` if the axes allow no braking on the way or the
/// block ends first.
///
/// `trace` receives the ramp's states and the margin from each where it flattened in the
/// simulated part; it is left empty otherwise (the closed-form tail starts a fixed number of
/// nodes after the ramp's start, so a ramp that reached it is not its states' own rest).
#[allow(clippy::too_many_arguments)]
pub(super) fn ramp_margin(
    view: &View,
    t0: usize,
    v0: f64,
    a0: f64,
    lim: &Limits,
    ceiling: &FlattenUnder,
    work: &mut Work,
    trace: &mut RampTrace,
    wanted: Wanted,
) -> Option<f64> {
    work.ramps += 1;
    // The flat test takes the node ranges computed with `lim` (see below).
    debug_assert!(lim.acc_max == ceiling.lim.acc_max && lim.acc_min == ceiling.lim.acc_min);
    let give_up = match wanted {
        Wanted::Margin => MARGIN_GIVE_UP,
        Wanted::Verdict => CEILING_REL_TOL,
    };
    trace.start(t0 + 1);
    let last = view.len() - 1;
    let (mut v, mut a) = (v0, a0);
    let mut margin = v / ceiling.velocity(t0) - 1.0;
    let mut j_last = 0.0;
    let mut ranges = None;
    // The trace holds only where the ramp flattened in its simulated part.
    let (result, flattened) = 'ramp: {
        for t in (t0..).take(MAX_RAMP_NODES) {
            if margin > give_up {
                break 'ramp (Some(margin), false);
            }
            // The carried ranges are for this node's side and state; their acceleration range
            // depends on the acceleration limits only, which backward branches share with their
            // ceiling (they scale the jerk limits alone). Where the flat test needs that range,
            // the ramp's next interval needs the node's ranges too: computed once for both.
            if ranges.is_none() && ceiling.needs_acc_range(t, v) {
                ranges = Some(NodeRanges::at(view.start_geom(t), view.sign(), v, a, lim));
            }
            if a <= ceiling.flat_acc_in(t, v, ranges.map(|r: NodeRanges| r.acc)) {
                // Flat, but it must be able to go on: at an element joint A‴ (and A″) can jump,
                // and a state that kept the limits arriving can leave no jerk for the next side.
                // The ranges the ramp holds are the state's own on this side (see above).
                let leaves = t >= last || ranges.map_or_else(|| can_leave(view, t, v, a, lim), |r| r.allow_leaving(a));
                break 'ramp (leaves.then_some(margin), leaves);
            }
            if t >= last {
                break;
            }
            // The closed-form tail needs a braking jerk; a ramp still forced to raise its
            // acceleration (into a dip of the passes' ceiling) is simulated on.
            if t - t0 >= RAMP_SIMULATED_NODES && j_last < 0.0 {
                break 'ramp (ramp_tail_margin(view, t, v, a, j_last, ceiling, work).map(|m| margin.max(m)), false);
            }
            let Some((iv, landed, r1)) = landing_ramp_interval(view, t, v, a, lim, ceiling, ranges) else { break };
            ranges = r1;
            j_last = iv.j;
            work.ramp_nodes += 1;
            let cap = ceiling.velocity(t).min(ceiling.velocity(t + 1));
            let (at_peak, at_end) = (peak_velocity(&iv) / cap - 1.0, iv.v1() / ceiling.velocity(t + 1) - 1.0);
            margin = margin.max(at_peak).max(at_end);
            v = iv.v1();
            // A landed ramp is flat: its a₁ is on target up to rounding, which must not keep it
            // going.
            a = if landed { iv.a1().min(ceiling.flat_acc(t + 1, v)) } else { iv.a1() };
            trace.states.push((v, a));
            // A ramp from this state starts with this term; the peak term is the interval's own.
            trace.margins.push(at_end);
            trace.margins.push(at_peak);
        }
        (None, false)
    };
    if flattened {
        trace.finish();
    } else {
        trace.states.clear();
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Settings;
    use crate::planner::node::Node;

    /// Two nodes 1 µm apart on one axis whose A‴ (falling from −10 to −10.6 J/v³ across the
    /// interval) forces the path jerk into a narrow window far above zero (9 J to 11 J at the
    /// start) that moves up along it, as on a rotary axis held at its velocity limit through a
    /// swing.
    fn swing(lim: &Limits, v_mm_s: f64) -> Vec<Node> {
        let node = |s_mm: f64, d3_share: f64| {
            let mut g = NodeGeom::default();
            g.d1[0] = 1.0;
            g.d3[0] = -d3_share * lim.jerk[0] / v_mm_s.powi(3);
            Node::for_test(s_mm, g, 1e3)
        };
        vec![node(0.0, 10.0), node(SWING_DS_MM, 10.6)]
    }

    const SWING_DS_MM: f64 = 0.001;

    #[test]
    fn a_forced_jerk_window_is_searched_inside_not_only_at_its_edge() {
        let lim = Limits::from_settings(&Settings::default_machine());
        let v = 10.0; // mm/s
        let nodes = swing(&lim, v);
        let view = View::forward(&nodes);
        let (jlo, jhi) = jerk_range(&nodes[0].right, 1.0, v, 0.0, &lim);
        assert!(jlo > 0.0 && jhi > jlo, "the window must exclude zero: ({jlo}, {jhi})");
        // Its lower edge keeps the start node but not the end, where the window has moved up.
        let edge = Interval::with_jerk(v, 0.0, SWING_DS_MM, jlo).unwrap();
        assert!(violates(&edge, &view.interval_geom(0), &lim));
        let iv = ramp_interval(&view, 0, v, 0.0, &lim, Check::Full).expect("a jerk inside the window");
        assert!(iv.j > jlo && iv.j < jhi && !violates(&iv, &view.interval_geom(0), &lim));
    }

    /// The steepest braking interval settles within its corrections (for all but 1 % of the
    /// states) wherever the start node allows braking, on the five-axis example table in both
    /// directions, from states near the ceiling and just above their acceleration floor (where
    /// a braking ramp rides it), and it keeps both nodes' ranges.
    #[test]
    fn the_end_corrections_of_the_steepest_braking_settle() {
        let cfg = Settings::five_axis_machine();
        let lim = Limits::from_settings(&cfg);
        let nodes = table_nodes(&cfg);
        let (mut applied, mut unsettled) = (0, 0);
        for view in [View::forward(&nodes), View::backward(&nodes)] {
            for t in 1..view.len() - 1 {
                let vbar = view.node(t).vbar_mm_s.min(view.node(t).feed_mm_s);
                for (share, above_floor) in [(0.999, 0.02), (0.99, 0.05), (0.95, 0.1), (0.9, 0.3)] {
                    let v = share * vbar;
                    let (alo, ahi) = acc_range(view.start_geom(t), view.sign(), v, &lim);
                    let a = alo + above_floor * (ahi - alo);
                    let r0 = NodeRanges::at(view.start_geom(t), view.sign(), v, a, &lim);
                    let (jlo, jhi) = r0.jerk;
                    if !(a > r0.acc.0 && jlo < 0.0 && jlo <= jhi) {
                        continue;
                    }
                    applied += 1;
                    let ds_mm = view.ds(t);
                    let Some((iv, r1)) = steepest_braking(&view, t, (v, a), ds_mm, (jlo, jhi), &lim) else {
                        unsettled += 1;
                        continue;
                    };
                    let ((jlo1, jhi1), (alo1, _)) = (r1.jerk, r1.acc);
                    assert!(iv.j >= jlo && iv.j <= jhi, "node {t}: jerk {} outside ({jlo}, {jhi})", iv.j);
                    assert!(jlo1 > jhi1 || iv.j >= jlo1, "node {t}: jerk {} below the end's {jlo1}", iv.j);
                    assert!(iv.a1() >= alo1, "node {t}: a₁ {} below the end's floor {alo1}", iv.a1());
                }
            }
        }
        assert!(applied > 3_000, "only {applied} braking states");
        assert!(unsettled * 100 < applied, "{unsettled} of {applied} did not settle");
    }

    fn table_nodes(cfg: &Settings) -> Vec<Node> {
        let table =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/five_axis_table.csv")).unwrap();
        let path = crate::program::parse(&table, "t.csv", cfg).unwrap().path;
        crate::planner::Planner::sample_path(cfg, &path)
    }

    /// A ramp's trace gives, for every state it passed, exactly the margin of a ramp started
    /// there (what lets a greedy step skip that ramp), on the five-axis example table in both
    /// directions, through its swings and elsewhere, from states below and near its ceiling. A
    /// ramp asked for its verdict only stops early but judges alike.
    #[test]
    fn a_ramps_trace_is_the_ramp_from_each_state_it_passed() {
        let cfg = Settings::five_axis_machine();
        let lim = Limits::from_settings(&cfg);
        let nodes = table_nodes(&cfg);
        let mut work = Work::default();
        let (mut trace, mut fresh) = (RampTrace::default(), RampTrace::default());
        let (mut checked, mut verdicts) = (0, [0; 2]);
        for view in [View::forward(&nodes), View::backward(&nodes)] {
            let ceiling = FlattenUnder { view, cap: f64::INFINITY, lim: &lim };
            for t in (1..view.len() - 1).step_by(3) {
                let vbar = ceiling.velocity(t);
                for (share, a) in [(0.95, 0.0), (0.9, 300.0), (0.8, 1500.0)] {
                    let m =
                        ramp_margin(&view, t, share * vbar, a, &lim, &ceiling, &mut work, &mut fresh, Wanted::Verdict);
                    let viable = |m: Option<f64>| m.is_some_and(|m| m <= CEILING_REL_TOL);
                    verdicts[usize::from(viable(m))] += 1;
                    let full =
                        ramp_margin(&view, t, share * vbar, a, &lim, &ceiling, &mut work, &mut trace, Wanted::Margin);
                    assert_eq!(viable(m), viable(full), "verdict {m:?}, margin {full:?} from node {t}");
                    for (i, &(v, a)) in trace.states.iter().enumerate() {
                        let node = trace.first + i;
                        let m = ramp_margin(&view, node, v, a, &lim, &ceiling, &mut work, &mut fresh, Wanted::Margin);
                        assert_eq!(m, Some(trace.margins[i]), "from node {node} ({v}, {a}), traced from {t}");
                        assert_eq!(trace.margin_from(node, v, a), m);
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 2_000, "only {checked} traced states");
        assert!(verdicts[0] > 100 && verdicts[1] > 100, "not viable / viable: {verdicts:?}");
    }
}
