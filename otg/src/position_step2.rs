//! Step 2, position interface: a profile of one DoF that lasts exactly a given duration T (the
//! synchronised duration), respecting all limits (Berscheid & Kröger, RSS 2021, Sec. IV-C).
//!
//! Main family, the cruise family: time-optimal velocity change from the start to a cruise
//! velocity v_c (acceleration zero), cruise, time-optimal change from v_c to the target. It covers
//! every profile with a zero-acceleration phase: Ruckig's *_VEL cases in both directions and with
//! both jerk patterns (UDDU and UDUD). With T1, D1 (T2, D2) the duration and distance of the
//! first (second) change, the cruise lasts g = T - T1 - T2 and the position residual is
//! F(v_c) = D1 + D2 + v_c·g - pd. Differentiating the closed forms gives
//! dD/dv_c - v_c·dT/dv_c = |peak acceleration|/2 for each change, hence
//! F'(v_c) = g + (|peak1| + |peak2|)/2 > 0 wherever g ≥ 0: on each interval of feasible cruise
//! velocities F is increasing and has at most one root. The feasible set {T1 + T2 ≤ T} has at
//! most two intervals (T1 and T2 are each V-shaped with concave arms), found by bracketing.
//!
//! Profiles without a cruise are needed when T is close to the minimum duration: the step-1
//! families with the jerk reduced below the limit, and profiles whose acceleration holds at a
//! value inside the limits (see [`crate::position_step2_patterns`]).

use crate::brake::BrakeProfile;
use crate::frame::{Candidate, Frame, Orientation, Polish};
use crate::position_step1::{Half, change_from_cruise, change_to_cruise, opposite};
use crate::position_step2_patterns as patterns;
use crate::profile::{Goal, JerkSigns, Profile, ReachedLimits};
use crate::roots::solve_quadratic;
use crate::{Limits, State};

/// Relative tolerance of the cruise velocity root (far below the check's tolerance).
const CRUISE_ROOT_REL: f64 = 1e-15;
/// Iteration cap for bracketed root finding (bisection alone needs ~60 for full precision).
const BRACKET_MAX_ITERATIONS: usize = 100;
/// Iteration cap of the quick Newton attempt on the cruise velocity.
const QUICK_NEWTON_ITERATIONS: usize = 12;
/// A reduced jerk may exceed the limit by this relative amount (rounding of the closed form).
const JERK_SLACK_REL: f64 = 1e-12;

/// Accepts the first valid candidate.
pub(crate) struct Step2<'a> {
    pub profile: Profile,
    start: State,
    goal: Goal,
    limits: &'a Limits,
    brake: BrakeProfile,
}

impl<'a> Step2<'a> {
    pub(crate) fn new(
        duration: f64,
        start: State,
        target: State,
        limits: &'a Limits,
        brake: BrakeProfile,
        position: bool,
    ) -> Self {
        Step2 {
            profile: Profile::default(),
            start,
            goal: Goal { target, position, duration: Some(duration) },
            limits,
            brake,
        }
    }

    /// Check a candidate; keep it if valid.
    pub(crate) fn try_candidate(&mut self, frame: &Frame, c: &Candidate) -> bool {
        self.profile.brake = self.brake;
        frame.accept(c, &self.start, &self.goal, self.limits, &mut self.profile)
    }

    pub(crate) fn start(&self) -> &State {
        &self.start
    }

    pub(crate) fn target(&self) -> &State {
        &self.goal.target
    }

    pub(crate) fn limits(&self) -> &Limits {
        self.limits
    }
}

/// A profile of the main part lasting exactly `duration` [s] from the braked start state.
pub(crate) fn calculate(
    duration: f64,
    start: &State,
    target: &State,
    limits: &Limits,
    brake: &BrakeProfile,
) -> Option<Profile> {
    if !(duration >= 0.0) {
        return None;
    }
    let mut s2 = Step2::new(duration, *start, *target, limits, *brake, true);
    let f_up = Frame::new(Orientation::Up, start, target, limits);
    let t_total = f_up.time_to_frame(duration);
    if cruise_family(&f_up, t_total, &mut s2) {
        return Some(s2.profile);
    }
    let first = if target.p - start.p >= duration * start.v { Orientation::Up } else { Orientation::Down };
    for orientation in [first, opposite(first)] {
        let frame = if orientation == Orientation::Up { f_up } else { Frame::new(orientation, start, target, limits) };
        let t_frame = frame.time_to_frame(duration);
        if acc0_acc1_reduced_jerk(&frame, t_frame, &mut s2) || patterns::try_all(&frame, t_frame, &mut s2) {
            return Some(s2.profile);
        }
    }
    None
}

/// The cruise family evaluated at one cruise velocity.
#[derive(Clone, Copy, Debug)]
struct CruiseEval {
    first: Half,
    second: Half,
    /// Cruise duration T - T1 - T2.
    g: f64,
    /// Position residual.
    f: f64,
    /// dF/dv_c.
    df: f64,
    /// d(T1 + T2)/dv_c.
    ds: f64,
    /// Magnitude of the terms F is made of (for the stopping test).
    scale: f64,
}

