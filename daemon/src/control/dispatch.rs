//! From one received line to the line sent back: the JSON-RPC rules (parse errors, invalid
//! requests, notifications, batches), the calls into [`Motion`], and the error codes of its
//! refusals.

use super::errors::{AppendError, DriveError, LawError, LoadError, ManualError, NotAllowed, ResumeError, StartError};
use super::motion::{Motion, ProgramSource};
use crate::sinks::drive_command::{DriveCommandError, SdoOp};
use interpd_canopen::Address;
use interpd_protocol::api::{self, Ack, Call, Event, LoadParams, OverrideResult, Subscribed, codes};
use interpd_protocol::jsonrpc::{self, ErrorObject, Id, Incoming, Invalid, Request, Response};
use serde::Serialize;
use serde_json::Value;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Counters the server keeps for its log and for tests.
#[derive(Debug, Default)]
pub(crate) struct Counters {
    pub connections: AtomicU64,
    pub rejected: AtomicU64,
    pub requests: AtomicU64,
    pub errors: AtomicU64,
    pub panics: AtomicU64,
}

/// What all connections share.
pub(crate) struct Context {
    pub motion: Arc<dyn Motion>,
    /// The connection whose `motion.start` was accepted last: the one whose disconnect stops
    /// the motion when `stop_on_disconnect` is set.
    pub start_owner: Mutex<Option<u64>>,
    pub counters: Counters,
}

/// Per-connection state seen by the dispatcher.
#[derive(Debug)]
pub(crate) struct Session {
    pub id: u64,
    /// `subscribe` was accepted on this connection (a second one changes nothing).
    pub subscribed: bool,
    /// The receiver of a `subscribe` just accepted: the server starts forwarding only after it
    /// has written the response, so the response always comes before the first event.
    pub new_subscription: Option<crossbeam::channel::Receiver<Event>>,
}

impl Session {
    pub fn new(id: u64) -> Session {
        Session { id, subscribed: false, new_subscription: None }
    }
}

impl Context {
    pub fn new(motion: Arc<dyn Motion>) -> Context {
        Context { motion, start_owner: Mutex::new(None), counters: Counters::default() }
    }

    /// Handles one line (without its newline) and returns the line to answer with, if any:
    /// nothing for blank lines, notifications and batches of notifications only.
    pub fn handle_line(&self, session: &mut Session, line: &[u8]) -> Option<String> {
        // Blank lines are what people type into socat by accident; they carry no request.
        if line.iter().all(u8::is_ascii_whitespace) {
            return None;
        }
        match jsonrpc::parse_incoming(line) {
            Err(e) => {
                tracing::debug!(conn = session.id, error = %e.message, "unparsable line");
                self.counters.errors.fetch_add(1, Ordering::Relaxed);
                Some(encode(&Response::error(Id::Null, e)))
            }
            Ok(Incoming::Single(item)) => self.handle_item(session, item).map(|r| encode(&r)),
            Ok(Incoming::Batch(items)) => {
                let responses: Vec<Response> =
                    items.into_iter().filter_map(|item| self.handle_item(session, item)).collect();
                if responses.is_empty() {
                    return None;
                }
                Some(encode(&responses))
            }
        }
    }

    fn handle_item(&self, session: &mut Session, item: Result<Request, Invalid>) -> Option<Response> {
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        let req = match item {
            Ok(req) => req,
            Err(inv) => {
                tracing::debug!(conn = session.id, error = %inv.error.message, "invalid request");
                self.counters.errors.fetch_add(1, Ordering::Relaxed);
                return Some(Response::error(inv.id, inv.error));
            }
        };
        let outcome = Call::parse(&req.method, req.params).and_then(|call| {
            let method = call.method();
            // A panic in the service must not take the connection (and the server's
            // bookkeeping) with it: it becomes an internal error for this one request.
            catch_unwind(AssertUnwindSafe(|| self.execute(session, call))).unwrap_or_else(|_| {
                self.counters.panics.fetch_add(1, Ordering::Relaxed);
                tracing::error!(conn = session.id, %method, "the motion core panicked");
                Err(ErrorObject::internal(&format!(
                    "the motion core failed while handling {method}; see the daemon log"
                )))
            })
        });
        if let Err(e) = &outcome {
            self.counters.errors.fetch_add(1, Ordering::Relaxed);
            tracing::debug!(conn = session.id, method = %excerpt(&req.method), code = e.code, error = %e.message, "request refused");
        }
        // Notifications are never answered, not even with an error (JSON-RPC 2.0 §4.1).
        req.id.map(|id| match outcome {
            Ok(v) => Response::result(id, v),
            Err(e) => Response::error(id, e),
        })
    }

