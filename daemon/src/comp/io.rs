//! The compensation stage's shared-memory side: a thread of its own subscribes to
//! `<prefix>/measurement` and publishes `<prefix>/actuator` (iceoryx2 ports allocate on receive
//! and loan, so they stay out of the real-time cycle). The cycle exchanges samples with it
//! through two lock-free queues and wakes it after queueing an actuator command.

use crossbeam::queue::ArrayQueue;
use interpd_protocol::shm::{ActuatorCommand, Measurement, NodeOptions, open_service, qos};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{JoinHandle, Thread};
use std::time::Duration;

/// Measurements queued for the cycle: 64 (the plant sends about two per 4 ms cycle).
const QUEUE: usize = 64;
/// Poll period of the measurement subscriber: a sample waits at most this before the cycle can
/// take it.
const POLL: Duration = Duration::from_micros(200);

/// The cycle's side.
pub struct CompIo {
    pub measurements: Arc<ArrayQueue<Measurement>>,
    actuator: Arc<ArrayQueue<ActuatorCommand>>,
    worker: Thread,
}

impl CompIo {
    /// Queues an actuator command and wakes the publisher (no allocation, no lock).
    pub fn send_actuator(&self, c: &ActuatorCommand) {
        if self.actuator.push(*c).is_err() {
            // The thread is a whole queue behind: the newest command replaces the oldest.
            let _ = self.actuator.pop();
            let _ = self.actuator.push(*c);
        }
        self.worker.unpark();
    }
}

/// The thread; stops when dropped.
pub struct CompIoWorker {
    handle: Option<JoinHandle<()>>,
    quit: Arc<AtomicBool>,
    /// Measurements dropped because the cycle did not take them.
    pub dropped: Arc<AtomicU64>,
}

impl Drop for CompIoWorker {
    fn drop(&mut self) {
        self.quit.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            h.thread().unpark();
            let _ = h.join();
        }
    }
}

/// Starts the thread on `prefix`; `actuator`: also publish actuator commands.
pub fn spawn(prefix: &str, actuator: bool) -> Result<(CompIo, CompIoWorker), String> {
    let measurements = Arc::new(ArrayQueue::new(QUEUE));
    let commands = Arc::new(ArrayQueue::new(QUEUE));
    let quit = Arc::new(AtomicBool::new(false));
    let dropped = Arc::new(AtomicU64::new(0));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<(), String>>();
    let (mq, cq, q, d, prefix) =
        (measurements.clone(), commands.clone(), quit.clone(), dropped.clone(), prefix.to_string());
    let handle = std::thread::Builder::new()
        .name("interpd-comp-io".into())
        .spawn(move || {
            let setup = || -> Result<_, String> {
                let node = NodeOptions::new().name("interpd-comp").create().map_err(|e| e.to_string())?;
                let ms = open_service::<Measurement>(&node, &prefix).map_err(|e| e.to_string())?;
                let sub = ms
                    .subscriber_builder()
                    .buffer_size(qos::SUBSCRIBER_BUFFER_SIZE)
                    .create()
                    .map_err(|e| format!("cannot subscribe to {prefix}/measurement: {e:?}"))?;
                let publisher = if actuator {
                    let s = open_service::<ActuatorCommand>(&node, &prefix).map_err(|e| e.to_string())?;
                    Some(
                        s.publisher_builder()
                            .create()
                            .map_err(|e| format!("cannot publish on {prefix}/actuator: {e:?}"))?,
                    )
                } else {
                    None
                };
                Ok((node, sub, publisher))
            };
            let (_node, sub, publisher) = match setup() {
                Ok(x) => {
                    let _ = ready_tx.send(Ok(()));
                    x
                }
                Err(e) => {
                    let _ = ready_tx.send(Err(e));
                    return;
                }
            };
            while !q.load(Ordering::SeqCst) {
                while let Some(c) = cq.pop() {
                    if let Some(p) = &publisher {
                        if let Ok(sample) = p.loan_uninit() {
                            let _ = sample.write_payload(c).send();
                        }
                    }
                }
                while let Ok(Some(sample)) = sub.receive() {
                    if mq.push(*sample).is_err() {
                        d.fetch_add(1, Ordering::Relaxed);
                    }
                }
                std::thread::park_timeout(POLL);
            }
        })
        .map_err(|e| e.to_string())?;
    match ready_rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(e),
        Err(_) => return Err("the compensation I/O thread exited".into()),
    }
    let worker = handle.thread().clone();
    Ok((CompIo { measurements, actuator: commands, worker }, CompIoWorker { handle: Some(handle), quit, dropped }))
}
