//! `[plant]`: the simulated axis plant (sim-plant).
//!
//! Every axis gets a model preset (embedded files in `config/plants/*.toml`, each parameter
//! commented with its source) and optional per-axis overrides of any parameter:
//!
//! ```toml
//! [plant]
//! preset = "schneider-soft"        # linear axes (default "haas-laser")
//! rotary_preset = "schneider-joint1" # rotary axes (default)
//! servo_rate_hz = 10000.0          # drive cycle: controller and plant step
//! fine_interpolation = "quintic"   # how the drive fills in the setpoints: linear | cubic | quintic
//!
//! [[plant.axis]]
//! name = "Y"
//! preset = "schneider-stiff"
//! backlash_m = 0.0
//! process_force_n = 300.0
//! ```
//!
//! Parameters are in SI units named in the key: `_kg`, `_n_per_m`, `_m`, … for linear axes and
//! `_kg_m2`, `_nm_per_rad`, `_rad`, … for rotary axes. Using a linear key on a rotary axis (or
//! the reverse), or a key that the axis's model does not have, is an error naming the key.
//! [`PlantConfig::resolve`] turns the section into one [`ResolvedAxisPlant`] per axis with every
//! value in SI base units of the axis (m or rad).
//!
//! Each model has its own typed parameter structs, read by serde from the flat keys:
//! [`LinearTwoMass`] / [`RotaryTwoMass`] (`two_mass`), [`ThreeMass`] (`three_mass`), the drive
//! [`LinearDrive`] / [`RotaryDrive`] (`drive`) and the process force [`LinearProcess`] /
//! [`RotaryProcess`] (`process`); [`ParamSet`] says which an axis reads (`params`), the flat
//! [`ParamTable`] and its range checks are in `table`, presets are in `preset` and
//! `[[plant.axis]]` in `overrides`.

mod drive;
mod milling;
mod overrides;
mod params;
mod preset;
mod process;
mod table;
mod three_mass;
mod two_mass;

pub use drive::{DriveParams, LinearDrive, RotaryDrive};
pub use milling::{ActuatorConfig, MeasurementConfig, MillingConfig, StructureConfig};
pub use overrides::PlantAxisConfig;
pub use params::{AxisParams, ModelKind, ModelParams, ParamSet};
pub use preset::{DEFAULT_LINEAR_PRESET, DEFAULT_ROTARY_PRESET, PRESETS, PresetFile, preset, preset_names};
pub use process::{LinearProcess, ProcessParams, RotaryProcess};
pub use table::ParamTable;
pub use three_mass::{ThreeMass, ThreeMassParams};
pub use two_mass::{LinearTwoMass, RotaryTwoMass, TwoMassParams};

use crate::{AxisConfig, AxisKind, AxisLetter, ConfigError, Validator};
use preset::kind_word;
use serde::Deserialize;
use table::Check;

/// How the drive interpolates the setpoints (one per interpolation cycle) onto its servo cycle,
/// as a CiA 402 drive in cyclic synchronous position mode does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum FineInterpolation {
    /// Straight line between positions; velocity feedforward from the difference quotient.
    Linear,
    /// Cubic Hermite from position and velocity at both ends.
    Cubic,
    /// Quintic Hermite from position, velocity and acceleration at both ends (C² command).
    #[default]
    Quintic,
}

