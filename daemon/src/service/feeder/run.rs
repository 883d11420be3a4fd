//! One motion being queued: what every kind of run shares (its epoch, the chunks it queued,
//! where it waits) and what differs by kind ([`Motion`]).

use super::{MANUAL_QUEUE_CHUNKS, QUEUE_CAPACITY, QUEUE_CHUNKS};
use crate::interp::coarse::CoarsePoint;
use crate::interp::{Chunk, DivertCause, Epoch};
use crate::service::law_run::LawPart;
use crate::service::lock;
use crate::service::manual::ManualPart;
use crate::service::messages::MessageBoard;
use crate::service::modal_track::ModalTrack;
use interpd_motion::{Feed, Segment};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// A planned segment starting this close to an element's start (mm) starts at it.
pub(super) const PAUSE_AT_MM: f64 = 1e-6;

/// Where a run waits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Wait {
    /// Producing chunks.
    No,
    /// The executor diverted; waiting for it to stand.
    Stand { cause: DivertCause, resume_requested: bool },
    /// Held at rest at `s_mm` after the tail of chunk `seq`; waiting for resume.
    Resume { s_mm: f64, seq: u64 },
}

/// What a run queues.
pub(super) enum Motion {
    /// A program or a path made whole (MDI blocks), planned along its path.
    Path(PathRun),
    /// Motion-law moves, sampled as designed along the lines of `feed` (held whole). The feed
    /// override does not scale them; after a hold or an underrun the rest of the strokes runs as
    /// rapid moves along the same lines (the run becomes a [`Motion::Path`]).
    Law { feed: Box<Feed>, law: Box<LawPart> },
    /// A jog or move-to (the path is empty).
    Manual(ManualPart),
}

impl Motion {
    /// The OTG motion being sampled: a jog or move-to, or the move back to the held point
    /// before a resumed program continues.
    pub(super) fn manual(&self) -> Option<&ManualPart> {
        match self {
            Motion::Manual(part) => Some(part),
            Motion::Path(p) => p.returning.as_ref(),
            Motion::Law { .. } => None,
        }
    }

    /// The path of a program or law run, for a restart along it.
    pub(super) fn into_path(self) -> Option<PathRun> {
        match self {
            Motion::Path(p) => Some(p),
            Motion::Law { feed, .. } => Some(PathRun::new(*feed, None)),
            Motion::Manual(_) => None,
        }
    }
}

/// A run along a path: its feed, where the program's tool and offset changes go, and the move
/// back to the held point that runs first when a held program resumes.
pub(super) struct PathRun {
    pub(super) feed: Box<Feed>,
    /// The running program's tool and offset changes (`status.modal`); `None` for a path
    /// made whole, which leaves the track of the program it interrupts as it is.
    modal: Option<Arc<Mutex<ModalTrack>>>,
    /// Where the program's operator messages wait for the motion; `None` for a path made whole.
    messages: Option<Arc<Mutex<MessageBoard>>>,
    pub(super) returning: Option<ManualPart>,
}

impl PathRun {
    pub(super) fn new(feed: Feed, modal: Option<Arc<Mutex<ModalTrack>>>) -> PathRun {
        PathRun { feed: Box::new(feed), modal, messages: None, returning: None }
    }

    /// The run's operator messages go to `board`.
    pub(super) fn with_messages(mut self, board: Arc<Mutex<MessageBoard>>) -> PathRun {
        self.messages = Some(board);
        self
    }

    /// Moves the tool and offset changes the feed has read into the track, and its operator
    /// messages onto the board.
    pub(super) fn track_modal(&mut self) {
        if let Some(board) = &self.messages {
            if let Some(first) = self.feed.take_message() {
                let mut b = lock(board);
                b.push(first);
                while let Some(m) = self.feed.take_message() {
                    b.push(m);
                }
            }
        }
        let Some(track) = &self.modal else { return };
        let mut next = self.feed.take_modal_change();
        if next.is_none() {
            return;
        }
        let mut t = lock(track);
        while let Some((line, state)) = next {
            t.push(line, state);
            next = self.feed.take_modal_change();
        }
    }

    /// Drops the path behind `s_mm`: the machine has passed it, and with it the tool and offset
    /// changes before the first element kept.
    pub(super) fn trim_before(&mut self, s_mm: f64) {
        self.track_modal();
        self.feed.trim_before(s_mm);
        if let (Some(track), Some(first)) = (&self.modal, self.feed.path().elements.first()) {
            lock(track).passed(first.source.line);
        }
    }
}

