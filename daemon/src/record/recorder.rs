//! The recorder: two threads of their own (normal scheduling). One subscribes to
//! `<prefix>/setpoints` and `<prefix>/feedback` over iceoryx2 like any other client and only
//! moves every sample into an in-process queue of [`WRITE_QUEUE_SAMPLES`]; the other writes
//! them to an MCAP file. It never touches the real-time cycle: the publisher's iceoryx2 service
//! overwrites the oldest queued sample when a subscriber falls behind (safe overflow), so the
//! subscriber queues ([`qos::SUBSCRIBER_BUFFER_SIZE`], 256 ms at 4 ms) bound how long the
//! receiving thread may go unscheduled, and the write queue (16 s of both streams at 4 ms)
//! how long a write may stall (compression, a disk busy with writeback) before samples are
//! lost; lost samples are counted as missing cycles, never a late cycle. A write that fails (a
//! full disk) ends the recording at once, with the file finished as far as it goes, and is
//! reported through [`Recorder::failures`] while the daemon runs on.

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
/// Samples (of both streams) queued between the receiving and the writing thread: 16 s of
/// setpoints and feedback at 4 ms, so a write (MCAP chunk compression, a disk busy with
/// writeback) may stall that long before a sample is lost; about 420 bytes a slot (3.4 MB,
/// allocated with the queue).
pub const WRITE_QUEUE_SAMPLES: usize = 8192;

/// How a recording is made.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// iceoryx2 service prefix: services `<prefix>/setpoints` and `<prefix>/feedback`.
    pub prefix: String,
    /// Time between drains of the subscriber queues (≤ [`MAX_POLL`]).
    pub poll: Duration,
    /// Extra entries for the file's metadata record (machine, axes, ...).
    pub metadata: BTreeMap<String, String>,
    /// The writing thread stalls this long before its first write, as on a disk busy with
    /// writeback (tests: the write queue bridges it).
    pub write_stall: Option<Duration>,
}

impl RecordOptions {
    pub fn new(prefix: &str) -> Self {
        Self { prefix: prefix.into(), poll: DEFAULT_POLL, metadata: BTreeMap::new(), write_stall: None }
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
    /// Most samples waiting for the writing thread (of [`WRITE_QUEUE_SAMPLES`]).
    pub max_write_queue: usize,
    /// Samples dropped because the write queue was full (each also a missing cycle).
    pub write_queue_dropped: u64,
    /// Messages written before one with an earlier log time (see [`Interleave`]); 0 unless a
    /// stream lagged the other by more than the reorder window.
    pub out_of_order: u64,
}

impl fmt::Display for RecordReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "recorded setpoints: {}; feedback: {}; {:.1} s to {} ({} bytes; largest subscriber backlog {} of {}; \
             largest write queue {} of {}, {} dropped; {} out of log-time order)",
            self.setpoints,
            self.feedback,
            self.duration_s,
            self.path.display(),
            self.bytes,
            self.max_backlog,
            qos::SUBSCRIBER_BUFFER_SIZE,
            self.max_write_queue,
            WRITE_QUEUE_SAMPLES,
            self.write_queue_dropped,
            self.out_of_order
        )
    }
}

/// A running recorder; [`Recorder::stop`] finishes the file.
pub struct Recorder {
    stop: Arc<AtomicBool>,
    receiver: Option<JoinHandle<Received>>,
    writer: Option<JoinHandle<Result<RecordReport, RecordError>>>,
    failures: Receiver<RecordError>,
}

/// What goes from the receiving to the writing thread. Samples travel by value: they are
/// nearly every message, and the queue's slots hold them without an allocation each.
#[allow(clippy::large_enum_variant)]
enum Message {
    Sample(Payload),
    /// Receiving failed: the recording ends.
    Failed(RecordError),
}

