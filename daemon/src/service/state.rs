//! The control-side state machine: which command is allowed in which state, what the loaded
//! program is, and the bookkeeping of a run (its epochs, the start event, the underrun flag).
//!
//! | state    | program.load | motion.start     | motion.hold | motion.resume | motion.stop |
//! |----------|--------------|------------------|-------------|---------------|-------------|
//! | idle     | idle         | running¹ ²       | refused     | refused       | no-op       |
//! | running  | refused      | refused          | holding     | refused       | stopping    |
//! | holding  | refused      | refused          | refused     | running³      | stopping    |
//! | stopping | refused      | refused          | refused     | refused       | no-op       |
//! | finished | idle         | running¹         | refused     | refused       | no-op       |
//! | error    | refused      | refused          | refused     | refused       | stopping    |
//! | paused   | refused      | refused          | refused     | running⁴      | stopping    |
//!
//! `motion.jog`, `motion.move_to` and `mdi` start from idle, finished or a held program at rest
//! (jog and move-to also replace a running manual motion, state `jogging`); a manual motion ends
//! in idle, or in holding when it left a held program, whose resume returns to the held point
//! first ([`Control::check_manual`], `excursion`).
//!
//! ¹ holding instead while the feed override is 0 %; ² with a program loaded; ³ not while the
//! override is 0 %; ⁴ the executor goes on from the program stop it stands at (M0, M1, M60:
//! the real-time thread pauses there on its own and the supervisor turns running into paused). `motion.law` is a load and a start in one. `feed.override` is allowed in
//! every state; setting 0 % while running holds, raising it again resumes that hold.
//!
//! The threads move the state on their own: running or holding becomes finished at the end of
//! the program, stopping becomes idle when the machine stands, a planning failure becomes
//! error, and a drive fault while moving stops the machine like `motion.stop` with the fault as
//! `last_error`.
//!
//! Only the rules and the bookkeeping are here; the calls that carry the transitions out are
//! in [`super::commands`] (the control server's) and [`super::supervisor`] (the executor's
//! notices).

use super::feeder::ProgramText;
use super::law_run::LawProgram;
use super::tooling::Tooling;
use crate::control::{ManualError, NotAllowed};
use crate::interp::Epochs;
use interpd_motion::program::{Appends, ModalState};
use interpd_protocol::api::{ManualStatus, Method, PauseStatus, ProgramInfo, State};
use std::sync::Arc;

/// Override factors below this act as a feed hold (0 % feed).
pub const OVERRIDE_HOLD_BELOW: f64 = 1e-3;

/// A loaded program: a path to plan, or motion-law moves (made from where the machine stands
/// when it starts).
#[derive(Clone)]
pub(super) enum Loaded {
    /// G-code or a path table, read as the motion runs with the tool table and work offsets
    /// it was loaded with; a program without an end takes the text `program.append` adds.
    Program {
        text: ProgramText,
        tooling: Arc<Tooling>,
        appends: Option<Appends>,
        /// The work offsets G54 … G59.3 (with rotations) and G28/G30 positions the program
        /// leaves (its G10 L2/L20, G28.1/G30.1 executed at the load's check), kept in the
        /// parameter file when it has run to its end.
        offsets_end: Option<Arc<super::param_store::Kept>>,
    },
    Laws(Arc<LawProgram>),
}

/// What the current (or last) motion is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RunKind {
    /// The loaded program (or a law move).
    Program,
    /// MDI blocks.
    Mdi,
    /// A jog or move-to (state `jogging`).
    Manual,
}

