//! The look-ahead feedrate planner of Kopp et al. 2019: a C¹ path-velocity profile with
//! piecewise constant path jerk (eq. 2) under axis velocity, acceleration and jerk limits
//! (eq. 1a–1c, 7a–7d).
//!
//! Data flow inside the planner: elements → `sampling` (nodes s_i with A′…A‴ and the velocity
//! bound v̄, §2.2 and eq. 5–6) → blocks between stops (`block`) → `branch` and `forward`
//! (backward branches from the section ends, the forward branch, joins; §3, Fig. 3) →
//! [`Segment`]s handed on. The branch steps (`step`, eq. 7) pick the largest next velocity
//! whose interval keeps every limit; a viability test (`ramp`) replaces the paper's stepping
//! back, so the work per node is bounded. [`brake`] gives the fastest stop from any planned
//! state, [`export`] the sampled problem for an independent optimiser. See `docs/planner.md`
//! for the whole algorithm.
//!
//! The planner works online: it takes elements one at a time, keeps a horizon of at least
//! `planner.lookahead_mm` (or `lookahead_samples`) ahead of what it handed on, and plans the
//! horizon as if the motion had to stop at its end. It hands on only the part of the profile
//! that does not depend on that assumed stop, so every handed-over piece ends in a state from
//! which the machine can still stop within the planned path, and planning element by element
//! gives the same profile as planning the whole program.

mod block;
pub(crate) mod brake;
mod branch;
mod check;
mod envelope;
mod error;
pub mod export;
mod falsi;
mod forward;
mod hermite_basis;
mod interval;
mod join;
mod lanes;
mod limits;
mod node;
pub mod profile;
mod ramp;
mod reach;
mod repair;
mod resume;
mod sampling;
mod scurve;
mod step;
mod view;

pub use error::{Infeasibility, PlanError};
pub use limits::Limits;
pub use profile::{PathState, Segment};
pub(crate) use resume::{STANDSTILL_A_MM_S2, STANDSTILL_V_MM_S};
pub use step::Work;

use crate::Settings;
use crate::path::{Element, Path};
use node::Node;
use sampling::SamplingParams;
use std::collections::VecDeque;

/// Totals over a planning run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanStats {
    /// Nodes sampled.
    pub nodes: u64,
    /// Blocks (stop to stop, or horizon pieces) planned.
    pub blocks: u64,
    pub work: Work,
    /// Horizons that could not continue from the state the one before handed over and took
    /// that one's stop instead (see `Planner::retained_stop`).
    pub horizon_stops: u64,
    /// Horizons that could not continue from that state and braked along half of its stop
    /// before trying again (each try counts).
    pub horizon_brakes: u64,
    /// Nodes where no profile keeping the limits passed (the branches and the repairs of the
    /// block found none), so the motion stops there (`Planner::force_stop`).
    pub forced_stops: u64,
    /// The most work (`Work::units`) one block plan took, a failed one included, over all the
    /// calls it took.
    pub block_work_max: u64,
    /// Block searches a call paused, to go on at the next call (`CALL_WORK_UNITS`).
    pub search_pauses: u64,
}

impl PlanStats {
    /// Adds the counters of another planning run (a planner replaced by a replan).
    pub(crate) fn absorb(&mut self, other: &PlanStats) {
        self.nodes += other.nodes;
        self.blocks += other.blocks;
        self.work.add(&other.work);
        self.horizon_stops += other.horizon_stops;
        self.horizon_brakes += other.horizon_brakes;
        self.forced_stops += other.forced_stops;
        self.block_work_max = self.block_work_max.max(other.block_work_max);
        self.search_pauses += other.search_pauses;
    }
}

/// About the most work (`Work::units`) one block plan of `nodes` nodes takes, found or not (its
/// work budget, past which the planner stops at the node it is stuck at, and one round of the
/// search): `PlanStats::block_work_max` stays below it for the largest block's node count.
pub fn block_work_bound_units(nodes: usize) -> u64 {
    block::work_bound_units(nodes)
}

/// A retained stop at most this long is taken whole when the next horizon cannot continue
/// from the hand-over state; a longer one is followed half-way first
/// (`Planner::brake_along_stop`).
const STOP_TAKEN_WHOLE_MAX_INTERVALS: usize = 4;

/// Nodes a forced stop keeps from the block's ends (`Planner::force_stop`): a profile from
/// rest to rest takes at least three constant-jerk intervals.
const STOP_CLEARANCE_NODES: usize = 3;

