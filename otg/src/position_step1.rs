//! Step 1, position interface: all time-extremal profiles of one DoF, hence its minimum duration
//! and its blocked intervals (Berscheid & Kröger, RSS 2021, Sec. IV-A/B).
//!
//! Time-optimal profiles have the jerk pattern UDDU (+j, 0, -j, 0, -j, 0, +j, in the chosen
//! direction). They differ in which limits they reach:
//!
//! - with a cruise at v_max (VEL, ACC0_VEL, ACC1_VEL, ACC0_ACC1_VEL): each half is the
//!   time-optimal velocity change to / from (v_max, 0) and the cruise length follows from the
//!   distance: closed form;
//! - ACC0_ACC1 (both acceleration limits, no cruise): a quadratic in the velocity at the start of
//!   the middle ramp;
//! - NONE, ACC0, ACC1: a quartic each, derived from the velocity and position equations.
//!
//! The equations were derived independently in the normalised frame of [`crate::frame`]
//! (j_max = a_max = 1, a_min = -r) by integrating the phases symbolically.

use crate::block::Block;
use crate::brake::BrakeProfile;
use crate::frame::{Candidate, Frame, Orientation, Polish, UDDU};
use crate::profile::{Goal, JerkSigns, PolishSpec, Profile, ReachedLimits};
use crate::roots::{solve_quadratic, solve_quartic_monic};
use crate::{Limits, State};

/// Up to five extremal profiles exist; a few spares absorb duplicates found by two families.
const MAX_CANDIDATES: usize = 8;
/// Roots this far (normalised units, relative to the range bound) outside their valid range are
/// still tried: closed forms lose digits near the ends of the range; the check decides.
const ROOT_SLACK_REL: f64 = 1e-9;
/// Target velocity and acceleration below this (normalised) count as "rest": then there are no
/// blocked intervals and the first valid profile is the optimum.
const REST_EPS: f64 = f64::EPSILON;

const ROWS_AVP: u8 = PolishSpec::END_A | PolishSpec::END_V | PolishSpec::END_P;
const ROWS_VP: u8 = PolishSpec::END_V | PolishSpec::END_P;

/// Collects accepted candidates.
pub(crate) struct Collector<'a> {
    pub profiles: [Profile; MAX_CANDIDATES],
    pub n: usize,
    start: State,
    goal: Goal,
    limits: &'a Limits,
    brake: BrakeProfile,
}

impl<'a> Collector<'a> {
    pub(crate) fn new(start: State, target: State, limits: &'a Limits, brake: BrakeProfile, position: bool) -> Self {
        Collector {
            profiles: [Profile::default(); MAX_CANDIDATES],
            n: 0,
            start,
            goal: Goal { target, position, duration: None },
            limits,
            brake,
        }
    }

    pub(crate) fn start(&self) -> &State {
        &self.start
    }

    pub(crate) fn target(&self) -> &State {
        &self.goal.target
    }

    /// Check a candidate; keep it if valid.
    pub(crate) fn add(&mut self, frame: &Frame, c: &Candidate) -> bool {
        if self.n == MAX_CANDIDATES {
            return false;
        }
        let out = &mut self.profiles[self.n];
        out.brake = self.brake;
        if frame.accept(c, &self.start, &self.goal, self.limits, out) {
            self.n += 1;
            true
        } else {
            false
        }
    }

    /// The zero-length profile (start already equals the target).
    pub(crate) fn add_zero(&mut self) -> bool {
        let frame = Frame::new(Orientation::Up, &self.start, &self.goal.target, self.limits);
        let c = Candidate {
            t: [0.0; 7],
            j: [0.0; 7],
            limits: ReachedLimits::None,
            signs: JerkSigns::Uddu,
            polish: Polish::NONE,
        };
        self.add(&frame, &c)
    }

    pub(crate) fn found(&self) -> &[Profile] {
        &self.profiles[..self.n]
    }

