//! End to end: manual motion of `interpd run` as a real process over the control socket —
//! `motion.move_to`, `motion.jog` (continuous, by a distance, changed while moving, towards a
//! soft limit with the simulated plant), `mdi`, a jog from a held program and `motion.resume`
//! back to it — the setpoints received over iceoryx2 and checked: no gaps, axis limits by
//! finite differences of the 4 ms positions, the move-to's duration against `interpd otg`, no
//! overshoot of the soft limit (commanded and the plant's load), and bad input refused.

use interpd::config::Config;
use interpd_e2e::binary;
use interpd_e2e::daemon::{AxisLimits, Client, Collector, Daemon, FeedbackCollector, limit_ratios};
use interpd_protocol::shm::{Setpoints, flags};
use serde_json::{Value, json};
use std::process::{Command, Stdio};
use std::time::Duration;

const TIMEOUT: Duration = Duration::from_secs(30);

/// No gaps and every axis limit kept (velocity, acceleration ×1.001, jerk ×1.02).
fn check_limits(name: &str, config: &Config, sps: &[Setpoints]) -> [f64; 4] {
    assert!(sps.len() > 10, "{name}: only {} setpoints", sps.len());
    for w in sps.windows(2) {
        assert_eq!(w[1].cycle, w[0].cycle + 1, "{name}: gap in cycle numbers");
    }
    let r = limit_ratios(config.cycle_s(), &AxisLimits::of(config), sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02 && r[3] <= 1.001, "{name}: limit ratios {r:?}");
    eprintln!("{name}: {} setpoints, limit ratios v/a/j/a_reported {r:.4?}", sps.len());
    r
}

/// Setpoints in motion (any axis velocity not zero).
fn moving(sps: &[Setpoints]) -> usize {
    sps.iter().filter(|s| s.vel.iter().any(|v| v.abs() > 1e-9)).count()
}

fn wait_done(c: &mut Client) -> Value {
    c.wait_event("jog_done", TIMEOUT);
    c.wait_state(&["idle", "holding"], TIMEOUT)
}

/// `status.position` equals `want` to 1e-9 per axis.
fn assert_near(pos: &Value, want: &[f64]) {
    for (k, w) in want.iter().enumerate() {
        let got = pos[k].as_f64().expect("a position");
        assert!((got - w).abs() < 1e-9, "axis {k} at {got}, not {w}: {pos}");
    }
}

fn pause(ms: u64) {
    std::thread::sleep(Duration::from_millis(ms));
}

/// `interpd otg --json` for the same problem: its duration, s.
fn otg_duration(from: &str, to: &str, limits: &str) -> f64 {
    let out = Command::new(binary("interpd"))
        .args(["otg", "--from", from, "--to", to, "--limits", limits, "--json"])
        .stderr(Stdio::inherit())
        .output()
        .expect("interpd otg");
    assert!(out.status.success(), "interpd otg failed");
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    v["duration_s"].as_f64().expect("duration_s")
}

