//! The weighted least-squares B-spline of one window (Haas 2012, §4.6–4.7): control points
//! such that the spline's values and parametric derivatives at the QP's points match the
//! optimised ones in the weighted least-squares sense (`lscov` with weights per derivative
//! order), with the leading derivatives at the window's ends fixed so that windows chain
//! continuously.

use super::banded::{BandedSpd, NotPositiveDefinite};
use super::basis::{DEGREE, Knots, MAX_DERIV, ORDER};

/// Values per point: position and derivatives up to x⁗.
pub(crate) const LEVELS: usize = MAX_DERIV + 1;
/// Levels the emitted pieces take at each point: x, x′, x″ (quintic Hermite ends).
pub(crate) const PIECE_LEVELS: usize = 3;

/// Why a window has no B-spline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FitError {
    /// The breakpoints do not increase strictly.
    Knots,
    /// The fixed end derivatives need more control points than the window has.
    TooFewControlPoints,
    /// The normal equations are singular (a control point no data row determines).
    Singular,
}

impl From<NotPositiveDefinite> for FitError {
    fn from(_: NotPositiveDefinite) -> Self {
        FitError::Singular
    }
}

/// The fit's structure for one window (knots, weights, fixed ends), factorised once and
/// solved per axis.
pub(crate) struct Fit {
    pub knots: Knots,
    u: Vec<f64>,
    levels: usize,
    weights: [f64; LEVELS],
    fixed_left: usize,
    fixed_right: usize,
    /// Basis derivatives at each point (from the interval starting there; the last point from
    /// the last interval) and their span; the next fit's cache.
    at_points: Vec<CachedBasis>,
    normal: BandedSpd,
}

/// One point's block of KᵀWK (lower triangle) over its `L` levels: `wd` are the basis
/// derivatives `d` times the level's weight. The levels are a constant, so the sums unroll.
fn point_block<const L: usize>(
    wd: &[[f64; ORDER]; LEVELS],
    d: &[[f64; ORDER]; LEVELS],
    block: &mut [[f64; ORDER]; ORDER],
) {
    for a in 0..ORDER {
        for b in 0..=a {
            let mut v = wd[0][a] * d[0][b];
            for l in 1..L {
                v += wd[l][a] * d[l][b];
            }
            block[a][b] = v;
        }
    }
}

/// One point's share of KᵀW y over its `L` levels for `NA` axes (`r[g]` the weighted data of
/// axis g), added to `out` (`out[a][g]`: control point a, axis g).
fn point_rhs<const L: usize, const NA: usize>(
    d: &[[f64; ORDER]; LEVELS],
    r: &[[f64; LEVELS]; NA],
    out: &mut [[f64; NA]; ORDER],
) {
    for (a, o) in out.iter_mut().enumerate() {
        for g in 0..NA {
            let mut v = d[0][a] * r[g][0];
            for l in 1..L {
                v += d[l][a] * r[g][l];
            }
            o[g] += v;
        }
    }
}

/// The basis values and derivatives at the points of the last fit, for the next one: they
/// depend only on the knots around a point relative to it (`Knots::offsets`), so a point
/// whose neighbours are still the same has the same values in the next window, which starts
/// where this one commits. An entry is taken over only when its offsets agree, so a point
/// inserted or a window that starts elsewhere costs evaluations, never wrong values.
#[derive(Debug, Default)]
pub(crate) struct BasisCache {
    entries: Vec<CachedBasis>,
    /// The list before last, kept for its allocation.
    spare: Vec<CachedBasis>,
}

/// The points of a fit named for the cache: `keys[j]` is point j's s on the path (mm,
/// increasing, as the breakpoints).
pub(crate) struct CachedPoints<'a> {
    pub keys: &'a [f64],
    pub cache: &'a mut BasisCache,
}

#[derive(Debug, Clone, Copy)]
struct CachedBasis {
    /// The point's s (mm).
    key: f64,
    offsets: [f64; 2 * DEGREE],
    /// Derivatives held: 0 ..= n_deriv.
    n_deriv: usize,
    /// Knot span of the point in its fit (the interval starting there; the last point's:
    /// the interval ending there).
    span: usize,
    d: [[f64; ORDER]; LEVELS],
}

/// The basis derivatives at one breakpoint, all levels (see [`Fit::state_basis`]).
pub(crate) struct StateBasis {
    first: usize,
    d: [[f64; ORDER]; LEVELS],
}

