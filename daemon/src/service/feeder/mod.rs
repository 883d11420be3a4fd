//! The planner thread: plans the running motion ahead of the machine, cuts it into chunks of
//! a few cycles, turns them into coarse points (stage 1 of the interpolation), adds to each
//! the fastest stop from its end, and keeps the real-time queue filled to a short depth. It
//! also carries out feed override changes (replanning from the end of the queue) and restarts
//! after a hold or an underrun (replanning from rest where the machine stands). See
//! [`crate::interp`] for the contract with the real-time thread.
//!
//! A run queues one kind of motion ([`run::Motion`]): a program or MDI blocks planned along
//! their path through an [`interpd_motion::Feed`] (`program`), motion-law moves (`law`), or a
//! jog or move-to (`manual`); `restart` continues a run after the planned motion was left or
//! changed, `health` measures how the thread keeps up.

mod health;
mod law;
mod manual;
mod program;
mod restart;
mod run;

pub use health::{FeederStats, LookaheadHealth};
pub use program::{FileStamp, PathSource, ProgramText};

use super::law_run::LawPart;
use super::lock;
use super::manual::{ManualGoal, ManualPart, ManualPlanError};
use super::messages::MessageBoard;
use super::modal_track::ModalTrack;
use super::otg_motion::AxisLimits;
use crate::interp::coarse::CoarsePoint;
use crate::interp::{Chunk, DivertCause, Epoch};
use crossbeam::channel::{Receiver, Sender};
use crossbeam::queue::ArrayQueue;
use interpd_config::Config;
use interpd_motion::path::{AxisVec, Path};
use interpd_motion::{Feed, FeedError, Settings};
use program::OpenError;
use run::{Motion, Run, Wait};
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
/// The longest the thread reads ahead before it looks again for commands and chunks due (one
/// read, with its smoothing window, may take longer).
const READ_AHEAD_SLICE: Duration = Duration::from_millis(2);
/// How long the thread waits for a command when it has nothing to do.
const IDLE_WAIT: Duration = Duration::from_millis(2);
/// A look-ahead step longer than this is logged (debug) with what it spent its time on.
const SLOW_STEP: Duration = Duration::from_millis(40);
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

