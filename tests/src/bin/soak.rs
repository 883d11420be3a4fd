//! `soak`: the daemon and the plant for a long time under a random client; prints the figures
//! and exits 1 when the run shows a limit violation, a cycle gap, an underrun or memory growth
//! (see `interpd_e2e::soak`). Not part of CI at full length:
//!
//! ```sh
//! cargo build --release -p interpd -p sim-plant -p interpd-e2e --bin soak
//! target/release/soak --seconds 3600 [--seed N] [--dir DIR] [--keep] [--progress-s 60]
//! ```

use interpd_e2e::rng::seed_from_env;
use interpd_e2e::soak::{SoakOptions, run};
use std::io::Write;
use std::process::ExitCode;
use std::time::Duration;

const USAGE: &str = "usage: soak [--seconds N (default $SOAK_SECONDS, else 300)] [--seed N (default $SOAK_SEED, \
                     else from the clock)] [--dir DIR] [--keep] [--progress-s N]";

fn main() -> ExitCode {
    match parse(std::env::args().skip(1).collect()) {
        Ok(options) => {
            eprintln!(
                "soak: SOAK_SEED={} for {} s in {}",
                options.seed,
                options.duration.as_secs(),
                options.dir.display()
            );
            let report = run(&options);
            // The figures are the tool's output: stdout.
            let _ = writeln!(std::io::stdout(), "{report}");
            if report.failures().is_empty() { ExitCode::SUCCESS } else { ExitCode::FAILURE }
        }
        Err(message) => {
            eprintln!("soak: {message}\n{USAGE}");
            ExitCode::from(2)
        }
    }
}

fn parse(args: Vec<String>) -> Result<SoakOptions, String> {
    let env_seconds = std::env::var("SOAK_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(300);
    let mut options = SoakOptions {
        duration: Duration::from_secs(env_seconds),
        seed: seed_from_env("SOAK_SEED"),
        dir: std::env::temp_dir().join(format!("interpd-soak-{}", std::process::id())),
        keep: false,
        progress: None,
    };
    let mut it = args.into_iter();
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        let number = |name: &str, v: String| v.parse::<u64>().map_err(|_| format!("{name}: not a whole number: {v}"));
        match arg.as_str() {
            "--seconds" => options.duration = Duration::from_secs(number("--seconds", value("--seconds")?)?),
            "--seed" => options.seed = number("--seed", value("--seed")?)?,
            "--dir" => options.dir = value("--dir")?.into(),
            "--keep" => options.keep = true,
            "--progress-s" => {
                options.progress = Some(Duration::from_secs(number("--progress-s", value("--progress-s")?)?.max(1)))
            }
            "-h" | "--help" => return Err("help".into()),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if options.duration.is_zero() {
        return Err("--seconds must be at least 1".into());
    }
    Ok(options)
}
