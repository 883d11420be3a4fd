//! `[compensation]`: corrections the daemon adds to the setpoints after the fine interpolation,
//! per axis, from the measurements a plant publishes (Schneider 2016: deflection compensation
//! §4.1, end-effector position control §4.2, mid-ranging with a fast actuator §2.4/§4.3.3).
//!
//! ```toml
//! [compensation]
//! max_age_ms = 25.0
//!
//! [compensation.measurement]       # what the measurement stream carries
//! force_axes = ["X", "Y"]
//! position_axes = ["X", "Y"]
//!
//! [[compensation.axis]]
//! name = "X"
//! strategy = "position"            # none | deflection | position | position+actuator
//! ```

use crate::{AxisConfig, AxisKind, AxisLetter, ConfigError, Validator};
use serde::Deserialize;

/// What one axis's correction is made of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
pub enum Strategy {
    /// No correction.
    #[default]
    #[serde(rename = "none")]
    None,
    /// The filtered force through the stiffness model (Schneider 2016, eq. 4.1).
    #[serde(rename = "deflection")]
    Deflection,
    /// PI on the external position measurement (eq. 4.3–4.9).
    #[serde(rename = "position")]
    Position,
    /// The error to a fast actuator, its excursion to the axis (mid-ranging, §2.4, §4.3.3).
    #[serde(rename = "position+actuator")]
    PositionActuator,
}

impl Strategy {
    pub fn name(self) -> &'static str {
        match self {
            Strategy::None => "none",
            Strategy::Deflection => "deflection",
            Strategy::Position => "position",
            Strategy::PositionActuator => "position+actuator",
        }
    }
}

/// `[compensation]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CompensationConfig {
    /// A measurement older than this (from its measured instant) is stale: the correction fades
    /// out, ms.
    pub max_age_ms: f64,
    /// Time over which a correction fades out when its measurement goes stale (and back in), s.
    pub fade_s: f64,
    /// Share of each axis's velocity, acceleration and jerk limit reserved for the corrections:
    /// the planner plans with the rest, so the sum keeps every limit.
    pub limit_share: f64,
    /// Largest correction, mm.
    pub max_correction_mm: f64,
    /// A measured position farther than this from the setpoint is discarded as absurd, mm.
    pub absurd_position_mm: f64,
    /// A force signal larger than this is discarded as absurd, N.
    pub absurd_force_n: f64,
    /// Corner frequency of the first-order filter on the force signal, Hz (well below the
    /// axis modes, so the noise does not excite them).
    pub force_filter_hz: f64,
    /// What the measurement stream carries.
    pub measurement: MeasurementSource,
    /// Per-axis strategy and parameters.
    pub axis: Vec<AxisCompensation>,
}

impl Default for CompensationConfig {
    fn default() -> Self {
        Self {
            // Dead time 3.7 ms + cycle 2.3 ms of the external measurement, with room for a late
            // cycle of the daemon and the plant.
            max_age_ms: 25.0,
            fade_s: 0.3,
            limit_share: 0.1,
            max_correction_mm: 2.0,
            absurd_position_mm: 5.0,
            absurd_force_n: 10_000.0,
            force_filter_hz: 2.0,
            measurement: MeasurementSource::default(),
            axis: Vec::new(),
        }
    }
}

/// `[compensation.measurement]`: the axes the measurement stream (`<prefix>/measurement`)
/// carries each signal for.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct MeasurementSource {
    /// Axes with a force signal.
    pub force_axes: Vec<AxisLetter>,
    /// Axes with an external tool position measurement.
    pub position_axes: Vec<AxisLetter>,
    /// Axes with a fast actuator (position reported, commands on `<prefix>/actuator`).
    pub actuator_axes: Vec<AxisLetter>,
}