    /// The shortest profile found.
    pub(crate) fn fastest(&self) -> Option<Profile> {
        self.found().iter().copied().min_by(|x, y| x.duration().total_cmp(&y.duration()))
    }
}

/// Step 1 for one DoF from the (braked) start state. `None` if no valid profile exists.
pub(crate) fn calculate(start: &State, target: &State, limits: &Limits, brake: &BrakeProfile) -> Option<Block> {
    let mut col = Collector::new(*start, *target, limits, *brake, true);
    let zero = col.add_zero();
    let f_up = Frame::new(Orientation::Up, start, target, limits);
    let at_rest = f_up.vf.abs() < REST_EPS && f_up.af.abs() < REST_EPS;
    if at_rest {
        if zero {
            return col.fastest().map(Block::single);
        }
        // A rest target has no blocked interval: the first valid profile, searched in the
        // direction of the target first, is the time-optimal one.
        let first = if target.p >= start.p { Orientation::Up } else { Orientation::Down };
        for orientation in [first, opposite(first)] {
            let frame =
                if orientation == Orientation::Up { f_up } else { Frame::new(orientation, start, target, limits) };
            if vel_family(&frame, &mut col)
                || none_family(&frame, &mut col)
                || acc0_family(&frame, &mut col)
                || acc1_family(&frame, &mut col)
                || acc0_acc1_family(&frame, &mut col)
            {
                return col.fastest().map(Block::single);
            }
        }
    } else {
        let f_down = Frame::new(Orientation::Down, start, target, limits);
        for frame in [&f_up, &f_down] {
            none_family(frame, &mut col);
            acc0_family(frame, &mut col);
            acc1_family(frame, &mut col);
            acc0_acc1_family(frame, &mut col);
            vel_family(frame, &mut col);
        }
        if col.n > 0 {
            return Block::from_profiles(col.found());
        }
    }
    // Numerically degenerate inputs (a phase of exactly zero length, a limit reached exactly):
    // short closed forms for profiles with fewer phases.
    for orientation in [Orientation::Up, Orientation::Down] {
        let frame = Frame::new(orientation, start, target, limits);
        if degenerate_family(&frame, &mut col) {
            return col.fastest().map(Block::single);
        }
    }
    None
}

pub(crate) fn opposite(o: Orientation) -> Orientation {
    match o {
        Orientation::Up => Orientation::Down,
        Orientation::Down => Orientation::Up,
    }
}

/// One half of a profile with a cruise: the time-optimal velocity change between a state with
/// acceleration and a cruise (acceleration zero), as three phases (ramp, hold, ramp).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Half {
    pub t: [f64; 3],
    /// Jerk of the three phases (±1).
    pub j: [f64; 3],
    /// Distance travelled.
    pub dist: f64,
    /// Duration.
    pub dur: f64,
    /// Magnitude of the peak acceleration (the limit if the hold is at it).
    pub peak: f64,
    /// Whether the hold is at the acceleration limit.
    pub at_limit: bool,
}

impl Half {
    fn new(t: [f64; 3], j: [f64; 3], v: f64, a: f64, peak: f64, at_limit: bool) -> Half {
        let (mut p, mut vv, mut aa) = (0.0, v, a);
        for k in 0..3 {
            (p, vv, aa) = crate::profile::integrate(t[k], p, vv, aa, j[k]);
        }
        Half { t, j, dist: p, dur: t[0] + t[1] + t[2], peak, at_limit }
    }

    fn mirrored(mut self) -> Half {
        self.j = [-self.j[0], -self.j[1], -self.j[2]];
        self.dist = -self.dist;
        self
    }
}

