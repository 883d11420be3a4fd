//! `[[plant.axis]]`: per-axis overrides of the preset. Which parameters an axis has depends on
//! its preset, which may come later (`interpd plan --plant`), so a table is read as its axis,
//! preset and crosstalk targets plus any model parameter as a number; resolution checks the
//! parameters against the axis's model.

use super::params::all_keys;
use super::table::ParamTable;
use crate::AxisLetter;
use serde::Deserialize;
use serde::de::{self, MapAccess, Visitor};
use std::fmt;
use std::sync::OnceLock;

/// One `[[plant.axis]]` table.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlantAxisConfig {
    /// Axis the overrides apply to (required).
    pub name: Option<AxisLetter>,
    /// Preset for this axis (replaces `[plant] preset` / `rotary_preset`).
    pub preset: Option<String>,
    /// Axes receiving this axis's two crosstalk outputs (three-mass model). Default: the
    /// other two of X, Y, Z in that order.
    pub crosstalk_targets: Option<Vec<AxisLetter>>,
    /// Model parameters, each a key of some model (which one is checked on resolution).
    pub params: ParamTable,
}

impl<'de> Deserialize<'de> for PlantAxisConfig {
    fn deserialize<D: de::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_map(AxisVisitor)
    }
}

/// Every key a `[[plant.axis]]` table may have.
fn table_keys() -> &'static [&'static str] {
    static KEYS: OnceLock<Vec<&'static str>> = OnceLock::new();
    KEYS.get_or_init(|| ["name", "preset", "crosstalk_targets"].iter().chain(all_keys()).copied().collect())
}

/// A key of a `[[plant.axis]]` table, checked as it is read so that an unknown key is
/// reported at its place in the file, as in the derived sections.
struct Key(String);

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: de::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let key = String::deserialize(deserializer)?;
        match table_keys().contains(&key.as_str()) {
            true => Ok(Key(key)),
            false => Err(de::Error::unknown_field(&key, table_keys())),
        }
    }
}

/// Reads the table key by key: each value is checked for its type where it stands.
struct AxisVisitor;

impl<'de> Visitor<'de> for AxisVisitor {
    type Value = PlantAxisConfig;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a [[plant.axis]] table")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<PlantAxisConfig, A::Error> {
        let mut axis = PlantAxisConfig::default();
        while let Some(Key(key)) = map.next_key()? {
            match key.as_str() {
                "name" => axis.name = Some(map.next_value()?),
                "preset" => axis.preset = Some(map.next_value()?),
                "crosstalk_targets" => axis.crosstalk_targets = Some(map.next_value()?),
                _ => {
                    let x = map.next_value()?;
                    axis.params.insert(key, x);
                }
            }
        }
        Ok(axis)
    }
}
