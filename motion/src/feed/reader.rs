//! Reading a program: one read hands the smoothing stage the next programmed element and takes
//! what the stage gives back ([`Reader::read`]). The reads run in the caller's thread, or in a
//! thread of their own that keeps a look-ahead length ahead of the caller ([`ReaderThread`]),
//! so that the caller's steps plan and never wait for a window solve of the smoothing stage
//! (at the cusps of CAM data one solve takes up to 0.3 s). Either way the caller applies the
//! same reads in the same order, so the motion is the same to the last bit.

use super::FeedError;
use crate::Settings;
use crate::path::Element;
use crate::prep::{Prep, PrepStats};
use crate::program::{ActiveModal, AppendBuffer, Message, ProgramStream, Summary};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What one read of the program gave.
pub(super) struct Read {
    /// The elements the smoothing stage gave out, on the window's path positions.
    pub elements: Vec<Element>,
    /// The program has ended: no element follows these.
    pub ended: bool,
    /// Nothing more of the program is there yet (text appended later continues it).
    pub waiting: bool,
    /// After this read the smoothing stage has given out everything before the next element,
    /// which starts at rest (`Prep::rests_before_next`).
    pub rests: bool,
    /// The dwell after the last element, s (when `ended`).
    pub final_dwell_s: f64,
    pub read_time: Duration,
    pub prep_time: Duration,
    pub error: Option<FeedError>,
    /// Where the path given out so far ends, mm.
    pub end_mm: f64,
    /// Lines read so far.
    pub lines: u32,
}

/// A program's stream and its smoothing stage.
pub(super) struct Reader {
    stream: ProgramStream,
    prep: Prep,
    /// Length of the approach move before the program, mm: the program's path positions are
    /// shifted by it.
    s_offset_mm: f64,
    end_mm: f64,
}

impl Reader {
    pub(super) fn new(stream: ProgramStream, settings: &Settings, s_offset_mm: f64) -> Reader {
        Reader { stream, prep: Prep::new(settings), s_offset_mm, end_mm: s_offset_mm }
    }

    /// One read: the next programmed element through the smoothing stage.
    pub(super) fn read(&mut self) -> Read {
        let mut out = Read {
            elements: Vec::new(),
            ended: false,
            waiting: false,
            rests: false,
            final_dwell_s: 0.0,
            read_time: Duration::ZERO,
            prep_time: Duration::ZERO,
            error: None,
            end_mm: self.end_mm,
            lines: 0,
        };
        let started = Instant::now();
        let got = self.stream.next_element();
        let read = Instant::now();
        out.read_time = read - started;
        out.lines = self.stream.summary().lines;
        let got = match got {
            Ok(got) => got,
            Err(e) => {
                out.error = Some(e.into());
                return out;
            }
        };
        if got.is_none() && self.stream.waiting() {
            // Nothing more yet; the smoothing stage keeps its open run for what comes.
            out.waiting = true;
            return out;
        }
        out.ended = got.is_none();
        let smoothed = match got {
            Some(e) => self.prep.push(e),
            None => self.prep.finish(),
        };
        out.prep_time = read.elapsed();
        if let Err(e) = smoothed {
            out.error = Some(e.into());
            return out;
        }
        if out.ended {
            out.final_dwell_s = self.stream.final_dwell_s().unwrap_or(0.0);
        }
        out.rests = !out.ended && self.prep.rests_before_next();
        self.take_smoothed(&mut out.elements);
        out.end_mm = self.end_mm;
        out
    }

    /// A waiting program stops at the end of what is there: the smoothing stage closes its open
    /// run there (ending at rest). Returns what that gives out.
    pub(super) fn flush(&mut self) -> Result<Vec<Element>, FeedError> {
        self.stream.flush_waiting();
        while let Some(e) = self.stream.next_element()? {
            self.prep.push(e)?;
        }
        self.prep.finish()?;
        let mut elements = Vec::new();
        self.take_smoothed(&mut elements);
        Ok(elements)
    }

    fn take_smoothed(&mut self, out: &mut Vec<Element>) {
        while let Some(mut e) = self.prep.pop() {
            e.s_start_mm += self.s_offset_mm;
            self.end_mm = e.s_end_mm();
            out.push(e);
        }
    }

    pub(super) fn with_appends(self, buffer: Arc<AppendBuffer>) -> Reader {
        Reader { stream: self.stream.with_appends(buffer), ..self }
    }

    pub(super) fn summary(&self) -> &Summary {
        self.stream.summary()
    }

    pub(super) fn prep_stats(&self) -> PrepStats {
        self.prep.stats
    }

    pub(super) fn take_modal_change(&mut self) -> Option<(u32, ActiveModal)> {
        self.stream.take_modal_change()
    }

    pub(super) fn take_message(&mut self) -> Option<Message> {
        self.stream.take_message()
    }
}

/// A read done by the reading thread, with what the program's state gave beside it.
pub(super) struct ThreadRead {
    pub read: Read,
    pub modal: Vec<(u32, ActiveModal)>,
    pub messages: Vec<Message>,
    pub prep_stats: PrepStats,
    /// The summary, once the program has ended (or failed).
    pub summary: Option<Summary>,
}

