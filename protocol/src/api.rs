//! interpd's control API on top of [`crate::jsonrpc`]: the methods, their parameters and
//! results, the `status` snapshot and the events of `subscribe`. The reference with examples
//! is docs/control-api.md.
//!
//! - [`Call::parse`] checks a method name and its parameters (deserialized with serde, see
//!   [`params`]) and names what is wrong.
//! - [`Status`] and [`Event`] are the result of `status` and the payloads of `subscribe`;
//!   [`DriveStatus`] is one CAN drive in `status.drives`.

pub mod drives;
pub mod params;
pub mod status;
pub mod tooling;

pub use drives::{
    HomeResult, HomedAxis, ResetDrive, ResetParams, ResetResult, SdoReadParams, SdoResult, SdoType, SdoWriteParams,
};
pub use params::{
    AppendParams, JogMode, JogParams, LawParams, LoadParams, MdiParams, MoveToParams, OptionalStopParams,
    OverrideParams,
};
pub use status::{
    CutterMode, CutterStatus, CycleStats, DriveStatus, LookaheadStatus, ManualStatus, MdiModal, PauseStatus,
    Percentiles, ProgramBuffer, ProgramInfo, ProgramModal, SpindleTool, State, Status, ToolLength,
};
pub use tooling::{Tool, ToolTable, WorkOffsets};

use crate::jsonrpc::params::Params;
use crate::jsonrpc::{ErrorObject, Notification};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;
use std::fmt;

/// Method name of the notifications that carry [`Event`]s.
pub const EVENT_METHOD: &str = "event";

/// Largest feed override factor (`feed.override {"factor": ...}`); 0 is allowed (feed stop).
pub const OVERRIDE_MAX: f64 = 2.0;

/// The same bound in percent (`feed.override {"percent": ...}`).
pub const OVERRIDE_MAX_PERCENT: f64 = 200.0;

/// Name given to a program loaded as inline text without a `name`.
pub const INLINE_PROGRAM_NAME: &str = "inline";

/// The error codes of the control API: the JSON-RPC ones and interpd's own, in −32099…−32000.
pub mod codes {
    pub use crate::jsonrpc::codes::*;

    /// `program.load`: the program could not be read, parsed or prepared.
    pub const BAD_PROGRAM: i32 = -32001;
    /// The command is not allowed in the current state (`data` holds `state` and `action`).
    pub const NOT_ALLOWED: i32 = -32002;
    /// `motion.start`: a CAN drive is not in Operation enabled (the message names the drive).
    pub const DRIVES_NOT_READY: i32 = -32005;
    /// `program.append`: the program buffer cannot take the text now (`data` holds
    /// `buffered_bytes` and `limit_bytes`); send it again when the motion has used some.
    pub const BUFFER_FULL: i32 = -32006;
    /// `drives.sdo_read`, `drives.sdo_write`, `drives.reset`: the drive refused or did not
    /// answer (the message names the node, the object and the SDO abort code with its meaning;
    /// `data.abort_code` holds the code).
    pub const DRIVE_COMMAND_FAILED: i32 = -32007;
    /// `drives.*`: the daemon runs no CAN master (`interpd run --can IFACE`), or has no such node.
    pub const NO_SUCH_DRIVE: i32 = -32008;
}

// ---------------------------------------------------------------------------------------------
// Methods
// ---------------------------------------------------------------------------------------------

/// The methods of the control API.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    ProgramLoad,
    ProgramAppend,
    MotionStart,
    MotionHold,
    MotionResume,
    MotionStop,
    FeedOverride,
    Status,
    Subscribe,
    MotionLaw,
    MotionJog,
    MotionJogStop,
    MotionMoveTo,
    Mdi,
    ToolsGet,
    ToolsSet,
    OffsetsGet,
    OffsetsSet,
    DrivesSdoRead,
    DrivesSdoWrite,
    DrivesReset,
    MachineHome,
    MotionOptionalStop,
}

impl Method {
    pub const ALL: [Method; 23] = [
        Method::ProgramLoad,
        Method::ProgramAppend,
        Method::MotionStart,
        Method::MotionHold,
        Method::MotionResume,
        Method::MotionStop,
        Method::FeedOverride,
        Method::Status,
        Method::Subscribe,
        Method::MotionLaw,
        Method::MotionJog,
        Method::MotionJogStop,
        Method::MotionMoveTo,
        Method::Mdi,
        Method::ToolsGet,
        Method::ToolsSet,
        Method::OffsetsGet,
        Method::OffsetsSet,
        Method::DrivesSdoRead,
        Method::DrivesSdoWrite,
        Method::DrivesReset,
        Method::MachineHome,
        Method::MotionOptionalStop,
    ];

