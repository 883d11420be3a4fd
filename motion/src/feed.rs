//! The front door from a program to planned motion: [`Feed`] reads a program (from a file, from
//! text, continued by appended text, or a path held whole), smooths its G64 runs, plans the
//! path velocity ahead of the machine and hands out the planned [`Segment`]s in time order.
//!
//! ```text
//!  program text ─► ProgramStream ─► Prep (G64) ─► window of elements ─► Planner ─► segments
//!                  (program/)       (prep/)       s from a little behind   (planner/)   handed out
//!                                                 the machine to ahead
//! ```
//!
//! A caller asks for motion ([`Feed::plan`]: at least so many seconds planned and not yet
//! handed out), takes segments ([`Feed::take`], [`Feed::pop_segment`]), evaluates the geometry
//! they run on ([`Feed::path`]) and drops what the machine has passed ([`Feed::trim_before`]):
//! memory grows with the look-ahead, never with the program. A feed replans from any planned
//! state ([`Feed::replan`], after a new feed override) or from rest ([`Feed::restart_at_rest`],
//! after a hold or a failure), and gives the fastest stop from any planned state ([`Feed::stop_from`]).
//!
//! The planner plans after the same elements however the program is read (just in time, or
//! ahead with [`Feed::read_ahead`]): after each read of the program, which hands the smoothing
//! stage one programmed element. So a program planned through a `Feed` gives the same motion to
//! the last bit in the daemon and in `interpd plan`.

mod approach;
mod reader;
mod window;

pub use approach::AT_POSITION_TOL;

use crate::Settings;
use crate::path::{AxisDerivs, AxisVec, Path};
use crate::planner::brake::{brake_along, next_stop_s};
use crate::planner::{Limits, PlanError, PlanStats, Planner, STANDSTILL_A_MM_S2, STANDSTILL_V_MM_S, Segment};
use crate::prep::{PrepError, PrepStats};
use crate::program::{Appends, ProgramErrors, ProgramStream, Summary};
use std::collections::VecDeque;
use std::time::{Duration, Instant};
use window::{After, Window};

/// A segment this much longer than the time asked for is split rather than handed out whole
/// (fraction of the time asked for; [`Feed::take`]).
const SPLIT_OVERHANG: f64 = 0.25;

/// Why a feed cannot go on: the program's errors (file, line, column), the smoothing stage's or
/// the planner's, each as it was raised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeedError {
    #[error("{0}")]
    Program(#[from] ProgramErrors),
    #[error("path smoothing: {0}")]
    Prep(#[from] PrepError),
    #[error("{0}")]
    Plan(#[from] PlanError),
    /// The thread that reads the program ahead could not be started (the system's message).
    #[error("cannot start the thread that reads the program: {0}")]
    ReaderThread(String),
    /// The thread that reads the program ahead ended without its read: a bug in it.
    #[error("the thread that reads the program ended unexpectedly")]
    ReaderThreadEnded,
}

/// Where a feed's motion stands: what it has read, planned and handed out.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Progress {
    /// Program lines read (0 for a path held whole).
    pub lines_read: u32,
    /// Where the path read so far ends, mm.
    pub read_to_mm: f64,
    /// Where the elements given to the planner end, mm.
    pub planned_to_mm: f64,
    /// Motion planned and not yet handed out, s.
    pub buffered_s: f64,
    /// Segments handed out since the feed opened (a split one counts once per part).
    pub segments: u64,
    /// The program waits for appended text.
    pub waiting_for_text: bool,
    /// The whole motion is planned and handed out ([`Feed::finished`]).
    pub finished: bool,
}

/// Counters and timings of a feed since it opened.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeedStats {
    /// Reading and parsing the program, s.
    pub read_s: f64,
    /// The smoothing stage, s.
    pub prep_s: f64,
    /// Waiting for the thread that reads the program ([`FeedBuilder::read_in_thread`]), s.
    pub read_wait_s: f64,
    /// The planner, s.
    pub plan_s: f64,
    /// The longest single planner call, s.
    pub plan_call_max_s: f64,
    /// The longest step of one read of the program taken by the planner and planned (reading
    /// and smoothing included), s: what motion planned earlier must outlast.
    pub step_max_s: f64,
    /// Segments planned.
    pub segments: u64,
    /// Planner restarts ([`Feed::replan`], [`Feed::restart_at_rest`]).
    pub replans: u64,
    /// The smoothing stage's counters (all zero for a path held whole).
    pub prep: PrepStats,
    /// The planner's counters, over every planner of the feed.
    pub plan: PlanStats,
}

