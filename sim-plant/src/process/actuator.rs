//! The fast auxiliary actuator between load and tool (Schneider 2016, §2.4, §4.3): a flexure
//! stage with a lightly damped first mode, driven through its own inner loop on a strain gauge:
//! PID (eq. 4.14; the D part on the measured rate, so a reference step gives no kick) plus a
//! feedforward of the reference through the inverse static gain, with anti-windup at the
//! drive's limit (Åström). The stage sits against end stops at ± stroke.
//!
//! ```text
//! ẍ = ω² (u − x) − 2ζω ẋ                           (static gain 1: u in displacement units)
//! u = sat(K_ff r + K_p (r − x) + K_i ∫(r − x) − K_d ẋ),  |u| ≤ stroke
//! |x| ≤ stroke                                      (end stops)
//! ```
//!
//! Work in SI (m) inside; the reaction force on the load is neglected (the stage's moving mass
//! is small against the robot's).

use interpd_config::plant::ActuatorConfig;

/// Integration sub-steps per servo step: at 10 kHz ωh = 0.05 for 80 Hz, a quarter of that per
/// sub-step keeps the semi-implicit Euler's frequency error below 0.01 %.
const SUBSTEPS: u32 = 4;

/// One actuator.
#[derive(Debug, Clone)]
pub struct Actuator {
    stroke_m: f64,
    omega: f64,
    zeta: f64,
    kp: f64,
    ki: f64,
    kd: f64,
    kff: f64,
    x: f64,
    v: f64,
    integral: f64,
    /// Reference ramp: from, to, duration, time into it.
    r_from: f64,
    r_to: f64,
    r_dur_s: f64,
    r_t_s: f64,
    saturated: bool,
    /// Servo steps spent at the drive limit or an end stop.
    saturated_steps: u64,
    /// Largest |x| seen, m.
    max_abs_m: f64,
}

impl Actuator {
    pub fn new(c: &ActuatorConfig) -> Self {
        Self {
            stroke_m: c.stroke_mm * 1e-3,
            omega: 2.0 * std::f64::consts::PI * c.mode_hz,
            zeta: c.damping,
            kp: c.kp,
            ki: c.ki_per_s,
            kd: c.kd_s,
            kff: c.feedforward,
            x: 0.0,
            v: 0.0,
            integral: 0.0,
            r_from: 0.0,
            r_to: 0.0,
            r_dur_s: 0.0,
            r_t_s: 0.0,
            saturated: false,
            saturated_steps: 0,
            max_abs_m: 0.0,
        }
    }

    /// At rest at mid-stroke.
    pub fn reset(&mut self) {
        self.x = 0.0;
        self.v = 0.0;
        self.integral = 0.0;
        self.r_from = 0.0;
        self.r_to = 0.0;
        self.r_t_s = 0.0;
        self.r_dur_s = 0.0;
    }

    /// A new position command (m from mid-stroke), reached by a ramp over `dur_s`. Commands
    /// beyond the stroke are clamped to it; a non-finite one keeps the previous command.
    pub fn command(&mut self, r_m: f64, dur_s: f64) {
        let r = if r_m.is_finite() { r_m.clamp(-self.stroke_m, self.stroke_m) } else { self.r_to };
        self.r_from = self.reference();
        self.r_to = r;
        self.r_dur_s = dur_s.max(0.0);
        self.r_t_s = 0.0;
    }

    fn reference(&self) -> f64 {
        if self.r_dur_s <= 0.0 || self.r_t_s >= self.r_dur_s {
            self.r_to
        } else {
            self.r_from + (self.r_to - self.r_from) * (self.r_t_s / self.r_dur_s)
        }
    }

    /// One servo step of `h_s`: the inner loop, then the stage.
    #[inline]
    pub fn step(&mut self, h_s: f64) {
        self.r_t_s += h_s;
        let r = self.reference();
        let e = r - self.x;
        let u_free = self.kff * r + self.kp * e + self.integral - self.kd * self.v;
        let u = u_free.clamp(-self.stroke_m, self.stroke_m);
        self.saturated = u != u_free;
        // Anti-windup: the integrator holds while the drive is at its limit and the error
        // pushes further out.
        if !(self.saturated && e * u_free > 0.0) {
            self.integral += self.ki * e * h_s;
        }
        let hs = h_s / f64::from(SUBSTEPS);
        let w2 = self.omega * self.omega;
        for _ in 0..SUBSTEPS {
            self.v += hs * (w2 * (u - self.x) - 2.0 * self.zeta * self.omega * self.v);
            self.x += hs * self.v;
            if self.x.abs() > self.stroke_m {
                // End stop: the stage stops there.
                self.x = self.x.clamp(-self.stroke_m, self.stroke_m);
                self.v = 0.0;
                self.saturated = true;
            }
        }
        self.saturated_steps += u64::from(self.saturated);
        self.max_abs_m = self.max_abs_m.max(self.x.abs());
    }

    /// Position from mid-stroke, m.
    pub fn pos_m(&self) -> f64 {
        self.x
    }
    /// The commanded position at the end of the current ramp, m.
    pub fn command_m(&self) -> f64 {
        self.r_to
    }
    /// Stroke, ± m.
    pub fn stroke_m(&self) -> f64 {
        self.stroke_m
    }
    /// The last step hit the drive limit or an end stop.
    pub fn saturated(&self) -> bool {
        self.saturated
    }
    /// Servo steps at the drive limit or an end stop.
    pub fn saturated_steps(&self) -> u64 {
        self.saturated_steps
    }
    /// Largest |position| so far, m (stroke use = this / stroke).
    pub fn max_abs_m(&self) -> f64 {
        self.max_abs_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step_response(c: &ActuatorConfig, r: f64, steps: usize) -> Vec<f64> {
        let mut a = Actuator::new(c);
        a.command(r, 0.0);
        (0..steps)
            .map(|_| {
                a.step(1e-4);
                a.pos_m()
            })
            .collect()
    }

    #[test]
    fn the_inner_loop_settles_on_the_reference_within_tens_of_milliseconds() {
        let x = step_response(&ActuatorConfig::default(), 50e-6, 500);
        assert!((x[499] - 50e-6).abs() < 0.5e-6, "after 50 ms: {}", x[499]);
        // Feedforward and P act on a step together: the overshoot stays below 40 %; the
        // commands the daemon sends are ramps over the cycle.
        let peak = x.iter().cloned().fold(0.0, f64::max);
        assert!(peak < 70e-6, "overshoot to {peak}");
    }

    #[test]
    fn the_open_stage_rings_at_its_mode() {
        // Without the loop's damping the step rings at the mode frequency: zero crossings of
        // x − r every half period.
        let c = ActuatorConfig { kp: 0.0, ki_per_s: 0.0, kd_s: 0.0, ..ActuatorConfig::default() };
        let x = step_response(&c, 10e-6, 1000);
        let crossings: Vec<usize> =
            (1..x.len()).filter(|&k| (x[k - 1] - 10e-6).signum() != (x[k] - 10e-6).signum()).collect();
        let half_period_s = (crossings[4] - crossings[2]) as f64 * 1e-4 / 2.0;
        assert!((1.0 / (2.0 * half_period_s) - 80.0).abs() < 1.0, "{half_period_s}");
    }

    #[test]
    fn commands_beyond_the_stroke_stop_at_it() {
        let x = step_response(&ActuatorConfig::default(), 1.0, 2000);
        assert!(x.iter().all(|v| v.abs() <= 0.25e-3), "{}", x.iter().cloned().fold(0.0, f64::max));
    }
}