    /// The wire name, e.g. `"motion.start"`.
    pub const fn name(self) -> &'static str {
        match self {
            Method::ProgramLoad => "program.load",
            Method::ProgramAppend => "program.append",
            Method::MotionStart => "motion.start",
            Method::MotionHold => "motion.hold",
            Method::MotionResume => "motion.resume",
            Method::MotionStop => "motion.stop",
            Method::FeedOverride => "feed.override",
            Method::Status => "status",
            Method::Subscribe => "subscribe",
            Method::MotionLaw => "motion.law",
            Method::MotionJog => "motion.jog",
            Method::MotionJogStop => "motion.jog_stop",
            Method::MotionMoveTo => "motion.move_to",
            Method::Mdi => "mdi",
            Method::ToolsGet => "tools.get",
            Method::ToolsSet => "tools.set",
            Method::OffsetsGet => "offsets.get",
            Method::OffsetsSet => "offsets.set",
            Method::DrivesSdoRead => "drives.sdo_read",
            Method::DrivesSdoWrite => "drives.sdo_write",
            Method::DrivesReset => "drives.reset",
            Method::MachineHome => "machine.home",
            Method::MotionOptionalStop => "motion.optional_stop",
        }
    }

    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A method serializes as its wire name (the `action` of a refused command).
impl Serialize for Method {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Method {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Method::from_name(&name).ok_or_else(|| serde::de::Error::custom(format!("unknown method {name:?}")))
    }
}

/// −32601 naming `method` and listing interpd's methods.
pub fn method_not_found(method: &str) -> ErrorObject {
    let valid: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
    ErrorObject::method_not_found(method, &valid)
}

/// −32602 for `method`; `param` (if any) is the parameter at fault, also in `data`.
pub fn invalid_params(method: Method, param: Option<&str>, detail: &str) -> ErrorObject {
    ErrorObject::invalid_params(method.name(), param, detail)
}

/// A checked method call.
#[derive(Debug, Clone, PartialEq)]
pub enum Call {
    ProgramLoad(LoadParams),
    ProgramAppend(AppendParams),
    MotionStart,
    MotionHold,
    MotionResume,
    MotionStop,
    FeedOverride(OverrideParams),
    Status,
    Subscribe,
    MotionLaw(LawParams),
    MotionJog(JogParams),
    MotionJogStop,
    MotionMoveTo(MoveToParams),
    Mdi(MdiParams),
    ToolsGet,
    ToolsSet(ToolTable),
    OffsetsGet,
    OffsetsSet(WorkOffsets),
    DrivesSdoRead(SdoReadParams),
    DrivesSdoWrite(SdoWriteParams),
    DrivesReset(ResetParams),
    MachineHome,
    MotionOptionalStop(OptionalStopParams),
}

impl Call {
    /// Checks the method name and its parameters: −32601 for an unknown method, −32602 naming
    /// the parameter for missing, unknown, mistyped or out-of-range parameters.
    pub fn parse(method: &str, params: Option<Value>) -> Result<Call, ErrorObject> {
        let m = Method::from_name(method).ok_or_else(|| method_not_found(method))?;
        let params = Params::new(params);
        Ok(match m {
            Method::ProgramLoad => Call::ProgramLoad(LoadParams::parse(params)?),
            Method::ProgramAppend => Call::ProgramAppend(AppendParams::parse(params)?),
            Method::FeedOverride => Call::FeedOverride(OverrideParams::parse(params)?),
            Method::MotionLaw => Call::MotionLaw(LawParams::parse(params)?),
            Method::MotionJog => Call::MotionJog(JogParams::parse(params)?),
            Method::MotionMoveTo => Call::MotionMoveTo(MoveToParams::parse(params)?),
            Method::Mdi => Call::Mdi(MdiParams::parse(params)?),
            Method::ToolsSet => Call::ToolsSet(ToolTable::parse(params)?),
            Method::OffsetsSet => Call::OffsetsSet(WorkOffsets::parse(params)?),
            Method::DrivesSdoRead => Call::DrivesSdoRead(SdoReadParams::parse(params)?),
            Method::DrivesSdoWrite => Call::DrivesSdoWrite(SdoWriteParams::parse(params)?),
            Method::DrivesReset => Call::DrivesReset(ResetParams::parse(params)?),
            Method::MotionOptionalStop => Call::MotionOptionalStop(OptionalStopParams::parse(params)?),
            Method::ToolsGet => params::none(m, params).map(|()| Call::ToolsGet)?,
            Method::OffsetsGet => params::none(m, params).map(|()| Call::OffsetsGet)?,
            Method::MotionJogStop => params::none(m, params).map(|()| Call::MotionJogStop)?,
            Method::MotionStart => params::none(m, params).map(|()| Call::MotionStart)?,
            Method::MotionHold => params::none(m, params).map(|()| Call::MotionHold)?,
            Method::MotionResume => params::none(m, params).map(|()| Call::MotionResume)?,
            Method::MotionStop => params::none(m, params).map(|()| Call::MotionStop)?,
            Method::Status => params::none(m, params).map(|()| Call::Status)?,
            Method::Subscribe => params::none(m, params).map(|()| Call::Subscribe)?,
            Method::MachineHome => params::none(m, params).map(|()| Call::MachineHome)?,
        })
    }

