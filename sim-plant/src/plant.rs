//! A set of simulated axes stepping from coarse setpoints, as the drives of a machine do.
//!
//! Each coarse setpoint is the target for its time stamp; between two of them every drive
//! interpolates at the servo rate (fine interpolation, see [`crate::drive::Segment`]) and the
//! plant integrates. The state reported for a setpoint is the state at the setpoint's time, so
//! following and load errors compare like with like. The per-step path does not allocate.

use crate::PlantError;
use crate::axis::{Axis, AxisOutput};
use crate::process::actuator::Actuator;
use crate::process::measurement::Sensors;
use crate::process::milling::Milling;
use crate::process::structure::Structure;
use interpd_config::Config;
use interpd_config::plant::{PlantConfig, PlantModel, ResolvedAxisPlant};
use interpd_protocol::MAX_AXES;
use interpd_protocol::shm::{
    ActuatorCommand, Feedback, Measurement, PAYLOAD_VERSION, Setpoints, feedback_flags, measurement_flags,
};
use thiserror::Error;

/// A longer silence than this between two setpoints restarts the plant at the new setpoint
/// instead of simulating the gap.
pub const MAX_GAP_S: f64 = 60.0;

/// The target of one axis for one instant, in the axis unit (mm or deg) and per second.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisTarget {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
}

/// Why a received setpoint payload was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum SetpointError {
    #[error("payload version {got}, expected {expected}")]
    BadVersion { got: u32, expected: u32 },
    #[error("payload has {got} axes, the plant {expected}")]
    AxisCount { got: u32, expected: usize },
    #[error("non-finite value for axis {axis}")]
    NonFinite { axis: usize },
}

/// Counts of what arrived on the setpoint input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputStats {
    /// Payloads received.
    pub received: u64,
    /// Payloads used (one feedback each).
    pub accepted: u64,
    /// Rejected: wrong [`PAYLOAD_VERSION`].
    pub bad_version: u64,
    /// Rejected: axis count differs from the plant's.
    pub bad_axis_count: u64,
    /// Rejected: NaN or infinite position, velocity or acceleration.
    pub non_finite: u64,
    /// Cycles missing between consecutive accepted setpoints (cycle numbers skipped).
    pub missed_cycles: u64,
    /// Setpoints whose time did not advance (duplicate or backwards): applied without motion.
    pub time_anomalies: u64,
    /// Restarts after a silence longer than [`MAX_GAP_S`].
    pub resyncs: u64,
}

impl InputStats {
    /// All rejected payloads.
    pub fn rejected(&self) -> u64 {
        self.bad_version + self.bad_axis_count + self.non_finite
    }
}

/// The simulated axes of one machine.
#[derive(Debug, Clone)]
pub struct Plant {
    axes: Vec<Axis>,
    /// Crosstalk routes (source axis, output slot, target axis).
    routes: Vec<(usize, usize, usize)>,
    apply_crosstalk: bool,
    h_ns: u64,
    h_s: f64,
    /// Time of the current state, ns (a whole number of servo periods after the last reset).
    t_ns: u64,
    /// Time of the last target, ns (the state time is within half a servo period of it).
    t_target_ns: u64,
    /// Time of the first reset (origin of [`Plant::time_s`]), ns.
    origin_ns: u64,
    started: bool,
    /// The last call placed the plant at rest instead of moving it.
    was_reset: bool,
    outputs: Vec<AxisOutput>,
    stats: InputStats,
    last_cycle: Option<u64>,
    /// The milling force of `[plant.milling]`.
    milling: Option<Milling>,
    /// The structure's coupled compliance of `[plant.structure]`.
    structure: Option<Structure>,
    /// The sensors of `[plant.measurement]`.
    sensors: Option<Sensors>,
    /// The fast actuator of each axis (`[plant.actuator]`).
    actuators: Vec<Option<Actuator>>,
    /// Actuator commands for the next segment, axis unit.
    actuator_cmd: [f64; MAX_AXES],
    /// Actuator commands rejected (wrong version or axis count, non-finite values).
    pub actuator_rejected: u64,
}

impl Plant {
    /// The plant for a validated configuration: one axis per `[[axis]]`, models from `[plant]`.
    pub fn from_config(config: &Config) -> Result<Self, PlantError> {
        let resolved = config.plant.resolve(&config.axes, "<config>")?;
        Self::new(&resolved, &config.plant)
    }

