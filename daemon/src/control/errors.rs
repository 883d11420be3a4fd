//! Why the service refused or failed a command: one error type per operation, carrying its
//! causes as data (a program error's file, line and column; each drive that is not ready and
//! why). The JSON-RPC layer (`control::dispatch`) gives each a code and uses its `Display` as
//! the message.
//!
//! Also here: why the control server itself cannot start ([`ServerError`]), which the socket
//! file and the server's start-up both return.
//!
//! The causes that the service's own checks produce ([`ProgramPathError`] for a path outside
//! the programs directory, [`LawProgramError`] for a program of `LAW` statements) are defined
//! here as well: the control layer names them in its errors and codes, and depends on nothing
//! of the service.

use crate::sinks::DrivesNotReady;
use crate::sinks::drive_command::DriveCommandError;
use interpd_motion::law::program::LawBlockError;
use interpd_motion::prep::PrepError;
use interpd_motion::program::ProgramErrors;
use interpd_protocol::api::{Method, State};
use std::io;
use std::path::PathBuf;

/// A command that is not allowed in the current state (−32002).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{action} is not allowed while {state}: {}", hint(*action, *state))]
pub struct NotAllowed {
    pub state: State,
    pub action: Method,
}

/// `drives.sdo_read`, `drives.sdo_write`, `drives.reset`, `machine.home` refused or failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DriveError {
    /// Something moves (−32002): commissioning happens at rest.
    #[error(transparent)]
    NotAllowed(#[from] NotAllowed),
    /// No CAN master or no such node (−32008), or the drive refused or did not answer
    /// (−32007, `data.abort_code` with the SDO abort code).
    #[error(transparent)]
    Drive(#[from] DriveCommandError),
}

/// `program.load` refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    NotAllowed(#[from] NotAllowed),
    /// The program cannot be read or parsed (−32001); every error with its place.
    #[error("bad program: {0}")]
    Program(#[from] ProgramErrors),
    /// A program of `LAW` statements is malformed, or a move cannot be made from where the
    /// machine stands (−32001).
    #[error("bad program: {0}")]
    Laws(#[from] LawProgramError),
    /// The path lies outside the programs directory (−32602, `data.param` "path").
    #[error("invalid params for program.load: {0}")]
    Path(#[from] ProgramPathError),
}

/// A path given to `program.load` that the rule refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramPathError {
    #[error(
        "path {path:?} contains `..`: programs are read from the programs directory {dir} ([programs] dir) and below it only"
    )]
    ParentComponent { path: String, dir: String },
    #[error(
        "path {path:?} lies outside the programs directory {dir} ([programs] dir; symbolic links resolved): programs are read from there only"
    )]
    Outside { path: String, dir: String },
}

/// What is wrong with a program of `LAW` statements, at its file and line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawProgramError {
    /// A `LAW` statement does not parse. A syntax error carries its column, printed after the
    /// line (`FILE:LINE:COL: message`).
    #[error("{file}:{line}:{error}")]
    Statement { file: String, line: u32, error: LawBlockError },
    /// A line that is neither a `LAW` statement nor a comment.
    #[error(
        "{file}:{line}: {text:?} in a program of LAW statements: only LAW statements and comments may appear \
         there (law moves and G-code do not mix in one program)"
    )]
    Mixed { file: String, line: u32, text: String },
    /// A statement whose move cannot be made from where the previous one ends: a limit it
    /// breaks, an axis the machine lacks.
    #[error("{file}:{line}: {error}")]
    Move { file: String, line: u32, error: LawBlockError },
}

/// `program.append` refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AppendError {
    /// No program is loaded (−32002).
    #[error("no program is loaded: load one without M2/M30 with program.load first")]
    NoProgram,
    /// The loaded program was not loaded with `"open": true` (−32002).
    #[error("the loaded program is not open for program.append: load it with \"open\": true")]
    NotOpen,
    /// The loaded program has ended or cannot be continued (−32001).
    #[error("bad program: {0}")]
    Closed(#[from] interpd_motion::program::AppendError),
    /// The text does not parse as the continuation of the program (−32001).
    #[error("bad program: {0}")]
    Program(#[from] ProgramErrors),
    /// The buffer cannot take the text now (−32006).
    #[error(
        "program buffer full: {buffered_bytes} of {limit_bytes} bytes used, {wanted_bytes} more do not fit; send again when the motion has used some"
    )]
    Full { buffered_bytes: usize, limit_bytes: usize, wanted_bytes: usize },
}