/// A block longer than this many nodes is planned in chunks (`Planner::plan_horizon`): the
/// first `CHUNK_NODES` as if the motion stopped at the last of them, handing over what does
/// not depend on that stop, then on from the hand-over state, as consecutive horizons do. One
/// search over a long block of dense nodes (the tight curves of smoothed CAM data, a node every
/// few µm) repeats every pass over all its nodes after each repair, and so ran out of its work
/// budget and forced stops in mid-surface (issue 41: a block of 3 431 nodes on the family's
/// wander program, the 500 mm look-ahead of `3D_Chips.ngc`); a chunk's search needs only its
/// own repairs, within the budget of 1 000 units per node (`block::LONG_BLOCK_NODES`).
///
/// Measured on `3D_Chips.ngc` at a 500 mm look-ahead (motion s / forced stops), fixed chunk
/// lengths: 500 nodes 59.79 / 0, 700 60.16 / 0, 1 000 60.37 / 1, 2 000 60.66 / 0, 3 000
/// 61.74 / 7. Short chunks suit the tight curves of CAM data, long ones clean dense data (a
/// 10 000-point G06 spline at a 60 mm look-ahead: chunks of 400 gave 3.975 s against 3.879 s
/// and 2.7 × the work), so the length follows the work (`CHUNK_WORK_UNITS`); this is the
/// longest.
const CHUNK_NODES: usize = 2_000;
/// Work a chunk's search should take (`Work::units`, some 5 per µs): the next chunk has as
/// many nodes as the last chunk's work per node allows for this, at least `CHUNK_NODES_MIN`.
/// The cusp trochoid of 300 000 moves (about 1 000 units per node): longest call 258 ms
/// against 7.6 s with whole 2 000-node chunks in one call, motion 55.47 s against 55.60 s;
/// `3D_Chips.ngc` at 60 / 500 mm: 59.74 / 59.75 s against 59.87 / 60.66 s.
const CHUNK_WORK_UNITS: u64 = 200_000;
/// The shortest chunk the work allows: below it a chunk hands over less than a stopping
/// distance on CAM data, and its repairs cost more than they save.
const CHUNK_NODES_MIN: usize = 400;
/// The shortest chunk a retry from the hand-over state plans (each failed try halves it).
const RETRY_CHUNK_NODES_MIN: usize = 250;
/// A planning call returns at the first hand-over (a chunk's, a stop's, a brake along the kept
/// stop) at which the work it did reaches this (some 20 ms), or pauses a block's search at the
/// first end of a round (an envelope and a forward branch) past it; the next call goes on from
/// there, and the profile is the same as without the pause.
const CALL_WORK_UNITS: u64 = 100_000;

/// Interval lengths of a retained stop against the node spacing
/// ([`Planner::can_stop_within_horizon`]).
#[cfg(test)]
const STOP_CHECK_DS_TOL_MM: f64 = 1e-9;

/// The online planner.
pub struct Planner {
    lim: Limits,
    params: SamplingParams,
    lookahead_mm: f64,
    lookahead_samples: usize,
    /// Nodes of a chunk at most (`CHUNK_NODES`; shorter in tests).
    chunk_nodes: usize,
    /// Work after which a call returns (`CALL_WORK_UNITS`; other amounts in tests).
    call_units: u64,
    /// Nodes of the next chunk: at most `chunk_nodes`, fewer where the last chunk's search took
    /// much work per node (`CHUNK_WORK_UNITS`) or a retry from the hand-over state found no
    /// continuation (`RETRY_CHUNK_NODES_MIN`).
    chunk_next: usize,
    /// Elements received but not yet sampled (the newest waits for its successor).
    pending: VecDeque<Element>,
    /// The last sampled element and its end (for the joint with the next one).
    prev: Option<(Element, sampling::ElementEnd)>,
    since_stop_mm: f64,
    input_done: bool,
    /// The newest element ends at rest, though its successor is not here yet
    /// ([`Planner::rest_follows`]).
    rest_follows: bool,
    /// `nodes` ends in the stop node [`Planner::rest_follows`] put there ahead of the element
    /// that starts at it; that element's own start node replaces it.
    rest_node: bool,
    end_sampled: bool,
    final_dwell_s: f64,
    /// Nodes from the hand-over point on; `nodes[0]` has the state `start`.
    nodes: Vec<Node>,
    start: (f64, f64),
    /// The path starts in motion (`with_start_state`): its first node is no stop.
    start_moving: bool,
    t_now_s: f64,
    /// Node count at the last plan (replan only after the horizon grew enough).
    planned_len: usize,
    /// A feasible profile from the start whose velocity floors the bounds (`resume`).
    vbar_floor: Vec<Segment>,
    /// The rest of the last horizon's plan from the hand-over node to where it came to rest
    /// (its virtual end): the stop the hand-over state is guaranteed to have. It is not a
    /// second way of computing a stop but the part of the plan not handed on yet, kept for the
    /// next horizon to fall back on; a stop from any state of a planned motion is
    /// [`brake::brake_along`].
    retained_stop: Vec<interval::Interval>,
    /// The block search the last call paused (`CALL_WORK_UNITS`), which the next call resumes
    /// before it takes new elements.
    paused: Option<Paused>,
    out: Vec<Segment>,
    pub stats: PlanStats,
}

