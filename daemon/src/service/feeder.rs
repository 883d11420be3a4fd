//! The planner thread: runs the look-ahead planner over the program, cuts its profile into
//! chunks of a few cycles, turns them into coarse points (stage 1 of the interpolation), adds
//! to each the fastest stop from its end, and keeps the real-time queue filled to a short
//! depth. It also carries out feed override changes (replanning from the end of the queue)
//! and restarts after a hold or an underrun (replanning from rest where the machine stands).
//! See [`crate::interp`] for the contract with the real-time thread.

use super::law_run::LawPart;
use super::lock;
use super::manual::{ManualGoal, ManualPart, ManualPlanError};
use super::modal_track::ModalTrack;
use super::otg_motion::AxisLimits;
use super::path_feed::{FeedError, PathFeed, PathSource};
use crate::interp::coarse::{CoarseBuilder, CoarsePoint, split};
use crate::interp::{Chunk, DivertCause, Epoch};
use crossbeam::channel::{Receiver, Sender};
use crossbeam::queue::ArrayQueue;
use interpd_config::Config;
use interpd_motion::Settings;
use interpd_motion::path::{AxisVec, Feed, Path};
use interpd_motion::planner::brake::{brake_along, next_stop_s};
use interpd_motion::planner::{PlanError, Planner, STANDSTILL_A_MM_S2, STANDSTILL_V_MM_S, Segment};
use interpd_protocol::api::LookaheadStatus;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Cycles of motion per chunk: the reaction time to a hold or stop is at most this.
pub const CHUNK_CYCLES: u32 = 8;
/// Chunks kept queued for the real-time thread: the planner thread may stall this long
/// (× chunk duration) without an underrun; a feed override acts after it. Reading, smoothing
/// and planning dense CAM data comes in bursts (a smoothing window, a horizon replan) that a
/// shallower queue does not bridge.
pub const QUEUE_CHUNKS: usize = 10;
/// Chunks of a new epoch (a start or a replan) planned before the first is released: a slow
/// first plan does not run dry at once, and the first motion follows a start quickly.
const START_CHUNKS: usize = 2;
/// Chunks kept queued for a manual motion: a changed jog takes effect after them, and sampling
/// the OTG is fast enough (tens of µs a chunk) that a shallow queue does not run dry.
pub const MANUAL_QUEUE_CHUNKS: usize = 3;
/// Capacity of the queues between the threads (chunks in flight never exceed it).
pub const QUEUE_CAPACITY: usize = 16;
/// A segment this much longer than the room left in a chunk is split rather than taken whole
/// (fraction of a chunk).
const SPLIT_OVERHANG: f64 = 0.25;
/// The longest the thread reads ahead before it looks again for commands and chunks due (one
/// read, with its smoothing window, may take longer).
const READ_AHEAD_SLICE: Duration = Duration::from_millis(2);
/// How long the thread waits for a command when it has nothing to do.
const IDLE_WAIT: Duration = Duration::from_millis(2);
/// A program waiting for appended text stops at the end of what is there once no more than
/// this many chunks are queued (until then, text that arrives continues it without a stop).
const STARVED_STOP_CHUNKS: usize = 2;

/// Commands to the planner thread.
#[derive(Debug, Clone)]
pub enum FeederCommand {
    /// Plan and queue the path of `source` from its start, at rest, as epoch `epoch`.
    Start {
        source: PathSource,
        epoch: Epoch,
        feed_override: f64,
        /// Keep the held program to resume it later (an MDI from a hold) instead of dropping it.
        suspend: bool,
    },
    /// Queue the manual motion `goal` from rest at `here` as epoch `epoch`.
    StartManual {
        goal: ManualGoal,
        here: AxisVec,
        epoch: Epoch,
        feed_override: f64,
        /// As for `Start`.
        suspend: bool,
    },
    /// A changed manual command: the running manual motion replans from the end of the queue.
    Manual(ManualGoal),
    /// Resume the suspended (held) program as epoch `epoch`: a move-to from `here` back to the
    /// held point, then the rest of the program.
    ResumeSuspended {
        epoch: Epoch,
        here: AxisVec,
    },
    /// Queue the motion-law moves `laws` along `path` (its lines, one per move) from its
    /// start, at rest, as epoch `epoch`. The laws' time profiles are executed as they are:
    /// the feed override does not scale them (see [`LawPart`]).
    StartLaws {
        path: Arc<Path>,
        laws: Box<LawPart>,
        epoch: Epoch,
        feed_override: f64,
    },
    /// New feed override factor (> 0).
    Override(f64),
    /// The executor left the planned motion (it runs a tail).
    Diverted {
        epoch: Epoch,
        cause: DivertCause,
    },
    /// The executor stands at `s_mm` after a tail.
    Stood {
        epoch: Epoch,
        seq: u64,
        cause: DivertCause,
        s_mm: f64,
    },
    /// Continue after a hold.
    Resume,
    /// Abandon the program.
    Abort,
    /// Stall once for `for_s` after `after_s` seconds of motion were queued (underrun tests).
    DebugStall {
        after_s: f64,
        for_s: f64,
    },
    Shutdown,
}

/// What the planner thread reports.
#[derive(Debug, Clone, PartialEq)]
pub enum FeederReport {
    /// Planning failed: the motion stops at the end of the queue.
    Error(String),
    /// The last chunk of the program is queued.
    Complete { epoch: Epoch },
    /// A jog of axis `axis` brakes to its soft limit `limit`.
    JogLimit { axis: usize, limit: f64 },
}

/// The queues shared with the real-time thread.
#[derive(Clone)]
pub struct Queues {
    pub chunks: Arc<ArrayQueue<Box<Chunk>>>,
    pub recycle: Arc<ArrayQueue<Box<Chunk>>>,
}

