//! The recorder: a thread of its own (normal scheduling) that subscribes to
//! `<prefix>/setpoints` and `<prefix>/feedback` over iceoryx2 like any other client and writes
//! every sample to an MCAP file. It never touches the real-time cycle: the publisher's
//! iceoryx2 service overwrites the oldest queued sample when a subscriber falls behind, so a
//! slow disk costs recorded samples (counted as missing cycles), never a late cycle. A write
//! that fails (a full disk) ends the recording at once, with the file finished as far as it
//! goes, and is reported through [`Recorder::failures`] while the daemon runs on.

use super::RecordError;
use super::file::RecordFile;
use super::gaps::StreamCount;
use super::interleave::Interleave;
use super::schema::{self, Payload, Stream};
use crossbeam::channel::{Receiver, Sender};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use interpd_protocol::shm::{Feedback, NodeOptions, Setpoints, open_service, qos};
use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Default time between two drains of the subscriber queues. The queues hold
/// [`qos::SUBSCRIBER_BUFFER_SIZE`] = 64 samples, 256 ms at 4 ms (64 ms when a replay runs at
/// speed 4), so 10 ms leaves a wide margin for a descheduled recorder.
pub const DEFAULT_POLL: Duration = Duration::from_millis(10);
/// Longest accepted poll period: well below the 64-sample buffer at 4 ms.
pub const MAX_POLL: Duration = Duration::from_millis(50);
/// Invalid samples logged one by one; later ones are only counted.
const LOGGED_INVALID: u64 = 5;

/// How a recording is made.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// iceoryx2 service prefix: services `<prefix>/setpoints` and `<prefix>/feedback`.
    pub prefix: String,
    /// Time between drains of the subscriber queues (≤ [`MAX_POLL`]).
    pub poll: Duration,
    /// Extra entries for the file's metadata record (machine, axes, ...).
    pub metadata: BTreeMap<String, String>,
}

impl RecordOptions {
    pub fn new(prefix: &str) -> Self {
        Self { prefix: prefix.into(), poll: DEFAULT_POLL, metadata: BTreeMap::new() }
    }
}

/// What a recording holds, reported when it stops.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordReport {
    pub path: PathBuf,
    pub setpoints: StreamCount,
    pub feedback: StreamCount,
    /// File size, bytes.
    pub bytes: u64,
    /// Wall time the recorder ran, s.
    pub duration_s: f64,
    /// Most samples found queued in one subscriber at one drain (of
    /// [`qos::SUBSCRIBER_BUFFER_SIZE`]): the headroom left before samples are lost.
    pub max_backlog: usize,
    /// Messages written before one with an earlier log time (see [`Interleave`]); 0 unless a
    /// stream lagged the other by more than the reorder window.
    pub out_of_order: u64,
}

impl fmt::Display for RecordReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "recorded setpoints: {}; feedback: {}; {:.1} s to {} ({} bytes; largest subscriber backlog {} of {}; {} \
             out of log-time order)",
            self.setpoints,
            self.feedback,
            self.duration_s,
            self.path.display(),
            self.bytes,
            self.max_backlog,
            qos::SUBSCRIBER_BUFFER_SIZE,
            self.out_of_order
        )
    }
}

/// A running recorder; [`Recorder::stop`] finishes the file.
pub struct Recorder {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<RecordReport, RecordError>>>,
    failures: Receiver<RecordError>,
}

struct Subscribers {
    setpoints: Subscriber<ipc::Service, Setpoints, ()>,
    feedback: Subscriber<ipc::Service, Feedback, ()>,
    // The node owns the services; it lives as long as the subscribers.
    _node: Node<ipc::Service>,
}