/// A block search a planning call paused, and where the horizon's loop stood: the block runs
/// from node 0 (what was final before it was handed on, so the block starts at the hand-over
/// state `Planner::start`) to node `end`.
struct Paused {
    search: block::BlockSearch,
    end: usize,
    /// The block ends at a chunk's end (`Planner::plan_horizon`).
    chunk_cut: bool,
    /// The block's end is planned as a stop, though it is none; its own v̄.
    virtual_end: Option<f64>,
    /// Whether the horizon is still planned in chunks.
    chunking: bool,
}

impl Planner {
    pub fn new(settings: &Settings) -> Self {
        Self::with_limits(settings, Limits::from_settings(settings))
    }

    fn with_limits(settings: &Settings, lim: Limits) -> Self {
        let p = &settings.planner;
        Self {
            lim,
            params: SamplingParams::from_settings(settings),
            lookahead_mm: p.lookahead_mm,
            lookahead_samples: p.lookahead_samples.unwrap_or(usize::MAX),
            chunk_nodes: CHUNK_NODES,
            call_units: CALL_WORK_UNITS,
            chunk_next: CHUNK_NODES,
            pending: VecDeque::new(),
            prev: None,
            since_stop_mm: 0.0,
            input_done: false,
            rest_follows: false,
            rest_node: false,
            end_sampled: false,
            final_dwell_s: 0.0,
            nodes: Vec::new(),
            start: (0.0, 0.0),
            start_moving: false,
            t_now_s: 0.0,
            planned_len: 0,
            vbar_floor: Vec::new(),
            retained_stop: Vec::new(),
            paused: None,
            out: Vec::new(),
            stats: PlanStats::default(),
        }
    }

    pub fn limits(&self) -> &Limits {
        &self.lim
    }

    /// Adds the next element of the path.
    pub fn push(&mut self, element: Element) {
        debug_assert!(!self.rest_follows || element.stops_before(), "rest_follows, then an element that starts moving");
        self.rest_follows = false;
        self.pending.push_back(element);
    }

    /// The element pushed last ends at rest: the one after it, not pushed yet, starts with a
    /// stop (the smoothing stage knows this before it can give that element out). The path up
    /// to the stop is then planned and handed on whole without waiting for what follows: the
    /// first motion of a program that begins with a rapid to the part does not wait for the
    /// first smoothing window of the cut after it.
    pub fn rest_follows(&mut self) {
        self.rest_follows = !self.pending.is_empty();
    }

    /// No more elements follow; `final_dwell_s` is the dwell after the last one.
    pub fn finish(&mut self, final_dwell_s: f64) {
        self.input_done = true;
        self.final_dwell_s = final_dwell_s;
    }

    /// A call paused a block's search (`CALL_WORK_UNITS`): the next call goes on with it and
    /// takes no new elements before it ends.
    pub(crate) fn search_paused(&self) -> bool {
        self.paused.is_some()
    }

    /// Everything received has been planned and handed on.
    pub fn done(&self) -> bool {
        self.input_done && self.end_sampled && self.nodes.len() <= 1 && self.pending.is_empty()
    }

