//! Motion laws after the motion-design article (Bewegungsdesign nach Maß): single-axis moves
//! designed as one polynomial f(z) on the normalised section z ∈ [0, 1] (stroke 1, duration 1),
//! fixed by interpolation conditions f⁽ⁱ⁾(z) = F, with the VDI 2143 characteristic values
//! C_v = max|f′|, C_a = max|f″|, C_j = max|f‴|, and executable as synchronised axis moves.
//!
//! - [`Condition`], [`ConditionSet`]: conditions and their validation; the solve runs in a
//!   Chebyshev basis (well conditioned up to degree 24) and yields a [`Law`];
//! - [`Preset`]: the article's laws; [`Characteristics`]: exact extrema;
//! - [`AxisLimits`] and [`LawMove`]: a law as a timed move on machine axes, checked against the
//!   axis limits; [`program`]: the `LAW` program statement.
//!
//! See `docs/motion-laws.md`.

mod characteristic;
mod chebyshev;
mod condition;
mod ddouble;
mod limits;
mod movement;
mod polynomial;
mod preset;
pub mod program;
mod roots;
mod solver;

pub use characteristic::{Characteristics, Extreme, Peak};
pub use condition::{Condition, ConditionSet, LawError, MAX_CONDITIONS, MAX_DEGREE};
pub use limits::{AxisLimits, LimitError, LimitKind};
pub use movement::{AxisState, LawAxis, LawMove, LawMoveError};
pub use polynomial::{Derivs, Law, Residual};
pub use preset::Preset;

#[cfg(test)]
mod tests;
