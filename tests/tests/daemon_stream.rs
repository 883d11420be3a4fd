//! End to end: `interpd run` as a real process, programs loaded over the control socket, the
//! setpoint stream received over real iceoryx2 shared memory and checked: no gaps in cycle
//! numbers, axis limits by finite differences of the 4 ms positions, on the path within 1 µm,
//! ending exactly at the program's end point; feed override, hold, resume, stop; underrun.

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Client, Collector, Daemon, limit_ratios};
use interpd_e2e::{example, repo_root};
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::program;
use interpd_motion::{Feed, Settings};
use interpd_protocol::shm::{Setpoints, flags};
use serde_json::{Value, json};
use std::time::Duration;

const RUN_TIMEOUT: Duration = Duration::from_secs(60);

/// Largest |value|/limit of velocity, acceleration, jerk from finite differences of the
/// positions, and of the reported acceleration.
fn ratios(config: &Config, sps: &[Setpoints]) -> [f64; 4] {
    let limits: Vec<AxisLimits> = AxisLimits::of(config);
    limit_ratios(config.cycle_s(), &limits, sps)
}

/// Distance of a point from the path near path position `s` (golden-section search).
fn distance_near(path: &Path, pos: &[f64], s: f64, window_mm: f64) -> f64 {
    let mut d = AxisDerivs::default();
    let mut dist = |x: f64| {
        path.eval(x.clamp(0.0, path.length_mm()), &mut d);
        (0..path.n_axes).map(|k| (pos[k] - d.pos[k]).powi(2)).sum::<f64>().sqrt()
    };
    let (mut a, mut b) = (s - window_mm, s + window_mm);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (c, e) = (b - g * (b - a), a + g * (b - a));
        if dist(c) < dist(e) { b = e } else { a = c }
    }
    dist(0.5 * (a + b)).min(dist(s))
}

/// The whole-stream checks; returns the largest distance from the path (mm).
fn check_stream(name: &str, config: &Config, path: &Path, sps: &[Setpoints]) -> f64 {
    assert!(sps.len() > 10, "{name}: only {} setpoints", sps.len());
    for w in sps.windows(2) {
        assert_eq!(w[1].cycle, w[0].cycle + 1, "{name}: gap in cycle numbers");
    }
    let r = ratios(config, sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02 && r[3] <= 1.001, "{name}: limit ratios {r:?}");
    let mut worst: f64 = 0.0;
    for sp in sps {
        worst = worst.max(distance_near(path, &sp.pos[..path.n_axes], sp.s_mm, 0.05));
    }
    assert!(worst <= 1e-3, "{name}: a setpoint is {worst} mm off the path");
    worst
}

fn load(client: &mut Client, file: &std::path::Path) {
    client.ok("program.load", json!({ "path": file.display().to_string() }));
}

/// Runs `name` on a fresh daemon and returns the stream and the path it followed.
fn run_example(name: &str, machine: Option<&str>) -> (Config, Path, Vec<Setpoints>) {
    let config = match machine {
        Some(m) => Config::load(&repo_root().join(m)).expect("machine"),
        None => Config::default_machine(),
    };
    let mut args = Vec::new();
    let mpath;
    if let Some(m) = machine {
        mpath = repo_root().join(m).display().to_string();
        args = vec!["--config", mpath.as_str()];
    }
    let daemon = Daemon::start(&args);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    load(&mut c, &example(name));
    c.ok("motion.start", Value::Null);
    c.wait_state(&["finished", "error"], RUN_TIMEOUT);
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "finished", "{name}: {st}");
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{name}: interpd run exit status; stderr:\n{stderr}");
    let text = std::fs::read_to_string(example(name)).unwrap();
    let parsed = program::parse(&text, name, &Settings::from(&config)).unwrap().path;
    // The daemon starts at the origin: its motion runs the rapid move to the program's start
    // first, as a feed started there does.
    let settings = Settings::from(&config);
    let path = Feed::builder(&settings).start_from([0.0; interpd_motion::path::MAX_AXES]).whole(parsed).path().clone();
    (config, path, sps)
}