/// The planner thread's state.
pub struct Feeder {
    /// The machine's motion settings, with the look-ahead the daemon plans with.
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
    /// The running program's operator messages, taken by the supervisor.
    pub(super) messages: Arc<Mutex<MessageBoard>>,
    /// How the thread kept up, read by `status`.
    health: Arc<LookaheadHealth>,
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
            messages: Arc::default(),
            health: Arc::default(),
        }
    }

    /// Where the running program's tool and offset state changes are kept (`status.modal`).
    pub fn modal_track(&self) -> Arc<Mutex<ModalTrack>> {
        self.modal.clone()
    }

    /// Where the running program's operator messages wait for the motion.
    pub fn message_board(&self) -> Arc<Mutex<MessageBoard>> {
        self.messages.clone()
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
                    lock(&self.messages).clear();
                }
                match self.start_path(source, feed_override, epoch) {
                    Ok(run) => self.run = Some(run),
                    Err(e) => self.failed(&e),
                }
            }
            FeederCommand::StartManual { goal, here, epoch, feed_override, suspend } => {
                self.health.reset();
                self.replace_run(suspend);
                match ManualPart::new(goal, here, &self.axis_limits, feed_override, None) {
                    Ok(part) => {
                        let start = CoarsePoint::at_rest(0.0, 0.0, 0, here);
                        self.run = Some(Run::new(Motion::Manual(part), feed_override, epoch, 0.0, start));
                    }
                    Err(e) => self.manual_failed(&e),
                }
            }
            FeederCommand::Manual(goal) => {
                let Some(Run { motion: Motion::Manual(part), .. }) = self.run.as_mut() else { return };
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
                let feed = Box::new(
                    Feed::builder(&self.settings).feed_override(feed_override).whole(Arc::unwrap_or_clone(path)),
                );
                self.run = Some(Run::new(Motion::Law { feed, law: laws }, feed_override, epoch, 0.0, start));
            }
            FeederCommand::Override(factor) => self.set_override(factor),
            FeederCommand::Diverted { epoch, cause } => {
                if let Some(run) = self.run.as_mut().filter(|r| r.epoch == epoch) {
                    run.epoch = epoch.replan();
                    run.seq = 0;
                    run.wait = Wait::Stand { cause, resume_requested: false };
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

    /// A run along the path of `source` from its start, at rest.
    fn start_path(&self, source: PathSource, feed_override: f64, epoch: Epoch) -> Result<Run, OpenError> {
        let mut path = self.open_path(source, feed_override)?;
        let (here, line) = path.feed.start()?;
        path.track_modal();
        let start = CoarsePoint::at_rest(0.0, 0.0, line, here);
        Ok(Run::new(Motion::Path(path), feed_override, epoch, 0.0, start))
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
        let manual = matches!(run.motion, Motion::Manual(_));
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
        let Some(run) = &self.run else { return false };
        let queued = self.queues.chunks.len();
        // A program waiting for appended text has nothing to do until it arrives, unless the
        // queue runs low (then it is planned to rest at the end of what is there).
        let waits = match &run.motion {
            Motion::Path(path) => path.feed.waits_for_text(queued > STARVED_STOP_CHUNKS),
            _ => false,
        };
        run.active() && queued < run.depth() && !waits
    }

    /// The queue is full and the run's program is not yet read as far ahead as its planner's
    /// next replan may need.
    pub(super) fn wants_to_read_ahead(&self) -> bool {
        self.run.as_ref().is_some_and(|run| match &run.motion {
            // A return move reads nothing; a law or manual path is held whole and cannot.
            Motion::Path(path) => run.active() && path.returning.is_none() && path.feed.wants_to_read_ahead(),
            _ => false,
        })
    }

    /// Reads and smooths the program ahead of the planner for one slice: the reading and
    /// smoothing a horizon replan needs are then done while the queue is full, and the step
    /// that replans does the planning alone.
    pub(super) fn read_ahead(&mut self) {
        let Some(run) = self.run.as_mut() else { return };
        let Motion::Path(path) = &mut run.motion else { return };
        let started = Instant::now();
        path.feed.read_ahead(started + READ_AHEAD_SLICE);
        path.track_modal();
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
            if took > SLOW_STEP {
                self.log_slow_step(took);
            }
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
            Err(FeedError::Plan(e)) => {
                chunk.clear();
                self.pool.push(chunk);
                if !self.recover(&e) {
                    self.failed(&format!("planning failed: {e}"));
                }
            }
            Err(e) => {
                chunk.clear();
                self.pool.push(chunk);
                self.failed(&e);
            }
        }
    }

    /// Logs (debug) what a step longer than `SLOW_STEP` spent its time on.
    fn log_slow_step(&self, took: Duration) {
        let Some(Motion::Path(path)) = self.run.as_ref().map(|r| &r.motion) else { return };
        let st = path.feed.stats();
        tracing::debug!(
            took_ms = took.as_secs_f64() * 1e3,
            s_mm = path.feed.progress().planned_to_mm,
            plan_call_max_ms = st.plan_call_max_s * 1e3,
            read_wait_s = st.read_wait_s,
            "slow look-ahead step"
        );
    }

    /// Fills `chunk` with the next stretch of the run's motion; `Ok(false)` when nothing is
    /// left.
    fn fill_chunk(&mut self, chunk: &mut Chunk) -> Result<bool, FeedError> {
        let Some(run) = self.run.as_ref() else { return Ok(false) };
        match &run.motion {
            Motion::Law { .. } => Ok(self.fill_law_chunk(chunk)),
            m if m.manual().is_some() => Ok(self.fill_manual_chunk(chunk)),
            _ => self.fill_path_chunk(chunk),
        }
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

/// Why a restart along the path, or the return to a held program, cannot start.
#[derive(Debug, thiserror::Error)]
enum RestartError {
    #[error("manual motion: {0}")]
    Manual(#[from] ManualPlanError),
    #[error("{0}")]
    Feed(#[from] FeedError),
}
