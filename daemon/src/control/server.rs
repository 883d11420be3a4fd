//! The control socket: accepting clients, reading their lines, writing answers and events.
//!
//! Threads: one accept thread, and per client one thread reading requests (it also writes the
//! answers) plus, once the client has subscribed, one thread forwarding events. A client can
//! only ever hold up its own threads: reads are bounded to one line of at most
//! [`MAX_LINE_BYTES`], and a client that does not read what it is sent
//! for [`ControlServerBuilder::write_timeout`] is disconnected. The service is only ever
//! called, never waited on by it.

use super::dispatch::{Context, Session, encode};
use super::framing::{Frame, LineReader};
use super::motion::Motion;
use interpd_protocol::api::{Event, State};
use interpd_protocol::jsonrpc::{ErrorObject, Id, MAX_LINE_BYTES, Response};
use std::collections::HashMap;
use std::fs;
use std::io::{self, Read, Write};
use std::net::Shutdown;
use std::os::fd::AsRawFd;
use std::os::unix::fs::{DirBuilderExt, FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// Permissions of the socket file: owner and group may connect (docs/control-api.md).
pub const SOCKET_MODE: u32 = 0o660;

/// Default for [`ControlServerBuilder::max_clients`].
pub const DEFAULT_MAX_CLIENTS: usize = 16;

/// Default for [`ControlServerBuilder::write_timeout`].
pub const DEFAULT_WRITE_TIMEOUT: Duration = Duration::from_secs(5);

/// Stack of a connection thread. The daemon locks all its memory (`mlockall`, for the
/// real-time thread), so every thread's whole stack is resident while it runs and stays in the
/// C library's stack cache after it: at the default 2 MiB, 16 connections with subscriptions
/// held 64 MiB. Parsing, checking and planning any example program runs in less than a
/// 200 KiB stack (`ulimit -s 200; interpd plan …`); this leaves more than twice that.
pub const CONNECTION_STACK_BYTES: usize = 512 * 1024;
/// Stack of an event thread: it only encodes and writes notifications.
pub const EVENT_STACK_BYTES: usize = 128 * 1024;

/// After a too-large request, how long (and how much) the server keeps reading and discarding
/// the rest, so that the client's write completes and it can read the error instead of
/// failing with a broken pipe.
const DRAIN_TIME: Duration = Duration::from_millis(500);
const DRAIN_BYTES: usize = 16 << 20;

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

/// What the accept thread, the connection threads and the [`ControlServer`] handle share.
struct Inner {
    ctx: Context,
    stop_on_disconnect: bool,
    max_clients: usize,
    write_timeout: Duration,
    shutting_down: AtomicBool,
    clients: Mutex<HashMap<u64, Client>>,
    next_id: AtomicU64,
}

/// A connection as the server keeps track of it.
struct Client {
    /// A second handle on the socket, to shut it down from [`ControlServer::shutdown`].
    stream: UnixStream,
    /// Set right after the thread is spawned (the entry exists before, so that a thread that
    /// ends at once still finds its entry to remove).
    thread: Option<JoinHandle<()>>,
}

/// A poisoned lock only means another thread panicked while holding it; the data (a map of
/// handles, an id) is still consistent, so carry on rather than propagate the panic.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

// ---------------------------------------------------------------------------------------------
// Socket file
// ---------------------------------------------------------------------------------------------

/// Binds the socket at `path` with mode 0660 and returns it with the file's (dev, ino).
fn create_socket(path: &Path) -> Result<(UnixListener, (u64, u64)), ServerError> {
    let socket_err = |source| ServerError::Socket { path: path.to_path_buf(), source };
    clear_stale(path)?;
    let listener = match bind_private(path) {
        Ok(l) => l,
        Err(PrivateBind::Exists) => return Err(ServerError::AlreadyRunning(path.to_path_buf())),
        Err(PrivateBind::Unavailable(e)) => {
            tracing::debug!(error = %e, "cannot bind in a private directory; binding in place");
            bind_in_place(path).map_err(socket_err)?
        }
    };
    let md = fs::symlink_metadata(path).map_err(socket_err)?;
    Ok((listener, (md.dev(), md.ino())))
}

/// A socket file at `path` is either a live daemon's (error) or left by one that crashed
/// (removed). Anything else at the path is not ours to delete.
fn clear_stale(path: &Path) -> Result<(), ServerError> {
    let socket_err = |source| ServerError::Socket { path: path.to_path_buf(), source };
    let md = match fs::symlink_metadata(path) {
        Ok(md) => md,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(socket_err(e)),
    };
    if !md.file_type().is_socket() {
        return Err(ServerError::NotASocket(path.to_path_buf()));
    }
    match UnixStream::connect(path) {
        Ok(_) => Err(ServerError::AlreadyRunning(path.to_path_buf())),
        Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
            match fs::remove_file(path) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(socket_err(e)),
            }
            tracing::warn!(socket = %path.display(), "removed a stale control socket left by a daemon that did not shut down");
            Ok(())
        }
        Err(e) => Err(socket_err(e)),
    }
}