impl Queues {
    pub fn new() -> Self {
        Self {
            chunks: Arc::new(ArrayQueue::new(QUEUE_CAPACITY)),
            recycle: Arc::new(ArrayQueue::new(QUEUE_CAPACITY * 2)),
        }
    }
}

impl Default for Queues {
    fn default() -> Self {
        Self::new()
    }
}

/// Where a run waits.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Wait {
    /// Producing chunks.
    No,
    /// The executor diverted; waiting for it to stand.
    Stand { cause: DivertCause, resume_requested: bool },
    /// Held at rest at `s_mm` after the tail of chunk `seq`; waiting for resume.
    Resume { s_mm: f64, seq: u64 },
}

/// One program being planned and queued.
struct Run {
    /// The program's path from a little behind the machine to the planner's horizon (geometry
    /// for coarse points, stops and replans).
    feed: PathFeed,
    feed_override: f64,
    epoch: Epoch,
    seq: u64,
    planner: Planner,
    /// Where the planner's path starts (the run's start, or the queue end after an override
    /// change): the element containing it is cut there.
    plan_from_s_mm: f64,
    /// Path position where the last element given to the planner ends.
    pushed_end_mm: f64,
    /// Index (in the whole path) of the next element for the planner; `None` until the
    /// element at `plan_from_s_mm` is found.
    next_element: Option<usize>,
    finished_input: bool,
    /// The next element for the planner is the first of its path: cut at `plan_from_s_mm`.
    cut_first: bool,
    /// Elements pushed to the planner since the run (re)started.
    pushed: u64,
    /// The program waits for appended text and nothing of it is left to plan.
    idle_for_input: bool,
    /// The program waits for appended text and the planner was told to stop at the end of what
    /// is there: the run ends at rest there, and an underrun restart continues it.
    stopped_for_input: bool,
    /// Start positions of the chunks of this run the real-time thread gave back, newest last:
    /// the path behind the oldest of them is no longer needed (see [`Run::reclaimed`]).
    reclaimed_s: VecDeque<f64>,
    /// Planned segments not yet queued.
    buffer: VecDeque<Segment>,
    /// The last queued point (start of the next chunk).
    end: CoarsePoint,
    /// The stop tail queued with the last chunk.
    last_tail: Vec<Segment>,
    /// The last chunk of the program is queued.
    complete: bool,
    /// Chunks of a new epoch held back until the queue start is deep enough. Boxed: a chunk
    /// moves between threads as one pointer.
    #[allow(clippy::vec_box)]
    staged: Vec<Box<Chunk>>,
    /// The queue has reached this run's depth once: from then on its low point is a measure
    /// of how the look-ahead keeps up (`status.lookahead`).
    reached_depth: bool,
    wait: Wait,
    /// Seconds of motion queued in this run (for the debug stall).
    queued_s: f64,
    /// Motion-law moves still to sample (instead of planning `path`); `None` for programs
    /// and after a restart (the rest of a law program then runs as rapid moves).
    law: Option<LawPart>,
    /// Manual motion to queue (instead of planning `path`): a jog or move-to (then `path` is
    /// empty), or the return move to the held point `s_start_mm` before a program resumes.
    manual: Option<ManualPart>,
    /// Path position the run (re)started at.
    s_start_mm: f64,
}

/// The planner thread's state.
pub struct Feeder {
    settings: Settings,
    cycle_s: f64,
    chunk_s: f64,
    queues: Queues,
    /// Chunks ready for reuse (boxed: they move through the queues as pointers).
    #[allow(clippy::vec_box)]
    pool: Vec<Box<Chunk>>,
    run: Option<Run>,
    /// A held program kept while a manual motion or an MDI runs (and after it, until the
    /// program resumes or is stopped).
    suspended: Option<Run>,
    /// The axes' limits and travel, for manual motion.
    axis_limits: Vec<AxisLimits>,
    reports: Sender<FeederReport>,
    stall: Option<(f64, f64)>,
    /// Axis jerk limits (for the coarse points' jerk check).
    max_jerk: [f64; interpd_motion::path::MAX_AXES],
    /// Counters for the status and tests.
    pub stats: FeederStats,
    /// The running program's tool and offset state changes, read by `status`.
    modal: Arc<Mutex<ModalTrack>>,
    /// How the thread kept up, read by `status`.
    health: Arc<LookaheadHealth>,
}

/// How the planner thread kept up in the current motion (`status.lookahead`): it writes, the
/// control thread reads.
#[derive(Debug)]
pub struct LookaheadHealth {
    step_max_ns: AtomicU64,
    /// Least chunks queued when a step began; `u64::MAX` before the queue first reached its depth.
    queue_min_chunks: AtomicU64,
}

impl Default for LookaheadHealth {
    fn default() -> Self {
        Self { step_max_ns: AtomicU64::new(0), queue_min_chunks: AtomicU64::new(u64::MAX) }
    }
}

impl LookaheadHealth {
    fn reset(&self) {
        self.step_max_ns.store(0, Ordering::Relaxed);
        self.queue_min_chunks.store(u64::MAX, Ordering::Relaxed);
    }

    fn step(&self, took: Duration) {
        self.step_max_ns.fetch_max(u64::try_from(took.as_nanos()).unwrap_or(u64::MAX), Ordering::Relaxed);
    }

    fn queued(&self, chunks: usize) {
        self.queue_min_chunks.fetch_min(chunks as u64, Ordering::Relaxed);
    }

    /// The figures for `status`, with chunks of `chunk_s` seconds.
    pub fn status(&self, chunk_s: f64) -> LookaheadStatus {
        let min = self.queue_min_chunks.load(Ordering::Relaxed);
        LookaheadStatus {
            step_max_ms: self.step_max_ns.load(Ordering::Relaxed) as f64 * 1e-6,
            queue_min_s: (min != u64::MAX).then_some(min as f64 * chunk_s),
        }
    }
}

