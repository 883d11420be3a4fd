//! The set of feasible durations of one DoF: `[t_min, ∞)` minus at most two open blocked
//! intervals (Berscheid & Kröger, RSS 2021, Sec. IV-B). Step 1 finds every time-extremal
//! profile; their durations are the boundaries of this set. A profile whose duration is the right
//! end of each interval is kept, so that the synchronised duration can land on it without
//! running step 2.
//!
//! Ported from Ruckig's `block.hpp` (MIT licence, <https://github.com/pantor/ruckig>),
//! including its handling of the profile counts that only numerical issues produce (2 and 4).

use crate::profile::Profile;

/// Two extremal profiles closer than this (s) are the same profile found twice (Ruckig: 8 ε).
const SAME_PROFILE_S: f64 = 8.0 * f64::EPSILON;
/// Tolerances (s) for pairing up "identical" profiles of opposite direction when four are found
/// (Ruckig: 32 ε and 256 ε).
const IDENTICAL_FIRST_S: f64 = 32.0 * f64::EPSILON;
const IDENTICAL_OTHER_S: f64 = 256.0 * f64::EPSILON;

/// A blocked interval of durations (left, right) and the profile whose duration is `right`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Interval {
    pub left: f64,
    pub right: f64,
    pub profile: Profile,
}

impl Interval {
    /// The interval between two extremal profiles (in either order).
    fn between(x: &Profile, y: &Profile) -> Interval {
        let (dx, dy) = (x.duration(), y.duration());
        if dx < dy {
            Interval { left: dx, right: dy, profile: *y }
        } else {
            Interval { left: dy, right: dx, profile: *x }
        }
    }
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
    pub(crate) fn set_min_profile(&mut self, profile: &Profile) {
        self.p_min = *profile;
        self.t_min = profile.duration();
        self.a = None;
        self.b = None;
    }

    /// Build the block from the valid extremal profiles (in the order step 1 found them).
    /// Returns false if their number is inconsistent.
    pub(crate) fn calculate(&mut self, profiles: &mut [Profile], count: usize) -> bool {
        let mut n = count;
        let total = |p: &Profile| p.t_sum[6];
        match n {
            1 => {
                self.set_min_profile(&profiles[0]);
                return true;
            }
            2 => {
                if (total(&profiles[0]) - total(&profiles[1])).abs() < SAME_PROFILE_S {
                    self.set_min_profile(&profiles[0]);
                    return true;
                }
                // An extremal profile was missed numerically: block everything between the two
                // found, so that every chosen duration is reachable.
                let idx_min = if total(&profiles[0]) < total(&profiles[1]) { 0 } else { 1 };
                let other = 1 - idx_min;
                self.set_min_profile(&profiles[idx_min]);
                self.a = Some(Interval::between(&profiles[idx_min], &profiles[other]));
                return true;
            }
            4 => {
                // Numerical issues: one profile found twice (in both directions).
                let d = |i: usize, k: usize| (total(&profiles[i]) - total(&profiles[k])).abs();
                let opposite = |i: usize, k: usize| profiles[i].direction != profiles[k].direction;
                let remove = if d(0, 1) < IDENTICAL_FIRST_S && opposite(0, 1) {
                    1
                } else if (d(2, 3) < IDENTICAL_OTHER_S && opposite(2, 3))
                    || (d(0, 3) < IDENTICAL_OTHER_S && opposite(0, 3))
                {
                    3
                } else {
                    return false;
                };
                profiles.copy_within(remove + 1..n, remove);
                n -= 1;
            }
            _ if n % 2 == 0 => return false,
            _ => {}
        }

        let mut idx_min = 0;
        for i in 1..n {
            if total(&profiles[i]) < total(&profiles[idx_min]) {
                idx_min = i;
            }
        }
        self.set_min_profile(&profiles[idx_min]);
        let at = |k: usize| &profiles[(idx_min + k) % n];
        if n == 3 {
            self.a = Some(Interval::between(at(1), at(2)));
            true
        } else if n == 5 {
            if at(1).direction == at(2).direction {
                self.a = Some(Interval::between(at(1), at(2)));
                self.b = Some(Interval::between(at(3), at(4)));
            } else {
                self.a = Some(Interval::between(at(1), at(4)));
                self.b = Some(Interval::between(at(2), at(3)));
            }
            true
        } else {
            false
        }
    }

    /// Whether duration `t` is not reachable by this DoF, where durations within `tol` of one
    /// of the DoF's stored extremal profiles (the minimum, the right ends of the intervals) are
    /// that profile's: two DoFs' equal extremal durations may differ by rounding.
    #[inline]
    pub(crate) fn is_blocked_within(&self, t: f64, tol: f64) -> bool {
        let near = |x: f64| (t - x).abs() <= tol;
        let stored = near(self.t_min)
            || self.a.as_ref().is_some_and(|i| near(i.right))
            || self.b.as_ref().is_some_and(|i| near(i.right));
        !stored && self.is_blocked(t)
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
        p.t_sum[6] = d;
        p
    }

    #[test]
    fn single_and_three_profiles() {
        let mut b = Block::default();
        assert!(b.calculate(&mut [with_duration(2.0)], 1));
        assert_eq!(b.t_min, 2.0);
        assert!(b.a.is_none() && !b.is_blocked(5.0) && b.is_blocked(1.0));
        let mut ps = [with_duration(4.0), with_duration(1.0), with_duration(3.0)];
        assert!(b.calculate(&mut ps, 3));
        assert_eq!(b.t_min, 1.0);
        assert!(b.is_blocked(3.5) && !b.is_blocked(2.0) && !b.is_blocked(4.0) && !b.is_blocked(3.0));
        assert_eq!(b.a.unwrap().profile.duration(), 4.0);
    }

    #[test]
    fn duplicates_and_five_profiles() {
        let mut b = Block::default();
        assert!(b.calculate(&mut [with_duration(1.0), with_duration(1.0 + 1e-16)], 2));
        assert!(b.a.is_none());
        let mut ps =
            [with_duration(1.0), with_duration(2.0), with_duration(3.0), with_duration(4.0), with_duration(5.0)];
        assert!(b.calculate(&mut ps, 5));
        assert!(b.is_blocked(2.5) && b.is_blocked(4.5) && !b.is_blocked(3.5) && !b.is_blocked(1.5));
        assert!(!b.calculate(&mut ps, 0));
    }
}