/// One motion being planned and queued.
pub(super) struct Run {
    pub(super) motion: Motion,
    pub(super) feed_override: f64,
    pub(super) epoch: Epoch,
    pub(super) seq: u64,
    /// Start positions of the chunks of this run the real-time thread gave back, newest last:
    /// the path behind the oldest of them is no longer needed (see [`Run::reclaimed`]).
    reclaimed_s: VecDeque<f64>,
    /// The last queued point (start of the next chunk).
    pub(super) end: CoarsePoint,
    /// The stop tail queued with the last chunk.
    pub(super) last_tail: Vec<Segment>,
    /// The last chunk of the motion is queued.
    pub(super) complete: bool,
    /// Chunks of a new epoch held back until the queue start is deep enough. Boxed: a chunk
    /// moves between threads as one pointer.
    #[allow(clippy::vec_box)]
    pub(super) staged: Vec<Box<Chunk>>,
    /// The queue has reached this run's depth once: from then on its low point is a measure
    /// of how the look-ahead keeps up (`status.lookahead`).
    pub(super) reached_depth: bool,
    pub(super) wait: Wait,
    /// Seconds of motion queued in this run (for the debug stall).
    pub(super) queued_s: f64,
    /// Path position the run (re)started at.
    pub(super) s_start_mm: f64,
    /// Program stops at or before this path position are queued already (or lie behind the
    /// start): each is put into one chunk only.
    pub(super) pause_armed_mm: f64,
}

impl Run {
    /// A run of `motion` from rest at `start` (path position `start.s_mm` for the chunks'
    /// points), starting its path at `s_mm`.
    pub(super) fn new(motion: Motion, feed_override: f64, epoch: Epoch, s_mm: f64, start: CoarsePoint) -> Run {
        Run {
            motion,
            feed_override,
            epoch,
            seq: 0,
            reclaimed_s: VecDeque::new(),
            end: start,
            last_tail: Vec::new(),
            complete: false,
            staged: Vec::new(),
            reached_depth: false,
            wait: Wait::No,
            queued_s: 0.0,
            s_start_mm: s_mm,
            // A stop exactly where the run starts from rest is still ahead of it.
            pause_armed_mm: s_mm - PAUSE_AT_MM,
        }
    }

    /// The run queues chunks: neither held nor waiting to resume, and not complete.
    pub(super) fn active(&self) -> bool {
        self.wait == Wait::No && !self.complete
    }

    /// Chunks kept queued for this run.
    pub(super) fn depth(&self) -> usize {
        if self.motion.manual().is_some() { MANUAL_QUEUE_CHUNKS } else { QUEUE_CHUNKS }
    }

    /// Starts `chunk` as this run's next one, from its last queued point.
    pub(super) fn open_chunk(&self, chunk: &mut Chunk) {
        chunk.clear();
        chunk.epoch = self.epoch;
        chunk.seq = self.seq;
        chunk.feed_override = self.feed_override;
        chunk.points.push(CoarsePoint { t_s: 0.0, ..self.end });
    }

    /// A chunk ending at `end` with the stop `tail` is filled: the next one starts there.
    pub(super) fn close_chunk(&mut self, end: CoarsePoint, tail: Vec<Segment>) {
        self.last_tail = tail;
        self.end = end;
        self.seq += 1;
    }

    /// The real-time thread gave back a chunk of `epoch` that started at `s_mm`. At most
    /// [`QUEUE_CAPACITY`] chunks are in flight, so the machine is past the start of a chunk
    /// given back that many chunks ago, whatever it does now (a hold or an underrun stands
    /// further on): the path behind it is dropped.
    pub(super) fn reclaimed(&mut self, epoch: Epoch, s_mm: f64) {
        let Motion::Path(path) = &mut self.motion else { return };
        if epoch != self.epoch || self.wait != Wait::No || path.returning.is_some() {
            return;
        }
        self.reclaimed_s.push_back(s_mm);
        if self.reclaimed_s.len() > QUEUE_CAPACITY {
            if let Some(behind) = self.reclaimed_s.pop_front() {
                path.trim_before(behind.min(self.end.s_mm));
            }
        }
    }
}
