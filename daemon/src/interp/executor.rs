//! Stage 2 of the two-stage interpolation, run every cycle in the real-time thread: the simple,
//! exact executor of the chunks the planner thread prepared (the contract is in
//! [`super`]). It evaluates the quintic between coarse points, switches chunks, and diverts
//! into a chunk's stop tail on a hold, a stop or an underrun. It never allocates, frees,
//! locks or blocks: chunks arrive and leave through lock-free queues, notices go out through
//! one.

use super::chunk::Chunk;
use super::coarse::CoarsePoint;
use super::epoch::Epoch;
use super::hermite;
use crossbeam::queue::ArrayQueue;
use interpd_protocol::api::PauseCode;
use interpd_protocol::shm::{Setpoints, flags};

/// Why the executor stopped following the planned motion and ran a chunk's tail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DivertCause {
    /// Feed hold requested (resume continues the program).
    Hold,
    /// Stop requested (the program is abandoned).
    Stop,
    /// No next chunk was there in time (the program continues when chunks arrive).
    Underrun,
}

/// What the executor tells the rest of the daemon (through a lock-free queue).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Notice {
    /// Motion of `epoch` began (from rest).
    Started { epoch: Epoch, cycle: u64 },
    /// The executor left the planned motion at the end of chunk `seq` of `epoch` and runs its
    /// tail; it expects chunks of `epoch.replan()` next and discards those of `epoch`.
    Diverted { epoch: Epoch, seq: u64, cause: DivertCause, cycle: u64 },
    /// The tail ended: the machine stands at `s_mm`.
    Stood { epoch: Epoch, seq: u64, cause: DivertCause, s_mm: f64, cycle: u64 },
    /// The last chunk of the program ended: the machine stands at the program end.
    Finished { epoch: Epoch, s_mm: f64, cycle: u64 },
    /// The setpoints entered program line `line`.
    Line { line: u32, cycle: u64 },
    /// The motion stands at the program stop `code` of line `line` and waits for a release.
    Paused { line: u32, code: PauseCode, cycle: u64 },
    /// The motion reached the program's operator messages up to number `upto`.
    Message { upto: u64, cycle: u64 },
}

/// Where the executor is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// At rest at `rest`.
    Standing,
    /// Following a chunk's motion.
    Main,
    /// Running a chunk's tail to rest.
    Tail(DivertCause),
    /// Standing at a program stop inside the running chunk, waiting for a release.
    Paused,
}

/// The queues between the executor and the planner thread, and the requests it obeys.
pub struct Io<'a> {
    /// Chunks from the planner thread.
    pub chunks: &'a ArrayQueue<Box<Chunk>>,
    /// Chunks done with, back to the planner thread.
    pub recycle: &'a ArrayQueue<Box<Chunk>>,
    /// Notices to the daemon.
    pub notices: &'a ArrayQueue<Notice>,
    /// A feed hold is requested.
    pub hold: bool,
    /// A stop is requested.
    pub stop: bool,
    /// Chunks of epochs below this belong to stopped motion and are dropped
    /// ([`super::epoch::Epochs::floor`]).
    pub epoch_floor: Epoch,
    /// The optional-stop switch: M1 pauses like M0.
    pub optional_stop: bool,
    /// Releases of program stops so far (`motion.resume` counts it up): a pause ends when it
    /// differs from its value when the pause began.
    pub releases: u64,
}

/// Counters of things that should not happen, for the status.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExecutorFaults {
    /// Notices dropped because the notice queue was full.
    pub notices_dropped: u64,
    /// Chunks leaked because the recycle queue was full (never freed in the cycle).
    pub chunks_leaked: u64,
    /// Chunks of an old epoch discarded.
    pub stale_chunks: u64,
}