/// The 0.25 ms samples of `interpd otg --out` keep the limits of each DoF.
fn otg_samples_keep_limits(from: &str, to: &str, lims: &[(f64, f64, f64)]) {
    let dir = std::env::temp_dir().join(format!("interpd-manual-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("move.csv");
    let spec: Vec<String> = lims.iter().map(|(v, a, j)| format!("{v},{a},{j}")).collect();
    let status = Command::new(binary("interpd"))
        .args(["otg", "--from", from, "--to", to, "--limits", &spec.join(";"), "--period-ms", "0.25", "--out"])
        .arg(&csv)
        .status()
        .expect("interpd otg");
    assert!(status.success());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut worst = [0.0f64; 3];
    for line in text.lines().skip(1) {
        let cols: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        for (k, (v, a, j)) in lims.iter().enumerate() {
            worst[0] = worst[0].max(cols[2 + 4 * k].abs() / v);
            worst[1] = worst[1].max(cols[3 + 4 * k].abs() / a);
            worst[2] = worst[2].max(cols[4 + 4 * k].abs() / j);
        }
    }
    assert!(worst[0] <= 1.001 && worst[1] <= 1.001 && worst[2] <= 1.02, "OTG at 0.25 ms: ratios {worst:?}");
    eprintln!("move-to sampled from the OTG at 0.25 ms: limit ratios v/a/j {worst:.4?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn move_to_keeps_the_limits_and_takes_the_otg_duration() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    let r = c.ok("motion.move_to", json!({"target": {"X": 40.0, "Y": -12.5, "Z": 3.0}}));
    let duration_s = r["duration_s"].as_f64().unwrap();
    let st = wait_done(&mut c);
    assert_eq!(st["state"], "idle", "{st}");
    assert_near(&st["position"], &[40.0, -12.5, 3.0]);
    pause(100);
    let sps = collector.finish();
    check_limits("move_to", &config, &sps);
    // The same problem through `interpd otg`.
    let lims = "250,2500,50000;250,2500,50000;200,2000,40000";
    let want = otg_duration("0;0;0", "40;-12.5;3", lims);
    assert!((duration_s - want).abs() < 1e-9, "move_to {duration_s} s, interpd otg {want} s");
    let moved_s = moving(&sps) as f64 * config.cycle_s();
    assert!(
        (moved_s - want).abs() <= config.cycle_s(),
        "setpoints moved {moved_s} s, the OTG takes {want} s (more than one cycle apart)"
    );
    otg_samples_keep_limits(
        "0;0;0",
        "40;-12.5;3",
        &[(250.0, 2500.0, 50000.0), (250.0, 2500.0, 50000.0), (200.0, 2000.0, 40000.0)],
    );
    let names: Vec<&str> = c.events.iter().filter_map(|e| e["event"].as_str()).collect();
    assert!(names.contains(&"jogging") && names.contains(&"jog_done"), "{names:?}");
    eprintln!("move_to: {duration_s:.6} s planned, {moved_s:.3} s of moving setpoints, interpd otg {want:.6} s");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
}

#[test]
fn a_jog_changed_twenty_times_never_steps() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    // A small deterministic generator: the instants and velocities vary, the test repeats.
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..20 {
        let (vx, vy) = (200.0 * (next() - 0.5) * 2.0, 150.0 * (next() - 0.5) * 2.0);
        c.ok("motion.jog", json!({"axes": {"X": vx, "Y": vy}}));
        if i == 0 {
            c.wait_state(&["jogging"], TIMEOUT);
        }
        pause(20 + (next() * 180.0) as u64);
    }
    // A jog by a distance replaces the continuous one, then a stop.
    c.ok("motion.jog_stop", Value::Null);
    let st = wait_done(&mut c);
    assert_eq!(st["state"], "idle");
    c.ok("motion.jog", json!({"axes": {"Z": -2.5}, "mode": "distance"}));
    wait_done(&mut c);
    pause(100);
    let sps = collector.finish();
    let r = check_limits("jog changed 20 times", &config, &sps);
    // No step: the reported velocity and acceleration change by at most what the limits allow
    // in one cycle.
    let dt = config.cycle_s();
    for w in sps.windows(2) {
        for (k, a) in config.axes.iter().enumerate() {
            let dv = (w[1].vel[k] - w[0].vel[k]).abs();
            let da = (w[1].acc[k] - w[0].acc[k]).abs();
            assert!(dv <= a.max_acc_per_s2 * dt * 1.001, "velocity steps by {dv} at cycle {}", w[1].cycle);
            assert!(da <= a.max_jerk_per_s3 * dt * 1.02, "acceleration steps by {da} at cycle {}", w[1].cycle);
        }
    }
    let last = sps.last().unwrap();
    assert!(last.flags & flags::IDLE != 0 && last.vel.iter().all(|v| *v == 0.0));
    eprintln!("jog changed 20 times: ratios {r:.4?}");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
}

/// The default machine with the X travel cut to `max_x` (a config file in `dir`).
fn short_travel(dir: &std::path::Path, max_x: f64) -> (Config, String) {
    let text = std::fs::read_to_string(interpd_e2e::repo_root().join("config/machines/xyz.toml")).unwrap();
    let text = text.replacen("max = 1000.0", &format!("max = {max_x}"), 1);
    let path = dir.join("machine.toml");
    std::fs::write(&path, text).unwrap();
    (Config::load(&path).expect("machine"), path.display().to_string())
}

#[test]
fn a_continuous_jog_stops_at_the_soft_limit_with_the_plant() {
    let dir = std::env::temp_dir().join(format!("interpd-jog-limit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let limit = 40.0;
    let (config, cfg) = short_travel(&dir, limit);
    let daemon = Daemon::start(&["--config", &cfg]);
    let log = std::fs::File::create(dir.join("plant.log")).unwrap();
    let mut plant = Command::new(binary("sim-plant"))
        .args(["--config", &cfg, "--service-prefix", &daemon.prefix])
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .expect("sim-plant");
    let until = std::time::Instant::now() + TIMEOUT;
    while !std::fs::read_to_string(dir.join("plant.log")).unwrap_or_default().contains("ready") {
        assert!(std::time::Instant::now() < until, "sim-plant not ready");
        pause(20);
    }
    let collector = Collector::start(&daemon.prefix);
    let feedback = FeedbackCollector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    c.ok("motion.jog", json!({"axes": {"X": 200.0}}));
    let st = wait_done(&mut c);
    assert_eq!(st["state"], "idle", "{st}");
    assert_eq!(st["manual"]["limit_reached"], json!(["X"]), "{st}");
    assert!(c.events.iter().any(|e| e["event"] == "jog_limit_reached" && e["axis"] == "X"), "{:?}", c.events);
    // Jogging on towards the limit moves no further.
    c.ok("motion.jog", json!({"axes": {"X": 50.0}}));
    c.wait_state(&["idle"], TIMEOUT);
    pause(500);
    let sps = collector.finish();
    let fbs = feedback.finish();
    // SAFETY: kill(2) on our own child.
    unsafe { libc::kill(plant.id() as i32, libc::SIGINT) };
    let _ = plant.wait();
    check_limits("jog to the soft limit", &config, &sps);
    let top = sps.iter().map(|s| s.pos[0]).fold(f64::MIN, f64::max);
    assert!(top <= limit, "the setpoint passed the limit: {top}");
    assert!(top > limit - 1e-3, "stopped short of the limit at {top}");
    assert!(sps.iter().all(|s| s.vel[0] <= 200.0 * 1.001), "faster than the jog velocity");
    assert!(fbs.len() > 100, "only {} feedback samples", fbs.len());
    let load_top = fbs.iter().map(|f| f.load_pos[0]).fold(f64::MIN, f64::max);
    let motor_top = fbs.iter().map(|f| f.motor_pos[0]).fold(f64::MIN, f64::max);
    eprintln!(
        "jog to the soft limit {limit}: setpoint max {top:.6}, plant load max {load_top:.6}, motor max {motor_top:.6} \
         ({} setpoints, {} feedback samples)",
        sps.len(),
        fbs.len()
    );
    assert!(load_top <= limit, "the plant's load overshot the limit: {load_top}");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Lines and an arc at 100 mm/s, about 1.5 s.
const PROGRAM: &str = "G21 G90 G17\nG1 X60 Y0 F6000\nG3 X70 Y10 I0 J10\nG1 X70 Y60\nG1 X0 Y60\nM30\n";

#[test]
fn mdi_and_a_jog_from_a_hold_then_resume_returns_to_the_path() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    // MDI with modal state carried between calls: G91, G1 and F from the first call.
    let r = c.ok("mdi", json!({"line": "G91 G1 X10 F1200"}));
    assert_eq!(r["elements"], 1);
    c.wait_state(&["finished"], TIMEOUT);
    c.ok("mdi", json!({"line": "Y5"}));
    c.wait_state(&["finished"], TIMEOUT);
    let st = c.ok("status", Value::Null);
    assert_near(&st["position"], &[10.0, 5.0, 0.0]);
    let e = c.call("mdi", json!({"line": "G1 X F600"}));
    assert_eq!(e["error"]["code"], -32001, "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("mdi:1:4"), "{e}");
    // Back to absolute for the program (it starts with G90 anyway).
    c.ok("mdi", json!({"line": "G90"}));
    c.ok("program.load", json!({"text": PROGRAM, "name": "part.ngc"}));
    c.ok("motion.start", Value::Null);
    pause(500);
    c.ok("motion.hold", Value::Null);
    c.wait_event("held", TIMEOUT);
    let held = c.ok("status", Value::Null);
    let held_pos = held["position"].clone();
    // A jog and a move-to from the hold, then an MDI block.
    c.ok("motion.jog", json!({"axes": {"Z": 5.0}, "mode": "distance"}));
    let st = wait_done(&mut c);
    assert_eq!(st["state"], "holding", "{st}");
    c.ok("motion.move_to", json!({"target": {"X": 20.0}, "velocity_factor": 0.5}));
    wait_done(&mut c);
    c.ok("mdi", json!({"line": "G91 G1 Y-3 F3000"}));
    let st = c.wait_state(&["holding"], TIMEOUT);
    assert!((st["position"][1].as_f64().unwrap() - (held_pos[1].as_f64().unwrap() - 3.0)).abs() < 1e-9, "{st}");
    // Resume: back to the held point, then the rest of the program.
    c.ok("motion.resume", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    assert_near(&st["position"], &[0.0, 60.0, 0.0]);
    pause(100);
    let sps = collector.finish();
    check_limits("mdi, program, jog from the hold, resume", &config, &sps);
    // The return passed the held point: a setpoint at rest there after the excursion.
    let back = sps.iter().rposition(|s| {
        (0..3).all(|k| (s.pos[k] - held_pos[k].as_f64().unwrap()).abs() < 1e-6) && s.vel.iter().all(|v| v.abs() < 1e-9)
    });
    assert!(back.is_some(), "never back at the held point {held_pos}");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
}

#[test]
fn bad_input_is_refused_naming_the_parameter_and_nothing_moves() {
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    let refused = |c: &mut Client, method: &str, params: Value, code: i64, param: Option<&str>| {
        let r = c.call(method, params.clone());
        assert_eq!(r["error"]["code"], code, "{method} {params}: {r}");
        if let Some(p) = param {
            assert_eq!(r["error"]["data"]["param"], p, "{method} {params}: {r}");
        }
        eprintln!("{method} {params} -> {}", r["error"]["message"]);
    };
    refused(&mut c, "motion.jog", json!({"axes": {"Q": 1.0}}), -32602, Some("axes.Q"));
    refused(&mut c, "motion.jog", json!({"axes": {}}), -32602, Some("axes"));
    refused(&mut c, "motion.jog", json!({"axes": {"X": 1000.0}}), -32602, Some("axes.X"));
    refused(&mut c, "motion.jog", json!({"axes": {"X": 1.0}, "mode": "fast"}), -32602, Some("mode"));
    refused(&mut c, "motion.move_to", json!({"target": {"X": 5000.0}}), -32602, Some("target.X"));
    refused(&mut c, "motion.move_to", json!({"target": {"W": 1.0}}), -32602, Some("target.W"));
    refused(
        &mut c,
        "motion.move_to",
        json!({"target": {"X": 1.0}, "velocity_factor": 0.0}),
        -32602,
        Some("velocity_factor"),
    );
    refused(
        &mut c,
        "motion.move_to",
        json!({"target": {"X": 1.0}, "velocity_factor": -1.0}),
        -32602,
        Some("velocity_factor"),
    );
    refused(
        &mut c,
        "motion.move_to",
        json!({"target": {"X": 1.0}, "velocity": {"X": 900.0}}),
        -32602,
        Some("velocity.X"),
    );
    refused(
        &mut c,
        "motion.move_to",
        json!({"target": {"X": 999.0}, "velocity": {"X": 240.0}}),
        -32602,
        Some("velocity.X"),
    );
    refused(&mut c, "motion.move_to", json!({"target": {"X": "ten"}}), -32602, Some("X"));
    refused(&mut c, "mdi", json!({"line": "G1 X10 Y F600"}), -32001, None);
    refused(&mut c, "mdi", json!({"line": ""}), -32602, Some("line"));
    // NaN is not JSON: the line does not parse (−32700), and nothing is executed.
    let mut raw = std::os::unix::net::UnixStream::connect(&daemon.socket).unwrap();
    use std::io::{BufRead, Write};
    writeln!(raw, r#"{{"jsonrpc":"2.0","id":1,"method":"motion.move_to","params":{{"target":{{"X":NaN}}}}}}"#).unwrap();
    let mut line = String::new();
    std::io::BufReader::new(raw.try_clone().unwrap()).read_line(&mut line).unwrap();
    let v: Value = serde_json::from_str(&line).unwrap();
    assert_eq!(v["error"]["code"], -32700, "{v}");
    // Not allowed while a program runs.
    c.ok("program.load", json!({"text": PROGRAM, "name": "part.ngc"}));
    c.ok("motion.start", Value::Null);
    refused(&mut c, "motion.jog", json!({"axes": {"X": 1.0}}), -32002, None);
    refused(&mut c, "mdi", json!({"line": "G1 X1"}), -32002, None);
    c.ok("motion.stop", Value::Null);
    c.wait_state(&["idle"], TIMEOUT);
    pause(100);
    let sps = collector.finish();
    // The only motion is the program's, up to the stop.
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "idle");
    assert!(sps.iter().all(|s| s.pos[2] == 0.0), "an axis moved that only the refused commands named");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
}