/// Time-optimal change from (v, a) up to (v_target, 0), peak acceleration limited to `a_lim`
/// (> 0): ramp up, hold, ramp down. `None` if it cannot be done upwards.
pub(crate) fn rise_to(v: f64, a: f64, v_target: f64, a_lim: f64) -> Option<Half> {
    // Squared peak of the triangle ramp-up / ramp-down.
    let w = v_target - v + 0.5 * a * a;
    if !(w >= 0.0) || a > a_lim {
        return None;
    }
    if w >= a_lim * a_lim {
        Some(Half::new([a_lim - a, (w - a_lim * a_lim) / a_lim, a_lim], [1.0, 0.0, -1.0], v, a, a_lim, true))
    } else {
        let peak = w.sqrt();
        if peak < a {
            return None;
        }
        Some(Half::new([peak - a, 0.0, peak], [1.0, 0.0, -1.0], v, a, peak, false))
    }
}

/// Time-optimal change from (v, 0) down to (v_target, a_target), trough limited to `-a_lim`
/// (a_lim > 0): ramp down, hold, ramp up. `None` if it cannot be done downwards.
pub(crate) fn fall_to(v: f64, v_target: f64, a_target: f64, a_lim: f64) -> Option<Half> {
    let u = v - v_target + 0.5 * a_target * a_target;
    if !(u >= 0.0) || a_target < -a_lim {
        return None;
    }
    if u >= a_lim * a_lim {
        Some(Half::new([a_lim, u / a_lim - a_lim, a_target + a_lim], [-1.0, 0.0, 1.0], v, 0.0, a_lim, true))
    } else {
        let trough = u.sqrt();
        if a_target + trough < 0.0 {
            return None;
        }
        Some(Half::new([trough, 0.0, a_target + trough], [-1.0, 0.0, 1.0], v, 0.0, trough, false))
    }
}

/// Time-optimal change from (v, a) to (v_target, 0) in whichever direction it takes, with
/// acceleration limits `[a_lo, a_hi]` (a_lo < 0 < a_hi).
pub(crate) fn change_to_cruise(v: f64, a: f64, v_target: f64, a_lo: f64, a_hi: f64) -> Option<Half> {
    let v_stop = v + 0.5 * a * a.abs();
    if v_target >= v_stop {
        rise_to(v, a, v_target, a_hi).or_else(|| rise_to(-v, -a, -v_target, -a_lo).map(Half::mirrored))
    } else {
        rise_to(-v, -a, -v_target, -a_lo).map(Half::mirrored).or_else(|| rise_to(v, a, v_target, a_hi))
    }
}

/// Time-optimal change from (v, 0) to (v_target, a_target) in whichever direction it takes.
pub(crate) fn change_from_cruise(v: f64, v_target: f64, a_target: f64, a_lo: f64, a_hi: f64) -> Option<Half> {
    let v_pre = v_target - 0.5 * a_target * a_target.abs();
    if v >= v_pre {
        fall_to(v, v_target, a_target, -a_lo).or_else(|| fall_to(-v, -v_target, -a_target, a_hi).map(Half::mirrored))
    } else {
        fall_to(-v, -v_target, -a_target, a_hi).map(Half::mirrored).or_else(|| fall_to(v, v_target, a_target, -a_lo))
    }
}

/// Cruise at v_max between a rise from the start and a fall to the target.
fn vel_family(f: &Frame, col: &mut Collector) -> bool {
    let Some(up) = rise_to(f.v0, f.a0, f.v_max, 1.0) else {
        return false;
    };
    let Some(down) = fall_to(f.v_max, f.vf, f.af, -f.a_min) else {
        return false;
    };
    let cruise = (f.pd - up.dist - down.dist) / f.v_max;
    if cruise < -ROOT_SLACK_REL * (f.pd.abs() / f.v_max).max(1.0) {
        return false;
    }
    let limits = match (up.at_limit, down.at_limit) {
        (true, true) => ReachedLimits::Acc0Acc1Vel,
        (true, false) => ReachedLimits::Acc0Vel,
        (false, true) => ReachedLimits::Acc1Vel,
        (false, false) => ReachedLimits::Vel,
    };
    let c = Candidate {
        t: [up.t[0], up.t[1], up.t[2], cruise.max(0.0), down.t[0], down.t[1], down.t[2]],
        j: UDDU,
        limits,
        signs: JerkSigns::Uddu,
        polish: Polish::new(&[3], PolishSpec::END_P),
    };
    col.add(f, &c)
}