/// One `[[compensation.axis]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct AxisCompensation {
    /// The axis (required).
    pub name: Option<AxisLetter>,
    pub strategy: Strategy,
    /// Deflection model (eq. 4.1 about the zero-load point): stiffness above it, N/mm.
    pub stiffness_pos_n_per_mm: f64,
    /// Stiffness below the zero-load point, N/mm.
    pub stiffness_neg_n_per_mm: f64,
    /// Backlash: the deflection jumps by this across the zero-load zone, mm.
    pub gap_mm: f64,
    /// Zero-load point (the force at which the deflection is zero), N.
    pub zero_load_n: f64,
    /// Half-width of the backlash zone, the cubic joining the two lines with continuous slope, N.
    pub blend_n: f64,
    /// Below this distance of the force from the zero-load point the model gives no correction
    /// (rising smoothly to the full model at twice it), N: there the load rests anywhere in the
    /// backlash, and the force signal's drift alone is of this size.
    pub deadband_n: f64,
    /// Position control: proportional gain (eq. 4.8).
    pub kp: f64,
    /// Position control: integral gain, 1/s (no D term: the measurement is noisy).
    pub ki_per_s: f64,
    /// Position control: bandwidth limit, a first-order filter on the correction, Hz.
    pub bandwidth_hz: f64,
    /// Mid-ranging: the fast actuator's PI on the error, proportional gain.
    pub actuator_kp: f64,
    /// Mid-ranging: the fast actuator's PI, integral gain, 1/s.
    pub actuator_ki_per_s: f64,
    /// Mid-ranging: rate at which the axis takes over the actuator's excursion, 1/s.
    pub midrange_per_s: f64,
    /// Mid-ranging: the axis's own PI on the error, integral gain, 1/s.
    pub midrange_ki_per_s: f64,
    /// Usable actuator stroke about mid-stroke, ± mm.
    pub actuator_stroke_mm: f64,
}

impl Default for AxisCompensation {
    fn default() -> Self {
        Self {
            name: None,
            strategy: Strategy::None,
            stiffness_pos_n_per_mm: 0.0,
            stiffness_neg_n_per_mm: 0.0,
            gap_mm: 0.0,
            zero_load_n: 0.0,
            blend_n: 5.0,
            // The force signal drifts by a few N (Schneider 2016: drift matters more than the noise).
            deadband_n: 5.0,
            // Loop design against the axis (position loop Kv ≈ 20/s, a 6 Hz mode with Q ≈ 17):
            // crossover ≈ 3 rad/s, 56° phase margin, gain margin ≈ 10 at the mode with the 1 Hz
            // bandwidth limit.
            kp: 0.3,
            ki_per_s: 3.0,
            bandwidth_hz: 1.0,
            // Against ≈ 12 ms of loop delay (3.7 ms dead time, 2.3 ms cycle, one 4 ms cycle,
            // the command ramp, the stage): crossover ≈ 50 rad/s, about 50° phase margin.
            actuator_kp: 0.2,
            actuator_ki_per_s: 50.0,
            midrange_per_s: 2.0,
            midrange_ki_per_s: 0.0,
            actuator_stroke_mm: 0.25,
        }
    }
}

