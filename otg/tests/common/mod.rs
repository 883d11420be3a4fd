//! Shared by the property test and the benchmark: a seeded random problem generator, the Ruckig
//! oracle (the `ruckig` crate, official bindings to the C++ library), and an independent
//! validator that integrates a trajectory and checks target and limits.
#![allow(dead_code)]

use interpd_otg::{ControlInterface, Input, Limits, MAX_DOFS, State, Synchronization, Trajectory};

/// xorshift64* — small, fast, reproducible.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// 10^U(lo_exp, hi_exp).
    pub fn log_uniform(&mut self, lo_exp: f64, hi_exp: f64) -> f64 {
        10f64.powf(self.range(lo_exp, hi_exp))
    }

    pub fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }
}

/// How a problem was generated (for the statistics).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// Consistent units: one length and one time scale (over 6 decades of limits), limits
    /// within a factor 200 of each other; states inside the limits.
    Scaled,
    /// Like `Scaled` but the initial velocity and/or acceleration outside the limits.
    OutsideLimits,
    /// Every limit independently log-uniform in [1e-3, 1e3]: time constants (a/j, v/a) whose
    /// ratios reach 1e12, positions up to 1e10 and durations up to 1e8 s. Ruckig refuses
    /// durations above 7.6e3 s and fails on many of the others; the test then compares with
    /// Ruckig on the time-scaled problem.
    Independent,
    /// Asymmetric limits. The Rust bindings of Ruckig only take symmetric limits: each DoF's
    /// minimum duration is checked against Ruckig's with the loosest and the tightest symmetric
    /// limits around the asymmetric ones.
    Asymmetric,
    /// Velocity interface.
    Velocity,
    /// Collinear input with phase synchronisation.
    Phase,
    /// Small integers (-1, 0, 1 for states, 1 or 2 for limits): exact ties and zero lengths.
    Discrete,
    /// Like `Scaled`, with the duration rounded up to a multiple of a period (no oracle: the
    /// bindings cannot set Ruckig's duration discretisation).
    DiscreteDuration,
}

pub const KINDS: [Kind; 8] = [
    Kind::Scaled,
    Kind::OutsideLimits,
    Kind::Independent,
    Kind::Asymmetric,
    Kind::Velocity,
    Kind::Phase,
    Kind::Discrete,
    Kind::DiscreteDuration,
];

/// Velocity before arrival (see input validation): the target must be reachable inside limits.
pub fn target_is_valid(t: &State, l: &Limits, position: bool) -> bool {
    if t.a > l.a_max || t.a < l.a_min {
        return false;
    }
    if !position {
        return true;
    }
    if t.v > l.v_max || t.v < l.v_min {
        return false;
    }
    let v_before = t.v - t.a * t.a.abs() / (2.0 * l.j_max);
    !((t.a < 0.0 && v_before > l.v_max) || (t.a > 0.0 && v_before < l.v_min))
}

