//! The fastest stop along the path from any state of the planned motion: every chunk the
//! planner thread queues carries one (its tail), so a feed hold, a stop or an underrun never
//! needs the planner at that moment.
//!
//! The stop is the time-optimal jerk-limited brake in path space (jerk −J down to the
//! deceleration A, hold, jerk +J up to rest; the trajectory generator's closed form
//! [`interpd_otg::scurve::brake_to_rest`]) under constant path limits, checked afterwards
//! against every axis limit along the exact geometry (chain rule with A′, A″, A‴ at a fine
//! time step). A stop that fails the check is retried with gentler path limits; a stop that
//! would pass the next exact stop of the path (a corner, the program end) is refused, and the
//! caller ends its chunk elsewhere. So a tail is valid by measurement, not by assumption.

use super::{Limits, Segment};
use crate::path::{AxisDerivs, JointKind, Path};
use interpd_otg::scurve::brake_to_rest;

/// Path limits tried, as fractions of the smallest axis acceleration and jerk limits.
const GENTLER: [f64; 7] = [1.0, 0.6, 0.35, 0.2, 0.12, 0.07, 0.04];
/// Time step of the limit check along a stop, s.
const CHECK_STEP_S: f64 = 2.5e-4;
/// Relative slack when the deceleration is released just in time to reach rest.
const UNDERSHOOT_REL_TOL: f64 = 1e-9;
/// Relative slack of the limit check (rounding only; the limits are already the planner's).
const CHECK_REL_TOL: f64 = 1e-9;

/// Where the path next requires rest after `s_mm`: the next corner or dwell, or its end.
pub(crate) fn next_stop_s(path: &Path, s_mm: f64) -> f64 {
    let from = path.element_index_at(s_mm) + 1;
    path.elements[from.min(path.elements.len())..]
        .iter()
        .find(|e| e.stops_before() || e.joint == JointKind::Corner)
        .map_or(path.length_mm(), |e| e.s_start_mm)
}

/// The fastest stop from (s, v ≥ 0, a) that keeps every axis limit in `lim` along `path`
/// and ends before `s_limit_mm`; segments from time 0. Empty at rest; `None` if none of the
/// tried path limits gives one.
pub(crate) fn brake_along(
    path: &Path,
    s_mm: f64,
    v: f64,
    a: f64,
    lim: &Limits,
    s_limit_mm: f64,
    line: u32,
) -> Option<Vec<Segment>> {
    if v <= 1e-9 && a.abs() <= 1e-9 {
        return Some(Vec::new());
    }
    let (acc0, jerk0) = (lim.min_acc(), lim.min_jerk());
    // Candidate path limits, fastest stop first; at speed on a curve the jerk the axes leave
    // for braking is small (A‴v³ takes most of it), the acceleration less so.
    let mut candidates: Vec<(f64, [(f64, f64); 3])> = Vec::with_capacity(GENTLER.len() * GENTLER.len());
    for fa in GENTLER {
        for fj in GENTLER {
            let (acc, jerk) = ((acc0 * fa).max(-a), jerk0 * fj);
            if a < 0.0 && v < a * a / (2.0 * jerk) * (1.0 - UNDERSHOOT_REL_TOL) {
                // Releasing the deceleration with this jerk would reverse the motion.
                continue;
            }
            let phases = brake_to_rest(v, a, acc, jerk);
            candidates.push((phases.iter().map(|p| p.0).sum(), phases));
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0));
    for (_, phases) in candidates {
        let segments = segments_of(s_mm, v, a, &phases, line);
        let end = segments.last().map_or(s_mm, Segment::s1_mm);
        if end <= s_limit_mm && keeps_limits(path, &segments, lim) && passes_curvature_jumps(path, &segments, lim) {
            return Some(segments);
        }
    }
    None
}

/// Constant-jerk segments from (s, v, a) through `phases`.
fn segments_of(s_mm: f64, v: f64, a: f64, phases: &[(f64, f64)], line: u32) -> Vec<Segment> {
    let mut out = Vec::with_capacity(phases.len());
    let (mut s, mut vv, mut aa, mut t) = (s_mm, v, a, 0.0);
    for &(dt, j) in phases {
        if dt <= 0.0 {
            continue;
        }
        let ds = (vv * dt + 0.5 * aa * dt * dt + j * dt * dt * dt / 6.0).max(0.0);
        out.push(Segment { s0_mm: s, t0_s: t, v0: vv, a0: aa, j, dt_s: dt, ds_mm: ds, line });
        s += ds;
        vv += aa * dt + 0.5 * j * dt * dt;
        aa += j * dt;
        t += dt;
    }
    out
}