#[test]
fn every_example_streams_within_limits_on_the_path_to_its_end() {
    for (name, machine) in [
        ("circle_r10.ngc", None),
        ("corner_90.ngc", None),
        ("line_arc_line.ngc", None),
        ("staircase.ngc", None),
        ("ellipse_g06.ngc", None),
        ("five_axis_table.csv", Some("config/machines/xyzab.toml")),
    ] {
        let (config, path, sps) = run_example(name, machine);
        let worst = check_stream(name, &config, &path, &sps);
        let end = path.end_position();
        let last = sps.last().unwrap();
        for (k, (got, want)) in last.pos.iter().zip(end.iter()).take(path.n_axes).enumerate() {
            assert!((got - want).abs() < 1e-9, "{name}: axis {k} ends at {got} instead of {want}");
        }
        assert!(last.flags & flags::FINISHED != 0, "{name}: last setpoint not flagged finished");
        eprintln!("{name}: {} setpoints, largest distance from the path {:.4} µm", sps.len(), worst * 1e3);
    }
}

/// Lines and arcs at 100 mm/s, a few seconds long.
const LOOP: &str = "G21 G90 G17\nG1 X0 Y0 F6000\nG1 X100 Y0\nG3 X110 Y10 I0 J10\nG1 X110 Y60\nG3 X100 Y70 I-10 J0\n\
G1 X0 Y70\nG3 X-10 Y60 I0 J-10\nG1 X-10 Y10\nG3 X0 Y0 I10 J0\nG1 X100 Y0\nG3 X110 Y10 I0 J10\nG1 X110 Y60\nM30\n";

#[test]
fn override_hold_resume_and_stop_keep_the_limits_and_the_path() {
    let config = Config::default_machine();
    let name = "loop.ngc";
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    c.ok("program.load", json!({ "text": LOOP, "name": name }));
    c.ok("motion.start", Value::Null);
    let pause = |ms| std::thread::sleep(Duration::from_millis(ms));
    pause(300);
    c.ok("feed.override", json!({ "percent": 150 }));
    pause(300);
    c.ok("feed.override", json!({ "percent": 30 }));
    pause(400);
    c.ok("motion.hold", Value::Null);
    let held = c.wait_state(&["holding"], RUN_TIMEOUT);
    pause(500);
    let still = c.ok("status", Value::Null);
    assert_eq!(held["state"], "holding");
    assert!(still["feed_mm_s"].as_f64().unwrap().abs() < 1e-9, "not at rest while held: {still}");
    c.ok("motion.resume", Value::Null);
    pause(400);
    c.ok("motion.stop", Value::Null);
    let st = c.wait_state(&["idle"], RUN_TIMEOUT);
    assert!(st["s_mm"].as_f64().unwrap() > 0.0);
    c.wait_event("stopped", Duration::from_secs(5));
    pause(100);
    let sps = collector.finish();
    let path = program::parse(LOOP, name, &Settings::from(&config)).unwrap().path;
    let worst = check_stream(name, &config, &path, &sps);
    let last = sps.last().unwrap();
    assert!(last.v_mm_s.abs() < 1e-9 && last.flags & flags::IDLE != 0, "not standing after stop");
    // The override took effect: the path speed reached 150 % and later 30 % of the feed.
    let v_max = sps.iter().map(|s| s.v_mm_s).fold(0.0, f64::max);
    assert!(v_max > 140.0, "150 % never reached: {v_max} mm/s");
    let names: Vec<&str> = c.events.iter().filter_map(|e| e["event"].as_str()).collect();
    for want in ["started", "held", "resumed", "stopped"] {
        assert!(names.contains(&want), "event {want} missing: {names:?}");
    }
    let overrides: Vec<f64> = sps.iter().map(|s| s.feed_override).collect();
    assert!(overrides.contains(&1.5) && overrides.contains(&0.3), "overrides never took effect");
    let (code, _) = daemon.terminate();
    assert_eq!(code, Some(0));
    eprintln!("override/hold/stop: {} setpoints, largest distance from the path {:.4} µm", sps.len(), worst * 1e3);
}

