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

use crate::{AxisConfig, AxisKind, AxisLetter, ConfigError, Validator};
use serde::Deserialize;

/// The embedded model presets: (name, TOML text).
pub const PRESETS: [(&str, &str); 4] = [
    ("schneider-soft", include_str!("../plants/schneider-soft.toml")),
    ("schneider-stiff", include_str!("../plants/schneider-stiff.toml")),
    ("schneider-joint1", include_str!("../plants/schneider-joint1.toml")),
    ("haas-laser", include_str!("../plants/haas-laser.toml")),
];

/// Preset used for linear axes when `[plant] preset` is not given.
pub const DEFAULT_LINEAR_PRESET: &str = "haas-laser";
/// Preset used for rotary axes when `[plant] rotary_preset` is not given.
pub const DEFAULT_ROTARY_PRESET: &str = "schneider-joint1";

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
            file_presets: Vec::new(),
        }
    }
}

/// Declares [`PlantAxisConfig`] with every numeric parameter as `Option<f64>` and a list of
/// (key, value) pairs so resolution and validation can treat them uniformly.
macro_rules! axis_params {
    ($($(#[$doc:meta])* $key:ident,)*) => {
        /// One `[[plant.axis]]` table, or the parameter table of a preset file. Every parameter
        /// is optional; unset ones come from the preset.
        #[derive(Debug, Clone, Deserialize, PartialEq, Default)]
        #[serde(deny_unknown_fields, default)]
        pub struct PlantAxisConfig {
            /// Axis the overrides apply to (required in `[[plant.axis]]`, absent in presets).
            pub name: Option<AxisLetter>,
            /// Preset for this axis (replaces `[plant] preset` / `rotary_preset`).
            pub preset: Option<String>,
            /// Axes receiving this axis's two crosstalk outputs (3-mass model). Default: the
            /// other two of X, Y, Z in that order.
            pub crosstalk_targets: Option<Vec<AxisLetter>>,
            $( $(#[$doc])* pub $key: Option<f64>, )*
        }

        impl PlantAxisConfig {
            /// All numeric parameters as (key, value) pairs.
            pub fn numeric(&self) -> Vec<(&'static str, Option<f64>)> {
                vec![$((stringify!($key), self.$key)),*]
            }
        }
    };
}

axis_params! {
    // ---- two-mass model, linear axis (load-referred; seed 004 §5a)
    /// Motor-side mass m_M, kg.
    motor_mass_kg,
    /// Load mass m_L, kg.
    load_mass_kg,
    /// Transmission stiffness k₊ for positive spring force, N/m.
    stiffness_n_per_m,
    /// Transmission stiffness k₋ for negative spring force, N/m (default k₊).
    stiffness_neg_n_per_m,
    /// Transmission damping c_s, N·s/m (acts while the flanks are in contact).
    damping_n_s_per_m,
    /// Motor viscous friction c_M, N·s/m.
    motor_viscous_n_s_per_m,
    /// Load viscous friction c_L, N·s/m.
    load_viscous_n_s_per_m,
    /// Motor Coulomb friction, N.
    motor_coulomb_n,
    /// Load Coulomb friction, N.
    load_coulomb_n,
    /// Total backlash width b, m.
    backlash_m,
    /// Half-width of the C¹ blend at each backlash flank, m (≤ b/2).
    backlash_blend_m,
    // ---- two-mass model, rotary axis (same model with J, θ, τ)
    /// Motor inertia, kg·m².
    motor_inertia_kg_m2,
    /// Load inertia, kg·m².
    load_inertia_kg_m2,
    /// Stiffness for positive torque, N·m/rad.
    stiffness_nm_per_rad,
    /// Stiffness for negative torque, N·m/rad (default the positive one).
    stiffness_neg_nm_per_rad,
    /// Transmission damping, N·m·s/rad.
    damping_nm_s_per_rad,
    /// Motor viscous friction, N·m·s/rad.
    motor_viscous_nm_s_per_rad,
    /// Load viscous friction, N·m·s/rad.
    load_viscous_nm_s_per_rad,
    /// Motor Coulomb friction, N·m.
    motor_coulomb_nm,
    /// Load Coulomb friction, N·m.
    load_coulomb_nm,
    /// Total backlash width, rad.
    backlash_rad,
    /// Half-width of the C¹ blend at each flank, rad.
    backlash_blend_rad,
    // ---- three-mass model, linear axis (seed 000 §5.2, Table 5.1)
    /// Motor mass m₁, kg.
    m1_kg,
    /// Slide mass m₂, kg.
    m2_kg,
    /// Structure (TCP) mass m₃, kg.
    m3_kg,
    /// Stiffness motor–slide k₁, N/m.
    k1_n_per_m,
    /// Stiffness slide–structure k₂, N/m.
    k2_n_per_m,
    /// Motor friction d_M, N·s/m.
    d_motor_n_s_per_m,
    /// Slide friction d_Sch, N·s/m.
    d_slide_n_s_per_m,
    /// Structure friction d_S, N·s/m.
    d_structure_n_s_per_m,
    /// Damping motor–slide d₁, N·s/m.
    d1_n_s_per_m,
    /// Damping slide–structure d₂, N·s/m.
    d2_n_s_per_m,
    /// Intalk parameter I_T, s².
    intalk_s2,
    /// Crosstalk parameter C_Ty (first target axis), s².
    crosstalk_y_s2,
    /// Crosstalk parameter C_Tz (second target axis), s².
    crosstalk_z_s2,
    // ---- process force on the load (seed 004 §5a: F_proc = F_static + F_dyn)
    /// Static process force, N (linear axes).
    process_force_n,
    /// Amplitude of the sinusoidal process force (tooth pass), N.
    process_force_dyn_n,
    /// Static process torque, N·m (rotary axes).
    process_torque_nm,
    /// Amplitude of the sinusoidal process torque, N·m.
    process_torque_dyn_nm,
    /// Frequency of the dynamic process force, Hz (teeth × rpm / 60).
    process_dyn_hz,
    // ---- drive: quantised motor encoder, P position / PI velocity cascade, current loop
    /// Motor encoder quantum referred to the load side, m (0: ideal).
    encoder_step_m,
    /// Motor encoder quantum, rad (0: ideal).
    encoder_step_rad,
    /// Position loop gain Kv, 1/s.
    kv_per_s,
    /// Velocity loop proportional gain, N·s/m.
    kp_n_s_per_m,
    /// Velocity loop proportional gain, N·m·s/rad.
    kp_nm_s_per_rad,
    /// Velocity loop reset time Tn, s.
    tn_s,
    /// Current loop (power module) bandwidth of the PT1 lag, Hz.
    current_loop_hz,
    /// Peak motor force, N.
    force_limit_n,
    /// Peak motor torque, N·m.
    torque_limit_nm,
    /// Velocity feedforward gain (1 = full).
    vel_ff,
    /// Acceleration (force) feedforward gain, fraction of the total moved mass (1 = full).
    acc_ff,
    /// PT1 filter on the encoder velocity, Hz (0: no filter).
    velocity_filter_hz,
}

/// Which mechanical model a preset uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Motor, elastic transmission with backlash, load (seed 004 §5a).
    TwoMass,
    /// Motor, slide, structure/TCP with crosstalk outputs (seed 000 §5.2).
    ThreeMass,
}

/// A preset file: header plus the parameter table.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PresetFile {
    /// One line saying what the preset models.
    pub description: String,
    /// Axis kind the preset is for.
    pub kind: AxisKind,
    /// Mechanical model.
    pub model: ModelKind,
    /// The parameters (all a model needs).
    pub params: PlantAxisConfig,
}

/// The parsed preset `name`, or `None` if there is no such preset.
pub fn preset(name: &str) -> Option<PresetFile> {
    let (_, text) = PRESETS.iter().find(|(n, _)| *n == name)?;
    // The embedded files are checked by the unit test `presets_parse_and_resolve`.
    toml::from_str(text).ok()
}

/// Names of all presets, for messages.
pub fn preset_names() -> String {
    PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// Two-mass parameters in SI base units of the axis (m, kg, N — or rad, kg·m², N·m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoMassParams {
    /// m_M (kg or kg·m²).
    pub motor_mass: f64,
    /// m_L (kg or kg·m²).
    pub load_mass: f64,
    /// k₊ (N/m or N·m/rad).
    pub stiffness_pos: f64,
    /// k₋ (N/m or N·m/rad).
    pub stiffness_neg: f64,
    /// c_s (N·s/m or N·m·s/rad).
    pub damping: f64,
    /// c_M.
    pub motor_viscous: f64,
    /// c_L.
    pub load_viscous: f64,
    /// Motor Coulomb friction (N or N·m).
    pub motor_coulomb: f64,
    /// Load Coulomb friction (N or N·m).
    pub load_coulomb: f64,
    /// Backlash width b (m or rad).
    pub backlash: f64,
    /// Blend half-width at each flank (m or rad).
    pub backlash_blend: f64,
}

/// Three-mass parameters (linear axes; SI).
#[derive(Debug, Clone, PartialEq)]
pub struct ThreeMassParams {
    pub m1_kg: f64,
    pub m2_kg: f64,
    pub m3_kg: f64,
    pub k1_n_per_m: f64,
    pub k2_n_per_m: f64,
    pub d_motor_n_s_per_m: f64,
    pub d_slide_n_s_per_m: f64,
    pub d_structure_n_s_per_m: f64,
    pub d1_n_s_per_m: f64,
    pub d2_n_s_per_m: f64,
    /// Motor Coulomb friction, N.
    pub motor_coulomb_n: f64,
    pub intalk_s2: f64,
    /// [C_Ty, C_Tz], s².
    pub crosstalk_s2: [f64; 2],
    /// Axis indices receiving the two crosstalk outputs (None: not on this machine).
    pub crosstalk_targets: [Option<usize>; 2],
}

/// The mechanical model of one axis.
#[derive(Debug, Clone, PartialEq)]
pub enum PlantModel {
    TwoMass(TwoMassParams),
    ThreeMass(ThreeMassParams),
}

/// Drive parameters in SI base units of the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveParams {
    /// Encoder quantum (m or rad); 0 = ideal.
    pub encoder_step: f64,
    /// Position gain Kv, 1/s.
    pub kv_per_s: f64,
    /// Velocity PI gain (N·s/m or N·m·s/rad).
    pub kp: f64,
    /// Reset time Tn, s.
    pub tn_s: f64,
    /// Current-loop PT1 bandwidth, Hz.
    pub current_loop_hz: f64,
    /// Force/torque limit (N or N·m).
    pub force_limit: f64,
    /// Velocity feedforward gain.
    pub vel_ff: f64,
    /// Acceleration feedforward gain (fraction of the total mass).
    pub acc_ff: f64,
    /// Encoder velocity PT1 filter, Hz; None = unfiltered.
    pub velocity_filter_hz: Option<f64>,
}

/// Process force on the load: static + sinusoidal part (N or N·m).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProcessParams {
    pub static_force: f64,
    pub dyn_force: f64,
    pub dyn_hz: f64,
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

/// Parameter pairs (linear key, rotary key) of the two-mass model, in [`TwoMassParams`] order.
const TWO_MASS_KEYS: [(&str, &str); 11] = [
    ("motor_mass_kg", "motor_inertia_kg_m2"),
    ("load_mass_kg", "load_inertia_kg_m2"),
    ("stiffness_n_per_m", "stiffness_nm_per_rad"),
    ("stiffness_neg_n_per_m", "stiffness_neg_nm_per_rad"),
    ("damping_n_s_per_m", "damping_nm_s_per_rad"),
    ("motor_viscous_n_s_per_m", "motor_viscous_nm_s_per_rad"),
    ("load_viscous_n_s_per_m", "load_viscous_nm_s_per_rad"),
    ("motor_coulomb_n", "motor_coulomb_nm"),
    ("load_coulomb_n", "load_coulomb_nm"),
    ("backlash_m", "backlash_rad"),
    ("backlash_blend_m", "backlash_blend_rad"),
];

/// Three-mass keys (linear only), in [`ThreeMassParams`] order, plus the motor Coulomb key.
const THREE_MASS_KEYS: [&str; 13] = [
    "m1_kg",
    "m2_kg",
    "m3_kg",
    "k1_n_per_m",
    "k2_n_per_m",
    "d_motor_n_s_per_m",
    "d_slide_n_s_per_m",
    "d_structure_n_s_per_m",
    "d1_n_s_per_m",
    "d2_n_s_per_m",
    "intalk_s2",
    "crosstalk_y_s2",
    "crosstalk_z_s2",
];

/// Drive and process keys: (linear key, rotary key); equal when the unit does not differ.
const COMMON_KEYS: [(&str, &str); 13] = [
    ("encoder_step_m", "encoder_step_rad"),
    ("kv_per_s", "kv_per_s"),
    ("kp_n_s_per_m", "kp_nm_s_per_rad"),
    ("tn_s", "tn_s"),
    ("current_loop_hz", "current_loop_hz"),
    ("force_limit_n", "torque_limit_nm"),
    ("vel_ff", "vel_ff"),
    ("acc_ff", "acc_ff"),
    ("velocity_filter_hz", "velocity_filter_hz"),
    ("process_force_n", "process_torque_nm"),
    ("process_force_dyn_n", "process_torque_dyn_nm"),
    ("process_dyn_hz", "process_dyn_hz"),
    // Present in both models for linear axes (motor friction of the 3-mass model).
    ("motor_coulomb_n", "motor_coulomb_nm"),
];

/// Keys that may be absent: (key, default).
const OPTIONAL_KEYS: [(&str, f64); 17] = [
    ("motor_coulomb_n", 0.0),
    ("motor_coulomb_nm", 0.0),
    ("load_coulomb_n", 0.0),
    ("load_coulomb_nm", 0.0),
    ("backlash_m", 0.0),
    ("backlash_rad", 0.0),
    ("backlash_blend_m", 0.0),
    ("backlash_blend_rad", 0.0),
    ("process_force_n", 0.0),
    ("process_force_dyn_n", 0.0),
    ("process_torque_nm", 0.0),
    ("process_torque_dyn_nm", 0.0),
    ("process_dyn_hz", 0.0),
    ("velocity_filter_hz", 0.0),
    ("acc_ff", 0.0),
    ("encoder_step_m", 0.0),
    ("encoder_step_rad", 0.0),
];

/// Looks up parameters: the axis override first, then the preset. Errors name the key where
/// the value was set (`plant.axis[i].key` or `preset NAME: key`).
struct Lookup<'a> {
    preset_name: &'a str,
    preset: &'a PlantAxisConfig,
    over: Option<(usize, &'a PlantAxisConfig)>,
}

impl Lookup<'_> {
    fn get(&self, key: &str) -> Option<(f64, String)> {
        let find = |c: &PlantAxisConfig| c.numeric().into_iter().find(|(k, _)| *k == key).and_then(|(_, v)| v);
        if let Some((i, o)) = self.over {
            if let Some(v) = find(o) {
                return Some((v, format!("plant.axis[{i}].{key}")));
            }
        }
        find(self.preset).map(|v| (v, format!("plant preset {}: {key}", self.preset_name)))
    }

    /// The value of `key`; a default for optional keys; else an error naming the axis.
    fn value(&self, v: &Validator, key: &str, axis_key: &str) -> Result<(f64, String), ConfigError> {
        if let Some(found) = self.get(key) {
            return Ok(found);
        }
        if let Some((_, d)) = OPTIONAL_KEYS.iter().find(|(k, _)| *k == key) {
            return Ok((*d, format!("{axis_key}.{key}")));
        }
        Err(v.err(&format!("{axis_key}.{key}"), &format!("missing; preset {} does not set it", self.preset_name)))
    }

    fn non_negative(&self, v: &Validator, key: &str, axis_key: &str) -> Result<f64, ConfigError> {
        let (x, k) = self.value(v, key, axis_key)?;
        v.non_negative(&k, x)?;
        Ok(x)
    }

    fn positive(&self, v: &Validator, key: &str, axis_key: &str) -> Result<f64, ConfigError> {
        let (x, k) = self.value(v, key, axis_key)?;
        v.positive(&k, x)?;
        Ok(x)
    }
}

