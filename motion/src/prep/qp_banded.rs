//! The window QP of `qp.rs` solved by a primal-dual interior-point method that uses its
//! structure: a diagonal objective (Haas 2012, eq. 3.9), equality rows that couple only
//! neighbouring points (the trapezoid rule, eq. 3.11) and bounds on single positions (the
//! band, eq. 3.12). With the variables and rows ordered point by point, the KKT matrix of every
//! Newton step is banded (half-bandwidth about twice the levels per point), so one step costs
//! O(n·b²) for n points instead of a general sparse factorisation.
//!
//! - **Fixed ends** (the left state, the right position or join) are eliminated: their values
//!   move to the right-hand side of the rows that use them.
//! - **Step** (Mehrotra's predictor-corrector, as in Clarabel and most IPM codes): an affine
//!   direction, the centring σ = (μ_aff / μ)³, and a corrector with the second-order term, both
//!   from one LDLᵀ factorisation of
//!   ```text
//!   [ P + W + ρI   Eᵀ ]      W = diag(λ_u/s_u + λ_l/s_l) on the banded positions
//!   [ E           −δI ]
//!   ```
//!   (quasi-definite through the static regularisation ρ, δ, 1e-10 relative: far below the
//!   solve tolerance, so, as Clarabel in `qp.rs`, without iterative refinement).
//! - **Stop** when the equality and dual residuals and the complementarity gap are below
//!   `SOLVER_TOL` relative to the data, as `qp.rs` asks of Clarabel. A window this method does
//!   not solve within `MAX_ITER` steps (an infeasible band, a degenerate window) is handed to
//!   Clarabel by the caller, which also tells infeasible from numerically hard.

use super::qp_shape::{SOLVER_TOL, Shape, a_entries, quadrature_weight};
use std::time::Instant;

/// How a solve ended without a solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Unsolved {
    /// Not within `MAX_ITER` steps, the equality residual stalled, or a pivot vanished: the
    /// caller hands the window to Clarabel.
    Declined,
    /// The time limit (`prep.max_solve_ms`) ran out, as Clarabel's `MaxTime`.
    Slow,
}

/// Newton steps before the window is handed to Clarabel; a well-posed window needs 6–12.
const MAX_ITER: u32 = 30;
/// Steps over which the equality residual must at least halve, else the window (nearly
/// infeasible: the iterates reach the band's edges before the rows hold) goes to Clarabel.
const STALL_STEPS: u32 = 8;
/// Static regularisation of the primal and dual diagonal blocks, relative to the largest
/// diagonal entry of the objective.
const REG_PRIMAL: f64 = 1e-10;
const REG_DUAL: f64 = 1e-10;
/// Fraction of the way to the boundary a step may go.
const STEP_TO_BOUNDARY: f64 = 0.99;

/// A symmetric matrix of half-bandwidth `b`, factorised in place as L D Lᵀ without pivoting
/// (quasi-definite: the regularisation keeps every pivot away from zero with a known sign).
struct BandedLdl {
    n: usize,
    b: usize,
    /// Row i holds entries (i, i − d) for d = 0..=b at `i * (b + 1) + d`; after `factor` the
    /// diagonal holds D and the rest L.
    band: Vec<f64>,
}

impl BandedLdl {
    fn new(n: usize, b: usize) -> Self {
        Self { n, b, band: vec![0.0; n * (b + 1)] }
    }

    fn clear(&mut self) {
        self.band.iter_mut().for_each(|v| *v = 0.0);
    }

