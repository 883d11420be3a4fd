//! Online trajectory generation (OTG): time-optimal, jerk-limited state-to-state motion.
//!
//! From any kinematic state (p, v, a) to any target state, under velocity, acceleration and jerk
//! limits (asymmetric), for up to [`MAX_DOFS`] degrees of freedom that end together. The
//! algorithm is Ruckig's (L. Berscheid, T. Kröger: "Jerk-limited Real-time Trajectory Generation
//! with Arbitrary Target States", RSS 2021), and its case analysis is ported from Ruckig's C++
//! source (MIT licence, <https://github.com/pantor/ruckig>, version 0.19):
//!
//! 1. per DoF, bring an out-of-limit initial state back inside first ([`brake`] pre-phase);
//! 2. step 1 (`position_step1`, `velocity_step1`): all time-extremal profiles of each DoF, giving
//!    its minimum duration and the blocked intervals of durations it cannot reach (`block`);
//! 3. the synchronised duration: the smallest duration no DoF blocks (optionally at least a
//!    minimum duration, or rounded up to a multiple of a period);
//! 4. step 2 (`position_step2`, `velocity_step2`): for every other DoF a profile of exactly that
//!    duration, or the limiting DoF's timing scaled (phase synchronisation, straight lines).
//!
//! Beyond Ruckig, so that every problem over six decades of limits is solved: the precisions of
//! the [`profile`] check are relative to the magnitudes instead of absolute, the profiles used are
//! refined by Newton steps on their phase durations until they integrate onto the target, step 2
//! has a fallback for durations far beyond the ramp times (`position_step2_cruise`), and there is
//! no upper bound on the duration (Ruckig refuses more than 7.6e3 s).
//!
//! Everything is computed in fixed-size arrays: [`Otg::calculate`] and [`Trajectory::at_time`]
//! never allocate, so they can run inside a real-time cycle.
//!
//! ```
//! use interpd_otg::{Input, Limits, Otg, State, Trajectory};
//! let mut input = Input::new(1);
//! input.current[0] = State { p: 0.0, v: 0.0, a: 0.0 };
//! input.target[0] = State { p: 10.0, v: 0.0, a: 0.0 };
//! input.limits[0] = Limits::symmetric(1.0, 1.0, 1.0);
//! let mut otg = Otg::new();
//! let mut trajectory = Trajectory::default();
//! otg.calculate(&input, &mut trajectory).unwrap();
//! assert!((trajectory.duration() - 12.0).abs() < 1e-12);
//! let mut now = [State::default(); 1];
//! trajectory.at_time(6.0, &mut now);
//! assert!((now[0].p - 5.0).abs() < 1e-12);
//! ```

mod block;
pub mod brake;
mod phase;
mod position_step1;
mod position_step2;
mod position_step2_cruise;
pub mod profile;
mod refine;
mod roots;
pub mod scurve;
mod trajectory;
mod velocity_step1;
mod velocity_step2;

use block::Block;
pub use brake::BrakeProfile;
use position_step1::MAX_PROFILES;
pub use profile::{ControlSigns, Direction, Profile, ReachedLimits};
use std::fmt;
pub use trajectory::Trajectory;

/// Maximum number of degrees of freedom of one calculation.
pub const MAX_DOFS: usize = 9;

/// The synchronised duration equals a DoF's extremal duration (so that its step-1 profile is
/// used instead of running step 2) when they agree within this, relative (Ruckig: 2 ε absolute).
const SAME_DURATION_REL: f64 = 4.0 * f64::EPSILON;
/// Phase synchronisation: a DoF's (Δp, v0, a0, vf, af) is a multiple of the reference DoF's when
/// every component agrees within this, relative to the largest value of that component over all
/// DoFs (Ruckig: ε absolute). The scaled profiles are checked against the target afterwards.
const COLLINEAR_REL: f64 = 1e-10;
/// Discrete durations: a candidate duration less than this (relative) above a multiple of the
/// period counts as that multiple (Ruckig: ε absolute).
const DISCRETE_REMAINDER_REL: f64 = 4.0 * f64::EPSILON;
/// Duration of a DoF's phase-synchronised profile must equal the trajectory's within this
/// (relative).
const PHASE_DURATION_REL: f64 = 1e-12;

