//! Axis limits along an interval (Kopp et al. 2019, eq. 7b–7d): the chain rule of eq. 1a–1c
//! evaluated at the nodes (with the interval's own jerk on both ends, since jerk jumps at
//! nodes) and at interior points, so the continuous motion keeps the limits and not only the
//! samples. The paper checks the nodes only; between them the axis jerk varies while the path
//! jerk is constant.
//!
//! Between the nodes the geometry is interpolated from the node data: on smoothed pieces A′ by
//! the quintic Hermite that matches A′, A″ and A‴ at both ends, A″ and A‴ as its derivatives
//! ([`HermiteBasis`]); elsewhere A′ and A″ by cubic Hermite (their derivatives A″, A‴ are known
//! at both ends), A‴ linearly ([`CubicBasis`]). The sampling keeps intervals short enough that
//! this is accurate to well inside the limit headroom.

use super::hermite_basis::HermiteBasis;
use super::interval::Interval;
use super::limits::Limits;
use super::node::{IntervalGeom, NodeGeom, SpanPoly};

/// Violations up to this (relative to the limit) are rounding, not a breach: the limits the
/// planner works with already keep `planner.limit_fraction` of headroom.
pub(super) const VIOLATION_TOL: f64 = 1e-12;

/// Points inside an interval (fractions of its duration) where the limits are checked.
pub(super) const CHECK_FRACTIONS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];
/// The same on a path table's interval that the nodes do not interpolate well
/// (`SpanPoly::fine_checks`): such intervals are long (rows split by time only) and their
/// geometry can bulge between five points, enough to use up most of the headroom the
/// planner's `limit_fraction` keeps; seven points keep the motion within it, and more cost
/// time without a gain.
pub(super) const FINE_CHECK_FRACTIONS: [f64; 7] = [0.0, 1.0 / 6.0, 2.0 / 6.0, 0.5, 4.0 / 6.0, 5.0 / 6.0, 1.0];

/// The check points of interval `g`.
#[inline]
fn check_fractions(g: &IntervalGeom) -> &'static [f64] {
    if g.fine_checks() { &FINE_CHECK_FRACTIONS } else { &CHECK_FRACTIONS }
}

/// Geometry at fraction σ of the interval's length: exact where the interval has a
/// [`SpanPoly`], else interpolated.
#[inline]
pub(super) fn geom_at(g: &IntervalGeom, sigma: f64, k: usize) -> (f64, f64, f64) {
    match g.span {
        Some(p) => span_at(g, p, &span_powers(g, sigma), k),
        None if g.quintic => hermite_at(g, &HermiteBasis::at(sigma, g.ds_mm), k),
        None => cubic_at(g, &CubicBasis::at(sigma), k),
    }
}

/// [`geom_at`] for the first `n_axes` axes, as a node's geometry (the powers or the basis at σ
/// computed once for all of them).
pub(super) fn node_geom_at(g: &IntervalGeom, sigma: f64, n_axes: usize) -> NodeGeom {
    let mut ng = NodeGeom::default();
    let mut put = |k: usize, (d1, d2, d3): (f64, f64, f64)| (ng.d1[k], ng.d2[k], ng.d3[k]) = (d1, d2, d3);
    match g.span {
        Some(p) => {
            let powers = span_powers(g, sigma);
            (0..n_axes).for_each(|k| put(k, span_at(g, p, &powers, k)));
        }
        None if g.quintic => {
            let h = HermiteBasis::at(sigma, g.ds_mm);
            (0..n_axes).for_each(|k| put(k, hermite_at(g, &h, k)));
        }
        None => {
            let h = CubicBasis::at(sigma);
            (0..n_axes).for_each(|k| put(k, cubic_at(g, &h, k)));
        }
    }
    ng
}

/// The cubic Hermite basis at fraction σ, shared by the axes of one point (every interval
/// but the smoothed pieces' steps that need the quintic one: see [`IntervalGeom::quintic`]).
#[derive(Clone, Copy)]
pub(super) struct CubicBasis {
    pub sigma: f64,
    pub h00: f64,
    pub h10: f64,
    pub h01: f64,
    pub h11: f64,
}

impl CubicBasis {
    #[inline(always)]
    pub(super) fn at(sigma: f64) -> Self {
        let (s2, s3) = (sigma * sigma, sigma * sigma * sigma);
        CubicBasis {
            sigma,
            h00: 2.0 * s3 - 3.0 * s2 + 1.0,
            h10: s3 - 2.0 * s2 + sigma,
            h01: -2.0 * s3 + 3.0 * s2,
            h11: s3 - s2,
        }
    }
}