    pub fn method(&self) -> Method {
        match self {
            Call::ProgramLoad(_) => Method::ProgramLoad,
            Call::ProgramAppend(_) => Method::ProgramAppend,
            Call::MotionStart => Method::MotionStart,
            Call::MotionHold => Method::MotionHold,
            Call::MotionResume => Method::MotionResume,
            Call::MotionStop => Method::MotionStop,
            Call::FeedOverride(_) => Method::FeedOverride,
            Call::Status => Method::Status,
            Call::Subscribe => Method::Subscribe,
            Call::MotionLaw(_) => Method::MotionLaw,
            Call::MotionJog(_) => Method::MotionJog,
            Call::MotionJogStop => Method::MotionJogStop,
            Call::MotionMoveTo(_) => Method::MotionMoveTo,
            Call::Mdi(_) => Method::Mdi,
            Call::ToolsGet => Method::ToolsGet,
            Call::ToolsSet(_) => Method::ToolsSet,
            Call::OffsetsGet => Method::OffsetsGet,
            Call::OffsetsSet(_) => Method::OffsetsSet,
            Call::DrivesSdoRead(_) => Method::DrivesSdoRead,
            Call::DrivesSdoWrite(_) => Method::DrivesSdoWrite,
            Call::DrivesReset(_) => Method::DrivesReset,
            Call::MachineHome => Method::MachineHome,
            Call::MotionOptionalStop(_) => Method::MotionOptionalStop,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Results
// ---------------------------------------------------------------------------------------------

/// Result of `motion.start`, `motion.hold`, `motion.resume` and `motion.stop`: the command was
/// accepted (the motion itself proceeds in the background; watch `status` or the events).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ack {
    pub ok: bool,
}

impl Default for Ack {
    fn default() -> Ack {
        Ack { ok: true }
    }
}

/// Result of `feed.override`: the factor now in effect (targeted; the change itself is
/// jerk-limited).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OverrideResult {
    #[serde(rename = "override")]
    pub factor: f64,
}

/// Result of `motion.optional_stop`: the switch now in effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct OptionalStopResult {
    pub optional_stop: bool,
}

/// The program stop a program pauses at (`paused` event, `status.pause`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PauseCode {
    M0,
    M1,
    M60,
}

/// The comment an operator message comes from (`message` event).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MessageKind {
    /// `(MSG,…)`, shown as written.
    Msg,
    /// `(DEBUG,…)`, parameters substituted (while `#5599` > 0).
    Debug,
    /// `(PRINT,…)`, parameters substituted.
    Print,
}

/// Result of `subscribe`: the connection now also carries event notifications.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Subscribed {
    pub subscribed: bool,
    /// The event names that may follow ([`Event::NAMES`]).
    pub events: Vec<String>,
}

impl Default for Subscribed {
    fn default() -> Subscribed {
        Subscribed { subscribed: true, events: Event::NAMES.iter().map(|s| s.to_string()).collect() }
    }
}

/// Result of `motion.law`: the move's figures (it has started).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LawResult {
    /// Duration of the move (its law's duration, stretched if it said `STRETCH`), s.
    pub duration_s: f64,
    /// Length of the straight line the axes move along, mm.
    pub length_mm: f64,
}

/// Result of `motion.move_to`: the move's duration as planned (it has started).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MoveToResult {
    /// Time from the start (or the handover instant, when it replaces a running manual motion)
    /// until every axis has reached the target, s.
    pub duration_s: f64,
}