/// Both acceleration limits, no cruise: ramp to 1, hold, ramp through zero to a_min, hold, ramp
/// to a_f. With the velocity v_b at the start of the middle ramp as unknown, the position
/// equation is a quadratic.
fn acc0_acc1_family(f: &Frame, col: &mut Collector) -> bool {
    if f.a0 > 1.0 || f.af < f.a_min {
        return false;
    }
    let r = -f.a_min;
    let ramp0 = 1.0 - f.a0;
    let (p_a, v_a, _) = crate::profile::integrate(ramp0, 0.0, f.v0, f.a0, 1.0);
    // Middle ramp 1 → -r lasts 1 + r; it changes the velocity by h.
    let mid = 1.0 + r;
    let h = 0.5 * (1.0 - r * r);
    let c_mid = 0.5 * mid * mid - mid * mid * mid / 6.0;
    // Final ramp -r → a_f: the velocity before it is fixed by the target.
    let ramp6 = f.af + r;
    let v_d = f.vf - 0.5 * (f.af * f.af - r * r);
    let (p_e, _, _) = crate::profile::integrate(ramp6, 0.0, v_d, -r, 1.0);
    // (v_b² - v_a²)/2 + v_b·mid + c_mid + ((v_b + h)² - v_d²)/(2r) + p_a + p_e = pd, times 2r:
    let qa = r + 1.0;
    let qb = 2.0 * (r * mid + h);
    let qc = h * h - r * v_a * v_a - v_d * v_d + 2.0 * r * (c_mid + p_a + p_e - f.pd);
    let mut found = false;
    for &v_b in solve_quadratic(qa, qb, qc).as_slice() {
        let hold0 = v_b - v_a;
        let hold1 = (v_b + h - v_d) / r;
        let slack = ROOT_SLACK_REL * (v_b.abs() + v_a.abs() + 1.0);
        if hold0 < -slack || hold1 < -slack * (1.0 + 1.0 / r) {
            continue;
        }
        let c = Candidate {
            t: [ramp0, hold0.max(0.0), 1.0, 0.0, r, hold1.max(0.0), ramp6],
            j: UDDU,
            limits: ReachedLimits::Acc0Acc1,
            signs: JerkSigns::Uddu,
            polish: Polish::new(&[1, 5], ROWS_VP),
        };
        found |= col.add(f, &c);
    }
    found
}

/// No limit reached: ramp up to a1, ramp down to a2, ramp up to a_f. With d = a1 - a2 (the
/// middle ramp's length) the velocity equation gives a1² - a2² = K, so a1 + a2 = K / d, and the
/// position equation becomes the monic quartic d⁴ + c2 d² + c1 d - K² = 0.
fn none_family(f: &Frame, col: &mut Collector) -> bool {
    let (v0, a0, vf, af) = (f.v0, f.a0, f.vf, f.af);
    let k = (vf - v0) + 0.5 * (a0 * a0 - af * af);
    let c2 = 2.0 * (2.0 * (v0 + vf) - a0 * a0 - af * af);
    let c1 = -4.0 / 3.0 * (af * af * af - a0 * a0 * a0 + 3.0 * (a0 * v0 - af * vf + f.pd));
    let c0 = -k * k;
    let mut found = false;
    for &d in solve_quartic_monic(0.0, c2, c1, c0).as_slice() {
        if !(d > 0.0) {
            continue;
        }
        let sum = k / d;
        let a1 = 0.5 * (sum + d);
        let a2 = 0.5 * (sum - d);
        let slack = ROOT_SLACK_REL * (1.0 + a1.abs() + a2.abs());
        if a1 > 1.0 + slack || a2 < f.a_min - slack || a1 - a0 < -slack || af - a2 < -slack {
            continue;
        }
        let c = Candidate {
            t: [(a1 - a0).max(0.0), 0.0, d, 0.0, 0.0, 0.0, (af - a2).max(0.0)],
            j: UDDU,
            limits: ReachedLimits::None,
            signs: JerkSigns::Uddu,
            polish: Polish::new(&[0, 2, 6], ROWS_AVP),
        };
        found |= col.add(f, &c);
    }
    found
}

