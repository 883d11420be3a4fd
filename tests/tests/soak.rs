//! The soak run in CI: `interpd_e2e::soak` for `SOAK_SECONDS` (default 30 s here; the hour-long
//! run is `target/release/soak --seconds 3600`, docs/testing.md). Fails on a limit violation
//! or a gap in the recorded stream, an underrun, or resident memory growth beyond the bound
//! derived from the run length.

use interpd_e2e::rng::seed_from_env;
use interpd_e2e::soak::{SoakOptions, run};
use std::time::Duration;

/// Length of the run when `SOAK_SECONDS` is not set: enough for every kind of action.
const DEFAULT_SECONDS: u64 = 30;

#[test]
fn soak_keeps_the_limits_and_its_memory() {
    let seconds = std::env::var("SOAK_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(DEFAULT_SECONDS);
    let options = SoakOptions {
        duration: Duration::from_secs(seconds),
        seed: seed_from_env("SOAK_SEED"),
        dir: std::env::temp_dir().join(format!("interpd-e2e-soak-{}", std::process::id())),
        keep: false,
        progress: None,
    };
    let report = run(&options);
    eprintln!("{report}");
    let _ = std::fs::remove_dir_all(&options.dir);
    let failures = report.failures();
    assert!(failures.is_empty(), "{report}");
    for what in ["start", "override", "hold", "resume"] {
        assert!(report.actions.counts.get(what).copied().unwrap_or(0) > 0, "no {what} in {} s: {report}", seconds);
    }
}