/// The receiving thread's counters, reported when it ends.
#[derive(Debug, Default, Clone, Copy)]
struct Received {
    max_backlog: usize,
    max_write_queue: usize,
    dropped: u64,
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
        let (queue_tx, queue_rx) = crossbeam::channel::bounded(WRITE_QUEUE_SAMPLES);
        let thread_stop = stop.clone();
        let (poll, write_stall) = (options.poll, options.write_stall);
        let receiver = std::thread::Builder::new()
            .name("interpd-rec-recv".into())
            .spawn(move || {
                let subs = match subscribe(&options.prefix) {
                    Ok(s) => s,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return Received::default();
                    }
                };
                let _ = ready_tx.send(Ok(()));
                receive(&subs, &thread_stop, poll, &queue_tx)
            })
            .map_err(|e| RecordError::Setup(format!("cannot start the recorder thread: {e}")))?;
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                let _ = receiver.join();
                return Err(e);
            }
            Err(_) => return Err(RecordError::Setup("the recorder thread ended during start-up".into())),
        }
        let writer = std::thread::Builder::new()
            .name("interpd-recorder".into())
            .spawn(move || {
                if let Some(stall) = write_stall {
                    std::thread::sleep(stall);
                }
                record(file, &queue_rx, &failed_tx)
            })
            .map_err(|e| RecordError::Setup(format!("cannot start the recorder thread: {e}")))?;
        Ok(Recorder { stop, receiver: Some(receiver), writer: Some(writer), failures })
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
        let received = self.receiver.take().expect("a recorder is stopped once").join().unwrap_or_default();
        let writer = self.writer.take().expect("a recorder is stopped once");
        let mut report =
            writer.join().unwrap_or_else(|_| Err(RecordError::Setup("the recorder thread panicked".into())))?;
        report.max_backlog = received.max_backlog;
        report.max_write_queue = received.max_write_queue;
        report.write_queue_dropped = received.dropped;
        Ok(report)
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.receiver.take() {
            let _ = t.join();
        }
        if let Some(t) = self.writer.take() {
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
}

impl Tally {
    fn count(&mut self, stream: Stream) -> &mut StreamCount {
        match stream {
            Stream::Setpoints => &mut self.setpoints,
            Stream::Feedback => &mut self.feedback,
        }
    }
}

/// The receiving loop: every `poll`, everything queued in both subscribers into the write
/// queue; until `stop` (then one last drain) or the writer is gone. A full write queue drops
/// the sample (counted; the writer sees the missing cycle).
fn receive(subs: &Subscribers, stop: &AtomicBool, poll: Duration, queue: &Sender<Message>) -> Received {
    let mut counts = Received::default();
    let mut batch = Vec::new();
    loop {
        let last = stop.load(Ordering::Acquire);
        let drained = drain(&subs.setpoints, &mut batch, &mut counts)
            .and_then(|()| drain(&subs.feedback, &mut batch, &mut counts));
        for p in batch.drain(..) {
            match queue.try_send(Message::Sample(p)) {
                Ok(()) => {}
                Err(crossbeam::channel::TrySendError::Full(_)) => counts.dropped += 1,
                Err(crossbeam::channel::TrySendError::Disconnected(_)) => return counts,
            }
        }
        counts.max_write_queue = counts.max_write_queue.max(queue.len());
        if let Err(e) = drained {
            let _ = queue.send(Message::Failed(e));
            return counts;
        }
        if last {
            return counts;
        }
        std::thread::sleep(poll);
    }
}

