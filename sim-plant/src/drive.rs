//! The servo drive: fine interpolation of the coarse setpoints, quantised motor encoder,
//! cascade P position / PI velocity controller with feedforward and anti-windup. The current
//! loop (PT1 with saturation of its input) is a state of the mechanics, see [`crate::model`].
//!
//! The structure is the cascade of position, velocity and current loop that Schneider 2016,
//! §4.2 describes for the robot's drives; loops and gain names are those of Haas 2012,
//! Table 5.2 (P position loop Kv, PI velocity loop Kp/Tn on the motor encoder, velocity
//! feedforward, power module PT1):
//! ```text
//! x_enc = q·round(x_M/q)                           encoder quantum q
//! v_enc = PT1_f[(x_enc,k − x_enc,k−1)/h]           backward difference, optional filter
//! v_ref = Kv (x_cmd − x_enc) + K_vff v_cmd          (Haas 2012, Table 5.2: Kpv1, VV1)
//! F_cmd = Kp [(v_ref − v_enc) + (1/Tn) ∫(v_ref − v_enc)] + K_aff m_tot a_cmd   (Kpx1, Tni1)
//! sat(F_cmd) = clamp(F_cmd, ±F_max); the integrator holds while saturated and pushing outward
//! ```

use interpd_config::plant::{DriveParams, FineInterpolation};

/// One fine-interpolation segment between two coarse setpoints, as a polynomial in the time
/// since the segment start (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Segment {
    /// Start position (kept apart for precision), m or rad.
    p0: f64,
    /// Coefficients of p(t) − p0 = c1 t + … + c5 t⁵.
    c: [f64; 5],
    /// Duration, s (0: constant).
    dur_s: f64,
}

/// A point of the commanded motion.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
}

impl Segment {
    /// Standing still at `p`.
    pub fn hold(p: f64) -> Self {
        Self { p0: p, c: [0.0; 5], dur_s: 0.0 }
    }

    /// From `a` to `b` in `dur_s` seconds with the chosen interpolation. Linear and cubic use
    /// only what they need from the end states, as a CSP drive fed positions (and velocities).
    pub fn new(a: Command, b: Command, dur_s: f64, kind: FineInterpolation) -> Self {
        if dur_s <= 0.0 || !dur_s.is_finite() {
            return Self::hold(b.pos);
        }
        let t = dur_s;
        let dp = b.pos - a.pos;
        let c = match kind {
            FineInterpolation::Linear => [dp / t, 0.0, 0.0, 0.0, 0.0],
            FineInterpolation::Cubic => {
                // Cubic Hermite from (p, v) at both ends.
                let c2 = (3.0 * dp - (2.0 * a.vel + b.vel) * t) / (t * t);
                let c3 = (-2.0 * dp + (a.vel + b.vel) * t) / (t * t * t);
                [a.vel, c2, c3, 0.0, 0.0]
            }
            FineInterpolation::Quintic => {
                // Quintic Hermite from (p, v, a) at both ends.
                let t2 = t * t;
                let c3 = (20.0 * dp - (8.0 * b.vel + 12.0 * a.vel) * t - (3.0 * a.acc - b.acc) * t2) / (2.0 * t2 * t);
                let c4 = (-30.0 * dp + (14.0 * b.vel + 16.0 * a.vel) * t + (3.0 * a.acc - 2.0 * b.acc) * t2)
                    / (2.0 * t2 * t2);
                let c5 = (12.0 * dp - 6.0 * (b.vel + a.vel) * t + (b.acc - a.acc) * t2) / (2.0 * t2 * t2 * t);
                [a.vel, a.acc / 2.0, c3, c4, c5]
            }
        };
        Self { p0: a.pos, c, dur_s: t }
    }

    /// Position, velocity and acceleration `t_s` after the segment start (clamped to it).
    #[inline]
    pub fn eval(&self, t_s: f64) -> Command {
        let t = t_s.clamp(0.0, self.dur_s);
        let c = &self.c;
        let pos = self.p0 + t * (c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * c[4]))));
        let vel = c[0] + t * (2.0 * c[1] + t * (3.0 * c[2] + t * (4.0 * c[3] + t * 5.0 * c[4])));
        let acc = 2.0 * c[1] + t * (6.0 * c[2] + t * (12.0 * c[3] + t * 20.0 * c[4]));
        Command { pos, vel, acc }
    }
}

