//! The forward branch and its joins onto the backward branches (Kopp et al. 2019, §3.3).
//!
//! The forward branch runs free from its anchor (the block start, or the end of the last
//! backward branch it followed): greedy steps under v̄ that only need to be able to flatten.
//! Where it would cross a backward branch it joins it exactly (two intervals whose middle
//! velocity makes the second end on the branch's state) and follows the branch's stored
//! intervals to that branch's section end. A crossing on a steep part of both branches has no
//! join within the jerk limits; then both are capped at a common velocity v_c — the highest
//! for which they meet flat — and recomputed between the anchor and the section end. This is
//! the paper's "lower the faster branch locally" (§3.3), done once by bisection instead of by
//! repeated recomputation, so the work per section is bounded.

use super::branch::{MAX_BACK_OFFS_PER_BRANCH, Ramps, Stuck, backward_branch, greedy_step};
use super::envelope::{END_CURVE, Envelope};
use super::error::Infeasibility;
use super::interval::Interval;
use super::join::{join_three, join_two};
use super::limits::Limits;
use super::node::Node;
use super::ramp::{Check, FlattenUnder, ramp_interval};
use super::step::{Budget, Work};
use super::view::View;

/// The cap search first steps down from the highest bound towards the lowest possible cap
/// (the anchor's or the section end's velocity), shrinking the gap by this factor per try...
/// (a slower descent costs many capped runs in a section where every cap fails, and finds no
/// better cap than the bisection after it).
const CAP_DESCENT_FACTOR: f64 = 0.6;
/// ... at most this many times (down to about 1e-4 of it).
const CAP_DESCENT_STEPS: usize = 60;
/// Bisection steps when searching the cap v_c.
const CAP_SEARCH_ITERS: usize = 30;
/// The cap search stops when the bracket is this narrow relative to v_c.
const CAP_SEARCH_REL_TOL: f64 = 1e-4;
/// A state this close to v = 0 and a = 0 is at rest (a block's end, a kept stop).
pub(super) const REST_V_TOL_MM_S: f64 = 1e-6;
pub(super) const REST_A_TOL_MM_S2: f64 = 1e-3;
/// Bisection steps on the jerk blend of a brake join's first interval.
const BLEND_ITERS: usize = 40;
/// Joins are tried from ramp states at least this close (relative) below the branch.
const JOIN_NEAR_FRACTION: f64 = 0.97;
/// A forward state exceeding the branch by less than this (relative) is on it.
const ON_BRANCH_REL_TOL: f64 = 1e-9;

