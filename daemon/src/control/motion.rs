//! The interface between the control server and the service.
//!
//! The server turns each JSON-RPC call into one call of [`Motion`] and each refusal (the
//! operation's error type in [`super::errors`]) into a JSON-RPC error object. Parameters
//! arrive already checked: types, presence, and the override range 0.0..=2.0.

use super::errors::{AppendError, DriveError, LawError, LoadError, ManualError, NotAllowed, ResumeError, StartError};
use crate::sinks::drive_command::{DriveCommandError, SdoOp};
use interpd_protocol::api::{
    AppendParams, AppendResult, Event, HomedAxis, JogParams, LawResult, MdiParams, MdiResult, Method, MoveToParams,
    MoveToResult, ProgramInfo, ResetDrive, Status, ToolTable, WorkOffsets,
};
use std::convert::Infallible;
use std::path::PathBuf;

/// Where `program.load` takes the program from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ProgramSource {
    /// A file the daemon reads, as the client gave it: a relative path is relative to the
    /// daemon's working directory.
    File(PathBuf),
    /// Program text sent inline. `name` is the client's `name`, or
    /// [`INLINE_PROGRAM_NAME`](interpd_protocol::api::INLINE_PROGRAM_NAME); error positions
    /// use it (`NAME:LINE:COL: message`).
    Text { name: String, text: String },
}

/// The service as the control server sees it.
///
/// The server calls these from its connection threads, possibly from several at once, never
/// from the real-time thread. Calls should return promptly (they hold up only the calling
/// client, but a client waits for its answer): a command is accepted or refused here, and its
/// effect (ramping down for a hold, planning ahead) proceeds in the background and shows up in
/// [`Motion::status`] and the events.
pub trait Motion: Send + Sync + 'static {
    /// Reads, parses and prepares a program, replacing the loaded one. Refused while motion is
    /// in progress; a program that cannot be read, parsed or prepared says where and why.
    /// `open`: the program continues with [`Motion::append`] (without it, a program ends at
    /// the end of its text).
    fn load(&self, source: ProgramSource, open: bool) -> Result<ProgramInfo, LoadError>;

    /// Continues the loaded program, which has no end yet, with `params.text` (`program.append`):
    /// checked against the program so far, then buffered for the motion to read. Allowed in
    /// every state while such a program is loaded.
    fn append(&self, params: &AppendParams) -> Result<AppendResult, AppendError>;

    /// Starts the loaded program from its beginning.
    fn start(&self) -> Result<(), StartError>;

    /// Feed hold: brings the path velocity to zero along the path (jerk-limited); the
    /// [`Event::Held`] event follows when the machine stands. Allowed while running only.
    fn hold(&self) -> Result<(), NotAllowed>;

    /// Continues after a hold.
    fn resume(&self) -> Result<(), ResumeError>;

    /// Sets the optional-stop switch (`motion.optional_stop`): M1 pauses the program while it
    /// is on. Returns the switch now in effect. Allowed in every state; a change applies to the
    /// next M1 the motion reaches. The default: a service without program stops ignores it.
    fn set_optional_stop(&self, enabled: bool) -> bool {
        enabled
    }

    /// Controlled stop. Succeeds in every state (a no-op when nothing moves): the server calls
    /// it for `stop_on_disconnect`, and the daemon on SIGTERM/SIGINT.
    fn stop(&self) -> Result<(), Infallible>;

    /// Sets the feed override factor, already checked to be within 0.0..=2.0; 0 holds the
    /// motion like [`Motion::hold`] until the factor is raised again.
    fn set_override(&self, factor: f64) -> Result<(), Infallible>;

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
    /// `motion.start` is; the default refuses (a service without law moves).
    fn law(&self, statement: &str) -> Result<LawResult, LawError> {
        let _ = statement;
        Err(LawError::Unsupported)
    }

    /// Jogs (`motion.jog`): continuous at velocities or by distances; replaces a running jog or
    /// move-to from the end of its queued motion. Allowed while idle, finished, holding (the
    /// machine standing) and jogging.
    fn jog(&self, params: &JogParams) -> Result<(), ManualError>;

    /// Ends a manual motion (`motion.jog_stop`): every axis's fastest stop at the end of the
    /// running chunk. A no-op when no manual motion runs.
    fn jog_stop(&self) -> Result<(), Infallible>;

    /// Moves the named axes to a target (`motion.move_to`), time-synchronised. Allowed where
    /// [`Motion::jog`] is.
    fn move_to(&self, params: &MoveToParams) -> Result<MoveToResult, ManualError>;

    /// Runs G-code blocks (`mdi`) through the program path from where the machine stands, the
    /// modal state carried from the previous call. Allowed while idle, finished and holding.
    fn mdi(&self, params: &MdiParams) -> Result<MdiResult, ManualError>;

    /// The tool table programs are read with (`tools.get`).
    fn tools(&self) -> ToolTable;

    /// Replaces the tool table (`tools.set`) for programs loaded after the call.
    fn set_tools(&self, table: ToolTable) -> ToolTable;

    /// The work offsets G54 … G59 (`offsets.get`).
    fn offsets(&self) -> WorkOffsets;

    /// Replaces the systems given (`offsets.set`) for programs loaded after the call; an axis
    /// the machine does not have is refused.
    fn set_offsets(&self, offsets: WorkOffsets) -> Result<WorkOffsets, ManualError>;

    /// One SDO transfer with CAN drive `node` (`drives.sdo_read`, `drives.sdo_write` as
    /// `method`): the bytes read (none for a write). Refused unless the machine is idle or
    /// finished; the default: no drives.
    fn drive_sdo(&self, method: Method, node: u8, op: SdoOp) -> Result<Vec<u8>, DriveError> {
        let _ = (method, node, op);
        Err(DriveCommandError::NoMaster.into())
    }

    /// Fault reset of the CAN drives `nodes` (none: every drive in Fault), `drives.reset`.
    /// Allowed where [`Motion::drive_sdo`] is.
    fn drive_reset(&self, nodes: &[u8]) -> Result<Vec<ResetDrive>, DriveError> {
        let _ = nodes;
        Err(DriveCommandError::NoMaster.into())
    }

    /// Homes the CAN drives in the configured order (`machine.home`). Allowed where
    /// [`Motion::drive_sdo`] is.
    fn machine_home(&self) -> Result<Vec<HomedAxis>, DriveError> {
        Err(DriveCommandError::NoMaster.into())
    }
}
