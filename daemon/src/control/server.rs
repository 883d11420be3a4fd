//! The control socket: accepting clients, reading their lines, writing answers and events.
//!
//! Threads: one accept thread, and per client one thread reading requests (it also writes the
//! answers) plus, once the client has subscribed, one thread forwarding events. A client can
//! only ever hold up its own threads: reads are bounded to one line of at most
//! [`MAX_LINE_BYTES`](interpd_protocol::jsonrpc::MAX_LINE_BYTES), and a client that does not
//! read what it is sent for [`ControlServerBuilder::write_timeout`] is disconnected. The
//! service is only ever called, never waited on by it.
//!
//! This file holds the handle: settings, start-up and shutdown. The socket file is made in
//! `socket`, clients are accepted in `accept` and served in `connection`, and the state they
//! share is in `shared`.

use super::accept::accept_loop;
use super::dispatch::Context;
use super::motion::Motion;
use super::shared::{Client, Inner, lock};
use super::socket::create_socket;
use std::collections::HashMap;
use std::fs;
use std::io::Write;
use std::net::Shutdown;
use std::os::unix::fs::MetadataExt;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::Duration;

// `control::server::…` names the server's limits and its error wherever they are defined.
pub use super::connection::{CONNECTION_STACK_BYTES, EVENT_STACK_BYTES};
pub use super::errors::ServerError;
pub use super::socket::SOCKET_MODE;

/// Default for [`ControlServerBuilder::max_clients`].
pub const DEFAULT_MAX_CLIENTS: usize = 16;

/// Default for [`ControlServerBuilder::write_timeout`].
pub const DEFAULT_WRITE_TIMEOUT: Duration = Duration::from_secs(5);

/// Settings of a [`ControlServer`]; see [`ControlServer::builder`].
#[derive(Debug, Clone)]
pub struct ControlServerBuilder {
    socket: Option<PathBuf>,
    stop_on_disconnect: bool,
    max_clients: usize,
    write_timeout: Duration,
}

impl ControlServerBuilder {
    /// The socket path (required), e.g. from `interpd_config::ControlConfig::socket_path`.
    pub fn socket(mut self, path: impl Into<PathBuf>) -> Self {
        self.socket = Some(path.into());
        self
    }

    /// Stop the motion when the connection that issued the accepted `motion.start` closes
    /// while the state is running or holding. Default: off (motion continues).
    pub fn stop_on_disconnect(mut self, on: bool) -> Self {
        self.stop_on_disconnect = on;
        self
    }

    /// Most simultaneous connections (subscribers included); further clients get error
    /// −32004 and are closed. Default [`DEFAULT_MAX_CLIENTS`].
    pub fn max_clients(mut self, n: usize) -> Self {
        self.max_clients = n;
        self
    }

    /// How long a write to a client may block (its socket buffer full because it does not
    /// read) before the client is disconnected. Default [`DEFAULT_WRITE_TIMEOUT`].
    pub fn write_timeout(mut self, t: Duration) -> Self {
        self.write_timeout = t;
        self
    }

    /// Creates the socket (mode 0660; a stale socket file is replaced, a live one is an error)
    /// and starts accepting clients.
    pub fn build(self, motion: Arc<dyn Motion>) -> Result<ControlServer, ServerError> {
        let path = self.socket.ok_or(ServerError::NoSocketPath)?;
        if self.max_clients == 0 {
            return Err(ServerError::Config("max_clients must be at least 1"));
        }
        if self.write_timeout.is_zero() {
            return Err(ServerError::Config("write_timeout must be longer than zero"));
        }
        let (listener, file_id) = create_socket(&path)?;
        let socket_err = |source| ServerError::Socket { path: path.clone(), source };
        // Cleanup of the file if anything below fails: the server never ran.
        let fail = |e: ServerError| {
            let _ = fs::remove_file(&path);
            e
        };
        listener.set_nonblocking(true).map_err(socket_err).map_err(fail)?;
        let (wake, wake_rx) = UnixStream::pair().map_err(socket_err).map_err(fail)?;
        wake_rx.set_nonblocking(true).map_err(socket_err).map_err(fail)?;
        let inner = Arc::new(Inner {
            ctx: Context::new(motion),
            stop_on_disconnect: self.stop_on_disconnect,
            max_clients: self.max_clients,
            write_timeout: self.write_timeout,
            shutting_down: AtomicBool::new(false),
            clients: Mutex::new(HashMap::new()),
            next_id: AtomicU64::new(1),
        });
        let accept_inner = Arc::clone(&inner);
        let accept = thread::Builder::new()
            .name("interpd-ctl".to_string())
            .spawn(move || accept_loop(&accept_inner, listener, wake_rx))
            .map_err(ServerError::Thread)
            .map_err(fail)?;
        tracing::info!(
            socket = %path.display(),
            max_clients = self.max_clients,
            stop_on_disconnect = self.stop_on_disconnect,
            "control server listening"
        );
        Ok(ControlServer { inner, path, file_id, accept: Mutex::new(Some(accept)), wake })
    }
}