    /// Plans as far as the look-ahead allows, or up to the first hand-over after
    /// `CALL_WORK_UNITS` of work, and returns the segments that are final. Call it again until
    /// [`Planner::done`]: a call that stopped early goes on at the next one.
    pub fn plan(&mut self) -> Result<Vec<Segment>, PlanError> {
        if self.paused.is_some() {
            // The paused search goes on over the same nodes: new elements wait until it ends.
            self.plan_horizon(self.end_sampled)?;
            return Ok(std::mem::take(&mut self.out));
        }
        self.sample_pending();
        if self.nodes.len() < 2 {
            if self.end_sampled {
                // The motion was planned to the path's end before the planner learned that it
                // is the end ([`Planner::rest_follows`]).
                self.emit_final_dwell();
            }
            return Ok(std::mem::take(&mut self.out));
        }
        let complete = self.end_sampled;
        let ahead_mm = self.nodes[self.nodes.len() - 1].s_mm - self.nodes[0].s_mm;
        let ahead_n = self.nodes.len();
        let enough = ahead_mm >= self.lookahead_mm || ahead_n >= self.lookahead_samples;
        // Replan when the program is complete, or when the horizon is full and has grown by a
        // quarter since the last plan (so each node is planned a bounded number of times).
        let grown = self.nodes.len() >= self.planned_len + self.planned_len / 4 + 16;
        // A horizon that ends in a stop plans to rest there and hands on everything up to it.
        let ends_at_rest = self.nodes.last().is_some_and(|n| n.stop) && self.nodes.len() > self.planned_len;
        if complete || (enough && grown) || ends_at_rest {
            self.plan_horizon(complete)?;
        }
        Ok(std::mem::take(&mut self.out))
    }

    /// After [`Planner::finish`]: plans the rest of the path, call after call, and returns all
    /// its segments.
    pub(crate) fn plan_to_end(&mut self) -> Result<Vec<Segment>, PlanError> {
        let mut segments = Vec::new();
        loop {
            segments.extend(self.plan()?);
            if self.done() {
                return Ok(segments);
            }
        }
    }

    /// Plans the horizon now, however short, when elements came since the last plan: for a
    /// path that is not known further yet (a program still arriving). What it hands on does
    /// not depend on the stop assumed at the horizon's end, as always.
    pub(crate) fn plan_now(&mut self) -> Result<Vec<Segment>, PlanError> {
        if self.paused.is_some() {
            return self.plan();
        }
        self.sample_pending();
        if self.nodes.len() >= 2 && (self.end_sampled || self.nodes.len() > self.planned_len) {
            self.plan_horizon(self.end_sampled)?;
        }
        Ok(std::mem::take(&mut self.out))
    }

    /// Whether the machine, in the state handed over last, can still come to rest within the
    /// path planned so far (the nodes held for the horizon): the invariant every hand-over
    /// keeps. The stop the last horizon planned proves it when it starts in that state, runs
    /// node to node and ends at rest; otherwise a stop is planned on a copy. The planner is
    /// unchanged.
    #[cfg(test)]
    pub(crate) fn can_stop_within_horizon(&self) -> bool {
        if self.nodes.len() < 2 {
            return self.start.0.abs() < 1e-9 && self.start.1.abs() < 1e-6;
        }
        if self.retained_stop_holds() {
            return true;
        }
        // The nodes up to the first stop (or the horizon end, taken as one).
        let end = (1..self.nodes.len()).find(|&i| self.nodes[i].stop).unwrap_or(self.nodes.len() - 1);
        let mut nodes = self.nodes[..=end].to_vec();
        if let Some(last) = nodes.last_mut() {
            last.vbar_mm_s = 0.0;
        }
        block::plan_block(&mut nodes, self.start, false, &self.lim, &mut Work::default()).is_ok()
    }

    /// Whether `retained_stop` is a stop from the hand-over state within the held nodes.
    #[cfg(test)]
    fn retained_stop_holds(&self) -> bool {
        let (Some(first), Some(last)) = (self.retained_stop.first(), self.retained_stop.last()) else { return false };
        let fits = self.retained_stop.len() < self.nodes.len()
            && self.retained_stop.iter().enumerate().all(|(k, iv)| {
                let ds = self.nodes[k + 1].s_mm - self.nodes[k].s_mm;
                (iv.ds_mm - ds).abs() <= STOP_CHECK_DS_TOL_MM
            });
        fits && first.v0 == self.start.0
            && first.a0 == self.start.1
            && last.v1().abs() <= forward::REST_V_TOL_MM_S
            && last.a1().abs() <= forward::REST_A_TOL_MM_S2
    }

    /// Plans a whole path at once (the offline use of the same online machinery).
    pub fn plan_path(settings: &Settings, path: &Path) -> Result<(Vec<Segment>, PlanStats), PlanError> {
        let mut planner = Planner::new(settings);
        planner.lookahead_mm = f64::INFINITY;
        for e in &path.elements {
            planner.push(e.clone());
        }
        planner.finish(path.final_dwell_s);
        let segments = planner.plan_to_end()?;
        Ok((segments, planner.stats))
    }

