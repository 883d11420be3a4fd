//! Subcommands of `interpd`.

mod check;
mod demo;
mod law;
mod law_plot;
mod milling;
mod otg;
mod plan;
mod record;
mod replay;
mod replay_shm;
mod run;
mod signals;

use clap::{Parser, Subcommand};
use std::fmt;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    name = "interpd",
    version,
    about = "Real-time interpolator daemon: part program in, jerk-limited axis setpoints out"
)]
pub struct Cli {
    /// More log output on stderr (-v debug, -vv trace). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
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
    Plan(plan::PlanArgs),
    /// The service: control socket, planner and real-time threads, setpoint sinks.
    Run(run::RunArgs),
    /// The main job on embedded defaults: interpd run + sim-plant over iceoryx2, an example
    /// program, a summary and a plot.
    Demo(demo::DemoArgs),
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
}

/// A failed command: bad input (exit 2) or anything else (exit 1).
#[derive(Debug)]
pub enum CliError {
    BadInput(String),
    Failure(String),
}

impl CliError {
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::BadInput(_) => 2,
            CliError::Failure(_) => 1,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::BadInput(m) | CliError::Failure(m) => write!(f, "{m}"),
        }
    }
}

impl From<interpd::config::ConfigError> for CliError {
    fn from(e: interpd::config::ConfigError) -> Self {
        CliError::BadInput(e.to_string())
    }
}

impl From<interpd_motion::program::ProgramErrors> for CliError {
    fn from(e: interpd_motion::program::ProgramErrors) -> Self {
        CliError::BadInput(e.to_string())
    }
}

pub fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ =
        tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_target(false).try_init();
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Check { program, machine } => check::run(&program, machine.as_deref()),
        Command::Plan(args) => plan::run(&args),
        Command::Run(args) => run::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Replay(args) => replay::run(&args),
        Command::Law(args) => law::run(&args),
        Command::Otg(args) => otg::run(&args),
        Command::Record(args) => record::run(&args),
    }
}
