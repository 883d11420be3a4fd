//! Real-time benchmark of the running service, printed as figures (not pass/fail):
//!
//! ```sh
//! cargo bench -p interpd --bench rt_loop            # 25 000 cycles per run: about 14 min
//! RT_BENCH_CYCLES=2500 cargo bench -p interpd --bench rt_loop   # a short run
//! ```
//!
//! Per scenario, in one run: a **bare loop** (the daemon's own `rt::run_loop`, scheduled as the
//! daemon's real-time thread: SCHED_FIFO, mlockall, pinned CPU from `[rt]`; its cycle is a fixed
//! synthetic computation calibrated to interpd's median cycle length, the baseline of the
//! compute-time figures),
//! half of its cycles before and half after the service run so slow drifts of a shared
//! machine hit both alike; then the **real service** (`Service`, iceoryx2 on, a service
//! prefix of its own) for the same number of cycles while it plans and executes a program,
//! restarted each time it ends. A real-time subscriber on the other CPU checks that every cycle
//! number arrives exactly once, computed for its own time (late ones flagged `LATE`), and times
//! the shared-memory hop (receive − `publish_ns`).
//!
//! Scenarios (`RT_BENCH_SCENARIOS`, comma-separated, default all):
//! - `xyz-idle`, `xyz-hog`: 3 axes, `examples/dense_freeform.ngc` (100 000 G1 segments) with
//!   tolerance-band smoothing (G64 P0.01: the prep QP and the planner run continuously);
//! - `xyzab-idle`, `xyzab-hog`: 5 axes (`config/machines/xyzab.toml`),
//!   `examples/five_axis_table.csv`;
//!
//! `-hog`: a busy thread (normal priority, writing through 4 MiB) pinned to the other CPU for
//! the whole scenario, bare runs included. `RT_BENCH_CYCLES` sets the cycles per run (default
//! 25 000 = 100 s at 4 ms).

mod bare;
mod cpu;
mod hog;
mod service;
mod stream;
mod table;
mod work;

use interpd::config::{Config, PrepMode};
use interpd::rt::{LoopTotals, sched::SchedReport, stats::CycleHistograms};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Cycles per run unless `RT_BENCH_CYCLES` says otherwise (100 s at 4 ms).
const DEFAULT_CYCLES: u64 = 25_000;
/// Fewest cycles that give a p99.9 at all.
const MIN_CYCLES: u64 = 1_000;
/// Tolerance of the smoothed dense program (G64 P0.01), mm.
const DENSE_TOLERANCE_MM: f64 = 0.01;

/// Which machine and program a scenario runs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Job {
    DenseXyz,
    TableXyzab,
}

/// A scenario of the benchmark.
#[derive(Debug, Clone, Copy)]
struct Scenario {
    name: &'static str,
    job: Job,
    hog: bool,
}

const SCENARIOS: [Scenario; 4] = [
    Scenario { name: "xyz-idle", job: Job::DenseXyz, hog: false },
    Scenario { name: "xyz-hog", job: Job::DenseXyz, hog: true },
    Scenario { name: "xyzab-idle", job: Job::TableXyzab, hog: false },
    Scenario { name: "xyzab-hog", job: Job::TableXyzab, hog: true },
];