/// The fine interpolator's state.
pub struct Executor {
    n_axes: usize,
    /// Chunks of this epoch continue the motion.
    epoch: Epoch,
    chunk: Option<Box<Chunk>>,
    phase: Phase,
    /// Index of the piece (`points[piece]` → `points[piece + 1]`) last evaluated.
    piece: usize,
    /// Time within the running sequence (main or tail), s.
    t_s: f64,
    /// Where the machine stands (when standing) or stood last.
    rest: CoarsePoint,
    stand_reason: Option<DivertCause>,
    finished: bool,
    line: u32,
    feed_override: f64,
    /// Index of the running chunk's next program stop.
    next_pause: usize,
    /// Index of the running chunk's next operator message marker.
    next_message: usize,
    /// `Io::releases` when the current pause began.
    released_seen: u64,
    pub faults: ExecutorFaults,
}

impl Executor {
    /// An executor at rest at `position` (axis units).
    pub fn new(n_axes: usize, position: [f64; interpd_motion::path::MAX_AXES]) -> Self {
        Self {
            n_axes,
            epoch: Epoch::NONE,
            chunk: None,
            phase: Phase::Standing,
            piece: 0,
            t_s: 0.0,
            rest: CoarsePoint::at_rest(0.0, 0.0, 0, position),
            stand_reason: None,
            finished: false,
            line: 0,
            feed_override: 1.0,
            next_pause: 0,
            next_message: 0,
            released_seen: 0,
            faults: ExecutorFaults::default(),
        }
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The epoch whose chunks the executor takes next.
    pub fn epoch(&self) -> Epoch {
        self.epoch
    }

    /// Where the machine stands or stood last.
    pub fn rest(&self) -> &CoarsePoint {
        &self.rest
    }

    /// At rest: axis `axis` stands at `pos` from now on, without motion (homing gave its drive
    /// a new reference; the machine did not move). Returns false, changing nothing, unless
    /// the executor stands.
    pub fn rest_at(&mut self, axis: usize, pos: f64) -> bool {
        if self.phase != Phase::Standing || axis >= self.n_axes {
            return false;
        }
        self.rest.pos[axis] = pos;
        true
    }

    /// Computes the setpoint of cycle `cycle` (`dt_s` after the previous one) into `out`.
    pub fn step(&mut self, cycle: u64, dt_s: f64, io: &Io, out: &mut Setpoints) {
        match self.phase {
            Phase::Standing => self.try_start(cycle, io),
            Phase::Main | Phase::Tail(_) => {
                self.t_s += dt_s;
                self.advance(cycle, io);
            }
            Phase::Paused => self.wait_paused(cycle, dt_s, io),
        }
        self.write(out);
        if out.line != self.line && out.line != 0 {
            self.line = out.line;
            self.notify(io, Notice::Line { line: out.line, cycle });
        }
    }

    /// At rest: starts the next chunk if it is the first of the current (or a newer) epoch, not
    /// below the stop floor, and no hold or stop is requested. Chunks below the floor belong to
    /// stopped motion, whenever the planner thread queued them (it may still be queueing the
    /// restart of a resume when the stop completes). Motion from rest always begins with the
    /// first chunk of an epoch, where the machine stands; a later one would jump to where the
    /// chunks before it ended.
    fn try_start(&mut self, cycle: u64, io: &Io) {
        if io.hold || io.stop {
            return;
        }
        let oldest = self.epoch.max(io.epoch_floor);
        while let Some(chunk) = io.chunks.pop() {
            if chunk.epoch < oldest || chunk.seq != 0 || chunk.points.len() < 2 {
                self.faults.stale_chunks += 1;
                self.recycle(io, chunk);
                continue;
            }
            self.epoch = chunk.epoch;
            self.feed_override = chunk.feed_override;
            self.chunk = Some(chunk);
            self.phase = Phase::Main;
            self.piece = 0;
            self.next_pause = 0;
            self.next_message = 0;
            self.t_s = 0.0;
            self.stand_reason = None;
            self.finished = false;
            self.notify(io, Notice::Started { epoch: self.epoch, cycle });
            return;
        }
    }

    /// Moves past sequence ends until `t_s` lies inside the running sequence (or at rest).
    fn advance(&mut self, cycle: u64, io: &Io) {
        loop {
            let Some(chunk) = self.chunk.as_ref() else {
                self.phase = Phase::Standing;
                return;
            };
            // Messages first: those before a program stop at the same point come before it.
            let message = chunk
                .messages
                .get(self.next_message)
                .filter(|m| m.after_pauses <= self.next_pause)
                .filter(|m| chunk.points.get(m.point).is_none_or(|at| self.t_s >= at.t_s))
                .map(|m| m.upto);
            let due = chunk
                .pauses
                .get(self.next_pause)
                .and_then(|p| Some((*p, *chunk.points.get(p.point)?)))
                .filter(|(_, at)| self.t_s >= at.t_s);
            match self.phase {
                Phase::Main if message.is_some() => {
                    let Some(upto) = message else { return };
                    self.next_message += 1;
                    self.notify(io, Notice::Message { upto, cycle });
                }
                Phase::Main if due.is_some() => {
                    let Some((p, at)) = due else { return };
                    self.next_pause += 1;
                    if p.code == PauseCode::M1 && !io.optional_stop {
                        continue;
                    }
                    // The stop is a coarse point at rest: the machine stands at it exactly (its
                    // line is the line the motion goes on with) until the release.
                    self.rest = CoarsePoint::at_rest(at.t_s, at.s_mm, at.line, at.pos);
                    self.t_s = at.t_s;
                    self.phase = Phase::Paused;
                    self.released_seen = io.releases;
                    self.notify(io, Notice::Paused { line: p.line, code: p.code, cycle });
                    return;
                }
                Phase::Main if self.t_s > chunk.duration_s() => {
                    let over = self.t_s - chunk.duration_s();
                    let (epoch, seq, last) = (chunk.epoch, chunk.seq, chunk.last);
                    if last {
                        let end = *chunk.points.last().expect("a chunk has points");
                        self.stand(io, end);
                        self.finished = true;
                        self.notify(io, Notice::Finished { epoch, s_mm: end.s_mm, cycle });
                        return;
                    }
                    let cause = if io.stop {
                        Some(DivertCause::Stop)
                    } else if io.hold {
                        Some(DivertCause::Hold)
                    } else {
                        match self.next_chunk(io, epoch, seq) {
                            Some(next) => {
                                self.feed_override = next.feed_override;
                                let old = self.chunk.replace(next).expect("a running chunk");
                                self.recycle(io, old);
                                self.t_s = over;
                                self.piece = 0;
                                self.next_pause = 0;
                                self.next_message = 0;
                                continue;
                            }
                            None => Some(DivertCause::Underrun),
                        }
                    };
                    if let Some(cause) = cause {
                        self.epoch = epoch.replan();
                        self.phase = Phase::Tail(cause);
                        self.t_s = over;
                        self.piece = 0;
                        self.notify(io, Notice::Diverted { epoch, seq, cause, cycle });
                        continue;
                    }
                }
                Phase::Tail(cause) if self.t_s > chunk.tail_duration_s() || chunk.tail.len() < 2 => {
                    let end = *chunk.tail.last().or(chunk.points.last()).expect("a chunk has points");
                    let (epoch, seq) = (chunk.epoch, chunk.seq);
                    self.stand(io, end);
                    self.stand_reason = Some(cause);
                    self.notify(io, Notice::Stood { epoch, seq, cause, s_mm: end.s_mm, cycle });
                    return;
                }
                _ => return,
            }
        }
    }

    /// At a program stop: a stop request ends the program here (as a stop at rest); a release
    /// goes on along the same chunk.
    fn wait_paused(&mut self, cycle: u64, dt_s: f64, io: &Io) {
        if io.stop {
            let Some(chunk) = self.chunk.as_ref() else {
                self.phase = Phase::Standing;
                return;
            };
            let (epoch, seq, at) = (chunk.epoch, chunk.seq, self.rest);
            self.epoch = epoch.replan();
            self.notify(io, Notice::Diverted { epoch, seq, cause: DivertCause::Stop, cycle });
            self.stand(io, at);
            self.stand_reason = Some(DivertCause::Stop);
            self.notify(io, Notice::Stood { epoch, seq, cause: DivertCause::Stop, s_mm: at.s_mm, cycle });
        } else if io.releases != self.released_seen {
            self.phase = Phase::Main;
            self.t_s += dt_s;
            self.advance(cycle, io);
        }
    }

    /// The next chunk of `epoch` after `seq`, discarding older ones.
    fn next_chunk(&mut self, io: &Io, epoch: Epoch, seq: u64) -> Option<Box<Chunk>> {
        while let Some(next) = io.chunks.pop() {
            if next.epoch == epoch && next.seq == seq + 1 && next.points.len() >= 2 {
                return Some(next);
            }
            self.faults.stale_chunks += 1;
            self.recycle(io, next);
        }
        None
    }

    /// Comes to rest at `end` and gives the chunk back.
    fn stand(&mut self, io: &Io, end: CoarsePoint) {
        self.rest = CoarsePoint::at_rest(end.t_s, end.s_mm, end.line, end.pos);
        self.phase = Phase::Standing;
        self.t_s = 0.0;
        if let Some(chunk) = self.chunk.take() {
            self.recycle(io, chunk);
        }
    }

    fn recycle(&mut self, io: &Io, chunk: Box<Chunk>) {
        if let Err(chunk) = io.recycle.push(chunk) {
            // Freeing here would call the allocator in the cycle: leak instead, and count.
            self.faults.chunks_leaked += 1;
            std::mem::forget(chunk);
        }
    }

    fn notify(&mut self, io: &Io, notice: Notice) {
        if io.notices.push(notice).is_err() {
            self.faults.notices_dropped += 1;
        }
    }

    /// The setpoint at the current time.
    fn write(&mut self, out: &mut Setpoints) {
        out.n_axes = self.n_axes as u32;
        out.feed_override = self.feed_override;
        let (points, t) = match (self.phase, self.chunk.as_ref()) {
            (Phase::Main, Some(c)) => (&c.points[..], self.t_s),
            (Phase::Tail(_), Some(c)) if c.tail.len() >= 2 => (&c.tail[..], self.t_s),
            _ => {
                let r = &self.rest;
                out.s_mm = r.s_mm;
                out.v_mm_s = 0.0;
                out.a_mm_s2 = 0.0;
                out.line = r.line;
                out.pos[..self.n_axes].copy_from_slice(&r.pos[..self.n_axes]);
                out.vel = [0.0; interpd_motion::path::MAX_AXES];
                out.acc = [0.0; interpd_motion::path::MAX_AXES];
                out.flags = self.flags();
                return;
            }
        };
        let mut i = self.piece.min(points.len() - 2);
        while i + 2 < points.len() && points[i + 1].t_s < t {
            i += 1;
        }
        self.piece = i;
        let (a, b) = (&points[i], &points[i + 1]);
        let (h, tau) = (b.t_s - a.t_s, t - a.t_s);
        let path = hermite::eval(a.path(), b.path(), h, tau);
        out.s_mm = path.p;
        out.v_mm_s = path.v;
        out.a_mm_s2 = path.a;
        out.line = a.line;
        for k in 0..self.n_axes {
            let q = hermite::eval(a.axis(k), b.axis(k), h, tau);
            out.pos[k] = q.p;
            out.vel[k] = q.v;
            out.acc[k] = q.a;
        }
        out.flags = self.flags();
    }

    fn flags(&self) -> u32 {
        match self.phase {
            Phase::Main => flags::RUNNING,
            Phase::Tail(DivertCause::Hold) => flags::RUNNING | flags::HOLDING,
            Phase::Tail(DivertCause::Stop) => flags::RUNNING | flags::STOPPING,
            Phase::Tail(DivertCause::Underrun) => flags::RUNNING | flags::UNDERRUN,
            Phase::Paused => flags::RUNNING | flags::PAUSED,
            Phase::Standing => {
                flags::IDLE
                    | match self.stand_reason {
                        Some(DivertCause::Hold) => flags::HOLDING,
                        Some(DivertCause::Underrun) => flags::UNDERRUN,
                        _ if self.finished => flags::FINISHED,
                        _ => 0,
                    }
            }
        }
    }
}