/// The geometry of axis `k` interpolated from the nodes: A′ and A″ by cubic Hermite (their
/// derivatives are known at both ends), A‴ linearly.
#[inline(always)]
fn cubic_at(g: &IntervalGeom, h: &CubicBasis, k: usize) -> (f64, f64, f64) {
    let (a, b, sg, ds) = (g.start, g.end, g.sign, g.ds_mm);
    let d1 = sg * (h.h00 * a.d1[k] + h.h01 * b.d1[k]) + ds * (h.h10 * a.d2[k] + h.h11 * b.d2[k]);
    let d2 = h.h00 * a.d2[k] + h.h01 * b.d2[k] + sg * ds * (h.h10 * a.d3[k] + h.h11 * b.d3[k]);
    let d3 = sg * ((1.0 - h.sigma) * a.d3[k] + h.sigma * b.d3[k]);
    (d1, d2, d3)
}

/// The geometry of axis `k` interpolated from the nodes by the quintic Hermite A′ of
/// [`HermiteBasis`]. The sums run in the order `lanes` runs them, so both give the same bits.
#[inline(always)]
fn hermite_at(g: &IntervalGeom, h: &HermiteBasis, k: usize) -> (f64, f64, f64) {
    let (a, b, sg) = (g.start, g.end, g.sign);
    let (p0, p1) = (sg * a.d1[k], sg * b.d1[k]);
    let (q0, q1) = (a.d2[k], b.d2[k]);
    let (r0, r1) = (sg * a.d3[k], sg * b.d3[k]);
    let d = p1 - p0;
    let w = &h.d1;
    let d1 = w[0] * p0 + w[1] * p1 + w[2] * q0 + w[3] * q1 + w[4] * r0 + w[5] * r1;
    let w = &h.d2;
    let d2 = w[0] * d + w[1] * q0 + w[2] * q1 + w[3] * r0 + w[4] * r1;
    let w = &h.d3;
    let d3 = w[0] * d + w[1] * q0 + w[2] * q1 + w[3] * r0 + w[4] * r1;
    (d1, d2, d3)
}

/// [`SpanPoly::powers`] at fraction σ of the interval in traversal order: traversed
/// backwards, σ counts from the far end.
#[inline(always)]
fn span_powers(g: &IntervalGeom, sigma: f64) -> [f64; 7] {
    SpanPoly::powers(if g.sign > 0.0 { sigma } else { 1.0 - sigma })
}

/// The exact geometry of axis `k` in traversal order (A′ and A‴ flip backwards, see `sign`).
#[inline(always)]
fn span_at(g: &IntervalGeom, p: &SpanPoly, powers: &[f64; 7], k: usize) -> (f64, f64, f64) {
    let (d1, d2, d3) = p.at(powers, k);
    (g.sign * d1, d2, g.sign * d3)
}

/// Interior points (fractions of the length) where the velocity bound is evaluated; on the
/// intervals that get [`FINE_CHECK_FRACTIONS`], at those.
pub(super) const VBAR_FRACTIONS: [f64; 3] = [0.25, 0.5, 0.75];

/// The lowest velocity bounds inside an interval (on its geometry, see [`geom_at`]): the
/// acceleration-only bound and the flat v̄ (Kopp et al. 2019, eq. 6), as (`velocity_bound`,
/// `flat_velocity_bound`). A minimum between two nodes must lower the nodes' bounds, or a
/// branch starting there at v̄ with a = 0 would break a limit a little further on; the
/// planner lowers the acceleration-only bound only by a minimum below both nodes'
/// (`Planner::refine_vbar`), and never at a stop.
pub(super) fn interior_vbar(g: &IntervalGeom, lim: &Limits) -> (f64, f64) {
    if let Some(bounds) = g.span.and_then(SpanPoly::interior_vbar) {
        return bounds;
    }
    interior_vbar_around(g, lim, None, f64::INFINITY)
}

/// [`interior_vbar`] computed, with the geometry at the middle (σ = ½, one of every set of
/// fractions) and its `flat_velocity_bound` where they are known already. The
/// acceleration-only bound matters only below both nodes' (`Planner::refine_vbar`): where a
/// point's is at least `needed_below` ([`moves_at`]), it is not computed, so the first value
/// is exact only where it is below `needed_below`.
pub(super) fn interior_vbar_around(
    g: &IntervalGeom,
    lim: &Limits,
    middle: Option<(&NodeGeom, f64)>,
    needed_below: f64,
) -> (f64, f64) {
    let (mut v, mut v_flat) = (f64::INFINITY, f64::INFINITY);
    let fractions =
        if g.fine_checks() { &FINE_CHECK_FRACTIONS[1..FINE_CHECK_FRACTIONS.len() - 1] } else { &VBAR_FRACTIONS[..] };
    for &sigma in fractions {
        let (ng, flat) = match middle {
            Some((m, flat)) if sigma == 0.5 => (*m, flat),
            _ => {
                let ng = node_geom_at(g, sigma, lim.n_axes);
                (ng, super::node::flat_velocity_bound(&ng, lim))
            }
        };
        if !moves_at(&ng, needed_below, lim) {
            v = v.min(super::node::velocity_bound(&ng, lim));
        }
        v_flat = v_flat.min(flat);
    }
    (v, v_flat)
}

