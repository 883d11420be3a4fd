//! The compensation stage: per axis a correction added to the setpoint after the fine
//! interpolation, from the measurements a plant publishes (`[compensation]`, after Schneider
//! 2016):
//!
//! - `deflection`: the force signal, filtered well below the axis modes, through the stiffness
//!   model of eq. 4.1 ([`deflection`]); the setpoint moves against the predicted displacement.
//! - `position`: end-effector position control on the external measurement, δx = x_r − x_m
//!   (eq. 4.3) with x_r the setpoint at the measured instant (the measurement's age is taken
//!   into account), a PI (eq. 4.8/4.9, no D term: the measurement is noisy) behind a
//!   first-order bandwidth limit.
//! - `position+actuator`: mid-ranging (§2.4, §4.3.3): the error goes to the fast actuator
//!   through a PI (C_s); the axis integrates the actuator's distance from mid-stroke (and
//!   optionally the error, C_l), so it takes over the slow part and keeps the actuator centred.
//!
//! Every correction passes [`limiter`]: the stream sent to the drives keeps every axis's
//! velocity, acceleration and jerk limit (the planner plans with the rest) and the travel range.
//! A measurement older than `max_age_ms` fades the correction out over `fade_s` (a smoothstep,
//! the limiter after it) and freezes the integrators; an invalid one (wrong version or axis
//! count, NaN, farther from the setpoint than `absurd_position_mm`, a force above
//! `absurd_force_n`) is discarded and counted. The stage runs in the real-time cycle: it does
//! not allocate, lock or block.

// Per-axis loops index several fixed arrays of the payloads at once.
#![allow(clippy::needless_range_loop)]

pub mod deflection;
pub mod io;
pub mod limiter;

use deflection::Deflection;
use interpd_config::Config;
use interpd_config::compensation::{CompensationConfig, Strategy};
use interpd_protocol::MAX_AXES;
use interpd_protocol::shm::{ActuatorCommand, Measurement, PAYLOAD_VERSION, Setpoints, measurement_flags};
use limiter::{Bounds, Limiter};

/// Setpoints kept to look up the reference at a measured instant: 128 cycles (512 ms at 4 ms),
/// far beyond any accepted measurement age.
const HISTORY: usize = 128;

/// What happened to the measurements, for `status` and the tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CompStats {
    /// Samples used.
    pub accepted: u64,
    /// Discarded: wrong version or axis count, or a NaN / infinite value.
    pub discarded_invalid: u64,
    /// Discarded: a position far from the setpoint or an absurd force.
    pub discarded_absurd: u64,
    /// Times the measurement went stale (each raises a `measurement_lost` event).
    pub lost: u64,
    /// Times it came back (`measurement_restored`).
    pub restored: u64,
    /// Limiter steps in which a hard clamp acted.
    pub limiter_clamps: u64,
}

/// A change the service reports as an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CompEvent {
    /// No valid measurement for longer than the allowed age: corrections fade out.
    Lost { age_ms: f64 },
    /// Measurements arrive again: corrections fade back in.
    Restored,
}

#[derive(Debug, Clone, Copy, Default)]
struct AxisState {
    strategy: Strategy,
    model: Option<Deflection>,
    kp: f64,
    ki: f64,
    bandwidth_hz: f64,
    akp: f64,
    aki: f64,
    mid_rate: f64,
    mid_ki: f64,
    stroke: f64,
    bounds: Option<Bounds>,
    travel: (f64, f64),
    /// Filtered force, N.
    force: f64,
    force_init: bool,
    /// Latest position error x_r − x_m, axis unit, and whether it is new this cycle.
    err: f64,
    err_sum: f64,
    err_n: u32,
    actuator_meas: f64,
    integral: f64,
    filtered: f64,
    act_integral: f64,
    act_cmd: f64,
    mid: f64,
    lim: Limiter,
}

