//! Adaptive sampling of the path (Kopp et al. 2019, §2.2: non-constant spacing, finer where
//! the curvature or the orientation changes fast): nodes are denser where the curvature, its
//! change or the orientation change is high, near stops (where the motion is slow), and so
//! that no interval lasts much longer than `planner.max_interval_ms` at the bound speed (jerk
//! can only switch at nodes).
//!
//! Sampling depends only on an element, its predecessor, whether its successor stops, and
//! the distance from the last stop, so planning a program element by element gives the same
//! nodes as planning it whole.

use super::check::{CHECK_FRACTIONS, interior_vbar_around, node_geom_at};
use super::limits::Limits;
use super::node::{IntervalGeom, Node, NodeGeom, SpanPoly, curvature_jump_cap, flat_velocity_bound, velocity_bound};
use crate::Settings;
use crate::path::{AxisDerivs, Element, Feed, JointKind};
use interpd_config::AxisKind;
use std::sync::Arc;

/// Sampling parameters derived from `[planner]`.
#[derive(Debug, Clone)]
pub(super) struct SamplingParams {
    pub max_step_mm: f64,
    pub min_step_mm: f64,
    pub max_turn_rad: f64,
    pub max_turn_deg: f64,
    pub max_interval_s: f64,
    pub curvature_jump_s: f64,
    pub rapid_feed_mm_s: f64,
    pub linear: Vec<bool>,
    /// `[planner] quintic_checks`.
    pub quintic_checks: bool,
}

impl SamplingParams {
    pub(super) fn from_settings(settings: &Settings) -> Self {
        let p = &settings.planner;
        Self {
            max_step_mm: p.max_step_mm,
            min_step_mm: p.min_step_mm,
            max_turn_rad: p.max_turn_deg.to_radians(),
            max_turn_deg: p.max_turn_deg,
            max_interval_s: p.max_interval_ms * 1e-3,
            curvature_jump_s: p.curvature_jump_ms * 1e-3,
            rapid_feed_mm_s: p.rapid_feed_mm_s.unwrap_or(f64::INFINITY),
            linear: settings.axes.iter().map(|a| a.kind == AxisKind::Linear).collect(),
            quintic_checks: p.quintic_checks,
        }
    }
}

/// Samples per step length when profiling how sharply a spline span turns: a span much
/// longer than a step gets this many per step (up to `SHARPNESS_SAMPLES`), a span shorter
/// than a step, as in a dense G06 spline, at least `SHARPNESS_MIN_SAMPLES`, so the profile
/// resolves the same share of a step either way.
const SHARPNESS_SAMPLES: usize = 32;
/// Fewest samples of a span's sharpness profile.
const SHARPNESS_MIN_SAMPLES: usize = 8;
/// Golden-section steps refining a sharp local maximum of the sharpness (the bracket of two
/// sample spacings shrinks to 0.618¹⁶ ≈ 5·10⁻⁴ of itself).
const SHARPNESS_REFINE: usize = 16;
/// A local maximum whose neighbours both lie within this fraction below it is flat: between
/// the samples the curve is close to the parabola through the three, whose vertex lies at most
/// `FLAT_PEAK_SHARE` of the drop above the sample, so it is raised by that (a margin, not a
/// strict bound) instead of searched.
const FLAT_PEAK_DROP: f64 = 0.1;
const FLAT_PEAK_SHARE: f64 = 0.25;
/// A minimum of |P′| below this share of the span's mean |P′| (its length) is a dip where the
/// sharpness can spike between samples.
const SPEED_DIP_SHARE: f64 = 0.5;

/// How sharply a curved span turns along its length, so a step is bounded by the sharpest
/// point it covers and not only by where it starts (a narrow tight spot would be stepped
/// over): tangent turn rate, its change, and orientation rate, sampled along the span with
/// every local maximum bounded (flat ones) or refined (sharp ones).
struct Sharpness {
    s: Vec<f64>,
    /// Per sample: (curvature, curvature change, orientation rate) as the step criteria use them.
    value: Vec<(f64, f64, f64)>,
}

/// One criterion of a sharpness triple.
#[inline]
fn criterion(v: &(f64, f64, f64), crit: usize) -> f64 {
    [v.0, v.1, v.2][crit]
}

/// Raises one criterion of a sharpness triple to at least `x`.
fn raise(v: &mut (f64, f64, f64), crit: usize, x: f64) {
    match crit {
        0 => v.0 = v.0.max(x),
        1 => v.1 = v.1.max(x),
        _ => v.2 = v.2.max(x),
    }
}

