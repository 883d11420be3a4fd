//! Branches (Kopp et al. 2019, §3, Fig. 3): the greedy step shared by forward and backward
//! branches, the backward branches from the section ends, and the envelope they form.
//!
//! Every step picks the largest feasible next velocity (α = 1 in the terms of §3.2) that is
//! also viable (see `ramp`); when the greedy choice is not viable, a bisection between it and
//! the braking ramp's own next state (viable whenever the current state is) finds the largest
//! viable one. No step ever goes back, so the work per node is bounded.

use super::check::violates;
use super::envelope::{BranchNode, CurveStart, END_CURVE, Envelope};
use super::error::Infeasibility;
use super::falsi::Illinois;
use super::interval::Interval;
use super::limits::Limits;
use super::node::{IntervalGeom, Node};
use super::ramp::{CEILING_REL_TOL, Check, FlattenUnder, RampTrace, Wanted, ramp_interval, ramp_margin};
use super::step::{Budget, Work, feasible, max_feasible};
use super::view::{Reads, View};
use std::sync::Arc;

/// Bisection steps when the greedy choice is not viable.
const VIABLE_SEARCH_ITERS: usize = 40;
/// Relative bracket width at which the viable search stops.
const VIABLE_SEARCH_REL_TOL: f64 = 1e-4;
/// The viable search's secant points keep this share of the bracket away from its ends.
const VIABLE_SECANT_MARGIN: f64 = 0.02;
/// The viable search also stops once the best state's braking ramp peaks within this share
/// below the ceiling: the peak rises about as fast as the next velocity or faster, so no viable
/// velocity is more than this share higher. Cuts the slow tail of the search for at most
/// 0.03 % of speed at that node.
const VIABLE_TOUCH_MARGIN: f64 = 3e-4;
/// The viable search's secant aims this far below the ceiling (a margin of −1e-4), inside the
/// touch band rather than at its edge. The margin is convex in the next velocity, and the
/// upper end's margin is only a lower bound (a verdict), so a secant aimed at the edge lands
/// just above it often, and a trial that is not viable costs the most (its ramp runs on above
/// the ceiling until it flattens). Aiming deeper slows the motion a little for no gain.
///
/// Not where the greedy choice is the step's cap itself (the next node's ceiling, the feed):
/// the branch is reaching a ceiling it may then ride flat, and the flat landing that keeps it
/// from chattering there takes only states within `FLAT_LANDING_REL_TOL` of it. Aimed below
/// there, a branch cruising at its feed would settle under it and search at every node.
const VIABLE_SEARCH_AIM: f64 = VIABLE_TOUCH_MARGIN / 3.0;
/// Backward branches brake with this share of the jerk the axes allow, the forward branch
/// with all of it: where the forward branch crosses a backward branch its braking is the
/// steeper, which leaves jerk for the exact join.
pub(super) const BACKWARD_JERK_FRACTION: f64 = 0.95;
/// A flattened backward branch this far (relative) below the ceiling is done.
const FLAT_BELOW_CEILING: f64 = 1e-3;
/// Start velocity factors tried when a backward branch cannot leave its section end at v̄
/// (Kopp et al. 2019, §4: "a section whose transition speed is not reached must be
/// recomputed"). Fine near 1: at a dip of the acceleration-only ceiling (`block`) the first
/// factors often fail, and every step down costs the motion time there.
const BACKWARD_START_FACTORS: [f64; 12] = [1.0, 0.97, 0.94, 0.9, 0.85, 0.8, 0.7, 0.6, 0.5, 0.35, 0.2, 0.0];

/// Caps (shares of the block's highest v̄) tried for the backward branch from the block end
/// when it gets stuck uncapped (`build_envelope`).
const BLOCK_END_CAP_FRACTIONS: [f64; 4] = [0.75, 0.5, 0.25, 0.1];

/// A block could not be planned from some node on: where, and why.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Stuck {
    /// Node index (within the block) where no step was possible.
    pub node: usize,
    pub reason: Infeasibility,
}

