//! The interpd configuration: schema, validation and the embedded default machines.
//!
//! A configuration is one TOML file (see `machines/*.toml` for commented examples):
//!
//! ```toml
//! [machine]
//! cycle_ms = 4.0
//!
//! [[axis]]
//! name = "X"
//! kind = "linear"
//! max_vel = 250.0     # mm/s   (deg/s for rotary axes)
//! max_acc = 2500.0    # mm/s²
//! max_jerk = 50000.0  # mm/s³
//! min = -1000.0       # mm
//! max = 1000.0
//! ```
//!
//! plus optional `[planner]`, `[prep]`, `[sinks]`, `[plant]`, `[control]`, `[rt]`,
//! `[compensation]`, `[work_offsets]` sections and `[[tool]]` tables.
//! Unknown keys, missing keys and values out of range are errors that name the file and the
//! key; nothing is silently defaulted except the optional sections and keys documented here.

pub mod compensation;
mod error;
mod keys;
mod machine;
pub mod plant;
mod sections;
pub mod sinks;
mod tooling;

pub use error::ConfigError;
pub use keys::keys_of;
pub use machine::{AxisConfig, AxisKind, AxisLetter, MAX_AXES, MachineSection};
pub use sections::{
    ControlConfig, PlannerConfig, PointDistribution, PrepConfig, PrepMethod, PrepMode, ProgramsConfig, QpSolver,
    RtConfig,
};
pub use tooling::{MAX_TOOL_NUMBER, ToolConfig, WORK_SYSTEMS, WorkOffsetsConfig, validate_tools};

use serde::Deserialize;
use std::path::Path;

/// Text of the embedded default machine: three linear axes X Y Z.
pub const DEFAULT_MACHINE_TOML: &str = include_str!("../machines/xyz.toml");
/// Text of the embedded five-axis example machine: X Y Z linear, A B rotary.
pub const FIVE_AXIS_MACHINE_TOML: &str = include_str!("../machines/xyzab.toml");

/// A validated machine and daemon configuration.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub machine: MachineSection,
    #[serde(rename = "axis")]
    pub axes: Vec<AxisConfig>,
    #[serde(default)]
    pub planner: PlannerConfig,
    #[serde(default)]
    pub prep: PrepConfig,
    #[serde(default)]
    pub sinks: sinks::SinksConfig,
    #[serde(default)]
    pub plant: plant::PlantConfig,
    #[serde(default)]
    pub control: ControlConfig,
    #[serde(default)]
    pub programs: ProgramsConfig,
    #[serde(default)]
    pub rt: RtConfig,
    /// `[compensation]`: corrections after the fine interpolation (none without the section).
    #[serde(default)]
    pub compensation: Option<compensation::CompensationConfig>,
    /// The tool table: `[[tool]]` tables (optional).
    #[serde(rename = "tool", default)]
    pub tools: Vec<ToolConfig>,
    /// Work coordinate systems G54 … G59 (optional).
    #[serde(default)]
    pub work_offsets: WorkOffsetsConfig,
}

impl Config {
    /// Parses and validates TOML text; `origin` names the file in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let config: Config = toml::from_str(text).map_err(|e| ConfigError::from_toml(origin, text, &e))?;
        config.validate(origin)?;
        Ok(config)
    }

    /// Reads, parses and validates a configuration file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::Io { file: origin.clone(), message: e.to_string() })?;
        Self::from_toml_str(&text, &origin)
    }

    /// The embedded default machine (X Y Z), used when no file is given.
    pub fn default_machine() -> Self {
        Self::from_toml_str(DEFAULT_MACHINE_TOML, "<embedded xyz.toml>")
            .expect("embedded default machine is valid (checked by a unit test)")
    }

    /// The embedded five-axis example machine (X Y Z A B).
    pub fn five_axis_machine() -> Self {
        Self::from_toml_str(FIVE_AXIS_MACHINE_TOML, "<embedded xyzab.toml>")
            .expect("embedded five-axis machine is valid (checked by a unit test)")
    }

    /// Loads `path` if given, otherwise the embedded default machine.
    pub fn load_or_default(path: Option<&Path>) -> Result<Self, ConfigError> {
        match path {
            Some(p) => Self::load(p),
            None => Ok(Self::default_machine()),
        }
    }

    /// Interpolation cycle in seconds.
    pub fn cycle_s(&self) -> f64 {
        self.machine.cycle_ms * 1e-3
    }

    /// Index of the axis with this G-code letter, if the machine has it.
    pub fn axis_index(&self, letter: AxisLetter) -> Option<usize> {
        self.axes.iter().position(|a| a.name == letter)
    }

    /// Axis names in configuration order.
    pub fn axis_names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.to_string()).collect()
    }

    fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let v = Validator { file: origin };
        self.machine.validate(&v)?;
        if self.axes.is_empty() {
            return Err(v.err("axis", "at least one [[axis]] table is required"));
        }
        if self.axes.len() > MAX_AXES {
            return Err(v.err("axis", &format!("at most {MAX_AXES} axes are supported, got {}", self.axes.len())));
        }
        for (i, axis) in self.axes.iter().enumerate() {
            axis.validate(&v, i)?;
            if let Some(j) = self.axes[..i].iter().position(|a| a.name == axis.name) {
                return Err(
                    v.err(&format!("axis[{i}].name"), &format!("duplicate axis name {} (also axis[{j}])", axis.name))
                );
            }
        }
        self.planner.validate(&v)?;
        self.prep.validate(&v)?;
        self.sinks.validate(&v, &self.axes)?;
        self.plant.validate(&v, &self.axes)?;
        self.control.validate(&v)?;
        self.programs.validate(&v)?;
        self.rt.validate(&v)?;
        if let Some(c) = &self.compensation {
            c.validate(&v, &self.axes)?;
        }
        validate_tools(&v, &self.tools)?;
        self.work_offsets.validate(&v, &self.axes)?;
        Ok(())
    }
}

/// Helper handed to the section validators so every error names the file and key alike.
pub struct Validator<'a> {
    file: &'a str,
}

impl Validator<'_> {
    /// An error for `key` with a message a person can act on.
    pub fn err(&self, key: &str, message: &str) -> ConfigError {
        ConfigError::Invalid { file: self.file.to_string(), key: key.to_string(), message: message.to_string() }
    }

    /// `value` must be finite and > 0.
    pub fn positive(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(self.err(key, &format!("must be a positive finite number, got {value}")))
        }
    }

    /// `value` must be finite and ≥ 0.
    pub fn non_negative(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        if value.is_finite() && value >= 0.0 {
            Ok(())
        } else {
            Err(self.err(key, &format!("must be a finite number ≥ 0, got {value}")))
        }
    }

    /// `value` must be finite and inside `[lo, hi]`.
    pub fn in_range(&self, key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
        if value.is_finite() && value >= lo && value <= hi {
            Ok(())
        } else {
            Err(self.err(key, &format!("must lie in [{lo}, {hi}], got {value}")))
        }
    }
}

#[cfg(test)]
mod tests;
