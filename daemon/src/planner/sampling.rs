//! Adaptive sampling of the path (seed 001 §2.2): nodes are denser where the curvature, its
//! change or the orientation change is high, near stops (where the motion is slow), and so
//! that no interval lasts much longer than `planner.max_interval_ms` at the bound speed (jerk
//! can only switch at nodes).
//!
//! Sampling depends only on an element, its predecessor, whether its successor stops, and
//! the distance from the last stop, so planning a program element by element gives the same
//! nodes as planning it whole.

use super::limits::Limits;
use super::node::{Node, NodeGeom, curvature_jump_cap, velocity_bound};
use crate::path::{AxisDerivs, Element, Feed, JointKind};
use interpd_config::{AxisKind, Config};

/// Sampling parameters derived from `[planner]`.
#[derive(Debug, Clone)]
pub struct SamplingParams {
    pub max_step_mm: f64,
    pub min_step_mm: f64,
    pub max_turn_rad: f64,
    pub max_turn_deg: f64,
    pub max_interval_s: f64,
    pub curvature_jump_s: f64,
    pub rapid_feed_mm_s: f64,
    pub linear: Vec<bool>,
}

impl SamplingParams {
    pub fn from_config(config: &Config) -> Self {
        let p = &config.planner;
        Self {
            max_step_mm: p.max_step_mm,
            min_step_mm: p.min_step_mm,
            max_turn_rad: p.max_turn_deg.to_radians(),
            max_turn_deg: p.max_turn_deg,
            max_interval_s: p.max_interval_ms * 1e-3,
            curvature_jump_s: p.curvature_jump_ms * 1e-3,
            rapid_feed_mm_s: p.rapid_feed_mm_s.unwrap_or(f64::INFINITY),
            linear: config.axes.iter().map(|a| a.kind == AxisKind::Linear).collect(),
        }
    }
}

/// The feed of an element in mm/s.
pub fn feed_of(e: &Element, params: &SamplingParams) -> f64 {
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
/// nodes; the node at its end belongs to the next element (or [`end_node`]).
///
/// `since_stop_mm` is the path length from the last stop to the element start; it is updated
/// to the element end. `next_stops` tells whether the motion must be at rest at the element end.
pub fn sample_element(
    prev: Option<&Element>,
    e: &Element,
    next_stops: bool,
    since_stop_mm: &mut f64,
    lim: &Limits,
    params: &SamplingParams,
    out: &mut Vec<Node>,
) {
    let len = e.geometry.length_mm();
    let feed = feed_of(e, params);
    let mut d = AxisDerivs::default();
    e.geometry.eval(0.0, &mut d);
    let right = NodeGeom::from(&d);
    let (left, stop) = match prev {
        Some(p) => {
            let mut dp = AxisDerivs::default();
            p.geometry.eval(p.geometry.length_mm(), &mut dp);
            (NodeGeom::from(&dp), e.stops_before())
        }
        None => (right, true),
    };
    if stop {
        *since_stop_mm = 0.0;
    }
    let mut vbar = velocity_bound(&left, lim).min(velocity_bound(&right, lim)).min(feed);
    if let Some(p) = prev {
        vbar = vbar.min(feed_of(p, params));
    }
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
        feed_mm_s: feed,
        stop,
        dwell_s: e.dwell_before_s,
        line: e.source.line,
    });

    // A straight line between two stops is planned in closed form (`scurve`): its interior
    // nodes would not be used. A path table brings its own samples (seed 001 §2.2: the
    // control supplies A … A‴ at each s_i); they are the nodes, as in the seed's example.
    // Only near stops does a table get extra nodes, where the motion is too slow for its
    // rows' spacing.
    let own_samples = matches!(e.geometry, crate::path::Geometry::Septic(_));
    if stop && next_stops && matches!(e.geometry, crate::path::Geometry::Line(_)) {
        *since_stop_mm += len;
        return;
    }
    let j_path = lim.min_jerk();
    let a_path = lim.min_acc();
    let mut s = 0.0;
    loop {
        let from_start = *since_stop_mm + s;
        let to_end = if next_stops { len - s } else { f64::INFINITY };
        let mut ds = if own_samples {
            table_step(e, s, &mut d, feed, from_start, to_end, j_path, a_path, lim, params)
        } else {
            step_at(e, s, &mut d, feed, from_start, to_end, j_path, a_path, lim, params)
        };
        // Look at the far end of the step too, so a step does not jump into a sharp region.
        if s + ds < len && !own_samples {
            let ds2 = step_at(e, s + ds, &mut d, feed, from_start + ds, to_end - ds, j_path, a_path, lim, params);
            ds = ds.min(ds2.max(0.5 * ds));
        }
        let remaining = len - s;
        if remaining <= 1.5 * ds {
            if remaining > ds {
                // Two equal steps instead of a long one followed by a sliver.
                push_interior(e, s + 0.5 * remaining, &mut d, feed, lim, out);
            }
            break;
        }
        s += ds;
        push_interior(e, s, &mut d, feed, lim, out);
    }
    *since_stop_mm += len;
}