/// The stage for all axes.
#[derive(Debug, Clone)]
pub struct Compensation {
    n: usize,
    cfg: CompensationConfig,
    axes: [AxisState; MAX_AXES],
    hist_t: [u64; HISTORY],
    hist_p: [[f64; MAX_AXES]; HISTORY],
    hist_len: usize,
    hist_head: usize,
    last_measured_ns: Option<u64>,
    last_seq: Option<u64>,
    stale: bool,
    /// Fade weight 0..1 (before the smoothstep).
    weight: f64,
    stats: CompStats,
    actuator: ActuatorCommand,
}

/// Corrections and the share of each limit they may use, for a configuration with an active
/// `[compensation]`; the axis limits the planner must plan with are (1 − share) of these.
pub fn planner_limit_factor(config: &Config) -> f64 {
    match &config.compensation {
        Some(c) if c.active() => 1.0 - c.limit_share,
        _ => 1.0,
    }
}

impl Compensation {
    /// The stage for `config`, `None` without an active `[compensation]`.
    pub fn new(config: &Config) -> Option<Self> {
        let cfg = config.compensation.as_ref().filter(|c| c.active())?.clone();
        let n = config.axes.len();
        let mut axes = [AxisState::default(); MAX_AXES];
        for (i, ax) in config.axes.iter().enumerate() {
            let s = &mut axes[i];
            s.travel = (ax.min_pos, ax.max_pos);
            let Some(a) = cfg.of(ax.name) else { continue };
            s.strategy = a.strategy;
            s.model = (a.strategy == Strategy::Deflection).then(|| Deflection::new(a));
            s.kp = a.kp;
            s.ki = a.ki_per_s;
            s.bandwidth_hz = a.bandwidth_hz;
            s.akp = a.actuator_kp;
            s.aki = a.actuator_ki_per_s;
            s.mid_rate = a.midrange_per_s;
            s.mid_ki = a.midrange_ki_per_s;
            s.stroke = a.actuator_stroke_mm;
            s.bounds = Some(Bounds {
                vel: cfg.limit_share * ax.max_vel_per_s,
                acc: cfg.limit_share * ax.max_acc_per_s2,
                jerk: cfg.limit_share * ax.max_jerk_per_s3,
                max: cfg.max_correction_mm,
            });
        }
        Some(Self {
            n,
            cfg,
            axes,
            hist_t: [0; HISTORY],
            hist_p: [[0.0; MAX_AXES]; HISTORY],
            hist_len: 0,
            hist_head: 0,
            last_measured_ns: None,
            last_seq: None,
            stale: true,
            weight: 0.0,
            stats: CompStats::default(),
            actuator: ActuatorCommand { n_axes: n as u32, ..ActuatorCommand::default() },
        })
    }

    pub fn stats(&self) -> &CompStats {
        &self.stats
    }

    /// Whether the stage commands fast actuators.
    pub fn uses_actuator(&self) -> bool {
        self.cfg.uses_actuator()
    }

    /// The correction now applied to axis `i`, axis unit.
    pub fn correction(&self, i: usize) -> f64 {
        self.axes.get(i).map_or(0.0, |a| a.lim.pos)
    }

    /// The fade weight now applied (0: faded out, 1: full).
    pub fn weight(&self) -> f64 {
        smoothstep(self.weight)
    }

    /// The reference (setpoint before correction) of every axis at `t_ns`, interpolated in the
    /// history; `None` outside it.
    fn reference_at(&self, t_ns: u64, out: &mut [f64; MAX_AXES]) -> bool {
        if self.hist_len == 0 {
            return false;
        }
        let idx = |k: usize| (self.hist_head + HISTORY - 1 - k) % HISTORY;
        // Newest first.
        for k in 0..self.hist_len {
            let j = idx(k);
            if self.hist_t[j] <= t_ns {
                if k == 0 {
                    // Newer than the newest setpoint: take the newest.
                    *out = self.hist_p[j];
                    return true;
                }
                let jn = idx(k - 1);
                let (t0, t1) = (self.hist_t[j], self.hist_t[jn]);
                let u = if t1 > t0 { (t_ns - t0) as f64 / (t1 - t0) as f64 } else { 0.0 };
                for i in 0..self.n {
                    out[i] = self.hist_p[j][i] + u * (self.hist_p[jn][i] - self.hist_p[j][i]);
                }
                return true;
            }
        }
        false
    }

