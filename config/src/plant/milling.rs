//! `[plant.milling]`, `[plant.measurement]`, `[plant.actuator]`, `[plant.structure]`: the
//! machining process, the sensors and fast actuator, and the structure's coupled compliance of
//! Schneider 2016 (robot milling with an F/T sensor at the flange,
//! an optical tracker on tool and workpiece, a piezo actuator between spindle and robot).
//!
//! ```toml
//! [plant.milling]              # a milling force on the load that follows the feed direction
//! force_n = 200.0              # static part, N
//! angle_deg = 90.0             # from the feed direction towards its left (inward on a CCW circle)
//!
//! [plant.measurement]          # F/T signal and external position measurement
//! position_period_ms = 2.3
//! position_dead_time_ms = 3.7
//!
//! [plant.actuator]             # fast auxiliary actuator between load and tool
//! axes = ["X", "Y"]
//!
//! [plant.structure]            # coupled compliance of the arm between the axes and the tool
//! compliance_um_per_n = [0.8, 0.1]
//! angle_deg = 30.0
//! ```
//!
//! Every section is optional; absent, the plant has no milling force, publishes no
//! measurement and has no actuator. Units are in the key names.

use crate::{AxisConfig, AxisKind, AxisLetter, ConfigError, Validator};
use serde::Deserialize;

/// `[plant.milling]`: the process force of milling on the load (Schneider 2016, §2.2.4, §3.4,
/// Fig. 5.5/5.8). The static part follows the feed direction in the plane of `axes`: on a
/// circle in full-slot engagement it turns with the path, so each axis sees a sinusoid. On top
/// come the tooth-passing harmonic (teeth × spindle speed) and a slow drift.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MillingConfig {
    /// The two linear axes spanning the cutting plane (first: the angle's 0° axis).
    pub axes: Vec<AxisLetter>,
    /// Static force while cutting, N. 200 N deflects the soft robot preset by
    /// 200 N / 0.545 N/µm = 0.37 mm plus half its backlash (Schneider 2016, §3.2: 0.19–0.55 mm).
    pub force_n: f64,
    /// Direction of the force on the load, degrees from the feed direction counter-clockwise
    /// in the plane (90: towards the left of the feed, the centre of a counter-clockwise circle).
    pub angle_deg: f64,
    /// Path speed from which the tool cuts, mm/s (below it the force fades out).
    pub engage_speed_mm_s: f64,
    /// Time constant of the force's rise and fall at engagement, s.
    pub engage_time_s: f64,
    /// Teeth of the cutter.
    pub teeth: u32,
    /// Spindle speed, 1/min (tooth-passing frequency = teeth × rpm / 60).
    pub spindle_rpm: f64,
    /// Amplitude of the tooth-passing harmonic, N (along the static force).
    pub tooth_force_n: f64,
    /// Amplitude of the slow drift of the static part, N (wear, temperature).
    pub drift_n: f64,
    /// Period of the drift, s.
    pub drift_period_s: f64,
    /// Standard deviation of the random variation of the static part, N: the varying material
    /// removal of a real cut (Schneider 2016, §2.2.4: "varying material removal" is one of the
    /// three causes of the dynamic force), band-limited by `variation_hz`.
    pub variation_n: f64,
    /// Bandwidth of that variation (corner of its second-order low-pass), Hz.
    pub variation_hz: f64,
    /// Seed of the variation's noise generator (runs are reproducible).
    pub seed: u64,
}

impl Default for MillingConfig {
    fn default() -> Self {
        Self {
            axes: vec![AxisLetter::X, AxisLetter::Y],
            force_n: 200.0,
            angle_deg: 90.0,
            engage_speed_mm_s: 0.5,
            engage_time_s: 0.2,
            // Schneider 2016, Tab. 5.1: 4-tooth cutter at 28 000 1/min.
            teeth: 4,
            spindle_rpm: 28_000.0,
            tooth_force_n: 20.0,
            drift_n: 10.0,
            drift_period_s: 60.0,
            variation_n: 0.0,
            variation_hz: 2.0,
            seed: 2,
        }
    }
}

