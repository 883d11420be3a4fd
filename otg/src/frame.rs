//! A normalised, direction-mirrored view of one DoF's problem.
//!
//! The step-1 and step-2 solvers are written once, for motion whose first jerk phase is positive
//! ("up"), in units where the jerk limit and the upper acceleration limit are 1. The problem in
//! the other direction is the mirror image (p, v, a negated; upper and lower limits swapped and
//! negated). Normalising removes j_max and a_max from every formula, keeps the numbers near 1 for
//! limits spanning many orders of magnitude, and halves the number of cases (Ruckig passes the
//! swapped limits with a negated jerk instead: RSS 2021, Sec. IV-A).
//!
//! Units: time t_unit = a_hi / j_max, acceleration a_hi, velocity a_hi·t_unit, position
//! a_hi·t_unit², where a_hi is the upper acceleration limit in the chosen direction.

use crate::profile::{Direction, Goal, JerkSigns, PolishSpec, Profile, ReachedLimits};
use crate::{Limits, State};

/// Mirror sign: +1 keeps the problem, -1 mirrors it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Orientation {
    Up,
    Down,
}

impl Orientation {
    #[inline]
    pub(crate) fn sign(self) -> f64 {
        match self {
            Orientation::Up => 1.0,
            Orientation::Down => -1.0,
        }
    }
}

/// The normalised problem (position interface; `pd` is unused by the velocity interface).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub orientation: Orientation,
    /// Seconds per normalised time unit.
    pub t_unit: f64,
    pub a_unit: f64,
    pub v_unit: f64,
    pub p_unit: f64,
    /// Real jerk limit (normalised jerk 1).
    pub j_real: f64,
    pub v0: f64,
    pub a0: f64,
    pub vf: f64,
    pub af: f64,
    /// Normalised distance to go.
    pub pd: f64,
    pub v_max: f64,
    pub v_min: f64,
    /// Lower acceleration limit (negative); the upper one is 1.
    pub a_min: f64,
}

/// A candidate in normalised units: durations and jerks (in units of the jerk limit).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Candidate {
    pub t: [f64; 7],
    pub j: [f64; 7],
    pub limits: ReachedLimits,
    pub signs: JerkSigns,
    pub polish: Polish,
}

/// Which phases polishing may adjust, in normalised terms (converted by the frame).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Polish {
    pub free: u8,
    pub rows: u8,
    /// Acceleration constraint at the end of a phase, normalised.
    pub acc_at: Option<(usize, f64)>,
}

impl Polish {
    pub(crate) const NONE: Polish = Polish { free: 0, rows: 0, acc_at: None };

    /// Free phases and the equations to satisfy (see [`PolishSpec`] row flags).
    pub(crate) const fn new(phases: &[usize], rows: u8) -> Polish {
        let spec = PolishSpec::free(phases);
        Polish { free: spec.free, rows, acc_at: None }
    }

    pub(crate) const fn with_acc_at(mut self, phase: usize, acc: f64) -> Polish {
        self.acc_at = Some((phase, acc));
        self
    }
}

pub(crate) const UDDU: [f64; 7] = [1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0];
pub(crate) const UDUD: [f64; 7] = [1.0, 0.0, -1.0, 0.0, 1.0, 0.0, -1.0];

impl Frame {
    /// Normalise `start → target` under `lim` in the given orientation.
    pub(crate) fn new(orientation: Orientation, start: &State, target: &State, lim: &Limits) -> Frame {
        let s = orientation.sign();
        let (v_hi, v_lo, a_hi, a_lo) = match orientation {
            Orientation::Up => (lim.v_max, lim.v_min, lim.a_max, lim.a_min),
            Orientation::Down => (-lim.v_min, -lim.v_max, -lim.a_min, -lim.a_max),
        };
        let t_unit = a_hi / lim.j_max;
        let a_unit = a_hi;
        let v_unit = a_hi * t_unit;
        let p_unit = v_unit * t_unit;
        Frame {
            orientation,
            t_unit,
            a_unit,
            v_unit,
            p_unit,
            j_real: lim.j_max,
            v0: s * start.v / v_unit,
            a0: s * start.a / a_unit,
            vf: s * target.v / v_unit,
            af: s * target.a / a_unit,
            pd: s * (target.p - start.p) / p_unit,
            v_max: v_hi / v_unit,
            v_min: v_lo / v_unit,
            a_min: a_lo / a_unit,
        }
    }

    /// Normalised duration of a real one.
    #[inline]
    pub(crate) fn time_to_frame(&self, t: f64) -> f64 {
        t / self.t_unit
    }

    /// Convert a candidate to real units, integrate it from `start` and check it against the goal
    /// and the limits (polishing if it is only slightly off target). On success `out` holds it.
    pub(crate) fn accept(&self, c: &Candidate, start: &State, goal: &Goal, lim: &Limits, out: &mut Profile) -> bool {
        let s = self.orientation.sign();
        for i in 0..7 {
            out.t[i] = c.t[i] * self.t_unit;
            out.j[i] = s * c.j[i] * self.j_real;
        }
        out.set_start(*start);
        out.limits = c.limits;
        out.signs = c.signs;
        out.direction = match self.orientation {
            Orientation::Up => Direction::Up,
            Orientation::Down => Direction::Down,
        };
        let spec = PolishSpec {
            free: c.polish.free,
            rows: c.polish.rows,
            acc_at: c.polish.acc_at.map(|(phase, acc)| (phase, s * acc * self.a_unit)),
        };
        out.check_or_polish(goal, lim, spec)
    }
}
