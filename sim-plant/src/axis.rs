//! One simulated axis: drive (fine interpolation, encoder, cascade control) plus mechanics,
//! stepping at the servo rate. Works in SI base units inside; converts at the boundary from
//! and to the axis unit (mm or deg) used on the wire.

use crate::PlantError;
use crate::drive::{Command, Drive, Segment};
use crate::model::Mechanics;
use interpd_config::plant::{FineInterpolation, ProcessParams, ResolvedAxisPlant};
use interpd_config::{AxisKind, AxisLetter};

/// What one axis shows after a step, in the axis unit (mm or deg) and N (or N·m).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisOutput {
    /// Commanded (coarse) setpoint position this output answers.
    pub setpoint: f64,
    /// Commanded velocity of that setpoint, unit/s.
    pub setpoint_vel: f64,
    /// Motor position as the (quantised) encoder reads it.
    pub motor_pos: f64,
    /// True motor velocity, unit/s.
    pub motor_vel: f64,
    /// Load position (TCP for the 3-mass model, including crosstalk received from other axes
    /// when `[plant] apply_crosstalk`).
    pub load_pos: f64,
    /// Load velocity, unit/s.
    pub load_vel: f64,
    /// Setpoint minus encoder position.
    pub following_error: f64,
    /// Setpoint minus load position.
    pub load_error: f64,
    /// Motor force after the current loop, N (N·m).
    pub motor_force: f64,
    /// Force in the transmission spring, N (N·m).
    pub spring_force: f64,
    /// Process force acting on the load, N (N·m); positive pushes the load towards negative
    /// positions.
    pub process_force: f64,
    /// Fast actuator position from its mid-stroke, axis unit (0 without an actuator).
    pub actuator_pos: f64,
    /// Tool position: load plus actuator, axis unit.
    pub tool_pos: f64,
    /// The two crosstalk outputs this axis produces (3-mass model), in the target axes' unit.
    pub crosstalk: [f64; 2],
    /// The last force command hit the drive's limit.
    pub saturated: bool,
    /// Backlash flanks in contact.
    pub contact: bool,
}

/// One axis of the plant.
#[derive(Debug, Clone)]
pub struct Axis {
    pub name: AxisLetter,
    pub kind: AxisKind,
    pub preset: String,
    /// SI base units per axis unit (1e-3 m/mm or π/180 rad/deg).
    scale: f64,
    mech: Mechanics,
    drive: Drive,
    interp: FineInterpolation,
    seg: Segment,
    /// The last coarse target (SI).
    target: Command,
    process: ProcessParams,
    /// Process force set through the API instead of the configured static part.
    process_override: Option<f64>,
    /// Force on the load from outside the axis (the milling force), along +axis, N (N·m).
    f_ext: f64,
    f_proc_now: f64,
    /// The holding brake: the motor position it clamps (SI) while engaged.
    brake: Option<f64>,
}

impl Axis {
    /// Builds the axis for servo period `h_s`.
    pub fn new(r: &ResolvedAxisPlant, h_s: f64, substeps: u32, interp: FineInterpolation) -> Result<Self, PlantError> {
        let t_i_s = 1.0 / (2.0 * std::f64::consts::PI * r.drive.current_loop_hz);
        let mech = Mechanics::new(&r.model, t_i_s, h_s, substeps)?;
        let drive = Drive::new(&r.drive, h_s, mech.total_mass());
        let scale = match r.kind {
            AxisKind::Linear => 1e-3,
            AxisKind::Rotary => std::f64::consts::PI / 180.0,
        };
        Ok(Self {
            name: r.axis,
            kind: r.kind,
            preset: r.preset.clone(),
            scale,
            mech,
            drive,
            interp,
            seg: Segment::hold(0.0),
            target: Command::default(),
            process: r.process,
            process_override: None,
            f_ext: 0.0,
            f_proc_now: r.process.static_force,
            brake: None,
        })
    }

    /// SI units per axis unit.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The mechanics (for analysis and tests).
    pub fn mechanics(&self) -> &Mechanics {
        &self.mech
    }
    pub fn mechanics_mut(&mut self) -> &mut Mechanics {
        &mut self.mech
    }
    pub fn drive(&self) -> &Drive {
        &self.drive
    }
    pub fn drive_mut(&mut self) -> &mut Drive {
        &mut self.drive
    }
    pub fn model_is_three_mass(&self) -> bool {
        matches!(self.mech, Mechanics::ThreeMass(_))
    }

    /// Static process force at time `t_s` (N or N·m).
    #[inline]
    fn process_force(&self, t_s: f64) -> f64 {
        let base = self.process_override.unwrap_or(self.process.static_force) - self.f_ext;
        if self.process.dyn_force != 0.0 && self.process.dyn_hz > 0.0 {
            base + self.process.dyn_force * (2.0 * std::f64::consts::PI * self.process.dyn_hz * t_s).sin()
        } else {
            base
        }
    }

    /// Replaces the configured static process force (N or N·m); `None` restores it.
    pub fn set_process_force(&mut self, force: Option<f64>) {
        self.process_override = force;
    }

    /// Sets the force on the load from outside the axis (N or N·m, positive towards positive
    /// positions), held until the next call.
    #[inline]
    pub fn set_external_force(&mut self, force: f64) {
        self.f_ext = force;
    }

    /// The whole process force on the load in the last step along +axis (what a force sensor
    /// at the load sees), N (N·m).
    #[inline]
    pub fn load_force(&self) -> f64 {
        -self.f_proc_now
    }

    /// True load position in the axis unit (without crosstalk).
    #[inline]
    pub fn load_pos(&self) -> f64 {
        self.mech.load_pos() / self.scale
    }

