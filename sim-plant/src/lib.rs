//! Simulated axis plant: elastic multi-mass axes with a cascade drive controller.
//!
//! - [`model`]: the two-mass axis of seed 004 §5a (asymmetric stiffness, backlash with C¹
//!   flanks, Coulomb and viscous friction, process force) and the 3-mass axis of seed 000 §5.2
//!   (signs corrected, crosstalk outputs), each with the current loop as a PT1 state.
//! - [`discretize`]: exact discretisation Φ = e^{Ah}, Γ = ∫e^{As}ds·B (matrix exponential).
//! - [`drive`]: fine interpolation of the coarse setpoints, quantised encoder, P/PI cascade with
//!   feedforward and anti-windup.
//! - [`plant::Plant`]: a set of axes stepping from setpoints; [`metrics`], [`plot`] for
//!   evaluation; [`shm`] runs the plant as an iceoryx2 node (the `sim-plant` binary).
//! - [`analysis`]: modes and closed-loop eigenvalues; [`scenario`]: jerk-limited test moves
//!   and the acceptance scenarios T1–T3 and the Haas positioning move.

pub mod analysis;
pub mod axis;
pub mod discretize;
pub mod drive;
pub mod metrics;
pub mod model;
pub mod plant;
pub mod plot;
pub mod scenario;
pub mod shm;

pub use axis::AxisOutput;
pub use metrics::{Metrics, MetricsSummary};
pub use plant::{AxisTarget, InputStats, Plant, SetpointError};

use thiserror::Error;

/// Errors of the plant library.
#[derive(Debug, Error)]
pub enum PlantError {
    /// The configuration is invalid (names file and key).
    #[error(transparent)]
    Config(#[from] interpd_config::ConfigError),
    /// A model could not be built (non-finite matrices and the like).
    #[error("plant model: {0}")]
    Model(String),
    /// Bad input to the in-process API (wrong axis count, non-finite target).
    #[error("plant input: {0}")]
    Input(String),
    /// Shared-memory transport failure.
    #[error("iceoryx2: {0}")]
    Transport(String),
    /// Writing a plot failed.
    #[error("plot: {0}")]
    Plot(String),
}
