//! Parse a part program, smooth it, plan it and print the figures: the motion library's whole
//! path from text to a feedrate profile, without the daemon.
//!
//! ```sh
//! cargo run --release -p interpd-motion --example plan_program -- examples/circle_r10.ngc
//! cargo run --release -p interpd-motion --example plan_program -- \
//!     examples/five_axis_table.csv config/machines/xyzab.toml
//! ```
//!
//! The first argument is the program (G-code or a path table), the optional second one a
//! machine file (default: the embedded 3-axis machine).

#![allow(clippy::print_stdout)] // printing the figures is what the example is for

use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::profile::{Cursor, duration_s};
use interpd_motion::planner::{Planner, Segment};
use interpd_motion::{prep, program};
use std::process::ExitCode;
use std::time::Instant;

/// Sampling period of the limit check, s (a quarter of the default 4 ms cycle).
const CHECK_PERIOD_S: f64 = 0.25e-3;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(program_file) = args.first() else {
        eprintln!("usage: plan_program PROGRAM [MACHINE.toml]");
        return ExitCode::from(2);
    };
    match run(std::path::Path::new(program_file), args.get(1).map(std::path::Path::new)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{message}");
            ExitCode::from(2)
        }
    }
}

fn run(program_file: &std::path::Path, machine: Option<&std::path::Path>) -> Result<(), String> {
    // 1. The machine: axes with their limits, planner and smoothing settings.
    let settings = match machine {
        Some(file) => Settings::load(file).map_err(|e| e.to_string())?,
        None => Settings::default_machine(),
    };

    // 2. The program: parse errors carry file, line and column.
    let program = program::load(program_file, &settings).map_err(|e| e.to_string())?;
    println!(
        "{}: {} lines, {} blocks, {} elements, {:.3} mm of path, axes {}",
        program_file.display(),
        program.summary.lines,
        program.summary.blocks,
        program.path.elements.len(),
        program.path.length_mm(),
        settings.axis_names().join(" ")
    );

    // 3. Tolerance smoothing of G64 runs (a program without G64 comes back unchanged).
    let prepared = prep::prepare_path(&settings, &program.path).map_err(|e| e.to_string())?;
    if prepared.stats.windows > 0 {
        println!(
            "smoothing: {} windows, {:.3} mm smoothed, in {:.1} ms",
            prepared.stats.windows,
            prepared.stats.smoothed_mm,
            prepared.wall_s * 1e3
        );
    }

    // 4. The look-ahead planner, fed element by element as the daemon's look-ahead thread does.
    let t0 = Instant::now();
    let mut planner = Planner::new(&settings);
    let mut segments: Vec<Segment> = Vec::new();
    for element in &prepared.path.elements {
        planner.push(element.clone());
        segments.extend(planner.plan().map_err(|e| e.to_string())?);
    }
    planner.finish(prepared.path.final_dwell_s);
    while !planner.done() {
        segments.extend(planner.plan().map_err(|e| e.to_string())?);
    }
    let plan_ms = t0.elapsed().as_secs_f64() * 1e3;
    let motion_s = duration_s(&segments);
    println!(
        "plan: {motion_s:.4} s of motion ({:.1} mm/s mean), {} profile pieces, {} nodes, planned in {plan_ms:.1} ms",
        prepared.path.length_mm() / motion_s.max(f64::MIN_POSITIVE),
        segments.len(),
        planner.stats.nodes
    );

    // 5. Every axis against its limits, sampled along the profile (chain rule of the path).
    let peaks = axis_peaks(&prepared.path, &segments);
    for (k, name) in settings.axis_names().iter().enumerate() {
        let axis = &settings.axes[k];
        println!(
            "  {name}: velocity {:.3}, acceleration {:.3} of the limit",
            peaks[k].0 / axis.max_vel_per_s,
            peaks[k].1 / axis.max_acc_per_s2
        );
    }
    Ok(())
}

/// Peak |velocity| and |acceleration| per axis: Ȧ = A′v and Ä = A″v² + A′a at every
/// `CHECK_PERIOD_S`.
fn axis_peaks(path: &Path, segments: &[Segment]) -> Vec<(f64, f64)> {
    let mut peaks = vec![(0.0_f64, 0.0_f64); path.n_axes];
    let mut cursor = Cursor::default();
    let mut d = AxisDerivs::default();
    let steps = (duration_s(segments) / CHECK_PERIOD_S).ceil() as usize;
    for i in 0..=steps {
        let Some(sample) = cursor.sample(segments, i as f64 * CHECK_PERIOD_S) else { break };
        let st = sample.state;
        if sample.at_start {
            path.eval(st.s_mm, &mut d);
        } else {
            path.eval_left(st.s_mm, &mut d);
        }
        for (k, peak) in peaks.iter_mut().enumerate() {
            peak.0 = peak.0.max((d.d1[k] * st.v).abs());
            peak.1 = peak.1.max((d.d2[k] * st.v * st.v + d.d1[k] * st.a).abs());
        }
    }
    peaks
}
