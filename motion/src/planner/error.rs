//! Why a program cannot be planned.

/// Why a program cannot be planned, with where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// The axes cannot move along the path at some point: the velocity bound there is zero or
    /// not a number.
    #[error(
        "line {line}: the axes cannot move along the path at s = {s_mm:.4} mm: velocity bound {vbar_mm_s} \
         (an axis limit or the feed does not allow motion here)"
    )]
    Immovable { s_mm: f64, line: u32, vbar_mm_s: f64 },
    /// No profile keeping the limits was found from some point on.
    #[error("line {line}: no motion within the axis limits found at s = {s_mm:.4} mm: {reason}")]
    Infeasible { s_mm: f64, line: u32, reason: Infeasibility },
}

/// Where the branch search of a block gave up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Infeasibility {
    /// No backward branch leaves a section end, whatever its start velocity.
    NoBackwardBranch,
    /// The forward branch found no next velocity that keeps the limits and can still brake
    /// under the ceiling.
    NoViableStep,
    /// The forward branch met a backward branch but no join onto it keeps the limits.
    CannotJoin,
    /// The forward branch reached the block end in motion.
    NotAtRest,
    /// The block still had no profile after the most repairs of its velocity bound allowed.
    TooManyRepairs,
    /// The block's search for a profile took the most work allowed for its length.
    OutOfWork,
}

impl Infeasibility {
    /// The reason in words, as in [`PlanError`]'s message.
    pub fn as_str(self) -> &'static str {
        match self {
            Infeasibility::NoBackwardBranch => "no backward branch leaves this section end",
            Infeasibility::NoViableStep => "no feasible and viable next velocity",
            Infeasibility::CannotJoin => "the forward branch cannot join the backward branch",
            Infeasibility::NotAtRest => "the forward branch did not come to rest at the block end",
            Infeasibility::TooManyRepairs => "too many repairs",
            Infeasibility::OutOfWork => "the search took the most work allowed for the block",
        }
    }
}

impl std::fmt::Display for Infeasibility {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_line_the_place_and_the_reason() {
        let e = PlanError::Immovable { s_mm: 12.345_67, line: 7, vbar_mm_s: 0.0 };
        assert_eq!(
            e.to_string(),
            "line 7: the axes cannot move along the path at s = 12.3457 mm: velocity bound 0 \
             (an axis limit or the feed does not allow motion here)"
        );
        let e = PlanError::Infeasible { s_mm: 1.0, line: 3, reason: Infeasibility::CannotJoin };
        assert_eq!(
            e.to_string(),
            "line 3: no motion within the axis limits found at s = 1.0000 mm: the forward branch cannot join the backward branch"
        );
    }
}
