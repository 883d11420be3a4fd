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

/// The profile of a block: one interval per node pair, the first node whose state depends
/// on where the block ends, and the work it took.
#[derive(Debug, Clone)]
pub struct BlockPlan {
    pub intervals: Vec<Interval>,
    pub final_before: usize,
    pub work: Work,
}

/// Plans `nodes` (first node: given state `start`; last node: rest).
pub fn plan_block(nodes: &mut [Node], start: (f64, f64), lim: &Limits) -> Result<BlockPlan, Stuck> {
    let mut work = Work::default();
    let mut repairs_at: Vec<(usize, usize)> = Vec::new();
    for _ in 0..=MAX_REPAIRS {
        let env = build_envelope(nodes, lim, &mut work)?;
        match forward_branch(nodes, &env, start, lim, &mut work) {
            Ok(f) => return Ok(BlockPlan { intervals: f.intervals, final_before: f.final_before, work }),
            Err(stuck) => {
                work.repairs += 1;
                let k = stuck.node.clamp(1, nodes.len() - 1);
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