/// The viability ramps a branch keeps between its greedy steps, in buffers reused from step
/// to step: the ramp from the current state, and the best and the latest of a step's search.
#[derive(Debug, Clone, Default)]
pub(super) struct Ramps {
    current: RampTrace,
    best: RampTrace,
    trial: RampTrace,
}

/// The largest feasible and viable step from (v, a) at traversal position `t`: the greedy
/// choice if viable, else the boundary of viability between it and the braking ramp's own
/// next state (viable whenever the current state is), found by regula falsi on the ramp
/// margin.
///
/// `ramps` holds the current state's own viability ramp from the step that accepted it. Where
/// the braking ramp's next state is a state that ramp passed, its margin is known without a
/// ramp of its own: common where branches ride their braking ramps.
#[allow(clippy::too_many_arguments)]
pub(super) fn greedy_step(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    v_max: f64,
    ceiling: &FlattenUnder,
    lim: &Limits,
    work: &mut Work,
    ramps: &mut Ramps,
) -> Option<Interval> {
    let g = view.interval_geom(t);
    // The braking ramp's own interval is feasible by construction: the fallback when the
    // search finds nothing (its anchors sample the jerk range at the start node only).
    let Some(cand) = max_feasible(v, a, v_max, &g, lim, work)
        .or_else(|| ramp_interval(view, t, v, a, lim, Check::Full).filter(|iv| iv.v1() <= v_max * (1.0 + 1e-12)))
    else {
        tracing::trace!(t, v, a, v_max, "no feasible next velocity");
        return None;
    };
    let margin = |iv: &Interval, work: &mut Work, into: &mut RampTrace, wanted: Wanted| {
        ramp_margin(view, t + 1, iv.v1(), iv.a1(), lim, ceiling, work, into, wanted)
    };
    let ok = |m: Option<f64>| m.is_some_and(|m| m <= CEILING_REL_TOL);
    if let Some(land) = flat_landing(t, (v, a), cand.v1().min(v_max), &g, ceiling, lim) {
        if ok(margin(&land, work, &mut ramps.trial, Wanted::Verdict)) {
            std::mem::swap(&mut ramps.current, &mut ramps.trial);
            return Some(land);
        }
    }
    // Of the greedy choice only the verdict: where it is not viable, its ramp stops as soon as
    // it rises above the ceiling, and that margin (a lower bound of the full one) is the
    // search's upper end. Running failing ramps on until they flatten, for their full margin,
    // costs much and hardly moves the search.
    let m_cand = margin(&cand, work, &mut ramps.trial, Wanted::Verdict);
    if ok(m_cand) {
        std::mem::swap(&mut ramps.current, &mut ramps.trial);
        return Some(cand);
    }
    work.bisections += 1;
    // A viable lower end: the braking ramp's next state, with its margin where the current
    // state's own ramp passed it, else lower velocities. `on_current`: the best state so far
    // lies on the current state's ramp (else its ramp is `ramps.best`).
    let braking = ramp_interval(view, t, v, a, lim, Check::Full)
        .filter(|iv| iv.v1() <= v_max * (1.0 + 1e-12) && iv.v1() < cand.v1());
    let known = braking.and_then(|iv| ramps.current.margin_from(t + 1, iv.v1(), iv.a1()));
    let mut on_current = ok(known);
    let mut lo = braking.and_then(|iv| {
        let m = known.or_else(|| margin(&iv, work, &mut ramps.best, Wanted::Margin));
        ok(m).then(|| (iv, m.unwrap_or(0.0)))
    });
    if lo.is_none() {
        let fracs = [0.999, 0.99, 0.95, 0.9, 0.7, 0.5].into_iter();
        let halvings = std::iter::successors(Some(0.25), |f| (*f > 1e-15).then_some(f * 0.5));
        for frac in fracs.chain(halvings) {
            if let Some(iv) = feasible(v, a, frac * cand.v1(), &g, lim, work) {
                let m = margin(&iv, work, &mut ramps.best, Wanted::Margin);
                if ok(m) {
                    lo = Some((iv, m.unwrap_or(0.0)));
                    break;
                }
            }
        }
    }
    let Some((mut best, mut m_lo)) = lo else {
        tracing::trace!(t, v, a, v_max, "no viable next velocity");
        return None;
    };
    let (mut x_lo, mut x_hi, mut m_hi) = (best.v1(), cand.v1(), m_cand);
    let aim = if x_hi >= v_max * (1.0 - CEILING_REL_TOL) { 0.0 } else { VIABLE_SEARCH_AIM };
    // The secant runs through the margins shifted by the aim: its root is where the margin is
    // −aim. The margins themselves stay true: `m_lo` is also the touch test.
    let aimed = |m: f64| m + aim;
    let mut falsi = Illinois::default();
    for _ in 0..VIABLE_SEARCH_ITERS {
        if x_hi - x_lo <= VIABLE_SEARCH_REL_TOL * x_hi.max(1e-12) || m_lo >= -VIABLE_TOUCH_MARGIN {
            break;
        }
        let x = falsi.next((x_lo, aimed(m_lo)), (x_hi, m_hi.map(aimed)), VIABLE_SECANT_MARGIN);
        let trial = feasible(v, a, x, &g, lim, work);
        let m = trial.as_ref().and_then(|iv| margin(iv, work, &mut ramps.trial, Wanted::Margin));
        match (trial, m) {
            (Some(iv), Some(m)) if m <= CEILING_REL_TOL => {
                best = iv;
                std::mem::swap(&mut ramps.best, &mut ramps.trial);
                on_current = false;
                x_lo = x;
                m_lo = m;
                falsi.lower_moved();
            }
            (_, m) => {
                x_hi = x;
                m_hi = m;
                falsi.upper_moved();
            }
        }
    }
    // The next state's own ramp: the current one passes it, or the search's best is it.
    if !on_current {
        std::mem::swap(&mut ramps.current, &mut ramps.best);
    }
    Some(best)
}