    /// Takes one measurement sample: validated, then folded into the filters.
    fn take(&mut self, m: &Measurement) {
        let n = self.n;
        if m.version != PAYLOAD_VERSION || m.n_axes as usize != n {
            self.stats.discarded_invalid += 1;
            return;
        }
        if self.last_seq.is_some_and(|s| m.seq <= s) || self.last_measured_ns.is_some_and(|t| m.measured_ns < t) {
            // A repeat or out of order: nothing new.
            return;
        }
        let mut reference = [0.0; MAX_AXES];
        let has_ref = self.reference_at(m.measured_ns, &mut reference);
        let has_pos = m.flags & measurement_flags::POSITION != 0;
        let has_force = m.flags & measurement_flags::FORCE != 0;
        let has_act = m.flags & measurement_flags::ACTUATOR != 0;
        for i in 0..n {
            let a = &self.axes[i];
            let (need_pos, need_force, need_act) = match a.strategy {
                Strategy::None => (false, false, false),
                Strategy::Deflection => (false, true, false),
                Strategy::Position => (true, false, false),
                Strategy::PositionActuator => (true, false, true),
            };
            if (need_pos && !has_pos) || (need_force && !has_force) || (need_act && !has_act) {
                self.stats.discarded_invalid += 1;
                return;
            }
            let finite = (!need_pos || m.tool_pos[i].is_finite())
                && (!need_force || m.force_n[i].is_finite())
                && (!need_act || m.actuator_pos[i].is_finite());
            if !finite {
                self.stats.discarded_invalid += 1;
                return;
            }
            let absurd = (need_pos && (!has_ref || (m.tool_pos[i] - reference[i]).abs() > self.cfg.absurd_position_mm))
                || (need_force && m.force_n[i].abs() > self.cfg.absurd_force_n)
                || (need_act && m.actuator_pos[i].abs() > 2.0 * a.stroke);
            if absurd {
                self.stats.discarded_absurd += 1;
                return;
            }
        }
        let dt_s = self.last_measured_ns.map_or(0.0, |t| (m.measured_ns - t) as f64 * 1e-9);
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * self.cfg.force_filter_hz * dt_s).exp();
        for i in 0..n {
            let a = &mut self.axes[i];
            if let Some(model) = a.model {
                if !a.force_init {
                    // The filter starts from "no load", not from one noisy sample.
                    a.force = model.zero_load_n();
                    a.force_init = true;
                }
                a.force += alpha * (m.force_n[i] - a.force);
            }
            if matches!(a.strategy, Strategy::Position | Strategy::PositionActuator) {
                a.err_sum += reference[i] - m.tool_pos[i];
                a.err_n += 1;
                a.actuator_meas = m.actuator_pos[i];
            }
        }
        self.last_seq = Some(m.seq);
        self.last_measured_ns = Some(m.measured_ns);
        self.stats.accepted += 1;
    }

    /// One cycle: takes the measurements that arrived (`incoming` until `None`), updates the
    /// corrections and adds them to `sp` (position, velocity, acceleration). Returns an event
    /// when the measurement went stale or came back. `sp.time_ns` is the cycle's time.
    pub fn apply(
        &mut self,
        sp: &mut Setpoints,
        dt_s: f64,
        mut incoming: impl FnMut() -> Option<Measurement>,
    ) -> Option<CompEvent> {
        let n = self.n;
        // The reference history: the setpoints before correction.
        self.hist_t[self.hist_head] = sp.time_ns;
        self.hist_p[self.hist_head][..n].copy_from_slice(&sp.pos[..n]);
        self.hist_head = (self.hist_head + 1) % HISTORY;
        self.hist_len = (self.hist_len + 1).min(HISTORY);
        while let Some(m) = incoming() {
            self.take(&m);
        }
        let age_ns = self.last_measured_ns.map(|t| sp.time_ns.saturating_sub(t));
        let max_age_ns = (self.cfg.max_age_ms * 1e6) as u64;
        let fresh = age_ns.is_some_and(|a| a <= max_age_ns);
        let mut event = None;
        if fresh && self.stale {
            self.stale = false;
            if self.stats.lost > 0 {
                self.stats.restored += 1;
                event = Some(CompEvent::Restored);
            }
        } else if !fresh && !self.stale {
            self.stale = true;
            self.stats.lost += 1;
            event = Some(CompEvent::Lost { age_ms: age_ns.unwrap_or(0) as f64 * 1e-6 });
        }
        let rate = dt_s / self.cfg.fade_s;
        self.weight = if fresh { (self.weight + rate).min(1.0) } else { (self.weight - rate).max(0.0) };
        let w = smoothstep(self.weight);
        let bw_alpha = |hz: f64| 1.0 - (-2.0 * std::f64::consts::PI * hz * dt_s).exp();
        let max_c = self.cfg.max_correction_mm;
        for i in 0..n {
            let a = &mut self.axes[i];
            let Some(bounds) = a.bounds else { continue };
            let new_err = a.err_n > 0;
            if new_err {
                a.err = a.err_sum / f64::from(a.err_n);
                a.err_sum = 0.0;
                a.err_n = 0;
            }
            let raw = match a.strategy {
                Strategy::None => 0.0,
                Strategy::Deflection => a.model.map_or(0.0, |m| -m.displacement_mm(a.force)),
                Strategy::Position => {
                    if fresh {
                        a.integral = (a.integral + a.ki * a.err * dt_s).clamp(-max_c, max_c);
                    }
                    let u = a.kp * a.err + a.integral;
                    a.filtered += bw_alpha(a.bandwidth_hz) * (u - a.filtered);
                    a.filtered
                }
                Strategy::PositionActuator => {
                    if fresh {
                        // C_s: the fast actuator takes the error (anti-windup at the stroke).
                        a.act_integral = (a.act_integral + a.aki * a.err * dt_s).clamp(-a.stroke, a.stroke);
                        a.act_cmd = (a.akp * a.err + a.act_integral).clamp(-a.stroke, a.stroke);
                        // The axis takes over the actuator's excursion from mid-stroke (and C_l).
                        a.mid = (a.mid + dt_s * (a.mid_rate * a.actuator_meas + a.mid_ki * a.err)).clamp(-max_c, max_c);
                    }
                    a.mid
                }
            };
            let target = if raw.is_finite() { w * raw } else { 0.0 };
            let travel = (a.travel.0 - sp.pos[i], a.travel.1 - sp.pos[i]);
            let clamps = a.lim.clamps;
            a.lim.step(target, travel, &bounds, dt_s);
            self.stats.limiter_clamps += a.lim.clamps - clamps;
            sp.pos[i] += a.lim.pos;
            sp.vel[i] += a.lim.vel;
            sp.acc[i] += a.lim.acc;
            self.actuator.pos[i] = if a.strategy == Strategy::PositionActuator { w * a.act_cmd } else { 0.0 };
        }
        self.actuator.cycle = sp.cycle;
        self.actuator.time_ns = sp.time_ns;
        event
    }

    /// The fast actuators' commands of the last cycle.
    pub fn actuator_command(&self) -> &ActuatorCommand {
        &self.actuator
    }
}

/// 3w² − 2w³: from 0 to 1 with zero slope at both ends.
fn smoothstep(w: f64) -> f64 {
    let w = w.clamp(0.0, 1.0);
    w * w * (3.0 - 2.0 * w)
}

#[cfg(test)]
mod tests;
