//! Read a part program, smooth it, plan it and print the figures: the motion library's whole
//! path from text to a feedrate profile through its front door, [`Feed`], without the daemon.
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

use interpd_motion::path::AxisDerivs;
use interpd_motion::{Feed, Settings};
use std::process::ExitCode;

/// Motion planned ahead of what is sampled, s: the look-ahead a machine would run behind.
const AHEAD_S: f64 = 0.5;
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

    // 2. The feed reads the program as the motion needs it; its errors carry file, line and
    //    column.
    let mut feed = Feed::builder(&settings).open_file(program_file).map_err(|e| e.to_string())?;

    // 3. Plan ahead, take the planned segments in time order and check every axis against its
    //    limits along them (chain rule of the path); drop the path the samples have passed.
    let mut peaks = vec![Peak::default(); settings.axes.len()];
    let (mut t_s, mut motion_s, mut segments) = (0.0, 0.0, 0u64);
    let mut d = AxisDerivs::default();
    while !feed.finished() {
        feed.plan(AHEAD_S).map_err(|e| e.to_string())?;
        while let Some(segment) = feed.pop_segment() {
            while t_s <= segment.t1_s() {
                let sample = segment.sample(t_s);
                let st = sample.state;
                if sample.at_start {
                    feed.path().eval(st.s_mm, &mut d);
                } else {
                    feed.path().eval_left(st.s_mm, &mut d);
                }
                for (k, peak) in peaks.iter_mut().enumerate() {
                    let [vel, acc, _] = d.axis_rates(k, st.v, st.a, st.j);
                    peak.vel = peak.vel.max(vel.abs());
                    peak.acc = peak.acc.max(acc.abs());
                }
                t_s += CHECK_PERIOD_S;
            }
            motion_s = segment.t1_s();
            segments += 1;
            feed.trim_before(segment.s0_mm);
        }
    }

    // 4. What was read, smoothed and planned.
    let summary = feed.summary().cloned().unwrap_or_default();
    let stats = feed.stats();
    let length_mm = feed.path().length_mm();
    println!(
        "{}: {} lines, {} blocks, {:.3} mm of path, axes {}",
        program_file.display(),
        summary.lines,
        summary.blocks,
        length_mm,
        settings.axis_names().join(" ")
    );
    if stats.prep.windows > 0 {
        println!(
            "smoothing: {} windows, {:.3} mm smoothed, in {:.1} ms",
            stats.prep.windows,
            stats.prep.smoothed_mm,
            stats.prep_s * 1e3
        );
    }
    println!(
        "plan: {motion_s:.4} s of motion ({:.1} mm/s mean), {segments} profile pieces, {} nodes, planned in {:.1} ms",
        length_mm / motion_s.max(f64::MIN_POSITIVE),
        stats.plan.nodes,
        stats.plan_s * 1e3
    );
    for (k, name) in settings.axis_names().iter().enumerate() {
        let axis = &settings.axes[k];
        println!(
            "  {name}: velocity {:.3}, acceleration {:.3} of the limit",
            peaks[k].vel / axis.max_vel_per_s,
            peaks[k].acc / axis.max_acc_per_s2
        );
    }
    Ok(())
}

/// Largest |velocity| and |acceleration| of one axis.
#[derive(Debug, Clone, Copy, Default)]
struct Peak {
    vel: f64,
    acc: f64,
}