/// A random problem of the given kind with `dofs` DoFs.
pub fn random_problem(rng: &mut Rng, kind: Kind, dofs: usize) -> Input {
    let mut input = Input::new(dofs);
    input.control = if kind == Kind::Velocity { ControlInterface::Velocity } else { ControlInterface::Position };
    input.sync = if kind == Kind::Phase { Synchronization::Phase } else { Synchronization::Time };
    let position = input.control == ControlInterface::Position;
    // One length and time scale per problem.
    let length = rng.log_uniform(-3.0, 3.0);
    let time = rng.log_uniform(-1.0, 1.0);
    if kind == Kind::DiscreteDuration {
        input.discrete_period_s = Some(time * rng.log_uniform(-2.0, -0.5));
    }
    let mut reference: Option<[f64; 5]> = None;
    for dof in 0..dofs {
        loop {
            let lim = match kind {
                Kind::Independent => Limits::symmetric(
                    rng.log_uniform(-3.0, 3.0),
                    rng.log_uniform(-3.0, 3.0),
                    rng.log_uniform(-3.0, 3.0),
                ),
                Kind::Discrete => Limits::symmetric(
                    (1 + rng.next_u64() % 2) as f64,
                    (1 + rng.next_u64() % 2) as f64,
                    (1 + rng.next_u64() % 2) as f64,
                ),
                _ => {
                    let v = length / time * rng.range(0.08, 16.0);
                    let a = length / (time * time) * rng.range(0.08, 16.0);
                    let j = length / (time * time * time) * rng.range(0.08, 16.0);
                    if kind == Kind::Asymmetric {
                        Limits {
                            v_max: v,
                            v_min: -v * rng.log_uniform(-1.0, 1.0),
                            a_max: a,
                            a_min: -a * rng.log_uniform(-1.0, 1.0),
                            j_max: j,
                        }
                    } else {
                        Limits::symmetric(v, a, j)
                    }
                }
            };
            let (vs, as_) = match kind {
                Kind::Independent | Kind::Discrete => (lim.v_max, lim.a_max),
                _ => (length / time, length / (time * time)),
            };
            let ps = match kind {
                Kind::Independent => {
                    lim.v_max * (lim.v_max / lim.a_max + lim.a_max / lim.j_max) * rng.log_uniform(-1.0, 1.0)
                }
                Kind::Discrete => 1.0,
                _ => length,
            };
            let draw = |rng: &mut Rng, p: f64, scale: f64| {
                if kind == Kind::Discrete {
                    (rng.next_u64() % 3) as f64 - 1.0
                } else if rng.chance(p) {
                    0.8 * scale * rng.normal()
                } else {
                    0.0
                }
            };
            let mut current = State { p: 4.0 * ps * rng.normal(), v: draw(rng, 0.9, vs), a: draw(rng, 0.8, as_) };
            let mut target = State { p: 4.0 * ps * rng.normal(), v: draw(rng, 0.7, vs), a: draw(rng, 0.6, as_) };
            if kind == Kind::Discrete {
                current.p = draw(rng, 1.0, 1.0);
                target.p = draw(rng, 1.0, 1.0);
            }
            if kind == Kind::OutsideLimits {
                if rng.chance(0.6) {
                    current.v = lim.v_max * rng.range(1.0, 3.0) * if rng.chance(0.5) { 1.0 } else { -1.0 };
                }
                if rng.chance(0.6) {
                    current.a = lim.a_max * rng.range(0.5, 3.0) * if rng.chance(0.5) { 1.0 } else { -1.0 };
                }
            }
            if let (Kind::Phase, Some(r)) = (kind, reference) {
                // Collinear: every DoF a multiple of the first one's (Δp, v0, a0, vf, af).
                let s = rng.range(-2.0, 2.0);
                target.p = current.p + s * r[0];
                current.v = s * r[1];
                current.a = s * r[2];
                target.v = s * r[3];
                target.a = s * r[4];
            }
            if !target_is_valid(&target, &lim, position) {
                continue;
            }
            if kind != Kind::OutsideLimits && position {
                // Initial state inside the limits and not inevitably leaving them.
                let inside = current.v <= lim.v_max
                    && current.v >= lim.v_min
                    && current.a <= lim.a_max
                    && current.a >= lim.a_min
                    && current.v + current.a * current.a.abs() / (2.0 * lim.j_max) <= lim.v_max
                    && current.v + current.a * current.a.abs() / (2.0 * lim.j_max) >= lim.v_min;
                if !inside {
                    continue;
                }
            }
            if kind == Kind::Phase && dof == 0 {
                reference = Some([target.p - current.p, current.v, current.a, target.v, target.a]);
            }
            input.current[dof] = current;
            input.target[dof] = target;
            input.limits[dof] = lim;
            break;
        }
    }
    input
}

/// Ruckig's result for an input: duration and a handle to sample it.
pub struct RuckigResult {
    pub duration: f64,
    pub trajectory: ruckig::Trajectory,
}