    fn execute(&self, session: &mut Session, call: Call) -> Result<Value, ErrorObject> {
        let motion = &*self.motion;
        let method = call.method();
        let result = match call {
            Call::Status => return to_value(&motion.status()),
            Call::Subscribe => {
                if !session.subscribed {
                    session.new_subscription = Some(motion.subscribe());
                    session.subscribed = true;
                    tracing::debug!(conn = session.id, "subscribed to events");
                }
                return to_value(&Subscribed::default());
            }
            Call::ProgramLoad(params) => {
                let (source, open) = match params {
                    LoadParams::Path { path, open } => (ProgramSource::File(PathBuf::from(path)), open),
                    LoadParams::Text { text, name, open } => {
                        let name = name.unwrap_or_else(|| api::INLINE_PROGRAM_NAME.to_string());
                        (ProgramSource::Text { name, text }, open)
                    }
                };
                let what = match &source {
                    ProgramSource::File(p) => p.display().to_string(),
                    ProgramSource::Text { name, text } => format!("{name} ({} bytes inline)", text.len()),
                };
                let info = motion.load(source, open)?;
                tracing::info!(conn = session.id, program = %what, elements = info.elements, length_mm = info.length_mm, "program loaded");
                to_value(&info)
            }
            Call::MotionStart => {
                motion.start()?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                to_value(&Ack::default())
            }
            Call::MotionHold => motion.hold().map_err(ErrorObject::from).and_then(|()| to_value(&Ack::default())),
            Call::MotionResume => motion.resume().map_err(ErrorObject::from).and_then(|()| to_value(&Ack::default())),
            Call::MotionOptionalStop(p) => {
                to_value(&api::OptionalStopResult { optional_stop: motion.set_optional_stop(p.enabled) })
            }
            Call::MotionStop => {
                let Ok(()) = motion.stop();
                to_value(&Ack::default())
            }
            Call::MotionLaw(p) => {
                let figures = motion.law(&p.statement)?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                to_value(&figures)
            }
            Call::MotionJog(p) => {
                motion.jog(&p)?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                to_value(&Ack::default())
            }
            Call::MotionJogStop => {
                let Ok(()) = motion.jog_stop();
                to_value(&Ack::default())
            }
            Call::MotionMoveTo(p) => {
                let result = motion.move_to(&p)?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                to_value(&result)
            }
            Call::ProgramAppend(p) => to_value(&motion.append(&p)?),
            Call::Mdi(p) => {
                let result = motion.mdi(&p)?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                to_value(&result)
            }
            Call::ToolsGet => to_value(&motion.tools()),
            Call::ToolsSet(table) => to_value(&motion.set_tools(table)),
            Call::OffsetsGet => to_value(&motion.offsets()),
            Call::OffsetsSet(offsets) => {
                motion.set_offsets(offsets).map_err(ErrorObject::from).and_then(|o| to_value(&o))
            }
            Call::DrivesSdoRead(p) => {
                let data = motion.drive_sdo(method, p.node, SdoOp::Read(Address::new(p.index, p.sub)))?;
                to_value(&api::SdoResult::new(p.node, p.index, p.sub, &data, p.ty))
            }
            Call::DrivesSdoWrite(p) => {
                motion.drive_sdo(method, p.node, SdoOp::Write(Address::new(p.index, p.sub), p.data.clone()))?;
                tracing::info!(conn = session.id, node = p.node, index = p.index, sub = p.sub, "SDO write");
                to_value(&api::SdoResult::new(p.node, p.index, p.sub, &p.data, Some(p.ty)))
            }
            Call::DrivesReset(p) => to_value(&api::ResetResult { drives: motion.drive_reset(&p.nodes)? }),
            Call::MachineHome => {
                let axes = motion.machine_home()?;
                tracing::info!(conn = session.id, axes = axes.len(), "machine homed");
                to_value(&api::HomeResult { axes })
            }
            Call::FeedOverride(p) => {
                let Ok(()) = motion.set_override(p.factor);
                tracing::info!(conn = session.id, factor = p.factor, "feed override");
                to_value(&OverrideResult { factor: p.factor })
            }
        };
        if result.is_ok() && !matches!(method, api::Method::FeedOverride | api::Method::ProgramLoad) {
            tracing::info!(conn = session.id, %method, "accepted");
        }
        result
    }
}

