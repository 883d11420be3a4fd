//! Planning from a state in motion, and the fastest stop along the path.
//!
//! The daemon replans in the middle of a program: after a feed override change it continues
//! from the state where the queued motion ends; every piece it hands to the interpolator
//! carries the fastest stop from the piece's end, which the interpolator runs on a feed hold,
//! a stop or an underrun. Both start at a node that is no stop, with a given (v, a).

use super::block::plan_block;
use super::node::Node;
use super::profile::Segment;
use super::{PlanError, Planner};
use crate::path::Path;
use interpd_config::Config;

/// Below these the machine counts as standing: no stop needs planning.
pub const STANDSTILL_V_MM_S: f64 = 1e-9;
pub const STANDSTILL_A_MM_S2: f64 = 1e-9;
/// The first guess of the stopping distance is multiplied by this before more path is
/// sampled (curvature lowers the path limits below the axis limits).
const STOP_DISTANCE_MARGIN: f64 = 4.0;
/// Path sampled at least this far ahead for a stop, mm.
const MIN_STOP_LOOKAHEAD_MM: f64 = 1.0;

impl Planner {
    /// A planner for a path whose first element starts with path velocity `v_mm_s` and
    /// acceleration `a_mm_s2` (mm/s, mm/s²) instead of at rest. Use it with
    /// [`Path::suffix_from`] to continue planning from a state in motion.
    pub fn with_start_state(config: &Config, v_mm_s: f64, a_mm_s2: f64) -> Self {
        let mut p = Planner::new(config);
        p.start = (v_mm_s, a_mm_s2);
        p.start_moving = v_mm_s > STANDSTILL_V_MM_S || a_mm_s2.abs() > STANDSTILL_A_MM_S2;
        if !p.start_moving {
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

/// The fastest stop along `path` for a machine at its start with path velocity `v_mm_s` and
/// acceleration `a_mm_s2`: constant-jerk segments (times from 0) that keep every axis limit and
/// end at rest at a sample node, the nearest one at which a stop is feasible. Empty when the
/// machine already stands. An error when no stop is possible within the path (the motion
/// that led here was not stoppable, which the planner's hand-over rule excludes).
pub fn fastest_stop(config: &Config, path: &Path, v_mm_s: f64, a_mm_s2: f64) -> Result<Vec<Segment>, PlanError> {
    let mut planner = Planner::with_start_state(config, v_mm_s, a_mm_s2);
    if !planner.start_moving {
        return Ok(Vec::new());
    }
    let lim = planner.lim.clone();
    let (v, a) = planner.start;
    // Braking from (v, a): ramp a down to the lowest path acceleration, then brake.
    let (acc, jerk) = (lim.min_acc(), lim.min_jerk());
    let t_guess = a.max(0.0) / jerk + acc / jerk + v / acc;
    let mut need_mm = (STOP_DISTANCE_MARGIN * v * t_guess).max(MIN_STOP_LOOKAHEAD_MM);
    let mut next = 0;
    let mut pushed_mm = 0.0;
    loop {
        while next < path.elements.len() && (pushed_mm < need_mm || next < 2) {
            pushed_mm += path.elements[next].geometry.length_mm();
            planner.push(path.elements[next].clone());
            next += 1;
        }
        if next == path.elements.len() {
            planner.finish(0.0);
        }
        planner.sample_pending();
        if let Some(segments) = stop_within(&planner, v, a)? {
            return Ok(segments);
        }
        if next == path.elements.len() {
            let s_mm = path.elements.first().map_or(0.0, |e| e.s_start_mm);
            return Err(PlanError::Infeasible {
                s_mm,
                line: path.elements.first().map_or(0, |e| e.source.line),
                reason: format!("no stop from {v:.3} mm/s within the rest of the path"),
            });
        }
        need_mm *= 2.0;
    }
}

/// The stop at the nearest feasible node among the sampled ones (up to the first real stop),
/// as segments; `None` if none of them is reachable at rest.
fn stop_within(planner: &Planner, v: f64, a: f64) -> Result<Option<Vec<Segment>>, PlanError> {
    let nodes = &planner.nodes;
    if nodes.len() < 2 {
        return Ok(None);
    }
    let last = (1..nodes.len()).find(|&i| nodes[i].stop).unwrap_or(nodes.len() - 1);
    // Exponential search for a feasible stop node, then bisection for the nearest.
    let mut lo = 0;
    let mut hi = 1;
    let found = loop {
        if let Some(segments) = try_stop_at(planner, hi, (v, a)) {
            break segments;
        }
        if hi == last {
            return Ok(None);
        }
        lo = hi;
        hi = (hi * 2).min(last);
    };
    let mut best = found;
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        match try_stop_at(planner, mid, (v, a)) {
            Some(segments) => {
                best = segments;
                hi = mid;
            }
            None => lo = mid,
        }
    }
    Ok(Some(best))
}

/// The profile from the start state to rest at node `k`, if the block planner finds one.
fn try_stop_at(planner: &Planner, k: usize, start: (f64, f64)) -> Option<Vec<Segment>> {
    let mut nodes: Vec<Node> = planner.nodes[..=k].to_vec();
    nodes[k].vbar_mm_s = 0.0;
    let plan = plan_block(&mut nodes, start, false, &planner.lim).ok()?;
    if !plan.node_aligned {
        return None;
    }
    let mut t = 0.0;
    let segments = plan
        .intervals
        .iter()
        .zip(&nodes)
        .map(|(iv, node)| {
            let seg = Segment {
                s0_mm: node.s_mm,
                t0_s: t,
                v0: iv.v0,
                a0: iv.a0,
                j: iv.j,
                dt_s: iv.t_s,
                ds_mm: iv.ds_mm,
                line: node.line,
            };
            t += iv.t_s;
            seg
        })
        .collect();
    Some(segments)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::profile;
    use crate::program;

    fn prog(text: &str) -> program::Program {
        program::parse(text, "t.ngc", &Config::default_machine()).unwrap()
    }

    /// Plans `text` whole, cuts the profile at `t_cut_s`, and stops from there.
    fn stop_from(text: &str, t_cut_s: f64) -> (Vec<Segment>, f64, f64) {
        let cfg = Config::default_machine();
        let p = prog(text);
        let (segs, _) = Planner::plan_path(&cfg, &p.path).unwrap();
        let mut cur = profile::Cursor::default();
        let (st, _) = cur.at(&segs, t_cut_s).unwrap();
        let tail = fastest_stop(&cfg, &p.path.suffix_from(st.s_mm), st.v, st.a).unwrap();
        (tail, st.s_mm, st.v)
    }

    #[test]
    fn stop_from_cruise_on_a_line_is_continuous_and_ends_at_rest() {
        let (tail, s0, v0) = stop_from("G1 X400 F9000", 1.0);
        assert!(v0 > 100.0, "not cruising: {v0}");
        let first = tail.first().unwrap();
        assert!((first.s0_mm - s0).abs() < 1e-9 && (first.v0 - v0).abs() < 1e-9);
        let end = tail.last().unwrap().at(tail.last().unwrap().dt_s);
        assert!(end.v.abs() < 1e-6 && end.a.abs() < 1e-3, "end state {end:?}");
        // 150 mm/s, 2500 mm/s², 50000 mm/s³ (path along X): ~0.06 s + 0.05 s.
        let t = profile::duration_s(&tail);
        assert!(t < 0.2, "stop took {t} s");
        for w in tail.windows(2) {
            let e = w[0].at(w[0].dt_s);
            assert!((e.v - w[1].v0).abs() < 1e-6 && (e.a - w[1].a0).abs() < 1e-3);
        }
    }

    #[test]
    fn stop_on_an_arc_keeps_before_the_corner() {
        let text = "G1 X10 F6000\nG2 X30 Y0 I10 J0\nG1 X30 Y-20";
        let (tail, _, v0) = stop_from(text, 0.2);
        assert!(v0 > 1.0);
        let end = tail.last().unwrap();
        assert!(end.s1_mm() <= 10.0 + std::f64::consts::PI * 10.0 + 1e-9, "stopped past the corner");
    }

    #[test]
    fn standing_machine_needs_no_stop() {
        let cfg = Config::default_machine();
        let p = prog("G1 X10 F600");
        assert!(fastest_stop(&cfg, &p.path, 0.0, 0.0).unwrap().is_empty());
    }

    #[test]
    fn planning_from_a_moving_state_continues_the_profile() {
        let cfg = Config::default_machine();
        let p = prog("G1 X100 F6000\nG1 X100 Y50");
        let (segs, _) = Planner::plan_path(&cfg, &p.path).unwrap();
        let total = profile::duration_s(&segs);
        let mut cur = profile::Cursor::default();
        let (st, _) = cur.at(&segs, 0.3).unwrap();
        let rest = p.path.suffix_from(st.s_mm);
        let mut planner = Planner::with_start_state(&cfg, st.v, st.a);
        for e in &rest.elements {
            planner.push(e.clone());
        }
        planner.finish(0.0);
        let cont = planner.plan().unwrap();
        assert!((cont[0].v0 - st.v).abs() < 1e-9 && (cont[0].a0 - st.a).abs() < 1e-9);
        let t = 0.3 + profile::duration_s(&cont);
        assert!((t - total).abs() < 0.01 * total, "continued {t} s vs whole {total} s");
        assert!((cont.last().unwrap().s1_mm() - p.path.length_mm()).abs() < 1e-6);
    }
}
