//! `interpd replay LOG [--to shm|can:IFACE] [--speed X]`: plays a recorded stream back at its
//! original timing.
//!
//! An MCAP recording (`interpd run --record`, `interpd record`) goes to shared memory
//! (`--to shm`, the default for an MCAP file): see `replay_shm.rs` and docs/formats.md.
//!
//! A candump log (`candump -l` format, as `interpd run --candump` writes it) goes to a CAN
//! interface as can-utils' `canplayer` would send it: every frame at its recorded offset from
//! the first, divided by `--speed`, on absolute deadlines (no drift over long logs). Without
//! `--to`, the interface named in the log's first line is used. The whole log is read and
//! checked before the first frame goes out, so a bad line never leaves a half-played bus.
//! SocketCAN error frames in the log are skipped (only the kernel can produce them).

use super::CliError;
use super::replay_shm;
use interpd::rt::clock;
use interpd_protocol::can_socket::{SendFailure, to_socketcan};
use interpd_protocol::candump::{self, Record};
use interpd_protocol::cia301::FrameKind;
use socketcan::{CanSocket, Socket};
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How long a frame may wait for room in a full transmit queue (ENOBUFS) before it is dropped.
const QUEUE_FULL_RETRY: Duration = Duration::from_millis(100);
/// The start of an MCAP file (the shared-memory recording format).
const MCAP_MAGIC: &[u8] = b"\x89MCAP";

/// Options of `interpd replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The recording: an MCAP file (`interpd run --record`, `interpd record`) or a candump log
    /// (`(seconds.micros) IFACE ID#DATA` per line).
    pub log: PathBuf,
    /// Where to: `shm` (MCAP recordings: iceoryx2 services `<prefix>/setpoints` and
    /// `<prefix>/feedback`) or `can:IFACE` (candump logs). Default: `shm` for an MCAP file, else
    /// the CAN interface named in the log.
    #[arg(long, value_name = "shm|can:IFACE")]
    pub to: Option<String>,
    /// Time scale: 2 plays twice as fast, 0.5 at half speed; at most 1000 (and for MCAP at
    /// least 0.001).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// With `--to shm`: the iceoryx2 service prefix to publish on; default:
    /// $INTERPD_SERVICE_PREFIX, else "interpd".
    #[arg(long)]
    pub service_prefix: Option<String>,
}

/// Where a replay goes.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Target {
    Shm,
    Can(String),
}

fn parse_target(to: &str) -> Result<Target, CliError> {
    match to {
        "shm" => Ok(Target::Shm),
        s if s.starts_with("can:") => {
            let iface = &s[4..];
            interpd::config::sinks::CanConfig::check_interface(iface)
                .map_err(|e| CliError::BadInput(format!("--to {s}: {e}")))?;
            Ok(Target::Can(iface.to_string()))
        }
        s => Err(CliError::BadInput(format!("--to {s}: expected `shm` or `can:IFACE`"))),
    }
}

pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    if !(args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1000.0) {
        return Err(CliError::BadInput(format!("--speed must lie in (0, 1000], got {}", args.speed)));
    }
    let target = args.to.as_deref().map(parse_target).transpose()?;
    let mcap = is_mcap(&args.log)?;
    match (&target, mcap) {
        (Some(Target::Shm) | None, true) => {
            return replay_shm::run_shm(&args.log, args.speed, args.service_prefix.as_deref());
        }
        (Some(Target::Shm), false) => {
            return Err(CliError::BadInput(format!(
                "{}: --to shm needs an MCAP recording (from interpd run --record or interpd record), and this \
                 file does not start with the MCAP magic; candump logs replay with --to can:IFACE",
                args.log.display()
            )));
        }
        (Some(Target::Can(iface)), true) => {
            return Err(CliError::BadInput(format!(
                "{}: an MCAP recording of the shared-memory streams cannot go to can:{iface}; replay it with --to shm",
                args.log.display()
            )));
        }
        (_, false) => {}
    }
    if args.service_prefix.is_some() {
        return Err(CliError::BadInput("--service-prefix applies to --to shm only".into()));
    }
    let records = read_log(&args.log)?;
    let Some(first) = records.first() else {
        eprintln!("interpd: {}: the log is empty, nothing to replay", args.log.display());
        return Ok(());
    };
    let iface = match target {
        Some(Target::Can(i)) => i,
        _ => first.iface.as_str().to_string(),
    };
    let socket = CanSocket::open(&iface).map_err(|e| {
        CliError::Failure(format!("cannot open CAN interface {iface}: {e} (does it exist and is it up?)"))
    })?;
    let report = play(&socket, &records, args.speed);
    eprintln!(
        "interpd: replayed {} of {} frames from {} to {iface} in {:.3} s (log span {:.3} s, speed {}): {} error \
         frames skipped, {} not sent; latest frame {:.3} ms behind its time",
        report.sent,
        records.len(),
        args.log.display(),
        report.wall_s,
        report.span_s,
        args.speed,
        report.skipped_error_frames,
        report.failed,
        report.max_late_ms
    );
    if report.failed > 0 {
        return Err(CliError::Failure(format!("{} frames could not be sent on {iface}", report.failed)));
    }
    Ok(())
}