/// A flat landing is taken where the greedy choice reaches the ceiling within this share, and
/// the landing's next velocity is within this share of the greedy one (see [`flat_landing`]).
const FLAT_LANDING_REL_TOL: f64 = 1e-4;

/// The interval from (v, a) at `t` (geometry `g`) that ends flat at the next node (at the
/// acceleration [`FlattenUnder::flat_acc`] counts as flat there; from a flat state, the one
/// with j = 0), where the greedy choice `v_greedy` (the largest feasible next velocity, capped)
/// reaches a ceiling that does not rise there, the interval keeps every limit, and its next
/// velocity is within `FLAT_LANDING_REL_TOL` of `v_greedy`.
///
/// Kopp et al. 2019, §3.2: α = 1 alone makes the jerk bang-bang. Riding a flat ceiling (an axis
/// at its velocity limit on a line), the largest viable velocity overshoots the flat state,
/// and from a flat state just under the ceiling the braking ramp's next state already counts
/// as touching it (`VIABLE_TOUCH_MARGIN`), so the branch chatters under the ceiling with
/// jerks of ±J. A forward branch chattering onto a backward branch joins it only by luck, and
/// a failed join costs a capped section. A landing costs at most the tolerance at that node,
/// and a branch cruising flat stays within twice the tolerance under the ceiling (further
/// below, the greedy choice does not reach it and accelerates).
fn flat_landing(
    t: usize,
    (v, a): (f64, f64),
    v_greedy: f64,
    g: &IntervalGeom,
    ceiling: &FlattenUnder,
    lim: &Limits,
) -> Option<Interval> {
    let (c0, c1) = (ceiling.velocity(t), ceiling.velocity(t + 1));
    if c1 > c0 || v_greedy < (1.0 - FLAT_LANDING_REL_TOL) * c1 {
        return None;
    }
    let land = Interval::landing(v, a, g.ds_mm, ceiling.flat_acc(t + 1, v))?;
    let v1 = land.v1();
    let close = v1 >= (1.0 - FLAT_LANDING_REL_TOL) * v_greedy && v1 <= v_greedy * (1.0 + CEILING_REL_TOL);
    (close && !violates(&land, g, lim)).then_some(land)
}

