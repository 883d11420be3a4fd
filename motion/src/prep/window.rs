//! One window of the QP: the points from the committed node on, their bands and the end
//! conditions turned into one solve per moving axis (Haas 2012, §3.6.3, windowing III).

use super::band;
use super::points::Point;
use super::qp::{QpFailure, WindowQp};
use super::qp_shape::{Rhs, SOLVER_TOL, Shape};
use super::settings::StageSettings;
use crate::path::MAX_AXES;
use std::collections::HashMap;

/// Position and derivatives per axis in τ = s / point_spacing_mm (level 0 = position; levels
/// beyond the continuity degree stay 0, x⁗ is carried for the B-spline method).
pub(super) type State = [[f64; STATE_LEVELS]; MAX_AXES];
/// Levels a state holds: x … x⁗ (continuity degree 4).
pub(super) const STATE_LEVELS: usize = 5;

/// How the window ends.
// The join state is copied once per run end; boxing it would cost more than it saves.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum RightEnd {
    /// The last point is held at its programmed position, derivatives free (Haas 2012, §3.6.1:
    /// position only is best).
    Position,
    /// The last point only keeps its band (the looser end of the fallback).
    Band,
    /// The run ends where a programmed element continues tangentially: position and the
    /// first two derivatives are fixed to it, so the joint stays C².
    Join(State),
}

/// What one window solve needs.
pub(super) struct WindowInput<'a> {
    pub points: &'a [Point],
    /// State of the committed node (`points[0]`); its first `left_levels` levels are fixed.
    pub left: &'a State,
    pub left_levels: usize,
    pub right: RightEnd,
    /// Band factor per point (1 = full band; the check after the solve lowers it).
    pub shrink: &'a [f64],
}

/// Positions may slide this many window lengths along an unconstrained axis (a finite stand-in
/// for "no bound", which the solver needs).
const FREE_BAND_WINDOWS: f64 = 1.0;
/// A window is solved in its own scale where its mean spacing is below this share of
/// `point_spacing_mm` (above, the scale changes too little to matter).
const RESCALE_BELOW: f64 = 0.5;
/// An axis whose points differ by less than this over a window does not move there, mm.
const STILL_AXIS_MM: f64 = 1e-12;

/// The solvers, one per window shape, reused across windows.
#[derive(Default)]
pub(super) struct Solvers {
    by_shape: HashMap<Shape, WindowQp>,
    q: Vec<f64>,
    b: Vec<f64>,
    bands: Vec<(f64, f64)>,
    deltas: Vec<f64>,
    /// Axis solves the banded method declined and Clarabel took, in all.
    pub declined: u64,
    /// Axis solves re-done with iterative refinement, in all.
    pub refined_steps: u64,
    /// Windows solved in a parameter scaled to their own spacing, in all.
    pub rescaled: u64,
}

/// The window's solution per point.
#[derive(Debug, Clone, Default)]
pub(super) struct Solution {
    pub states: Vec<State>,
    /// Solver iterations summed over the axes.
    pub iterations: u32,
}

impl Solvers {
    /// Solves the window in τ = s / point_spacing_mm, or, where its points crowd (corners and
    /// U-turns approached at 2 tol spacing), in a parameter scaled to its own spacing: in τ
    /// such a window's entries spread over many orders (Δ² / 12 against 1) and Clarabel needs
    /// ~130 iterations per axis on the CAM family's raster U-turns instead of ~15. Where the
    /// solve fails numerically in one parameter, it is tried in the other.
    pub(super) fn solve(&mut self, st: &StageSettings, w: &WindowInput<'_>) -> Result<Solution, QpFailure> {
        let n = w.points.len();
        // Geometric mean of the spacings in τ: the scale that centres the coupling's entries Δ
        // and Δ² around 1.
        let log_sum: f64 = w.points.windows(2).map(|p| ((p[1].s_mm - p[0].s_mm) / st.spacing_mm).ln()).sum();
        let c = (log_sum / (n - 1).max(1) as f64).exp();
        // Scaled, the weights of the low derivatives shrink by c²ˡ against the highest; below
        // the solver's tolerance they would no longer shape the solution (on loops below the
        // tolerance, c ≈ 0.02, the motion took up to 47 % longer), so such windows start in τ.
        let own = c < RESCALE_BELOW && scaled_weights(&st.weights_tau, c).iter().all(|&w| w == 0.0 || w >= SOLVER_TOL);
        if own {
            self.rescaled += 1;
        }
        match self.solve_scaled(st, w, if own { c } else { 1.0 }) {
            Err(QpFailure::Numerical) => {
                tracing::debug!(scale = c, points = n, own, "window QP re-solved in the other parameter");
                self.solve_scaled(st, w, if own { 1.0 } else { c })
            }
            r => r,
        }
    }

