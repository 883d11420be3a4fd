//! The single-DoF motion: an optional brake pre-phase and seven constant-jerk phases, the states
//! at the phase boundaries, and the check that accepts a candidate only if it reaches the target
//! and respects every limit (Berscheid & Kröger, RSS 2021, Sec. IV: every candidate profile of
//! step 1 and step 2 is integrated and checked).
//!
//! Ported from Ruckig's `profile.hpp` (MIT licence, <https://github.com/pantor/ruckig>): the
//! same phase bookkeeping and the same checks, so that candidates are accepted or rejected as in
//! Ruckig. Two deliberate differences: the limit margins are relative to the limits, and the
//! target precisions are relative to max(1, magnitude of the quantity along the profile)
//! (Ruckig's are absolute and tuned for SI units near 1; interpd's limits span six decades).

use crate::brake::BrakeProfile;

/// Margin on velocity and acceleration limits, relative to the limit (Ruckig: 1e-12 absolute).
const LIMIT_EPS_REL: f64 = 1e-12;
/// Margin on a reduced jerk, relative to the jerk limit (Ruckig: 1e-12 absolute).
pub(crate) const JERK_EPS_REL: f64 = 1e-12;
/// Target precision of the position, relative to max(1, |p| along the profile) (Ruckig: 1e-8).
const P_PRECISION: f64 = 1e-8;
/// Target precision of the velocity, relative to max(1, |v| along the profile) (Ruckig: 1e-8).
const V_PRECISION: f64 = 1e-8;
/// Target precision of the acceleration, relative to max(1, |a| along the profile) (Ruckig: 1e-10).
const A_PRECISION: f64 = 1e-10;
/// Profiles longer than this are rejected as numerically meaningless [s] (Ruckig: 1e12).
const T_MAX_S: f64 = 1e12;
/// Phases that must have a positive length (a plateau at a limit) must be longer than this [s].
const T_EPS_S: f64 = f64::EPSILON;
/// Refinement runs when a final profile's phases, integrated from the start (pinned plateau
/// accelerations as they come out, unless within rounding), miss the end state by more than
/// this, relative to max(1, magnitude of the quantity along the profile): well above rounding,
/// well below the target precisions.
const REFINE_TRIGGER: f64 = 1e-12;
/// Refinement stops once every scaled residual is below this.
const REFINE_GOAL: f64 = 2.0 * f64::EPSILON;
/// A refined candidate replaces the original only if its scaled residuals are below this.
const REFINE_ACCEPT: f64 = 1e-11;
/// An iteration that does not reduce the residual below this fraction of the best so far has
/// reached the rounding floor.
const REFINE_PROGRESS: f64 = 0.5;
/// Newton iterations of the refinement (quadratic convergence from ~1e-9 needs two).
const REFINE_ITERATIONS: usize = 6;
/// A pinned acceleration this many ulps (of the values it is computed from) off its value is
/// that value: the resolution of the phase durations (the test's integration does the same).
const PIN_ROUNDING_ULPS: f64 = 8.0;
/// A plateau acceleration within this (relative to the acceleration limit) of a limit or of zero
/// is held exactly there by the refinement.
const PIN_DETECT_REL: f64 = 1e-9;
/// Products a_i·a_{i+1} below -this mark a zero crossing of the acceleration inside a phase.
const A_SIGN_CHANGE_EPS: f64 = f64::EPSILON;

/// Which limits a profile reaches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReachedLimits {
    /// Both acceleration limits and the velocity limit.
    Acc0Acc1Vel,
    /// Only the velocity limit.
    Vel,
    /// The acceleration limit while speeding up.
    Acc0,
    /// The acceleration limit while slowing down.
    Acc1,
    /// Both acceleration limits.
    Acc0Acc1,
    /// Acceleration limit while speeding up and the velocity limit.
    Acc0Vel,
    /// Acceleration limit while slowing down and the velocity limit.
    Acc1Vel,
    /// No limit.
    #[default]
    None,
}

impl ReachedLimits {
    /// Profiles with a cruise phase at the velocity limit.
    #[inline]
    const fn has_cruise(self) -> bool {
        matches!(
            self,
            ReachedLimits::Acc0Acc1Vel | ReachedLimits::Acc0Vel | ReachedLimits::Acc1Vel | ReachedLimits::Vel
        )
    }
}

/// Sign of the first jerk phase: motion towards the upper (`Up`) or the lower limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Direction {
    #[default]
    Up,
    Down,
}