/// Counters since the server started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ServerStats {
    /// Connections accepted.
    pub connections: u64,
    /// Connections open now.
    pub active: usize,
    /// Connections refused because of `max_clients`.
    pub rejected: u64,
    /// Requests and notifications received (batch elements counted one by one).
    pub requests: u64,
    /// Of those, the ones that failed (answered with an error, or notifications that failed).
    pub errors: u64,
    /// Panics caught in the server or in motion calls (each became an internal error or a
    /// closed connection); should stay 0.
    pub panics: u64,
}

/// The JSON-RPC control server (docs/control-api.md).
///
/// It does not stop the motion when it shuts down: on SIGTERM the daemon stops the motion
/// (`Motion::stop`) and then calls [`ControlServer::shutdown`].
pub struct ControlServer {
    inner: Arc<Inner>,
    path: PathBuf,
    /// Device and inode of the socket file created, so that shutdown removes only that file
    /// and not one a later daemon put at the same path.
    file_id: (u64, u64),
    accept: Mutex<Option<JoinHandle<()>>>,
    wake: UnixStream,
}

impl ControlServer {
    /// Settings with their defaults; [`ControlServerBuilder::socket`] is required.
    pub fn builder() -> ControlServerBuilder {
        ControlServerBuilder {
            socket: None,
            stop_on_disconnect: false,
            max_clients: DEFAULT_MAX_CLIENTS,
            write_timeout: DEFAULT_WRITE_TIMEOUT,
        }
    }

    pub fn socket_path(&self) -> &Path {
        &self.path
    }

    pub fn stats(&self) -> ServerStats {
        let c = &self.inner.ctx.counters;
        ServerStats {
            connections: c.connections.load(Ordering::Relaxed),
            active: lock(&self.inner.clients).len(),
            rejected: c.rejected.load(Ordering::Relaxed),
            requests: c.requests.load(Ordering::Relaxed),
            errors: c.errors.load(Ordering::Relaxed),
            panics: c.panics.load(Ordering::Relaxed),
        }
    }

    /// Stops accepting, closes every connection, waits for their threads and removes the
    /// socket file. Idempotent; also done on drop. It waits for motion calls in progress to
    /// return.
    pub fn shutdown(&self) {
        if self.inner.shutting_down.swap(true, Ordering::AcqRel) {
            return;
        }
        // The accept thread sleeps in poll(2) on the listener and this pair.
        let _ = (&self.wake).write(&[1]);
        if let Some(h) = lock(&self.accept).take() {
            let _ = h.join();
        }
        // No new clients now; close the others. Shutting a socket down wakes its reader (and a
        // writer blocked on a full buffer), so the threads end promptly.
        let clients: Vec<Client> = lock(&self.inner.clients).drain().map(|(_, c)| c).collect();
        for c in &clients {
            let _ = c.stream.shutdown(Shutdown::Both);
        }
        for c in clients {
            if let Some(h) = c.thread {
                let _ = h.join();
            }
        }
        match fs::symlink_metadata(&self.path) {
            Ok(md) if (md.dev(), md.ino()) == self.file_id => {
                if let Err(e) = fs::remove_file(&self.path) {
                    tracing::warn!(socket = %self.path.display(), error = %e, "cannot remove the control socket");
                }
            }
            Ok(_) => tracing::warn!(
                socket = %self.path.display(),
                "the control socket path now holds another file; left in place"
            ),
            Err(_) => {}
        }
        let s = self.stats();
        tracing::info!(
            connections = s.connections,
            rejected = s.rejected,
            requests = s.requests,
            errors = s.errors,
            panics = s.panics,
            "control server stopped"
        );
    }
}

impl Drop for ControlServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}
