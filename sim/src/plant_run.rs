//! `plan --plant`: the simulated axes (sim-plant, in-process) driven by the sampled setpoints,
//! one setpoint per row, as the sampling's [`SampleObserver`]: four columns per axis in the
//! CSV (motor, load, following error, load error), the member `plant` in the JSON figures and
//! the plant's summary in the text.

use interpd::plan::{AxisSample, ObserverError, SampleObserver};
use interpd_config::{Config, ConfigError};
use std::io::Write;

/// Why the plant of `--plant` cannot be built: the option names no usable plant.
#[derive(Debug, thiserror::Error)]
pub enum PlantRunError {
    /// No such preset or file, or a plant that does not fit the machine's axes.
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("--plant: {0}")]
    Plant(sim_plant::PlantError),
}

/// Standstill simulated after the motion end for the plant summary's residual vibration, s.
const PLANT_SETTLE_S: f64 = 1.0;

/// `--plant`: the simulated axes (sim-plant, in-process) driven by the sampled setpoints.
pub struct PlantRun {
    plant: sim_plant::Plant,
    metrics: sim_plant::metrics::Metrics,
    /// The current row's setpoint per axis.
    targets: Vec<sim_plant::AxisTarget>,
    period_s: f64,
    names: Vec<String>,
}

impl PlantRun {
    /// The plant `choice` selects (`--plant`'s value: empty for the machine's `[plant]`, a
    /// preset or a file) for the axes of `config`, stepped every `period_s`.
    pub fn new(config: &Config, choice: &str, period_s: f64) -> Result<Self, PlantRunError> {
        let plant_config = config.plant.select(choice, &config.axes, "--plant")?;
        let resolved = plant_config.resolve(&config.axes, "--plant")?;
        let plant = sim_plant::Plant::new(&resolved, &plant_config).map_err(PlantRunError::Plant)?;
        // The recording keeps the last `[plant] record_s` (the summary's residual vibration
        // needs only the settling after the end); the maxima run over everything.
        let metrics = sim_plant::metrics::Metrics::new(&plant, (config.plant.record_s / period_s).ceil() as usize);
        let targets = vec![sim_plant::AxisTarget::default(); plant.n_axes()];
        Ok(Self { plant, metrics, targets, period_s, names: config.axis_names() })
    }

    /// One step to the current targets.
    fn advance(&mut self) -> Result<(), StepError> {
        self.plant.step(&self.targets, self.period_s).map_err(StepError)?;
        self.metrics.record_plant(&self.plant);
        Ok(())
    }
}

/// A plant step failed (an internal error: the setpoints come from the planner).
#[derive(Debug, thiserror::Error)]
#[error("plant step: {0}")]
struct StepError(sim_plant::PlantError);

impl SampleObserver for PlantRun {
    fn write_header(&self, w: &mut dyn Write) -> std::io::Result<()> {
        for n in &self.names {
            write!(w, ",{n}_motor,{n}_load,{n}_following_error,{n}_load_error")?;
        }
        Ok(())
    }

    /// The first row places the plant at rest at its setpoint; each further row is one
    /// setpoint `period_s` later.
    fn step(&mut self, axes: &[AxisSample]) -> Result<(), ObserverError> {
        for (t, a) in self.targets.iter_mut().zip(axes) {
            *t = sim_plant::AxisTarget { pos: a.pos, vel: a.vel, acc: a.acc };
        }
        Ok(self.advance()?)
    }

    fn write_columns(&self, w: &mut dyn Write) -> std::io::Result<()> {
        for o in self.plant.outputs() {
            write!(w, ",{},{},{},{}", o.motor_pos, o.load_pos, o.following_error, o.load_error)?;
        }
        Ok(())
    }

    /// Holds the last setpoint for [`PLANT_SETTLE_S`] more (not written to the CSV), so the
    /// summary has the residual vibration after the motion end.
    fn settle(&mut self) -> Result<(), ObserverError> {
        for t in &mut self.targets {
            *t = sim_plant::AxisTarget { pos: t.pos, vel: 0.0, acc: 0.0 };
        }
        for _ in 0..(PLANT_SETTLE_S / self.period_s).ceil() as u64 {
            self.advance()?;
        }
        Ok(())
    }

    fn json(&self) -> (&'static str, serde_json::Value) {
        let s = self.metrics.summary();
        let per_axis =
            |f: fn(&sim_plant::metrics::AxisSummary) -> serde_json::Value| s.axes.iter().map(f).collect::<Vec<_>>();
        let figures = serde_json::json!({
            "presets": per_axis(|a| a.preset.clone().into()),
            "max_following_error": per_axis(|a| a.max_following_error.into()),
            "max_load_error": per_axis(|a| a.max_load_error.into()),
            "residual_vibration": per_axis(|a| a.residual_amplitude.into()),
            "residual_peak_hz": per_axis(|a| a.residual_peak_hz.into()),
            "max_contour_error_mm": s.max_contour_error,
        });
        ("plant", figures)
    }

    fn summary(&self) -> String {
        self.metrics.summary().to_string()
    }
}
