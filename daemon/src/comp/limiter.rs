//! The limiter every correction passes: the correction is followed by a jerk-limited tracker
//! whose own velocity, acceleration and jerk stay within a share r of each axis limit, and whose
//! target stays within the travel range and the largest correction. The planner plans with the
//! rest, (1 − r) of each limit, and finite differences add: the stream sent to the drives,
//! setpoint plus correction, keeps every limit.
//!
//! The tracker's state is kept as finite differences (c_k = c_{k−1} + ċ_k h, ċ_k = ċ_{k−1} + c̈_k h,
//! c̈_k = c̈_{k−1} + j_k h), so the limits hold for the sampled stream itself. Towards a target it
//! is a critically damped second-order approach, braking early enough for the velocity and
//! acceleration limits given the jerk limit.

/// Braking margin on the kinematic bounds: the discrete steps overshoot the continuous braking
/// curve by up to one step, which this keeps inside the limits.
const BRAKE_MARGIN: f64 = 0.8;

/// Bounds of one axis's correction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub vel: f64,
    pub acc: f64,
    pub jerk: f64,
    /// Largest |correction|.
    pub max: f64,
}

/// One axis's correction with its derivatives (finite differences), axis unit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Limiter {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
    /// Steps in which a hard clamp had to act (the braking logic let a bound be reached).
    pub clamps: u64,
}

impl Limiter {
    /// One step of `h_s` towards `target` within `b`; `travel` is the range the correction may
    /// take here (setpoint to the travel limits).
    #[inline]
    pub fn step(&mut self, target: f64, travel: (f64, f64), b: &Bounds, h_s: f64) {
        let t = target.clamp(-b.max, b.max).clamp(travel.0.min(0.0), travel.1.max(0.0));
        // The acceleration loop is no faster than the jerk bound lets the acceleration change
        // (half the time from 0 to the bound), the position loop four times slower: critically
        // damped, so a step is approached without overshoot.
        let tau_a = (2.0 * h_s).max(0.5 * b.acc / b.jerk);
        let tau_v = 4.0 * tau_a;
        let e = t - self.pos;
        // Velocity wanted: linear near the target, braking-limited (acceleration and jerk)
        // farther out.
        // Braking from v at acceleration A takes v²/2A; jerk-limited braking from v takes about
        // v·√(v/J): both bounds with the margin.
        let v_far = (BRAKE_MARGIN * b.acc * e.abs()).sqrt().min((BRAKE_MARGIN * b.jerk * e * e).cbrt());
        let v_des = (e / tau_v).clamp(-v_far, v_far).clamp(-BRAKE_MARGIN * b.vel, BRAKE_MARGIN * b.vel);
        // Acceleration wanted, limited so that it can be taken back to 0 before the velocity
        // passes v_des (jerk limit).
        let dv = v_des - self.vel;
        let a_room = (2.0 * BRAKE_MARGIN * b.jerk * dv.abs()).sqrt();
        let a_des = (dv / tau_a).clamp(-a_room, a_room).clamp(-BRAKE_MARGIN * b.acc, BRAKE_MARGIN * b.acc);
        let j = ((a_des - self.acc) / h_s).clamp(-b.jerk, b.jerk);
        let (a0, v0) = (self.acc, self.vel);
        let mut a = a0 + j * h_s;
        let mut v = v0 + a * h_s;
        if v.abs() > b.vel || a.abs() > b.acc {
            self.clamps += 1;
            v = v.clamp(-b.vel, b.vel);
            a = ((v - v0) / h_s).clamp(-b.acc, b.acc);
            v = v0 + a * h_s;
        }
        self.acc = a;
        self.vel = v;
        self.pos += v * h_s;
    }
}

#[cfg(test)]
#[allow(clippy::print_stdout)]
mod tests {
    use super::*;

    fn fd_check(xs: &[f64], h: f64, b: &Bounds) -> (f64, f64, f64) {
        let v: Vec<f64> = xs.windows(2).map(|w| (w[1] - w[0]) / h).collect();
        let a: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / h).collect();
        let j: Vec<f64> = a.windows(2).map(|w| (w[1] - w[0]) / h).collect();
        let m = |x: &[f64]| x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let r = (m(&v) / b.vel, m(&a) / b.acc, m(&j) / b.jerk);
        assert!(r.0 <= 1.0 + 1e-9 && r.1 <= 1.0 + 1e-9 && r.2 <= 1.0 + 1e-9, "{r:?}");
        r
    }

    #[test]
    fn steps_and_noise_in_the_target_keep_every_bound() {
        let b = Bounds { vel: 25.0, acc: 250.0, jerk: 5000.0, max: 2.0 };
        let h = 0.004;
        let mut l = Limiter::default();
        let mut xs = vec![0.0, 0.0, 0.0];
        let mut seed = 1u64;
        for k in 0..5000 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let noise = ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.2;
            let target = match (k / 500) % 4 {
                0 => 1.5,
                1 => -3.0,
                2 => noise,
                _ => 0.3 * (k as f64 * 0.05).sin(),
            };
            l.step(target, (-1000.0, 1000.0), &b, h);
            xs.push(l.pos);
        }
        let r = fd_check(&xs, h, &b);
        println!("largest use of the bounds: v {:.2}, a {:.2}, j {:.2}", r.0, r.1, r.2);
        assert!(xs.iter().all(|x| x.abs() <= 2.0 + 1e-12));
    }

    #[test]
    fn a_step_is_approached_without_overshoot() {
        let b = Bounds { vel: 25.0, acc: 250.0, jerk: 5000.0, max: 2.0 };
        let mut l = Limiter::default();
        let mut peak = 0.0_f64;
        for _ in 0..500 {
            l.step(0.2, (-1000.0, 1000.0), &b, 0.004);
            peak = peak.max(l.pos);
        }
        assert!((l.pos - 0.2).abs() < 1e-9 && peak <= 0.2 + 1e-6, "{} peak {peak}", l.pos);
    }
}