    /// The plant for resolved axis parameters and the `[plant]` options.
    pub fn new(axes: &[ResolvedAxisPlant], options: &PlantConfig) -> Result<Self, PlantError> {
        if axes.is_empty() || axes.len() > MAX_AXES {
            return Err(PlantError::Model(format!("need 1..={MAX_AXES} axes, got {}", axes.len())));
        }
        let rate = options.servo_rate_hz;
        if !(rate.is_finite() && (1_000.0..=1_000_000.0).contains(&rate)) {
            return Err(PlantError::Model(format!("servo rate {rate} Hz out of range")));
        }
        let h_ns = (1e9 / rate).round() as u64;
        let h_s = h_ns as f64 * 1e-9;
        let built = axes
            .iter()
            .map(|r| Axis::new(r, h_s, options.substeps, options.fine_interpolation))
            .collect::<Result<Vec<_>, _>>()?;
        let index = |n: interpd_config::AxisLetter| axes.iter().position(|a| a.axis == n);
        let milling = match &options.milling {
            Some(m) => match (index(m.axes[0]), index(m.axes[1])) {
                (Some(a), Some(b)) => Some(Milling::new(m, [a, b])),
                _ => return Err(PlantError::Model("plant.milling.axes: axis not in the machine".into())),
            },
            None => None,
        };
        let structure = match &options.structure {
            Some(c) => match (index(c.axes[0]), index(c.axes[1])) {
                (Some(a), Some(b)) => Some(Structure::new(c, [a, b])),
                _ => return Err(PlantError::Model("plant.structure.axes: axis not in the machine".into())),
            },
            None => None,
        };
        let sensors = options.measurement.as_ref().map(|m| Sensors::new(m, axes.len()));
        let actuators = axes
            .iter()
            .map(|a| options.actuator.as_ref().filter(|c| c.axes.contains(&a.axis)).map(Actuator::new))
            .collect();
        let mut routes = Vec::new();
        for (src, r) in axes.iter().enumerate() {
            if let PlantModel::ThreeMass(p) = &r.model {
                for (slot, t) in p.crosstalk_targets.iter().enumerate() {
                    if let Some(dst) = *t {
                        if dst < axes.len() && dst != src {
                            routes.push((src, slot, dst));
                        }
                    }
                }
            }
        }
        Ok(Self {
            outputs: vec![AxisOutput::default(); built.len()],
            axes: built,
            routes,
            apply_crosstalk: options.apply_crosstalk,
            h_ns,
            h_s,
            t_ns: 0,
            t_target_ns: 0,
            origin_ns: 0,
            started: false,
            was_reset: false,
            stats: InputStats::default(),
            last_cycle: None,
            milling,
            structure,
            sensors,
            actuators,
            actuator_cmd: [0.0; MAX_AXES],
            actuator_rejected: 0,
        })
    }

    pub fn n_axes(&self) -> usize {
        self.axes.len()
    }
    pub fn axes(&self) -> &[Axis] {
        &self.axes
    }
    /// One axis, for analysis or to change its process force.
    pub fn axis_mut(&mut self, i: usize) -> Option<&mut Axis> {
        self.axes.get_mut(i)
    }
    /// Servo period, s.
    pub fn servo_period_s(&self) -> f64 {
        self.h_s
    }
    /// The outputs of the last step (or reset).
    pub fn outputs(&self) -> &[AxisOutput] {
        &self.outputs
    }
    /// Input counters (setpoint payloads).
    pub fn stats(&self) -> &InputStats {
        &self.stats
    }
    /// Whether the plant has been placed at a first setpoint.
    pub fn started(&self) -> bool {
        self.started
    }
    /// Time of the current state, ns (the time base of the setpoints).
    pub fn time_ns(&self) -> u64 {
        self.t_ns
    }
    /// Seconds since the first setpoint.
    pub fn time_s(&self) -> f64 {
        self.t_ns.saturating_sub(self.origin_ns) as f64 * 1e-9
    }

    /// Sets the static process force of axis `i` (N or N·m); `None` restores the configured one.
    pub fn set_process_force(&mut self, i: usize, force: Option<f64>) {
        if let Some(a) = self.axes.get_mut(i) {
            a.set_process_force(force);
        }
    }

