//! Plant presets: one axis model with all its parameters, in a TOML file of the form of
//! `config/plants/*.toml` (a header and `[params]`). The embedded presets are those files;
//! `interpd plan --plant FILE` takes a user file of the same form (`[plant] preset` names an
//! embedded preset).

use super::params::{ModelKind, ParamSet};
use super::table::ParamTable;
use crate::{AxisKind, ConfigError, Validator};
use serde::Deserialize;

/// The embedded model presets: (name, TOML text).
pub const PRESETS: [(&str, &str); 4] = [
    ("schneider-soft", include_str!("../../plants/schneider-soft.toml")),
    ("schneider-stiff", include_str!("../../plants/schneider-stiff.toml")),
    ("schneider-joint1", include_str!("../../plants/schneider-joint1.toml")),
    ("haas-laser", include_str!("../../plants/haas-laser.toml")),
];

/// Preset used for linear axes when `[plant] preset` is not given.
pub const DEFAULT_LINEAR_PRESET: &str = "haas-laser";
/// Preset used for rotary axes when `[plant] rotary_preset` is not given.
pub const DEFAULT_ROTARY_PRESET: &str = "schneider-joint1";

/// "linear" or "rotary", for messages.
pub(crate) fn kind_word(k: AxisKind) -> &'static str {
    match k {
        AxisKind::Linear => "linear",
        AxisKind::Rotary => "rotary",
    }
}

/// A preset file: header plus the parameter table. Read it with [`PresetFile::parse`], which
/// also checks `[params]` against the model.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PresetFile {
    /// One line saying what the preset models.
    pub description: String,
    /// Axis kind the preset is for.
    pub kind: AxisKind,
    /// Mechanical model.
    pub model: ModelKind,
    /// Every parameter of the model that has no default, and any that have one.
    pub params: ParamTable,
}

impl PresetFile {
    /// Parses a preset file and checks that `[params]` holds the keys of its model on its kind
    /// of axis, all that have no default and no others; errors name `origin` and the key.
    pub fn parse(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let file: PresetFile = toml::from_str(text).map_err(|e| ConfigError::from_toml(origin, text, &e))?;
        let v = Validator { file: origin };
        let set = file.param_set().ok_or_else(|| v.err("model", "the three-mass model is for linear axes only"))?;
        let keys = set.keys();
        if let Some(key) = file.params.keys().find(|k| !keys.contains(&k.as_str())) {
            return Err(v.err(
                &format!("params.{key}"),
                &format!("not a parameter of the {} model on a {} axis", file.model, kind_word(file.kind)),
            ));
        }
        set.read(&file.params).map_err(|e| v.err("params", &e.to_string()))?;
        Ok(file)
    }

    /// The keys the preset's model reads on its kind of axis (`None` for a rotary three-mass
    /// preset, which [`PresetFile::parse`] rejects).
    pub fn param_set(&self) -> Option<ParamSet> {
        ParamSet::of(self.model, self.kind)
    }
}

/// The embedded preset `name`, or `None` if there is no such preset.
pub fn preset(name: &str) -> Option<PresetFile> {
    let (_, text) = PRESETS.iter().find(|(n, _)| *n == name)?;
    // The embedded files are checked by the unit test `presets_parse_and_resolve`.
    PresetFile::parse(text, name).ok()
}

/// Names of all presets, for messages.
pub fn preset_names() -> String {
    PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}