/// The forward branch's intervals, and the first node whose state depends on where the
/// block ends (on the backward branch from its end): a horizon can hand over the profile up
/// to that node and no further.
pub(super) struct ForwardPlan {
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

/// How far a forward branch got before it got stuck: its intervals from the block start and
/// the section ends it passed, where a run after a repair further on can resume.
pub(super) struct Progress {
    intervals: Vec<Interval>,
    /// The section ends passed, in order; the block start first.
    anchors: Vec<Anchor>,
}

/// A section end a forward branch passed, and its bookkeeping there.
#[derive(Debug, Clone, Copy)]
struct Anchor {
    node: usize,
    /// See [`ForwardPlan::final_before`].
    final_before: usize,
    /// Back-offs taken so far (bounded per branch, `MAX_BACK_OFFS_PER_BRANCH`).
    backoffs: usize,
}

/// A forward branch that got stuck: where, and how far it got.
pub(super) struct Failed {
    pub stuck: Stuck,
    pub progress: Progress,
}

/// [`forward_pausable`] without a pause.
#[cfg(test)]
pub(super) fn forward_branch(
    nodes: &[Node],
    env: &Envelope,
    start: (f64, f64),
    resume: Option<(&Progress, usize)>,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Result<ForwardPlan, Failed> {
    match forward_pausable(nodes, env, start, resume, lim, work, budget, &Budget::unlimited()) {
        Ok(plan) => Ok(plan),
        Err(Halted::Stuck(failed)) => Err(failed),
        Err(Halted::Paused(_)) => unreachable!("an unlimited pause budget never pauses"),
    }
}

/// A forward branch that stopped before the block end.
pub(super) enum Halted {
    Stuck(Failed),
    /// Paused at a section end it joined, once `work` reached the pause budget: go on with
    /// [`forward_on`].
    Paused(Box<PausedRun>),
}

/// A forward branch paused at a section end: the run so far and the state its search carries
/// from step to step, so that it goes on as if it had not paused.
pub(super) struct PausedRun {
    run: Run,
    anchors: Vec<Anchor>,
    carry: Carry,
}

/// What the forward run carries from step to step besides its intervals: the viability ramps,
/// and where it last got stuck and how deep its back-off went.
#[derive(Default)]
struct Carry {
    ramps: Ramps,
    stuck_at: Option<usize>,
    depth: usize,
}

/// The forward branch over a block from `start` = (v, a) at node 0 to rest at the last node;
/// with `resume` = (progress, node), it keeps the earlier run up to its last section end before
/// `node` (where the block and its envelope are as they were) and runs on from there. The kept
/// run is valid as it stands: every interval was checked, and it ends on a branch's section
/// end. A run built anew could differ only where the kept one's viability ramps looked past
/// that section end, which they seldom do (they flatten under the branch it joined).
///
/// It pauses at the first section end it joins once `work` has reached `pause`
/// ([`Halted::Paused`], go on with [`forward_on`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn forward_pausable(
    nodes: &[Node],
    env: &Envelope,
    start: (f64, f64),
    resume: Option<(&Progress, usize)>,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
    pause: &Budget,
) -> Result<ForwardPlan, Halted> {
    let mut run = Run::new(0, start);
    let mut anchors = vec![Anchor { node: 0, final_before: nodes.len() - 1, backoffs: 0 }];
    if let Some((p, before)) = resume {
        let kept = p.anchors.iter().take_while(|an| an.node < before).count().max(1);
        anchors = p.anchors[..kept].to_vec();
        for iv in &p.intervals[..anchors[kept - 1].node] {
            run.push(*iv);
        }
    }
    forward_on(nodes, env, Box::new(PausedRun { run, anchors, carry: Carry::default() }), lim, work, budget, pause)
}

/// Goes on with a paused forward branch over the same nodes and envelope.
pub(super) fn forward_on(
    nodes: &[Node],
    env: &Envelope,
    paused: Box<PausedRun>,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
    pause: &Budget,
) -> Result<ForwardPlan, Halted> {
    let PausedRun { mut run, mut anchors, mut carry } = *paused;
    match run_forward(nodes, env, &mut run, &mut anchors, &mut carry, lim, work, budget, pause) {
        Ok(Some(final_before)) => Ok(ForwardPlan { intervals: run.intervals, final_before }),
        Ok(None) => Err(Halted::Paused(Box::new(PausedRun { run, anchors, carry }))),
        Err(stuck) => Err(Halted::Stuck(Failed { stuck, progress: Progress { intervals: run.intervals, anchors } })),
    }
}

/// Runs the forward branch on from the last of `anchors` to the block end: `final_before`, or
/// `None` where it paused at a section end it joined (`pause`).
#[allow(clippy::too_many_arguments)]
fn run_forward(
    nodes: &[Node],
    env: &Envelope,
    run: &mut Run,
    anchors: &mut Vec<Anchor>,
    carry: &mut Carry,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
    pause: &Budget,
) -> Result<Option<usize>, Stuck> {
    let n = nodes.len();
    let view = View::forward(nodes);
    let free = FlattenUnder { view, cap: f64::INFINITY, lim };
    let Anchor { node: mut anchor, mut final_before, mut backoffs } = *anchors.last().expect("the block start");
    let mut evals_at_anchor = work.evals;
    // Where a capped section starts: the anchor, or a section end passed below its branch
    // since.
    let mut section_start = anchor;
    // Where the branch last got stuck and how deep its back-off went (as `backward_branch`).
    let Carry { ramps, stuck_at, depth } = carry;
    while run.last() + 1 < n {
        let t = run.last();
        let (v, a) = run.state(t);
        let step = greedy_step(&view, t, v, a, nodes[t + 1].vbar_mm_s, &free, lim, work, ramps);
        // Stuck with no branch right ahead: brake earlier (a branch right ahead is joined).
        if step.is_none()
            && !(t + 1..(t + 4).min(n)).any(|i| env.on_curve(i))
            && t > anchor
            && backoffs < MAX_BACK_OFFS_PER_BRANCH
        {
            backoffs += 1;
            // Stuck again where the last back-off led: the same ramp would lead there again.
            *depth = if *stuck_at == Some(t) { *depth + 1 } else { 0 };
            *stuck_at = Some(t);
            let states = &run.states[anchor - run.first..];
            if let Some((base, ramp)) = super::branch::back_off(&view, &free, lim, work, states, anchor, *depth) {
                if base < section_start {
                    // Backed off before a section end it had passed: it passes it anew.
                    section_start = anchor;
                }
                run.truncate(base);
                for iv in ramp {
                    run.push(iv);
                }
                continue;
            }
        }
        tracing::trace!(t, v, a, step = ?step.map(|iv| (iv.v1(), iv.a1())), env_next = env.v[t + 1], "forward free step");
        let crosses = match &step {
            Some(iv) => env.on_curve(t + 1) && iv.v1() > env.v[t + 1] * (1.0 + ON_BRANCH_REL_TOL),
            None => true,
        };
        if !crosses {
            run.push(step.expect("not crossing implies a step"));
            // A section end passed below its branch: a capped section further on starts from
            // it, as from one joined at, and does not re-plan the sections before. Back-offs
            // still reach back to the last join: braking before a section end passed below can
            // still help.
            let i = run.last();
            let c = env.curve[i];
            if c != 0 && env.starts[c as usize].node == i {
                tracing::trace!(
                    s_mm = nodes[i].s_mm,
                    v = run.state(i).0,
                    "forward branch: section end passed below its branch"
                );
                section_start = i;
            }
            continue;
        }
        // The branch crossed (or the next one ahead, if the free run got stuck before it).
        let Some(c) = (t + 1..n).map(|i| env.curve[i]).find(|&c| c != 0) else {
            return Err(Stuck { node: t, reason: Infeasibility::NoViableStep });
        };
        let section_end = env.starts[c as usize].node;
        let joined = direct_join(&view, run, t, anchor, env, c, lim, work)
            .or_else(|| brake_join(&view, run, t, anchor, env, c, lim, work))
            .map(|(from, ivs)| {
                if c == END_CURVE {
                    final_before = final_before.min(from);
                }
                run.truncate(from);
                for iv in ivs {
                    run.push(iv);
                }
            })
            .or_else(|| {
                let capped = capped_section(nodes, run, section_start, env, c, lim, work, budget)?;
                if c == END_CURVE {
                    final_before = final_before.min(section_start);
                }
                run.truncate(section_start);
                for iv in capped {
                    run.push(iv);
                }
                Some(())
            });
        if joined.is_none() {
            return Err(Stuck { node: t, reason: Infeasibility::CannotJoin });
        }
        // Follow the branch to its section end.
        while run.last() < section_end {
            let i = run.last();
            if env.curve[i] != c {
                break; // a capped section already ends there
            }
            run.push(env.iv[i]);
        }
        tracing::debug!(
            s_from_mm = nodes[anchor].s_mm,
            s_to_mm = nodes[run.last()].s_mm,
            nodes = run.last() - anchor,
            evals = work.evals - evals_at_anchor,
            evals_per_node = (work.evals - evals_at_anchor) as f64 / (run.last() - anchor).max(1) as f64,
            "forward branch: section joined"
        );
        evals_at_anchor = work.evals;
        anchor = run.last();
        section_start = anchor;
        anchors.push(Anchor { node: anchor, final_before, backoffs });
        if pause.exhausted(work) && run.last() + 1 < n {
            return Ok(None);
        }
    }
    let (v, a) = run.state(n - 1);
    if v.abs() > REST_V_TOL_MM_S || a.abs() > REST_A_TOL_MM_S2 {
        return Err(Stuck { node: n - 1, reason: Infeasibility::NotAtRest });
    }
    Ok(Some(final_before))
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
) -> Option<(usize, Vec<Interval>)> {
    let lo = anchor.max(run.first).max(t.saturating_sub(2));
    for from in (lo..=t).rev() {
        let to = from + 2;
        if to >= env.len() || env.curve[to] != c {
            continue;
        }
        let (v, a) = run.state(from);
        if let Some((i1, i2)) = join_two(view, from, v, a, (env.v[to], env.a[to]), lim, work) {
            work.joins += 1;
            return Some((from, vec![i1, i2]));
        }
        if to + 1 < env.len() && env.curve[to + 1] == c {
            if let Some(ivs) = join_three(view, from, v, a, (env.v[to + 1], env.a[to + 1]), lim, work) {
                work.joins += 1;
                return Some((from, ivs.to_vec()));
            }
        }
    }
    None
}

/// What a braking ramp from the forward branch does relative to backward branch `c`.
enum RampToBranch {
    /// It crosses the branch at this node: it started too late.
    Crosses,
    /// It passes under the branch without touching it: it started too early.
    Below,
    /// It joins the branch exactly: the ramp intervals and the two join intervals.
    Joined(Vec<Interval>),
}

/// The forward branch accelerating into a backward branch that brakes: find the latest point
/// before the crossing from which a braking ramp stays under the branch, and join from that
/// ramp where it touches the branch. The ramp brakes with the full jerk, the branch with
/// `BACKWARD_JERK_FRACTION` of it, so the touch leaves jerk for the join.
///
/// The start node is found by an exponential then binary search back from the crossing (a
/// later start crosses the branch, an earlier one passes under it); between the last start
/// that passes under and the first that crosses, the first interval's jerk is blended from
/// the free run's to the ramp's (λ ∈ [0, 1], bisection) so the ramp touches the branch.
#[allow(clippy::too_many_arguments)]
fn brake_join(
    view: &View,
    run: &Run,
    t: usize,
    anchor: usize,
    env: &Envelope,
    c: u32,
    lim: &Limits,
    work: &mut Work,
) -> Option<(usize, Vec<Interval>)> {
    let first = anchor.max(run.first);
    let outcome = |f: usize, work: &mut Work| ramp_to_branch(view, run.state(f), f, env, c, lim, work);
    // Exponential search back from the crossing for a start that does not cross.
    let mut hi = t; // crosses (the free run crossed right after t)
    let mut step = 1;
    let mut lo = loop {
        if hi <= first {
            return None;
        }
        let f = hi.saturating_sub(step).max(first);
        match outcome(f, work) {
            RampToBranch::Joined(ivs) => return Some((f, ivs)),
            RampToBranch::Below => break f,
            RampToBranch::Crosses => {
                hi = f;
                step *= 2;
            }
        }
    };
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        match outcome(mid, work) {
            RampToBranch::Crosses => hi = mid,
            RampToBranch::Joined(ivs) => return Some((mid, ivs)),
            RampToBranch::Below => lo = mid,
        }
    }
    // Blend the jerk of the interval lo → lo+1 between the free run's (λ = 0: the ramp
    // effectively starts at lo+1 and crosses) and the ramp's (λ = 1: starts at lo, under).
    let (v, a) = run.state(lo);
    let j_free = run.intervals[lo - run.first].j;
    let j_ramp = ramp_interval(view, lo, v, a, lim, Check::Full)?.j;
    let g = view.interval_geom(lo);
    let (mut l_lo, mut l_hi) = (0.0f64, 1.0f64);
    for _ in 0..BLEND_ITERS {
        let lambda = 0.5 * (l_lo + l_hi);
        let Some(first_iv) = Interval::with_jerk(v, a, g.ds_mm, j_free + lambda * (j_ramp - j_free)) else {
            l_hi = lambda;
            continue;
        };
        if super::check::violation(&first_iv, &g, lim) > super::check::VIOLATION_TOL {
            l_hi = lambda;
            continue;
        }
        match ramp_to_branch(view, (first_iv.v1(), first_iv.a1()), lo + 1, env, c, lim, work) {
            RampToBranch::Crosses => l_lo = lambda,
            RampToBranch::Below => l_hi = lambda,
            RampToBranch::Joined(mut ivs) => {
                ivs.insert(0, first_iv);
                return Some((lo, ivs));
            }
        }
    }
    tracing::trace!(lo, t, "brake join: no join at the touching ramp");
    None
}