fn push_interior(e: &Element, s_local: f64, d: &mut AxisDerivs, feed: f64, lim: &Limits, out: &mut Vec<Node>) {
    e.geometry.eval(s_local, d);
    let g = NodeGeom::from(&*d);
    out.push(Node {
        s_mm: e.s_start_mm + s_local,
        left: g,
        right: g,
        vbar_mm_s: velocity_bound(&g, lim).min(feed),
        feed_mm_s: feed,
        stop: false,
        dwell_s: 0.0,
        line: e.source.line,
    });
}

/// The node at the end of the path (the motion ends at rest).
pub fn end_node(last: &Element, final_dwell_s: f64, params: &SamplingParams) -> Node {
    let mut d = AxisDerivs::default();
    last.geometry.eval(last.geometry.length_mm(), &mut d);
    let g = NodeGeom::from(&d);
    Node {
        s_mm: last.s_end_mm(),
        left: g,
        right: g,
        vbar_mm_s: 0.0,
        feed_mm_s: feed_of(last, params),
        stop: true,
        dwell_s: final_dwell_s,
        line: last.source.line,
    }
}

/// Rows of a path table farther apart in time than this many `max_interval_ms` get nodes in
/// between: jerk can only switch at nodes, and branches cannot meet smoothly on a coarser grid.
const TABLE_INTERVAL_FACTOR: f64 = 3.0;

/// Step inside a path-table interval: the row spacing unless the motion is slow there (near
/// a stop) or an interval would last longer than `TABLE_INTERVAL_FACTOR` × `max_interval_ms`
/// at the velocity bound.
#[allow(clippy::too_many_arguments)]
fn table_step(
    e: &Element,
    s: f64,
    d: &mut AxisDerivs,
    feed: f64,
    from_start_mm: f64,
    to_end_mm: f64,
    j_path: f64,
    a_path: f64,
    lim: &Limits,
    params: &SamplingParams,
) -> f64 {
    e.geometry.eval(s, d);
    let v = velocity_bound(&NodeGeom::from(&*d), lim)
        .min(feed)
        .min(speed_from_rest(from_start_mm.max(0.0), j_path, a_path))
        .min(speed_from_rest(to_end_mm.max(0.0), j_path, a_path));
    let ds = v * params.max_interval_s * TABLE_INTERVAL_FACTOR;
    if ds.is_finite() { ds.max(params.min_step_mm) } else { e.geometry.length_mm() }
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
    lim: &Limits,
    params: &SamplingParams,
) -> f64 {
    e.geometry.eval(s, d);
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
    let mut ds = params.max_step_mm;
    let curv = curv2.sqrt();
    if curv > 0.0 {
        ds = ds.min(params.max_turn_rad / curv); // tangent turn per step
    }
    let dcurv = dcurv2.sqrt();
    if dcurv > 0.0 {
        ds = ds.min((params.max_turn_rad / dcurv).sqrt()); // change of curvature per step
    }
    let rot_rate = rot_rate2.sqrt();
    if rot_rate > 0.0 {
        ds = ds.min(params.max_turn_deg / rot_rate); // orientation change per step, degrees
    }
    let g = NodeGeom::from(&*d);
    let v_nom = velocity_bound(&g, lim)
        .min(feed)
        .min(speed_from_rest(from_start_mm.max(0.0), j_path, a_path))
        .min(speed_from_rest(to_end_mm.max(0.0), j_path, a_path));
    if v_nom.is_finite() {
        ds = ds.min(v_nom * params.max_interval_s);
    }
    ds.max(params.min_step_mm)
}
