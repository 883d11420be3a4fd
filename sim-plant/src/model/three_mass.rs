//! The 3-mass axis of Haas 2012, §5.2: motor m₁, slide m₂, structure/TCP m₃. Haas 2012,
//! eq. 5.11 prints the restoring forces with a positive sign, which makes the axis unstable; the
//! equations below restore the signs of a spring–damper chain.
//!
//! State z = [x₁, x₂, x₃, v₁, v₂, v₃, F_M], inputs u = [F_cmd (saturated), f₁, f₃]:
//! ```text
//! m₁ẍ₁ = F_M − k₁(x₁−x₂) − d₁(ẋ₁−ẋ₂) − d_M ẋ₁ + f₁                      (Haas 2012, eq. 5.11, signs restored)
//! m₂ẍ₂ = k₁(x₁−x₂) − k₂(x₂−x₃) + d₁(ẋ₁−ẋ₂) − d₂(ẋ₂−ẋ₃) − d_Sch ẋ₂       (Haas 2012, eq. 5.11, signs restored)
//! m₃ẍ₃ = k₂(x₂−x₃) + d₂(ẋ₂−ẋ₃) − d_S ẋ₃ + f₃                            (Haas 2012, eq. 5.11, signs restored)
//! dF_M/dt = (sat(F_cmd) − F_M)/T_el                                        (Haas 2012, Table 5.2, power module)
//! Crosstalk_{y,z} = (C_T{y,z}/I_T)(x₃ − x₂)                                (Haas 2012, eq. 5.13, output rows 5–6)
//! ```
//! The model is linear: one exact discretisation. f₁ carries motor Coulomb friction (0 in
//! Table 5.1), f₃ the process force on the TCP (0 for laser cutting).

use super::friction::coulomb_force;
use crate::PlantError;
use crate::discretize::{Discrete, discretize};
use interpd_config::plant::ThreeMassParams;
use nalgebra::{SMatrix, SVector};

/// The three-mass mechanics with the power-module state.
#[derive(Debug, Clone)]
pub struct ThreeMass {
    p: ThreeMassParams,
    d: Discrete<7, 3>,
    substeps: u32,
    /// [x₁, x₂, x₃, v₁, v₂, v₃, F_M] in SI.
    pub z: SVector<f64, 7>,
}

impl ThreeMass {
    pub fn new(p: &ThreeMassParams, t_el_s: f64, h_s: f64, substeps: u32) -> Result<Self, PlantError> {
        let (a, b) = continuous(p, t_el_s);
        let d = discretize(&a, &b, h_s / f64::from(substeps.max(1)))?;
        Ok(Self { p: p.clone(), d, substeps: substeps.max(1), z: SVector::zeros() })
    }

    /// At rest with the motor at `x_m`, in static equilibrium with the TCP force F_proc.
    pub fn set_rest(&mut self, x_m: f64, f_proc: f64) {
        let x2 = x_m - f_proc / self.p.k1_n_per_m;
        let x3 = x2 - f_proc / self.p.k2_n_per_m;
        self.z = SVector::from([x_m, x2, x3, 0.0, 0.0, 0.0, f_proc]);
    }

    #[inline]
    pub fn step(&mut self, f_cmd: f64, f_load: f64) {
        for _ in 0..self.substeps {
            let u = SVector::<f64, 3>::new(f_cmd, 0.0, f_load);
            let mut next = self.d.phi * self.z + self.d.gamma * u;
            let f_m = coulomb_force(next[3], self.d.gamma[(3, 1)], self.p.motor_coulomb_n);
            if f_m != 0.0 {
                next += self.d.gamma.column(1) * f_m;
            }
            self.z = next;
        }
    }

    /// Motor clamped at `x_m` by its brake: x₁ fixed, v₁ = 0, F_M = 0 (power stage off).
    #[inline]
    pub fn brake_motor(&mut self, x_m: f64) {
        self.z[0] = x_m;
        self.z[3] = 0.0;
        self.z[6] = 0.0;
    }

