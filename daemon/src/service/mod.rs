//! The running service: the threads behind `interpd run` and the state machine the control
//! API drives.
//!
//! - the real-time thread (`rt_loop`) runs the executor ([`crate::interp`]) every cycle and
//!   publishes the setpoints to the sinks;
//! - the planner thread ([`feeder`]) plans ahead and keeps the chunk queue filled;
//! - the supervisor thread (`supervisor`) turns the executor's notices into state changes and
//!   events, and the timing samples into histograms;
//! - [`ServiceCore`] implements [`crate::control::Motion`] (`commands`, `load`): the
//!   control server's calls become atomic flags the real-time thread reads (hold, stop) and
//!   commands to the planner thread, checked against the state machine in `state`.
//!
//! The contract between the planner thread and the real-time thread is in [`crate::interp`];
//! docs/architecture.md draws the threads and queues.

mod allocator;
mod commands;
pub mod feeder;
pub mod law_run;
pub mod live;
mod load;
pub mod manual;
pub mod messages;
pub mod modal_track;
pub mod otg_motion;
pub mod param_store;
pub mod programs;
mod reposition;
mod rt_loop;
mod state;
mod supervisor;
pub mod tooling;

pub use rt_loop::CycleStall;

use crate::interp::Notice;
use crate::interp::executor::ExecutorFaults;
use crate::rt::{self, LoopTotals, TimingSample, sched::SchedReport, stats::CycleHistograms};
use crate::sinks::deferred::{self, DeferredStats, DeferredWorker};
use crate::sinks::{DriveMonitor, SetpointSink, shm::ShmSink};
use crossbeam::channel::{self, Sender};
use crossbeam::queue::ArrayQueue;
use feeder::{Feeder, FeederCommand, FeederStats, Queues};
use interpd_config::Config;
use interpd_motion::Settings;
use interpd_motion::path::MAX_AXES;
use interpd_protocol::api::Event;
use live::LiveSetpoint;
use state::Control;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Capacity of the notice and timing queues out of the real-time thread.
const NOTICE_CAPACITY: usize = 1024;
const TIMING_CAPACITY: usize = 8192;
/// Events buffered per subscriber before events are dropped for it.
const SUBSCRIBER_CAPACITY: usize = 1024;

/// How the service is set up.
#[derive(Debug, Clone)]
pub struct ServiceOptions {
    pub config: Config,
    /// Publish on iceoryx2 (`[sinks] shm`).
    pub shm: bool,
}

/// What the caller sets up besides the configured sinks (the CAN master): more sinks for the
/// real-time thread, the drives to ask before motion and to watch for faults, and the position
/// the machine stands at (the drives' actual positions) instead of the origin.
#[derive(Default)]
pub struct ServiceExtras {
    pub sinks: Vec<Box<dyn SetpointSink + Send>>,
    pub drives: Option<Arc<dyn DriveMonitor>>,
    pub start_position: Option<[f64; MAX_AXES]>,
    /// Testing aid: one stalled cycle of the real-time thread (see [`CycleStall`]).
    pub debug_stall_cycle: Option<CycleStall>,
}

