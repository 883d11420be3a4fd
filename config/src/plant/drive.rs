//! The drive of an axis: a quantised motor encoder, a P position loop, a PI velocity loop and
//! the current loop as a PT1 lag (the cascade of Haas 2012, Table 5.2, with its gains Kpv1,
//! Kpx1 and Tni1), velocity feedforward (VV1 there) and acceleration feedforward. A linear
//! drive ([`LinearDrive`]) works in m and N, a rotary one ([`RotaryDrive`]) in rad and N·m.

use super::table::Check;
use crate::ConfigError;
use serde::Deserialize;

/// The drive of a linear axis.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct LinearDrive {
    /// Motor encoder quantum referred to the load side, m (0: ideal; default 0).
    #[serde(default)]
    pub encoder_step_m: f64,
    /// Position loop gain Kv, 1/s.
    pub kv_per_s: f64,
    /// Velocity loop proportional gain, N·s/m.
    pub kp_n_s_per_m: f64,
    /// Velocity loop reset time Tn, s.
    pub tn_s: f64,
    /// Current loop (power module) bandwidth of the PT1 lag, Hz.
    pub current_loop_hz: f64,
    /// Peak motor force, N.
    pub force_limit_n: f64,
    /// Velocity feedforward gain (1 = full).
    pub vel_ff: f64,
    /// Acceleration (force) feedforward gain, fraction of the total moved mass (1 = full;
    /// default 0).
    #[serde(default)]
    pub acc_ff: f64,
    /// PT1 filter on the encoder velocity, Hz (0: no filter; default 0).
    #[serde(default)]
    pub velocity_filter_hz: f64,
}

/// The drive of a rotary axis: [`LinearDrive`] in rad and N·m.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RotaryDrive {
    /// Motor encoder quantum, rad (0: ideal; default 0).
    #[serde(default)]
    pub encoder_step_rad: f64,
    /// Position loop gain Kv, 1/s.
    pub kv_per_s: f64,
    /// Velocity loop proportional gain, N·m·s/rad.
    pub kp_nm_s_per_rad: f64,
    /// Velocity loop reset time Tn, s.
    pub tn_s: f64,
    /// Current loop bandwidth of the PT1 lag, Hz.
    pub current_loop_hz: f64,
    /// Peak motor torque, N·m.
    pub torque_limit_nm: f64,
    /// Velocity feedforward gain (1 = full).
    pub vel_ff: f64,
    /// Acceleration (torque) feedforward gain, fraction of the total inertia (default 0).
    #[serde(default)]
    pub acc_ff: f64,
    /// PT1 filter on the encoder velocity, Hz (0: no filter; default 0).
    #[serde(default)]
    pub velocity_filter_hz: f64,
}

/// Drive parameters in SI base units of the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveParams {
    /// Encoder quantum (m or rad); 0 = ideal.
    pub encoder_step: f64,
    /// Position gain Kv, 1/s.
    pub kv_per_s: f64,
    /// Velocity PI gain (N·s/m or N·m·s/rad).
    pub kp: f64,
    /// Reset time Tn, s.
    pub tn_s: f64,
    /// Current-loop PT1 bandwidth, Hz.
    pub current_loop_hz: f64,
    /// Force/torque limit (N or N·m).
    pub force_limit: f64,
    /// Velocity feedforward gain.
    pub vel_ff: f64,
    /// Acceleration feedforward gain (fraction of the total mass).
    pub acc_ff: f64,
    /// Encoder velocity PT1 filter, Hz; None = unfiltered.
    pub velocity_filter_hz: Option<f64>,
}

/// Largest feedforward gain: 1 is full feedforward; a little more over-compensates on purpose,
/// much more is a mistake.
const MAX_FF_GAIN: f64 = 1.5;
/// Largest current-loop and filter bandwidth: the highest servo rate `[plant]` accepts.
const MAX_BANDWIDTH_HZ: f64 = 1.0e5;

impl LinearDrive {
    /// The drive for a servo cycle of `servo_rate_hz`.
    pub(crate) fn resolve(&self, c: &Check, servo_rate_hz: f64) -> Result<DriveParams, ConfigError> {
        let p = DriveParams {
            encoder_step: c.non_negative("encoder_step_m", self.encoder_step_m)?,
            kv_per_s: c.positive("kv_per_s", self.kv_per_s)?,
            kp: c.positive("kp_n_s_per_m", self.kp_n_s_per_m)?,
            tn_s: c.positive("tn_s", self.tn_s)?,
            current_loop_hz: c.in_range("current_loop_hz", self.current_loop_hz, 1.0, MAX_BANDWIDTH_HZ)?,
            force_limit: c.positive("force_limit_n", self.force_limit_n)?,
            vel_ff: c.in_range("vel_ff", self.vel_ff, 0.0, MAX_FF_GAIN)?,
            acc_ff: c.in_range("acc_ff", self.acc_ff, 0.0, MAX_FF_GAIN)?,
            velocity_filter_hz: None,
        };
        velocity_filter(c, self.velocity_filter_hz, servo_rate_hz).map(|f| DriveParams { velocity_filter_hz: f, ..p })
    }
}

impl RotaryDrive {
    /// The drive for a servo cycle of `servo_rate_hz`.
    pub(crate) fn resolve(&self, c: &Check, servo_rate_hz: f64) -> Result<DriveParams, ConfigError> {
        let p = DriveParams {
            encoder_step: c.non_negative("encoder_step_rad", self.encoder_step_rad)?,
            kv_per_s: c.positive("kv_per_s", self.kv_per_s)?,
            kp: c.positive("kp_nm_s_per_rad", self.kp_nm_s_per_rad)?,
            tn_s: c.positive("tn_s", self.tn_s)?,
            current_loop_hz: c.in_range("current_loop_hz", self.current_loop_hz, 1.0, MAX_BANDWIDTH_HZ)?,
            force_limit: c.positive("torque_limit_nm", self.torque_limit_nm)?,
            vel_ff: c.in_range("vel_ff", self.vel_ff, 0.0, MAX_FF_GAIN)?,
            acc_ff: c.in_range("acc_ff", self.acc_ff, 0.0, MAX_FF_GAIN)?,
            velocity_filter_hz: None,
        };
        velocity_filter(c, self.velocity_filter_hz, servo_rate_hz).map(|f| DriveParams { velocity_filter_hz: f, ..p })
    }
}

/// The velocity filter's corner, `None` for 0; the filter is discretised at the servo rate, so
/// its corner must lie below the Nyquist frequency.
fn velocity_filter(c: &Check, hz: f64, servo_rate_hz: f64) -> Result<Option<f64>, ConfigError> {
    let hz = c.in_range("velocity_filter_hz", hz, 0.0, MAX_BANDWIDTH_HZ)?;
    if hz > 0.0 && hz * 2.0 > servo_rate_hz {
        return Err(
            c.err("velocity_filter_hz", &format!("must be below half the servo rate ({} Hz)", servo_rate_hz / 2.0))
        );
    }
    Ok((hz > 0.0).then_some(hz))
}
