//! Plans one block: the nodes between two stops (or the start of the horizon and its end).
//! Builds the ceiling, runs the forward branch, and repairs the rare dead end by lowering the
//! velocity bound where the branch got stuck (a new section end), a bounded number of times.

use super::branch::{Stuck, build_envelope};
use super::forward::forward_branch;
use super::interval::Interval;
use super::limits::Limits;
use super::node::Node;
use super::step::Work;

/// Repairs per block before the block is reported as infeasible.
pub const MAX_REPAIRS: usize = 64;
/// Factors applied to the stuck node's velocity, in order, when repairing there again.
const REPAIR_FACTORS: [f64; 5] = [0.9, 0.7, 0.4, 0.1, 0.0];

/// The profile of a block, the first node whose state depends on where the block ends, and
/// the work it took.
#[derive(Debug, Clone)]
pub struct BlockPlan {
    pub intervals: Vec<Interval>,
    /// `intervals[k]` runs from node k to node k+1; otherwise the intervals are a time-domain
    /// profile from the first node to the last (a closed-form straight move).
    pub node_aligned: bool,
    pub final_before: usize,
    pub work: Work,
}

/// Plans `nodes` (first node: given state `start`; last node: rest). `end_is_stop` tells
/// whether the last node is a real stop (and not just where the horizon ends).
pub fn plan_block(nodes: &mut [Node], start: (f64, f64), end_is_stop: bool, lim: &Limits) -> Result<BlockPlan, Stuck> {
    let mut work = Work::default();
    if end_is_stop && start == (0.0, 0.0) {
        if let Some(intervals) = straight_move(nodes, lim) {
            return Ok(BlockPlan { intervals, node_aligned: false, final_before: nodes.len() - 1, work });
        }
    }
    let mut repairs_at: Vec<(usize, usize)> = Vec::new();
    for _ in 0..=MAX_REPAIRS {
        let env = build_envelope(nodes, lim, &mut work)?;
        match forward_branch(nodes, &env, start, lim, &mut work) {
            Ok(f) => {
                return Ok(BlockPlan {
                    intervals: f.intervals,
                    node_aligned: true,
                    final_before: f.final_before,
                    work,
                });
            }
            Err(stuck) => {
                work.repairs += 1;
                // Never the block end itself (a stop): lowering there changes nothing, and
                // its zero would spread to the node before it.
                if nodes.len() < 3 {
                    return Err(stuck);
                }
                let k = stuck.node.clamp(1, nodes.len() - 2);
                let count = match repairs_at.iter_mut().find(|(n, _)| *n == k) {
                    Some((_, c)) => {
                        *c += 1;
                        *c
                    }
                    None => {
                        repairs_at.push((k, 1));
                        1
                    }
                };
                let Some(&factor) = REPAIR_FACTORS.get(count - 1) else {
                    return Err(stuck);
                };
                tracing::debug!(
                    node = k,
                    s_mm = nodes[k].s_mm,
                    factor,
                    reason = stuck.reason,
                    "planner repair: lowering v̄"
                );
                // Lower the bound at the stuck node and one before it: a new section end.
                let base = nodes[k].vbar_mm_s.min(nodes[k - 1].vbar_mm_s);
                for i in [k - 1, k] {
                    if i > 0 {
                        nodes[i].vbar_mm_s = nodes[i].vbar_mm_s.min(factor * base);
                    }
                }
            }
        }
    }
    Err(Stuck { node: nodes.len() - 1, reason: "too many repairs" })
}

/// Relative tolerance for "the same direction" along a straight block (as for a smooth joint,
/// `path::TANGENT_ANGLE_TOL_RAD`).
const STRAIGHT_REL_TOL: f64 = 1e-9;

/// A block that is one straight line with one feed, from rest to rest: its time-optimal
/// profile in closed form (see `scurve`). `None` for any other block.
fn straight_move(nodes: &[Node], lim: &Limits) -> Option<Vec<Interval>> {
    let n = nodes.len();
    if n < 2 {
        return None;
    }
    let d1 = nodes[0].right.d1;
    let scale = d1[..lim.n_axes].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if scale == 0.0 {
        return None;
    }
    let same = |g: &super::node::NodeGeom| {
        (0..lim.n_axes).all(|k| (g.d1[k] - d1[k]).abs() <= STRAIGHT_REL_TOL * scale && g.d2[k] == 0.0 && g.d3[k] == 0.0)
    };
    let feed = nodes[0].feed_mm_s;
    for (i, node) in nodes.iter().enumerate() {
        let left_ok = i == 0 || same(&node.left);
        let right_ok = i == n - 1 || same(&node.right);
        if !(left_ok && right_ok) || (i + 1 < n && node.feed_mm_s != feed) {
            return None;
        }
    }
    // Path limits along the line: each axis moves d1_k per unit of path.
    let (mut v, mut a, mut j) = (feed, f64::INFINITY, f64::INFINITY);
    for (k, d) in d1.iter().enumerate().take(lim.n_axes) {
        let c = d.abs();
        if c > 0.0 {
            v = v.min(lim.vel[k] / c);
            a = a.min(lim.acc_max[k].min(-lim.acc_min[k]) / c);
            j = j.min(lim.jerk[k] / c);
        }
    }
    let length = nodes[n - 1].s_mm - nodes[0].s_mm;
    (length > 0.0 && v > 0.0 && v.is_finite()).then(|| super::scurve::rest_to_rest(length, v, a, j))
}