/// Kinematic state of one DoF.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct State {
    /// Position.
    pub p: f64,
    /// Velocity.
    pub v: f64,
    /// Acceleration.
    pub a: f64,
}

/// Kinematic limits of one DoF (asymmetric velocity and acceleration limits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Upper velocity limit (> 0).
    pub v_max: f64,
    /// Lower velocity limit (< 0).
    pub v_min: f64,
    /// Upper acceleration limit (> 0).
    pub a_max: f64,
    /// Lower acceleration limit (< 0).
    pub a_min: f64,
    /// Jerk limit (> 0), symmetric.
    pub j_max: f64,
}

impl Limits {
    /// Symmetric limits: ±v, ±a, ±j.
    pub const fn symmetric(v: f64, a: f64, j: f64) -> Limits {
        Limits { v_max: v, v_min: -v, a_max: a, a_min: -a, j_max: j }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits::symmetric(1.0, 1.0, 1.0)
    }
}

/// What the target prescribes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ControlInterface {
    /// Reach the target position, velocity and acceleration.
    #[default]
    Position,
    /// Reach the target velocity and acceleration; the position is free (jog, override ramps).
    Velocity,
}

/// How the DoFs are synchronised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Synchronization {
    /// All DoFs end together, at the earliest duration every DoF can reach (respecting the
    /// blocked intervals).
    #[default]
    Time,
    /// Like `Time`, and when the inputs are collinear all DoFs share the same phase durations,
    /// so that the motion is a straight line in space; falls back to `Time` otherwise.
    Phase,
    /// Every DoF moves in its own minimum time.
    None,
}

/// Input of one calculation (fixed capacity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input {
    /// Number of DoFs used (1..=MAX_DOFS).
    pub dofs: usize,
    /// Current states.
    pub current: [State; MAX_DOFS],
    /// Target states.
    pub target: [State; MAX_DOFS],
    /// Limits per DoF.
    pub limits: [Limits; MAX_DOFS],
    /// Position or velocity interface.
    pub control: ControlInterface,
    /// Synchronisation of the DoFs.
    pub sync: Synchronization,
    /// Optional lower bound of the trajectory duration (s).
    pub min_duration_s: Option<f64>,
    /// Optional period (s): the (synchronised) duration becomes a multiple of it, so that the
    /// motion ends exactly on a control cycle. Ignored with `Synchronization::None`.
    pub discrete_period_s: Option<f64>,
}

impl Input {
    /// An input for `dofs` DoFs at rest at zero, with unit limits.
    pub fn new(dofs: usize) -> Input {
        Input {
            dofs,
            current: [State::default(); MAX_DOFS],
            target: [State::default(); MAX_DOFS],
            limits: [Limits::default(); MAX_DOFS],
            control: ControlInterface::Position,
            sync: Synchronization::Time,
            min_duration_s: None,
            discrete_period_s: None,
        }
    }
}

/// Why a calculation failed. Invalid input is reported before anything is computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OtgError {
    /// `dofs` is 0 or larger than [`MAX_DOFS`].
    InvalidDofs { dofs: usize },
    /// A state value is NaN or infinite.
    NonFinite { dof: usize, what: &'static str },
    /// A limit is not finite or has the wrong sign (v_max, a_max, j_max must be > 0,
    /// v_min, a_min < 0).
    InvalidLimit { dof: usize, limit: &'static str, value: f64 },
    /// The target velocity or acceleration is outside the limits, or the target state cannot be
    /// reached without leaving them.
    TargetOutsideLimits { dof: usize, what: &'static str, value: f64 },
    /// The requested minimum duration is negative or not finite.
    InvalidMinDuration { value: f64 },
    /// The period of discrete durations is not a positive finite number.
    InvalidDiscretePeriod { value: f64 },
    /// No profile found for this DoF (should not happen for valid input).
    NoProfile { dof: usize },
    /// No common duration or no profile of the synchronised duration for this DoF.
    NoSynchronization { dof: usize, duration: f64 },
}

impl fmt::Display for OtgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            OtgError::InvalidDofs { dofs } => write!(f, "number of DoFs {dofs} is not in 1..={MAX_DOFS}"),
            OtgError::NonFinite { dof, what } => write!(f, "DoF {dof}: {what} is not a finite number"),
            OtgError::InvalidLimit { dof, limit, value } => {
                write!(
                    f,
                    "DoF {dof}: limit {limit} = {value} is invalid (v_max, a_max, j_max must be > 0, v_min, a_min < 0)"
                )
            }
            OtgError::TargetOutsideLimits { dof, what, value } => {
                write!(f, "DoF {dof}: target {what} = {value} is outside the limits or cannot be reached within them")
            }
            OtgError::InvalidMinDuration { value } => write!(f, "minimum duration {value} must be finite and >= 0"),
            OtgError::InvalidDiscretePeriod { value } => {
                write!(f, "period of discrete durations {value} must be finite and > 0")
            }
            OtgError::NoProfile { dof } => write!(f, "DoF {dof}: no time-optimal profile found"),
            OtgError::NoSynchronization { dof, duration } => {
                write!(f, "DoF {dof}: no profile found for the synchronised duration {duration} s")
            }
        }
    }
}

