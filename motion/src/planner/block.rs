//! Plans one block: the nodes between two stops (or the start of the horizon and its end).
//! Builds the ceiling, runs the forward branch, and repairs the rare dead end by lowering the
//! velocity bound where the branch got stuck (a new section end), a bounded number of times.
//! A straight line between two stops takes the closed-form S-curve instead.
//!
//! Two ceilings: the flat one, v̄ of Kopp et al. 2019, eq. 6 (a = j = 0 at the node), which the
//! greedy branches follow closely, and the relaxed one, the maximum velocity curve of the
//! acceleration-only problem lowered to what acceleration can reach (`reach`). The relaxed
//! ceiling lets the motion pass an orientation swing of rotary axes braking into it and
//! accelerating out, as the time-optimal profile does, where eq. 6's v̄ lies several times
//! lower. A block is planned under the flat ceiling, or, where the acceleration-only profile
//! says the relaxed one gains more than `RELAXED_MIN_GAIN`, under the relaxed one first, and
//! under the flat one too unless the relaxed plan is clearly below the acceleration-only time
//! under it (which a plan under that ceiling can undercut only by the passes' discretisation
//! error); the faster plan is kept. Both keep every limit (every interval is checked); they
//! differ only in speed.

use super::branch::{Previous, Stuck, build_envelope};
use super::envelope::{END_CURVE, Envelope};
use super::error::Infeasibility;
use super::forward::{Failed, Progress, forward_branch};
use super::interval::Interval;
use super::limits::Limits;
use super::node::Node;
use super::step::{Budget, Work};

/// Repairs per block before the block is reported as infeasible.
pub(super) const MAX_REPAIRS: usize = 64;
/// Work (`Work::units`) a block's search may take per node, repairs and cap searches included,
/// before it gives up at the node it is stuck at (the planner stops there,
/// `Planner::force_stop`). One pass of the branches over a block takes some 20 to 100 per node
/// (the ramps simulate up to 96 nodes per step), the examples' blocks up to about 100 in all
/// and a converging search with a hundred repairs (smoothed noisy CAM data) up to about 800;
/// so this allows some ten passes, and only a search that does not converge reaches it...
const WORK_UNITS_PER_NODE: u64 = 1_000;
/// ... on the first this many nodes of a block; beyond them, on a long block of dense nodes
/// where each pass takes long, `WORK_UNITS_PER_FURTHER_NODE`, some two passes: a search that
/// has not converged by then stops, which keeps a planning call short.
const LONG_BLOCK_NODES: u64 = 2_000;
const WORK_UNITS_PER_FURTHER_NODE: u64 = 200;
/// ... and at least this much on a short block, where a few repairs and cap searches cost more
/// per node.
const WORK_UNITS_MIN: u64 = 400_000;
/// Share of the budget the plan under the relaxed ceiling may take where both are planned
/// (`plan_both`): the plan under the flat ceiling, the fallback, keeps the rest.
const RELAXED_BUDGET_SHARE: u64 = 2;
/// A ceiling the acceleration-only passes lower by less than this share stays as it is.
const PASS_NEGLIGIBLE: f64 = 1e-3;
/// The relaxed ceiling is tried when the acceleration-only profile under it is at least this
/// much faster than under the flat one.
const RELAXED_MIN_GAIN: f64 = 0.02;
/// A relaxed plan this much faster than the acceleration-only time under the flat ceiling is
/// kept without planning under that ceiling.
const FLAT_SKIP_MARGIN: f64 = 0.02;
/// A repair up to this many nodes (beyond the last one's span) before the last repair counts
/// as the branch creeping back from it.
const CREEP_SLACK_NODES: usize = 2;
/// A node's v̄ this much (relative) above its flat v̄ is lowered to that first
/// (`above_flat`).
const FLAT_REPAIR_MARGIN: f64 = 1e-3;
/// Factors applied to the stuck node's velocity, in order, when repairing there again.
const REPAIR_FACTORS: [f64; 5] = [0.9, 0.7, 0.4, 0.1, 0.0];

/// The profile of a block and the first node whose state depends on where the block ends.
#[derive(Debug, Clone)]
pub(super) struct BlockPlan {
    pub intervals: Vec<Interval>,
    /// `intervals[k]` runs from node k to node k+1; otherwise the intervals are a time-domain
    /// profile from the first node to the last (a closed-form straight move).
    pub node_aligned: bool,
    pub final_before: usize,
}

