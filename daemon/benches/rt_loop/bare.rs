//! The baseline: the daemon's own loop (`rt::run_loop`: clock_nanosleep to absolute deadlines,
//! the same timing samples) in a thread scheduled exactly as the daemon's real-time thread
//! (`rt::sched::apply` with the same `[rt]` settings), whose cycle is a fixed synthetic
//! computation of about interpd's median cycle length (`work`). What it measures is the
//! machine: timer, scheduler and hypervisor, without any interpd code.

use super::work::work;
use crossbeam::queue::ArrayQueue;
use interpd::config::RtConfig;
use interpd::rt::{self, LoopTotals, TimingSample, sched::SchedReport};
use std::sync::atomic::AtomicBool;

/// Delay from the start of the thread to the first deadline (as the daemon's).
const FIRST_CYCLE_DELAY_NS: u64 = 20_000_000;

/// One bare run.
pub struct BareRun {
    pub sched: SchedReport,
    pub totals: LoopTotals,
    pub samples: Vec<TimingSample>,
}

/// Runs `cycles` cycles of `period_ns`, each [`work`]`(work_iters)`, with the scheduling `rt`.
pub fn run(rt_cfg: &RtConfig, period_ns: u64, cycles: u64, work_iters: u64) -> BareRun {
    let rt_cfg = rt_cfg.clone();
    std::thread::Builder::new()
        .name("rt-bench-bare".into())
        .spawn(move || {
            let sched = rt::sched::apply(&rt_cfg);
            // One sample per wake-up at most: room for all of them, nothing is dropped.
            let queue = ArrayQueue::new(cycles.max(1) as usize);
            let quit = AtomicBool::new(false);
            let start_ns = rt::clock::now_ns() + FIRST_CYCLE_DELAY_NS;
            let totals = rt::run_loop(start_ns, period_ns, &quit, &queue, |cycle, _, _| {
                std::hint::black_box(work(work_iters));
                cycle + 1 < cycles
            });
            let samples = std::iter::from_fn(|| queue.pop()).collect();
            BareRun { sched, totals, samples }
        })
        .expect("cannot start the bare loop thread")
        .join()
        .expect("the bare loop thread panicked")
}
