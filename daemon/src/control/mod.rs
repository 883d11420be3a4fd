//! The control API: JSON-RPC 2.0, one message per line, on a Unix socket (reference with
//! examples in docs/control-api.md).
//!
//! - [`motion`]: the [`Motion`] trait the service implements;
//! - [`errors`]: why it refuses a command, one error type per operation;
//! - [`server`]: [`ControlServer`]: its settings, start-up and shutdown;
//! - `socket`: the socket file (mode 0660, stale files replaced, live ones refused);
//! - `accept`: the accept thread, admitting clients up to `max_clients`;
//! - `connection`: one client's threads (requests and answers, events);
//! - `shared`: the state those threads and the handle share;
//! - `dispatch`: one received line to one answer (JSON-RPC rules, calls into [`Motion`], error
//!   codes);
//! - `framing`: lines out of a byte stream, never more than 1 MiB.
//!
//! The message types themselves are in [`interpd_protocol::jsonrpc`] (the envelope) and
//! [`interpd_protocol::api`] (methods, parameters, results, status, events).
//!
//! ```no_run
//! # use std::sync::Arc;
//! # fn demo(motion: Arc<dyn interpd::control::Motion>) -> Result<(), interpd::control::ServerError> {
//! use interpd::control::ControlServer;
//! let server = ControlServer::builder()
//!     .socket("/run/interpd/control.sock")
//!     .stop_on_disconnect(false)
//!     .max_clients(16)
//!     .build(motion)?;
//! // ... on SIGTERM: stop the motion, then
//! server.shutdown();
//! # Ok(()) }
//! ```

mod accept;
mod connection;
mod dispatch;
pub mod errors;
mod framing;
pub mod motion;
pub mod server;
mod shared;
mod socket;

pub use errors::{
    AppendError, DriveError, LawError, LawProgramError, LoadError, ManualError, NotAllowed, ProgramPathError,
    ResumeError, StartError,
};
pub use motion::{Motion, ProgramSource};
pub use server::{ControlServer, ControlServerBuilder, ServerError, ServerStats};