impl Sharpness {
    /// Profile of a spline span; `None` for lines and arcs (constant sharpness) and path-table
    /// spans (the table brings its own sample points). `step_mm` is the sampling step at the
    /// span's start, which sets the profile's resolution.
    fn of(e: &Element, lim: &Limits, params: &SamplingParams, step_mm: f64) -> Option<Self> {
        let crate::path::Geometry::Cubic(c) = &e.geometry else { return None };
        let mut d = AxisDerivs::default();
        let mut sharp_at = |x: f64| {
            c.eval_at_u(x, &mut d);
            sharpness_at(&d, lim, params)
        };
        let per_step = SHARPNESS_SAMPLES as f64 * c.length_mm() / step_mm;
        let n = if per_step.is_finite() {
            (per_step.ceil() as usize).clamp(SHARPNESS_MIN_SAMPLES, SHARPNESS_SAMPLES)
        } else {
            SHARPNESS_SAMPLES
        };
        let h = 1.0 / n as f64;
        let mut u: Vec<f64> = (0..=n).map(|i| i as f64 * h).collect();
        let mut value: Vec<(f64, f64, f64)> = u.iter().map(|&x| sharp_at(x)).collect();
        let mut s = uniform_arc_lengths(c, n);
        let mut extra = Vec::new();
        let mut raises = Vec::new();
        for crit in 0..3 {
            for i in 0..=n {
                let here = criterion(&value[i], crit);
                let left = if i > 0 { criterion(&value[i - 1], crit) } else { f64::NEG_INFINITY };
                let right = if i < n { criterion(&value[i + 1], crit) } else { f64::NEG_INFINITY };
                if !(here > 0.0 && here >= left && here >= right) {
                    continue;
                }
                // At the span's ends only the inner neighbour counts, and without a third point
                // no parabola: the whole drop is added.
                let (lowest, share) = if i == 0 {
                    (right, 1.0)
                } else if i == n {
                    (left, 1.0)
                } else {
                    (left.min(right), FLAT_PEAK_SHARE)
                };
                let drop = here - lowest.max(0.0);
                if drop <= FLAT_PEAK_DROP * here {
                    raises.push((i, crit, here + share * drop));
                } else {
                    let (a, b) = (((i as f64 - 1.0) * h).max(0.0), ((i as f64 + 1.0) * h).min(1.0));
                    let x = refine_peak(&mut sharp_at, crit, a, b);
                    extra.push((x, sharp_at(x)));
                }
            }
        }
        // Raised only now, so each criterion's peaks were found on the sampled values.
        for (i, crit, x) in raises {
            raise(&mut value[i], crit, x);
        }
        // A narrow spike of any criterion (they all divide by powers of |P′|) can only sit
        // where |P′| dips well below its mean: refine every criterion there.
        for &um in c.speed_minima() {
            if c.speed_at_u(um).0 < SPEED_DIP_SHARE * c.length_mm() {
                let (a, b) = ((um - h).max(0.0), (um + h).min(1.0));
                for crit in 0..3 {
                    let x = refine_peak(&mut sharp_at, crit, a, b);
                    extra.push((x, sharp_at(x)));
                }
            }
        }
        // Refined maxima (rare: only where the curve turns sharply inside a span) get their
        // exact arc length, kept between its neighbours' approximate ones so `s` stays sorted.
        for (x, v) in extra {
            let at = u.partition_point(|&y| y < x);
            let lo = if at > 0 { s[at - 1] } else { 0.0 };
            let hi = s.get(at).copied().unwrap_or(f64::INFINITY);
            u.insert(at, x);
            value.insert(at, v);
            s.insert(at, c.s_at(x).clamp(lo, hi.max(lo)));
        }
        Some(Self { s, value })
    }

    /// The sharpest values over [a, b] (including the samples just outside, since the
    /// sharpness between two samples may exceed both only near a refined maximum).
    fn max_over(&self, a: f64, b: f64) -> (f64, f64, f64) {
        let i0 = self.s.partition_point(|&x| x < a).saturating_sub(1);
        let i1 = (self.s.partition_point(|&x| x <= b) + 1).min(self.s.len());
        self.value[i0..i1].iter().fold((0.0, 0.0, 0.0), |m, v| (m.0.max(v.0), m.1.max(v.1), m.2.max(v.2)))
    }
}

/// Arc length at u = i/n, i = 0..=n, of a cubic span: the trapezoid rule with its end
/// correction (Euler–Maclaurin, h²/12·(σ′ᵢ − σ′ᵢ₊₁), fourth order) per piece, scaled so the
/// last equals the span's exact length, at n + 1 speed evaluations instead of a quadrature per
/// point. Away from deep dips of |P′| it is accurate far beyond what locating a step needs;
/// near one less so, which only shifts where a step looks up the profile.
fn uniform_arc_lengths(c: &crate::path::CubicSpan, n: usize) -> Vec<f64> {
    let h = 1.0 / n as f64;
    let mut s = Vec::with_capacity(n + 1);
    s.push(0.0);
    let (mut f0, mut df0) = c.speed_at_u(0.0);
    for i in 1..=n {
        let (f1, df1) = c.speed_at_u(i as f64 * h);
        let piece = 0.5 * h * (f0 + f1) + h * h / 12.0 * (df0 - df1);
        s.push(s[i - 1] + piece);
        (f0, df0) = (f1, df1);
    }
    let total = s[n];
    let scale = if total > 0.0 { c.length_mm() / total } else { 1.0 };
    for x in &mut s {
        *x *= scale;
    }
    s
}

/// The parameter in [a, b] where criterion `crit` peaks: golden-section search, one new
/// evaluation per step.
fn refine_peak(sharp_at: &mut impl FnMut(f64) -> (f64, f64, f64), crit: usize, a: f64, b: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (a, b);
    let (mut p, mut q) = (b - g * (b - a), a + g * (b - a));
    let (mut fp, mut fq) = (criterion(&sharp_at(p), crit), criterion(&sharp_at(q), crit));
    for _ in 0..SHARPNESS_REFINE {
        if fp > fq {
            b = q;
            (q, fq) = (p, fp);
            p = b - g * (b - a);
            fp = criterion(&sharp_at(p), crit);
        } else {
            a = p;
            (p, fp) = (q, fq);
            q = a + g * (b - a);
            fq = criterion(&sharp_at(q), crit);
        }
    }
    if fp > fq { p } else { q }
}