/// The writing loop: samples from the write queue into the merge, what the merge releases
/// into the file; when the receiving thread ends, everything held. On a write or receive
/// error the file is still finished, so what was recorded stays readable.
fn record(
    mut file: RecordFile,
    queue: &Receiver<Message>,
    failed: &Sender<RecordError>,
) -> Result<RecordReport, RecordError> {
    let started = Instant::now();
    let mut tally = Tally::default();
    let mut merge = Interleave::default();
    let mut ready = Vec::new();
    let outcome = loop {
        let (step, last) = match queue.recv() {
            Ok(Message::Sample(p)) => {
                match schema::check(&p) {
                    Ok(()) => merge.push(p),
                    Err(e) => {
                        let count = tally.count(p.stream());
                        count.invalid += 1;
                        if count.invalid <= LOGGED_INVALID {
                            tracing::warn!(
                                "{} sample of cycle {} not recorded: {e}",
                                p.stream().schema().name,
                                p.cycle()
                            );
                        }
                    }
                }
                merge.pop_ready(&mut ready);
                (Ok(()), false)
            }
            Ok(Message::Failed(e)) => (Err(e), false),
            Err(_) => {
                merge.pop_all(&mut ready);
                (Ok(()), true)
            }
        };
        let step = step.and_then(|()| {
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
        max_backlog: 0,
        max_write_queue: 0,
        write_queue_dropped: 0,
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

/// Receives every queued sample of `sub` into `out` (checked by the writer).
fn drain<T: Recordable>(
    sub: &Subscriber<ipc::Service, T, ()>,
    out: &mut Vec<Payload>,
    counts: &mut Received,
) -> Result<(), RecordError> {
    let before = out.len();
    loop {
        let sample = sub
            .receive()
            .map_err(|e| RecordError::Transport(format!("receive on {}: {e:?}", T::STREAM.schema().service)))?;
        let Some(sample) = sample else { break };
        out.push((*sample).wrap());
    }
    counts.max_backlog = counts.max_backlog.max(out.len() - before);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_protocol::shm::Feedback;

    /// A writer stalled for 1.5 s, six times what the subscriber queues hold at 4 ms, while
    /// both streams are published every 4 ms: nothing is lost, the write queue bridges it.
    #[test]
    fn a_stalled_writer_loses_no_sample() {
        let prefix = format!("interpd-test/recorder-stall-{}", std::process::id());
        let path = std::env::temp_dir().join(format!("interpd-recorder-stall-{}.mcap", std::process::id()));
        let node = NodeOptions::new().name("interpd-recorder-test").create().expect("node");
        let sp = open_service::<Setpoints>(&node, &prefix).expect("setpoints");
        let fb = open_service::<Feedback>(&node, &prefix).expect("feedback");
        let (sp_pub, fb_pub) =
            (sp.publisher_builder().create().expect("publisher"), fb.publisher_builder().create().expect("publisher"));
        let mut options = RecordOptions::new(&prefix);
        let stall = Duration::from_millis(1500);
        options.write_stall = Some(stall);
        let recorder = Recorder::start(RecordFile::create(&path).expect("file"), options).expect("recorder");
        const CYCLES: u64 = 500;
        let started = Instant::now();
        for cycle in 1..=CYCLES {
            let t = 1_000_000_000 + cycle * 4_000_000;
            let setpoint = Setpoints { n_axes: 3, cycle, time_ns: t, publish_ns: t, ..Setpoints::default() };
            let feedback = Feedback { n_axes: 3, cycle, time_ns: t, setpoint_publish_ns: t, ..Feedback::default() };
            sp_pub.loan_uninit().expect("loan").write_payload(setpoint).send().expect("send");
            fb_pub.loan_uninit().expect("loan").write_payload(feedback).send().expect("send");
            std::thread::sleep(Duration::from_millis(4));
        }
        assert!(started.elapsed() > stall, "the stall outlasts the publishing");
        let report = recorder.stop().expect("report");
        let _ = std::fs::remove_file(&path);
        assert!(report.max_write_queue > 2 * qos::SUBSCRIBER_BUFFER_SIZE, "{report}");
        for count in [report.setpoints, report.feedback] {
            assert_eq!((count.samples, count.missing, count.first_cycle), (CYCLES, 0, Some(1)), "{report}");
        }
        assert_eq!(report.write_queue_dropped, 0, "{report}");
    }
}
