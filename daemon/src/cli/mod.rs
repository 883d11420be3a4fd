//! Subcommands of `interpd`.

mod can;
mod check;
mod demo;
mod law;
mod law_plot;
mod otg;
mod record;
mod replay;
mod replay_shm;
mod run;
mod signals;

pub use interpd::cmdline::CliError;

use clap::{Parser, Subcommand};
use interpd::cmdline::GlobalArgs;
use interpd::plan::{PlanArgs, Setup};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    name = "interpd",
    version,
    about = "Real-time interpolator daemon: part program in, jerk-limited axis setpoints out"
)]
pub struct Cli {
    #[command(flatten)]
    pub global: GlobalArgs,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Parse and validate a program against the machine; errors as FILE:LINE:COL: message.
    Check {
        /// Program file (G-code, or a path table .csv).
        program: PathBuf,
        /// Machine configuration (TOML); default: the embedded 3-axis machine.
        #[arg(long)]
        machine: Option<PathBuf>,
    },
    /// Plan a program offline and sample the motion in simulated time (CSV and/or JSON).
    Plan(PlanArgs),
    /// The service: control socket, planner and real-time threads, setpoint sinks.
    Run(run::RunArgs),
    /// The main job on embedded defaults: interpd run + sim-plant over iceoryx2, an example
    /// program, a summary and a plot.
    Demo(interpd::demo::DemoArgs),
    /// Replay a recording at its original timing: an MCAP recording onto iceoryx2 (`--to shm`),
    /// or a candump log to a CAN interface (`--to can:IFACE`, as can-utils' canplayer does).
    Replay(replay::ReplayArgs),
    /// Design a motion law from interpolation conditions: degree, VDI 2143 characteristic
    /// values, residuals, coefficients; CSV samples and a plot on request.
    Law(law::LawArgs),
    /// One online-trajectory calculation: time-optimal jerk-limited motion from state to state.
    Otg(otg::OtgArgs),
    /// Record the shared-memory streams (setpoints, feedback) to MCAP until SIGINT/SIGTERM or
    /// `--duration-s`.
    Record(record::RecordArgs),
    /// Commissioning of the CAN drives: `sdo read|write` (one SDO transfer, through the daemon or
    /// directly on the bus with --can) and `reset` (fault reset, through the daemon).
    Can(can::CanArgs),
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Check { program, machine } => check::run(&program, machine.as_deref()),
        Command::Plan(args) if args.plant.is_some() => in_sim("`interpd plan --plant`"),
        Command::Plan(args) => plan(&args),
        Command::Run(args) => run::run(&args),
        Command::Demo(args) if args.scenario.is_some() => in_sim("`interpd demo --scenario`"),
        Command::Demo(args) => demo::run(&args),
        Command::Replay(args) => replay::run(&args),
        Command::Law(args) => law::run(&args),
        Command::Otg(args) => otg::run(&args),
        Command::Record(args) => record::run(&args),
        Command::Can(args) => can::run(&args),
    }
}

/// `interpd plan` without the plant: the sampling of `interpd::plan` on its own.
fn plan(args: &PlanArgs) -> Result<(), CliError> {
    let setup = Setup::from_args(args)?;
    interpd::plan::run(args, &setup, None, &mut std::io::stdout().lock())?;
    Ok(())
}

/// Hands the command line, as it is, to `interpd-sim` beside this binary, which runs the
/// simulated plant in-process (interpd links no simulator); returns only when that fails.
fn in_sim(what: &str) -> Result<(), CliError> {
    let sim = interpd::cmdline::sibling_binary("interpd-sim").map_err(|e| {
        CliError::Failure(format!("{what} runs in interpd-sim, which runs the simulated plant in-process: {e}"))
    })?;
    tracing::debug!("{what}: running {}", sim.display());
    let e = std::process::Command::new(&sim).args(std::env::args_os().skip(1)).exec();
    Err(CliError::Failure(format!("{what}: cannot start {}: {e}", sim.display())))
}
