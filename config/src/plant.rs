//! `[plant]`: the simulated axis plant (sim-plant). Owned by the plant models; see sim-plant/.

use crate::{ConfigError, Validator};
use serde::Deserialize;

/// `[plant]`.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct PlantConfig {
    /// Name of the model preset every axis uses unless overridden.
    pub preset: Option<String>,
}

impl PlantConfig {
    pub(crate) fn validate(&self, _v: &Validator, _axes: usize) -> Result<(), ConfigError> {
        Ok(())
    }
}
