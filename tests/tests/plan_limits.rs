//! `interpd plan` on every example program and on machines with default, tight and loose
//! limits, checked from the outside: the CSV sampled at 0.25 ms is differentiated numerically
//! and every axis must stay within 1.001 × max_vel and max_acc and 1.02 × max_jerk. The 4 ms
//! setpoints must lie on the programmed geometry within 1 µm (checked against the shapes'
//! own equations, not the planner's path code).

use interpd_config::Config;
use interpd_e2e::{binary, repo_root};
use std::path::Path;
use std::process::Command;

struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
}

fn plan_csv(program: &str, machine: Option<&str>, period_ms: f64) -> (Csv, serde_json::Value) {
    plan_csv_with(program, machine, period_ms, &[])
}

/// [`plan_csv`] with further `interpd plan` arguments.
fn plan_csv_with(program: &str, machine: Option<&str>, period_ms: f64, extra: &[&str]) -> (Csv, serde_json::Value) {
    let out = std::env::temp_dir().join(format!(
        "interpd-plan-{}-{}-{}.csv",
        std::process::id(),
        Path::new(program).file_stem().and_then(|s| s.to_str()).unwrap_or("p"),
        machine.map_or("default".to_string(), |m| Path::new(m).file_stem().unwrap().to_string_lossy().into_owned())
    ));
    let mut cmd = Command::new(binary("interpd"));
    cmd.current_dir(repo_root())
        .args(["plan", program, "--json", "--period-ms"])
        .arg(period_ms.to_string())
        .arg("--out")
        .arg(&out)
        .args(extra);
    if let Some(m) = machine {
        cmd.args(["--machine", m]);
    }
    let res = cmd.output().expect("run interpd plan");
    assert!(res.status.success(), "{program} on {machine:?}: {}", String::from_utf8_lossy(&res.stderr));
    let json: serde_json::Value = serde_json::from_slice(&res.stdout).expect("plan --json output");
    let text = std::fs::read_to_string(&out).expect("read csv");
    std::fs::remove_file(&out).ok();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().expect("header").split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|x| x.parse::<f64>().expect("number")).collect()).collect();
    (Csv { header, rows }, json)
}

