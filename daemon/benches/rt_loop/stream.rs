//! The subscriber side of the benchmark, in a real-time thread of its own on the other CPU:
//!
//! - **stream check**: every setpoint received on `<prefix>/setpoints` is checked against the
//!   contract of a late wake-up: cycle numbers without gaps or repeats, `time_ns` = the
//!   cycle's own deadline (start + cycle · period), late ones flagged `LATE`;
//! - **shared-memory latency**: receive time − `publish_ns` (both CLOCK_MONOTONIC). The
//!   subscriber has no notification to wait on (the wire contract is polling), so it sleeps to
//!   shortly before each cycle's deadline and then polls without sleeping until that cycle's
//!   setpoint is there: the time it sees the sample is its arrival time to within one poll
//!   (< 1 µs). A sample that was already waiting at the first poll after a wake-up (the
//!   subscriber itself woke late) has no known arrival time: it is checked but kept out of the
//!   latency figures, and counted.

use super::cpu;
use hdrhistogram::Histogram;
use interpd::rt::clock;
use interpd_protocol::shm::{NodeOptions, Setpoints, flags, open_service, qos};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

/// The subscriber wakes this long before a deadline to be polling when the setpoint comes.
const LEAD_NS: u64 = 100_000;
/// Poll period before the first setpoint has told the subscriber where the deadlines lie.
const SEARCH_POLL_NS: u64 = 500_000;
/// Latency histogram range, ns.
const MAX_LATENCY_NS: u64 = 1_000_000_000;

/// The checks and figures of one run.
#[derive(Debug, Clone)]
pub struct StreamCheck {
    pub received: u64,
    pub first_cycle: Option<u64>,
    pub last_cycle: Option<u64>,
    /// Cycle numbers skipped between consecutive samples.
    pub missing: u64,
    /// Samples whose cycle number was not above the previous one.
    pub repeated: u64,
    /// Samples whose `time_ns` was not start + cycle · period.
    pub wrong_time: u64,
    /// Samples flagged `LATE`.
    pub late_flagged: u64,
    /// publish → receive, ns, over the samples whose arrival was seen.
    pub latency_ns: Histogram<u64>,
    /// Samples already waiting when the subscriber polled first (no arrival time).
    pub latency_unseen: u64,
    pub sched: Result<i32, String>,
    pub pinned: Result<usize, String>,
}

impl StreamCheck {
    fn new() -> Self {
        Self {
            received: 0,
            first_cycle: None,
            last_cycle: None,
            missing: 0,
            repeated: 0,
            wrong_time: 0,
            late_flagged: 0,
            latency_ns: Histogram::new_with_bounds(1, MAX_LATENCY_NS, 3).expect("valid histogram bounds"),
            latency_unseen: 0,
            sched: Err("not set".into()),
            pinned: Err("not set".into()),
        }
    }

    /// Checks one sample; `start_ns` is the time of cycle 0.
    fn check(&mut self, sp: &Setpoints, start_ns: u64, period_ns: u64) {
        self.received += 1;
        self.first_cycle.get_or_insert(sp.cycle);
        match self.last_cycle {
            Some(last) if sp.cycle <= last => self.repeated += 1,
            Some(last) => self.missing += sp.cycle - last - 1,
            None => {}
        }
        if self.last_cycle.is_none_or(|last| sp.cycle > last) {
            self.last_cycle = Some(sp.cycle);
        }
        if sp.time_ns != start_ns + sp.cycle * period_ns {
            self.wrong_time += 1;
        }
        if sp.flags & flags::LATE != 0 {
            self.late_flagged += 1;
        }
    }

    /// Every cycle 0..cycles received exactly once, each for its own time.
    pub fn complete(&self, cycles: u64) -> bool {
        self.first_cycle == Some(0)
            && self.last_cycle == Some(cycles.saturating_sub(1))
            && self.missing == 0
            && self.repeated == 0
            && self.wrong_time == 0
            && self.received == cycles
    }
}

/// The running subscriber thread.
pub struct Monitor {
    quit: Arc<AtomicBool>,
    handle: JoinHandle<Result<StreamCheck, String>>,
}

