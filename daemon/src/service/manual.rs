//! Manual motion: jog (continuous or by a distance) and move-to, planned with the online
//! trajectory generator (interpd-otg) in the planner thread and handed to the real-time thread
//! as chunks with stop tails, exactly like programs.
//!
//! - A continuous jog drives each named axis with the OTG's velocity interface to its jog
//!   velocity (scaled by the feed override) and cruises there; a jog by a distance and a
//!   move-to use the position interface, a move-to with all its axes time-synchronised.
//! - A changed command replans from the state at the end of the queued motion (the handover
//!   instant): position, velocity and acceleration continue, so nothing steps.
//! - Every chunk's tail is every axis's fastest stop (the velocity interface to rest), checked
//!   to stay inside the travel; where it would not, the chunk is made longer.
//! - Soft limits: before a chunk of continuous jog is queued, the stop from its end is checked
//!   against the travel of each cruising axis. Where it would cross a limit, that axis switches
//!   at the chunk's start to the position interface with the limit as target at rest (its
//!   velocity bounded by the jog velocity): it brakes in time and stops at the limit. The stop
//!   from the chunk's start was checked one chunk earlier, so that target is reachable.

use super::otg_motion::{self, AxisLimits, OtgMotion};
use crate::interp::coarse::{CoarsePoint, TOLERANCE_MM};
use interpd_motion::path::{AxisVec, MAX_AXES};
use interpd_otg::{ControlInterface, Input, Otg, OtgError, State, Synchronization, Trajectory};
use interpd_protocol::api::ManualKind;
use std::collections::VecDeque;

/// A jog stops this far inside a soft limit (axis unit): the quintic's own tolerance, so that
/// neither it nor the OTG's rounding reaches past the limit.
pub const LIMIT_INSIDE: f64 = TOLERANCE_MM;
/// Slack of the travel checks (axis unit): rounding of positions that end on a limit.
const TRAVEL_SLACK: f64 = 1e-9;
/// Step of the travel checks along a planned motion, s (as the planner's stop checks).
const CHECK_STEP_S: f64 = 2.5e-4;
/// A chunk whose stop would leave the travel is made longer by this share of a chunk.
const EXTEND_SHARE: f64 = 0.25;
/// A finite motion ending less than this share of a chunk after a chunk's end is taken into
/// that chunk whole (no sliver chunk).
const END_SHARE: f64 = 0.25;
/// Tail ends remembered per queued chunk (more than the queue holds).
const TAIL_ENDS: usize = 32;

/// What the operator asked for.
#[derive(Debug, Clone, PartialEq)]
pub enum ManualGoal {
    /// Continuous jog: per named axis a velocity (axis unit/s, before the feed override);
    /// the other axes come to rest.
    JogVelocity { vel: [Option<f64>; MAX_AXES] },
    /// Jog by a distance (axis unit) from where the axis is at the handover instant; at the
    /// axis velocity limit scaled by the feed override.
    JogDistance { dist: [Option<f64>; MAX_AXES] },
    /// A jog by a distance once resolved: each named axis on its own to its target.
    JogTo { target: [Option<f64>; MAX_AXES] },
    /// Named axes to `target` (with `vel` there), time-synchronised, velocity limits scaled
    /// by `factor`; the other axes come to rest.
    MoveTo { target: [Option<f64>; MAX_AXES], vel: AxisVec, factor: f64 },
}

impl ManualGoal {
    pub fn kind(&self) -> ManualKind {
        match self {
            ManualGoal::MoveTo { .. } => ManualKind::MoveTo,
            _ => ManualKind::Jog,
        }
    }
}

/// Why a manual motion cannot be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ManualPlanError {
    #[error("trajectory generation failed: {0:?}")]
    Otg(OtgError),
    /// The motion (a move-to and the stop after a target velocity) leaves the travel.
    #[error("axis {axis} would reach {pos:.6}, outside its travel {min} to {max}")]
    LeavesTravel { axis: usize, pos: f64, min: f64, max: f64 },
}

impl From<OtgError> for ManualPlanError {
    fn from(e: OtgError) -> Self {
        ManualPlanError::Otg(e)
    }
}