/// Whether the axes can move along geometry `g` at path velocity `v_mm_s` with some path
/// acceleration (every axis within its velocity limit, the acceleration ranges of eq. 1b
/// intersecting): `node::velocity_bound` is at least `v_mm_s`, tested without its pairwise
/// divisions.
fn moves_at(g: &NodeGeom, v_mm_s: f64, lim: &Limits) -> bool {
    let within_vel = (0..lim.n_axes).all(|k| g.d1[k].abs() * v_mm_s <= lim.vel[k]);
    within_vel && {
        let (lo, hi) = acc_range(g, 1.0, v_mm_s, lim);
        lo <= hi
    }
}

/// Largest normalised limit use minus one over all axes, limits and check points:
/// ≤ 0 means the interval keeps every limit. (value / limit − 1, per limit.)
pub(super) fn violation(iv: &Interval, g: &IntervalGeom, lim: &Limits) -> f64 {
    point_violations(iv, g, lim).fold(f64::NEG_INFINITY, raise_to)
}

/// Whether the interval breaks a limit by more than `VIOLATION_TOL` (stops at the first).
pub(super) fn violates(iv: &Interval, g: &IntervalGeom, lim: &Limits) -> bool {
    point_violations(iv, g, lim).any(|x| x > VIOLATION_TOL)
}

/// Whether the interval breaks a limit by more than `VIOLATION_TOL` at a check point between
/// its nodes (stops at the first): for a caller that knows the nodes keep the limits.
pub(super) fn violates_inside(iv: &Interval, g: &IntervalGeom, lim: &Limits) -> bool {
    let fractions = check_fractions(g);
    points_violations(iv, g, lim, &fractions[1..fractions.len() - 1]).any(|x| x > VIOLATION_TOL)
}

/// [`point_violation`] at each of the interval's check points, in order.
#[inline]
fn point_violations<'a>(iv: &'a Interval, g: &'a IntervalGeom, lim: &'a Limits) -> impl Iterator<Item = f64> + 'a {
    points_violations(iv, g, lim, check_fractions(g))
}

/// [`point_violation`] at the check points at the given time fractions, in order.
#[inline]
fn points_violations<'a>(
    iv: &'a Interval,
    g: &'a IntervalGeom,
    lim: &'a Limits,
    fractions: &'static [f64],
) -> impl Iterator<Item = f64> + 'a {
    let inv_ds = 1.0 / g.ds_mm;
    fractions.iter().map(move |&f| {
        let (sigma, v, a) = check_point(iv, f, inv_ds);
        point_violation(g, sigma, v, a, iv.j, lim)
    })
}

/// Geometry fraction σ, velocity and acceleration at time fraction `f` of the interval, whose
/// length's reciprocal is `inv_ds` (one division per interval rather than one per point, whose
/// latency would sit on the critical path of every check).
#[inline]
fn check_point(iv: &Interval, f: f64, inv_ds: f64) -> (f64, f64, f64) {
    let (s, v, a) = iv.state_at(f * iv.t_s);
    let sigma = if f == 0.0 {
        0.0
    } else if f == 1.0 {
        1.0
    } else {
        (s * inv_ds).clamp(0.0, 1.0)
    };
    (sigma, v, a)
}

/// Normalised limit use minus one at one point with state (v, a) and jerk j.
#[inline(always)]
pub(super) fn point_violation(g: &IntervalGeom, sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    if lim.n_axes < LANES_FROM_AXES {
        point_violation_scalar(g, sigma, v, a, j, lim)
    } else {
        point_violation_wide(g, sigma, v, a, j, lim)
    }
}

/// [`point_violation`] four axes at a time, with AVX where the CPU has it. Not inlined: the
/// scalar loop for fewer axes stays small enough to be inlined into its callers.
#[inline(never)]
fn point_violation_wide(g: &IntervalGeom, sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (detected just above).
        return unsafe { point_violation_avx(g, sigma, v, a, j, lim) };
    }
    point_violation_lanes(g, sigma, v, a, j, lim)
}

/// Machines with this many axes or more check four at a time (`lanes`); with fewer, the
/// scalar loop inlined into its caller is faster.
const LANES_FROM_AXES: usize = 4;

