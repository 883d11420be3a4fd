//! `interpd demo`: the main job on the embedded defaults. Starts `interpd run` and `sim-plant`
//! as two processes talking over iceoryx2 (a service prefix of their own), runs the embedded
//! example program through the control socket, and prints a summary: motion time, following
//! and contour error of the simulated plant, residual vibration, the real-time loop's wake-up
//! latency; the plant writes a PNG plot.

use super::CliError;
use interpd::demo::{DemoArgs, Pair};
use serde_json::Value;
use std::path::Path;
use std::time::{Duration, Instant};

/// The embedded program.
const DEMO_PROGRAM: &str = include_str!("../../../examples/demo.ngc");

pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    // The scenarios (--scenario) run in interpd-sim (cli/mod.rs hands them over).
    if args.json {
        return Err(CliError::BadInput("--json goes with --scenario".into()));
    }
    let (program_text, program_name) = match &args.program {
        Some(p) => (
            std::fs::read_to_string(p).map_err(|e| CliError::BadInput(format!("--program {}: {e}", p.display())))?,
            p.display().to_string(),
        ),
        None => (DEMO_PROGRAM.to_string(), "demo.ngc".to_string()),
    };
    let plot = std::path::absolute(&args.plot).map_err(|e| CliError::BadInput(format!("--plot: {e}")))?;
    let dir = std::env::temp_dir().join(format!("interpd-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::Failure(format!("{}: {e}", dir.display())))?;
    let started = Instant::now();
    let pair = Pair { dir: dir.clone(), machine: None, plot: Some(plot.clone()), trace: None };
    let (status, summary, motion_s) = pair.run("interpd-demo", &program_text, &program_name, true)?;
    print_summary(&status, &summary, motion_s, &plot, started.elapsed());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[allow(clippy::print_stdout)]
fn print_summary(status: &Value, plant: &Value, motion_s: f64, plot: &Path, wall: Duration) {
    let um = |v: &Value| v.as_f64().map_or("n/a".to_string(), |x| format!("{:.2} µm", x * 1e3));
    println!(
        "interpd demo: {} finished in {:.2} s of motion ({:.1} s wall)",
        status["program"]["name"].as_str().unwrap_or("program"),
        motion_s,
        wall.as_secs_f64()
    );
    println!(
        "  setpoints received by the plant: {}, missed cycles: {}",
        plant["setpoints_received"], plant["missed_cycles"]
    );
    if let Some(axes) = plant["axes"].as_array() {
        for a in axes {
            println!(
                "  axis {} ({}): max following error {}, max load error {}",
                a["name"].as_str().unwrap_or("?"),
                a["preset"].as_str().unwrap_or("?"),
                um(&a["max_following_error"]),
                um(&a["max_load_error"]),
            );
            println!("    after the motion end: {}", settling_text(a));
        }
    }
    println!("  max contour error (load side): {}", um(&plant["max_contour_error"]));
    let w = &status["cycles"]["wakeup_us"];
    println!(
        "  real-time loop: wake-up latency p50 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs; {} late cycles",
        w["p50"].as_f64().unwrap_or(0.0),
        w["p999"].as_f64().unwrap_or(0.0),
        w["max"].as_f64().unwrap_or(0.0),
        status["cycles"]["late"]
    );
    println!("  plot: {}", plot.display());
}

/// Settling and vibration after the motion end, apart: a decay is settling (time, overshoot),
/// an oscillation (a spectral peak) is vibration (amplitude, frequency).
fn settling_text(a: &Value) -> String {
    let um = |v: &Value| v.as_f64().map_or("n/a".to_string(), |x| format!("{:.2} µm", x * 1e3));
    let window = a["settling_window_s"].as_f64().unwrap_or(0.0);
    if a["settling_band"].is_null() {
        return "no standstill recorded".to_string();
    }
    let settle = match a["settling_time_s"].as_f64() {
        Some(t) => format!("settled in {t:.3} s within ±{}", um(&a["settling_band"])),
        None => format!("still settling after {window:.2} s (band ±{})", um(&a["settling_band"])),
    };
    let vib = match (a["vibration_amplitude"].as_f64(), a["vibration_hz"].as_f64()) {
        (Some(x), Some(f)) => format!("residual vibration {:.2} µm at {f:.1} Hz", x * 1e3),
        _ => "residual vibration none (no spectral peak)".to_string(),
    };
    format!("{settle}, overshoot {}, {vib}", um(&a["overshoot"]))
}
