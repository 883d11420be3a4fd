//! End to end: the rest of the persistent parameters of `interpd run`'s parameter file
//! (`[programs] parameter_file`): a program's G28.1 and `G10 L2 P8 X5 R30` are written to it
//! at the program's end (#5161 …, #5361, #5370); the restarted daemon's next program goes to
//! the stored G28 position and has G59.2 at X5 turned 30°; `offsets.get` shows G59.2 with its
//! rotation, and `offsets.set` of G59.3 with a rotation writes the file.

use interpd_e2e::daemon::{Client, Daemon};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

const TIMEOUT: Duration = Duration::from_secs(60);

/// A directory with a configuration (the embedded machine's file with a parameter file named
/// relative to it).
fn machine_dir(tag: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("interpd-param-persist-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::read_to_string(interpd_e2e::repo_root().join("config/machines/xyz.toml")).unwrap();
    let config = dir.join("machine.toml");
    std::fs::write(&config, format!("{base}\n[programs]\nparameter_file = \"machine.var\"\n")).unwrap();
    (dir, config)
}

fn run(c: &mut Client, program: &str) -> Vec<f64> {
    c.ok("program.load", json!({"text": program, "name": "p"}));
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

fn var(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("machine.var")).unwrap_or_default()
}

fn has_line(text: &str, n: u32, v: f64) -> bool {
    text.lines().any(|l| l == format!("{n}\t{v:?}"))
}

fn near(at: &[f64], want: [f64; 3]) -> bool {
    at.iter().zip(want).all(|(a, w)| (a - w).abs() < 1e-6)
}

#[test]
fn g28_1_and_g10_l2_r_of_a_program_survive_a_restart() {
    let (dir, config) = machine_dir("g28");
    let cfg = config.to_str().unwrap();
    let daemon = Daemon::start(&["--config", cfg]);
    let mut c = daemon.client();
    let o = c.ok("offsets.get", Value::Null);
    assert_eq!((o["offsets"]["G59.2"]["X"].clone(), o["rotations_deg"]["G59.2"].clone()), (json!(0.0), json!(0.0)));

    // Store G28 at (12, 34, 5), set G59.2 at X5 turned 30°, and move elsewhere.
    let at = run(&mut c, "G0 X12 Y34 Z5\nG28.1\nG10 L2 P8 X5 R30\nG0 X0 Y0 Z0\nM2\n");
    assert!(near(&at, [0.0, 0.0, 0.0]), "{at:?}");
    let text = var(&dir);
    for (n, v) in [(5161, 12.0), (5162, 34.0), (5163, 5.0), (5361, 5.0), (5370, 30.0)] {
        assert!(has_line(&text, n, v), "#{n} = {v} in the file:\n{text}");
    }
    let o = c.ok("offsets.get", Value::Null);
    assert_eq!((o["offsets"]["G59.2"]["X"].clone(), o["rotations_deg"]["G59.2"].clone()), (json!(5.0), json!(30.0)));
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");

    // The restarted daemon: offsets.get has G59.2, G28 goes to the stored point, G59.2 X1 is
    // 1 mm along the turned X axis from (5, 0).
    let daemon = Daemon::start(&["--config", cfg]);
    let mut c = daemon.client();
    let o = c.ok("offsets.get", Value::Null);
    assert_eq!(
        (o["offsets"]["G59.2"].clone(), o["rotations_deg"]["G59.2"].clone(), o["rotations_deg"]["G54"].clone()),
        (json!({"X": 5.0, "Y": 0.0, "Z": 0.0}), json!(30.0), json!(0.0)),
        "{o}"
    );
    let at = run(&mut c, "G28\nM2\n");
    assert!(near(&at, [12.0, 34.0, 5.0]), "G28 to the stored position: {at:?}");
    let at = run(&mut c, "G59.2 G0 X1 Y0 Z0\nM2\n");
    let (s, co) = 30f64.to_radians().sin_cos();
    assert!(near(&at, [5.0 + co, s, 0.0]), "G59.2 X1 turned 30° about (5, 0): {at:?}");

    // offsets.set of G59.3 with a rotation writes the file (#5381, #5390); a system named only
    // in offsets keeps its rotation.
    let before = var(&dir);
    let o = c.ok("offsets.set", json!({"offsets": {"G59.3": {"Y": -2.0}}, "rotations_deg": {"G59.3": -45.0}}));
    assert_eq!((o["offsets"]["G59.3"]["Y"].clone(), o["rotations_deg"]["G59.3"].clone()), (json!(-2.0), json!(-45.0)));
    let o = c.ok("offsets.set", json!({"offsets": {"G59.2": {"X": 5.0}}}));
    assert_eq!(o["rotations_deg"]["G59.2"], json!(30.0), "{o}");
    let text = var(&dir);
    assert!(has_line(&text, 5382, -2.0) && has_line(&text, 5390, -45.0), "{text}");
    assert_ne!(before, text);
    // An unknown system in rotations_deg is refused, naming it.
    let e = c.call("offsets.set", json!({"rotations_deg": {"G60": 1.0}}));
    assert_eq!(e["error"]["data"]["param"], "rotations_deg.G60", "{e}");

    // A program that leaves everything as it found it does not rewrite the file.
    let stamp = std::fs::metadata(dir.join("machine.var")).unwrap().modified().unwrap();
    run(&mut c, "G28\nG28.1\nG59.2 G0 X0\nM2\n");
    assert_eq!(std::fs::metadata(dir.join("machine.var")).unwrap().modified().unwrap(), stamp);
    drop(daemon);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_a_parameter_file_g28_goes_to_machine_zero_in_every_program() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    // The first program stores G28 at X7; the next one starts with it at 0 again.
    let at = run(&mut c, "G0 X7 Y1\nG28.1\nG0 X0 Y0\nG28\nM2\n");
    assert!(near(&at, [7.0, 1.0, 0.0]), "{at:?}");
    let at = run(&mut c, "G0 X3\nG28\nM2\n");
    assert!(near(&at, [0.0, 0.0, 0.0]), "{at:?}");
}
