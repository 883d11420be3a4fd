//! A motion law executed as a timed move of one or several synchronised axes: axis k follows
//! p_k(t) = start_k + stroke_k · f(t/T). Checked against the axis limits before it starts,
//! stretched in time when asked, and sampled allocation-free in the fine cycle.

use super::characteristic::Characteristics;
use super::limits::{AxisLimits, LimitError, LimitKind};
use super::polynomial::Law;
use interpd_config::MAX_AXES;

/// The law must start and end at rest: |f(0)|, |f(1) − 1|, |f′|, |f″| at both ends ≤ this.
pub(super) const REST_TOL: f64 = 1e-9;

/// A peak may exceed its limit by this share (rounding of the stretched duration) and pass.
pub(super) const LIMIT_REL_TOL: f64 = 1e-12;

/// A position may pass the travel limit by this much (axis unit) and pass.
pub(super) const TRAVEL_TOL: f64 = 1e-9;

/// Longest accepted duration, s (a day: longer is a typo, not a cam move).
pub(super) const MAX_DURATION_S: f64 = 86_400.0;

/// Largest |stroke| and |start|, axis unit.
pub(super) const MAX_ABS_POS: f64 = 1e9;

/// One axis of a law move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawAxis {
    /// Machine axis index (order of `[[axis]]` in the configuration).
    pub axis: usize,
    /// Position at t = 0, axis unit (mm or deg).
    pub start: f64,
    /// Signed stroke, axis unit: the axis ends at start + stroke.
    pub stroke: f64,
}