/// Totals of the planner thread.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeederStats {
    pub chunks: u64,
    pub coarse_points: u64,
    pub max_coarse_error_mm: f64,
    pub replans: u64,
    pub plan_time_s: f64,
    /// Chunk ends moved later because no stop could follow them.
    pub tail_retries: u64,
    /// Planning failures in motion recovered by stopping along the path and replanning.
    pub recoveries: u64,
}

impl Feeder {
    pub fn new(config: &Config, queues: Queues, reports: Sender<FeederReport>) -> Self {
        let cycle_s = config.cycle_s();
        let chunk_s = cycle_s * f64::from(CHUNK_CYCLES);
        let mut settings = Settings::from_config(config);
        let bounded = bounded_lookahead_mm(&settings);
        if bounded < settings.planner.lookahead_mm {
            tracing::info!(
                configured_mm = settings.planner.lookahead_mm,
                used_mm = bounded,
                "look-ahead bounded to what braking from full speed needs (replans stay fast)"
            );
            settings.planner.lookahead_mm = bounded;
        }
        let mut max_jerk = [f64::INFINITY; interpd_motion::path::MAX_AXES];
        for (m, a) in max_jerk.iter_mut().zip(&settings.axes) {
            *m = a.max_jerk_per_s3;
        }
        let axis_limits = axis_limits(config);
        Self {
            settings,
            cycle_s,
            chunk_s,
            queues,
            pool: Vec::new(),
            run: None,
            suspended: None,
            axis_limits,
            reports,
            stall: None,
            max_jerk,
            stats: FeederStats::default(),
            modal: Arc::default(),
            health: Arc::default(),
        }
    }

    /// Where the running program's tool and offset state changes are kept (`status.modal`).
    pub fn modal_track(&self) -> Arc<Mutex<ModalTrack>> {
        self.modal.clone()
    }

    /// How this thread keeps up with the motion (`status.lookahead`).
    pub fn health(&self) -> Arc<LookaheadHealth> {
        self.health.clone()
    }

    /// The thread's loop: commands in, chunks out, until `Shutdown` or the channel closes.
    pub fn run(mut self, commands: Receiver<FeederCommand>) -> FeederStats {
        loop {
            let busy = self.wants_to_produce() || self.wants_to_read_ahead();
            let cmd = if busy { commands.try_recv().ok() } else { commands.recv_timeout(IDLE_WAIT).ok() };
            if let Some(cmd) = cmd {
                if matches!(cmd, FeederCommand::Shutdown) {
                    return self.stats;
                }
                self.command(cmd);
                continue;
            }
            if commands.is_empty() && matches!(commands.try_recv(), Err(crossbeam::channel::TryRecvError::Disconnected))
            {
                return self.stats;
            }
            self.reclaim();
            if self.wants_to_produce() {
                self.produce();
            } else if self.wants_to_read_ahead() {
                self.read_ahead();
            }
        }
    }

    /// Carries out one command (the thread's loop calls this; tests drive it directly).
    pub fn command(&mut self, cmd: FeederCommand) {
        match cmd {
            FeederCommand::Start { source, epoch, feed_override, suspend } => {
                self.health.reset();
                self.replace_run(suspend);
                if !suspend {
                    // The program run before is over; an excursion from a held one keeps it.
                    lock(&self.modal).clear();
                }
                let modal = self.modal.clone();
                let opened = PathFeed::open(source, &self.settings).and_then(|mut feed| {
                    feed.track_modal(modal);
                    let line = feed.element(0)?.map_or(0, |e| e.source.line);
                    Ok((feed, line))
                });
                match opened {
                    Ok((feed, line)) => {
                        let start = CoarsePoint::at_rest(0.0, 0.0, line, feed.path().start);
                        self.run = Some(Run::new(&self.settings, feed, feed_override, epoch, 0.0, start));
                    }
                    Err(e) => self.failed(&e),
                }
            }
            FeederCommand::StartManual { goal, here, epoch, feed_override, suspend } => {
                self.health.reset();
                self.replace_run(suspend);
                match ManualPart::new(goal, here, &self.axis_limits, feed_override, None) {
                    Ok(part) => {
                        let feed = PathFeed::empty(&self.settings, here);
                        let start = CoarsePoint::at_rest(0.0, 0.0, 0, here);
                        let mut run = Run::new(&self.settings, feed, feed_override, epoch, 0.0, start);
                        run.manual = Some(part);
                        self.run = Some(run);
                    }
                    Err(e) => self.manual_failed(&e),
                }
            }
            FeederCommand::Manual(goal) => {
                let Some(part) = self.run.as_mut().and_then(|r| r.manual.as_mut()).filter(|p| !p.is_return()) else {
                    return;
                };
                if let Err(e) = part.plan(goal) {
                    // The control side checked the goal from the state when it was sent; from
                    // the handover state it fails: the motion stops at the end of the queue.
                    self.manual_failed(&e);
                }
            }
            FeederCommand::ResumeSuspended { epoch, here } => self.resume_suspended(epoch, here),
            FeederCommand::StartLaws { path, laws, epoch, feed_override } => {
                self.health.reset();
                self.abort();
                let start =
                    CoarsePoint::at_rest(0.0, 0.0, path.elements.first().map_or(0, |e| e.source.line), path.start);
                let mut run = Run::new(&self.settings, PathFeed::whole(&path), feed_override, epoch, 0.0, start);
                run.law = Some(*laws);
                self.run = Some(run);
            }
            FeederCommand::Override(factor) => self.set_override(factor),
            FeederCommand::Diverted { epoch, cause } => {
                if let Some(run) = self.run.as_mut().filter(|r| r.epoch == epoch) {
                    run.epoch = epoch.replan();
                    run.seq = 0;
                    run.wait = Wait::Stand { cause, resume_requested: false };
                    run.buffer.clear();
                    let staged = std::mem::take(&mut run.staged);
                    self.pool.extend(staged);
                }
            }
            FeederCommand::Stood { epoch, seq, cause, s_mm } => self.stood(epoch, seq, cause, s_mm),
            FeederCommand::Resume => {
                let Some(run) = self.run.as_mut() else { return };
                match run.wait {
                    Wait::Resume { s_mm, seq } => self.restart_at_rest(seq, s_mm),
                    Wait::Stand { cause, .. } => run.wait = Wait::Stand { cause, resume_requested: true },
                    Wait::No => {}
                }
            }
            FeederCommand::Abort => self.abort(),
            FeederCommand::DebugStall { after_s, for_s } => self.stall = Some((after_s, for_s)),
            FeederCommand::Shutdown => {}
        }
    }