/// Ruckig's solver for a given DoF count, reused across calls.
pub struct RuckigOracle {
    pub dofs: usize,
    pub otg: ruckig::Ruckig,
    pub input: ruckig::InputParameter,
    pub trajectory: ruckig::Trajectory,
}

impl RuckigOracle {
    pub fn new(dofs: usize) -> RuckigOracle {
        RuckigOracle {
            dofs,
            otg: ruckig::Ruckig::new_direct(dofs, 0.001),
            input: ruckig::InputParameter::new(dofs),
            trajectory: ruckig::Trajectory::new_direct(dofs),
        }
    }

    /// Fill Ruckig's input from ours (symmetric limits only).
    pub fn set_input(&mut self, input: &Input) {
        fill_ruckig_input(&mut self.input, input);
    }

    /// A separate Ruckig input for `input` (benchmarks keep one per problem).
    pub fn make_input(&self, input: &Input) -> ruckig::InputParameter {
        let mut ri = ruckig::InputParameter::new(input.dofs);
        fill_ruckig_input(&mut ri, input);
        ri
    }

    /// Calculate; Ok(duration) or Err(Ruckig's result code).
    pub fn calculate(&mut self, input: &Input) -> Result<f64, ruckig::Result> {
        self.set_input(input);
        match self.otg.calculate(&mut self.input, &mut self.trajectory) {
            ruckig::Result::Working | ruckig::Result::Finished => Ok(self.trajectory.get_duration()),
            e => Err(e),
        }
    }
}

/// Fill Ruckig's input from ours (symmetric limits only: the bindings have no minimum limits).
pub fn fill_ruckig_input(ri: &mut ruckig::InputParameter, input: &Input) {
    let n = input.dofs;
    ri.control_interface = match input.control {
        ControlInterface::Position => ruckig::ControlInterface::Position,
        ControlInterface::Velocity => ruckig::ControlInterface::Velocity,
    };
    ri.synchronization = match input.sync {
        Synchronization::Time => ruckig::Synchronization::Time,
        Synchronization::Phase => ruckig::Synchronization::Phase,
        Synchronization::None => ruckig::Synchronization::None,
    };
    ri.current_position = (0..n).map(|d| input.current[d].p).collect();
    ri.current_velocity = (0..n).map(|d| input.current[d].v).collect();
    ri.current_acceleration = (0..n).map(|d| input.current[d].a).collect();
    ri.target_position = (0..n).map(|d| input.target[d].p).collect();
    ri.target_velocity = (0..n).map(|d| input.target[d].v).collect();
    ri.target_acceleration = (0..n).map(|d| input.target[d].a).collect();
    ri.max_velocity = (0..n).map(|d| input.limits[d].v_max).collect();
    ri.max_acceleration = (0..n).map(|d| input.limits[d].a_max).collect();
    ri.max_jerk = (0..n).map(|d| input.limits[d].j_max).collect();
}

/// Tolerances of the independent validation: target within 1e-8 and limits within 1e-9,
/// relative to max(1, magnitude).
pub const TARGET_TOL: f64 = 1e-8;
pub const LIMIT_TOL: f64 = 1e-9;
/// An integrated acceleration within this many ulps (of the values it is computed from) of zero
/// is zero (see `validate_ours`).
pub const ZERO_ACC_ULPS: f64 = 8.0;
/// Dense samples per DoF for the limit check.
pub const SAMPLES: usize = 64;

/// Result of validating one trajectory.
#[derive(Clone, Copy, Debug, Default)]
pub struct Validation {
    pub ok: bool,
    /// Largest final-state error relative to max(1, magnitude) for p, v, a.
    pub target_err: f64,
    /// Largest limit excess relative to the limit (≤ 0: inside).
    pub limit_excess: f64,
    /// Largest deviation of a DoF's own end from the trajectory duration (relative).
    pub sync_err: f64,
    pub reason: &'static str,
    /// The DoF of the first failure.
    pub dof: usize,
    /// The DoF with the largest target error.
    pub worst_target_dof: usize,
}

