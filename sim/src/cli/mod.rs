//! Subcommands of `interpd-sim`: those of `interpd` that run the simulated plant in-process,
//! with the same options.

mod milling;
mod plan;

use clap::{Parser, Subcommand};
use interpd::cmdline::{CliError, GlobalArgs};
use interpd::demo::DemoArgs;
use interpd::plan::PlanArgs;

#[derive(Debug, Parser)]
#[command(
    name = "interpd-sim",
    version,
    about = "The simulated plant in-process for interpd: `plan --plant` and the demo scenarios (interpd starts it \
             for them)"
)]
pub struct Cli {
    #[command(flatten)]
    pub global: GlobalArgs,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Plan a program offline and sample the motion in simulated time (CSV and/or JSON), with
    /// the simulated plant on the samples (`--plant`).
    Plan(PlanArgs),
    /// A demo scenario: `--scenario milling-circle`.
    Demo(DemoArgs),
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Plan(args) => plan::run(&args),
        Command::Demo(args) => match args.scenario.as_deref() {
            Some("milling-circle") => milling::run(&args),
            Some(other) => Err(CliError::BadInput(format!("--scenario {other}: unknown; known: milling-circle"))),
            None => Err(CliError::BadInput(
                "interpd-sim demo runs a scenario (--scenario milling-circle); the demo itself is `interpd demo`"
                    .into(),
            )),
        },
    }
}