enum PrivateBind {
    /// Something appeared at the path meanwhile (another daemon starting).
    Exists,
    Unavailable(io::Error),
}

/// Binds in a fresh mode-0700 directory next to `path`, sets 0660, then links the socket to
/// `path`. Binding directly at `path` would leave the socket reachable with umask permissions
/// (possibly 0777) until the chmod; and `link(2)` fails rather than replace a file that
/// another daemon created at `path` in the meantime.
fn bind_private(path: &Path) -> Result<UnixListener, PrivateBind> {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = parent.join(format!(".interpd-{}-{}", std::process::id(), SEQ.fetch_add(1, Ordering::Relaxed)));
    fs::DirBuilder::new().mode(0o700).create(&dir).map_err(PrivateBind::Unavailable)?;
    let tmp = dir.join("s");
    let result = (|| {
        let listener = UnixListener::bind(&tmp).map_err(PrivateBind::Unavailable)?;
        fs::set_permissions(&tmp, fs::Permissions::from_mode(SOCKET_MODE)).map_err(PrivateBind::Unavailable)?;
        match fs::hard_link(&tmp, path) {
            Ok(()) => Ok(listener),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Err(PrivateBind::Exists),
            Err(e) => Err(PrivateBind::Unavailable(e)),
        }
    })();
    let _ = fs::remove_file(&tmp);
    let _ = fs::remove_dir(&dir);
    result
}

/// Fallback where the private directory cannot be used (no hard links on the file system, a
/// temporary path over the 108-byte socket path limit).
fn bind_in_place(path: &Path) -> io::Result<UnixListener> {
    let listener = UnixListener::bind(path)?;
    if let Err(e) = fs::set_permissions(path, fs::Permissions::from_mode(SOCKET_MODE)) {
        let _ = fs::remove_file(path);
        return Err(e);
    }
    Ok(listener)
}

// ---------------------------------------------------------------------------------------------
// Accepting
// ---------------------------------------------------------------------------------------------

fn accept_loop(inner: &Arc<Inner>, listener: UnixListener, wake: UnixStream) {
    while !inner.shutting_down.load(Ordering::Acquire) {
        // The timeout is a safety net only: shutdown wakes the poll through `wake`.
        if let Err(e) = wait_readable(&listener, &wake, 500) {
            tracing::error!(error = %e, "poll on the control socket failed");
            thread::sleep(Duration::from_millis(100));
            continue;
        }
        if inner.shutting_down.load(Ordering::Acquire) {
            break;
        }
        loop {
            match listener.accept() {
                Ok((stream, _)) => admit(inner, stream),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if matches!(e.kind(), io::ErrorKind::Interrupted | io::ErrorKind::ConnectionAborted) => {}
                Err(e) => {
                    // Typically EMFILE: back off instead of spinning on a readable listener.
                    tracing::error!(error = %e, "cannot accept a control connection");
                    thread::sleep(Duration::from_millis(100));
                    break;
                }
            }
        }
    }
}

/// poll(2) on the listener and the wake-up socket.
fn wait_readable(listener: &UnixListener, wake: &UnixStream, timeout_ms: i32) -> io::Result<()> {
    let mut fds = [
        libc::pollfd { fd: listener.as_raw_fd(), events: libc::POLLIN, revents: 0 },
        libc::pollfd { fd: wake.as_raw_fd(), events: libc::POLLIN, revents: 0 },
    ];
    // SAFETY: `fds` is a valid array of two pollfd that outlives the call, and both
    // descriptors are owned by live objects borrowed for the duration of the call.
    let r = unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, timeout_ms) };
    if r < 0 {
        let e = io::Error::last_os_error();
        if e.kind() != io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
    Ok(())
}

