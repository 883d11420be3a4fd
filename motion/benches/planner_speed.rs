//! Planner speed, printed as figures (not pass/fail):
//! `cargo bench -p interpd-motion --bench planner_speed`.
//!
//! - The example programs (the five-axis path table, circle R10, line–arc–line): plan
//!   time of the online planner as the daemon runs it (elements pushed one by one, default
//!   look-ahead), best and median of several runs, wall clock and the thread's CPU time
//!   (the machine is shared; CPU time is what the planner itself costs).
//! - G06 natural splines of 10 000, 50 000 and 150 000 support points: samples (support
//!   points) per second and planner nodes per second, and the plan time per point relative
//!   to the 10 000-point run measured in the same run (1.0 = linear growth).
//!
//! `PLANNER_BENCH_REPS` sets the repetitions for the examples (default 20),
//! `PLANNER_BENCH_SIZES` the spline sizes (default `10000,50000,150000`).

use interpd_motion::Settings;
use interpd_motion::path::Path;
use interpd_motion::planner::{PlanStats, Planner, profile};
use std::io::Write;
use std::time::Instant;

/// CPU time of the calling thread, s.
fn thread_cpu_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec to the valid pointer it is given.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// One online planning run: wall s, CPU s, motion time s, stats; or the planning error.
fn plan_once(cfg: &Settings, path: &Path) -> Result<(f64, f64, f64, PlanStats), String> {
    let (w0, c0) = (Instant::now(), thread_cpu_s());
    let mut planner = Planner::new(cfg);
    let mut segments = Vec::new();
    for e in &path.elements {
        planner.push(e.clone());
        segments.extend(planner.plan().map_err(|e| e.to_string())?);
    }
    planner.finish(path.final_dwell_s);
    segments.extend(planner.plan().map_err(|e| e.to_string())?);
    if !planner.done() {
        return Err("the planner did not finish".into());
    }
    let (wall, cpu) = (w0.elapsed().as_secs_f64(), thread_cpu_s() - c0);
    Ok((wall, cpu, profile::duration_s(&segments), planner.stats))
}

fn best_and_median(mut x: Vec<f64>) -> (f64, f64) {
    x.sort_by(f64::total_cmp);
    (x[0], x[x.len() / 2])
}

/// A G06 natural spline through `points` support points on a smooth closed figure (a
/// Lissajous-like curve, one turn per 10 000 points, so the points lie ~0.036 mm apart at
/// every size), written to 1 nm: rounding to 1 µm at this spacing makes the natural spline's
/// A‴ noisy (that is the job of path smoothing, not of the planner).
fn spline_program(points: usize) -> String {
    let mut t = String::with_capacity(points * 32);
    t += "G21 G90 G17\nG1 X40 Y0 F6000\nG06\n";
    let turns = (points as f64 / 10_000.0).max(1.0);
    for i in 1..=points {
        let u = i as f64 / points as f64 * std::f64::consts::TAU * turns;
        let (x, y) = (40.0 * u.cos() + 8.0 * (3.0 * u).sin(), 30.0 * (2.0 * u).sin());
        t += &format!("X{x:.9} Y{y:.9} Z0;\n");
    }
    t + "\nM30\n"
}

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let reps: usize = std::env::var("PLANNER_BENCH_REPS").ok().and_then(|s| s.parse().ok()).unwrap_or(20).max(1);
    let sizes: Vec<usize> = std::env::var("PLANNER_BENCH_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10_000, 50_000, 150_000]);
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "planner speed (release), {reps} runs each; wall and thread CPU time, best / median");
    let examples: [(&str, Settings); 3] = [
        ("examples/five_axis_table.csv", Settings::five_axis_machine()),
        ("examples/circle_r10.ngc", Settings::default_machine()),
        ("examples/line_arc_line.ngc", Settings::default_machine()),
    ];
    for (file, cfg) in &examples {
        let prog = interpd_motion::program::load(&root.join(file), cfg).expect("example parses");
        let rows = prog.path.elements.len();
        let (mut walls, mut cpus) = (Vec::new(), Vec::new());
        let mut last = None;
        for _ in 0..reps {
            let (w, c, d, st) = plan_once(cfg, &prog.path).expect("the example plans");
            walls.push(w);
            cpus.push(c);
            last = Some((d, st));
        }
        let (d, st) = last.expect("at least one run");
        let (wb, wm) = best_and_median(walls);
        let (cb, cm) = best_and_median(cpus);
        let _ = writeln!(
            out,
            "{file}: {rows} elements, {} nodes, motion {d:.4} s; plan wall {:.2} / {:.2} ms, cpu {:.2} / {:.2} ms; \
             {:.1} evaluations and {:.1} ramp nodes per node",
            st.nodes,
            wb * 1e3,
            wm * 1e3,
            cb * 1e3,
            cm * 1e3,
            st.work.evals as f64 / st.nodes as f64,
            st.work.ramp_nodes as f64 / st.nodes as f64,
        );
    }
    let cfg = Settings::default_machine();
    let mut base: Option<f64> = None;
    for &n in &sizes {
        let text = spline_program(n);
        let t_parse = Instant::now();
        let prog = interpd_motion::program::parse(&text, "bench.ngc", &cfg).expect("spline parses");
        let parse_s = t_parse.elapsed().as_secs_f64();
        let (wall, cpu, d, st) = match plan_once(&cfg, &prog.path) {
            Ok(r) => r,
            Err(e) => {
                let _ = writeln!(out, "G06 spline {n} points: FAILED: {e}");
                continue;
            }
        };
        let per_point = cpu / n as f64;
        let ratio = base.map_or(1.0, |b| per_point / b);
        base.get_or_insert(per_point);
        let _ = writeln!(
            out,
            "G06 spline {n} points: {} nodes, motion {d:.2} s; plan wall {:.1} ms, cpu {:.1} ms (parse {:.1} ms); \
             {:.0} samples/s, {:.0} nodes/s (cpu); time per point vs {} points: {ratio:.2}; \
             {:.1} evaluations and {:.1} ramp nodes per node",
            st.nodes,
            wall * 1e3,
            cpu * 1e3,
            parse_s * 1e3,
            n as f64 / cpu,
            st.nodes as f64 / cpu,
            sizes[0],
            st.work.evals as f64 / st.nodes as f64,
            st.work.ramp_nodes as f64 / st.nodes as f64,
        );
    }
}