impl std::error::Error for OtgError {}

/// Where the synchronised duration comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SyncSource {
    /// The minimum duration of a DoF (0) or the right end of its blocked interval a (1) or b (2).
    Dof(usize, u8),
    /// The requested minimum duration.
    MinDuration,
}

/// The trajectory generator. Holds per-DoF scratch space so that [`Otg::calculate`] needs no
/// heap memory; create it once and reuse it every cycle.
#[derive(Clone, Debug)]
pub struct Otg {
    blocks: [Block; MAX_DOFS],
    candidates: [Profile; MAX_PROFILES],
}

impl Default for Otg {
    fn default() -> Self {
        Otg::new()
    }
}

impl Otg {
    pub fn new() -> Otg {
        Otg { blocks: [Block::default(); MAX_DOFS], candidates: [Profile::default(); MAX_PROFILES] }
    }

    /// Calculate the trajectory for `input` into `trajectory`. Allocation-free.
    pub fn calculate(&mut self, input: &Input, trajectory: &mut Trajectory) -> Result<(), OtgError> {
        self.profiles(input, trajectory)?;
        // Refine the phase durations of the profiles actually used so that they integrate onto
        // the target (their durations are kept).
        let position = input.control == ControlInterface::Position;
        for (p, lim) in trajectory.profiles[..input.dofs].iter_mut().zip(&input.limits) {
            let t = p.t_sum[6];
            p.polish(position, Some(t), lim);
        }
        Ok(())
    }

    /// Brake, step 1, synchronisation and step 2: the profiles of all DoFs.
    fn profiles(&mut self, input: &Input, trajectory: &mut Trajectory) -> Result<(), OtgError> {
        validate(input)?;
        let n = input.dofs;
        trajectory.dofs = n;
        trajectory.limiting_dof = None;
        for dof in 0..n {
            self.step1(input, dof, &mut trajectory.profiles[dof])?;
            trajectory.independent_min_durations[dof] = self.blocks[dof].t_min;
        }

        let discrete = input.discrete_period_s.filter(|_| input.sync != Synchronization::None);
        let independent =
            input.sync == Synchronization::None || (n == 1 && input.min_duration_s.is_none() && discrete.is_none());
        if independent {
            let mut duration = 0.0f64;
            for dof in 0..n {
                trajectory.profiles[dof] = self.blocks[dof].p_min;
                if self.blocks[dof].t_min >= duration {
                    duration = self.blocks[dof].t_min;
                    trajectory.limiting_dof = Some(dof);
                }
            }
            trajectory.duration = duration;
            return Ok(());
        }

        let Some((duration, source)) = self.synchronized_duration(n, input.min_duration_s, discrete) else {
            return Err(OtgError::NoSynchronization { dof: 0, duration: input.min_duration_s.unwrap_or(0.0) });
        };
        trajectory.duration = duration;
        let limiting = match source {
            SyncSource::Dof(dof, which) => {
                trajectory.limiting_dof = Some(dof);
                let block = &self.blocks[dof];
                let profile = match which {
                    0 => Some(&block.p_min),
                    1 => block.a.as_ref().map(|i| &i.profile),
                    _ => block.b.as_ref().map(|i| &i.profile),
                };
                if let Some(p) = profile {
                    trajectory.profiles[dof] = *p;
                }
                // With discrete durations the limiting DoF also needs a profile of the rounded
                // duration (step 2 below).
                if discrete.is_some() { None } else { Some(dof) }
            }
            SyncSource::MinDuration => None,
        };
        if duration == 0.0 {
            for dof in 0..n {
                trajectory.profiles[dof] = self.blocks[dof].p_min;
            }
            return Ok(());
        }
        if discrete.is_some() {
            if let Some(dof) = trajectory.limiting_dof {
                self.time_synchronize(input, dof, duration, &mut trajectory.profiles[dof])?;
            }
        }

        if input.sync == Synchronization::Phase && self.phase_synchronize(input, trajectory) {
            return Ok(());
        }
        for dof in 0..n {
            if Some(dof) == limiting || (discrete.is_some() && Some(dof) == trajectory.limiting_dof) {
                continue;
            }
            self.time_synchronize(input, dof, duration, &mut trajectory.profiles[dof])?;
        }
        Ok(())
    }

