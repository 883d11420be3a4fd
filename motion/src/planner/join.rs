//! Exact join of a branch onto another branch's state (Kopp et al. 2019, §3.3): two intervals whose
//! middle velocity is chosen so the second ends with the target's velocity and acceleration.

use super::check::{VIOLATION_TOL, jerk_range, violates, violation};
use super::interval::Interval;
use super::limits::Limits;
use super::step::Work;
use super::view::View;

/// Samples when bracketing the join equation. Most joins tried fail without a bracket (a
/// braking ramp tries one at every node near the branch), and a failed scan costs all of them;
/// a finer scan finds no more joins.
const JOIN_SAMPLES: usize = 8;
/// Bisection steps on the join equation.
const JOIN_ITERS: usize = 60;
/// The joined acceleration may miss the target by this, relative to (|a| + 1).
const JOIN_ACC_REL_TOL: f64 = 1e-6;

/// The lowest middle velocity a two-interval join tries, as a share of the slower end's.
const JOIN_LOWEST_MIDDLE_SHARE: f64 = 0.5;

/// Whether a two-interval join from (v, a) at traversal position `t` can reach the branch state
/// `target` = (v, a) at t+2 with the jerk the axes allow: a cheap test [`join_two`] runs first.
/// The joined acceleration changes by j₁T₁ + j₂T₂. The join checks the first interval at its
/// start node and the second at its end node, so j₁ must lie in the jerk range the axes allow
/// at t for (v, a), and j₂ in the one at t+2 for `target`. With T₁ + T₂ at most the distance
/// over half the slower end's velocity (the lowest middle velocity [`join_two`] tries), the
/// change lies between the lower ends' smaller (or zero) and the upper ends' larger (or zero)
/// times that time. A braking ramp that grazes a branch passes dozens of nodes close to it
/// where no join can work, and each failed attempt would cost a full scan.
fn join_in_reach(view: &View, t: usize, v: f64, a: f64, target: (f64, f64), lim: &Limits) -> bool {
    let (lo1, hi1) = jerk_range(view.start_geom(t), view.sign(), v, a, lim);
    let (lo2, hi2) = jerk_range(view.end_geom(t + 2), view.sign(), target.0, target.1, lim);
    let v_low = JOIN_LOWEST_MIDDLE_SHARE * v.min(target.0);
    if lo1 > hi1 || lo2 > hi2 || v_low <= 0.0 {
        return true; // no estimate (the join's checks allow rounding): let the join decide
    }
    let t_max = (view.node(t + 2).s_mm - view.node(t).s_mm).abs() / v_low;
    let da = target.1 - a;
    da >= lo1.min(lo2).min(0.0) * t_max && da <= hi1.max(hi2).max(0.0) * t_max
}

