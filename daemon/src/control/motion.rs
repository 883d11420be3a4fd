//! The interface between the control server and the motion core.
//!
//! The server turns each JSON-RPC call into one call of [`Motion`] and each [`MotionError`]
//! into a JSON-RPC error object ([`MotionError::to_error_object`]). Parameters arrive already
//! checked: types, presence, and the override range 0.0..=2.0.

use interpd_protocol::api::{Event, ProgramInfo, State, Status, codes};
use interpd_protocol::jsonrpc::ErrorObject;
use std::path::PathBuf;

/// Where `program.load` takes the program from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ProgramSource {
    /// A file the daemon reads, as the client gave it: a relative path is relative to the
    /// daemon's working directory.
    File(PathBuf),
    /// Program text sent inline. `name` is the client's `name`, or
    /// [`api::INLINE_PROGRAM_NAME`](interpd_protocol::api::INLINE_PROGRAM_NAME); use it in error positions (`NAME:LINE:COL: message`).
    Text { name: String, text: String },
}

/// The motion core as the control server sees it.
///
/// The server calls these from its connection threads, possibly from several at once, never
/// from the real-time thread. Calls should return promptly (they hold up only the calling
/// client, but a client waits for its answer): a command is accepted or refused here, and its
/// effect (ramping down for a hold, planning ahead) proceeds in the background and shows up in
/// [`Motion::status`] and the events.
pub trait Motion: Send + Sync + 'static {
    /// Reads, parses and prepares a program, replacing the loaded one. Refused with
    /// [`MotionError::NotAllowed`] while motion is in progress; a program that cannot be read,
    /// parsed or prepared is [`MotionError::BadProgram`] with `FILE:LINE:COL: message` text.
    fn load(&self, source: ProgramSource) -> Result<ProgramInfo, MotionError>;

    /// Starts the loaded program from its beginning.
    fn start(&self) -> Result<(), MotionError>;

    /// Feed hold: brings the path velocity to zero along the path (jerk-limited); the
    /// [`Event::Held`] event follows when the machine stands.
    fn hold(&self) -> Result<(), MotionError>;

    /// Continues after a hold.
    fn resume(&self) -> Result<(), MotionError>;

    /// Controlled stop. Should succeed in every state (a no-op when nothing moves): the server
    /// calls it for `stop_on_disconnect`, and the daemon on SIGTERM/SIGINT.
    fn stop(&self) -> Result<(), MotionError>;

    /// Sets the feed override factor, already checked to be within 0.0..=2.0.
    fn set_override(&self, factor: f64) -> Result<(), MotionError>;

    /// A snapshot of the state (`status`). Called often (clients poll it); it should not wait
    /// for the real-time thread.
    fn status(&self) -> Status;

    /// A new receiver of the events from now on, one per subscribing connection. The sending
    /// side must never block the motion on a slow client: use a bounded channel with
    /// `try_send`, dropping events for a full receiver, and forget senders whose receiver is
    /// gone (`TrySendError::Disconnected`: the client disconnected). The server drops the
    /// receiver when the connection closes.
    fn subscribe(&self) -> crossbeam::channel::Receiver<Event>;

    /// Runs one motion-law move (`motion.law`): the statement in the program syntax, checked
    /// against the axis limits before it starts. Returns the move's figures. Allowed where
    /// `motion.start` is; the default refuses (a core without law moves).
    fn law(&self, statement: &str) -> Result<serde_json::Value, MotionError> {
        let _ = statement;
        Err(MotionError::InvalidParams("motion.law is not supported by this motion core".into()))
    }
}

/// Why the motion core refused or failed a command.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MotionError {
    /// The program cannot be read, parsed or prepared (−32001); the text says where and why.
    #[error("bad program: {0}")]
    BadProgram(String),
    /// The command (`action`, the method name such as `"motion.resume"`) is not allowed in
    /// `state` (−32002).
    #[error("{action} is not allowed while {state}: {}", hint(action, *state))]
    NotAllowed { state: State, action: &'static str },
    /// A parameter the server could not check (−32602), e.g. a file that is not a program.
    #[error("invalid parameters: {0}")]
    InvalidParams(String),
    /// `motion.start` while a CAN drive is not in Operation enabled (−32005); the text names
    /// each drive and why.
    #[error("{0}")]
    DrivesNotReady(String),
    /// A failure in the daemon that the client cannot fix (−32603).
    #[error("internal error: {0}")]
    Internal(String),
}