fn is_mcap(path: &Path) -> Result<bool, CliError> {
    let mut head = [0u8; 5];
    let mut f = std::fs::File::open(path).map_err(|e| CliError::BadInput(format!("{}: {e}", path.display())))?;
    let n = f.read(&mut head).map_err(|e| CliError::BadInput(format!("{}: {e}", path.display())))?;
    Ok(head[..n] == *MCAP_MAGIC)
}

/// The whole log; the first bad line is an error naming `FILE:LINE:COL`.
fn read_log(path: &Path) -> Result<Vec<Record>, CliError> {
    let file = std::fs::File::open(path).map_err(|e| CliError::BadInput(format!("{}: {e}", path.display())))?;
    let mut records = Vec::new();
    for r in candump::Reader::new(BufReader::new(file)) {
        match r {
            Ok(rec) => records.push(rec),
            Err(candump::ReadError::Parse(e)) => {
                return Err(CliError::BadInput(format!("{}:{}:{}: {}", path.display(), e.line, e.column, e.kind)));
            }
            Err(e) => return Err(CliError::BadInput(format!("{}: {e}", path.display()))),
        }
    }
    if let Some(w) = records.windows(2).position(|w| w[1].time < w[0].time) {
        eprintln!(
            "interpd: {}:{}: the time goes backwards; such frames are sent without waiting",
            path.display(),
            w + 2
        );
    }
    Ok(records)
}

/// What [`play`] did.
#[derive(Debug, Default)]
struct PlayReport {
    sent: u64,
    failed: u64,
    skipped_error_frames: u64,
    wall_s: f64,
    span_s: f64,
    max_late_ms: f64,
}

fn play(socket: &CanSocket, records: &[Record], speed: f64) -> PlayReport {
    let mut report = PlayReport::default();
    let t_first = records.first().map_or(0, |r| r.time.as_micros());
    let start_ns = clock::now_ns();
    for r in records {
        let offset_us = r.time.as_micros().saturating_sub(t_first);
        let due_ns = start_ns + (offset_us as f64 * 1e3 / speed).round() as u64;
        clock::sleep_until_ns(due_ns);
        report.max_late_ms = report.max_late_ms.max(clock::now_ns().saturating_sub(due_ns) as f64 * 1e-6);
        report.span_s = offset_us as f64 * 1e-6;
        if r.frame.kind() == FrameKind::Error {
            report.skipped_error_frames += 1;
            continue;
        }
        let Some(frame) = to_socketcan(&r.frame) else {
            report.failed += 1;
            continue;
        };
        if send(socket, &frame) {
            report.sent += 1;
        } else {
            report.failed += 1;
        }
    }
    report.wall_s = clock::now_ns().saturating_sub(start_ns) as f64 * 1e-9;
    report
}

/// Sends, waiting out a full transmit queue for up to [`QUEUE_FULL_RETRY`] (canplayer waits too).
fn send(socket: &CanSocket, frame: &socketcan::CanFrame) -> bool {
    let until = clock::now_ns() + QUEUE_FULL_RETRY.as_nanos() as u64;
    loop {
        match socket.write_frame(frame) {
            Ok(()) => return true,
            Err(e) => {
                let retry = matches!(SendFailure::classify(&e), SendFailure::QueueFull | SendFailure::WouldBlock);
                if !retry || clock::now_ns() > until {
                    tracing::warn!("replay: sending failed: {e}");
                    return false;
                }
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse() {
        assert_eq!(parse_target("shm").ok(), Some(Target::Shm));
        assert_eq!(parse_target("can:vcan0").ok(), Some(Target::Can("vcan0".into())));
        assert!(parse_target("can:").is_err());
        assert!(parse_target("tcp:1").is_err());
    }
}
