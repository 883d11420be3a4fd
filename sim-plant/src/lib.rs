//! Simulated axis plant: elastic multi-mass axes with a cascade drive controller.
//!
//! - [`model`]: the two-mass axis fitted to Schneider 2016 (direction-dependent stiffness,
//!   backlash with C¹ flanks, Coulomb and viscous friction, process force) and the 3-mass axis
//!   of Haas 2012, §5.2 (signs of eq. 5.11 restored, crosstalk outputs), each with the current
//!   loop as a PT1 state.
//! - [`discretize`]: exact discretisation Φ = e^{Ah}, Γ = ∫e^{As}ds·B (matrix exponential).
//! - [`drive`]: fine interpolation of the coarse setpoints, quantised encoder, P/PI cascade with
//!   feedforward and anti-windup.
//! - [`plant::Plant`]: a set of axes stepping from setpoints; [`metrics`], [`plot`] for
//!   evaluation; [`shm`] runs the plant as an iceoryx2 node (the `sim-plant` binary).
//! - [`analysis`]: modes and closed-loop eigenvalues; [`scenario`]: jerk-limited test moves
//!   and the acceptance scenarios (static compliance, backlash reversal, residual vibration,
//!   the Haas positioning move).
//!
//! # In-process use
//!
//! One [`Plant`] per machine, built from the validated configuration (`[[axis]]` and
//! `[plant]`); one [`Plant::step`] per setpoint with the targets of all axes in the axis unit
//! (mm or deg) and the time since the previous setpoint. The first step places the plant at
//! rest at its targets. [`Metrics`] accumulates the outputs; [`plot::write_png`] draws them.
//!
//! ```
//! use interpd_config::Config;
//! use sim_plant::plot::{self, PlotOptions};
//! use sim_plant::scenario::SCurve;
//! use sim_plant::{AxisTarget, Metrics, Plant};
//!
//! # fn main() -> Result<(), sim_plant::PlantError> {
//! let config = Config::default_machine(); // X Y Z on the haas-laser preset
//! let mut plant = Plant::from_config(&config)?;
//! let mut metrics = Metrics::new(&plant, 1000);
//! let dt_s = config.cycle_s(); // one setpoint per 4 ms interpolation cycle
//! // X: a jerk-limited move 0 → 20 mm (100 mm/s, 1000 mm/s², 20000 mm/s³); Y, Z stand still.
//! let mv = SCurve::new(0.0, 20.0, 100.0, 1000.0, 20_000.0);
//! for k in 0..=150 {
//!     let (pos, vel, acc) = mv.eval(k as f64 * dt_s);
//!     let x = AxisTarget { pos, vel, acc };
//!     let out = plant.step(&[x, AxisTarget::default(), AxisTarget::default()], dt_s)?;
//!     assert!(out[0].load_error.abs() < 0.05); // mm: setpoint − load
//!     metrics.record_plant(&plant);
//! }
//! let summary = metrics.summary();
//! assert!(summary.axes[0].max_following_error > 0.0 && summary.max_contour_error.is_some());
//! let png = std::env::temp_dir().join(format!("sim-plant-doc-{}.png", std::process::id()));
//! plot::write_png(&png, &metrics, &PlotOptions { title: "ramp".into(), ..PlotOptions::default() })?;
//! # std::fs::remove_file(&png).ok();
//! # Ok(())
//! # }
//! ```

pub mod analysis;
pub mod axis;
pub mod can;
pub mod can_homing;
pub mod can_node;
pub mod can_od;
pub mod discretize;
pub mod drive;
pub mod metrics;
pub mod model;
pub mod noise;
pub mod plant;
pub mod plot;
pub mod process;
pub mod scenario;
pub mod shm;

pub use axis::AxisOutput;
pub use metrics::{Metrics, MetricsSummary};
pub use plant::{AxisTarget, InputStats, Plant, SetpointError};
pub use plot::{PlotOptions, write_png};

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
