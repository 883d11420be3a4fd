//! The plant's sensors as Schneider 2016 had them: a force/torque signal at the load (noise of
//! a few N, an offset that drifts, §1.7/§5) and an external measurement of the tool position
//! (optical tracker: noise, a measurement cycle of its own of 2.3 ms and a dead time of about
//! 1.7 ms + 2 ms from the measured instant to its arrival, §4.2).
//!
//! The position is sampled on its own cycle in plant time; each sample becomes available one
//! dead time later. Samples wait in fixed rings (no allocation per step); the front end takes
//! the arrived ones with [`Sensors::pop`].

use crate::noise::Noise;
use interpd_config::plant::MeasurementConfig;
use interpd_protocol::MAX_AXES;

/// Samples in flight (measured, not yet arrived) and arrived, not yet taken: the dead time is
/// at most 100 ms, 44 cycles of 2.3 ms; the front end takes samples at least every setpoint.
const RING: usize = 64;

/// One arrived measurement, in axis units (mm) and N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub seq: u64,
    pub measured_ns: u64,
    pub arrived_ns: u64,
    /// Measured tool position, axis unit.
    pub tool_pos: [f64; MAX_AXES],
    /// Force signal at arrival, N (along the axis, positive towards positive positions).
    pub force_n: [f64; MAX_AXES],
    /// Actuator position at arrival (its own fast sensor), axis unit.
    pub actuator_pos: [f64; MAX_AXES],
}

impl Default for Sample {
    fn default() -> Self {
        Self {
            seq: 0,
            measured_ns: 0,
            arrived_ns: 0,
            tool_pos: [0.0; MAX_AXES],
            force_n: [0.0; MAX_AXES],
            actuator_pos: [0.0; MAX_AXES],
        }
    }
}

/// A fixed-capacity FIFO of samples.
#[derive(Debug, Clone)]
struct Ring {
    buf: [Sample; RING],
    head: usize,
    len: usize,
}

impl Ring {
    fn new() -> Self {
        Self { buf: [Sample::default(); RING], head: 0, len: 0 }
    }
    fn push(&mut self, s: Sample) -> bool {
        if self.len == RING {
            return false;
        }
        self.buf[(self.head + self.len) % RING] = s;
        self.len += 1;
        true
    }
    fn front(&self) -> Option<&Sample> {
        (self.len > 0).then(|| &self.buf[self.head])
    }
    fn pop(&mut self) -> Option<Sample> {
        let s = *self.front()?;
        self.head = (self.head + 1) % RING;
        self.len -= 1;
        Some(s)
    }
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// The sensors of one plant.
#[derive(Debug, Clone)]
pub struct Sensors {
    n_axes: usize,
    period_ns: u64,
    dead_ns: u64,
    pos_sigma_mm: f64,
    force_sigma_n: f64,
    force_drift_n_per_s: f64,
    force_drift_period_s: f64,
    noise: Noise,
    next_sample_ns: Option<u64>,
    seq: u64,
    in_flight: Ring,
    arrived: Ring,
    /// Samples lost because nobody took them.
    pub dropped: u64,
}

impl Sensors {
    pub fn new(c: &MeasurementConfig, n_axes: usize) -> Self {
        Self {
            n_axes,
            period_ns: (c.position_period_ms * 1e6).round() as u64,
            dead_ns: (c.position_dead_time_ms * 1e6).round() as u64,
            pos_sigma_mm: c.position_noise_um * 1e-3,
            force_sigma_n: c.force_noise_n,
            force_drift_n_per_s: c.force_drift_n_per_s,
            force_drift_period_s: c.force_drift_period_s,
            noise: Noise::new(c.seed),
            next_sample_ns: None,
            seq: 0,
            in_flight: Ring::new(),
            arrived: Ring::new(),
            dropped: 0,
        }
    }

    /// Dead time, ns.
    pub fn dead_time_ns(&self) -> u64 {
        self.dead_ns
    }

    /// Restarts the measurement cycle at `t_ns` (nothing in flight; the first sample one
    /// period later).
    pub fn reset(&mut self, t_ns: u64) {
        self.next_sample_ns = Some(t_ns + self.period_ns);
        self.in_flight.clear();
        self.arrived.clear();
    }

    /// After a servo step ending at `t_ns` (`t_s` plant seconds): takes a position sample when
    /// its cycle is due and moves samples whose dead time has passed to the arrived queue,
    /// adding the force signal and actuator position of that instant. `truth(i)` gives axis
    /// i's true tool position (axis unit), force on the load (N) and actuator position.
    #[inline]
    pub fn after_step(&mut self, t_ns: u64, t_s: f64, truth: impl Fn(usize) -> [f64; 3]) {
        let next = *self.next_sample_ns.get_or_insert(t_ns);
        if t_ns >= next {
            let mut s =
                Sample { seq: self.seq, measured_ns: t_ns, arrived_ns: t_ns + self.dead_ns, ..Sample::default() };
            for i in 0..self.n_axes {
                s.tool_pos[i] = truth(i)[0] + self.pos_sigma_mm * self.noise.gauss();
            }
            self.seq += 1;
            if !self.in_flight.push(s) {
                self.dropped += 1;
            }
            // The cycle runs on its own clock: the next instant is one period after the last.
            self.next_sample_ns = Some(next + self.period_ns);
        }
        while self.in_flight.front().is_some_and(|s| s.arrived_ns <= t_ns) {
            if let Some(mut s) = self.in_flight.pop() {
                for i in 0..self.n_axes {
                    let [_, f, a] = truth(i);
                    s.force_n[i] = self.force_signal(f, t_s);
                    s.actuator_pos[i] = a;
                }
                if !self.arrived.push(s) {
                    self.dropped += 1;
                }
            }
        }
    }

    /// The next arrived sample.
    pub fn pop(&mut self) -> Option<Sample> {
        self.arrived.pop()
    }

    /// The force signal for the true force `f_n` on the load at plant time `t_s`: noise plus a
    /// drifting offset (a triangle of slope ± drift rate).
    pub fn force_signal(&mut self, f_n: f64, t_s: f64) -> f64 {
        let p = self.force_drift_period_s;
        let phase = (t_s / p).rem_euclid(1.0);
        let tri = if phase < 0.5 { phase } else { 1.0 - phase };
        f_n + self.force_drift_n_per_s * p * tri + self.force_sigma_n * self.noise.gauss()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_arrive_one_dead_time_after_their_cycle() {
        let c = MeasurementConfig { position_noise_um: 0.0, ..MeasurementConfig::default() };
        let mut s = Sensors::new(&c, 1);
        s.reset(0);
        let mut got = Vec::new();
        for k in 1..=200u64 {
            let t = k * 100_000;
            s.after_step(t, t as f64 * 1e-9, |_| [t as f64, 0.0, 0.0]);
            while let Some(x) = s.pop() {
                got.push(x);
            }
        }
        // 20 ms: samples at 2.3, 4.6, 6.9 … ms, each arriving 3.7 ms later.
        assert!(got.len() >= 7, "{}", got.len());
        assert_eq!(got[0].measured_ns, 2_300_000);
        for w in got.windows(2) {
            assert_eq!(w[1].measured_ns - w[0].measured_ns, 2_300_000);
        }
        for x in &got {
            assert_eq!(x.arrived_ns - x.measured_ns, 3_700_000);
            assert_eq!(x.tool_pos[0], x.measured_ns as f64, "the value of the measured instant");
        }
    }
}
