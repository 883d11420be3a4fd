//! The forward branch and its joins onto the backward branches (seed 001 §3.3).
//!
//! The forward branch runs free from its anchor (the block start, or the end of the last
//! backward branch it followed): greedy steps under v̄ that only need to be able to flatten.
//! Where it would cross a backward branch it joins it exactly (two intervals whose middle
//! velocity makes the second end on the branch's state) and follows the branch's stored
//! intervals to that branch's section end. A crossing on a steep part of both branches has no
//! join within the jerk limits; then both are capped at a common velocity v_c — the highest
//! for which they meet flat — and recomputed between the anchor and the section end. This is
//! seed 001's "lower the faster branch locally", done once by bisection instead of by
//! repeated recomputation, so the work per section is bounded.

use super::branch::{Stuck, backward_branch, greedy_step};
use super::envelope::{END_CURVE, Envelope};
use super::interval::Interval;
use super::join::join_two;
use super::limits::Limits;
use super::node::Node;
use super::ramp::FlattenUnder;
use super::step::Work;
use super::view::View;

/// The cap search first steps down from the highest bound towards the lowest possible cap
/// (the anchor's or the section end's velocity), shrinking the gap by this factor per try...
const CAP_DESCENT_FACTOR: f64 = 0.85;
/// ... at most this many times (down to about 1e-4 of it).
const CAP_DESCENT_STEPS: usize = 60;
/// Bisection steps when searching the cap v_c.
const CAP_SEARCH_ITERS: usize = 30;
/// The cap search stops when the bracket is this narrow relative to v_c.
const CAP_SEARCH_REL_TOL: f64 = 1e-6;
/// A forward state exceeding the branch by less than this (relative) is on it.
const ON_BRANCH_REL_TOL: f64 = 1e-9;

/// The forward branch's intervals, and the first node whose state depends on where the
/// block ends (on the backward branch from its end): a horizon can hand over the profile up
/// to that node and no further.
pub struct ForwardPlan {
    pub intervals: Vec<Interval>,
    pub final_before: usize,
}

/// A profile piece being built: states per node from `first` on, and the intervals between.
struct Run {
    first: usize,
    states: Vec<(f64, f64)>,
    intervals: Vec<Interval>,
}

impl Run {
    fn new(first: usize, state: (f64, f64)) -> Self {
        Self { first, states: vec![state], intervals: Vec::new() }
    }

    fn last(&self) -> usize {
        self.first + self.intervals.len()
    }

    fn state(&self, node: usize) -> (f64, f64) {
        self.states[node - self.first]
    }

    fn push(&mut self, iv: Interval) {
        self.states.push((iv.v1(), iv.a1()));
        self.intervals.push(iv);
    }

    /// Drops everything after `node`.
    fn truncate(&mut self, node: usize) {
        self.states.truncate(node - self.first + 1);
        self.intervals.truncate(node - self.first);
    }
}

/// The forward branch over a block from `start` = (v, a) at node 0 to rest at the last node.
pub fn forward_branch(
    nodes: &[Node],
    env: &Envelope,
    start: (f64, f64),
    lim: &Limits,
    work: &mut Work,
) -> Result<ForwardPlan, Stuck> {
    let n = nodes.len();
    let view = View::forward(nodes);
    let free = FlattenUnder { view, cap: f64::INFINITY };
    let mut run = Run::new(0, start);
    let mut anchor = 0;
    let mut final_before = n - 1;
    while run.last() + 1 < n {
        let t = run.last();
        let (v, a) = run.state(t);
        let step = greedy_step(&view, t, v, a, nodes[t + 1].vbar_mm_s, &free, lim, work);
        let crosses = match &step {
            Some(iv) => env.on_curve(t + 1) && iv.v1() > env.v[t + 1] * (1.0 + ON_BRANCH_REL_TOL),
            None => true,
        };
        if !crosses {
            run.push(step.expect("not crossing implies a step"));
            continue;
        }
        // The branch crossed (or the next one ahead, if the free run got stuck before it).
        let Some(c) = (t + 1..n).map(|i| env.curve[i]).find(|&c| c != 0) else {
            return Err(Stuck { node: t, reason: "no feasible and viable next velocity" });
        };
        let section_end = env.starts[c as usize].node;
        let joined = direct_join(&view, &run, t, anchor, env, c, lim, work)
            .map(|(from, i1, i2)| {
                if c == END_CURVE {
                    final_before = final_before.min(from);
                }
                run.truncate(from);
                run.push(i1);
                run.push(i2);
            })
            .or_else(|| {
                let capped = capped_section(nodes, &run, anchor, env, c, lim, work)?;
                if c == END_CURVE {
                    final_before = final_before.min(anchor);
                }
                run.truncate(anchor);
                for iv in capped {
                    run.push(iv);
                }
                Some(())
            });
        if joined.is_none() {
            return Err(Stuck { node: t, reason: "the forward branch cannot join the backward branch" });
        }
        // Follow the branch to its section end.
        while run.last() < section_end {
            let i = run.last();
            if env.curve[i] != c {
                break; // a capped section already ends there
            }
            run.push(env.iv[i]);
        }
        anchor = run.last();
    }
    let (v, a) = run.state(n - 1);
    if v.abs() > 1e-6 || a.abs() > 1e-3 {
        return Err(Stuck { node: n - 1, reason: "the forward branch did not come to rest at the block end" });
    }
    Ok(ForwardPlan { intervals: run.intervals, final_before })
}

