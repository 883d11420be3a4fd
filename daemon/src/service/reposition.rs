//! A request to the real-time thread to move one axis's setpoint at rest, without motion:
//! after homing, the drive's position has a new reference (the home offset at the home
//! position) while the machine stands where it stood, so the setpoint must take the drive's
//! position before the drive follows it again. Lock-free: the real-time thread reads one
//! atomic per cycle.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// The request: axis and position, and whether it is pending.
#[derive(Debug, Default)]
pub struct Reposition {
    pending: AtomicBool,
    axis: AtomicUsize,
    pos_bits: AtomicU64,
}

impl Reposition {
    /// Asks for axis `axis` to stand at `pos` (control thread).
    pub fn request(&self, axis: usize, pos: f64) {
        self.axis.store(axis, Ordering::Relaxed);
        self.pos_bits.store(pos.to_bits(), Ordering::Relaxed);
        self.pending.store(true, Ordering::Release);
    }

    /// The pending request, if any (real-time thread).
    #[inline]
    pub fn pending(&self) -> Option<(usize, f64)> {
        if !self.pending.load(Ordering::Acquire) {
            return None;
        }
        Some((self.axis.load(Ordering::Relaxed), f64::from_bits(self.pos_bits.load(Ordering::Relaxed))))
    }

    /// The request is carried out (real-time thread) or given up (control thread).
    pub fn clear(&self) {
        self.pending.store(false, Ordering::Release);
    }

    pub fn is_pending(&self) -> bool {
        self.pending.load(Ordering::Acquire)
    }
}