/// Magnitude of a quantity for the relative target tolerance: max(1, |x| over the motion).
fn magnitude(values: impl Iterator<Item = f64>) -> f64 {
    values.fold(1.0f64, |m, x| m.max(x.abs()))
}

/// Integrate our profile phase by phase from the input's current state (independently of the
/// library's stored boundary states) and check the end state against the target; check the
/// limits at phase boundaries, inside phases where the velocity peaks, and at dense samples
/// (after the brake pre-phase, whose purpose is to bring the state back inside).
pub fn validate_ours(input: &Input, traj: &Trajectory) -> Validation {
    let position = input.control == ControlInterface::Position;
    let mut v = Validation { ok: true, ..Validation::default() };
    let fail = |v: &mut Validation, reason: &'static str, dof: usize| {
        if v.ok {
            v.reason = reason;
            v.dof = dof;
        }
        v.ok = false;
    };
    let duration = traj.duration();
    if !(duration.is_finite() && duration >= 0.0) {
        fail(&mut v, "duration not finite", 0);
        return v;
    }
    for (dof, prof) in traj.profiles().iter().enumerate() {
        let lim = &input.limits[dof];
        let target = input.target[dof];
        let c = input.current[dof];
        // Independent integration.
        let (mut p, mut vel, mut a) = (c.p, c.v, c.a);
        let mut ps = vec![p];
        let mut vs = vec![vel];
        let mut as_ = vec![a];
        // A ramp that ends at zero acceleration leaves a rounding residual in `a` that a long
        // cruise after it would turn into a drift (½·δa·T²); the generator holds exactly a = 0
        // there, and so does this integration: an end acceleration within rounding of zero
        // (relative to the values it was computed from) is zero.
        let step = |t: f64, j: f64, p: &mut f64, vel: &mut f64, a: &mut f64| {
            *p += t * (*vel + t * (*a / 2.0 + t * j / 6.0));
            *vel += t * (*a + t * j / 2.0);
            let a_new = *a + t * j;
            let rounding = ZERO_ACC_ULPS * f64::EPSILON * (a.abs() + (t * j).abs());
            *a = if a_new.abs() <= rounding { 0.0 } else { a_new };
        };
        for k in 0..2 {
            if prof.brake.t[k] > 0.0 {
                step(prof.brake.t[k], prof.brake.j[k], &mut p, &mut vel, &mut a);
            }
        }
        let mut boundary = Vec::with_capacity(8);
        boundary.push((p, vel, a, 0.0f64));
        for k in 0..7 {
            if prof.t[k] < 0.0 || !prof.t[k].is_finite() {
                fail(&mut v, "negative or non-finite phase duration", dof);
            }
            let (pa, va, aa) = (p, vel, a);
            step(prof.t[k], prof.j[k], &mut p, &mut vel, &mut a);
            // Velocity extremum inside the phase.
            if aa * a < 0.0 && prof.j[k] != 0.0 {
                let v_ext = va - aa * aa / (2.0 * prof.j[k]);
                boundary.push((pa, v_ext, 0.0, prof.j[k]));
            }
            boundary.push((p, vel, a, prof.j[k]));
            ps.push(p);
            vs.push(vel);
            as_.push(a);
        }
        let own_end = prof.duration();
        if input.sync != Synchronization::None {
            let e = (own_end - duration).abs() / duration.max(1e-300);
            v.sync_err = v.sync_err.max(if duration > 0.0 { e } else { own_end });
            if e > 1e-9 && (own_end - duration).abs() > 1e-12 {
                fail(&mut v, "DoF does not end at the trajectory duration", dof);
            }
        }
        let mag_p = magnitude(ps.iter().copied().chain([target.p]));
        let mag_v = magnitude(vs.iter().copied().chain([target.v]));
        let mag_a = magnitude(as_.iter().copied().chain([target.a]));
        let mut errs = [(vel - target.v).abs() / mag_v, (a - target.a).abs() / mag_a];
        if !position {
            errs[0] = (vel - target.v).abs() / mag_v;
        }
        let mut err = errs[0].max(errs[1]);
        if position {
            err = err.max((p - target.p).abs() / mag_p);
        }
        if err > v.target_err {
            v.target_err = err;
            v.worst_target_dof = dof;
        }
        if err.is_nan() || err > TARGET_TOL {
            fail(&mut v, "target not reached", dof);
        }
        // Limits at boundaries and extrema, then at dense samples, after the brake pre-phase.
        // A velocity still outside the band after the brake must come back monotonically: until
        // it is inside, only the bound it moves towards is checked.
        let mut excess = 0.0f64;
        let mut recovery = VelocityRecovery::new(boundary[0].1, lim, position);
        for &(_, vel_b, a_b, j_b) in &boundary {
            excess = excess.max(band_excess(a_b, lim.a_max, lim.a_min)).max(band_excess(j_b, lim.j_max, -lim.j_max));
            excess = excess.max(recovery.excess(vel_b));
        }
        let t0 = prof.brake.duration;
        let (first, _) = traj.state_of(dof, t0);
        let mut recovery = VelocityRecovery::new(first.v, lim, position);
        for s in 0..=SAMPLES {
            let t = t0 + (own_end - t0) * s as f64 / SAMPLES as f64;
            let (st, j) = traj.state_of(dof, t);
            excess = excess.max(band_excess(st.a, lim.a_max, lim.a_min)).max(band_excess(j, lim.j_max, -lim.j_max));
            excess = excess.max(recovery.excess(st.v));
        }
        // At the end, the sampled state is the target.
        let (end, _) = traj.state_of(dof, duration);
        let e_end = ((end.v - target.v).abs() / mag_v).max((end.a - target.a).abs() / mag_a).max(if position {
            (end.p - target.p).abs() / mag_p
        } else {
            0.0
        });
        if e_end.is_nan() || e_end > TARGET_TOL {
            fail(&mut v, "sampled end state is not the target", dof);
        }
        v.limit_excess = v.limit_excess.max(excess);
        if excess > LIMIT_TOL {
            fail(&mut v, "limit violated", dof);
        }
    }
    v
}