/// Runs a braking ramp from `state` at node `from` against backward branch `c`.
fn ramp_to_branch(
    view: &View,
    state: (f64, f64),
    from: usize,
    env: &Envelope,
    c: u32,
    lim: &Limits,
    work: &mut Work,
) -> RampToBranch {
    let n = env.len();
    let (mut v, mut a) = state;
    let mut ivs = Vec::new();
    let mut k = from;
    while k + 2 < n {
        if env.curve[k] == c && v > env.v[k] * (1.0 + ON_BRANCH_REL_TOL) {
            return RampToBranch::Crosses;
        }
        if env.curve[k + 2] == c && v >= JOIN_NEAR_FRACTION * env.v[k] {
            if let Some((i1, i2)) = join_two(view, k, v, a, (env.v[k + 2], env.a[k + 2]), lim, work) {
                work.joins += 1;
                ivs.push(i1);
                ivs.push(i2);
                return RampToBranch::Joined(ivs);
            }
            // No three-interval join here: a ramp passes many nodes near the branch, and
            // one per node (17 two-interval joins each) would cost most of a join's work. The
            // blend in `brake_join` makes the ramp touch the branch, where two suffice;
            // `direct_join` still tries three.
        }
        if env.curve[k] == c && a < env.a[k] && v < env.v[k] {
            return RampToBranch::Below; // braking harder below the branch: it moves away
        }
        // A ramp that cannot go on has braked itself to rest below the branch: too early.
        let Some(iv) = ramp_interval(view, k, v, a, lim, Check::Full) else { return RampToBranch::Below };
        work.ramp_nodes += 1;
        v = iv.v1();
        a = iv.a1();
        ivs.push(iv);
        k += 1;
    }
    RampToBranch::Below
}