/// A manual motion being queued: its goal, the per-axis OTG motion, and where queueing stands.
#[derive(Debug, Clone)]
pub struct ManualPart {
    goal: ManualGoal,
    motion: OtgMotion,
    /// Motion time of the end of the queued motion (the next handover instant), s.
    t_s: f64,
    feed_override: f64,
    /// Path position of the return move (constant; zero path velocity), for the move back to a
    /// held program's path.
    fixed_s: Option<f64>,
    /// Axes whose jog brakes to a soft limit.
    pub limit_hit: [bool; MAX_AXES],
    /// Limits hit since the last call of [`ManualPart::take_limit_reports`]: (axis, limit).
    limit_reports: Vec<(usize, f64)>,
    /// Per queued chunk (sequence number), where its tail ends.
    tail_ends: VecDeque<(u64, AxisVec)>,
    /// Motion time at which the last plan arrives (a move-to's synchronised duration).
    arrive_s: f64,
    otg: Box<Otg>,
}

impl ManualPart {
    /// Plans `goal` from rest at `pos`.
    pub fn new(
        goal: ManualGoal,
        pos: AxisVec,
        limits: &[AxisLimits],
        feed_override: f64,
        fixed_s: Option<f64>,
    ) -> Result<ManualPart, ManualPlanError> {
        let mut part = ManualPart {
            goal: goal.clone(),
            motion: OtgMotion::at_rest(pos, limits),
            t_s: 0.0,
            feed_override,
            fixed_s,
            limit_hit: [false; MAX_AXES],
            limit_reports: Vec::new(),
            tail_ends: VecDeque::new(),
            arrive_s: 0.0,
            otg: Box::new(Otg::new()),
        };
        part.plan(goal)?;
        Ok(part)
    }

    pub fn kind(&self) -> ManualKind {
        self.goal.kind()
    }

    /// The return move of a held program: `goal` is a move-to, the path position stays `s_mm`.
    pub fn is_return(&self) -> bool {
        self.fixed_s.is_some()
    }

    pub fn take_limit_reports(&mut self) -> Vec<(usize, f64)> {
        std::mem::take(&mut self.limit_reports)
    }

    /// Duration of the planned motion from the handover instant until every axis stands, s;
    /// `None` for a continuous jog.
    pub fn remaining_s(&self) -> Option<f64> {
        self.motion.end_s().map(|e| (e - self.t_s).max(0.0))
    }

    /// Duration of the motion as planned from its start until every axis stands (for a
    /// move-to arriving in motion: until it arrives), s; 0 for a continuous jog.
    pub fn planned_duration_s(&self) -> f64 {
        self.arrive_s
    }

    /// The goal again, from rest at `pos` (after an underrun): a jog by a distance continues
    /// to the targets it resolved to.
    pub fn restarted(&self, pos: AxisVec) -> Result<ManualPart, ManualPlanError> {
        ManualPart::new(self.goal.clone(), pos, self.motion.limits(), self.feed_override, self.fixed_s)
    }

    /// Where the tail of chunk `seq` ends (the machine stands there after a divert).
    pub fn tail_end(&self, seq: u64) -> Option<AxisVec> {
        self.tail_ends.iter().find(|(s, _)| *s == seq).map(|(_, p)| *p)
    }

    /// A new feed override: a continuous jog replans its velocities at the handover instant.
    pub fn set_override(&mut self, factor: f64) -> Result<(), ManualPlanError> {
        self.feed_override = factor;
        if matches!(self.goal, ManualGoal::JogVelocity { .. }) { self.plan(self.goal.clone()) } else { Ok(()) }
    }

