//! Test moves and the acceptance scenarios of `tests/acceptance.rs`: T1 static compliance, T2
//! backlash reversal, T3 residual vibration, and the positioning move of Haas 2012, §5.2,
//! Fig. 5.6. The moves are computed here, independent of the daemon's planner.

use crate::PlantError;
use crate::metrics;
use crate::plant::{AxisTarget, Plant};
use interpd_config::plant::{PlantConfig, PlantModel, ResolvedAxisPlant};
use interpd_config::{AxisConfig, AxisKind, AxisLetter};
use interpd_otg::{Input, Limits, Otg, Profile, State, Trajectory};

/// A 7-phase jerk-limited point-to-point move (constant-jerk pieces) from `start` by
/// `distance`, rest to rest: the time-optimal profile of the trajectory generator
/// (interpd-otg, position interface, one degree of freedom).
#[derive(Debug, Clone)]
pub struct SCurve {
    start: f64,
    sign: f64,
    /// The move over |distance| from 0.
    profile: Profile,
}

impl SCurve {
    /// Time-optimal under |v| ≤ `v_max`, |a| ≤ `a_max`, |j| ≤ `j_max` (all > 0 and finite;
    /// panics otherwise).
    pub fn new(start: f64, distance: f64, v_max: f64, a_max: f64, j_max: f64) -> Self {
        let mut input = Input::new(1);
        input.target[0] = State { p: distance.abs(), v: 0.0, a: 0.0 };
        input.limits[0] = Limits::symmetric(v_max, a_max, j_max);
        let mut trajectory = Trajectory::default();
        if let Err(e) = Otg::new().calculate(&input, &mut trajectory) {
            panic!("S-curve over {distance} under v {v_max}, a {a_max}, j {j_max}: {e}");
        }
        Self { start, sign: distance.signum(), profile: trajectory.profiles()[0] }
    }

    pub fn duration_s(&self) -> f64 {
        self.profile.duration()
    }

    /// (position, velocity, acceleration) at time `t_s` (held before 0 and after the end).
    pub fn eval(&self, t_s: f64) -> (f64, f64, f64) {
        let (pos, vel, acc, _) = self.profile.state_at(t_s.max(0.0).min(self.duration_s()));
        (self.start + self.sign * pos, self.sign * vel, self.sign * acc)
    }
}

/// A single-axis plant for `preset` with `edit` applied to the resolved parameters.
pub fn single_axis(
    preset: &str,
    kind: AxisKind,
    edit: impl FnOnce(&mut ResolvedAxisPlant),
) -> Result<Plant, PlantError> {
    let name = if kind == AxisKind::Rotary { AxisLetter::A } else { AxisLetter::X };
    let axes = [AxisConfig {
        name,
        kind,
        max_vel_per_s: 1e3,
        max_acc_per_s2: 1e4,
        max_jerk_per_s3: 1e6,
        min_pos: -1e4,
        max_pos: 1e4,
    }];
    let cfg = PlantConfig {
        preset: (kind == AxisKind::Linear).then(|| preset.to_string()),
        rotary_preset: (kind == AxisKind::Rotary).then(|| preset.to_string()),
        ..PlantConfig::default()
    };
    let mut r = cfg.resolve(&axes, "<scenario>")?;
    edit(&mut r[0]);
    Plant::new(&r, &cfg)
}

/// A recorded single-axis run at the setpoint rate.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    pub t_s: Vec<f64>,
    pub setpoint: Vec<f64>,
    pub motor: Vec<f64>,
    pub load: Vec<f64>,
    pub following_error: Vec<f64>,
    pub load_error: Vec<f64>,
    pub motor_force: Vec<f64>,
    pub crosstalk: Vec<[f64; 2]>,
}