/// Forward and backward branch capped at the highest common velocity v_c for which they meet
/// flat, between the anchor and the section end of branch `c`: the intervals from the anchor
/// to the section end. Each cap tried costs a run over the whole section: the search stops
/// where `budget` is spent (with the best cap found so far, if any).
#[allow(clippy::too_many_arguments)]
fn capped_section(
    nodes: &[Node],
    run: &Run,
    anchor: usize,
    env: &Envelope,
    c: u32,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Option<Vec<Interval>> {
    let start = env.starts[c as usize];
    let (va, _) = run.state(anchor);
    let lo = va.max(start.v);
    let hi = (anchor..=start.node).map(|i| nodes[i].vbar_mm_s).fold(0.0, f64::max).max(lo);
    let try_cap = |cap: f64, work: &mut Work| {
        work.cap_tries += 1;
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
        // A heuristic too: caps within the bisection's tolerance above the lowest are not
        // tried. One of them could still work where every higher cap failed (the backward
        // branch and the ramps' ceiling change with the cap), but the descent would creep
        // towards `lo` in ever smaller steps, each a capped run of the section, where a short
        // look-ahead fails whatever the cap.
        if gap <= CAP_SEARCH_REL_TOL * lo || budget.exhausted(work) {
            break;
        }
        match try_cap(cap, work) {
            Ok(p) => {
                best = Some((cap, p));
                break;
            }
            // The forward branch got stuck at or below every cap still to try (the caps lie
            // above `lo`). A heuristic: a lower cap changes the run mainly where it was above
            // that cap (it also lowers the backward branch and the ramps' ceiling), and the
            // run fails below all of them (the block repair then lowers v̄ there). Trying
            // them all would dominate the planning time on a dense spline and not change the
            // motion.
            Err(CapFail::ForwardStuck { v_mm_s }) if v_mm_s <= lo => {
                tracing::trace!(
                    anchor,
                    section_end = start.node,
                    cap,
                    v_mm_s,
                    lo,
                    "capped section: stuck below every cap"
                );
                return None;
            }
            Err(_) => hi_bad = cap,
        }
    }
    let (mut lo_ok, mut profile) = best?;
    for _ in 0..CAP_SEARCH_ITERS {
        if hi_bad - lo_ok <= CAP_SEARCH_REL_TOL * hi_bad || budget.exhausted(work) {
            break;
        }
        let cap = 0.5 * (lo_ok + hi_bad);
        match try_cap(cap, work) {
            Ok(p) => {
                lo_ok = cap;
                profile = p;
            }
            Err(_) => hi_bad = cap,
        }
    }
    tracing::trace!(anchor, section_end = start.node, cap = lo_ok, "capped section");
    Some(profile)
}

/// Why a capped run failed, as far as the cap search acts on it (each failure is traced where
/// it happens).
#[derive(Debug, Clone, Copy, PartialEq)]
enum CapFail {
    /// The forward branch found no feasible and viable step, at this velocity.
    ForwardStuck { v_mm_s: f64 },
    /// The backward branch got stuck, no join onto it keeps the limits, or the forward branch
    /// reached the section end without meeting it.
    Other,
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
) -> Result<Vec<Interval>, CapFail> {
    let Some(branch) = backward_branch(View::backward(nodes), end, bwd.0, bwd.1, cap, anchor, |_, _| false, lim, work)
    else {
        tracing::trace!(cap, anchor, end, "capped run: backward branch stuck");
        return Err(CapFail::Other);
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
    let ceiling = FlattenUnder { view, cap, lim };
    let mut run = Run::new(anchor, fwd);
    let mut ramps = Ramps::default();
    while run.last() < end {
        let t = run.last();
        let (v, a) = run.state(t);
        let v_max = nodes[t + 1].vbar_mm_s.min(cap).min(bv[t + 1]);
        let step = greedy_step(&view, t, v, a, v_max, &ceiling, lim, work, &mut ramps);
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
            if let Some((i1, i2)) = join_two(&view, from, v, a, (bv[to], ba[to]), lim, work) {
                joined = Some((from, vec![i1, i2]));
                break;
            }
            if to < end {
                if let Some(three) = join_three(&view, from, v, a, (bv[to + 1], ba[to + 1]), lim, work) {
                    joined = Some((from, three.to_vec()));
                    break;
                }
            }
        }
        let Some((from, ivs)) = joined else {
            tracing::trace!(cap, t, left, v, a, bv = bv[t + 1], ba = ba[t + 1], step = ?step.map(|iv| (iv.v1(), iv.a1())), "capped run: no join");
            return Err(if step.is_none() { CapFail::ForwardStuck { v_mm_s: v } } else { CapFail::Other });
        };
        run.truncate(from);
        for iv in ivs {
            run.push(iv);
        }
        while run.last() < end {
            let i = run.last();
            run.push(biv[i]);
        }
        work.joins += 1;
        return Ok(run.intervals);
    }
    tracing::trace!(cap, anchor, end, "capped run: forward reached the end without meeting");
    Err(CapFail::Other)
}
