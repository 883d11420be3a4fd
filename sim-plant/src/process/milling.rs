//! The milling force on the load (Schneider 2016, §2.2.4, §3.4, Fig. 5.5/5.8): a static part
//! that follows the feed direction in the cutting plane (full-slot engagement on a circle pulls
//! the tool inward, so each axis sees a sinusoid over one revolution), the tooth-passing
//! harmonic at teeth × spindle speed, and a slow drift of the static part. The tool cuts while
//! the path speed exceeds the engagement speed; the force rises and falls with a first-order
//! lag there, so a start or a stop gives no force step.

use interpd_config::plant::MillingConfig;
use std::f64::consts::PI;

/// The force generator of one cutting plane.
#[derive(Debug, Clone)]
pub struct Milling {
    /// Plant axis indices of the plane's two axes.
    pub axes: [usize; 2],
    force_n: f64,
    /// cos, sin of the angle from the feed direction.
    rot: [f64; 2],
    engage_speed_mm_s: f64,
    engage_time_s: f64,
    tooth_hz: f64,
    tooth_force_n: f64,
    drift_n: f64,
    drift_period_s: f64,
    /// Unit feed direction in the plane (kept while standing).
    dir: [f64; 2],
    cutting: bool,
    /// Engagement 0..1 (first-order lag of `cutting`).
    engage: f64,
}

impl Milling {
    pub fn new(c: &MillingConfig, axes: [usize; 2]) -> Self {
        let a = c.angle_deg.to_radians();
        Self {
            axes,
            force_n: c.force_n,
            rot: [a.cos(), a.sin()],
            engage_speed_mm_s: c.engage_speed_mm_s,
            engage_time_s: c.engage_time_s,
            tooth_hz: c.tooth_hz(),
            tooth_force_n: c.tooth_force_n,
            drift_n: c.drift_n,
            drift_period_s: c.drift_period_s,
            dir: [1.0, 0.0],
            cutting: false,
            engage: 0.0,
        }
    }

    /// Not cutting, engagement 0.
    pub fn reset(&mut self) {
        self.cutting = false;
        self.engage = 0.0;
    }

    /// The commanded feed velocity of the plane's axes (mm/s), once per setpoint.
    pub fn set_feed(&mut self, v: [f64; 2]) {
        let speed = v[0].hypot(v[1]);
        if speed > 1e-9 {
            self.dir = [v[0] / speed, v[1] / speed];
        }
        self.cutting = speed >= self.engage_speed_mm_s;
    }

    /// Advances the engagement by `h_s` and returns the force on the load along the plane's two
    /// axes at plant time `t_s`, N.
    #[inline]
    pub fn step(&mut self, t_s: f64, h_s: f64) -> [f64; 2] {
        let target = if self.cutting { 1.0 } else { 0.0 };
        self.engage += (target - self.engage) * (h_s / self.engage_time_s).min(1.0);
        if self.engage < 1e-12 {
            return [0.0, 0.0];
        }
        let magnitude = self.force_n
            + self.drift_n * (2.0 * PI * t_s / self.drift_period_s).sin()
            + self.tooth_force_n * (2.0 * PI * self.tooth_hz * t_s).sin();
        let f = self.engage * magnitude;
        let [c, s] = self.rot;
        let [dx, dy] = self.dir;
        [f * (c * dx - s * dy), f * (s * dx + c * dy)]
    }

    /// Engagement 0..1.
    pub fn engagement(&self) -> f64 {
        self.engage
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_force_turns_with_the_feed_and_points_left_of_it() {
        let c = MillingConfig { tooth_force_n: 0.0, drift_n: 0.0, ..MillingConfig::default() };
        let mut m = Milling::new(&c, [0, 1]);
        // Feed along +X: 90° to the left is +Y.
        m.set_feed([5.0, 0.0]);
        let mut f = [0.0; 2];
        for k in 0..20_000 {
            f = m.step(k as f64 * 1e-4, 1e-4);
        }
        assert!(f[0].abs() < 1e-9 && (f[1] - 200.0).abs() < 0.05, "{f:?}");
        // Feed along −Y: the left is +X.
        m.set_feed([0.0, -5.0]);
        let f = m.step(2.0, 1e-4);
        assert!((f[0] - 200.0).abs() < 0.05 && f[1].abs() < 1e-9, "{f:?}");
    }

    #[test]
    fn engagement_rises_without_a_step() {
        let mut m = Milling::new(&MillingConfig::default(), [0, 1]);
        m.set_feed([5.0, 0.0]);
        let f0 = m.step(0.0, 1e-4);
        assert!(f0[1].abs() < 1.0, "first step {f0:?}");
        m.set_feed([0.1, 0.0]);
        assert!(!m.cutting);
    }
}