/// Sign pattern of the four jerk phases.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ControlSigns {
    /// up, down, down, up
    #[default]
    Uddu,
    /// up, down, up, down
    Udud,
}

/// One DoF's motion: a brake pre-phase (possibly empty) followed by seven constant-jerk phases.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Profile {
    /// Phase durations [s].
    pub t: [f64; 7],
    /// End time of each phase, measured from the end of the brake pre-phase [s].
    pub t_sum: [f64; 7],
    /// Jerk of each phase.
    pub j: [f64; 7],
    /// Acceleration at the phase boundaries (index 0: start of the main profile, 7: its end).
    pub a: [f64; 8],
    /// Velocity at the phase boundaries.
    pub v: [f64; 8],
    /// Position at the phase boundaries.
    pub p: [f64; 8],
    /// Pre-phase that brings an out-of-limit initial state back inside the limits.
    pub brake: BrakeProfile,
    /// Target position.
    pub pf: f64,
    /// Target velocity.
    pub vf: f64,
    /// Target acceleration.
    pub af: f64,
    /// Limits reached.
    pub limits: ReachedLimits,
    /// Direction of the first jerk phase.
    pub direction: Direction,
    /// Jerk sign pattern.
    pub control_signs: ControlSigns,
}

/// What a candidate is checked against.
struct Candidate {
    signs: ControlSigns,
    limits: ReachedLimits,
    set_limits: bool,
    jf: f64,
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
}

/// One equation of the refinement.
#[derive(Clone, Copy)]
enum Row {
    EndA,
    EndV,
    EndP,
    Duration(f64),
    /// The acceleration at the start of phase `.0` equals its pinned value.
    Pin(usize),
}

