//! The search of one block under one ceiling: the envelope and the forward branch, with
//! repairs where the forward branch gets stuck (the velocity bound lowered there, a new
//! section end), a bounded number of times. A planning call may pause the search between two
//! rounds and the next call resumes it: the rounds run in the same order on the same state,
//! so the profile does not depend on where calls end.

use super::branch::{Previous, Stuck, build_envelope};
use super::envelope::{END_CURVE, Envelope};
use super::error::Infeasibility;
use super::forward::{Failed, Halted, PausedRun, Progress, forward_on, forward_pausable};
use super::interval::Interval;
use super::limits::Limits;
use super::node::Node;
use super::step::{Budget, Work};

/// Repairs per block before the block is reported as infeasible.
pub(super) const MAX_REPAIRS: usize = 64;
/// A repair up to this many nodes (beyond the last one's span) before the last repair counts
/// as the branch creeping back from it.
const CREEP_SLACK_NODES: usize = 2;
/// A node's v̄ this much (relative) above its flat v̄ is lowered to that first
/// (`above_flat`).
const FLAT_REPAIR_MARGIN: f64 = 1e-3;
/// Factors applied to the stuck node's velocity, in order, when repairing there again.
const REPAIR_FACTORS: [f64; 5] = [0.9, 0.7, 0.4, 0.1, 0.0];

/// A block's profile found by the search: its intervals node to node, the first node whose
/// state depends on where the block ends (`ForwardPlan::final_before`), and the first node a
/// repair forced by the block's end lowered (`forced_by_end`): the plan is final only before
/// it, and the next plan does not keep that repair or those after.
pub(super) struct Found {
    pub intervals: Vec<Interval>,
    pub final_before: usize,
    pub end_repair_from: usize,
}

/// Where a search stands between two rounds: everything its next round needs.
#[derive(Default)]
pub(super) struct Repairs {
    /// Rounds run (a round builds the envelope and runs the forward branch).
    rounds: usize,
    /// Nodes repaired by a factor, and how often.
    repairs_at: Vec<(usize, usize)>,
    /// The last repair's node and how many nodes before it it lowered.
    last: Option<(usize, usize)>,
    /// The last envelope, how far the forward branch got on it, and the first and last node
    /// lowered since.
    before: Option<(Envelope, Progress, (usize, usize))>,
    /// Where the forward branch last got stuck.
    stuck_last: Option<usize>,
    /// See [`Found::end_repair_from`].
    end_repair_from: Option<usize>,
    /// The round's envelope and its forward branch, paused at a section end.
    paused: Option<(Envelope, Box<PausedRun>)>,
}

/// How a round ended.
enum Round {
    /// The search ended: the profile, or stuck.
    Ended(Result<Found, Stuck>),
    /// Its forward branch paused (`Repairs::paused`).
    Paused,
    /// It repaired where the forward branch got stuck: the next round goes on.
    Repaired,
}

impl Repairs {
    /// Runs rounds until the search ends (`Some`: the profile, or stuck where the forward
    /// branch last got stuck, after `MAX_REPAIRS` or once `work` has reached `budget`) or
    /// `work` has reached `pause` (`None`: call again to go on): at the end of a round after
    /// the first, or where the forward branch joins a section end (it joins at least one per
    /// run, so every run gets on).
    ///
    /// After a repair the envelope takes over its branches before the lowered nodes, and the
    /// forward branch resumes from its last section end before the first node where the block
    /// or the envelope changed (`branch::build_envelope`, `forward::forward_branch`).
    pub(super) fn run(
        &mut self,
        nodes: &mut [Node],
        start: (f64, f64),
        lim: &Limits,
        work: &mut Work,
        budget: &Budget,
        pause: &Budget,
    ) -> Option<Result<Found, Stuck>> {
        let mut ran = false;
        loop {
            if self.paused.is_none() {
                if self.rounds > MAX_REPAIRS {
                    let node = self.stuck_last.unwrap_or(nodes.len() - 1);
                    return Some(Err(Stuck { node, reason: Infeasibility::TooManyRepairs }));
                }
                if ran && pause.exhausted(work) {
                    return None;
                }
                self.rounds += 1;
            }
            ran = true;
            match self.round(nodes, start, lim, work, budget, pause) {
                Round::Ended(end) => return Some(end),
                Round::Paused => return None,
                Round::Repaired => {}
            }
        }
    }

