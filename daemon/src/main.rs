//! The `interpd` command line. Exit codes: 0 success, 2 bad input, 1 any other failure.
//! Messages go to stderr, data to stdout.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    interpd::cmdline::init_logging(args.global.verbose);
    interpd::cmdline::exit(cli::run(args))
}
