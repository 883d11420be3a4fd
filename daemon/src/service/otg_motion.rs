//! Per-axis OTG trajectories (interpd-otg) as coarse points: the form in which manual motion
//! (jog, move-to) and the return move before a resumed program reach the real-time thread.
//!
//! Each axis follows a sequence of pieces, each a DoF of an OTG [`Trajectory`] from a start
//! time on; a replan appends a piece from the state at the handover instant, so position,
//! velocity and acceleration stay continuous. Within a piece every axis moves with piecewise
//! constant jerk, and the coarse points sit at every phase switch of every axis: the quintic
//! between two neighbours (stage 2, [`crate::interp::hermite`]) then reproduces the trajectory
//! exactly. Every piece is still checked at interior points against the exact trajectory,
//! position and jerk, as [`crate::interp::coarse`] does for planned paths.
//!
//! The OTG runs here, in the planner thread (and in the control thread for validation), never
//! in the real-time cycle.

use crate::interp::coarse::{CoarsePoint, JERK_TOLERANCE, TOLERANCE_MM};
use crate::interp::hermite::{self, Kinematic};
use interpd_motion::path::{AxisVec, MAX_AXES};
use interpd_otg::{ControlInterface, Input, Limits, Otg, OtgError, State, Synchronization, Trajectory};

/// Phase switches closer than this are one coarse point, s: the jerk step between them moves
/// a position by less than j·dt³ ≈ 5e-14 mm at 50 m/s³.
const MERGE_S: f64 = 1e-6;
/// Pieces shorter than this are checked for position only (a merged switch may sit inside), s.
const MIN_JERK_CHECK_S: f64 = 2.5e-4;
/// Interior check points per piece.
const CHECKS: usize = 3;
/// Bisections of one piece before it is accepted as it is.
const MAX_SPLITS: usize = 16;
/// Below this speed (unit/s) the direction of motion is undefined: path acceleration 0.
const STANDSTILL_SPEED: f64 = 1e-12;
/// An OTG profile ending with |v| and |a| below this share of the axis limits ends at rest:
/// a synchronised profile's end state is integrated, and lands within rounding of zero.
const AT_REST_REL: f64 = 1e-9;

/// One axis's motion from `t0_s` on (motion time): DoF `dof` of `traj`.
#[derive(Debug, Clone, Copy)]
struct Piece {
    t0_s: f64,
    traj: Trajectory,
    dof: usize,
}

/// The kinematic limits of one axis (axis units per s, s², s³) and its travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimits {
    pub vel: f64,
    pub acc: f64,
    pub jerk: f64,
    pub min: f64,
    pub max: f64,
    /// A linear axis (its speed counts into the path velocity).
    pub linear: bool,
}

impl AxisLimits {
    /// The OTG limits, velocity scaled by `factor`.
    pub fn otg(&self, factor: f64) -> Limits {
        Limits::symmetric(self.vel * factor, self.acc, self.jerk)
    }
}

/// Per-axis OTG motion, sampled on demand.
#[derive(Debug, Clone)]
pub struct OtgMotion {
    n: usize,
    /// Where each axis stands before its first piece.
    rest: AxisVec,
    pieces: Vec<Vec<Piece>>,
    limits: Vec<AxisLimits>,
}

impl OtgMotion {
    /// All axes at rest at `pos`.
    pub fn at_rest(pos: AxisVec, limits: &[AxisLimits]) -> OtgMotion {
        let n = limits.len();
        OtgMotion { n, rest: pos, pieces: vec![Vec::new(); n], limits: limits.to_vec() }
    }

    pub fn limits(&self) -> &[AxisLimits] {
        &self.limits
    }

    /// State and jerk of axis `k` at motion time `t_s`.
    pub fn axis_at(&self, k: usize, t_s: f64) -> (State, f64) {
        match self.pieces[k].iter().rev().find(|p| p.t0_s <= t_s) {
            Some(p) => p.traj.state_of(p.dof, t_s - p.t0_s),
            None => (State { p: self.rest[k], v: 0.0, a: 0.0 }, 0.0),
        }
    }