/// (curvature, curvature change, orientation rate) at one point, as the step criteria use them.
fn sharpness_at(d: &AxisDerivs, lim: &Limits, params: &SamplingParams) -> (f64, f64, f64) {
    let (mut curv2, mut dcurv2, mut rot_rate2) = (0.0, 0.0, 0.0);
    for k in 0..lim.n_axes {
        if params.linear[k] {
            curv2 += d.d2[k] * d.d2[k];
            dcurv2 += d.d3[k] * d.d3[k];
        } else {
            rot_rate2 += d.d1[k] * d.d1[k];
            let r = d.d2[k].to_radians();
            curv2 += r * r;
            let r3 = d.d3[k].to_radians();
            dcurv2 += r3 * r3;
        }
    }
    (curv2.sqrt(), dcurv2.sqrt(), rot_rate2.sqrt())
}

/// Step limit from sharpness values: tangent turn, change of curvature and orientation
/// change per step each at most `max_turn`.
fn geometric_step(sharp: (f64, f64, f64), params: &SamplingParams) -> f64 {
    let (curv, dcurv, rot_rate) = sharp;
    let mut ds = params.max_step_mm;
    if curv > 0.0 {
        ds = ds.min(params.max_turn_rad / curv);
    }
    if dcurv > 0.0 {
        ds = ds.min((params.max_turn_rad / dcurv).sqrt());
    }
    if rot_rate > 0.0 {
        ds = ds.min(params.max_turn_deg / rot_rate);
    }
    ds
}

/// The feed of an element in mm/s.
pub(super) fn feed_of(e: &Element, params: &SamplingParams) -> f64 {
    match e.feed {
        Feed::Programmed { mm_per_s } => mm_per_s,
        Feed::Rapid => params.rapid_feed_mm_s,
    }
}

/// Speed reachable from rest within `d_mm` under path jerk `j` and acceleration `a`: a rough
/// upper bound used only to make the sampling dense near stops.
fn speed_from_rest(d_mm: f64, j: f64, a: f64) -> f64 {
    let jerk_phase = 0.5 * j * (6.0 * d_mm / j).powf(2.0 / 3.0); // s = j t³/6, v = j t²/2
    let acc_phase = (2.0 * a * d_mm).sqrt();
    jerk_phase.min(acc_phase)
}