    /// The window solved in τ' = τ / `c`: derivatives of order l scale by cˡ, the weights by
    /// c⁻²ˡ (renormalised); the solution comes back in τ.
    fn solve_scaled(&mut self, st: &StageSettings, w: &WindowInput<'_>, c: f64) -> Result<Solution, QpFailure> {
        let pts = w.points;
        let n = pts.len();
        let right_fixed = match w.right {
            RightEnd::Position => 1,
            RightEnd::Band => 0,
            RightEnd::Join(_) => 3.min(st.levels),
        };
        let shape = Shape { n_points: n, levels: st.levels, left_fixed: w.left_levels, right_fixed };
        let time_limit = st.max_solve_s;
        let banded = st.qp_solver == interpd_config::QpSolver::Banded;
        let qp = self.by_shape.entry(shape).or_insert_with(|| WindowQp::new(shape, time_limit, banded));
        self.deltas.clear();
        self.deltas.extend(pts.windows(2).map(|p| (p[1].s_mm - p[0].s_mm) / (st.spacing_mm * c)));
        let weights = scaled_weights(&st.weights_tau, c);
        // Level l of a state in τ' is cˡ times that in τ.
        let to_scaled = |l: usize| c.powi(l as i32);
        qp.load(&self.deltas, &weights);

        let active = active_axes(st, w);
        let origin = pts[0].pos;
        let free = FREE_BAND_WINDOWS * st.window_mm();
        // (below, above) the programmed position per axis. An axis along which the path runs
        // exactly (Haas 2012, Alg. 3.2: NaN wins) slides along the path, but only as far as
        // the path stays that straight line, at most a spacing (`Point::straight_mm`): beyond,
        // the point would leave the path (a plunge along Z slid back past the corner it came
        // round).
        let halfwidths: Vec<[(f64, f64); MAX_AXES]> = shape
            .bounded()
            .map(|j| {
                let p = &pts[j];
                let b = band::split(&p.tangent, &active, p.tol_mm);
                std::array::from_fn(|k| {
                    if b[k].is_finite() {
                        let h = b[k] * (1.0 - st.band_margin) * w.shrink[j];
                        (h, h)
                    } else {
                        let (back, ahead) = p.straight_mm;
                        let (minus, plus) = if p.tangent[k] >= 0.0 { (back, ahead) } else { (ahead, back) };
                        (minus.min(free) * p.tangent[k].abs(), plus.min(free) * p.tangent[k].abs())
                    }
                })
            })
            .collect();
        let mut sol = Solution { states: vec![[[0.0; STATE_LEVELS]; MAX_AXES]; n], iterations: 0 };
        for k in 0..MAX_AXES {
            if !active[k] {
                // A still axis stays where it is.
                for s in sol.states.iter_mut() {
                    s[k][0] = origin[k];
                }
                continue;
            }
            let left: Vec<f64> =
                (0..st.levels).map(|l| (w.left[k][l] - if l == 0 { origin[k] } else { 0.0 }) * to_scaled(l)).collect();
            let right: Vec<f64> = match &w.right {
                RightEnd::Position => vec![pts[n - 1].pos[k] - origin[k]],
                RightEnd::Band => Vec::new(),
                RightEnd::Join(s) => {
                    (0..right_fixed).map(|l| (s[k][l] - if l == 0 { origin[k] } else { 0.0 }) * to_scaled(l)).collect()
                }
            };
            self.bands.clear();
            for (i, j) in shape.bounded().enumerate() {
                let c = pts[j].pos[k] - origin[k];
                self.bands.push((c - halfwidths[i][k].0, c + halfwidths[i][k].1));
            }
            shape.rhs(&Rhs { left: &left, right: &right, bands: &self.bands }, &mut self.b);
            self.q.clear();
            self.q.resize(shape.n_vars(), 0.0);
            if weights[0] > 0.0 {
                // Position weight: ½w₀q_j(z − x_j)² pulls towards the programmed point.
                for j in 0..n {
                    let qj = 0.5
                        * (self.deltas.get(j.wrapping_sub(1)).copied().unwrap_or(0.0)
                            + self.deltas.get(j).copied().unwrap_or(0.0));
                    self.q[j * st.levels] = -weights[0] * qj * (pts[j].pos[k] - origin[k]);
                }
            }
            let (declined, retried) = (qp.declined, qp.retried);
            let solved = qp.solve(&self.q, &self.b);
            self.declined += qp.declined - declined;
            self.refined_steps += qp.retried - retried;
            solved?;
            sol.iterations += qp.iterations;
            for (j, s) in sol.states.iter_mut().enumerate() {
                for l in 0..st.levels {
                    s[k][l] = qp.solution[j * st.levels + l] / to_scaled(l) + if l == 0 { origin[k] } else { 0.0 };
                }
            }
        }
        // The fixed values exactly as given, so windows and programmed elements join exactly.
        for k in 0..MAX_AXES {
            for l in 0..w.left_levels {
                sol.states[0][k][l] = w.left[k][l];
            }
            match &w.right {
                RightEnd::Position => sol.states[n - 1][k][0] = pts[n - 1].pos[k],
                RightEnd::Join(s) => {
                    for l in 0..right_fixed {
                        sol.states[n - 1][k][l] = s[k][l];
                    }
                }
                RightEnd::Band => {}
            }
        }
        Ok(sol)
    }
}

/// The weights per level in τ / `c`, normalised to a largest weight of 1.
fn scaled_weights(weights_tau: &[f64], c: f64) -> Vec<f64> {
    let w: Vec<f64> = weights_tau.iter().enumerate().map(|(l, w)| w * c.powi(-2 * l as i32)).collect();
    let top = w.iter().copied().fold(0.0, f64::max);
    w.iter().map(|x| x / top).collect()
}

/// Linear axes that move in the window (or whose fixed end derivatives are not zero).
fn active_axes(st: &StageSettings, w: &WindowInput<'_>) -> [bool; MAX_AXES] {
    let mut active = [false; MAX_AXES];
    for k in 0..st.n_axes {
        if !st.linear[k] {
            continue;
        }
        let x0 = w.points[0].pos[k];
        let moves =
            w.points.iter().any(|p| (p.pos[k] - x0).abs() > STILL_AXIS_MM) || (w.left[k][0] - x0).abs() > STILL_AXIS_MM;
        let left_d = (1..w.left_levels).any(|l| w.left[k][l] != 0.0);
        let right_d = matches!(&w.right, RightEnd::Join(s) if (1..3).any(|l| s[k][l] != 0.0));
        active[k] = moves || left_d || right_d;
    }
    active
}
