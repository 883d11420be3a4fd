//! The evidence a setpoint stream gives, checked one setpoint at a time so that an hour of
//! recording needs no more memory than a second of it: cycle numbers without gaps, the axis
//! limits by finite differences, underrun and late cycles. Fed from a live subscriber or from
//! an MCAP recording ([`check_recording`]).

use crate::daemon::AxisLimits;
use interpd::record::schema::Payload;
use interpd::record::{RecordError, read_messages};
use interpd_protocol::shm::{Setpoints, flags};
use std::path::Path;

/// Accepted ratio of velocity and acceleration to their limits by finite differences: the
/// planner keeps them exactly, the quintic between coarse points adds rounding only.
pub const VEL_ACC_TOLERANCE: f64 = 1.001;
/// Accepted ratio of jerk to its limit: the quintic between coarse points may exceed the
/// planned jerk by up to 0.5 % (the coarse tolerance), and a third difference at 4 ms samples
/// it with a little more.
pub const JERK_TOLERANCE: f64 = 1.02;
/// Share of the limit by which a reported velocity or acceleration may differ from the central
/// difference of the positions beyond what the difference itself misses (j·dt²/6 and j·dt/3
/// at a jerk reversal): rounding and the quintic's jerk tolerance.
pub const AGREEMENT_MARGIN: f64 = 0.02;
/// Gaps kept by place for the report; more are only counted.
const GAPS_KEPT: usize = 10;

/// Running evidence over a setpoint stream.
#[derive(Debug, Clone)]
pub struct StreamCheck {
    limits: Vec<AxisLimits>,
    dt_s: f64,
    window: Vec<Setpoints>,
    /// Setpoints seen.
    pub count: u64,
    /// First and last cycle number seen.
    pub first_cycle: Option<u64>,
    pub last_cycle: u64,
    /// Places where cycle numbers jump (previous, next), the first [`GAPS_KEPT`].
    pub gaps: Vec<(u64, u64)>,
    /// Cycles missing or out of order in all.
    pub missing: u64,
    /// Cycles flagged UNDERRUN, and how many underruns began (a cycle flagged after one not).
    pub underrun_cycles: u64,
    pub underruns: u64,
    /// The first cycle of each underrun, the first [`GAPS_KEPT`].
    pub underrun_starts: Vec<u64>,
    /// Cycles flagged LATE.
    pub late_cycles: u64,
    /// Largest |value|/limit: velocity, acceleration, jerk by finite differences, and the
    /// reported acceleration; with the cycle where each occurred.
    pub ratios: [f64; 4],
    pub worst_cycle: [u64; 4],
    /// Largest disagreement of the reported velocity and acceleration with the central
    /// differences of the positions, as a share of what is allowed (≤ 1 passes; see
    /// [`AGREEMENT_MARGIN`]), with the cycle: a drive may use them as feed-forward.
    pub agreement: [f64; 2],
    pub agreement_cycle: [u64; 2],
    last_flags: u32,
}

impl StreamCheck {
    pub fn new(limits: Vec<AxisLimits>, dt_s: f64) -> StreamCheck {
        StreamCheck {
            limits,
            dt_s,
            window: Vec::with_capacity(4),
            count: 0,
            first_cycle: None,
            last_cycle: 0,
            gaps: Vec::new(),
            missing: 0,
            underrun_cycles: 0,
            underruns: 0,
            underrun_starts: Vec::new(),
            late_cycles: 0,
            ratios: [0.0; 4],
            worst_cycle: [0; 4],
            agreement: [0.0; 2],
            agreement_cycle: [0; 2],
            last_flags: 0,
        }
    }