    /// Replans for `goal` from the state at the handover instant.
    pub fn plan(&mut self, goal: ManualGoal) -> Result<(), ManualPlanError> {
        let t0 = self.t_s;
        let from = self.motion.states_at(t0);
        let limits = self.motion.limits().to_vec();
        let n = limits.len();
        let mut replanned = self.motion.clone();
        let mut goal = goal;
        match &goal {
            ManualGoal::JogVelocity { vel } => {
                for k in 0..n {
                    let v = vel[k].map_or(0.0, |v| (v * self.feed_override).clamp(-limits[k].vel, limits[k].vel));
                    let traj = one_dof(&mut self.otg, from[k], State { p: 0.0, v, a: 0.0 }, &limits[k], 1.0, true)?;
                    replanned.replan_axis(k, t0, &traj, 0);
                    self.limit_hit[k] = false;
                }
            }
            ManualGoal::JogDistance { dist } => {
                let mut target = [None; MAX_AXES];
                for k in 0..n {
                    let Some(d) = dist[k] else { continue };
                    let (lo, hi) = (limits[k].min + LIMIT_INSIDE, limits[k].max - LIMIT_INSIDE);
                    let want = from[k].p + d;
                    let p = if want > hi && d > 0.0 {
                        hi.max(from[k].p)
                    } else if want < lo && d < 0.0 {
                        lo.min(from[k].p)
                    } else {
                        want
                    };
                    if p != want {
                        self.limit_hit[k] = true;
                        self.limit_reports.push((k, if d > 0.0 { limits[k].max } else { limits[k].min }));
                    }
                    target[k] = Some(p);
                }
                // Planned (and, after an interruption, continued) as the targets it resolves to.
                goal = ManualGoal::JogTo { target };
                self.plan_jog_to(&mut replanned, &target, t0, &from)?;
            }
            ManualGoal::JogTo { target } => self.plan_jog_to(&mut replanned, target, t0, &from)?,
            ManualGoal::MoveTo { target, vel, factor } => {
                let traj = move_to(&mut self.otg, &from[..n], target, vel, &limits, *factor)?;
                let dofs: Vec<usize> = (0..n).filter(|&k| target[k].is_some()).collect();
                for k in 0..n {
                    match dofs.iter().position(|&d| d == k) {
                        Some(i) => replanned.replan_axis(k, t0, &traj, i),
                        None => {
                            let stop = one_dof(&mut self.otg, from[k], State::default(), &limits[k], 1.0, true)?;
                            replanned.replan_axis(k, t0, &stop, 0);
                        }
                    }
                }
                // Arriving in motion: each such axis then stops (unless a command follows).
                let end = t0 + traj.duration();
                self.arrive_s = end;
                for &k in &dofs {
                    if vel[k] != 0.0 {
                        let s = replanned.axis_at(k, end).0;
                        let stop = one_dof(&mut self.otg, s, State::default(), &limits[k], 1.0, true)?;
                        replanned.replan_axis(k, end, &stop, 0);
                    }
                }
                check_travel(&replanned, t0, &from[..n])?;
            }
        }
        self.motion = replanned;
        self.goal = goal;
        Ok(())
    }

    /// Each named axis on its own to its target, the others to rest.
    fn plan_jog_to(
        &mut self,
        motion: &mut OtgMotion,
        target: &[Option<f64>; MAX_AXES],
        t0: f64,
        from: &[State; MAX_AXES],
    ) -> Result<(), ManualPlanError> {
        let limits = motion.limits().to_vec();
        let factor = self.feed_override.min(1.0);
        for (k, lim) in limits.iter().enumerate() {
            let traj = match target[k] {
                Some(p) => one_dof(&mut self.otg, from[k], State { p, v: 0.0, a: 0.0 }, lim, factor, false)?,
                None => one_dof(&mut self.otg, from[k], State::default(), lim, 1.0, true)?,
            };
            motion.replan_axis(k, t0, &traj, 0);
        }
        Ok(())
    }