impl Monitor {
    /// Subscribes to `<prefix>/setpoints` and starts checking; returns once subscribed (before
    /// the daemon publishes, so cycle 0 is seen).
    pub fn start(prefix: &str, period_ns: u64, cpu_index: usize, priority: i32) -> Result<Monitor, String> {
        let quit = Arc::new(AtomicBool::new(false));
        let (q, prefix) = (quit.clone(), prefix.to_string());
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let handle = std::thread::Builder::new()
            .name("rt-bench-sub".into())
            .spawn(move || {
                let mut check = StreamCheck::new();
                check.pinned = cpu::pin_current_thread(cpu_index);
                check.sched = cpu::set_fifo(priority);
                let node = NodeOptions::new().name("rt-bench").create().map_err(|e| e.to_string())?;
                let service = open_service::<Setpoints>(&node, &prefix).map_err(|e| e.to_string())?;
                let sub = service
                    .subscriber_builder()
                    .buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
                    .create()
                    .map_err(|e| format!("cannot create the subscriber: {e:?}"))?;
                let _ = ready_tx.send(());
                let mut poll = || sub.receive().map(|s| s.map(|s| *s)).map_err(|e| format!("receive: {e:?}"));
                watch(&mut poll, &q, period_ns, &mut check)?;
                Ok(check)
            })
            .map_err(|e| format!("cannot start the subscriber thread: {e}"))?;
        match ready_rx.recv() {
            Ok(()) => Ok(Monitor { quit, handle }),
            Err(_) => {
                Err(handle.join().map_err(|_| "the subscriber thread panicked".to_string())?.err().unwrap_or_default())
            }
        }
    }

    /// Receives what is still queued, stops and returns the checks.
    pub fn finish(self) -> Result<StreamCheck, String> {
        self.quit.store(true, Ordering::SeqCst);
        self.handle.join().map_err(|_| "the subscriber thread panicked".to_string())?
    }
}

type Poll<'a> = dyn FnMut() -> Result<Option<Setpoints>, String> + 'a;

/// The subscriber loop: find the deadlines from the first sample, then wake before each one
/// and poll until its setpoint is there (or the next deadline comes).
fn watch(poll: &mut Poll, quit: &AtomicBool, period_ns: u64, check: &mut StreamCheck) -> Result<(), String> {
    let start_ns = loop {
        if quit.load(Ordering::SeqCst) {
            return Ok(());
        }
        if let Some(sp) = poll()? {
            let start_ns = sp.time_ns - sp.cycle * period_ns;
            check.check(&sp, start_ns, period_ns);
            check.latency_unseen += 1;
            break start_ns;
        }
        clock::sleep_until_ns(clock::now_ns() + SEARCH_POLL_NS);
    };
    let mut wake_cycle = check.last_cycle.unwrap_or(0) + 1;
    while !quit.load(Ordering::SeqCst) {
        let deadline = start_ns + wake_cycle * period_ns;
        clock::sleep_until_ns(deadline.saturating_sub(LEAD_NS));
        let give_up = deadline + period_ns;
        let mut first_poll = true;
        loop {
            let got = poll()?;
            let now = clock::now_ns();
            match got {
                Some(sp) => {
                    check.check(&sp, start_ns, period_ns);
                    if first_poll {
                        check.latency_unseen += 1;
                    } else {
                        check.latency_ns.saturating_record(now.saturating_sub(sp.publish_ns).max(1));
                    }
                    if sp.cycle >= wake_cycle {
                        break;
                    }
                }
                None if now > give_up || quit.load(Ordering::Relaxed) => break,
                None => {
                    first_poll = false;
                    std::hint::spin_loop();
                }
            }
        }
        wake_cycle = (wake_cycle + 1).max(check.last_cycle.map_or(0, |c| c + 1));
    }
    // The daemon has shut down: whatever is still queued.
    while let Some(sp) = poll()? {
        check.check(&sp, start_ns, period_ns);
        check.latency_unseen += 1;
    }
    Ok(())
}
