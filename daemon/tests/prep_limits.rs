//! `interpd plan` on smoothed programs (G64 P<tol>), checked from the outside like
//! tests/tests/plan_limits.rs: the CSV sampled at 0.25 ms is differentiated numerically and
//! every axis must stay within 1.001 × max_vel and max_acc and 1.02 × max_jerk. Also the motion
//! time with smoothing against exact stops on the dense CAM program (first 5000 segments here;
//! the full program is in `cargo bench -p interpd-motion --bench prep_throughput`).

use interpd::config::Config;
use std::process::Command;

// The programmed path as a polyline, shared with the plant benches.
#[path = "../benches/common/reference.rs"]
#[allow(dead_code)]
mod reference;

fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` before its first G1 block, cut after `max_moves` coordinate lines.
fn with_mode(text: &str, word: &str, max_moves: usize) -> String {
    let (mut out, mut moves, mut inserted) = (String::new(), 0, false);
    for line in text.lines() {
        if !inserted && line.starts_with("G1") {
            out.push_str(word);
            out.push('\n');
            inserted = true;
        }
        if line.starts_with('X') {
            moves += 1;
            if moves > max_moves {
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Runs `interpd plan` on `text`; returns the CSV rows (if `period_ms`) and the JSON summary.
fn plan(tag: &str, text: &str, period_ms: Option<f64>, machine: Option<&str>) -> (Vec<Vec<f64>>, serde_json::Value) {
    let dir = std::env::temp_dir();
    let prog = dir.join(format!("interpd-prep-{}-{tag}.ngc", std::process::id()));
    let csv = dir.join(format!("interpd-prep-{}-{tag}.csv", std::process::id()));
    std::fs::write(&prog, text).expect("write program");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_interpd"));
    cmd.arg("plan").arg(&prog).arg("--json");
    let machine_file = dir.join(format!("interpd-prep-{}-{tag}.toml", std::process::id()));
    if let Some(m) = machine {
        std::fs::write(&machine_file, m).expect("write machine");
        cmd.arg("--machine").arg(&machine_file);
    }

    if let Some(p) = period_ms {
        cmd.arg("--period-ms").arg(p.to_string()).arg("--out").arg(&csv);
    }
    let out = cmd.output().expect("run interpd plan");
    std::fs::remove_file(&prog).ok();
    std::fs::remove_file(&machine_file).ok();
    assert!(out.status.success(), "{tag}: {}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let rows = if period_ms.is_some() {
        let text = std::fs::read_to_string(&csv).expect("csv");
        std::fs::remove_file(&csv).ok();
        text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().expect("number")).collect()).collect()
    } else {
        Vec::new()
    };
    (rows, json)
}

/// Largest |value| / limit per quantity from finite differences of the axis positions.
fn fd_ratios(rows: &[Vec<f64>], cfg: &Config) -> [f64; 3] {
    let dt = rows[1][0] - rows[0][0];
    let mut worst = [0.0f64; 3];
    for (k, axis) in cfg.axes.iter().enumerate() {
        let x: Vec<f64> = rows.iter().map(|r| r[5 + k]).collect();
        for i in 1..x.len().saturating_sub(2) {
            let v = (x[i + 1] - x[i]) / dt;
            let a = (x[i + 1] - 2.0 * x[i] + x[i - 1]) / (dt * dt);
            let j = (x[i + 2] - 3.0 * x[i + 1] + 3.0 * x[i] - x[i - 1]) / (dt * dt * dt);
            worst[0] = worst[0].max(v.abs() / axis.max_vel_per_s);
            worst[1] = worst[1].max(a.abs() / axis.max_acc_per_s2);
            worst[2] = worst[2].max(j.abs() / axis.max_jerk_per_s3);
        }
    }
    worst
}

fn check_limits(name: &str, tol: &str) -> [f64; 3] {
    let cfg = Config::default_machine();
    let text = with_mode(&repo_file(&format!("examples/{name}.ngc")), &format!("G64 P{tol}"), usize::MAX);
    // Smooth every corner of the shapes (the default leaves turns above 90° exact).
    let machine = format!("{}\n[prep]\nmax_corner_deg = 170.0\n", interpd::config::DEFAULT_MACHINE_TOML);
    let (rows, json) = plan(&format!("{name}-{tol}"), &text, Some(0.25), Some(&machine));
    let r = fd_ratios(&rows, &cfg);
    eprintln!(
        "{name:>14} P{tol}: {:.4} s; finite differences vel {:.4} acc {:.4} jerk {:.4}; planner's report {}",
        json["duration_s"].as_f64().unwrap(),
        r[0],
        r[1],
        r[2],
        json["max_ratio"]
    );
    r
}

const SHAPES: [&str; 5] = ["corner_90", "line_arc_line", "staircase", "zigzag", "two_arcs"];

#[test]
fn smoothed_shapes_keep_the_axis_limits() {
    for name in SHAPES {
        for tol in ["0.01", "0.1"] {
            let [v, a, j] = check_limits(name, tol);
            assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "{name} P{tol}: vel {v:.5} acc {a:.5} jerk {j:.5}");
        }
    }
}

#[test]
fn dense_slice_is_5x_faster_smoothed_and_keeps_the_limits() {
    let cfg = Config::default_machine();
    let dense = repo_file("examples/dense_freeform.ngc");
    let (rows, smooth) = plan("dense-g64", &with_mode(&dense, "G64 P0.01", 5000), Some(0.25), None);
    let (_, exact) = plan("dense-g61", &with_mode(&dense, "G61", 5000), None, None);
    let (t_s, t_e) = (smooth["duration_s"].as_f64().unwrap(), exact["duration_s"].as_f64().unwrap());
    let [v, a, j] = fd_ratios(&rows, &cfg);
    eprintln!(
        "dense (5000 segments): G64 P0.01 {t_s:.3} s, G61 {t_e:.3} s, exact / smoothed {:.1}; finite differences \
         vel {v:.4} acc {a:.4} jerk {j:.4}; prep {}",
        t_e / t_s,
        smooth["prep"]
    );
    assert!(t_e >= 5.0 * t_s, "smoothing must make the dense program ≥ 5x faster: {t_s} vs {t_e}");
    assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "vel {v:.5} acc {a:.5} jerk {j:.5}");
}

/// Largest distance of the setpoints (CSV rows) from the programmed path of `text`, X/Y, mm.
fn setpoint_distance(rows: &[Vec<f64>], text: &str) -> f64 {
    let settings = interpd_motion::Settings::from(&Config::default_machine());
    let path = interpd_motion::program::parse(text, "p.ngc", &settings).expect("parses").path;
    let reference = reference::Reference::new(&path);
    rows.iter().map(|r| reference.distance(r[5], r[6])).fold(0.0, f64::max)
}

#[test]
fn hermite_pieces_of_degree_7_and_9_keep_the_band_and_the_axis_limits() {
    let cfg = Config::default_machine();
    for name in ["corner_90", "line_arc_line"] {
        let source = repo_file(&format!("examples/{name}.ngc"));
        for degree in [3, 4] {
            for tol in ["0.01", "0.1"] {
                let text = with_mode(&source, &format!("G64 P{tol}"), usize::MAX);
                let machine = format!(
                    "{}\n[prep]\ncontinuity_degree = {degree}\nhermite_continuity = {degree}\n",
                    interpd::config::DEFAULT_MACHINE_TOML
                );
                let (rows, json) = plan(&format!("{name}-h{degree}-{tol}"), &text, Some(0.25), Some(&machine));
                let [v, a, j] = fd_ratios(&rows, &cfg);
                let dev = setpoint_distance(&rows, &source);
                eprintln!(
                    "{name:>14} Hermite C{degree} P{tol}: {:.4} s; setpoints {dev:.6} mm from the path; finite \
                     differences vel {v:.4} acc {a:.4} jerk {j:.4}",
                    json["duration_s"].as_f64().unwrap(),
                );
                let tol_mm: f64 = tol.parse().unwrap();
                assert!(dev <= tol_mm + 1e-3, "{name} Hermite C{degree} P{tol}: {dev} mm off the path");
                assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "{name} P{tol}: vel {v:.5} acc {a:.5} jerk {j:.5}");
            }
        }
    }
}

#[test]
fn bspline_method_keeps_the_band_and_the_axis_limits() {
    let cfg = Config::default_machine();
    for name in ["corner_90", "line_arc_line"] {
        let source = repo_file(&format!("examples/{name}.ngc"));
        for degree in [2, 3, 4] {
            for tol in ["0.01", "0.1"] {
                // The method chosen in the program (G64 Q2); the degree in the machine file.
                let text = with_mode(&source, &format!("G64 P{tol} Q2"), usize::MAX);
                let machine =
                    format!("{}\n[prep]\ncontinuity_degree = {degree}\n", interpd::config::DEFAULT_MACHINE_TOML);
                let (rows, json) = plan(&format!("{name}-bs{degree}-{tol}"), &text, Some(0.25), Some(&machine));
                let [v, a, j] = fd_ratios(&rows, &cfg);
                let dev = setpoint_distance(&rows, &source);
                let stats = &json["prep"]["stats"];
                eprintln!(
                    "{name:>14} B-spline {degree} P{tol}: {:.4} s; setpoints {dev:.6} mm from the path; finite \
                     differences vel {v:.4} acc {a:.4} jerk {j:.4}; spline windows {}, Hermite instead {}",
                    json["duration_s"].as_f64().unwrap(),
                    stats["bspline_windows"],
                    stats["bspline_to_hermite"]
                );
                assert!(stats["bspline_windows"].as_u64().unwrap() > 0, "{name}: the B-spline was not used");
                let tol_mm: f64 = tol.parse().unwrap();
                assert!(dev <= tol_mm + 1e-3, "{name} B-spline {degree} P{tol}: {dev} mm off the path");
                assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "{name} P{tol}: vel {v:.5} acc {a:.5} jerk {j:.5}");
            }
        }
    }
}
