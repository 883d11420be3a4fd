//! Why a plan failed, and which failures are the input's (the command line exits 2 on those).

use crate::cmdline::CliError;
use interpd_motion::FeedError;
use std::path::PathBuf;

/// Why a sample observer (`super::SampleObserver`) failed.
pub type ObserverError = Box<dyn std::error::Error + Send + Sync>;

#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The machine configuration cannot be loaded or is invalid.
    #[error(transparent)]
    Config(#[from] interpd_config::ConfigError),
    #[error("--lookahead-mm must be positive, got {0}")]
    Lookahead(f64),
    #[error("--period-ms must be a number ≥ 0.01, got {0}")]
    Period(f64),
    /// The program has errors (all of them, by line and column).
    #[error(transparent)]
    Program(#[from] interpd_motion::program::ProgramErrors),
    #[error("{}: the program has no motion", .0.display())]
    NoMotion(PathBuf),
    /// The motion lasts longer than the sampling is bounded to: almost surely a mistyped feed
    /// or limit.
    #[error(
        "{}: the planned motion lasts more than {max_samples} samples at {period_ms} ms ({duration_s:.3e} s); is the \
         feed (F, mm/min) or an axis limit far too low?",
        program.display()
    )]
    TooLong { program: PathBuf, max_samples: u64, period_ms: f64, duration_s: f64 },
    /// The smoothing stage failed (a fault of interpd's, not of the program).
    #[error(transparent)]
    Smoothing(interpd_motion::prep::PrepError),
    /// The planner found no motion along the path within the limits.
    #[error(transparent)]
    Planner(interpd_motion::planner::PlanError),
    /// The thread that reads the program failed (a fault of the system's or of interpd's).
    #[error(transparent)]
    Reading(interpd_motion::FeedError),
    #[error("{}: cannot create: {source}", path.display())]
    Create { path: PathBuf, source: std::io::Error },
    /// Writing the CSV or the figures failed.
    #[error("cannot write output: {0}")]
    Write(#[from] std::io::Error),
    #[error("{}: cannot write: {source}", path.display())]
    ExportNodes { path: PathBuf, source: std::io::Error },
    #[error("internal error: the planned motion is not finite")]
    NotFinite,
    /// The sample observer failed (the simulated plant of `--plant`).
    #[error("internal error: {0}")]
    Observer(ObserverError),
}

impl PlanError {
    /// The input's fault (the program, the machine, an option), not the machine's running it.
    pub fn is_bad_input(&self) -> bool {
        match self {
            PlanError::Config(_)
            | PlanError::Lookahead(_)
            | PlanError::Period(_)
            | PlanError::Program(_)
            | PlanError::NoMotion(_)
            | PlanError::TooLong { .. }
            | PlanError::Planner(_) => true,
            PlanError::Smoothing(_)
            | PlanError::Create { .. }
            | PlanError::Write(_)
            | PlanError::Reading(_)
            | PlanError::ExportNodes { .. }
            | PlanError::NotFinite
            | PlanError::Observer(_) => false,
        }
    }
}

impl From<FeedError> for PlanError {
    fn from(e: FeedError) -> Self {
        match e {
            FeedError::Program(e) => PlanError::Program(e),
            FeedError::Prep(e) => PlanError::Smoothing(e),
            FeedError::Plan(e) => PlanError::Planner(e),
            e @ (FeedError::ReaderThread(_) | FeedError::ReaderThreadEnded) => PlanError::Reading(e),
        }
    }
}

impl From<PlanError> for CliError {
    fn from(e: PlanError) -> Self {
        if e.is_bad_input() { CliError::BadInput(e.to_string()) } else { CliError::Failure(e.to_string()) }
    }
}
