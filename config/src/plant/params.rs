//! The parameters of one axis as TOML writes them: flat `key = number` pairs in a preset's
//! `[params]` and in a `[[plant.axis]]` table. Which keys an axis has depends on its model
//! and its kind ([`ParamSet`]); serde reads the table into that model's typed structs, and
//! [`Check`] names the key where an offending value is set.

use super::drive::{LinearDrive, RotaryDrive};
use super::preset::ModelKind;
use super::process::{LinearProcess, RotaryProcess};
use super::three_mass::ThreeMass;
use super::two_mass::{LinearTwoMass, RotaryTwoMass};
use crate::{AxisKind, ConfigError, Validator, keys_of};
use serde::Deserialize;
use serde::de::value::MapDeserializer;
use serde::de::{self, DeserializeOwned};
use std::collections::BTreeMap;
use std::sync::OnceLock;

/// Model parameters by key, in SI units named in the key (`_kg`, `_n_per_m`, `_rad`, …).
pub type ParamTable = BTreeMap<String, f64>;

/// Everything one axis model reads from its flat table: the mechanics, the drive and the
/// process force on the load. Unknown keys are errors.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisParams<M, D, P> {
    #[serde(flatten)]
    pub mechanics: M,
    #[serde(flatten)]
    pub drive: D,
    #[serde(flatten)]
    pub process: P,
}

/// A model on a kind of axis, which decides the keys it reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamSet {
    /// The two-mass model with masses, N/m and m.
    LinearTwoMass,
    /// The two-mass model with inertias, N·m/rad and rad.
    RotaryTwoMass,
    /// The three-mass model (linear axes only: its parameters are masses and N/m).
    ThreeMass,
}

/// The parameters of an axis, read into the structs of its [`ParamSet`].
#[derive(Debug, Clone, PartialEq)]
pub enum ModelParams {
    LinearTwoMass(AxisParams<LinearTwoMass, LinearDrive, LinearProcess>),
    RotaryTwoMass(AxisParams<RotaryTwoMass, RotaryDrive, RotaryProcess>),
    ThreeMass(AxisParams<ThreeMass, LinearDrive, LinearProcess>),
}

impl ParamSet {
    /// The parameter set of `model` on a `kind` axis; `None` for the three-mass model on a
    /// rotary axis, which does not exist.
    pub fn of(model: ModelKind, kind: AxisKind) -> Option<Self> {
        match (model, kind) {
            (ModelKind::TwoMass, AxisKind::Linear) => Some(Self::LinearTwoMass),
            (ModelKind::TwoMass, AxisKind::Rotary) => Some(Self::RotaryTwoMass),
            (ModelKind::ThreeMass, AxisKind::Linear) => Some(Self::ThreeMass),
            (ModelKind::ThreeMass, AxisKind::Rotary) => None,
        }
    }

    /// Every key of the set, mechanics first, then drive, then process force.
    pub fn keys(self) -> Vec<&'static str> {
        match self {
            Self::LinearTwoMass => keys_of3::<LinearTwoMass, LinearDrive, LinearProcess>(),
            Self::RotaryTwoMass => keys_of3::<RotaryTwoMass, RotaryDrive, RotaryProcess>(),
            Self::ThreeMass => keys_of3::<ThreeMass, LinearDrive, LinearProcess>(),
        }
    }

    /// Reads a complete table (a preset's, with any overrides applied); the error says which
    /// key is missing or unknown.
    pub fn read(self, table: &ParamTable) -> Result<ModelParams, de::value::Error> {
        let table = || MapDeserializer::<_, de::value::Error>::new(table.iter().map(|(k, x)| (k.as_str(), *x)));
        Ok(match self {
            Self::LinearTwoMass => ModelParams::LinearTwoMass(AxisParams::deserialize(table())?),
            Self::RotaryTwoMass => ModelParams::RotaryTwoMass(AxisParams::deserialize(table())?),
            Self::ThreeMass => ModelParams::ThreeMass(AxisParams::deserialize(table())?),
        })
    }
}

/// Every parameter key of every model, for `[[plant.axis]]` tables, which are read before
/// their axis's model is known.
pub fn all_keys() -> &'static [&'static str] {
    static ALL: OnceLock<Vec<&'static str>> = OnceLock::new();
    ALL.get_or_init(|| {
        let mut all = Vec::new();
        for set in [ParamSet::LinearTwoMass, ParamSet::RotaryTwoMass, ParamSet::ThreeMass] {
            for key in set.keys() {
                if !all.contains(&key) {
                    all.push(key);
                }
            }
        }
        all
    })
}

fn keys_of3<M: DeserializeOwned, D: DeserializeOwned, P: DeserializeOwned>() -> Vec<&'static str> {
    [keys_of::<M>(), keys_of::<D>(), keys_of::<P>()].concat()
}

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
