//! Linear analysis: open-loop modes of the mechanics and closed-loop eigenvalues of an axis
//! with its cascade controller, continuous (ideal analog controller) and discrete (the actual
//! sampled implementation, obtained by probing the step function).

use crate::PlantError;
use crate::axis::Axis;
use crate::model::{Mechanics, three_mass, two_mass::TwoMass};
use interpd_config::plant::{FineInterpolation, PlantModel, ResolvedAxisPlant};
use nalgebra::{Complex, DMatrix};

/// A vibration mode: damped natural frequency and damping ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Undamped natural frequency |λ|/2π, Hz.
    pub natural_hz: f64,
    /// Damped frequency Im λ/2π, Hz.
    pub damped_hz: f64,
    /// Damping ratio −Re λ/|λ|.
    pub damping: f64,
}

fn modes_of(eig: &[Complex<f64>]) -> Vec<Mode> {
    let mut modes: Vec<Mode> = eig
        .iter()
        .filter(|l| l.im > 1e-6)
        .map(|l| {
            let w = l.norm();
            Mode {
                natural_hz: w / (2.0 * std::f64::consts::PI),
                damped_hz: l.im / (2.0 * std::f64::consts::PI),
                damping: -l.re / w,
            }
        })
        .collect();
    modes.sort_by(|a, b| a.natural_hz.total_cmp(&b.natural_hz));
    modes
}

fn eigenvalues(m: DMatrix<f64>) -> Vec<Complex<f64>> {
    m.complex_eigenvalues().iter().copied().collect()
}

/// Open-loop modes of the mechanics alone (motor force input open, no controller). For the
/// two-mass model the spring is engaged with k₊ (backlash closed).
pub fn open_loop_modes(model: &PlantModel) -> Result<Vec<Mode>, PlantError> {
    match model {
        PlantModel::ThreeMass(p) => {
            let (a, _) = three_mass::continuous(p, 1e-4);
            // The mechanical 6×6 block (without the power-module state).
            let m = DMatrix::from_fn(6, 6, |i, j| a[(i, j)]);
            Ok(modes_of(&eigenvalues(m)))
        }
        PlantModel::TwoMass(p) => {
            let tm = TwoMass::new(p, 1e-4, 1e-4, 1)?;
            let (a, _) = tm.continuous(1e-4, p.stiffness_pos);
            let m = DMatrix::from_fn(4, 4, |i, j| a[(i, j)]);
            Ok(modes_of(&eigenvalues(m)))
        }
    }
}

/// Eigenvalues of the continuous closed loop: mechanics with current-loop PT1, velocity PI
/// on the exact motor velocity, P position loop on the exact motor position (feedforward does
/// not change stability). Backlash closed (k₊), no friction, no saturation.
pub fn closed_loop_continuous(r: &ResolvedAxisPlant) -> Result<Vec<Complex<f64>>, PlantError> {
    let d = &r.drive;
    let t_i = 1.0 / (2.0 * std::f64::consts::PI * d.current_loop_hz);
    // (A, b_F, motor-position index, motor-velocity index)
    let (a, b, ix, iv): (DMatrix<f64>, Vec<f64>, usize, usize) = match &r.model {
        PlantModel::TwoMass(p) => {
            let tm = TwoMass::new(p, t_i, 1e-4, 1)?;
            let (a, b) = tm.continuous(t_i, p.stiffness_pos);
            (DMatrix::from_fn(5, 5, |i, j| a[(i, j)]), (0..5).map(|i| b[(i, 0)]).collect(), 0, 1)
        }
        PlantModel::ThreeMass(p) => {
            let (a, b) = three_mass::continuous(p, t_i);
            (DMatrix::from_fn(7, 7, |i, j| a[(i, j)]), (0..7).map(|i| b[(i, 0)]).collect(), 0, 3)
        }
    };
    let n = a.nrows();
    // Augment with the integrator state I (F_cmd = Kp (e_v + I), dI/dt = e_v/Tn,
    // e_v = −Kv x_M − v_M for a zero setpoint).
    let mut m = DMatrix::<f64>::zeros(n + 1, n + 1);
    m.view_mut((0, 0), (n, n)).copy_from(&a);
    for (i, bi) in b.iter().enumerate() {
        if *bi != 0.0 {
            m[(i, ix)] += bi * d.kp * (-d.kv_per_s);
            m[(i, iv)] -= bi * d.kp;
            m[(i, n)] += bi * d.kp;
        }
    }
    m[(n, ix)] = -d.kv_per_s / d.tn_s;
    m[(n, iv)] = -1.0 / d.tn_s;
    Ok(eigenvalues(m))
}

/// Eigenvalues of the sampled closed loop as implemented (servo period `h_s`): the axis step
/// is linear without encoder quantisation, saturation, friction and backlash, so its matrix
/// follows column by column from unit states.
pub fn closed_loop_discrete(r: &ResolvedAxisPlant, h_s: f64) -> Result<Vec<Complex<f64>>, PlantError> {
    let mut lin = r.clone();
    lin.drive.encoder_step = 0.0;
    lin.drive.force_limit = f64::MAX;
    lin.process = Default::default();
    match &mut lin.model {
        PlantModel::TwoMass(p) => {
            p.motor_coulomb = 0.0;
            p.load_coulomb = 0.0;
            p.backlash = 0.0;
            p.backlash_blend = 0.0;
            p.stiffness_neg = p.stiffness_pos;
        }
        PlantModel::ThreeMass(p) => p.motor_coulomb_n = 0.0,
    }
    let mut axis = Axis::new(&lin, h_s, 1, FineInterpolation::Quintic)?;
    axis.reset(0.0, 0.0);
    let n_mech = mech_state(axis.mechanics()).len();
    let n = n_mech + 3;
    let mut m = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        let mut x = vec![0.0; n];
        x[j] = 1.0;
        set_mech_state(axis.mechanics_mut(), &x[..n_mech]);
        axis.drive_mut().set_state([x[n_mech], x[n_mech + 1], x[n_mech + 2]]);
        axis.step(0.0, 0.0);
        let mut y = mech_state(axis.mechanics());
        y.extend_from_slice(&axis.drive().state());
        for i in 0..n {
            m[(i, j)] = y[i];
        }
    }
    Ok(eigenvalues(m))
}

/// Largest |λ| of a discrete spectrum (stable when < 1).
pub fn spectral_radius(eig: &[Complex<f64>]) -> f64 {
    eig.iter().map(|l| l.norm()).fold(0.0, f64::max)
}

/// Largest real part of a continuous spectrum (stable when < 0).
pub fn max_real_part(eig: &[Complex<f64>]) -> f64 {
    eig.iter().map(|l| l.re).fold(f64::NEG_INFINITY, f64::max)
}

/// Closed-loop modes from a continuous spectrum.
pub fn modes(eig: &[Complex<f64>]) -> Vec<Mode> {
    modes_of(eig)
}

fn mech_state(m: &Mechanics) -> Vec<f64> {
    match m {
        Mechanics::TwoMass(t) => t.z.iter().copied().collect(),
        Mechanics::ThreeMass(t) => t.z.iter().copied().collect(),
    }
}

fn set_mech_state(m: &mut Mechanics, x: &[f64]) {
    match m {
        Mechanics::TwoMass(t) => t.z.copy_from_slice(x),
        Mechanics::ThreeMass(t) => t.z.copy_from_slice(x),
    }
}
