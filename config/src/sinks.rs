//! `[sinks]`: where the setpoints go (iceoryx2 shared memory, SocketCAN).

use crate::{ConfigError, Validator};
use serde::Deserialize;

/// `[sinks]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SinksConfig {
    /// Publish setpoints on the iceoryx2 service `interpd/setpoints`.
    pub shm: bool,
}

impl Default for SinksConfig {
    fn default() -> Self {
        Self { shm: true }
    }
}

impl SinksConfig {
    pub(crate) fn validate(&self, _v: &Validator, _axes: usize) -> Result<(), ConfigError> {
        Ok(())
    }
}