    /// The nodes of a whole path as the planner samples them (for tests and tools).
    pub(crate) fn sample_path(settings: &Settings, path: &Path) -> Vec<Node> {
        let mut planner = Planner::new(settings);
        for e in &path.elements {
            planner.push(e.clone());
        }
        planner.finish(path.final_dwell_s);
        planner.sample_pending();
        planner.nodes
    }

    /// Samples every pending element whose successor is known (or all, at the end).
    fn sample_pending(&mut self) {
        while let Some(e) = self.pending.front() {
            let next_stops = match self.pending.get(1) {
                Some(next) => next.stops_before(),
                None if self.input_done || self.rest_follows => true,
                None => break,
            };
            let mut replaced_first = false;
            if std::mem::take(&mut self.rest_node) {
                // The element starting at the stop `rest_follows` planned to brings its own
                // start node (its dwell, line, and the geometry leaving the stop).
                let held = self.nodes.pop().expect("the stop node of rest_follows");
                self.stats.nodes -= 1;
                debug_assert!(held.stop && (held.s_mm - e.s_start_mm).abs() <= 1e-9 * (1.0 + held.s_mm.abs()));
                replaced_first = self.nodes.is_empty();
            }
            let count_before = self.nodes.len();
            let end = sampling::sample_element(
                self.prev.as_ref().map(|(p, end)| (p, end)),
                self.start_moving,
                e,
                next_stops,
                &mut self.since_stop_mm,
                &self.lim,
                &self.params,
                &mut self.nodes,
            );
            self.stats.nodes += (self.nodes.len() - count_before) as u64;
            self.refine_vbar(count_before.saturating_sub(1));
            if !self.vbar_floor.is_empty() {
                resume::raise_to_floor(&mut self.nodes[count_before.saturating_sub(1)..], &self.vbar_floor);
            }
            if count_before == 0 && self.start_moving && !replaced_first {
                resume::admit_start_state(&mut self.nodes[0], self.start);
            }
            self.prev = self.pending.pop_front().map(|e| (e, end));
        }
        if std::mem::take(&mut self.rest_follows) && !self.input_done {
            self.rest_node = self.push_end_node(0.0);
        }
        if self.input_done && self.pending.is_empty() && !self.end_sampled {
            if std::mem::take(&mut self.rest_node) {
                // The stop `rest_follows` planned to is the path's end.
                let end = self.nodes.last_mut().expect("the stop node of rest_follows");
                end.dwell_s = self.final_dwell_s;
            } else {
                self.push_end_node(self.final_dwell_s);
            }
            self.end_sampled = true;
        }
    }

    /// Puts in the stop node at the end of the last sampled element, with `dwell_s` after it;
    /// `false` if no element was sampled.
    fn push_end_node(&mut self, dwell_s: f64) -> bool {
        let Some((last, end)) = &self.prev else { return false };
        self.nodes.push(sampling::end_node(last, end, dwell_s, &self.params));
        self.stats.nodes += 1;
        self.refine_vbar(self.nodes.len().saturating_sub(2));
        true
    }

    /// Lowers the velocity bounds of nodes `from..` by the minimum of v̄ inside each interval
    /// whose both nodes now exist. The acceleration-only bound is lowered only by a minimum
    /// below both nodes' bounds: one falling across the interval is kept by the lower node
    /// already, and lowering the higher node to it cuts a notch into a steep ceiling (beside a
    /// long interval into an orientation swing of rotary axes), under which the time-optimal
    /// motion would run and at which no backward branch could start.
    fn refine_vbar(&mut self, from: usize) {
        for i in from..self.nodes.len().saturating_sub(1) {
            let (v, v_flat) = check::interior_vbar(&view::View::forward(&self.nodes).interval_geom(i), &self.lim);
            let below_both = v < self.nodes[i].vbar_mm_s.min(self.nodes[i + 1].vbar_mm_s);
            for k in [i, i + 1] {
                let node = &mut self.nodes[k];
                if !node.stop {
                    if below_both {
                        node.vbar_mm_s = node.vbar_mm_s.min(v);
                    }
                    node.vbar_flat_mm_s = node.vbar_flat_mm_s.min(v_flat);
                }
            }
        }
    }