/// A fitted spline for one axis: its control points.
pub(crate) struct Curve {
    pub ctrl: Vec<f64>,
}

/// Axes whose right-hand sides one pass over the points and the band takes (more are solved
/// in groups): the three of a Cartesian machine, the common case.
pub(crate) const AXES_PER_SOLVE: usize = 3;

/// The data and fixed ends of all axes, as [`Fit::solve`] takes them.
type AxesData<'a, const A: usize> = (&'a [[[f64; LEVELS]; A]], &'a [[f64; LEVELS]; A], &'a [[f64; LEVELS]; A]);

/// Relative pivot below which the normal equations count as singular.
const PIVOT_REL_TOL: f64 = 1e-13;

/// Knot offsets (in τ, where the points are about 1 apart) that count as the same when the
/// basis values of one point are taken over for the next: the values then differ by about
/// this much relatively, far below what the band check resolves.
const SAME_OFFSET_TOL: f64 = 1e-12;

fn same_offsets(a: &[f64; 2 * DEGREE], b: &[f64; 2 * DEGREE]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= SAME_OFFSET_TOL * x.abs().max(1.0))
}

impl BasisCache {
    /// Points held (those of the last fit).
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.entries.len()
    }
}

impl Fit {
    /// The fit over breakpoints `u` (one per QP point, strictly increasing), inner knots of
    /// `multiplicity`, data `levels` (x … x^(levels − 1)) per point weighted by `weights`,
    /// `fixed_left` / `fixed_right` leading derivatives fixed at the ends; `cached` holds the
    /// basis values of the previous fit's points and takes this fit's.
    pub(crate) fn new(
        u: &[f64],
        cached: CachedPoints,
        multiplicity: usize,
        levels: usize,
        weights: [f64; LEVELS],
        fixed_left: usize,
        fixed_right: usize,
    ) -> Result<Self, FitError> {
        let knots = Knots::clamped(u, multiplicity).ok_or(FitError::Knots)?;
        let n_ctrl = knots.n_basis();
        // A clamped end's k-th derivative depends on the first (last) k + 1 control points only;
        // both ends' fixed points must not overlap.
        if fixed_left > ORDER || fixed_right > ORDER || fixed_left + fixed_right > n_ctrl {
            return Err(FitError::TooFewControlPoints);
        }
        let n = u.len();
        let CachedPoints { keys, cache } = cached;
        debug_assert_eq!(keys.len(), n);
        // Derivative orders each point needs: the data's levels and the pieces' x, x′, x″; the
        // first point all of them (the fixed left end can hold up to x⁗), the committed
        // point's full state is evaluated again when asked for (`state_basis`).
        let n_deriv = levels.clamp(PIECE_LEVELS, LEVELS) - 1;
        let mut at_points = std::mem::take(&mut cache.spare);
        at_points.clear();
        // The previous fit's entry at or after the point (both lists run along s).
        let mut c = cache.entries.partition_point(|e| e.key < keys[0]);
        for j in 0..n {
            let span = knots.span(j.min(n - 2));
            let offsets = knots.offsets(span, u[j]);
            let need = if j == 0 { MAX_DERIV } else { n_deriv };
            while c < cache.entries.len() && cache.entries[c].key < keys[j] {
                c += 1;
            }
            let fits = |e: &&CachedBasis| e.n_deriv >= need && same_offsets(&e.offsets, &offsets);
            // On equidistant points (most of a window) the values repeat from point to point;
            // the points the previous window also had (about two thirds of it, since a window
            // commits about a third) have them from there; only the rest is evaluated.
            let held = at_points.last().filter(fits).or(cache.entries.get(c).filter(|e| e.key == keys[j]).filter(fits));
            let point = match held {
                Some(e) => CachedBasis { key: keys[j], offsets, span, ..*e },
                None => {
                    let mut d = [[0.0; ORDER]; LEVELS];
                    knots.derivs_upto(span, u[j], need, &mut d);
                    CachedBasis { key: keys[j], offsets, n_deriv: need, span, d }
                }
            };
            at_points.push(point);
        }
        let free = fixed_left..n_ctrl - fixed_right;
        let mut normal = BandedSpd::zeros(free.len());
        let mut block = [[0.0; ORDER]; ORDER];
        // The basis values `block` was summed from, if it holds a point's block.
        let mut block_of: Option<&[[f64; ORDER]; LEVELS]> = None;
        for CachedBasis { span, d, .. } in &at_points {
            let first = span - DEGREE;
            if first >= free.start && first + DEGREE < free.end {
                // Away from the fixed ends every entry of the block is free. The point's block
                // of KᵀWK (lower triangle) is summed over the levels before it is added to the
                // band: one addition per entry instead of one per entry and level; on
                // equidistant points it is the previous point's.
                if block_of != Some(d) {
                    let wd: [[f64; ORDER]; LEVELS] = std::array::from_fn(|l| d[l].map(|v| weights[l] * v));
                    match levels {
                        3 => point_block::<3>(&wd, d, &mut block),
                        4 => point_block::<4>(&wd, d, &mut block),
                        _ => point_block::<LEVELS>(&wd, d, &mut block),
                    }
                    block_of = Some(d);
                }
                normal.add_block(first - free.start, &block);
                continue;
            }
            let wd: [[f64; ORDER]; LEVELS] = std::array::from_fn(|l| d[l].map(|v| weights[l] * v));
            for a in 0..ORDER {
                let ia = first + a;
                if !free.contains(&ia) {
                    continue;
                }
                for b in 0..=a {
                    let ib = first + b;
                    if free.contains(&ib) {
                        let mut v = wd[0][a] * d[0][b];
                        for l in 1..levels {
                            v += wd[l][a] * d[l][b];
                        }
                        normal.add(ia - free.start, ib - free.start, v);
                    }
                }
            }
        }
        if !normal.is_empty() {
            normal.cholesky(PIVOT_REL_TOL)?;
        }
        Ok(Self { knots, u: u.to_vec(), levels, weights, fixed_left, fixed_right, at_points, normal })
    }