/// Every axis keeps its velocity, acceleration and jerk limit along `segments` (checked at
/// `CHECK_STEP_S` and at segment ends, on both sides of element joints).
fn keeps_limits(path: &Path, segments: &[Segment], lim: &Limits) -> bool {
    let mut d = AxisDerivs::default();
    let check = |s: f64, v: f64, a: f64, j: f64, left: bool, d: &mut AxisDerivs| {
        if left {
            path.eval_left(s, d)
        } else {
            path.eval(s, d)
        }
        (0..lim.n_axes).all(|k| {
            let vel = d.d1[k] * v;
            let acc = d.d2[k] * v * v + d.d1[k] * a;
            let jerk = d.d3[k] * v * v * v + 3.0 * d.d2[k] * v * a + d.d1[k] * j;
            // Against the configured limits: the planner aims at `limit_fraction` of them and
            // its states can sit a hair above that between nodes.
            let tol = 1.0 + CHECK_REL_TOL;
            vel.abs() <= lim.configured_vel[k] * tol
                && acc.abs() <= lim.configured_acc[k] * tol
                && jerk.abs() <= lim.configured_jerk[k] * tol
        })
    };
    for seg in segments {
        let n = (seg.dt_s / CHECK_STEP_S).ceil().max(1.0) as usize;
        for i in 0..=n {
            let st = seg.at(seg.dt_s * i as f64 / n as f64);
            if !check(st.s_mm, st.v.max(0.0), st.a, seg.j, false, &mut d)
                || !check(st.s_mm, st.v.max(0.0), st.a, seg.j, true, &mut d)
            {
                return false;
            }
        }
    }
    true
}

/// Every curvature jump (G¹ but not G² joint) the stop passes after its start is passed slowly
/// enough: the axis acceleration steps by ΔA″_k·v² there, invisible to the check on either
/// side, so the speed must keep the step within what the jerk limit moves in
/// `lim.curvature_jump_s`, as the planner caps its nodes (`node.rs` `curvature_jump_cap`).
fn passes_curvature_jumps(path: &Path, segments: &[Segment], lim: &Limits) -> bool {
    let (Some(first), Some(last)) = (segments.first(), segments.last()) else { return true };
    let (s_from, s_to) = (first.s0_mm, last.s1_mm());
    let (mut left, mut right) = (AxisDerivs::default(), AxisDerivs::default());
    let from = path.element_index_at(s_from);
    for e in path.elements[from..].iter().take_while(|e| e.s_start_mm <= s_to) {
        if e.joint != JointKind::CurvatureJump || e.s_start_mm <= s_from {
            continue;
        }
        let s = e.s_start_mm;
        let k = segments.partition_point(|seg| seg.s1_mm() < s).min(segments.len() - 1);
        let seg = &segments[k];
        // Time in the segment at which it reaches the joint (s(τ) is monotone while v ≥ 0).
        let (mut lo, mut hi) = (0.0, seg.dt_s);
        for _ in 0..JOINT_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if seg.at(mid).s_mm < s { lo = mid } else { hi = mid }
        }
        let v = seg.at(hi).v.max(0.0);
        path.eval_left(s, &mut left);
        path.eval(s, &mut right);
        let step_ok = (0..lim.n_axes).all(|k| {
            v * v * (left.d2[k] - right.d2[k]).abs() <= lim.jerk[k] * lim.curvature_jump_s * (1.0 + CHECK_REL_TOL)
        });
        if !step_ok {
            return false;
        }
    }
    true
}

