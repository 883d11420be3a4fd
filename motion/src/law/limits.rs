//! Axis limits a law move is checked against, and the error naming the limit it breaks.

use crate::Settings;
use interpd_config::{AxisConfig, AxisLetter};
use std::fmt;

/// Limits of one machine axis in its unit (mm or deg) per s, s², s³, and its travel range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimits {
    pub name: AxisLetter,
    /// "mm" or "deg", for messages.
    pub unit: &'static str,
    pub max_vel_per_s: f64,
    pub max_acc_per_s2: f64,
    pub max_jerk_per_s3: f64,
    pub min_pos: f64,
    pub max_pos: f64,
}

impl AxisLimits {
    pub(crate) fn from_axis(a: &AxisConfig) -> Self {
        AxisLimits {
            name: a.name,
            unit: a.kind.unit(),
            max_vel_per_s: a.max_vel_per_s,
            max_acc_per_s2: a.max_acc_per_s2,
            max_jerk_per_s3: a.max_jerk_per_s3,
            min_pos: a.min_pos,
            max_pos: a.max_pos,
        }
    }

    /// The configured limits of every axis, in machine axis order (indices of [`super::LawAxis`]).
    pub fn from_settings(settings: &Settings) -> Vec<Self> {
        settings.axes.iter().map(Self::from_axis).collect()
    }

    /// The limit on the k-th time derivative (1 velocity, 2 acceleration, 3 jerk).
    pub(crate) fn of(&self, kind: LimitKind) -> f64 {
        match kind {
            LimitKind::Velocity => self.max_vel_per_s,
            LimitKind::Acceleration => self.max_acc_per_s2,
            LimitKind::Jerk => self.max_jerk_per_s3,
        }
    }
}

/// Which dynamic limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitKind {
    Velocity,
    Acceleration,
    Jerk,
}

impl LimitKind {
    pub const ALL: [LimitKind; 3] = [LimitKind::Velocity, LimitKind::Acceleration, LimitKind::Jerk];

    /// The time derivative order k: the peak of this quantity scales with 1/Tᵏ.
    pub fn order(self) -> i32 {
        match self {
            LimitKind::Velocity => 1,
            LimitKind::Acceleration => 2,
            LimitKind::Jerk => 3,
        }
    }

    /// Unit suffix after the axis unit: "/s", "/s²", "/s³".
    fn per(self) -> &'static str {
        match self {
            LimitKind::Velocity => "/s",
            LimitKind::Acceleration => "/s²",
            LimitKind::Jerk => "/s³",
        }
    }
}

impl fmt::Display for LimitKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LimitKind::Velocity => "velocity",
            LimitKind::Acceleration => "acceleration",
            LimitKind::Jerk => "jerk",
        })
    }
}

/// Why a law move may not run as it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// A dynamic limit is exceeded; the move becomes feasible with `factor` × the duration.
    #[error(
        "axis {axis}: peak {kind} {peak:.6} {unit}{per} exceeds the limit {limit} {unit}{per}; the duration must \
         grow by a factor of {factor:.6} to {min_duration_s:.6} s",
        per = kind.per()
    )]
    Exceeded {
        /// Machine axis index.
        axis_index: usize,
        axis: AxisLetter,
        unit: &'static str,
        kind: LimitKind,
        /// |stroke|·C / Tᵏ at the requested duration.
        peak: f64,
        limit: f64,
        /// (peak/limit)^(1/k) > 1: how much longer the move must take.
        factor: f64,
        /// duration × factor: the shortest duration this move may have.
        min_duration_s: f64,
    },
    /// The law leaves the travel range; no duration fixes that.
    #[error("axis {axis}: the move reaches {pos:.6} {unit}, outside the travel range [{min}, {max}] {unit}")]
    Travel { axis_index: usize, axis: AxisLetter, unit: &'static str, pos: f64, min: f64, max: f64 },
    #[error("move axis index {index} does not exist: the machine has {count} axes")]
    NoSuchAxis { index: usize, count: usize },
}
