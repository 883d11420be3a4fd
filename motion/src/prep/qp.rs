//! The per-axis QP of one window (Haas 2012, §3.3, eq. 3.8–3.12) as a sparse problem for
//! Clarabel: min ½zᵀPz + qᵀz s.t. A z + s = b, s ∈ {0}ᵐ¹ × ℝ₊ᵐ².
//!
//! z holds, per point j, the position and its derivatives z_{j,0} … z_{j,r} with respect to the
//! normalised path parameter τ = s / h (h = `prep.point_spacing_mm`, so the entries are of
//! order one). Equality rows: the trapezoid coupling between neighbouring points at every
//! level, with its Euler–Maclaurin end correction where the level two above exists (plain
//! trapezoid data are consistent with a smooth curve only to O(Δ³), and the quintic pieces
//! turn that error into a sawtooth in A‴ that the planner must crawl through), then the fixed
//! values at the left and right end. Inequality rows: the band of every
//! point whose position is not fixed.
//!
//! The sparsity patterns of one window shape (point count, levels, fixed ends) are built once
//! and reused: later windows only refill the values (the spacing of the points), and the axes
//! of one window share one solver (P, A, its scaling and its symbolic factorisation) and
//! change only q and b.

use super::qp_banded::{BandedQp, Unsolved};
use super::qp_shape::{SOLVER_TOL, Shape, a_entries, quadrature_weight};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

/// Why a window solve gave no usable result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum QpFailure {
    Infeasible,
    /// Stopped by the time limit (`prep.max_solve_ms`).
    Slow,
    /// Iteration limit, numerical trouble or a solver set-up error.
    Numerical,
}

/// Iteration cap of one solve; a well-posed window needs 10–30.
const MAX_ITER: u32 = 200;

/// Entries generated in a fixed order (repeats allowed, they add up) and where each lands in
/// the CSC storage.
struct Pattern {
    rows: usize,
    cols: usize,
    colptr: Vec<usize>,
    rowval: Vec<usize>,
    /// `slot[i]` = stored position of the i-th generated entry.
    slot: Vec<usize>,
}

impl Pattern {
    fn new(rows: usize, cols: usize, entries: &[(usize, usize)]) -> Self {
        let mut order: Vec<usize> = (0..entries.len()).collect();
        order.sort_by_key(|&i| (entries[i].1, entries[i].0));
        let mut colptr = vec![0; cols + 1];
        let mut rowval = Vec::with_capacity(entries.len());
        let mut slot = vec![0; entries.len()];
        let mut last = None;
        for &i in &order {
            let (r, c) = entries[i];
            if last != Some((r, c)) {
                rowval.push(r);
                colptr[c + 1] += 1;
                last = Some((r, c));
            }
            slot[i] = rowval.len() - 1;
        }
        for c in 0..cols {
            colptr[c + 1] += colptr[c];
        }
        Self { rows, cols, colptr, rowval, slot }
    }

    fn values(&self, generated: &[f64]) -> Vec<f64> {
        let mut v = vec![0.0; self.rowval.len()];
        for (i, g) in generated.iter().enumerate() {
            v[self.slot[i]] += g;
        }
        v
    }

    fn matrix(&self, generated: &[f64]) -> CscMatrix<f64> {
        CscMatrix::new(self.rows, self.cols, self.colptr.clone(), self.rowval.clone(), self.values(generated))
    }
}

/// A reusable solver for one window shape.
pub(super) struct WindowQp {
    shape: Shape,
    p_pattern: Pattern,
    a_pattern: Pattern,
    p_gen: Vec<f64>,
    a_gen: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
    time_limit_s: f64,
    solver: Option<DefaultSolver<f64>>,
    /// Solves re-done with refined steps, since the solver was made.
    pub retried: u64,
    /// The banded interior-point method, tried first where `prep.qp_solver` is "banded".
    banded: Option<BandedQp>,
    pub solution: Vec<f64>,
    pub iterations: u32,
    /// Solves the banded method declined and Clarabel took, since the solver was made.
    pub declined: u64,
}

impl WindowQp {
    pub(super) fn new(shape: Shape, time_limit_s: f64, banded: bool) -> Self {
        let (a_entries, _) = a_entries(&shape, &vec![1.0; shape.n_points - 1]);
        let n = shape.n_vars();
        let p_entries: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        Self {
            p_pattern: Pattern::new(n, n, &p_entries),
            a_pattern: Pattern::new(shape.n_rows(), n, &a_entries),
            p_gen: vec![0.0; p_entries.len()],
            a_gen: Vec::new(),
            cones: vec![
                SupportedConeT::ZeroConeT(shape.n_eq()),
                SupportedConeT::NonnegativeConeT(2 * shape.bounded().len()),
            ],
            time_limit_s,
            solver: None,
            retried: 0,
            banded: banded.then(|| BandedQp::new(shape)),
            shape,
            solution: vec![0.0; n],
            iterations: 0,
            declined: 0,
        }
    }