    fn at(&mut self, i: usize, j: usize) -> &mut f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= self.b);
        &mut self.band[i * (self.b + 1) + (i - j)]
    }

    /// False if a pivot vanishes (or is not finite).
    fn factor(&mut self) -> bool {
        let w = self.b + 1;
        for i in 0..self.n {
            let j0 = i.saturating_sub(self.b);
            for j in j0..i {
                // L(i, j) D_j = A(i, j) − Σ_{k<j} L(i, k) D_k L(j, k)
                let mut s = self.band[i * w + (i - j)];
                for k in j0.max(j.saturating_sub(self.b))..j {
                    s -= self.band[i * w + (i - k)] * self.band[k * w] * self.band[j * w + (j - k)];
                }
                self.band[i * w + (i - j)] = s / self.band[j * w];
            }
            let mut d = self.band[i * w];
            for k in j0..i {
                let l = self.band[i * w + (i - k)];
                d -= l * l * self.band[k * w];
            }
            if !d.is_finite() || d == 0.0 {
                return false;
            }
            self.band[i * w] = d;
        }
        true
    }

    fn solve(&self, x: &mut [f64]) {
        let w = self.b + 1;
        // L y = x (unit lower), row by row over the band left of the diagonal.
        for i in 0..self.n {
            let j0 = i.saturating_sub(self.b);
            let row = &self.band[i * w..i * w + w];
            let s: f64 = (j0..i).map(|k| row[i - k] * x[k]).sum();
            x[i] -= s;
        }
        for (xi, d) in x.iter_mut().zip(self.band.iter().step_by(w)) {
            *xi /= d;
        }
        // Lᵀ z = y, column by column: x[k] for k < i gets L(i, k) x[i] taken off.
        for i in (0..self.n).rev() {
            let xi = x[i];
            let j0 = i.saturating_sub(self.b);
            let row = &self.band[i * w..i * w + w];
            for k in j0..i {
                x[k] -= row[i - k] * xi;
            }
        }
    }
}

/// One equality row over the free variables: its KKT index and (KKT index of the variable,
/// coefficient) per term; the fixed variables' share goes to the right-hand side per solve.
#[derive(Debug, Clone, Default)]
struct Row {
    kkt: usize,
    terms: Vec<(usize, f64)>,
}

/// The window QP of one shape, for the banded interior-point method.
pub(super) struct BandedQp {
    shape: Shape,
    /// KKT index of variable j·levels + k, or `None` where it is fixed.
    var_kkt: Vec<Option<usize>>,
    rows: Vec<Row>,
    /// Per trapezoid row, the (variable, coefficient) pairs in the original numbering.
    coupling: Vec<Vec<(usize, f64)>>,
    /// Variables with a band: (variable, index of its band in the right-hand side).
    banded: Vec<(usize, usize)>,
    p: Vec<f64>,
    ldl: BandedLdl,
    pub solution: Vec<f64>,
    pub iterations: u32,
}

impl BandedQp {
    pub(super) fn new(shape: Shape) -> Self {
        let (n, l) = (shape.n_points, shape.levels);
        let fixed = |v: usize| {
            let (j, k) = (v / l, v % l);
            (j == 0 && k < shape.left_fixed) || (j == n - 1 && k < shape.right_fixed)
        };
        let mut var_kkt = vec![None; n * l];
        let mut rows = Vec::with_capacity((n - 1) * (l - 1));
        let mut next = 0;
        for j in 0..n {
            for k in 0..l {
                if !fixed(j * l + k) {
                    var_kkt[j * l + k] = Some(next);
                    next += 1;
                }
            }
            if j + 1 < n {
                for _ in 0..l - 1 {
                    rows.push(Row { kkt: next, terms: Vec::new() });
                    next += 1;
                }
            }
        }
        let banded = shape.bounded().enumerate().map(|(i, j)| (j * l, i)).collect();
        let mut qp = Self {
            shape,
            var_kkt,
            rows,
            coupling: Vec::new(),
            banded,
            p: vec![0.0; n * l],
            ldl: BandedLdl::new(next, 0),
            solution: vec![0.0; n * l],
            iterations: 0,
        };
        qp.load(&vec![1.0; n - 1], &vec![1.0; l]);
        let b = qp.rows.iter().flat_map(|r| r.terms.iter().map(move |&(v, _)| r.kkt.abs_diff(v))).max().unwrap_or(0);
        qp.ldl = BandedLdl::new(next, b);
        qp
    }

