//! `plan PROGRAM … --plant[=PRESET|FILE]`: `interpd::plan` with the simulated plant on every
//! sample (without `--plant` the same as `interpd plan`).

use interpd::cmdline::CliError;
use interpd::plan::{PlanArgs, SampleObserver, Setup};
use interpd_sim::plant_run::PlantRun;

pub fn run(args: &PlanArgs) -> Result<(), CliError> {
    let setup = Setup::from_args(args)?;
    let mut plant = match &args.plant {
        Some(choice) => {
            Some(PlantRun::new(&setup.config, choice, setup.period_s).map_err(|e| CliError::BadInput(e.to_string()))?)
        }
        None => None,
    };
    let observer = plant.as_mut().map(|p| p as &mut dyn SampleObserver);
    interpd::plan::run(args, &setup, observer, &mut std::io::stdout().lock())?;
    Ok(())
}
