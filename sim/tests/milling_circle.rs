//! `interpd demo --scenario milling-circle`: interpd hands it to interpd-sim, which identifies
//! the deflection model on the plant in-process and mills the circle once per strategy.

use interpd_e2e::binary;
use std::process::Command;

/// `interpd demo --scenario milling-circle --json`: the circle of Schneider 2016, Tab. 5.1 per
/// compensation strategy (about a minute: four 44 s circles in real time, side by side). Checks
/// the figures the thesis's remedies are measured by: the uncompensated error of the order of
/// the thesis's, every strategy reducing it at least as much as there and in the thesis's order,
/// and the fast actuator giving a smoother surface than position control through the axes.
#[test]
fn milling_circle_scenario_reports_every_strategy() {
    let dir = std::env::temp_dir().join(format!("interpd-milling-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(binary("interpd"))
        .args(["demo", "--scenario", "milling-circle", "--json"])
        .current_dir(&dir)
        .output()
        .expect("run the scenario");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the scenario failed:\n{stdout}\n{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("JSON on stdout");
    let s = v["strategies"].as_array().expect("strategies");
    let names: Vec<&str> = s.iter().map(|x| x["name"].as_str().unwrap_or("?")).collect();
    assert_eq!(names, ["none", "deflection", "position", "position+actuator"]);
    let f = |i: usize, k: &str| s[i][k].as_f64().unwrap_or(f64::NAN);
    let none = f(0, "mae_um");
    assert!((150.0..=600.0).contains(&none), "uncompensated MAE {none} µm");
    // Schneider 2016, Tab. 5.1: −22.7 %, −81.5 %, −87.4 % against uncompensated.
    for (i, least) in [(1, 0.227), (2, 0.815), (3, 0.874)] {
        assert!(1.0 - f(i, "mae_um") / none >= least, "{}: MAE {} µm against {none}", names[i], f(i, "mae_um"));
    }
    let mae: Vec<f64> = (0..4).map(|i| f(i, "mae_um")).collect();
    assert!(mae[0] > mae[1] && mae[1] > mae[2] && mae[2] > mae[3], "order of the MAE: {mae:?}");
    let (position, actuator) = (f(2, "surface_std_um"), f(3, "surface_std_um"));
    assert!(actuator < position, "surface with the actuator {actuator} µm against {position} µm");
    eprintln!("{stdout}");
    let png = std::fs::read(dir.join("interpd-milling-circle.png")).expect("the polar plot");
    assert!(png.starts_with(b"\x89PNG"), "not a plot");
    let _ = std::fs::remove_dir_all(&dir);
}