/// `[plant.measurement]`: the sensors of Schneider 2016: a force/torque sensor at the load
/// (read at 10 kHz, noise of a few N, drift, §1.7/§5) and an optical measurement of the tool
/// position (Nikon K600: origin noise sphere 26.3 µm over 10 measurements, measurement cycle
/// 2.3 ms, dead time about 1.7 ms + 2 ms, §4.2).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MeasurementConfig {
    /// Standard deviation of the force signal's noise, N.
    pub force_noise_n: f64,
    /// Drift rate of the force signal's offset, N/s (changes sign every `force_drift_period_s`).
    pub force_drift_n_per_s: f64,
    /// Period of the force offset's drift, s.
    pub force_drift_period_s: f64,
    /// Standard deviation per axis of the position measurement's noise, µm. 10 µm: the farthest
    /// of 10 samples lies about 2.6 σ from their mean in 3-D, the 26 µm sphere of the K600.
    pub position_noise_um: f64,
    /// Measurement cycle of the position, ms.
    pub position_period_ms: f64,
    /// Dead time from the measured instant to its arrival, ms.
    pub position_dead_time_ms: f64,
    /// Seed of the noise generator (runs are reproducible).
    pub seed: u64,
}

impl Default for MeasurementConfig {
    fn default() -> Self {
        Self {
            force_noise_n: 2.0,
            force_drift_n_per_s: 0.2,
            force_drift_period_s: 40.0,
            position_noise_um: 10.0,
            position_period_ms: 2.3,
            position_dead_time_ms: 3.7,
            seed: 1,
        }
    }
}

/// `[plant.actuator]`: a fast auxiliary actuator per axis between load and tool (the piezo
/// actuator of Schneider 2016, §2.4, §4.3: stroke 0.5 mm, first modes 50–100 Hz, low damping,
/// an inner PID loop with feedforward on its strain gauge).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorConfig {
    /// Linear axes that carry an actuator.
    pub axes: Vec<AxisLetter>,
    /// Stroke about mid-stroke, ± mm.
    pub stroke_mm: f64,
    /// First mode, Hz.
    pub mode_hz: f64,
    /// Damping ratio of the mode (flexure hinges: almost none).
    pub damping: f64,
    /// Inner loop: proportional gain (per unit of position error).
    pub kp: f64,
    /// Inner loop: integral gain, 1/s.
    pub ki_per_s: f64,
    /// Inner loop: derivative gain on the measured position, s.
    pub kd_s: f64,
    /// Inner loop: feedforward gain on the reference (1: the inverse static gain).
    pub feedforward: f64,
}

impl Default for ActuatorConfig {
    fn default() -> Self {
        Self {
            axes: vec![AxisLetter::X, AxisLetter::Y],
            stroke_mm: 0.25,
            mode_hz: 80.0,
            damping: 0.02,
            // Closed inner loop ω_c = ω·√(1 + kp) ≈ 2π·113 Hz with ζ ≈ 0.6 from the D term.
            kp: 1.0,
            ki_per_s: 300.0,
            kd_s: 3.3e-3,
            feedforward: 1.0,
        }
    }
}

/// `[plant.structure]`: the compliance of the structure between the axes and the tool in a
/// plane. A robot arm deforms anisotropically, so its Cartesian compliance has off-diagonal
/// terms in the machine's axes (Schneider 2016, §2.2.4, §5): the tool moves from the load by
/// R(θ) diag(c₁, c₂) R(θ)ᵀ · F behind a mode of the structure. The axes' own transmissions
/// (the preset) come on top.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StructureConfig {
    /// The two linear axes of the plane (first: the angle's 0° axis).
    pub axes: Vec<AxisLetter>,
    /// Principal compliances c₁, c₂, µm/N.
    pub compliance_um_per_n: [f64; 2],
    /// Direction of c₁, degrees from the first axis counter-clockwise.
    pub angle_deg: f64,
    /// Mode of the structure, Hz.
    pub mode_hz: f64,
    /// Damping ratio of the mode.
    pub damping: f64,
}

impl Default for StructureConfig {
    fn default() -> Self {
        Self {
            axes: vec![AxisLetter::X, AxisLetter::Y],
            compliance_um_per_n: [0.8, 0.1],
            angle_deg: 30.0,
            mode_hz: 30.0,
            damping: 0.05,
        }
    }
}

