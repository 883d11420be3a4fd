//! Cycle timing statistics: the real-time thread hands one [`TimingSample`] per wake-up
//! through a lock-free queue; this side, outside the cycle, keeps the histograms (hdrhistogram)
//! and turns them into the percentiles of `status` and the report at exit.

use super::TimingSample;
use hdrhistogram::Histogram;
use interpd_protocol::api::{CycleStats, Percentiles};
use std::fmt;

/// Highest value the histograms hold, ns (10 s: anything slower is clamped).
const MAX_TRACKED_NS: u64 = 10_000_000_000;
/// Significant decimal digits of the histograms.
const SIGNIFICANT_DIGITS: u8 = 3;

/// Wake-up latency and compute time histograms, with late and overrun counts.
#[derive(Debug, Clone)]
pub struct CycleHistograms {
    wakeup: Histogram<u64>,
    compute: Histogram<u64>,
    pub late_cycles: u64,
    pub overruns: u64,
    pub samples: u64,
}

impl Default for CycleHistograms {
    fn default() -> Self {
        Self::new()
    }
}

impl CycleHistograms {
    pub fn new() -> Self {
        let h = || Histogram::new_with_bounds(1, MAX_TRACKED_NS, SIGNIFICANT_DIGITS).expect("valid histogram bounds");
        Self { wakeup: h(), compute: h(), late_cycles: 0, overruns: 0, samples: 0 }
    }

    pub fn record(&mut self, s: &TimingSample) {
        self.wakeup.saturating_record(s.wakeup_ns.max(1));
        self.compute.saturating_record(s.compute_ns.max(1));
        self.late_cycles += u64::from(s.late_cycles);
        self.overruns += u64::from(s.overrun);
        self.samples += 1;
    }

    /// Wake-up latency percentiles, µs.
    pub fn wakeup_us(&self) -> Percentiles {
        percentiles_us(&self.wakeup)
    }

    /// Compute time percentiles, µs.
    pub fn compute_us(&self) -> Percentiles {
        percentiles_us(&self.compute)
    }

    /// The `status` form.
    pub fn cycle_stats(&self) -> CycleStats {
        CycleStats {
            wakeup_us: self.wakeup_us(),
            compute_us: self.compute_us(),
            overruns: self.overruns,
            late: self.late_cycles,
        }
    }
}

fn percentiles_us(h: &Histogram<u64>) -> Percentiles {
    if h.is_empty() {
        return Percentiles::default();
    }
    let us = |ns: u64| ns as f64 / 1000.0;
    Percentiles {
        p50: us(h.value_at_quantile(0.5)),
        p99: us(h.value_at_quantile(0.99)),
        p999: us(h.value_at_quantile(0.999)),
        max: us(h.max()),
    }
}

impl fmt::Display for CycleHistograms {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (w, c) = (self.wakeup_us(), self.compute_us());
        write!(
            f,
            "{} wake-ups: wake-up latency p50 {:.1} µs, p99 {:.1} µs, p99.9 {:.1} µs, max {:.1} µs; \
             compute p50 {:.1} µs, p99.9 {:.1} µs, max {:.1} µs; {} late cycles, {} overruns",
            self.samples, w.p50, w.p99, w.p999, w.max, c.p50, c.p999, c.max, self.late_cycles, self.overruns
        )
    }
}