#[test]
fn an_underrun_stops_along_the_path_and_the_program_completes() {
    let config = Config::default_machine();
    let name = "line_arc_line.ngc";
    let daemon = Daemon::start(&["--debug-stall-planner", "0.2:0.5"]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    load(&mut c, &example(name));
    c.ok("motion.start", Value::Null);
    c.wait_state(&["finished", "error"], RUN_TIMEOUT);
    pause_ms(100);
    let sps = collector.finish();
    let text = std::fs::read_to_string(example(name)).unwrap();
    let path = program::parse(&text, name, &Settings::from(&config)).unwrap().path;
    check_stream(name, &config, &path, &sps);
    let underrun: Vec<&Setpoints> = sps.iter().filter(|s| s.flags & flags::UNDERRUN != 0).collect();
    assert!(!underrun.is_empty(), "no underrun was provoked");
    assert!(underrun.iter().any(|s| s.v_mm_s.abs() < 1e-9), "the underrun did not come to rest");
    let end = path.end_position();
    let last = sps.last().unwrap();
    assert!((0..3).all(|k| (last.pos[k] - end[k]).abs() < 1e-9), "did not complete after the underrun");
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0));
    assert!(stderr.contains("underrun"), "underrun not reported: {stderr}");
}

fn pause_ms(ms: u64) {
    std::thread::sleep(Duration::from_millis(ms));
}

/// An override of 0 % set while idle holds the next start, of a program and of an MDI block;
/// raising it starts the motion, which then keeps the limits and ends where it should.
#[test]
fn an_override_of_zero_set_while_idle_holds_the_start_until_it_is_raised() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    c.ok("feed.override", json!({ "percent": 0 }));
    c.ok("program.load", json!({ "text": "G21 G90\nG1 X20 F3000\nM30\n", "name": "line.ngc" }));
    c.ok("motion.start", Value::Null);
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "holding", "{st}");
    c.wait_event("held", RUN_TIMEOUT);
    std::thread::sleep(Duration::from_millis(500));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "holding", "{st}");
    assert_eq!(st["position"][0], 0.0, "moved at an override of 0: {st}");
    c.ok("feed.override", json!({ "percent": 50 }));
    let st = c.wait_state(&["finished"], RUN_TIMEOUT);
    assert!((st["position"][0].as_f64().unwrap_or(f64::NAN) - 20.0).abs() < 1e-9, "{st}");
    assert!(c.events.iter().any(|e| e["event"] == "resumed"), "{:?}", c.events);
    // An MDI block at 0 % starts held as well.
    c.ok("feed.override", json!({ "percent": 0 }));
    c.ok("mdi", json!({ "line": "G1 X10 F3000" }));
    std::thread::sleep(Duration::from_millis(300));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "holding", "{st}");
    assert_eq!(st["position"][0], 20.0, "MDI moved at an override of 0: {st}");
    c.ok("feed.override", json!({ "percent": 100 }));
    let st = c.wait_state(&["finished"], RUN_TIMEOUT);
    assert!((st["position"][0].as_f64().unwrap_or(f64::NAN) - 10.0).abs() < 1e-9, "{st}");
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    let r = ratios(&config, &sps);
    assert!(r[0] <= 1.0 + 1e-9 && r[1] <= 1.0 + 1e-9 && r[2] <= 1.0 + 1e-9, "limit ratios {r:?}");
    // At 50 % the line runs at 25 mm/s, not at the programmed 50 (the MDI block after it at 100 %).
    let line_end = sps.iter().position(|s| s.pos[0] >= 20.0 - 1e-9).expect("the line's end");
    let fastest =
        sps[..=line_end].windows(2).map(|w| (w[1].pos[0] - w[0].pos[0]).abs() / config.cycle_s()).fold(0.0, f64::max);
    assert!(fastest < 25.0 * 1.001 + 1e-6 && fastest > 24.0, "fastest {fastest} mm/s");
}
