//! How the planner thread keeps up (`status.lookahead`) and its totals.

use interpd_protocol::api::LookaheadStatus;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// How the planner thread kept up in the current motion (`status.lookahead`): it writes, the
/// control thread reads.
#[derive(Debug)]
pub struct LookaheadHealth {
    step_max_ns: AtomicU64,
    /// Least chunks queued when a step began; `u64::MAX` before the queue first reached its depth.
    queue_min_chunks: AtomicU64,
}

impl Default for LookaheadHealth {
    fn default() -> Self {
        Self { step_max_ns: AtomicU64::new(0), queue_min_chunks: AtomicU64::new(u64::MAX) }
    }
}

impl LookaheadHealth {
    pub(super) fn reset(&self) {
        self.step_max_ns.store(0, Ordering::Relaxed);
        self.queue_min_chunks.store(u64::MAX, Ordering::Relaxed);
    }

    pub(super) fn step(&self, took: Duration) {
        self.step_max_ns.fetch_max(u64::try_from(took.as_nanos()).unwrap_or(u64::MAX), Ordering::Relaxed);
    }

    pub(super) fn queued(&self, chunks: usize) {
        self.queue_min_chunks.fetch_min(chunks as u64, Ordering::Relaxed);
    }

    /// The figures for `status`, with chunks of `chunk_s` seconds.
    pub fn status(&self, chunk_s: f64) -> LookaheadStatus {
        let min = self.queue_min_chunks.load(Ordering::Relaxed);
        LookaheadStatus {
            step_max_ms: self.step_max_ns.load(Ordering::Relaxed) as f64 * 1e-6,
            queue_min_s: (min != u64::MAX).then_some(min as f64 * chunk_s),
        }
    }
}

/// Totals of the planner thread.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeederStats {
    pub chunks: u64,
    pub coarse_points: u64,
    pub max_coarse_error_mm: f64,
    pub replans: u64,
    pub plan_time_s: f64,
    /// Chunk ends moved later because no stop could follow them.
    pub tail_retries: u64,
    /// Planning failures in motion recovered by stopping along the path and replanning.
    pub recoveries: u64,
}