    /// The state of every axis at `t_s`.
    pub fn states_at(&self, t_s: f64) -> [State; MAX_AXES] {
        let mut out = [State::default(); MAX_AXES];
        for (k, s) in out.iter_mut().enumerate().take(self.n) {
            *s = self.axis_at(k, t_s).0;
        }
        out
    }

    /// From `t0_s` on, axis `k` follows DoF `dof` of `traj` (later pieces are dropped).
    pub fn replan_axis(&mut self, k: usize, t0_s: f64, traj: &Trajectory, dof: usize) {
        self.pieces[k].retain(|p| p.t0_s < t0_s);
        self.pieces[k].push(Piece { t0_s, traj: *traj, dof });
    }

    /// When every axis stands for good (all pieces end at rest), motion time; `None` while an
    /// axis cruises or ends moving.
    pub fn end_s(&self) -> Option<f64> {
        let mut end: f64 = 0.0;
        for k in 0..self.n {
            if !self.axis_ends_at_rest(k) {
                return None;
            }
            if let Some(p) = self.pieces[k].last() {
                end = end.max(p.t0_s + p.traj.duration());
            }
        }
        Some(end)
    }

    /// Whether axis `k` ends at rest (its last piece is not a cruise or a move ending in motion).
    pub fn axis_ends_at_rest(&self, k: usize) -> bool {
        let l = &self.limits[k];
        self.pieces[k].last().is_none_or(|p| {
            let (s, _) = p.traj.state_of(p.dof, p.traj.duration());
            s.v.abs() <= AT_REST_REL * l.vel && s.a.abs() <= AT_REST_REL * l.acc
        })
    }

    /// Phase switch times of every axis inside (ta, tb), appended to `out`.
    fn switch_times(&self, ta: f64, tb: f64, out: &mut Vec<f64>) {
        for axis in &self.pieces {
            for (i, p) in axis.iter().enumerate() {
                let until = axis.get(i + 1).map_or(f64::INFINITY, |n| n.t0_s);
                let prof = &p.traj.profiles()[p.dof];
                let mut push = |t: f64| {
                    let at = p.t0_s + t;
                    if at > ta && at < tb && at < until {
                        out.push(at);
                    }
                };
                push(0.0);
                push(prof.brake.t[0]);
                push(prof.brake.duration);
                for &s in &prof.t_sum {
                    push(prof.brake.duration + s);
                }
                push(p.traj.duration());
            }
        }
    }

    /// The coarse point at motion time `t_s`, stamped `stamp_s`, with path position `s_mm`.
    fn point(&self, t_s: f64, stamp_s: f64, s_mm: f64, line: u32) -> CoarsePoint {
        let mut p = CoarsePoint { t_s: stamp_s, s_mm, line, ..CoarsePoint::default() };
        for k in 0..self.n {
            let (st, _) = self.axis_at(k, t_s);
            p.pos[k] = st.p;
            p.vel[k] = st.v;
            p.acc[k] = st.a;
        }
        let (v, a) = path_rate(&self.limits, &p.vel, &p.acc);
        p.v_mm_s = v;
        p.a_mm_s2 = a;
        p
    }

    /// Appends the coarse points of motion time (ta, tb] to `out`, whose last point is the
    /// motion at `ta` (its `t_s` the stamp of `ta`). Path position: integrated speed, or
    /// `fixed_s` with zero path velocity (the return move before a program resumes).
    pub fn sample(&self, ta: f64, tb: f64, max_piece_s: f64, fixed_s: Option<f64>, out: &mut Vec<CoarsePoint>) {
        let base = *out.last().expect("a start point");
        let stamp0 = base.t_s - ta;
        let mut breaks = Vec::new();
        self.switch_times(ta, tb, &mut breaks);
        breaks.push(tb);
        breaks.sort_by(f64::total_cmp);
        let mut t = ta;
        for &b in &breaks {
            if b <= t || (b - t < MERGE_S && b < tb) {
                continue;
            }
            let steps = ((b - t) / max_piece_s).ceil().max(1.0);
            let h = (b - t) / steps;
            for i in 1..=steps as usize {
                let t1 = if i == steps as usize { b } else { t + h * i as f64 };
                self.push_checked(out.last().expect("a point").t_s - stamp0, t1, stamp0, fixed_s, 0, out);
            }
            t = b;
        }
    }

