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

use super::branch::Stuck;
use super::interval::Interval;
use super::limits::Limits;
use super::node::Node;
use super::repair::{Found, Repairs};
use super::step::{Budget, Work};

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
/// (`Phase::Relaxed`): the plan under the flat ceiling, the fallback, keeps the rest.
const RELAXED_BUDGET_SHARE: u64 = 2;
/// A ceiling the acceleration-only passes lower by less than this share stays as it is.
const PASS_NEGLIGIBLE: f64 = 1e-3;
/// The relaxed ceiling is tried when the acceleration-only profile under it is at least this
/// much faster than under the flat one.
const RELAXED_MIN_GAIN: f64 = 0.02;
/// A relaxed plan this much faster than the acceleration-only time under the flat ceiling is
/// kept without planning under that ceiling.
const FLAT_SKIP_MARGIN: f64 = 0.02;

/// The profile of a block and the first node whose state depends on where the block ends.
#[derive(Debug, Clone)]
pub(super) struct BlockPlan {
    pub intervals: Vec<Interval>,
    /// `intervals[k]` runs from node k to node k+1; otherwise the intervals are a time-domain
    /// profile from the first node to the last (a closed-form straight move).
    pub node_aligned: bool,
    pub final_before: usize,
}

/// Plans `nodes` (first node: given state `start`; last node: rest) in one go. `end_is_stop`
/// tells whether the last node is a real stop (and not just where the horizon ends). Adds the
/// work it took to `work`, also where it finds no profile.
#[cfg(test)]
pub(super) fn plan_block(
    nodes: &mut [Node],
    start: (f64, f64),
    end_is_stop: bool,
    lim: &Limits,
    work: &mut Work,
) -> Result<BlockPlan, Stuck> {
    let mut search = BlockSearch::new(nodes, start, end_is_stop, lim);
    let plan = search.run(nodes, lim, u64::MAX).expect("a search without a pause ends");
    work.add(&search.work);
    plan
}

/// The search for one block's profile, which a planning call may pause between two rounds
/// ([`BlockSearch::run`]) and the next call resumes: `nodes` must then be the same slice,
/// unchanged in between.
///
/// A block is planned under the flat ceiling, or, where the acceleration-only profile says the
/// relaxed one gains more than `RELAXED_MIN_GAIN`, under the relaxed one first, and under the
/// flat one too unless the relaxed plan is clearly below the acceleration-only time under it
/// (which a plan under that ceiling can undercut only by the passes' discretisation error);
/// the faster plan is kept. During the search the nodes hold the v̄ of the ceiling searched
/// under, lowered by its repairs; at its end they get their own v̄ back, lowered by the
/// repairs of the plan kept, for the next horizon.
pub(super) struct BlockSearch {
    start: (f64, f64),
    /// The nodes' own v̄.
    raw: Vec<f64>,
    /// The flat ceiling: v̄ with a = j = 0 (Kopp et al. 2019, eq. 6), every state (v̄, 0, 0)
    /// keeping the limits.
    flat: Ceiling,
    /// The block's whole budget.
    budget: Budget,
    phase: Phase,
    /// The work the search took so far, also where it finds no profile.
    pub work: Work,
}

enum Phase {
    /// A straight line between two stops: its closed-form S-curve.
    Straight(Vec<Interval>),
    /// Under the relaxed ceiling, with its share of the budget.
    Relaxed { relaxed: Relaxed, repairs: Repairs, budget: Budget },
    /// Under the flat ceiling, after the plan under the relaxed one where there is one.
    Flat { repairs: Repairs, free: Option<(Relaxed, Result<Planned, Stuck>)> },
}

impl BlockSearch {
    pub(super) fn new(nodes: &mut [Node], start: (f64, f64), end_is_stop: bool, lim: &Limits) -> Self {
        let raw: Vec<f64> = nodes.iter().map(|nd| nd.vbar_mm_s).collect();
        let flat = Ceiling {
            v: nodes.iter().zip(&raw).map(|(nd, &r)| nd.vbar_flat_mm_s.min(r)).collect(),
            dip: vec![false; nodes.len()],
        };
        let work = Work::default();
        let budget = Budget::after(&work, block_budget_units(nodes.len()));
        let straight = (end_is_stop && start == (0.0, 0.0)).then(|| straight_move(nodes, lim)).flatten();
        let phase = match straight {
            Some(intervals) => Phase::Straight(intervals),
            None => match relaxed_worth_trying(nodes, &raw, &flat.v, start.0, lim) {
                None => {
                    enter(nodes, &flat);
                    Phase::Flat { repairs: Repairs::default(), free: None }
                }
                Some(relaxed) => {
                    enter(nodes, &relaxed.ceiling);
                    let budget = Budget::after(&work, block_budget_units(nodes.len()) / RELAXED_BUDGET_SHARE);
                    Phase::Relaxed { relaxed, repairs: Repairs::default(), budget }
                }
            },
        };
        let mut search = Self { start, raw, flat, budget, phase, work };
        if let Phase::Relaxed { .. } = search.phase {
            search.work.relaxed_tried += 1;
        }
        search
    }