    /// Soft limits of a continuous jog: an axis whose stop from `tb` would cross its travel
    /// brakes from `ta` to the limit instead (see the module documentation).
    fn check_limits(&mut self, ta: f64, tb: f64) -> Result<(), ManualPlanError> {
        let limits = self.motion.limits().to_vec();
        for (k, lim) in limits.iter().enumerate() {
            if self.motion.axis_ends_at_rest(k) {
                continue;
            }
            let at_end = self.motion.axis_at(k, tb).0;
            let stop = one_dof(&mut self.otg, at_end, State::default(), lim, 1.0, true)?;
            let p_stop = stop.profiles()[0].p[7];
            let (lo, hi) = (lim.min + LIMIT_INSIDE, lim.max - LIMIT_INSIDE);
            if p_stop <= hi && p_stop >= lo {
                continue;
            }
            let up = p_stop > hi;
            let from = self.motion.axis_at(k, ta).0;
            // The cruise velocity of the jog bounds the approach to the limit.
            let cruise = self.motion.axis_at(k, f64::MAX.min(tb + 1e6)).0.v.abs().max(from.v.abs());
            let target = State { p: if up { hi } else { lo }, v: 0.0, a: 0.0 };
            let mut l = lim.otg(1.0);
            if up {
                l.v_max = cruise.min(lim.vel).max(f64::MIN_POSITIVE);
            } else {
                l.v_min = -cruise.min(lim.vel).max(f64::MIN_POSITIVE);
            }
            let mut input = Input::new(1);
            input.current[0] = from;
            input.target[0] = target;
            input.limits[0] = l;
            let mut traj = Trajectory::default();
            let approach_ok = self.otg.calculate(&input, &mut traj).is_ok() && {
                let mut probe = self.motion.clone();
                probe.replan_axis(k, ta, &traj, 0);
                let (p_lo, p_hi) = probe.extent(k, ta, ta + traj.duration(), CHECK_STEP_S);
                p_lo >= lo.min(from.p) - TRAVEL_SLACK && p_hi <= hi.max(from.p) + TRAVEL_SLACK
            };
            if !approach_ok {
                // Never expected (the stop from `ta` was checked a chunk earlier): stop now.
                tracing::warn!(axis = k, "jog: no approach to the soft limit; braking at once");
                traj = one_dof(&mut self.otg, from, State::default(), lim, 1.0, true)?;
            }
            self.motion.replan_axis(k, ta, &traj, 0);
            self.limit_hit[k] = true;
            self.limit_reports.push((k, if up { lim.max } else { lim.min }));
        }
        Ok(())
    }

    /// Fills the points and the tail of the next chunk (about `chunk_s` of motion); `true`
    /// when the motion ends at rest with it. `points` holds the chunk's start already.
    pub fn fill(
        &mut self,
        seq: u64,
        chunk_s: f64,
        cycle_s: f64,
        max_piece_s: f64,
        points: &mut Vec<CoarsePoint>,
        tail: &mut Vec<CoarsePoint>,
    ) -> Result<bool, ManualPlanError> {
        let ta = self.t_s;
        let mut tb = ta + chunk_s;
        let limits = self.motion.limits().to_vec();
        let n = limits.len();
        let (last, stop) = loop {
            self.check_limits(ta, tb)?;
            if let Some(end) = self.motion.end_s() {
                if end <= tb + END_SHARE * chunk_s {
                    tb = end.max(ta + cycle_s);
                    break (true, None);
                }
            }
            let states = self.motion.states_at(tb);
            let stop = otg_motion::brake(&mut self.otg, &states[..n], &limits)?;
            let inside = stop.as_ref().is_none_or(|t| {
                t.profiles().iter().zip(&limits).zip(&states).all(|((p, l), s)| {
                    let p = p.p[7];
                    (p >= l.min - TRAVEL_SLACK || p >= s.p) && (p <= l.max + TRAVEL_SLACK || p <= s.p)
                })
            });
            if inside {
                break (false, stop);
            }
            tb += EXTEND_SHARE * chunk_s;
        };
        self.motion.sample(ta, tb, max_piece_s, self.fixed_s, points);
        let end = points.last_mut().expect("points");
        if last {
            end.vel = [0.0; MAX_AXES];
            end.acc = [0.0; MAX_AXES];
            end.v_mm_s = 0.0;
            end.a_mm_s2 = 0.0;
        }
        let end = *end;
        let mut tail_end = end.pos;
        if let Some(stop) = stop {
            otg_motion::sample_trajectory(&stop, &end, &limits, max_piece_s, self.fixed_s, tail);
            for (k, p) in stop.profiles().iter().enumerate() {
                tail_end[k] = p.p[7];
            }
            if let Some(t) = tail.last_mut() {
                t.pos[..n].copy_from_slice(&tail_end[..n]);
            }
        }
        self.tail_ends.push_back((seq, tail_end));
        while self.tail_ends.len() > TAIL_ENDS {
            self.tail_ends.pop_front();
        }
        self.t_s = tb;
        Ok(last)
    }
}

/// One axis from `from` to `to`: the velocity interface (`velocity`: reach `to.v`) or the
/// position interface, velocity limit scaled by `factor`.
pub fn one_dof(
    otg: &mut Otg,
    from: State,
    to: State,
    lim: &AxisLimits,
    factor: f64,
    velocity: bool,
) -> Result<Trajectory, OtgError> {
    let mut input = Input::new(1);
    input.current[0] = from;
    input.target[0] = to;
    input.limits[0] = lim.otg(factor);
    input.control = if velocity { ControlInterface::Velocity } else { ControlInterface::Position };
    let mut traj = Trajectory::default();
    otg.calculate(&input, &mut traj)?;
    Ok(traj)
}

