//! The state the accept thread, the connection threads and the
//! [`ControlServer`](super::ControlServer) handle share: the dispatch context, the settings,
//! the shutdown flag and the table of open connections. Every other file of the server takes
//! it from here.

use super::dispatch::Context;
use std::collections::HashMap;
use std::os::unix::net::UnixStream;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::{Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// What the accept thread, the connection threads and the [`ControlServer`](super::ControlServer)
/// handle share.
pub(super) struct Inner {
    pub(super) ctx: Context,
    pub(super) stop_on_disconnect: bool,
    pub(super) max_clients: usize,
    pub(super) write_timeout: Duration,
    pub(super) shutting_down: AtomicBool,
    pub(super) clients: Mutex<HashMap<u64, Client>>,
    pub(super) next_id: AtomicU64,
}

/// A connection as the server keeps track of it.
pub(super) struct Client {
    /// A second handle on the socket, to shut it down from
    /// [`ControlServer::shutdown`](super::ControlServer::shutdown).
    pub(super) stream: UnixStream,
    /// Set right after the thread is spawned (the entry exists before, so that a thread that
    /// ends at once still finds its entry to remove).
    pub(super) thread: Option<JoinHandle<()>>,
}

/// A poisoned lock only means another thread panicked while holding it; the data (a map of
/// handles, an id) is still consistent, so carry on rather than propagate the panic.
pub(super) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