    /// Takes the next setpoint of the stream.
    pub fn push(&mut self, sp: &Setpoints) {
        if self.first_cycle.is_some() && sp.cycle != self.last_cycle + 1 {
            if self.gaps.len() < GAPS_KEPT {
                self.gaps.push((self.last_cycle, sp.cycle));
            }
            self.missing += sp.cycle.saturating_sub(self.last_cycle + 1).max(1);
            // Differences across a gap say nothing about the motion.
            self.window.clear();
        }
        self.first_cycle.get_or_insert(sp.cycle);
        self.last_cycle = sp.cycle;
        self.count += 1;
        if sp.flags & flags::UNDERRUN != 0 {
            self.underrun_cycles += 1;
            if self.last_flags & flags::UNDERRUN == 0 {
                self.underruns += 1;
                if self.underrun_starts.len() < GAPS_KEPT {
                    self.underrun_starts.push(sp.cycle);
                }
            }
        }
        if sp.flags & flags::LATE != 0 {
            self.late_cycles += 1;
        }
        self.last_flags = sp.flags;
        if self.window.len() == 4 {
            self.window.remove(0);
        }
        self.window.push(*sp);
        for k in 0..self.limits.len() {
            let ratio = sp.acc[k].abs() / self.limits[k].acc;
            self.note(3, ratio, sp.cycle);
        }
        if self.window.len() >= 3 {
            let dt = self.dt_s;
            let n = self.window.len();
            let (before, mid, after) = (&self.window[n - 3], &self.window[n - 2], &self.window[n - 1]);
            for k in 0..self.limits.len() {
                let lim = self.limits[k];
                let v = (after.pos[k] - before.pos[k]) / (2.0 * dt);
                let a = (after.pos[k] - 2.0 * mid.pos[k] + before.pos[k]) / (dt * dt);
                let v_allowed = lim.jerk * dt * dt / 6.0 + AGREEMENT_MARGIN * lim.vel;
                let a_allowed = lim.jerk * dt / 3.0 + AGREEMENT_MARGIN * lim.acc;
                for (i, r) in
                    [(mid.vel[k] - v).abs() / v_allowed, (mid.acc[k] - a).abs() / a_allowed].into_iter().enumerate()
                {
                    if r > self.agreement[i] || r.is_nan() {
                        self.agreement[i] = r;
                        self.agreement_cycle[i] = mid.cycle;
                    }
                }
            }
        }
        if self.window.len() == 4 {
            let dt = self.dt_s;
            for k in 0..self.limits.len() {
                let lim = self.limits[k];
                let p = [self.window[0].pos[k], self.window[1].pos[k], self.window[2].pos[k], self.window[3].pos[k]];
                let v = (p[3] - p[2]) / dt;
                let a = (p[3] - 2.0 * p[2] + p[1]) / (dt * dt);
                let j = (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]) / (dt * dt * dt);
                self.note(0, v.abs() / lim.vel, sp.cycle);
                self.note(1, a.abs() / lim.acc, sp.cycle);
                self.note(2, j.abs() / lim.jerk, sp.cycle);
            }
        }
    }

    fn note(&mut self, i: usize, ratio: f64, cycle: u64) {
        if ratio > self.ratios[i] || ratio.is_nan() {
            self.ratios[i] = ratio;
            self.worst_cycle[i] = cycle;
        }
    }

    /// Whether every ratio is within [`VEL_ACC_TOLERANCE`] / [`JERK_TOLERANCE`].
    pub fn limits_kept(&self) -> bool {
        let [v, a, j, r] = self.ratios;
        v <= VEL_ACC_TOLERANCE && a <= VEL_ACC_TOLERANCE && j <= JERK_TOLERANCE && r <= VEL_ACC_TOLERANCE
    }

    /// What is wrong with the stream: limit violations and cycle gaps (underruns and late
    /// cycles are for the caller to judge).
    pub fn violations(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.limits_kept() {
            out.push(format!(
                "limit ratios vel {:.4} acc {:.4} jerk {:.4} reported acc {:.4} (at cycles {:?})",
                self.ratios[0], self.ratios[1], self.ratios[2], self.ratios[3], self.worst_cycle
            ));
        }
        if !(self.agreement[0] <= 1.0 && self.agreement[1] <= 1.0) {
            out.push(format!(
                "reported velocity and acceleration disagree with the positions: {:.3} and {:.3} of the allowed (at \
                 cycles {:?})",
                self.agreement[0], self.agreement[1], self.agreement_cycle
            ));
        }
        if self.missing > 0 {
            out.push(format!("{} cycles missing, first gaps (previous, next) {:?}", self.missing, self.gaps));
        }
        out
    }
}

/// What a recording holds beside its setpoints.
#[derive(Debug, Clone)]
pub struct RecordingCheck {
    pub setpoints: StreamCheck,
    pub feedback: u64,
    /// The error that ended the reading (a file cut short), if any.
    pub error: Option<String>,
}

/// Reads the MCAP recording at `path` message by message into a [`StreamCheck`]; a reading
/// error ends it and is kept (everything before it is still counted).
pub fn check_recording(path: &Path, limits: Vec<AxisLimits>, dt_s: f64) -> Result<RecordingCheck, RecordError> {
    let mut out = RecordingCheck { setpoints: StreamCheck::new(limits, dt_s), feedback: 0, error: None };
    for m in read_messages(path)? {
        match m {
            Ok(r) => match r.payload {
                Payload::Setpoints(sp) => out.setpoints.push(&sp),
                Payload::Feedback(_) => out.feedback += 1,
            },
            Err(e) => {
                out.error = Some(e.to_string());
                break;
            }
        }
    }
    Ok(out)
}