/// Why the service could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartupError {
    #[error("{0}")]
    Sink(#[from] crate::sinks::SinkError),
    #[error("cannot start the {what} thread: {source}")]
    Thread {
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot start the real-time thread: exited during start-up")]
    RealTimeExited,
    #[error(transparent)]
    ProgramsDir(#[from] programs::ProgramsDirError),
    /// The parameter file cannot be read or is corrupt: nothing may move until it is fixed.
    #[error("{0}; fix or remove the file ([programs] parameter_file)")]
    ParamFile(#[from] interpd_motion::program::ParamFileError),
}

/// What the service did, reported at shutdown.
#[derive(Debug, Clone)]
pub struct ShutdownReport {
    pub sched: SchedReport,
    pub totals: LoopTotals,
    pub histograms: CycleHistograms,
    pub feeder: FeederStats,
    pub publish_errors: u64,
    pub executor_faults: ExecutorFaults,
    /// Per deferred publisher (shared memory): published, dropped, failed.
    pub publishers: Vec<DeferredStats>,
    /// The compensation stage's measurement counters (`None` without one).
    pub compensation: Option<crate::comp::CompStats>,
}

/// What the threads of the service share.
struct Shared {
    config: Config,
    /// The motion sections of `config`, as the motion library takes them.
    settings: Settings,
    /// Requests the real-time thread reads every cycle.
    hold: AtomicBool,
    stop: AtomicBool,
    /// The optional-stop switch (M1 pauses while it is on), `motion.optional_stop`.
    optional_stop: AtomicBool,
    /// Releases of program stops (`motion.resume` while paused counts it up).
    pause_releases: AtomicU64,
    /// The stop floor ([`crate::interp::Epochs::floor`]) as its number: chunks of older epochs
    /// never start.
    epoch_floor: AtomicU64,
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
    /// Changes of the compensation stage's measurement (lost, restored), from the cycle.
    comp_events: ArrayQueue<crate::comp::CompEvent>,
    /// The stage's counters at the end of the real-time loop.
    comp_stats: Mutex<Option<crate::comp::CompStats>>,
    drives: Option<Arc<dyn DriveMonitor>>,
    /// Where `program.load {"path"}` may read from.
    programs: programs::ProgramsDir,
    /// The tool table and work offsets programs are read with: the machine file's, until
    /// `tools.set` / `offsets.set` replace them.
    tooling: Mutex<Arc<tooling::Tooling>>,
    /// The running program's tool and offset state along its lines (the look-ahead thread
    /// writes it, `status` reads it).
    modal: Arc<Mutex<modal_track::ModalTrack>>,
    /// The running program's operator messages waiting for the motion (the look-ahead thread
    /// writes, the supervisor takes them as the motion reaches them).
    messages: Arc<Mutex<messages::MessageBoard>>,
    /// How the look-ahead thread keeps up (it writes, `status` reads).
    lookahead: Arc<feeder::LookaheadHealth>,
    /// An axis's setpoint moved at rest (homing), for the real-time thread.
    reposition: reposition::Reposition,
    /// The parameter file the work offsets and G28/G30 positions are kept in
    /// (`[programs] parameter_file`).
    params: Option<param_store::ParamStore>,
}

impl Shared {
    /// The settings a program is read with: the machine's, with the tool table and work
    /// offsets in effect now.
    fn program_settings(&self) -> Settings {
        self.tooling_now().apply(&self.settings)
    }

    /// The tool table and work offsets in effect now.
    fn tooling_now(&self) -> Arc<tooling::Tooling> {
        lock(&self.tooling).clone()
    }

    /// Requests a stop (the control lock held): the real-time thread diverts into the stop tail
    /// at the next chunk end, and chunks queued for the motion so far never start.
    fn request_stop(&self, ctl: &mut Control) {
        self.stop.store(true, Ordering::SeqCst);
        self.epoch_floor.fetch_max(ctl.epochs.floor().get(), Ordering::SeqCst);
        ctl.state = interpd_protocol::api::State::Stopping;
        let _ = self.feeder.send(FeederCommand::Abort);
    }

    /// Sends `event` to every subscriber without waiting: a full subscriber misses it, a gone
    /// one is forgotten.
    fn emit(&self, event: Event) {
        let mut subs = lock(&self.subscribers);
        subs.retain(|s| !matches!(s.try_send(event.clone()), Err(channel::TrySendError::Disconnected(_))));
    }
}

/// The service as the control API sees it (cheap to clone).
#[derive(Clone)]
pub struct ServiceCore {
    shared: Arc<Shared>,
}

/// The running service: the core and its threads.
pub struct Service {
    core: ServiceCore,
    sched: SchedReport,
    rt: Option<JoinHandle<(LoopTotals, ExecutorFaults)>>,
    publishers: Vec<DeferredWorker>,
    /// The compensation stage's shared-memory thread (stopped when dropped).
    comp_io: Option<crate::comp::io::CompIoWorker>,
    feeder: Option<JoinHandle<FeederStats>>,
    supervisor: Option<JoinHandle<()>>,
}

/// Compensation events queued for the supervisor (it drains them every 2 ms).
const COMP_EVENT_CAPACITY: usize = 16;

/// The configuration the planner plans with: with an active `[compensation]`, every axis's
/// velocity, acceleration and jerk limit less the share the corrections may use, so setpoint
/// plus correction keep the full limits.
fn planning_config(config: &Config) -> Config {
    let factor = crate::comp::planner_limit_factor(config);
    let mut c = config.clone();
    if factor < 1.0 {
        for a in &mut c.axes {
            a.max_vel_per_s *= factor;
            a.max_acc_per_s2 *= factor;
            a.max_jerk_per_s3 *= factor;
        }
    }
    c
}

/// A poisoned lock only means another thread panicked while holding it; the state behind it
/// is updated in single assignments and stays consistent, so carry on.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Service {
    /// Starts the real-time, planner and supervisor threads. Side effect: the calling thread
    /// and the threads it starts afterwards are kept off the real-time CPU
    /// ([`rt::sched::keep_off_rt_cpu`]).
    pub fn start(opts: ServiceOptions) -> Result<Service, StartupError> {
        Self::start_with(opts, ServiceExtras::default())
    }

    /// [`Service::start`] with extra sinks and drives (see [`ServiceExtras`]).
    pub fn start_with(opts: ServiceOptions, extras: ServiceExtras) -> Result<Service, StartupError> {
        let ServiceExtras { sinks: extra_sinks, drives, start_position, debug_stall_cycle } = extras;
        let programs = programs::ProgramsDir::from_config(&opts.config.programs)?;
        let params = param_store::ParamStore::open(opts.config.programs.parameter_file.as_deref())?;
        let mut kept = param_store::Kept { work_offsets: opts.config.work_offsets.clone(), ..Default::default() };
        if let Some(p) = &params {
            p.apply(&mut kept, &opts.config.axes);
        }
        allocator::keep_memory_returnable();
        // Before any thread starts: they all inherit it; the real-time thread pins itself.
        match rt::sched::keep_off_rt_cpu(&opts.config.rt) {
            Ok(cpu) => tracing::info!(cpu, "non-real-time threads kept off the real-time CPU"),
            Err(why) => tracing::info!("non-real-time threads share the real-time CPU: {why}"),
        }
        // With corrections the planner plans with what the limiter leaves of each limit.
        let plan_config = planning_config(&opts.config);
        let (feeder_tx, feeder_rx) = channel::unbounded();
        let (report_tx, report_rx) = channel::unbounded();
        let queues = Queues::new();
        let feeder = Feeder::new(&plan_config, queues.clone(), report_tx);
        let shared = Arc::new(Shared {
            config: opts.config.clone(),
            settings: Settings::from_config(&plan_config),
            hold: AtomicBool::new(false),
            epoch_floor: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            // On, as LinuxCNC starts.
            optional_stop: AtomicBool::new(true),
            pause_releases: AtomicU64::new(0),
            quit: AtomicBool::new(false),
            live: LiveSetpoint::default(),
            control: Mutex::new(Control::new()),
            feeder: feeder_tx,
            subscribers: Mutex::new(Vec::new()),
            histograms: Mutex::new(CycleHistograms::new()),
            queues: queues.clone(),
            notices: ArrayQueue::new(NOTICE_CAPACITY),
            timing: ArrayQueue::new(TIMING_CAPACITY),
            publish_errors: AtomicU64::new(0),
            comp_events: ArrayQueue::new(COMP_EVENT_CAPACITY),
            comp_stats: Mutex::new(None),
            drives,
            programs,
            tooling: Mutex::new(Arc::new(tooling::Tooling {
                tools: opts.config.tools.clone(),
                work_offsets: kept.work_offsets,
                home_positions: kept.home_positions,
            })),
            modal: feeder.modal_track(),
            messages: feeder.message_board(),
            lookahead: feeder.health(),
            reposition: reposition::Reposition::default(),
            params,
        });
        let thread_err = |what: &'static str| move |source| StartupError::Thread { what, source };

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
        // The compensation stage and, over shared memory, its measurement and actuator streams.
        let mut comp_io = None;
        let comp = match crate::comp::Compensation::new(&opts.config) {
            Some(stage) if opts.shm => {
                let prefix = &opts.config.sinks.shm_prefix;
                let (io, worker) = crate::comp::io::spawn(prefix, stage.uses_actuator())
                    .map_err(|message| crate::sinks::SinkError::Setup { sink: "compensation".into(), message })?;
                comp_io = Some(worker);
                Some((stage, Some(io)))
            }
            Some(stage) => Some((stage, None)),
            None => None,
        };
        let (ready_tx, ready_rx) = channel::bounded(1);
        let rt_shared = shared.clone();
        let rt = std::thread::Builder::new()
            .name("interpd-rt".into())
            .spawn(move || rt_loop::run(rt_shared, sinks, comp, start_position, debug_stall_cycle, ready_tx))
            .map_err(thread_err("real-time"))?;
        let Ok(sched) = ready_rx.recv() else { return Err(StartupError::RealTimeExited) };

        let sup_shared = shared.clone();
        let supervisor = std::thread::Builder::new()
            .name("interpd-supervisor".into())
            .spawn(move || supervisor::run(sup_shared, report_rx))
            .map_err(thread_err("supervisor"))?;
        Ok(Service {
            core: ServiceCore { shared },
            sched,
            rt: Some(rt),
            publishers,
            comp_io,
            feeder: Some(feeder),
            supervisor: Some(supervisor),
        })
    }

    pub fn core(&self) -> ServiceCore {
        self.core.clone()
    }

    /// Where `program.load {"path"}` reads files from.
    pub fn programs_dir(&self) -> &std::path::Path {
        self.core.shared.programs.path()
    }

    /// What the real-time set-up achieved.
    pub fn sched(&self) -> &SchedReport {
        &self.sched
    }

    /// Stops the threads (call after the motion came to rest) and reports.
    pub fn shutdown(mut self) -> ShutdownReport {
        let shared = &self.core.shared;
        shared.quit.store(true, Ordering::SeqCst);
        let _ = shared.feeder.send(FeederCommand::Shutdown);
        let (totals, executor_faults) = self.rt.take().and_then(|h| h.join().ok()).unwrap_or_default();
        let feeder = self.feeder.take().and_then(|h| h.join().ok()).unwrap_or_default();
        if let Some(h) = self.supervisor.take() {
            let _ = h.join();
        }
        supervisor::drain_timing(shared);
        let publishers = self.publishers.drain(..).map(DeferredWorker::stop).collect();
        drop(self.comp_io.take());
        ShutdownReport {
            sched: self.sched.clone(),
            totals,
            histograms: lock(&shared.histograms).clone(),
            feeder,
            publish_errors: shared.publish_errors.load(Ordering::Relaxed),
            executor_faults,
            publishers,
            compensation: *lock(&shared.comp_stats),
        }
    }
}

#[cfg(test)]
mod tests;