    /// The executor stands after the tail of `epoch` (the run moved to `epoch.replan()` when
    /// told of the divert).
    fn stood(&mut self, epoch: Epoch, seq: u64, cause: DivertCause, s_mm: f64) {
        // A program held before a manual motion or an MDI took over learns where it stands.
        if let Some(held) = self.suspended.as_mut().filter(|r| r.epoch == epoch.replan()) {
            held.wait = Wait::Resume { s_mm, seq };
            return;
        }
        let Some(run) = self.run.as_mut() else { return };
        if run.epoch != epoch.replan() {
            return;
        }
        let resume_requested = matches!(run.wait, Wait::Stand { resume_requested: true, .. });
        let manual = run.manual.as_ref().filter(|m| !m.is_return()).is_some();
        match cause {
            DivertCause::Stop => self.abort(),
            // A hold (or motion.jog_stop) ends a manual motion; a held program comes back.
            DivertCause::Hold if manual => {
                if let Some(mut run) = self.run.take() {
                    self.pool.append(&mut run.staged);
                }
            }
            DivertCause::Underrun => self.restart_at_rest(seq, s_mm),
            DivertCause::Hold if resume_requested => self.restart_at_rest(seq, s_mm),
            DivertCause::Hold => run.wait = Wait::Resume { s_mm, seq },
        }
    }

    fn abort(&mut self) {
        if let Some(mut run) = self.run.take() {
            self.pool.append(&mut run.staged);
        }
        if let Some(mut run) = self.suspended.take() {
            self.pool.append(&mut run.staged);
        }
    }

    /// A new run takes over: the running one is dropped, or kept as the suspended held program.
    fn replace_run(&mut self, suspend: bool) {
        if suspend {
            if let Some(mut run) = self.run.take() {
                self.pool.append(&mut run.staged);
                // A program held earlier stays the one to resume; a finished manual motion or
                // MDI in between is dropped.
                if self.suspended.is_none() {
                    self.suspended = Some(run);
                }
            }
        } else {
            self.abort();
        }
    }

    /// A manual motion cannot be planned: reported as a planning failure, nothing more is
    /// queued (the queued motion ends with its stop tail).
    fn manual_failed(&mut self, e: &ManualPlanError) {
        self.failed(&format!("manual motion: {e}"));
    }

    /// The run cannot go on: reported, nothing more is queued (the queued motion ends with its
    /// stop tail).
    fn failed(&mut self, e: &dyn std::fmt::Display) {
        tracing::error!("{e}");
        let _ = self.reports.send(FeederReport::Error(e.to_string()));
        self.abort();
    }

    /// The held program continues as `epoch`: first a move-to from `here` back to the point it
    /// was held at, then the rest of the program from rest there.
    fn resume_suspended(&mut self, epoch: Epoch, here: AxisVec) {
        let Some(held) = self.suspended.take() else { return };
        // The figures of the excursion (jog, MDI) are not the program's.
        self.health.reset();
        let Wait::Resume { s_mm, .. } = held.wait else {
            tracing::error!("resume: the held program never came to rest");
            return;
        };
        if let Some(mut run) = self.run.take() {
            self.pool.append(&mut run.staged);
        }
        match self.return_run(held.feed, held.feed_override, epoch, s_mm, here) {
            Ok(run) => {
                self.stats.replans += 1;
                self.run = Some(run);
            }
            Err(e) => self.failed(&e),
        }
    }

    /// A run of `path` from `s_mm` as `epoch`, preceded by the move from `here` to the path
    /// there when the machine stands elsewhere.
    fn return_run(
        &self,
        mut feed: PathFeed,
        feed_override: f64,
        epoch: Epoch,
        s_mm: f64,
        here: AxisVec,
    ) -> Result<Run, ReturnError> {
        let (at, line) = feed.eval(s_mm)?;
        let n = self.axis_limits.len();
        let away = (0..n).any(|k| (here[k] - at.pos[k]).abs() > super::approach::AT_START_TOL);
        let start = CoarsePoint::at_rest(0.0, s_mm, line, if away { here } else { at.pos });
        let mut run = Run::new(&self.settings, feed, feed_override, epoch, s_mm, start);
        if away {
            let mut target = [None; interpd_motion::path::MAX_AXES];
            for (t, p) in target.iter_mut().zip(at.pos).take(n) {
                *t = Some(p);
            }
            let goal = ManualGoal::MoveTo { target, vel: [0.0; interpd_motion::path::MAX_AXES], factor: 1.0 };
            run.manual = Some(ManualPart::new(goal, here, &self.axis_limits, 1.0, Some(s_mm))?);
        }
        Ok(run)
    }

