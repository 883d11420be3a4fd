//! The CPU hog of the loaded scenarios: a thread of normal priority pinned to one CPU that
//! never sleeps. It writes through a buffer larger than the per-core caches, so besides taking
//! the CPU it also evicts shared cache lines and loads the memory bus, as a busy neighbour
//! process would.

use super::cpu;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Instant;

/// Bytes the hog writes through per pass (larger than the L2 of common cores).
const HOG_BUFFER_BYTES: usize = 4 << 20;
/// Stride of the writes: one cache line.
const CACHE_LINE_BYTES: usize = 64;

/// A running hog.
pub struct Hog {
    quit: Arc<AtomicBool>,
    handle: JoinHandle<HogReport>,
}

/// What the hog did.
#[derive(Debug, Clone)]
pub struct HogReport {
    /// The CPU it was pinned to, or why pinning failed.
    pub pinned: Result<usize, String>,
    /// Passes over the buffer per second of wall time (shows that it really ran).
    pub passes_per_s: f64,
}

impl Hog {
    /// Starts the hog on `cpu_index`.
    pub fn start(cpu_index: usize) -> Hog {
        let quit = Arc::new(AtomicBool::new(false));
        let q = quit.clone();
        let handle = std::thread::Builder::new()
            .name("rt-bench-hog".into())
            .spawn(move || {
                let pinned = cpu::pin_current_thread(cpu_index);
                let mut buf = vec![0u8; HOG_BUFFER_BYTES];
                let (t0, mut passes) = (Instant::now(), 0u64);
                while !q.load(Ordering::Relaxed) {
                    for i in (0..buf.len()).step_by(CACHE_LINE_BYTES) {
                        buf[i] = buf[i].wrapping_add(1);
                    }
                    std::hint::black_box(&mut buf);
                    passes += 1;
                }
                HogReport { pinned, passes_per_s: passes as f64 / t0.elapsed().as_secs_f64() }
            })
            .expect("cannot start the hog thread");
        Hog { quit, handle }
    }

    /// Stops the hog and reports.
    pub fn stop(self) -> HogReport {
        self.quit.store(true, Ordering::Relaxed);
        self.handle.join().expect("the hog thread panicked")
    }
}