    pub fn motor_pos(&self) -> f64 {
        self.z[0]
    }
    pub fn motor_vel(&self) -> f64 {
        self.z[3]
    }
    /// Slide position x₂.
    pub fn slide_pos(&self) -> f64 {
        self.z[1]
    }
    /// Structure/TCP position x₃ (the load point of this axis).
    pub fn load_pos(&self) -> f64 {
        self.z[2]
    }
    pub fn load_vel(&self) -> f64 {
        self.z[5]
    }
    pub fn motor_force(&self) -> f64 {
        self.z[6]
    }
    /// Force in the motor–slide spring k₁(x₁−x₂) + d₁(ẋ₁−ẋ₂).
    pub fn spring_force(&self) -> f64 {
        self.p.k1_n_per_m * (self.z[0] - self.z[1]) + self.p.d1_n_s_per_m * (self.z[3] - self.z[4])
    }
    /// The two crosstalk outputs (C_T/I_T)(x₃ − x₂), m (Haas 2012, eq. 5.13).
    pub fn crosstalk(&self) -> [f64; 2] {
        let rel = self.z[2] - self.z[1];
        [self.p.crosstalk_s2[0] / self.p.intalk_s2 * rel, self.p.crosstalk_s2[1] / self.p.intalk_s2 * rel]
    }
    pub fn total_mass(&self) -> f64 {
        self.p.m1_kg + self.p.m2_kg + self.p.m3_kg
    }
    pub fn params(&self) -> &ThreeMassParams {
        &self.p
    }
}

/// A (7×7, with the power-module row) and B for u = [F_cmd, f₁, f₃].
/// Haas 2012, eq. 5.12 prints A as diag(m₁, m₂, m₃); the state matrix of eq. 5.11 is
/// A = [[0, I], [−M⁻¹K, −M⁻¹D]].
pub fn continuous(p: &ThreeMassParams, t_el_s: f64) -> (SMatrix<f64, 7, 7>, SMatrix<f64, 7, 3>) {
    let (m1, m2, m3) = (p.m1_kg, p.m2_kg, p.m3_kg);
    let (k1, k2) = (p.k1_n_per_m, p.k2_n_per_m);
    let (d1, d2) = (p.d1_n_s_per_m, p.d2_n_s_per_m);
    let (dm, dsch, ds) = (p.d_motor_n_s_per_m, p.d_slide_n_s_per_m, p.d_structure_n_s_per_m);
    let mut a = SMatrix::<f64, 7, 7>::zeros();
    a[(0, 3)] = 1.0;
    a[(1, 4)] = 1.0;
    a[(2, 5)] = 1.0;
    // m₁ row
    a[(3, 0)] = -k1 / m1;
    a[(3, 1)] = k1 / m1;
    a[(3, 3)] = -(d1 + dm) / m1;
    a[(3, 4)] = d1 / m1;
    a[(3, 6)] = 1.0 / m1;
    // m₂ row
    a[(4, 0)] = k1 / m2;
    a[(4, 1)] = -(k1 + k2) / m2;
    a[(4, 2)] = k2 / m2;
    a[(4, 3)] = d1 / m2;
    a[(4, 4)] = -(d1 + d2 + dsch) / m2;
    a[(4, 5)] = d2 / m2;
    // m₃ row
    a[(5, 1)] = k2 / m3;
    a[(5, 2)] = -k2 / m3;
    a[(5, 4)] = d2 / m3;
    a[(5, 5)] = -(d2 + ds) / m3;
    // power module
    a[(6, 6)] = -1.0 / t_el_s;
    let mut b = SMatrix::<f64, 7, 3>::zeros();
    b[(6, 0)] = 1.0 / t_el_s;
    b[(3, 1)] = 1.0 / m1;
    b[(5, 2)] = 1.0 / m3;
    (a, b)
}