/// Relative excess of x over [lo, hi] (≤ 0 inside).
fn band_excess(x: f64, hi: f64, lo: f64) -> f64 {
    ((x - hi) / hi.abs()).max((lo - x) / lo.abs())
}

/// Velocity limit check that allows a monotone return from outside the band (after a brake).
struct VelocityRecovery {
    hi: f64,
    lo: f64,
    above: bool,
    below: bool,
    active: bool,
}

impl VelocityRecovery {
    fn new(v0: f64, lim: &Limits, position: bool) -> Self {
        let hi = lim.v_max * (1.0 + LIMIT_TOL);
        let lo = lim.v_min * (1.0 + LIMIT_TOL);
        VelocityRecovery { hi: lim.v_max, lo: lim.v_min, above: v0 > hi, below: v0 < lo, active: position }
    }

    fn excess(&mut self, v: f64) -> f64 {
        if !self.active {
            return f64::NEG_INFINITY;
        }
        let mut e = f64::NEG_INFINITY;
        if !self.above {
            e = e.max((v - self.hi) / self.hi.abs());
        }
        if !self.below {
            e = e.max((self.lo - v) / self.lo.abs());
        }
        self.above &= v > self.hi * (1.0 + LIMIT_TOL);
        self.below &= v < self.lo * (1.0 + LIMIT_TOL);
        e
    }
}