/// Samples one element: pushes the node at its start (the joint with `prev`) and its interior
/// nodes, on a path table with the exact geometry of the intervals after them
/// ([`attach_spans`]); the node at its end belongs to the next element (or [`end_node`]).
///
/// `since_stop_mm` is the path length from the last stop to the element start; it is updated
/// to the element end. `next_stops` tells whether the motion must be at rest at the element end.
/// Without `prev` the element starts the path: at rest, unless `start_moving` (a replan from a
/// state in motion, see `Planner::with_start_state`).
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_element(
    prev: Option<(&Element, &ElementEnd)>,
    start_moving: bool,
    e: &Element,
    next_stops: bool,
    since_stop_mm: &mut f64,
    lim: &Limits,
    params: &SamplingParams,
    out: &mut Vec<Node>,
) -> ElementEnd {
    let first = out.len();
    let len = e.geometry.length_mm();
    let feed = feed_of(e, params);
    let mut d = AxisDerivs::default();
    e.geometry.eval(0.0, &mut d);
    let right = NodeGeom::from(&d);
    let at_right = ElementEnd::at(right, lim);
    let (left, stop) = match prev {
        Some((_, end)) => (*end, e.stops_before()),
        None => (at_right, !start_moving),
    };
    if stop {
        *since_stop_mm = 0.0;
    }
    let mut vbar = left.vbar_mm_s.min(at_right.vbar_mm_s).min(feed);
    if let Some((p, _)) = prev {
        vbar = vbar.min(feed_of(p, params));
    }
    let (flat, left) = (left.flat_mm_s.min(at_right.flat_mm_s), left.geom);
    if e.joint == JointKind::CurvatureJump {
        vbar = vbar.min(curvature_jump_cap(&left, &right, lim, params.curvature_jump_s));
    }
    if stop {
        vbar = 0.0;
    }
    out.push(Node {
        s_mm: e.s_start_mm,
        left,
        right,
        vbar_mm_s: vbar,
        vbar_flat_mm_s: flat.min(vbar),
        feed_mm_s: feed,
        stop,
        dwell_s: e.dwell_before_s,
        line: e.source.line,
        reach_bound: false,
        span: None,
        quintic: false,
    });

    // A straight line between two stops is planned in closed form (`scurve`): its interior
    // nodes would not be used. A path table brings its own samples (Kopp et al. 2019, §2: the
    // control supplies A … A‴ at each s_i); they are the nodes, as in the paper's five-axis
    // example. Only near stops does a table get extra nodes, where the motion is too slow for
    // its rows' spacing.
    let own_samples = matches!(e.geometry, crate::path::Geometry::Septic(_));
    let end = ElementEnd::of(e, lim);
    if stop && next_stops && matches!(e.geometry, crate::path::Geometry::Line(_)) {
        *since_stop_mm += len;
        return end;
    }
    let j_path = lim.min_jerk();
    let a_path = lim.min_acc();
    let cruise = cruise_ramp_mm(e, feed, a_path, j_path, lim, params);
    // Profiled at the first step, whose length sets the profile's resolution.
    let mut sharpness: Option<Option<Sharpness>> = None;
    let mut s = 0.0;
    loop {
        let from_start = *since_stop_mm + s;
        let to_end = if next_stops { len - s } else { f64::INFINITY };
        let mut ds = if own_samples {
            // `d` holds the geometry at s: evaluated there above, or by `push_interior`.
            table_step(e, &d, feed, from_start, to_end, j_path, a_path, lim, params)
        } else {
            step_at(e, s, &mut d, feed, from_start, to_end, j_path, a_path, cruise, lim, params)
        };
        // Look at the far end of the step too, so a step does not jump into a sharp region.
        if s + ds < len && !own_samples {
            let ds2 =
                step_at(e, s + ds, &mut d, feed, from_start + ds, to_end - ds, j_path, a_path, cruise, lim, params);
            ds = ds.min(ds2.max(0.5 * ds));
        }
        // And the sharpest point the step covers (splines and tables can turn tightly in a
        // narrow spot between two sample points).
        if let Some(sh) = sharpness.get_or_insert_with(|| Sharpness::of(e, lim, params, ds)) {
            for _ in 0..SHARPNESS_ITERS {
                let bound = geometric_step(sh.max_over(s, s + ds), params).max(GEOMETRY_MIN_STEP_MM);
                if bound >= ds {
                    break;
                }
                ds = bound;
            }
        }
        // And the node data must describe the geometry between the nodes: the limit checks
        // interpolate it (`check::geom_at`), so the step halves until the interpolation
        // error, weighed at the fastest motion possible there, is a small share of a limit.
        // (Not for a path table: its checks evaluate the exact geometry, see `attach_spans`.)
        // On a smoothed piece, where the cubic scheme would need a shorter step, the quintic
        // one is taken if it holds at this step (`is_quintic`).
        let mut quintic = false;
        if !matches!(e.geometry, crate::path::Geometry::Line(_)) && e.geometry.as_septic().is_none() {
            let may_quintic = params.quintic_checks && is_quintic(e);
            for _ in 0..INTERP_HALVINGS {
                let h = ds.min(len - s);
                if h <= GEOMETRY_MIN_STEP_MM || interpolation_error(e, s, h, feed, false, lim) <= INTERP_ERROR_TOL {
                    break;
                }
                if may_quintic && interpolation_error(e, s, h, feed, true, lim) <= INTERP_ERROR_TOL {
                    quintic = true;
                    break;
                }
                ds *= 0.5;
            }
        }
        out.last_mut().expect("the node at s").quintic = quintic;
        let remaining = len - s;
        if remaining <= 1.5 * ds {
            if remaining > ds {
                // Two equal steps instead of a long one followed by a sliver.
                push_interior(e, s + 0.5 * remaining, &mut d, feed, lim, out);
                out.last_mut().expect("just pushed").quintic = quintic;
            }
            break;
        }
        s += ds;
        push_interior(e, s, &mut d, feed, lim, out);
    }
    attach_spans(e, &mut out[first..], &end, feed, lim);
    *since_stop_mm += len;
    end
}

/// The geometry at one end of an element and its velocity bounds there (the acceleration-only
/// `velocity_bound` and the flat `flat_velocity_bound`, neither capped by a feed): an
/// element's end is evaluated once, for its own last interval and the next element's first
/// node.
#[derive(Debug, Clone, Copy)]
pub(super) struct ElementEnd {
    geom: NodeGeom,
    vbar_mm_s: f64,
    flat_mm_s: f64,
}

impl ElementEnd {
    fn at(geom: NodeGeom, lim: &Limits) -> Self {
        Self { geom, vbar_mm_s: velocity_bound(&geom, lim), flat_mm_s: flat_velocity_bound(&geom, lim) }
    }

    /// The end of element `e`.
    fn of(e: &Element, lim: &Limits) -> Self {
        Self::at(geom_at(e, e.geometry.length_mm()), lim)
    }
}

/// The geometry of element `e` at local position `s_mm`, as a node's.
fn geom_at(e: &Element, s_mm: f64) -> NodeGeom {
    let mut d = AxisDerivs::default();
    e.geometry.eval(s_mm, &mut d);
    NodeGeom::from(&d)
}