struct Cruise<'f> {
    f: &'f Frame,
    t_total: f64,
}

impl Cruise<'_> {
    fn eval(&self, vc: f64) -> Option<CruiseEval> {
        let f = self.f;
        let first = change_to_cruise(f.v0, f.a0, vc, f.a_min, 1.0)?;
        let second = change_from_cruise(vc, f.vf, f.af, f.a_min, 1.0)?;
        let g = self.t_total - first.dur - second.dur;
        let res = first.dist + second.dist + vc * g - f.pd;
        // Each change lasts longer the further v_c is from where it is shortest.
        let ds = first.j[0] / first.peak - second.j[0] / second.peak;
        Some(CruiseEval {
            first,
            second,
            g,
            f: res,
            df: g + 0.5 * (first.peak + second.peak),
            ds,
            scale: f.pd.abs() + first.dist.abs() + second.dist.abs() + (vc * g).abs(),
        })
    }

    fn candidate(&self, e: &CruiseEval) -> Candidate {
        let (a, b) = (e.first, e.second);
        let signs = if a.j[0] == b.j[0] { JerkSigns::Udud } else { JerkSigns::Uddu };
        let limits = match (a.at_limit, b.at_limit) {
            (true, true) => ReachedLimits::Acc0Acc1Vel,
            (true, false) => ReachedLimits::Acc0Vel,
            (false, true) => ReachedLimits::Acc1Vel,
            (false, false) => ReachedLimits::Vel,
        };
        Candidate {
            t: [a.t[0], a.t[1], a.t[2], e.g.max(0.0), b.t[0], b.t[1], b.t[2]],
            j: [a.j[0], a.j[1], a.j[2], 0.0, b.j[0], b.j[1], b.j[2]],
            limits,
            signs,
            polish: Polish::NONE,
        }
    }
}

/// Root of a continuous function on [lo, hi] with `f(lo) ≤ 0 ≤ f(hi)` (or the reverse): Newton
/// steps kept inside the bracket, bisection otherwise. `eval` returns (f, f').
fn bracketed_root(mut lo: f64, mut hi: f64, increasing: bool, eval: impl Fn(f64) -> Option<(f64, f64)>) -> f64 {
    let mut x = 0.5 * (lo + hi);
    for _ in 0..BRACKET_MAX_ITERATIONS {
        let Some((fx, dfx)) = eval(x) else {
            // Outside the domain of the closed forms (rounding at a case border): bisect.
            x = 0.5 * (lo + hi);
            hi = x;
            continue;
        };
        if fx == 0.0 {
            return x;
        }
        if (fx > 0.0) == increasing {
            hi = x;
        } else {
            lo = x;
        }
        if hi - lo <= CRUISE_ROOT_REL * lo.abs().max(hi.abs()) {
            return 0.5 * (lo + hi);
        }
        let newton = x - fx / dfx;
        x = if newton > lo && newton < hi && newton.is_finite() { newton } else { 0.5 * (lo + hi) };
        if x == lo || x == hi {
            return x;
        }
    }
    x
}

