//! Planning from a state in motion.
//!
//! The daemon replans in the middle of a program: after a feed override change it continues
//! from the state where the queued motion ends, at a node that is no stop, with a given
//! (v, a). (The stop every piece carries for a feed hold, a stop or an underrun is
//! [`super::brake`].)

use super::Planner;
use super::node::Node;
use super::profile::Segment;
use crate::Settings;

/// Below these the machine counts as standing: no stop needs planning.
pub(crate) const STANDSTILL_V_MM_S: f64 = 1e-9;
pub(crate) const STANDSTILL_A_MM_S2: f64 = 1e-9;

impl Planner {
    /// A planner for a path whose first element starts with path velocity `v_mm_s` and
    /// acceleration `a_mm_s2` (mm/s, mm/s²) instead of at rest. Use it with
    /// [`Path::suffix_from`](crate::path::Path::suffix_from) to continue planning from a state
    /// in motion.
    #[cfg(test)]
    pub(crate) fn with_start_state(settings: &Settings, v_mm_s: f64, a_mm_s2: f64) -> Self {
        Self::with_start_state_and_floor(settings, v_mm_s, a_mm_s2, Vec::new())
    }

    /// Like [`Planner::with_start_state`], with a velocity floor for the bounds near the start:
    /// pass a stop from the start state (as [`brake_along`](super::brake::brake_along) gives
    /// it). Where the new bounds lie below the start velocity (a lower feed override, nodes
    /// placed differently from the plan the state came from), the floor keeps the start
    /// viable.
    pub(crate) fn with_start_state_and_floor(
        settings: &Settings,
        v_mm_s: f64,
        a_mm_s2: f64,
        floor: Vec<Segment>,
    ) -> Self {
        let mut p = Planner::new(settings);
        p.vbar_floor = floor;
        p.start = (v_mm_s, a_mm_s2);
        p.start_moving = v_mm_s > STANDSTILL_V_MM_S || a_mm_s2.abs() > STANDSTILL_A_MM_S2;
        if p.start_moving {
            // Sampling is dense near stops (where the motion is slow); the start is none.
            p.since_stop_mm = f64::INFINITY;
        } else {
            p.start = (0.0, 0.0);
        }
        p
    }
}

/// The first node of a path that starts in motion: no stop, and its bound admits the state
/// (a bound below the start velocity would make the start itself infeasible; what follows the
/// start is still bounded by the nodes after it).
pub(super) fn admit_start_state(node: &mut Node, start: (f64, f64)) {
    node.stop = false;
    node.dwell_s = 0.0;
    node.vbar_mm_s = node.vbar_mm_s.max(start.0);
}

/// Raises the velocity bound of `nodes` inside `floor`'s path range to the velocity `floor`
/// has there. `floor` is a profile known to be feasible from the start state (the stop the
/// machine could run from there): it keeps the start viable when the new bounds lie below the
/// start velocity (a feed override decrease, or sample nodes placed differently from the
/// plan the state came from).
pub(super) fn raise_to_floor(nodes: &mut [Node], floor: &[Segment]) {
    let (Some(first), Some(last)) = (floor.first(), floor.last()) else { return };
    let (s_from, s_to) = (first.s0_mm, last.s1_mm());
    for node in nodes.iter_mut().filter(|n| n.s_mm >= s_from && n.s_mm <= s_to && !n.stop) {
        let k = floor.partition_point(|seg| seg.s1_mm() < node.s_mm).min(floor.len() - 1);
        let seg = &floor[k];
        // Time in the segment at which it reaches the node (s(τ) is monotone).
        let (mut lo, mut hi) = (0.0, seg.dt_s);
        for _ in 0..FLOOR_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if seg.at(mid).s_mm < node.s_mm { lo = mid } else { hi = mid }
        }
        node.vbar_mm_s = node.vbar_mm_s.max(seg.at(hi).v);
    }
}

/// Bisection steps locating a node's position inside a floor segment.
const FLOOR_BISECTIONS: usize = 50;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::profile;
    use crate::program;

    #[test]
    fn planning_from_a_moving_state_continues_the_profile() {
        let cfg = Settings::default_machine();
        let p = program::parse("G1 X100 F6000\nG1 X100 Y50", "t.ngc", &cfg).unwrap();
        let (segs, _) = Planner::plan_path(&cfg, &p.path).unwrap();
        let total = profile::duration_s(&segs);
        let mut cur = profile::Cursor::default();
        let st = cur.sample(&segs, 0.3).unwrap().state;
        let rest = p.path.suffix_from(st.s_mm);
        let mut planner = Planner::with_start_state(&cfg, st.v, st.a);
        for e in &rest.elements {
            planner.push(e.clone());
        }
        planner.finish(0.0);
        let cont = planner.plan_to_end().unwrap();
        assert!((cont[0].v0 - st.v).abs() < 1e-9 && (cont[0].a0 - st.a).abs() < 1e-9);
        let t = 0.3 + profile::duration_s(&cont);
        assert!((t - total).abs() < 0.01 * total, "continued {t} s vs whole {total} s");
        assert!((cont.last().unwrap().s1_mm() - p.path.length_mm()).abs() < 1e-6);
    }
}