    /// Standing still at `pos` (axis unit), in equilibrium with the static process force.
    pub fn reset(&mut self, pos: f64, t_s: f64) {
        let x = pos * self.scale;
        self.brake = None;
        let f = self.process_force(t_s);
        self.mech.set_rest(x, f);
        self.drive.set_rest(x, f);
        self.target = Command { pos: x, vel: 0.0, acc: 0.0 };
        self.seg = Segment::hold(x);
        self.f_proc_now = f;
    }

    /// Starts a fine-interpolation segment to the new coarse target (axis units) lasting
    /// `dur_s`.
    #[inline]
    pub fn set_target(&mut self, pos: f64, vel: f64, acc: f64, dur_s: f64) {
        let b = Command { pos: pos * self.scale, vel: vel * self.scale, acc: acc * self.scale };
        self.seg = Segment::new(self.target, b, dur_s, self.interp);
        self.target = b;
    }

    /// Engages or releases the motor's holding brake. Engaged, the motor stands where it is
    /// and the drive's loops are off (a CiA 402 drive with its power stage off); the load may
    /// still swing on the transmission. Released, the drive takes over at the motor's position
    /// with the holding force already built up, so the axis does not sag or jump.
    pub fn set_brake(&mut self, engaged: bool) {
        match (engaged, self.brake) {
            (true, None) => {
                let x = self.mech.motor_pos();
                self.brake = Some(x);
                self.mech.brake_motor(x);
            }
            (false, Some(x)) => {
                self.brake = None;
                let f_hold = self.mech.spring_force();
                self.drive.set_rest(x, f_hold);
                self.mech.set_motor_force(f_hold);
                self.target = Command { pos: x, vel: 0.0, acc: 0.0 };
                self.seg = Segment::hold(x);
            }
            _ => {}
        }
    }

    /// Whether the holding brake is engaged.
    pub fn braked(&self) -> bool {
        self.brake.is_some()
    }

    /// One servo step at `t_seg_s` into the current segment (plant time `t_s`).
    #[inline]
    pub fn step(&mut self, t_seg_s: f64, t_s: f64) {
        self.f_proc_now = self.process_force(t_s);
        if let Some(x) = self.brake {
            self.mech.step(0.0, -self.f_proc_now);
            self.mech.brake_motor(x);
            return;
        }
        let cmd = self.seg.eval(t_seg_s);
        let f_cmd = self.drive.control(self.mech.motor_pos(), cmd);
        self.mech.step(f_cmd, -self.f_proc_now);
    }

    /// The output against the current coarse target, in axis units (crosstalk not yet added).
    pub fn output(&self) -> AxisOutput {
        let s = self.scale;
        let setpoint = self.target.pos / s;
        // Read the encoder at the output instant (the drive's last reading is one step old).
        let q = self.drive.params().encoder_step;
        let x_m = self.mech.motor_pos();
        let enc = if q > 0.0 { (x_m / q).round() * q } else { x_m };
        // + 0.0 turns the −0 of a reading rounded from below zero into 0 (tidier CSV columns).
        let motor_pos = enc / s + 0.0;
        let load_pos = self.mech.load_pos() / s;
        let ct = self.mech.crosstalk();
        AxisOutput {
            setpoint,
            setpoint_vel: self.target.vel / s,
            motor_pos,
            motor_vel: self.mech.motor_vel() / s,
            load_pos,
            load_vel: self.mech.load_vel() / s,
            following_error: setpoint - motor_pos,
            load_error: setpoint - load_pos,
            motor_force: self.mech.motor_force(),
            spring_force: self.mech.spring_force(),
            process_force: self.f_proc_now,
            actuator_pos: 0.0,
            tool_pos: load_pos,
            // Crosstalk goes into linear target axes: m → mm.
            crosstalk: [ct[0] * 1e3, ct[1] * 1e3],
            saturated: self.drive.saturated(),
            contact: self.mech.contact(),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::{AxisTarget, Plant};
    use interpd_config::Config;

    /// The default machine's plant, at rest at 0.
    fn plant() -> Plant {
        let mut p = Plant::from_config(&Config::default_machine()).expect("plant");
        p.reset(0, &[0.0; 3]).expect("reset");
        p
    }

    #[test]
    fn the_brake_holds_the_motor_still_while_the_load_swings_out() {
        let mut p = plant();
        // Move X to 1 mm and brake in mid-motion, with the drive still lagging.
        let targets = [AxisTarget { pos: 1.0, ..AxisTarget::default() }, AxisTarget::default(), AxisTarget::default()];
        for _ in 0..3 {
            p.step(&targets, 0.004).expect("step");
        }
        assert!(p.outputs()[0].motor_vel.abs() > 1.0, "moving when the brake engages");
        p.axis_mut(0).expect("X").set_brake(true);
        let held = p.outputs()[0].motor_pos;
        let mut load = Vec::new();
        for _ in 0..50 {
            p.step(&targets, 0.004).expect("step");
            assert_eq!(p.outputs()[0].motor_pos, held, "the braked motor moved");
            assert_eq!(p.outputs()[0].motor_vel, 0.0);
            load.push(p.outputs()[0].load_pos);
        }
        let swing =
            load.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - load.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(swing > 0.0, "the load swings on the transmission");
        // A brake released at rest hands the motor to the drive without a jump.
        let mut p = plant();
        let zero = [AxisTarget::default(); 3];
        p.axis_mut(0).expect("X").set_brake(true);
        for _ in 0..10 {
            p.step(&zero, 0.004).expect("step");
        }
        p.axis_mut(0).expect("X").set_brake(false);
        for _ in 0..10 {
            p.step(&zero, 0.004).expect("step");
            assert!(p.outputs()[0].motor_pos.abs() < 1e-6, "{}", p.outputs()[0].motor_pos);
        }
    }
}
