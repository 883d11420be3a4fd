//! The control server's calls ([`Motion`] for [`ServiceCore`]): each is checked against the
//! state machine ([`super::state`]) and becomes flags the real-time thread reads every cycle
//! (hold, stop) and commands to the planner thread. None waits for the motion: its effect shows
//! in `status` and the events.

use super::approach;
use super::feeder::{self, FeederCommand, QUEUE_CHUNKS};
use super::law_run;
use super::state::{Control, Loaded, OVERRIDE_HOLD_BELOW};
use super::{SUBSCRIBER_CAPACITY, ServiceCore, lock};
use crate::control::{LawError, LoadError, Motion, NotAllowed, ProgramSource, ResumeError, StartError};
use crossbeam::channel::{self, Receiver};
use interpd_protocol::api::{Event, LawResult, Method, ProgramInfo, State, Status};
use interpd_protocol::shm::flags;
use std::convert::Infallible;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

impl ServiceCore {
    /// Holds (the control lock held): the real-time thread diverts into the stop tail at the
    /// next chunk end; `held` follows from the supervisor, or now if the machine stands.
    fn hold_locked(&self, ctl: &mut Control) {
        let shared = &self.shared;
        shared.hold.store(true, Ordering::SeqCst);
        ctl.state = State::Holding;
        if shared.live.load().flags & flags::IDLE != 0 {
            shared.emit(Event::Held);
        }
    }

    /// Resumes a hold (the control lock held): the planner thread replans from where the
    /// machine stands, or from where it will stand once the tail has run.
    fn resume_locked(&self, ctl: &mut Control) {
        let shared = &self.shared;
        shared.hold.store(false, Ordering::SeqCst);
        ctl.state = State::Running;
        ctl.held_by_override = false;
        let _ = shared.feeder.send(FeederCommand::Resume);
        shared.emit(Event::Resumed);
    }

    /// Lets the planner thread stall once (underrun tests and demonstrations).
    pub fn debug_stall_planner(&self, after_s: f64, for_s: f64) {
        let _ = self.shared.feeder.send(FeederCommand::DebugStall { after_s, for_s });
    }