    /// The spacings Δ_j (in τ) and the objective weights per level, as `WindowQp::load`.
    pub(super) fn load(&mut self, deltas: &[f64], weights: &[f64]) {
        let s = self.shape;
        let (n, l) = (s.n_points, s.levels);
        for j in 0..n {
            let q = quadrature_weight(deltas, j);
            for k in 0..l {
                self.p[j * l + k] = q * weights[k];
            }
        }
        // The trapezoid rows of the QP (eq. 3.11 with its Euler–Maclaurin correction), grouped
        // by row.
        let (idx, val) = a_entries(&s, deltas);
        self.coupling.clear();
        self.coupling.resize_with(s.n_trapezoid(), Vec::new);
        for (&(row, col), &v) in idx.iter().zip(&val) {
            if row < s.n_trapezoid() {
                self.coupling[row].push((col, v));
            }
        }
        for (row, t) in self.rows.iter_mut().zip(&self.coupling) {
            row.terms = t.iter().filter_map(|&(v, c)| self.var_kkt[v].map(|i| (i, c))).collect();
        }
    }

    /// Solves with linear term `q` and right-hand side `b` laid out as `Shape::rhs` (zeros for
    /// the trapezoid rows, the fixed values, then (upper, −lower) per banded point), within
    /// `time_limit_s`.
    pub(super) fn solve(&mut self, q: &[f64], b: &[f64], time_limit_s: f64) -> Result<(), Unsolved> {
        let t0 = Instant::now();
        let s = self.shape;
        let (n, l) = (s.n_points, s.levels);
        let n_trap = s.n_eq() - s.left_fixed - s.right_fixed;
        // Fixed values into the solution; their share of each row to its right-hand side.
        let mut x_full = vec![0.0; n * l];
        x_full[..s.left_fixed].copy_from_slice(&b[n_trap..n_trap + s.left_fixed]);
        for k in 0..s.right_fixed {
            x_full[(n - 1) * l + k] = b[n_trap + s.left_fixed + k];
        }
        let e: Vec<f64> = self
            .coupling
            .iter()
            .map(|t| -t.iter().filter(|&&(v, _)| self.var_kkt[v].is_none()).map(|&(v, c)| c * x_full[v]).sum::<f64>())
            .collect();
        let n_kkt = self.ldl.n;
        let bands: Vec<(f64, f64)> =
            (0..self.banded.len()).map(|i| (-b[s.n_eq() + 2 * i + 1], b[s.n_eq() + 2 * i])).collect();
        // Free variables by KKT index.
        let free: Vec<usize> = (0..n * l).filter(|&v| self.var_kkt[v].is_some()).collect();
        let kv = |v: usize| self.var_kkt[v].expect("free");
        let p_max = self.p.iter().copied().fold(0.0, f64::max).max(1e-300);
        let rho = REG_PRIMAL * p_max;
        let delta = REG_DUAL;
        let scale_e = 1.0 + e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let scale_q = 1.0 + free.iter().fold(0.0f64, |m, &v| m.max(q[v].abs()));

        // Start: positions mid-band, derivatives 0; slacks and duals from the band widths.
        let mut x = vec![0.0; n_kkt];
        for (i, &(v, _)) in self.banded.iter().enumerate() {
            x[kv(v)] = 0.5 * (bands[i].0 + bands[i].1);
        }
        let m = self.banded.len();
        let mut su: Vec<f64> = (0..m).map(|i| (0.5 * (bands[i].1 - bands[i].0)).max(1e-12)).collect();
        let mut sl = su.clone();
        let mut lu: Vec<f64> = su.iter().map(|_| 1.0).collect();
        let mut ll = lu.clone();
        let mut y = vec![0.0; self.rows.len()];
        let mut rhs = vec![0.0; n_kkt];
        let mut sol = vec![0.0; n_kkt];
        let mut w = vec![0.0; n_kkt];
        let mut best_re = (f64::INFINITY, 0u32);
        for it in 0..MAX_ITER {
            if t0.elapsed().as_secs_f64() > time_limit_s {
                return Err(Unsolved::Slow);
            }
            // Residuals: r_d = P x + q + Eᵀ y + (λ_u − λ_l) on the banded, r_e = E x − e,
            // r_u = x + s_u − u, r_l = −x + s_l + l.
            let mut rd = vec![0.0; n_kkt];
            for &v in &free {
                rd[kv(v)] = self.p[v] * x[kv(v)] + q[v];
            }
            let mut re = vec![0.0; self.rows.len()];
            for (ri, row) in self.rows.iter().enumerate() {
                let mut acc = -e[ri];
                for &(i, c) in &row.terms {
                    acc += c * x[i];
                    rd[i] += c * y[ri];
                }
                re[ri] = acc;
            }
            let (mut ru, mut rl) = (vec![0.0; m], vec![0.0; m]);
            for (i, &(v, _)) in self.banded.iter().enumerate() {
                let xi = x[kv(v)];
                rd[kv(v)] += lu[i] - ll[i];
                ru[i] = xi + su[i] - bands[i].1;
                rl[i] = -xi + sl[i] + bands[i].0;
            }
            let gap: f64 = (0..m).map(|i| su[i] * lu[i] + sl[i] * ll[i]).sum();
            let mu = gap / (2 * m).max(1) as f64;
            let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let obj: f64 = free.iter().map(|&v| 0.5 * self.p[v] * x[kv(v)] * x[kv(v)] + q[v] * x[kv(v)]).sum();
            let re_norm = norm(&re);
            if re_norm < 0.5 * best_re.0 {
                best_re = (re_norm, it);
            } else if it - best_re.1 >= STALL_STEPS && re_norm > SOLVER_TOL * scale_e {
                return Err(Unsolved::Declined);
            }
            if re_norm <= SOLVER_TOL * scale_e
                && norm(&ru).max(norm(&rl)) <= SOLVER_TOL * scale_e
                && free.iter().all(|&v| rd[kv(v)].abs() <= SOLVER_TOL * scale_q)
                && gap <= SOLVER_TOL * (1.0 + obj.abs())
            {
                self.iterations = it;
                for (v, &k) in self.var_kkt.iter().enumerate() {
                    if let Some(k) = k {
                        x_full[v] = x[k];
                    }
                }
                if !x_full.iter().all(|v| v.is_finite()) {
                    return Err(Unsolved::Declined);
                }
                self.solution.copy_from_slice(&x_full);
                return Ok(());
            }
            // The KKT matrix of this step.
            self.ldl.clear();
            w.iter_mut().for_each(|v| *v = 0.0);
            for &v in &free {
                w[kv(v)] = self.p[v];
            }
            for (i, &(v, _)) in self.banded.iter().enumerate() {
                w[kv(v)] += lu[i] / su[i] + ll[i] / sl[i];
            }
            for &v in &free {
                *self.ldl.at(kv(v), kv(v)) = w[kv(v)] + rho;
            }
            for row in &self.rows {
                *self.ldl.at(row.kkt, row.kkt) = -delta;
                for &(i, c) in &row.terms {
                    *self.ldl.at(row.kkt, i) += c;
                }
            }
            if !self.ldl.factor() {
                return Err(Unsolved::Declined);
            }
            // One Newton direction for the complementarity target (cu, cl): Λ Δs + S Δλ = c.
            let mut direction = |cu: &[f64], cl: &[f64], dx: &mut Vec<f64>| {
                rhs.iter_mut().for_each(|v| *v = 0.0);
                for &v in &free {
                    rhs[kv(v)] = -rd[kv(v)];
                }
                for (ri, row) in self.rows.iter().enumerate() {
                    rhs[row.kkt] = -re[ri];
                }
                for (i, &(v, _)) in self.banded.iter().enumerate() {
                    // Δλ_u = (c_u + λ_u (r_u + Δx)) / s_u, Δλ_l = (c_l + λ_l (r_l − Δx)) / s_l.
                    rhs[kv(v)] -= (cu[i] + lu[i] * ru[i]) / su[i] - (cl[i] + ll[i] * rl[i]) / sl[i];
                }
                sol.copy_from_slice(&rhs);
                self.ldl.solve(&mut sol);
                dx.clear();
                dx.extend_from_slice(&sol);
            };
            let step_of = |dx: &[f64], cu: &[f64], cl: &[f64]| {
                // Δs and Δλ from Δx, and the largest step that keeps s, λ > 0.
                let mut ds = Vec::with_capacity(2 * m);
                let mut alpha = 1.0f64;
                for (i, &(v, _)) in self.banded.iter().enumerate() {
                    let d = dx[kv(v)];
                    let dsu = -ru[i] - d;
                    let dsl = -rl[i] + d;
                    let dlu = (cu[i] - lu[i] * dsu) / su[i];
                    let dll = (cl[i] - ll[i] * dsl) / sl[i];
                    for (val, dv) in [(su[i], dsu), (sl[i], dsl), (lu[i], dlu), (ll[i], dll)] {
                        if dv < 0.0 {
                            alpha = alpha.min(-val / dv);
                        }
                    }
                    ds.push((dsu, dsl, dlu, dll));
                }
                (ds, alpha)
            };
            // Predictor.
            let cu0: Vec<f64> = (0..m).map(|i| -su[i] * lu[i]).collect();
            let cl0: Vec<f64> = (0..m).map(|i| -sl[i] * ll[i]).collect();
            let mut dx = Vec::with_capacity(n_kkt);
            direction(&cu0, &cl0, &mut dx);
            let (ds_aff, a_aff) = step_of(&dx, &cu0, &cl0);
            let mu_aff: f64 = (0..m)
                .map(|i| {
                    let (dsu, dsl, dlu, dll) = ds_aff[i];
                    (su[i] + a_aff * dsu) * (lu[i] + a_aff * dlu) + (sl[i] + a_aff * dsl) * (ll[i] + a_aff * dll)
                })
                .sum::<f64>()
                / (2 * m).max(1) as f64;
            let sigma = if mu > 0.0 { (mu_aff / mu).powi(3).min(1.0) } else { 0.0 };
            // Corrector: centring and the second-order term.
            let cu: Vec<f64> = (0..m).map(|i| cu0[i] - ds_aff[i].0 * ds_aff[i].2 + sigma * mu).collect();
            let cl: Vec<f64> = (0..m).map(|i| cl0[i] - ds_aff[i].1 * ds_aff[i].3 + sigma * mu).collect();
            direction(&cu, &cl, &mut dx);
            let (ds, alpha) = step_of(&dx, &cu, &cl);
            self.iterations = it + 1;
            let a = (STEP_TO_BOUNDARY * alpha).min(1.0);
            for (xi, d) in x.iter_mut().zip(&dx) {
                *xi += a * d;
            }
            for (ri, row) in self.rows.iter().enumerate() {
                y[ri] += a * dx[row.kkt];
            }
            for i in 0..m {
                let (dsu, dsl, dlu, dll) = ds[i];
                su[i] += a * dsu;
                sl[i] += a * dsl;
                lu[i] += a * dlu;
                ll[i] += a * dll;
            }
        }
        Err(Unsolved::Declined)
    }
}

