//! The set of feasible durations of one DoF: `[t_min, ∞)` minus at most two open blocked
//! intervals (Ruckig RSS 2021, Sec. IV-B, "blocked intervals"). Step 1 finds every extremal
//! profile; their durations are the boundaries of this set, sorted: t_min, then pairs
//! (left, right) of blocked intervals. A profile with duration exactly `right` is kept for each
//! interval, so that the synchronised duration can land on it without running step 2.

use crate::profile::Profile;

/// Two durations closer than this (relative) are the same extremal profile found twice, e.g.
/// a profile on the border between two cases.
const DUPLICATE_REL: f64 = 1e-12;

/// A blocked interval of durations (left, right) and the profile whose duration is `right`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Interval {
    pub left: f64,
    pub right: f64,
    pub profile: Profile,
}

/// Feasible durations of one DoF and the profiles at their boundaries.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Block {
    pub t_min: f64,
    pub p_min: Profile,
    pub a: Option<Interval>,
    pub b: Option<Interval>,
}

impl Block {
    /// A block with only a minimum duration.
    pub(crate) fn single(profile: Profile) -> Block {
        Block { t_min: profile.duration(), p_min: profile, a: None, b: None }
    }

    /// Build the block from all valid extremal profiles. Returns `None` if there are none.
    pub(crate) fn from_profiles(profiles: &[Profile]) -> Option<Block> {
        let n_all = profiles.len();
        if n_all == 0 {
            return None;
        }
        // Sort indices by duration (insertion sort: at most a handful of candidates).
        let mut idx = [0usize; 16];
        let n_all = n_all.min(idx.len());
        for (k, slot) in idx.iter_mut().enumerate().take(n_all) {
            *slot = k;
        }
        for k in 1..n_all {
            let mut m = k;
            while m > 0 && profiles[idx[m - 1]].duration() > profiles[idx[m]].duration() {
                idx.swap(m - 1, m);
                m -= 1;
            }
        }
        // Drop duplicates.
        let mut unique = [0usize; 16];
        let mut n = 0;
        for &k in &idx[..n_all] {
            let d = profiles[k].duration();
            if n > 0 {
                let last = profiles[unique[n - 1]].duration();
                if (d - last).abs() <= DUPLICATE_REL * d.abs().max(last.abs()) {
                    continue;
                }
            }
            unique[n] = k;
            n += 1;
        }
        let interval = |lo: usize, hi: usize| Interval {
            left: profiles[unique[lo]].duration(),
            right: profiles[unique[hi]].duration(),
            profile: profiles[unique[hi]],
        };
        let mut block = Block::single(profiles[unique[0]]);
        match n {
            1 => {}
            // An even count means an extremal profile was missed (numerically); block
            // conservatively between the ones found so that every chosen duration is reachable.
            2 => block.a = Some(interval(0, 1)),
            3 => block.a = Some(interval(1, 2)),
            4 => {
                block.a = Some(interval(1, 3));
            }
            _ => {
                block.a = Some(interval(1, 2));
                block.b = Some(interval(3, n - 1));
            }
        }
        Some(block)
    }

    /// Whether duration `t` is not reachable by this DoF.
    #[inline]
    pub(crate) fn is_blocked(&self, t: f64) -> bool {
        t < self.t_min
            || self.a.as_ref().is_some_and(|i| i.left < t && t < i.right)
            || self.b.as_ref().is_some_and(|i| i.left < t && t < i.right)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_duration(d: f64) -> Profile {
        let mut p = Profile::default();
        p.t_end[6] = d;
        p
    }

    #[test]
    fn single_and_three_profiles() {
        let b = Block::from_profiles(&[with_duration(2.0)]).unwrap();
        assert_eq!(b.t_min, 2.0);
        assert!(b.a.is_none() && !b.is_blocked(5.0) && b.is_blocked(1.0));
        let b = Block::from_profiles(&[with_duration(4.0), with_duration(1.0), with_duration(3.0)]).unwrap();
        assert_eq!(b.t_min, 1.0);
        assert!(b.is_blocked(3.5) && !b.is_blocked(2.0) && !b.is_blocked(4.0) && !b.is_blocked(3.0));
    }

    #[test]
    fn duplicates_are_merged_and_five_give_two_intervals() {
        let b = Block::from_profiles(&[with_duration(1.0), with_duration(1.0 + 1e-15)]).unwrap();
        assert!(b.a.is_none());
        let ds = [5.0, 1.0, 2.0, 3.0, 4.0];
        let ps: Vec<Profile> = ds.iter().map(|&d| with_duration(d)).collect();
        let b = Block::from_profiles(&ps).unwrap();
        assert!(b.is_blocked(2.5) && b.is_blocked(4.5) && !b.is_blocked(3.5) && !b.is_blocked(1.5));
    }
}