    /// Places every axis at rest at `positions` (axis units) at time `t_ns`.
    pub fn reset(&mut self, t_ns: u64, positions: &[f64]) -> Result<&[AxisOutput], PlantError> {
        self.check_len(positions.len())?;
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(PlantError::Input("non-finite position".into()));
        }
        if !self.started {
            self.origin_ns = t_ns;
        }
        self.t_ns = t_ns;
        self.t_target_ns = t_ns;
        self.started = true;
        self.was_reset = true;
        let t_s = self.time_s();
        for (a, &p) in self.axes.iter_mut().zip(positions) {
            a.set_external_force(0.0);
            a.reset(p, t_s);
        }
        if let Some(m) = &mut self.milling {
            m.reset();
        }
        if let Some(st) = &mut self.structure {
            let [a, b] = st.axes;
            st.reset([self.axes[a].load_force(), self.axes[b].load_force()]);
        }
        for a in self.actuators.iter_mut().flatten() {
            a.reset();
        }
        self.actuator_cmd = [0.0; MAX_AXES];
        if let Some(s) = &mut self.sensors {
            s.reset(t_ns);
        }
        self.update_outputs();
        Ok(&self.outputs)
    }

    /// Advances to time `t_ns`, the drives interpolating from the previous targets to
    /// `targets` (axis units). The first call places the plant at rest at the targets.
    pub fn advance_to(&mut self, t_ns: u64, targets: &[AxisTarget]) -> Result<&[AxisOutput], PlantError> {
        self.check_len(targets.len())?;
        if targets.iter().any(|t| !(t.pos.is_finite() && t.vel.is_finite() && t.acc.is_finite())) {
            return Err(PlantError::Input("non-finite target".into()));
        }
        if !self.started {
            let mut pos = [0.0; MAX_AXES];
            for (p, t) in pos.iter_mut().zip(targets) {
                *p = t.pos;
            }
            return self.reset(t_ns, &pos[..targets.len()]);
        }
        let half = self.h_ns / 2;
        if t_ns <= self.t_target_ns {
            // Time did not advance: take the new target without motion.
            self.stats.time_anomalies += 1;
            self.was_reset = false;
            for (a, t) in self.axes.iter_mut().zip(targets) {
                a.set_target(t.pos, t.vel, t.acc, 0.0);
            }
            self.update_outputs();
            return Ok(&self.outputs);
        }
        let gap_ns = t_ns - self.t_ns.min(t_ns);
        if gap_ns as f64 * 1e-9 > MAX_GAP_S {
            self.stats.resyncs += 1;
            let mut pos = [0.0; MAX_AXES];
            for (p, t) in pos.iter_mut().zip(targets) {
                *p = t.pos;
            }
            return self.reset(t_ns, &pos[..targets.len()]);
        }
        self.t_target_ns = t_ns;
        self.was_reset = false;
        let dur_s = gap_ns as f64 * 1e-9;
        for (a, t) in self.axes.iter_mut().zip(targets) {
            a.set_target(t.pos, t.vel, t.acc, dur_s);
        }
        for (i, a) in self.actuators.iter_mut().enumerate() {
            if let Some(a) = a {
                a.command(self.actuator_cmd[i] * 1e-3, dur_s);
            }
        }
        if let Some(m) = &mut self.milling {
            m.set_feed([targets[m.axes[0]].vel, targets[m.axes[1]].vel]);
        }
        let n = (gap_ns + half) / self.h_ns;
        let t0_s = self.time_s();
        for j in 0..n {
            let t_seg = j as f64 * self.h_s;
            let t_s = t0_s + t_seg;
            if let Some(m) = &mut self.milling {
                let f = m.step(t_s, self.h_s);
                self.axes[m.axes[0]].set_external_force(f[0]);
                self.axes[m.axes[1]].set_external_force(f[1]);
            }
            for a in self.axes.iter_mut() {
                a.step(t_seg, t_s);
            }
            for a in self.actuators.iter_mut().flatten() {
                a.step(self.h_s);
            }
            if let Some(st) = &mut self.structure {
                let [a, b] = st.axes;
                st.step([self.axes[a].load_force(), self.axes[b].load_force()], self.h_s);
            }
            if let Some(s) = &mut self.sensors {
                let (axes, acts, st) = (&self.axes, &self.actuators, &self.structure);
                let t_step_ns = self.t_ns + (j + 1) * self.h_ns;
                s.after_step(t_step_ns, t_s + self.h_s, |i| {
                    let act_mm = acts[i].as_ref().map_or(0.0, |a| a.pos_m() * 1e3);
                    let ax = &axes[i];
                    [ax.load_pos() + structure_offset(st, i) + act_mm, ax.load_force(), act_mm]
                });
            }
        }
        self.t_ns += n * self.h_ns;
        self.update_outputs();
        Ok(&self.outputs)
    }

    /// One setpoint `dt_s` after the previous one: the drives interpolate from the previous
    /// targets to `targets` (axis units) over `dt_s` and the plant integrates at the servo rate
    /// (see [`Plant::advance_to`]). Returns the state at the new setpoint's time.
    pub fn step(&mut self, targets: &[AxisTarget], dt_s: f64) -> Result<&[AxisOutput], PlantError> {
        if !(dt_s.is_finite() && dt_s > 0.0 && dt_s <= MAX_GAP_S) {
            return Err(PlantError::Input(format!("time step must lie in (0, {MAX_GAP_S}] s, got {dt_s}")));
        }
        let t = self.t_target_ns + (dt_s * 1e9).round() as u64;
        self.advance_to(t, targets)
    }

    /// Validates one received payload and advances to its time. Rejected payloads are counted
    /// in [`Plant::stats`] and leave the plant untouched.
    pub fn step_setpoint(&mut self, sp: &Setpoints) -> Result<&[AxisOutput], SetpointError> {
        self.stats.received += 1;
        if let Err(e) = self.check_setpoint(sp) {
            match e {
                SetpointError::BadVersion { .. } => self.stats.bad_version += 1,
                SetpointError::AxisCount { .. } => self.stats.bad_axis_count += 1,
                SetpointError::NonFinite { .. } => self.stats.non_finite += 1,
            }
            return Err(e);
        }
        if let Some(last) = self.last_cycle {
            // Cycle 0 starts a new motion; otherwise count skipped cycle numbers.
            if sp.cycle > last + 1 {
                self.stats.missed_cycles += sp.cycle - last - 1;
            }
        }
        self.last_cycle = Some(sp.cycle);
        let n = self.axes.len();
        let mut targets = [AxisTarget::default(); MAX_AXES];
        for (i, t) in targets.iter_mut().enumerate().take(n) {
            *t = AxisTarget { pos: sp.pos[i], vel: sp.vel[i], acc: sp.acc[i] };
        }
        self.stats.accepted += 1;
        // Lengths and values were checked above, so this cannot fail.
        if self.advance_to(sp.time_ns, &targets[..n]).is_err() {
            return Err(SetpointError::NonFinite { axis: 0 });
        }
        Ok(&self.outputs)
    }

    fn check_setpoint(&self, sp: &Setpoints) -> Result<(), SetpointError> {
        if sp.version != PAYLOAD_VERSION {
            return Err(SetpointError::BadVersion { got: sp.version, expected: PAYLOAD_VERSION });
        }
        if sp.n_axes as usize != self.axes.len() {
            return Err(SetpointError::AxisCount { got: sp.n_axes, expected: self.axes.len() });
        }
        for i in 0..self.axes.len() {
            if !(sp.pos[i].is_finite() && sp.vel[i].is_finite() && sp.acc[i].is_finite()) {
                return Err(SetpointError::NonFinite { axis: i });
            }
        }
        Ok(())
    }

    /// Writes the feedback answering `sp` from the current outputs.
    pub fn fill_feedback(&self, sp: &Setpoints, fb: &mut Feedback) {
        let any = |f: fn(&AxisOutput) -> bool| self.outputs.iter().any(f);
        let bit = |on: bool, flag: u32| if on { flag } else { 0 };
        let flags = bit(any(|o| o.saturated), feedback_flags::SATURATED)
            | bit(any(|o| !o.contact), feedback_flags::GAP_OPEN)
            | bit(self.was_reset, feedback_flags::RESYNC);
        *fb = Feedback {
            version: PAYLOAD_VERSION,
            n_axes: self.axes.len() as u32,
            cycle: sp.cycle,
            time_ns: self.t_ns,
            setpoint_publish_ns: sp.publish_ns,
            flags,
            ..Feedback::default()
        };
        for (i, o) in self.outputs.iter().enumerate() {
            fb.motor_pos[i] = o.motor_pos;
            fb.load_pos[i] = o.load_pos;
            fb.following_error[i] = o.following_error;
            fb.load_error[i] = o.load_error;
            fb.motor_force[i] = o.motor_force;
        }
    }

    /// Sets the fast actuators' position commands (axis unit from mid-stroke), reached by a ramp
    /// over the next setpoint interval. Entries of axes without an actuator are ignored.
    pub fn set_actuator_commands(&mut self, pos: &[f64]) {
        for (c, p) in self.actuator_cmd.iter_mut().zip(pos) {
            if p.is_finite() {
                *c = *p;
            }
        }
    }

    /// Takes an [`ActuatorCommand`] payload: checked like a setpoint; a rejected one is counted
    /// in [`Plant::actuator_rejected`] and changes nothing.
    pub fn take_actuator_command(&mut self, c: &ActuatorCommand) -> bool {
        let n = self.axes.len();
        if c.version != PAYLOAD_VERSION || c.n_axes as usize != n || c.pos[..n].iter().any(|p| !p.is_finite()) {
            self.actuator_rejected += 1;
            return false;
        }
        self.actuator_cmd[..n].copy_from_slice(&c.pos[..n]);
        true
    }

    /// Whether the plant has sensors (`[plant.measurement]`).
    pub fn has_sensors(&self) -> bool {
        self.sensors.is_some()
    }

    /// The fast actuator of axis `i`, if it has one.
    pub fn actuator(&self, i: usize) -> Option<&Actuator> {
        self.actuators.get(i).and_then(|a| a.as_ref())
    }

    /// The milling force generator, if configured.
    pub fn milling(&self) -> Option<&Milling> {
        self.milling.as_ref()
    }

    /// The next measurement that has arrived by the plant's current time, as its payload.
    pub fn pop_measurement(&mut self, out: &mut Measurement) -> bool {
        let Some(s) = self.sensors.as_mut().and_then(|s| s.pop()) else { return false };
        let n = self.axes.len();
        let mut flags = measurement_flags::POSITION | measurement_flags::FORCE;
        if self.actuators.iter().any(|a| a.is_some()) {
            flags |= measurement_flags::ACTUATOR;
        }
        *out = Measurement {
            n_axes: n as u32,
            seq: s.seq,
            measured_ns: s.measured_ns,
            time_ns: s.arrived_ns,
            flags,
            ..Measurement::default()
        };
        out.tool_pos[..n].copy_from_slice(&s.tool_pos[..n]);
        out.force_n[..n].copy_from_slice(&s.force_n[..n]);
        out.actuator_pos[..n].copy_from_slice(&s.actuator_pos[..n]);
        true
    }

    fn check_len(&self, n: usize) -> Result<(), PlantError> {
        if n != self.axes.len() {
            return Err(PlantError::Input(format!("{n} targets for {} axes", self.axes.len())));
        }
        Ok(())
    }

    fn update_outputs(&mut self) {
        for ((o, a), act) in self.outputs.iter_mut().zip(&self.axes).zip(&self.actuators) {
            *o = a.output();
            if let Some(act) = act {
                o.actuator_pos = act.pos_m() * 1e3;
            }
        }
        if self.apply_crosstalk {
            for &(src, slot, dst) in &self.routes {
                let c = self.outputs[src].crosstalk[slot];
                let o = &mut self.outputs[dst];
                o.load_pos += c;
                o.load_error = o.setpoint - o.load_pos;
            }
        }
        for (i, o) in self.outputs.iter_mut().enumerate() {
            o.tool_pos = o.load_pos + structure_offset(&self.structure, i) + o.actuator_pos;
        }
    }
}

/// The tool's displacement from the load along axis `i` by the structure's compliance, axis
/// unit (mm); 0 for an axis outside its plane or without `[plant.structure]`.
#[inline]
fn structure_offset(structure: &Option<Structure>, i: usize) -> f64 {
    match structure {
        Some(st) if st.axes[0] == i => st.offset_mm()[0],
        Some(st) if st.axes[1] == i => st.offset_mm()[1],
        _ => 0.0,
    }
}
