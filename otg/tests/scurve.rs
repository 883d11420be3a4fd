//! The closed forms of `interpd_otg::scurve` against the general solver: on random moves from
//! rest to rest and random brakes to rest, over six decades of limits, the durations agree to
//! 1e-12 (relative), and the closed-form phases integrate onto the target within the limits.

use interpd_otg::scurve::{brake_to_rest, rest_to_rest};
use interpd_otg::{ControlInterface, Input, Limits, Otg, State, Trajectory};

/// Random problems per kind.
const PROBLEMS: usize = 20_000;
/// Relative agreement of the durations.
const DURATION_REL_TOL: f64 = 1e-12;

struct Rng(u64);

impl Rng {
    /// Uniform in [0, 1) (xorshift64*).
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Log-uniform over `decades` decades around 1.
    fn magnitude(&mut self, decades: f64) -> f64 {
        10f64.powf(decades * (self.unit() - 0.5))
    }
}

/// Integrates constant-jerk phases from (v, a): the distance covered and the end state, with the
/// largest |v| and |a| on the way (at phase ends, where the extremes of these profiles lie).
fn integrate(phases: &[(f64, f64)], mut v: f64, mut a: f64) -> (f64, f64, f64, f64, f64) {
    let (mut s, mut v_peak, mut a_peak) = (0.0, v.abs(), a.abs());
    for &(t, j) in phases {
        assert!(t >= 0.0, "negative phase duration {t}");
        s += v * t + a * t * t / 2.0 + j * t * t * t / 6.0;
        v += a * t + j * t * t / 2.0;
        a += j * t;
        v_peak = v_peak.max(v.abs());
        a_peak = a_peak.max(a.abs());
    }
    (s, v, a, v_peak, a_peak)
}

fn general_duration(input: &Input) -> f64 {
    let mut trajectory = Trajectory::default();
    Otg::new().calculate(input, &mut trajectory).expect("the general solver finds a profile");
    trajectory.duration()
}

#[test]
fn rest_to_rest_equals_the_general_solver() {
    let mut rng = Rng(0x5eed_0001);
    for _ in 0..PROBLEMS {
        let (length, v, a, j) = (rng.magnitude(6.0), rng.magnitude(6.0), rng.magnitude(6.0), rng.magnitude(6.0));
        let phases = rest_to_rest(length, v, a, j);
        let closed: f64 = phases.iter().map(|p| p.0).sum();
        let mut input = Input::new(1);
        input.target[0] = State { p: length, v: 0.0, a: 0.0 };
        input.limits[0] = Limits::symmetric(v, a, j);
        let general = general_duration(&input);
        assert!(
            (closed - general).abs() <= DURATION_REL_TOL * general,
            "L {length}, v {v}, a {a}, j {j}: closed form {closed} s, general {general} s"
        );
        let (s, v_end, a_end, v_peak, a_peak) = integrate(&phases, 0.0, 0.0);
        assert!((s - length).abs() <= 1e-9 * length, "covers {s} of {length}");
        assert!(v_end.abs() <= 1e-9 * v && a_end.abs() <= 1e-6 * a, "ends at ({v_end}, {a_end})");
        assert!(v_peak <= v * (1.0 + 1e-12) && a_peak <= a * (1.0 + 1e-12), "peaks {v_peak}, {a_peak}");
    }
}

#[test]
fn brake_to_rest_equals_the_general_solver() {
    let mut rng = Rng(0x5eed_0002);
    let mut checked = 0;
    while checked < PROBLEMS {
        let (acc, jerk) = (rng.magnitude(6.0), rng.magnitude(6.0));
        let v0 = rng.magnitude(6.0);
        let a0 = acc * (2.0 * rng.unit() - 1.0);
        if a0 < 0.0 && v0 <= a0 * a0 / (2.0 * jerk) {
            // Releasing the deceleration at once would reverse: callers exclude these states.
            continue;
        }
        let phases = brake_to_rest(v0, a0, acc, jerk);
        let closed: f64 = phases.iter().map(|p| p.0).sum();
        let mut input = Input::new(1);
        input.control = ControlInterface::Velocity;
        input.current[0] = State { p: 0.0, v: v0, a: a0 };
        input.limits[0] = Limits { v_max: f64::MAX, v_min: -f64::MAX, a_max: acc, a_min: -acc, j_max: jerk };
        let general = general_duration(&input);
        assert!(
            (closed - general).abs() <= DURATION_REL_TOL * general.max(f64::MIN_POSITIVE),
            "v0 {v0}, a0 {a0}, acc {acc}, jerk {jerk}: closed form {closed} s, general {general} s"
        );
        let (_, v_end, a_end, _, a_peak) = integrate(&phases, v0, a0);
        assert!(v_end.abs() <= 1e-9 * v0.max(acc * acc / jerk), "ends at v {v_end}");
        assert!(a_end.abs() <= 1e-6 * acc && a_peak <= acc * (1.0 + 1e-12), "a end {a_end}, peak {a_peak}");
        checked += 1;
    }
}
