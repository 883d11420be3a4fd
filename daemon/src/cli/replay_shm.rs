//! `interpd replay LOG.mcap --to shm [--speed X] [--service-prefix P]`: republishes a
//! recording on iceoryx2 at its original timing (divided by X). Every message is validated
//! before the first is published; a bad file exits 2 naming the message.

use super::CliError;
use interpd::record::RecordError;
use interpd::record::replay::{check_speed, replay, scan};
use interpd_protocol::shm::{DEFAULT_SERVICE_PREFIX, SERVICE_PREFIX_ENV, check_service_prefix};
use std::path::Path;

/// The iceoryx2 service prefix: `flag`, else $INTERPD_SERVICE_PREFIX, else "interpd".
pub fn resolve_prefix(flag: Option<&str>) -> Result<String, CliError> {
    let env = std::env::var(SERVICE_PREFIX_ENV).ok().filter(|p| !p.is_empty());
    let prefix = flag.map(str::to_string).or(env).unwrap_or_else(|| DEFAULT_SERVICE_PREFIX.to_string());
    check_service_prefix(&prefix).map_err(|e| CliError::BadInput(format!("--service-prefix: {e}")))?;
    Ok(prefix)
}

/// Maps a recording error to the exit code contract: file problems are bad input (2).
pub fn cli_error(e: RecordError) -> CliError {
    if e.is_bad_input() { CliError::BadInput(e.to_string()) } else { CliError::Failure(e.to_string()) }
}

pub fn run_shm(log: &Path, speed: f64, prefix: Option<&str>) -> Result<(), CliError> {
    check_speed(speed).map_err(|e| CliError::BadInput(format!("--speed: {e}")))?;
    let prefix = resolve_prefix(prefix)?;
    let found = scan(log).map_err(cli_error)?;
    eprintln!(
        "interpd: replaying {}: {} setpoints, {} feedback samples, {:.3} s recorded, at speed {speed} on iceoryx2 {prefix}/",
        log.display(),
        found.setpoints,
        found.feedback,
        found.span_s()
    );
    let report = replay(log, &found, &prefix, speed).map_err(cli_error)?;
    eprintln!("interpd: {report}");
    Ok(())
}
