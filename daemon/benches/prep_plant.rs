//! Exact stop vs smoothed on the Haas axis plant (Haas 2012, §3.6.4, §5.3): the programmed
//! motion of the 90° corner and the staircase, sampled every cycle, drives the 3-mass axes of
//! `config/plants/haas-laser.toml` (with crosstalk); printed are the lateral deviation of the
//! setpoints and of the TCP (load) from the programmed path, and the excitation metric, the
//! TCP's deviation minus the setpoints' own deviation at each instant.
//!
//! ```sh
//! cargo bench -p interpd --bench prep_plant
//! ```

use interpd::config::Config;
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::Planner;
use interpd_motion::planner::profile::{Cursor, duration_s};
use interpd_motion::prep::prepare_path;
use interpd_motion::program;
use sim_plant::{AxisTarget, Plant};
use std::io::Write;

fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` before its first G1 block.
fn with_mode(text: &str, word: &str) -> String {
    let mut out = String::new();
    let mut inserted = false;
    for line in text.lines() {
        if !inserted && line.starts_with("G1") {
            out.push_str(word);
            out.push('\n');
            inserted = true;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Distance of (x, y) to the programmed polyline (these shapes are lines only).
fn distance(corners: &[(f64, f64)], x: f64, y: f64) -> f64 {
    corners
        .windows(2)
        .map(|w| {
            let ((ax, ay), (bx, by)) = (w[0], w[1]);
            let (dx, dy) = (bx - ax, by - ay);
            let t = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            (x - ax - t * dx).hypot(y - ay - t * dy)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Settling time simulated after the motion ends, s.
const SETTLE_S: f64 = 0.2;

struct Figures {
    duration_s: f64,
    setpoint_max_mm: f64,
    load_max_mm: f64,
    excitation_max_mm: f64,
    excitation_rms_mm: f64,
}

fn simulate(config: &Config, path: &Path, corners: &[(f64, f64)]) -> Figures {
    let (segments, _) = Planner::plan_path(&Settings::from(config), path).expect("plans");
    let duration = duration_s(&segments);
    let mut plant = Plant::from_config(config).expect("plant");
    let n = path.n_axes;
    let cycle = config.cycle_s();
    let mut cursor = Cursor::default();
    let mut d = AxisDerivs::default();
    let (mut sp_max, mut load_max, mut ex_max, mut ex_sq, mut count) = (0.0f64, 0.0f64, 0.0f64, 0.0, 0usize);
    let steps = ((duration + SETTLE_S) / cycle).ceil() as usize;
    let mut targets = vec![AxisTarget::default(); n];
    for k in 0..=steps {
        let t = k as f64 * cycle;
        let Some(sample) = cursor.sample(&segments, t) else { break };
        let st = sample.state;
        if sample.at_start {
            path.eval(st.s_mm, &mut d)
        } else {
            path.eval_left(st.s_mm, &mut d)
        }
        for (i, tg) in targets.iter_mut().enumerate() {
            *tg = AxisTarget { pos: d.pos[i], vel: d.d1[i] * st.v, acc: d.d2[i] * st.v * st.v + d.d1[i] * st.a };
        }
        let out = plant.advance_to((t * 1e9).round() as u64, &targets).expect("plant step");
        let sp = distance(corners, d.pos[0], d.pos[1]);
        let load = distance(corners, out[0].load_pos, out[1].load_pos);
        sp_max = sp_max.max(sp);
        load_max = load_max.max(load);
        ex_max = ex_max.max((load - sp).abs());
        ex_sq += (load - sp) * (load - sp);
        count += 1;
    }
    Figures {
        duration_s: duration,
        setpoint_max_mm: sp_max,
        load_max_mm: load_max,
        excitation_max_mm: ex_max,
        excitation_rms_mm: (ex_sq / count.max(1) as f64).sqrt(),
    }
}

fn main() {
    let text = format!(
        "{}\n[plant]\npreset = \"haas-laser\"\napply_crosstalk = true\n",
        interpd::config::DEFAULT_MACHINE_TOML
    );
    let config = Config::from_toml_str(&text, "<default machine, haas-laser plant>").expect("machine");
    let mut out = std::io::stdout().lock();
    let shapes: [(&str, Vec<(f64, f64)>); 2] = [
        ("corner_90", vec![(0.0, 0.0), (100.0, 0.0), (100.0, 100.0)]),
        (
            "staircase",
            vec![(0.0, 0.0), (40.0, 0.0), (40.0, 20.0), (60.0, 20.0), (60.0, 40.0), (80.0, 40.0), (80.0, 80.0)],
        ),
    ];
    for (name, corners) in &shapes {
        let source = repo_file(&format!("examples/{name}.ngc"));
        for mode in ["G61", "G64 P0.1", "G64 P0.01"] {
            let path =
                program::parse(&with_mode(&source, mode), "bench.ngc", &Settings::from(&config)).expect("parses").path;
            let path = prepare_path(&Settings::from(&config), &path).expect("smoothing").path;
            let f = simulate(&config, &path, corners);
            writeln!(
                out,
                "{name:>10} {mode:<9}: {:.4} s; lateral deviation max: setpoints {:.4} mm, TCP {:.4} mm; \
                 excitation (TCP − setpoint deviation) max {:.5} mm, rms {:.5} mm",
                f.duration_s, f.setpoint_max_mm, f.load_max_mm, f.excitation_max_mm, f.excitation_rms_mm
            )
            .ok();
        }
    }
}