/// How a feed starts: see [`Feed::builder`].
#[derive(Debug, Clone)]
pub struct FeedBuilder<'a> {
    settings: &'a Settings,
    here: Option<AxisVec>,
    appends: Option<Appends>,
    track_modal: bool,
    feed_override: f64,
    read_thread: Option<fn()>,
}

impl FeedBuilder<'_> {
    /// Reads and smooths the program in a thread of its own, up to a look-ahead length ahead of
    /// the planner ([`Feed::read_ahead`] then takes what it has read and never waits), so that
    /// a planning step never waits for the smoothing stage's window solves. `on_start` runs first
    /// in the thread (to set its scheduling). The motion is the same to the last bit. Not for a
    /// program continued by appended text, nor a path held whole.
    pub fn read_in_thread(mut self, on_start: fn()) -> Self {
        self.read_thread = Some(on_start);
        self
    }

    /// The machine stands at `here`: a straight rapid move (G0) to the program's start runs
    /// first when that lies elsewhere. Without it the motion starts at the program's start.
    pub fn start_from(mut self, here: AxisVec) -> Self {
        self.here = Some(here);
        self
    }

    /// The program goes on with the text appended to `appends` (a program loaded without an
    /// end; see [`crate::program::check_open`]).
    pub fn appends(mut self, appends: &Appends) -> Self {
        self.appends = Some(appends.clone());
        self
    }

    /// Records where the program's tool and offset state changes, for
    /// [`Feed::take_modal_change`].
    pub fn track_modal(mut self) -> Self {
        self.track_modal = true;
        self
    }

    /// Scales the programmed feeds by `factor` (> 0; rapid moves and the axis limits are not
    /// scaled).
    pub fn feed_override(mut self, factor: f64) -> Self {
        self.feed_override = factor;
        self
    }

    /// Opens the program file at `path` (named as given in messages).
    pub fn open_file(self, path: &std::path::Path) -> Result<Feed, FeedError> {
        let stream = ProgramStream::open(path, self.settings)?;
        self.open_stream(stream)
    }

    /// Opens program text held in memory (`name` names it in messages). Fails only where the
    /// reading thread asked for cannot start.
    pub fn open_text(self, name: &str, text: impl Into<String>) -> Result<Feed, FeedError> {
        let stream = ProgramStream::from_text(text.into(), name, self.settings);
        self.open_stream(stream)
    }

    /// A feed along a path made whole (MDI blocks, motion-law lines), planned as it is: it is
    /// not smoothed again.
    pub fn whole(self, path: Path) -> Feed {
        let path = match self.here {
            Some(here) => approach::with_approach(self.settings, &here, path),
            None => path,
        };
        self.build(Window::whole(path))
    }

    fn open_stream(self, mut stream: ProgramStream) -> Result<Feed, FeedError> {
        let start = stream.start();
        let before = approach::approach(self.settings, &self.here.unwrap_or(start), &start);
        let buffer = self.appends.as_ref().map(Appends::buffer);
        if self.track_modal {
            stream.track_modal();
        }
        let window = Window::stream(stream, before, self.settings, buffer, self.read_thread)?;
        Ok(self.build(window))
    }

    fn build(self, window: Window) -> Feed {
        Feed {
            settings: self.settings.clone(),
            window,
            planner: Planner::new(self.settings),
            feed_override: self.feed_override,
            cursor: Cursor::at(0.0),
            buffer: VecDeque::new(),
            handed_out: 0,
            timing: Timing::default(),
            earlier_plans: PlanStats::default(),
            replans: 0,
        }
    }
}