fn admit(inner: &Arc<Inner>, stream: UnixStream) {
    // accept(2) does not pass O_NONBLOCK on to the new socket on Linux, but be explicit: the
    // connection threads rely on blocking reads.
    if let Err(e) = stream.set_nonblocking(false) {
        tracing::warn!(error = %e, "cannot configure a control connection; closing it");
        return;
    }
    let id = inner.next_id.fetch_add(1, Ordering::Relaxed);
    let mut clients = lock(&inner.clients);
    if clients.len() >= inner.max_clients {
        drop(clients);
        inner.ctx.counters.rejected.fetch_add(1, Ordering::Relaxed);
        tracing::warn!(conn = id, max_clients = inner.max_clients, "too many control clients; refusing one");
        reject(stream, inner.max_clients);
        return;
    }
    let handle = match stream.try_clone() {
        Ok(h) => h,
        Err(e) => {
            tracing::warn!(error = %e, "cannot configure a control connection; closing it");
            return;
        }
    };
    clients.insert(id, Client { stream: handle, thread: None });
    drop(clients);
    inner.ctx.counters.connections.fetch_add(1, Ordering::Relaxed);
    let thread_inner = Arc::clone(inner);
    match thread::Builder::new()
        .name(format!("interpd-ctl-{id}"))
        .stack_size(CONNECTION_STACK_BYTES)
        .spawn(move || run_client(&thread_inner, id, stream))
    {
        Ok(h) => {
            // If the thread already ended and removed its entry, dropping the handle detaches
            // a finished thread.
            if let Some(c) = lock(&inner.clients).get_mut(&id) {
                c.thread = Some(h);
            }
        }
        Err(e) => {
            tracing::error!(conn = id, error = %e, "cannot start a thread for a control connection; closing it");
            if let Some(c) = lock(&inner.clients).remove(&id) {
                let _ = c.stream.shutdown(Shutdown::Both);
            }
        }
    }
}

/// Tells a client beyond `max_clients` why it is closed. The socket buffer of a new
/// connection is empty, so this small write does not block; the timeout is a safeguard for the
/// accept thread.
fn reject(mut stream: UnixStream, max: usize) {
    let _ = stream.set_write_timeout(Some(Duration::from_millis(100)));
    let mut line = encode(&Response::error(Id::Null, ErrorObject::too_many_clients(max)));
    line.push('\n');
    let _ = stream.write_all(line.as_bytes());
    let _ = stream.shutdown(Shutdown::Both);
}

// ---------------------------------------------------------------------------------------------
// One connection
// ---------------------------------------------------------------------------------------------

/// The body of a connection thread: serve, then the bookkeeping that must happen whatever
/// happened while serving.
fn run_client(inner: &Arc<Inner>, id: u64, stream: UnixStream) {
    tracing::debug!(conn = id, "control client connected");
    if catch_unwind(AssertUnwindSafe(|| serve(inner, id, stream))).is_err() {
        inner.ctx.counters.panics.fetch_add(1, Ordering::Relaxed);
        tracing::error!(conn = id, "control connection handler panicked; connection closed");
    }
    // Removing the entry closes the server's last handle on the socket.
    if let Some(c) = lock(&inner.clients).remove(&id) {
        let _ = c.stream.shutdown(Shutdown::Both);
    }
    if catch_unwind(AssertUnwindSafe(|| after_disconnect(inner, id))).is_err() {
        inner.ctx.counters.panics.fetch_add(1, Ordering::Relaxed);
        tracing::error!(conn = id, "the motion core panicked while handling a disconnect");
    }
    tracing::debug!(conn = id, "control client disconnected");
}

/// Serializes the writes of the request thread and the event thread, so lines never
/// interleave.
struct Writer {
    stream: Mutex<UnixStream>,
}

impl Writer {
    /// Writes one line. An error (including the write timeout) leaves a partial line on the
    /// wire, so the caller must close the connection.
    fn send(&self, mut line: String) -> io::Result<()> {
        line.push('\n');
        lock(&self.stream).write_all(line.as_bytes())
    }

    fn close(&self) {
        let _ = lock(&self.stream).shutdown(Shutdown::Both);
    }
}