impl PlantConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        v.in_range("plant.servo_rate_hz", self.servo_rate_hz, 10_000.0, 100_000.0)?;
        if !(1..=64).contains(&self.substeps) {
            return Err(v.err("plant.substeps", &format!("must lie in 1..=64, got {}", self.substeps)));
        }
        v.in_range("plant.record_s", self.record_s, 1.0, 86_400.0)?;
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
        axes.iter().enumerate().map(|(ax, a)| self.resolve_axis(v, axes, ax, a, over_for[ax])).collect()
    }

    fn resolve_axis(
        &self,
        v: &Validator,
        axes: &[AxisConfig],
        ax: usize,
        axis: &AxisConfig,
        over: Option<usize>,
    ) -> Result<ResolvedAxisPlant, ConfigError> {
        let over = over.map(|i| (i, &self.axis[i]));
        let axis_key = match over {
            Some((i, _)) => format!("plant.axis[{i}]"),
            None => format!("plant (axis {})", axis.name),
        };
        // Preset choice: axis override, then section default for the axis kind.
        let (preset_name, preset_key) = match over.and_then(|(i, o)| o.preset.clone().map(|p| (i, p))) {
            Some((i, p)) => (p, format!("plant.axis[{i}].preset")),
            None => match axis.kind {
                AxisKind::Linear => (
                    self.preset.clone().unwrap_or_else(|| DEFAULT_LINEAR_PRESET.to_string()),
                    "plant.preset".to_string(),
                ),
                AxisKind::Rotary => (
                    self.rotary_preset.clone().unwrap_or_else(|| DEFAULT_ROTARY_PRESET.to_string()),
                    "plant.rotary_preset".to_string(),
                ),
            },
        };
        let Some(file) = self.find_preset(&preset_name) else {
            return Err(v.err(&preset_key, &format!("unknown preset `{preset_name}`; known: {}", preset_names())));
        };
        if file.kind != axis.kind {
            return Err(v.err(
                &preset_key,
                &format!(
                    "preset `{preset_name}` is for {} axes but axis {} is {}",
                    kind_word(file.kind),
                    axis.name,
                    kind_word(axis.kind)
                ),
            ));
        }
        // Every key set in the override must belong to this model and axis kind.
        if let Some((i, o)) = over {
            let allowed = allowed_keys(file.model, axis.kind);
            for (key, value) in o.numeric() {
                if value.is_some() && !allowed.contains(&key) {
                    return Err(v.err(
                        &format!("plant.axis[{i}].{key}"),
                        &format!(
                            "not a parameter of the {} model on a {} axis (preset `{preset_name}`)",
                            model_word(file.model),
                            kind_word(axis.kind)
                        ),
                    ));
                }
            }
            if o.crosstalk_targets.is_some() && file.model != ModelKind::ThreeMass {
                return Err(v.err(
                    &format!("plant.axis[{i}].crosstalk_targets"),
                    "only the three-mass model has crosstalk outputs",
                ));
            }
        }
        let look = Lookup { preset_name: &preset_name, preset: &file.params, over };
        let rot = axis.kind == AxisKind::Rotary;
        let pick = |pair: (&'static str, &'static str)| if rot { pair.1 } else { pair.0 };

        let model = match file.model {
            ModelKind::TwoMass => {
                let k = |i: usize| pick(TWO_MASS_KEYS[i]);
                let motor_mass = look.positive(v, k(0), &axis_key)?;
                let load_mass = look.positive(v, k(1), &axis_key)?;
                let stiffness_pos = look.positive(v, k(2), &axis_key)?;
                let stiffness_neg = match look.get(k(3)) {
                    Some((x, key)) => {
                        v.positive(&key, x)?;
                        x
                    }
                    None => stiffness_pos,
                };
                let damping = look.non_negative(v, k(4), &axis_key)?;
                let motor_viscous = look.non_negative(v, k(5), &axis_key)?;
                let load_viscous = look.non_negative(v, k(6), &axis_key)?;
                let motor_coulomb = look.non_negative(v, k(7), &axis_key)?;
                let load_coulomb = look.non_negative(v, k(8), &axis_key)?;
                let backlash = look.non_negative(v, k(9), &axis_key)?;
                let (mut blend, blend_key) = look.value(v, k(10), &axis_key)?;
                v.non_negative(&blend_key, blend)?;
                // A preset's blend shrinks with an overridden smaller backlash; an explicit
                // override larger than b/2 is an error.
                if blend > backlash / 2.0 && !blend_key.starts_with("plant.axis") {
                    blend = backlash / 2.0;
                }
                if blend > backlash / 2.0 {
                    return Err(v.err(
                        &blend_key,
                        &format!("must not exceed half the backlash ({}), got {blend}", backlash / 2.0),
                    ));
                }
                PlantModel::TwoMass(TwoMassParams {
                    motor_mass,
                    load_mass,
                    stiffness_pos,
                    stiffness_neg,
                    damping,
                    motor_viscous,
                    load_viscous,
                    motor_coulomb,
                    load_coulomb,
                    backlash,
                    backlash_blend: blend,
                })
            }
            ModelKind::ThreeMass => {
                let mut x = [0.0; 13];
                for (i, key) in THREE_MASS_KEYS.iter().enumerate() {
                    x[i] = if i < 5 || i == 10 {
                        look.positive(v, key, &axis_key)?
                    } else {
                        look.non_negative(v, key, &axis_key)?
                    };
                }
                let targets_key = match over {
                    Some((i, o)) if o.crosstalk_targets.is_some() => format!("plant.axis[{i}].crosstalk_targets"),
                    _ => String::new(),
                };
                let targets: Vec<AxisLetter> = match over.and_then(|(_, o)| o.crosstalk_targets.clone()) {
                    Some(t) => {
                        if t.len() > 2 {
                            return Err(v.err(&targets_key, &format!("at most 2 target axes, got {}", t.len())));
                        }
                        if t.contains(&axis.name) {
                            return Err(
                                v.err(&targets_key, &format!("axis {} cannot cross-talk into itself", axis.name))
                            );
                        }
                        for l in &t {
                            if !axes.iter().any(|a| a.name == *l) {
                                return Err(v.err(&targets_key, &format!("no axis {l} in this machine")));
                            }
                        }
                        t
                    }
                    None => [AxisLetter::X, AxisLetter::Y, AxisLetter::Z]
                        .into_iter()
                        .filter(|l| *l != axis.name)
                        .take(2)
                        .collect(),
                };
                let index = |i: usize| {
                    targets
                        .get(i)
                        .and_then(|l| axes.iter().position(|a| a.name == *l))
                        .filter(|&t| t != ax && axes[t].kind == AxisKind::Linear)
                };
                let motor_coulomb_n = look.non_negative(v, "motor_coulomb_n", &axis_key)?;
                PlantModel::ThreeMass(ThreeMassParams {
                    m1_kg: x[0],
                    m2_kg: x[1],
                    m3_kg: x[2],
                    k1_n_per_m: x[3],
                    k2_n_per_m: x[4],
                    d_motor_n_s_per_m: x[5],
                    d_slide_n_s_per_m: x[6],
                    d_structure_n_s_per_m: x[7],
                    d1_n_s_per_m: x[8],
                    d2_n_s_per_m: x[9],
                    motor_coulomb_n,
                    intalk_s2: x[10],
                    crosstalk_s2: [x[11], x[12]],
                    crosstalk_targets: [index(0), index(1)],
                })
            }
        };

        let k = |i: usize| pick(COMMON_KEYS[i]);
        let encoder_step = look.non_negative(v, k(0), &axis_key)?;
        let kv_per_s = look.positive(v, k(1), &axis_key)?;
        let kp = look.positive(v, k(2), &axis_key)?;
        let tn_s = look.positive(v, k(3), &axis_key)?;
        let (current_loop_hz, cl_key) = look.value(v, k(4), &axis_key)?;
        v.in_range(&cl_key, current_loop_hz, 1.0, 1.0e5)?;
        let force_limit = look.positive(v, k(5), &axis_key)?;
        let (vel_ff, vff_key) = look.value(v, k(6), &axis_key)?;
        v.in_range(&vff_key, vel_ff, 0.0, 1.5)?;
        let (acc_ff, aff_key) = look.value(v, k(7), &axis_key)?;
        v.in_range(&aff_key, acc_ff, 0.0, 1.5)?;
        let (vf_hz, vf_key) = look.value(v, k(8), &axis_key)?;
        v.in_range(&vf_key, vf_hz, 0.0, 1.0e5)?;
        let static_force = finite(v, &look, k(9), &axis_key)?;
        let dyn_force = finite(v, &look, k(10), &axis_key)?;
        let dyn_hz = look.non_negative(v, k(11), &axis_key)?;
        if vf_hz > 0.0 && vf_hz * 2.0 > self.servo_rate_hz {
            return Err(v.err(&vf_key, &format!("must be below half the servo rate ({} Hz)", self.servo_rate_hz / 2.0)));
        }
        Ok(ResolvedAxisPlant {
            axis: axis.name,
            kind: axis.kind,
            preset: preset_name,
            model,
            drive: DriveParams {
                encoder_step,
                kv_per_s,
                kp,
                tn_s,
                current_loop_hz,
                force_limit,
                vel_ff,
                acc_ff,
                velocity_filter_hz: (vf_hz > 0.0).then_some(vf_hz),
            },
            process: ProcessParams { static_force, dyn_force, dyn_hz },
        })
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
        let file: PresetFile = toml::from_str(&text).map_err(|e| ConfigError::from_toml(choice, &text, &e))?;
        let allowed = allowed_keys(file.model, file.kind);
        if let Some((key, _)) = file.params.numeric().into_iter().find(|(k, x)| x.is_some() && !allowed.contains(k)) {
            return Err(fv.err(
                &format!("params.{key}"),
                &format!("not a parameter of the {} model on a {} axis", model_word(file.model), kind_word(file.kind)),
            ));
        }
        if file.params.name.is_some() || file.params.preset.is_some() || file.params.crosstalk_targets.is_some() {
            return Err(
                fv.err("params", "a preset file sets model parameters only (no name, preset or crosstalk_targets)")
            );
        }
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

fn finite(v: &Validator, look: &Lookup, key: &str, axis_key: &str) -> Result<f64, ConfigError> {
    let (x, k) = look.value(v, key, axis_key)?;
    if !x.is_finite() {
        return Err(v.err(&k, &format!("must be finite, got {x}")));
    }
    Ok(x)
}

fn kind_word(k: AxisKind) -> &'static str {
    match k {
        AxisKind::Linear => "linear",
        AxisKind::Rotary => "rotary",
    }
}