    /// The next horizon found no continuation from the state at node `stop_from`, where what is
    /// left of the last horizon's stop (`retained_stop`) starts: that horizon handed over only what
    /// can still stop along it. Emits half of it (at most log₂ of its length more plans) and
    /// keeps the rest, or, with at most `STOP_TAKEN_WHOLE_MAX_INTERVALS` left, all of it (the
    /// motion comes to rest). Returns the node reached and the state there.
    fn brake_along_stop(&mut self, stop_from: usize, reason: &str) -> (usize, (f64, f64)) {
        let stop = std::mem::take(&mut self.retained_stop);
        let k = if stop.len() > STOP_TAKEN_WHOLE_MAX_INTERVALS { stop.len() / 2 } else { stop.len() };
        self.emit(stop_from, &stop[..k]);
        let reached = stop_from + k;
        if let Some(rest) = stop.get(k) {
            tracing::warn!(
                s_from_mm = self.nodes[stop_from].s_mm,
                s_mm = self.nodes[reached].s_mm,
                reason,
                "planner: no continuation from the hand-over state; braking along its stop and retrying"
            );
            self.stats.horizon_brakes += 1;
            let state = (rest.v0, rest.a0);
            self.retained_stop = stop[k..].to_vec();
            return (reached, state);
        }
        tracing::warn!(
            s_stop_mm = self.nodes[reached].s_mm,
            reason,
            "planner: no continuation from the hand-over state; stopping where the last horizon ended"
        );
        self.stats.horizon_stops += 1;
        (reached, (0.0, 0.0))
    }

    /// The block `first..=last` found no profile through node `at`: makes the interior node
    /// nearest to it a stop (v̄ = 0, the motion comes to rest there), counted and logged.
    /// `None` where the block has no interior node left to stop at.
    fn force_stop(&mut self, first: usize, last: usize, at: usize, reason: Infeasibility) -> Option<usize> {
        // A stop needs a few intervals on both sides to brake into and to leave (jerk −, 0, +).
        if last < first + 2 * STOP_CLEARANCE_NODES {
            return None;
        }
        let k = at.clamp(first + STOP_CLEARANCE_NODES, last - STOP_CLEARANCE_NODES);
        let node = &mut self.nodes[k];
        node.stop = true;
        node.vbar_mm_s = 0.0;
        node.vbar_flat_mm_s = 0.0;
        self.stats.forced_stops += 1;
        tracing::warn!(
            s_mm = node.s_mm,
            line = node.line,
            reason = reason.as_str(),
            "planner: no profile through this node; stopping there"
        );
        Some(k)
    }

