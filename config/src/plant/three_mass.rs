//! The three-mass axis of Haas 2012, §5.2: motor m₁, slide m₂ and structure/TCP m₃ in a chain
//! of springs and dampers, with two crosstalk outputs into other axes (eq. 5.13); parameter
//! names and values as in Table 5.1. Linear axes only.

use super::table::Check;
use crate::{AxisConfig, AxisKind, AxisLetter, ConfigError, Validator};
use serde::Deserialize;

/// The three-mass parameters (Haas 2012, Table 5.1).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ThreeMass {
    /// Motor mass m₁, kg.
    pub m1_kg: f64,
    /// Slide mass m₂, kg.
    pub m2_kg: f64,
    /// Structure (TCP) mass m₃, kg.
    pub m3_kg: f64,
    /// Stiffness motor–slide k₁, N/m.
    pub k1_n_per_m: f64,
    /// Stiffness slide–structure k₂, N/m.
    pub k2_n_per_m: f64,
    /// Motor friction d_M, N·s/m.
    pub d_motor_n_s_per_m: f64,
    /// Slide friction d_Sch, N·s/m.
    pub d_slide_n_s_per_m: f64,
    /// Structure friction d_S, N·s/m.
    pub d_structure_n_s_per_m: f64,
    /// Damping motor–slide d₁, N·s/m.
    pub d1_n_s_per_m: f64,
    /// Damping slide–structure d₂, N·s/m.
    pub d2_n_s_per_m: f64,
    /// Intalk parameter I_T, s².
    pub intalk_s2: f64,
    /// Crosstalk parameter C_Ty (first target axis), s².
    pub crosstalk_y_s2: f64,
    /// Crosstalk parameter C_Tz (second target axis), s².
    pub crosstalk_z_s2: f64,
    /// Motor Coulomb friction, N (default 0; Table 5.1 has viscous friction only).
    #[serde(default)]
    pub motor_coulomb_n: f64,
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

impl ThreeMass {
    /// The parameters with the crosstalk going to the axes at `crosstalk_targets`.
    pub(crate) fn resolve(
        &self,
        c: &Check,
        crosstalk_targets: [Option<usize>; 2],
    ) -> Result<ThreeMassParams, ConfigError> {
        Ok(ThreeMassParams {
            m1_kg: c.positive("m1_kg", self.m1_kg)?,
            m2_kg: c.positive("m2_kg", self.m2_kg)?,
            m3_kg: c.positive("m3_kg", self.m3_kg)?,
            k1_n_per_m: c.positive("k1_n_per_m", self.k1_n_per_m)?,
            k2_n_per_m: c.positive("k2_n_per_m", self.k2_n_per_m)?,
            d_motor_n_s_per_m: c.non_negative("d_motor_n_s_per_m", self.d_motor_n_s_per_m)?,
            d_slide_n_s_per_m: c.non_negative("d_slide_n_s_per_m", self.d_slide_n_s_per_m)?,
            d_structure_n_s_per_m: c.non_negative("d_structure_n_s_per_m", self.d_structure_n_s_per_m)?,
            d1_n_s_per_m: c.non_negative("d1_n_s_per_m", self.d1_n_s_per_m)?,
            d2_n_s_per_m: c.non_negative("d2_n_s_per_m", self.d2_n_s_per_m)?,
            intalk_s2: c.positive("intalk_s2", self.intalk_s2)?,
            crosstalk_s2: [
                c.non_negative("crosstalk_y_s2", self.crosstalk_y_s2)?,
                c.non_negative("crosstalk_z_s2", self.crosstalk_z_s2)?,
            ],
            motor_coulomb_n: c.non_negative("motor_coulomb_n", self.motor_coulomb_n)?,
            crosstalk_targets,
        })
    }
}

/// The indices of the axes receiving the crosstalk of axis `ax`: an override's
/// `crosstalk_targets` (with the key that sets it) or by default the other two of X, Y, Z in
/// that order, which receive nothing where the machine lacks them. Rotary axes receive nothing.
pub(crate) fn crosstalk_targets(
    v: &Validator,
    targets: Option<(String, &[AxisLetter])>,
    axes: &[AxisConfig],
    ax: usize,
) -> Result<[Option<usize>; 2], ConfigError> {
    let name = axes[ax].name;
    let targets: Vec<AxisLetter> = match targets {
        Some((key, t)) => {
            let key = key.as_str();
            if t.len() > 2 {
                return Err(v.err(key, &format!("at most 2 target axes, got {}", t.len())));
            }
            if t.contains(&name) {
                return Err(v.err(key, &format!("axis {name} cannot cross-talk into itself")));
            }
            if let Some(l) = t.iter().find(|l| !axes.iter().any(|a| a.name == **l)) {
                return Err(v.err(key, &format!("no axis {l} in this machine")));
            }
            t.to_vec()
        }
        None => [AxisLetter::X, AxisLetter::Y, AxisLetter::Z].into_iter().filter(|l| *l != name).take(2).collect(),
    };
    let index = |i: usize| {
        targets
            .get(i)
            .and_then(|l| axes.iter().position(|a| a.name == *l))
            .filter(|&t| t != ax && axes[t].kind == AxisKind::Linear)
    };
    Ok([index(0), index(1)])
}