/// [`point_violation_lanes`] compiled for AVX: the same operations, four lanes per instruction.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn point_violation_avx(g: &IntervalGeom, sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    point_violation_lanes(g, sigma, v, a, j, lim)
}

/// [`point_violation`] four axes at a time (see `lanes`): the same value to the bit as
/// [`point_violation_scalar`].
#[inline(always)]
fn point_violation_lanes(g: &IntervalGeom, sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    use super::lanes;
    if sigma == 0.0 {
        lanes::at_node(g, g.start, v, a, j, lim)
    } else if sigma == 1.0 {
        lanes::at_node(g, g.end, v, a, j, lim)
    } else if let Some(p) = g.span {
        lanes::on_span(g, p, &span_powers(g, sigma), v, a, j, lim)
    } else if g.quintic {
        lanes::interpolated_quintic(g, &HermiteBasis::at(sigma, g.ds_mm), v, a, j, lim)
    } else {
        let h = CubicBasis::at(sigma);
        lanes::interpolated(g, [h.h00, h.h10, h.h01, h.h11], sigma, v, a, j, lim)
    }
}

/// [`point_violation`] one axis at a time: for fewer than `LANES_FROM_AXES` axes, and the
/// reference the lanes are tested against.
#[inline(always)]
fn point_violation_scalar(g: &IntervalGeom, sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    // One loop per source of the geometry, chosen once per point rather than per axis.
    if sigma == 0.0 {
        axes_violation(v, a, j, lim, |k| node_at(g, g.start, k))
    } else if sigma == 1.0 {
        axes_violation(v, a, j, lim, |k| node_at(g, g.end, k))
    } else if let Some(p) = g.span {
        let powers = span_powers(g, sigma);
        axes_violation(v, a, j, lim, |k| span_at(g, p, &powers, k))
    } else if g.quintic {
        let h = HermiteBasis::at(sigma, g.ds_mm);
        axes_violation(v, a, j, lim, |k| hermite_at(g, &h, k))
    } else {
        let h = CubicBasis::at(sigma);
        axes_violation(v, a, j, lim, |k| cubic_at(g, &h, k))
    }
}

/// A node's geometry of axis `k` in traversal order (A′ and A‴ flip backwards, see `sign`).
#[inline(always)]
fn node_at(g: &IntervalGeom, n: &NodeGeom, k: usize) -> (f64, f64, f64) {
    (g.sign * n.d1[k], n.d2[k], g.sign * n.d3[k])
}

/// [`point_violation`] with the geometry (A′, A″, A‴ of axis k in traversal order) from `geom`.
#[inline(always)]
fn axes_violation(v: f64, a: f64, j: f64, lim: &Limits, geom: impl Fn(usize) -> (f64, f64, f64)) -> f64 {
    let mut worst = f64::NEG_INFINITY;
    let (v2, v3) = (v * v, v * v * v);
    let va3 = 3.0 * v * a;
    for k in 0..lim.n_axes {
        let [r_vel, r_acc, r_jerk] = axis_uses(geom(k), (v, v2, v3), (a, va3), j, lim, k);
        worst = raise_to(raise_to(raise_to(worst, r_vel), r_acc), r_jerk);
    }
    worst - 1.0
}

/// Velocity, acceleration and jerk of axis `k` (Kopp et al. 2019, eq. 1a–1c) as shares of
/// their limits, for geometry (A′, A″, A‴) and state (v, a) with jerk j, the velocity given as
/// (v, v², v³) and the acceleration as (a, 3va): the product every axis shares is formed once
/// per point, not on each axis's chain from its geometry to its uses.
#[inline(always)]
fn axis_uses(
    (d1, d2, d3): (f64, f64, f64),
    (v, v2, v3): (f64, f64, f64),
    (a, va3): (f64, f64),
    j: f64,
    lim: &Limits,
    k: usize,
) -> [f64; 3] {
    let vel = d1 * v; // Kopp et al. 2019, eq. 1a
    let acc = d2 * v2 + d1 * a; // eq. 1b
    let jerk = d3 * v3 + d2 * va3 + d1 * j; // eq. 1c
    let r_acc = acc * if acc >= 0.0 { lim.inv_acc_max[k] } else { lim.inv_acc_min[k] };
    [vel.abs() * lim.inv_vel[k], r_acc, jerk.abs() * lim.inv_jerk[k]]
}

/// One term of [`violation`]: one limit (0 velocity, 1 acceleration, 2 jerk, as in
/// [`axis_uses`]) of one axis at one check point. A step search that knows which term bounds
/// it follows that term alone, a fraction of the cost of all of them (`step::max_feasible`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Term {
    point: usize,
    axis: usize,
    limit: usize,
}