/// Feeds `profile(t) → (p, v, a)` to axis 0 of `plant` as setpoints every `cycle_s` for
/// `duration_s` and records axis 0.
pub fn run_profile(
    plant: &mut Plant,
    cycle_s: f64,
    duration_s: f64,
    mut profile: impl FnMut(f64) -> (f64, f64, f64),
) -> Result<Trace, PlantError> {
    let n = (duration_s / cycle_s).round() as usize;
    let mut tr = Trace::default();
    let t0_ns = plant.time_ns();
    let first = !plant.started();
    for k in 0..=n {
        let t = k as f64 * cycle_s;
        let (p, v, a) = profile(t);
        let targets = [AxisTarget { pos: p, vel: v, acc: a }];
        let t_ns = t0_ns + (t * 1e9).round() as u64;
        let o = if k == 0 && first { plant.reset(t_ns, &[p])?[0] } else { plant.advance_to(t_ns, &targets)?[0] };
        tr.t_s.push(t);
        tr.setpoint.push(o.setpoint);
        tr.motor.push(o.motor_pos);
        tr.load.push(o.load_pos);
        tr.following_error.push(o.following_error);
        tr.load_error.push(o.load_error);
        tr.motor_force.push(o.motor_force);
        tr.crosstalk.push(o.crosstalk);
    }
    Ok(tr)
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// T1 result: static deflection under a process force.
#[derive(Debug, Clone, Copy)]
pub struct Compliance {
    pub force: f64,
    /// Load displacement from 0 to `force` with the backlash removed, axis unit.
    pub deflection: f64,
    /// With the preset's backlash: twist beyond the flank, (x_M − x_L) − b/2, axis unit.
    pub elastic_twist_with_backlash: f64,
    /// With backlash: load displacement from 0 to `force` (includes b/2), axis unit.
    pub displacement_with_backlash: f64,
    /// Expected F/k, axis unit.
    pub expected: f64,
}

/// T1: the axis holds position 0; `force` (N or N·m, positive pulls the load negative) is
/// applied as a step and the load settles for 6 s. Returns magnitudes.
pub fn static_compliance(preset: &str, kind: AxisKind, force: f64) -> Result<Compliance, PlantError> {
    let measure = |backlash: bool| -> Result<(f64, f64, f64, f64), PlantError> {
        let mut plant = single_axis(preset, kind, |r| {
            if let PlantModel::TwoMass(p) = &mut r.model {
                if !backlash {
                    p.backlash = 0.0;
                    p.backlash_blend = 0.0;
                }
            }
        })?;
        let scale = plant.axes()[0].scale();
        let (half_gap, k) = match &plant.axes()[0].mechanics() {
            crate::model::Mechanics::TwoMass(m) => {
                let p = m.params();
                (p.backlash / 2.0 / scale, if force >= 0.0 { p.stiffness_pos } else { p.stiffness_neg })
            }
            crate::model::Mechanics::ThreeMass(m) => {
                let p = m.params();
                (0.0, 1.0 / (1.0 / p.k1_n_per_m + 1.0 / p.k2_n_per_m))
            }
        };
        let before = run_profile(&mut plant, 0.004, 1.0, |_| (0.0, 0.0, 0.0))?;
        let l0 = mean(&before.load[before.load.len() - 50..]);
        plant.set_process_force(0, Some(force));
        let after = run_profile(&mut plant, 0.004, 6.0, |_| (0.0, 0.0, 0.0))?;
        let tail = after.load.len() - 250;
        let l1 = mean(&after.load[tail..]);
        let m1 = mean(&after.motor[tail..]);
        Ok((l0 - l1, (m1 - l1).abs() - half_gap, force / k / scale, m1))
    };
    let (deflection, _, expected, _) = measure(false)?;
    let (displacement, twist, _, _) = measure(true)?;
    Ok(Compliance {
        force,
        deflection: deflection.abs(),
        elastic_twist_with_backlash: twist,
        displacement_with_backlash: displacement.abs(),
        expected: expected.abs(),
    })
}

/// T2 result: lost motion at a reversal.
#[derive(Debug, Clone, Copy)]
pub struct Reversal {
    /// Load error difference between the constant-velocity parts of the forward and the
    /// backward move: the load's lost motion, axis unit.
    pub lost_motion: f64,
    /// The same difference of the motor-side following error, axis unit.
    pub following_error_shift: f64,
    /// Largest |following error| over the whole test, axis unit.
    pub max_following_error: f64,
    /// Encoder quantum, axis unit.
    pub encoder_step: f64,
    /// Configured backlash, axis unit.
    pub backlash: f64,
}

/// Load-side Coulomb friction (N) the backlash-reversal test adds: a load that floats without
/// any friction coasts through the gap and rattles, and lost motion is not defined. 0.25 N
/// makes the load stand still while the motor crosses the gap and adds only 2·F/k (0.9 µm on
/// the soft preset) of elastic wind-up.
pub const REVERSAL_LOAD_FRICTION_N: f64 = 0.25;

/// T2 (ISO 230-2 style reversal): forward 1 mm, dwell 1 s, back 1 mm at 0.1 mm/s with
/// 0.4 mm/s² (slower than the load friction can decelerate the load, so the load never runs
/// ahead into the gap). Lost motion = difference of the mean load error between the last 40 %
/// of the two cruise phases; the same for the motor-side following error.
pub fn backlash_reversal(preset: &str) -> Result<Reversal, PlantError> {
    let mut plant = single_axis(preset, AxisKind::Linear, |r| {
        if let PlantModel::TwoMass(p) = &mut r.model {
            p.load_coulomb = p.load_coulomb.max(REVERSAL_LOAD_FRICTION_N);
        }
    })?;
    let scale = plant.axes()[0].scale();
    let q = plant.axes()[0].drive().params().encoder_step / scale;
    let b = match plant.axes()[0].mechanics() {
        crate::model::Mechanics::TwoMass(m) => m.params().backlash / scale,
        crate::model::Mechanics::ThreeMass(_) => 0.0,
    };
    let (dist, v, a, j) = (1.0, 0.1, 0.4, 1.6);
    let fwd = SCurve::new(0.0, dist, v, a, j);
    let back = SCurve::new(dist, -dist, v, a, j);
    let (pre, t1, dwell) = (0.5, fwd.duration_s(), 1.0);
    let t_back = pre + t1 + dwell;
    let total = t_back + back.duration_s() + 0.5;
    let tr = run_profile(&mut plant, 0.004, total, |t| {
        if t < pre {
            (0.0, 0.0, 0.0)
        } else if t < t_back {
            fwd.eval(t - pre)
        } else {
            back.eval(t - t_back)
        }
    })?;
    // Cruise phase of a move: where its velocity is ±v with zero acceleration.
    let window = |t_start: f64, mv: &SCurve| {
        let idx: Vec<usize> = (0..tr.t_s.len())
            .filter(|&i| {
                let t = tr.t_s[i] - t_start;
                let (_, vv, aa) = mv.eval(t);
                t > 0.0 && t < mv.duration_s() && (vv.abs() - v).abs() < 1e-9 && aa == 0.0
            })
            .collect();
        let (lo, hi) = (idx.first().copied().unwrap_or(0), idx.last().copied().unwrap_or(0));
        (hi - (hi - lo) * 2 / 5, hi)
    };
    let (a0, a1) = window(pre, &fwd);
    let (b0, b1) = window(t_back, &back);
    let lost = mean(&tr.load_error[a0..a1]) - mean(&tr.load_error[b0..b1]);
    let fe = mean(&tr.following_error[a0..a1]) - mean(&tr.following_error[b0..b1]);
    let max_fe = tr.following_error.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    Ok(Reversal {
        lost_motion: lost,
        following_error_shift: fe,
        max_following_error: max_fe,
        encoder_step: q,
        backlash: b,
    })
}

/// T3 result: residual vibration after a jerk-limited move.
#[derive(Debug, Clone, Copy)]
pub struct Modal {
    /// Peak of the load-error spectrum after the move, Hz; `None` when the load does not ring
    /// (with the backlash open and no preload it drifts inside the gap and stops).
    pub peak_hz: Option<f64>,
    /// Locked-motor antiresonance √(k/m_L)/2π of the preset, Hz.
    pub expected_hz: f64,
    /// Largest |detrended load error| after the move, axis unit.
    pub residual_amplitude: f64,
}

/// T3: a 100 mm jerk-limited move (v 100 mm/s) whose acceleration deflects the spring by
/// about 0.05 mm (a = 0.05 mm · ω_a²) and whose jerk phase lasts 0.3/f_a (a strong, not
/// cancelling excitation), then 4 s of standstill; FFT of the detrended load error after the
/// move. `preload` is a static process force that keeps the backlash closed (the thesis robot
/// is preloaded by gravity); `backlash` false removes the backlash instead.
pub fn modal_check(preset: &str, preload: f64, backlash: bool) -> Result<Modal, PlantError> {
    let mut plant = single_axis(preset, AxisKind::Linear, |r| {
        r.process.static_force = preload;
        if let PlantModel::TwoMass(p) = &mut r.model {
            if !backlash {
                p.backlash = 0.0;
                p.backlash_blend = 0.0;
            }
        }
    })?;
    let expected_hz = match plant.axes()[0].mechanics() {
        crate::model::Mechanics::TwoMass(m) => {
            let p = m.params();
            (p.stiffness_pos / p.load_mass).sqrt() / (2.0 * std::f64::consts::PI)
        }
        crate::model::Mechanics::ThreeMass(_) => {
            return Err(PlantError::Input("the modal check is defined for the two-mass presets".into()));
        }
    };
    let w = 2.0 * std::f64::consts::PI * expected_hz;
    let acc = 0.05 * w * w;
    let jerk = acc * expected_hz / 0.3;
    let mv = SCurve::new(0.0, 100.0, 100.0, acc, jerk);
    let pre = 0.5;
    let tr = run_profile(&mut plant, 0.004, pre + mv.duration_s() + 4.0, |t| mv.eval(t - pre))?;
    let end = tr.t_s.iter().position(|&t| t >= pre + mv.duration_s()).unwrap_or(0);
    let tail = &tr.load_error[end..];
    let d = metrics::detrend(tail);
    let residual_amplitude = d.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let spec = metrics::spectrum(&d, 0.004);
    let peak_hz = metrics::peak_frequency(&spec, 1.0, 100.0);
    Ok(Modal { peak_hz, expected_hz, residual_amplitude })
}

/// Result of the Haas 0 → 100 mm positioning move (Haas 2012, §5.2, Fig. 5.6).
#[derive(Debug, Clone, Copy)]
pub struct Positioning {
    /// Largest |crosstalk_y| during the move and after, mm.
    pub max_crosstalk_mm: f64,
    /// Crosstalk_y / acceleration in the middle of the constant-acceleration phase, m per m/s².
    pub crosstalk_per_acc: f64,
    /// Largest |following error|, mm.
    pub max_following_error_mm: f64,
    /// Largest |load (TCP) error|, mm.
    pub max_load_error_mm: f64,
    /// |load error| 0.2 s after the move, mm.
    pub settled_error_mm: f64,
}

/// The Haas positioning move 0 → 100 mm with the default machine's X limits (250 mm/s,
/// 2500 mm/s², 50000 mm/s³), `k2` overriding k₂ (N/m).
pub fn haas_positioning(k2: f64) -> Result<(Positioning, Trace), PlantError> {
    let mut plant = single_axis("haas-laser", AxisKind::Linear, |r| {
        if let PlantModel::ThreeMass(p) = &mut r.model {
            p.k2_n_per_m = k2;
        }
    })?;
    let mv = SCurve::new(0.0, 100.0, 250.0, 2500.0, 50000.0);
    let pre = 0.1;
    let tr = run_profile(&mut plant, 0.004, pre + mv.duration_s() + 0.3, |t| mv.eval(t - pre))?;
    let max_ct = tr.crosstalk.iter().fold(0.0_f64, |m, c| m.max(c[0].abs()));
    // Constant-acceleration phase: phase 2 of the S-curve, from t_j to t_j + t_a.
    let tj = 2500.0 / 50000.0;
    let ta = 250.0 / 2500.0 - tj;
    let t_mid = pre + tj + ta / 2.0;
    let i_mid = tr.t_s.iter().position(|&t| t >= t_mid).unwrap_or(0);
    let ratio = tr.crosstalk[i_mid][0] * 1e-3 / 2.5; // mm → m, per 2.5 m/s²
    let max_fe = tr.following_error.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let max_le = tr.load_error.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let i_set = tr.t_s.iter().position(|&t| t >= pre + mv.duration_s() + 0.2).unwrap_or(tr.t_s.len() - 1);
    Ok((
        Positioning {
            max_crosstalk_mm: max_ct,
            crosstalk_per_acc: ratio,
            max_following_error_mm: max_fe,
            max_load_error_mm: max_le,
            settled_error_mm: tr.load_error[i_set].abs(),
        },
        tr,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn s_curve_respects_limits_and_reaches_the_end() {
        for (d, v, a, j) in
            [(100.0, 200.0, 2000.0, 40000.0), (0.5, 200.0, 2000.0, 40000.0), (-3.0, 10.0, 200.0, 4000.0)]
        {
            let s = SCurve::new(1.0, d, v, a, j);
            let (p, vv, aa) = s.eval(s.duration_s());
            assert!((p - (1.0 + d)).abs() < 1e-9, "end {p}");
            assert!(vv.abs() < 1e-9 && aa.abs() < 1e-9);
            let n = 2000;
            let mut prev = s.eval(0.0);
            for i in 1..=n {
                let t = s.duration_s() * i as f64 / n as f64;
                let x = s.eval(t);
                assert!(x.1.abs() <= v * (1.0 + 1e-9) && x.2.abs() <= a * (1.0 + 1e-9));
                // Continuity of position and velocity.
                let dt = s.duration_s() / n as f64;
                assert!((x.0 - prev.0).abs() <= v * dt * 1.0001);
                prev = x;
            }
        }
    }
}
