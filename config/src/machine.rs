use crate::{ConfigError, Validator};
use serde::Deserialize;
use std::fmt;

/// Most axes a machine may have: one per G-code axis letter X Y Z A B C U V W.
pub const MAX_AXES: usize = 9;

/// `[machine]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MachineSection {
    /// Interpolation cycle in milliseconds.
    #[serde(default = "default_cycle_ms")]
    pub cycle_ms: f64,
    /// Free text shown in status output.
    #[serde(default)]
    pub name: Option<String>,
}

fn default_cycle_ms() -> f64 {
    4.0
}

impl MachineSection {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.in_range("machine.cycle_ms", self.cycle_ms, 0.05, 100.0)
    }
}

/// A G-code axis letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, PartialOrd, Ord)]
pub enum AxisLetter {
    X,
    Y,
    Z,
    A,
    B,
    C,
    U,
    V,
    W,
}

impl AxisLetter {
    pub const ALL: [AxisLetter; MAX_AXES] = [
        AxisLetter::X,
        AxisLetter::Y,
        AxisLetter::Z,
        AxisLetter::A,
        AxisLetter::B,
        AxisLetter::C,
        AxisLetter::U,
        AxisLetter::V,
        AxisLetter::W,
    ];

    /// The letter for an upper-case character, if it names an axis.
    pub fn from_char(c: char) -> Option<Self> {
        Self::ALL.iter().copied().find(|l| l.as_char() == c)
    }

    pub fn as_char(self) -> char {
        match self {
            AxisLetter::X => 'X',
            AxisLetter::Y => 'Y',
            AxisLetter::Z => 'Z',
            AxisLetter::A => 'A',
            AxisLetter::B => 'B',
            AxisLetter::C => 'C',
            AxisLetter::U => 'U',
            AxisLetter::V => 'V',
            AxisLetter::W => 'W',
        }
    }
}

impl fmt::Display for AxisLetter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.as_char())
    }
}

/// Linear axes move in mm, rotary axes in degrees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisKind {
    Linear,
    Rotary,
}

impl AxisKind {
    /// Unit of position for messages: "mm" or "deg".
    pub fn unit(self) -> &'static str {
        match self {
            AxisKind::Linear => "mm",
            AxisKind::Rotary => "deg",
        }
    }
}

/// One `[[axis]]` table. Positions are in the axis unit (mm or deg), limits per second.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    pub name: AxisLetter,
    pub kind: AxisKind,
    /// Velocity limit, axis unit per s.
    #[serde(rename = "max_vel")]
    pub max_vel_per_s: f64,
    /// Acceleration limit (symmetric), axis unit per s².
    #[serde(rename = "max_acc")]
    pub max_acc_per_s2: f64,
    /// Jerk limit (symmetric), axis unit per s³.
    #[serde(rename = "max_jerk")]
    pub max_jerk_per_s3: f64,
    /// Lower travel limit, axis unit.
    #[serde(rename = "min")]
    pub min_pos: f64,
    /// Upper travel limit, axis unit.
    #[serde(rename = "max")]
    pub max_pos: f64,
}

impl AxisConfig {
    pub(crate) fn validate(&self, v: &Validator, i: usize) -> Result<(), ConfigError> {
        let key = |k: &str| format!("axis[{i}].{k} ({})", self.name);
        v.positive(&key("max_vel"), self.max_vel_per_s)?;
        v.positive(&key("max_acc"), self.max_acc_per_s2)?;
        v.positive(&key("max_jerk"), self.max_jerk_per_s3)?;
        if !self.min_pos.is_finite() {
            return Err(v.err(&key("min"), &format!("must be finite, got {}", self.min_pos)));
        }
        if !self.max_pos.is_finite() {
            return Err(v.err(&key("max"), &format!("must be finite, got {}", self.max_pos)));
        }
        if self.min_pos >= self.max_pos {
            return Err(v.err(&key("min"), &format!("min ({}) must be less than max ({})", self.min_pos, self.max_pos)));
        }
        Ok(())
    }
}
