//! End to end: the parameter file (`[programs] parameter_file`, LinuxCNC's `.var` format) of
//! `interpd run`. A program's `G10 L2 P2 X5` is written to it at the program's end and the
//! restarted daemon has G55 at X5; `offsets.set` writes it too; a corrupt file keeps the
//! daemon from starting, naming the file and line, and nothing moves. The other persistent
//! values: a program's G28.1 and `G10 L2 P8 X5 R30` are written at its end (#5161 …, #5361,
//! #5370); the restarted daemon's next program goes to the stored G28 position and has G59.2
//! at X5 turned 30°; `offsets.set` of G59.3 with a rotation writes the file.

use interpd_e2e::daemon::{Client, Daemon};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);

/// A directory with a configuration (the embedded machine's file with a parameter file named
/// relative to it).
fn machine_dir(tag: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("interpd-param-file-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::read_to_string(interpd_e2e::repo_root().join("config/machines/xyz.toml")).unwrap();
    let config = dir.join("machine.toml");
    std::fs::write(&config, format!("{base}\n[programs]\nparameter_file = \"machine.var\"\n")).unwrap();
    (dir, config)
}

fn position(st: &Value) -> Vec<f64> {
    st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

fn run(c: &mut Client, program: &str) -> Value {
    c.ok("program.load", json!({"text": program, "name": "p"}));
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    st
}

/// When the parameter file was last written.
fn modified(dir: &Path) -> std::time::SystemTime {
    std::fs::metadata(dir.join("machine.var")).unwrap().modified().unwrap()
}

fn var(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("machine.var")).unwrap_or_default()
}

#[test]
fn a_programs_g10_l2_is_kept_across_a_restart_and_offsets_set_writes_the_file() {
    let (dir, config) = machine_dir("keep");
    let cfg = config.to_str().unwrap();
    let daemon = Daemon::start(&["--config", cfg]);
    let mut c = daemon.client();
    assert_eq!(c.ok("offsets.get", Value::Null)["offsets"]["G55"]["X"], 0.0);
    assert_eq!(var(&dir), "", "no file before anything is kept");

    // A program sets G55's X; at its end the file holds #5241 (G55 X) = 5.
    run(&mut c, "G10 L2 P2 X5\nG55 G0 X1 Y0\nM2\n");
    let text = var(&dir);
    assert!(text.lines().any(|l| l == "5241\t5.0"), "{text}");
    assert_eq!(c.ok("offsets.get", Value::Null)["offsets"]["G55"]["X"], 5.0);

    // offsets.set writes it too.
    c.ok("offsets.set", json!({"offsets": {"G56": {"Y": 2.5}}}));
    assert!(var(&dir).lines().any(|l| l == "5262\t2.5"), "{}", var(&dir));
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");

    // The restarted daemon has them.
    let daemon = Daemon::start(&["--config", cfg]);
    let mut c = daemon.client();
    let o = c.ok("offsets.get", Value::Null);
    assert_eq!((o["offsets"]["G55"]["X"].clone(), o["offsets"]["G56"]["Y"].clone()), (json!(5.0), json!(2.5)), "{o}");
    let st = run(&mut c, "G55 G0 X1 Y0\nM2\n");
    let at = position(&st);
    assert!((at[0] - 6.0).abs() < 1e-9 && at[1].abs() < 1e-9, "G55 X1 is machine X6: {at:?}");
    // A program that leaves the offsets as they are does not rewrite the file.
    let before = modified(&dir);
    run(&mut c, "G0 X0\nM2\n");
    assert_eq!(modified(&dir), before);
    drop(daemon);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_corrupt_parameter_file_keeps_the_daemon_from_starting() {
    let (dir, config) = machine_dir("corrupt");
    std::fs::write(dir.join("machine.var"), "5221\t0.000000\n5241\t5,5\n").unwrap();
    let socket = dir.join("control.sock");
    let mut child = Command::new(interpd_e2e::binary("interpd"))
        .arg("run")
        .arg("--config")
        .arg(&config)
        .arg("--socket")
        .arg(&socket)
        .arg("--service-prefix")
        .arg(format!("interpd-test/pf{}", std::process::id()))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start interpd run");
    let until = Instant::now() + TIMEOUT;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < until, "interpd run started with a corrupt parameter file");
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(2), "{stderr}");
    let want = format!(
        "parameter file {}:2: the value of #5241, \"5,5\", is not a finite number",
        dir.join("machine.var").display()
    );
    assert!(stderr.contains(&want), "{stderr}");
    assert!(!socket.exists(), "no control socket: nothing can move");
    // The file is left as it was.
    assert_eq!(var(&dir), "5221\t0.000000\n5241\t5,5\n");
    let _ = std::fs::remove_dir_all(&dir);
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
    let at = position(&run(&mut c, "G0 X12 Y34 Z5\nG28.1\nG10 L2 P8 X5 R30\nG0 X0 Y0 Z0\nM2\n"));
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
    let at = position(&run(&mut c, "G28\nM2\n"));
    assert!(near(&at, [12.0, 34.0, 5.0]), "G28 to the stored position: {at:?}");
    let at = position(&run(&mut c, "G59.2 G0 X1 Y0 Z0\nM2\n"));
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
    let stamp = modified(&dir);
    run(&mut c, "G28\nG28.1\nG59.2 G0 X0\nM2\n");
    assert_eq!(modified(&dir), stamp);
    drop(daemon);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_a_parameter_file_g28_goes_to_machine_zero_in_every_program() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    // The first program stores G28 at X7; the next one starts with it at 0 again.
    let at = position(&run(&mut c, "G0 X7 Y1\nG28.1\nG0 X0 Y0\nG28\nM2\n"));
    assert!(near(&at, [7.0, 1.0, 0.0]), "{at:?}");
    let at = position(&run(&mut c, "G0 X3\nG28\nM2\n"));
    assert!(near(&at, [0.0, 0.0, 0.0]), "{at:?}");
}
