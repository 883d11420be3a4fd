//! Mechanical axis models: the two-mass axis (fitted to Schneider 2016) and the 3-mass axis
//! (Haas 2012, §5.2).

pub mod backlash;
pub mod friction;
pub mod three_mass;
pub mod two_mass;

use crate::PlantError;
use interpd_config::plant::PlantModel;
pub use three_mass::ThreeMass;
pub use two_mass::TwoMass;

/// The mechanics of one axis, in SI base units (m or rad).
#[derive(Debug, Clone)]
// Both variants hold their discretised matrices inline (about 1 kB): boxing would add a pointer
// chase to every servo step of every axis.
#[allow(clippy::large_enum_variant)]
pub enum Mechanics {
    TwoMass(TwoMass),
    ThreeMass(ThreeMass),
}

impl Mechanics {
    /// Builds the model; `t_i_s` is the current-loop time constant, `h_s` the servo period.
    pub fn new(model: &PlantModel, t_i_s: f64, h_s: f64, substeps: u32) -> Result<Self, PlantError> {
        Ok(match model {
            PlantModel::TwoMass(p) => Mechanics::TwoMass(TwoMass::new(p, t_i_s, h_s, substeps)?),
            PlantModel::ThreeMass(p) => Mechanics::ThreeMass(ThreeMass::new(p, t_i_s, h_s, substeps)?),
        })
    }

    /// One servo step: saturated force command, external force on the load (−F_proc).
    #[inline]
    pub fn step(&mut self, f_cmd: f64, f_load: f64) {
        match self {
            Mechanics::TwoMass(m) => m.step(f_cmd, f_load),
            Mechanics::ThreeMass(m) => m.step(f_cmd, f_load),
        }
    }

    /// At rest at motor position `x_m`, in equilibrium with the process force `f_proc`.
    pub fn set_rest(&mut self, x_m: f64, f_proc: f64) {
        match self {
            Mechanics::TwoMass(m) => m.set_rest(x_m, f_proc),
            Mechanics::ThreeMass(m) => m.set_rest(x_m, f_proc),
        }
    }

    /// Holds the motor at `x_m` (a holding brake): motor position fixed, motor velocity and
    /// motor force zero; the load keeps moving on the transmission.
    #[inline]
    pub fn brake_motor(&mut self, x_m: f64) {
        match self {
            Mechanics::TwoMass(m) => m.brake_motor(x_m),
            Mechanics::ThreeMass(m) => m.brake_motor(x_m),
        }
    }

    /// Sets the motor force state F_M (the current loop's output), e.g. the holding force a
    /// drive builds up before it releases the brake.
    pub fn set_motor_force(&mut self, f_m: f64) {
        match self {
            Mechanics::TwoMass(m) => m.z[4] = f_m,
            Mechanics::ThreeMass(m) => m.z[6] = f_m,
        }
    }

    #[inline]
    pub fn motor_pos(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.motor_pos(),
            Mechanics::ThreeMass(m) => m.motor_pos(),
        }
    }
    #[inline]
    pub fn motor_vel(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.motor_vel(),
            Mechanics::ThreeMass(m) => m.motor_vel(),
        }
    }
    /// Load point: the load mass (two-mass) or the structure/TCP mass x₃ (3-mass).
    #[inline]
    pub fn load_pos(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.load_pos(),
            Mechanics::ThreeMass(m) => m.load_pos(),
        }
    }
    #[inline]
    pub fn load_vel(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.load_vel(),
            Mechanics::ThreeMass(m) => m.load_vel(),
        }
    }
    /// Motor force F_M after the current loop.
    #[inline]
    pub fn motor_force(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.motor_force(),
            Mechanics::ThreeMass(m) => m.motor_force(),
        }
    }
    /// Force in the (first) transmission spring.
    #[inline]
    pub fn spring_force(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.spring_force(),
            Mechanics::ThreeMass(m) => m.spring_force(),
        }
    }
    /// Backlash flanks in contact (always true for the 3-mass model).
    #[inline]
    pub fn contact(&self) -> bool {
        match self {
            Mechanics::TwoMass(m) => m.contact(),
            Mechanics::ThreeMass(_) => true,
        }
    }
    /// Crosstalk outputs (3-mass only), m.
    #[inline]
    pub fn crosstalk(&self) -> [f64; 2] {
        match self {
            Mechanics::TwoMass(_) => [0.0; 2],
            Mechanics::ThreeMass(m) => m.crosstalk(),
        }
    }
    /// Total moved mass (for acceleration feedforward).
    pub fn total_mass(&self) -> f64 {
        match self {
            Mechanics::TwoMass(m) => m.total_mass(),
            Mechanics::ThreeMass(m) => m.total_mass(),
        }
    }
}