impl MotionError {
    /// The JSON-RPC error code.
    pub fn code(&self) -> i32 {
        match self {
            MotionError::BadProgram(_) => codes::BAD_PROGRAM,
            MotionError::NotAllowed { .. } => codes::NOT_ALLOWED,
            MotionError::InvalidParams(_) => codes::INVALID_PARAMS,
            MotionError::Internal(_) => codes::INTERNAL_ERROR,
            MotionError::DrivesNotReady(_) => codes::DRIVES_NOT_READY,
        }
    }

    /// The JSON-RPC error object: the message is this error's `Display` (what went wrong and
    /// what to do next); `data` carries `state` and `action` for refused commands.
    pub fn to_error_object(&self) -> ErrorObject {
        let e = ErrorObject::new(self.code(), self.to_string());
        match self {
            MotionError::NotAllowed { state, action } => {
                e.with_data(serde_json::json!({ "state": state, "action": action }))
            }
            _ => e,
        }
    }
}

impl From<MotionError> for ErrorObject {
    fn from(e: MotionError) -> ErrorObject {
        e.to_error_object()
    }
}

/// What a person can do when `action` is refused in `state`: the state machine's next step,
/// phrased with the API's method names.
pub fn hint(action: &str, state: State) -> &'static str {
    use State::*;
    match (action, state) {
        (_, Stopping) => "a stop is in progress; wait until status reports idle",
        (_, Error) => "motion was aborted by an error (see last_error in status); call motion.stop to reset",
        ("program.load", Running | Holding) => "call motion.stop and wait for state idle before loading a program",
        ("motion.start", Idle) => "load a program with program.load first",
        ("motion.start", Running) => "motion is already running; use motion.hold, motion.resume or motion.stop",
        ("motion.start", Holding) => "motion is held; call motion.resume to continue or motion.stop to abort",
        ("motion.start", Finished) => "the program has finished; load a program with program.load to run again",
        ("motion.hold", Holding) => "motion is already held; call motion.resume to continue or motion.stop to abort",
        ("motion.hold", Idle | Finished) => "nothing is moving; motion.hold applies while running",
        ("motion.resume", Idle) => "load a program and call motion.start first",
        ("motion.resume", Running) => "motion is not held; motion.resume applies after motion.hold",
        ("motion.resume", Finished) => "the program has finished; load a program and call motion.start",
        _ => "check the state with status",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_codes_and_messages() {
        let e = MotionError::NotAllowed { state: State::Idle, action: "motion.resume" };
        assert_eq!(
            e.to_string(),
            "motion.resume is not allowed while idle: load a program and call motion.start first"
        );
        let o = e.to_error_object();
        assert_eq!(o.code, codes::NOT_ALLOWED);
        assert_eq!(o.data, Some(serde_json::json!({"state": "idle", "action": "motion.resume"})));
        assert_eq!(MotionError::BadProgram("a.ngc:2:8: word 'Y' has no number".into()).code(), codes::BAD_PROGRAM);
        assert_eq!(
            MotionError::BadProgram("a.ngc:2:8: x".into()).to_error_object().message,
            "bad program: a.ngc:2:8: x"
        );
        assert_eq!(MotionError::InvalidParams("x".into()).code(), codes::INVALID_PARAMS);
        assert_eq!(MotionError::Internal("x".into()).code(), codes::INTERNAL_ERROR);
        assert_eq!(ErrorObject::from(MotionError::Internal("q".into())).message, "internal error: q");
    }

    #[test]
    fn every_refusal_has_a_hint() {
        for m in interpd_protocol::api::Method::ALL {
            for s in State::ALL {
                assert!(!hint(m.name(), s).is_empty());
            }
        }
        assert!(hint("motion.start", State::Idle).contains("program.load"));
    }
}