/// `[plant]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PlantConfig {
    /// Preset for linear axes (default [`DEFAULT_LINEAR_PRESET`]).
    pub preset: Option<String>,
    /// Preset for rotary axes (default [`DEFAULT_ROTARY_PRESET`]).
    pub rotary_preset: Option<String>,
    /// Drive servo rate: position/velocity controller and plant step, Hz.
    pub servo_rate_hz: f64,
    /// Plant integration sub-steps per servo step (the controller output is held).
    pub substeps: u32,
    /// Fine interpolation of the setpoints in the drive.
    pub fine_interpolation: FineInterpolation,
    /// Add each 3-mass axis's crosstalk output to the load (TCP) position of its target axes.
    pub apply_crosstalk: bool,
    /// Length of the metrics/plot recording (setpoint rate), s; older samples are dropped.
    pub record_s: f64,
    /// Per-axis overrides, `[[plant.axis]]` with `name` and any model parameter.
    pub axis: Vec<PlantAxisConfig>,
    /// `[plant.milling]`: the milling process force (none without the section).
    pub milling: Option<MillingConfig>,
    /// `[plant.measurement]`: force signal and external position measurement (none without).
    pub measurement: Option<MeasurementConfig>,
    /// `[plant.actuator]`: fast auxiliary actuators between load and tool (none without).
    pub actuator: Option<ActuatorConfig>,
    /// `[plant.structure]`: the structure's coupled compliance between the axes and the tool
    /// (none without: the tool sits on the load).
    pub structure: Option<StructureConfig>,
    /// Presets read from files ([`PlantConfig::select`]), by the name `preset` uses for them;
    /// looked up before the embedded ones.
    #[serde(skip)]
    pub file_presets: Vec<(String, PresetFile)>,
}

impl Default for PlantConfig {
    fn default() -> Self {
        Self {
            preset: None,
            rotary_preset: None,
            servo_rate_hz: 10_000.0,
            substeps: 1,
            fine_interpolation: FineInterpolation::Quintic,
            apply_crosstalk: true,
            record_s: 600.0,
            axis: Vec::new(),
            milling: None,
            measurement: None,
            actuator: None,
            structure: None,
            file_presets: Vec::new(),
        }
    }
}

/// The mechanical model of one axis.
#[derive(Debug, Clone, PartialEq)]
pub enum PlantModel {
    TwoMass(TwoMassParams),
    ThreeMass(ThreeMassParams),
}

/// Everything the plant needs for one axis, resolved from preset and overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedAxisPlant {
    pub axis: AxisLetter,
    pub kind: AxisKind,
    /// Preset name the axis is based on.
    pub preset: String,
    pub model: PlantModel,
    pub drive: DriveParams,
    pub process: ProcessParams,
}

