//! Online trajectory generation (OTG): time-optimal, jerk-limited state-to-state motion.
//!
//! From any kinematic state (p, v, a) to any target state, under velocity, acceleration and jerk
//! limits (asymmetric), for up to [`MAX_DOFS`] degrees of freedom that end together. The
//! algorithm follows Ruckig (L. Berscheid, T. Kröger: "Jerk-limited Real-time Trajectory
//! Generation with Arbitrary Target States", RSS 2021):
//!
//! 1. per DoF, bring an out-of-limit initial state back inside first ([`brake`] pre-phase);
//! 2. step 1: all time-extremal profiles of each DoF, giving its minimum duration and the
//!    blocked intervals of durations it cannot reach;
//! 3. the synchronised duration: the smallest duration no DoF blocks;
//! 4. step 2: for every other DoF a profile of exactly that duration.
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
mod frame;
mod position_step1;
mod position_step2;
mod position_step2_patterns;
pub mod profile;
mod roots;
mod trajectory;
mod velocity_step1;
mod velocity_step2;

use block::Block;
pub use brake::BrakeProfile;
pub use profile::{Direction, JerkSigns, Profile, ReachedLimits};
use std::fmt;
pub use trajectory::Trajectory;

/// Maximum number of degrees of freedom of one calculation.
pub const MAX_DOFS: usize = 9;

/// Two durations closer than this (relative) are the same; used to land exactly on a duration
/// that step 1 already has a profile for.
const SAME_DURATION_REL: f64 = 4.0 * f64::EPSILON;
/// Inputs whose components agree within this (relative to the vector norm) are collinear for
/// phase synchronisation.
const COLLINEAR_REL: f64 = 1e-12;

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
    /// All DoFs end together, at the duration of the slowest (respecting blocked intervals).
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
    /// Optional lower bound of the trajectory duration [s].
    pub min_duration: Option<f64>,
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
            min_duration: None,
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
            OtgError::NoProfile { dof } => write!(f, "DoF {dof}: no time-optimal profile found"),
            OtgError::NoSynchronization { dof, duration } => {
                write!(f, "DoF {dof}: no profile found for the synchronised duration {duration} s")
            }
        }
    }
}

impl std::error::Error for OtgError {}

/// The trajectory generator. Holds per-DoF scratch space so that [`Otg::calculate`] needs no
/// heap memory; create it once and reuse it every cycle.
#[derive(Clone, Debug)]
pub struct Otg {
    blocks: [Block; MAX_DOFS],
}

impl Default for Otg {
    fn default() -> Self {
        Otg::new()
    }
}

impl Otg {
    pub fn new() -> Otg {
        Otg { blocks: [Block::default(); MAX_DOFS] }
    }