/// Upper acceleration limit only: ramp to 1, hold, ramp down by t to a2 = 1 - t, ramp up to a_f.
/// Quartic in t (the hold length follows from the velocity equation).
fn acc0_family(f: &Frame, col: &mut Collector) -> bool {
    let (v0, a0, vf, af) = (f.v0, f.a0, f.vf, f.af);
    if a0 > 1.0 {
        return false;
    }
    let (a0_2, af_2) = (a0 * a0, af * af);
    let c2 = 1.0 - af_2 + 2.0 * vf;
    let c0 = -(6.0 * (a0_2 - af_2)
        + 12.0 * (vf - v0)
        + 8.0 * (af * af_2 - a0 * a0_2)
        + 24.0 * (a0 * v0 - af * vf + f.pd)
        + 3.0 * (a0_2 * a0_2 - af_2 * af_2)
        + 12.0 * (af_2 * vf - a0_2 * v0)
        + 12.0 * (v0 * v0 - vf * vf))
        / 12.0;
    let t_lo = 1.0 - af;
    let t_hi = 1.0 - f.a_min;
    let slack = ROOT_SLACK_REL * (1.0 + t_hi.abs());
    let mut found = false;
    for &t in solve_quartic_monic(-2.0, c2, 0.0, c0).as_slice() {
        if t < t_lo - slack || t > t_hi + slack {
            continue;
        }
        let hold = 0.5 * (2.0 * t * t - 4.0 * t + a0_2 - af_2) + vf - v0;
        if hold < -slack * (1.0 + t * t) {
            continue;
        }
        let c = Candidate {
            t: [1.0 - a0, hold.max(0.0), t.max(0.0), 0.0, 0.0, 0.0, (af - 1.0 + t).max(0.0)],
            j: UDDU,
            limits: ReachedLimits::Acc0,
            signs: JerkSigns::Uddu,
            polish: Polish::new(&[1, 2, 6], ROWS_AVP),
        };
        found |= col.add(f, &c);
    }
    found
}

