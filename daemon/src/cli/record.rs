//! `interpd record --out FILE.mcap [--service-prefix P] [--duration-s S]`: records the
//! shared-memory streams of whatever publishes on `<prefix>/setpoints` and `<prefix>/feedback`
//! (a running daemon and plant, or a replay) until SIGINT/SIGTERM or for S seconds.

use super::CliError;
use super::replay_shm::{cli_error, resolve_prefix};
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

/// SIGINT and SIGTERM, blocked in this thread and the threads started after, and waited for.
struct TerminationSignals {
    set: libc::sigset_t,
}

impl TerminationSignals {
    fn block() -> Self {
        // SAFETY: sigset manipulation on a local set; pthread_sigmask on the calling thread.
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, libc::SIGINT);
            libc::sigaddset(&mut set, libc::SIGTERM);
            libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
            TerminationSignals { set }
        }
    }

    /// Waits for a signal (its name) or until `timeout_s` passed (`None`).
    fn wait(&self, timeout_s: Option<f64>) -> Option<&'static str> {
        let deadline = timeout_s.map(|s| std::time::Instant::now() + std::time::Duration::from_secs_f64(s));
        loop {
            let left = deadline.map(|d| d.saturating_duration_since(std::time::Instant::now()));
            if left.is_some_and(|l| l.is_zero()) {
                return None;
            }
            // Wake at least once a second so the deadline is checked without a timed wait
            // API of its own.
            let step = left.map_or(std::time::Duration::from_secs(1), |l| l.min(std::time::Duration::from_secs(1)));
            let ts =
                libc::timespec { tv_sec: step.as_secs() as libc::time_t, tv_nsec: step.subsec_nanos() as libc::c_long };
            // SAFETY: valid set and timespec; a null siginfo is allowed.
            let sig = unsafe { libc::sigtimedwait(&self.set, std::ptr::null_mut(), &ts) };
            if sig == libc::SIGINT {
                return Some("SIGINT");
            }
            if sig == libc::SIGTERM {
                return Some("SIGTERM");
            }
        }
    }
}