/// [`violation`] and, where it is above `VIOLATION_TOL`, the term that reaches it.
pub(super) fn violation_term(iv: &Interval, g: &IntervalGeom, lim: &Limits) -> (f64, Option<Term>) {
    let mut worst = (f64::NEG_INFINITY, 0);
    for (i, x) in point_violations(iv, g, lim).enumerate() {
        if x > worst.0 {
            worst = (x, i);
        }
    }
    if worst.0 <= VIOLATION_TOL {
        return (worst.0, None);
    }
    // The term itself, at the worst point: the same arithmetic as there, so it compares equal.
    let point = worst.1;
    let (mut best, mut term) = (f64::NEG_INFINITY, None);
    for axis in 0..lim.n_axes {
        for (limit, r) in term_uses(iv, g, lim, point, axis).into_iter().enumerate() {
            if r - 1.0 > best {
                (best, term) = (r - 1.0, Some(Term { point, axis, limit }));
            }
        }
    }
    (worst.0, term)
}

/// The value of one term of [`violation`] for interval `iv` (bit for bit the value that term
/// has inside [`violation`]).
pub(super) fn term_violation(iv: &Interval, g: &IntervalGeom, lim: &Limits, t: Term) -> f64 {
    term_uses(iv, g, lim, t.point, t.axis)[t.limit] - 1.0
}

/// [`axis_uses`] of one axis at one check point, with the geometry [`point_violation`] takes:
/// the nodes' own at the ends, else [`geom_at`] (which `point_violation` inlines per source).
#[inline]
fn term_uses(iv: &Interval, g: &IntervalGeom, lim: &Limits, point: usize, k: usize) -> [f64; 3] {
    let (sigma, v, a) = check_point(iv, check_fractions(g)[point], 1.0 / g.ds_mm);
    let geom = match sigma {
        0.0 => node_at(g, g.start, k),
        1.0 => node_at(g, g.end, k),
        _ => geom_at(g, sigma, k),
    };
    axis_uses(geom, (v, v * v, v * v * v), (a, 3.0 * v * a), iv.j, lim, k)
}

/// `worst.max(x)` for an accumulator that is never NaN (it starts at −∞ and takes only values
/// greater than itself): a NaN `x` is skipped, as `f64::max` skips it, in one compare instead
/// of `f64::max`'s NaN handling on both sides (the planner spends much of its time in the
/// loop above).
#[inline(always)]
fn raise_to(worst: f64, x: f64) -> f64 {
    if x > worst { x } else { worst }
}

/// `best.min(x)` for an accumulator that is never NaN (see [`raise_to`]).
#[inline(always)]
fn lower_to(best: f64, x: f64) -> f64 {
    if x < best { x } else { best }
}

/// The ends of a range (lower·r, upper·r) in order, for lower ≤ upper: the sign of r orders
/// them, exactly (rounding is monotone), without `f64::min`/`max` on both. Where one end is NaN
/// (an infinite limit meeting an infinite curvature term) it is skipped with the other, where
/// `min`/`max` would keep the other: no finite limit and state gets there.
#[inline(always)]
fn in_order(lower_r: f64, upper_r: f64, r: f64) -> (f64, f64) {
    if r > 0.0 { (lower_r, upper_r) } else { (upper_r, lower_r) }
}

/// The path jerks j allowed at a point with geometry `g` (traversal orientation `sign`) and
/// state (v, a): the intersection over the axes of |A‴v³ + 3A″va + A′j| ≤ J
/// (Kopp et al. 2019, eq. 1c and 7d).
/// Returns (lo, hi); lo > hi means no jerk keeps every axis inside.
pub(super) fn jerk_range(g: &NodeGeom, sign: f64, v: f64, a: f64, lim: &Limits) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..lim.n_axes {
        let d1 = sign * g.d1[k];
        let c = sign * g.d3[k] * v * v * v + 3.0 * g.d2[k] * v * a;
        let jl = lim.jerk[k];
        if d1.abs() <= f64::MIN_POSITIVE {
            if c.abs() > jl {
                return (1.0, -1.0);
            }
            continue;
        }
        let r = 1.0 / d1;
        let (x, y) = in_order((-jl - c) * r, (jl - c) * r, r);
        lo = raise_to(lo, x);
        hi = lower_to(hi, y);
    }
    (lo, hi)
}

