//! `interpd otg`: the command-line contract run through the real binary: JSON with
//! `duration_s`, the CSV layout `t,p<i>,v<i>,a<i>,j<i>`, several DoFs separated by ';', the
//! velocity interface and asymmetric limits, and exit 2 with a message naming the option and
//! the value for bad input.

use std::path::PathBuf;
use std::process::{Command, Output};

fn otg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_interpd")).arg("otg").args(args).output().expect("run interpd")
}

fn json(args: &[&str]) -> serde_json::Value {
    let mut all = args.to_vec();
    all.push("--json");
    let out = otg(&all);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

fn duration(v: &serde_json::Value) -> f64 {
    v["duration_s"].as_f64().expect("duration_s")
}

fn temp_file(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("interpd-otg-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

#[test]
fn rest_to_rest_duration() {
    // 10 units with v, a, j = 1: ramps of 1 s, cruise 8 s.
    let v = json(&["--from", "0,0,0", "--to", "10,0,0", "--limits", "1,1,1"]);
    assert!((duration(&v) - 12.0).abs() < 1e-9, "{v}");
    assert_eq!(v["dofs"][0]["phases_s"].as_array().map(Vec::len), Some(7));
    // Without --json: a one-line summary first.
    let out = otg(&["--from", "0", "--to", "10", "--limits", "1,1,1"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("duration 12.000000000 s"));
}

#[test]
fn several_dofs_end_together() {
    let v = json(&["--from", "0,0,0;5,0.5,0;-1", "--to", "10,0,0;0,0,0;-1,0.2,0", "--limits", "1,1,1"]);
    assert!((duration(&v) - 12.0).abs() < 1e-9, "{v}");
    let dofs = v["dofs"].as_array().expect("dofs");
    assert_eq!(dofs.len(), 3);
    for (d, target) in dofs.iter().zip([[10.0, 0.0], [0.0, 0.0], [-1.0, 0.2]]) {
        let total: f64 = d["phases_s"].as_array().unwrap().iter().map(|t| t.as_f64().unwrap()).sum();
        assert!((total - 12.0).abs() < 1e-9, "{d}");
        let end = d["end"].as_array().unwrap();
        assert!((end[0].as_f64().unwrap() - target[0]).abs() < 1e-9, "{d}");
        assert!((end[1].as_f64().unwrap() - target[1]).abs() < 1e-9, "{d}");
    }
}

#[test]
fn csv_samples_the_motion() {
    let path = temp_file("two.csv");
    let out = otg(&[
        "--from",
        "0,0,0;1,0,0",
        "--to",
        "2,0,0;0,0,0",
        "--limits",
        "1,1,1;2,2,2",
        "--out",
        path.to_str().unwrap(),
        "--period-ms",
        "10",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&path).expect("csv");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,p0,v0,a0,j0,p1,v1,a1,j1"));
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|x| x.parse().expect("number")).collect()).collect();
    // 2 units with unit limits take 4 s: rows at 0, 0.01, ..., 4.00.
    assert_eq!(rows.len(), 401);
    assert_eq!(rows[0], vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, -2.0]);
    let last = rows.last().unwrap();
    assert!((last[0] - 4.0).abs() < 1e-9 && (last[1] - 2.0).abs() < 1e-9 && (last[5] - 0.0).abs() < 1e-9, "{last:?}");
    for (k, r) in rows.iter().enumerate() {
        assert!((r[0] - k as f64 * 0.01).abs() < 1e-12);
        for (dof, lim) in [(0, 1.0), (1, 2.0)] {
            let (v, a, j) = (r[2 + 4 * dof], r[3 + 4 * dof], r[4 + 4 * dof]);
            assert!(v.abs() <= lim * (1.0 + 1e-9) && a.abs() <= lim * (1.0 + 1e-9) && j.abs() <= lim, "{r:?}");
        }
    }
    // The positions are the integral of the velocities (trapezoid rule, 10 ms steps).
    for w in rows.windows(2) {
        let dp = w[1][1] - w[0][1];
        assert!((dp - 0.005 * (w[0][2] + w[1][2])).abs() < 1e-6, "{w:?}");
    }
    std::fs::remove_file(&path).ok();
}

#[test]
fn velocity_interface_and_asymmetric_limits() {
    // Velocity 2 → -0.5 with unit limits (outside: braked first): position free.
    let v = json(&["--from", "0,2,0", "--to", "0,-0.5,0", "--limits", "1,1,1", "--velocity"]);
    assert!((duration(&v) - 3.5).abs() < 1e-9, "{v}");
    assert!((v["dofs"][0]["end"][1].as_f64().unwrap() + 0.5).abs() < 1e-12, "{v}");
    // Moving down is slower with a tighter lower velocity limit.
    let sym = duration(&json(&["--from", "0", "--to", "-10", "--limits", "1,1,1"]));
    let asym = duration(&json(&["--from", "0", "--to", "-10", "--limits", "1,1,1", "--vmin", "-0.5"]));
    assert!((sym - 12.0).abs() < 1e-9 && asym > sym + 1.0, "{sym} {asym}");
}

/// Exit 2, nothing on stdout, and a message that names the option and quotes the value.
fn assert_bad(args: &[&str], option: &str, value: &str) {
    let out = otg(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(out.stdout.is_empty(), "{args:?}");
    assert!(stderr.contains(option) && stderr.contains(value), "{args:?}: {stderr}");
}

#[test]
fn bad_input_exits_2_naming_option_and_value() {
    assert_bad(&["--from", "0,0,0", "--to", "1,0,0", "--limits", "1,x,1"], "--limits", "\"x\"");
    assert_bad(&["--from", "0,0,0", "--to", "1,0,0", "--limits", "1,1"], "--limits", "\"1,1\"");
    assert_bad(&["--from", "0,nan,0", "--to", "1,0,0", "--limits", "1,1,1"], "--from", "\"nan\"");
    assert_bad(&["--from", "0;1", "--to", "1", "--limits", "1,1,1"], "--to", "1 DoFs");
    assert_bad(&["--from", "0", "--to", "1", "--limits", "1,1,-2"], "--limits", "j_max = -2");
    assert_bad(&["--from", "0", "--to", "1", "--limits", "1,1,1", "--vmin", "0.5"], "--vmin", "0.5");
    assert_bad(&["--from", "0", "--to", "1,3,0", "--limits", "1,1,1"], "--to", "velocity = 3");
    assert_bad(&["--from", "0", "--to", "1", "--limits", "1,1,1", "--sync", "fast"], "--sync", "\"fast\"");
    assert_bad(
        &["--from", "0", "--to", "1", "--limits", "1,1,1", "--out", "x.csv", "--period-ms", "0"],
        "--period-ms",
        "0",
    );
    assert_bad(&["--from", "0", "--to", "1", "--limits", "1,1,1", "--min-duration-s", "-1"], "minimum duration", "-1");
}
