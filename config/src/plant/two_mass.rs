//! The two-mass axis: motor, elastic transmission with backlash and direction-dependent
//! stiffness, load; referred to the load side. Schneider 2016 measures a robot joint's
//! stiffness and backlash (Fig. 3.6) and the arm's eigenfrequencies (Tab. 3.1) without a
//! two-mass model; the `schneider-*` presets fit this model to those measurements.
//!
//! The same model has two sets of keys: masses, N/m and m on a linear axis
//! ([`LinearTwoMass`]), inertias, N·m/rad and rad on a rotary one ([`RotaryTwoMass`]).

use super::table::Check;
use crate::ConfigError;
use serde::Deserialize;

/// The two-mass parameters of a linear axis.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct LinearTwoMass {
    /// Motor-side mass m_M, kg.
    pub motor_mass_kg: f64,
    /// Load mass m_L, kg.
    pub load_mass_kg: f64,
    /// Transmission stiffness k₊ for positive spring force, N/m.
    pub stiffness_n_per_m: f64,
    /// Transmission stiffness k₋ for negative spring force, N/m (default k₊).
    #[serde(default)]
    pub stiffness_neg_n_per_m: Option<f64>,
    /// Transmission damping c_s, N·s/m (acts while the flanks are in contact).
    pub damping_n_s_per_m: f64,
    /// Motor viscous friction c_M, N·s/m.
    pub motor_viscous_n_s_per_m: f64,
    /// Load viscous friction c_L, N·s/m.
    pub load_viscous_n_s_per_m: f64,
    /// Motor Coulomb friction, N (default 0).
    #[serde(default)]
    pub motor_coulomb_n: f64,
    /// Load Coulomb friction, N (default 0).
    #[serde(default)]
    pub load_coulomb_n: f64,
    /// Total backlash width b, m (default 0).
    #[serde(default)]
    pub backlash_m: f64,
    /// Half-width of the C¹ blend at each backlash flank, m (≤ b/2; default 0).
    #[serde(default)]
    pub backlash_blend_m: f64,
}

/// The two-mass parameters of a rotary axis: [`LinearTwoMass`] with J, θ and τ.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RotaryTwoMass {
    /// Motor inertia, kg·m².
    pub motor_inertia_kg_m2: f64,
    /// Load inertia, kg·m².
    pub load_inertia_kg_m2: f64,
    /// Stiffness for positive torque, N·m/rad.
    pub stiffness_nm_per_rad: f64,
    /// Stiffness for negative torque, N·m/rad (default the positive one).
    #[serde(default)]
    pub stiffness_neg_nm_per_rad: Option<f64>,
    /// Transmission damping, N·m·s/rad.
    pub damping_nm_s_per_rad: f64,
    /// Motor viscous friction, N·m·s/rad.
    pub motor_viscous_nm_s_per_rad: f64,
    /// Load viscous friction, N·m·s/rad.
    pub load_viscous_nm_s_per_rad: f64,
    /// Motor Coulomb friction, N·m (default 0).
    #[serde(default)]
    pub motor_coulomb_nm: f64,
    /// Load Coulomb friction, N·m (default 0).
    #[serde(default)]
    pub load_coulomb_nm: f64,
    /// Total backlash width, rad (default 0).
    #[serde(default)]
    pub backlash_rad: f64,
    /// Half-width of the C¹ blend at each flank, rad (≤ half the backlash; default 0).
    #[serde(default)]
    pub backlash_blend_rad: f64,
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

impl LinearTwoMass {
    pub(crate) fn resolve(&self, c: &Check) -> Result<TwoMassParams, ConfigError> {
        let motor_mass = c.positive("motor_mass_kg", self.motor_mass_kg)?;
        let load_mass = c.positive("load_mass_kg", self.load_mass_kg)?;
        let stiffness_pos = c.positive("stiffness_n_per_m", self.stiffness_n_per_m)?;
        let stiffness_neg = stiffness_neg(c, "stiffness_neg_n_per_m", self.stiffness_neg_n_per_m, stiffness_pos)?;
        let damping = c.non_negative("damping_n_s_per_m", self.damping_n_s_per_m)?;
        let motor_viscous = c.non_negative("motor_viscous_n_s_per_m", self.motor_viscous_n_s_per_m)?;
        let load_viscous = c.non_negative("load_viscous_n_s_per_m", self.load_viscous_n_s_per_m)?;
        let motor_coulomb = c.non_negative("motor_coulomb_n", self.motor_coulomb_n)?;
        let load_coulomb = c.non_negative("load_coulomb_n", self.load_coulomb_n)?;
        let backlash = c.non_negative("backlash_m", self.backlash_m)?;
        let backlash_blend = backlash_blend(c, "backlash_blend_m", self.backlash_blend_m, backlash)?;
        Ok(TwoMassParams {
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
            backlash_blend,
        })
    }
}

impl RotaryTwoMass {
    pub(crate) fn resolve(&self, c: &Check) -> Result<TwoMassParams, ConfigError> {
        let motor_mass = c.positive("motor_inertia_kg_m2", self.motor_inertia_kg_m2)?;
        let load_mass = c.positive("load_inertia_kg_m2", self.load_inertia_kg_m2)?;
        let stiffness_pos = c.positive("stiffness_nm_per_rad", self.stiffness_nm_per_rad)?;
        let stiffness_neg = stiffness_neg(c, "stiffness_neg_nm_per_rad", self.stiffness_neg_nm_per_rad, stiffness_pos)?;
        let damping = c.non_negative("damping_nm_s_per_rad", self.damping_nm_s_per_rad)?;
        let motor_viscous = c.non_negative("motor_viscous_nm_s_per_rad", self.motor_viscous_nm_s_per_rad)?;
        let load_viscous = c.non_negative("load_viscous_nm_s_per_rad", self.load_viscous_nm_s_per_rad)?;
        let motor_coulomb = c.non_negative("motor_coulomb_nm", self.motor_coulomb_nm)?;
        let load_coulomb = c.non_negative("load_coulomb_nm", self.load_coulomb_nm)?;
        let backlash = c.non_negative("backlash_rad", self.backlash_rad)?;
        let backlash_blend = backlash_blend(c, "backlash_blend_rad", self.backlash_blend_rad, backlash)?;
        Ok(TwoMassParams {
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
            backlash_blend,
        })
    }
}

/// k₋, which is k₊ unless given.
fn stiffness_neg(c: &Check, key: &str, neg: Option<f64>, pos: f64) -> Result<f64, ConfigError> {
    neg.map_or(Ok(pos), |x| c.positive(key, x))
}

/// The flank blend fits inside the gap: a preset's blend shrinks to half an overridden smaller
/// backlash, while a blend the override sets itself must fit.
fn backlash_blend(c: &Check, key: &str, blend: f64, backlash: f64) -> Result<f64, ConfigError> {
    c.non_negative(key, blend)?;
    let half = backlash / 2.0;
    if blend <= half {
        Ok(blend)
    } else if c.overridden(key) {
        Err(c.err(key, &format!("must not exceed half the backlash ({half}), got {blend}")))
    } else {
        Ok(half)
    }
}