/// Bisection steps locating a joint inside a stop's segment.
const JOINT_BISECTIONS: usize = 60;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Settings;
    use crate::program;
    use interpd_config::Config;

    fn end_state(v: f64, a: f64, acc: f64, jerk: f64) -> (f64, f64, f64) {
        let (mut vv, mut aa, mut t) = (v, a, 0.0);
        for (dt, j) in brake_to_rest(v, a, acc, jerk) {
            assert!(dt >= 0.0);
            vv += aa * dt + 0.5 * j * dt * dt;
            aa += j * dt;
            t += dt;
            assert!(aa >= -acc * (1.0 + 1e-12), "acceleration {aa} below −{acc}");
        }
        (vv, aa, t)
    }

    #[test]
    fn all_cases_end_at_rest() {
        for &(v, a) in &[
            (200.0, 0.0),
            (200.0, 2000.0),
            (5.0, 0.0),
            (50.0, -1500.0),
            (2.0, -400.0),
            (57.6, -2400.0),
            (250.0, -2500.0),
        ] {
            let (ve, ae, t) = end_state(v, a, 2500.0, 50_000.0);
            assert!(
                ve.abs() < 1e-9 * v.max(1.0) + 1e-9 && ae.abs() < 1e-9,
                "from ({v}, {a}): ends ({ve}, {ae}) after {t}"
            );
        }
    }

    #[test]
    fn cruise_stop_takes_the_textbook_time() {
        // 250 mm/s, A 2500, J 50000: t = v/A + A/J = 0.1 + 0.05.
        let (_, _, t) = end_state(250.0, 0.0, 2500.0, 50_000.0);
        assert!((t - 0.15).abs() < 1e-12);
    }

    fn stop_checked(text: &str, at_s: f64) -> Option<(Vec<Segment>, f64)> {
        let cfg = Config::default_machine();
        let p = program::parse(text, "t.ngc", &Settings::from(&cfg)).unwrap();
        let (segs, _) = crate::planner::Planner::plan_path(&Settings::from(&cfg), &p.path).unwrap();
        let mut cur = crate::planner::profile::Cursor::default();
        let st = cur.sample(&segs, at_s).unwrap().state;
        let lim = Limits::from_settings(&Settings::from(&cfg));
        brake_along(&p.path, st.s_mm, st.v, st.a, &lim, next_stop_s(&p.path, st.s_mm), 1).map(|s| (s, st.v))
    }

    #[test]
    fn stops_pass_a_curvature_jump_no_faster_than_the_planner_does() {
        // demo.ngc's quarter arc into a line (G¹, not G²) at (80, 50), s = 190.708 mm, met at
        // the speeds and decelerations a lowered feed override brakes with.
        let text = "G1 X90 Y0 F6000\nG1 X90 Y40\nG3 X80 Y50 I-10 J0\nG1 X10 Y50";
        let cfg = Config::default_machine();
        let settings = Settings::from(&cfg);
        let p = program::parse(text, "t.ngc", &settings).unwrap();
        let lim = Limits::from_settings(&settings);
        let joint = p.path.elements[3].s_start_mm;
        assert_eq!(p.path.elements[3].joint, JointKind::CurvatureJump);
        let (mut left, mut right) = (AxisDerivs::default(), AxisDerivs::default());
        p.path.eval_left(joint, &mut left);
        p.path.eval(joint, &mut right);
        let cap = (0..lim.n_axes)
            .filter(|&k| left.d2[k] != right.d2[k])
            .map(|k| (lim.jerk[k] * lim.curvature_jump_s / (left.d2[k] - right.d2[k]).abs()).sqrt())
            .fold(f64::INFINITY, f64::min);
        let mut crossing = 0;
        for &(before_mm, v, a) in
            &[(5.0, 111.0, -530.0), (2.0, 70.0, -1500.0), (1.0, 60.0, -1670.0), (0.5, 20.0, 0.0), (0.001, 0.8, 0.0)]
        {
            let s0 = joint - before_mm;
            let Some(stop) = brake_along(&p.path, s0, v, a, &lim, next_stop_s(&p.path, s0), 7) else { continue };
            let Some(seg) = stop.iter().find(|seg| seg.s1_mm() >= joint) else { continue };
            crossing += 1;
            let (mut lo, mut hi) = (0.0, seg.dt_s);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if seg.at(mid).s_mm < joint { lo = mid } else { hi = mid }
            }
            let at = seg.at(hi).v;
            assert!(at <= cap * (1.0 + 1e-6), "from {before_mm} mm before at {v} mm/s: passes at {at} mm/s > {cap}");
        }
        // The slow one passes it (below the cap); the fast ones stop before it or are refused.
        assert!(crossing >= 1, "no stop passes the joint (cap {cap:.3} mm/s)");
    }

    #[test]
    fn stops_on_a_circle_at_speed_keep_the_limits() {
        let text = "G1 X10 F12000\nG2 X10 Y0 I-10 J0\nG1 X0";
        let mut found = 0;
        for i in 1..40 {
            let Some((stop, v)) = stop_checked(text, 0.0125 * i as f64) else { continue };
            found += 1;
            let end = stop.last().map(|s| s.at(s.dt_s));
            assert!(end.is_none_or(|e| e.v.abs() < 1e-9), "from {v}: {end:?}");
            assert!(crate::planner::profile::duration_s(&stop) < 1.0);
        }
        eprintln!("stops found at {found} of 39 instants");
        // This circle runs at three limits at once (160 mm/s on R10: A‴v³ alone is 80 % of the
        // jerk limit): a constant-jerk stop fits only at some instants, and the planner thread
        // ends its chunks there.
        assert!(found >= 10, "stops found at {found} of 39 instants");
    }
}