fn serve(inner: &Arc<Inner>, id: u64, stream: UnixStream) {
    // The timeout is per socket, so it covers the writer's handle too.
    if let Err(e) = stream.set_write_timeout(Some(inner.write_timeout)) {
        tracing::warn!(conn = id, error = %e, "cannot configure a control connection; closing it");
        return;
    }
    let writer = match stream.try_clone() {
        Ok(s) => Arc::new(Writer { stream: Mutex::new(s) }),
        Err(e) => {
            tracing::warn!(conn = id, error = %e, "cannot configure a control connection; closing it");
            return;
        }
    };
    // Never sent on: dropping the sender when this function returns tells the event thread
    // that the connection is gone.
    let (closed_tx, closed_rx) = crossbeam::channel::bounded::<()>(0);
    let mut events: Option<JoinHandle<()>> = None;
    let mut session = Session::new(id);
    let mut lines = LineReader::new(&stream, MAX_LINE_BYTES);
    loop {
        let (line, last) = match lines.next_line() {
            Ok(Frame::Line(l)) => (l, false),
            Ok(Frame::Eof) => break,
            // A final line without newline (`printf '...' | socat`) is still a message; a
            // truncated request cannot parse, so it only gets a parse error.
            Ok(Frame::EofMidLine(l)) => (l, true),
            Ok(Frame::TooLong) => {
                inner.ctx.counters.requests.fetch_add(1, Ordering::Relaxed);
                inner.ctx.counters.errors.fetch_add(1, Ordering::Relaxed);
                tracing::warn!(conn = id, limit = MAX_LINE_BYTES, "request too large; closing the connection");
                let error = ErrorObject::request_too_large(MAX_LINE_BYTES);
                if writer.send(encode(&Response::error(Id::Null, error))).is_ok() {
                    let _ = stream.shutdown(Shutdown::Write);
                    drain(&stream);
                }
                break;
            }
            Err(e) => {
                tracing::debug!(conn = id, error = %e, "control connection read failed");
                break;
            }
        };
        if let Some(reply) = inner.ctx.handle_line(&mut session, &line) {
            if let Err(e) = writer.send(reply) {
                tracing::debug!(conn = id, error = %e, "cannot answer a control client; closing the connection");
                break;
            }
        }
        if let Some(rx) = session.new_subscription.take() {
            let (w, closed) = (Arc::clone(&writer), closed_rx.clone());
            match thread::Builder::new()
                .name(format!("interpd-ev-{id}"))
                .stack_size(EVENT_STACK_BYTES)
                .spawn(move || forward_events(id, &rx, &w, &closed))
            {
                Ok(h) => events = Some(h),
                Err(e) => {
                    tracing::error!(conn = id, error = %e, "cannot start the event thread; closing the connection");
                    break;
                }
            }
        }
        if last {
            break;
        }
    }
    writer.close();
    drop(closed_tx);
    if let Some(h) = events {
        if h.join().is_err() {
            inner.ctx.counters.panics.fetch_add(1, Ordering::Relaxed);
            tracing::error!(conn = id, "the event thread panicked");
        }
    }
}

/// Reads and discards what a client is still sending after a too-large request, for a bounded
/// time and amount.
fn drain(mut stream: &UnixStream) {
    if stream.set_read_timeout(Some(Duration::from_millis(100))).is_err() {
        return;
    }
    let deadline = Instant::now() + DRAIN_TIME;
    let mut buf = [0u8; 16 * 1024];
    let mut total = 0;
    while Instant::now() < deadline && total < DRAIN_BYTES {
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => total += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
}

/// The event thread of a subscribed connection: one notification line per event until the
/// client goes away, the service drops the sender, or a write fails (the client stopped
/// reading for longer than the write timeout).
fn forward_events(
    id: u64,
    events: &crossbeam::channel::Receiver<Event>,
    writer: &Writer,
    closed: &crossbeam::channel::Receiver<()>,
) {
    loop {
        crossbeam::select! {
            recv(events) -> ev => match ev {
                Ok(ev) => {
                    if let Err(e) = writer.send(encode(&ev.to_notification())) {
                        tracing::info!(conn = id, error = %e, "subscriber does not take events; disconnecting it");
                        writer.close();
                        return;
                    }
                }
                Err(_) => {
                    tracing::debug!(conn = id, "event source closed");
                    return;
                }
            },
            recv(closed) -> _ => return,
        }
    }
}

/// `stop_on_disconnect`: the connection that started the motion is gone.
fn after_disconnect(inner: &Inner, id: u64) {
    let was_owner = {
        let mut owner = lock(&inner.ctx.start_owner);
        let was = *owner == Some(id);
        if was {
            *owner = None;
        }
        was
    };
    // At shutdown the daemon decides how motion ends (SIGTERM: controlled stop).
    if !was_owner || inner.shutting_down.load(Ordering::Acquire) {
        return;
    }
    let state = inner.ctx.motion.status().state;
    if !matches!(state, State::Running | State::Holding) {
        return;
    }
    if !inner.stop_on_disconnect {
        tracing::info!(conn = id, %state, "the client that started the motion disconnected; motion continues");
        return;
    }
    tracing::warn!(conn = id, %state, "the client that started the motion disconnected; stopping (stop_on_disconnect)");
    let Ok(()) = inner.ctx.motion.stop();
}