/// Plans `nodes` (first node: given state `start`; last node: rest). `end_is_stop` tells
/// whether the last node is a real stop (and not just where the horizon ends). Adds the work
/// it took to `work`, also where it finds no profile.
pub(super) fn plan_block(
    nodes: &mut [Node],
    start: (f64, f64),
    end_is_stop: bool,
    lim: &Limits,
    work: &mut Work,
) -> Result<BlockPlan, Stuck> {
    if end_is_stop && start == (0.0, 0.0) {
        if let Some(intervals) = straight_move(nodes, lim) {
            return Ok(BlockPlan { intervals, node_aligned: false, final_before: nodes.len() - 1 });
        }
    }
    let budget = Budget::after(work, block_budget_units(nodes.len()));
    let raw: Vec<f64> = nodes.iter().map(|nd| nd.vbar_mm_s).collect();
    // The flat ceiling: v̄ with a = j = 0 (Kopp et al. 2019, eq. 6), every state (v̄, 0, 0)
    // keeping the limits.
    let flat = Ceiling {
        v: nodes.iter().zip(&raw).map(|(nd, &r)| nd.vbar_flat_mm_s.min(r)).collect(),
        dip: vec![false; nodes.len()],
    };
    let chosen = match relaxed_worth_trying(nodes, &raw, &flat.v, start.0, lim) {
        None => plan_under(nodes, &flat, start, lim, work, &budget),
        Some(relaxed) => plan_both(nodes, &flat, &relaxed, start, lim, work, &budget),
    };
    // The nodes keep the repairs of the plan that was chosen, for the next horizon.
    for (nd, &r) in nodes.iter_mut().zip(&raw) {
        nd.vbar_mm_s = r;
    }
    if let Ok(c) = &chosen {
        for &(i, v) in c.repairs.iter().filter(|(i, _)| *i < c.end_repair_from) {
            nodes[i].vbar_mm_s = nodes[i].vbar_mm_s.min(v);
        }
    }
    chosen.map(|c| BlockPlan { intervals: c.intervals, node_aligned: true, final_before: c.final_before })
}

