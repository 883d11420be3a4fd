//! Synthetic cycle work for the bare loop: a fixed amount of floating-point work, calibrated
//! once to last about as long as interpd's median cycle. Its compute-time quantiles are what
//! the machine does to a fixed computation of that length (host preemption, interrupts, cache
//! misses after a sleep), the baseline for interpd's compute-time quantiles.

use interpd::rt::clock;
use std::hint::black_box;

/// Target duration of the synthetic work, µs: about interpd's median cycle compute time for 3
/// and 5 axes (the p50 of the "cycle compute" row this benchmark prints for the service).
pub const WORK_TARGET_US: f64 = 25.0;
/// Iterations timed per calibration probe.
const PROBE_ITERS: u64 = 20_000;
/// Probes timed; the fastest one counts (the others were disturbed).
const PROBES: usize = 50;

/// A computation of `iters` dependent multiply-adds that the optimiser cannot remove.
pub fn work(iters: u64) -> f64 {
    let mut x = black_box(1.0f64);
    for _ in 0..iters {
        x = black_box(x.mul_add(0.999_999_9, 1e-9));
    }
    x
}

/// Iterations of [`work`] that take [`WORK_TARGET_US`] on this machine (fastest of several
/// probes, so a disturbance during calibration does not shorten the work).
pub fn calibrate() -> u64 {
    let best_ns = (0..PROBES)
        .map(|_| {
            let t0 = clock::now_ns();
            black_box(work(PROBE_ITERS));
            clock::now_ns() - t0
        })
        .min()
        .unwrap_or(1)
        .max(1);
    let ns_per_iter = best_ns as f64 / PROBE_ITERS as f64;
    (WORK_TARGET_US * 1e3 / ns_per_iter).round().max(1.0) as u64
}