    /// Pushes the point at `t1`, bisecting the piece from the last point while the quintic
    /// misses the exact motion.
    fn push_checked(
        &self,
        t0: f64,
        t1: f64,
        stamp0: f64,
        fixed_s: Option<f64>,
        depth: usize,
        out: &mut Vec<CoarsePoint>,
    ) {
        let start = *out.last().expect("a point");
        let s1 = match fixed_s {
            Some(s) => s,
            None => start.s_mm + self.distance(t0, t1),
        };
        let mut end = self.point(t1, t1 + stamp0, s1, start.line);
        if fixed_s.is_some() {
            end.v_mm_s = 0.0;
            end.a_mm_s2 = 0.0;
        }
        if depth >= MAX_SPLITS || self.fits(t0, t1, &start, &end) {
            out.push(end);
            return;
        }
        let mid = 0.5 * (t0 + t1);
        self.push_checked(t0, mid, stamp0, fixed_s, depth + 1, out);
        self.push_checked(mid, t1, stamp0, fixed_s, depth + 1, out);
    }

    /// The quintic from `start` to `end` follows the exact motion on [t0, t1].
    fn fits(&self, t0: f64, t1: f64, start: &CoarsePoint, end: &CoarsePoint) -> bool {
        let h = t1 - t0;
        (1..=CHECKS).all(|c| {
            let tau = h * c as f64 / (CHECKS + 1) as f64;
            (0..self.n).all(|k| {
                let (exact, j) = self.axis_at(k, t0 + tau);
                let (k0, k1) = (start.axis(k), end.axis(k));
                let pos_ok = (hermite::eval(k0, k1, h, tau).p - exact.p).abs() <= TOLERANCE_MM;
                let jerk_ok = h <= MIN_JERK_CHECK_S
                    || (hermite::jerk(k0, k1, h, tau) - j).abs() <= JERK_TOLERANCE * self.limits[k].jerk;
                pos_ok && jerk_ok
            })
        })
    }

    /// Distance travelled on [t0, t1] (Simpson's rule on the speed of [`path_rate`]).
    fn distance(&self, t0: f64, t1: f64) -> f64 {
        let speed = |t: f64| {
            let mut vel = [0.0; MAX_AXES];
            let acc = [0.0; MAX_AXES];
            for (k, v) in vel.iter_mut().enumerate().take(self.n) {
                *v = self.axis_at(k, t).0.v;
            }
            path_rate(&self.limits, &vel, &acc).0
        };
        (t1 - t0) / 6.0 * (speed(t0) + 4.0 * speed(0.5 * (t0 + t1)) + speed(t1))
    }

    /// Largest and smallest position of axis `k` on [ta, tb], sampled every `step_s` and at
    /// the ends (the brake and approach profiles are monotone between samples this close).
    pub fn extent(&self, k: usize, ta: f64, tb: f64, step_s: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut t = ta;
        loop {
            let p = self.axis_at(k, t.min(tb)).0.p;
            lo = lo.min(p);
            hi = hi.max(p);
            if t >= tb {
                return (lo, hi);
            }
            t += step_s;
        }
    }
}

/// Path velocity and acceleration of a manual motion: the speed over the linear axes (over all
/// axes when none is linear) and its rate of change.
pub fn path_rate(limits: &[AxisLimits], vel: &AxisVec, acc: &AxisVec) -> (f64, f64) {
    let any_linear = limits.iter().any(|l| l.linear);
    let (mut vv, mut va) = (0.0, 0.0);
    for (k, l) in limits.iter().enumerate() {
        if l.linear || !any_linear {
            vv += vel[k] * vel[k];
            va += vel[k] * acc[k];
        }
    }
    let v = vv.sqrt();
    if v > STANDSTILL_SPEED { (v, va / v) } else { (0.0, 0.0) }
}