    /// Brake pre-phase and step 1 of one DoF; leaves the boundary (braked start state, target,
    /// brake) in `profile` and the feasible durations in `self.blocks[dof]`.
    fn step1(&mut self, input: &Input, dof: usize, profile: &mut Profile) -> Result<(), OtgError> {
        let (c, t, l) = (&input.current[dof], &input.target[dof], &input.limits[dof]);
        let position = input.control == ControlInterface::Position;
        profile.brake = if position {
            BrakeProfile::position(c.v, c.a, l.v_max, l.v_min, l.a_max, l.a_min, l.j_max)
        } else {
            BrakeProfile::velocity(c.a, l.a_max, l.a_min, l.j_max)
        };
        let (mut p0, mut v0, mut a0) = (c.p, c.v, c.a);
        profile.brake.finalize(&mut p0, &mut v0, &mut a0);
        profile.set_boundary(p0, v0, a0, t.p, t.v, t.a);

        self.candidates[0].set_boundary_from(profile);
        let block = &mut self.blocks[dof];
        let found = if position {
            position_step1::calculate(&mut self.candidates, block, l.v_max, l.v_min, l.a_max, l.a_min, l.j_max)
        } else {
            velocity_step1::calculate(&mut self.candidates, block, l.a_max, l.a_min, l.j_max)
        };
        if found { Ok(()) } else { Err(OtgError::NoProfile { dof }) }
    }

    /// A profile of DoF `dof` lasting exactly `duration` (including its brake pre-phase):
    /// an extremal profile of step 1 if one has that duration, otherwise step 2.
    fn time_synchronize(&self, input: &Input, dof: usize, duration: f64, p: &mut Profile) -> Result<(), OtgError> {
        let block = &self.blocks[dof];
        let same = |t: f64| (t - duration).abs() <= SAME_DURATION_REL * duration;
        if same(block.t_min) {
            *p = block.p_min;
            return Ok(());
        }
        for interval in [&block.a, &block.b].into_iter().flatten() {
            if same(interval.right) {
                *p = interval.profile;
                return Ok(());
            }
        }
        // The boundary may have been overwritten by a failed phase synchronisation attempt or
        // by a step-1 profile: restore it from the block.
        p.set_boundary_from(&block.p_min);
        let t_profile = duration - p.brake.duration;
        let l = &input.limits[dof];
        let found = match input.control {
            ControlInterface::Position => {
                let t_min = block.t_min - p.brake.duration;
                position_step2::calculate(p, t_profile, t_min, l.v_max, l.v_min, l.a_max, l.a_min, l.j_max)
            }
            ControlInterface::Velocity => velocity_step2::calculate(p, t_profile, l.a_max, l.a_min, l.j_max),
        };
        if found { Ok(()) } else { Err(OtgError::NoSynchronization { dof, duration }) }
    }