/// The move-to of the named axes (`target[k]` is `Some`), time-synchronised: one DoF per named
/// axis, in axis order.
pub fn move_to(
    otg: &mut Otg,
    from: &[State],
    target: &[Option<f64>; MAX_AXES],
    vel: &AxisVec,
    limits: &[AxisLimits],
    factor: f64,
) -> Result<Trajectory, OtgError> {
    let dofs: Vec<usize> = (0..limits.len()).filter(|&k| target[k].is_some()).collect();
    let mut input = Input::new(dofs.len());
    input.sync = Synchronization::Time;
    for (i, &k) in dofs.iter().enumerate() {
        input.current[i] = from[k];
        input.target[i] = State { p: target[k].unwrap_or_default(), v: vel[k], a: 0.0 };
        input.limits[i] = limits[k].otg(factor);
    }
    let mut traj = Trajectory::default();
    otg.calculate(&input, &mut traj)?;
    Ok(traj)
}

/// Every axis of `motion` stays inside its travel from `t0` until it stands (an axis already
/// outside may only move back in).
fn check_travel(motion: &OtgMotion, t0: f64, from: &[State]) -> Result<(), ManualPlanError> {
    let end = motion.end_s().unwrap_or(t0);
    for (k, l) in motion.limits().iter().enumerate() {
        let (lo, hi) = motion.extent(k, t0, end, CHECK_STEP_S);
        let (min, max) = (l.min.min(from[k].p), l.max.max(from[k].p));
        for pos in [lo, hi] {
            if pos < min - TRAVEL_SLACK || pos > max + TRAVEL_SLACK {
                return Err(ManualPlanError::LeavesTravel { axis: k, pos, min: l.min, max: l.max });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Vec<AxisLimits> {
        vec![AxisLimits { vel: 250.0, acc: 2500.0, jerk: 50_000.0, min: -100.0, max: 100.0, linear: true }; 2]
    }

    fn run(part: &mut ManualPart, chunks: usize) -> Vec<CoarsePoint> {
        let mut all = vec![CoarsePoint::default()];
        for seq in 0..chunks as u64 {
            let start = *all.last().unwrap();
            let mut pts = vec![CoarsePoint { t_s: 0.0, ..start }];
            let mut tail = Vec::new();
            let last = part.fill(seq, 0.032, 0.004, 0.008, &mut pts, &mut tail).unwrap();
            let t0 = start.t_s;
            all.extend(pts[1..].iter().map(|p| CoarsePoint { t_s: p.t_s + t0, ..*p }));
            if last {
                break;
            }
        }
        all
    }

    #[test]
    fn a_continuous_jog_stops_inside_the_soft_limit() {
        let mut vel = [None; MAX_AXES];
        vel[0] = Some(200.0);
        let mut part = ManualPart::new(ManualGoal::JogVelocity { vel }, [0.0; MAX_AXES], &limits(), 1.0, None).unwrap();
        let pts = run(&mut part, 200);
        let last = pts.last().unwrap();
        assert!(part.limit_hit[0]);
        let top = pts.iter().map(|p| p.pos[0]).fold(f64::MIN, f64::max);
        assert!(top <= 100.0, "overshoot to {top}");
        assert!((last.pos[0] - (100.0 - LIMIT_INSIDE)).abs() < 1e-9, "stopped at {}", last.pos[0]);
        assert!(pts.iter().all(|p| p.vel[0] <= 200.0 + 1e-9), "faster than the jog velocity");
    }

    #[test]
    fn a_jog_by_a_distance_ends_there() {
        let mut dist = [None; MAX_AXES];
        dist[1] = Some(-2.5);
        let mut part =
            ManualPart::new(ManualGoal::JogDistance { dist }, [0.0; MAX_AXES], &limits(), 1.0, None).unwrap();
        let pts = run(&mut part, 100);
        assert!((pts.last().unwrap().pos[1] + 2.5).abs() < 1e-9);
    }
}
