//! The unit the planner thread hands to the real-time thread.

use super::coarse::CoarsePoint;
use super::epoch::Epoch;
use interpd_protocol::api::PauseCode;

/// A program stop (M0, M1, M60) inside a chunk: at coarse point `point` (where the planned
/// motion is at rest, its exact stop) the executor waits for a release. M1 waits only while
/// the optional-stop switch is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChunkPause {
    /// Index of the stop's coarse point in the chunk's `points`.
    pub point: usize,
    pub code: PauseCode,
    /// The program line of the stop.
    pub line: u32,
}

/// Operator messages inside a chunk: when the motion reaches coarse point `point` (a planned
/// exact stop), and the chunk's first `after_pauses` program stops are behind it, the executor
/// reports that the program's messages up to number `upto` are due. The texts stay with the
/// planner thread and the supervisor (`service::messages`); the chunk carries numbers only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChunkMessage {
    /// Index of the coarse point in the chunk's `points`.
    pub point: usize,
    /// The last message number due there.
    pub upto: u64,
    /// How many of the chunk's `pauses` come before the messages.
    pub after_pauses: usize,
}

/// A stretch of planned motion, a few interpolation cycles long, with the fastest stop that
/// can follow it. The real-time thread runs `points`; at their end it continues with the next
/// chunk of the same epoch, or, on a hold, a stop or when no chunk is there (underrun), runs
/// `tail` to rest instead. Chunks are allocated by the planner thread and returned to it
/// through the recycle queue, so the real-time thread never allocates or frees memory.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Chunk {
    /// Motion generation (see [`super::epoch`]): chunks of an epoch older than the one the
    /// executor expects are discarded.
    pub epoch: Epoch,
    /// Sequence number within the epoch, from 0.
    pub seq: u64,
    /// The motion; `points[0]` (at t = 0) is where the previous chunk ended.
    pub points: Vec<CoarsePoint>,
    /// The fastest stop from the end of `points` (times from 0 at that end); empty when the
    /// motion ends at rest there.
    pub tail: Vec<CoarsePoint>,
    /// The program ends with this chunk.
    pub last: bool,
    /// Feed override the chunk was planned with (1.0 = 100 %).
    pub feed_override: f64,
    /// Program stops within `points`, in time order (the planner thread fills them; the
    /// executor only reads them).
    pub pauses: Vec<ChunkPause>,
    /// Operator messages within `points`, in time order (filled by the planner thread).
    pub messages: Vec<ChunkMessage>,
}

impl Chunk {
    /// Duration of the motion (without the tail), s.
    pub fn duration_s(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.t_s)
    }

    /// Duration of the tail, s.
    pub fn tail_duration_s(&self) -> f64 {
        self.tail.last().map_or(0.0, |p| p.t_s)
    }

    /// Empties the chunk for reuse, keeping its memory.
    pub fn clear(&mut self) {
        self.points.clear();
        self.tail.clear();
        self.pauses.clear();
        self.messages.clear();
        self.last = false;
    }
}
