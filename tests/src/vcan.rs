//! Helpers for tests over a real SocketCAN interface (`INTERPD_VCAN`, see scripts/vcan-vm.sh):
//! the bus lock, sockets, a capture with kernel timestamps, and child processes whose stderr
//! is kept in a file.

use interpd_protocol::can_socket::{from_socketcan, to_socketcan};
use interpd_protocol::cia301::Frame;
use socketcan::{CanSocket, Socket, SocketOptions};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant, SystemTime};

/// Serialises the tests of one binary: they share the bus.
static BUS: Mutex<()> = Mutex::new(());

/// The interface under test and the bus lock, or `None` (with a note) when CAN tests are off.
pub fn bus(test: &str) -> Option<(String, MutexGuard<'static, ()>)> {
    match std::env::var("INTERPD_VCAN") {
        Ok(iface) if !iface.is_empty() => Some((iface, BUS.lock().unwrap_or_else(|p| p.into_inner()))),
        _ => {
            eprintln!(
                "note: {test} skipped: INTERPD_VCAN is not set (run scripts/vcan-vm.sh, which uses the host's vcan0 \
                 or boots a VM with one)"
            );
            None
        }
    }
}

/// A socket on `iface` with a read timeout.
pub fn open(iface: &str, timeout: Duration) -> CanSocket {
    let s = CanSocket::open(iface).unwrap_or_else(|e| panic!("cannot open CAN interface {iface}: {e}"));
    s.set_read_timeout(timeout).expect("set read timeout");
    s
}

/// Sends a frame, retrying briefly on a full queue.
pub fn send(sock: &CanSocket, f: &Frame) {
    let frame = to_socketcan(f).expect("a sendable frame");
    for _ in 0..200 {
        match sock.write_frame(&frame) {
            Ok(()) => return,
            Err(e) if e.raw_os_error() == Some(105) => thread::sleep(Duration::from_millis(1)),
            Err(e) => panic!("send {f:?}: {e}"),
        }
    }
    panic!("send {f:?}: the queue stayed full");
}

/// Every frame on the bus with the kernel's receive timestamp, captured in a thread.
pub struct Capture {
    stop: Arc<AtomicBool>,
    frames: Arc<Mutex<Vec<(SystemTime, Frame)>>>,
    handle: Option<thread::JoinHandle<()>>,
}

impl Capture {
    pub fn start(iface: &str) -> Capture {
        let sock = open(iface, Duration::from_millis(20));
        sock.set_recv_timestamp(true).expect("SO_TIMESTAMPNS");
        // A large receive buffer: a slow emulated CPU must not drop frames here.
        let _ = sock.set_socket_option_int(libc::SOL_SOCKET, libc::SO_RCVBUF, 4 << 20);
        let stop = Arc::new(AtomicBool::new(false));
        let frames = Arc::new(Mutex::new(Vec::new()));
        let (flag, out) = (stop.clone(), frames.clone());
        let handle = thread::spawn(move || {
            let mut batch = Vec::new();
            loop {
                match sock.read_frame_with_timestamps() {
                    Ok((f, ts)) => {
                        let frame = from_socketcan(&f).expect("kernel frames are valid");
                        batch.push((ts.socket.unwrap_or_else(SystemTime::now), frame));
                        if batch.len() >= 64 {
                            out.lock().expect("frames").append(&mut batch);
                        }
                    }
                    Err(_) => {
                        out.lock().expect("frames").append(&mut batch);
                        if flag.load(Ordering::Acquire) {
                            return;
                        }
                    }
                }
            }
        });
        Capture { stop, frames, handle: Some(handle) }
    }

    /// The frames so far.
    pub fn snapshot(&self) -> Vec<(SystemTime, Frame)> {
        self.frames.lock().expect("frames").clone()
    }

    /// Waits until `pred` holds for the frames so far, or `timeout`.
    pub fn wait_for(&self, timeout: Duration, pred: impl Fn(&[(SystemTime, Frame)]) -> bool) -> bool {
        let until = Instant::now() + timeout;
        while Instant::now() < until {
            if pred(&self.frames.lock().expect("frames")) {
                return true;
            }
            thread::sleep(Duration::from_millis(20));
        }
        false
    }

    /// Stops once the bus has been quiet for one read timeout; returns everything.
    pub fn finish(mut self) -> Vec<(SystemTime, Frame)> {
        self.stop.store(true, Ordering::Release);
        if let Some(h) = self.handle.take() {
            h.join().expect("capture thread");
        }
        std::mem::take(&mut *self.frames.lock().expect("frames"))
    }
}

/// A child process with its stderr in a file; SIGTERM and wait on drop.
pub struct Proc {
    child: Option<Child>,
    log: PathBuf,
    name: String,
}

impl Proc {
    /// Starts `bin` (see [`crate::binary`]) with `args`, stderr into `dir/<name>.stderr`.
    pub fn start(bin: &str, args: &[&str], dir: &Path) -> Proc {
        let log = dir.join(format!("{bin}.stderr"));
        let err = std::fs::File::create(&log).expect("stderr file");
        let child = Command::new(crate::binary(bin))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::from(err))
            .spawn()
            .unwrap_or_else(|e| panic!("start {bin}: {e}"));
        Proc { child: Some(child), log, name: bin.to_string() }
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Waits until stderr contains `text`; panics with the stderr after `timeout`.
    pub fn wait_for_stderr(&mut self, text: &str, timeout: Duration) {
        let until = Instant::now() + timeout;
        while !self.stderr().contains(text) {
            if let Some(Ok(Some(status))) = self.child.as_mut().map(Child::try_wait) {
                panic!("{} exited ({status}) before printing {text:?}:\n{}", self.name, self.stderr());
            }
            assert!(
                Instant::now() < until,
                "{} did not print {text:?} within {timeout:?}:\n{}",
                self.name,
                self.stderr()
            );
            thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether it is still running.
    pub fn alive(&mut self) -> bool {
        matches!(self.child.as_mut().map(Child::try_wait), Some(Ok(None)))
    }

    /// SIGTERM, wait; returns the exit code and stderr.
    pub fn terminate(mut self) -> (Option<i32>, String) {
        let child = self.child.take().expect("running");
        // SAFETY: kill(2) on our own child.
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        let out = child.wait_with_output().expect("wait");
        (out.status.code(), self.stderr())
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            // SAFETY: as above.
            unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
            let _ = c.wait();
        }
    }
}

/// A fresh temporary directory for one test.
pub fn temp_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::AtomicU64;
    static N: AtomicU64 = AtomicU64::new(0);
    let dir =
        std::env::temp_dir().join(format!("interpd-{tag}-{}-{}", std::process::id(), N.fetch_add(1, Ordering::SeqCst)));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
