//! What the command lines of `interpd` and `interpd-sim` share: a failed command and its exit
//! code, the log output on stderr, and the binaries that lie beside the running one (`interpd`
//! starts `sim-plant` for the demo and hands `plan --plant` and the demo scenarios to
//! `interpd-sim`, which runs the simulated plant in-process).

use std::fmt;
use std::path::PathBuf;
use std::process::ExitCode;

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

impl std::error::Error for CliError {}

impl From<interpd_config::ConfigError> for CliError {
    fn from(e: interpd_config::ConfigError) -> Self {
        CliError::BadInput(e.to_string())
    }
}

impl From<interpd_motion::program::ProgramErrors> for CliError {
    fn from(e: interpd_motion::program::ProgramErrors) -> Self {
        CliError::BadInput(e.to_string())
    }
}

/// The options of every command of `interpd` and `interpd-sim` (the same, so `interpd` can
/// hand its arguments over as they are).
#[derive(Debug, clap::Args)]
pub struct GlobalArgs {
    /// More log output on stderr (-v debug, -vv trace). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
}

/// The end of a command line's `main`: the error, if any, on stderr, and the exit code.
pub fn exit(result: Result<(), CliError>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// Log output on stderr: warnings, `-v` debug, `-vv` trace; RUST_LOG overrides.
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

/// A binary of the workspace that is not beside the running one.
#[derive(Debug, thiserror::Error)]
pub enum SiblingError {
    #[error("cannot locate the running executable: {0}")]
    CurrentExe(std::io::Error),
    #[error(
        "{name} not found: looked for {}, beside {}; `cargo build --release` builds it (with the whole workspace)",
        path.display(),
        exe.display()
    )]
    Missing { name: String, path: PathBuf, exe: PathBuf },
}

/// The binary `name` in the directory of the running executable: the workspace's binaries are
/// built (and installed) side by side.
pub fn sibling_binary(name: &str) -> Result<PathBuf, SiblingError> {
    let exe = std::env::current_exe().map_err(SiblingError::CurrentExe)?;
    let path = exe.with_file_name(name);
    if path.exists() { Ok(path) } else { Err(SiblingError::Missing { name: name.to_string(), path, exe }) }
}