/// Largest |value| / limit per axis and quantity from finite differences of the positions.
fn fd_ratios(csv: &Csv, cfg: &Config) -> [f64; 3] {
    let dt = csv.rows[1][0] - csv.rows[0][0];
    let mut worst = [0.0f64; 3];
    for (k, axis) in cfg.axes.iter().enumerate() {
        let col = 5 + k;
        assert_eq!(csv.header[col], axis.name.to_string());
        let x: Vec<f64> = csv.rows.iter().map(|r| r[col]).collect();
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

const PROGRAMS: [&str; 9] = [
    "examples/circle_r10.ngc",
    "examples/corner_90.ngc",
    "examples/line_arc_line.ngc",
    "examples/staircase.ngc",
    "examples/zigzag.ngc",
    "examples/two_arcs.ngc",
    "examples/ellipse_g06.ngc",
    "examples/ellipse_natural.ngc",
    "examples/ellipse_g06_comp.ngc",
];

fn check_limits(program: &str, machine: Option<&str>) {
    check_limits_with(program, machine, &[]);
}

/// [`check_limits`] with further `interpd plan` arguments.
fn check_limits_with(program: &str, machine: Option<&str>, extra: &[&str]) -> serde_json::Value {
    let cfg = match machine {
        Some(m) => Config::load(&repo_root().join(m)).expect("machine"),
        None => Config::default_machine(),
    };
    let (csv, json) = plan_csv_with(program, machine, 0.25, extra);
    let [v, a, j] = fd_ratios(&csv, &cfg);
    assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "{program} on {machine:?}: vel {v:.5} acc {a:.5} jerk {j:.5}");
    // The planner's own report must agree that nothing exceeds the limits.
    let mr = &json["max_ratio"];
    for q in ["vel", "acc", "jerk"] {
        assert!(mr[q].as_f64().expect("ratio") <= 1.0 + 1e-9, "{program}: reported {q} ratio {}", mr[q]);
    }
    // The longest single planning call is part of the whole planning time.
    let (call_ms, plan_ms) =
        (json["plan_call_max_ms"].as_f64().expect("plan_call_max_ms"), json["plan_ms"].as_f64().expect("plan_ms"));
    assert!(call_ms > 0.0 && call_ms <= plan_ms, "{program}: longest call {call_ms} ms of {plan_ms} ms");
    // It ends at the program's end point, at rest.
    let last = csv.rows.last().expect("rows");
    assert!(last[2].abs() < 1e-9, "{program}: ends with v = {}", last[2]);
    json
}

#[test]
fn limits_hold_on_the_default_machine() {
    for p in PROGRAMS {
        check_limits(p, None);
    }
}

#[test]
fn limits_hold_on_a_tight_machine() {
    for p in PROGRAMS {
        check_limits(p, Some("tests/machines/xyz_tight.toml"));
    }
}

#[test]
fn limits_hold_on_a_loose_machine() {
    for p in PROGRAMS {
        check_limits(p, Some("tests/machines/xyz_loose.toml"));
    }
}

/// Online with short look-aheads on a dense G06 spline on `tests/machines/xyz_tight.toml`, horizons find no
/// continuation from the handed-over state and brake along the stop they kept before trying
/// again (`horizon_brakes`): the limits hold there too.
#[test]
fn limits_hold_online_with_a_short_look_ahead() {
    let mut text = String::from("G21 G90 G17\nG1 X40 Y0 F6000\nG06\n");
    for i in 1..=1000 {
        let u = i as f64 / 1000.0 * std::f64::consts::TAU;
        text += &format!("X{:.9} Y{:.9} Z0;\n", 40.0 * u.cos() + 8.0 * (3.0 * u).sin(), 30.0 * (2.0 * u).sin());
    }
    text += "\nM30\n";
    let program = std::env::temp_dir().join(format!("interpd-plan-limits-spline-{}.ngc", std::process::id()));
    std::fs::write(&program, text).expect("write program");
    let program = program.to_string_lossy().into_owned();
    let mut brakes = 0;
    for lookahead_mm in ["10", "30"] {
        let json =
            check_limits_with(&program, Some("tests/machines/xyz_tight.toml"), &["--lookahead-mm", lookahead_mm]);
        brakes += json["horizon_brakes"].as_u64().expect("horizon_brakes");
    }
    std::fs::remove_file(&program).ok();
    assert!(brakes > 0, "no horizon braked: the case no longer covers the fallback");
}

#[test]
fn limits_hold_on_the_five_axis_table() {
    for m in ["config/machines/xyzab.toml", "tests/machines/xyzab_tight.toml", "tests/machines/xyzab_loose.toml"] {
        check_limits("examples/five_axis_table.csv", Some(m));
    }
}

/// Distance from a point (x, y) to the programmed shape of each example, by its own equations.
fn distance_to_shape(program: &str, x: f64, y: f64) -> f64 {
    let seg = |ax: f64, ay: f64, bx: f64, by: f64| {
        let (dx, dy) = (bx - ax, by - ay);
        let t = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        (x - ax - t * dx).hypot(y - ay - t * dy)
    };
    let arc = |cx: f64, cy: f64, r: f64, from: f64, to: f64| {
        // Arc from angle `from` to `to` counter-clockwise; distance to the arc.
        let ang = (y - cy).atan2(x - cx);
        let norm = |a: f64| a.rem_euclid(std::f64::consts::TAU);
        let inside = norm(ang - from) <= norm(to - from) + 1e-12;
        if inside {
            ((x - cx).hypot(y - cy) - r).abs()
        } else {
            let (ax, ay) = (cx + r * from.cos(), cy + r * from.sin());
            let (bx, by) = (cx + r * to.cos(), cy + r * to.sin());
            (x - ax).hypot(y - ay).min((x - bx).hypot(y - by))
        }
    };
    use std::f64::consts::{FRAC_PI_2, PI};
    match program {
        "examples/circle_r10.ngc" => ((x + 10.0).hypot(y) - 10.0).abs(),
        "examples/corner_90.ngc" => seg(0.0, 0.0, 100.0, 0.0).min(seg(100.0, 0.0, 100.0, 100.0)),
        "examples/line_arc_line.ngc" => {
            seg(0.0, 0.0, 50.0, 0.0).min(arc(50.0, 20.0, 20.0, -FRAC_PI_2, 0.0)).min(seg(70.0, 20.0, 70.0, 70.0))
        }
        "examples/staircase.ngc" => {
            let p = [(0.0, 0.0), (40.0, 0.0), (40.0, 20.0), (60.0, 20.0), (60.0, 40.0), (80.0, 40.0), (80.0, 80.0)];
            p.windows(2).map(|w| seg(w[0].0, w[0].1, w[1].0, w[1].1)).fold(f64::INFINITY, f64::min)
        }
        "examples/two_arcs.ngc" => {
            arc(0.0, 20.0, 20.0, -FRAC_PI_2, 0.0).min(arc(30.0, 20.0, 10.0, PI, FRAC_PI_2 + PI).min(
                // the second arc is clockwise from (20,20) to (30,30) about (30,20): angles π → π/2
                arc(30.0, 20.0, 10.0, FRAC_PI_2, PI),
            ))
        }
        _ => unreachable!("no shape equation for {program}"),
    }
}

#[test]
fn setpoints_lie_on_the_programmed_geometry() {
    for program in [
        "examples/circle_r10.ngc",
        "examples/corner_90.ngc",
        "examples/line_arc_line.ngc",
        "examples/staircase.ngc",
        "examples/two_arcs.ngc",
    ] {
        let (csv, _) = plan_csv(program, None, 4.0);
        let mut worst = 0.0f64;
        for r in &csv.rows {
            worst = worst.max(distance_to_shape(program, r[5], r[6]));
            assert!(r[7].abs() < 1e-12, "{program}: Z moved");
        }
        assert!(worst <= 1e-3 * 1e-3 * 1e3, "{program}: setpoints {worst:.3e} mm off the geometry");
        assert!(worst <= 0.001, "{program}: {worst} mm");
    }
}

#[test]
fn spline_setpoints_lie_on_the_hermite_spans() {
    // Densely sampled spans P(u) of Huan, eq. 1–2 (with the corrected R₃), independent of the
    // planner's arc-length map; distance of every 4 ms setpoint to that polyline.
    let text = std::fs::read_to_string(repo_root().join("examples/ellipse_g06.ngc")).expect("read");
    let mut pts: Vec<(f64, f64)> = Vec::new();
    let mut tans: Vec<(f64, f64)> = Vec::new();
    let word = |line: &str, l: char| -> Option<f64> {
        let i = line.find(l)?;
        line[i + 1..].split([' ', ';']).next()?.parse().ok()
    };
    for line in text.lines() {
        if line.starts_with('(') {
            continue;
        }
        if line.starts_with("G0 ") {
            pts.push((word(line, 'X').unwrap(), word(line, 'Y').unwrap()));
        } else if line.contains("G06") {
            tans.push((word(line, 'I').unwrap(), word(line, 'J').unwrap()));
        } else if line.ends_with(';') {
            pts.push((word(line, 'X').unwrap(), word(line, 'Y').unwrap()));
            tans.push((word(line, 'P').unwrap(), word(line, 'Q').unwrap()));
        }
    }
    assert_eq!(pts.len(), 21);
    let mut poly = Vec::new();
    for i in 0..20 {
        let (a, b, ta, tb) = (pts[i], pts[i + 1], tans[i], tans[i + 1]);
        for k in 0..20_000 {
            let u = k as f64 / 20_000.0;
            let h = |p0: f64, p1: f64, t0: f64, t1: f64| {
                let r2 = 3.0 * (p1 - p0) - 2.0 * t0 - t1;
                let r3 = 2.0 * (p0 - p1) + t0 + t1;
                ((r3 * u + r2) * u + t0) * u + p0
            };
            poly.push((h(a.0, b.0, ta.0, tb.0), h(a.1, b.1, ta.1, tb.1)));
        }
    }
    let (csv, _) = plan_csv("examples/ellipse_g06.ngc", None, 4.0);
    let mut worst = 0.0f64;
    for r in &csv.rows {
        let (x, y) = (r[5], r[6]);
        // The program starts with a G0 from the origin to the first support point.
        let on_g0 = if y.abs() < 1e-12 && (0.0..=40.0).contains(&x) { 0.0 } else { f64::INFINITY };
        let d = poly.iter().map(|p| (p.0 - x).hypot(p.1 - y)).fold(on_g0, f64::min);
        worst = worst.max(d);
    }
    // Chord error of the dense polyline is < 1e-7 mm; the setpoints must be within 1 µm.
    assert!(worst <= 0.001, "spline setpoints {worst:.3e} mm off the spans");
}

/// Runs `interpd plan` on a program text and machine text written to temporary files:
/// (exit code, stdout, stderr).
fn plan_raw(name: &str, program: &str, machine: Option<&str>) -> (i32, String, String) {
    plan_raw_with(name, program, machine, &[])
}

/// [`plan_raw`] with further `interpd plan` arguments.
fn plan_raw_with(name: &str, program: &str, machine: Option<&str>, extra: &[&str]) -> (i32, String, String) {
    let dir = std::env::temp_dir().join(format!("interpd-plan-bad-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let prog = dir.join("p.ngc");
    std::fs::write(&prog, program).expect("write program");
    let mut cmd = Command::new(binary("interpd"));
    cmd.arg("plan").arg(&prog).arg("--json").args(extra);
    if let Some(m) = machine {
        let file = dir.join("m.toml");
        std::fs::write(&file, m).expect("write machine");
        cmd.arg("--machine").arg(&file);
    }
    let out = cmd.output().expect("run interpd plan");
    std::fs::remove_dir_all(&dir).ok();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `[prep] max_solve_ms` is the daemon's wall-clock guard on a window solve; `interpd plan`
/// applies it only with `--timed-solves`, so that a plan does not depend on the host's load. A
/// limit of 0 ms sends every window to the fallback when applied, and changes nothing when not.
#[test]
fn plan_applies_the_solve_time_limit_only_when_asked() {
    let machine = std::fs::read_to_string(repo_root().join("config/machines/xyz.toml")).expect("xyz.toml")
        + "\n[prep]\nmax_solve_ms = 0.0\n";
    let program = "G64 P0.01\nG1 X10 F3000\nG1 X10 Y10\nG1 X20 Y10\nG1 X20 Y20\n";
    let slow = |extra: &[&str]| {
        let (code, out, err) = plan_raw_with("timed", program, Some(&machine), extra);
        assert_eq!(code, 0, "stderr: {err}");
        let json: serde_json::Value = serde_json::from_str(&out).expect("json");
        (
            json["prep"]["stats"]["slow"].as_u64().expect("slow"),
            json["prep"]["stats"]["windows"].as_u64().expect("windows"),
        )
    };
    let (untimed, windows) = slow(&[]);
    assert!(windows > 0, "the program is smoothed");
    assert_eq!(untimed, 0, "no window solve is timed without --timed-solves");
    let (timed, _) = slow(&["--timed-solves"]);
    assert!(timed > 0, "with --timed-solves a limit of 0 ms stops the window solves");
}

#[test]
fn infeasible_requests_give_a_clear_error_and_no_nan() {
    let axis = |acc: &str| {
        format!(
            "[[axis]]\nname = \"X\"\nkind = \"linear\"\nmax_vel = 100\nmax_acc = {acc}\nmax_jerk = 10000\nmin = -1000\nmax = 1000\n\
             [[axis]]\nname = \"Y\"\nkind = \"linear\"\nmax_vel = 100\nmax_acc = 1000\nmax_jerk = 10000\nmin = -1000\nmax = 1000\n"
        )
    };
    // A limit of zero: refused with the key named, before any planning.
    let (code, out, err) = plan_raw("zero", "G1 X10 F600\n", Some(&format!("[machine]\n{}", axis("0"))));
    assert_eq!(code, 2, "stderr: {err}");
    assert!(err.contains("max_acc") && out.is_empty(), "stderr: {err}");
    // A feed the axes can never carry out in reasonable time (1e-7 mm/min over 10 mm).
    let (code, out, err) = plan_raw("slow", "G1 X10 F0.0000001\n", None);
    assert_eq!(code, 2, "stderr: {err}");
    assert!(err.contains("feed") && out.is_empty(), "stderr: {err}");
    // A feed far above what the axes can reach is capped, not an error: finite figures.
    let (code, out, err) = plan_raw("fast", "G1 X10 Y5 F9000000\nG2 X20 Y5 I5 J0\n", None);
    assert_eq!(code, 0, "stderr: {err}");
    assert!(!out.contains("NaN") && !out.contains("null"), "{out}");
    let json: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert!(json["duration_s"].as_f64().is_some_and(f64::is_finite), "{out}");
    for q in ["vel", "acc", "jerk"] {
        assert!(json["max_ratio"][q].as_f64().is_some_and(|r| r.is_finite() && r <= 1.0 + 1e-9), "{out}");
    }
}

/// `--export-nodes` gives the reference optimiser (benches/reference/optimum.py) the geometry
/// the planner's checks use between the nodes: on a path table each node's "span" (per axis
/// A′, A″, A‴ to the next node as polynomials in the interval fraction, 7 + 6 + 5
/// coefficients), which must start at the node's own A′…A‴ and end at the next node's; none
/// where the checks interpolate (a circle).
#[test]
fn the_node_export_carries_a_tables_exact_geometry() {
    let export = |program: &str, machine: Option<&str>| -> serde_json::Value {
        let file = std::env::temp_dir().join(format!("interpd-export-{}.json", std::process::id()));
        let mut cmd = Command::new(binary("interpd"));
        cmd.current_dir(repo_root()).args(["plan", program, "--export-nodes"]).arg(&file);
        if let Some(m) = machine {
            cmd.args(["--machine", m]);
        }
        let res = cmd.output().expect("run interpd plan");
        assert!(res.status.success(), "{program}: {}", String::from_utf8_lossy(&res.stderr));
        let json = serde_json::from_str(&std::fs::read_to_string(&file).expect("read export")).expect("JSON");
        std::fs::remove_file(&file).ok();
        json
    };
    let table = export("examples/five_axis_table.csv", Some("config/machines/xyzab.toml"));
    let nodes = table["nodes"].as_array().expect("nodes");
    let poly = |c: &[serde_json::Value], lo: usize, hi: usize, sigma: f64| -> f64 {
        c[lo..hi].iter().rev().fold(0.0, |acc, x| acc * sigma + x.as_f64().unwrap())
    };
    let mut checked = 0;
    for (i, pair) in nodes.windows(2).enumerate() {
        let span = pair[0]["span"].as_array().unwrap_or_else(|| panic!("node {i} has no span"));
        assert_eq!(span.len(), 5, "node {i}: one polynomial set per axis");
        for (k, c) in span.iter().enumerate() {
            let c = c.as_array().expect("coefficients");
            assert_eq!(c.len(), 18);
            for (sigma, side, node) in [(0.0, "right", &pair[0]), (1.0, "left", &pair[1])] {
                for (d, (lo, hi)) in ["d1", "d2", "d3"].iter().zip([(0, 7), (7, 13), (13, 18)]) {
                    let want = node[side][d][k].as_f64().unwrap();
                    let got = poly(c, lo, hi, sigma);
                    assert!(
                        (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
                        "node {i} axis {k} {d} at {sigma}: {got} vs {want}"
                    );
                }
            }
        }
        checked += 1;
    }
    assert!(checked > 1000, "{checked} intervals");
    // Intervals the nodes do not interpolate well are checked at the finer points.
    let fine = nodes.iter().filter(|n| n["fine"].as_bool().expect("a fine flag per node")).count();
    assert!(fine > 0 && fine < nodes.len(), "{fine} of {} nodes fine", nodes.len());
    assert_eq!(table["fine_check_fractions"].as_array().map(Vec::len), Some(7));
    let circle = export("examples/circle_r10.ngc", None);
    assert!(circle["nodes"].as_array().unwrap().iter().all(|n| n["span"].is_null()), "a circle has no spans");
}