/// The control-side state, behind one mutex.
pub(super) struct Control {
    pub state: State,
    pub program: Option<(ProgramInfo, Loaded)>,
    /// The factor last set with `feed.override`; below [`OVERRIDE_HOLD_BELOW`] it holds.
    pub feed_override: f64,
    /// The current hold comes from a 0 % override (raising the override resumes it).
    pub held_by_override: bool,
    /// A program or MDI start made at a 0 % override: nothing is planned until the override is
    /// raised, so the run is then planned with the factor that raised it.
    pub pending_start: Option<super::feeder::FeederCommand>,
    pub last_error: Option<String>,
    pub epochs: Epochs,
    /// `started` is emitted at the first motion of a run, not after a restart.
    pub start_event_pending: bool,
    /// An underrun is in progress (`underrun_cleared` follows when motion resumes).
    pub underrun: bool,
    /// The cycle the run started in, for the duration in `finished`.
    pub start_cycle: u64,
    pub kind: RunKind,
    /// A held program waits while (or since) a manual motion or an MDI moved the machine:
    /// `motion.resume` returns to the held point first.
    pub excursion: bool,
    /// The manual motion running or run last, for `status.manual`.
    pub manual: Option<ManualStatus>,
    /// `motion.jog_stop` (or a hold) brakes the manual motion to rest.
    pub manual_braking: bool,
    /// The G-code modal state MDI carries from call to call.
    pub mdi_modal: Option<ModalState>,
    /// The program stop the program waits at (state `paused`).
    pub pause: Option<PauseStatus>,
}

impl Control {
    pub fn new() -> Control {
        Control {
            state: State::Idle,
            program: None,
            feed_override: 1.0,
            held_by_override: false,
            pending_start: None,
            last_error: None,
            epochs: Epochs::default(),
            start_event_pending: false,
            underrun: false,
            start_cycle: 0,
            kind: RunKind::Program,
            excursion: false,
            manual: None,
            manual_braking: false,
            mdi_modal: None,
            pause: None,
        }
    }

    /// Whether a manual motion or MDI (`action`) may start or change now: from rest (idle,
    /// finished, a held program with the machine standing) and, for jog and move-to, while
    /// one runs (unless it brakes after `motion.jog_stop`).
    pub fn check_manual(&self, action: Method, standing: bool) -> Result<(), ManualError> {
        let refuse = || ManualError::from(NotAllowed { state: self.state, action });
        match self.state {
            State::Idle | State::Finished => Ok(()),
            State::Holding if self.kind != RunKind::Program => Err(refuse()),
            State::Holding if !standing => Err(ManualError::Moving { method: action, what: "brakes for the hold" }),
            State::Holding => Ok(()),
            State::Jogging if action == Method::Mdi => Err(refuse()),
            State::Jogging if self.manual_braking => {
                Err(ManualError::Moving { method: action, what: "brakes to rest after motion.jog_stop" })
            }
            State::Jogging => Ok(()),
            _ => Err(refuse()),
        }
    }

    /// Whether `action` is allowed now: a program is loaded only while nothing moves, a
    /// start needs a loaded program, a hold a running motion, a resume a held one. The other
    /// commands are allowed in every state.
    pub fn check(&self, action: Method) -> Result<(), NotAllowed> {
        let at_rest = matches!(self.state, State::Idle | State::Finished);
        let allowed = match action {
            Method::ProgramLoad | Method::MotionLaw => at_rest,
            Method::MotionStart => at_rest && self.program.is_some(),
            Method::MotionHold => matches!(self.state, State::Running | State::Jogging),
            Method::MotionResume => matches!(self.state, State::Holding | State::Paused),
            _ => true,
        };
        if allowed { Ok(()) } else { Err(NotAllowed { state: self.state, action }) }
    }

    /// `program.load` succeeded: `program` replaces the loaded one.
    pub fn loaded(&mut self, info: ProgramInfo, program: Loaded) {
        self.program = Some((info, program));
        self.state = State::Idle;
        self.last_error = None;
    }

    /// A run begins (the start is checked): running, or holding if the override is at 0 %.
    /// Returns the run's epoch.
    pub fn begin_run(&mut self) -> crate::interp::Epoch {
        let epoch = self.epochs.start();
        // The override set last decides, whenever it was set: at 0 % the run starts held.
        self.held_by_override = self.feed_override < OVERRIDE_HOLD_BELOW;
        self.state = if self.held_by_override { State::Holding } else { State::Running };
        self.start_event_pending = true;
        self.underrun = false;
        self.last_error = None;
        self.kind = RunKind::Program;
        self.excursion = false;
        self.manual = None;
        self.pause = None;
        epoch
    }

    /// The factor a run is planned with: the override, or 100 % while it holds at 0 % (the
    /// hold flag keeps the machine at rest until the override is raised).
    pub fn planned_override(&self) -> f64 {
        if self.feed_override < OVERRIDE_HOLD_BELOW { 1.0 } else { self.feed_override }
    }
}
