//! One connection: its thread reads requests line by line (at most one line of
//! [`MAX_LINE_BYTES`] held) and writes the answers; once the client subscribes, a second thread
//! forwards events. Both write through one lock, so lines never interleave, and a client that
//! does not read for the write timeout is disconnected. When the connection ends,
//! `stop_on_disconnect` applies.

use super::dispatch::{Session, encode};
use super::framing::{Frame, LineReader};
use super::shared::{Inner, lock};
use interpd_protocol::api::{Event, State};
use interpd_protocol::jsonrpc::{ErrorObject, Id, MAX_LINE_BYTES, Response};
use std::io::{self, Read, Write};
use std::net::Shutdown;
use std::os::unix::net::UnixStream;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

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

/// The body of a connection thread: serve, then the bookkeeping that must happen whatever
/// happened while serving.
pub(super) fn run_client(inner: &Arc<Inner>, id: u64, stream: UnixStream) {
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