    /// Plans the current horizon and hands on what is final, or goes on with the block search
    /// the last call paused.
    fn plan_horizon(&mut self, complete: bool) -> Result<(), PlanError> {
        let mut resumed = self.paused.take();
        if resumed.is_none() {
            self.validate_bounds()?;
        }
        let n = self.nodes.len();
        let last_is_real_end = complete;
        // Blocks end at stops; the horizon end counts as one.
        let mut block_start = 0;
        let mut handed = 0; // nodes[..=handed] are final
        let mut state = self.start;
        let mut idx = 1;
        // Node where `retained_stop` (what is left of it) starts. A paused block started at
        // node 0 after its hand-over; where it did not start where the stop kept begins, no
        // stop is kept (a block planned from there replaced it), and node 0 serves as well.
        let mut stop_from = 0;
        // Off for the rest of the horizon once a chunk handed over nothing (see below).
        let mut chunking = resumed.as_ref().is_none_or(|p| p.chunking);
        // Work done in this call, and whether the call ended before the horizon's end.
        let mut call_units = 0u64;
        let mut bounded = false;
        while idx < n {
            // The search, and its work before this call.
            let (mut search, before, chunk_cut, virtual_end) = match resumed.take() {
                Some(p) => {
                    idx = p.end;
                    let before = p.search.work;
                    (p.search, before, p.chunk_cut, p.virtual_end)
                }
                None => {
                    let is_end = idx == n - 1;
                    // A chunk reaches past the stop kept from the hand-over state, so that a
                    // chunk with no continuation can still brake along that stop.
                    let past_stop = block_start != stop_from || idx > stop_from + self.retained_stop.len();
                    let chunk_cut = chunking
                        && !is_end
                        && !self.nodes[idx].stop
                        && idx - block_start >= self.chunk_next.min(self.chunk_nodes)
                        && past_stop;
                    if !(self.nodes[idx].stop || is_end || chunk_cut) {
                        idx += 1;
                        continue;
                    }
                    // A chunk's end is planned as a stop, as the horizon's end is.
                    let virtual_end = ((is_end && !last_is_real_end && !self.nodes[idx].stop) || chunk_cut)
                        .then(|| std::mem::replace(&mut self.nodes[idx].vbar_mm_s, 0.0));
                    let search = block::BlockSearch::new(
                        &mut self.nodes[block_start..=idx],
                        state,
                        virtual_end.is_none(),
                        &self.lim,
                    );
                    (search, Work::default(), chunk_cut, virtual_end)
                }
            };
            let run =
                search.run(&mut self.nodes[block_start..=idx], &self.lim, self.call_units.saturating_sub(call_units));
            let this_call = search.work.since(&before);
            call_units += this_call.units();
            self.stats.work.add(&this_call);
            let Some(result) = run else {
                // Enough for one call, in the middle of a block's search: the next call goes on
                // with it, from the hand-over state at its first node.
                debug_assert_eq!(block_start, handed);
                self.stats.search_pauses += 1;
                self.paused = Some(Paused { search, end: idx - handed, chunk_cut, virtual_end, chunking });
                bounded = true;
                break;
            };
            let work = search.work;
            self.stats.block_work_max = self.stats.block_work_max.max(work.units());
            if let Some(vbar) = virtual_end {
                self.nodes[idx].vbar_mm_s = vbar;
            }
            let plan = match result {
                Ok(plan) => plan,
                Err(stuck)
                    if block_start == stop_from
                        && !self.retained_stop.is_empty()
                        && stop_from + self.retained_stop.len() < idx =>
                {
                    // No continuation from the hand-over state with the longer horizon (a
                    // dead end the branches do not find their way out of).
                    let (from, brake_state) = self.brake_along_stop(stop_from, stuck.reason.as_str());
                    (stop_from, handed, block_start, idx, state) = (from, from, from, from + 1, brake_state);
                    // The dead end lies near the hand-over state: the next try plans a shorter
                    // chunk, which costs less and needs fewer repairs.
                    self.chunk_next = (self.chunk_next.min(self.chunk_nodes) / 2).max(RETRY_CHUNK_NODES_MIN);
                    if call_units >= self.call_units {
                        bounded = true;
                        break;
                    }
                    continue;
                }
                Err(stuck) => {
                    // Where the branches and their repairs find no profile through a node,
                    // the motion stops there: the block splits into two that each end at rest,
                    // planned again from the block start.
                    let at = block_start + stuck.node.min(idx - block_start);
                    let Some(k) = self.force_stop(block_start, idx, at, stuck.reason) else {
                        let node = &self.nodes[at];
                        return Err(PlanError::Infeasible { s_mm: node.s_mm, line: node.line, reason: stuck.reason });
                    };
                    debug_assert!(block_start < k && k < idx);
                    idx = block_start + 1;
                    continue;
                }
            };
            self.stats.blocks += 1;
            tracing::debug!(
                s_from_mm = self.nodes[block_start].s_mm,
                s_to_mm = self.nodes[idx].s_mm,
                nodes = idx - block_start + 1,
                evals = work.evals,
                evals_per_node = work.evals as f64 / (idx - block_start) as f64,
                ramps = work.ramps,
                joins = work.joins,
                repairs = work.repairs,
                "planned section block"
            );
            if !plan.node_aligned {
                self.retained_stop.clear();
                self.emit_block(block_start, idx, &plan.intervals);
                handed = idx;
                state = (0.0, 0.0);
                block_start = idx;
                idx += 1;
                continue;
            }
            let final_count = if virtual_end.is_some() { plan.final_before } else { plan.intervals.len() };
            if chunk_cut && final_count == 0 {
                // Nothing of the chunk is final (its whole profile depends on the stop at its
                // end): the block is planned whole from here, as without chunks.
                chunking = false;
                idx += 1;
                continue;
            }
            // The stop kept from the hand-over state is replaced only by a plan that hands
            // something on: a chunk that hands on nothing leaves it the fallback of the block
            // planned whole.
            if block_start == stop_from {
                self.retained_stop.clear();
            }
            self.emit(block_start, &plan.intervals[..final_count]);
            handed = block_start + final_count;
            if final_count < plan.intervals.len() {
                let iv = &plan.intervals[final_count];
                state = (iv.v0, iv.a0);
                self.retained_stop = plan.intervals[final_count..].to_vec();
                if chunk_cut {
                    let per_node = work.units() / (idx - block_start) as u64;
                    let fits = (CHUNK_WORK_UNITS / per_node.max(1)) as usize;
                    self.chunk_next = fits.clamp(CHUNK_NODES_MIN.min(self.chunk_nodes), self.chunk_nodes);
                    if call_units >= self.call_units {
                        // Enough for one call: the next call goes on from the hand-over state,
                        // exactly as this one would (the chunk after this one does not depend
                        // on the nodes beyond it).
                        bounded = true;
                        break;
                    }
                    // On from the hand-over state, with the rest of the chunk's plan as the
                    // stop kept, exactly as the next horizon would go on.
                    (stop_from, block_start, idx) = (handed, handed, handed + 1);
                    continue;
                }
                break;
            }
            state = (0.0, 0.0);
            block_start = idx;
            idx += 1;
            if call_units >= self.call_units && idx < n {
                // Handed over to a stop: the next call goes on from there.
                bounded = true;
                break;
            }
        }
        if handed > 0 {
            self.nodes.drain(..handed);
        }
        self.start = state;
        // A call that stopped after a chunk goes on at the next call, whatever came since.
        self.planned_len = if bounded { 0 } else { self.nodes.len() };
        if complete {
            self.emit_final_dwell();
        }
        Ok(())
    }