    /// Replans the rest of the program from rest at `s_mm`, as the run's current epoch; a
    /// manual motion continues its goal from rest where the tail of chunk `seq` ended.
    fn restart_at_rest(&mut self, seq: u64, s_mm: f64) {
        let Some(mut old) = self.run.take() else { return };
        if let Some(part) = old.manual.take() {
            let here = part.tail_end(seq).unwrap_or(old.end.pos);
            self.stats.replans += 1;
            if part.is_return() {
                match self.return_run(old.feed, old.feed_override, old.epoch, old.s_start_mm, here) {
                    Ok(mut run) => {
                        run.queued_s = old.queued_s;
                        self.run = Some(run);
                    }
                    Err(e) => self.failed(&e),
                }
                return;
            }
            match part.restarted(here) {
                Ok(part) => {
                    let start = CoarsePoint::at_rest(0.0, old.end.s_mm, 0, here);
                    let mut run = Run::new(&self.settings, old.feed, old.feed_override, old.epoch, 0.0, start);
                    run.manual = Some(part);
                    run.queued_s = old.queued_s;
                    self.run = Some(run);
                }
                Err(e) => self.manual_failed(&e),
            }
            return;
        }
        let (pos, line) = match old.feed.eval(s_mm) {
            Ok(at) => at,
            Err(e) => return self.failed(&e),
        };
        let start = CoarsePoint::at_rest(0.0, s_mm, line, pos.pos);
        let mut run = Run::new(&self.settings, old.feed, old.feed_override, old.epoch, s_mm, start);
        run.queued_s = old.queued_s;
        self.stats.replans += 1;
        self.run = Some(run);
    }

    /// A new feed override: replans from the end of the queue (the queued motion runs out
    /// first) with the programmed feeds scaled. The stop tail from there floors the new bounds,
    /// so a lower feed is reached by braking no harder than that stop.
    fn set_override(&mut self, factor: f64) {
        let Some(run) = self.run.as_mut() else { return };
        run.feed_override = factor;
        if let Some(part) = run.manual.as_mut().filter(|p| !p.is_return()) {
            if let Err(e) = part.set_override(factor) {
                self.manual_failed(&e);
            }
            return;
        }
        if run.wait != Wait::No || run.complete || run.law.is_some() {
            return;
        }
        self.stats.replans += 1;
        let end = run.end;
        let floor = run.last_tail.clone();
        let moving = end.v_mm_s > STANDSTILL_V_MM_S || end.a_mm_s2.abs() > STANDSTILL_A_MM_S2;
        let planner = if moving {
            Planner::with_start_state_and_floor(&self.settings, end.v_mm_s, end.a_mm_s2, floor)
        } else {
            Planner::new(&self.settings)
        };
        run.planner = planner;
        run.plan_from_s_mm = end.s_mm;
        run.next_element = None;
        run.finished_input = false;
        run.buffer.clear();
    }

    /// Returns recycled chunks to the pool.
    pub fn reclaim(&mut self) {
        while let Some(mut chunk) = self.queues.recycle.pop() {
            if let (Some(run), Some(first)) = (self.run.as_mut(), chunk.points.first()) {
                run.reclaimed(chunk.epoch, first.s_mm);
            }
            chunk.clear();
            self.pool.push(chunk);
        }
    }

    /// A chunk is due: a run is producing and the queue is below its depth.
    pub fn wants_to_produce(&self) -> bool {
        match &self.run {
            Some(run) => {
                let queued = self.queues.chunks.len();
                run.active() && queued < run.depth() && !run.waits_for_input(queued)
            }
            None => false,
        }
    }

    /// The queue is full and the run's program is not yet read as far ahead as its planner's
    /// next replan may need.
    pub(super) fn wants_to_read_ahead(&self) -> bool {
        self.run.as_ref().is_some_and(|run| {
            // A return move reads nothing; a law or manual path is held whole and cannot.
            run.active() && run.manual.is_none() && run.feed.can_read_ahead(run.read_ahead_to_mm(&self.settings))
        })
    }

    /// Reads and smooths the program ahead of the planner for one slice: the reading and
    /// smoothing a horizon replan needs are then done while the queue is full, and the step
    /// that replans does the planning alone.
    pub(super) fn read_ahead(&mut self) {
        let Some(run) = self.run.as_mut() else { return };
        let started = Instant::now();
        let until_mm = run.read_ahead_to_mm(&self.settings);
        run.feed.read_ahead(until_mm, started + READ_AHEAD_SLICE);
        if run.reached_depth {
            self.health.step(started.elapsed());
        }
    }

    /// Plans and queues one chunk.
    pub fn produce(&mut self) {
        // Once the queue has been full, what is queued when a step begins is all that bridges it.
        let steady = self.run.as_ref().is_some_and(|r| r.reached_depth);
        if steady {
            self.health.queued(self.queues.chunks.len());
        }
        let started = Instant::now();
        if let Some((after_s, for_s)) = self.stall {
            if self.run.as_ref().is_some_and(|r| r.queued_s >= after_s) {
                tracing::warn!(for_s, "debug: planner thread stalls");
                std::thread::sleep(Duration::from_secs_f64(for_s));
                self.stall = None;
            }
        }
        let mut chunk = self.pool.pop().unwrap_or_default();
        let result = self.fill_chunk(&mut chunk);
        let took = started.elapsed();
        self.stats.plan_time_s += took.as_secs_f64();
        if steady {
            self.health.step(took);
        }
        let Some(run) = self.run.as_mut() else { return };
        match result {
            Ok(true) => {
                run.queued_s += chunk.duration_s();
                self.stats.chunks += 1;
                self.stats.coarse_points += (chunk.points.len() + chunk.tail.len()) as u64;
                let complete = chunk.last;
                // A new epoch starts only once half the queue depth is ready (or the program
                // is complete), so a slow first plan does not underrun at once.
                let deep_enough = run.seq as usize >= START_CHUNKS.min(run.depth() / 2) || complete;
                run.staged.push(chunk);
                if deep_enough {
                    for c in run.staged.drain(..) {
                        if let Err(c) = self.queues.chunks.push(c) {
                            // Cannot happen: production stops below the capacity.
                            tracing::error!("chunk queue full; dropping a chunk");
                            self.pool.push(c);
                        }
                    }
                }
                run.reached_depth |= self.queues.chunks.len() >= run.depth();
                if complete {
                    run.complete = true;
                    let _ = self.reports.send(FeederReport::Complete { epoch: run.epoch });
                }
            }
            Ok(false) => {
                chunk.clear();
                self.pool.push(chunk);
            }
            Err(RunError::Plan(e)) => {
                chunk.clear();
                self.pool.push(chunk);
                if !self.recover(&e) {
                    self.failed(&format!("planning failed: {e}"));
                }
            }
            Err(RunError::Feed(e)) => {
                chunk.clear();
                self.pool.push(chunk);
                self.failed(&e);
            }
        }
    }