impl PlantConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        v.in_range("plant.servo_rate_hz", self.servo_rate_hz, 10_000.0, 100_000.0)?;
        if !(1..=64).contains(&self.substeps) {
            return Err(v.err("plant.substeps", &format!("must lie in 1..=64, got {}", self.substeps)));
        }
        v.in_range("plant.record_s", self.record_s, 1.0, 86_400.0)?;
        if let Some(m) = &self.milling {
            m.validate(v, axes)?;
        }
        if let Some(m) = &self.measurement {
            m.validate(v)?;
        }
        if let Some(a) = &self.actuator {
            a.validate(v, axes)?;
        }
        if let Some(s) = &self.structure {
            s.validate(v, axes)?;
        }
        self.resolve_with(v, axes).map(|_| ())
    }

    /// Resolves preset and overrides into one parameter set per configured axis (in axis
    /// order). `origin` names the configuration file in errors. A configuration that passed
    /// [`crate::Config`] validation always resolves.
    pub fn resolve(&self, axes: &[AxisConfig], origin: &str) -> Result<Vec<ResolvedAxisPlant>, ConfigError> {
        self.resolve_with(&Validator { file: origin }, axes)
    }

    /// Servo (drive) period in seconds.
    pub fn servo_period_s(&self) -> f64 {
        1.0 / self.servo_rate_hz
    }

    fn resolve_with(&self, v: &Validator, axes: &[AxisConfig]) -> Result<Vec<ResolvedAxisPlant>, ConfigError> {
        for name in [("plant.preset", &self.preset), ("plant.rotary_preset", &self.rotary_preset)] {
            if let (key, Some(p)) = name {
                if self.find_preset(p).is_none() {
                    return Err(v.err(key, &format!("unknown preset `{p}`; known: {}", preset_names())));
                }
            }
        }
        // Overrides: each names an existing axis, at most once.
        let mut over_for: Vec<Option<usize>> = vec![None; axes.len()];
        for (i, o) in self.axis.iter().enumerate() {
            let key = format!("plant.axis[{i}].name");
            let Some(name) = o.name else {
                return Err(v.err(&key, "missing; every [[plant.axis]] names its axis"));
            };
            let Some(ax) = axes.iter().position(|a| a.name == name) else {
                return Err(v.err(&key, &format!("no axis {name} in this machine")));
            };
            if let Some(j) = over_for[ax] {
                return Err(v.err(&key, &format!("axis {name} already overridden in plant.axis[{j}]")));
            }
            over_for[ax] = Some(i);
        }
        (0..axes.len()).map(|ax| self.resolve_axis(v, axes, ax, over_for[ax])).collect()
    }

    /// Resolves axis `ax`: its preset with the override `over` applied, every value checked.
    fn resolve_axis(
        &self,
        v: &Validator,
        axes: &[AxisConfig],
        ax: usize,
        over: Option<usize>,
    ) -> Result<ResolvedAxisPlant, ConfigError> {
        let axis = &axes[ax];
        let over = over.map(|i| (i, &self.axis[i]));
        let (preset_name, preset_key) = self.preset_of(axis, over);
        let Some(file) = self.find_preset(&preset_name) else {
            return Err(v.err(&preset_key, &format!("unknown preset `{preset_name}`; known: {}", preset_names())));
        };
        if file.kind != axis.kind {
            let (want, is) = (kind_word(file.kind), kind_word(axis.kind));
            let message = format!("preset `{preset_name}` is for {want} axes but axis {} is {is}", axis.name);
            return Err(v.err(&preset_key, &message));
        }
        let set = file.param_set().ok_or_else(|| v.err(&preset_key, "the three-mass model is for linear axes only"))?;
        let mut table = file.params.clone();
        if let Some((i, o)) = over {
            // The override sets parameters of this axis's model only.
            let keys = set.keys();
            if let Some(key) = o.params.keys().find(|k| !keys.contains(&k.as_str())) {
                let (model, kind) = (file.model, kind_word(axis.kind));
                let message = format!("not a parameter of the {model} model on a {kind} axis (preset `{preset_name}`)");
                return Err(v.err(&format!("plant.axis[{i}].{key}"), &message));
            }
            if o.crosstalk_targets.is_some() && set != ParamSet::ThreeMass {
                let key = format!("plant.axis[{i}].crosstalk_targets");
                return Err(v.err(&key, "only the three-mass model has crosstalk outputs"));
            }
            table.extend(o.params.iter().map(|(k, x)| (k.clone(), *x)));
        }
        let axis_key = match over {
            Some((i, _)) => format!("plant.axis[{i}]"),
            None => format!("plant (axis {})", axis.name),
        };
        let c = Check {
            v,
            preset_name: &preset_name,
            preset: &file.params,
            over: over.map(|(i, o)| (i, &o.params)),
            axis_key: &axis_key,
        };
        // `PresetFile::parse` has checked that the preset sets every key without a default.
        let params = set.read(&table).map_err(|e| v.err(&axis_key, &e.to_string()))?;
        let servo_rate_hz = self.servo_rate_hz;
        let (model, drive, process) = match params {
            ModelParams::LinearTwoMass(p) => (
                PlantModel::TwoMass(p.mechanics.resolve(&c)?),
                p.drive.resolve(&c, servo_rate_hz)?,
                p.process.resolve(&c)?,
            ),
            ModelParams::RotaryTwoMass(p) => (
                PlantModel::TwoMass(p.mechanics.resolve(&c)?),
                p.drive.resolve(&c, servo_rate_hz)?,
                p.process.resolve(&c)?,
            ),
            ModelParams::ThreeMass(p) => {
                let targets = over.and_then(|(i, o)| {
                    o.crosstalk_targets.as_deref().map(|t| (format!("plant.axis[{i}].crosstalk_targets"), t))
                });
                let targets = three_mass::crosstalk_targets(v, targets, axes, ax)?;
                (
                    PlantModel::ThreeMass(p.mechanics.resolve(&c, targets)?),
                    p.drive.resolve(&c, servo_rate_hz)?,
                    p.process.resolve(&c)?,
                )
            }
        };
        Ok(ResolvedAxisPlant { axis: axis.name, kind: axis.kind, preset: preset_name, model, drive, process })
    }

    /// The preset of `axis` and the key that names it: the override's, else the section's for
    /// the axis's kind, else the default for that kind.
    fn preset_of(&self, axis: &AxisConfig, over: Option<(usize, &PlantAxisConfig)>) -> (String, String) {
        if let Some((i, Some(p))) = over.map(|(i, o)| (i, &o.preset)) {
            return (p.clone(), format!("plant.axis[{i}].preset"));
        }
        let (preset, default, key) = match axis.kind {
            AxisKind::Linear => (&self.preset, DEFAULT_LINEAR_PRESET, "plant.preset"),
            AxisKind::Rotary => (&self.rotary_preset, DEFAULT_ROTARY_PRESET, "plant.rotary_preset"),
        };
        (preset.clone().unwrap_or_else(|| default.to_string()), key.to_string())
    }
}