/// Validate Ruckig's trajectory by sampling it (its phases are not exposed by the bindings):
/// end state at its duration, limits at dense samples after `skip[dof]` (the brake pre-phase).
pub fn validate_ruckig(input: &Input, oracle: &RuckigOracle, skip: &[f64]) -> Validation {
    let position = input.control == ControlInterface::Position;
    let mut v = Validation { ok: true, ..Validation::default() };
    let traj = &oracle.trajectory;
    let duration = traj.get_duration();
    let n = input.dofs;
    let (p_end, v_end, a_end) = traj.at_time(duration);
    let mut max_p = vec![1.0f64; n];
    v.limit_excess = f64::NEG_INFINITY;
    let samples = 4 * SAMPLES;
    let mut recoveries: Vec<Option<VelocityRecovery>> = (0..n).map(|_| None).collect();
    for s in 0..=samples {
        let t = duration * s as f64 / samples as f64;
        let (ps, vs, as_) = traj.at_time(t);
        for d in 0..n {
            let lim = &input.limits[d];
            max_p[d] = max_p[d].max(ps[d].abs());
            if t < skip[d] {
                continue;
            }
            let rec = recoveries[d].get_or_insert_with(|| VelocityRecovery::new(vs[d], lim, position));
            let excess = band_excess(as_[d], lim.a_max, lim.a_min).max(rec.excess(vs[d]));
            v.limit_excess = v.limit_excess.max(excess);
        }
    }
    if v.limit_excess > LIMIT_TOL {
        v.ok = false;
        v.reason = "limit violated";
    }
    for d in 0..n {
        let t = input.target[d];
        let mut err = ((v_end[d] - t.v).abs() / t.v.abs().max(1.0)).max((a_end[d] - t.a).abs() / t.a.abs().max(1.0));
        if position {
            err = err.max((p_end[d] - t.p).abs() / max_p[d].max(t.p.abs()));
        }
        v.target_err = v.target_err.max(err);
    }
    if v.target_err.is_nan() || v.target_err > TARGET_TOL {
        v.ok = false;
        v.reason = "target not reached";
    }
    v
}

/// MAX_DOFS re-export for convenience.
pub const CAPACITY: usize = MAX_DOFS;

/// One DoF of a problem as a literal: `[p0, v0, a0, pf, vf, af, v_min, v_max, a_min, a_max, j_max]`.
pub type DofCase = [f64; 11];

/// An input as a pasteable Rust literal (full precision): `case("Position/Time", &[[...], ...])`,
/// the form the regression tests and `examples/inspect.rs` take.
pub fn fmt_input(input: &Input) -> String {
    let mut s = format!("case(\"{:?}/{:?}\", &[", input.control, input.sync);
    for d in 0..input.dofs {
        let (c, t, l) = (input.current[d], input.target[d], input.limits[d]);
        let values = [c.p, c.v, c.a, t.p, t.v, t.a, l.v_min, l.v_max, l.a_min, l.a_max, l.j_max];
        let items: Vec<String> = values.iter().map(|x| format!("{x:?}")).collect();
        s += &format!("\n    [{}],", items.join(", "));
    }
    s + "\n])"
}

/// The input of a case literal (see [`fmt_input`]); `mode` is "Position/Time", "Velocity/Phase", ...
pub fn case(mode: &str, dofs: &[DofCase]) -> Input {
    let mut input = Input::new(dofs.len());
    input.control = if mode.contains("Velocity") { ControlInterface::Velocity } else { ControlInterface::Position };
    input.sync = if mode.contains("Phase") {
        Synchronization::Phase
    } else if mode.contains("None") {
        Synchronization::None
    } else {
        Synchronization::Time
    };
    for (d, x) in dofs.iter().enumerate() {
        input.current[d] = State { p: x[0], v: x[1], a: x[2] };
        input.target[d] = State { p: x[3], v: x[4], a: x[5] };
        input.limits[d] = Limits { v_min: x[6], v_max: x[7], a_min: x[8], a_max: x[9], j_max: x[10] };
    }
    input
}

