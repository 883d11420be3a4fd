//! `[sinks]`: where the setpoints go (iceoryx2 shared memory, SocketCAN).

use crate::{ConfigError, Validator};
use serde::Deserialize;

/// `[sinks]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SinksConfig {
    /// Publish setpoints on the iceoryx2 service `<shm_prefix>/setpoints`.
    pub shm: bool,
    /// Prefix of the iceoryx2 service names (`<prefix>/setpoints`, `<prefix>/feedback`).
    pub shm_prefix: String,
}

/// Default iceoryx2 service prefix (DESIGN.md: `interpd/setpoints`, `interpd/feedback`).
pub const DEFAULT_SHM_PREFIX: &str = "interpd";

impl Default for SinksConfig {
    fn default() -> Self {
        Self { shm: true, shm_prefix: DEFAULT_SHM_PREFIX.to_string() }
    }
}

impl SinksConfig {
    pub(crate) fn validate(&self, v: &Validator, _axes: usize) -> Result<(), ConfigError> {
        let p = &self.shm_prefix;
        let ok = !p.is_empty()
            && p.len() <= 200
            && p.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '/' | '.'))
            && !p.starts_with('/')
            && !p.ends_with('/');
        if !ok {
            return Err(v.err(
                "sinks.shm_prefix",
                &format!("must be 1–200 characters of A–Z a–z 0–9 _ - . / (not starting or ending with /), got {p:?}"),
            ));
        }
        Ok(())
    }
}