#[cfg(test)]
mod tests {
    use super::super::qp::WindowQp;
    use super::super::qp_shape::{Rhs, Shape};
    use super::*;

    /// A small deterministic generator (the tests must not depend on a crate's random stream).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Windows like the stage's: a curved path sampled at uneven spacings, a narrow band, the
    /// left state fixed, the right end by position, band or join; both solvers agree.
    #[test]
    fn agrees_with_clarabel_on_random_windows() {
        let mut rng = Lcg(7);
        let mut worst = 0.0f64;
        let mut missed = 0;
        let mut steps = Vec::new();
        for case in 0..60 {
            let levels = [3, 4, 5][case % 3];
            let n = 5 + (rng.next() * 60.0) as usize;
            let right_fixed = [0, 1, 3.min(levels)][(case / 3) % 3];
            let shape = Shape { n_points: n, levels, left_fixed: levels, right_fixed };
            let deltas: Vec<f64> = (0..n - 1).map(|_| 0.3 + rng.next()).collect();
            let weights: Vec<f64> = [0.0, 1e-2, 1e-4, 1e-6, 1e-8][..levels].iter().map(|w| w * 2500.0).collect();
            let tol = 0.001 + 0.02 * rng.next();
            // Programmed positions: a curve in τ with a kink somewhere.
            let kink = rng.next() * n as f64;
            let mut t = 0.0;
            let mut path = vec![0.0];
            for d in &deltas {
                t += d;
                path.push(0.7 * t + if t > kink { 0.4 * (t - kink) } else { 0.0 } + 0.05 * (t * 0.9).sin());
            }
            let bands: Vec<(f64, f64)> = shape.bounded().map(|j| (path[j] - tol, path[j] + tol)).collect();
            let mut left = vec![0.0; levels];
            left[1] = 0.7 + 0.05 * 0.9;
            let right: Vec<f64> = (0..right_fixed)
                .map(|k| {
                    if k == 0 {
                        path[n - 1]
                    } else if k == 1 {
                        1.1
                    } else {
                        0.0
                    }
                })
                .collect();
            let mut b = Vec::new();
            shape.rhs(&Rhs { left: &left, right: &right, bands: &bands }, &mut b);
            let q = vec![0.0; shape.n_vars()];
            let mut reference = WindowQp::new(shape, f64::INFINITY, false);
            reference.load(&deltas, &weights);
            let want = reference.solve(&q, &b).map(|_| reference.solution.clone());
            let mut qp = BandedQp::new(shape);
            qp.load(&deltas, &weights);
            let got = qp.solve(&q, &b, f64::INFINITY).ok().map(|_| qp.solution.clone());
            steps.push((qp.iterations, reference.iterations));
            match (want, got) {
                (Ok(w), Some(g)) => {
                    // Positions within the band, and the two solutions as close as the
                    // solvers' tolerance makes them.
                    for (i, j) in shape.bounded().enumerate() {
                        let x = g[j * levels];
                        assert!(
                            x >= bands[i].0 - 1e-7 && x <= bands[i].1 + 1e-7,
                            "case {case}: x_{j} = {x} outside {:?}",
                            bands[i]
                        );
                    }
                    // Both meet the trapezoid rows and reach the same objective (the positions
                    // themselves may differ along directions the objective hardly sees).
                    let obj = |z: &[f64]| {
                        let mut p = vec![0.0; n];
                        for j in 0..n {
                            p[j] =
                                0.5 * (if j > 0 { deltas[j - 1] } else { 0.0 } + deltas.get(j).copied().unwrap_or(0.0));
                        }
                        (0..n)
                            .flat_map(|j| (0..levels).map(move |k| (j, k)))
                            .map(|(j, k)| 0.5 * p[j] * weights[k] * z[j * levels + k].powi(2))
                            .sum::<f64>()
                    };
                    for j in 0..n - 1 {
                        for k in 0..levels - 1 {
                            let z = |jj: usize, kk: usize| g[jj * levels + kk];
                            let mut res = z(j + 1, k) - z(j, k) - 0.5 * deltas[j] * (z(j, k + 1) + z(j + 1, k + 1));
                            if k + 2 < levels {
                                res += deltas[j] * deltas[j] / 12.0 * (z(j + 1, k + 2) - z(j, k + 2));
                            }
                            assert!(res.abs() < 1e-5, "case {case}: trapezoid residual {res:e}");
                        }
                    }
                    let (ow, og) = (obj(&w), obj(&g));
                    let rel = (og - ow) / ow.abs().max(1e-12);
                    worst = worst.max(rel.abs());
                    assert!(
                        rel < 1e-4,
                        "case {case} (n {n}, levels {levels}, right {right_fixed}): objective {og:e} against {ow:e}"
                    );
                }
                (Err(_), None) => {}
                (Ok(_), None) => {
                    // Declined: the caller hands the window to Clarabel.
                    eprintln!(
                        "case {case} (n {n}, levels {levels}, right {right_fixed}, tol {tol}): declined after {} steps",
                        qp.iterations
                    );
                    missed += 1;
                }
                (Err(_), Some(_)) => panic!("case {case}: solved a window Clarabel finds infeasible"),
            }
        }
        eprintln!("largest relative objective difference: {worst:e}; steps (banded, clarabel): {steps:?}");
        assert!(missed <= 3, "{missed} of 60 windows declined");
    }

    #[test]
    fn conflicting_ends_are_not_solved() {
        let shape = Shape { n_points: 2, levels: 3, left_fixed: 3, right_fixed: 2 };
        let mut qp = BandedQp::new(shape);
        qp.load(&[1.0], &[0.0, 1.0, 1.0]);
        let mut b = Vec::new();
        shape.rhs(&Rhs { left: &[0.0, 0.0, 0.0], right: &[1.0, 0.0], bands: &[] }, &mut b);
        assert_eq!(qp.solve(&[0.0; 6], &b, f64::INFINITY), Err(Unsolved::Declined));
        assert_eq!(qp.solve(&[0.0; 6], &b, 0.0), Err(Unsolved::Slow));
    }
}
