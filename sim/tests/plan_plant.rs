//! `interpd plan --plant`: the simulated plant in-process on the planned setpoints, adding
//! per-axis plant columns to the CSV and plant figures to the JSON. interpd hands the command
//! to interpd-sim beside it, so every test here runs through both binaries.

use interpd_e2e::{binary, example};
use std::process::Command;

fn run(args: &[&str]) -> (Option<i32>, String, String) {
    run_binary(&binary("interpd"), args)
}

fn run_binary(exe: &std::path::Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(exe).args(args).output().expect("run the binary");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn read_csv(path: &std::path::Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("csv written");
    let mut lines = text.lines();
    let header = lines.next().expect("header").split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|x| x.parse::<f64>().expect("number")).collect()).collect();
    (header, rows)
}

#[test]
fn plant_columns_follow_the_planned_setpoints() {
    let dir = std::env::temp_dir().join(format!("interpd-plan-plant-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (plain_csv, plant_csv) = (dir.join("plain.csv"), dir.join("plant.csv"));
    let program = example("circle_r10.ngc");
    let program = program.to_str().unwrap();
    let (code, _, err) = run(&["plan", program, "--out", plain_csv.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let (code, json, err) =
        run(&["plan", program, "--out", plant_csv.to_str().unwrap(), "--json", "--plant=schneider-stiff"]);
    assert_eq!(code, Some(0), "{err}");

    let (h0, rows0) = read_csv(&plain_csv);
    let (h1, rows1) = read_csv(&plant_csv);
    // The planned columns are unchanged; four plant columns per axis follow them.
    assert_eq!(&h1[..h0.len()], &h0[..]);
    let extra: Vec<&str> = h1[h0.len()..].iter().map(String::as_str).collect();
    assert_eq!(&extra[..4], &["X_motor", "X_load", "X_following_error", "X_load_error"]);
    assert_eq!(extra.len(), 12);
    assert_eq!(rows0.len(), rows1.len());
    let col = |name: &str| h1.iter().position(|h| h == name).unwrap();
    let (x, xm, xl, xfe, xle) =
        (col("X"), col("X_motor"), col("X_load"), col("X_following_error"), col("X_load_error"));
    for (r0, r1) in rows0.iter().zip(&rows1) {
        assert_eq!(&r1[..h0.len()], &r0[..]);
        // Consistent columns: errors are setpoint minus motor / load.
        assert!((r1[x] - r1[xm] - r1[xfe]).abs() < 1e-9 && (r1[x] - r1[xl] - r1[xle]).abs() < 1e-9);
        // The stiff axis follows the 10 mm circle within a few tenths of a millimetre
        // (backlash 0.228 mm plus elastic lag).
        assert!(r1[xle].abs() < 0.5, "load error {} mm at t = {}", r1[xle], r1[0]);
    }
    let max_fe = rows1.iter().map(|r| r[xfe].abs()).fold(0.0, f64::max);
    assert!(max_fe > 1e-4 && max_fe < 0.1, "following error {max_fe} mm");

    let v: serde_json::Value = serde_json::from_str(json.trim()).expect("json");
    let plant = &v["plant"];
    assert_eq!(plant["presets"][0], "schneider-stiff");
    assert!((plant["max_following_error"][0].as_f64().unwrap() - max_fe).abs() < 1e-12);
    assert!(plant["max_contour_error_mm"].as_f64().unwrap() > 0.0);
    assert!(plant["residual_vibration"][0].as_f64().is_some(), "settling simulated after the end: {plant}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plant_option_errors_exit_2_and_name_the_option() {
    let program = example("circle_r10.ngc");
    let (code, _, err) = run(&["plan", program.to_str().unwrap(), "--plant=nope"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--plant: nope: neither a plant preset"), "{err}");
    // Without a value: the machine's own [plant] section (the default machine: haas-laser).
    let (code, out, err) = run(&["plan", program.to_str().unwrap(), "--plant"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("haas-laser") && out.contains("contour error"), "{out}");
}

#[test]
fn interpd_hands_the_plant_to_interpd_sim_with_its_arguments() {
    let dir = std::env::temp_dir().join(format!("interpd-plan-plant-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let program = example("circle_r10.ngc");
    let program = program.to_str().unwrap();
    let mut csv = Vec::new();
    for exe in ["interpd", "interpd-sim"] {
        let out = dir.join(format!("{exe}.csv"));
        let (code, text, err) =
            run_binary(&binary(exe), &["plan", program, "--plant=schneider-soft", "--out", out.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{exe}: {err}");
        assert!(text.contains("schneider-soft") && text.contains("contour error"), "{exe}: {text}");
        csv.push(std::fs::read(&out).expect("csv written"));
    }
    assert!(csv[0] == csv[1], "interpd plan --plant and interpd-sim plan --plant differ");
    let _ = std::fs::remove_dir_all(&dir);
}

/// interpd without interpd-sim beside it: what needs the plant in-process fails and says what
/// is missing, where it was looked for and how to build it; the rest of interpd works.
#[test]
fn without_interpd_sim_the_plant_commands_say_what_is_missing() {
    let dir = std::env::temp_dir().join(format!("interpd-alone-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lone = dir.join("interpd");
    std::fs::copy(binary("interpd"), &lone).expect("copy interpd");
    let program = example("circle_r10.ngc");
    let program = program.to_str().unwrap();
    let looked_for = dir.join("interpd-sim");
    for (args, what) in [
        (vec!["plan", program, "--plant=schneider-stiff", "--json"], "`interpd plan --plant`"),
        (vec!["demo", "--scenario", "milling-circle"], "`interpd demo --scenario`"),
    ] {
        let (code, out, err) = run_binary(&lone, &args);
        assert_eq!(code, Some(1), "{args:?}: {out}\n{err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        for want in [what, "interpd-sim not found", looked_for.to_str().unwrap(), "`cargo build --release`"] {
            assert!(err.contains(want), "{args:?}: the message lacks {want:?}: {err}");
        }
    }
    let (code, out, err) = run_binary(&lone, &["plan", program, "--json"]);
    assert_eq!(code, Some(0), "plan without the plant: {err}");
    assert!(out.contains("\"duration_s\"") && !out.contains("\"plant\""), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}
