//! Replay: a recording's payloads republished on iceoryx2 at their original timing.
//!
//! Two passes over the file: [`scan`] validates every message first (so a corrupted file is
//! refused before anything is published, naming the bad message), then [`replay`] publishes
//! the exact recorded bytes (times included: a replay recorded again gives the same payloads)
//! at `start + (log_time − first log_time) / speed` on CLOCK_MONOTONIC.

use super::RecordError;
use super::file::read_messages;
use super::schema::{Payload, Stream};
use crate::rt::clock::{now_ns, sleep_until_ns};
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use interpd_protocol::shm::{Feedback, NodeOptions, Setpoints, open_service};
use std::fmt;
use std::path::Path;
use std::time::Duration;

/// Fastest accepted replay speed: at 1000× a 4 ms stream comes every 4 µs, already faster than
/// a subscriber polling its 64-sample queue every 10 ms can keep up with.
pub const MAX_SPEED: f64 = 1000.0;
/// Slowest accepted replay speed.
pub const MIN_SPEED: f64 = 1e-3;
/// Delay from the end of set-up to the first message.
const START_DELAY: Duration = Duration::from_millis(20);
/// The publishers stay this long after the last message, so subscribers that poll (up to every
/// 50 ms) take the last samples before the service loses its publisher.
const LINGER: Duration = Duration::from_millis(150);

/// What a recording holds (from the validation pass).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Scan {
    pub setpoints: u64,
    pub feedback: u64,
    pub first_log_ns: u64,
    pub last_log_ns: u64,
}

impl Scan {
    pub fn messages(&self) -> u64 {
        self.setpoints + self.feedback
    }

    /// Recorded time span, s.
    pub fn span_s(&self) -> f64 {
        self.last_log_ns.saturating_sub(self.first_log_ns) as f64 * 1e-9
    }
}

/// Reads and validates every message of `path`.
pub fn scan(path: &Path) -> Result<Scan, RecordError> {
    let mut scan = Scan { first_log_ns: u64::MAX, ..Scan::default() };
    for m in read_messages(path)? {
        let m = m?;
        match m.payload.stream() {
            Stream::Setpoints => scan.setpoints += 1,
            Stream::Feedback => scan.feedback += 1,
        }
        scan.first_log_ns = scan.first_log_ns.min(m.log_time_ns);
        scan.last_log_ns = scan.last_log_ns.max(m.log_time_ns);
    }
    if scan.messages() == 0 {
        return Err(RecordError::Empty { path: path.to_path_buf() });
    }
    Ok(scan)
}

/// Checks a replay speed factor.
pub fn check_speed(speed: f64) -> Result<(), String> {
    if speed.is_finite() && (MIN_SPEED..=MAX_SPEED).contains(&speed) {
        Ok(())
    } else {
        Err(format!("speed {speed} outside [{MIN_SPEED}, {MAX_SPEED}]"))
    }
}

/// What a replay did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ReplayReport {
    pub setpoints: u64,
    pub feedback: u64,
    /// Wall time from the first to the last message, s.
    pub wall_s: f64,
    /// Latest wake-up after a message's due time (the message is sent right after), µs.
    pub max_late_us: f64,
    /// Messages published more than 1 ms after their due time.
    pub late_over_1ms: u64,
}

impl fmt::Display for ReplayReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "replayed {} setpoints and {} feedback samples in {:.3} s; latest {:.0} µs after its due time, {} more than 1 ms late",
            self.setpoints, self.feedback, self.wall_s, self.max_late_us, self.late_over_1ms
        )
    }
}

struct Publishers {
    setpoints: Option<Publisher<ipc::Service, Setpoints, ()>>,
    feedback: Option<Publisher<ipc::Service, Feedback, ()>>,
    _node: Node<ipc::Service>,
}

fn publishers(prefix: &str, scan: &Scan) -> Result<Publishers, RecordError> {
    let setup = |e: &dyn std::error::Error| RecordError::Setup(e.to_string());
    let node = NodeOptions::new().name("interpd-replay").create().map_err(|e| setup(&e))?;
    let err = |what: &str, e: &dyn fmt::Debug| RecordError::Setup(format!("cannot publish on {prefix}/{what}: {e:?}"));
    let setpoints = if scan.setpoints > 0 {
        let service = open_service::<Setpoints>(&node, prefix).map_err(|e| setup(&e))?;
        Some(service.publisher_builder().create().map_err(|e| err("setpoints", &e))?)
    } else {
        None
    };
    let feedback = if scan.feedback > 0 {
        let service = open_service::<Feedback>(&node, prefix).map_err(|e| setup(&e))?;
        Some(service.publisher_builder().create().map_err(|e| err("feedback", &e))?)
    } else {
        None
    };
    Ok(Publishers { setpoints, feedback, _node: node })
}

fn send<T: fmt::Debug + ZeroCopySend + Copy + 'static>(
    publisher: Option<&Publisher<ipc::Service, T, ()>>,
    value: T,
) -> Result<(), RecordError> {
    let publisher =
        publisher.ok_or_else(|| RecordError::Transport("no publisher for a stream the scan did not see".into()))?;
    let sample = publisher.loan_uninit().map_err(|e| RecordError::Transport(format!("loan: {e:?}")))?;
    sample.write_payload(value).send().map_err(|e| RecordError::Transport(format!("send: {e:?}")))?;
    Ok(())
}

/// Publishes the messages of `path` (validated by `scan`) on `<prefix>/setpoints` and
/// `<prefix>/feedback` at their recorded timing divided by `speed`.
pub fn replay(path: &Path, scan: &Scan, prefix: &str, speed: f64) -> Result<ReplayReport, RecordError> {
    check_speed(speed).map_err(RecordError::Setup)?;
    let pubs = publishers(prefix, scan)?;
    let mut report = ReplayReport::default();
    let start_ns = now_ns() + START_DELAY.as_nanos() as u64;
    for m in read_messages(path)? {
        let m = m?;
        let offset_ns = (m.log_time_ns.saturating_sub(scan.first_log_ns) as f64 / speed).round() as u64;
        let due_ns = start_ns + offset_ns;
        sleep_until_ns(due_ns);
        let late_ns = now_ns().saturating_sub(due_ns);
        match m.payload {
            Payload::Setpoints(sp) => {
                send(pubs.setpoints.as_ref(), sp)?;
                report.setpoints += 1;
            }
            Payload::Feedback(fb) => {
                send(pubs.feedback.as_ref(), fb)?;
                report.feedback += 1;
            }
        }
        report.max_late_us = report.max_late_us.max(late_ns as f64 * 1e-3);
        if late_ns > 1_000_000 {
            report.late_over_1ms += 1;
        }
    }
    report.wall_s = now_ns().saturating_sub(start_ns) as f64 * 1e-9;
    std::thread::sleep(LINGER);
    Ok(report)
}