/// Parse the text of a case literal (whitespace and the `case(` wrapper are optional).
pub fn parse_case(text: &str) -> Option<Input> {
    let body = &text[text.find("&[")? + 2..];
    let mut dofs = Vec::new();
    for chunk in body.split('[').skip(1) {
        let inner = chunk.split(']').next()?;
        let values: Vec<f64> =
            inner.split(',').filter(|x| !x.trim().is_empty()).map(|x| x.trim().parse().ok()).collect::<Option<_>>()?;
        dofs.push(<DofCase>::try_from(values.as_slice()).ok()?);
    }
    (!dofs.is_empty()).then(|| case(text, &dofs))
}

/// Durations agree within this (relative).
pub const DURATION_REL_TOL: f64 = 1e-6;
/// Ruckig refuses trajectories longer than this (`ErrorTrajectoryDuration`).
pub const RUCKIG_MAX_DURATION_S: f64 = 7.6e3;
/// Duration the time-scaled problem is given for Ruckig [s].
pub const SCALED_DURATION_S: f64 = 1e3;

/// How one problem went.
#[derive(Debug)]
pub enum Outcome {
    /// Same duration as Ruckig (on the problem itself, or on the time-scaled problem).
    Equal { scaled: bool, rel: f64 },
    /// Ours is shorter and Ruckig's trajectory is valid: Ruckig missed the optimum.
    OursShorterValid,
    /// The durations differ and Ruckig's trajectory is invalid.
    RuckigInvalid,
    /// Ruckig returned an error (and the time-scaled problem did not help).
    RuckigError(String),
    /// No duration oracle (asymmetric limits, discrete durations); the checks of the kind held.
    Checked,
    /// A failure of ours: class and details.
    Failed(String, String),
}

/// The same problem `k` times faster: durations divided by k.
pub fn time_scaled(input: &Input, k: f64) -> Input {
    let mut out = *input;
    let scale = |s: &State| State { p: s.p, v: s.v * k, a: s.a * k * k };
    for d in 0..input.dofs {
        out.current[d] = scale(&input.current[d]);
        out.target[d] = scale(&input.target[d]);
        let l = input.limits[d];
        out.limits[d] = Limits {
            v_max: l.v_max * k,
            v_min: l.v_min * k,
            a_max: l.a_max * k * k,
            a_min: l.a_min * k * k,
            j_max: l.j_max * k * k * k,
        };
    }
    out
}

/// Compare our duration with Ruckig's; where they differ, validate Ruckig's trajectory.
pub fn compare_with_ruckig(input: &Input, traj: &Trajectory, oracle: &mut RuckigOracle) -> Outcome {
    let d_ours = traj.duration();
    let brakes: Vec<f64> = traj.profiles().iter().map(|p| p.brake.duration).collect();
    let (problem, k, d_ruckig) = match oracle.calculate(input) {
        Ok(d) => (*input, 1.0, d),
        Err(ruckig::Result::ErrorTrajectoryDuration) if d_ours > RUCKIG_MAX_DURATION_S => {
            let k = d_ours / SCALED_DURATION_S;
            let scaled = time_scaled(input, k);
            match oracle.calculate(&scaled) {
                Ok(d) => (scaled, k, d * k),
                Err(e) => return Outcome::RuckigError(format!("{e:?} (time-scaled)")),
            }
        }
        Err(e) => return Outcome::RuckigError(format!("{e:?}")),
    };
    let diff = (d_ours - d_ruckig).abs();
    let rel = diff / d_ours.max(d_ruckig).max(f64::MIN_POSITIVE);
    if rel <= DURATION_REL_TOL || diff < 1e-12 {
        return Outcome::Equal { scaled: k != 1.0, rel };
    }
    let skip: Vec<f64> = brakes.iter().map(|b| b / k).collect();
    let rv = validate_ruckig(&problem, oracle, &skip);
    if !rv.ok {
        Outcome::RuckigInvalid
    } else if d_ours < d_ruckig {
        Outcome::OursShorterValid
    } else {
        Outcome::Failed(
            "not optimal".into(),
            format!("ours {d_ours} > ruckig {d_ruckig} (valid, time scale {k}): {}", fmt_input(input)),
        )
    }
}