/// The exact geometry of each interval after `nodes` (the nodes of element `e`, the last one's
/// interval ending at the element's end) where the element is a polynomial in s; `feed` is the
/// element's, mm/s.
fn attach_spans(e: &Element, nodes: &mut [Node], element_end: &ElementEnd, feed: f64, lim: &Limits) {
    let Some((span, offset_mm)) = e.geometry.as_septic() else { return };
    let len = e.geometry.length_mm();
    // Each interval's end: position, geometry and both velocity bounds (the next node's, or
    // the element's end, which is the next element's first node: its v̄ will be at most this).
    // The flat v̄ only enters below capped by the feed, as the interior nodes hold it.
    let ends: Vec<(f64, NodeGeom, f64, f64)> = nodes
        .iter()
        .skip(1)
        .map(|n| (n.s_mm - e.s_start_mm, n.left, n.vbar_mm_s, n.vbar_flat_mm_s))
        .chain([(len, element_end.geom, element_end.vbar_mm_s.min(feed), element_end.flat_mm_s.min(feed))])
        .collect();
    // The flat v̄ of the interval's start geometry: the last one's end where the node between
    // them has one geometry (every node but the element's first).
    let mut start_flat = None;
    for (node, (s1, end, end_vbar, end_flat)) in nodes.iter_mut().zip(ends) {
        let s0 = node.s_mm - e.s_start_mm;
        let ds_mm = s1 - s0;
        let start = &node.right;
        let flats = (start_flat.unwrap_or_else(|| flat_velocity_bound(start, lim).min(feed)), end_flat);
        start_flat = Some(flats.1);
        if ds_mm > 0.0 {
            let piece = span.piece(offset_mm + s0, ds_mm);
            let mut poly = SpanPoly::from_position(&piece, span.axes(), ds_mm, false);
            // The middle of the piece, for the interpolation test and the interior bounds.
            let m = node_geom_at(&on_piece(start, &end, ds_mm, &poly), 0.5, lim.n_axes);
            let m_flat = flat_velocity_bound(&m, lim);
            let v = flats.0.max(flats.1).max(m_flat).min(feed);
            let error = interpolation_error_at(ds_mm, (start, &end), (0.5, &m), v, false, lim);
            poly.set_interpolable(error <= INTERP_ERROR_TOL);
            // The interior's acceleration-only bound lowers the nodes' only below both.
            let needed_below = node.vbar_mm_s.min(end_vbar);
            let g = on_piece(start, &end, ds_mm, &poly);
            let bounds = interior_vbar_around(&g, lim, Some((&m, m_flat)), needed_below);
            poly.set_interior_vbar(bounds);
            node.span = Some(Arc::new(poly));
        }
    }
}

/// The interval from geometry `start` to `end`, `ds_mm` long, on its exact piece `poly`.
fn on_piece<'a>(start: &'a NodeGeom, end: &'a NodeGeom, ds_mm: f64, poly: &'a SpanPoly) -> IntervalGeom<'a> {
    IntervalGeom { start, end, ds_mm, sign: 1.0, span: Some(poly), quintic: false }
}

/// Halvings of a step at most for the interpolation error (a factor of 2⁻¹² in length).
const INTERP_HALVINGS: usize = 12;
/// Largest interpolation error of the node geometry inside an interval, as a share of an axis
/// limit at the velocity bound (the planner keeps `1 − limit_fraction` of headroom).
const INTERP_ERROR_TOL: f64 = 1e-3;

/// How far the geometry the limit checks interpolate between nodes at `s` and `s + h` misses
/// the element's own at the middle (on smoothed pieces also at a quarter and three quarters:
/// a quintic A′ can bulge off the element's between the middle and the ends, where the cubic
/// scheme's linear A‴ cannot), as the largest share of an axis limit it can cost (see
/// [`interpolation_error_at`]), weighed at the highest flat v̄ of the ends and those points.
fn interpolation_error(e: &Element, s: f64, h: f64, feed: f64, quintic: bool, lim: &Limits) -> f64 {
    let (a, b) = (geom_at(e, s), geom_at(e, s + h));
    let sigmas: &[f64] = if quintic { &CHECK_FRACTIONS[1..CHECK_FRACTIONS.len() - 1] } else { &[0.5] };
    let inner: Vec<(f64, NodeGeom)> = sigmas.iter().map(|&x| (x, geom_at(e, s + x * h))).collect();
    let flat = |g: &NodeGeom| flat_velocity_bound(g, lim);
    let v = inner.iter().fold(flat(&a).max(flat(&b)), |m, (_, g)| m.max(flat(g))).min(feed);
    let error =
        inner.iter().map(|(x, m)| interpolation_error_at(h, (&a, &b), (*x, m), v, quintic, lim)).fold(0.0, f64::max);
    if !quintic {
        return error;
    }
    let checked: Vec<&NodeGeom> = [&a].into_iter().chain(inner.iter().map(|(_, g)| g)).chain([&b]).collect();
    error.max(check_point_bulge(e, s, h, &checked, v, lim))
}

/// How far the element's A″ and A‴ between the limit checks' points (`check::CHECK_FRACTIONS`
/// of the interval from `s` to `s + h`, whose geometry is `checked`) exceed what those points
/// see, as the largest share of an axis limit at path velocity `v`. The quintic scheme's A‴ is
/// a cubic in s: on an interval where it peaks between two check points, motion planned to the
/// limit at the points breaks it in between (a smoothed B-spline piece: 2 % over the jerk limit,
/// its A‴ peaking 0.09 of the interval from the nearest point). The cubic scheme's A‴ is linear
/// and peaks at a node, so only the quintic scheme's steps are tested.
fn check_point_bulge(e: &Element, s: f64, h: f64, checked: &[&NodeGeom], v: f64, lim: &Limits) -> f64 {
    if !v.is_finite() {
        return 0.0;
    }
    let mut worst = 0.0f64;
    for (pair, sigmas) in checked.windows(2).zip(CHECK_FRACTIONS.windows(2)) {
        let sigma = 0.5 * (sigmas[0] + sigmas[1]);
        let m = geom_at(e, s + sigma * h);
        for k in 0..lim.n_axes {
            let d2 = m.d2[k].abs() - pair[0].d2[k].abs().max(pair[1].d2[k].abs());
            let d3 = m.d3[k].abs() - pair[0].d3[k].abs().max(pair[1].d3[k].abs());
            let inv_acc = lim.inv_acc_max[k].max(-lim.inv_acc_min[k]);
            worst = worst.max(d2 * v * v * inv_acc).max(d3 * v * v * v * lim.inv_jerk[k]);
        }
    }
    if worst.is_nan() { f64::INFINITY } else { worst }
}

