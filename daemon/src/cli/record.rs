//! `interpd record --out FILE.mcap [--service-prefix P] [--duration-s S]`: records the
//! shared-memory streams of whatever publishes on `<prefix>/setpoints` and `<prefix>/feedback`
//! (a running daemon and plant, or a replay) until SIGINT/SIGTERM or for S seconds.

use super::CliError;
use super::replay_shm::{cli_error, resolve_prefix};
use super::signals::TerminationSignals;
use interpd::record::{RecordFile, RecordOptions, Recorder};
use std::path::PathBuf;

/// Longest `--duration-s`: a day.
const MAX_DURATION_S: f64 = 86_400.0;

/// Options of `interpd record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// Output file (MCAP); created or truncated.
    #[arg(long, value_name = "FILE.mcap")]
    pub out: PathBuf,
    /// iceoryx2 service prefix; default: $INTERPD_SERVICE_PREFIX, else "interpd".
    #[arg(long)]
    pub service_prefix: Option<String>,
    /// Stop after this many seconds (default: at SIGINT or SIGTERM).
    #[arg(long)]
    pub duration_s: Option<f64>,
}

pub fn run(args: &RecordArgs) -> Result<(), CliError> {
    let prefix = resolve_prefix(args.service_prefix.as_deref())?;
    if let Some(d) = args.duration_s {
        if !(d.is_finite() && d > 0.0 && d <= MAX_DURATION_S) {
            return Err(CliError::BadInput(format!("--duration-s {d}: expected a number in (0, {MAX_DURATION_S}]")));
        }
    }
    let file = RecordFile::create(&args.out).map_err(cli_error)?;
    // Before the recorder thread starts, so that it inherits the blocked signals.
    let signals = TerminationSignals::block();
    let recorder = Recorder::start(file, RecordOptions::new(&prefix)).map_err(cli_error)?;
    eprintln!(
        "interpd: recording {prefix}/setpoints and {prefix}/feedback to {}; SIGINT or SIGTERM ends it",
        args.out.display()
    );
    match signals.wait(args.duration_s) {
        Some(name) => eprintln!("interpd: {name}: finishing the recording"),
        None => eprintln!("interpd: {} s elapsed: finishing the recording", args.duration_s.unwrap_or_default()),
    }
    let report = recorder.stop().map_err(cli_error)?;
    eprintln!("interpd: {report}");
    Ok(())
}
