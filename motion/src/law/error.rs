//! Why a condition set gives no motion law. Indices are 0-based places in the set; messages
//! print them 1-based ("condition 3"), as a person counts `--cond` options.

use super::condition::Condition;

/// Lists 0-based indices as 1-based numbers: "1, 4 and 7".
fn numbers(indices: &[usize]) -> String {
    let n: Vec<String> = indices.iter().map(|i| (i + 1).to_string()).collect();
    match n.len() {
        0 => String::from("(none identified)"),
        1 => n[0].clone(),
        _ => format!("{} and {}", n[..n.len() - 1].join(", "), n[n.len() - 1]),
    }
}

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
    #[error(
        "conditions {} are not independent, or too nearly dependent to give a reliable law (reciprocal condition \
         number {rcond:.1e}, minimum {min:.0e}): they do not determine a polynomial of degree {degree}; replace one \
         of them or spread them over the section",
        numbers(indices),
        min = super::solver::RCOND_MIN
    )]
    Dependent { indices: Vec<usize>, rcond: f64, degree: usize },
    #[error("condition {} ({condition}) is met only to {residual:.1e} after solving (limit {limit:.0e})", index + 1)]
    Inaccurate { index: usize, condition: Condition, residual: f64, limit: f64 },
    #[error("the linear algebra did not converge ({what})")]
    Numerical { what: String },
    #[error("unknown preset '{name}'; known: {known}")]
    UnknownPreset { name: String, known: String },
    #[error("preset '{name}': {why}")]
    PresetParameter { name: String, why: String },
}