/// The interpolation error of the interval `h` long from geometry `a` to `b`, whose point at
/// fraction σ has the geometry `m`, at path velocity `v`: the errors of A′, A″, A‴ there times
/// v, v², v³ (and the cross terms of eq. 1b–1c with the path acceleration and jerk the axes
/// allow along A′), as the largest share of an axis limit.
fn interpolation_error_at(
    h: f64,
    (a, b): (&NodeGeom, &NodeGeom),
    (sigma, m): (f64, &NodeGeom),
    v: f64,
    quintic: bool,
    lim: &Limits,
) -> f64 {
    if !v.is_finite() {
        return 0.0;
    }
    // Path acceleration and jerk the axes allow along the tangent alone.
    let (mut acc_p, mut jerk_p) = (f64::INFINITY, f64::INFINITY);
    for k in 0..lim.n_axes {
        let t = m.d1[k].abs();
        if t > 0.0 {
            acc_p = acc_p.min(lim.acc_max[k].min(-lim.acc_min[k]) / t);
            jerk_p = jerk_p.min(lim.jerk[k] / t);
        }
    }
    let g = IntervalGeom { start: a, end: b, ds_mm: h, sign: 1.0, span: None, quintic };
    let i = node_geom_at(&g, sigma, lim.n_axes);
    let mut worst = 0.0f64;
    for k in 0..lim.n_axes {
        let (e1, e2, e3) = ((i.d1[k] - m.d1[k]).abs(), (i.d2[k] - m.d2[k]).abs(), (i.d3[k] - m.d3[k]).abs());
        let inv_acc = lim.inv_acc_max[k].max(-lim.inv_acc_min[k]);
        let r_vel = e1 * v * lim.inv_vel[k];
        let r_acc = (e2 * v * v + e1 * acc_p.min(f64::MAX)) * inv_acc;
        let r_jerk =
            (e3 * v * v * v + 3.0 * e2 * v * acc_p.min(f64::MAX) + e1 * jerk_p.min(f64::MAX)) * lim.inv_jerk[k];
        worst = worst.max(r_vel).max(r_acc).max(r_jerk);
    }
    if worst.is_nan() { f64::INFINITY } else { worst }
}

/// Whether the checks may interpolate the geometry of `e` between its nodes with the quintic
/// Hermite A′ (`hermite_basis::HermiteBasis`): on smoothed pieces, whose A‴ can change too fast for the
/// linear A‴ of the cubic scheme (its O(ds²) error, weighed by v³, set a node every 0.5–1.5 µm
/// on tight smoothed CAM paths). It is taken only on the steps where the cubic scheme would
/// need a shorter one; lines, arcs, splines, path tables and every other step keep the cubic
/// scheme their figures were measured with. The coarser grid costs some speed on clean data
/// (fewer places for the constant-jerk profile to change its jerk: the 2 µm trochoid of
/// `cam_bench.py --quick` runs 1.6 % longer), which `[planner] quintic_checks = false` avoids.
fn is_quintic(e: &Element) -> bool {
    matches!(e.geometry, crate::path::Geometry::Quintic(_))
}

fn push_interior(e: &Element, s_local: f64, d: &mut AxisDerivs, feed: f64, lim: &Limits, out: &mut Vec<Node>) {
    e.geometry.eval(s_local, d);
    let g = NodeGeom::from(&*d);
    out.push(Node {
        s_mm: e.s_start_mm + s_local,
        left: g,
        right: g,
        vbar_mm_s: velocity_bound(&g, lim).min(feed),
        vbar_flat_mm_s: flat_velocity_bound(&g, lim).min(feed),
        feed_mm_s: feed,
        stop: false,
        dwell_s: 0.0,
        line: e.source.line,
        reach_bound: false,
        span: None,
        quintic: false,
    });
}

/// The node at the end of the path (the motion ends at rest).
pub(super) fn end_node(last: &Element, end: &ElementEnd, final_dwell_s: f64, params: &SamplingParams) -> Node {
    let g = end.geom;
    Node {
        s_mm: last.s_end_mm(),
        left: g,
        right: g,
        vbar_mm_s: 0.0,
        vbar_flat_mm_s: 0.0,
        feed_mm_s: feed_of(last, params),
        stop: true,
        dwell_s: final_dwell_s,
        line: last.source.line,
        reach_bound: false,
        span: None,
        quintic: false,
    }
}

/// Rows of a path table farther apart in time than this many `max_interval_ms` get nodes in
/// between: jerk can only switch at nodes, and branches cannot meet smoothly on a coarser grid.
const TABLE_INTERVAL_FACTOR: f64 = 3.0;

/// Step inside a path-table interval from a point with geometry `d`: the row spacing unless
/// the motion is slow there (near a stop) or an interval would last longer than
/// `TABLE_INTERVAL_FACTOR` × `max_interval_ms` at the velocity bound.
#[allow(clippy::too_many_arguments)]
fn table_step(
    e: &Element,
    d: &AxisDerivs,
    feed: f64,
    from_start_mm: f64,
    to_end_mm: f64,
    j_path: f64,
    a_path: f64,
    lim: &Limits,
    params: &SamplingParams,
) -> f64 {
    let v = flat_velocity_bound(&NodeGeom::from(d), lim)
        .min(feed)
        .min(speed_from_rest(from_start_mm.max(0.0), j_path, a_path))
        .min(speed_from_rest(to_end_mm.max(0.0), j_path, a_path));
    let ds = v * params.max_interval_s * TABLE_INTERVAL_FACTOR;
    let ds = if ds.is_finite() { ds.max(params.min_step_mm) } else { e.geometry.length_mm() };
    ds.min(stop_grading_step(from_start_mm, to_end_mm, params))
}

