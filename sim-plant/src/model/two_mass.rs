//! The load-referred two-mass axis: motor, elastic transmission with direction-dependent
//! stiffness and backlash, load; the drive's current loop as a PT1 state. Schneider 2016
//! measures such a transmission (stiffness and backlash of a robot joint, §3.2, Fig. 3.6)
//! without a two-mass model; the `schneider-*` presets fit this one to its measurements.
//!
//! State z = [x_M, v_M, x_L, v_L, F_M], inputs u = [F_cmd (saturated), f_M, f_L]:
//! ```text
//! m_M dv_M/dt = F_M − F_S − c_M v_M + f_M         (f_M: Coulomb friction, spring residual)
//! m_L dv_L/dt = F_S − c_L v_L + f_L               (f_L = −F_proc + spring residual + load Coulomb)
//! dF_M/dt     = (sat(F_cmd) − F_M)/T_i            (current loop as a PT1)
//! F_S         = k± δ_e(δ) + c_s δ_e′(δ) (v_M − v_L),  δ = x_M − x_L
//! ```
//! Integration: the spring is linear in each of three regimes (gap open; contact on the
//! positive flank with k₊; contact on the negative flank with k₋). Each regime has its exact
//! discretisation Φ, Γ (see [`crate::discretize`]); per step the regime nearest to the current
//! twist is chosen (contact when δ_e′ ≥ ½) and the difference between the true spring force
//! and the regime's linear spring — the constant flank offset k± b/2, plus the small blend
//! correction while crossing a flank — is applied as a force held over the step. Outside the
//! blends this is exact; inside, the explicit part is at most half the stiffness for the few
//! steps a crossing lasts, which the energy and step-halving tests bound. Coulomb friction is
//! solved implicitly per step ([`super::friction`]).

use super::backlash::{DeadZone, Transmission};
use super::friction::coulomb_force;
use crate::PlantError;
use crate::discretize::{Discrete, discretize};
use interpd_config::plant::TwoMassParams;
use nalgebra::{SMatrix, SVector};

const FREE: usize = 0;
const POS: usize = 1;
const NEG: usize = 2;

/// The two-mass mechanics with the current-loop state.
#[derive(Debug, Clone)]
pub struct TwoMass {
    p: TwoMassParams,
    tr: Transmission,
    /// Discretisations for the gap-open, positive-contact and negative-contact regimes.
    modes: [Discrete<5, 3>; 3],
    substeps: u32,
    /// [x_M, v_M, x_L, v_L, F_M] in SI (m or rad).
    pub z: SVector<f64, 5>,
    spring_force: f64,
    contact: bool,
}

impl TwoMass {
    /// Mechanics with servo period `h_s` split into `substeps` integration steps; `t_i_s` is the
    /// current-loop time constant.
    pub fn new(p: &TwoMassParams, t_i_s: f64, h_s: f64, substeps: u32) -> Result<Self, PlantError> {
        let tr = Transmission {
            zone: DeadZone::new(p.backlash, p.backlash_blend),
            k_pos: p.stiffness_pos,
            k_neg: p.stiffness_neg,
            damping: p.damping,
        };
        let hs = h_s / f64::from(substeps.max(1));
        let b = input_matrix(p, t_i_s);
        let modes = [
            discretize(&system_matrix(p, 0.0, 0.0, t_i_s), &b, hs)?,
            discretize(&system_matrix(p, p.stiffness_pos, p.damping, t_i_s), &b, hs)?,
            discretize(&system_matrix(p, p.stiffness_neg, p.damping, t_i_s), &b, hs)?,
        ];
        Ok(Self { p: *p, tr, modes, substeps: substeps.max(1), z: SVector::zeros(), spring_force: 0.0, contact: false })
    }

    /// At rest at motor position `x_m` in static equilibrium with the load force `f_load`
    /// (positive pulls the load towards negative positions, like the process force).
    pub fn set_rest(&mut self, x_m: f64, f_proc: f64) {
        let delta = self.twist_for_force(f_proc);
        self.z = SVector::from([x_m, 0.0, x_m - delta, 0.0, f_proc]);
        self.spring_force = f_proc;
        self.contact = f_proc != 0.0 || self.tr.zone.half_gap() == 0.0;
    }

