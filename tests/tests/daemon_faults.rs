//! End to end, faults around the daemon process: a second daemon on the same control socket is
//! refused and the first goes on unharmed; SIGTERM while the motion is held ends the daemon
//! in order (exit 0), with the machine at rest and the recorded stream within the limits.

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Collector, Daemon, limit_ratios};
use serde_json::{Value, json};
use std::time::Duration;

/// A program long enough to be held in the middle of a move.
const LONG: &str = "G21 G90\nG1 X80 Y40 F3000\nG1 X0 Y0\nM30\n";
const TIMEOUT: Duration = Duration::from_secs(30);

#[test]
fn a_second_daemon_on_the_same_socket_is_refused_and_the_first_goes_on() {
    let first = Daemon::start(&[]);
    let mut c = first.client();
    c.ok("program.load", json!({ "text": LONG, "name": "long.ngc" }));
    c.ok("motion.start", Value::Null);
    let out = std::process::Command::new(interpd_e2e::binary("interpd"))
        .args(["run", "--no-shm", "--service-prefix", "interpd-test/second", "--socket"])
        .arg(&first.socket)
        .output()
        .expect("run a second interpd");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("another interpd is running on"), "{stderr}");
    // The first still answers on its socket and finishes its program.
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    drop(c);
    let (code, err) = first.terminate();
    assert_eq!(code, Some(0), "{err}");
}

#[test]
fn sigterm_while_held_ends_the_daemon_in_order() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("program.load", json!({ "text": LONG, "name": "long.ngc" }));
    c.ok("motion.start", Value::Null);
    std::thread::sleep(Duration::from_millis(300));
    c.ok("motion.hold", Value::Null);
    let held = c.wait_state(&["holding"], TIMEOUT);
    std::thread::sleep(Duration::from_millis(300));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "holding", "{held}");
    drop(c);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    let sps = collector.finish();
    assert!(sps.len() > 100, "{} setpoints", sps.len());
    // The machine stood from the hold on: the last setpoints do not move.
    let last = &sps[sps.len() - 1];
    let before = &sps[sps.len() - 20];
    assert_eq!(last.pos[..3], before.pos[..3], "moving at the end");
    let limits: Vec<AxisLimits> = AxisLimits::of(&config);
    let [v, a, j, _] = limit_ratios(config.cycle_s(), &limits, &sps);
    assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "limits: vel {v} acc {a} jerk {j}");
}