fn model_word(m: ModelKind) -> &'static str {
    match m {
        ModelKind::TwoMass => "two-mass",
        ModelKind::ThreeMass => "three-mass",
    }
}

/// Keys an override may set for a model on an axis kind.
fn allowed_keys(model: ModelKind, kind: AxisKind) -> Vec<&'static str> {
    let rot = kind == AxisKind::Rotary;
    let pick = |p: &(&'static str, &'static str)| if rot { p.1 } else { p.0 };
    let mut keys: Vec<&'static str> = COMMON_KEYS.iter().map(pick).collect();
    match model {
        ModelKind::TwoMass => keys.extend(TWO_MASS_KEYS.iter().map(pick)),
        ModelKind::ThreeMass => keys.extend(THREE_MASS_KEYS),
    }
    keys
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    fn machine(plant: &str) -> String {
        format!(
            "[machine]\n{plant}\n[[axis]]\nname = \"X\"\nkind = \"linear\"\nmax_vel = 100.0\nmax_acc = 1000.0\n\
             max_jerk = 10000.0\nmin = -10.0\nmax = 10.0\n[[axis]]\nname = \"A\"\nkind = \"rotary\"\n\
             max_vel = 100.0\nmax_acc = 1000.0\nmax_jerk = 10000.0\nmin = -10.0\nmax = 10.0\n"
        )
    }

    fn parse(plant: &str) -> Result<Config, ConfigError> {
        Config::from_toml_str(&machine(plant), "m.toml")
    }

    #[test]
    fn presets_parse_and_resolve() {
        for (name, text) in PRESETS {
            let file: PresetFile = toml::from_str(text).unwrap_or_else(|e| panic!("preset {name}: {e}"));
            assert!(file.params.name.is_none() && file.params.preset.is_none(), "{name}");
            // Every key the preset sets belongs to its model and kind.
            let allowed = allowed_keys(file.model, file.kind);
            for (k, val) in file.params.numeric() {
                assert!(val.is_none() || allowed.contains(&k), "preset {name} sets foreign key {k}");
            }
            let (letter, kind) = match file.kind {
                AxisKind::Linear => ("X", "linear"),
                AxisKind::Rotary => ("A", "rotary"),
            };
            let text = format!(
                "[machine]\n[plant]\npreset = \"{name}\"\nrotary_preset = \"{name}\"\n[[axis]]\nname = \"{letter}\"\n\
                 kind = \"{kind}\"\nmax_vel = 1.0\nmax_acc = 1.0\nmax_jerk = 1.0\nmin = -1.0\nmax = 1.0\n"
            );
            let c = Config::from_toml_str(&text, "m.toml").unwrap_or_else(|e| panic!("preset {name}: {e}"));
            let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
            assert_eq!(r[0].preset, name);
        }
    }

    #[test]
    fn select_takes_a_preset_a_preset_file_or_a_plant_section() {
        let c = parse("").unwrap();
        let same = c.plant.select("", &c.axes, "--plant").unwrap();
        assert_eq!(same, c.plant);
        let soft = c.plant.select("schneider-soft", &c.axes, "--plant").unwrap();
        assert_eq!(soft.resolve(&c.axes, "m").unwrap()[0].preset, "schneider-soft");
        let e = c.plant.select("nope", &c.axes, "--plant").unwrap_err().to_string();
        assert!(e.contains("--plant: nope: neither a plant preset"), "{e}");

        let dir = std::env::temp_dir().join(format!("interpd-config-select-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A preset file: the embedded soft preset with a different load mass.
        let preset_path = dir.join("heavy.toml");
        let text = PRESETS[0].1.replace("load_mass_kg = 381.0", "load_mass_kg = 500.0");
        std::fs::write(&preset_path, text).unwrap();
        let p = preset_path.to_str().unwrap();
        let heavy = c.plant.select(p, &c.axes, "--plant").unwrap();
        let r = heavy.resolve(&c.axes, "m").unwrap();
        let PlantModel::TwoMass(m) = r[0].model else { panic!("two-mass") };
        assert_eq!((r[0].preset.as_str(), m.load_mass), (p, 500.0));
        assert_eq!(r[1].preset, DEFAULT_ROTARY_PRESET, "rotary axes keep theirs");
        // A bad key in a preset file names the file and key.
        std::fs::write(&preset_path, PRESETS[0].1.replace("load_mass_kg", "m1_kg")).unwrap();
        let e = c.plant.select(p, &c.axes, "--plant").unwrap_err().to_string();
        assert!(e.contains("heavy.toml: params.m1_kg: not a parameter of the two-mass model"), "{e}");
        // A file with a [plant] section replaces the section.
        let section = dir.join("plant.toml");
        std::fs::write(&section, "[machine]\n[plant]\npreset = \"schneider-stiff\"\nservo_rate_hz = 20000.0\n")
            .unwrap();
        let s = c.plant.select(section.to_str().unwrap(), &c.axes, "--plant").unwrap();
        assert_eq!((s.preset.as_deref(), s.servo_rate_hz), (Some("schneider-stiff"), 20000.0));
        std::fs::write(&section, "[plant]\nservo_rate_hz = 5.0\n").unwrap();
        let e = c.plant.select(section.to_str().unwrap(), &c.axes, "--plant").unwrap_err().to_string();
        assert!(e.contains("plant.toml: plant.servo_rate_hz"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn defaults_resolve_per_kind() {
        let c = parse("").unwrap();
        let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
        assert_eq!(r[0].preset, DEFAULT_LINEAR_PRESET);
        assert_eq!(r[1].preset, DEFAULT_ROTARY_PRESET);
        assert!(matches!(r[0].model, PlantModel::ThreeMass(_)));
        let PlantModel::TwoMass(j) = r[1].model else { panic!("joint preset is two-mass") };
        assert_eq!(j.stiffness_pos, 1.23e6);
        assert_eq!(j.stiffness_neg, 3.60e6);
        // Crosstalk of X goes to Y and Z, which this machine lacks.
        let PlantModel::ThreeMass(h) = &r[0].model else { unreachable!() };
        assert_eq!(h.crosstalk_targets, [None, None]);
        assert_eq!(c.plant.servo_rate_hz, 10_000.0);
    }

    #[test]
    fn overrides_apply_and_name_their_key() {
        let c = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nbacklash_m = 0.0\nprocess_force_n = 300.0\n")
            .unwrap();
        let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
        let PlantModel::TwoMass(p) = r[0].model else { panic!() };
        assert_eq!(p.backlash, 0.0);
        assert_eq!(p.stiffness_pos, 0.545e6);
        assert_eq!(r[0].process.static_force, 300.0);

        let e = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nstiffness_n_per_m = -1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("plant.axis[0].stiffness_n_per_m"), "{e}");
        let e = parse("[[plant.axis]]\nname = \"A\"\nbacklash_m = 0.001\n").unwrap_err().to_string();
        assert!(e.contains("plant.axis[0].backlash_m: not a parameter of the two-mass model on a rotary axis"), "{e}");
        let e = parse("[[plant.axis]]\nname = \"X\"\nbacklash_m = 0.001\n").unwrap_err().to_string();
        assert!(e.contains("three-mass"), "{e}");
        let e = parse("[[plant.axis]]\nname = \"Y\"\n").unwrap_err().to_string();
        assert!(e.contains("plant.axis[0].name: no axis Y"), "{e}");
        let e = parse("[plant]\npreset = \"nope\"\n").unwrap_err().to_string();
        assert!(e.contains("plant.preset: unknown preset `nope`"), "{e}");
        let e = parse("[plant]\npreset = \"schneider-joint1\"\n").unwrap_err().to_string();
        assert!(e.contains("is for rotary axes but axis X is linear"), "{e}");
        let e = parse("[plant]\nservo_rate_hz = 1000.0\n").unwrap_err().to_string();
        assert!(e.contains("plant.servo_rate_hz"), "{e}");
        let e = parse("[plant]\nspeed = 1\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `speed`"), "{e}");
        let e = parse("[[plant.axis]]\nname = \"X\"\nk2_n_per_m = 2e6\ncrosstalk_targets = [\"X\"]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot cross-talk into itself"), "{e}");
        let e = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nbacklash_blend_m = 0.001\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("plant.axis[0].backlash_blend_m: must not exceed half the backlash"), "{e}");
    }
}
