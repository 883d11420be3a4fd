//! Counting what a recording missed: cycle numbers go up by one per sample, so a jump of
//! more than one is samples lost (the subscriber's buffer overflowed, or it joined late), and
//! a step back is a new stream (the publisher restarted).

use std::fmt;

/// Per-stream counts of a recording.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamCount {
    /// Samples recorded.
    pub samples: u64,
    /// First and last cycle number recorded.
    pub first_cycle: Option<u64>,
    pub last_cycle: Option<u64>,
    /// Cycle numbers skipped between consecutive samples (lost samples).
    pub missing: u64,
    /// Places where the cycle number did not increase (a restarted or repeated stream).
    pub restarts: u64,
    /// Samples received but not recorded because they were invalid (wrong version, NaN ...).
    pub invalid: u64,
}

impl StreamCount {
    /// Accounts for one recorded sample with cycle number `cycle`.
    pub fn record(&mut self, cycle: u64) {
        match self.last_cycle {
            Some(last) if cycle > last => self.missing += cycle - last - 1,
            Some(_) => self.restarts += 1,
            None => self.first_cycle = Some(cycle),
        }
        self.last_cycle = Some(cycle);
        self.samples += 1;
    }
}

impl fmt::Display for StreamCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.samples)?;
        if let (Some(a), Some(b)) = (self.first_cycle, self.last_cycle) {
            write!(f, " (cycles {a}–{b}, {} missing", self.missing)?;
            if self.restarts > 0 {
                write!(f, ", {} restarts", self.restarts)?;
            }
            write!(f, ")")?;
        }
        if self.invalid > 0 {
            write!(f, ", {} invalid not recorded", self.invalid)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_missing_cycles_and_restarts() {
        let mut c = StreamCount::default();
        for cycle in [5, 6, 7, 10, 11, 0, 1] {
            c.record(cycle);
        }
        assert_eq!(c.samples, 7);
        assert_eq!(c.first_cycle, Some(5));
        assert_eq!(c.last_cycle, Some(1));
        assert_eq!(c.missing, 2);
        assert_eq!(c.restarts, 1);
        assert_eq!(c.to_string(), "7 (cycles 5–1, 2 missing, 1 restarts)");
        assert_eq!(StreamCount::default().to_string(), "0");
    }
}