    /// The control points of the axes `axes`, one [`Curve`] each in that order: `data[j][k][l]`
    /// is the l-th derivative wanted at point j on axis k, `left[k]` / `right[k]` its fixed end
    /// derivatives (at least `fixed_left` / `fixed_right` of them). Up to [`AXES_PER_SOLVE`]
    /// axes share one pass over the points and the band.
    pub(crate) fn solve<const A: usize>(
        &self,
        data: &[[[f64; LEVELS]; A]],
        axes: &[usize],
        left: &[[f64; LEVELS]; A],
        right: &[[f64; LEVELS]; A],
    ) -> Vec<Curve> {
        let mut curves = Vec::with_capacity(axes.len());
        let ends = (data, left, right);
        for group in axes.chunks(AXES_PER_SOLVE) {
            match *group {
                [a] => self.solve_group([a], ends, &mut curves),
                [a, b] => self.solve_group([a, b], ends, &mut curves),
                [a, b, c] => self.solve_group([a, b, c], ends, &mut curves),
                _ => unreachable!("groups of at most AXES_PER_SOLVE axes"),
            }
        }
        curves
    }

    /// [`Self::solve`] for the `NA` axes `axes`, their curves appended to `out`. Each axis gets
    /// the operations, in the order, of a solve of its own.
    fn solve_group<const A: usize, const NA: usize>(
        &self,
        axes: [usize; NA],
        (data, left, right): AxesData<A>,
        out: &mut Vec<Curve>,
    ) {
        let n_ctrl = self.knots.n_basis();
        let n = self.u.len();
        let mut ctrl = vec![[0.0; NA]; n_ctrl];
        for (g, &k_axis) in axes.iter().enumerate() {
            // Left end: derivative k at u₀ is Σ_{i ≤ k} N_i^(k)(u₀) P_i, triangular.
            let d0 = &self.at_points[0].d;
            for k in 0..self.fixed_left {
                let s: f64 = (0..k).map(|i| d0[k][i] * ctrl[i][g]).sum();
                ctrl[k][g] = (left[k_axis][k] - s) / d0[k][k];
            }
            // Right end: derivative k at u_{n−1} involves the last k + 1 control points.
            let d1 = &self.at_points[n - 1].d;
            for k in 0..self.fixed_right {
                let s: f64 = (0..k).map(|i| d1[k][ORDER - 1 - i] * ctrl[n_ctrl - 1 - i][g]).sum();
                ctrl[n_ctrl - 1 - k][g] = (right[k_axis][k] - s) / d1[k][ORDER - 1 - k];
            }
        }
        let free = self.fixed_left..n_ctrl - self.fixed_right;
        let mut rhs = vec![[0.0; NA]; free.len()];
        for (CachedBasis { span, d, .. }, point) in self.at_points.iter().zip(data) {
            let first = span - DEGREE;
            if first >= free.start && first + DEGREE < free.end {
                // Only the points near the ends see fixed control points.
                let r: [[f64; LEVELS]; NA] = axes.map(|k| std::array::from_fn(|l| self.weights[l] * point[k][l]));
                let out: &mut [[f64; NA]; ORDER] =
                    (&mut rhs[first - free.start..][..ORDER]).try_into().expect("ORDER entries");
                match self.levels {
                    3 => point_rhs::<3, NA>(d, &r, out),
                    4 => point_rhs::<4, NA>(d, &r, out),
                    _ => point_rhs::<LEVELS, NA>(d, &r, out),
                }
                continue;
            }
            for (g, &k_axis) in axes.iter().enumerate() {
                let mut r = [0.0; LEVELS];
                for l in 0..self.levels {
                    // Residual of the data against the fixed control points' share.
                    let fixed: f64 =
                        (0..ORDER).filter(|a| !free.contains(&(first + a))).map(|a| d[l][a] * ctrl[first + a][g]).sum();
                    r[l] = self.weights[l] * (point[k_axis][l] - fixed);
                }
                for a in 0..ORDER {
                    if free.contains(&(first + a)) {
                        rhs[first + a - free.start][g] += (0..self.levels).map(|l| d[l][a] * r[l]).sum::<f64>();
                    }
                }
            }
        }
        if !rhs.is_empty() {
            self.normal.solve(&mut rhs);
        }
        ctrl[free].copy_from_slice(&rhs);
        out.extend((0..NA).map(|g| Curve { ctrl: ctrl.iter().map(|c| c[g]).collect() }));
    }