/// The fastest stop of every axis from `from` (each in its own minimum time): the tail of a
/// manual motion's chunk. `None` when every axis stands already.
pub fn brake(otg: &mut Otg, from: &[State], limits: &[AxisLimits]) -> Result<Option<Trajectory>, OtgError> {
    if from.iter().all(|s| s.v == 0.0 && s.a == 0.0) {
        return Ok(None);
    }
    let mut input = Input::new(from.len());
    input.control = ControlInterface::Velocity;
    input.sync = Synchronization::None;
    for (k, l) in limits.iter().enumerate() {
        input.current[k] = from[k];
        input.limits[k] = l.otg(1.0);
    }
    let mut traj = Trajectory::default();
    otg.calculate(&input, &mut traj)?;
    Ok(Some(traj))
}

/// Samples a whole trajectory (all DoFs from time 0) as coarse points after `start`.
pub fn sample_trajectory(
    traj: &Trajectory,
    start: &CoarsePoint,
    limits: &[AxisLimits],
    max_piece_s: f64,
    fixed_s: Option<f64>,
    out: &mut Vec<CoarsePoint>,
) {
    let mut m = OtgMotion::at_rest(start.pos, limits);
    for k in 0..limits.len() {
        m.replan_axis(k, 0.0, traj, k);
    }
    out.push(CoarsePoint { t_s: 0.0, ..*start });
    m.sample(0.0, traj.duration(), max_piece_s, fixed_s, out);
    if let Some(last) = out.last_mut() {
        // The end stands still: exactly, not to the integration's rounding.
        last.vel = [0.0; MAX_AXES];
        last.acc = [0.0; MAX_AXES];
        last.v_mm_s = 0.0;
        last.a_mm_s2 = 0.0;
    }
}

/// A kinematic triple of a state (for tests and checks).
pub fn kinematic(s: &State) -> Kinematic {
    Kinematic { p: s.p, v: s.v, a: s.a }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> Vec<AxisLimits> {
        vec![
            AxisLimits { vel: 250.0, acc: 2500.0, jerk: 50_000.0, min: -1000.0, max: 1000.0, linear: true },
            AxisLimits { vel: 200.0, acc: 2000.0, jerk: 40_000.0, min: -500.0, max: 500.0, linear: true },
        ]
    }

    #[test]
    fn coarse_points_reproduce_the_trajectory() {
        let limits = lim();
        let mut input = Input::new(2);
        input.target[0] = State { p: 30.0, v: 0.0, a: 0.0 };
        input.target[1] = State { p: -7.0, v: 0.0, a: 0.0 };
        for (k, l) in limits.iter().enumerate() {
            input.limits[k] = l.otg(1.0);
        }
        let mut traj = Trajectory::default();
        Otg::new().calculate(&input, &mut traj).unwrap();
        let mut m = OtgMotion::at_rest([0.0; MAX_AXES], &limits);
        m.replan_axis(0, 0.0, &traj, 0);
        m.replan_axis(1, 0.0, &traj, 1);
        let mut pts = vec![CoarsePoint::default()];
        m.sample(0.0, traj.duration(), 0.008, None, &mut pts);
        let mut worst: f64 = 0.0;
        let mut t: f64 = 0.0;
        let mut i = 0;
        while t < traj.duration() {
            while pts[i + 1].t_s < t {
                i += 1;
            }
            let (a, b) = (&pts[i], &pts[i + 1]);
            for k in 0..2 {
                let q = hermite::eval(a.axis(k), b.axis(k), b.t_s - a.t_s, t - a.t_s);
                worst = worst.max((q.p - m.axis_at(k, t).0.p).abs());
            }
            t += 1e-4;
        }
        assert!(worst < 1e-9, "quintic off the trajectory by {worst} mm");
        let last = pts.last().unwrap();
        assert!((last.pos[0] - 30.0).abs() < 1e-8 && (last.pos[1] + 7.0).abs() < 1e-8);
        // The path position is the distance travelled (a straight line here up to the timing).
        assert!(last.s_mm > 30.5 && last.s_mm < 31.5, "{}", last.s_mm);
        assert_eq!(m.end_s(), Some(traj.duration()));
    }
}