    /// Sets the spacing Δ_j (in τ) between the points and the objective weights per level
    /// (already scaled to τ): P = diag(q_j·w_k) with the trapezoid quadrature weight q_j
    /// (Haas 2012, eq. 3.9: H = blockdiag(diag(w_x, w_x′, …))).
    pub(super) fn load(&mut self, deltas: &[f64], weights: &[f64]) {
        debug_assert_eq!(deltas.len(), self.shape.n_points - 1);
        let s = self.shape;
        for j in 0..s.n_points {
            let q = quadrature_weight(deltas, j);
            for k in 0..s.levels {
                self.p_gen[s.var(j, k)] = q * weights[k];
            }
        }
        self.a_gen = a_entries(&s, deltas).1;
        if let Some(b) = &mut self.banded {
            b.load(deltas, weights);
        }
        // A new window gets a new solver: its equilibration is computed for these values (a
        // window through a corner scales nothing like one on a straight line). The axes of the
        // window share it and change only q and b.
        self.solver = None;
    }

    /// Solves with linear term `q` and right-hand side `b`; the solution is in `self.solution`.
    pub(super) fn solve(&mut self, q: &[f64], b: &[f64]) -> Result<(), QpFailure> {
        if let Some(banded) = &mut self.banded {
            match banded.solve(q, b, self.time_limit_s) {
                Ok(()) => {
                    self.solution.copy_from_slice(&banded.solution);
                    self.iterations = banded.iterations;
                    return Ok(());
                }
                Err(Unsolved::Slow) => return Err(QpFailure::Slow),
                Err(Unsolved::Declined) => self.declined += 1,
            }
        }
        if self.solver.is_none() {
            self.solver = Some(self.new_solver(q, b, settings(self.time_limit_s))?);
        }
        let solver = self.solver.as_mut().expect("created above");
        solver.update_q(&q.to_vec()).map_err(|_| QpFailure::Numerical)?;
        solver.update_b(&b.to_vec()).map_err(|_| QpFailure::Numerical)?;
        solver.solve();
        self.iterations = solver.info.iterations;
        let status = solver.solution.status;
        if !matches!(
            status,
            SolverStatus::InsufficientProgress | SolverStatus::NumericalError | SolverStatus::MaxIterations
        ) {
            return outcome(solver, &mut self.solution);
        }
        // The fast settings lost their way: on windows whose points crowd into a corner (spacing
        // 2 tol against a largest of a millimetre) the KKT systems are too ill-conditioned for
        // unrefined steps. The same problem once more with iterative refinement.
        tracing::debug!(?status, iterations = self.iterations, "window QP re-solved with refined steps");
        let mut robust = self.new_solver(q, b, robust_settings(self.time_limit_s))?;
        robust.solve();
        self.iterations += robust.info.iterations;
        self.retried += 1;
        outcome(&robust, &mut self.solution)
    }

    fn new_solver(
        &self,
        q: &[f64],
        b: &[f64],
        settings: DefaultSettings<f64>,
    ) -> Result<DefaultSolver<f64>, QpFailure> {
        let p = self.p_pattern.matrix(&self.p_gen);
        let a = self.a_pattern.matrix(&self.a_gen);
        DefaultSolver::new(&p, q, &a, b, &self.cones, settings).map_err(|_| QpFailure::Numerical)
    }
}

/// The outcome of `solver`'s last solve; its solution into `solution` where it solved.
fn outcome(solver: &DefaultSolver<f64>, solution: &mut [f64]) -> Result<(), QpFailure> {
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            solution.copy_from_slice(&solver.solution.x);
            if solution.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(QpFailure::Numerical) }
        }
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => Err(QpFailure::Infeasible),
        SolverStatus::MaxTime => Err(QpFailure::Slow),
        s => {
            tracing::debug!(status = ?s, iterations = solver.info.iterations, "window QP not solved");
            Err(QpFailure::Numerical)
        }
    }
}

/// The settings of the re-solve after the fast settings made no progress.
fn robust_settings(time_limit_s: f64) -> DefaultSettings<f64> {
    DefaultSettings { iterative_refinement_enable: true, ..settings(time_limit_s) }
}