/// Exact joins onto branch `c` near node t: from the forward state at `from` onto the
/// branch's state at `from + 2`, for the nodes around the crossing.
#[allow(clippy::too_many_arguments)]
fn direct_join(
    view: &View,
    run: &Run,
    t: usize,
    anchor: usize,
    env: &Envelope,
    c: u32,
    lim: &Limits,
    work: &mut Work,
) -> Option<(usize, Interval, Interval)> {
    let lo = anchor.max(run.first).max(t.saturating_sub(2));
    for from in (lo..=t).rev() {
        let to = from + 2;
        if to >= env.len() || env.curve[to] != c {
            continue;
        }
        let (v, a) = run.state(from);
        if let Some((i1, i2)) = join_two(view, from, v, a, (env.v[to], env.a[to]), lim, work) {
            work.joins += 1;
            return Some((from, i1, i2));
        }
    }
    None
}

/// Forward and backward branch capped at the highest common velocity v_c for which they meet
/// flat, between the anchor and the section end of branch `c`: the intervals from the anchor
/// to the section end.
fn capped_section(
    nodes: &[Node],
    run: &Run,
    anchor: usize,
    env: &Envelope,
    c: u32,
    lim: &Limits,
    work: &mut Work,
) -> Option<Vec<Interval>> {
    let start = env.starts[c as usize];
    let (va, _) = run.state(anchor);
    let lo = va.max(start.v);
    let hi = (anchor..=start.node).map(|i| nodes[i].vbar_mm_s).fold(0.0, f64::max).max(lo);
    let try_cap = |cap: f64, work: &mut Work| {
        capped_run(nodes, run.state(anchor), anchor, start.node, (start.v, start.a), cap, lim, work)
    };
    // Caps descending from the top until one works; then bisection between it and the last
    // that failed. (Very low caps fail too near rest: nothing can flatten under them.)
    let mut hi_bad = hi;
    let mut best = None;
    let mut gap = hi - lo;
    for _ in 0..CAP_DESCENT_STEPS {
        gap *= CAP_DESCENT_FACTOR;
        let cap = lo + gap;
        if cap <= lo * (1.0 + 1e-12) {
            break;
        }
        if let Some(p) = try_cap(cap, work) {
            best = Some((cap, p));
            break;
        }
        hi_bad = cap;
    }
    let (mut lo_ok, mut profile) = best?;
    for _ in 0..CAP_SEARCH_ITERS {
        if hi_bad - lo_ok <= CAP_SEARCH_REL_TOL * hi_bad {
            break;
        }
        let cap = 0.5 * (lo_ok + hi_bad);
        match try_cap(cap, work) {
            Some(p) => {
                lo_ok = cap;
                profile = p;
            }
            None => hi_bad = cap,
        }
    }
    tracing::trace!(anchor, section_end = start.node, cap = lo_ok, "capped section");
    Some(profile)
}

/// Forward from `anchor` with state `fwd`, backward from `end` with state `bwd`, both under
/// v̄ capped at `cap`; joined exactly where the forward one reaches the backward one.
#[allow(clippy::too_many_arguments)]
fn capped_run(
    nodes: &[Node],
    fwd: (f64, f64),
    anchor: usize,
    end: usize,
    bwd: (f64, f64),
    cap: f64,
    lim: &Limits,
    work: &mut Work,
) -> Option<Vec<Interval>> {
    let Some(branch) = backward_branch(nodes, end, bwd.0, bwd.1, cap, anchor, |_, _| false, lim, work) else {
        tracing::trace!(cap, anchor, end, "capped run: backward branch stuck");
        return None;
    };
    // Backward states per node from the branch's leftmost node to `end`; left of it the
    // branch has flattened at the cap (or v̄).
    let left = branch.last().map_or(end, |b| b.0);
    let mut bv = vec![f64::INFINITY; end + 1];
    let mut ba = vec![0.0; end + 1];
    let mut biv = vec![Interval::default(); end + 1];
    bv[end] = bwd.0;
    ba[end] = bwd.1;
    for &(i, v, a, iv) in &branch {
        bv[i] = v;
        ba[i] = a;
        biv[i] = iv;
    }
    let view = View::forward(nodes);
    let ceiling = FlattenUnder { view, cap };
    let mut run = Run::new(anchor, fwd);
    while run.last() < end {
        let t = run.last();
        let (v, a) = run.state(t);
        let v_max = nodes[t + 1].vbar_mm_s.min(cap).min(bv[t + 1]);
        let step = greedy_step(&view, t, v, a, v_max, &ceiling, lim, work);
        let reached = step.as_ref().is_none_or(|iv| t + 1 >= left && iv.v1() >= bv[t + 1] * (1.0 - ON_BRANCH_REL_TOL));
        if !reached {
            run.push(step.expect("a step when not reached"));
            continue;
        }
        // Join onto the backward branch at t+1 or t+2 from t or t−1.
        let mut joined = None;
        for from in [t, t.saturating_sub(1).max(anchor)] {
            let to = from + 2;
            if to > end || to < left {
                continue;
            }
            let (v, a) = run.state(from);
            if let Some(j) = join_two(&view, from, v, a, (bv[to], ba[to]), lim, work) {
                joined = Some((from, j));
                break;
            }
        }
        let Some((from, (i1, i2))) = joined else {
            tracing::trace!(cap, t, left, v, a, bv = bv[t + 1], ba = ba[t + 1], step = ?step.map(|iv| (iv.v1(), iv.a1())), "capped run: no join");
            return None;
        };
        run.truncate(from);
        run.push(i1);
        run.push(i2);
        while run.last() < end {
            let i = run.last();
            run.push(biv[i]);
        }
        work.joins += 1;
        return Some(run.intervals);
    }
    tracing::trace!(cap, anchor, end, "capped run: forward reached the end without meeting");
    None
}
