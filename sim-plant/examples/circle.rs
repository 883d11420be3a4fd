//! The in-process plant API on a circle: configure a machine, feed 4 ms setpoints, accumulate
//! metrics, print the summary and write the plot.
//!
//! ```sh
//! cargo run --release -p sim-plant --example circle -- [PRESET] [OUT.png]
//! ```
//!
//! PRESET (default `schneider-soft`) is the model of the linear axes of the embedded XYZ
//! machine; the program is a Ø70 mm circle in XY (the milled circle of Schneider 2016, Tab. 5.1,
//! here at 100 mm/s instead of 300 mm/min), started and stopped with a jerk-limited path-speed profile,
//! followed by 1.5 s of standstill for the residual vibration.
#![allow(clippy::print_stdout)]

use interpd_config::Config;
use sim_plant::metrics::Metrics;
use sim_plant::plot::{self, PlotOptions};
use sim_plant::scenario::SCurve;
use sim_plant::{AxisTarget, Plant};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let preset = args.next().unwrap_or_else(|| "schneider-soft".to_string());
    let out = PathBuf::from(args.next().unwrap_or_else(|| "circle.png".to_string()));

    let text = format!("{}\n[plant]\npreset = \"{preset}\"\n", interpd_config::DEFAULT_MACHINE_TOML);
    let config = Config::from_toml_str(&text, "<xyz>")?;
    let mut plant = Plant::from_config(&config)?;
    let cycle_s = config.cycle_s();
    let mut metrics = Metrics::new(&plant, (config.plant.record_s / cycle_s) as usize);

    // Path speed along s ∈ [0, 2πr]: 100 mm/s, 1000 mm/s², 20000 mm/s³; the circle starts at
    // 12 o'clock and runs counter-clockwise, as in Schneider 2016, Tab. 5.1.
    let r = 35.0;
    let profile = SCurve::new(0.0, 2.0 * std::f64::consts::PI * r, 100.0, 1000.0, 20_000.0);
    let duration_s = profile.duration_s() + 1.5;
    let n = (duration_s / cycle_s).ceil() as usize;
    for k in 0..=n {
        let (s, v, a) = profile.eval(k as f64 * cycle_s);
        // Angle from 12 o'clock: x = −r sin φ, y = r cos φ with φ = s/r (chain rule for v, a).
        let (sin, cos) = (s / r).sin_cos();
        let x = AxisTarget { pos: -r * sin, vel: -v * cos, acc: -a * cos + v * v / r * sin };
        let y = AxisTarget { pos: r * cos - r, vel: -v * sin, acc: -a * sin - v * v / r * cos };
        let z = AxisTarget::default();
        // The first step places the plant at rest at its targets.
        plant.step(&[x, y, z], cycle_s)?;
        metrics.record_plant(&plant);
    }
    print!("{}", metrics.summary());
    let options =
        PlotOptions { title: format!("Ø70 mm circle at 100 mm/s, preset {preset}"), ..PlotOptions::default() };
    plot::write_png(&out, &metrics, &options)?;
    println!("plot: {}", out.display());
    Ok(())
}