impl CompensationConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        v.in_range("compensation.max_age_ms", self.max_age_ms, 1.0, 1000.0)?;
        v.in_range("compensation.fade_s", self.fade_s, 0.01, 10.0)?;
        v.in_range("compensation.limit_share", self.limit_share, 0.01, 0.5)?;
        v.in_range("compensation.max_correction_mm", self.max_correction_mm, 1e-3, 100.0)?;
        v.in_range("compensation.absurd_position_mm", self.absurd_position_mm, 1e-3, 1000.0)?;
        v.in_range("compensation.absurd_force_n", self.absurd_force_n, 1.0, 1e7)?;
        v.in_range("compensation.force_filter_hz", self.force_filter_hz, 0.01, 100.0)?;
        for (key, list) in [
            ("compensation.measurement.force_axes", &self.measurement.force_axes),
            ("compensation.measurement.position_axes", &self.measurement.position_axes),
            ("compensation.measurement.actuator_axes", &self.measurement.actuator_axes),
        ] {
            for n in list {
                if !axes.iter().any(|a| a.name == *n) {
                    return Err(v.err(key, &format!("no axis {n} in this machine")));
                }
            }
        }
        for (i, a) in self.axis.iter().enumerate() {
            let key = |k: &str| format!("compensation.axis[{i}].{k}");
            let Some(name) = a.name else {
                return Err(v.err(&key("name"), "missing; every [[compensation.axis]] names its axis"));
            };
            let Some(axis) = axes.iter().find(|x| x.name == name) else {
                return Err(v.err(&key("name"), &format!("no axis {name} in this machine")));
            };
            if axis.kind != AxisKind::Linear && a.strategy != Strategy::None {
                return Err(v.err(&key("strategy"), &format!("axis {name} is rotary; corrections are for linear axes")));
            }
            if let Some(j) = self.axis[..i].iter().position(|b| b.name == Some(name)) {
                return Err(v.err(&key("name"), &format!("axis {name} already in compensation.axis[{j}]")));
            }
            let needs = |list: &[AxisLetter], signal: &str, source: &str| {
                if list.contains(&name) {
                    Ok(())
                } else {
                    Err(v.err(
                        &key("strategy"),
                        &format!(
                            "`{}` needs the {signal} of axis {name}, but compensation.measurement.{source} does not \
                             name it",
                            a.strategy.name()
                        ),
                    ))
                }
            };
            match a.strategy {
                Strategy::None => {}
                Strategy::Deflection => {
                    needs(&self.measurement.force_axes, "force signal", "force_axes")?;
                    v.positive(&key("stiffness_pos_n_per_mm"), a.stiffness_pos_n_per_mm)?;
                    v.positive(&key("stiffness_neg_n_per_mm"), a.stiffness_neg_n_per_mm)?;
                    v.in_range(&key("gap_mm"), a.gap_mm, 0.0, 10.0)?;
                    v.in_range(&key("zero_load_n"), a.zero_load_n, -1e5, 1e5)?;
                    v.in_range(&key("blend_n"), a.blend_n, 1e-3, 1e5)?;
                    v.in_range(&key("deadband_n"), a.deadband_n, 0.0, 1e5)?;
                }
                Strategy::Position => {
                    needs(&self.measurement.position_axes, "position measurement", "position_axes")?;
                    v.in_range(&key("kp"), a.kp, 0.0, 10.0)?;
                    v.in_range(&key("ki_per_s"), a.ki_per_s, 0.0, 1000.0)?;
                    v.in_range(&key("bandwidth_hz"), a.bandwidth_hz, 0.01, 125.0)?;
                }
                Strategy::PositionActuator => {
                    needs(&self.measurement.position_axes, "position measurement", "position_axes")?;
                    needs(&self.measurement.actuator_axes, "fast actuator", "actuator_axes")?;
                    v.in_range(&key("actuator_kp"), a.actuator_kp, 0.0, 10.0)?;
                    v.in_range(&key("actuator_ki_per_s"), a.actuator_ki_per_s, 0.0, 10_000.0)?;
                    v.in_range(&key("midrange_per_s"), a.midrange_per_s, 0.0, 1000.0)?;
                    v.in_range(&key("midrange_ki_per_s"), a.midrange_ki_per_s, 0.0, 1000.0)?;
                    v.in_range(&key("actuator_stroke_mm"), a.actuator_stroke_mm, 1e-3, 10.0)?;
                }
            }
        }
        Ok(())
    }

    /// The strategy of axis `letter` (none if it has no table).
    pub fn of(&self, letter: AxisLetter) -> Option<&AxisCompensation> {
        self.axis.iter().find(|a| a.name == Some(letter))
    }

    /// Whether any axis has a correction.
    pub fn active(&self) -> bool {
        self.axis.iter().any(|a| a.strategy != Strategy::None)
    }

    /// Whether any axis drives a fast actuator.
    pub fn uses_actuator(&self) -> bool {
        self.axis.iter().any(|a| a.strategy == Strategy::PositionActuator)
    }
}