/// Back-offs one branch may take before it gives up.
pub(super) const MAX_BACK_OFFS_PER_BRANCH: usize = 16;
/// How many steps a stuck branch backs off, in turn, before giving up.
const BACK_OFF_STEPS: [usize; 7] = [1, 2, 4, 8, 16, 32, 64];

/// A branch found no viable next step at the end of `states` (traversal states from position
/// `p0`): brake earlier. The last k steps (k = 1, 2, 4, …) are replaced by a braking ramp from
/// the state k steps back, every interval fully checked and under the ceiling, until it has
/// flattened. Returns the position the ramp starts from and its intervals; `None` if no
/// back-off up to `BACK_OFF_STEPS` helps. Bounded work, and rare: the viability test
/// normally keeps branches out of such dead ends. `depth` skips the shortest back-offs: a
/// branch stuck again at the same place after a back-off must brake from further back, since
/// the same ramp would lead it into the same dead end.
pub(super) fn back_off(
    view: &View,
    ceiling: &FlattenUnder,
    lim: &Limits,
    work: &mut Work,
    states: &[(f64, f64)],
    p0: usize,
    depth: usize,
) -> Option<(usize, Vec<Interval>)> {
    work.repairs += 1;
    let current = states.len() - 1;
    for k in BACK_OFF_STEPS.into_iter().skip(depth) {
        if k > current {
            break;
        }
        let base = p0 + current - k;
        let (mut v, mut a) = states[current - k];
        let mut pos = base;
        let mut ramp = Vec::new();
        let ok = loop {
            if a <= ceiling.flat_acc(pos, v) && !ramp.is_empty() {
                break pos + 1 >= view.len() || super::ramp::can_leave(view, pos, v, a, lim);
            }
            if pos + 1 >= view.len() {
                break false;
            }
            let Some(iv) = ramp_interval(view, pos, v, a, lim, Check::Full) else { break false };
            let cap = ceiling.velocity(pos).min(ceiling.velocity(pos + 1));
            if super::ramp::peak_velocity(&iv) > cap * (1.0 + CEILING_REL_TOL) {
                break false;
            }
            v = iv.v1();
            a = iv.a1();
            ramp.push(iv);
            pos += 1;
        };
        if ok {
            tracing::trace!(k, base, steps = ramp.len(), "backed off");
            return Some((base, ramp));
        }
    }
    None
}