/// The cascade controller of one axis.
#[derive(Debug, Clone)]
pub struct Drive {
    p: DriveParams,
    h_s: f64,
    /// Feedforward mass K_aff · m_tot.
    ff_mass: f64,
    /// Velocity-filter coefficient α = 1 − e^{−ω_f h} (1 = no filter).
    alpha: f64,
    /// ∫ e_v dt / Tn, m/s.
    integ: f64,
    enc_prev: f64,
    v_filt: f64,
    enc: f64,
    saturated: bool,
}

impl Drive {
    pub fn new(p: &DriveParams, h_s: f64, total_mass: f64) -> Self {
        let alpha = match p.velocity_filter_hz {
            Some(f) => 1.0 - (-2.0 * std::f64::consts::PI * f * h_s).exp(),
            None => 1.0,
        };
        Self {
            p: *p,
            h_s,
            ff_mass: p.acc_ff * total_mass,
            alpha,
            integ: 0.0,
            enc_prev: 0.0,
            v_filt: 0.0,
            enc: 0.0,
            saturated: false,
        }
    }

    /// At rest at motor position `x_m`, holding the force `f_hold` through the integrator.
    pub fn set_rest(&mut self, x_m: f64, f_hold: f64) {
        self.enc = self.quantise(x_m);
        self.enc_prev = self.enc;
        self.v_filt = 0.0;
        self.integ = f_hold / self.p.kp;
        self.saturated = false;
    }

    #[inline]
    fn quantise(&self, x: f64) -> f64 {
        let q = self.p.encoder_step;
        if q > 0.0 { (x / q).round() * q } else { x }
    }

    /// One controller sample: reads the motor position `x_m` through the encoder and returns
    /// the saturated force command for the next servo period.
    #[inline]
    pub fn control(&mut self, x_m: f64, cmd: Command) -> f64 {
        let p = &self.p;
        let enc = self.quantise(x_m);
        let v_raw = (enc - self.enc_prev) / self.h_s;
        self.enc_prev = enc;
        self.enc = enc;
        self.v_filt += self.alpha * (v_raw - self.v_filt);
        // Haas 2012, Table 5.2: P position loop with velocity feedforward VV1.
        let v_ref = p.kv_per_s * (cmd.pos - enc) + p.vel_ff * cmd.vel;
        let e_v = v_ref - self.v_filt;
        // Haas 2012, Table 5.2: PI velocity loop Kpx1, Tni1; plus acceleration feedforward.
        let integ_new = self.integ + self.h_s / p.tn_s * e_v;
        let f = p.kp * (e_v + integ_new) + self.ff_mass * cmd.acc;
        let f_sat = f.clamp(-p.force_limit, p.force_limit);
        self.saturated = f_sat != f;
        // Clamping anti-windup: integrate unless saturated and the error pushes further out.
        if !(self.saturated && e_v * f > 0.0) {
            self.integ = integ_new;
        }
        f_sat
    }

    /// The last encoder reading (m or rad).
    pub fn encoder(&self) -> f64 {
        self.enc
    }
    /// The last command hit the force limit.
    pub fn saturated(&self) -> bool {
        self.saturated
    }
    pub fn params(&self) -> &DriveParams {
        &self.p
    }

    /// Controller state [integrator, previous encoder, filtered velocity] (for the
    /// closed-loop analysis).
    pub fn state(&self) -> [f64; 3] {
        [self.integ, self.enc_prev, self.v_filt]
    }
    pub fn set_state(&mut self, s: [f64; 3]) {
        self.integ = s[0];
        self.enc_prev = s[1];
        self.v_filt = s[2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quintic_segment_matches_end_states() {
        let a = Command { pos: 1.0, vel: -0.2, acc: 3.0 };
        let b = Command { pos: 1.01, vel: 0.4, acc: -1.0 };
        let s = Segment::new(a, b, 0.004, FineInterpolation::Quintic);
        let e0 = s.eval(0.0);
        let e1 = s.eval(0.004);
        for (x, y) in
            [(e0.pos, a.pos), (e0.vel, a.vel), (e0.acc, a.acc), (e1.pos, b.pos), (e1.vel, b.vel), (e1.acc, b.acc)]
        {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
        let c = Segment::new(a, b, 0.004, FineInterpolation::Cubic);
        let (c0, c1) = (c.eval(0.0), c.eval(0.004));
        assert!((c0.vel - a.vel).abs() < 1e-9 && (c1.vel - b.vel).abs() < 1e-9 && (c1.pos - b.pos).abs() < 1e-12);
        let l = Segment::new(a, b, 0.004, FineInterpolation::Linear);
        assert!((l.eval(0.002).pos - 1.005).abs() < 1e-12);
    }
}