fn to_value<T: Serialize>(v: &T) -> Result<Value, ErrorObject> {
    serde_json::to_value(v).map_err(|e| ErrorObject::internal(&format!("cannot encode the result: {e}")))
}

/// One line of JSON. Serializing these types cannot fail in practice (no maps with non-string
/// keys, non-finite floats become null); should it, the client still gets a valid answer.
pub(crate) fn encode<T: Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap_or_else(|e| {
        tracing::error!(error = %e, "cannot encode a response");
        r#"{"jsonrpc":"2.0","error":{"code":-32603,"message":"internal error: cannot encode the response"},"id":null}"#
            .to_string()
    })
}

/// Client-supplied text for logs, kept short.
fn excerpt(s: &str) -> &str {
    match s.char_indices().nth(64) {
        Some((i, _)) => &s[..i],
        None => s,
    }
}

// ---------------------------------------------------------------------------------------------
// Refusals on the wire: the code of each error; its `Display` is the message
// ---------------------------------------------------------------------------------------------

/// −32002 with `data` holding `state` and `action`.
impl From<NotAllowed> for ErrorObject {
    fn from(e: NotAllowed) -> ErrorObject {
        ErrorObject::new(codes::NOT_ALLOWED, e.to_string())
            .with_data(serde_json::json!({ "state": e.state, "action": e.action }))
    }
}

impl From<DriveError> for ErrorObject {
    fn from(e: DriveError) -> ErrorObject {
        match e {
            DriveError::NotAllowed(e) => e.into(),
            DriveError::Drive(d) => match &d {
                DriveCommandError::NoMaster | DriveCommandError::UnknownNode { .. } => {
                    ErrorObject::new(codes::NO_SUCH_DRIVE, d.to_string())
                }
                DriveCommandError::Sdo { abort_code, .. } => {
                    ErrorObject::new(codes::DRIVE_COMMAND_FAILED, d.to_string())
                        .with_data(serde_json::json!({ "abort_code": abort_code.map(|c| format!("0x{c:08X}")) }))
                }
                DriveCommandError::Reset(_) | DriveCommandError::Stopped(_) | DriveCommandError::Homing(_) => {
                    ErrorObject::new(codes::DRIVE_COMMAND_FAILED, d.to_string())
                }
            },
        }
    }
}

impl From<LoadError> for ErrorObject {
    fn from(e: LoadError) -> ErrorObject {
        match e {
            LoadError::NotAllowed(e) => e.into(),
            LoadError::Program(_) | LoadError::Laws(_) => ErrorObject::new(codes::BAD_PROGRAM, e.to_string()),
            LoadError::Path(e) => ErrorObject::invalid_params("program.load", Some("path"), &e.to_string()),
        }
    }
}

impl From<AppendError> for ErrorObject {
    fn from(e: AppendError) -> ErrorObject {
        match e {
            AppendError::NoProgram | AppendError::NotOpen => ErrorObject::new(codes::NOT_ALLOWED, e.to_string()),
            AppendError::Closed(_) | AppendError::Program(_) => ErrorObject::new(codes::BAD_PROGRAM, e.to_string()),
            AppendError::Full { buffered_bytes, limit_bytes, .. } => {
                ErrorObject::new(codes::BUFFER_FULL, e.to_string())
                    .with_data(serde_json::json!({ "buffered_bytes": buffered_bytes, "limit_bytes": limit_bytes }))
            }
        }
    }
}

impl From<StartError> for ErrorObject {
    fn from(e: StartError) -> ErrorObject {
        let code = match e {
            StartError::NotAllowed(e) => return e.into(),
            StartError::DrivesNotReady(_) => codes::DRIVES_NOT_READY,
            StartError::Laws(_) => codes::BAD_PROGRAM,
            StartError::AppendedOnce => codes::NOT_ALLOWED,
            StartError::PlannerGone => codes::INTERNAL_ERROR,
        };
        ErrorObject::new(code, e.to_string())
    }
}

impl From<ResumeError> for ErrorObject {
    fn from(e: ResumeError) -> ErrorObject {
        match e {
            ResumeError::NotAllowed(e) => e.into(),
            ResumeError::OverrideZero => ErrorObject::new(codes::INVALID_PARAMS, e.to_string()),
        }
    }
}