/// Setpoint of one axis at a time t, axis unit per s, s², s³.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AxisState {
    pub pos: f64,
    pub vel_per_s: f64,
    pub acc_per_s2: f64,
    pub jerk_per_s3: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawMoveError {
    #[error("the law is not rest to rest: {what} = {value:e} (must be {want} within {REST_TOL:e})")]
    NotRestToRest { what: &'static str, value: f64, want: f64 },
    #[error("duration must be a number in (0, {MAX_DURATION_S}] s, got {0}")]
    BadDuration(f64),
    #[error("axis index {axis}: {what} must be finite with magnitude ≤ 1e9, got {value}")]
    BadPosition { axis: usize, what: &'static str, value: f64 },
    #[error("a law move needs 1 to {MAX_AXES} axes, got {0}")]
    AxisCount(usize),
    #[error("axis index {0} appears twice in the move")]
    DuplicateAxis(usize),
}

/// A motion law as a move: the law, the axes with their start and stroke, the duration.
#[derive(Debug, Clone, PartialEq)]
pub struct LawMove {
    law: Law,
    axes: Vec<LawAxis>,
    duration_s: f64,
    /// The law's characteristic values, computed once.
    chars: Characteristics,
}

impl LawMove {
    /// Validates the pieces; the law must be rest to rest (f(0) = 0, f(1) = 1, f′ = f″ = 0 at
    /// both ends) so the axes start and stop without steps in velocity or acceleration.
    pub fn new(law: Law, axes: Vec<LawAxis>, duration_s: f64) -> Result<Self, LawMoveError> {
        check_rest_to_rest(&law)?;
        if !(duration_s > 0.0 && duration_s <= MAX_DURATION_S) {
            return Err(LawMoveError::BadDuration(duration_s));
        }
        if axes.is_empty() || axes.len() > MAX_AXES {
            return Err(LawMoveError::AxisCount(axes.len()));
        }
        for (k, a) in axes.iter().enumerate() {
            for (what, value) in [("start", a.start), ("stroke", a.stroke)] {
                if !value.is_finite() || value.abs() > MAX_ABS_POS {
                    return Err(LawMoveError::BadPosition { axis: a.axis, what, value });
                }
            }
            if axes[..k].iter().any(|b| b.axis == a.axis) {
                return Err(LawMoveError::DuplicateAxis(a.axis));
            }
        }
        let chars = law.characteristics();
        Ok(LawMove { law, axes, duration_s, chars })
    }

    pub fn law(&self) -> &Law {
        &self.law
    }

    pub fn axes(&self) -> &[LawAxis] {
        &self.axes
    }

    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    pub fn characteristics(&self) -> &Characteristics {
        &self.chars
    }

    /// C_v, C_a, C_j for k = 1, 2, 3.
    fn c_of(&self, kind: LimitKind) -> f64 {
        match kind {
            LimitKind::Velocity => self.chars.cv.value,
            LimitKind::Acceleration => self.chars.ca.value,
            LimitKind::Jerk => self.chars.cj.value,
        }
    }

    /// Ok when every axis keeps its velocity, acceleration, jerk and travel limits; otherwise the
    /// travel violation, or the dynamic limit needing the largest duration factor.
    pub fn check(&self, limits: &[AxisLimits]) -> Result<(), LimitError> {
        match self.worst(limits)? {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The shortest duration that keeps every dynamic limit: the largest over axes and limits of
    /// (C·|stroke|/limit)^(1/k). Errors only for what time cannot fix (travel, unknown axis).
    pub fn min_duration_s(&self, limits: &[AxisLimits]) -> Result<f64, LimitError> {
        self.check_travel(limits)?;
        let mut t_min = 0.0f64;
        for a in &self.axes {
            let lim = &limits[a.axis];
            for kind in LimitKind::ALL {
                // peak(T) = |stroke|·C/Tᵏ ≤ limit ⇔ T ≥ (|stroke|·C/limit)^(1/k)
                let t = (a.stroke.abs() * self.c_of(kind) / lim.of(kind)).powf(1.0 / f64::from(kind.order()));
                t_min = t_min.max(t);
            }
        }
        Ok(t_min)
    }

    /// The same move with its duration grown to the shortest feasible one (never shortened).
    pub fn stretched(&self, limits: &[AxisLimits]) -> Result<LawMove, LimitError> {
        let t = self.min_duration_s(limits)?.max(self.duration_s);
        Ok(LawMove { duration_s: t, ..self.clone() })
    }

    /// The dynamic violation with the largest factor, after the travel check.
    fn worst(&self, limits: &[AxisLimits]) -> Result<Option<LimitError>, LimitError> {
        self.check_travel(limits)?;
        let mut worst: Option<LimitError> = None;
        let mut worst_factor = 1.0 + LIMIT_REL_TOL;
        for a in &self.axes {
            let lim = &limits[a.axis];
            for kind in LimitKind::ALL {
                let k = kind.order();
                let peak = a.stroke.abs() * self.c_of(kind) / self.duration_s.powi(k);
                let limit = lim.of(kind);
                // The peak scales with 1/Tᵏ, so T·(peak/limit)^(1/k) brings it to the limit.
                let factor = (peak / limit).powf(1.0 / f64::from(k));
                if factor > worst_factor {
                    worst_factor = factor;
                    worst = Some(LimitError::Exceeded {
                        axis_index: a.axis,
                        axis: lim.name,
                        unit: lim.unit,
                        kind,
                        peak,
                        limit,
                        factor,
                        min_duration_s: self.duration_s * factor,
                    });
                }
            }
        }
        Ok(worst)
    }

    /// Every axis index exists, and start + stroke·f stays in the travel range for f between
    /// the law's minimum and maximum (a law may over- or undershoot).
    fn check_travel(&self, limits: &[AxisLimits]) -> Result<(), LimitError> {
        for a in &self.axes {
            let lim = limits.get(a.axis).ok_or(LimitError::NoSuchAxis { index: a.axis, count: limits.len() })?;
            let p1 = a.start + a.stroke * self.chars.f_min.value;
            let p2 = a.start + a.stroke * self.chars.f_max.value;
            for pos in [a.start, p1, p2, a.start + a.stroke] {
                if pos < lim.min_pos - TRAVEL_TOL || pos > lim.max_pos + TRAVEL_TOL {
                    return Err(LimitError::Travel {
                        axis_index: a.axis,
                        axis: lim.name,
                        unit: lim.unit,
                        pos,
                        min: lim.min_pos,
                        max: lim.max_pos,
                    });
                }
            }
        }
        Ok(())
    }

    /// Setpoints at time `t_s` since the start, one per axis of the move in the order of
    /// [`LawMove::axes`] (extra entries of `out` are left alone; a shorter `out` gets the first
    /// axes). Before 0 (and for NaN) the axes rest at their starts; from the duration on they
    /// rest exactly at start + stroke. Allocation-free.
    pub fn sample(&self, t_s: f64, out: &mut [AxisState]) {
        let t_end = self.duration_s;
        if t_s >= t_end {
            for (o, a) in out.iter_mut().zip(&self.axes) {
                *o = AxisState { pos: a.start + a.stroke, ..AxisState::default() };
            }
            return;
        }
        if t_s.is_nan() || t_s < 0.0 {
            for (o, a) in out.iter_mut().zip(&self.axes) {
                *o = AxisState { pos: a.start, ..AxisState::default() };
            }
            return;
        }
        let d = self.law.eval(t_s / t_end);
        let inv_t = 1.0 / t_end;
        for (o, a) in out.iter_mut().zip(&self.axes) {
            // p = s₀ + h·f(t/T), ṗ = h/T·f′, p̈ = h/T²·f″, p⃛ = h/T³·f‴ (chain rule, z = t/T)
            let h = a.stroke;
            *o = AxisState {
                pos: a.start + h * d.f,
                vel_per_s: h * d.f1 * inv_t,
                acc_per_s2: h * d.f2 * inv_t * inv_t,
                jerk_per_s3: h * d.f3 * inv_t * inv_t * inv_t,
            };
        }
    }
}

fn check_rest_to_rest(law: &Law) -> Result<(), LawMoveError> {
    let (s, e) = (law.eval(0.0), law.eval(1.0));
    let checks = [
        ("f(0)", s.f, 0.0),
        ("f(1)", e.f, 1.0),
        ("f'(0)", s.f1, 0.0),
        ("f'(1)", e.f1, 0.0),
        ("f''(0)", s.f2, 0.0),
        ("f''(1)", e.f2, 0.0),
    ];
    for (what, value, want) in checks {
        if (value - want).abs() > REST_TOL {
            return Err(LawMoveError::NotRestToRest { what, value, want });
        }
    }
    Ok(())
}