/// A backward branch on `view` (a backward view of the block's nodes) from node `m` with state
/// (`v_start`, forward acceleration `a_start`), running under v̄ capped at `cap`, leftwards
/// until it has flattened, reaches node `stop` (exclusive), or meets a node where
/// `lower(i, v)` says another branch already lies lower. `None` if it gets stuck. It reads
/// the nodes through `view` only, so a tracking view (`View::tracking`) sees every node it
/// depends on.
#[allow(clippy::too_many_arguments)]
pub(super) fn backward_branch(
    view: View,
    m: usize,
    v_start: f64,
    a_start: f64,
    cap: f64,
    stop: usize,
    lower: impl Fn(usize, f64) -> bool,
    lim: &Limits,
    work: &mut Work,
) -> Option<Vec<BranchNode>> {
    let ceiling = FlattenUnder { view, cap, lim };
    let mut lim_b = lim.clone();
    for j in lim_b.jerk.iter_mut() {
        *j *= BACKWARD_JERK_FRACTION;
    }
    lim_b.refresh();
    let mut out: Vec<BranchNode> = Vec::new();
    let t0 = view.position(m);
    // Traversal states (v, a in the branch's own direction) from t0 on, for backing off.
    let mut states = vec![(v_start, -a_start)];
    let (mut v, mut a) = (v_start, -a_start);
    let mut t = t0;
    let mut backoffs = 0;
    // Where the branch last got stuck and how deep its back-off went.
    let (mut stuck_at, mut depth): (Option<usize>, usize) = (None, 0);
    let mut ramps = Ramps::default();
    while view.index(t) > stop + 1 {
        let i_next = view.index(t + 1);
        let v_max = view.node(t + 1).vbar_mm_s.min(cap);
        let iv = match greedy_step(&view, t, v, a, v_max, &ceiling, &lim_b, work, &mut ramps) {
            Some(iv) => iv,
            None if (v > v_max || v_max < view.node(t).vbar_mm_s) && i_next > stop && cap.is_infinite() => {
                // The ceiling ahead falls faster than the branch can follow (it is above the
                // next bound, or the curvature rising into the next interval takes more
                // acceleration than its jerk can give up): a minimum of v̄ lies further on,
                // and the branch from it covers the nodes from here. This branch ends; the
                // forward branch passes under it (it runs under v̄).
                tracing::trace!(from = m, node = i_next, v, a, v_max, "backward branch ends under a falling ceiling");
                break;
            }
            None => {
                tracing::trace!(from = m, node = i_next, v, a, v_max, "backward branch stuck: backing off");
                // Bounded: a branch that keeps getting stuck gives up (its caller lowers the
                // start or reports the section).
                backoffs += 1;
                if backoffs > MAX_BACK_OFFS_PER_BRANCH {
                    return None;
                }
                // Stuck again where the last back-off led: brake from further back.
                depth = if stuck_at == Some(i_next) { depth + 1 } else { 0 };
                stuck_at = Some(i_next);
                let (base, ramp) = back_off(&view, &ceiling, &lim_b, work, &states, t0, depth)?;
                let keep = base - t0;
                out.truncate(keep);
                states.truncate(keep + 1);
                let mut tt = base;
                for r in ramp {
                    out.push((view.index(tt + 1), r.v1(), -r.a1(), r.reversed()));
                    states.push((r.v1(), r.a1()));
                    tt += 1;
                }
                t = tt;
                (v, a) = *states.last().expect("states never empty");
                continue;
            }
        };
        let (v1, a1) = (iv.v1(), iv.a1());
        if lower(i_next, v1) {
            break; // another branch lies lower from here on
        }
        out.push((i_next, v1, -a1, iv.reversed()));
        states.push((v1, a1));
        v = v1;
        a = a1;
        t += 1;
        // Flattened: done once it lies clearly below the ceiling (a forward branch running
        // along v̄ will cross it), or the ceiling stops rising away from the section end.
        // While it rides a v̄ that keeps falling towards the section end it goes on: the
        // forward branch cannot follow a falling v̄ without it.
        if a1 <= ceiling.flat_acc(t, v1) {
            let here = view.node(t).vbar_mm_s.min(cap);
            let further = if i_next > 0 { view.node(t + 1).vbar_mm_s.min(cap) } else { here };
            let clearly_below = v1 < (1.0 - FLAT_BELOW_CEILING) * here && !view.node(t).reach_bound;
            if clearly_below || further <= here {
                break;
            }
        }
    }
    Some(out)
}

/// The envelope before a repair lowered v̄ at nodes `from ..= to`, to rebuild from (see
/// [`build_envelope`]).
pub(super) struct Previous<'a> {
    pub env: &'a Envelope,
    pub from: usize,
    pub to: usize,
}

/// The backward branch from the block end at rest (node `n − 1`) under the first cap of
/// `BLOCK_END_CAP_FRACTIONS` (shares of the block's highest v̄) it runs under, after it got
/// stuck uncapped. From rest the branch can only have run into a dead end its viability ramps
/// did not foresee, far back from the block end, where backing off leads back into it (a
/// dense spline under a short look-ahead). Under a cap it flattens before it gets there, and
/// the forward branch joins it like any branch ending flat under v̄. This holds for every
/// block end, online or not: a block planned under the relaxed ceiling whose end branch needs
/// a cap competes with the plan under the flat ceiling.
fn capped_from_block_end(
    view: View,
    lower: impl Fn(usize, f64) -> bool + Copy,
    lim: &Limits,
    work: &mut Work,
) -> Option<Vec<BranchNode>> {
    let end = view.len() - 1;
    // Read through the view: the cap depends on every node.
    let top_vbar_mm_s = (0..view.len()).map(|t| view.node(t).vbar_mm_s).fold(0.0, f64::max);
    if !top_vbar_mm_s.is_finite() {
        return None;
    }
    BLOCK_END_CAP_FRACTIONS.iter().find_map(|&f| {
        let cap = f * top_vbar_mm_s;
        work.end_caps += 1;
        let b = backward_branch(view, end, 0.0, 0.0, cap, 0, lower, lim, work)?;
        tracing::debug!(s_end_mm = view.node(0).s_mm, cap, "backward branch from the block end capped");
        Some(b)
    })
}