    /// After a planning failure in motion (the planner could not continue from a state in
    /// motion, e.g. after an override change): the queue ends with a stop tail that is known to
    /// keep the limits. Run it as motion and replan the rest from rest at its end. `false` if
    /// the machine is at rest there already (a failure from rest is a real error).
    fn recover(&mut self, e: &PlanError) -> bool {
        let Some(run) = self.run.as_mut() else { return false };
        let Some(last) = run.last_tail.last() else { return false };
        let s_stop = last.s1_mm();
        tracing::warn!("planner: {e}; stopping along the path at s = {s_stop:.3} mm and replanning from there");
        self.stats.recoveries += 1;
        let feed = std::mem::replace(&mut run.feed, PathFeed::empty(&self.settings, run.end.pos));
        let mut fresh = Run::new(&self.settings, feed, run.feed_override, run.epoch, s_stop, run.end);
        fresh.seq = run.seq;
        fresh.queued_s = run.queued_s;
        fresh.buffer = std::mem::take(&mut run.last_tail).into();
        fresh.staged = std::mem::take(&mut run.staged);
        *run = fresh;
        true
    }

    /// Fills `chunk` with the next stretch of motion (about one chunk duration, longer where
    /// no stop can follow its end); `Ok(false)` when nothing is left.
    fn fill_chunk(&mut self, chunk: &mut Chunk) -> Result<bool, RunError> {
        let chunk_s = self.chunk_s;
        let max_piece_s = 2.0 * self.cycle_s;
        let stop_if_waiting = self.queues.chunks.len() <= STARVED_STOP_CHUNKS;
        let Some(run) = self.run.as_mut() else { return Ok(false) };
        if run.law.is_some() {
            return Ok(self.fill_law_chunk(chunk));
        }
        if run.manual.is_some() {
            return Ok(self.fill_manual_chunk(chunk));
        }
        let lim = run.planner.limits().clone();
        let mut segments = Vec::new();
        let mut t = 0.0;
        let mut target = chunk_s;
        let tail = loop {
            run.fill_buffer(target - t, stop_if_waiting)?;
            run.take(target - t, &mut segments, &mut t);
            let Some(last) = segments.last() else { return Ok(false) };
            let end = last.at(last.dt_s);
            if run.buffer.is_empty() && run.planner.done() {
                break Vec::new();
            }
            // The planner's horizon holds a stop, so one exists before the end of what it was
            // given. The window may reach further, as far as reading ahead got: that depends on
            // timing, so it does not bound the stop.
            let held_mm = if run.feed.reads_ahead() { run.pushed_end_mm } else { f64::INFINITY };
            let limit = next_stop_s(run.feed.path(), end.s_mm).min(held_mm);
            if let Some(stop) = brake_along(run.feed.path(), end.s_mm, end.v, end.a, &lim, limit, last.line) {
                break stop;
            }
            // No stop from here: end the chunk a little later.
            self.stats.tail_retries += 1;
            target = t + 0.25 * chunk_s;
        };
        run.open_chunk(chunk);
        let mut builder = CoarseBuilder::new(run.feed.path(), max_piece_s, &self.max_jerk);
        builder.build(&segments, 0.0, &mut chunk.points);
        let end = *chunk.points.last().expect("points");
        chunk.last = run.buffer.is_empty() && run.planner.done() && !run.stopped_for_input;
        if !tail.is_empty() {
            chunk.tail.push(CoarsePoint { t_s: 0.0, ..end });
            builder.build(&tail, 0.0, &mut chunk.tail);
        }
        self.stats.max_coarse_error_mm = self.stats.max_coarse_error_mm.max(builder.max_error_mm);
        run.close_chunk(end, tail);
        Ok(true)
    }

    /// [`Feeder::fill_chunk`] for motion-law moves: samples about one chunk of the laws
    /// (longer where no stop can follow) and gives it the fastest stop along the move's line
    /// as its tail; `false` when nothing is left.
    fn fill_law_chunk(&mut self, chunk: &mut Chunk) -> bool {
        let (chunk_s, max_piece_s) = (self.chunk_s, 2.0 * self.cycle_s);
        let Some(run) = self.run.as_mut() else { return false };
        if run.law.as_ref().is_none_or(LawPart::is_done) {
            return false;
        }
        let lim = run.planner.limits().clone();
        run.open_chunk(chunk);
        let Some(law) = run.law.as_mut() else { return false };
        let mut want_s = chunk_s;
        let tail = loop {
            law.sample(want_s, max_piece_s, &self.max_jerk, &mut chunk.points);
            let end = *chunk.points.last().expect("points");
            if law.is_done() {
                break Vec::new();
            }
            // A law may run backwards for a while (overshooting laws); the path stop needs v ≥ 0.
            if end.v_mm_s >= 0.0 {
                let limit = next_stop_s(run.feed.path(), end.s_mm);
                if let Some(stop) =
                    brake_along(run.feed.path(), end.s_mm, end.v_mm_s, end.a_mm_s2, &lim, limit, end.line)
                {
                    break stop;
                }
            }
            self.stats.tail_retries += 1;
            want_s = 0.25 * chunk_s;
        };
        let end = *chunk.points.last().expect("points");
        chunk.last = law.is_done();
        if !tail.is_empty() {
            chunk.tail.push(CoarsePoint { t_s: 0.0, ..end });
            let mut builder = CoarseBuilder::new(run.feed.path(), max_piece_s, &self.max_jerk);
            builder.build(&tail, 0.0, &mut chunk.tail);
            self.stats.max_coarse_error_mm = self.stats.max_coarse_error_mm.max(builder.max_error_mm);
        }
        run.close_chunk(end, tail);
        true
    }
}

