//! The milling force on the load (Schneider 2016, §2.2.4, §3.4, Fig. 5.5/5.8): a static part
//! that follows the feed direction in the cutting plane (full-slot engagement on a circle pulls
//! the tool inward, so each axis sees a sinusoid over one revolution), the tooth-passing
//! harmonic at teeth × spindle speed, a slow drift of the static part, and a band-limited random
//! variation of it (the varying material removal of a real cut, §2.2.4). The tool cuts while
//! the path speed exceeds the engagement speed; the force rises and falls with a first-order
//! lag there, so a start or a stop gives no force step.

use crate::noise::Noise;
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
    /// The variation: white noise through two first-order low-passes of pole `var_pole`
    /// (exp(−2π f h) per step of `var_step_s`), input scaled so the output's standard deviation
    /// is `variation_n`.
    variation_n: f64,
    variation_hz: f64,
    noise: Noise,
    var_stage: [f64; 2],
    /// Unit feed direction in the plane (the last one while cutting).
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
            variation_n: c.variation_n,
            variation_hz: c.variation_hz,
            noise: Noise::new(c.seed),
            var_stage: [0.0; 2],
            dir: [1.0, 0.0],
            cutting: false,
            engage: 0.0,
        }
    }

    /// Not cutting, engagement 0.
    pub fn reset(&mut self) {
        self.cutting = false;
        self.engage = 0.0;
        self.var_stage = [0.0; 2];
    }

    /// Advances the random variation by `h_s`, N. Two cascaded first-order low-passes at f_c
    /// driven by white noise: the first stage's output has variance σ₁², the second halves it
    /// (∫ du / (1 + u²)² = π/4 of the first stage's ∫ du / (1 + u²) = π/2), so σ₁ = √2 σ.
    #[inline]
    fn variation(&mut self, h_s: f64) -> f64 {
        if self.variation_n == 0.0 {
            return 0.0;
        }
        let a = (-2.0 * PI * self.variation_hz * h_s).exp();
        let sigma1 = std::f64::consts::SQRT_2 * self.variation_n;
        self.var_stage[0] = a * self.var_stage[0] + (1.0 - a * a).sqrt() * sigma1 * self.noise.gauss();
        self.var_stage[1] += (1.0 - a) * (self.var_stage[0] - self.var_stage[1]);
        self.var_stage[1]
    }

    /// The commanded feed velocity of the plane's axes (mm/s), once per setpoint. The direction
    /// is taken only while the tool cuts: below the engagement speed the force
    /// fades out along the last cutting direction, as the chip thins out, and does not turn with
    /// the small motions of a standstill (a correction's, a settling axis's).
    pub fn set_feed(&mut self, v: [f64; 2]) {
        let speed = v[0].hypot(v[1]);
        self.cutting = speed >= self.engage_speed_mm_s;
        if self.cutting {
            self.dir = [v[0] / speed, v[1] / speed];
        }
    }

    /// Advances the engagement by `h_s` and returns the force on the load along the plane's two
    /// axes at plant time `t_s`, N.
    #[inline]
    pub fn step(&mut self, t_s: f64, h_s: f64) -> [f64; 2] {
        let target = if self.cutting { 1.0 } else { 0.0 };
        self.engage += (target - self.engage) * (h_s / self.engage_time_s).min(1.0);
        let variation = self.variation(h_s);
        if self.engage < 1e-12 {
            return [0.0, 0.0];
        }
        let magnitude = self.force_n
            + self.drift_n * (2.0 * PI * t_s / self.drift_period_s).sin()
            + self.tooth_force_n * (2.0 * PI * self.tooth_hz * t_s).sin()
            + variation;
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

    #[test]
    fn below_the_engagement_speed_the_force_keeps_its_last_direction() {
        let c = MillingConfig { tooth_force_n: 0.0, drift_n: 0.0, ..MillingConfig::default() };
        let mut m = Milling::new(&c, [0, 1]);
        m.set_feed([5.0, 0.0]);
        for k in 0..20_000 {
            m.step(k as f64 * 1e-4, 1e-4);
        }
        // A standstill's small motion across the last feed direction does not turn the force.
        m.set_feed([0.0, -0.05]);
        let f = m.step(2.0, 1e-4);
        assert!(f[0].abs() < 1e-9 && f[1] > 150.0, "{f:?}");
    }

    #[test]
    fn the_variation_has_its_standard_deviation_and_little_content_above_its_band() {
        let c = MillingConfig { tooth_force_n: 0.0, drift_n: 0.0, variation_n: 20.0, ..MillingConfig::default() };
        let mut m = Milling::new(&c, [0, 1]);
        m.set_feed([5.0, 0.0]);
        let h = 1e-4;
        let (mut sum, mut sq, mut n, mut diff_sq) = (0.0, 0.0, 0.0, 0.0);
        let mut last = None;
        for k in 0..(600.0 / h) as usize {
            let f = m.step(k as f64 * h, h)[1];
            if k as f64 * h > 5.0 {
                let v = f - 200.0;
                sum += v;
                sq += v * v;
                n += 1.0;
                if let Some(l) = last {
                    diff_sq += (v - l) * (v - l);
                }
                last = Some(v);
            }
        }
        let std = (sq / n - (sum / n) * (sum / n)).sqrt();
        assert!((std - 20.0).abs() < 2.0, "std {std} N");
        // A second-order band at 2 Hz: the rate's standard deviation is a few σ · 2π f_c.
        let rate = (diff_sq / n).sqrt() / h;
        assert!(rate < 20.0 * 2.0 * PI * 2.0 * 2.0, "rate {rate} N/s");
    }
}