/// Exact join (Kopp et al. 2019, §3.3): from (v, a) at node t onto the backward branch's state at
/// node t+2, through a velocity at t+1 found by bisection on the acceleration mismatch.
pub(super) fn join_two(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    target: (f64, f64),
    lim: &Limits,
    work: &mut Work,
) -> Option<(Interval, Interval)> {
    if !join_in_reach(view, t, v, a, target, lim) {
        return None;
    }
    let (vt, at) = target;
    let (g1, g2) = (view.interval_geom(t), view.interval_geom(t + 1));
    let v_hi = view.node(t + 1).vbar_mm_s;
    let mismatch = |x: f64, work: &mut Work| -> Option<(f64, Interval, Interval)> {
        work.evals += 2;
        let i1 = Interval::through(v, a, g1.ds_mm, x)?;
        let i2 = Interval::through(x, i1.a1(), g2.ds_mm, vt)?;
        Some((i2.a1() - at, i1, i2))
    };
    let lo_v = JOIN_LOWEST_MIDDLE_SHARE * v.min(vt);
    let hi_v = v_hi.min(1.5 * v.max(vt) + 1e-9);
    let mut prev: Option<(f64, f64)> = None;
    let mut bracket = None;
    for k in 0..=JOIN_SAMPLES {
        let x = lo_v + (hi_v - lo_v) * k as f64 / JOIN_SAMPLES as f64;
        if let Some((f, _, _)) = mismatch(x, work) {
            if let Some((xp, fp)) = prev {
                if fp.signum() != f.signum() {
                    bracket = Some((xp, fp, x, f));
                    break;
                }
            }
            prev = Some((x, f));
        }
    }
    let Some((mut lo, mut f_lo, mut hi, mut f_hi)) = bracket else {
        tracing::trace!(t, v, a, vt, at, lo_v, hi_v, "join: no bracket");
        return None;
    };
    // Regula falsi with the Illinois modification: superlinear on this smooth mismatch, with
    // the bracket kept (a plain bisection needs ~45 steps for the same tolerance).
    let mut best = None;
    let mut side = 0i8;
    for _ in 0..JOIN_ITERS {
        let x = if f_hi != f_lo {
            (lo - f_lo * (hi - lo) / (f_hi - f_lo)).clamp(lo.min(hi), lo.max(hi))
        } else {
            0.5 * (lo + hi)
        };
        let (f, i1, i2) = mismatch(x, work)?;
        best = Some((f, i1, i2));
        if f.abs() <= JOIN_ACC_REL_TOL * 1e-3 * (at.abs() + 1.0) || (hi - lo).abs() <= 1e-14 * hi.abs().max(1e-12) {
            break;
        }
        if f.signum() == f_lo.signum() {
            lo = x;
            f_lo = f;
            if side == 1 {
                f_hi *= 0.5;
            }
            side = 1;
        } else {
            hi = x;
            f_hi = f;
            if side == -1 {
                f_lo *= 0.5;
            }
            side = -1;
        }
    }
    let (f, i1, i2) = best?;
    if f.abs() > JOIN_ACC_REL_TOL * (at.abs() + 1.0) {
        return None;
    }
    let (f1, f2) = (violation(&i1, &g1, lim), violation(&i2, &g2, lim));
    if f1 > VIOLATION_TOL || f2 > VIOLATION_TOL {
        tracing::trace!(t, v, a, vt, at, x = i1.v1(), f1, f2, j1 = i1.j, j2 = i2.j, "join: violates");
        return None;
    }
    Some((i1, i2))
}

/// Samples of the first middle velocity in a three-interval join.
const JOIN3_SAMPLES: usize = 16;

/// Exact join over three intervals, from (v, a) at node t onto `target` at node t+3: the
/// velocity at t+1 is scanned between the two ends' velocities (and a little beyond), and for
/// each the two-interval join from t+1 fixes the velocity at t+2. One more degree of freedom
/// than [`join_two`], for states farther from the branch. The highest feasible path wins.
pub(super) fn join_three(
    view: &View,
    t: usize,
    v: f64,
    a: f64,
    target: (f64, f64),
    lim: &Limits,
    work: &mut Work,
) -> Option<[Interval; 3]> {
    if t + 3 >= view.len() {
        return None;
    }
    let g1 = view.interval_geom(t);
    let (lo, hi) = (v.min(target.0), v.max(target.0));
    let span = (hi - lo).max(1e-9 * hi.max(1.0));
    let v_cap = view.node(t + 1).vbar_mm_s;
    let mut best: Option<[Interval; 3]> = None;
    for k in 0..=JOIN3_SAMPLES {
        let x = (lo - 0.25 * span + 1.5 * span * k as f64 / JOIN3_SAMPLES as f64).min(v_cap);
        if x <= 0.0 {
            continue;
        }
        work.evals += 1;
        let Some(i1) = Interval::through(v, a, g1.ds_mm, x) else { continue };
        if violates(&i1, &g1, lim) {
            continue;
        }
        if let Some((i2, i3)) = join_two(view, t + 1, i1.v1(), i1.a1(), target, lim, work) {
            let better = best.as_ref().is_none_or(|b| i1.v1() + i2.v1() > b[0].v1() + b[1].v1());
            if better {
                best = Some([i1, i2, i3]);
            }
        }
    }
    best
}