    /// Value and the first two derivatives of `curve` at breakpoint `j` (the ends of the pieces
    /// there), from the basis values the fit already holds there (those of the interval
    /// starting at `j`; at the last breakpoint, of the interval ending there). The spline's
    /// x, x′, x″ are the same from either side of a breakpoint (m ≤ 3).
    pub(crate) fn piece_end(&self, curve: &Curve, j: usize) -> [f64; PIECE_LEVELS] {
        let CachedBasis { span, d, .. } = &self.at_points[j];
        let first = span - DEGREE;
        std::array::from_fn(|l| (0..ORDER).map(|a| d[l][a] * curve.ctrl[first + a]).sum())
    }

    /// The basis values and derivatives 0..LEVELS at breakpoint `j` (of the interval starting
    /// there; at the last breakpoint, of the interval ending there), for [`Self::state`]: the
    /// fit holds only the levels its data and the pieces need.
    pub(crate) fn state_basis(&self, j: usize) -> StateBasis {
        let span = self.knots.span(j.min(self.u.len() - 2));
        let mut d = [[0.0; ORDER]; LEVELS];
        self.knots.derivs(span, self.u[j], &mut d);
        StateBasis { first: span - DEGREE, d }
    }

    /// Value and derivatives 0..LEVELS of `curve` where `basis` was taken. The derivatives up
    /// to the spline's continuity are the same from either side of the breakpoint, so this is
    /// also the end state of interval `j − 1` in them; the levels above the continuity are
    /// those of the interval starting at `j`.
    pub(crate) fn state(&self, curve: &Curve, basis: &StateBasis) -> [f64; LEVELS] {
        let StateBasis { first, d } = basis;
        std::array::from_fn(|l| (0..ORDER).map(|a| d[l][a] * curve.ctrl[first + a]).sum())
    }

    /// Hands the basis values of this fit's points to `cache` for the next fit.
    pub(crate) fn into_cache(self, cache: &mut BasisCache) {
        cache.spare = std::mem::replace(&mut cache.entries, self.at_points);
    }