/// Solution of the m×n system `J x = r` (m, n ≤ 7) by Householder QR: the minimum-norm solution
/// if it is underdetermined (m ≤ n, QR of Jᵀ), the least-squares one otherwise (QR of J). No
/// normal equations, so the condition number is not squared. `None` if J is rank-deficient.
fn solve_small(jac: &[[f64; 7]; 7], rhs: &[f64; 7], m: usize, n: usize) -> Option<[f64; 7]> {
    // A is rows × cols with rows ≥ cols: Jᵀ (n × m) or J (m × n).
    let transpose = m <= n;
    let (rows, cols) = if transpose { (n, m) } else { (m, n) };
    let mut qr = [[0.0f64; 7]; 7];
    for r in 0..rows {
        for c in 0..cols {
            qr[r][c] = if transpose { jac[c][r] } else { jac[r][c] };
        }
    }
    // Householder vectors are kept below the diagonal, R on and above it.
    let mut diag = [0.0f64; 7];
    let mut column_norm = [0.0f64; 7];
    for (c, norm) in column_norm.iter_mut().enumerate().take(cols) {
        *norm = (0..rows).map(|r| qr[r][c] * qr[r][c]).sum::<f64>().sqrt();
    }
    for k in 0..cols {
        // What is left of column k after removing its components along the previous ones.
        let norm = (k..rows).map(|r| qr[r][k] * qr[r][k]).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= RANK_TOLERANCE * column_norm[k] {
            return None;
        }
        let alpha = if qr[k][k] > 0.0 { -norm } else { norm };
        qr[k][k] -= alpha;
        let vnorm2: f64 = (k..rows).map(|r| qr[r][k] * qr[r][k]).sum();
        for c in k + 1..cols {
            let dot: f64 = (k..rows).map(|r| qr[r][k] * qr[r][c]).sum();
            let f = 2.0 * dot / vnorm2;
            for row in qr.iter_mut().take(rows).skip(k) {
                row[c] -= f * row[k];
            }
        }
        diag[k] = alpha;
        // Store the reflector normalised so that it can be applied later.
        let scale = (2.0 / vnorm2).sqrt();
        for row in qr.iter_mut().take(rows).skip(k) {
            row[k] *= scale;
        }
    }
    let r_at = |r: usize, c: usize| if r == c { diag[r] } else { qr[r][c] };
    let apply_reflector = |x: &mut [f64; 7], k: usize| {
        let dot: f64 = (k..rows).map(|r| qr[r][k] * x[r]).sum();
        for (r, xr) in x.iter_mut().enumerate().take(rows).skip(k) {
            *xr -= dot * qr[r][k];
        }
    };
    let mut x = [0.0f64; 7];
    if transpose {
        // J = Rᵀ Qᵀ: solve Rᵀ y = r (forward), then x = Q [y; 0].
        for c in 0..cols {
            let s: f64 = (0..c).map(|k| r_at(k, c) * x[k]).sum();
            x[c] = (rhs[c] - s) / r_at(c, c);
        }
        for k in (0..cols).rev() {
            apply_reflector(&mut x, k);
        }
    } else {
        // J = Q R: x = R⁻¹ (Qᵀ r)[..n].
        let mut y = *rhs;
        for k in 0..cols {
            apply_reflector(&mut y, k);
        }
        for c in (0..cols).rev() {
            let s: f64 = (c + 1..cols).map(|k| r_at(c, k) * x[k]).sum();
            x[c] = (y[c] - s) / r_at(c, c);
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// A column of the refinement's system whose part independent of the previous columns is
/// shorter than this (relative to its length) makes the system rank-deficient.
const RANK_TOLERANCE: f64 = 1e-13;

/// Integrate one constant-jerk phase: (p, v, a) after `t` seconds.
#[inline]
pub(crate) fn integrate(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    (p + t * (v + t * (a / 2.0 + t * j / 6.0)), v + t * (a + t * j / 2.0), a + t * j)
}

/// max(1, |x_i|, |extra|).
#[inline]
fn magnitude(values: &[f64], extra: f64) -> f64 {
    values.iter().fold(extra.abs().max(1.0), |m, x| m.max(x.abs()))
}

/// max(|x_i|, |extra|), or 1 if all are zero.
#[inline]
fn magnitude_or_one(values: &[f64], extra: f64) -> f64 {
    let m = values.iter().fold(extra.abs(), |m, x| m.max(x.abs()));
    if m > 0.0 { m } else { 1.0 }
}

/// `|x - target| < precision · max(1, magnitude)`, the magnitude computed only when needed.
#[inline]
fn within_precision(x: f64, target: f64, precision: f64, along: &[f64]) -> bool {
    let err = (x - target).abs();
    err < precision || err < precision * magnitude(along, target)
}

impl Profile {
    /// Duration of the brake pre-phase and the seven phases [s].
    #[inline]
    pub fn duration(&self) -> f64 {
        self.brake.duration + self.t_sum[6]
    }

    /// The jerk of the first ramp direction (+j of a UDDU/UDUD profile going up), recovered from
    /// the phases that are not empty; `j` phases all have this magnitude.
    pub(crate) fn ramp_jerk(&self) -> f64 {
        let signs = match self.control_signs {
            ControlSigns::Uddu => [1.0, -1.0, -1.0, 1.0],
            ControlSigns::Udud => [1.0, -1.0, 1.0, -1.0],
        };
        for (k, sign) in signs.into_iter().enumerate() {
            if self.t[2 * k] > 0.0 && self.j[2 * k] != 0.0 {
                return sign * self.j[2 * k];
            }
        }
        0.0
    }

    /// Check phase durations ≥ 0 and fill `t_sum`; false for a negative duration.
    #[inline]
    fn fill_t_sum(&mut self) -> bool {
        if self.t[0] < 0.0 {
            return false;
        }
        self.t_sum[0] = self.t[0];
        for i in 0..6 {
            if self.t[i + 1] < 0.0 {
                return false;
            }
            self.t_sum[i + 1] = self.t_sum[i] + self.t[i + 1];
        }
        true
    }

    /// Jerks of the four ramps for the sign pattern (zero for empty phases).
    #[inline]
    fn set_jerks(&mut self, signs: ControlSigns, jf: f64) {
        let (s4, s6) = match signs {
            ControlSigns::Uddu => (-1.0, 1.0),
            ControlSigns::Udud => (1.0, -1.0),
        };
        let on = |t: f64, j: f64| if t > 0.0 { j } else { 0.0 };
        self.j = [on(self.t[0], jf), 0.0, on(self.t[2], -jf), 0.0, on(self.t[4], s4 * jf), 0.0, on(self.t[6], s6 * jf)];
    }

    /// Step 1, position interface: integrate the candidate (durations in `t`) with jerk `jf` and
    /// accept it if it reaches the target and respects the limits. The limits are given in the
    /// direction of the profile (mirrored for `Down`). `set_limits` pins the plateau
    /// accelerations to the limits they are known to equal (removes rounding).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check(
        &mut self,
        signs: ControlSigns,
        limits: ReachedLimits,
        set_limits: bool,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits, jf, v_max, v_min, a_max, a_min };
        self.check_position(&c)
    }

    /// Step 2, position interface: like [`Profile::check`] for a profile that must last `tf`.
    /// The duration itself is not checked (as in Ruckig): every step-2 family computes one phase
    /// as tf minus the others; the parameter keeps the call sites readable.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_with_timing(
        &mut self,
        _tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max, v_min, a_max, a_min };
        self.check_position(&c)
    }

    /// [`Profile::check_with_timing`] with a jerk `jf` that may be below the limit `j_max`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_with_timing_and_jerk(
        &mut self,
        tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        v_max: f64,
        v_min: f64,
        a_max: f64,
        a_min: f64,
        j_max: f64,
    ) -> bool {
        jf.abs() < j_max.abs() * (1.0 + JERK_EPS_REL)
            && self.check_with_timing(tf, signs, limits, jf, v_max, v_min, a_max, a_min)
    }

    /// The check of the position interface (Ruckig's `Profile::check`), followed by the
    /// refinement of an accepted candidate whose end state or pinned plateaus are off by more
    /// than rounding.
    fn check_position(&mut self, c: &Candidate) -> bool {
        if !self.fill_t_sum() {
            return false;
        }
        let limits = c.limits;
        if limits.has_cruise() && self.t[3] < T_EPS_S {
            return false;
        }
        if matches!(limits, ReachedLimits::Acc0 | ReachedLimits::Acc0Acc1) && self.t[1] < T_EPS_S {
            return false;
        }
        if matches!(limits, ReachedLimits::Acc1 | ReachedLimits::Acc0Acc1) && self.t[5] < T_EPS_S {
            return false;
        }
        if self.t_sum[6] > T_MAX_S {
            return false;
        }
        self.set_jerks(c.signs, c.jf);

        let up = c.v_max > 0.0;
        self.direction = if up { Direction::Up } else { Direction::Down };
        let v_eps = LIMIT_EPS_REL * c.v_max.abs().max(c.v_min.abs());
        let v_upp = if up { c.v_max } else { c.v_min } + v_eps;
        let v_low = if up { c.v_min } else { c.v_max } - v_eps;
        let zero_at_3 = limits.has_cruise() || limits == ReachedLimits::Acc0Acc1;

        for i in 0..7 {
            let (t, j) = (self.t[i], self.j[i]);
            self.a[i + 1] = self.a[i] + t * j;
            self.v[i + 1] = self.v[i] + t * (self.a[i] + t * j / 2.0);
            self.p[i + 1] = self.p[i] + t * (self.v[i] + t * (self.a[i] / 2.0 + t * j / 6.0));

            let pin = if zero_at_3 && i == 2 {
                Some(0.0)
            } else if c.set_limits && limits == ReachedLimits::Acc1 && i == 2 {
                Some(c.a_min)
            } else if c.set_limits && limits == ReachedLimits::Acc0Acc1 && i == 0 {
                Some(c.a_max)
            } else if c.set_limits && limits == ReachedLimits::Acc0Acc1 && i == 4 {
                Some(c.a_min)
            } else {
                None
            };
            if let Some(value) = pin {
                self.a[i + 1] = value;
            }
            // Velocity extremum inside a phase where the acceleration changes sign.
            if i > 1 && self.a[i + 1] * self.a[i] < -A_SIGN_CHANGE_EPS {
                let v_a_zero = self.v[i] - (self.a[i] * self.a[i]) / (2.0 * self.j[i]);
                if v_a_zero > v_upp || v_a_zero < v_low {
                    return false;
                }
            }
        }
        self.control_signs = c.signs;
        self.limits = limits;

        let a_eps = LIMIT_EPS_REL * c.a_max.abs().max(c.a_min.abs());
        let a_upp = if up { c.a_max } else { c.a_min } + a_eps;
        let a_low = if up { c.a_min } else { c.a_max } - a_eps;
        let (a, v) = (&self.a, &self.v);
        within_precision(self.p[7], self.pf, P_PRECISION, &self.p)
            && within_precision(v[7], self.vf, V_PRECISION, v)
            && within_precision(a[7], self.af, A_PRECISION, a)
            && a[1] >= a_low
            && a[3] >= a_low
            && a[5] >= a_low
            && a[1] <= a_upp
            && a[3] <= a_upp
            && a[5] <= a_upp
            && v[3] <= v_upp
            && v[4] <= v_upp
            && v[5] <= v_upp
            && v[6] <= v_upp
            && v[3] >= v_low
            && v[4] >= v_low
            && v[5] >= v_low
            && v[6] >= v_low
    }

    /// Velocity interface, step 1: like [`Profile::check`] without position and velocity limits.
    #[inline]
    pub(crate) fn check_for_velocity(
        &mut self,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        a_max: f64,
        a_min: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max: 0.0, v_min: 0.0, a_max, a_min };
        self.check_velocity(&c)
    }

    /// Velocity interface, step 2: a profile that must last `tf` (not checked, see
    /// [`Profile::check_with_timing`]), with a jerk `jf` that may be below the limit `j_max`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn check_for_velocity_with_timing_and_jerk(
        &mut self,
        _tf: f64,
        signs: ControlSigns,
        limits: ReachedLimits,
        jf: f64,
        a_max: f64,
        a_min: f64,
        j_max: f64,
    ) -> bool {
        let c = Candidate { signs, limits, set_limits: false, jf, v_max: 0.0, v_min: 0.0, a_max, a_min };
        jf.abs() < j_max.abs() * (1.0 + JERK_EPS_REL) && self.check_velocity(&c)
    }

    /// Ruckig's `check_for_velocity`, followed by the refinement of an accepted candidate.
    fn check_velocity(&mut self, c: &Candidate) -> bool {
        if !self.fill_t_sum() {
            return false;
        }
        if c.limits == ReachedLimits::Acc0 && self.t[1] < T_EPS_S {
            return false;
        }
        if self.t_sum[6] > T_MAX_S {
            return false;
        }
        self.set_jerks(c.signs, c.jf);
        for i in 0..7 {
            let (t, j) = (self.t[i], self.j[i]);
            self.a[i + 1] = self.a[i] + t * j;
            self.v[i + 1] = self.v[i] + t * (self.a[i] + t * j / 2.0);
            self.p[i + 1] = self.p[i] + t * (self.v[i] + t * (self.a[i] / 2.0 + t * j / 6.0));
        }
        self.control_signs = c.signs;
        self.limits = c.limits;
        let up = c.a_max > 0.0;
        self.direction = if up { Direction::Up } else { Direction::Down };
        let a_eps = LIMIT_EPS_REL * c.a_max.abs().max(c.a_min.abs());
        let a_upp = if up { c.a_max } else { c.a_min } + a_eps;
        let a_low = if up { c.a_min } else { c.a_max } - a_eps;
        let a = &self.a;
        within_precision(self.v[7], self.vf, V_PRECISION, &self.v)
            && within_precision(a[7], self.af, A_PRECISION, a)
            && a[1] >= a_low
            && a[3] >= a_low
            && a[5] >= a_low
            && a[1] <= a_upp
            && a[3] <= a_upp
            && a[5] <= a_upp
    }

    /// Whether the velocity stays within [v_min, v_max] over the whole profile, including the
    /// first phases and the extrema inside phases (the checks above skip the first phases,
    /// which the step-1/2 families never take beyond the limits; a phase-synchronised copy of
    /// another DoF's timing can).
    pub(crate) fn velocity_within(&self, v_max: f64, v_min: f64) -> bool {
        let v_eps = LIMIT_EPS_REL * v_max.abs().max(v_min.abs());
        let (hi, lo) = (v_max + v_eps, v_min - v_eps);
        (0..7).all(|i| {
            let v_end = self.v[i + 1];
            let inside = v_end <= hi && v_end >= lo;
            let (a0, a1) = (self.a[i], self.a[i + 1]);
            let extremum_inside = if self.j[i] != 0.0 && a0 * a1 < 0.0 {
                let v_ext = self.v[i] - a0 * a0 / (2.0 * self.j[i]);
                v_ext <= hi && v_ext >= lo
            } else {
                true
            };
            inside && extremum_inside
        })
    }

    /// Refine the phase durations of a final profile (see [`Profile::refined_durations`]) if integrating
    /// its phases from the start would miss the target by more than [`REFINE_TRIGGER`]: the
    /// closed forms and Ruckig's root refinement leave up to 1e-8, and a pinned plateau
    /// acceleration hides the drift its rounding causes. The refined profile replaces this one
    /// only if it passes the check again. `duration`: the phases must keep lasting this long.
    pub(crate) fn polish(&mut self, position: bool, duration: Option<f64>, lim: &crate::Limits) {
        let (v_max, v_min, a_max, a_min) = match self.direction {
            Direction::Up => (lim.v_max, lim.v_min, lim.a_max, lim.a_min),
            Direction::Down => (lim.v_min, lim.v_max, lim.a_min, lim.a_max),
        };
        if self.integrates_onto_target(position) {
            return;
        }
        let Some(durations) = self.refined_durations(duration, position, a_max, a_min) else {
            return;
        };
        let mut refined = *self;
        refined.t = durations;
        let c = Candidate {
            signs: self.control_signs,
            limits: self.limits,
            set_limits: false,
            jf: self.ramp_jerk(),
            v_max,
            v_min,
            a_max,
            a_min,
        };
        let ok = if position { refined.check_position(&c) } else { refined.check_velocity(&c) };
        if ok {
            // The check recomputes the bookkeeping; keep what the profile reported before.
            refined.limits = self.limits;
            *self = refined;
        }
    }

    /// Cheap pre-check of [`Profile::polish`]: the stored boundary states equal the integration of
    /// the phases (no acceleration was pinned by more than rounding) and end on the target within
    /// [`REFINE_TRIGGER`].
    fn integrates_onto_target(&self, position: bool) -> bool {
        let unpinned = (0..7).all(|i| {
            let step = self.t[i] * self.j[i];
            let raw = self.a[i] + step;
            (raw - self.a[i + 1]).abs() <= PIN_ROUNDING_ULPS * f64::EPSILON * (self.a[i].abs() + step.abs())
        });
        let near = |x: f64, target: f64, along: &[f64]| {
            let err = (x - target).abs();
            err <= REFINE_TRIGGER || err <= REFINE_TRIGGER * magnitude(along, target)
        };
        unpinned
            && near(self.a[7], self.af, &self.a)
            && near(self.v[7], self.vf, &self.v)
            && (!position || near(self.p[7], self.pf, &self.p))
    }

    /// Newton iterations on the durations of the non-empty phases (jerks fixed) so that the
    /// phases, integrated from the start without any pinning, end exactly on the target, last
    /// `duration` (step 2), and hold plateaus at the acceleration limit or at zero exactly.
    /// Minimum-norm steps: the system is usually underdetermined. Returns the new durations, or
    /// `None` if nothing needs refining, it does not converge, or a duration turns negative.
    fn refined_durations(&self, duration: Option<f64>, position: bool, a_max: f64, a_min: f64) -> Option<[f64; 7]> {
        let mut durations = self.t;
        let mut active = [0usize; 7];
        let mut n = 0;
        for i in 0..7 {
            if self.t[i] > 0.0 {
                active[n] = i;
                n += 1;
            }
        }
        if n == 0 {
            return None;
        }
        let active = &active[..n];
        let a_scale = a_max.abs().max(a_min.abs());
        // Plateaus (hold phases) at a limit or at zero keep that acceleration exactly.
        let mut pins = [(0usize, 0.0f64); 3];
        let mut n_pins = 0;
        for k in [1, 3, 5] {
            if self.t[k] > 0.0 {
                if let Some(value) =
                    [a_max, a_min, 0.0].into_iter().find(|&x| (self.a[k] - x).abs() <= PIN_DETECT_REL * a_scale)
                {
                    pins[n_pins] = (k, value);
                    n_pins += 1;
                }
            }
        }
        let pins = &pins[..n_pins];
        let mut rows = [Row::EndA; 7];
        let mut m = 0;
        let mut add = |row: Row| {
            rows[m] = row;
            m += 1;
        };
        add(Row::EndA);
        add(Row::EndV);
        if position {
            add(Row::EndP);
        }
        if let Some(d) = duration {
            add(Row::Duration(d));
        }
        for &(k, _) in pins {
            add(Row::Pin(k));
        }
        let rows = &rows[..m];

        let mut first_residual = f64::INFINITY;
        let mut best = (f64::INFINITY, durations);
        let mut stalled = 0;
        for iteration in 0..=REFINE_ITERATIONS {
            // Integrate without pinning, except that a pinned acceleration within rounding of its
            // value is that value (durations cannot resolve it any finer; a long plateau after it
            // would otherwise turn the last ulp into a drift).
            let (mut a, mut v, mut p) = ([0.0f64; 8], [0.0f64; 8], [0.0f64; 8]);
            (a[0], v[0], p[0]) = (self.a[0], self.v[0], self.p[0]);
            let mut pin_residual = [0.0f64; 8];
            let mut t_end = [0.0f64; 7];
            let mut total = 0.0;
            for i in 0..7 {
                let (t, j) = (durations[i], self.j[i]);
                (p[i + 1], v[i + 1], a[i + 1]) = integrate(t, p[i], v[i], a[i], j);
                if let Some(&(_, value)) = pins.iter().find(|&&(k, _)| k == i + 1) {
                    let offset = a[i + 1] - value;
                    let rounding = PIN_ROUNDING_ULPS * f64::EPSILON * (a[i].abs() + (t * j).abs());
                    if offset.abs() <= rounding {
                        a[i + 1] = value;
                    } else {
                        pin_residual[i + 1] = offset;
                    }
                }
                total += t;
                t_end[i] = total;
            }
            if iteration == 0 {
                // Off by more than the trigger (relative to max(1, magnitude), like the target
                // precisions)? Otherwise there is nothing to refine.
                let off = |err: f64, target: f64, along: &[f64]| {
                    err > REFINE_TRIGGER && err > REFINE_TRIGGER * magnitude(along, target)
                };
                let missed = off((a[7] - self.af).abs(), self.af, &a)
                    || off((v[7] - self.vf).abs(), self.vf, &v)
                    || (position && off((p[7] - self.pf).abs(), self.pf, &p));
                if !missed {
                    return None;
                }
            }
            let sa = magnitude(&a, self.af).max(a_scale);
            let sv = magnitude_or_one(&v, self.vf);
            let sp = magnitude_or_one(&p, self.pf);
            let mut jac = [[0.0f64; 7]; 7];
            let mut rhs = [0.0f64; 7];
            let mut residual = 0.0f64;
            for (r, row) in rows.iter().enumerate() {
                let (value, scale) = match *row {
                    Row::EndA => (a[7] - self.af, sa),
                    Row::EndV => (v[7] - self.vf, sv),
                    Row::EndP => (p[7] - self.pf, sp),
                    Row::Duration(d) => (total - d, d.max(f64::MIN_POSITIVE)),
                    Row::Pin(k) => (pin_residual[k], sa),
                };
                rhs[r] = -value / scale;
                residual = residual.max((value / scale).abs());
                for (col, &i) in active.iter().enumerate() {
                    let rem = total - t_end[i];
                    let (j, a1, v1) = (self.j[i], a[i + 1], v[i + 1]);
                    let d = match *row {
                        Row::EndA => j,
                        Row::EndV => a1 + j * rem,
                        Row::EndP => v1 + rem * (a1 + j * rem / 2.0),
                        Row::Duration(_) => 1.0,
                        Row::Pin(k) => {
                            if i < k {
                                j
                            } else {
                                0.0
                            }
                        }
                    };
                    jac[r][col] = d / scale;
                }
            }
            if iteration == 0 {
                first_residual = residual;
            }
            // Stop at the rounding floor: once two iterations in a row do not halve the best
            // residual (one may not: the max over rows is no merit function for Newton, a step
            // that fixes one row can raise another by its second-order terms).
            if residual < REFINE_PROGRESS * best.0 {
                stalled = 0;
            } else {
                stalled += 1;
            }
            if residual < best.0 {
                best = (residual, durations);
            }
            if residual <= REFINE_GOAL || stalled >= 2 || iteration == REFINE_ITERATIONS {
                break;
            }
            let delta = solve_small(&jac, &rhs, m, n)?;
            for (col, &i) in active.iter().enumerate() {
                durations[i] += delta[col];
                if durations[i].is_nan() || durations[i] < 0.0 {
                    return None;
                }
            }
        }
        (best.0 < first_residual && best.0 <= REFINE_ACCEPT).then_some(best.1)
    }

    /// Start state (after the brake) and target of the position interface.
    #[inline]
    pub(crate) fn set_boundary(&mut self, p0: f64, v0: f64, a0: f64, pf: f64, vf: f64, af: f64) {
        self.a[0] = a0;
        self.v[0] = v0;
        self.p[0] = p0;
        self.af = af;
        self.vf = vf;
        self.pf = pf;
    }

    /// Copy start state, target and brake of another profile.
    #[inline]
    pub(crate) fn set_boundary_from(&mut self, other: &Profile) {
        self.a[0] = other.a[0];
        self.v[0] = other.v[0];
        self.p[0] = other.p[0];
        self.af = other.af;
        self.vf = other.vf;
        self.pf = other.pf;
        self.brake = other.brake;
    }

    /// Kinematic state (p, v, a, j) at time `t` measured from the start of the brake pre-phase.
    /// After the end the motion continues with the final acceleration and zero jerk.
    pub fn state_at(&self, t: f64) -> (f64, f64, f64, f64) {
        let mut t = t;
        if self.brake.duration > 0.0 {
            if t < self.brake.duration {
                let idx = if t < self.brake.t[0] { 0 } else { 1 };
                if idx > 0 {
                    t -= self.brake.t[0];
                }
                let (p, v, a) =
                    integrate(t, self.brake.p[idx], self.brake.v[idx], self.brake.a[idx], self.brake.j[idx]);
                return (p, v, a, self.brake.j[idx]);
            }
            t -= self.brake.duration;
        }
        // First phase whose end lies after t (upper bound; phases are few: linear scan).
        let mut idx = 0;
        while idx < 7 && self.t_sum[idx] <= t {
            idx += 1;
        }
        if idx >= 7 {
            let (p, v, a) = integrate(t - self.t_sum[6], self.p[7], self.v[7], self.a[7], 0.0);
            return (p, v, a, 0.0);
        }
        let t_start = if idx == 0 { 0.0 } else { self.t_sum[idx - 1] };
        let (p, v, a) = integrate(t - t_start, self.p[idx], self.v[idx], self.a[idx], self.j[idx]);
        (p, v, a, self.j[idx])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rest to rest over distance 2 with unit limits: ramp up 1 s, ramp down 2 s, ramp up 1 s.
    fn none_profile(pf: f64) -> Profile {
        let mut p = Profile::default();
        p.set_boundary(0.0, 0.0, 0.0, pf, 0.0, 0.0);
        p.t = [1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
        p
    }

    #[test]
    fn accepts_exact_profile_and_integrates_boundaries() {
        let mut p = none_profile(2.0);
        assert!(p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
        assert_eq!(p.t_sum[6], 4.0);
        let (pos, vel, acc, _) = p.state_at(2.0);
        assert!((pos - 1.0).abs() < 1e-15 && (vel - 1.0).abs() < 1e-15 && acc.abs() < 1e-15);
        let (pos, vel, _, jerk) = p.state_at(10.0);
        assert_eq!((pos, vel, jerk), (2.0, 0.0, 0.0));
    }

    #[test]
    fn rejects_limit_violation_missed_target_and_negative_durations() {
        let mut p = none_profile(2.0);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 0.9, -0.9, 1.0, -1.0));
        let mut p = none_profile(2.1);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
        let mut p = none_profile(2.0);
        p.t[1] = -1e-3;
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1.0, 1.0, -1.0, 1.0, -1.0));
    }

    #[test]
    fn small_solver_square_underdetermined_and_overdetermined() {
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][..3].copy_from_slice(&[2.0, 1.0, 0.0]);
        jac[1][..3].copy_from_slice(&[1.0, 3.0, 1.0]);
        jac[2][..3].copy_from_slice(&[0.0, 1.0, 4.0]);
        let mut rhs = [0.0f64; 7];
        rhs[..3].copy_from_slice(&[3.0, 5.0, 5.0]);
        let x = solve_small(&jac, &rhs, 3, 3).unwrap();
        for (got, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((got - want).abs() < 1e-14, "{x:?}");
        }
        // x + y = 2: minimum norm (1, 1).
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][..2].copy_from_slice(&[1.0, 1.0]);
        let mut rhs = [0.0f64; 7];
        rhs[0] = 2.0;
        let x = solve_small(&jac, &rhs, 1, 2).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15, "{x:?}");
        // x = 1, x = 3: least squares 2.
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][0] = 1.0;
        jac[1][0] = 1.0;
        let mut rhs = [0.0f64; 7];
        rhs[..2].copy_from_slice(&[1.0, 3.0]);
        let x = solve_small(&jac, &rhs, 2, 1).unwrap();
        assert!((x[0] - 2.0).abs() < 1e-15, "{x:?}");
    }

    #[test]
    fn precision_is_relative_to_the_magnitude() {
        // The same profile a million times larger in position (jerk 1e6): an error that is
        // rounding-size relative to the positions is accepted.
        let mut p = none_profile(2e6 + 1e-4);
        assert!(p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1e6, 1e6, -1e6, 1e6, -1e6));
        let mut p = none_profile(2e6 + 1.0);
        assert!(!p.check(ControlSigns::Uddu, ReachedLimits::None, false, 1e6, 1e6, -1e6, 1e6, -1e6));
    }
}