impl From<LawError> for ErrorObject {
    fn from(e: LawError) -> ErrorObject {
        let code = match e {
            LawError::Load(e) => return e.into(),
            LawError::Start(e) => return e.into(),
            LawError::NotAStatement { .. } | LawError::Unsupported => codes::INVALID_PARAMS,
            LawError::Laws(_) => codes::BAD_PROGRAM,
        };
        ErrorObject::new(code, e.to_string())
    }
}

impl From<ManualError> for ErrorObject {
    fn from(e: ManualError) -> ErrorObject {
        let code = match &e {
            ManualError::NotAllowed(e) => return (*e).into(),
            ManualError::Param { method, param, detail } => {
                return ErrorObject::invalid_params(method.name(), Some(param), detail);
            }
            ManualError::Moving { method, .. } => {
                return ErrorObject::new(codes::NOT_ALLOWED, e.to_string())
                    .with_data(serde_json::json!({ "action": method }));
            }
            ManualError::Program(_) | ManualError::Prep(_) => codes::BAD_PROGRAM,
            ManualError::DrivesNotReady(_) => codes::DRIVES_NOT_READY,
            ManualError::PlannerGone | ManualError::ParamFile { .. } => codes::INTERNAL_ERROR,
        };
        ErrorObject::new(code, e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::errors::{LawProgramError, hint};
    use crate::sinks::{DriveNotReady, DrivesNotReady, NotReady};
    use interpd_motion::program::{ProgramError, ProgramErrors};
    use interpd_protocol::api::{Method, State};

    #[test]
    fn error_codes_and_messages() {
        let e = NotAllowed { state: State::Idle, action: Method::MotionResume };
        assert_eq!(
            e.to_string(),
            "motion.resume is not allowed while idle: load a program and call motion.start first"
        );
        let o = ErrorObject::from(e);
        assert_eq!(o.code, codes::NOT_ALLOWED);
        assert_eq!(o.data, Some(serde_json::json!({"state": "idle", "action": "motion.resume"})));
        let program = |message: &str| {
            LoadError::Program(ProgramErrors(vec![ProgramError {
                file: "a.ngc".into(),
                line: 2,
                col: 8,
                message: message.into(),
            }]))
        };
        assert_eq!(ErrorObject::from(program("word 'Y' has no number")).code, codes::BAD_PROGRAM);
        let o = ErrorObject::from(program("x"));
        assert_eq!((o.code, o.message.as_str(), o.data), (codes::BAD_PROGRAM, "bad program: a.ngc:2:8: x", None));
        assert_eq!(ErrorObject::from(ResumeError::OverrideZero).code, codes::INVALID_PARAMS);
        assert_eq!(ErrorObject::from(LawError::Unsupported).code, codes::INVALID_PARAMS);
        let o = ErrorObject::from(StartError::PlannerGone);
        assert_eq!(
            (o.code, o.message.as_str()),
            (codes::INTERNAL_ERROR, "internal error: the planner thread has ended")
        );
        // Refusals nested in motion.law keep their own codes.
        let nested =
            LawError::Start(StartError::NotAllowed(NotAllowed { state: State::Running, action: Method::MotionStart }));
        assert_eq!(ErrorObject::from(nested).code, codes::NOT_ALLOWED);
        let laws = LawProgramError::Mixed { file: "l.ngc".into(), line: 3, text: "G1 X1".into() };
        let o = ErrorObject::from(LoadError::Laws(laws));
        assert_eq!(o.code, codes::BAD_PROGRAM);
        assert!(
            o.message.starts_with("bad program: l.ngc:3: \"G1 X1\" in a program of LAW statements"),
            "{}",
            o.message
        );
    }

    #[test]
    fn drives_not_ready_names_each_drive() {
        let e = StartError::DrivesNotReady(DrivesNotReady {
            drives: vec![DriveNotReady { axis: "Y".into(), node: 2, reason: NotReady::HeartbeatLost }],
            silent_interface: Some("vcan0".into()),
        });
        let o = ErrorObject::from(e);
        assert_eq!(o.code, codes::DRIVES_NOT_READY);
        assert_eq!(
            o.message,
            "CAN drives not ready for motion: drive Y (node 2) has lost its heartbeat; CAN interface vcan0 does not \
             receive (down?); the master enables drives at standstill once they answer (see status.drives)"
        );
    }

    #[test]
    fn every_refusal_has_a_hint() {
        for m in Method::ALL {
            for s in State::ALL {
                assert!(!hint(m, s).is_empty());
            }
        }
        assert!(hint(Method::MotionStart, State::Idle).contains("program.load"));
    }
}
