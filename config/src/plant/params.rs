//! Which keys a model reads: the models ([`ModelKind`]), a model on a kind of axis
//! ([`ParamSet`]), and the typed structs serde reads an axis's flat table into
//! ([`ModelParams`]). The table itself and the checks that name where a value is set are in
//! `table`, which every model file uses; this file uses every model file.

use super::drive::{LinearDrive, RotaryDrive};
use super::process::{LinearProcess, RotaryProcess};
use super::table::ParamTable;
use super::three_mass::ThreeMass;
use super::two_mass::{LinearTwoMass, RotaryTwoMass};
use crate::{AxisKind, keys_of};
use serde::Deserialize;
use serde::de::value::MapDeserializer;
use serde::de::{self, DeserializeOwned};
use std::fmt;
use std::sync::OnceLock;

/// Which mechanical model a preset uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Motor, elastic transmission with backlash, load ([`super::LinearTwoMass`],
    /// [`super::RotaryTwoMass`]).
    TwoMass,
    /// Motor, slide, structure/TCP with crosstalk outputs (Haas 2012, §5.2;
    /// [`super::ThreeMass`]).
    ThreeMass,
}

impl fmt::Display for ModelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ModelKind::TwoMass => "two-mass",
            ModelKind::ThreeMass => "three-mass",
        })
    }
}

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
