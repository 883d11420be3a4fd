//! The optional sections owned by the daemon: planner, prep, control and real-time settings.

use crate::{ConfigError, Validator};
use serde::Deserialize;

/// `[planner]`: the look-ahead feedrate planner (seed 001).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// Look-ahead horizon in mm of path. The planner hands pieces on only when this much path
    /// lies ahead of them (or the program ends).
    pub lookahead_mm: f64,
    /// Optional cap on the horizon in samples (whichever is reached first).
    pub lookahead_samples: Option<usize>,
    /// Largest distance between path samples, mm.
    pub max_step_mm: f64,
    /// Smallest distance between path samples, mm.
    pub min_step_mm: f64,
    /// Largest tangent or orientation turn between samples, degrees.
    pub max_turn_deg: f64,
    /// Largest planned time per sample interval, ms (keeps jerk switching fine on long lines).
    pub max_interval_ms: f64,
    /// Fraction of the axis limits the planner aims at; the rest is headroom for the motion
    /// between samples and rounding. 0.99 plans to 99 % of each limit.
    pub limit_fraction: f64,
    /// Feed for G0 rapid moves, mm/s; the axis limits cap it. Unset: the axis limits alone.
    pub rapid_feed_mm_s: Option<f64>,
    /// At a curvature jump (G¹ joint without G², e.g. line into arc) the axis acceleration
    /// steps by ΔA″·v². The speed there is capped so the step is what the jerk limit moves in
    /// this time, ms. The default keeps sampled jerk within the limit down to 0.1 ms sampling;
    /// smoothing (G64) removes the jump instead.
    pub curvature_jump_ms: f64,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            lookahead_mm: 500.0,
            lookahead_samples: None,
            max_step_mm: 2.0,
            min_step_mm: 1e-4,
            max_turn_deg: 2.0,
            max_interval_ms: 2.0,
            limit_fraction: 0.995,
            rapid_feed_mm_s: None,
            curvature_jump_ms: 0.002,
        }
    }
}

impl PlannerConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.positive("planner.lookahead_mm", self.lookahead_mm)?;
        if let Some(n) = self.lookahead_samples {
            if n < 16 {
                return Err(v.err("planner.lookahead_samples", &format!("must be ≥ 16, got {n}")));
            }
        }
        v.positive("planner.max_step_mm", self.max_step_mm)?;
        v.positive("planner.min_step_mm", self.min_step_mm)?;
        if self.min_step_mm > self.max_step_mm {
            return Err(v.err("planner.min_step_mm", "must not exceed planner.max_step_mm"));
        }
        v.in_range("planner.max_turn_deg", self.max_turn_deg, 0.01, 30.0)?;
        v.in_range("planner.max_interval_ms", self.max_interval_ms, 0.1, 1000.0)?;
        v.in_range("planner.limit_fraction", self.limit_fraction, 0.5, 1.0)?;
        v.in_range("planner.curvature_jump_ms", self.curvature_jump_ms, 0.0, 100.0)?;
        if let Some(f) = self.rapid_feed_mm_s {
            v.positive("planner.rapid_feed_mm_s", f)?;
        }
        Ok(())
    }
}

/// How corners and polylines are prepared before planning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PrepMode {
    /// Exact path (G61): corners are passed with v = a = 0.
    Exact,
    /// Tolerance-band smoothing (G64): corners and polylines are smoothed within the tolerance.
    Smooth,
}

/// `[prep]`: path preparation (tolerance-band smoothing, seed 000).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PrepConfig {
    /// Mode at program start; G61 / G64 switch it within a program.
    pub mode: PrepMode,
    /// Lateral tolerance for G64 without P, mm.
    pub tolerance_mm: f64,
}

impl Default for PrepConfig {
    fn default() -> Self {
        Self { mode: PrepMode::Exact, tolerance_mm: 0.01 }
    }
}

impl PrepConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        v.in_range("prep.tolerance_mm", self.tolerance_mm, 1e-6, 10.0)
    }
}

/// `[control]`: the JSON-RPC control socket.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ControlConfig {
    /// Path of the Unix socket. Unset: `$XDG_RUNTIME_DIR/interpd.sock`, else `/tmp/interpd.sock`.
    pub socket: Option<String>,
    /// Stop the motion when the client that started it disconnects.
    pub stop_on_disconnect: bool,
}

impl ControlConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        if let Some(s) = &self.socket {
            if s.is_empty() {
                return Err(v.err("control.socket", "must not be empty"));
            }
        }
        Ok(())
    }

    /// The socket path to use.
    pub fn socket_path(&self) -> String {
        if let Some(s) = &self.socket {
            return s.clone();
        }
        match std::env::var("XDG_RUNTIME_DIR") {
            Ok(dir) if !dir.is_empty() => format!("{dir}/interpd.sock"),
            _ => "/tmp/interpd.sock".to_string(),
        }
    }
}

/// `[rt]`: scheduling of the interpolation thread.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RtConfig {
    /// SCHED_FIFO priority (1–99) when permitted; 0 keeps the normal scheduler.
    pub priority: i32,
    /// CPU to pin the interpolation thread to; unset: the last CPU.
    pub cpu: Option<usize>,
    /// Lock all memory (mlockall) when permitted.
    pub lock_memory: bool,
}

impl Default for RtConfig {
    fn default() -> Self {
        Self { priority: 80, cpu: None, lock_memory: true }
    }
}

impl RtConfig {
    pub(crate) fn validate(&self, v: &Validator) -> Result<(), ConfigError> {
        if !(0..=99).contains(&self.priority) {
            return Err(v.err("rt.priority", &format!("must lie in 0..=99, got {}", self.priority)));
        }
        Ok(())
    }
}