fn settings(time_limit_s: f64) -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        // Data updates need the problem as given: no presolve, no dropped structural zeros.
        presolve_enable: false,
        input_sparse_dropzeros: false,
        max_iter: MAX_ITER,
        time_limit: time_limit_s,
        // Positions to ~1e-7 of the window's scale are far inside the micrometre budget; each
        // further digit costs IPM iterations, and refinement steps cost back-solves (the check
        // after the solve catches a solution that is off).
        tol_gap_abs: SOLVER_TOL,
        tol_gap_rel: SOLVER_TOL,
        tol_feas: SOLVER_TOL,
        iterative_refinement_enable: false,
        ..DefaultSettings::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::qp_shape::Rhs;
    use super::*;

    #[test]
    fn unconstrained_chain_is_a_straight_ramp() {
        // 11 points, position fixed at both ends, wide bands: minimising Σ x′² (+ x″²) gives
        // x nearly linear in τ and x′ nearly constant (the end correction lets the free x″ at the
        // ends shave the mean of x′ a little).
        let shape = Shape { n_points: 11, levels: 3, left_fixed: 1, right_fixed: 1 };
        let mut qp = WindowQp::new(shape, f64::INFINITY, false);
        qp.load(&[1.0; 10], &[0.0, 1.0, 1.0]);
        let bands: Vec<(f64, f64)> = shape.bounded().map(|_| (-100.0, 100.0)).collect();
        let mut b = Vec::new();
        shape.rhs(&Rhs { left: &[0.0], right: &[5.0], bands: &bands }, &mut b);
        qp.solve(&vec![0.0; shape.n_vars()], &b).unwrap();
        for j in 0..11 {
            let x = qp.solution[j * 3];
            assert!((x - 0.5 * j as f64).abs() < 1e-2, "x_{j} = {x}");
            assert!((qp.solution[j * 3 + 1] - 0.5).abs() < 5e-2, "x′_{j} = {}", qp.solution[j * 3 + 1]);
        }
    }

    #[test]
    fn band_is_kept_and_values_can_be_reloaded() {
        let shape = Shape { n_points: 5, levels: 4, left_fixed: 4, right_fixed: 1 };
        let mut qp = WindowQp::new(shape, f64::INFINITY, false);
        let mut b = Vec::new();
        for delta in [1.0, 0.5] {
            qp.load(&[delta; 4], &[0.0, 1e-2, 1e-4, 1e-6]);
            // Start moving up fast; the band caps the middle points at 0.1.
            let bands = [(-0.1, 0.1); 3];
            shape.rhs(&Rhs { left: &[0.0, 1.0, 0.0, 0.0], right: &[0.0], bands: &bands }, &mut b);
            qp.solve(&vec![0.0; shape.n_vars()], &b).unwrap();
            for j in 1..4 {
                let x = qp.solution[j * 4];
                assert!((-0.1 - 1e-7..=0.1 + 1e-7).contains(&x), "Δ = {delta}: x_{j} = {x}");
            }
            // Trapezoid rows hold.
            for j in 0..4 {
                for k in 0..3 {
                    let z = |jj: usize, kk: usize| qp.solution[jj * 4 + kk];
                    let mut res = z(j + 1, k) - z(j, k) - 0.5 * delta * (z(j, k + 1) + z(j + 1, k + 1));
                    if k + 2 < 4 {
                        res += delta * delta / 12.0 * (z(j + 1, k + 2) - z(j, k + 2));
                    }
                    assert!(res.abs() < 1e-7, "residual {res}");
                }
            }
        }
    }

    #[test]
    fn straight_line_stays_straight() {
        // A line with a narrow band, entered with its own slope: nothing to smooth.
        let (n, m) = (30, 0.866);
        let shape = Shape { n_points: n, levels: 4, left_fixed: 4, right_fixed: 1 };
        let mut qp = WindowQp::new(shape, f64::INFINITY, false);
        qp.load(&vec![1.0; n - 1], &[0.0, 0.0016, 0.04, 1.0]);
        let bands: Vec<(f64, f64)> = shape.bounded().map(|j| (m * j as f64 - 0.0045, m * j as f64 + 0.0045)).collect();
        let mut b = Vec::new();
        shape.rhs(&Rhs { left: &[0.0, m, 0.0, 0.0], right: &[m * (n - 1) as f64], bands: &bands }, &mut b);
        qp.solve(&vec![0.0; shape.n_vars()], &b).unwrap();
        for j in 0..n {
            // The free end lets x′ relax a little (its weight favours a slower parameter speed),
            // within the band.
            let x = qp.solution[j * 4];
            assert!((x - m * j as f64).abs() <= 0.0045 + 1e-9 && (qp.solution[j * 4 + 1] - m).abs() < 2e-3, "{j}: {x}");
        }
    }

    #[test]
    fn conflicting_ends_are_infeasible() {
        // Left fixed at 0 with x′ = 0, x″ = 0 on a 2-point chain, right fixed at 1: the
        // trapezoid rows force x′₁ = 2 and x″₁ = 4; with band-free ends that is feasible, so
        // pin x′ at the right as well to make it infeasible.
        let shape = Shape { n_points: 2, levels: 3, left_fixed: 3, right_fixed: 2 };
        let mut qp = WindowQp::new(shape, f64::INFINITY, false);
        qp.load(&[1.0], &[0.0, 1.0, 1.0]);
        let mut b = Vec::new();
        shape.rhs(&Rhs { left: &[0.0, 0.0, 0.0], right: &[1.0, 0.0], bands: &[] }, &mut b);
        assert!(qp.solve(&[0.0; 6], &b).is_err());
    }
}
