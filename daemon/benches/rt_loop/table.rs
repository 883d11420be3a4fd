//! The printed figures of one scenario, and the real-time targets checked against them
//! (docs/realtime.md).

use super::Outcome;
use interpd_protocol::api::Percentiles;
use std::io::Write;

/// interpd's wake-up quantiles may exceed the bare loop's by this factor …
pub const WAKEUP_RATIO_TARGET: f64 = 1.1;
/// … plus this much, µs.
pub const WAKEUP_SLACK_US: f64 = 20.0;
/// Cycle compute time p99.9 target, µs (5 axes).
pub const COMPUTE_P999_TARGET_US: f64 = 50.0;
/// Shared-memory publish → receive p99 target, µs.
pub const SHM_P99_TARGET_US: f64 = 50.0;

fn quantiles(p: &Percentiles) -> [f64; 4] {
    [p.p50, p.p99, p.p999, p.max]
}

fn met(ok: bool) -> &'static str {
    if ok { "met" } else { "MISSED" }
}

/// Whether interpd's wake-up quantile `ours` is within the target of the bare loop's `bare`.
pub fn wakeup_within(ours: f64, bare: f64) -> bool {
    ours <= WAKEUP_RATIO_TARGET * bare + WAKEUP_SLACK_US
}

/// Prints the block of one scenario.
pub fn print(out: &mut impl Write, o: &Outcome) -> std::io::Result<()> {
    let run = &o.run;
    let (bare, ours) = (quantiles(&o.bare.wakeup_us()), quantiles(&run.report.histograms.wakeup_us()));
    let row = |out: &mut dyn Write, label: &str, v: [String; 4]| {
        writeln!(out, "  {label:<26}{:>10}{:>10}{:>10}{:>10}", v[0], v[1], v[2], v[3])
    };
    let f = |x: [f64; 4], fmt: &dyn Fn(f64) -> String| x.map(fmt);
    writeln!(out, "  {:<26}{:>10}{:>10}{:>10}{:>10}", "wake-up latency [µs]", "p50", "p99", "p99.9", "max")?;
    row(out, "bare loop", f(bare, &|v| format!("{v:.1}")))?;
    row(out, "interpd", f(ours, &|v| format!("{v:.1}")))?;
    let ratio: [f64; 4] = std::array::from_fn(|i| ours[i] / bare[i]);
    let diff: [f64; 4] = std::array::from_fn(|i| ours[i] - bare[i]);
    let target: [f64; 4] = std::array::from_fn(|i| WAKEUP_RATIO_TARGET * bare[i] + WAKEUP_SLACK_US);
    row(out, "ratio interpd/bare", f(ratio, &|v| format!("{v:.3}")))?;
    row(out, "difference [µs]", f(diff, &|v| format!("{v:+.1}")))?;
    row(out, "target 1.1×bare+20 µs", f(target, &|v| format!("{v:.1}")))?;
    let within: [String; 4] = std::array::from_fn(|i| met(wakeup_within(ours[i], bare[i])).to_string());
    row(out, "interpd within target", within)?;

    let (bare_c, ours_c) = (quantiles(&o.bare.compute_us()), quantiles(&run.report.histograms.compute_us()));
    writeln!(out, "  {:<26}{:>10}{:>10}{:>10}{:>10}", "cycle compute [µs]", "p50", "p99", "p99.9", "max")?;
    row(out, "bare loop (fixed work)", f(bare_c, &|v| format!("{v:.1}")))?;
    row(out, "interpd", f(ours_c, &|v| format!("{v:.1}")))?;
    row(out, "ratio interpd/bare", f(std::array::from_fn(|i| ours_c[i] / bare_c[i]), &|v| format!("{v:.3}")))?;
    writeln!(
        out,
        "  interpd compute p99.9 {:.1} µs: target ≤ {COMPUTE_P999_TARGET_US} µs {}; the fixed work's p99.9 / p50 {:.2}",
        ours_c[2],
        met(ours_c[2] <= COMPUTE_P999_TARGET_US),
        bare_c[2] / bare_c[0]
    )?;
    let (bt, t) = (&o.bare_totals, &run.report.totals);
    writeln!(
        out,
        "  late cycles: bare {} of {} ({} overruns), interpd {} of {} ({} overruns)",
        bt.late_cycles, bt.cycles, bt.overruns, t.late_cycles, t.cycles, t.overruns
    )?;

    let s = &run.stream;
    let complete = s.complete(t.cycles) && s.late_flagged == t.late_cycles;
    writeln!(
        out,
        "  setpoint stream: {} received for cycles {}..={}, {} missing, {} repeated, {} not for their own time, \
         {} flagged LATE (loop counted {}): {}",
        s.received,
        s.first_cycle.map_or("-".into(), |c| c.to_string()),
        s.last_cycle.map_or("-".into(), |c| c.to_string()),
        s.missing + t.cycles.saturating_sub(s.last_cycle.map_or(0, |c| c + 1)),
        s.repeated,
        s.wrong_time,
        s.late_flagged,
        t.late_cycles,
        if complete { "every cycle exactly once, each for its own time" } else { "INCOMPLETE" }
    )?;
    let us = |q: f64| s.latency_ns.value_at_quantile(q) as f64 / 1e3;
    if s.latency_ns.is_empty() {
        writeln!(out, "  shared memory publish → receive: no timed samples")?;
    } else {
        writeln!(
            out,
            "  shared memory publish → receive [µs]: p50 {:.1}, p99 {:.1}, p99.9 {:.1}, max {:.1} over {} samples \
             ({} already waiting, not timed)  (target p99 ≤ {SHM_P99_TARGET_US} µs: {})",
            us(0.5),
            us(0.99),
            us(0.999),
            s.latency_ns.max() as f64 / 1e3,
            s.latency_ns.len(),
            s.latency_unseen,
            met(us(0.99) <= SHM_P99_TARGET_US)
        )?;
    }
    let fe = &run.report.feeder;
    let published: Vec<String> = run
        .report
        .publishers
        .iter()
        .map(|p| format!("{} published, {} dropped, {} failed", p.published, p.dropped, p.failed))
        .collect();
    writeln!(
        out,
        "  service: program started {}×, {} underruns, {} errors; {} chunks, planner {:.2} s; shm {}; {:.1} s wall",
        run.program_starts,
        run.underruns,
        run.errors.len(),
        fe.chunks,
        fe.plan_time_s,
        published.join("; "),
        run.wall_s
    )?;
    for e in run.errors.iter().take(3) {
        writeln!(out, "    error: {e}")?;
    }
    Ok(())
}
