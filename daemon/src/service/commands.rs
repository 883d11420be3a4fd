//! The control server's calls ([`Motion`] for [`ServiceCore`]): each is checked against the
//! state machine ([`super::state`]) and becomes flags the real-time thread reads every cycle
//! (hold, stop) and commands to the planner thread. None waits for the motion: its effect shows
//! in `status` and the events.

use super::feeder::{self, FeederCommand, PathSource, QUEUE_CHUNKS};
use super::law_run;
use super::manual::{ManualGoal, ManualPart, ManualPlanError};
use super::state::{Control, Loaded, OVERRIDE_HOLD_BELOW, RunKind};
use super::{SUBSCRIBER_CAPACITY, ServiceCore, lock};
use crate::control::{
    AppendError, DriveError, LawError, LoadError, ManualError, Motion, NotAllowed, ProgramSource, ResumeError,
    StartError,
};
use crate::sinks::drive_command::{DriveCommandError, SdoOp};
use crossbeam::channel::{self, Receiver};
use interpd_motion::path::MAX_AXES;
use interpd_motion::program::{self, AppendError as MotionAppendError, ModalState};
use interpd_protocol::api::{
    AppendParams, AppendResult, Event, HomedAxis, JogMode, JogParams, LawResult, ManualStatus, MdiModal, MdiParams,
    MdiResult, Method, MoveToParams, MoveToResult, ProgramBuffer, ProgramInfo, ResetDrive, State, Status, ToolLength,
    ToolTable, WorkOffsets,
};
use interpd_protocol::shm::flags;
use std::collections::BTreeMap;
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
    /// machine stands, or from where it will stand once the tail has run. A program left by a
    /// manual motion or an MDI first moves back to the point it was held at.
    fn resume_locked(&self, ctl: &mut Control) {
        let shared = &self.shared;
        let command = if ctl.excursion && ctl.kind == RunKind::Program {
            ctl.excursion = false;
            FeederCommand::ResumeSuspended { epoch: ctl.epochs.start(), here: shared.live.load().pos }
        } else {
            FeederCommand::Resume
        };
        shared.hold.store(false, Ordering::SeqCst);
        ctl.state = State::Running;
        ctl.held_by_override = false;
        let _ = shared.feeder.send(command);
        shared.emit(Event::Resumed);
    }

    /// Ends a manual motion (the control lock held): its axes stop at the end of the running
    /// chunk (every chunk's tail is their fastest stop).
    fn jog_stop_locked(&self, ctl: &mut Control) {
        if ctl.state == State::Jogging {
            self.shared.hold.store(true, Ordering::SeqCst);
            ctl.manual_braking = true;
        }
    }

    /// The machine stands (its setpoint is flagged idle).
    fn standing(&self) -> bool {
        self.shared.live.load().flags & flags::IDLE != 0
    }

    /// Axis index of `name`, or a refusal naming `param.name`.
    fn axis_index(&self, method: Method, param: &str, name: &str) -> Result<usize, ManualError> {
        let names = self.shared.config.axis_names();
        names.iter().position(|n| n == name).ok_or_else(|| ManualError::Param {
            method,
            param: format!("{param}.{name}"),
            detail: format!("unknown axis {name:?} in \"{param}\"; this machine has {}", names.join(", ")),
        })
    }

    /// Per-axis values of a parameter map, by axis index.
    fn axis_values(
        &self,
        method: Method,
        param: &str,
        map: &BTreeMap<String, f64>,
    ) -> Result<[Option<f64>; MAX_AXES], ManualError> {
        let mut out = [None; MAX_AXES];
        for (name, v) in map {
            out[self.axis_index(method, param, name)?] = Some(*v);
        }
        Ok(out)
    }

    /// Starts the manual motion `goal`, or hands it to the running one (checked already).
    fn start_manual(&self, ctl: &mut Control, goal: ManualGoal) -> Result<(), ManualError> {
        let shared = &self.shared;
        let kind = goal.kind();
        if ctl.state == State::Jogging {
            if let Some(m) = ctl.manual.as_mut() {
                m.kind = kind;
            }
            return shared.feeder.send(FeederCommand::Manual(goal)).map_err(|_| ManualError::PlannerGone);
        }
        if let Some(drives) = &shared.drives {
            drives.ready_for_motion()?;
        }
        let suspend = ctl.state == State::Holding;
        let epoch = ctl.epochs.start();
        ctl.excursion |= suspend;
        ctl.state = State::Jogging;
        ctl.kind = RunKind::Manual;
        ctl.start_event_pending = true;
        ctl.underrun = false;
        ctl.last_error = None;
        ctl.manual = Some(ManualStatus { kind, limit_reached: Vec::new() });
        ctl.manual_braking = false;
        shared.hold.store(false, Ordering::SeqCst);
        shared.stop.store(false, Ordering::SeqCst);
        let command = FeederCommand::StartManual {
            goal,
            here: shared.live.load().pos,
            epoch,
            feed_override: ctl.planned_override(),
            suspend,
        };
        shared.feeder.send(command).map_err(|_| ManualError::PlannerGone)
    }

    /// The recording stopped early (a write failed, e.g. a full disk): every subscriber gets
    /// an `error` event naming the file. The motion and the state are not touched: the
    /// recording only watches them.
    pub fn report_recording_failure(&self, error: &crate::record::RecordError) {
        self.shared.emit(Event::Error { message: format!("recording stopped: {error}; the motion goes on") });
    }

    /// Lets the planner thread stall once (underrun tests and demonstrations).
    pub fn debug_stall_planner(&self, after_s: f64, for_s: f64) {
        let _ = self.shared.feeder.send(FeederCommand::DebugStall { after_s, for_s });
    }

    /// The drive monitor, if the machine stands (idle or finished): commissioning commands
    /// must not change a drive under a running motion.
    fn drives_at_rest(&self, action: Method) -> Result<std::sync::Arc<dyn crate::sinks::DriveMonitor>, DriveError> {
        let state = lock(&self.shared.control).state;
        if !matches!(state, State::Idle | State::Finished) {
            return Err(NotAllowed { state, action }.into());
        }
        Ok(self.shared.drives.clone().ok_or(DriveCommandError::NoMaster)?)
    }

    /// Moves axis `axis`'s setpoint to `pos` at rest (homing): the real-time thread takes the
    /// request at its next standing cycle; returns once the sinks have sent it.
    fn reposition_at_rest(&self, axis: usize, pos: f64) -> Result<(), String> {
        const WAIT: Duration = Duration::from_secs(2);
        let shared = &self.shared;
        shared.reposition.request(axis, pos);
        let until = Instant::now() + WAIT;
        let cycle = Duration::from_secs_f64(shared.config.cycle_s());
        while shared.reposition.is_pending() {
            if Instant::now() >= until {
                shared.reposition.clear();
                return Err(format!("the machine did not stand within {} s", WAIT.as_secs()));
            }
            std::thread::sleep(cycle);
        }
        // Two more cycles: the cycle that took it has published it to every sink.
        std::thread::sleep(2 * cycle);
        Ok(())
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
    fn drive_sdo(&self, method: Method, node: u8, op: SdoOp) -> Result<Vec<u8>, DriveError> {
        let drives = self.drives_at_rest(method)?;
        Ok(drives.sdo(node, op)?)
    }

    fn drive_reset(&self, nodes: &[u8]) -> Result<Vec<ResetDrive>, DriveError> {
        let drives = self.drives_at_rest(Method::DrivesReset)?;
        Ok(drives.reset(nodes)?)
    }

    fn machine_home(&self) -> Result<Vec<HomedAxis>, DriveError> {
        let drives = self.drives_at_rest(Method::MachineHome)?;
        let reposition = |axis: usize, pos: f64| self.reposition_at_rest(axis, pos);
        Ok(drives.home(&reposition)?)
    }

    fn tools(&self) -> ToolTable {
        self.tool_table()
    }

    fn set_tools(&self, table: ToolTable) -> ToolTable {
        self.set_tool_table(table)
    }

    fn offsets(&self) -> WorkOffsets {
        self.work_offsets()
    }

    fn set_offsets(&self, offsets: WorkOffsets) -> Result<WorkOffsets, ManualError> {
        self.set_work_offsets(offsets)
    }

    fn load(&self, source: ProgramSource, open: bool) -> Result<ProgramInfo, LoadError> {
        self.load_program(source, open)
    }

    fn law(&self, statement: &str) -> Result<LawResult, LawError> {
        // The name the move's errors and `status.program` show.
        const NAME: &str = "motion.law";
        let Some(laws) = law_run::LawProgram::statement(statement, NAME) else {
            return Err(LawError::NotAStatement { got: statement.chars().take(80).collect() });
        };
        // The state first: a move is checked against the limits only from where the machine
        // stands still.
        lock(&self.shared.control).check(Method::MotionLaw).map_err(LoadError::from)?;
        let (info, duration_s) = self.load_laws(NAME.to_owned(), laws?)?;
        self.start()?;
        Ok(LawResult { duration_s, length_mm: info.length_mm })
    }

    fn append(&self, params: &AppendParams) -> Result<AppendResult, AppendError> {
        let appends = match &lock(&self.shared.control).program {
            Some((_, Loaded::Program { appends: Some(a), .. })) => a.clone(),
            Some((info, Loaded::Program { .. })) if !info.program_end => return Err(AppendError::NotOpen),
            Some(_) => return Err(AppendError::Closed(MotionAppendError::Ended)),
            None => return Err(AppendError::NoProgram),
        };
        let appended = appends.append(&params.text, params.end).map_err(|e| match e {
            MotionAppendError::Full { buffered_bytes, limit_bytes, wanted_bytes } => {
                AppendError::Full { buffered_bytes, limit_bytes, wanted_bytes }
            }
            MotionAppendError::Program(e) => AppendError::Program(e),
            e @ MotionAppendError::Ended => AppendError::Closed(e),
        })?;
        let end = appended.program_end;
        if let Some((info, _)) = lock(&self.shared.control).program.as_mut() {
            info.lines = appended.lines.1.max(info.lines);
            info.elements += appended.elements;
            info.length_mm += appended.length_mm;
            info.program_end = end;
        }
        Ok(AppendResult {
            lines: [appended.lines.0, appended.lines.1],
            elements: appended.elements,
            length_mm: appended.length_mm,
            program_end: end,
            buffered_bytes: appends.buffered_bytes() as u64,
            limit_bytes: appends.limit_bytes() as u64,
        })
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
            Loaded::Program { text, tooling, appends, .. } => {
                let appends = appends.clone();
                if appends.as_ref().is_some_and(|a| a.taken_bytes() > 0) {
                    return Err(StartError::AppendedOnce);
                }
                (PathSource::Program { text: text.clone(), here, tooling: tooling.clone(), appends }, None)
            }
            Loaded::Laws(prog) => {
                let moves = prog.moves(&shared.settings, &here, &info.name)?;
                let (path, laws) = law_run::law_path(&shared.settings, moves, here, &prog.lines());
                (PathSource::Whole(Arc::new(path)), Some(Box::new(laws)))
            }
        };
        let epoch = ctl.begin_run();
        shared.hold.store(ctl.held_by_override, Ordering::SeqCst);
        shared.stop.store(false, Ordering::SeqCst);
        let feed_override = ctl.planned_override();
        let command = match motion {
            (PathSource::Whole(path), Some(laws)) => FeederCommand::StartLaws { path, laws, epoch, feed_override },
            (source, _) => FeederCommand::Start { source, epoch, feed_override, suspend: false },
        };
        if ctl.held_by_override {
            ctl.pending_start = Some(command);
            shared.emit(Event::Held);
            return Ok(());
        }
        shared.feeder.send(command).map_err(|_| StartError::PlannerGone)
    }

    fn hold(&self) -> Result<(), NotAllowed> {
        let mut ctl = lock(&self.shared.control);
        ctl.check(Method::MotionHold)?;
        if ctl.state == State::Jogging {
            self.jog_stop_locked(&mut ctl);
        } else {
            self.hold_locked(&mut ctl);
        }
        Ok(())
    }

    fn resume(&self) -> Result<(), ResumeError> {
        let mut ctl = lock(&self.shared.control);
        ctl.check(Method::MotionResume)?;
        if ctl.feed_override < OVERRIDE_HOLD_BELOW {
            return Err(ResumeError::OverrideZero);
        }
        if ctl.state == State::Paused {
            // The executor goes on along the chunk it stands in: nothing is replanned.
            let shared = &self.shared;
            ctl.pause = None;
            ctl.state = State::Running;
            ctl.held_by_override = false;
            shared.hold.store(false, Ordering::SeqCst);
            shared.pause_releases.fetch_add(1, Ordering::SeqCst);
            shared.emit(Event::Resumed);
            return Ok(());
        }
        self.resume_locked(&mut ctl);
        Ok(())
    }

    fn stop(&self) -> Result<(), Infallible> {
        let shared = &self.shared;
        let mut ctl = lock(&shared.control);
        ctl.pending_start = None;
        match ctl.state {
            State::Running | State::Holding | State::Jogging | State::Paused => {
                ctl.pause = None;
                shared.request_stop(&mut ctl);
            }
            State::Error => {
                shared.request_stop(&mut ctl);
                ctl.last_error = None;
            }
            State::Idle | State::Finished | State::Stopping => {}
        }
        Ok(())
    }

    fn set_override(&self, factor: f64) -> Result<(), Infallible> {
        let mut ctl = lock(&self.shared.control);
        ctl.feed_override = factor;
        if factor < OVERRIDE_HOLD_BELOW {
            self.jog_stop_locked(&mut ctl);
            if ctl.state == State::Running {
                ctl.held_by_override = true;
                self.hold_locked(&mut ctl);
            }
            return Ok(());
        }
        if let Some(mut start) = ctl.pending_start.take() {
            // A start held at 0 %: planned now, with this factor.
            if let FeederCommand::Start { feed_override, .. } | FeederCommand::StartLaws { feed_override, .. } =
                &mut start
            {
                *feed_override = factor;
            }
            let shared = &self.shared;
            shared.hold.store(false, Ordering::SeqCst);
            ctl.state = State::Running;
            ctl.held_by_override = false;
            let _ = shared.feeder.send(start);
            shared.emit(Event::Resumed);
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
            program_buffer: ctl.program.as_ref().and_then(|(_, loaded)| match loaded {
                Loaded::Program { appends: Some(a), .. } => Some(ProgramBuffer {
                    buffered_bytes: a.buffered_bytes() as u64,
                    limit_bytes: a.limit_bytes() as u64,
                    open: !a.is_closed(),
                }),
                _ => None,
            }),
            axes: shared.config.axis_names(),
            position: live.pos[..n].to_vec(),
            drives: shared.drives.as_ref().map(|d| d.drives()).unwrap_or_default(),
            homed: shared.drives.as_ref().and_then(|d| d.homed()),
            can_bus: shared.drives.as_ref().and_then(|d| d.bus()),
            manual: ctl.manual.clone(),
            mdi: ctl.mdi_modal.as_ref().map(|m| MdiModal {
                work_offset: m.work_system().to_string(),
                tool_length: m.tool_length().map(|(tool, length_mm)| ToolLength { tool, length_mm }),
            }),
            modal: match ctl.kind {
                RunKind::Program => {
                    lock(&shared.modal).at(live.line).map(|m| super::modal_track::to_status(m, live.line, n))
                }
                RunKind::Mdi | RunKind::Manual => None,
            },
            lookahead: shared.lookahead.status(chunk_s),
            optional_stop: shared.optional_stop.load(Ordering::SeqCst),
            pause: ctl.pause,
        }
    }

    fn set_optional_stop(&self, enabled: bool) -> bool {
        self.shared.optional_stop.store(enabled, Ordering::SeqCst);
        tracing::info!(enabled, "optional stop (M1) switch");
        enabled
    }

    fn subscribe(&self) -> Receiver<Event> {
        let (tx, rx) = channel::bounded(SUBSCRIBER_CAPACITY);
        lock(&self.shared.subscribers).push(tx);
        rx
    }

    fn jog(&self, params: &JogParams) -> Result<(), ManualError> {
        const M: Method = Method::MotionJog;
        let values = self.axis_values(M, "axes", &params.axes)?;
        let mut ctl = lock(&self.shared.control);
        ctl.check_manual(M, self.standing())?;
        if ctl.feed_override < OVERRIDE_HOLD_BELOW {
            return Err(ManualError::Param {
                method: M,
                param: "axes".into(),
                detail: "the feed override is 0 %, so a jog would not move: raise it with feed.override".into(),
            });
        }
        let goal = match params.mode {
            JogMode::Velocity => {
                for (k, v) in values.iter().enumerate() {
                    let (Some(v), Some(axis)) = (v, self.shared.config.axes.get(k)) else { continue };
                    if v.abs() > axis.max_vel_per_s {
                        return Err(ManualError::Param {
                            method: M,
                            param: format!("axes.{}", axis.name),
                            detail: format!(
                                "jog velocity {v} {unit}/s of axis {} exceeds its limit {} {unit}/s",
                                axis.name,
                                axis.max_vel_per_s,
                                unit = axis.kind.unit()
                            ),
                        });
                    }
                }
                ManualGoal::JogVelocity { vel: values }
            }
            JogMode::Distance => ManualGoal::JogDistance { dist: values },
        };
        self.start_manual(&mut ctl, goal)
    }

    fn jog_stop(&self) -> Result<(), Infallible> {
        let mut ctl = lock(&self.shared.control);
        self.jog_stop_locked(&mut ctl);
        Ok(())
    }

    fn move_to(&self, params: &MoveToParams) -> Result<MoveToResult, ManualError> {
        const M: Method = Method::MotionMoveTo;
        let shared = &self.shared;
        let target = self.axis_values(M, "target", &params.target)?;
        let given_vel = self.axis_values(M, "velocity", &params.velocity)?;
        let factor = params.velocity_factor;
        let mut vel = [0.0; MAX_AXES];
        for (k, axis) in shared.config.axes.iter().enumerate() {
            let unit = axis.kind.unit();
            if let Some(p) = target[k] {
                if p < axis.min_pos || p > axis.max_pos {
                    return Err(ManualError::Param {
                        method: M,
                        param: format!("target.{}", axis.name),
                        detail: format!(
                            "target {p} {unit} of axis {} is outside its travel {} to {} {unit}",
                            axis.name, axis.min_pos, axis.max_pos
                        ),
                    });
                }
            }
            if let Some(v) = given_vel[k] {
                if v.abs() > axis.max_vel_per_s * factor {
                    return Err(ManualError::Param {
                        method: M,
                        param: format!("velocity.{}", axis.name),
                        detail: format!(
                            "target velocity {v} {unit}/s of axis {} exceeds its limit {} {unit}/s × velocity_factor {factor}",
                            axis.name, axis.max_vel_per_s
                        ),
                    });
                }
                vel[k] = v;
            }
        }
        let goal = ManualGoal::MoveTo { target, vel, factor };
        let mut ctl = lock(&shared.control);
        ctl.check_manual(M, self.standing())?;
        // Planned here from where the machine is now, for the checks and the duration; the
        // planner thread plans it again from the handover state.
        let limits = super::feeder::axis_limits(&shared.config);
        let here = shared.live.load().pos;
        let part = ManualPart::new(goal.clone(), here, &limits, 1.0, None).map_err(|e| match e {
            ManualPlanError::LeavesTravel { axis, pos, min, max } => {
                let name = shared.config.axes[axis].name;
                ManualError::Param {
                    method: M,
                    param: format!("velocity.{name}"),
                    detail: format!(
                        "the stop after arriving at the target velocity takes axis {name} to {pos:.3}, outside its travel {min} to {max}"
                    ),
                }
            }
            ManualPlanError::Otg(e) => {
                ManualError::Param { method: M, param: "target".into(), detail: format!("no trajectory: {e:?}") }
            }
        })?;
        let duration_s = part.planned_duration_s();
        self.start_manual(&mut ctl, goal)?;
        Ok(MoveToResult { duration_s })
    }

    fn mdi(&self, params: &MdiParams) -> Result<MdiResult, ManualError> {
        const NAME: &str = "mdi";
        let shared = &self.shared;
        let mut ctl = lock(&shared.control);
        ctl.check_manual(Method::Mdi, self.standing())?;
        let here = shared.live.load().pos;
        let settings = shared.program_settings();
        let mut modal = ctl.mdi_modal.clone().unwrap_or_else(|| ModalState::new(&settings, here));
        modal.set_position(here);
        let parsed = program::parse_gcode_from(&params.line, NAME, &settings, &mut modal)?;
        let prepared = interpd_motion::prep::prepare_path(&shared.settings, &parsed.path).map_err(ManualError::Prep)?;
        ctl.mdi_modal = Some(modal);
        let result = MdiResult { elements: prepared.path.elements.len() as u64, length_mm: prepared.path.length_mm() };
        if prepared.path.elements.is_empty() {
            // Modal words only (G91, F…): nothing moves.
            return Ok(result);
        }
        if let Some(drives) = &shared.drives {
            drives.ready_for_motion()?;
        }
        let suspend = ctl.state == State::Holding;
        let excursion = ctl.excursion || suspend;
        let epoch = ctl.begin_run();
        ctl.kind = RunKind::Mdi;
        ctl.excursion = excursion;
        shared.hold.store(ctl.held_by_override, Ordering::SeqCst);
        shared.stop.store(false, Ordering::SeqCst);
        let feed_override = ctl.planned_override();
        let command =
            FeederCommand::Start { source: PathSource::Whole(Arc::new(prepared.path)), epoch, feed_override, suspend };
        if ctl.held_by_override {
            ctl.pending_start = Some(command);
            shared.emit(Event::Held);
            return Ok(result);
        }
        shared.feeder.send(command).map_err(|_| ManualError::PlannerGone)?;
        Ok(result)
    }
}