/// Everything measured in one scenario.
pub struct Outcome {
    pub bare: CycleHistograms,
    pub bare_totals: LoopTotals,
    pub bare_sched: SchedReport,
    pub run: service::ServiceRun,
    pub hog: Option<hog::HogReport>,
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Configuration and program of a job, and a line saying what they are.
fn job(job: Job) -> (Config, PathBuf, String) {
    let root = root();
    match job {
        Job::DenseXyz => {
            let mut config = Config::load(&root.join("config/machines/xyz.toml")).expect("xyz.toml is valid");
            config.prep.mode = PrepMode::Smooth;
            config.prep.tolerance_mm = DENSE_TOLERANCE_MM;
            let what = format!("3 axes (xyz.toml), examples/dense_freeform.ngc, smoothed (G64 P{DENSE_TOLERANCE_MM})");
            (config, root.join("examples/dense_freeform.ngc"), what)
        }
        Job::TableXyzab => {
            let config = Config::load(&root.join("config/machines/xyzab.toml")).expect("xyzab.toml is valid");
            (
                config,
                root.join("examples/five_axis_table.csv"),
                "5 axes (xyzab.toml), examples/five_axis_table.csv".into(),
            )
        }
    }
}

fn histograms(runs: &[&bare::BareRun]) -> (CycleHistograms, LoopTotals) {
    let mut h = CycleHistograms::new();
    let mut totals = LoopTotals::default();
    for r in runs {
        r.samples.iter().for_each(|s| h.record(s));
        totals.cycles += r.totals.cycles;
        totals.late_cycles += r.totals.late_cycles;
        totals.overruns += r.totals.overruns;
        totals.samples_dropped += r.totals.samples_dropped;
    }
    (h, totals)
}

fn run_scenario(sc: &Scenario, cycles: u64, work_iters: u64) -> Result<(Outcome, String), String> {
    let (config, program, what) = job(sc.job);
    let period_ns = (config.machine.cycle_ms * 1e6).round() as u64;
    let other = cpu::other_cpu(&config.rt);
    let hog = sc.hog.then(|| hog::Hog::start(other));
    let before = bare::run(&config.rt, period_ns, cycles / 2, work_iters);
    let prefix = format!("interpd-bench/{}-{}", std::process::id(), sc.name);
    let monitor_priority = (config.rt.priority - 2).max(1);
    let run = service::run(config.clone(), &prefix, &program, cycles, other, monitor_priority);
    let after = bare::run(&config.rt, period_ns, cycles - cycles / 2, work_iters);
    let hog = hog.map(hog::Hog::stop);
    let run = run?;
    let (bare, bare_totals) = histograms(&[&before, &after]);
    Ok((Outcome { bare, bare_totals, bare_sched: before.sched, run, hog }, what))
}

fn kernel() -> String {
    let release = std::fs::read_to_string("/proc/sys/kernel/osrelease").unwrap_or_default();
    let rt = Path::new("/sys/kernel/realtime").exists();
    format!("{}{}", release.trim(), if rt { " (PREEMPT_RT)" } else { " (not PREEMPT_RT)" })
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

fn main() {
    let cycles = std::env::var("RT_BENCH_CYCLES")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .unwrap_or(DEFAULT_CYCLES)
        .max(MIN_CYCLES);
    let wanted = std::env::var("RT_BENCH_SCENARIOS").unwrap_or_default();
    let wanted: Vec<&str> = wanted.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
    let mut out = std::io::stdout().lock();
    if let Some(bad) = wanted.iter().find(|w| !SCENARIOS.iter().any(|s| s.name == **w)) {
        let names: Vec<&str> = SCENARIOS.iter().map(|s| s.name).collect();
        let _ = writeln!(out, "RT_BENCH_SCENARIOS: unknown scenario {bad:?}; known: {}", names.join(", "));
        std::process::exit(2);
    }
    let _ = writeln!(
        out,
        "real-time benchmark (release): {cycles} cycles per run; {} CPUs, kernel {}; load average {}",
        cpu::online(),
        kernel(),
        loadavg()
    );
    let work_iters = work::calibrate();
    let _ = writeln!(
        out,
        "bare loop cycle: {work_iters} dependent multiply-adds, calibrated to {} µs",
        work::WORK_TARGET_US
    );
    for sc in SCENARIOS.iter().filter(|s| wanted.is_empty() || wanted.contains(&s.name)) {
        let (outcome, what) = match run_scenario(sc, cycles, work_iters) {
            Ok(r) => r,
            Err(e) => {
                let _ = writeln!(out, "\n== {}: FAILED: {e}", sc.name);
                continue;
            }
        };
        let _ =
            writeln!(out, "\n== {}: {what}; {}", sc.name, if sc.hog { "CPU hog on the other core" } else { "no hog" });
        let s = &outcome.run.stream;
        let _ = writeln!(
            out,
            "  real-time thread: {}; subscriber: {}, {}; load average now {}",
            outcome.run.report.sched,
            s.pinned.as_ref().map_or_else(|e| format!("not pinned ({e})"), |c| format!("CPU {c}")),
            s.sched.as_ref().map_or_else(|e| format!("normal scheduling ({e})"), |p| format!("SCHED_FIFO {p}")),
            loadavg()
        );
        if outcome.bare_sched != outcome.run.report.sched {
            let _ = writeln!(out, "  bare loop thread: {} (differs!)", outcome.bare_sched);
        }
        if let Some(h) = &outcome.hog {
            let _ = writeln!(
                out,
                "  hog: {}, {:.0} passes over 4 MiB per s",
                h.pinned.as_ref().map_or_else(|e| format!("not pinned ({e})"), |c| format!("pinned to CPU {c}")),
                h.passes_per_s
            );
        }
        let _ = table::print(&mut out, &outcome);
        let _ = out.flush();
    }
}