/// Result of `program.append`: what the text added, and the buffer after it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AppendResult {
    /// The program's lines the text took (first, last), counted over the whole program.
    pub lines: [u32; 2],
    /// Geometry elements it added.
    pub elements: u64,
    /// Path length it added, mm.
    pub length_mm: f64,
    /// The program has ended (M2, M30, a closing `%`, or `"end": true`): nothing more can follow.
    pub program_end: bool,
    /// Appended text not yet read by the motion, bytes.
    pub buffered_bytes: u64,
    /// `[programs] append_buffer_kib` in bytes.
    pub limit_bytes: u64,
}

/// Result of `mdi`: the blocks as parsed (they have started).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MdiResult {
    /// Geometry elements of the blocks.
    pub elements: u64,
    /// Path length, mm.
    pub length_mm: f64,
}

/// What kind of manual motion (`jogging` state) runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ManualKind {
    /// `motion.jog`, continuous or by a distance.
    Jog,
    /// `motion.move_to`.
    MoveTo,
}

// ---------------------------------------------------------------------------------------------
// Events
// ---------------------------------------------------------------------------------------------

/// What a `subscribe`d connection receives, each as
/// `{"jsonrpc":"2.0","method":"event","params":{"event":"line_reached","line":12}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// Motion started (`motion.start` accepted and the first cycle ran).
    Started,
    /// Execution reached a new program line.
    LineReached { line: u32 },
    /// The profile queue ran dry at path position `s_mm`: the path velocity is being brought to
    /// zero along the path until the planner catches up.
    Underrun { s_mm: f64 },
    /// The planner caught up after an underrun; motion continues.
    UnderrunCleared,
    /// A feed hold has brought the machine to rest.
    Held,
    /// Motion resumed after a hold.
    Resumed,
    /// A stop has completed; the machine stands.
    Stopped,
    /// The program ran to its end after `duration_s` seconds of motion.
    Finished { duration_s: f64 },
    /// Motion was aborted; `message` says why.
    Error { message: String },
    /// A manual motion (`motion.jog`, `motion.move_to`) was accepted and its first cycle ran.
    Jogging { kind: ManualKind },
    /// A jog reached the point where it must brake to stop at the soft limit `limit` of `axis`
    /// (axis unit); it stops there.
    JogLimitReached { axis: String, limit: f64 },
    /// A manual motion ended: the machine stands after `duration_s` of motion.
    JogDone { kind: ManualKind, duration_s: f64 },
    /// The compensation stage has had no valid measurement for `age_ms` (more than its
    /// `max_age_ms`): its corrections fade out.
    MeasurementLost { age_ms: f64 },
    /// Valid measurements arrive again: the corrections fade back in.
    MeasurementRestored,
    /// The program stands at its program stop `code` (M0, M1 with the optional-stop switch
    /// on, M60) on line `line`: it waits for `motion.resume`.
    Paused { line: u32, code: PauseCode },
    /// The motion reached an operator message of the program (`(MSG,…)`, `(DEBUG,…)`,
    /// `(PRINT,…)` on line `line`): everything before it has moved. `text` is formatted when
    /// the program read the block (parameters substituted for DEBUG and PRINT, at most 255
    /// bytes); `dropped` counts the messages left out just before this one because too many
    /// waited for the motion (0 normally).
    Message { kind: MessageKind, text: String, line: u32, dropped: u64 },
}

impl Event {
    /// The `event` tag of every variant, in declaration order.
    pub const NAMES: [&'static str; 16] = [
        "started",
        "line_reached",
        "underrun",
        "underrun_cleared",
        "held",
        "resumed",
        "stopped",
        "finished",
        "error",
        "jogging",
        "jog_limit_reached",
        "jog_done",
        "measurement_lost",
        "measurement_restored",
        "paused",
        "message",
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Event::Started => "started",
            Event::LineReached { .. } => "line_reached",
            Event::Underrun { .. } => "underrun",
            Event::UnderrunCleared => "underrun_cleared",
            Event::Held => "held",
            Event::Resumed => "resumed",
            Event::Stopped => "stopped",
            Event::Finished { .. } => "finished",
            Event::Error { .. } => "error",
            Event::Jogging { .. } => "jogging",
            Event::JogLimitReached { .. } => "jog_limit_reached",
            Event::JogDone { .. } => "jog_done",
            Event::MeasurementLost { .. } => "measurement_lost",
            Event::MeasurementRestored => "measurement_restored",
            Event::Paused { .. } => "paused",
            Event::Message { .. } => "message",
        }
    }

    /// The notification that carries this event.
    pub fn to_notification(&self) -> Notification<&Event> {
        Notification::new(EVENT_METHOD, self)
    }
}

#[cfg(test)]
mod tests;