impl StructureConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        if self.axes.len() != 2 || self.axes[0] == self.axes[1] {
            return Err(v.err("plant.structure.axes", "must name two different linear axes, e.g. [\"X\", \"Y\"]"));
        }
        linear_axes(v, "plant.structure.axes", &self.axes, axes)?;
        for c in self.compliance_um_per_n {
            v.in_range("plant.structure.compliance_um_per_n", c, 0.0, 1e3)?;
        }
        v.in_range("plant.structure.angle_deg", self.angle_deg, -360.0, 360.0)?;
        v.in_range("plant.structure.mode_hz", self.mode_hz, 1.0, 1000.0)?;
        v.in_range("plant.structure.damping", self.damping, 0.001, 2.0)
    }
}

impl MillingConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        if self.axes.len() != 2 || self.axes[0] == self.axes[1] {
            return Err(v.err("plant.milling.axes", "must name two different linear axes, e.g. [\"X\", \"Y\"]"));
        }
        linear_axes(v, "plant.milling.axes", &self.axes, axes)?;
        v.in_range("plant.milling.force_n", self.force_n, 0.0, 1e5)?;
        v.in_range("plant.milling.angle_deg", self.angle_deg, -360.0, 360.0)?;
        v.in_range("plant.milling.engage_speed_mm_s", self.engage_speed_mm_s, 1e-3, 1e4)?;
        v.in_range("plant.milling.engage_time_s", self.engage_time_s, 1e-3, 100.0)?;
        if !(1..=100).contains(&self.teeth) {
            return Err(v.err("plant.milling.teeth", &format!("must lie in 1..=100, got {}", self.teeth)));
        }
        v.in_range("plant.milling.spindle_rpm", self.spindle_rpm, 0.0, 1e6)?;
        v.in_range("plant.milling.tooth_force_n", self.tooth_force_n, 0.0, 1e5)?;
        v.in_range("plant.milling.drift_n", self.drift_n, 0.0, 1e5)?;
        v.in_range("plant.milling.drift_period_s", self.drift_period_s, 0.1, 1e6)?;
        v.in_range("plant.milling.variation_n", self.variation_n, 0.0, 1e5)?;
        v.in_range("plant.milling.variation_hz", self.variation_hz, 0.01, 1000.0)
    }

    /// Tooth-passing frequency, Hz.
    pub fn tooth_hz(&self) -> f64 {
        f64::from(self.teeth) * self.spindle_rpm / 60.0
    }
}

impl MeasurementConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.in_range("plant.measurement.force_noise_n", self.force_noise_n, 0.0, 1e4)?;
        v.in_range("plant.measurement.force_drift_n_per_s", self.force_drift_n_per_s, 0.0, 1e3)?;
        v.in_range("plant.measurement.force_drift_period_s", self.force_drift_period_s, 0.1, 1e6)?;
        v.in_range("plant.measurement.position_noise_um", self.position_noise_um, 0.0, 1e4)?;
        v.in_range("plant.measurement.position_period_ms", self.position_period_ms, 0.1, 100.0)?;
        v.in_range("plant.measurement.position_dead_time_ms", self.position_dead_time_ms, 0.0, 100.0)
    }
}

impl ActuatorConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        linear_axes(v, "plant.actuator.axes", &self.axes, axes)?;
        v.in_range("plant.actuator.stroke_mm", self.stroke_mm, 1e-3, 10.0)?;
        v.in_range("plant.actuator.mode_hz", self.mode_hz, 5.0, 2000.0)?;
        v.in_range("plant.actuator.damping", self.damping, 0.0, 2.0)?;
        v.in_range("plant.actuator.kp", self.kp, 0.0, 100.0)?;
        v.in_range("plant.actuator.ki_per_s", self.ki_per_s, 0.0, 1e5)?;
        v.in_range("plant.actuator.kd_s", self.kd_s, 0.0, 1.0)?;
        v.in_range("plant.actuator.feedforward", self.feedforward, 0.0, 2.0)
    }
}

/// Every name in `names` is a linear axis of the machine, at most once.
fn linear_axes(v: &Validator, key: &str, names: &[AxisLetter], axes: &[AxisConfig]) -> Result<(), ConfigError> {
    for (i, n) in names.iter().enumerate() {
        match axes.iter().find(|a| a.name == *n) {
            None => return Err(v.err(key, &format!("no axis {n} in this machine"))),
            Some(a) if a.kind != AxisKind::Linear => return Err(v.err(key, &format!("axis {n} is not linear"))),
            Some(_) => {}
        }
        if names[..i].contains(n) {
            return Err(v.err(key, &format!("axis {n} named twice")));
        }
    }
    Ok(())
}