    /// Once the motion has reached the path's end (its last node, alone): the dwell there.
    fn emit_final_dwell(&mut self) {
        let [end] = self.nodes.as_mut_slice() else { return };
        let dwell = (end.s_mm, std::mem::take(&mut end.dwell_s), end.line);
        self.push_dwell(dwell);
    }

    /// Appends a dwell `(s_mm, dt_s, line)` (none where `dt_s` is 0).
    fn push_dwell(&mut self, (s0_mm, dt_s, line): (f64, f64, u32)) {
        if dt_s > 0.0 {
            self.out.push(Segment { s0_mm, t0_s: self.t_now_s, dt_s, line, ..Segment::default() });
            self.t_now_s += dt_s;
        }
    }

    /// Appends the segments of `intervals`, which start at node `first`.
    fn emit(&mut self, first: usize, intervals: &[interval::Interval]) {
        for (k, iv) in intervals.iter().enumerate() {
            let node = &self.nodes[first + k];
            if node.stop {
                self.push_dwell((node.s_mm, node.dwell_s, node.line));
            }
            let node = &self.nodes[first + k];
            self.out.push(Segment {
                s0_mm: node.s_mm,
                t0_s: self.t_now_s,
                v0: iv.v0,
                a0: iv.a0,
                j: iv.j,
                dt_s: iv.t_s,
                ds_mm: iv.ds_mm,
                line: node.line,
            });
            self.t_now_s += iv.t_s;
        }
        // A dwell at the first node is emitted once: clear it on the handed-over nodes.
        for node in &mut self.nodes[first..first + intervals.len()] {
            node.dwell_s = 0.0;
        }
    }

    /// Appends a time-domain profile from node `first` to node `last` (not node-aligned).
    fn emit_block(&mut self, first: usize, last: usize, intervals: &[interval::Interval]) {
        let start = &self.nodes[first];
        if start.stop {
            self.push_dwell((start.s_mm, start.dwell_s, start.line));
        }
        let mut s = self.nodes[first].s_mm;
        let end_s = self.nodes[last].s_mm;
        for (i, iv) in intervals.iter().enumerate() {
            // The last piece ends exactly at the block end, whatever the rounding of the sum.
            let ds = if i + 1 == intervals.len() { end_s - s } else { iv.ds_mm };
            // The program line of the element the piece starts in.
            let k = first + self.nodes[first..=last].partition_point(|n| n.s_mm <= s).saturating_sub(1);
            let line = self.nodes[k.min(last)].line;
            self.out.push(Segment {
                s0_mm: s,
                t0_s: self.t_now_s,
                v0: iv.v0,
                a0: iv.a0,
                j: iv.j,
                dt_s: iv.t_s,
                ds_mm: ds,
                line,
            });
            self.t_now_s += iv.t_s;
            s += ds;
        }
        for node in &mut self.nodes[first..last] {
            node.dwell_s = 0.0;
        }
    }

    fn validate_bounds(&self) -> Result<(), PlanError> {
        for (i, node) in self.nodes.iter().enumerate() {
            let v = node.vbar_mm_s;
            let interior = i > 0 && i + 1 < self.nodes.len() && !node.stop;
            if v.is_nan() || (interior && v <= 0.0) {
                return Err(PlanError::Immovable { s_mm: node.s_mm, line: node.line, vbar_mm_s: v });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