    /// The smallest duration ≥ every DoF's minimum (and ≥ the requested minimum) that no DoF
    /// blocks, rounded up to the discrete period if one is given, and where it comes from.
    fn synchronized_duration(
        &self,
        n: usize,
        min_duration: Option<f64>,
        discrete: Option<f64>,
    ) -> Option<(f64, SyncSource)> {
        const CAP: usize = 3 * MAX_DOFS + 1;
        let mut times = [f64::INFINITY; CAP];
        let mut sources = [SyncSource::MinDuration; CAP];
        let mut count = 0;
        let mut push = |t: f64, s: SyncSource| {
            times[count] = t;
            sources[count] = s;
            count += 1;
        };
        for (dof, b) in self.blocks[..n].iter().enumerate() {
            push(b.t_min, SyncSource::Dof(dof, 0));
            if let Some(i) = &b.a {
                push(i.right, SyncSource::Dof(dof, 1));
            }
            if let Some(i) = &b.b {
                push(i.right, SyncSource::Dof(dof, 2));
            }
        }
        if let Some(t) = min_duration {
            push(t, SyncSource::MinDuration);
        }
        if let Some(period) = discrete {
            for t in &mut times[..count] {
                let remainder = *t % period;
                if remainder > DISCRETE_REMAINDER_REL * t.max(period) {
                    *t += period - remainder;
                }
            }
        }
        let lower = min_duration.unwrap_or(0.0);
        let mut best: Option<(f64, SyncSource)> = None;
        for k in 0..count {
            let t = times[k];
            if t < lower || !t.is_finite() || best.is_some_and(|(b, _)| t >= b) {
                continue;
            }
            let tol = SAME_DURATION_REL * t;
            if self.blocks[..n].iter().all(|b| !b.is_blocked_within(t, tol)) {
                best = Some((t, sources[k]));
            }
        }
        best
    }

    /// Phase synchronisation: if every DoF's (Δp, v0, a0, vf, af) is a multiple k of the
    /// limiting DoF's, every DoF gets the limiting DoF's phase durations with its jerk scaled by
    /// k, so that all DoFs move along a straight line; each scaled profile is checked against its
    /// own target and limits. Returns false (the profiles are then time-synchronised) if that is
    /// not possible.
    fn phase_synchronize(&self, input: &Input, trajectory: &mut Trajectory) -> bool {
        let Some(lim_dof) = trajectory.limiting_dof else {
            return false;
        };
        let n = input.dofs;
        if (0..n).any(|d| self.blocks[d].p_min.brake.duration > 0.0) {
            return false;
        }
        let position = input.control == ControlInterface::Position;
        let vector = |d: usize| {
            let (c, t) = (&input.current[d], &input.target[d]);
            [if position { t.p - c.p } else { 0.0 }, c.v, c.a, t.v, t.a]
        };
        // Largest magnitude of each component over all DoFs (the collinearity tolerance).
        let mut magnitude = [0.0f64; 5];
        for d in 0..n {
            for (m, x) in magnitude.iter_mut().zip(vector(d)) {
                *m = m.max(x.abs());
            }
        }
        // The reference component: the largest of the limiting DoF's, relative to its magnitude.
        let reference = vector(lim_dof);
        let Some(k_ref) = (0..5)
            .filter(|&k| magnitude[k] > 0.0)
            .max_by(|&x, &y| (reference[x].abs() / magnitude[x]).total_cmp(&(reference[y].abs() / magnitude[y])))
        else {
            return false;
        };
        if reference[k_ref] == 0.0 {
            return false;
        }
        let p_lim = trajectory.profiles[lim_dof];
        let j_lim = p_lim.ramp_jerk();
        let mut profiles = trajectory.profiles;
        for (dof, p) in profiles.iter_mut().enumerate().take(n) {
            if dof == lim_dof {
                continue;
            }
            let x = vector(dof);
            let scale = x[k_ref] / reference[k_ref];
            let collinear = (0..5).all(|k| (x[k] - scale * reference[k]).abs() <= COLLINEAR_REL * magnitude[k]);
            if !collinear {
                return false;
            }
            p.t = p_lim.t;
            let l = &input.limits[dof];
            let jf = j_lim * scale;
            let ok = match input.control {
                ControlInterface::Position => p.check_with_timing_and_jerk(
                    trajectory.duration,
                    p_lim.control_signs,
                    ReachedLimits::None,
                    jf,
                    l.v_max,
                    l.v_min,
                    l.a_max,
                    l.a_min,
                    l.j_max,
                ),
                ControlInterface::Velocity => p.check_for_velocity_with_timing_and_jerk(
                    trajectory.duration,
                    p_lim.control_signs,
                    ReachedLimits::None,
                    jf,
                    l.a_max,
                    l.a_min,
                    l.j_max,
                ),
            };
            let within = !position || p.velocity_within(l.v_max, l.v_min);
            if !ok || !within || (p.duration() - trajectory.duration).abs() > PHASE_DURATION_REL * trajectory.duration {
                return false;
            }
            p.limits = p_lim.limits;
        }
        trajectory.profiles = profiles;
        true
    }
}

