//! The motion core: the threads of the running service and the state machine the control API
//! drives.
//!
//! - the real-time thread ([`crate::rt`]) runs the executor ([`crate::interp`]) every cycle
//!   and publishes the setpoints to the sinks;
//! - the planner thread ([`feeder`]) plans ahead and keeps the chunk queue filled;
//! - the supervisor thread turns the executor's notices into state changes and events, and
//!   the timing samples into histograms.
//!
//! [`MotionCore`] implements [`crate::control::Motion`]: the control server's calls become
//! atomic flags the real-time thread reads (hold, stop) and commands to the planner thread.

pub mod approach;
pub mod feeder;
pub mod law_run;
pub mod live;

use crate::control::{Motion, MotionError, ProgramSource};
use crate::interp::{DivertCause, Executor, Io, Notice};
use crate::rt::{self, LoopTotals, TimingSample, sched::SchedReport, stats::CycleHistograms};
use crate::sinks::deferred::{self, DeferredStats, DeferredWorker};
use crate::sinks::{DriveMonitor, SetpointSink, shm::ShmSink};
use crossbeam::channel::{self, Receiver, Sender};
use crossbeam::queue::ArrayQueue;
use feeder::{Feeder, FeederCommand, FeederReport, FeederStats, QUEUE_CHUNKS, Queues};
use interpd_config::Config;
use interpd_motion::Settings;
use interpd_motion::law::LawMove;
use interpd_motion::path::Path;
use interpd_motion::program;
use interpd_protocol::api::{Event, ProgramInfo, State, Status};
use interpd_protocol::shm::{Setpoints, flags};
use law_run::LawProgram;
use live::LiveSetpoint;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// Override factors below this act as a feed hold (0 % feed).
pub const OVERRIDE_HOLD_BELOW: f64 = 1e-3;
/// Capacity of the notice and timing queues out of the real-time thread.
const NOTICE_CAPACITY: usize = 1024;
const TIMING_CAPACITY: usize = 8192;
/// Events buffered per subscriber before events are dropped for it.
const SUBSCRIBER_CAPACITY: usize = 1024;
/// Supervisor poll period.
const SUPERVISOR_PERIOD: Duration = Duration::from_millis(2);
/// Delay from start-up to the first cycle (lets the threads settle).
const FIRST_CYCLE_DELAY_NS: u64 = 20_000_000;

/// How the service is set up.
#[derive(Debug, Clone)]
pub struct MotionOptions {
    pub config: Config,
    /// Publish on iceoryx2 (`[sinks] shm`).
    pub shm: bool,
}

/// What the caller sets up besides the configured sinks (the CAN master): more sinks for the
/// real-time thread, the drives to ask before motion and to watch for faults, and the position
/// the machine stands at (the drives' actual positions) instead of the origin.
#[derive(Default)]
pub struct MotionExtras {
    pub sinks: Vec<Box<dyn SetpointSink + Send>>,
    pub drives: Option<Arc<dyn DriveMonitor>>,
    pub start_position: Option<[f64; interpd_motion::path::MAX_AXES]>,
}

