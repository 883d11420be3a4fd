//! Axis limits as the planner uses them: the configured limits times `planner.limit_fraction`,
//! so the continuous motion keeps a little headroom for rounding and the sampled checks.

use crate::Settings;
use crate::path::MAX_AXES;

/// Per-axis limits in axis units per s, s², s³ (already scaled by the limit fraction).
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    pub n_axes: usize,
    pub vel: [f64; MAX_AXES],
    pub acc_max: [f64; MAX_AXES],
    pub acc_min: [f64; MAX_AXES],
    pub jerk: [f64; MAX_AXES],
    /// Reciprocals of the limits above (the checks multiply instead of dividing).
    pub(crate) inv_vel: [f64; MAX_AXES],
    pub(crate) inv_acc_max: [f64; MAX_AXES],
    pub(crate) inv_acc_min: [f64; MAX_AXES],
    pub(crate) inv_jerk: [f64; MAX_AXES],
    /// The configured (unscaled) limits, for reporting ratios against them.
    pub configured_vel: [f64; MAX_AXES],
    pub configured_acc: [f64; MAX_AXES],
    pub configured_jerk: [f64; MAX_AXES],
    /// Time in which the jerk limit must move the acceleration step at a curvature jump, s
    /// (`[planner] curvature_jump_ms`; see `node.rs` `curvature_jump_cap`).
    pub curvature_jump_s: f64,
}

impl Limits {
    pub(crate) fn from_settings(settings: &Settings) -> Self {
        let f = settings.planner.limit_fraction;
        let mut l = Limits {
            n_axes: settings.axes.len(),
            vel: [f64::INFINITY; MAX_AXES],
            acc_max: [f64::INFINITY; MAX_AXES],
            acc_min: [f64::NEG_INFINITY; MAX_AXES],
            jerk: [f64::INFINITY; MAX_AXES],
            inv_vel: [0.0; MAX_AXES],
            inv_acc_max: [0.0; MAX_AXES],
            inv_acc_min: [0.0; MAX_AXES],
            inv_jerk: [0.0; MAX_AXES],
            configured_vel: [f64::INFINITY; MAX_AXES],
            configured_acc: [f64::INFINITY; MAX_AXES],
            configured_jerk: [f64::INFINITY; MAX_AXES],
            curvature_jump_s: settings.planner.curvature_jump_ms * 1e-3,
        };
        for (k, a) in settings.axes.iter().enumerate() {
            l.vel[k] = a.max_vel_per_s * f;
            l.acc_max[k] = a.max_acc_per_s2 * f;
            l.acc_min[k] = -a.max_acc_per_s2 * f;
            l.jerk[k] = a.max_jerk_per_s3 * f;
            l.inv_vel[k] = 1.0 / l.vel[k];
            l.inv_acc_max[k] = 1.0 / l.acc_max[k];
            l.inv_acc_min[k] = 1.0 / l.acc_min[k];
            l.inv_jerk[k] = 1.0 / l.jerk[k];
            l.configured_vel[k] = a.max_vel_per_s;
            l.configured_acc[k] = a.max_acc_per_s2;
            l.configured_jerk[k] = a.max_jerk_per_s3;
        }
        l
    }

    /// Recomputes the reciprocals after the limits were changed.
    pub(crate) fn refresh(&mut self) {
        for k in 0..self.n_axes {
            self.inv_vel[k] = 1.0 / self.vel[k];
            self.inv_acc_max[k] = 1.0 / self.acc_max[k];
            self.inv_acc_min[k] = 1.0 / self.acc_min[k];
            self.inv_jerk[k] = 1.0 / self.jerk[k];
        }
    }

    /// Smallest jerk limit over the axes: a path-level scale for sampling heuristics.
    pub(crate) fn min_jerk(&self) -> f64 {
        self.jerk[..self.n_axes].iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Smallest acceleration limit over the axes.
    pub(crate) fn min_acc(&self) -> f64 {
        self.acc_max[..self.n_axes]
            .iter()
            .zip(&self.acc_min[..self.n_axes])
            .map(|(a, b)| a.min(-b))
            .fold(f64::INFINITY, f64::min)
    }
}