    /// Value and derivatives 0..LEVELS of `curve` at `x` on breakpoint interval `j` (the tests'
    /// reference for the spline between the points).
    #[cfg(test)]
    pub(crate) fn eval(&self, curve: &Curve, j: usize, x: f64) -> [f64; LEVELS] {
        let span = self.knots.span(j);
        let mut d = [[0.0; ORDER]; LEVELS];
        self.knots.derivs(span, x, &mut d);
        let first = span - DEGREE;
        std::array::from_fn(|l| (0..ORDER).map(|a| d[l][a] * curve.ctrl[first + a]).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A fit with the points named by their breakpoints and nothing cached.
    fn fit_new(
        u: &[f64],
        m: usize,
        levels: usize,
        w: [f64; LEVELS],
        fixed_left: usize,
        fixed_right: usize,
    ) -> Result<Fit, FitError> {
        let cached = CachedPoints { keys: u, cache: &mut BasisCache::default() };
        Fit::new(u, cached, m, levels, w, fixed_left, fixed_right)
    }

    /// The curve of one axis with data `data`.
    fn solve1(fit: &Fit, data: &[[f64; LEVELS]], left: &[f64; LEVELS], right: &[f64; LEVELS]) -> Curve {
        let data: Vec<[[f64; LEVELS]; 1]> = data.iter().map(|&d| [d]).collect();
        fit.solve(&data, &[0], &[*left], &[*right]).pop().expect("one axis")
    }

    #[test]
    fn axes_solved_together_are_those_solved_alone() {
        // Five axes (a group of three and one of two) against each alone, bit for bit; fixed
        // ends on both sides, so the points near them take the per-axis path too.
        let u = [0.0, 0.4, 1.0, 1.3, 2.2, 2.5, 3.0, 3.9, 4.5, 5.0, 5.8, 6.1];
        let fit = fit_new(&u, 1, 4, [1000.0, 100.0, 10.0, 1.0, 0.1], 3, 1).unwrap();
        let data: Vec<[[f64; LEVELS]; 5]> =
            u.iter().map(|&x| std::array::from_fn(|k| sample(x + k as f64).map(|v| v * (1.0 + k as f64)))).collect();
        let (left, right) = (data[0], data[u.len() - 1]);
        let axes = [4, 0, 2, 1, 3];
        let together = fit.solve(&data, &axes, &left, &right);
        assert_eq!(together.len(), axes.len());
        for (c, &k) in together.iter().zip(&axes) {
            let alone = fit.solve(&data, &[k], &left, &right);
            assert_eq!(c.ctrl, alone[0].ctrl, "axis {k}");
        }
    }

    fn sample(x: f64) -> [f64; LEVELS] {
        // sin(x) and its derivatives.
        [x.sin(), x.cos(), -x.sin(), -x.cos(), x.sin()]
    }

    #[test]
    fn matches_a_dense_weighted_least_squares_solve() {
        let u = [0.0, 0.4, 1.0, 1.3, 2.2, 2.5, 3.0, 3.9];
        let w = [1000.0, 100.0, 10.0, 1.0, 0.1];
        for (m, levels) in [(1, 5), (1, 3), (2, 4), (3, 3)] {
            let fit = fit_new(&u, m, levels, w, 0, 0).unwrap();
            // Noisy data so that the fit does not reproduce it exactly.
            let data: Vec<[f64; LEVELS]> =
                u.iter().enumerate().map(|(j, &x)| sample(x).map(|v| v + 0.01 * ((j * 7 % 5) as f64 - 2.0))).collect();
            let c = solve1(&fit, &data, &[0.0; LEVELS], &[0.0; LEVELS]);
            // Dense: rows √w_l N^(l)(u_j), solved by SVD.
            let nb = fit.knots.n_basis();
            let mut k = DMatrix::zeros(u.len() * levels, nb);
            let mut y = DVector::zeros(u.len() * levels);
            for (j, CachedBasis { span, d, .. }) in fit.at_points.iter().enumerate() {
                for l in 0..levels {
                    for a in 0..ORDER {
                        k[(j * levels + l, span - DEGREE + a)] = w[l].sqrt() * d[l][a];
                    }
                    y[j * levels + l] = w[l].sqrt() * data[j][l];
                }
            }
            let x = k.svd(true, true).solve(&y, 1e-12).unwrap();
            for i in 0..nb {
                assert!((c.ctrl[i] - x[i]).abs() < 1e-8 * (1.0 + x[i].abs()), "m {m} i {i}: {} vs {}", c.ctrl[i], x[i]);
            }
        }
    }

    #[test]
    fn fixed_ends_are_met_and_a_quintic_is_reproduced() {
        let u = [0.0, 0.5, 1.5, 2.0, 3.0, 3.2, 4.0];
        let q = |x: f64| -> [f64; LEVELS] {
            [
                1.0 + x - 0.5 * x * x + 0.1 * x.powi(5),
                1.0 - x + 0.5 * x.powi(4),
                -1.0 + 2.0 * x.powi(3),
                6.0 * x * x,
                12.0 * x,
            ]
        };
        let data: Vec<[f64; LEVELS]> = u.iter().map(|&x| q(x)).collect();
        let fit = fit_new(&u, 1, 5, [1000.0, 100.0, 10.0, 1.0, 0.1], 5, 3).unwrap();
        let c = solve1(&fit, &data, &q(0.0), &q(4.0));
        for j in 0..u.len() - 1 {
            for i in 0..=4 {
                let x = u[j] + (u[j + 1] - u[j]) * i as f64 / 4.0;
                let (got, want) = (fit.eval(&c, j, x), q(x));
                for l in 0..LEVELS {
                    assert!((got[l] - want[l]).abs() < 1e-8 * (1.0 + want[l].abs()), "x {x} l {l}");
                }
            }
        }
    }

    #[test]
    fn the_state_at_a_point_is_that_of_both_adjacent_intervals_up_to_the_continuity() {
        let u = [0.0, 0.4, 1.0, 1.3, 2.2, 2.5, 3.0, 3.9];
        let data: Vec<[f64; LEVELS]> = u.iter().map(|&x| sample(x)).collect();
        for m in 1..=3 {
            let fit = fit_new(&u, m, 3, [1000.0, 100.0, 10.0, 1.0, 0.1], 0, 0).unwrap();
            let c = solve1(&fit, &data, &[0.0; LEVELS], &[0.0; LEVELS]);
            for j in 0..u.len() {
                let at = fit.state(&c, &fit.state_basis(j));
                let end = fit.piece_end(&c, j);
                for l in 0..PIECE_LEVELS {
                    assert!((end[l] - at[l]).abs() < 1e-9 * (1.0 + at[l].abs()), "m {m} j {j} l {l}");
                }
                let mut sides = vec![];
                if j > 0 {
                    sides.push(fit.eval(&c, j - 1, u[j]));
                }
                if j + 1 < u.len() {
                    sides.push(fit.eval(&c, j, u[j]));
                }
                for side in sides {
                    for l in 0..=DEGREE - m {
                        assert!((at[l] - side[l]).abs() < 1e-9 * (1.0 + side[l].abs()), "m {m} j {j} l {l}");
                    }
                }
            }
        }
    }

    #[test]
    fn basis_values_taken_over_on_equidistant_points_are_those_evaluated() {
        // Equidistant runs (values taken over) between uneven points (evaluated).
        let u: Vec<f64> = (0..40).map(|j| if j < 20 { j as f64 * 0.8 } else { 16.0 + (j - 20) as f64 * 1.3 }).collect();
        let u: Vec<f64> = u.iter().enumerate().map(|(j, &x)| if j == 30 { x + 0.2 } else { x }).collect();
        for m in 1..=3 {
            let fit = fit_new(&u, m, 4, [1000.0, 100.0, 10.0, 1.0, 0.1], 0, 0).unwrap();
            for (j, CachedBasis { span, d, .. }) in fit.at_points.iter().enumerate() {
                let mut want = [[0.0; ORDER]; LEVELS];
                fit.knots.derivs(*span, u[j], &mut want);
                // The fit holds the levels its data and the pieces need; the first point all.
                let held = if j == 0 { LEVELS } else { 4 };
                for l in 0..held {
                    for a in 0..ORDER {
                        let tol = 1e-10 * want[l].iter().fold(1.0, |m: f64, v| m.max(v.abs()));
                        assert!((d[l][a] - want[l][a]).abs() <= tol, "m {m} j {j} l {l} a {a}");
                    }
                }
            }
        }
    }

    /// Every point's basis values in `fit` agree with those evaluated afresh.
    fn assert_basis_as_evaluated(fit: &Fit, u: &[f64], what: &str) {
        for (j, CachedBasis { span, d, n_deriv, .. }) in fit.at_points.iter().enumerate() {
            let mut want = [[0.0; ORDER]; LEVELS];
            fit.knots.derivs(*span, u[j], &mut want);
            for l in 0..=*n_deriv {
                for a in 0..ORDER {
                    let tol = 1e-10 * want[l].iter().fold(1.0, |m: f64, v| m.max(v.abs()));
                    assert!((d[l][a] - want[l][a]).abs() <= tol, "{what}: j {j} l {l} a {a}");
                }
            }
        }
    }

    #[test]
    fn basis_values_taken_over_from_the_previous_window_are_those_evaluated() {
        // Uneven points along s; the next window starts at point 13 of the first (its commit),
        // runs on past its end, and has a point inserted between 20 and 21 (a refinement).
        let s: Vec<f64> = (0..60).map(|j| j as f64 * 0.9 + 0.15 * ((j * 7 % 5) as f64)).collect();
        let w = [1000.0, 100.0, 10.0, 1.0, 0.1];
        for m in 1..=3 {
            let mut cache = BasisCache::default();
            let first = &s[..40];
            let u: Vec<f64> = first.iter().map(|x| (x - first[0]) / 0.9).collect();
            let a = Fit::new(&u, CachedPoints { keys: first, cache: &mut cache }, m, 4, w, 0, 0).unwrap();
            assert_basis_as_evaluated(&a, &u, "first window");
            a.into_cache(&mut cache);
            let mut next: Vec<f64> = s[13..55].to_vec();
            next.insert(8, 0.5 * (s[20] + s[21]));
            let u: Vec<f64> = next.iter().map(|x| (x - next[0]) / 0.9).collect();
            let b = Fit::new(&u, CachedPoints { keys: &next, cache: &mut cache }, m, 4, w, 3, 1).unwrap();
            assert_basis_as_evaluated(&b, &u, "next window");
            // The first point's full levels are there for the fixed left end.
            assert_eq!(b.at_points[0].n_deriv, MAX_DERIV);
        }
    }

    #[test]
    fn too_many_fixed_levels_are_refused() {
        assert_eq!(fit_new(&[0.0, 1.0], 1, 3, [1.0; LEVELS], 5, 3).err(), Some(FitError::TooFewControlPoints));
        assert_eq!(fit_new(&[0.0, 1.0, 1.0], 1, 3, [1.0; LEVELS], 1, 1).err(), Some(FitError::Knots));
    }

    #[test]
    fn committed_spans_do_not_see_the_data_beyond_the_margin() {
        // A window of 200 points, denser in a stretch (a corner), noisy data about a smooth
        // curve; the spans up to point `commit` of the fit over `commit + 1 + margin` points
        // (right end free) against those of the fit over all of them (right end fixed).
        let margin = super::super::FIT_MARGIN_POINTS;
        let commit = 42;
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 200;
        let mut u = vec![0.0];
        for j in 1..n {
            let step = if (60..90).contains(&j) { 0.3 + 0.2 * rnd() } else { 1.0 - 0.05 * rnd().abs() };
            u.push(u[j - 1] + step);
        }
        // Misfit 0.01 on data of amplitude 1.
        let data: Vec<[f64; LEVELS]> = u
            .iter()
            .map(|&x| {
                [(0.1 * x).sin(), 0.1 * (0.1 * x).cos(), -0.01 * (0.1 * x).sin(), 0.0, 0.0].map(|v| v + 0.01 * rnd())
            })
            .collect();
        let haas = [1000.0, 100.0, 10.0, 1.0, 0.1];
        let tightened = [1e7, 100.0, 10.0, 1.0, 0.1];
        for (levels, m, w) in [(4, 1, haas), (3, 1, haas), (5, 1, haas), (4, 1, tightened), (4, 2, haas), (3, 3, haas)]
        {
            let ends = |nt: usize, fixed_right: usize| {
                let f = fit_new(&u[..nt], m, levels, w, DEGREE + 1 - m, fixed_right).unwrap();
                let c = solve1(&f, &data[..nt], &data[0], &data[nt - 1]);
                (0..=commit).map(|j| f.piece_end(&c, j)).collect::<Vec<_>>()
            };
            let (whole, cut) = (ends(n, 1), ends(commit + 1 + margin, 0));
            for j in 0..=commit {
                for l in 0..PIECE_LEVELS {
                    let d = (whole[j][l] - cut[j][l]).abs();
                    // 1e-5 of the misfit (measured: at most 1.2e-8 at a margin of 20).
                    assert!(d < 1e-7, "levels {levels} m {m} w0 {}: point {j} level {l} differs by {d:e}", w[0]);
                }
            }
        }
    }
}
