//! The `[prep]` configuration turned into what the stage computes with.

use crate::Settings;
use interpd_config::{AxisKind, PointDistribution, PrepMethod, QpSolver};

/// First point spacing next to a corner, in units of the corner's tolerance; the spacing then
/// doubles away from the corner up to `point_spacing_mm`.
pub(super) const CORNER_FIRST_STEP_PER_TOL: f64 = 2.0;

/// The smoothing stage's settings, in the units and forms its steps use.
#[derive(Debug, Clone)]
pub(super) struct StageSettings {
    /// Derivative levels carried per point: continuity degree + 1.
    pub levels: usize,
    /// Objective weights per level for derivatives in τ = s / point_spacing_mm, normalised to
    /// a largest weight of 1.
    pub weights_tau: Vec<f64>,
    pub segment_mm: f64,
    pub window_segments: usize,
    pub spacing_mm: f64,
    /// Equidistant points or Haas 2012's cumulative density within a block.
    pub distribution: PointDistribution,
    pub max_turn_rad: f64,
    pub corner_rad: f64,
    pub max_corner_rad: f64,
    pub band_margin: f64,
    pub max_solve_s: f64,
    /// The window QPs' solver (`prep.qp_solver`).
    pub qp_solver: QpSolver,
    pub linear: Vec<bool>,
    pub n_axes: usize,
    /// How the points become pieces (Hermite or B-spline, `prep.method`).
    pub method: PrepMethod,
    /// Hermite: levels each piece matches at its ends (continuity + 1: 3, 4 or 5).
    pub hermite_levels: usize,
    /// B-spline: inner knot multiplicity (the spline is C^(5 − m)).
    pub bspline_multiplicity: usize,
    /// B-spline: least-squares weights of x … x⁗.
    pub bspline_weights: [f64; 5],
}

impl StageSettings {
    pub(super) fn new(settings: &Settings) -> Self {
        let p = &settings.prep;
        let levels = p.continuity_degree as usize + 1;
        // A derivative of order k in σ = s/L is (L/h)^k times the one in τ = s/h.
        let ratio = p.weight_length_mm / p.point_spacing_mm;
        let all = [p.weights[0], p.weights[1], p.weights[2], p.weights[3], p.weight_d4];
        let mut weights_tau: Vec<f64> = (0..levels).map(|k| all[k] * ratio.powi(2 * k as i32)).collect();
        let max = weights_tau.iter().copied().fold(0.0, f64::max);
        weights_tau.iter_mut().for_each(|w| *w /= max);
        Self {
            levels,
            weights_tau,
            segment_mm: p.segment_mm,
            window_segments: p.window_segments,
            spacing_mm: p.point_spacing_mm,
            distribution: p.point_distribution,
            max_turn_rad: p.max_turn_deg.to_radians(),
            corner_rad: p.corner_deg.to_radians(),
            max_corner_rad: p.max_corner_deg.to_radians(),
            band_margin: p.band_margin,
            max_solve_s: p.max_solve_ms * 1e-3,
            qp_solver: p.qp_solver,
            linear: settings.axes.iter().map(|a| a.kind == AxisKind::Linear).collect(),
            n_axes: settings.axes.len(),
            method: p.method,
            hermite_levels: p.hermite_continuity as usize + 1,
            bspline_multiplicity: p.bspline_knot_multiplicity as usize,
            bspline_weights: p.bspline_weights,
        }
    }

    /// Nominal window length, mm: how far a point may slide along an unconstrained axis.
    pub(super) fn window_mm(&self) -> f64 {
        self.segment_mm * self.window_segments as f64
    }
}