/// The `[plant]` section of a TOML file; other sections (a whole machine file) are ignored.
#[derive(Deserialize)]
struct PlantSectionFile {
    plant: PlantConfig,
}

impl PlantConfig {
    /// A preset read from a file or embedded, by name.
    fn find_preset(&self, name: &str) -> Option<PresetFile> {
        match self.file_presets.iter().find(|(n, _)| n == name) {
            Some((_, f)) => Some(f.clone()),
            None => preset(name),
        }
    }

    /// The plant for `interpd plan --plant [PRESET|FILE]` and similar options, validated for
    /// `axes`: `""` keeps this section; an embedded preset name becomes the preset of every
    /// axis of its kind (per-axis overrides of this section stay); a file is either a preset
    /// file in the format of `config/plants/*.toml` (used like a preset name) or a TOML file
    /// with a `[plant]` section (a machine file works) that replaces this section. Errors name
    /// `option` (e.g. `--plant`) or the file and key.
    pub fn select(&self, choice: &str, axes: &[AxisConfig], option: &str) -> Result<PlantConfig, ConfigError> {
        let v = Validator { file: option };
        if choice.is_empty() {
            return Ok(self.clone());
        }
        if let Some(file) = preset(choice) {
            let mut c = self.clone();
            c.use_preset(choice, file.kind);
            c.validate(&v, axes)?;
            return Ok(c);
        }
        let path = std::path::Path::new(choice);
        if !path.is_file() {
            return Err(
                v.err(choice, &format!("neither a plant preset (known: {}) nor an existing file", preset_names()))
            );
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::Io { file: choice.to_string(), message: e.to_string() })?;
        let fv = Validator { file: choice };
        let table: toml::Table = toml::from_str(&text).map_err(|e| ConfigError::from_toml(choice, &text, &e))?;
        if table.contains_key("plant") {
            let section: PlantSectionFile =
                toml::from_str(&text).map_err(|e| ConfigError::from_toml(choice, &text, &e))?;
            section.plant.validate(&fv, axes)?;
            return Ok(section.plant);
        }
        let file = PresetFile::parse(&text, choice)?;
        let mut c = self.clone();
        let kind = file.kind;
        c.file_presets.retain(|(n, _)| n != choice);
        c.file_presets.push((choice.to_string(), file));
        c.use_preset(choice, kind);
        c.validate(&fv, axes)?;
        Ok(c)
    }

    /// `name` for every axis of `kind`.
    fn use_preset(&mut self, name: &str, kind: AxisKind) {
        match kind {
            AxisKind::Linear => self.preset = Some(name.to_string()),
            AxisKind::Rotary => self.rotary_preset = Some(name.to_string()),
        }
    }
}

#[cfg(test)]
mod tests;