    /// Searches on until the block's plan is found or the block is stuck (`Some`), or, after
    /// at least one round, once this run has taken `pause_after_units` of work (`None`: run
    /// again on the same nodes to go on).
    pub(super) fn run(
        &mut self,
        nodes: &mut [Node],
        lim: &Limits,
        pause_after_units: u64,
    ) -> Option<Result<BlockPlan, Stuck>> {
        let pause = Budget::after(&self.work, pause_after_units);
        loop {
            match &mut self.phase {
                Phase::Straight(intervals) => {
                    let intervals = std::mem::take(intervals);
                    return Some(Ok(BlockPlan { intervals, node_aligned: false, final_before: nodes.len() - 1 }));
                }
                Phase::Relaxed { relaxed, repairs, budget } => {
                    let found = repairs.run(nodes, self.start, lim, &mut self.work, budget, &pause)?;
                    let free = leave(nodes, &relaxed.ceiling, found);
                    // A plan under the flat ceiling takes about at least the acceleration-only
                    // time under it: not strictly (the passes take the acceleration range at the
                    // nodes only, and a constant-jerk interval's mean speed is not that of its
                    // ends), hence the margin. A relaxed plan clearly below that bound wins
                    // anyway.
                    let flat_cannot_win =
                        free.as_ref().is_ok_and(|f| f.time_s < (1.0 - FLAT_SKIP_MARGIN) * relaxed.flat_bound_s);
                    if flat_cannot_win {
                        self.work.relaxed_kept += 1;
                        self.work.flat_skipped += 1;
                        return Some(self.finish(nodes, free));
                    }
                    let relaxed = std::mem::take(relaxed);
                    enter(nodes, &self.flat);
                    self.phase = Phase::Flat { repairs: Repairs::default(), free: Some((relaxed, free)) };
                }
                Phase::Flat { repairs, free } => {
                    let found = repairs.run(nodes, self.start, lim, &mut self.work, &self.budget, &pause)?;
                    let flat_plan = leave(nodes, &self.flat, found);
                    let Some((relaxed, free)) = free.take() else {
                        return Some(self.finish(nodes, flat_plan));
                    };
                    tracing::debug!(
                        s_from_mm = nodes[0].s_mm,
                        nodes = nodes.len(),
                        acc_only_gain = relaxed.gain,
                        flat_ceiling_s = flat_plan.as_ref().map_or(f64::NAN, |c| c.time_s),
                        flat_bound_s = relaxed.flat_bound_s,
                        relaxed_ceiling_s = free.as_ref().map_or(f64::NAN, |c| c.time_s),
                        "block planned under the relaxed ceiling"
                    );
                    let faster = match (&flat_plan, &free) {
                        (Ok(a), Ok(b)) => b.time_s < a.time_s,
                        (Err(_), Ok(_)) => true,
                        (_, Err(_)) => false,
                    };
                    if faster {
                        self.work.relaxed_kept += 1;
                        return Some(self.finish(nodes, free));
                    }
                    return Some(self.finish(nodes, flat_plan));
                }
            }
        }
    }

    /// The nodes get their own v̄ back, lowered by the repairs of the plan kept (for the next
    /// horizon), and the plan becomes the block's.
    fn finish(&self, nodes: &mut [Node], chosen: Result<Planned, Stuck>) -> Result<BlockPlan, Stuck> {
        for (nd, &r) in nodes.iter_mut().zip(&self.raw) {
            nd.vbar_mm_s = r;
        }
        if let Ok(c) = &chosen {
            for &(i, v) in c.repairs.iter().filter(|(i, _)| *i < c.end_repair_from) {
                nodes[i].vbar_mm_s = nodes[i].vbar_mm_s.min(v);
            }
        }
        chosen.map(|c| BlockPlan { intervals: c.intervals, node_aligned: true, final_before: c.final_before })
    }
}

/// A ceiling to plan a block under: v̄ per node, and where it is a dip the acceleration-only
/// passes made (`Node::reach_bound`).
#[derive(Default)]
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
    /// See [`Found::end_repair_from`].
    end_repair_from: usize,
}

/// The nodes take `ceiling` for a search under it.
fn enter(nodes: &mut [Node], ceiling: &Ceiling) {
    for ((nd, &v), &dip) in nodes.iter_mut().zip(&ceiling.v).zip(&ceiling.dip) {
        nd.vbar_mm_s = v;
        nd.reach_bound = dip;
    }
}

/// The end of a search under `ceiling`: its plan, with the nodes its repairs lowered.
fn leave(nodes: &mut [Node], ceiling: &Ceiling, found: Result<Found, Stuck>) -> Result<Planned, Stuck> {
    for nd in nodes.iter_mut() {
        nd.reach_bound = false;
    }
    let Found { intervals, final_before, end_repair_from } = found?;
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
#[derive(Default)]
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

/// The work budget of a block of `n` nodes.
fn block_budget_units(n: usize) -> u64 {
    let n = n as u64;
    let first = n.min(LONG_BLOCK_NODES) * WORK_UNITS_PER_NODE;
    let further = n.saturating_sub(LONG_BLOCK_NODES).saturating_mul(WORK_UNITS_PER_FURTHER_NODE);
    first.saturating_add(further).max(WORK_UNITS_MIN)
}

/// Work of one round of a block's search per node (a forward pass, a capped run or a backward
/// branch: a step's evaluations, its term evaluations and its ramps' nodes), about the most
/// seen on the examples and the family's snippets, for the bounds below. The first rounds of
/// chunks of the 300 000-move cusp trochoid take up to about 700 per node (ramps over nodes a
/// few µm apart): there a round, not the call's work, bounds a call.
const ROUND_UNITS_PER_NODE: u64 = 250;

/// About the most work one plan of a block of `n` nodes takes, found or not: its budget, which
/// a search overshoots by at most one round (the budget is checked between rounds).
pub(super) fn work_bound_units(n: usize) -> u64 {
    block_budget_units(n).saturating_add(round_bound_units(n))
}

/// About the most work one round of the search of a block of `n` nodes takes: what a planning
/// call may take past `CALL_WORK_UNITS` before it pauses the search.
pub(super) fn round_bound_units(n: usize) -> u64 {
    (n as u64).saturating_mul(ROUND_UNITS_PER_NODE)
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
