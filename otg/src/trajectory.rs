//! The result of a calculation: one profile per DoF, all ending together (time or phase
//! synchronisation) or independently, and sampling at any time.

use crate::phase::integrate;
use crate::profile::Profile;
use crate::{MAX_DOFS, State};

/// A DoF whose own duration is within this (relative) of the trajectory's ends with it.
const SAME_END_REL: f64 = 64.0 * f64::EPSILON;

/// A calculated multi-DoF trajectory (fixed capacity, no heap memory).
#[derive(Clone, Copy, Debug)]
pub struct Trajectory {
    pub(crate) dofs: usize,
    pub(crate) duration: f64,
    pub(crate) profiles: [Profile; MAX_DOFS],
    pub(crate) independent_min_durations: [f64; MAX_DOFS],
    pub(crate) limiting_dof: Option<usize>,
}

impl Default for Trajectory {
    fn default() -> Self {
        Trajectory {
            dofs: 0,
            duration: 0.0,
            profiles: [Profile::default(); MAX_DOFS],
            independent_min_durations: [0.0; MAX_DOFS],
            limiting_dof: None,
        }
    }
}

impl Trajectory {
    /// Number of DoFs.
    #[inline]
    pub fn dofs(&self) -> usize {
        self.dofs
    }

    /// Duration of the whole trajectory (s) (all DoFs have arrived).
    #[inline]
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// The profile of each DoF (brake pre-phase, seven phase durations and jerks, boundary states).
    #[inline]
    pub fn profiles(&self) -> &[Profile] {
        &self.profiles[..self.dofs]
    }

    /// Minimum duration each DoF would need on its own (s).
    #[inline]
    pub fn independent_min_durations(&self) -> &[f64] {
        &self.independent_min_durations[..self.dofs]
    }

    /// The DoF whose own minimum duration set the synchronised duration, if any (none when the
    /// duration was set by the requested minimum duration).
    #[inline]
    pub fn limiting_dof(&self) -> Option<usize> {
        self.limiting_dof
    }

    /// States of all DoFs at time `t` (s) from the start, written to `out[..dofs]`. Before 0 the
    /// start state is returned; after the end every DoF continues from its target state with
    /// constant acceleration (zero for a rest target).
    #[inline]
    pub fn at_time(&self, t: f64, out: &mut [State]) {
        for (dof, slot) in out.iter_mut().enumerate().take(self.dofs) {
            *slot = self.state_of(dof, t).0;
        }
    }

    /// State and jerk of one DoF at time `t` (s).
    #[inline]
    pub fn state_of(&self, dof: usize, t: f64) -> (State, f64) {
        let Some(profile) = self.profiles[..self.dofs].get(dof) else {
            return (State::default(), 0.0);
        };
        if t >= self.duration {
            // Every DoF has arrived: its end state, continued with its final acceleration from
            // its own end. A synchronised DoF's own duration equals `duration` only up to the
            // rounding of its phase sum: then the continuation starts at `duration`, so that
            // every DoF is exactly at its target there.
            let own_end = profile.duration();
            let from =
                if (own_end - self.duration).abs() <= SAME_END_REL * self.duration { self.duration } else { own_end };
            let (p, v, a) = integrate((t - from).max(0.0), profile.p[7], profile.v[7], profile.a[7], 0.0);
            return (State { p, v, a }, 0.0);
        }
        let (p, v, a, j) = profile.state_at(t.max(0.0));
        (State { p, v, a }, j)
    }

    /// Index of the phase DoF `dof` is in at time `t` (0..=1 brake, 2..=8 the seven phases,
    /// 9 after the end); useful to detect phase changes for logging.
    pub fn phase_at(&self, dof: usize, t: f64) -> usize {
        let Some(p) = self.profiles.get(dof) else {
            return 9;
        };
        let mut t = t.max(0.0);
        if p.brake.duration > 0.0 {
            if t < p.brake.duration {
                return if t < p.brake.t[0] { 0 } else { 1 };
            }
            t -= p.brake.duration;
        }
        match p.t_sum.iter().position(|&end| t < end) {
            Some(i) => 2 + i,
            None => 9,
        }
    }
}
