//! The real-time loop: one cycle every period at absolute deadlines (clock_nanosleep with
//! TIMER_ABSTIME), timing measured every cycle, late cycles caught up in order.
//!
//! A cycle that wakes late is still computed for its own deadline, and cycles whose deadlines
//! passed while the thread slept are computed at once, in order, so every cycle number gets
//! exactly one result (flagged late). Timing samples leave through a lock-free queue; the
//! histograms live in another thread ([`stats`]).

pub mod clock;
pub mod sched;
pub mod stats;

use crossbeam::queue::ArrayQueue;
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

thread_local! {
    /// Set while the calling thread computes a real-time cycle. A test's counting allocator
    /// reads it to prove that the cycle never allocates (daemon/tests/rt_no_alloc.rs).
    pub static IN_CYCLE: Cell<bool> = const { Cell::new(false) };
}

/// One wake-up of the loop.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TimingSample {
    /// Wake-up time minus the deadline slept for, ns.
    pub wakeup_ns: u64,
    /// Time to compute the cycle slept for, ns.
    pub compute_ns: u64,
    /// Cycles computed late in this wake-up (caught up), 0 if on time.
    pub late_cycles: u32,
    /// The computation of the last cycle of this wake-up ended after the next deadline.
    pub overrun: bool,
}

/// Totals of a loop run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoopTotals {
    pub cycles: u64,
    pub late_cycles: u64,
    pub overruns: u64,
    /// Timing samples dropped because their queue was full.
    pub samples_dropped: u64,
}

/// Runs `body(cycle, deadline_ns, late)` for cycle 0, 1, 2, … with deadlines
/// `start_ns + cycle · period_ns` until `body` returns false or `quit` is set.
pub fn run_loop(
    start_ns: u64,
    period_ns: u64,
    quit: &AtomicBool,
    samples: &ArrayQueue<TimingSample>,
    mut body: impl FnMut(u64, u64, bool) -> bool,
) -> LoopTotals {
    let mut totals = LoopTotals::default();
    let mut cycle: u64 = 0;
    loop {
        let deadline = start_ns + cycle * period_ns;
        clock::sleep_until_ns(deadline);
        let wake = clock::now_ns();
        let mut sample = TimingSample { wakeup_ns: wake.saturating_sub(deadline), ..TimingSample::default() };
        // Every deadline that has passed by now is due: the one slept for and any missed.
        let due_until = cycle + (wake.saturating_sub(deadline)) / period_ns;
        let mut go_on = true;
        while cycle <= due_until {
            let begin = clock::now_ns();
            // Late: computed after the next deadline had passed.
            let late = begin > start_ns + (cycle + 1) * period_ns;
            IN_CYCLE.with(|c| c.set(true));
            go_on = body(cycle, start_ns + cycle * period_ns, late);
            IN_CYCLE.with(|c| c.set(false));
            let end = clock::now_ns();
            if sample.compute_ns == 0 {
                sample.compute_ns = end - begin;
            }
            if late {
                sample.late_cycles += 1;
            }
            cycle += 1;
            totals.cycles += 1;
            if !go_on || quit.load(Ordering::Relaxed) {
                go_on = false;
                break;
            }
        }
        if clock::now_ns() > start_ns + cycle * period_ns {
            sample.overrun = true;
            totals.overruns += 1;
        }
        totals.late_cycles += u64::from(sample.late_cycles);
        if samples.push(sample).is_err() {
            totals.samples_dropped += 1;
        }
        if !go_on {
            return totals;
        }
    }
}