impl Recorder {
    /// Writes the channels and metadata to `file`, subscribes to both services (creating them
    /// if no publisher has yet, with the shared settings) and starts recording. Returns once
    /// the subscribers exist, so nothing published after this call is missed.
    pub fn start(mut file: RecordFile, options: RecordOptions) -> Result<Recorder, RecordError> {
        if options.poll.is_zero() || options.poll > MAX_POLL {
            return Err(RecordError::Setup(format!("poll period {:?} outside (0, {MAX_POLL:?}]", options.poll)));
        }
        file.begin(&options.prefix, &options.metadata)?;
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        // One failure ends the recording, so one slot suffices; the sender goes with the thread.
        let (failed_tx, failures) = crossbeam::channel::bounded(1);
        let thread_stop = stop.clone();
        let thread = std::thread::Builder::new()
            .name("interpd-recorder".into())
            .spawn(move || {
                let subs = match subscribe(&options.prefix) {
                    Ok(s) => s,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return Err(RecordError::Setup("subscription failed".into()));
                    }
                };
                let _ = ready_tx.send(Ok(()));
                record(file, &subs, &thread_stop, options.poll, &failed_tx)
            })
            .map_err(|e| RecordError::Setup(format!("cannot start the recorder thread: {e}")))?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Recorder { stop, thread: Some(thread), failures }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => Err(RecordError::Setup("the recorder thread ended during start-up".into())),
        }
    }

    /// The error that ended the recording early, when it happens (a write that failed); the
    /// channel closes when the recorder thread ends. The caller tells the clients (the daemon
    /// sends an `error` event) while the motion goes on.
    pub fn failures(&self) -> Receiver<RecordError> {
        self.failures.clone()
    }

    /// Drains what is queued, finishes the file, and reports.
    pub fn stop(mut self) -> Result<RecordReport, RecordError> {
        self.stop.store(true, Ordering::Release);
        let thread = self.thread.take().expect("a recorder is stopped once");
        thread.join().unwrap_or_else(|_| Err(RecordError::Setup("the recorder thread panicked".into())))
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn subscribe(prefix: &str) -> Result<Subscribers, RecordError> {
    let setup = |e: &dyn std::error::Error| RecordError::Setup(e.to_string());
    let node = NodeOptions::new().name("interpd-recorder").create().map_err(|e| setup(&e))?;
    let sp = open_service::<Setpoints>(&node, prefix).map_err(|e| setup(&e))?;
    let fb = open_service::<Feedback>(&node, prefix).map_err(|e| setup(&e))?;
    let err =
        |what: &str, e: &dyn fmt::Debug| RecordError::Setup(format!("cannot subscribe to {prefix}/{what}: {e:?}"));
    let setpoints =
        sp.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().map_err(|e| err("setpoints", &e))?;
    let feedback =
        fb.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().map_err(|e| err("feedback", &e))?;
    Ok(Subscribers { setpoints, feedback, _node: node })
}

/// Per-stream state of the recording loop.
#[derive(Default)]
struct Tally {
    setpoints: StreamCount,
    feedback: StreamCount,
    max_backlog: usize,
}

impl Tally {
    fn count(&mut self, stream: Stream) -> &mut StreamCount {
        match stream {
            Stream::Setpoints => &mut self.setpoints,
            Stream::Feedback => &mut self.feedback,
        }
    }
}

/// The loop: drain both queues into the merge, write what the merge releases; until `stop`,
/// then one last drain and everything held. On a write or receive error the file is still
/// finished, so what was recorded stays readable.
fn record(
    mut file: RecordFile,
    subs: &Subscribers,
    stop: &AtomicBool,
    poll: Duration,
    failed: &Sender<RecordError>,
) -> Result<RecordReport, RecordError> {
    let started = Instant::now();
    let mut tally = Tally::default();
    let mut merge = Interleave::default();
    let (mut received, mut ready) = (Vec::new(), Vec::new());
    let outcome = loop {
        let last = stop.load(Ordering::Acquire);
        let step = drain(&subs.setpoints, &mut received, &mut tally)
            .and_then(|()| drain(&subs.feedback, &mut received, &mut tally))
            .and_then(|()| {
                received.drain(..).for_each(|p| merge.push(p));
                if last {
                    merge.pop_all(&mut ready)
                } else {
                    merge.pop_ready(&mut ready)
                }
                ready.drain(..).try_for_each(|p: Payload| {
                    tally.count(p.stream()).record(p.cycle());
                    file.write(&p)
                })
            });
        if let Err(e) = step {
            tracing::error!("recording to {} stopped: {e}", file.path().display());
            let _ = failed.try_send(e.clone());
            break Err(e);
        }
        if last {
            break Ok(());
        }
        std::thread::sleep(poll);
    };
    let path = file.path().to_path_buf();
    // After a failed write the file ends with what was written before it; the error that
    // stopped the recording is the one to report, not the finish that fails after it.
    let finished = file.finish();
    outcome?;
    let bytes = finished?;
    Ok(RecordReport {
        path,
        setpoints: tally.setpoints,
        feedback: tally.feedback,
        bytes,
        duration_s: started.elapsed().as_secs_f64(),
        max_backlog: tally.max_backlog,
        out_of_order: merge.out_of_order,
    })
}

/// A payload type the recorder subscribes to.
trait Recordable: fmt::Debug + Copy + ZeroCopySend + 'static {
    const STREAM: Stream;
    fn wrap(self) -> Payload;
}

impl Recordable for Setpoints {
    const STREAM: Stream = Stream::Setpoints;
    fn wrap(self) -> Payload {
        Payload::Setpoints(self)
    }
}

impl Recordable for Feedback {
    const STREAM: Stream = Stream::Feedback;
    fn wrap(self) -> Payload {
        Payload::Feedback(self)
    }
}

/// Receives every queued sample of `sub` into `out`, valid ones only (invalid are counted).
fn drain<T: Recordable>(
    sub: &Subscriber<ipc::Service, T, ()>,
    out: &mut Vec<Payload>,
    tally: &mut Tally,
) -> Result<(), RecordError> {
    let before = out.len();
    loop {
        let sample = sub
            .receive()
            .map_err(|e| RecordError::Transport(format!("receive on {}: {e:?}", T::STREAM.schema().service)))?;
        let Some(sample) = sample else { break };
        let payload = (*sample).wrap();
        match schema::check(&payload) {
            Ok(()) => out.push(payload),
            Err(e) => {
                let count = tally.count(T::STREAM);
                count.invalid += 1;
                if count.invalid <= LOGGED_INVALID {
                    tracing::warn!("{} sample of cycle {} not recorded: {e}", T::STREAM.schema().name, payload.cycle());
                }
            }
        }
    }
    tally.max_backlog = tally.max_backlog.max(out.len() - before);
    Ok(())
}
