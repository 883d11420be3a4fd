//! End to end: the tool table and work offsets of `interpd run` over the control socket —
//! `tools.get/set`, `offsets.get/set`, their refusals, a program that needs a tool the table
//! gains only by `tools.set`, an `mdi` move in G55 after `offsets.set`, and the cutter-
//! compensated ellipse example run to its end with the setpoints received over iceoryx2: within
//! the axis limits, and offset outwards by the tool radius.

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Client, Collector, Daemon, limit_ratios};
use serde_json::{Value, json};
use std::time::Duration;

const TIMEOUT: Duration = Duration::from_secs(60);

fn refused(c: &mut Client, method: &str, params: Value) -> Value {
    let r = c.call(method, params);
    r.get("error").cloned().unwrap_or_else(|| panic!("{method} accepted: {r}"))
}

#[test]
fn tools_and_offsets_are_read_and_set_and_programs_use_them() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();

    // The embedded machine's table.
    let tools = c.ok("tools.get", Value::Null);
    assert_eq!(tools["tools"][0], json!({"number": 1, "diameter_mm": 6.0, "length_mm": 50.0}), "{tools}");
    assert_eq!(tools["tools"].as_array().map(Vec::len), Some(2), "{tools}");

    // A program with a tool the table does not have is refused, naming the place.
    let prog = "G0 X0 Y0\nF1000\nG41 D5\nG1 X10 Y0\nG1 X20 Y0\nG40 G1 X30 Y0\n";
    let e = refused(&mut c, "program.load", json!({"text": prog, "name": "comp"}));
    assert_eq!(e["code"], -32001, "{e}");
    assert!(e["message"].as_str().unwrap().contains("comp:3:5: tool 5 is not in the tool table"), "{e}");

    // With the tool set, the same program loads and reports what it uses.
    let table = json!({"tools": [{"number": 5, "diameter_mm": 4.0, "length_mm": 20.0, "name": "4 mm"}]});
    let set = c.ok("tools.set", table.clone());
    assert_eq!(set, table);
    let info = c.ok("program.load", json!({"text": prog, "name": "comp"}));
    assert_eq!((info["tools"].clone(), info["cutter_compensation"].clone()), (json!([5]), json!(true)), "{info}");
    let st = c.ok("status", Value::Null);
    assert_eq!(st["program"]["tools"], json!([5]), "{st}");

    // Refusals name the parameter.
    let e = refused(
        &mut c,
        "tools.set",
        json!({"tools": [{"number": 1, "diameter_mm": 6.0}, {"number": 1, "diameter_mm": 3.0}]}),
    );
    assert_eq!((e["code"].clone(), e["data"]["param"].clone()), (json!(-32602), json!("tools[1].number")), "{e}");
    let e = refused(&mut c, "tools.set", json!({"tools": [{"number": 1, "diameter_mm": -6.0}]}));
    assert_eq!(e["data"]["param"], "tools[0].diameter_mm", "{e}");
    let e = refused(&mut c, "offsets.set", json!({"offsets": {"G55": {"Q": 1.0}}}));
    assert_eq!(e["data"]["param"], "offsets.G55.Q", "{e}");
    let e = refused(&mut c, "offsets.set", json!({"offsets": {"G60": {"X": 1.0}}}));
    assert_eq!(e["data"]["param"], "offsets.G60", "{e}");

    // Offsets: every system with every axis; a set replaces the systems given.
    let o = c.ok("offsets.get", Value::Null);
    assert_eq!(o["offsets"]["G54"], json!({"X": 0.0, "Y": 0.0, "Z": 0.0}), "{o}");
    let o = c.ok("offsets.set", json!({"offsets": {"G55": {"X": 10.0, "Y": -5.0}}}));
    assert_eq!(o["offsets"]["G55"], json!({"X": 10.0, "Y": -5.0, "Z": 0.0}), "{o}");
    assert_eq!(o, c.ok("offsets.get", Value::Null));

    // An mdi move in G55 goes to the programmed point plus its origin.
    c.ok("mdi", json!({"line": "G55 G0 X1 Y2"}));
    let st = c.wait_state(&["idle", "finished"], TIMEOUT);
    let pos: Vec<f64> = st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((pos[0] - 11.0).abs() < 1e-9 && (pos[1] + 3.0).abs() < 1e-9, "{st}");
    assert_eq!(st["mdi"], json!({"work_offset": "G55", "tool_length": null}), "{st}");
    c.ok("mdi", json!({"line": "G43 H5"}));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["mdi"]["tool_length"], json!({"tool": 5, "length_mm": 20.0}), "{st}");
    c.ok("mdi", json!({"line": "G49"}));

    // A loaded program runs with the offsets it was loaded with, whatever is set after.
    let info = c.ok("program.load", json!({"text": "G55 G0 X1 Y2\nG0 X2\n", "name": "g55"}));
    assert_eq!(info["work_offsets"], json!(["G55"]), "{info}");
    c.ok("offsets.set", json!({"offsets": {"G55": {"X": 500.0}}}));
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    let pos: Vec<f64> = st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((pos[0] - 12.0).abs() < 1e-9 && (pos[1] + 3.0).abs() < 1e-9, "{st}");
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "stderr:\n{stderr}");
}

#[test]
fn the_compensated_ellipse_runs_within_the_limits_outside_the_contour() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    let info = c.ok("program.load", json!({"path": "examples/ellipse_g06_comp.ngc"}));
    assert_eq!(info["cutter_compensation"], true, "{info}");
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "stderr:\n{stderr}");
    let limits: Vec<AxisLimits> = AxisLimits::of(&config);
    let r = limit_ratios(config.cycle_s(), &limits, &sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limit ratios {r:?}");
    // Tool 1 (6 mm) right of the counter-clockwise ellipse a = 40, b = 20: the tool centre
    // reaches x = 43 and y = ±23 and never enters the ellipse.
    let max_x = sps.iter().map(|s| s.pos[0]).fold(f64::MIN, f64::max);
    let max_y = sps.iter().map(|s| s.pos[1]).fold(f64::MIN, f64::max);
    assert!((max_x - 43.0).abs() < 1e-3 && (max_y - 23.0).abs() < 1e-3, "extremes x {max_x}, y {max_y}");
    // After the rapid from the origin to the approach point (40, −10) (the setpoint nearest
    // to it: the motion passes it at rest for an instant between two cycles).
    let dist = |s: &interpd_protocol::shm::Setpoints| (s.pos[0] - 40.0).hypot(s.pos[1] + 10.0);
    let start = (0..sps.len()).min_by(|&a, &b| dist(&sps[a]).total_cmp(&dist(&sps[b]))).expect("setpoints");
    assert!(dist(&sps[start]) < 0.01, "the motion does not pass (40, -10)");
    let inside = sps[start..].iter().filter(|s| (s.pos[0] / 40.0).powi(2) + (s.pos[1] / 20.0).powi(2) < 1.0).count();
    assert_eq!(inside, 0, "setpoints inside the contour");
    eprintln!("compensated ellipse: {} setpoints, limit ratios v/a/j {r:.4?}", sps.len());
}
