//! From one received line to the line sent back: the JSON-RPC rules (parse errors, invalid
//! requests, notifications, batches) and the calls into [`Motion`].

use super::motion::{Motion, ProgramSource};
use interpd_protocol::api::{self, Ack, Call, Event, LoadParams, OverrideResult, Subscribed};
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
            // A panic in the motion core must not take the connection (and the server's
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
                let source = match params {
                    LoadParams::Path { path } => ProgramSource::File(PathBuf::from(path)),
                    LoadParams::Text { text, name } => {
                        ProgramSource::Text { name: name.unwrap_or_else(|| api::INLINE_PROGRAM_NAME.to_string()), text }
                    }
                };
                let what = match &source {
                    ProgramSource::File(p) => p.display().to_string(),
                    ProgramSource::Text { name, text } => format!("{name} ({} bytes inline)", text.len()),
                };
                let info = motion.load(source)?;
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
            Call::MotionStop => motion.stop().map_err(ErrorObject::from).and_then(|()| to_value(&Ack::default())),
            Call::MotionLaw(p) => {
                let info = motion.law(&p.statement)?;
                *self.start_owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(session.id);
                Ok(info)
            }
            Call::FeedOverride(p) => {
                motion.set_override(p.factor)?;
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