impl Feeder {
    /// [`Feeder::fill_chunk`] for manual motion (and the return move before a resumed
    /// program): samples about one chunk of the OTG motion with every axis's fastest stop as
    /// its tail; `false` when nothing is left or planning failed.
    fn fill_manual_chunk(&mut self, chunk: &mut Chunk) -> bool {
        let (chunk_s, cycle_s, max_piece_s) = (self.chunk_s, self.cycle_s, 2.0 * self.cycle_s);
        let Some(run) = self.run.as_mut() else { return false };
        run.open_chunk(chunk);
        let seq = run.seq;
        let Some(part) = run.manual.as_mut() else { return false };
        let filled = part.fill(seq, chunk_s, cycle_s, max_piece_s, &mut chunk.points, &mut chunk.tail);
        for (axis, limit) in part.take_limit_reports() {
            let _ = self.reports.send(FeederReport::JogLimit { axis, limit });
        }
        let last = match filled {
            Ok(last) => last,
            Err(e) => {
                self.manual_failed(&e);
                return false;
            }
        };
        let returning = part.is_return();
        let mut end = *chunk.points.last().expect("points");
        if returning && last {
            // Back on the path: the program continues from rest exactly at the held point, and
            // its queue fills to the program's depth from here.
            run.manual = None;
            run.reached_depth = false;
            let at = match run.feed.eval(run.s_start_mm) {
                Ok((at, _)) => at,
                Err(e) => {
                    self.failed(&e);
                    return false;
                }
            };
            end.pos = at.pos;
            end.line = run.end.line;
            if let Some(p) = chunk.points.last_mut() {
                *p = end;
            }
            chunk.last = false;
        } else {
            chunk.last = last;
        }
        run.last_tail.clear();
        run.close_chunk(end, Vec::new());
        true
    }
}

impl Run {
    /// Nothing to do until appended text arrives: the program waits for it, nothing planned is
    /// left to queue, and either the motion is planned to rest at the end of what is there or
    /// the `queued` chunks still bridge the wait.
    fn waits_for_input(&self, queued: usize) -> bool {
        if !self.feed.waiting() || !self.buffer.is_empty() {
            return false;
        }
        if self.stopped_for_input {
            return self.planner.done();
        }
        !self.feed.has_input() && (self.idle_for_input || queued > STARVED_STOP_CHUNKS)
    }

    /// The run queues chunks: neither held nor waiting to resume, and not complete.
    fn active(&self) -> bool {
        self.wait == Wait::No && !self.complete
    }

    /// How far ahead the program is read: a look-ahead length beyond what the planner has,
    /// which covers the elements its next replan takes.
    fn read_ahead_to_mm(&self, settings: &Settings) -> f64 {
        self.pushed_end_mm.max(self.plan_from_s_mm) + settings.planner.lookahead_mm
    }

    /// Chunks kept queued for this run.
    fn depth(&self) -> usize {
        if self.manual.is_some() { MANUAL_QUEUE_CHUNKS } else { QUEUE_CHUNKS }
    }

    /// Starts `chunk` as this run's next one, from its last queued point.
    fn open_chunk(&self, chunk: &mut Chunk) {
        chunk.clear();
        chunk.epoch = self.epoch;
        chunk.seq = self.seq;
        chunk.feed_override = self.feed_override;
        chunk.points.push(CoarsePoint { t_s: 0.0, ..self.end });
    }

    /// A chunk ending at `end` with the stop `tail` is filled: the next one starts there.
    fn close_chunk(&mut self, end: CoarsePoint, tail: Vec<Segment>) {
        self.last_tail = tail;
        self.end = end;
        self.seq += 1;
    }

    fn new(settings: &Settings, feed: PathFeed, feed_override: f64, epoch: Epoch, s_mm: f64, end: CoarsePoint) -> Run {
        let planner = Planner::new(settings);
        Run {
            feed,
            feed_override,
            epoch,
            seq: 0,
            planner,
            plan_from_s_mm: s_mm,
            pushed_end_mm: s_mm,
            next_element: None,
            finished_input: false,
            cut_first: false,
            pushed: 0,
            idle_for_input: false,
            stopped_for_input: false,
            reclaimed_s: VecDeque::new(),
            buffer: VecDeque::new(),
            last_tail: Vec::new(),
            end,
            complete: false,
            staged: Vec::new(),
            reached_depth: false,
            wait: Wait::No,
            queued_s: 0.0,
            law: None,
            manual: None,
            s_start_mm: s_mm,
        }
    }

