//! The latest setpoint, readable by any thread without a lock: the real-time thread stores
//! each cycle's values in atomics (a reader may see fields of neighbouring cycles, which is
//! fine for a status display).

use interpd_motion::path::MAX_AXES;
use interpd_protocol::shm::Setpoints;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

/// The latest setpoint in atomics.
#[derive(Debug, Default)]
pub struct LiveSetpoint {
    cycle: AtomicU64,
    flags: AtomicU32,
    line: AtomicU32,
    s_mm: AtomicU64,
    v_mm_s: AtomicU64,
    feed_override: AtomicU64,
    pos: [AtomicU64; MAX_AXES],
}

/// A copy of the values of [`LiveSetpoint`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LiveValues {
    pub cycle: u64,
    pub flags: u32,
    pub line: u32,
    pub s_mm: f64,
    pub v_mm_s: f64,
    pub feed_override: f64,
    pub pos: [f64; MAX_AXES],
}

impl LiveSetpoint {
    /// Stores `sp` (real-time thread; a handful of relaxed stores).
    #[inline]
    pub fn store(&self, sp: &Setpoints) {
        self.cycle.store(sp.cycle, Relaxed);
        self.flags.store(sp.flags, Relaxed);
        self.line.store(sp.line, Relaxed);
        self.s_mm.store(sp.s_mm.to_bits(), Relaxed);
        self.v_mm_s.store(sp.v_mm_s.to_bits(), Relaxed);
        self.feed_override.store(sp.feed_override.to_bits(), Relaxed);
        for (a, p) in self.pos.iter().zip(sp.pos.iter()) {
            a.store(p.to_bits(), Relaxed);
        }
    }

    pub fn load(&self) -> LiveValues {
        let mut pos = [0.0; MAX_AXES];
        for (p, a) in pos.iter_mut().zip(self.pos.iter()) {
            *p = f64::from_bits(a.load(Relaxed));
        }
        LiveValues {
            cycle: self.cycle.load(Relaxed),
            flags: self.flags.load(Relaxed),
            line: self.line.load(Relaxed),
            s_mm: f64::from_bits(self.s_mm.load(Relaxed)),
            v_mm_s: f64::from_bits(self.v_mm_s.load(Relaxed)),
            feed_override: f64::from_bits(self.feed_override.load(Relaxed)),
            pos,
        }
    }
}
