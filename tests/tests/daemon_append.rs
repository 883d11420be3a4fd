//! `program.append`: a program without an end, continued over the control API while it runs.
//! Fed fast enough, the motion never stops; fed too slowly, it comes to rest at the end of what
//! is there (an `underrun` event) and goes on when more arrives; the stream keeps the axis
//! limits either way and ends at the program's last point. A bad block is refused with its
//! line and column while the motion already queued completes; the buffer is bounded.

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Client, Collector, Daemon, limit_ratios};
use interpd_protocol::shm::{Setpoints, flags};
use serde_json::{Value, json};
use std::time::{Duration, Instant};

const RUN_TIMEOUT: Duration = Duration::from_secs(60);

/// Lines of a zig-zag of 0.5 mm moves with 3 µm of noise (G64 P0.01 smooths it to a line) from
/// piece `k` on: each piece advances 10 mm in X.
fn piece(k: usize, lines: usize) -> String {
    let mut t = String::new();
    for i in 0..lines {
        let n = k * lines + i + 1;
        let x = n as f64 * 10.0 / lines as f64;
        let y = if n % 2 == 0 { 0.0 } else { 0.003 };
        t.push_str(&format!("G1 X{x:.4} Y{y:.4}\n"));
    }
    t
}

const HEAD: &str = "G21 G90 G64 P0.01\nG1 X0 Y0 F1200\n";

/// Runs HEAD plus `pieces` pieces of 20 lines, sent every `every` after the start, then M2;
/// returns the setpoints, the events and the number of the last line.
fn run_appended(pieces: usize, every: Duration, before_start: usize) -> (Vec<Setpoints>, Vec<Value>, u64) {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    let mut events = Client::connect(&daemon.socket);
    events.ok("subscribe", Value::Null);
    let info = c.ok("program.load", json!({ "text": HEAD, "name": "stream", "open": true }));
    assert_eq!(info["program_end"], false, "{info}");
    let st = c.ok("status", Value::Null);
    assert_eq!(st["program_buffer"]["open"], true, "{st}");
    for k in 0..before_start {
        c.ok("program.append", json!({ "text": piece(k, 20) }));
    }
    let collector = Collector::start(&daemon.prefix);
    std::thread::sleep(Duration::from_millis(100));
    c.ok("motion.start", Value::Null);
    let t0 = Instant::now();
    let mut last_line = 2 + 20 * before_start as u64;
    for k in before_start..pieces {
        let due = every * (k - before_start + 1) as u32;
        if let Some(wait) = due.checked_sub(t0.elapsed()) {
            std::thread::sleep(wait);
        }
        let r = c.ok("program.append", json!({ "text": piece(k, 20) }));
        assert_eq!(r["lines"], json!([last_line + 1, last_line + 20]), "{r}");
        assert_eq!(r["elements"], 20, "{r}");
        last_line += 20;
        // Events queue per subscriber: read them as they come.
        events.ok("status", Value::Null);
    }
    let r = c.ok("program.append", json!({ "text": "M2\n" }));
    assert_eq!(r["program_end"], true, "{r}");
    let st = c.wait_state(&["finished", "error"], RUN_TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}\n{}", daemon.stderr());
    assert_eq!(st["program"]["program_end"], true, "{st}");
    // Nothing follows an ended program.
    let r = c.call("program.append", json!({ "text": "G1 X0\n" }));
    assert_eq!(r["error"]["code"], -32001, "{r}");
    std::thread::sleep(Duration::from_millis(100));
    events.ok("status", Value::Null);
    let sps = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "interpd run; stderr:\n{stderr}");
    (sps, events.events.clone(), last_line + 1)
}

fn check_stream(what: &str, sps: &[Setpoints], pieces: usize) {
    for w in sps.windows(2) {
        assert_eq!(w[1].cycle, w[0].cycle + 1, "{what}: gap in cycle numbers");
    }
    let config = Config::load_or_default(None).expect("default machine");
    let r = limit_ratios(config.cycle_s(), &AxisLimits::of(&config), sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02 && r[3] <= 1.001, "{what}: limit ratios {r:?}");
    let last = sps.last().expect("setpoints");
    let end_x = pieces as f64 * 10.0;
    assert!((last.pos[0] - end_x).abs() < 1e-9 && last.pos[1].abs() < 1e-9, "{what}: ends at {:?}", &last.pos[..3]);
    eprintln!("{what}: {} setpoints, limit ratios {r:.4?}", sps.len());
}