    /// Plans until at least `need_s` of motion is buffered or the program is planned. When the
    /// program waits for appended text, planning stops there, or with `stop_if_waiting` the
    /// motion is planned to rest at the end of what is there.
    fn fill_buffer(&mut self, need_s: f64, stop_if_waiting: bool) -> Result<(), RunError> {
        let mut have: f64 = self.buffer.iter().map(|s| s.dt_s).sum();
        while have < need_s && !self.planner.done() {
            let index = match self.next_element {
                Some(i) => i,
                None => {
                    let i = self.feed.index_from(self.plan_from_s_mm)?;
                    self.next_element = Some(i);
                    self.cut_first = true;
                    i
                }
            };
            // The planner's path: from `plan_from_s_mm`, with the feeds scaled.
            let (from_s_mm, cut) = (self.plan_from_s_mm, self.cut_first);
            let got = self.feed.element(index)?.map(|e| if cut { e.from(from_s_mm) } else { e.clone() });
            match got {
                Some(mut e) => {
                    if let Feed::Programmed { mm_per_s } = &mut e.feed {
                        *mm_per_s *= self.feed_override;
                    }
                    self.pushed_end_mm = e.s_end_mm();
                    self.planner.push(e);
                    self.pushed += 1;
                    self.cut_first = false;
                    self.idle_for_input = false;
                    self.next_element = Some(index + 1);
                }
                None if self.feed.waiting() && !self.finished_input => {
                    self.next_element = Some(index);
                    // What is there is planned now, so the motion goes on as far as it can
                    // still stop within it.
                    let planned = self.planner.plan_now().map_err(RunError::Plan)?;
                    if !planned.is_empty() || !stop_if_waiting {
                        self.buffer.extend(planned);
                        return Ok(());
                    }
                    // The queue runs low: the smoothing stage closes its run at the end of what
                    // exists, and the planner brings the motion to rest there.
                    self.feed.flush()?;
                    if self.feed.element(index)?.is_some() {
                        continue;
                    }
                    if self.pushed == 0 {
                        // Nothing to move along: wait for text.
                        self.idle_for_input = true;
                        return Ok(());
                    }
                    self.planner.finish(0.0);
                    self.finished_input = true;
                    self.stopped_for_input = true;
                }
                None if !self.finished_input => {
                    self.planner.finish(self.feed.final_dwell_s());
                    self.finished_input = true;
                    self.next_element = Some(index);
                }
                None => self.next_element = Some(index),
            }
            for seg in self.planner.plan().map_err(RunError::Plan)? {
                have += seg.dt_s;
                self.buffer.push_back(seg);
            }
        }
        Ok(())
    }

    /// The real-time thread gave back a chunk of `epoch` that started at `s_mm`. At most
    /// [`QUEUE_CAPACITY`] chunks are in flight, so the machine is past the start of a chunk
    /// given back that many chunks ago, whatever it does now (a hold or an underrun stands
    /// further on): the path behind it is dropped.
    fn reclaimed(&mut self, epoch: Epoch, s_mm: f64) {
        if epoch != self.epoch || self.wait != Wait::No || self.manual.is_some() || self.law.is_some() {
            return;
        }
        self.reclaimed_s.push_back(s_mm);
        if self.reclaimed_s.len() > QUEUE_CAPACITY {
            if let Some(behind) = self.reclaimed_s.pop_front() {
                // The element at `plan_from_s_mm` is needed only until the planner has it.
                let keep = if self.next_element.is_some() { f64::INFINITY } else { self.plan_from_s_mm };
                self.feed.trim_before(behind.min(self.end.s_mm).min(keep));
            }
        }
    }

    /// Moves about `want_s` of segments from the buffer to `out` (splitting a long one),
    /// adding their duration to `t`.
    fn take(&mut self, want_s: f64, out: &mut Vec<Segment>, t: &mut f64) {
        let mut got = 0.0;
        while got < want_s {
            let Some(seg) = self.buffer.pop_front() else { break };
            let room = want_s - got;
            let seg = if seg.dt_s > room * (1.0 + SPLIT_OVERHANG) && room > 0.0 {
                let (now, later) = split(&seg, room);
                self.buffer.push_front(later);
                now
            } else {
                seg
            };
            got += seg.dt_s;
            out.push(seg);
        }
        *t += got;
    }
}

/// The limits and travel of every axis, for manual motion.
pub fn axis_limits(config: &Config) -> Vec<AxisLimits> {
    config
        .axes
        .iter()
        .map(|a| AxisLimits {
            vel: a.max_vel_per_s,
            acc: a.max_acc_per_s2,
            jerk: a.max_jerk_per_s3,
            min: a.min_pos,
            max: a.max_pos,
            linear: a.kind == interpd_config::AxisKind::Linear,
        })
        .collect()
}

/// Look-ahead the daemon plans with: the configured one, but no more than
/// `LOOKAHEAD_STOPS` × the longest braking distance of any axis from its top speed (further
/// look-ahead cannot change the motion, and every replan after an override change or a
/// restart costs time proportional to it), and at least `MIN_LOOKAHEAD_MM`.
pub fn bounded_lookahead_mm(settings: &Settings) -> f64 {
    let brake_mm = settings
        .axes
        .iter()
        .map(|a| a.max_vel_per_s * (a.max_vel_per_s / a.max_acc_per_s2 + a.max_acc_per_s2 / a.max_jerk_per_s3))
        .fold(0.0, f64::max);
    settings.planner.lookahead_mm.min((LOOKAHEAD_STOPS * brake_mm).max(MIN_LOOKAHEAD_MM))
}

/// See [`bounded_lookahead_mm`].
const LOOKAHEAD_STOPS: f64 = 3.0;
const MIN_LOOKAHEAD_MM: f64 = 20.0;

/// Why a run cannot go on.
#[derive(Debug, thiserror::Error)]
enum RunError {
    #[error("{0}")]
    Plan(PlanError),
    #[error("{0}")]
    Feed(#[from] FeedError),
}

/// Why the return to a held program cannot start.
#[derive(Debug, thiserror::Error)]
enum ReturnError {
    #[error("manual motion: {0}")]
    Manual(#[from] ManualPlanError),
    #[error("{0}")]
    Feed(#[from] FeedError),
}
