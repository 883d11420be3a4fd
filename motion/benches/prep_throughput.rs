//! Figures of the tolerance-band smoothing (Haas 2012), printed, not asserted:
//! prep throughput against the programmed feed, window solve times, and motion time with
//! G64 against exact stops (G61) on the dense CAM program and the staircase.
//!
//! ```sh
//! cargo bench -p interpd-motion --bench prep_throughput                             # the full dense program
//! PREP_BENCH_SEGMENTS=5000 cargo bench -p interpd-motion --bench prep_throughput    # its first 5000 segments
//! PREP_BENCH_MACHINE=my.toml cargo bench -p interpd-motion --bench prep_throughput  # other limits or [prep] keys
//! ```

use interpd_motion::Settings;
use interpd_motion::path::{Feed, Path};
use interpd_motion::planner::Planner;
use interpd_motion::planner::profile::duration_s;
use interpd_motion::prep::prepare_path;
use interpd_motion::program;
use std::io::Write;
use std::time::Instant;

fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` (G61 or G64 P…) before its first G1 block.
fn with_mode(text: &str, word: &str, max_segments: usize) -> String {
    let mut out = String::new();
    let mut moves = 0;
    let mut inserted = false;
    for line in text.lines() {
        if !inserted && line.starts_with("G1") {
            out.push_str(word);
            out.push('\n');
            inserted = true;
        }
        if line.starts_with('X') {
            moves += 1;
            if moves > max_segments {
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// CPU time of this process, s (the machine may be shared: wall time alone understates a
/// stage that had the CPU only part of the time).
fn cpu_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec into the valid pointer we pass.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

fn parse(text: &str, config: &Settings) -> Path {
    program::parse(text, "bench.ngc", config).expect("program parses").path
}

fn plan_s(config: &Settings, path: &Path) -> (f64, f64) {
    let t0 = Instant::now();
    let (segments, _) = Planner::plan_path(config, path).expect("plans");
    (duration_s(&segments), t0.elapsed().as_secs_f64())
}

fn main() {
    let config = match std::env::var("PREP_BENCH_MACHINE") {
        Ok(file) => Settings::load(std::path::Path::new(&file)).expect("machine file"),
        Err(_) => Settings::default_machine(),
    };
    let mut out = std::io::stdout().lock();
    let max_segments = std::env::var("PREP_BENCH_SEGMENTS").ok().and_then(|v| v.parse().ok()).unwrap_or(usize::MAX);
    let dense = repo_file("examples/dense_freeform.ngc");

    // Dense CAM program: throughput of the stage alone, then motion time smoothed vs exact.
    let smooth = parse(&with_mode(&dense, "G64 P0.01", max_segments), &config);
    let exact = parse(&with_mode(&dense, "G61", max_segments), &config);
    let feed_mm_s = smooth
        .elements
        .iter()
        .find_map(|e| match e.feed {
            Feed::Programmed { mm_per_s } => Some(mm_per_s),
            Feed::Rapid => None,
        })
        .expect("a programmed feed");
    let cpu0 = cpu_s();
    let prepared = prepare_path(&config, &smooth).expect("smoothing");
    let cpu = cpu_s() - cpu0;
    let st = &prepared.stats;
    let rate = st.smoothed_mm / prepared.wall_s;
    writeln!(out, "dense_freeform, {} segments, G64 P0.01:", exact.elements.len().saturating_sub(1)).ok();
    writeln!(
        out,
        "  prep: {:.1} mm smoothed in {:.3} s wall ({:.3} s CPU) = {:.0} mm/s wall ({:.0} mm/s CPU); programmed feed \
         {:.0} mm/s; throughput / feed = {:.1} wall ({:.1} CPU)",
        st.smoothed_mm,
        prepared.wall_s,
        cpu,
        rate,
        st.smoothed_mm / cpu,
        feed_mm_s,
        rate / feed_mm_s,
        st.smoothed_mm / cpu / feed_mm_s
    )
    .ok();
    writeln!(
        out,
        "  windows {} (solves {}), window solve mean {:.3} ms, worst {:.3} ms, {:.1} iterations per solve; \
         fallbacks smaller/looser/exact {}/{}/{}, band retries {}; max checked deviation {:.5} mm",
        st.windows,
        st.solves,
        st.solve_s_mean() * 1e3,
        st.solve_s_max * 1e3,
        st.iterations as f64 / st.solves.max(1) as f64,
        st.fallback_smaller,
        st.fallback_looser,
        st.fallback_exact,
        st.verify_retries,
        st.max_deviation_mm
    )
    .ok();
    let (t_smooth, plan_smooth) = plan_s(&config, &prepared.path);
    let (t_exact, plan_exact) = plan_s(&config, &exact);
    writeln!(
        out,
        "  motion time: G64 P0.01 {t_smooth:.3} s ({} elements, planned in {plan_smooth:.2} s), G61 {t_exact:.3} s \
         (planned in {plan_exact:.2} s); exact / smoothed = {:.1}",
        prepared.path.elements.len(),
        t_exact / t_smooth
    )
    .ok();

    // Haas's shapes: smoothed / exact motion time (Haas 2012, Table 3.1, Treppe: 1.882 s /
    // 1.954 s), with the default [prep] (turns above max_corner_deg = 90° stay exact stops) and
    // with every corner smoothed.
    let mut all_corners = config.clone();
    all_corners.prep.max_corner_deg = 170.0;
    for name in ["staircase", "corner_90", "line_arc_line", "zigzag", "two_arcs"] {
        let text = repo_file(&format!("examples/{name}.ngc"));
        let (t_exact, _) = plan_s(&config, &parse(&with_mode(&text, "G61", usize::MAX), &config));
        for (label, cfg) in [("default", &config), ("all corners", &all_corners)] {
            for tol in ["0.01", "0.1"] {
                let p = prepare_path(cfg, &parse(&with_mode(&text, &format!("G64 P{tol}"), usize::MAX), cfg))
                    .expect("smoothing");
                let (t, _) = plan_s(cfg, &p.path);
                writeln!(
                    out,
                    "{name:>14} G64 P{tol:<4} ({label:>11}): {t:.4} s vs G61 {t_exact:.4} s, smoothed / exact = \
                     {:.3} ({:+.1} %); window solve mean {:.3} ms, worst {:.3} ms; fallbacks exact {}",
                    t / t_exact,
                    (t / t_exact - 1.0) * 100.0,
                    p.stats.solve_s_mean() * 1e3,
                    p.stats.solve_s_max * 1e3,
                    p.stats.fallback_exact
                )
                .ok();
            }
        }
    }
}