/// Reject invalid input before computing anything.
fn validate(input: &Input) -> Result<(), OtgError> {
    let n = input.dofs;
    if n == 0 || n > MAX_DOFS {
        return Err(OtgError::InvalidDofs { dofs: n });
    }
    if let Some(t) = input.min_duration_s {
        if !(t.is_finite() && t >= 0.0) {
            return Err(OtgError::InvalidMinDuration { value: t });
        }
    }
    if let Some(t) = input.discrete_period_s {
        if !(t.is_finite() && t > 0.0) {
            return Err(OtgError::InvalidDiscretePeriod { value: t });
        }
    }
    let position = input.control == ControlInterface::Position;
    for dof in 0..n {
        let (c, t, l) = (&input.current[dof], &input.target[dof], &input.limits[dof]);
        for (value, what) in [
            (c.p, "current position"),
            (c.v, "current velocity"),
            (c.a, "current acceleration"),
            (t.p, "target position"),
            (t.v, "target velocity"),
            (t.a, "target acceleration"),
        ] {
            if !value.is_finite() {
                return Err(OtgError::NonFinite { dof, what });
            }
        }
        for (value, limit, positive) in [
            (l.v_max, "v_max", true),
            (l.v_min, "v_min", false),
            (l.a_max, "a_max", true),
            (l.a_min, "a_min", false),
            (l.j_max, "j_max", true),
        ] {
            let ok = value.is_finite() && if positive { value > 0.0 } else { value < 0.0 };
            if !ok {
                return Err(OtgError::InvalidLimit { dof, limit, value });
            }
        }
        if t.a > l.a_max || t.a < l.a_min {
            return Err(OtgError::TargetOutsideLimits { dof, what: "acceleration", value: t.a });
        }
        if position {
            if t.v > l.v_max || t.v < l.v_min {
                return Err(OtgError::TargetOutsideLimits { dof, what: "velocity", value: t.v });
            }
            // Arriving with a_f < 0 means the velocity was higher just before, and vice versa.
            let v_before = t.v - t.a * t.a.abs() / (2.0 * l.j_max);
            if (t.a < 0.0 && v_before > l.v_max) || (t.a > 0.0 && v_before < l.v_min) {
                return Err(OtgError::TargetOutsideLimits { dof, what: "velocity before arrival", value: v_before });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn calc(input: &Input) -> Result<Trajectory, OtgError> {
        let mut otg = Otg::new();
        let mut t = Trajectory::default();
        otg.calculate(input, &mut t).map(|_| t)
    }

    #[test]
    fn invalid_inputs_are_typed_errors() {
        let mut input = Input::new(1);
        input.target[0].p = 1.0;
        input.limits[0].j_max = 0.0;
        assert!(matches!(calc(&input), Err(OtgError::InvalidLimit { limit: "j_max", .. })));
        input.limits[0] = Limits::default();
        input.current[0].v = f64::NAN;
        assert!(matches!(calc(&input), Err(OtgError::NonFinite { .. })));
        input.current[0].v = 0.0;
        input.target[0].v = 2.0;
        assert!(matches!(calc(&input), Err(OtgError::TargetOutsideLimits { .. })));
        assert!(matches!(calc(&Input::new(0)), Err(OtgError::InvalidDofs { .. })));
        assert!(matches!(calc(&Input::new(MAX_DOFS + 1)), Err(OtgError::InvalidDofs { .. })));
        let mut input = Input::new(1);
        input.min_duration_s = Some(-1.0);
        assert!(matches!(calc(&input), Err(OtgError::InvalidMinDuration { .. })));
    }

    #[test]
    fn time_synchronised_dofs_end_together() {
        let mut input = Input::new(3);
        input.target[0].p = 10.0;
        input.target[1].p = 1.0;
        input.target[2] = State { p: -2.0, v: 0.3, a: 0.0 };
        let t = calc(&input).unwrap();
        assert!((t.duration() - 12.0).abs() < 1e-12);
        let mut end = [State::default(); 3];
        t.at_time(t.duration(), &mut end);
        for (s, target) in end.iter().zip(&input.target) {
            assert!((s.p - target.p).abs() < 1e-9 && (s.v - target.v).abs() < 1e-9, "{s:?} vs {target:?}");
        }
        for p in t.profiles() {
            assert!((p.duration() - 12.0).abs() < 1e-9);
        }
    }

    #[test]
    fn min_duration_stretches_the_motion() {
        let mut input = Input::new(1);
        input.target[0].p = 1.0;
        input.min_duration_s = Some(20.0);
        let t = calc(&input).unwrap();
        assert!((t.duration() - 20.0).abs() < 1e-12);
        assert!((t.profiles()[0].duration() - 20.0).abs() < 1e-9);
    }

    #[test]
    fn phase_synchronisation_gives_a_straight_line() {
        let mut input = Input::new(2);
        input.sync = Synchronization::Phase;
        input.target[0].p = 4.0;
        input.target[1].p = 1.0;
        let t = calc(&input).unwrap();
        let mut s = [State::default(); 2];
        for k in 0..=20 {
            t.at_time(t.duration() * k as f64 / 20.0, &mut s);
            assert!((s[0].p - 4.0 * s[1].p).abs() < 1e-12);
        }
    }

    #[test]
    fn discrete_durations_are_multiples_of_the_period() {
        let mut input = Input::new(2);
        input.target[0].p = 10.0;
        input.target[1] = State { p: -3.0, v: 0.2, a: 0.0 };
        input.discrete_period_s = Some(0.7);
        let t = calc(&input).unwrap();
        // 12 s continuous: the next multiple of 0.7 s is 12.6 s.
        assert!((t.duration() - 12.6).abs() < 1e-9, "{}", t.duration());
        let mut end = [State::default(); 2];
        t.at_time(t.duration(), &mut end);
        assert!((end[0].p - 10.0).abs() < 1e-9 && (end[1].p + 3.0).abs() < 1e-9 && (end[1].v - 0.2).abs() < 1e-9);
        input.discrete_period_s = Some(0.0);
        assert!(matches!(calc(&input), Err(OtgError::InvalidDiscretePeriod { .. })));
    }

    #[test]
    fn without_synchronisation_each_dof_takes_its_own_time() {
        let mut input = Input::new(2);
        input.sync = Synchronization::None;
        input.target[0].p = 10.0;
        input.target[1].p = 2.0;
        let t = calc(&input).unwrap();
        assert!((t.duration() - 12.0).abs() < 1e-12);
        assert!((t.profiles()[1].duration() - 4.0).abs() < 1e-12);
        // DoF 1 rests at its target after 4 s.
        let (s, j) = t.state_of(1, 8.0);
        assert!((s.p - 2.0).abs() < 1e-12 && s.v == 0.0 && j == 0.0);
    }

    #[test]
    fn initial_state_outside_the_limits_is_braked() {
        let mut input = Input::new(1);
        input.current[0] = State { p: 0.0, v: 3.0, a: 2.0 };
        input.target[0].p = 1.0;
        let t = calc(&input).unwrap();
        let p = &t.profiles()[0];
        assert!(p.brake.duration > 0.0);
        // After the brake the state is inside the limits and stays there.
        for k in 0..=100 {
            let time = p.brake.duration + (t.duration() - p.brake.duration) * k as f64 / 100.0;
            let (s, _) = t.state_of(0, time);
            assert!(s.a.abs() <= 1.0 + 1e-9, "{time}: {s:?}");
        }
        let (end, _) = t.state_of(0, t.duration());
        assert!((end.p - 1.0).abs() < 1e-9 && end.v.abs() < 1e-9);
    }

    #[test]
    fn velocity_interface_reaches_velocity() {
        let mut input = Input::new(2);
        input.control = ControlInterface::Velocity;
        input.target[0].v = 0.8;
        input.target[1].v = -0.2;
        let t = calc(&input).unwrap();
        let mut s = [State::default(); 2];
        t.at_time(t.duration(), &mut s);
        assert!((s[0].v - 0.8).abs() < 1e-9 && (s[1].v + 0.2).abs() < 1e-9 && s[0].a.abs() < 1e-9);
    }
}