/// The path accelerations allowed at velocity v: A_min ≤ A″v² + A′a ≤ A_max per axis
/// (Kopp et al. 2019, eq. 1b and 7c).
pub(super) fn acc_range(g: &NodeGeom, sign: f64, v: f64, lim: &Limits) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..lim.n_axes {
        let d1 = sign * g.d1[k];
        let c = g.d2[k] * v * v;
        if d1.abs() <= f64::MIN_POSITIVE {
            if c > lim.acc_max[k] || c < lim.acc_min[k] {
                return (1.0, -1.0);
            }
            continue;
        }
        let r = 1.0 / d1;
        let (x, y) = in_order((lim.acc_min[k] - c) * r, (lim.acc_max[k] - c) * r, r);
        lo = raise_to(lo, x);
        hi = lower_to(hi, y);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{AxisVec, MAX_AXES};
    use crate::planner::node::SpanPoly;

    fn lim() -> Limits {
        let mut l = Limits {
            n_axes: 2,
            vel: [f64::INFINITY; MAX_AXES],
            acc_max: [f64::INFINITY; MAX_AXES],
            acc_min: [f64::NEG_INFINITY; MAX_AXES],
            jerk: [f64::INFINITY; MAX_AXES],
            inv_vel: [0.0; MAX_AXES],
            inv_acc_max: [0.0; MAX_AXES],
            inv_acc_min: [0.0; MAX_AXES],
            inv_jerk: [0.0; MAX_AXES],
            configured_vel: [1.0; MAX_AXES],
            configured_acc: [1.0; MAX_AXES],
            configured_jerk: [1.0; MAX_AXES],
            curvature_jump_s: 2e-6,
        };
        for k in 0..2 {
            l.vel[k] = 100.0;
            l.acc_max[k] = 1000.0;
            l.acc_min[k] = -1000.0;
            l.jerk[k] = 10000.0;
        }
        l.refresh();
        l
    }

    fn line_geom() -> NodeGeom {
        let mut d1: AxisVec = [0.0; MAX_AXES];
        d1[0] = 0.6;
        d1[1] = 0.8;
        NodeGeom { d1, ..NodeGeom::default() }
    }

    #[test]
    fn line_velocity_limit() {
        let g = line_geom();
        let ig = IntervalGeom { start: &g, end: &g, ds_mm: 1.0, sign: 1.0, span: None, quintic: false };
        // 0.8·v ≤ 100 → v ≤ 125
        let ok = Interval::through(124.0, 0.0, 1.0, 124.0).unwrap();
        assert!(violation(&ok, &ig, &lim()) <= 0.0);
        let bad = Interval::through(126.0, 0.0, 1.0, 126.0).unwrap();
        assert!(violation(&bad, &ig, &lim()) > 0.0);
    }

    /// The ranges and the violation with plain compares are what `f64::min`/`max` give, bit
    /// for bit, on finite states, also with axes that do not move along the path (A′ = 0) and
    /// states no jerk or acceleration keeps inside.
    #[test]
    fn the_ranges_and_violation_are_what_min_and_max_give() {
        fn reference(g: &NodeGeom, sign: f64, v: f64, a: f64, j: f64, l: &Limits) -> [f64; 5] {
            let (mut jlo, mut jhi, mut alo, mut ahi) =
                (f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
            let (mut jerk_empty, mut acc_empty) = (false, false);
            let mut worst = f64::NEG_INFINITY;
            for k in 0..l.n_axes {
                let d1 = sign * g.d1[k];
                let cj = sign * g.d3[k] * v * v * v + 3.0 * g.d2[k] * v * a;
                let ca = g.d2[k] * v * v;
                // As `point_violation` associates them.
                let (v2, v3, d3) = (v * v, v * v * v, sign * g.d3[k]);
                let (vel, acc, jerk) = (d1 * v, g.d2[k] * v2 + d1 * a, d3 * v3 + g.d2[k] * (3.0 * v * a) + d1 * j);
                let r_acc = acc * if acc >= 0.0 { l.inv_acc_max[k] } else { l.inv_acc_min[k] };
                worst = worst.max((vel.abs() * l.inv_vel[k]).max(r_acc).max(jerk.abs() * l.inv_jerk[k]));
                if d1.abs() <= f64::MIN_POSITIVE {
                    jerk_empty |= cj.abs() > l.jerk[k];
                    acc_empty |= ca > l.acc_max[k] || ca < l.acc_min[k];
                    continue;
                }
                let r = 1.0 / d1;
                let (x, y) = ((-l.jerk[k] - cj) * r, (l.jerk[k] - cj) * r);
                (jlo, jhi) = (jlo.max(x.min(y)), jhi.min(x.max(y)));
                let (x, y) = ((l.acc_min[k] - ca) * r, (l.acc_max[k] - ca) * r);
                (alo, ahi) = (alo.max(x.min(y)), ahi.min(x.max(y)));
            }
            let (jlo, jhi) = if jerk_empty { (1.0, -1.0) } else { (jlo, jhi) };
            let (alo, ahi) = if acc_empty { (1.0, -1.0) } else { (alo, ahi) };
            [jlo, jhi, alo, ahi, worst - 1.0]
        }
        use proptest::prelude::RngCore;
        use proptest::test_runner::{RngAlgorithm, TestRng};
        let l = lim();
        let mut rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
        // Uniform in [−1, 1).
        let mut next = || (rng.next_u64() >> 11) as f64 * 2f64.powi(-52) - 1.0;
        let mut empty = 0;
        for i in 0..20_000 {
            let mut g = NodeGeom::default();
            for k in 0..2 {
                g.d1[k] = if i % 7 == k { 0.0 } else { next() };
                g.d2[k] = 5.0 * next();
                g.d3[k] = 50.0 * next();
            }
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let (v, a, j) = (60.0 * (next() + 1.0), 2000.0 * next(), 20_000.0 * next());
            let ((jlo, jhi), (alo, ahi)) = (jerk_range(&g, sign, v, a, &l), acc_range(&g, sign, v, &l));
            let ig = IntervalGeom { start: &g, end: &g, ds_mm: 1.0, sign, span: None, quintic: false };
            let got = [jlo, jhi, alo, ahi, point_violation(&ig, 0.0, v, a, j, &l)];
            let want = reference(&g, sign, v, a, j, &l);
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{g:?} sign {sign} v {v} a {a} j {j}");
            empty += usize::from(jlo > jhi || alo > ahi);
        }
        assert!(empty > 100, "only {empty} empty ranges");
    }

    /// The limit uses four axes at a time (`lanes`: plain, and compiled for AVX where the CPU
    /// has it) are the scalar loop's to the bit, at nodes, on spans and interpolated, in both
    /// directions, for 1 to 9 axes, with axes that do not move along the path, limits that
    /// differ per axis and side, and states far outside them. The geometry past the machine's
    /// axes is noise the lanes must not see.
    #[test]
    fn the_lanes_are_the_scalar_loop_to_the_bit() {
        use proptest::prelude::RngCore;
        use proptest::test_runner::{RngAlgorithm, TestRng};
        let mut rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
        let mut next = || (rng.next_u64() >> 11) as f64 * 2f64.powi(-52) - 1.0;
        let mut compared = [0usize; 5];
        for i in 0..40_000 {
            let mut l = lim();
            l.n_axes = 1 + i % MAX_AXES;
            for k in 0..l.n_axes {
                l.vel[k] = 100.0 * (1.5 + next());
                l.acc_max[k] = 1000.0 * (1.5 + next());
                l.acc_min[k] = -1000.0 * (1.5 + next());
                l.jerk[k] = 10_000.0 * (1.5 + next());
            }
            l.refresh();
            let (mut g0, mut g1) = (NodeGeom::default(), NodeGeom::default());
            let mut c = [[0.0; 8]; MAX_AXES];
            for (k, row) in c.iter_mut().enumerate() {
                for g in [&mut g0, &mut g1] {
                    let d1 = if (i + k) % 5 == 0 { 0.0 } else { next() };
                    (g.d1[k], g.d2[k], g.d3[k]) = (d1, 5.0 * next(), 50.0 * next());
                }
                for x in row.iter_mut() {
                    *x = next();
                }
            }
            let span = SpanPoly::from_position(&c, MAX_AXES, 0.5, false);
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let ig = IntervalGeom {
                start: &g0,
                end: &g1,
                ds_mm: 0.5,
                sign,
                span: (i % 3 == 0).then_some(&span),
                quintic: i % 4 == 1,
            };
            let sigma = match i % 7 {
                0 => 0.0,
                1 => 1.0,
                _ => 0.5 * (next() + 1.0),
            };
            let (v, a, j) = (80.0 * (next() + 1.0), 3000.0 * next(), 30_000.0 * next());
            let want = point_violation_scalar(&ig, sigma, v, a, j, &l).to_bits();
            let source = if sigma == 0.0 || sigma == 1.0 {
                0
            } else if ig.span.is_some() {
                1
            } else if ig.quintic {
                3
            } else {
                2
            };
            assert_eq!(point_violation_lanes(&ig, sigma, v, a, j, &l).to_bits(), want, "case {i}");
            compared[source] += 1;
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: the CPU has AVX (detected just above).
                let avx = unsafe { point_violation_avx(&ig, sigma, v, a, j, &l) };
                assert_eq!(avx.to_bits(), want, "case {i}, AVX");
                compared[4] += 1;
            }
        }
        assert!(compared[..4].iter().all(|&n| n > 3_000), "nodes, spans, cubic, quintic: {compared:?}");
    }

    /// The quintic scheme is exact for a quintic A′ (A″, A‴ its derivatives) in either
    /// direction, where the cubic scheme's linear A‴ is not.
    #[test]
    fn the_quintic_scheme_reproduces_a_quintic_tangent() {
        // A′(s) = Σ c_i s^i on one axis, its derivatives, over an interval of 0.3 mm from s0.
        let c = [0.3, -1.2, 40.0, -350.0, 900.0, -2500.0];
        let at = |s: f64| {
            let d1: f64 = (0..6).map(|i| c[i] * s.powi(i as i32)).sum();
            let d2: f64 = (1..6).map(|i| i as f64 * c[i] * s.powi(i as i32 - 1)).sum();
            let d3: f64 = (2..6).map(|i| (i * (i - 1)) as f64 * c[i] * s.powi(i as i32 - 2)).sum();
            let mut g = NodeGeom::default();
            (g.d1[0], g.d2[0], g.d3[0]) = (d1, d2, d3);
            g
        };
        let (s0, ds) = (0.1, 0.3);
        let (g0, g1) = (at(s0), at(s0 + ds));
        for sign in [1.0, -1.0] {
            let (start, end) = if sign > 0.0 { (&g0, &g1) } else { (&g1, &g0) };
            for sigma in [0.1, 0.25, 0.5, 0.8] {
                let quintic = IntervalGeom { start, end, ds_mm: ds, sign, span: None, quintic: true };
                let cubic = IntervalGeom { quintic: false, ..quintic };
                let s = if sign > 0.0 { s0 + sigma * ds } else { s0 + ds - sigma * ds };
                let want = at(s);
                let want = (sign * want.d1[0], want.d2[0], sign * want.d3[0]);
                let got = geom_at(&quintic, sigma, 0);
                for (x, y) in [(got.0, want.0), (got.1, want.1), (got.2, want.2)] {
                    assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()), "σ {sigma} sign {sign}: {got:?} vs {want:?}");
                }
                let off = (geom_at(&cubic, sigma, 0).2 - want.2).abs();
                assert!(off > 1.0, "σ {sigma}: the cubic scheme's A‴ is off by only {off}");
            }
        }
    }

    /// The term [`violation_term`] names has, alone, the value of the whole violation, bit for
    /// bit, on interpolated and exact (span) geometry in both directions: the step search
    /// follows it and relies on its sign (`step::max_feasible`).
    #[test]
    fn the_worst_term_alone_has_the_violations_value() {
        use proptest::prelude::RngCore;
        use proptest::test_runner::{RngAlgorithm, TestRng};
        let l = lim();
        let mut rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
        let mut next = || (rng.next_u64() >> 11) as f64 * 2f64.powi(-52) - 1.0;
        let mut infeasible = 0;
        for i in 0..4000 {
            let (mut g0, mut g1) = (NodeGeom::default(), NodeGeom::default());
            let mut c = [[0.0; 8]; MAX_AXES];
            for (k, row) in c.iter_mut().enumerate().take(2) {
                for g in [&mut g0, &mut g1] {
                    (g.d1[k], g.d2[k], g.d3[k]) = (next(), 5.0 * next(), 50.0 * next());
                }
                for x in row.iter_mut() {
                    *x = next();
                }
            }
            let span = SpanPoly::from_position(&c, MAX_AXES, 2.0, i % 3 == 0);
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let ig = IntervalGeom {
                start: &g0,
                end: &g1,
                ds_mm: 0.5,
                sign,
                span: (i % 4 < 2).then_some(&span),
                quintic: false,
            };
            let Some(iv) = Interval::through(60.0 * (next() + 1.0), 2000.0 * next(), 0.5, 60.0 * (next() + 1.0)) else {
                continue;
            };
            let (f, term) = violation_term(&iv, &ig, &l);
            assert_eq!(f.to_bits(), violation(&iv, &ig, &l).to_bits());
            match term {
                Some(t) => {
                    infeasible += 1;
                    assert_eq!(term_violation(&iv, &ig, &l, t).to_bits(), f.to_bits(), "{t:?}");
                }
                None => assert!(f <= VIOLATION_TOL),
            }
        }
        assert!(infeasible > 500, "only {infeasible} infeasible intervals");
    }

    #[test]
    fn jerk_range_on_a_line() {
        let (lo, hi) = jerk_range(&line_geom(), 1.0, 50.0, 0.0, &lim());
        assert!((hi - 12500.0).abs() < 1e-9 && (lo + 12500.0).abs() < 1e-9);
        let (lo, hi) = acc_range(&line_geom(), -1.0, 50.0, &lim());
        assert!((hi - 1250.0).abs() < 1e-9 && (lo + 1250.0).abs() < 1e-9);
    }
}