/// Where the planner stands in the window.
#[derive(Debug, Clone, Copy)]
struct Cursor {
    /// Where the planner's path starts (the feed's start, or where it was replanned from): the
    /// element containing it is cut there.
    plan_from_s_mm: f64,
    /// Where the last element given to the planner ends, mm.
    pushed_end_mm: f64,
    /// Index (in the whole path) of the next element for the planner; `None` until the element
    /// at `plan_from_s_mm` is found.
    next_element: Option<usize>,
    /// The next element for the planner is the first of its path: cut at `plan_from_s_mm`.
    cut_first: bool,
    /// The planner was told that no element follows.
    finished_input: bool,
    /// Elements given to the planner since the feed (re)started at rest.
    pushed: u64,
    /// The program waits for appended text and nothing of it is left to plan.
    idle_for_text: bool,
    /// The program waits for appended text and the planner was told to stop at the end of
    /// what is there: the motion ends at rest there, and a restart continues it.
    stopped_for_text: bool,
    /// The planner was told that the element at this index starts at rest before it was
    /// read ([`Planner::rest_follows`]).
    told_rest_before: Option<usize>,
}

impl Cursor {
    fn at(s_mm: f64) -> Cursor {
        Cursor {
            plan_from_s_mm: s_mm,
            pushed_end_mm: s_mm,
            next_element: None,
            cut_first: false,
            finished_input: false,
            pushed: 0,
            idle_for_text: false,
            stopped_for_text: false,
            told_rest_before: None,
        }
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Timing {
    plan: Duration,
    plan_call_max: Duration,
    step_max: Duration,
    segments: u64,
}

/// A program (or a path held whole) on its way to planned motion; see the [module](self).
pub struct Feed {
    settings: Settings,
    window: Window,
    planner: Planner,
    feed_override: f64,
    cursor: Cursor,
    /// Planned segments not yet handed out.
    buffer: VecDeque<Segment>,
    handed_out: u64,
    timing: Timing,
    /// The counters of planners replaced by replans.
    earlier_plans: PlanStats,
    replans: u64,
}

impl Feed {
    /// How a feed opens, with `settings` (the machine's axes and limits, the planner's and the
    /// smoothing stage's settings, the tool table and work offsets the program is read with):
    /// `Feed::builder(&settings).start_from(here).open_file(path)`.
    pub fn builder(settings: &Settings) -> FeedBuilder<'_> {
        FeedBuilder { settings, here: None, appends: None, track_modal: false, feed_override: 1.0, read_thread: None }
    }

    /// The elements held: from a little behind the machine (what [`Feed::trim_before`] left) to
    /// as far as the program is read. Path positions are absolute.
    pub fn path(&self) -> &Path {
        self.window.path()
    }

    /// The axis limits the planner keeps.
    pub fn limits(&self) -> &Limits {
        self.planner.limits()
    }

    /// Where the motion starts (the machine position, or the program's start) and the program
    /// line of the first element; reads the program's first element.
    pub fn start(&mut self) -> Result<(AxisVec, u32), FeedError> {
        let line = self.window.element(0, false)?.map_or(0, |(e, _)| e.source.line);
        Ok((self.window.path().start, line))
    }

    /// Position, A′, A″, A‴ at path position `s_mm` and the program line there, reading on
    /// until the path holds it.
    pub fn eval(&mut self, s_mm: f64) -> Result<(AxisDerivs, u32), FeedError> {
        self.window.eval(s_mm)
    }

    /// Plans until at least `need_s` of motion is planned and not yet handed out, or the
    /// motion is planned to its end. A program that waits for appended text is planned as
    /// far as it can still stop within what is there.
    pub fn plan(&mut self, need_s: f64) -> Result<(), FeedError> {
        self.plan_until(need_s, false)
    }

    /// As [`Feed::plan`], but a program that waits for appended text and has nothing left to
    /// plan is planned to rest at the end of what is there (the caller's motion would
    /// otherwise run dry); text appended later continues after a restart from rest there.
    pub fn plan_or_rest(&mut self, need_s: f64) -> Result<(), FeedError> {
        self.plan_until(need_s, true)
    }

    fn plan_until(&mut self, need_s: f64, rest_at_text_end: bool) -> Result<(), FeedError> {
        self.window.planning(true);
        let planned = self.plan_while_short(need_s, rest_at_text_end);
        self.window.planning(false);
        planned
    }

    fn plan_while_short(&mut self, need_s: f64, rest_at_text_end: bool) -> Result<(), FeedError> {
        let mut have = self.buffered_s();
        while have < need_s && !self.planner.done() {
            let step = Instant::now();
            // A paused search goes on first: what a read would give it waits until it ends.
            if !self.planner.search_paused() && !self.take_read(rest_at_text_end)? {
                return Ok(());
            }
            let call = Instant::now();
            let planned = self.planner.plan()?;
            self.record_plan(call.elapsed(), step.elapsed(), planned.len());
            for seg in planned {
                have += seg.dt_s;
                self.buffer.push_back(seg);
            }
        }
        Ok(())
    }

    fn record_plan(&mut self, call: Duration, step: Duration, segments: usize) {
        let t = &mut self.timing;
        t.plan += call;
        t.plan_call_max = t.plan_call_max.max(call);
        t.step_max = t.step_max.max(step);
        t.segments += segments as u64;
    }

    /// Gives the planner the elements of the next read of the program (or tells it that none
    /// follows); `false` when planning stops here for now (the program waits for text).
    fn take_read(&mut self, rest_at_text_end: bool) -> Result<bool, FeedError> {
        // A reading thread reads on a look-ahead ahead of the planner while the planner takes
        // its reads, rather than one read per request.
        self.window.read_to(self.read_ahead_to_mm());
        loop {
            let index = match self.cursor.next_element {
                Some(i) => i,
                None => {
                    let i = self.window.index_from(self.cursor.plan_from_s_mm)?;
                    self.cursor.next_element = Some(i);
                    self.cursor.cut_first = true;
                    i
                }
            };
            // The planner's path: from `plan_from_s_mm`, with the feeds scaled.
            let c = self.cursor;
            let until_rest = c.told_rest_before != Some(index);
            let got = self
                .window
                .element(index, until_rest)?
                .map(|(e, after)| (if c.cut_first { e.from(c.plan_from_s_mm) } else { e.clone() }, after));
            match got {
                Some((mut e, after)) => {
                    if let crate::path::Feed::Programmed { mm_per_s } = &mut e.feed {
                        *mm_per_s *= self.feed_override;
                    }
                    let c = &mut self.cursor;
                    c.pushed_end_mm = e.s_end_mm();
                    c.pushed += 1;
                    c.cut_first = false;
                    c.idle_for_text = false;
                    c.next_element = Some(index + 1);
                    self.planner.push(e);
                    match after {
                        After::Take => {}
                        After::Plan => return Ok(true),
                        After::Finish => {
                            self.planner.finish(self.window.final_dwell_s());
                            self.cursor.finished_input = true;
                            return Ok(true);
                        }
                    }
                }
                None if until_rest && self.window.rest_before(index) && !self.cursor.finished_input => {
                    // Planned to the stop before the element is there; it is read next time.
                    self.planner.rest_follows();
                    self.cursor.told_rest_before = Some(index);
                    return Ok(true);
                }
                None if self.window.waiting() && !self.cursor.finished_input => {
                    // What is there is planned now, so the motion goes on as far as it can
                    // still stop within it.
                    let call = Instant::now();
                    let planned = self.planner.plan_now()?;
                    self.record_plan(call.elapsed(), call.elapsed(), planned.len());
                    if !planned.is_empty() || !rest_at_text_end {
                        self.buffer.extend(planned);
                        return Ok(false);
                    }
                    // The smoothing stage closes its run at the end of what exists, and the
                    // planner brings the motion to rest there.
                    self.window.flush()?;
                    if self.window.element(index, false)?.is_some() {
                        continue;
                    }
                    if self.cursor.pushed == 0 {
                        // Nothing to move along: wait for text.
                        self.cursor.idle_for_text = true;
                        return Ok(false);
                    }
                    self.planner.finish(0.0);
                    self.cursor.finished_input = true;
                    self.cursor.stopped_for_text = true;
                    return Ok(true);
                }
                None if !self.cursor.finished_input => {
                    self.planner.finish(self.window.final_dwell_s());
                    self.cursor.finished_input = true;
                    return Ok(true);
                }
                None => return Ok(true),
            }
        }
    }

    /// Motion planned and not yet handed out, s.
    pub fn buffered_s(&self) -> f64 {
        self.buffer.iter().map(|s| s.dt_s).sum()
    }

    /// The next planned segment, if one is planned.
    pub fn pop_segment(&mut self) -> Option<Segment> {
        let seg = self.buffer.pop_front()?;
        self.handed_out += 1;
        Some(seg)
    }

    /// Moves about `want_s` of planned segments to `out`, splitting one that reaches more than
    /// a quarter of the time asked for beyond it; returns the time moved, s.
    pub fn take(&mut self, want_s: f64, out: &mut Vec<Segment>) -> f64 {
        let mut got = 0.0;
        while got < want_s {
            let Some(seg) = self.buffer.pop_front() else { break };
            let room = want_s - got;
            let seg = if seg.dt_s > room * (1.0 + SPLIT_OVERHANG) && room > 0.0 {
                let (now, later) = seg.split_at(room);
                self.buffer.push_front(later);
                now
            } else {
                seg
            };
            got += seg.dt_s;
            self.handed_out += 1;
            out.push(seg);
        }
        got
    }

    /// Everything planned has been handed out and nothing more is planned until the feed
    /// restarts: the motion ends here, at the program's end or (see [`Feed::plan_or_rest`]) at
    /// rest where the appended text ran out.
    pub fn exhausted(&self) -> bool {
        self.buffer.is_empty() && self.planner.done()
    }

    /// The whole motion is planned and handed out ([`Feed::exhausted`] at the program's end).
    pub fn finished(&self) -> bool {
        self.exhausted() && !self.cursor.stopped_for_text
    }

    /// The program waits for appended text and nothing planned is left to hand out, so
    /// planning has nothing to do until text arrives: the motion was planned to rest at the
    /// end of what is there, or nothing of the program is there yet, or (with `queue_bridges`)
    /// the caller's queued motion still bridges the wait.
    pub fn waits_for_text(&self, queue_bridges: bool) -> bool {
        if !self.window.waiting() || !self.buffer.is_empty() {
            return false;
        }
        if self.cursor.stopped_for_text {
            return self.planner.done();
        }
        !self.window.has_input() && (self.cursor.idle_for_text || queue_bridges)
    }

    /// The fastest stop from the planned state (s, v ≥ 0, a) at program line `line`: it keeps
    /// every axis limit along the path and ends before the next exact stop and within what the
    /// planner holds (where the planned motion is known to be able to stop); segments from time
    /// 0, empty at rest. `None` when no stop fits there: the caller moves on a little and asks
    /// again.
    pub fn stop_from(&self, s_mm: f64, v_mm_s: f64, a_mm_s2: f64, line: u32) -> Option<Vec<Segment>> {
        // The window may reach further, as far as reading ahead got: that depends on timing,
        // so it does not bound the stop.
        let held_mm = if self.window.reads_ahead() { self.cursor.pushed_end_mm } else { f64::INFINITY };
        let limit = next_stop_s(self.path(), s_mm).min(held_mm);
        brake_along(self.path(), s_mm, v_mm_s, a_mm_s2, self.planner.limits(), limit, line)
    }

    /// Drops the elements that end before `s_mm` (the machine has passed them); elements the
    /// planner has still to take are kept.
    pub fn trim_before(&mut self, s_mm: f64) {
        // The element at `plan_from_s_mm` is needed only until the planner has it.
        let keep = if self.cursor.next_element.is_some() { f64::INFINITY } else { self.cursor.plan_from_s_mm };
        self.window.trim_before(s_mm.min(keep).min(self.cursor.pushed_end_mm));
    }

    /// Scales the programmed feeds by `factor` (> 0) from the next element the planner takes
    /// on; [`Feed::replan`] applies it to what is planned already.
    pub fn set_feed_override(&mut self, factor: f64) {
        self.feed_override = factor;
    }

    /// Replans from the planned state (s, v, a) with the feed override as it is now: what was
    /// planned and not handed out is dropped. `floor` is a motion known to keep the limits from
    /// that state (the stop the caller queued with it): the new plan's velocity bounds are at
    /// least its velocity, so a lower feed is reached by braking no harder than that stop.
    pub fn replan(&mut self, s_mm: f64, v_mm_s: f64, a_mm_s2: f64, floor: Vec<Segment>) {
        let moving = v_mm_s > STANDSTILL_V_MM_S || a_mm_s2.abs() > STANDSTILL_A_MM_S2;
        let planner = if moving {
            Planner::with_start_state_and_floor(&self.settings, v_mm_s, a_mm_s2, floor)
        } else {
            Planner::new(&self.settings)
        };
        self.replace_planner(planner);
        let c = &mut self.cursor;
        c.plan_from_s_mm = s_mm;
        c.next_element = None;
        c.finished_input = false;
        self.buffer.clear();
    }

    /// Plans the rest of the path from rest at `s_mm`, after the segments `first` (a stop the
    /// machine runs before it stands there; empty when it stands there already).
    pub fn restart_at_rest(&mut self, s_mm: f64, first: Vec<Segment>) {
        let planner = Planner::new(&self.settings);
        self.replace_planner(planner);
        self.cursor = Cursor::at(s_mm);
        self.buffer = first.into();
    }

    fn replace_planner(&mut self, planner: Planner) {
        let old = std::mem::replace(&mut self.planner, planner);
        self.earlier_plans.absorb(&old.stats);
        self.replans += 1;
    }

    /// Reads and smooths the program ahead of the planner until `deadline`, up to one
    /// look-ahead length beyond what the planner holds (which covers the elements its next
    /// replan takes); `true` if it read. A caller with time to spare (its queue is full) does
    /// this, so that a later [`Feed::plan`] plans alone. A read error is kept and returned
    /// where the planner reaches it. A program continued by appended text is not read ahead.
    pub fn read_ahead(&mut self, deadline: Instant) -> bool {
        let until_mm = self.read_ahead_to_mm();
        self.window.read_ahead(until_mm, deadline)
    }

    /// [`Feed::read_ahead`] has something to do.
    pub fn wants_to_read_ahead(&self) -> bool {
        self.window.can_read_ahead(self.read_ahead_to_mm())
    }

    fn read_ahead_to_mm(&self) -> f64 {
        self.cursor.pushed_end_mm.max(self.cursor.plan_from_s_mm) + self.settings.planner.lookahead_mm
    }

    /// Text appended to a waiting program has arrived (a whole line, or its end).
    pub fn has_new_text(&self) -> bool {
        self.window.has_input()
    }

    /// The next change of the program's tool and offset state read so far (with
    /// [`FeedBuilder::track_modal`]): the first source line it applies to and the state from
    /// there on, in program order.
    pub fn take_modal_change(&mut self) -> Option<(u32, crate::program::ActiveModal)> {
        self.window.take_modal_change()
    }

    /// The oldest operator message (`(MSG,…)`, `(DEBUG,…)`, `(PRINT,…)`) read so far and not yet
    /// taken, in program order. Its place in the motion is the [`crate::path::Pause`] of the
    /// element that names its number (messages after the last element have none: they belong
    /// to the program's end). The reader holds at most a bounded number
    /// ([`crate::program::MessageQueue`]): take them after each [`Feed::plan`].
    pub fn take_message(&mut self) -> Option<crate::program::Message> {
        self.window.take_message()
    }

    /// What the program's lines held so far (`None` for a path held whole).
    pub fn summary(&self) -> Option<&Summary> {
        self.window.summary()
    }

    /// Where the motion stands.
    pub fn progress(&self) -> Progress {
        Progress {
            lines_read: self.window.summary().map_or(0, |s| s.lines),
            read_to_mm: self.window.path().length_mm(),
            planned_to_mm: self.cursor.pushed_end_mm,
            buffered_s: self.buffered_s(),
            segments: self.handed_out,
            waiting_for_text: self.window.waiting(),
            finished: self.finished(),
        }
    }

    /// Counters and timings since the feed opened.
    pub fn stats(&self) -> FeedStats {
        let mut plan = self.earlier_plans;
        plan.absorb(&self.planner.stats);
        FeedStats {
            read_s: self.window.read_time.as_secs_f64(),
            prep_s: self.window.prep_time.as_secs_f64(),
            read_wait_s: self.window.read_wait.as_secs_f64(),
            plan_s: self.timing.plan.as_secs_f64(),
            plan_call_max_s: self.timing.plan_call_max.as_secs_f64(),
            step_max_s: self.timing.step_max.as_secs_f64(),
            segments: self.timing.segments,
            replans: self.replans,
            prep: self.window.prep_stats().unwrap_or_default(),
            plan,
        }
    }
}

#[cfg(test)]
mod tests;