    /// Motor clamped at `x_m` by its brake: x_M fixed, v_M = 0, F_M = 0 (power stage off).
    #[inline]
    pub fn brake_motor(&mut self, x_m: f64) {
        self.z[0] = x_m;
        self.z[1] = 0.0;
        self.z[4] = 0.0;
    }

    /// The twist δ at which the spring carries `force` statically (inverse of k± δ_e).
    pub fn twist_for_force(&self, force: f64) -> f64 {
        if force == 0.0 {
            return 0.0;
        }
        let k = if force > 0.0 { self.p.stiffness_pos } else { self.p.stiffness_neg };
        let de = (force / k).abs();
        let w = self.p.backlash_blend.min(self.tr.zone.half_gap());
        let hg = self.tr.zone.half_gap();
        let x = if de >= w { de + hg } else { hg - w + (4.0 * w * de).sqrt() };
        x.copysign(force)
    }

    /// One servo step with the motor force command `f_cmd` (already saturated) and external
    /// load force `f_load` (−F_proc) held over the step.
    #[inline]
    pub fn step(&mut self, f_cmd: f64, f_load: f64) {
        for _ in 0..self.substeps {
            self.substep(f_cmd, f_load);
        }
    }

    #[inline]
    fn substep(&mut self, f_cmd: f64, f_load: f64) {
        let z = &self.z;
        let delta = z[0] - z[2];
        let delta_dot = z[1] - z[3];
        let (f_true, slope) = self.tr.force(delta, delta_dot);
        let mode = if slope >= 0.5 { if delta > 0.0 { POS } else { NEG } } else { FREE };
        let f_lin = match mode {
            POS => self.p.stiffness_pos * delta + self.p.damping * delta_dot,
            NEG => self.p.stiffness_neg * delta + self.p.damping * delta_dot,
            _ => 0.0,
        };
        // The spring force the regime's matrix does not carry (flank offset, blend).
        let r = f_true - f_lin;
        let d = &self.modes[mode];
        let u = SVector::<f64, 3>::new(f_cmd, -r, r + f_load);
        let mut next = d.phi * z + d.gamma * u;
        // Coulomb friction, motor then load (implicit stick/slip per step).
        let f_m = coulomb_force(next[1], d.gamma[(1, 1)], self.p.motor_coulomb);
        if f_m != 0.0 {
            next += d.gamma.column(1) * f_m;
        }
        let f_l = coulomb_force(next[3], d.gamma[(3, 2)], self.p.load_coulomb);
        if f_l != 0.0 {
            next += d.gamma.column(2) * f_l;
        }
        self.z = next;
        let (fs, slope) = self.tr.force(next[0] - next[2], next[1] - next[3]);
        self.spring_force = fs;
        self.contact = slope > 0.0;
    }

    pub fn motor_pos(&self) -> f64 {
        self.z[0]
    }
    pub fn motor_vel(&self) -> f64 {
        self.z[1]
    }
    pub fn load_pos(&self) -> f64 {
        self.z[2]
    }
    pub fn load_vel(&self) -> f64 {
        self.z[3]
    }
    pub fn motor_force(&self) -> f64 {
        self.z[4]
    }
    pub fn spring_force(&self) -> f64 {
        self.spring_force
    }
    /// The flanks touch (δ_e′ > 0).
    pub fn contact(&self) -> bool {
        self.contact
    }
    /// m_M + m_L.
    pub fn total_mass(&self) -> f64 {
        self.p.motor_mass + self.p.load_mass
    }
    pub fn params(&self) -> &TwoMassParams {
        &self.p
    }

    /// Kinetic plus elastic energy (J), for the energy test.
    pub fn energy(&self) -> f64 {
        let z = &self.z;
        0.5 * self.p.motor_mass * z[1] * z[1] + 0.5 * self.p.load_mass * z[3] * z[3] + self.tr.energy(z[0] - z[2])
    }

