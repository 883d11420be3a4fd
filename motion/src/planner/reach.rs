//! What acceleration alone can reach: the ceiling of a block lowered by the forward and
//! backward passes of the acceleration-only time-optimal problem (the classical time-optimal
//! path parameterisation in b = v², where b is linear over a step of constant a).
//!
//! The node bound v̄ lets the acceleration be anything that keeps the axes within their limits;
//! above a sharp dip of v̄ no motion can follow it. Every jerk-limited profile is also
//! acceleration-limited, so it lies under the passes' profile: lowering the ceiling to it loses
//! nothing, and puts the section ends (the ceiling's minima, Kopp et al. 2019, §3.1) where the
//! motion must really be slowest.

use super::check::acc_range;
use super::limits::Limits;
use super::node::Node;

/// Lowers the interior of `ceiling` (initially the nodes' v̄) to what acceleration can reach
/// from, and brake to, the ceiling at the other interior nodes.
pub(super) fn lower_to_reachable(nodes: &[Node], ceiling: &mut [f64], lim: &Limits) {
    let n = nodes.len();
    // Backward: b_i ≤ b_{i+1} − 2·Δs·a_min at node i+1. Not from the block end: its stop
    // (or a horizon end a later horizon moves on) is the backward branch's business, and
    // the ceiling it would spread is no dip the branches need to know of.
    for i in (0..n.saturating_sub(2)).rev() {
        let v1 = ceiling[i + 1];
        let (lo, hi) = acc_range(&nodes[i + 1].left, 1.0, v1, lim);
        if lo <= hi {
            let ds = nodes[i + 1].s_mm - nodes[i].s_mm;
            let b = (v1 * v1 - 2.0 * ds * lo).max(0.0);
            ceiling[i] = ceiling[i].min(b.sqrt());
        }
    }
    // Forward: b_{i+1} ≤ b_i + 2·Δs·a_max at node i; not from the block start, whose state
    // the forward branch starts from anyway.
    for i in 1..n.saturating_sub(2) {
        let v0 = ceiling[i];
        let (lo, hi) = acc_range(&nodes[i].right, 1.0, v0, lim);
        if lo <= hi {
            let ds = nodes[i + 1].s_mm - nodes[i].s_mm;
            let b = (v0 * v0 + 2.0 * ds * hi).max(0.0);
            ceiling[i + 1] = ceiling[i + 1].min(b.sqrt());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::limits::Limits;
    use super::super::node::{Node, NodeGeom};
    use super::*;
    use crate::Settings;

    /// A straight X move with nodes 1 mm apart and a ceiling with one sharp dip.
    fn line(n: usize) -> Vec<Node> {
        let mut g = NodeGeom::default();
        g.d1[0] = 1.0;
        (0..n).map(|i| Node::for_test(i as f64, g, 100.0)).collect()
    }

    #[test]
    fn passes_lower_a_dip_to_what_acceleration_reaches_and_nothing_else() {
        let lim = Limits::from_settings(&Settings::default_machine());
        let a = lim.acc_max[0];
        let nodes = line(41);
        let mut c = vec![1000.0; 41];
        c[20] = 10.0;
        lower_to_reachable(&nodes, &mut c, &lim);
        for (i, &v) in c.iter().enumerate() {
            // b = v² grows by 2·a·Δs per node away from the dip (never above the original).
            let reach = (100.0 + 2.0 * a * (i as f64 - 20.0).abs()).sqrt().min(1000.0);
            if (1..40).contains(&i) {
                assert!((v - reach).abs() <= 1e-9 * reach, "node {i}: {v} vs {reach}");
            }
        }
        // The block ends are not propagated from (the branches take care of them).
        assert_eq!(c[40], 1000.0);
    }
}
