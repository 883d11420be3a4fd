//! The fine interpolator: two stages with a written contract between them. The split into a
//! coarse and a fine stage is Huan's two-stage interpolation (Huan, §3, Fig. 4–5); here the
//! coarse stage works ahead in the planner thread and the fine stage is a simple, exact
//! executor in the real-time thread, so every decision that takes time is made before the
//! cycle needs it.
//!
//! - Stage 1, [`coarse`], in the planner thread: the planned path-velocity profile and the
//!   exact geometry become coarse points (time; path s, v, a; per axis position, velocity and
//!   acceleration), spaced so the quintic between neighbours deviates from the geometry by at
//!   most [`coarse::TOLERANCE_MM`].
//! - Stage 2, [`executor`], in the real-time thread: every cycle evaluates the quintic
//!   ([`hermite`]) between the coarse points around the cycle's time. Setpoints are therefore
//!   continuous in position, velocity and acceleration.
//!
//! ## Contract between the planner thread and the executor
//!
//! 1. Motion arrives in [`chunk::Chunk`]s of a few cycles through a bounded lock-free queue.
//!    A chunk's first point is the previous chunk's last (same time, state and position).
//! 2. Every chunk carries its *tail*: the fastest stop along the path from its end, within
//!    the axis limits. At a chunk's end the executor continues with the next chunk of the
//!    same epoch and sequence number + 1, unless a hold or stop is requested or no chunk is
//!    there: then it runs the tail and stands. So a hold, a stop and an underrun are all
//!    jerk-limited, on the path, and need nothing from the planner at that moment.
//! 3. After running a tail the executor expects the next epoch ([`Epoch::replan`]). The
//!    planner thread learns of the divert from a [`executor::Notice`] and replans from the
//!    tail's end, at rest, as that epoch (at once after an underrun, after the hold is
//!    released after a hold, not at all after a stop). Chunks of an old epoch are discarded,
//!    and so are chunks below the floor a stop publishes, whenever they arrive; [`epoch`]
//!    states the rule, including how starts get fresh epochs.
//! 4. A feed override change does not divert: the planner thread replans from the end of the
//!    last chunk it queued, at the new feed, and the queued chunks run out first (latency =
//!    queue depth).
//! 5. Chunks go back to the planner thread through a recycle queue: the executor never
//!    allocates or frees.
//! 6. Manual motion (jog, move-to, the return to a held point) arrives in the same form: the
//!    planner thread samples per-axis OTG trajectories into chunks whose tails are every axis's
//!    fastest stop (`service::manual`); the OTG never runs in the cycle.
//! 7. The executor never locks, blocks or logs either: requests arrive as two flags (hold,
//!    stop), and what happened leaves as [`executor::Notice`]s through a lock-free queue.
//!    daemon/tests/rt_no_alloc.rs runs the real service and proves its cycle allocation-free.
//! 8. A program stop (M0, M1, M60) is a planned exact stop (v = a = 0) with a coarse point of
//!    its own; the chunk names that point ([`chunk::ChunkPause`]). The executor stands there,
//!    tells the daemon ([`executor::Notice::Paused`]) and waits until the release counter
//!    (`motion.resume`) moves past what it was at the stop, then goes on in the same chunk: the
//!    look-ahead plans on past the stop and nothing is replanned. M1 is skipped while the
//!    optional-stop switch (a flag read every cycle) is off. A stop request while paused ends
//!    the program there, as a stop at rest. Its `line` is the line of the M0/M1/M60 block.
//! 9. An operator message (`(MSG,…)`, `(DEBUG,…)`, `(PRINT,…)`) is a planned exact stop too
//!    (LinuxCNC's task waits for the motion before one); the chunk names its coarse point and
//!    the number of the last message due there ([`chunk::ChunkMessage`]), never its text. The
//!    executor reports [`executor::Notice::Message`] when its time comes and goes on at once;
//!    messages and a program stop at the same point come out in program order. The texts wait
//!    in a bounded queue outside the cycle (`service::messages`) for the supervisor.

pub mod chunk;
pub mod coarse;
pub mod epoch;
pub mod executor;
pub mod hermite;

pub use chunk::{Chunk, ChunkMessage, ChunkPause};
pub use coarse::{CoarseBuilder, CoarsePoint};
pub use epoch::{Epoch, Epochs};
pub use executor::{DivertCause, Executor, Io, Notice, Phase};
