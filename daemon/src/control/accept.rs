//! Accepting: the accept thread sleeps in poll(2) on the listener and a wake-up socket (which
//! [`ControlServer::shutdown`](super::ControlServer::shutdown) writes to), gives each admitted
//! client a connection thread, and refuses clients beyond `max_clients` with −32004.

use super::connection::{CONNECTION_STACK_BYTES, run_client};
use super::dispatch::encode;
use super::shared::{Client, Inner, lock};
use interpd_protocol::jsonrpc::{ErrorObject, Id, Response};
use std::io::{self, Write};
use std::net::Shutdown;
use std::os::fd::AsRawFd;
use std::os::unix::net::{UnixListener, UnixStream};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::thread;
use std::time::Duration;

pub(super) fn accept_loop(inner: &Arc<Inner>, listener: UnixListener, wake: UnixStream) {
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