/// Whether the forward branch can go on from a section end `m` in the state (`v_mm_s`, 0) a
/// backward branch from there starts in: a feasible and viable step to the next node exists.
/// The backward branch only checks its own direction; where an orientation swing forces the
/// jerk's sign (a dip of the acceleration-only ceiling), a flat state at the dip can have no
/// continuation forwards, and a forward branch joined onto that branch would be stuck at its
/// end (the block repairs then creep back from such dips one node at a time).
fn leaves_forward(nodes: &[Node], m: usize, v_mm_s: f64, reads: &Reads, lim: &Limits, work: &mut Work) -> bool {
    let view = View::forward(nodes).tracking(reads);
    let free = FlattenUnder { view, cap: f64::INFINITY, lim };
    let v_max = view.node(m + 1).vbar_mm_s;
    greedy_step(&view, m, v_mm_s, 0.0, v_max, &free, lim, work, &mut Ramps::default()).is_some()
}

/// The backward branches of a block: from the block end (at rest) and from every local
/// minimum of v̄ (Kopp et al. 2019, §3.1), right to left.
///
/// After a repair (`previous`), the branches from section ends before the lowered stretch are
/// taken over from the first section end that no branch from a later one reaches past, in the
/// old envelope or the new, and from which no old branch read a node of the stretch or after it
/// (`CurveStart::reads`: the forward step a section end must allow, `leaves_forward`, looks
/// right). They are then the branches a full build would make: a branch runs leftwards and
/// sees only the nodes it read and the envelope left of its section end, both as before. A
/// repair deep inside a long block then costs the branches after it, not the whole block.
///
/// Branches after the stretch are taken over too, from the block end leftwards, as long as
/// each one's build never read a node of the stretch (`CurveStart::reach`, recorded through a
/// tracking view): with every branch after it the same, it saw the same envelope and the same
/// nodes. A branch whose viability ramps looked into the stretch is built anew, and so is every
/// one before it. A forward branch stuck far before the block end then costs the branches
/// around the stretch, not every one from there to the block end once per repair.
pub(super) fn build_envelope(
    nodes: &[Node],
    previous: Option<Previous>,
    lim: &Limits,
    work: &mut Work,
    budget: &Budget,
) -> Result<Envelope, Stuck> {
    let n = nodes.len();
    let mut env = Envelope::from_vbar(nodes.iter().map(|nd| nd.vbar_mm_s));
    env.v[n - 1] = 0.0;
    let mut starts: Vec<usize> = (1..n.saturating_sub(1))
        .filter(|&i| nodes[i].vbar_mm_s < nodes[i - 1].vbar_mm_s && nodes[i].vbar_mm_s <= nodes[i + 1].vbar_mm_s)
        .collect();
    starts.push(n - 1);
    // After a repair: the old branches, latest section end first, and the first nodes reached
    // by the old branches from section ends after the current one and by the new ones.
    let mut old_branches = previous.as_ref().map(|p| p.env.extents()).unwrap_or_default().into_iter().peekable();
    let (mut old_reach, mut new_reach) = (n, n);
    // While every branch so far is the old one, the old branch from the next section end
    // (old ids run from the block end leftwards, as the build does).
    let mut same_as_old = previous.as_ref().map(|_| 1usize);
    // The highest node read by the old branches from each old id on (leftwards).
    let mut old_read_hi = Vec::new();
    if let Some(p) = &previous {
        old_read_hi = vec![0; p.env.starts.len() + 1];
        for c in (1..p.env.starts.len()).rev() {
            old_read_hi[c] = old_read_hi[c + 1].max(p.env.starts[c].reads.1);
        }
    }
    let mut old_next = 1usize;
    for &m in starts.iter().rev() {
        if let Some(p) = &previous {
            while let Some((_, first)) = old_branches.next_if(|&(end, _)| end > m) {
                old_reach = old_reach.min(first);
            }
            while old_next < p.env.starts.len() && p.env.starts[old_next].node > m {
                old_next += 1;
            }
            // The old branches from here leftwards never read the lowered stretch (their forward
            // steps from the section end look right).
            let clear_of_stretch = old_read_hi[old_next] < p.from;
            if m + 1 < p.from && m < old_reach && m < new_reach && clear_of_stretch {
                env.take_over_before(p.env, m + 1);
                return Ok(env);
            }
            if let Some(c) = same_as_old {
                match p.env.starts.get(c) {
                    // A section end after the lowered stretch and its neighbour (so a section
                    // end before as now), and the old branch from it never read the stretch:
                    // the envelope it saw is the same, so a build would make it again.
                    Some(st) if st.node == m && m > p.to + 1 && st.reads.0 > p.to => {
                        let id = env.lay(*st, p.env.built[c].clone());
                        new_reach = new_reach.min(env.built[id as usize].last().map_or(m, |b| b.0));
                        same_as_old = Some(c + 1);
                        continue;
                    }
                    // The old envelope has no branch from here (a later one lay lower): nor
                    // has this one, which is the same so far.
                    Some(st) if st.node < m && m > p.to + 1 => {}
                    None if m > p.to + 1 => {}
                    _ => same_as_old = None,
                }
            }
        }
        if m != n - 1 && (env.on_curve(m) || env.v[m] < nodes[m].vbar_mm_s) {
            continue; // a branch from further on already lies lower here
        }
        // A branch built here differs from the old ones, and so may those further left.
        same_as_old = None;
        let evals_before = work.evals;
        debug_assert!(m != n - 1 || env.starts.len() as u32 == END_CURVE);
        let mut built = None;
        let lower = |i: usize, v: f64| env.on_curve(i) && v >= env.v[i] * (1.0 - 1e-12);
        let reads = Reads::at(m);
        let view = View::backward(nodes).tracking(&reads);
        for factor in BACKWARD_START_FACTORS {
            // Each start velocity costs a branch that may run back over the whole block.
            if budget.exhausted(work) {
                break;
            }
            let v_start = if m == n - 1 { 0.0 } else { factor * nodes[m].vbar_mm_s };
            if m != n - 1 && !leaves_forward(nodes, m, v_start, &reads, lim, work) {
                continue;
            }
            if let Some(b) = backward_branch(view, m, v_start, 0.0, f64::INFINITY, 0, lower, lim, work) {
                built = Some((v_start, b));
                break;
            }
            if m == n - 1 {
                break;
            }
        }
        if built.is_none() && m == n - 1 && !budget.exhausted(work) {
            built = capped_from_block_end(view, lower, lim, work).map(|b| (0.0, b));
        }
        let Some((v_start, branch)) = built else {
            return Err(Stuck { node: m, reason: Infeasibility::NoBackwardBranch });
        };
        let branch_nodes = branch.len();
        tracing::debug!(
            s_end_mm = nodes[m].s_mm,
            v_start,
            vbar = nodes[m].vbar_mm_s,
            s_from_mm = branch.last().map_or(nodes[m].s_mm, |b| nodes[b.0].s_mm),
            nodes = branch_nodes,
            evals = work.evals - evals_before,
            evals_per_node = (work.evals - evals_before) as f64 / branch_nodes.max(1) as f64,
            "backward branch of a section"
        );
        new_reach = new_reach.min(branch.last().map_or(m, |b| b.0));
        env.lay(CurveStart { node: m, v: v_start, a: 0.0, reads: reads.span() }, Arc::from(branch));
    }
    Ok(env)
}