/// `motion.start` refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StartError {
    #[error(transparent)]
    NotAllowed(#[from] NotAllowed),
    /// A CAN drive is not in Operation enabled, or the bus does not receive (−32005).
    #[error(transparent)]
    DrivesNotReady(#[from] DrivesNotReady),
    /// A law move of the loaded program cannot be made from where the machine stands now
    /// (−32001).
    #[error("bad program: {0}")]
    Laws(#[from] LawProgramError),
    /// The loaded program was continued with `program.append` and has run (−32002): its
    /// appended text is gone, so it cannot run again.
    #[error("the program was continued with program.append and has run; load it again")]
    AppendedOnce,
    /// The planner thread is gone (−32603): the daemon is shutting down or failed.
    #[error("internal error: the planner thread has ended")]
    PlannerGone,
}

/// `motion.resume` refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ResumeError {
    #[error(transparent)]
    NotAllowed(#[from] NotAllowed),
    /// The hold comes from a 0 % feed override (−32602): raising the override resumes.
    #[error("invalid parameters: the feed override is 0 %: raise it with feed.override to continue")]
    OverrideZero,
}

/// `motion.law` refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawError {
    /// The statement is not one `LAW` statement (−32602); `got` is its beginning.
    #[error(
        "invalid parameters: \"statement\" must be one LAW statement, e.g. \"LAW PRESET=rr7 DURATION=0.8 X=10\"; \
         got {got:?}"
    )]
    NotAStatement { got: String },
    /// The statement does not parse, or its move breaks a limit from where the machine stands
    /// (−32001).
    #[error("bad program: {0}")]
    Laws(#[from] LawProgramError),
    /// Loading the move as the program was refused.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// Starting the move was refused.
    #[error(transparent)]
    Start(#[from] StartError),
    /// The service runs no law moves (−32602).
    #[error("invalid parameters: motion.law is not supported by this motion core")]
    Unsupported,
}

/// `motion.jog`, `motion.move_to` and `mdi` refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ManualError {
    #[error(transparent)]
    NotAllowed(#[from] NotAllowed),
    /// A parameter the daemon checks against the machine (−32602, `data.param` names it): an
    /// unknown axis, a target outside the travel, a velocity above the limit.
    #[error("invalid params for {method}: {detail}")]
    Param { method: Method, param: String, detail: String },
    /// The machine still moves (a hold or a `motion.jog_stop` brakes) (−32002).
    #[error("{method} is not allowed while the machine {what}: wait until it stands (the held or jog_done event)")]
    Moving { method: Method, what: &'static str },
    /// The MDI blocks do not parse (−32001), with line and column.
    #[error("bad program: {0}")]
    Program(#[from] ProgramErrors),
    /// The tolerance-band smoothing of the MDI blocks failed (−32001).
    #[error("bad program: mdi: {0}")]
    Prep(PrepError),
    /// A CAN drive is not ready (−32005).
    #[error(transparent)]
    DrivesNotReady(#[from] DrivesNotReady),
    /// The planner thread is gone (−32603).
    #[error("internal error: the planner thread has ended")]
    PlannerGone,
    /// The parameter file cannot be written (−32603); nothing was changed.
    #[error("internal error: cannot write the parameter file {file}: {message}; nothing was changed")]
    ParamFile { file: String, message: String },
}

/// Why the control server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error("no control socket path given (ControlServerBuilder::socket)")]
    NoSocketPath,
    #[error("invalid control server setting: {0}")]
    Config(&'static str),
    #[error("another interpd is running on {}", .0.display())]
    AlreadyRunning(PathBuf),
    #[error("{} exists and is not a socket; remove it or choose another control socket path", .0.display())]
    NotASocket(PathBuf),
    #[error("cannot create the control socket {}: {source}", path.display())]
    Socket {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("cannot start the control server thread: {0}")]
    Thread(#[source] io::Error),
}

/// What a person can do when `action` is refused in `state`: the state machine's next step,
/// phrased with the API's method names.
pub fn hint(action: Method, state: State) -> &'static str {
    use Method::*;
    use State::*;
    match (action, state) {
        (_, Stopping) => "a stop is in progress; wait until status reports idle",
        (_, Error) => "motion was aborted by an error (see last_error in status); call motion.stop to reset",
        (ProgramLoad, Running | Holding) => "call motion.stop and wait for state idle before loading a program",
        (MotionStart, Idle) => "load a program with program.load first",
        (MotionStart, Running) => "motion is already running; use motion.hold, motion.resume or motion.stop",
        (MotionStart, Holding) => "motion is held; call motion.resume to continue or motion.stop to abort",
        (MotionStart, Finished) => "the program has finished; load a program with program.load to run again",
        (MotionHold, Holding) => "motion is already held; call motion.resume to continue or motion.stop to abort",
        (MotionHold, Idle | Finished) => "nothing is moving; motion.hold applies while running",
        (MotionResume, Idle) => "load a program and call motion.start first",
        (MotionResume, Running) => "motion is not held; motion.resume applies after motion.hold",
        (MotionResume, Finished) => "the program has finished; load a program and call motion.start",
        (MotionJog | MotionMoveTo | Mdi, Running) => {
            "a program runs; hold it with motion.hold (then jog, move or run MDI from the hold) or stop it"
        }
        (MotionJog | MotionMoveTo | Mdi, Holding) => {
            "a held MDI block or return move comes first: call motion.resume or motion.stop"
        }
        (MachineHome, _) => {
            "homing runs while nothing moves: wait for state idle or finished (motion.stop ends a held or running motion)"
        }
        (DrivesSdoRead | DrivesSdoWrite | DrivesReset, _) => {
            "drive commissioning runs while nothing moves: wait for state idle or finished (motion.stop ends a held or \
             running motion)"
        }
        (_, Paused) => {
            "the program waits at a program stop (M0, M1, M60): call motion.resume to continue or motion.stop to end it"
        }
        (Mdi, Jogging) => "a manual motion runs; end it with motion.jog_stop and wait for the jog_done event",
        _ => "check the state with status",
    }
}