/// Step length at local position `s` of element `e`.
#[allow(clippy::too_many_arguments)]
fn step_at(
    e: &Element,
    s: f64,
    d: &mut AxisDerivs,
    feed: f64,
    from_start_mm: f64,
    to_end_mm: f64,
    j_path: f64,
    a_path: f64,
    cruise_ramp: Option<f64>,
    lim: &Limits,
    params: &SamplingParams,
) -> f64 {
    e.geometry.eval(s, d);
    let ds = geometric_step(sharpness_at(d, lim, params), params);
    let g = NodeGeom::from(&*d);
    let v_nom = flat_velocity_bound(&g, lim)
        .min(feed)
        .min(speed_from_rest(from_start_mm.max(0.0), j_path, a_path))
        .min(speed_from_rest(to_end_mm.max(0.0), j_path, a_path));
    // The speed-based spacing stops at min_step_mm; the geometry-based one may go below it,
    // down to GEOMETRY_MIN_STEP_MM, so tight features are resolved and not stepped over.
    let ds_geometry = ds.max(GEOMETRY_MIN_STEP_MM);
    let mut ds_speed =
        if v_nom.is_finite() { (v_nom * params.max_interval_s).max(params.min_step_mm) } else { f64::INFINITY };
    if let Some(ramp_mm) = cruise_ramp {
        let inside_mm = s.min(e.geometry.length_mm() - s) - ramp_mm;
        ds_speed = ds_speed.max(CRUISE_GRADING * inside_mm);
    }
    // At a feed so low that its whole stop is shorter than `min_step_mm` (F1 on a stiff
    // machine: 10 nm), the grading goes on below it, to a quarter of that stop; at any
    // usual feed the stop is far longer and `min_step_mm` is the floor.
    let v_cruise = flat_velocity_bound(&g, lim).min(feed);
    let floor = params.min_step_mm.min(0.25 * stop_distance_mm(v_cruise, a_path, j_path)).max(GEOMETRY_MIN_STEP_MM);
    ds_geometry.min(ds_speed).min((STOP_GRADING * from_start_mm.min(to_end_mm).max(0.0)).max(floor))
}

/// Where an element's velocity bound is its feed all along (a line, or an arc whose curvature
/// keeps every axis' limits above the feed, on linear axes), the motion can change speed only
/// near its ends, within the distance it needs to stop from the feed (`ramp`, returned); in
/// between it cruises, and a time step of `max_interval_ms` would only add nodes: at F1 on a
/// 3 m arc, 10⁸ of them. There the steps grow with the distance from that ramp
/// (`CRUISE_GRADING`, as near a stop) up to the geometric ones. `None` where the bound varies
/// along the element.
fn cruise_ramp_mm(
    e: &Element,
    feed: f64,
    a_path: f64,
    j_path: f64,
    lim: &Limits,
    params: &SamplingParams,
) -> Option<f64> {
    if !feed.is_finite() || !params.linear.iter().all(|&l| l) {
        return None;
    }
    if !matches!(e.geometry, crate::path::Geometry::Line(_) | crate::path::Geometry::Helix(_)) {
        return None;
    }
    // Along a line or helix of linear axes |A′| = 1 and ‖A″‖, ‖A‴‖ are constant: bounds of
    // every axis' |A′_k|, |A″_k|, |A‴_k| anywhere on it.
    let mut mid = AxisDerivs::default();
    e.geometry.eval(0.5 * e.geometry.length_mm(), &mut mid);
    let norm = |x: &[f64]| x[..lim.n_axes].iter().map(|v| v * v).sum::<f64>().sqrt();
    let (d2, d3) = (norm(&mid.d2), norm(&mid.d3));
    for k in 0..lim.n_axes {
        let a = lim.acc_max[k].min(-lim.acc_min[k]);
        let bound = lim.vel[k].min((a / d2).sqrt()).min((lim.jerk[k] / d3).cbrt());
        if feed > bound {
            return None;
        }
    }
    Some(stop_distance_mm(feed, a_path, j_path))
}

/// Distance of the time-optimal stop from velocity `v` (acceleration 0) with path acceleration
/// up to `acc` and jerk up to `jerk`: v·√(v/J) where the stop never reaches `acc`
/// (v ≤ A²/J), else v²/(2A) + vA/(2J).
fn stop_distance_mm(v: f64, acc: f64, jerk: f64) -> f64 {
    if v * jerk <= acc * acc { v * (v / jerk).sqrt() } else { v * v / (2.0 * acc) + v * acc / (2.0 * jerk) }
}

/// Largest step in a cruise, as a share of the distance from the ramp at either end of the
/// element (`cruise_ramp_mm`).
const CRUISE_GRADING: f64 = 0.5;

