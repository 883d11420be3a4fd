//! Interpolation conditions f⁽ⁱ⁾(z) = F on the normalised motion section z ∈ [0, 1]
//! (Bewegungsdesign nach Maß: "i = Ableitungsordnung, z = Zeitparameter, f = Funktionswert"),
//! their validation, and why a condition set gives no law ([`LawError`]): the error names the
//! conditions and the validation returns it, so both live here, below the solver and the
//! presets that use them.

use std::fmt;

/// Most conditions in one set; the law's degree is at most [`MAX_DEGREE`].
///
/// Why 25 (degree 24): the article's largest example (the asymmetric law) has 18 conditions,
/// degree 17, so this leaves room for combining its conditions with a few more. The solve itself
/// would go further (Chebyshev basis, double-double refinement), but the law is evaluated in f64
/// at run time, and f‴ amplifies the coefficients' rounding by up to T_n‴(1)·2³ ≈ 8n⁶/15
/// (V. Markov): ~1e8 at n = 24, i.e. C_j and the jerk setpoints to ~1e-8 relative. Beyond that
/// the margin shrinks quickly, and such laws have no use on a machine.
pub const MAX_CONDITIONS: usize = 25;

/// Highest polynomial degree a condition set may produce.
pub const MAX_DEGREE: usize = MAX_CONDITIONS - 1;

/// Two conditions are at the same place when their z differ by less than this (z is a
/// normalised time, so 1e-12 is far below any meaningful resolution).
pub(super) const SAME_Z_TOL: f64 = 1e-12;

/// Largest |F| accepted: the normalised law has stroke 1, so values far beyond this are typos.
pub(super) const MAX_ABS_VALUE: f64 = 1e9;

/// One interpolation condition: the `order`-th derivative of f at `z` equals `value`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condition {
    /// Derivative order i (0 = position, 1 = velocity, …), at most [`MAX_DEGREE`].
    pub order: u32,
    /// Normalised time z ∈ [0, 1].
    pub z: f64,
    /// Required value of f⁽ⁱ⁾(z), in normalised units (stroke 1, duration 1).
    pub value: f64,
}

impl Condition {
    pub const fn new(order: u32, z: f64, value: f64) -> Self {
        Condition { order, z, value }
    }

    /// Parses `I,Z,F` (the form of `--cond` and of the program's `COND=`), e.g. `2,0.5,0`.
    pub fn parse(text: &str) -> Result<Self, LawError> {
        let bad = |why: &str| LawError::Parse { text: text.to_string(), why: why.to_string() };
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        if parts.len() != 3 {
            return Err(bad("expected three numbers I,Z,F (derivative order, z in [0,1], value)"));
        }
        let order: u32 =
            parts[0].parse().map_err(|_| bad(&format!("derivative order '{}' is not a whole number ≥ 0", parts[0])))?;
        let z: f64 = parts[1].parse().map_err(|_| bad(&format!("z '{}' is not a number", parts[1])))?;
        let value: f64 = parts[2].parse().map_err(|_| bad(&format!("value '{}' is not a number", parts[2])))?;
        Ok(Condition { order, z, value })
    }

    /// Checks the ranges of this one condition; `index` is its 0-based place in its set.
    pub fn validate(&self, index: usize) -> Result<(), LawError> {
        if !self.z.is_finite() || !(0.0..=1.0).contains(&self.z) {
            return Err(LawError::ZOutOfRange { index, z: self.z });
        }
        if !self.value.is_finite() || self.value.abs() > MAX_ABS_VALUE {
            return Err(LawError::BadValue { index, value: self.value });
        }
        if self.order as usize > MAX_DEGREE {
            return Err(LawError::OrderTooHigh { index, order: self.order, max: MAX_DEGREE });
        }
        Ok(())
    }
}

impl fmt::Display for Condition {
    /// The article's notation: f(0.4) = 0.2, f'(0) = 0, f'''(1) = 0, f(5)(0.5) = 0.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.order {
            0..=3 => write!(f, "f{}({}) = {}", "'".repeat(self.order as usize), self.z, self.value),
            i => write!(f, "f({i})({}) = {}", self.z, self.value),
        }
    }
}

/// A validated set of conditions: 1 … [`MAX_CONDITIONS`] of them, each in range, no two at the
/// same derivative order and place. It still may be singular; the solver finds that out.
#[derive(Debug, Clone, PartialEq)]
pub struct ConditionSet {
    conditions: Vec<Condition>,
}