    /// The continuous system matrix with the spring engaged on the positive flank (for the
    /// stability analysis; the gap and negative flank differ only in k).
    pub fn continuous(&self, t_i_s: f64, k: f64) -> (SMatrix<f64, 5, 5>, SMatrix<f64, 5, 3>) {
        (system_matrix(&self.p, k, self.p.damping, t_i_s), input_matrix(&self.p, t_i_s))
    }
}

/// A of the regime with spring stiffness `k` and damping `c`, plus the PT1 row of the current
/// loop.
#[rustfmt::skip]
fn system_matrix(p: &TwoMassParams, k: f64, c: f64, t_i_s: f64) -> SMatrix<f64, 5, 5> {
    let (mm, ml) = (p.motor_mass, p.load_mass);
    SMatrix::<f64, 5, 5>::from_row_slice(&[
        0.0,     1.0,                          0.0,     0.0,                          0.0,
        -k / mm, -(c + p.motor_viscous) / mm,  k / mm,  c / mm,                       1.0 / mm,
        0.0,     0.0,                          0.0,     1.0,                          0.0,
        k / ml,  c / ml,                       -k / ml, -(c + p.load_viscous) / ml,   0.0,
        0.0,     0.0,                          0.0,     0.0,                          -1.0 / t_i_s,
    ])
}

/// B for u = [F_cmd, f_M, f_L].
fn input_matrix(p: &TwoMassParams, t_i_s: f64) -> SMatrix<f64, 5, 3> {
    let mut b = SMatrix::<f64, 5, 3>::zeros();
    b[(4, 0)] = 1.0 / t_i_s;
    b[(1, 1)] = 1.0 / p.motor_mass;
    b[(3, 2)] = 1.0 / p.load_mass;
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Soft preset mechanics without damping or friction: a conservative system.
    fn lossless() -> TwoMassParams {
        TwoMassParams {
            motor_mass: 190.0,
            load_mass: 381.0,
            stiffness_pos: 0.545e6,
            stiffness_neg: 1.58e6,
            damping: 0.0,
            motor_viscous: 0.0,
            load_viscous: 0.0,
            motor_coulomb: 0.0,
            load_coulomb: 0.0,
            backlash: 0.228e-3,
            backlash_blend: 2.0e-6,
        }
    }

    /// Free oscillation through the gap, flank to flank, for 2 s from `v0` m/s on the load.
    fn rattle(substeps: u32) -> (TwoMass, f64) {
        let mut m = TwoMass::new(&lossless(), 1e-4, 1e-4, substeps).unwrap();
        m.z = SVector::from([0.0, 0.0, 0.0, 0.01, 0.0]);
        let e0 = m.energy();
        for _ in 0..20_000 {
            m.step(0.0, 0.0);
        }
        (m, e0)
    }

    #[test]
    fn energy_is_conserved_through_repeated_flank_impacts() {
        let (m, e0) = rattle(1);
        let e1 = m.energy();
        // 10 mm/s crosses the 0.228 mm gap in 23 ms: about 80 impacts on both flanks in 2 s.
        assert!((e1 - e0).abs() < 1e-3 * e0, "energy {e0} → {e1}");
    }

    #[test]
    fn halving_the_step_changes_the_trajectory_little() {
        let (a, _) = rattle(1);
        let (b, _) = rattle(2);
        // Positions after 2 s of impacts agree to a small fraction of the gap.
        let d = (a.load_pos() - b.load_pos()).abs().max((a.motor_pos() - b.motor_pos()).abs());
        assert!(d < 0.01 * 0.228e-3, "10 kHz vs 20 kHz differ by {d} m");
    }

    #[test]
    fn static_twist_matches_the_asymmetric_spring() {
        let m = TwoMass::new(&lossless(), 1e-4, 1e-4, 1).unwrap();
        // δ = F/k± + b/2 outside the blend.
        assert!((m.twist_for_force(300.0) - (300.0 / 0.545e6 + 0.114e-3)).abs() < 1e-15);
        assert!((m.twist_for_force(-300.0) + (300.0 / 1.58e6 + 0.114e-3)).abs() < 1e-15);
        assert_eq!(m.twist_for_force(0.0), 0.0);
    }
}