/// Near a stop the nodes are graded geometrically: a step at most `STOP_GRADING` times the
/// distance to the stop. Leaving or approaching rest, the time from the stop grows only as
/// the cube root of the distance, so steps of `v · max_interval_ms` would put the whole jerk
/// phase of a slow approach into one or two intervals, where one constant jerk each cannot
/// shape it (the branches then arrive with a ≠ 0 and cannot join).
fn stop_grading_step(from_start_mm: f64, to_end_mm: f64, params: &SamplingParams) -> f64 {
    (STOP_GRADING * from_start_mm.min(to_end_mm).max(0.0)).max(params.min_step_mm)
}

/// Largest step near a stop, as a fraction of the distance to it.
const STOP_GRADING: f64 = 0.5;

/// Rounds of shrinking a step to the sharpest point it covers.
const SHARPNESS_ITERS: usize = 4;

/// Smallest step the geometry criteria may ask for, mm (spline spans turn on 1 µm radii at
/// the tightest; 1 nm resolves that by three orders of magnitude).
const GEOMETRY_MIN_STEP_MM: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Blend, CubicSpan, Geometry, Path, Source};

    /// A span whose curvature spikes to 29.8 /mm at u ≈ 0.060, where |P′| dips to 1.75 (mean
    /// 12.5), between the first two of 8 samples that show only 0.80 and 0.75: the profile
    /// finds the spike, not just the larger of the samples.
    #[test]
    fn a_curvature_spike_between_samples_is_found() {
        let cfg = Settings::default_machine();
        let lim = Limits::from_settings(&cfg);
        let params = SamplingParams::from_settings(&cfg);
        let v = |x: f64, y: f64| {
            let mut a = [0.0; crate::path::MAX_AXES];
            (a[0], a[1]) = (x, y);
            a
        };
        let span = CubicSpan::hermite(&v(0.0, 0.0), &v(9.27, -4.79), &v(-5.79, 2.10), &v(-2.48, 12.79), &[true; 3])
            .expect("the span passes the radius check");
        let len = span.length_mm();
        let mut path = Path::new(vec!["X".into(), "Y".into(), "Z".into()], [0.0; crate::path::MAX_AXES]);
        let src = Source { line: 1, block: 0 };
        path.push(Geometry::Cubic(Box::new(span)), Feed::Programmed { mm_per_s: 100.0 }, src, 0.0, Blend::Exact);
        // A step 4 times the span: the profile takes its fewest samples.
        let sharp = Sharpness::of(&path.elements[0], &lim, &params, 4.0 * len).expect("a cubic span is profiled");
        let curvature = sharp.max_over(0.0, len).0;
        assert!(curvature > 0.99 * 29.838, "largest curvature found {curvature} /mm, true 29.838 /mm");
    }

    /// Between the nodes of a path table the limit checks see the table's own geometry (its
    /// degree-7 rows), in both traversal directions, at every interval: A′, A″, A‴ from the
    /// element itself, to rounding. Also for the rest of the table from a point inside a row
    /// (a replan from a hold or hand-over cuts the row: `Path::suffix_from`). Interpolated from
    /// the nodes they would be off by up to a few per cent of a limit on these long intervals
    /// through the table's orientation swings.
    #[test]
    fn a_tables_checks_see_its_exact_geometry_between_nodes() {
        let cfg = Settings::five_axis_machine();
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/five_axis_table.csv")).unwrap();
        let path = crate::program::parse(&text, "t.csv", &cfg).unwrap().path;
        let (checked, worst) = exact_geometry_error(&cfg, &path);
        assert!(checked > 1000 && worst < 1e-9, "{checked} points, largest relative error {worst:e}");
        let rest = path.suffix_from(450.3);
        assert!(matches!(rest.elements[0].geometry, Geometry::Suffix(_)), "the cut lies inside a row");
        let (checked, worst) = exact_geometry_error(&cfg, &rest);
        assert!(checked > 100 && worst < 1e-9, "from 450.3 mm: {checked} points, largest relative error {worst:e}");
    }

    /// Points checked and the largest relative error of the checks' geometry between the
    /// nodes of `path` against the elements' own, with every interval required to carry its
    /// exact geometry.
    fn exact_geometry_error(cfg: &Settings, path: &Path) -> (usize, f64) {
        use crate::planner::check::geom_at;
        use crate::planner::view::View;
        let nodes = crate::planner::Planner::sample_path(cfg, path);
        let n = nodes.len();
        let at = |s_mm: f64| {
            let e = path.elements.iter().rev().find(|e| e.s_start_mm <= s_mm).unwrap();
            let mut d = AxisDerivs::default();
            e.geometry.eval(s_mm - e.s_start_mm, &mut d);
            d
        };
        let (mut checked, mut worst) = (0, 0.0f64);
        for (view, sign) in [(View::forward(&nodes), 1.0), (View::backward(&nodes), -1.0)] {
            for t in 0..n - 1 {
                let g = view.interval_geom(t);
                assert!(g.span.is_some() || g.ds_mm == 0.0, "interval {t} of {n} without its exact geometry");
                for sigma in [0.3, 0.5, 0.9] {
                    let s_mm = view.node(t).s_mm + sign * sigma * g.ds_mm;
                    let d = at(s_mm);
                    for k in 0..5 {
                        let (d1, d2, d3) = geom_at(&g, sigma, k);
                        let err = [(d1, sign * d.d1[k]), (d2, d.d2[k]), (d3, sign * d.d3[k])]
                            .map(|(x, want)| (x - want).abs() / (1.0 + want.abs()));
                        worst = worst.max(err.into_iter().fold(0.0, f64::max));
                    }
                    checked += 1;
                }
            }
        }
        (checked, worst)
    }
}