    /// One round, or the rest of a paused one: the envelope, the forward branch, and where it
    /// gets stuck, a repair.
    fn round(
        &mut self,
        nodes: &mut [Node],
        start: (f64, f64),
        lim: &Limits,
        work: &mut Work,
        budget: &Budget,
        pause: &Budget,
    ) -> Round {
        let (env, forward) = match self.paused.take() {
            Some((env, paused)) => {
                let forward = forward_on(nodes, &env, paused, lim, work, budget, pause);
                (env, forward)
            }
            None => {
                let previous = self.before.as_ref().map(|(env, _, (from, to))| Previous { env, from: *from, to: *to });
                let env = match build_envelope(nodes, previous, lim, work, budget) {
                    Ok(env) => env,
                    Err(s) => return Round::Ended(Err(out_of_work(s, work, budget))),
                };
                #[cfg(test)]
                if self.before.is_some() {
                    check_against_a_full_build(nodes, &env, lim, budget);
                }
                let resume = self
                    .before
                    .as_ref()
                    .map(|(old, progress, (from, _))| (progress, env.first_difference(old).min(*from)));
                let forward = forward_pausable(nodes, &env, start, resume, lim, work, budget, pause);
                (env, forward)
            }
        };
        let (stuck, progress) = match forward {
            Ok(f) => {
                let end_repair_from = self.end_repair_from.unwrap_or(usize::MAX);
                return Round::Ended(Ok(Found {
                    intervals: f.intervals,
                    final_before: f.final_before,
                    end_repair_from,
                }));
            }
            Err(Halted::Paused(paused)) => {
                self.paused = Some((env, paused));
                return Round::Paused;
            }
            Err(Halted::Stuck(Failed { stuck, progress })) => (stuck, progress),
        };
        work.repairs += 1;
        self.stuck_last = Some(stuck.node);
        if gives_up_for_test() {
            return Round::Ended(Err(Stuck { node: stuck.node, reason: Infeasibility::TooManyRepairs }));
        }
        if budget.exhausted(work) {
            tracing::debug!(
                node = stuck.node,
                s_mm = nodes[stuck.node].s_mm,
                units = work.units(),
                "planner: block out of work"
            );
            return Round::Ended(Err(out_of_work(stuck, work, budget)));
        }
        // Never the block end itself (a stop): lowering there changes nothing, and its zero
        // would spread to the node before it.
        if nodes.len() < 3 {
            return Round::Ended(Err(stuck));
        }
        let k = stuck.node.clamp(1, nodes.len() - 2);
        let span = repair_span(self.last, k);
        let first_at_k = !self.repairs_at.iter().any(|(n, _)| *n == k);
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
            let count = match self.repairs_at.iter_mut().find(|(n, _)| *n == k) {
                Some((_, c)) => {
                    *c += 1;
                    *c
                }
                None => {
                    self.repairs_at.push((k, 1));
                    1
                }
            };
            let Some(&factor) = REPAIR_FACTORS.get(count - 1) else {
                return Round::Ended(Err(stuck));
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
        self.last = Some((k, span));
        if forced_by_end(&env, stuck.node) {
            self.end_repair_from = Some(self.end_repair_from.map_or(lowered, |f| f.min(lowered)));
        }
        self.before = Some((env, progress, (lowered, k)));
        Round::Repaired
    }
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

#[cfg(test)]
thread_local! {
    /// Envelopes rebuilt after a repair so far, each compared with a full build.
    pub(super) static TEST_REBUILDS_CHECKED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// In tests, every envelope rebuilt after a repair is the one a full build makes.
#[cfg(test)]
fn check_against_a_full_build(nodes: &[Node], env: &Envelope, lim: &Limits, budget: &Budget) {
    let full = build_envelope(nodes, None, lim, &mut Work::default(), budget).expect("a full build");
    let at = env.first_difference(&full);
    assert!(at == env.len() && env.starts == full.starts, "rebuilt envelope differs at node {at}");
    TEST_REBUILDS_CHECKED.with(|c| c.set(c.get() + 1));
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
