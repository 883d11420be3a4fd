//! Motion generations. Every chunk carries the epoch it was planned for; the executor follows
//! only chunks of the epoch it expects and discards older ones, so motion planned before a hold,
//! a stop or an underrun can never run after it.
//!
//! The rule the three threads share, here once:
//!
//! - a start (`motion.start`, a law move) takes a fresh epoch from [`Epochs::start`];
//! - when the executor diverts into a chunk's tail (hold, stop, underrun) it expects
//!   [`Epoch::replan`] of the epoch it ran, and the planner thread, told of the divert, plans
//!   the continuation as that same epoch. So one start runs as epochs `e`, `e.replan()`,
//!   `e.replan().replan()`, … one per divert;
//! - the control side never hands out an epoch a running motion may still move to: every
//!   notice of an epoch reserves its successor ([`Epochs::saw`]), and a start reserves its own
//!   first successor at once;
//! - a stop publishes a floor ([`Epochs::floor`]): every epoch handed out or reserved before it
//!   lies below, so chunks the planner thread queued for the stopped motion, even after the
//!   stop completed, never start; the next start's epoch is at or above it.

/// A motion generation (see the module documentation).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Epoch(u64);

impl Epoch {
    /// Before any motion: the executor's epoch at start-up (every real epoch is later).
    pub const NONE: Epoch = Epoch(0);
    /// The first epoch [`Epochs`] hands out.
    pub const FIRST: Epoch = Epoch(1);

    /// The epoch that continues the motion after the executor diverted from `self`: the
    /// executor expects its chunks next, and the planner thread replans as it.
    #[must_use]
    pub const fn replan(self) -> Epoch {
        Epoch(self.0 + 1)
    }

    /// The number, for logs and for passing the epoch through an atomic.
    pub const fn get(self) -> u64 {
        self.0
    }

    /// The epoch numbered `n` (see [`Epoch::get`]).
    pub const fn from_number(n: u64) -> Epoch {
        Epoch(n)
    }
}

impl std::fmt::Display for Epoch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The control side's supply of fresh epochs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Epochs {
    /// Epochs below this are used or reserved.
    next: Epoch,
}

impl Default for Epochs {
    fn default() -> Self {
        Epochs { next: Epoch::FIRST }
    }
}

impl Epochs {
    /// An epoch for a new start, after every epoch used so far; its first replan is reserved
    /// with it.
    pub fn start(&mut self) -> Epoch {
        let epoch = self.next;
        self.next = epoch.replan().replan();
        epoch
    }

    /// The executor reported motion of `epoch`: it, and the replan a divert from it moves to,
    /// are used.
    pub fn saw(&mut self, epoch: Epoch) {
        self.next = self.next.max(epoch.replan().replan());
    }

    /// Above every epoch handed out or reserved so far, and at or below the next start: the
    /// floor a stop publishes (chunks below it are dropped).
    pub fn floor(&self) -> Epoch {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_never_reuses_an_epoch_a_running_motion_may_reach() {
        let mut epochs = Epochs::default();
        let first = epochs.start();
        assert_eq!(first, Epoch::FIRST);
        // The motion is held and resumed twice: it runs as two replans of its epoch.
        let held_twice = first.replan().replan();
        epochs.saw(first.replan());
        epochs.saw(held_twice);
        let second = epochs.start();
        assert!(second > held_twice.replan(), "{second} collides with {}", held_twice.replan());
        // A start with no notice yet still leaves room for its first divert.
        assert!(epochs.start() > second.replan());
    }

    #[test]
    fn a_stop_floor_lies_above_the_stopped_motion_and_at_or_below_the_next_start() {
        let mut epochs = Epochs::default();
        let run = epochs.start();
        // Stopped before any notice of the run: its first replan is below the floor too.
        let floor = epochs.floor();
        assert!(run < floor && run.replan() < floor);
        assert!(epochs.start() >= floor);
    }
}