/// Plans a block under the relaxed ceiling and, unless that plan is clearly faster than a plan
/// under the flat ceiling can be, under that one too; keeps the faster. The relaxed plan may
/// take `1 / RELAXED_BUDGET_SHARE` of `budget`.
fn plan_both(
    nodes: &mut [Node],
    flat: &Ceiling,
    relaxed: &Relaxed,
    start: (f64, f64),
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Result<Planned, Stuck> {
    work.relaxed_tried += 1;
    let relaxed_budget = Budget::after(work, block_budget_units(nodes.len()) / RELAXED_BUDGET_SHARE);
    let free = plan_under(nodes, &relaxed.ceiling, start, lim, work, &relaxed_budget);
    // A plan under the flat ceiling takes about at least the acceleration-only time under it:
    // not strictly (the passes take the acceleration range at the nodes only, and a
    // constant-jerk interval's mean speed is not that of its ends), hence the margin. A
    // relaxed plan clearly below that bound wins anyway.
    let flat_cannot_win = free.as_ref().is_ok_and(|f| f.time_s < (1.0 - FLAT_SKIP_MARGIN) * relaxed.flat_bound_s);
    let under_flat = (!flat_cannot_win).then(|| plan_under(nodes, flat, start, lim, work, budget));
    tracing::debug!(
        s_from_mm = nodes[0].s_mm,
        nodes = nodes.len(),
        acc_only_gain = relaxed.gain,
        flat_ceiling_s = under_flat.as_ref().map_or(f64::NAN, |c| c.as_ref().map_or(f64::NAN, |c| c.time_s)),
        flat_bound_s = relaxed.flat_bound_s,
        relaxed_ceiling_s = free.as_ref().map_or(f64::NAN, |c| c.time_s),
        "block planned under the relaxed ceiling"
    );
    let Some(flat_plan) = under_flat else {
        work.relaxed_kept += 1;
        work.flat_skipped += 1;
        return free;
    };
    let faster = match (&flat_plan, &free) {
        (Ok(a), Ok(b)) => b.time_s < a.time_s,
        (Err(_), Ok(_)) => true,
        (_, Err(_)) => false,
    };
    if faster {
        work.relaxed_kept += 1;
        free
    } else {
        flat_plan
    }
}

/// A ceiling to plan a block under: v̄ per node, and where it is a dip the acceleration-only
/// passes made (`Node::reach_bound`).
struct Ceiling {
    v: Vec<f64>,
    dip: Vec<bool>,
}

/// A block's profile under one ceiling.
struct Planned {
    intervals: Vec<Interval>,
    final_before: usize,
    time_s: f64,
    /// Nodes whose v̄ repairs lowered, and to what.
    repairs: Vec<(usize, f64)>,
    /// The first node a repair forced by the block's end lowered (`forced_by_end`): the plan
    /// is final only before it, and the next plan does not keep that repair or those after.
    end_repair_from: usize,
}

fn plan_under(
    nodes: &mut [Node],
    ceiling: &Ceiling,
    start: (f64, f64),
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Result<Planned, Stuck> {
    for ((nd, &v), &dip) in nodes.iter_mut().zip(&ceiling.v).zip(&ceiling.dip) {
        nd.vbar_mm_s = v;
        nd.reach_bound = dip;
    }
    let result = plan_repaired(nodes, start, lim, work, budget);
    for nd in nodes.iter_mut() {
        nd.reach_bound = false;
    }
    let (intervals, final_before, end_repair_from) = result?;
    let repairs = (0..nodes.len()).filter(|&i| nodes[i].vbar_mm_s < ceiling.v[i]);
    Ok(Planned {
        time_s: intervals.iter().map(|iv| iv.t_s).sum(),
        intervals,
        final_before: final_before.min(end_repair_from),
        end_repair_from,
        repairs: repairs.map(|i| (i, nodes[i].vbar_mm_s)).collect(),
    })
}

/// The relaxed ceiling, with the acceleration-only gain that justifies it and the
/// acceleration-only time under the flat ceiling (about a lower bound of any plan under that
/// one, see `plan_both`).
struct Relaxed {
    ceiling: Ceiling,
    gain: f64,
    flat_bound_s: f64,
}

/// The relaxed ceiling when it pays: only where the acceleration-only profile under it is more
/// than `RELAXED_MIN_GAIN` faster than under the flat one (orientation swings of rotary axes);
/// elsewhere the greedy branches do as well or better under the smoother flat ceiling, at half
/// the work. It cannot be faster by more than the ceilings differ, which is checked first (no
/// passes where they are alike).
fn relaxed_worth_trying(nodes: &[Node], raw: &[f64], flat: &[f64], v_start: f64, lim: &Limits) -> Option<Relaxed> {
    if !raw.iter().zip(flat).any(|(&r, &f)| r > f * (1.0 + RELAXED_MIN_GAIN)) {
        return None;
    }
    let ceiling = relaxed_ceiling(nodes, raw, flat, lim);
    let flat_bound_s = acc_only_time_s(nodes, flat, v_start, lim);
    let gain = flat_bound_s / acc_only_time_s(nodes, &ceiling.v, v_start, lim) - 1.0;
    (gain > RELAXED_MIN_GAIN).then_some(Relaxed { ceiling, gain, flat_bound_s })
}

/// The acceleration-only maximum velocity curve `raw` lowered by the passes of the
/// acceleration-only problem (`reach`), and where that lowering marks a dip. A lowering by
/// less than `PASS_NEGLIGIBLE` is ignored, and none goes below `flat`.
fn relaxed_ceiling(nodes: &[Node], raw: &[f64], flat: &[f64], lim: &Limits) -> Ceiling {
    let mut v = raw.to_vec();
    super::reach::lower_to_reachable(nodes, &mut v, lim);
    let mut dip = vec![false; nodes.len()];
    for i in 0..nodes.len() {
        let lowered = v[i] < raw[i] * (1.0 - PASS_NEGLIGIBLE);
        dip[i] = lowered && v[i] > flat[i];
        v[i] = if lowered { v[i].max(flat[i]) } else { raw[i] };
    }
    Ceiling { v, dip }
}

/// Time of the acceleration-only profile under `ceiling` (a lower bound of any jerk-limited
/// profile under it, up to the passes' discretisation): the passes of `reach`, then Δs over the
/// mean velocity of each interval.
fn acc_only_time_s(nodes: &[Node], ceiling: &[f64], v_start: f64, lim: &Limits) -> f64 {
    let mut v = ceiling.to_vec();
    super::reach::lower_to_reachable(nodes, &mut v, lim);
    v[0] = v_start;
    nodes
        .windows(2)
        .zip(v.windows(2))
        .map(|(n, w)| {
            let mean = 0.5 * (w[0] + w[1]);
            if mean > 0.0 { (n[1].s_mm - n[0].s_mm) / mean } else { 0.0 }
        })
        .sum()
}

/// The envelope and the forward branch, with repairs where the forward branch gets stuck. After
/// a repair the envelope takes over its branches before the lowered nodes, and the forward
/// branch resumes from its last section end before the first node where the block or the
/// envelope changed (`branch::build_envelope`, `forward::forward_branch`). The search ends,
/// stuck where the forward branch last got stuck, after `MAX_REPAIRS` or once `work` has
/// reached `budget`.
fn plan_repaired(
    nodes: &mut [Node],
    start: (f64, f64),
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Result<(Vec<Interval>, usize, usize), Stuck> {
    let mut repairs_at: Vec<(usize, usize)> = Vec::new();
    // The last repair's node and how many nodes before it it lowered.
    let mut last: Option<(usize, usize)> = None;
    // The last envelope, how far the forward branch got on it, and the first node lowered since.
    let mut before: Option<(Envelope, Progress, usize)> = None;
    let mut stuck_last = nodes.len() - 1;
    // The first node a repair forced by the block's end lowered: what lies beyond depends on
    // that end.
    let mut end_repair_from = usize::MAX;
    for _ in 0..=MAX_REPAIRS {
        let previous = before.as_ref().map(|(env, _, from)| Previous { env, from: *from });
        let env = build_envelope(nodes, previous, lim, work, budget).map_err(|s| out_of_work(s, work, budget))?;
        let resume = before.as_ref().map(|(old, progress, from)| (progress, env.first_difference(old).min(*from)));
        let (stuck, progress) = match forward_branch(nodes, &env, start, resume, lim, work, budget) {
            Ok(f) => return Ok((f.intervals, f.final_before, end_repair_from)),
            Err(Failed { stuck, progress }) => (stuck, progress),
        };
        work.repairs += 1;
        stuck_last = stuck.node;
        if gives_up_for_test() {
            break;
        }
        if budget.exhausted(work) {
            tracing::debug!(
                node = stuck.node,
                s_mm = nodes[stuck.node].s_mm,
                units = work.units(),
                "planner: block out of work"
            );
            return Err(out_of_work(stuck, work, budget));
        }
        // Never the block end itself (a stop): lowering there changes nothing, and its zero
        // would spread to the node before it.
        if nodes.len() < 3 {
            return Err(stuck);
        }
        let k = stuck.node.clamp(1, nodes.len() - 2);
        let span = repair_span(last, k);
        let first_at_k = !repairs_at.iter().any(|(n, _)| *n == k);
        let lowered = if first_at_k && above_flat(&nodes[k.saturating_sub(span).max(1)..=k]) {
            // Under the relaxed ceiling a node above its flat v̄ may have no state that keeps
            // the limits with a ≈ 0 (the jerk term A‴v³ alone is at the limit there), and a
            // branch flattening there is stuck. The first repair lowers such nodes to their
            // flat v̄, a state every limit allows, before the factors below (which it does not
            // count).
            tracing::debug!(
                node = k,
                s_mm = nodes[k].s_mm,
                reason = stuck.reason.as_str(),
                "planner repair: v̄ to the flat v̄"
            );
            lower_to_flat(nodes, k, span)
        } else {
            let count = match repairs_at.iter_mut().find(|(n, _)| *n == k) {
                Some((_, c)) => {
                    *c += 1;
                    *c
                }
                None => {
                    repairs_at.push((k, 1));
                    1
                }
            };
            let Some(&factor) = REPAIR_FACTORS.get(count - 1) else {
                return Err(stuck);
            };
            tracing::debug!(
                node = k,
                s_mm = nodes[k].s_mm,
                factor,
                reason = stuck.reason.as_str(),
                "planner repair: lowering v̄"
            );
            lower_before(nodes, k, span, factor)
        };
        last = Some((k, span));
        if forced_by_end(&env, stuck.node) {
            end_repair_from = end_repair_from.min(lowered);
        }
        before = Some((env, progress, lowered));
    }
    Err(Stuck { node: stuck_last, reason: Infeasibility::TooManyRepairs })
}

/// The work budget of a block of `n` nodes.
fn block_budget_units(n: usize) -> u64 {
    let n = n as u64;
    let first = n.min(LONG_BLOCK_NODES) * WORK_UNITS_PER_NODE;
    let further = n.saturating_sub(LONG_BLOCK_NODES).saturating_mul(WORK_UNITS_PER_FURTHER_NODE);
    first.saturating_add(further).max(WORK_UNITS_MIN)
}

/// Work of one round of a block's search per node (a forward pass, a capped run or a backward
/// branch: a step's evaluations, its term evaluations and its ramps' nodes), about the most
/// seen, for the bound below.
const ROUND_UNITS_PER_NODE: u64 = 250;

/// About the most work one plan of a block of `n` nodes takes, found or not: its budget, which
/// a search overshoots by at most one round (the budget is checked between rounds).
pub(super) fn work_bound_units(n: usize) -> u64 {
    block_budget_units(n).saturating_add((n as u64).saturating_mul(ROUND_UNITS_PER_NODE))
}

/// `stuck`, or where the budget ran out, that as the reason.
fn out_of_work(stuck: Stuck, work: &Work, budget: &Budget) -> Stuck {
    if budget.exhausted(work) { Stuck { node: stuck.node, reason: Infeasibility::OutOfWork } } else { stuck }
}

/// Whether a block gives up at its next repair as if the repairs did not converge: never,
/// except in tests, which take the planner's fallback past it (`Planner::force_stop`) on a
/// small program this way.
#[cfg(not(test))]
fn gives_up_for_test() -> bool {
    false
}

#[cfg(test)]
thread_local! {
    /// Blocks that give up at their next repair.
    pub(super) static TEST_GIVE_UPS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
fn gives_up_for_test() -> bool {
    TEST_GIVE_UPS.with(|c| {
        let left = c.get();
        c.set(left.saturating_sub(1));
        left > 0
    })
}

/// How many nodes before the stuck node `k` a repair lowers, given the last repair's node and
/// span: one, a new section end. A branch stuck again just before the last repair (it cannot
/// join the new end either) would creep back one node per replan of the whole block, so each
/// such repair lowers twice as many as the last; one stuck again at the same node keeps the
/// span (its factor falls instead).
fn repair_span(last: Option<(usize, usize)>, k: usize) -> usize {
    match last {
        Some((prev, prev_span)) if k == prev => prev_span,
        Some((prev, prev_span)) if k < prev && prev - k <= prev_span + CREEP_SLACK_NODES => (2 * prev_span).min(k),
        _ => 1,
    }
}

/// Lowers v̄ at nodes `k − span ..= k` (never node 0, the block's start state) to `factor` times
/// their lowest v̄ (node 0's included, as a section end right after the start must not be
/// faster than the start allows). Returns the first node it may have lowered.
pub(super) fn lower_before(nodes: &mut [Node], k: usize, span: usize, factor: f64) -> usize {
    let from = k.saturating_sub(span);
    let base = nodes[from..=k].iter().map(|nd| nd.vbar_mm_s).fold(f64::INFINITY, f64::min);
    for nd in &mut nodes[from.max(1)..=k] {
        nd.vbar_mm_s = nd.vbar_mm_s.min(factor * base);
    }
    from.max(1)
}

/// Whether any of `nodes` lies above its flat v̄ (Kopp et al. 2019, eq. 6) by more than
/// `FLAT_REPAIR_MARGIN`: only under the relaxed ceiling.
fn above_flat(nodes: &[Node]) -> bool {
    nodes.iter().any(|nd| nd.vbar_mm_s > nd.vbar_flat_mm_s * (1.0 + FLAT_REPAIR_MARGIN))
}

/// Lowers v̄ at nodes `k − span ..= k` (never node 0) to their flat v̄. Returns the first node
/// it may have lowered.
fn lower_to_flat(nodes: &mut [Node], k: usize, span: usize) -> usize {
    let from = k.saturating_sub(span).max(1);
    for nd in &mut nodes[from..=k] {
        nd.vbar_mm_s = nd.vbar_mm_s.min(nd.vbar_flat_mm_s);
    }
    from
}

/// Whether the forward branch stuck at node `stuck` got stuck on the branch from the block's
/// end: the first branch after it is that one. A repair there is forced by where the block
/// ends, which for a chunk or a horizon is not a real stop.
fn forced_by_end(env: &Envelope, stuck: usize) -> bool {
    (stuck + 1..env.len()).map(|i| env.curve[i]).find(|&c| c != 0) == Some(END_CURVE)
}

/// Relative tolerance for "the same direction" along a straight block (as for a smooth joint,
/// `path::TANGENT_ANGLE_TOL_RAD`).
const STRAIGHT_REL_TOL: f64 = 1e-9;

/// A block that is one straight line with one feed, from rest to rest: its time-optimal
/// profile (see `scurve`). `None` for any other block.
fn straight_move(nodes: &[Node], lim: &Limits) -> Option<Vec<Interval>> {
    let n = nodes.len();
    if n < 2 {
        return None;
    }
    let d1 = nodes[0].right.d1;
    let scale = d1[..lim.n_axes].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if scale == 0.0 {
        return None;
    }
    let same = |g: &super::node::NodeGeom| {
        (0..lim.n_axes).all(|k| (g.d1[k] - d1[k]).abs() <= STRAIGHT_REL_TOL * scale && g.d2[k] == 0.0 && g.d3[k] == 0.0)
    };
    let feed = nodes[0].feed_mm_s;
    for (i, node) in nodes.iter().enumerate() {
        let left_ok = i == 0 || same(&node.left);
        let right_ok = i == n - 1 || same(&node.right);
        if !(left_ok && right_ok) || (i + 1 < n && node.feed_mm_s != feed) {
            return None;
        }
    }
    // Path limits along the line: each axis moves d1_k per unit of path.
    let (mut v, mut a, mut j) = (feed, f64::INFINITY, f64::INFINITY);
    for (k, d) in d1.iter().enumerate().take(lim.n_axes) {
        let c = d.abs();
        if c > 0.0 {
            v = v.min(lim.vel[k] / c);
            a = a.min(lim.acc_max[k].min(-lim.acc_min[k]) / c);
            j = j.min(lim.jerk[k] / c);
        }
    }
    let length = nodes[n - 1].s_mm - nodes[0].s_mm;
    (length > 0.0 && v > 0.0 && v.is_finite()).then(|| super::scurve::rest_to_rest(length, v, a, j))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repair_creeping_back_widens_and_a_distant_one_starts_over() {
        let mut last = None;
        let mut spans = Vec::new();
        // Stuck again one or two nodes before each repair: 1, 2, 4, 8 nodes lowered.
        for k in [900, 899, 897, 893] {
            let span = repair_span(last, k);
            spans.push(span);
            last = Some((k, span));
        }
        assert_eq!(spans, [1, 2, 4, 8]);
        // The same node again keeps the span; one far before (another dip) starts over.
        assert_eq!(repair_span(last, 893), 8);
        assert_eq!(repair_span(last, 500), 1);
        // Never past the block start.
        assert_eq!(repair_span(Some((6, 8)), 5), 5);
    }

    #[test]
    fn lowering_spares_the_start_node_but_respects_its_bound() {
        let mut nodes: Vec<Node> = (0..6).map(|i| Node::for_test(i as f64, Default::default(), 100.0)).collect();
        (nodes[0].vbar_mm_s, nodes[0].stop) = (0.0, true);
        lower_before(&mut nodes, 4, 2, 0.9);
        let v: Vec<f64> = nodes.iter().map(|n| n.vbar_mm_s).collect();
        assert_eq!(v, [0.0, 100.0, 90.0, 90.0, 90.0, 100.0]);
        lower_before(&mut nodes, 1, 1, 0.9);
        assert_eq!(nodes[1].vbar_mm_s, 0.0, "a section end right after a stop is at rest too");
        assert_eq!(nodes[0].vbar_mm_s, 0.0);
    }
}