/// Lower acceleration limit only: ramp up by t to a1 = a0 + t, ramp down to a_min, hold, ramp up
/// to a_f. Quartic in t.
fn acc1_family(f: &Frame, col: &mut Collector) -> bool {
    let (v0, a0, vf, af) = (f.v0, f.a0, f.vf, f.af);
    let r = -f.a_min;
    if af + r < 0.0 {
        return false;
    }
    let (a0_2, af_2, r_2) = (a0 * a0, af * af, r * r);
    let b = 2.0 * (2.0 * a0 + r);
    let c = 5.0 * a0_2 + 6.0 * a0 * r + r_2 + 2.0 * v0;
    let d = 2.0 * (a0 + r) * (a0_2 + a0 * r + 2.0 * v0);
    let e = (3.0 * (a0_2 * a0_2 - af_2 * af_2)
        + 8.0 * r * (a0 * a0_2 - af * af_2)
        + 6.0 * r_2 * (a0_2 - af_2)
        + 12.0 * (a0_2 * v0 + af_2 * vf)
        + 24.0 * r * (a0 * v0 + af * vf - f.pd)
        + 12.0 * r_2 * (v0 + vf)
        + 12.0 * (v0 * v0 - vf * vf))
        / 12.0;
    let t_lo = (f.a_min - a0).max(0.0);
    let t_hi = 1.0 - a0;
    let slack = ROOT_SLACK_REL * (1.0 + t_hi.abs() + t_lo.abs());
    let mut found = false;
    for &t in solve_quartic_monic(b, c, d, e).as_slice() {
        if t < t_lo - slack || t > t_hi + slack {
            continue;
        }
        let t = t.max(0.0);
        let hold = (a0_2 + 4.0 * a0 * t + af_2 - 2.0 * r_2 + 2.0 * t * t + 2.0 * (v0 - vf)) / (2.0 * r);
        if hold < -slack * (1.0 + 1.0 / r) * (1.0 + t * t) {
            continue;
        }
        let cand = Candidate {
            t: [t, 0.0, (a0 + t + r).max(0.0), 0.0, 0.0, hold.max(0.0), af + r],
            j: UDDU,
            limits: ReachedLimits::Acc1,
            signs: JerkSigns::Uddu,
            polish: Polish::new(&[0, 2, 5], ROWS_VP).with_acc_at(2, f.a_min),
        };
        found |= col.add(f, &cand);
    }
    found
}

