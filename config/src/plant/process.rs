//! The process force on the load: a static part plus a sinusoidal part at the tooth-pass
//! frequency (teeth × rpm / 60), the two parts Schneider 2016 distinguishes in milling forces
//! (§2.2.4, §3.4). A positive force pushes the load towards negative positions. A linear axis
//! takes a force ([`LinearProcess`]), a rotary one a torque ([`RotaryProcess`]); every part
//! defaults to 0.

use super::table::Check;
use crate::ConfigError;
use serde::Deserialize;

/// The process force on a linear axis.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct LinearProcess {
    /// Static process force, N.
    #[serde(default)]
    pub process_force_n: f64,
    /// Amplitude of the sinusoidal process force (tooth pass), N.
    #[serde(default)]
    pub process_force_dyn_n: f64,
    /// Frequency of the sinusoidal part, Hz (teeth × rpm / 60).
    #[serde(default)]
    pub process_dyn_hz: f64,
}

/// The process torque on a rotary axis.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RotaryProcess {
    /// Static process torque, N·m.
    #[serde(default)]
    pub process_torque_nm: f64,
    /// Amplitude of the sinusoidal process torque, N·m.
    #[serde(default)]
    pub process_torque_dyn_nm: f64,
    /// Frequency of the sinusoidal part, Hz.
    #[serde(default)]
    pub process_dyn_hz: f64,
}

/// Process force on the load: static + sinusoidal part (N or N·m).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProcessParams {
    pub static_force: f64,
    pub dyn_force: f64,
    pub dyn_hz: f64,
}

impl LinearProcess {
    pub(crate) fn resolve(&self, c: &Check) -> Result<ProcessParams, ConfigError> {
        Ok(ProcessParams {
            static_force: c.finite("process_force_n", self.process_force_n)?,
            dyn_force: c.finite("process_force_dyn_n", self.process_force_dyn_n)?,
            dyn_hz: c.non_negative("process_dyn_hz", self.process_dyn_hz)?,
        })
    }
}

impl RotaryProcess {
    pub(crate) fn resolve(&self, c: &Check) -> Result<ProcessParams, ConfigError> {
        Ok(ProcessParams {
            static_force: c.finite("process_torque_nm", self.process_torque_nm)?,
            dyn_force: c.finite("process_torque_dyn_nm", self.process_torque_dyn_nm)?,
            dyn_hz: c.non_negative("process_dyn_hz", self.process_dyn_hz)?,
        })
    }
}