/// How far the reading thread reads, set by its owner.
struct Shared {
    /// Path position to read to, mm (f64 bits).
    target_mm: AtomicU64,
    /// Reads the owner waits for (it reads at least this many).
    requested: AtomicU64,
    /// Reads sent.
    sent: AtomicU64,
    stop: AtomicBool,
    /// The owner plans on the one CPU it shares with the thread: read only what it waits for.
    owner_planning: AtomicBool,
}

/// The reading thread checks its target this often while it has nothing to do (a raised target
/// wakes it at once).
const IDLE_PARK: Duration = Duration::from_millis(50);

/// A thread that reads ahead of its owner, up to the path position the owner sets and at least
/// as many reads as the owner waits for; the owner applies the reads in order. Where the two
/// may run on one CPU only, the thread reads ahead only while the owner does not plan
/// ([`ReaderThread::owner_planning`]).
pub(super) struct ReaderThread {
    rx: mpsc::Receiver<ThreadRead>,
    shared: Arc<Shared>,
    thread: std::thread::Thread,
    received: u64,
    /// The owner and the thread may run on one CPU only.
    share_cpu: bool,
}

impl ReaderThread {
    /// Starts the thread; `on_start` runs first in it (to set its scheduling).
    pub(super) fn spawn(mut reader: Reader, on_start: fn()) -> std::io::Result<ReaderThread> {
        let shared = Arc::new(Shared {
            target_mm: AtomicU64::new(0f64.to_bits()),
            requested: AtomicU64::new(0),
            sent: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            owner_planning: AtomicBool::new(false),
        });
        // Where the owner may run on one CPU only (the daemon keeps it off the real-time one),
        // reading ahead while it plans would only slow its planning down.
        let share_cpu = std::thread::available_parallelism().map_or(true, |n| n.get() <= 1);
        let (tx, rx) = mpsc::channel();
        let sh = shared.clone();
        let handle = std::thread::Builder::new().name("interpd-read".into()).spawn(move || {
            on_start();
            let mut done = 0u64;
            let mut end_mm = 0.0;
            loop {
                if sh.stop.load(Ordering::Acquire) {
                    return;
                }
                let wanted = done < sh.requested.load(Ordering::Acquire)
                    || end_mm < f64::from_bits(sh.target_mm.load(Ordering::Acquire));
                if !wanted {
                    std::thread::park_timeout(IDLE_PARK);
                    continue;
                }
                let read = reader.read();
                done += 1;
                end_mm = read.end_mm;
                let last = read.ended || read.error.is_some();
                let mut modal = Vec::new();
                while let Some(m) = reader.take_modal_change() {
                    modal.push(m);
                }
                let mut messages = Vec::new();
                while let Some(m) = reader.take_message() {
                    messages.push(m);
                }
                let summary = last.then(|| reader.summary().clone());
                let out = ThreadRead { read, modal, messages, prep_stats: reader.prep_stats(), summary };
                if tx.send(out).is_err() {
                    return;
                }
                sh.sent.store(done, Ordering::Release);
                if last {
                    return;
                }
            }
        })?;
        Ok(ReaderThread { rx, shared, thread: handle.thread().clone(), received: 0, share_cpu })
    }

    /// The owner plans (`true`) or has finished planning. Where the two share one CPU the
    /// thread then reads only what the owner waits for, between its reads: planning is what the
    /// motion waits for, reading works a look-ahead ahead.
    pub(super) fn owner_planning(&self, planning: bool) {
        if self.share_cpu {
            self.shared.owner_planning.store(planning, Ordering::Release);
            if !planning {
                self.thread.unpark();
            }
        }
    }

    /// Reads on to `until_mm` (at least).
    pub(super) fn read_to(&self, until_mm: f64) {
        let old = f64::from_bits(self.shared.target_mm.load(Ordering::Acquire));
        if until_mm > old {
            self.shared.target_mm.store(until_mm.to_bits(), Ordering::Release);
            self.thread.unpark();
        }
    }

    /// Whether the thread reads on to `until_mm` already.
    pub(super) fn reads_to(&self, until_mm: f64) -> bool {
        f64::from_bits(self.shared.target_mm.load(Ordering::Acquire)) >= until_mm
    }

    /// A read is waiting to be taken.
    pub(super) fn has_read(&self) -> bool {
        self.shared.sent.load(Ordering::Acquire) > self.received
    }

    /// The next read, if one is done.
    pub(super) fn try_next(&mut self) -> Option<ThreadRead> {
        let got = self.rx.try_recv().ok()?;
        self.received += 1;
        Some(got)
    }

    /// The next read, waiting for it; `None` if the thread ended without it (it panicked).
    pub(super) fn next(&mut self) -> Option<ThreadRead> {
        if let Some(got) = self.try_next() {
            return Some(got);
        }
        self.shared.requested.fetch_max(self.received + 1, Ordering::AcqRel);
        self.thread.unpark();
        let got = self.rx.recv().ok()?;
        self.received += 1;
        Some(got)
    }
}

impl Drop for ReaderThread {
    /// The thread ends after the read it is in (not waited for: a read can take a while).
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        self.thread.unpark();
    }
}
