//! Publishing outside the interpolation cycle. iceoryx2 0.10 allocates a small reference-
//! counted handle for every loaned sample, so publishing in the cycle would allocate in it.
//! The cycle therefore hands each setpoint to a publisher thread of its own through a
//! lock-free queue and wakes it (futex unpark: no lock, no allocation); that thread owns the
//! real sink and runs at the real-time priority one below the cycle's when permitted.

use super::{SetpointSink, SinkError};
use crossbeam::queue::ArrayQueue;
use interpd_protocol::shm::Setpoints;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{JoinHandle, Thread};

/// Setpoints the publisher thread may lag behind before setpoints are dropped (and counted).
pub const DEFERRED_QUEUE: usize = 256;

/// The cycle's side: queue and wake.
pub struct Deferred {
    queue: Arc<ArrayQueue<Setpoints>>,
    worker: Thread,
    shared: Arc<Shared>,
}

struct Shared {
    quit: AtomicBool,
    dropped: AtomicU64,
    failed: AtomicU64,
    published: AtomicU64,
}

/// The publisher thread; join it after dropping the [`Deferred`] side.
pub struct DeferredWorker {
    handle: Option<JoinHandle<()>>,
    shared: Arc<Shared>,
    waker: Thread,
}

/// Counters of a deferred sink.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeferredStats {
    pub published: u64,
    /// Setpoints dropped because the publisher thread lagged a whole queue behind.
    pub dropped: u64,
    /// Publish calls the sink refused.
    pub failed: u64,
}

impl SetpointSink for Deferred {
    fn publish(&mut self, setpoint: &Setpoints) -> Result<(), SinkError> {
        if self.queue.push(*setpoint).is_err() {
            self.shared.dropped.fetch_add(1, Ordering::Relaxed);
            return Err(SinkError::Publish);
        }
        self.worker.unpark();
        Ok(())
    }
}

/// Starts a publisher thread that creates its sink with `make` (in that thread) and publishes
/// what the cycle queues. `priority` > 0 asks for SCHED_FIFO at that priority.
pub fn spawn<S, F>(name: &str, priority: i32, make: F) -> Result<(Deferred, DeferredWorker), SinkError>
where
    S: SetpointSink + 'static,
    F: FnOnce() -> Result<S, SinkError> + Send + 'static,
{
    let queue = Arc::new(ArrayQueue::new(DEFERRED_QUEUE));
    let shared = Arc::new(Shared {
        quit: AtomicBool::new(false),
        dropped: AtomicU64::new(0),
        failed: AtomicU64::new(0),
        published: AtomicU64::new(0),
    });
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let (q, sh) = (queue.clone(), shared.clone());
    let handle = std::thread::Builder::new()
        .name(format!("interpd-{name}"))
        .spawn(move || {
            if priority > 0 {
                let param = libc::sched_param { sched_priority: priority };
                // SAFETY: plain syscall on this thread; refusal is fine (normal scheduling).
                unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
            }
            let mut sink = match make() {
                Ok(s) => {
                    let _ = ready_tx.send(Ok(()));
                    s
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            while !sh.quit.load(Ordering::Acquire) {
                while let Some(sp) = q.pop() {
                    match sink.publish(&sp) {
                        Ok(()) => sh.published.fetch_add(1, Ordering::Relaxed),
                        Err(_) => sh.failed.fetch_add(1, Ordering::Relaxed),
                    };
                }
                std::thread::park();
            }
            while let Some(sp) = q.pop() {
                let _ = sink.publish(&sp);
            }
        })
        .map_err(|e| SinkError::Setup {
            sink: name.into(),
            message: format!("cannot start the publisher thread: {e}"),
        })?;
    match ready_rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            let _ = handle.join();
            return Err(e);
        }
        Err(_) => {
            return Err(SinkError::Setup {
                sink: name.into(),
                message: "publisher thread ended during start-up".into(),
            });
        }
    }
    let worker = handle.thread().clone();
    Ok((
        Deferred { queue, worker: worker.clone(), shared: shared.clone() },
        DeferredWorker { handle: Some(handle), shared, waker: worker },
    ))
}

impl DeferredWorker {
    pub fn stats(&self) -> DeferredStats {
        DeferredStats {
            published: self.shared.published.load(Ordering::Relaxed),
            dropped: self.shared.dropped.load(Ordering::Relaxed),
            failed: self.shared.failed.load(Ordering::Relaxed),
        }
    }

    /// Publishes what is queued, stops the thread, returns the counters.
    pub fn stop(mut self) -> DeferredStats {
        self.shared.quit.store(true, Ordering::Release);
        self.waker.unpark();
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
        self.stats()
    }
}