    /// Waits until the state is one of `states` or `timeout` passes; returns the state.
    pub fn wait_for(&self, states: &[State], timeout: Duration) -> State {
        let until = Instant::now() + timeout;
        loop {
            let s = lock(&self.shared.control).state;
            if states.contains(&s) || Instant::now() >= until {
                return s;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Motion for ServiceCore {
    fn load(&self, source: ProgramSource) -> Result<ProgramInfo, LoadError> {
        self.load_program(source)
    }

    fn law(&self, statement: &str) -> Result<LawResult, LawError> {
        // The name the move's errors and `status.program` show.
        const NAME: &str = "motion.law";
        let Some(laws) = law_run::LawProgram::statement(statement, NAME) else {
            return Err(LawError::NotAStatement { got: statement.chars().take(80).collect() });
        };
        let (info, duration_s) = self.load_laws(NAME.to_owned(), laws?)?;
        self.start()?;
        Ok(LawResult { duration_s, length_mm: info.length_mm })
    }

    fn start(&self) -> Result<(), StartError> {
        let shared = &self.shared;
        let mut ctl = lock(&shared.control);
        ctl.check(Method::MotionStart)?;
        let Some((info, loaded)) = ctl.program.clone() else {
            return Err(NotAllowed { state: ctl.state, action: Method::MotionStart }.into());
        };
        if let Some(drives) = &shared.drives {
            drives.ready_for_motion()?;
        }
        let here = shared.live.load().pos;
        // Law moves are made (and checked against the limits) from where the machine stands.
        let motion = match &loaded {
            Loaded::Path(path) => (approach::with_approach(path, &here, &shared.config), None),
            Loaded::Laws(prog) => {
                let moves = prog.moves(&shared.settings, &here, &info.name)?;
                let (path, laws) = law_run::law_path(&shared.settings, moves, here, &prog.lines());
                (path, Some(Box::new(laws)))
            }
        };
        let epoch = ctl.begin_run();
        shared.hold.store(ctl.held_by_override, Ordering::SeqCst);
        shared.stop.store(false, Ordering::SeqCst);
        let feed_override = ctl.planned_override();
        let command = match motion {
            (path, Some(laws)) => FeederCommand::StartLaws { path: Arc::new(path), laws, epoch, feed_override },
            (path, None) => FeederCommand::Start { path: Arc::new(path), epoch, feed_override },
        };
        shared.feeder.send(command).map_err(|_| StartError::PlannerGone)
    }

    fn hold(&self) -> Result<(), NotAllowed> {
        let mut ctl = lock(&self.shared.control);
        ctl.check(Method::MotionHold)?;
        self.hold_locked(&mut ctl);
        Ok(())
    }

    fn resume(&self) -> Result<(), ResumeError> {
        let mut ctl = lock(&self.shared.control);
        ctl.check(Method::MotionResume)?;
        if ctl.feed_override < OVERRIDE_HOLD_BELOW {
            return Err(ResumeError::OverrideZero);
        }
        self.resume_locked(&mut ctl);
        Ok(())
    }

    fn stop(&self) -> Result<(), Infallible> {
        let shared = &self.shared;
        let mut ctl = lock(&shared.control);
        match ctl.state {
            State::Running | State::Holding => {
                shared.stop.store(true, Ordering::SeqCst);
                ctl.state = State::Stopping;
                let _ = shared.feeder.send(FeederCommand::Abort);
            }
            State::Error => {
                shared.stop.store(true, Ordering::SeqCst);
                ctl.state = State::Stopping;
                ctl.last_error = None;
                let _ = shared.feeder.send(FeederCommand::Abort);
            }
            State::Idle | State::Finished | State::Stopping => {}
        }
        Ok(())
    }

    fn set_override(&self, factor: f64) -> Result<(), Infallible> {
        let mut ctl = lock(&self.shared.control);
        ctl.feed_override = factor;
        if factor < OVERRIDE_HOLD_BELOW {
            if ctl.state == State::Running {
                ctl.held_by_override = true;
                self.hold_locked(&mut ctl);
            }
            return Ok(());
        }
        let _ = self.shared.feeder.send(FeederCommand::Override(factor));
        if ctl.held_by_override && ctl.state == State::Holding {
            self.resume_locked(&mut ctl);
        }
        ctl.held_by_override = false;
        Ok(())
    }

    fn status(&self) -> Status {
        let shared = &self.shared;
        let live = shared.live.load();
        let ctl = lock(&shared.control);
        let n = shared.config.axes.len();
        let queued = shared.queues.chunks.len();
        let chunk_s = shared.config.cycle_s() * f64::from(feeder::CHUNK_CYCLES);
        Status {
            state: ctl.state,
            line: live.line,
            s_mm: live.s_mm,
            feed_mm_s: live.v_mm_s,
            feed_override: ctl.feed_override,
            queue_fill: (queued as f64 / QUEUE_CHUNKS as f64).min(1.0),
            queue_s: queued as f64 * chunk_s,
            cycle: live.cycle,
            cycles: lock(&shared.histograms).cycle_stats(),
            last_error: ctl.last_error.clone(),
            program: ctl.program.as_ref().map(|(i, _)| i.clone()),
            axes: shared.config.axis_names(),
            position: live.pos[..n].to_vec(),
            drives: shared.drives.as_ref().map(|d| d.drives()).unwrap_or_default(),
            can_bus: shared.drives.as_ref().and_then(|d| d.bus()),
        }
    }

    fn subscribe(&self) -> Receiver<Event> {
        let (tx, rx) = channel::bounded(SUBSCRIBER_CAPACITY);
        lock(&self.shared.subscribers).push(tx);
        rx
    }
}
