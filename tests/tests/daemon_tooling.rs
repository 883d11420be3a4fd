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

/// The tool and offset state `status.modal` must report while the machine executes `line` of
/// [`MODAL_PROGRAM`] (offsets G55 = X10 Y−5; tools 1: 6 mm × 50 mm, 2: 10 mm × 62.5 mm).
fn expected_modal(line: u64) -> Value {
    let g54 = json!([0.0, 0.0, 0.0]);
    let g55 = json!([10.0, -5.0, 0.0]);
    let off = json!({"mode": "off", "radius_mm": 0.0, "tool": null});
    let tool1 = json!({"number": 1, "length_mm": 50.0, "radius_mm": 3.0});
    let tool2 = json!({"number": 2, "length_mm": 62.5, "radius_mm": 5.0});
    let tlo1 = json!({"tool": 1, "length_mm": 50.0});
    let tlo2 = json!({"tool": 2, "length_mm": 62.5});
    let zero = json!([0.0, 0.0, 0.0]);
    let (system, values, tool, tlo, cutter, g92) = match line {
        0..=3 => ("G54", &g54, Value::Null, Value::Null, off.clone(), &zero),
        4..=6 => ("G54", &g54, tool1.clone(), tlo1.clone(), off.clone(), &zero),
        7..=8 => ("G55", &g55, tool1.clone(), tlo1.clone(), off.clone(), &zero),
        9 => ("G55", &g55, tool2.clone(), tlo2.clone(), off.clone(), &zero),
        10..=12 => {
            ("G55", &g55, tool2.clone(), tlo2.clone(), json!({"mode": "left", "radius_mm": 3.0, "tool": 1}), &zero)
        }
        13..=14 => ("G55", &g55, tool2.clone(), tlo2.clone(), off.clone(), &zero),
        15..=16 => ("G55", &g55, tool2.clone(), tlo2.clone(), off.clone(), &json!([-10.0, 0.0, 0.0])),
        _ => ("G55", &g55, tool2.clone(), tlo2.clone(), off.clone(), &zero),
    };
    json!({"line": line, "work_offset": system, "work_offset_values": values, "g92_offset": g92,
           "tool": tool, "tool_length": tlo, "cutter": cutter})
}

/// G54 → G55, T1 → T2 with G43 H, G41 → G40, G92 → G92.1, each with a move after it.
const MODAL_PROGRAM: &str = "G21 G90 G64 P0.01\n\
    G0 X0 Y0 Z0\n\
    T1 M6 G43 H1\n\
    G1 X20 Y0 F1200\n\
    G1 X20 Y20\n\
    G55\n\
    G1 X0 Y0\n\
    T2 M6 G43 H2\n\
    G1 X0 Y20 Z5\n\
    G41 D1 G1 X20 Y20\n\
    G1 X20 Y0\n\
    G1 X0 Y0\n\
    G40 G1 X-10 Y0\n\
    G92 X0 Y0\n\
    G1 X5 Y5\n\
    G92.1\n\
    G1 X0 Y0\n\
    M2\n";

#[test]
fn status_reports_the_tool_offsets_and_compensation_of_the_executing_element() {
    let daemon = Daemon::start(&[]);
    let mut c = daemon.client();
    c.ok("offsets.set", json!({"offsets": {"G55": {"X": 10.0, "Y": -5.0}}}));
    c.ok("program.load", json!({"text": MODAL_PROGRAM, "name": "modal"}));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["modal"], Value::Null, "nothing runs yet: {st}");
    c.ok("motion.start", Value::Null);
    let until = std::time::Instant::now() + TIMEOUT;
    // The lines seen, in order, each with the state status reported for it.
    let mut seen: Vec<u64> = Vec::new();
    let mut samples = 0;
    loop {
        let st = c.ok("status", Value::Null);
        let modal = &st["modal"];
        let line = st["line"].as_u64().unwrap();
        if st["state"] == "running" && !modal.is_null() {
            samples += 1;
            let m = modal["line"].as_u64().unwrap();
            assert!(m == line || m + 1 == line || line + 1 == m, "status.modal of line {m} with status.line {line}");
            assert_eq!(*modal, expected_modal(m), "line {m}: {st}");
            if seen.last() != Some(&m) {
                seen.push(m);
            }
        }
        if st["state"] == "finished" || st["state"] == "error" {
            assert_eq!(st["state"], "finished", "{st}");
            // The end: G55 origin (G92 cleared) with tool 2's length on Z.
            let pos: Vec<f64> = st["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
            assert!((pos[0] - 10.0).abs() < 1e-9 && (pos[1] + 5.0).abs() < 1e-9, "{st}");
            assert!((pos[2] - 67.5).abs() < 1e-9, "{st}");
            assert_eq!(st["modal"], expected_modal(17), "after the end, the last element's state: {st}");
            break;
        }
        assert!(std::time::Instant::now() < until, "not finished after {TIMEOUT:?}: {st}");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(seen.windows(2).all(|w| w[0] < w[1]), "lines out of order: {seen:?}");
    // Every move's line, so every change of state, was seen while it ran.
    for line in [4, 5, 7, 9, 10, 11, 12, 13, 15, 17] {
        assert!(seen.contains(&line), "line {line} not seen while running: {seen:?}");
    }
    eprintln!("status.modal: {samples} samples while running, lines {seen:?}");
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "stderr:\n{stderr}");
}