/// Cruise family: find a cruise velocity with a non-negative cruise duration and zero position
/// residual.
fn cruise_family(f: &Frame, t_total: f64, s2: &mut Step2) -> bool {
    let cruise = Cruise { f, t_total };
    let (v_lo, v_hi) = (f.v_min, f.v_max);
    let converged = |e: &CruiseEval| e.f.abs() <= 8.0 * f64::EPSILON * e.scale;

    // Quick attempt: Newton from the mean velocity (the usual case: one root, long cruise).
    let mut vc = (f.pd / t_total).clamp(v_lo, v_hi);
    if !vc.is_finite() {
        vc = 0.0;
    }
    for _ in 0..QUICK_NEWTON_ITERATIONS {
        let Some(e) = cruise.eval(vc) else { break };
        if e.g >= 0.0 && converged(&e) {
            if s2.try_candidate(f, &cruise.candidate(&e)) {
                return true;
            }
            break;
        }
        if !(e.df > 0.0) {
            break;
        }
        let next = (vc - e.f / e.df).clamp(v_lo, v_hi);
        if next == vc {
            break;
        }
        vc = next;
    }

    // Full search over the (at most two) intervals of cruise velocities with g ≥ 0.
    let m1 = (f.v0 + 0.5 * f.a0 * f.a0.abs()).clamp(v_lo, v_hi);
    let m2 = (f.vf - 0.5 * f.af * f.af.abs()).clamp(v_lo, v_hi);
    let (lo, hi) = if m1 <= m2 { (m1, m2) } else { (m2, m1) };
    let g_at = |v: f64| cruise.eval(v).map(|e| e.g);
    let slack = |v: f64| -> Option<(f64, f64)> { cruise.eval(v).map(|e| (e.g, -e.ds)) };
    let (Some(g_lo), Some(g_hi)) = (g_at(lo), g_at(hi)) else {
        return false;
    };
    let mut intervals = [(0.0, 0.0); 2];
    let mut n_intervals = 0;
    // Left arm [v_min, lo]: g increasing.
    let left_end = if g_lo >= 0.0 {
        Some(if g_at(v_lo).is_some_and(|g| g >= 0.0) { v_lo } else { bracketed_root(v_lo, lo, true, slack) })
    } else {
        None
    };
    // Right arm [hi, v_max]: g decreasing.
    let right_end = if g_hi >= 0.0 {
        Some(if g_at(v_hi).is_some_and(|g| g >= 0.0) { v_hi } else { bracketed_root(hi, v_hi, false, slack) })
    } else {
        None
    };
    // Middle [lo, hi]: g convex.
    match (left_end, right_end) {
        (Some(l), Some(r)) => {
            // Minimum of g where its derivative changes sign.
            let v_peak =
                if hi > lo { bracketed_root(lo, hi, true, |v| cruise.eval(v).map(|e| (-e.ds, 0.0))) } else { lo };
            if g_at(v_peak).is_some_and(|g| g >= 0.0) {
                intervals[0] = (l, r);
                n_intervals = 1;
            } else {
                intervals[0] = (l, bracketed_root(lo, v_peak, false, slack));
                intervals[1] = (bracketed_root(v_peak, hi, true, slack), r);
                n_intervals = 2;
            }
        }
        (Some(l), None) => {
            intervals[0] = (l, bracketed_root(lo, hi, false, slack));
            n_intervals = 1;
        }
        (None, Some(r)) => {
            intervals[0] = (bracketed_root(lo, hi, true, slack), r);
            n_intervals = 1;
        }
        (None, None) => {}
    }
    for &(a, b) in &intervals[..n_intervals] {
        let (Some(ea), Some(eb)) = (cruise.eval(a), cruise.eval(b)) else {
            continue;
        };
        if ea.f > 0.0 || eb.f < 0.0 {
            continue;
        }
        let root = if ea.f == 0.0 {
            a
        } else if eb.f == 0.0 {
            b
        } else {
            bracketed_root(a, b, true, |v| cruise.eval(v).map(|e| (e.f, e.df)))
        };
        if let Some(e) = cruise.eval(root) {
            if e.g >= -8.0 * f64::EPSILON * t_total && s2.try_candidate(f, &cruise.candidate(&e)) {
                return true;
            }
        }
    }
    false
}

/// Both acceleration limits, no cruise, jerk reduced to j = 1/u ≤ 1 so that the profile lasts T
/// (the step-1 ACC0_ACC1 profile slowed down). The position equation is a quadratic in u.
fn acc0_acc1_reduced_jerk(f: &Frame, t_total: f64, s2: &mut Step2) -> bool {
    let (v0, a0, vf, af, pd, tt) = (f.v0, f.a0, f.vf, f.af, f.pd, t_total);
    let r = -f.a_min;
    if a0 > 1.0 || af < f.a_min {
        return false;
    }
    let vd = vf - v0;
    let (a0_2, af_2, r_2) = (a0 * a0, af * af, r * r);
    let up = (1.0 - a0) * (1.0 - a0);
    let down = (af + r) * (af + r);
    let k2 = (a0 - af)
        * (-3.0 * a0 * a0_2 - 3.0 * a0_2 * af - 4.0 * a0_2 * r
            + 8.0 * a0_2
            + 3.0 * a0 * af_2
            + 8.0 * a0 * af * r
            + 8.0 * a0 * af
            + 6.0 * a0 * r_2
            + 12.0 * a0 * r
            - 6.0 * a0
            + 3.0 * af * af_2
            + 8.0 * af_2 * r
            - 4.0 * af_2
            + 6.0 * af * r_2
            - 12.0 * af * r
            - 6.0 * af
            - 12.0 * r_2
            - 12.0 * r);
    let k1 = -12.0 * (tt * (r * up + down) + vd * (up - down));
    let k0 = 12.0 * (tt * tt * r + 2.0 * tt * (r * v0 + vf) - 2.0 * pd * (r + 1.0) - vd * vd);
    let r1 = r + 1.0;
    for &u in solve_quadratic(k2, k1, k0).as_slice() {
        if !(u >= 1.0 - JERK_SLACK_REL) {
            continue;
        }
        let hold0 = (tt * r + vd + u * (0.5 * (a0_2 - af_2) + r * (a0 - af) - r1 * r1)) / r1;
        let hold1 = (tt - vd + u * (0.5 * (af_2 - a0_2) + a0 - af - r1 * r1)) / r1;
        let jf = 1.0 / u;
        let c = Candidate {
            t: [(1.0 - a0) * u, hold0, u, 0.0, r * u, hold1, (af + r) * u],
            j: [jf, 0.0, -jf, 0.0, -jf, 0.0, jf],
            limits: ReachedLimits::Acc0Acc1,
            signs: JerkSigns::Uddu,
            polish: Polish::NONE,
        };
        if s2.try_candidate(f, &c) {
            return true;
        }
    }
    false
}