#[test]
fn a_program_fed_fast_enough_runs_without_a_stop() {
    // 10 mm per piece at 20 mm/s: a piece lasts 0.5 s of motion, one arrives every 0.2 s.
    let (sps, events, _) = run_appended(15, Duration::from_millis(200), 3);
    let underruns = sps.iter().filter(|s| s.flags & flags::UNDERRUN != 0).count();
    assert_eq!(underruns, 0, "the motion ran dry: {events:?}");
    let moving: Vec<&Setpoints> = sps.iter().filter(|s| s.flags & flags::RUNNING != 0).collect();
    let first = moving.iter().position(|s| s.v_mm_s > 0.0).expect("motion");
    let stops = moving[first..]
        .windows(2)
        .filter(|w| w[0].v_mm_s > 1e-6 && w[1].v_mm_s <= 1e-6 && w[1].s_mm < moving.last().expect("end").s_mm - 1e-6)
        .count();
    assert_eq!(stops, 0, "the motion stopped on the way");
    check_stream("fast", &sps, 15);
}

#[test]
fn a_program_fed_too_slowly_stops_at_the_end_of_what_is_there_and_goes_on() {
    // A piece lasts 0.5 s of motion; one arrives every 1.2 s.
    let (sps, events, _) = run_appended(5, Duration::from_millis(1200), 1);
    let underrun_events = events.iter().filter(|e| e["event"] == "underrun").count();
    let cleared = events.iter().filter(|e| e["event"] == "underrun_cleared").count();
    assert!(underrun_events >= 3 && cleared >= 3, "underrun events {underrun_events}, cleared {cleared}: {events:?}");
    // Each stop is at rest where the text so far ended (a multiple of 10 mm in X).
    let mut rests = Vec::new();
    for w in sps.windows(2) {
        if w[0].flags & flags::UNDERRUN == 0 && w[1].flags & flags::UNDERRUN != 0 {
            rests.push(w[1].pos[0]);
        }
    }
    for x in &rests {
        let off = (x / 10.0 - (x / 10.0).round()).abs() * 10.0;
        assert!(off < 1e-6, "a stop at X = {x}, not at the end of a piece: {rests:?}");
    }
    check_stream("slow", &sps, 5);
}

#[test]
fn bad_blocks_and_a_full_buffer_are_refused_and_the_motion_goes_on() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    // Without "open", a program ends with its text: nothing can be appended.
    c.ok("program.load", json!({ "text": HEAD }));
    let r = c.call("program.append", json!({ "text": piece(0, 20) }));
    assert_eq!(r["error"]["code"], -32002, "{r}");
    c.ok("program.load", json!({ "text": HEAD, "open": true }));
    let collector = Collector::start(&daemon.prefix);
    c.ok("program.append", json!({ "text": piece(0, 20) }));
    c.ok("motion.start", Value::Null);
    let r = c.call("program.append", json!({ "text": "G1 X30\nG1 X31 H5\n" }));
    assert_eq!(r["error"]["code"], -32001, "{r}");
    let msg = r["error"]["message"].as_str().unwrap_or_default();
    assert!(msg.contains("inline:24:8:"), "{msg}");
    // The buffer holds at most 4 MiB (the default): pieces of 0.9 MB of 100 mm moves (the
    // motion reads a few of them ahead) fill it.
    let big: String = (0..30_000)
        .map(|i| if i % 2 == 0 { "G1 X100.0000 Y0.0000 Z0.0000\n" } else { "G1 X10.0000 Y0.0000 Z0.0000\n" })
        .collect();
    let mut full = None;
    for _ in 0..6 {
        let r = c.call("program.append", json!({ "text": big }));
        if r.get("error").is_some() {
            full = Some(r);
            break;
        }
    }
    let r = full.expect("the buffer filled up");
    assert_eq!(r["error"]["code"], -32006, "{r}");
    assert!(r["error"]["data"]["limit_bytes"] == 4 * 1024 * 1024, "{r}");
    let st = c.ok("status", Value::Null);
    assert!(st["program_buffer"]["buffered_bytes"].as_u64().unwrap_or(0) > 3_000_000, "{st}");
    c.ok("motion.stop", Value::Null);
    let st = c.wait_state(&["idle", "error"], RUN_TIMEOUT);
    assert_eq!(st["state"], "idle", "{st}");
    let sps = collector.finish();
    let config = Config::load_or_default(None).expect("default machine");
    let r = limit_ratios(config.cycle_s(), &AxisLimits::of(&config), &sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02 && r[3] <= 1.001, "limit ratios {r:?}");
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "interpd run; stderr:\n{stderr}");
}