/// Profiles with fewer phases for inputs on the border between cases (e.g. a0 exactly at a
/// limit, a phase of exactly zero length), where the general closed forms divide by zero.
fn degenerate_family(f: &Frame, col: &mut Collector) -> bool {
    let (v0, a0, vf, af) = (f.v0, f.a0, f.vf, f.af);
    let none = |t: [f64; 7]| Candidate {
        t,
        j: UDDU,
        limits: ReachedLimits::None,
        signs: JerkSigns::Uddu,
        polish: Polish::NONE,
    };
    // Ramp up to a peak and straight down to a_f (no final ramp up).
    let peak_sq = 0.5 * (a0 * a0 + af * af) + vf - v0;
    if peak_sq >= 0.0 {
        let peak = peak_sq.sqrt();
        if col.add(f, &none([peak - a0, 0.0, peak - af, 0.0, 0.0, 0.0, 0.0])) {
            return true;
        }
    }
    // A single ramp from a0 to a_f.
    if col.add(f, &none([af - a0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])) {
        return true;
    }
    // Hold a0, then ramp down to a_f.
    if a0.abs() > 0.0 {
        let hold = (af * af - a0 * a0 + 2.0 * (vf - v0)) / (2.0 * a0);
        let mut c = none([0.0, hold, a0 - af, 0.0, 0.0, 0.0, 0.0]);
        c.limits = ReachedLimits::Acc0;
        if col.add(f, &c) {
            return true;
        }
    }
    // Ramp to 1, hold, ramp down to a_f.
    if a0 <= 1.0 {
        let hold = 0.5 * (a0 * a0 + af * af) - 1.0 + vf - v0;
        let mut c = none([1.0 - a0, hold, 1.0 - af, 0.0, 0.0, 0.0, 0.0]);
        c.limits = ReachedLimits::Acc0;
        if col.add(f, &c) {
            return true;
        }
    }
    // Ramp a0 to zero, cruise at the velocity reached, change to the target.
    let v_c = v0 + 0.5 * a0 * a0.abs();
    if v_c != 0.0 {
        if let Some(down) = change_from_cruise(v_c, vf, af, f.a_min, 1.0) {
            let (ramp, j_ramp) = if a0 >= 0.0 { (a0, -1.0) } else { (-a0, 1.0) };
            let (p_ramp, _, _) = crate::profile::integrate(ramp, 0.0, v0, a0, j_ramp);
            let cruise = (f.pd - p_ramp - down.dist) / v_c;
            let c = Candidate {
                t: [0.0, 0.0, ramp, cruise, down.t[0], down.t[1], down.t[2]],
                j: [1.0, 0.0, j_ramp, 0.0, down.j[0], down.j[1], down.j[2]],
                limits: ReachedLimits::Vel,
                signs: JerkSigns::Uddu,
                polish: Polish::NONE,
            };
            if col.add(f, &c) {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim(v: f64, a: f64, j: f64) -> Limits {
        Limits { v_max: v, v_min: -v, a_max: a, a_min: -a, j_max: j }
    }

    fn t_min(p0: f64, v0: f64, a0: f64, pf: f64, vf: f64, af: f64, l: &Limits) -> f64 {
        let start = State { p: p0, v: v0, a: a0 };
        let target = State { p: pf, v: vf, a: af };
        calculate(&start, &target, l, &BrakeProfile::default()).expect("profile").t_min
    }

    #[test]
    fn rest_to_rest_textbook_durations() {
        let l = lim(1.0, 1.0, 1.0);
        // Long move: ramp 1 s, hold 0 s (v reaches 1 exactly), ramp 1 s, cruise, mirrored: T = 4 + (10 - 2)/1.
        assert!((t_min(0.0, 0.0, 0.0, 10.0, 0.0, 0.0, &l) - 12.0).abs() < 1e-12);
        // Short move, no limit reached: d = 2 → T = 4 (1 s ramps), see profile tests.
        assert!((t_min(0.0, 0.0, 0.0, 2.0, 0.0, 0.0, &l) - 4.0).abs() < 1e-12);
        // Negative direction is symmetric.
        assert!((t_min(0.0, 0.0, 0.0, -2.0, 0.0, 0.0, &l) - 4.0).abs() < 1e-12);
        // Tiny move: T = 4 (d/2)^(1/3).
        let d = 1e-9;
        assert!((t_min(0.0, 0.0, 0.0, d, 0.0, 0.0, &l) - 4.0 * (d / 2.0f64).cbrt()).abs() < 1e-12);
    }

    #[test]
    fn zero_distance_is_zero_duration() {
        let l = lim(1.0, 1.0, 1.0);
        assert_eq!(t_min(3.0, 0.0, 0.0, 3.0, 0.0, 0.0, &l), 0.0);
        // Moving state equal to the target: also zero, but with a blocked interval after it.
        let start = State { p: 0.0, v: 0.5, a: 0.0 };
        let b = calculate(&start, &start, &l, &BrakeProfile::default()).unwrap();
        assert_eq!(b.t_min, 0.0);
    }

    #[test]
    fn acceleration_limited_move() {
        // v_max large, a_max 1, j_max 10: ACC0_ACC1 shape. Closed form: ramps of 0.1 s.
        let l = lim(100.0, 1.0, 10.0);
        let d = 1.0;
        let t = t_min(0.0, 0.0, 0.0, d, 0.0, 0.0, &l);
        // Trapezoid in a: T = 2 * (t_ramp + t_hold + t_ramp), with velocity peak v_p:
        // each half: v_p = a (t_hold + t_ramp), distance d/2 = v_p * (t_hold + 2 t_ramp)/2.
        // Solve numerically: t_ramp = 0.1, (t_h + 0.1)(t_h + 0.2)/2 = 0.5 → t_h.
        let th = (-0.3 + (0.09f64 - 4.0 * (0.02 - 1.0)).sqrt()) / 2.0;
        assert!((t - 2.0 * (th + 0.2)).abs() < 1e-12, "{t} vs {}", 2.0 * (th + 0.2));
    }

    #[test]
    fn target_velocity_at_limit_and_jerk_extremes() {
        let l = lim(1.0, 1.0, 1.0);
        assert!(t_min(0.0, 0.0, 0.0, 5.0, 1.0, 0.0, &l).is_finite());
        for j in [1e-3, 1e3] {
            let l = lim(1.0, 1.0, j);
            let t = t_min(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, &l);
            assert!(t.is_finite() && t > 0.0);
        }
    }
}