/// Why the service could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    #[error("{0}")]
    Sink(#[from] crate::sinks::SinkError),
    #[error("cannot start the {what} thread: {message}")]
    Thread { what: &'static str, message: String },
}

/// What the service did, reported at shutdown.
#[derive(Debug, Clone)]
pub struct ShutdownReport {
    pub sched: SchedReport,
    pub totals: LoopTotals,
    pub histograms: CycleHistograms,
    pub feeder: FeederStats,
    pub publish_errors: u64,
    pub executor_faults: crate::interp::executor::ExecutorFaults,
    /// Per deferred publisher (shared memory): published, dropped, failed.
    pub publishers: Vec<DeferredStats>,
}

/// A loaded program: a path to plan, or motion-law moves (made from where the machine stands
/// when it starts).
#[derive(Clone)]
enum Loaded {
    Path(Arc<Path>),
    Laws(Arc<LawProgram>),
}

/// The control-side state.
struct Control {
    state: State,
    program: Option<(ProgramInfo, Loaded)>,
    feed_override: f64,
    held_by_override: bool,
    last_error: Option<String>,
    /// Epochs below this are used; a start takes it and moves it on.
    next_epoch: u64,
    start_event_pending: bool,
    underrun: bool,
    start_cycle: u64,
}

struct Inner {
    config: Config,
    /// The motion sections of `config`, as the motion library takes them.
    settings: Settings,
    hold: AtomicBool,
    stop: AtomicBool,
    quit: AtomicBool,
    live: LiveSetpoint,
    control: Mutex<Control>,
    feeder: Sender<FeederCommand>,
    subscribers: Mutex<Vec<Sender<Event>>>,
    histograms: Mutex<CycleHistograms>,
    queues: Queues,
    notices: ArrayQueue<Notice>,
    timing: ArrayQueue<TimingSample>,
    publish_errors: AtomicU64,
    drives: Option<Arc<dyn DriveMonitor>>,
}

/// The motion core as the control API sees it (cheap to clone).
#[derive(Clone)]
pub struct MotionCore {
    inner: Arc<Inner>,
}

/// The running service: the core and its threads.
pub struct MotionService {
    core: MotionCore,
    sched: SchedReport,
    rt: Option<JoinHandle<(LoopTotals, crate::interp::executor::ExecutorFaults)>>,
    publishers: Vec<DeferredWorker>,
    feeder: Option<JoinHandle<FeederStats>>,
    supervisor: Option<JoinHandle<()>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl MotionService {
    /// Starts the real-time, planner and supervisor threads. Side effect: the calling thread
    /// and the threads it starts afterwards are kept off the real-time CPU
    /// ([`rt::sched::keep_off_rt_cpu`]).
    pub fn start(opts: MotionOptions) -> Result<MotionService, StartError> {
        Self::start_with(opts, MotionExtras::default())
    }

    /// [`MotionService::start`] with extra sinks and drives (see [`MotionExtras`]).
    pub fn start_with(opts: MotionOptions, extras: MotionExtras) -> Result<MotionService, StartError> {
        let MotionExtras { sinks: extra_sinks, drives, start_position } = extras;
        // Before any thread starts: they all inherit it; the real-time thread pins itself.
        match rt::sched::keep_off_rt_cpu(&opts.config.rt) {
            Ok(cpu) => tracing::info!(cpu, "non-real-time threads kept off the real-time CPU"),
            Err(why) => tracing::info!("non-real-time threads share the real-time CPU: {why}"),
        }
        let (feeder_tx, feeder_rx) = channel::unbounded();
        let (report_tx, report_rx) = channel::unbounded();
        let queues = Queues::new();
        let inner = Arc::new(Inner {
            config: opts.config.clone(),
            settings: Settings::from_config(&opts.config),
            hold: AtomicBool::new(false),
            stop: AtomicBool::new(false),
            quit: AtomicBool::new(false),
            live: LiveSetpoint::default(),
            control: Mutex::new(Control {
                state: State::Idle,
                program: None,
                feed_override: 1.0,
                held_by_override: false,
                last_error: None,
                next_epoch: 1,
                start_event_pending: false,
                underrun: false,
                start_cycle: 0,
            }),
            feeder: feeder_tx,
            subscribers: Mutex::new(Vec::new()),
            histograms: Mutex::new(CycleHistograms::new()),
            queues: queues.clone(),
            notices: ArrayQueue::new(NOTICE_CAPACITY),
            timing: ArrayQueue::new(TIMING_CAPACITY),
            publish_errors: AtomicU64::new(0),
            drives,
        });
        let thread_err =
            |what: &'static str| move |e: std::io::Error| StartError::Thread { what, message: e.to_string() };

        let feeder = Feeder::new(&opts.config, queues, report_tx);
        let planner_nice = opts.config.rt.planner_nice;
        let feeder = std::thread::Builder::new()
            .name("interpd-planner".into())
            .spawn(move || {
                match rt::sched::set_thread_nice(planner_nice) {
                    Ok(()) => tracing::info!(nice = planner_nice, "planner thread scheduled"),
                    Err(why) => tracing::info!("planner thread at the default nice value: {why}"),
                }
                feeder.run(feeder_rx)
            })
            .map_err(thread_err("planner"))?;

        // Sinks: iceoryx2 publishes from a thread of its own (its loan allocates).
        let mut sinks: Vec<Box<dyn SetpointSink + Send>> = Vec::new();
        let mut publishers = Vec::new();
        if opts.shm {
            let prefix = opts.config.sinks.shm_prefix.clone();
            let priority = (opts.config.rt.priority - 1).max(0);
            let (sink, worker) = deferred::spawn("shm", priority, move || ShmSink::create(&prefix))?;
            sinks.push(Box::new(sink));
            publishers.push(worker);
        }
        // The caller's sinks (the CAN master's) publish in the cycle itself: they neither
        // allocate nor block.
        sinks.extend(extra_sinks);
        let (ready_tx, ready_rx) = channel::bounded(1);
        let rt_inner = inner.clone();
        let rt = std::thread::Builder::new()
            .name("interpd-rt".into())
            .spawn(move || rt_thread(rt_inner, sinks, start_position, ready_tx))
            .map_err(thread_err("real-time"))?;
        let sched = match ready_rx.recv() {
            Ok(Ok(sched)) => sched,
            Ok(Err(e)) => {
                let _ = inner.feeder.send(FeederCommand::Shutdown);
                let _ = rt.join();
                let _ = feeder.join();
                return Err(e);
            }
            Err(_) => return Err(StartError::Thread { what: "real-time", message: "exited during start-up".into() }),
        };

        let sup_inner = inner.clone();
        let supervisor = std::thread::Builder::new()
            .name("interpd-supervisor".into())
            .spawn(move || supervise(sup_inner, report_rx))
            .map_err(thread_err("supervisor"))?;
        Ok(MotionService {
            core: MotionCore { inner },
            sched,
            rt: Some(rt),
            publishers,
            feeder: Some(feeder),
            supervisor: Some(supervisor),
        })
    }

    pub fn core(&self) -> MotionCore {
        self.core.clone()
    }

    /// What the real-time set-up achieved.
    pub fn sched(&self) -> &SchedReport {
        &self.sched
    }

    /// Stops the threads (call after the motion came to rest) and reports.
    pub fn shutdown(mut self) -> ShutdownReport {
        let inner = &self.core.inner;
        inner.quit.store(true, Ordering::SeqCst);
        let _ = inner.feeder.send(FeederCommand::Shutdown);
        let (totals, executor_faults) = self.rt.take().and_then(|h| h.join().ok()).unwrap_or_default();
        let feeder = self.feeder.take().and_then(|h| h.join().ok()).unwrap_or_default();
        if let Some(h) = self.supervisor.take() {
            let _ = h.join();
        }
        drain_timing(inner);
        let publishers = self.publishers.drain(..).map(DeferredWorker::stop).collect();
        ShutdownReport {
            sched: self.sched.clone(),
            totals,
            histograms: lock(&inner.histograms).clone(),
            feeder,
            publish_errors: inner.publish_errors.load(Ordering::Relaxed),
            executor_faults,
            publishers,
        }
    }
}

/// The real-time thread: scheduling, then the loop over the executor and the sinks.
fn rt_thread(
    inner: Arc<Inner>,
    mut sinks: Vec<Box<dyn SetpointSink + Send>>,
    start_position: Option<[f64; interpd_motion::path::MAX_AXES]>,
    ready: Sender<Result<SchedReport, StartError>>,
) -> (LoopTotals, crate::interp::executor::ExecutorFaults) {
    let sched = rt::sched::apply(&inner.config.rt);
    let _ = ready.send(Ok(sched));
    let n_axes = inner.config.axes.len();
    let mut executor = Executor::new(n_axes, start_position.unwrap_or([0.0; interpd_motion::path::MAX_AXES]));
    let mut sp = Setpoints { n_axes: n_axes as u32, ..Setpoints::default() };
    let period_ns = (inner.config.machine.cycle_ms * 1e6).round() as u64;
    let dt_s = period_ns as f64 * 1e-9;
    let start_ns = rt::clock::now_ns() + FIRST_CYCLE_DELAY_NS;
    let mut publish_errors = 0u64;
    let totals = rt::run_loop(start_ns, period_ns, &inner.quit, &inner.timing, |cycle, deadline_ns, late| {
        let io = Io {
            chunks: &inner.queues.chunks,
            recycle: &inner.queues.recycle,
            notices: &inner.notices,
            hold: inner.hold.load(Ordering::Relaxed),
            stop: inner.stop.load(Ordering::Relaxed),
        };
        executor.step(cycle, dt_s, &io, &mut sp);
        sp.cycle = cycle;
        sp.time_ns = deadline_ns;
        if late {
            sp.flags |= flags::LATE;
        }
        for sink in sinks.iter_mut() {
            if sink.publish(&sp).is_err() {
                publish_errors += 1;
            }
        }
        inner.live.store(&sp);
        if publish_errors > 0 && cycle % 256 == 0 {
            inner.publish_errors.store(publish_errors, Ordering::Relaxed);
        }
        true
    });
    inner.publish_errors.store(publish_errors, Ordering::Relaxed);
    (totals, executor.faults)
}

fn drain_timing(inner: &Inner) {
    let mut h = lock(&inner.histograms);
    while let Some(s) = inner.timing.pop() {
        h.record(&s);
    }
}

/// The supervisor: notices → state and events; feeder reports; timing → histograms.
fn supervise(inner: Arc<Inner>, reports: Receiver<FeederReport>) {
    while !inner.quit.load(Ordering::SeqCst) {
        while let Some(n) = inner.notices.pop() {
            on_notice(&inner, n);
        }
        while let Ok(r) = reports.try_recv() {
            on_report(&inner, r);
        }
        drain_timing(&inner);
        check_drives(&inner);
        finish_stop_if_standing(&inner);
        std::thread::sleep(SUPERVISOR_PERIOD);
    }
}

fn on_notice(inner: &Inner, n: Notice) {
    let mut ctl = lock(&inner.control);
    match n {
        Notice::Started { epoch, cycle } => {
            ctl.next_epoch = ctl.next_epoch.max(epoch + 2);
            if ctl.start_event_pending {
                ctl.start_event_pending = false;
                ctl.start_cycle = cycle;
                drop(ctl);
                inner.emit(Event::Started);
            } else if ctl.underrun {
                ctl.underrun = false;
                drop(ctl);
                inner.emit(Event::UnderrunCleared);
            }
        }
        Notice::Diverted { epoch, cause, .. } => {
            ctl.next_epoch = ctl.next_epoch.max(epoch + 2);
            let _ = inner.feeder.send(FeederCommand::Diverted { epoch, cause });
            if cause == DivertCause::Underrun {
                ctl.underrun = true;
                drop(ctl);
                tracing::warn!("underrun: the planner did not keep up; stopping along the path");
                inner.emit(Event::Underrun { s_mm: inner.live.load().s_mm });
            }
        }
        Notice::Stood { epoch, cause, s_mm, .. } => {
            ctl.next_epoch = ctl.next_epoch.max(epoch + 2);
            let _ = inner.feeder.send(FeederCommand::Stood { epoch, cause, s_mm });
            if ctl.state == State::Stopping {
                drop(ctl);
                inner.complete_stop();
            } else if cause == DivertCause::Hold && ctl.state == State::Holding {
                drop(ctl);
                inner.emit(Event::Held);
            }
        }
        Notice::Finished { epoch, cycle, .. } => {
            ctl.next_epoch = ctl.next_epoch.max(epoch + 2);
            if ctl.state == State::Stopping {
                drop(ctl);
                inner.complete_stop();
                return;
            }
            ctl.state = State::Finished;
            let duration_s = (cycle - ctl.start_cycle) as f64 * inner.config.cycle_s();
            drop(ctl);
            inner.emit(Event::Finished { duration_s });
        }
        Notice::Line { line, .. } => {
            drop(ctl);
            inner.emit(Event::LineReached { line });
        }
    }
}

fn on_report(inner: &Inner, r: FeederReport) {
    match r {
        FeederReport::Error(message) => {
            let mut ctl = lock(&inner.control);
            ctl.state = State::Error;
            ctl.last_error = Some(message.clone());
            drop(ctl);
            inner.emit(Event::Error { message });
        }
        FeederReport::Complete { .. } => {}
    }
}

/// A drive fault (reported by the drive monitor) while the machine moves: a controlled stop
/// along the path, the fault as `last_error` and an error event. At rest it is only logged
/// (motion.start refuses until the drives are ready again).
fn check_drives(inner: &Inner) {
    let Some(drives) = &inner.drives else { return };
    while let Some(message) = drives.take_fault() {
        let mut ctl = lock(&inner.control);
        if !matches!(ctl.state, State::Running | State::Holding) {
            continue;
        }
        inner.stop.store(true, Ordering::SeqCst);
        ctl.state = State::Stopping;
        ctl.last_error = Some(message.clone());
        let _ = inner.feeder.send(FeederCommand::Abort);
        drop(ctl);
        tracing::error!("drive fault during motion: {message}; stopping");
        inner.emit(Event::Error { message });
    }
}

/// A stop requested while the machine already stood (held, or after an underrun) completes
/// without a tail.
fn finish_stop_if_standing(inner: &Inner) {
    let stopping = lock(&inner.control).state == State::Stopping;
    if stopping && inner.live.load().flags & flags::IDLE != 0 {
        inner.complete_stop();
    }
}

impl Inner {
    fn emit(&self, event: Event) {
        let mut subs = lock(&self.subscribers);
        subs.retain(|s| !matches!(s.try_send(event.clone()), Err(channel::TrySendError::Disconnected(_))));
    }

    /// The machine stands after a stop: drop what is queued, clear the requests, go idle.
    fn complete_stop(&self) {
        let _ = self.feeder.send(FeederCommand::Abort);
        // The executor takes no chunk while the stop flag is set: empty the queue first.
        while let Some(c) = self.queues.chunks.pop() {
            let _ = self.queues.recycle.push(c);
        }
        let mut ctl = lock(&self.control);
        if ctl.state != State::Stopping {
            return;
        }
        ctl.state = State::Idle;
        ctl.held_by_override = false;
        self.hold.store(false, Ordering::SeqCst);
        self.stop.store(false, Ordering::SeqCst);
        drop(ctl);
        self.emit(Event::Stopped);
    }

    fn not_allowed(state: State, action: &'static str) -> MotionError {
        MotionError::NotAllowed { state, action }
    }
}

impl MotionCore {
    fn hold_locked(&self, ctl: &mut Control) {
        let inner = &self.inner;
        inner.hold.store(true, Ordering::SeqCst);
        ctl.state = State::Holding;
        if inner.live.load().flags & flags::IDLE != 0 {
            inner.emit(Event::Held);
        }
    }

    fn resume_locked(&self, ctl: &mut Control) {
        let inner = &self.inner;
        inner.hold.store(false, Ordering::SeqCst);
        ctl.state = State::Running;
        ctl.held_by_override = false;
        let _ = inner.feeder.send(FeederCommand::Resume);
        inner.emit(Event::Resumed);
    }

    /// Lets the planner thread stall once (underrun tests and demonstrations).
    pub fn debug_stall_planner(&self, after_s: f64, for_s: f64) {
        let _ = self.inner.feeder.send(FeederCommand::DebugStall { after_s, for_s });
    }

    /// Waits until the state is one of `states` or `timeout` passes; returns the state.
    pub fn wait_for(&self, states: &[State], timeout: Duration) -> State {
        let until = std::time::Instant::now() + timeout;
        loop {
            let s = lock(&self.inner.control).state;
            if states.contains(&s) || std::time::Instant::now() >= until {
                return s;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl MotionCore {
    /// `program.load` of a law program: the moves are made and checked from where the machine
    /// stands now (and again at `motion.start`, from where it stands then).
    /// Returns the program's info and the moves' total duration.
    fn load_laws(&self, name: String, laws: LawProgram) -> Result<(ProgramInfo, f64), MotionError> {
        let inner = &self.inner;
        let here = inner.live.load().pos;
        let moves = laws.moves(&inner.settings, &here, &name).map_err(MotionError::BadProgram)?;
        let duration_s = moves.iter().map(LawMove::duration_s).sum();
        let (path, _) = law_run::law_path(&inner.settings, moves, here, &laws.lines());
        let info = ProgramInfo {
            name,
            elements: laws.blocks.len() as u64,
            length_mm: path.length_mm(),
            lines: laws.blocks.last().map_or(0, |(n, _)| *n),
        };
        let mut ctl = lock(&inner.control);
        if !matches!(ctl.state, State::Idle | State::Finished) {
            return Err(Inner::not_allowed(ctl.state, "program.load"));
        }
        ctl.program = Some((info.clone(), Loaded::Laws(Arc::new(laws))));
        ctl.state = State::Idle;
        ctl.last_error = None;
        Ok((info, duration_s))
    }
}

/// The law program in `source`, if it is one (see [`law_run::parse_law_program`]).
fn law_program_of(source: &ProgramSource) -> Result<Option<(String, LawProgram)>, MotionError> {
    let (name, text) = match source {
        ProgramSource::Text { name, text } => (name.clone(), std::borrow::Cow::Borrowed(text.as_str())),
        ProgramSource::File(p) => match std::fs::read_to_string(p) {
            Ok(t) => (p.display().to_string(), std::borrow::Cow::Owned(t)),
            // Unreadable or not text: the program reader reports it.
            Err(_) => return Ok(None),
        },
    };
    let laws = law_run::parse_law_program(&text, &name).map_err(MotionError::BadProgram)?;
    Ok(laws.map(|l| (name, l)))
}

impl Motion for MotionCore {
    fn load(&self, source: ProgramSource) -> Result<ProgramInfo, MotionError> {
        let inner = &self.inner;
        let state = lock(&inner.control).state;
        if !matches!(state, State::Idle | State::Finished) {
            return Err(Inner::not_allowed(state, "program.load"));
        }
        if let Some((name, laws)) = law_program_of(&source)? {
            return self.load_laws(name, laws).map(|(info, _)| info);
        }
        let (name, parsed) = match source {
            ProgramSource::File(p) => (p.display().to_string(), program::load(&p, &inner.settings)),
            ProgramSource::Text { name, text } => {
                let parsed = program::parse(&text, &name, &inner.settings);
                (name, parsed)
            }
        };
        let prog = parsed.map_err(|e| MotionError::BadProgram(e.to_string()))?;
        // Tolerance-band smoothing (G64 P…) of the whole program, here in the control thread:
        // it runs ahead of the planner and never near the real-time thread.
        let prepared = interpd_motion::prep::prepare_path(&inner.settings, &prog.path)
            .map_err(|e| MotionError::BadProgram(format!("{name}: {e}")))?;
        if prepared.stats.windows > 0 {
            tracing::info!(
                program = %name,
                windows = prepared.stats.windows,
                wall_ms = prepared.wall_s * 1e3,
                "path smoothing (G64) prepared"
            );
        }
        let info = ProgramInfo {
            name,
            elements: prepared.path.elements.len() as u64,
            length_mm: prepared.path.length_mm(),
            lines: prog.summary.lines,
        };
        let prog = program::Program { path: prepared.path, summary: prog.summary };
        let mut ctl = lock(&inner.control);
        if !matches!(ctl.state, State::Idle | State::Finished) {
            return Err(Inner::not_allowed(ctl.state, "program.load"));
        }
        ctl.program = Some((info.clone(), Loaded::Path(Arc::new(prog.path))));
        ctl.state = State::Idle;
        ctl.last_error = None;
        Ok(info)
    }

    fn law(&self, statement: &str) -> Result<serde_json::Value, MotionError> {
        if statement.contains('\n') || !interpd_motion::law::program::is_law_statement(statement) {
            return Err(MotionError::InvalidParams(format!(
                "\"statement\" must be one LAW statement, e.g. \"LAW PRESET=rr7 DURATION=0.8 X=10\"; got {:?}",
                statement.chars().take(80).collect::<String>()
            )));
        }
        let name = "motion.law";
        let laws = law_run::parse_law_program(statement, name)
            .map_err(MotionError::BadProgram)?
            .ok_or_else(|| MotionError::Internal("a LAW statement did not parse as a law program".into()))?;
        let (info, duration_s) = self.load_laws(name.to_owned(), laws)?;
        self.start()?;
        Ok(serde_json::json!({ "duration_s": duration_s, "length_mm": info.length_mm }))
    }

    fn start(&self) -> Result<(), MotionError> {
        let inner = &self.inner;
        let mut ctl = lock(&inner.control);
        let Some((info, loaded)) = ctl.program.clone() else {
            return Err(Inner::not_allowed(ctl.state, "motion.start"));
        };
        if let (Some(drives), State::Idle | State::Finished) = (&inner.drives, ctl.state) {
            drives.ready_for_motion().map_err(MotionError::DrivesNotReady)?;
        }
        if !matches!(ctl.state, State::Idle | State::Finished) || ctl.state == State::Finished && ctl.program.is_none()
        {
            return Err(Inner::not_allowed(ctl.state, "motion.start"));
        }
        let here = inner.live.load().pos;
        // Law moves are made (and checked against the limits) from where the machine stands.
        let motion = match &loaded {
            Loaded::Path(path) => (approach::with_approach(path, &here, &inner.config), None),
            Loaded::Laws(prog) => {
                let moves = prog.moves(&inner.settings, &here, &info.name).map_err(MotionError::BadProgram)?;
                let (path, laws) = law_run::law_path(&inner.settings, moves, here, &prog.lines());
                (path, Some(Box::new(laws)))
            }
        };
        let epoch = ctl.next_epoch;
        ctl.next_epoch += 2;
        ctl.state = State::Running;
        ctl.start_event_pending = true;
        ctl.underrun = false;
        ctl.last_error = None;
        inner.hold.store(ctl.held_by_override, Ordering::SeqCst);
        if ctl.held_by_override {
            ctl.state = State::Holding;
        }
        inner.stop.store(false, Ordering::SeqCst);
        let feed_override = if ctl.feed_override < OVERRIDE_HOLD_BELOW { 1.0 } else { ctl.feed_override };
        let command = match motion {
            (path, Some(laws)) => FeederCommand::StartLaws { path: Arc::new(path), laws, epoch, feed_override },
            (path, None) => FeederCommand::Start { path: Arc::new(path), epoch, feed_override },
        };
        inner.feeder.send(command).map_err(|_| MotionError::Internal("the planner thread has ended".into()))
    }

    fn hold(&self) -> Result<(), MotionError> {
        let mut ctl = lock(&self.inner.control);
        if ctl.state != State::Running {
            return Err(Inner::not_allowed(ctl.state, "motion.hold"));
        }
        self.hold_locked(&mut ctl);
        Ok(())
    }

    fn resume(&self) -> Result<(), MotionError> {
        let mut ctl = lock(&self.inner.control);
        if ctl.state != State::Holding {
            return Err(Inner::not_allowed(ctl.state, "motion.resume"));
        }
        if ctl.feed_override < OVERRIDE_HOLD_BELOW {
            return Err(MotionError::InvalidParams(
                "the feed override is 0 %: raise it with feed.override to continue".into(),
            ));
        }
        self.resume_locked(&mut ctl);
        Ok(())
    }

    fn stop(&self) -> Result<(), MotionError> {
        let inner = &self.inner;
        let mut ctl = lock(&inner.control);
        match ctl.state {
            State::Running | State::Holding => {
                inner.stop.store(true, Ordering::SeqCst);
                ctl.state = State::Stopping;
                let _ = inner.feeder.send(FeederCommand::Abort);
            }
            State::Error => {
                inner.stop.store(true, Ordering::SeqCst);
                ctl.state = State::Stopping;
                ctl.last_error = None;
                let _ = inner.feeder.send(FeederCommand::Abort);
            }
            State::Idle | State::Finished | State::Stopping => {}
        }
        Ok(())
    }

    fn set_override(&self, factor: f64) -> Result<(), MotionError> {
        let mut ctl = lock(&self.inner.control);
        ctl.feed_override = factor;
        if factor < OVERRIDE_HOLD_BELOW {
            if ctl.state == State::Running {
                ctl.held_by_override = true;
                self.hold_locked(&mut ctl);
            }
            return Ok(());
        }
        let _ = self.inner.feeder.send(FeederCommand::Override(factor));
        if ctl.held_by_override && ctl.state == State::Holding {
            self.resume_locked(&mut ctl);
        }
        ctl.held_by_override = false;
        Ok(())
    }

    fn status(&self) -> Status {
        let inner = &self.inner;
        let live = inner.live.load();
        let ctl = lock(&inner.control);
        let n = inner.config.axes.len();
        let queued = inner.queues.chunks.len();
        let chunk_s = inner.config.cycle_s() * f64::from(feeder::CHUNK_CYCLES);
        Status {
            state: ctl.state,
            line: live.line,
            s_mm: live.s_mm,
            feed_mm_s: live.v_mm_s,
            feed_override: ctl.feed_override,
            queue_fill: (queued as f64 / QUEUE_CHUNKS as f64).min(1.0),
            queue_s: queued as f64 * chunk_s,
            cycle: live.cycle,
            cycles: lock(&inner.histograms).cycle_stats(),
            last_error: ctl.last_error.clone(),
            program: ctl.program.as_ref().map(|(i, _)| i.clone()),
            axes: inner.config.axis_names(),
            position: live.pos[..n].to_vec(),
            drives: inner.drives.as_ref().map(|d| d.drives()).unwrap_or_default(),
            can_bus: inner.drives.as_ref().and_then(|d| d.bus()),
        }
    }

    fn subscribe(&self) -> Receiver<Event> {
        let (tx, rx) = channel::bounded(SUBSCRIBER_CAPACITY);
        lock(&self.inner.subscribers).push(tx);
        rx
    }
}

#[cfg(test)]
mod tests;
