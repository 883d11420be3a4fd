//! End to end: the program stops M0, M1 and M60 in `interpd run` over the control socket, with
//! the setpoints received over iceoryx2. The motion stands exactly at each stop (state
//! `paused`, `status.pause`, the `paused` event naming line and code) and nothing moves until
//! `motion.resume`; `motion.optional_stop` turns M1 off; `motion.stop` while paused ends the
//! program where it stands.

use interpd_e2e::daemon::{Client, Collector, Daemon};
use interpd_protocol::shm::flags;
use serde_json::{Value, json};
use std::time::Duration;

const TIMEOUT: Duration = Duration::from_secs(60);

const PROGRAM: &str = "G21 G90 G1 F1200 X10\nM0\nG1 X20\nM1\nG1 X30 Y5\nM2\n";

fn position(st: &Value) -> Vec<f64> {
    st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
}

fn paused_events(c: &Client) -> Vec<Value> {
    c.events.iter().filter(|e| e["event"] == "paused").cloned().collect()
}

/// Waits for state `paused`, checks where and at what, and that nothing moves for a while.
fn expect_pause(c: &mut Client, line: u32, code: &str, x: f64) {
    let st = c.wait_state(&["paused", "finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "paused", "{st}");
    assert_eq!(st["pause"], json!({"line": line, "code": code}), "{st}");
    let at = position(&st);
    assert!((at[0] - x).abs() < 1e-9, "paused at {at:?}, not X{x}");
    std::thread::sleep(Duration::from_millis(300));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "paused", "{st}");
    assert_eq!(position(&st), at, "the machine moved while paused");
    assert_eq!(st["feed_mm_s"], 0.0, "{st}");
}

#[test]
fn m0_m1_m60_pause_until_resumed_and_the_optional_stop_switch_skips_m1() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    let collector = Collector::start(&daemon.prefix);

    // LinuxCNC starts with the optional-stop switch on.
    assert_eq!(c.ok("status", Value::Null)["optional_stop"], true);
    let info = c.ok("program.load", json!({"text": PROGRAM, "name": "stops"}));
    assert_eq!(info["elements"], 3, "{info}");
    // Resume is refused while nothing is paused or held.
    let r = c.call("motion.resume", Value::Null);
    assert_eq!(r["error"]["code"], -32002, "{r}");

    c.ok("motion.start", Value::Null);
    expect_pause(&mut c, 2, "M0", 10.0);
    // Not a hold: motion.hold is refused, motion.start too.
    let r = c.call("motion.hold", Value::Null);
    assert_eq!(r["error"]["data"]["state"], "paused", "{r}");
    c.ok("motion.resume", Value::Null);
    expect_pause(&mut c, 4, "M1", 20.0);
    c.ok("motion.resume", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    assert_eq!(st["pause"], Value::Null);
    let end = position(&st);
    assert!((end[0] - 30.0).abs() < 1e-9 && (end[1] - 5.0).abs() < 1e-9, "{end:?}");
    c.wait_event("finished", TIMEOUT);
    let events = paused_events(&c);
    assert_eq!(
        events,
        vec![json!({"event": "paused", "line": 2, "code": "M0"}), json!({"event": "paused", "line": 4, "code": "M1"})]
    );
    assert_eq!(c.events.iter().filter(|e| e["event"] == "resumed").count(), 2, "{:?}", c.events);

    // The setpoints: constant while flagged paused, two stretches at X10 and X20.
    let sps = collector.finish();
    let paused: Vec<_> = sps.iter().filter(|s| s.flags & flags::PAUSED != 0).collect();
    assert!(paused.len() >= 2 * 60, "only {} paused setpoints", paused.len());
    for s in &paused {
        let x = s.pos[0];
        assert!((x - 10.0).abs() < 1e-9 || (x - 20.0).abs() < 1e-9, "paused at X{x}");
        assert_eq!((s.pos[1], s.pos[2], s.v_mm_s), (0.0, 0.0, 0.0));
    }
    for w in paused.windows(2).filter(|w| w[1].cycle == w[0].cycle + 1) {
        assert_eq!(w[0].pos, w[1].pos, "a setpoint moved while paused");
    }

    // The switch off: M1 is passed (at its exact stop), M0 still pauses.
    let r = c.ok("motion.optional_stop", json!({"enabled": false}));
    assert_eq!(r, json!({"optional_stop": false}));
    assert_eq!(c.ok("status", Value::Null)["optional_stop"], false);
    let r = c.call("motion.optional_stop", json!({}));
    assert_eq!(r["error"]["code"], -32602, "{r}");
    c.ok("program.load", json!({"text": PROGRAM.replace("X30 Y5", "X30 Y0"), "name": "stops2"}));
    c.events.clear();
    c.ok("motion.start", Value::Null);
    expect_pause(&mut c, 2, "M0", 10.0);
    c.ok("motion.resume", Value::Null);
    let st = c.wait_state(&["finished", "paused", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "M1 must not pause with the switch off: {st}");
    assert!((position(&st)[0] - 30.0).abs() < 1e-9, "{st}");
    c.wait_event("finished", TIMEOUT);
    assert_eq!(paused_events(&c).len(), 1, "{:?}", c.events);

    // M60 pauses whatever the switch; motion.stop there ends the program where it stands.
    c.ok("program.load", json!({"text": "G1 F1200 X5\nM60\nG1 X0\nM2\n", "name": "m60"}));
    c.ok("motion.start", Value::Null);
    expect_pause(&mut c, 2, "M60", 5.0);
    c.ok("motion.stop", Value::Null);
    let st = c.wait_state(&["idle"], TIMEOUT);
    assert!((position(&st)[0] - 5.0).abs() < 1e-9, "{st}");
    assert_eq!(st["pause"], Value::Null);
    c.wait_event("stopped", TIMEOUT);
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
}