impl ConditionSet {
    pub fn new(conditions: Vec<Condition>) -> Result<Self, LawError> {
        if conditions.is_empty() {
            return Err(LawError::Empty);
        }
        if conditions.len() > MAX_CONDITIONS {
            return Err(LawError::TooMany { count: conditions.len(), max: MAX_CONDITIONS });
        }
        for (k, c) in conditions.iter().enumerate() {
            c.validate(k)?;
        }
        let degree = conditions.len() - 1;
        for (k, c) in conditions.iter().enumerate() {
            // A derivative above the degree is identically zero: F = 0 is redundant (the system
            // is then singular), F ≠ 0 impossible. Say so directly rather than via the rank.
            if c.order as usize > degree {
                return Err(LawError::OrderAboveDegree { index: k, condition: *c, degree });
            }
        }
        for (b, cb) in conditions.iter().enumerate() {
            for (a, ca) in conditions[..b].iter().enumerate() {
                if ca.order == cb.order && (ca.z - cb.z).abs() < SAME_Z_TOL {
                    return Err(if ca.value == cb.value {
                        LawError::Duplicate { first: a, second: b, condition: *cb }
                    } else {
                        LawError::Contradictory { indices: vec![a, b], detail: format!("{ca} and {cb}") }
                    });
                }
            }
        }
        Ok(ConditionSet { conditions })
    }

    pub fn conditions(&self) -> &[Condition] {
        &self.conditions
    }

    /// Degree n = count − 1 of the polynomial these conditions determine.
    pub fn degree(&self) -> usize {
        self.conditions.len() - 1
    }
}

/// Lists 0-based indices as 1-based numbers: "1, 4 and 7".
fn numbers(indices: &[usize]) -> String {
    let n: Vec<String> = indices.iter().map(|i| (i + 1).to_string()).collect();
    match n.len() {
        0 => String::from("(none identified)"),
        1 => n[0].clone(),
        _ => format!("{} and {}", n[..n.len() - 1].join(", "), n[n.len() - 1]),
    }
}

/// Why a condition set gives no motion law. Indices are 0-based places in the set; messages
/// print them 1-based ("condition 3"), as a person counts `--cond` options.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawError {
    #[error("'{text}': {why}")]
    Parse { text: String, why: String },
    #[error("no conditions given")]
    Empty,
    #[error("{count} conditions, at most {max} are supported (degree ≤ {})", max - 1)]
    TooMany { count: usize, max: usize },
    #[error("condition {}: z must be a number in [0, 1], got {z}", index + 1)]
    ZOutOfRange { index: usize, z: f64 },
    #[error("condition {}: value must be finite and |F| ≤ 1e9, got {value}", index + 1)]
    BadValue { index: usize, value: f64 },
    #[error("condition {}: derivative order {order} is above the supported maximum {max}", index + 1)]
    OrderTooHigh { index: usize, order: u32, max: usize },
    #[error(
        "condition {} ({condition}): derivative order {} is above the degree {degree} that {} conditions give; \
         that derivative is identically 0",
        index + 1, condition.order, degree + 1
    )]
    OrderAboveDegree { index: usize, condition: Condition, degree: usize },
    #[error("conditions {} and {} are the same ({condition})", first + 1, second + 1)]
    Duplicate { first: usize, second: usize, condition: Condition },
    #[error("conditions {} contradict each other: {detail}", numbers(indices))]
    Contradictory { indices: Vec<usize>, detail: String },
    /// `min` is the solver's limit the set fell below, carried like `Inaccurate`'s `limit` so
    /// that the message needs nothing of the solver.
    #[error(
        "conditions {} are not independent, or too nearly dependent to give a reliable law (reciprocal condition \
         number {rcond:.1e}, minimum {min:.0e}): they do not determine a polynomial of degree {degree}; replace one \
         of them or spread them over the section",
        numbers(indices)
    )]
    Dependent { indices: Vec<usize>, rcond: f64, min: f64, degree: usize },
    #[error("condition {} ({condition}) is met only to {residual:.1e} after solving (limit {limit:.0e})", index + 1)]
    Inaccurate { index: usize, condition: Condition, residual: f64, limit: f64 },
    #[error("the linear algebra did not converge ({what})")]
    Numerical { what: String },
    #[error("unknown preset '{name}'; known: {known}")]
    UnknownPreset { name: String, known: String },
    #[error("preset '{name}': {why}")]
    PresetParameter { name: String, why: String },
}
