//! The parameters of one axis as TOML writes them: flat `key = number` pairs in a preset's
//! `[params]` and in a `[[plant.axis]]` table ([`ParamTable`]), and the range checks that
//! name the key where an offending value is set ([`Check`]). Every model file checks its
//! values with them, so they depend on no model.

use crate::{ConfigError, Validator};
use std::collections::BTreeMap;

/// Model parameters by key, in SI units named in the key (`_kg`, `_n_per_m`, `_rad`, …).
pub type ParamTable = BTreeMap<String, f64>;

/// The range checks of one axis's parameters. A value comes from the axis's override, its
/// preset or a default; an error names the key where it is set: `plant.axis[i].KEY`,
/// `plant preset NAME: KEY`, or `AXIS.KEY` for a default.
pub(crate) struct Check<'a> {
    pub v: &'a Validator<'a>,
    pub preset_name: &'a str,
    /// The keys the preset sets.
    pub preset: &'a ParamTable,
    /// The override's index in `[[plant.axis]]` and the keys it sets.
    pub over: Option<(usize, &'a ParamTable)>,
    /// How the axis is named where no key is set: `plant.axis[i]` or `plant (axis X)`.
    pub axis_key: &'a str,
}

impl Check<'_> {
    /// Whether the axis's override sets `key`.
    pub fn overridden(&self, key: &str) -> bool {
        self.over.is_some_and(|(_, o)| o.contains_key(key))
    }

    /// Where `key` is set, for messages.
    pub fn key(&self, key: &str) -> String {
        match self.over {
            Some((i, _)) if self.overridden(key) => format!("plant.axis[{i}].{key}"),
            _ if self.preset.contains_key(key) => format!("plant preset {}: {key}", self.preset_name),
            _ => format!("{}.{key}", self.axis_key),
        }
    }

    pub fn err(&self, key: &str, message: &str) -> ConfigError {
        self.v.err(&self.key(key), message)
    }

    /// `x` if it is finite and > 0.
    pub fn positive(&self, key: &str, x: f64) -> Result<f64, ConfigError> {
        self.v.positive(&self.key(key), x).map(|_| x)
    }

    /// `x` if it is finite and ≥ 0.
    pub fn non_negative(&self, key: &str, x: f64) -> Result<f64, ConfigError> {
        self.v.non_negative(&self.key(key), x).map(|_| x)
    }

    /// `x` if it is finite and inside `[lo, hi]`.
    pub fn in_range(&self, key: &str, x: f64, lo: f64, hi: f64) -> Result<f64, ConfigError> {
        self.v.in_range(&self.key(key), x, lo, hi).map(|_| x)
    }

    /// `x` if it is finite.
    pub fn finite(&self, key: &str, x: f64) -> Result<f64, ConfigError> {
        if x.is_finite() { Ok(x) } else { Err(self.err(key, &format!("must be finite, got {x}"))) }
    }
}
