//! The tool table (`[[tool]]`) and the work offsets (`[work_offsets]`, G54–G59.3): the data the
//! G-code interpreter reads for tool length compensation (G43 H), cutter radius compensation
//! (G41/G42 D) and work coordinate systems.

use crate::{AxisConfig, AxisLetter, ConfigError, Validator};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Largest tool number (as LinuxCNC's default pocket range).
pub const MAX_TOOL_NUMBER: u32 = 99_999;

/// One `[[tool]]` table.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ToolConfig {
    /// Tool number, as programmed in H (G43) and D (G41/G42).
    pub number: u32,
    /// Cutter diameter, mm (≥ 0). G41/G42 offset the path by half of it.
    #[serde(rename = "diameter")]
    pub diameter_mm: f64,
    /// Tool length, mm: G43 adds it to Z.
    #[serde(rename = "length", default)]
    pub length_mm: f64,
    /// Free text for status output.
    #[serde(default)]
    pub name: Option<String>,
}

/// `[work_offsets]`: per coordinate system G54 … G59.3 the offset of its origin from machine
/// zero, per axis letter (mm, deg for rotary axes), and per system its rotation about Z
/// (`rotation`, degrees counter-clockwise, as `G10 L2 … R`). Axes left out are 0; a system
/// left out is all 0 and unturned.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct WorkOffsetsConfig {
    #[serde(rename = "G54")]
    pub g54: BTreeMap<String, f64>,
    #[serde(rename = "G55")]
    pub g55: BTreeMap<String, f64>,
    #[serde(rename = "G56")]
    pub g56: BTreeMap<String, f64>,
    #[serde(rename = "G57")]
    pub g57: BTreeMap<String, f64>,
    #[serde(rename = "G58")]
    pub g58: BTreeMap<String, f64>,
    #[serde(rename = "G59")]
    pub g59: BTreeMap<String, f64>,
    #[serde(rename = "G59.1")]
    pub g59_1: BTreeMap<String, f64>,
    #[serde(rename = "G59.2")]
    pub g59_2: BTreeMap<String, f64>,
    #[serde(rename = "G59.3")]
    pub g59_3: BTreeMap<String, f64>,
    /// System name → rotation about Z, degrees counter-clockwise (systems left out: 0).
    #[serde(rename = "rotation")]
    pub rotation_deg: BTreeMap<String, f64>,
}

/// The names of the coordinate systems in `WorkOffsetsConfig::systems` order (LinuxCNC's
/// P1 … P9 of G10 L2).
pub const WORK_SYSTEMS: [&str; 9] = ["G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"];

impl WorkOffsetsConfig {
    /// The nine systems in order G54 … G59.3.
    pub fn systems(&self) -> [&BTreeMap<String, f64>; 9] {
        [&self.g54, &self.g55, &self.g56, &self.g57, &self.g58, &self.g59, &self.g59_1, &self.g59_2, &self.g59_3]
    }

    /// The nine systems, mutable, in order G54 … G59.3.
    pub fn systems_mut(&mut self) -> [&mut BTreeMap<String, f64>; 9] {
        [
            &mut self.g54,
            &mut self.g55,
            &mut self.g56,
            &mut self.g57,
            &mut self.g58,
            &mut self.g59,
            &mut self.g59_1,
            &mut self.g59_2,
            &mut self.g59_3,
        ]
    }

    /// The offset of system `index` (0 = G54) per machine axis.
    pub fn vector(&self, index: usize, axes: &[AxisConfig]) -> [f64; crate::MAX_AXES] {
        let mut out = [0.0; crate::MAX_AXES];
        let sys = self.systems()[index];
        for (k, a) in axes.iter().enumerate() {
            out[k] = sys.get(&a.name.to_string()).copied().unwrap_or(0.0);
        }
        out
    }

    /// The rotation of system `index` (0 = G54) about Z, degrees.
    pub fn rotation(&self, index: usize) -> f64 {
        self.rotation_deg.get(WORK_SYSTEMS[index]).copied().unwrap_or(0.0)
    }

    /// Sets the rotation of system `index`; 0 is kept as no entry (a system left out).
    pub fn set_rotation(&mut self, index: usize, deg: f64) {
        if deg == 0.0 {
            self.rotation_deg.remove(WORK_SYSTEMS[index]);
        } else {
            self.rotation_deg.insert(WORK_SYSTEMS[index].to_string(), deg);
        }
    }

    /// The same offsets and rotations on the machine's axes, whatever a map leaves out (read
    /// as 0).
    pub fn same_on(&self, other: &WorkOffsetsConfig, axes: &[AxisConfig]) -> bool {
        (0..WORK_SYSTEMS.len())
            .all(|i| self.vector(i, axes) == other.vector(i, axes) && self.rotation(i) == other.rotation(i))
    }

    /// Every entry names an axis of the machine (a rotation: a system) and is finite.
    pub fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        for (name, sys) in WORK_SYSTEMS.iter().zip(self.systems()) {
            for (letter, value) in sys {
                let key = format!("work_offsets.{name}.{letter}");
                let known = AxisLetter::from_char(letter.chars().next().unwrap_or(' '))
                    .filter(|l| letter.len() == 1 && axes.iter().any(|a| a.name == *l));
                if known.is_none() {
                    let names: Vec<String> = axes.iter().map(|a| a.name.to_string()).collect();
                    return Err(v.err(&key, &format!("not an axis of this machine (axes: {})", names.join(" "))));
                }
                if !value.is_finite() {
                    return Err(v.err(&key, &format!("must be finite, got {value}")));
                }
            }
        }
        for (name, value) in &self.rotation_deg {
            let key = format!("work_offsets.rotation.{name}");
            if !WORK_SYSTEMS.contains(&name.as_str()) {
                return Err(v.err(&key, &format!("not a coordinate system (one of {})", WORK_SYSTEMS.join(" "))));
            }
            if !value.is_finite() {
                return Err(v.err(&key, &format!("must be finite, got {value}")));
            }
        }
        Ok(())
    }
}

/// Checks a tool table: numbers in range and unique, diameters ≥ 0, lengths finite.
pub fn validate_tools(v: &Validator, tools: &[ToolConfig]) -> Result<(), ConfigError> {
    for (i, t) in tools.iter().enumerate() {
        if t.number > MAX_TOOL_NUMBER {
            return Err(
                v.err(&format!("tool[{i}].number"), &format!("must lie in [0, {MAX_TOOL_NUMBER}], got {}", t.number))
            );
        }
        if let Some(j) = tools[..i].iter().position(|o| o.number == t.number) {
            return Err(
                v.err(&format!("tool[{i}].number"), &format!("duplicate tool number {} (also tool[{j}])", t.number))
            );
        }
        v.non_negative(&format!("tool[{i}].diameter"), t.diameter_mm)?;
        if !t.length_mm.is_finite() {
            return Err(v.err(&format!("tool[{i}].length"), &format!("must be finite, got {}", t.length_mm)));
        }
    }
    Ok(())
}