    /// Calculate the trajectory for `input` into `trajectory`. Allocation-free.
    pub fn calculate(&mut self, input: &Input, trajectory: &mut Trajectory) -> Result<(), OtgError> {
        validate(input)?;
        let n = input.dofs;
        let position = input.control == ControlInterface::Position;
        trajectory.dofs = n;
        trajectory.limiting_dof = None;

        // Brake pre-phase and step 1 per DoF.
        let mut braked = [State::default(); MAX_DOFS];
        for dof in 0..n {
            let lim = &input.limits[dof];
            let current = input.current[dof];
            let mut brake = if position {
                BrakeProfile::for_position(current.v, current.a, lim)
            } else {
                BrakeProfile::for_velocity(current.a, lim)
            };
            braked[dof] = brake.finalize(current);
            let block = if position {
                position_step1::calculate(&braked[dof], &input.target[dof], lim, &brake)
            } else {
                velocity_step1::calculate(&braked[dof], &input.target[dof], lim, &brake)
            };
            let Some(block) = block else {
                return Err(OtgError::NoProfile { dof });
            };
            trajectory.independent_min_durations[dof] = block.t_min;
            self.blocks[dof] = block;
        }

        if input.sync == Synchronization::None || (n == 1 && input.min_duration.is_none()) {
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

        // The synchronised duration: the smallest candidate (a t_min, the right end of a
        // blocked interval, or the requested minimum) that no DoF blocks.
        let min_duration = input.min_duration.unwrap_or(0.0);
        let (duration, limiting) = self
            .synchronized_duration(n, input.min_duration)
            .ok_or(OtgError::NoSynchronization { dof: 0, duration: min_duration })?;
        trajectory.duration = duration;
        trajectory.limiting_dof = limiting.map(|(dof, _)| dof);
        if let Some((dof, which)) = limiting {
            let block = &self.blocks[dof];
            trajectory.profiles[dof] = match which {
                0 => block.p_min,
                1 => block.a.as_ref().map_or(block.p_min, |i| i.profile),
                _ => block.b.as_ref().map_or(block.p_min, |i| i.profile),
            };
        }

        if input.sync == Synchronization::Phase && self.phase_synchronize(input, trajectory) {
            return Ok(());
        }

        // Time synchronisation: every other DoF gets a profile of exactly that duration.
        for dof in 0..n {
            if limiting.is_some_and(|(l, _)| l == dof) {
                continue;
            }
            let block = &self.blocks[dof];
            let brake = block.p_min.brake;
            let t_profile = duration - brake.duration;
            let same = |t: f64| (t - duration).abs() <= SAME_DURATION_REL * duration;
            if same(block.t_min) {
                trajectory.profiles[dof] = block.p_min;
                continue;
            }
            if let Some(i) = block.a.as_ref().filter(|i| same(i.right)) {
                trajectory.profiles[dof] = i.profile;
                continue;
            }
            if let Some(i) = block.b.as_ref().filter(|i| same(i.right)) {
                trajectory.profiles[dof] = i.profile;
                continue;
            }
            let lim = &input.limits[dof];
            let found = if position {
                position_step2::calculate(t_profile, &braked[dof], &input.target[dof], lim, &brake)
            } else {
                velocity_step2::calculate(t_profile, &braked[dof], &input.target[dof], lim, &brake)
            };
            match found {
                Some(p) => trajectory.profiles[dof] = p,
                None => return Err(OtgError::NoSynchronization { dof, duration }),
            }
        }
        Ok(())
    }

    /// Smallest duration ≥ every t_min and ≥ `min_duration` that no DoF blocks, with the DoF and
    /// the block entry (0: t_min, 1: interval a, 2: interval b) it comes from (`None` when it is
    /// the requested minimum duration).
    fn synchronized_duration(&self, n: usize, min_duration: Option<f64>) -> Option<(f64, Option<(usize, u8)>)> {
        let blocks = &self.blocks[..n];
        let lower = blocks.iter().fold(min_duration.unwrap_or(0.0), |m, b| m.max(b.t_min));
        let free = |t: f64| blocks.iter().all(|b| !b.is_blocked(t));
        let mut best: Option<(f64, Option<(usize, u8)>)> = None;
        let mut consider = |t: f64, source: Option<(usize, u8)>| {
            if t >= lower && t.is_finite() && best.is_none_or(|(b, _)| t < b) && free(t) {
                best = Some((t, source));
            }
        };
        if let Some(t) = min_duration {
            consider(t, None);
        }
        for (dof, b) in blocks.iter().enumerate() {
            consider(b.t_min, Some((dof, 0)));
            if let Some(i) = &b.a {
                consider(i.right, Some((dof, 1)));
            }
            if let Some(i) = &b.b {
                consider(i.right, Some((dof, 2)));
            }
        }
        best
    }

    /// Phase synchronisation: if every DoF's (Δp, v0, a0, vf, af) is a multiple of the limiting
    /// DoF's, all DoFs use its phase durations with the jerk scaled by that multiple; each
    /// scaled profile is checked against its own limits. Returns false (and leaves the profiles
    /// to time synchronisation) if that is not possible.
    fn phase_synchronize(&self, input: &Input, trajectory: &mut Trajectory) -> bool {
        let Some(lim_dof) = trajectory.limiting_dof else {
            return false;
        };
        let n = input.dofs;
        let position = input.control == ControlInterface::Position;
        let reference = trajectory.profiles[lim_dof];
        if (0..n).any(|d| self.blocks[d].p_min.brake.duration > 0.0) {
            return false;
        }
        let vector = |d: usize| {
            let (c, t) = (input.current[d], input.target[d]);
            [if position { t.p - c.p } else { 0.0 }, c.v, c.a, t.v, t.a]
        };
        let r = vector(lim_dof);
        let r_norm2: f64 = r.iter().map(|x| x * x).sum();
        if !(r_norm2 > 0.0) {
            return false;
        }
        let mut profiles = trajectory.profiles;
        for dof in 0..n {
            if dof == lim_dof {
                continue;
            }
            let x = vector(dof);
            let scale = x.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() / r_norm2;
            let x_norm2: f64 = x.iter().map(|v| v * v).sum();
            let dev2: f64 = x.iter().zip(&r).map(|(a, b)| (a - scale * b).powi(2)).sum();
            if dev2 > (COLLINEAR_REL * COLLINEAR_REL) * x_norm2.max(r_norm2 * scale * scale) {
                return false;
            }
            let p = &mut profiles[dof];
            *p = reference;
            p.brake = BrakeProfile::default();
            for j in &mut p.j {
                *j *= scale;
            }
            p.set_start(input.current[dof]);
            let goal = profile::Goal { target: input.target[dof], position, duration: None };
            if p.check(&goal, &input.limits[dof]) != profile::Verdict::Accepted {
                return false;
            }
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
    if let Some(t) = input.min_duration {
        if !(t.is_finite() && t >= 0.0) {
            return Err(OtgError::InvalidMinDuration { value: t });
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
        input.min_duration = Some(-1.0);
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
        input.min_duration = Some(20.0);
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
