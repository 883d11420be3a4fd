//! A solved motion law: the polynomial f(z) on the normalised section z ∈ [0, 1], its
//! derivatives for evaluation, and how well each condition is met.

use super::chebyshev;
use super::condition::{Condition, ConditionSet, LawError};
use super::ddouble::Dd;
use super::solver;

/// Highest derivative kept ready for evaluation: f⁗ is needed to find the extrema of f‴ (C_j).
pub(super) const KEPT_ORDERS: usize = 5;

/// f and its first three derivatives at one z (normalised units: stroke 1, duration 1).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Derivs {
    pub f: f64,
    pub f1: f64,
    pub f2: f64,
    pub f3: f64,
}

/// How one condition is met by the solved polynomial.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Residual {
    pub condition: Condition,
    /// f⁽ⁱ⁾(z) of the solved polynomial.
    pub achieved: f64,
    /// |f⁽ⁱ⁾(z) − F| of the solved polynomial (double-double coefficients and evaluation).
    pub abs: f64,
    /// |f⁽ⁱ⁾(z) − F| of the f64 coefficients that [`Law::eval`] uses at run time. Differs from
    /// `abs` by about ε·Σ|terms|: visible only for high derivative orders (≥ 5), where f⁽ⁱ⁾ is
    /// large; f … f‴ are unaffected at the 1e-12 level.
    pub abs_f64: f64,
}

/// An n-th order polynomial motion law (Bewegungsdesign nach Maß), stored as shifted Chebyshev
/// series.
#[derive(Debug, Clone, PartialEq)]
pub struct Law {
    conditions: Vec<Condition>,
    /// Chebyshev coefficients of f as solved, in double-double.
    coeffs_dd: Vec<Dd>,
    /// Their f64 rounding for f, f′, f″, f‴, f⁗ (derivatives with respect to z).
    series: [Vec<f64>; KEPT_ORDERS],
    residuals: Vec<Residual>,
    rcond: f64,
}

impl Law {
    /// Validates the conditions and solves them; see [`ConditionSet::new`] and [`Law::solve`]
    /// for the errors.
    pub fn from_conditions(conditions: Vec<Condition>) -> Result<Self, LawError> {
        Self::solve(&ConditionSet::new(conditions)?)
    }

    /// Solves a validated condition set in the Chebyshev basis (refined in double-double until
    /// every condition holds to its residual bound). Fails where the conditions contradict each
    /// other or do not determine the polynomial.
    pub fn solve(set: &ConditionSet) -> Result<Self, LawError> {
        let sol = solver::solve(set)?;
        let mut series: [Vec<f64>; KEPT_ORDERS] = Default::default();
        let mut dd = sol.coeffs.clone();
        for s in series.iter_mut() {
            *s = dd.iter().map(|v| v.to_f64()).collect();
            dd = chebyshev::derivative(&dd);
        }
        let mut law = Law {
            conditions: set.conditions().to_vec(),
            coeffs_dd: sol.coeffs,
            series,
            residuals: Vec::new(),
            rcond: sol.rcond,
        };
        law.residuals = law.measure_residuals()?;
        Ok(law)
    }

    /// Evaluates every condition on the solved series (Clenshaw on the derivative series: a
    /// different path from the matrix rows the solver used, so it also checks the basis code).
    fn measure_residuals(&self) -> Result<Vec<Residual>, LawError> {
        let mut out = Vec::with_capacity(self.conditions.len());
        for (index, c) in self.conditions.iter().enumerate() {
            let mut dd = self.coeffs_dd.clone();
            for _ in 0..c.order {
                dd = chebyshev::derivative(&dd);
            }
            let achieved = chebyshev::eval(&dd, c.z);
            let abs = (achieved - Dd::from(c.value)).abs().to_f64();
            let series: Vec<f64> = dd.iter().map(|v| v.to_f64()).collect();
            let abs_f64 = (chebyshev::eval(&series, c.z) - c.value).abs();
            let limit = solver::ACCEPT_REL * chebyshev::abs_sum(&series).max(1.0);
            if abs.is_nan() || abs > limit {
                return Err(LawError::Inaccurate { index, condition: *c, residual: abs, limit });
            }
            out.push(Residual { condition: *c, achieved: achieved.to_f64(), abs, abs_f64 });
        }
        Ok(out)
    }

    /// The kept series f, f′, …, f⁗ without copying (`order` < [`KEPT_ORDERS`]).
    pub(crate) fn kept_series(&self, order: usize) -> &[f64] {
        &self.series[order.min(KEPT_ORDERS - 1)]
    }

    /// Degree n = number of conditions − 1.
    pub fn degree(&self) -> usize {
        self.conditions.len() - 1
    }

    pub fn conditions(&self) -> &[Condition] {
        &self.conditions
    }

    /// Per-condition residuals, in the order of the conditions.
    pub fn residuals(&self) -> &[Residual] {
        &self.residuals
    }

    /// Largest |f⁽ⁱ⁾(z) − F| over the conditions (of the solved polynomial, [`Residual::abs`]).
    pub fn max_residual(&self) -> f64 {
        self.residuals.iter().map(|r| r.abs).fold(0.0, f64::max)
    }

    /// Largest residual of the f64 coefficients used at run time ([`Residual::abs_f64`]).
    pub fn max_residual_f64(&self) -> f64 {
        self.residuals.iter().map(|r| r.abs_f64).fold(0.0, f64::max)
    }

    /// σ_min/σ_max of the equilibrated Chebyshev system (1 = perfectly conditioned).
    pub fn rcond(&self) -> f64 {
        self.rcond
    }

    /// Coefficients in the shifted Chebyshev basis T_k(2z − 1), k = 0 … n.
    pub fn chebyshev_coefficients(&self) -> &[f64] {
        &self.series[0]
    }

    /// Coefficients a₀ … aₙ of the article's form f(z) = Σ a_k zᵏ, for reporting only: at high
    /// degree they are large and alternate, and summing them loses digits.
    pub fn monomial_coefficients(&self) -> Vec<f64> {
        chebyshev::to_monomial(&self.series[0])
    }

    /// f, f′, f″, f‴ at z, allocation-free. z is clamped to [0, 1] (NaN counts as 0): the law is
    /// only defined on its section.
    pub fn eval(&self, z: f64) -> Derivs {
        let z = if z.is_nan() { 0.0 } else { z.clamp(0.0, 1.0) };
        Derivs {
            f: chebyshev::eval(&self.series[0], z),
            f1: chebyshev::eval(&self.series[1], z),
            f2: chebyshev::eval(&self.series[2], z),
            f3: chebyshev::eval(&self.series[3], z),
        }
    }

    /// f⁽ᵒʳᵈᵉʳ⁾(z) for order ≤ 4, z clamped to [0, 1] as in [`Law::eval`].
    pub fn derivative(&self, order: usize, z: f64) -> f64 {
        let z = if z.is_nan() { 0.0 } else { z.clamp(0.0, 1.0) };
        chebyshev::eval(self.kept_series(order), z)
    }
}
