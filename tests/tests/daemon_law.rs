//! End to end: motion-law moves run by `interpd run` as a real process, started over
//! the control socket (`motion.law`, and a program of `LAW` statements with `program.load`),
//! the setpoints received over iceoryx2 and checked: no gaps, axis limits by finite
//! differences of the 4 ms positions, the law's duration, and the exact stroke at the end.
//! Then through the simulated plant: `interpd demo --program examples/laws.ngc`.

use interpd::config::Config;
use interpd::service::law_run::parse_law_program;
use interpd_e2e::daemon::{AxisLimits, Client, Collector, Daemon, limit_ratios};
use interpd_e2e::{binary, example};
use interpd_motion::Settings;
use interpd_protocol::shm::Setpoints;
use serde_json::{Value, json};
use std::time::Duration;

const RUN_TIMEOUT: Duration = Duration::from_secs(30);

/// Largest |value|/limit of velocity, acceleration and jerk over all axes.
fn ratios(config: &Config, sps: &[Setpoints]) -> [f64; 3] {
    let limits: Vec<AxisLimits> = AxisLimits::of(config);
    let r = limit_ratios(config.cycle_s(), &limits, sps);
    [r[0], r[1].max(r[3]), r[2]]
}

/// Runs to `finished` and returns the setpoints of this run (those after `from`).
fn run(c: &mut Client, collector: &Collector, from: usize) -> Vec<Setpoints> {
    c.wait_state(&["finished", "error"], RUN_TIMEOUT);
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "finished", "{st}");
    std::thread::sleep(Duration::from_millis(100));
    collector.snapshot()[from..].to_vec()
}

fn check(name: &str, config: &Config, sps: &[Setpoints], end: [f64; 3], duration_s: f64) {
    for w in sps.windows(2) {
        assert_eq!(w[1].cycle, w[0].cycle + 1, "{name}: gap in cycle numbers");
    }
    let r = ratios(config, sps);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "{name}: limit ratios {r:?}");
    let last = sps.last().expect("setpoints");
    for (k, want) in end.iter().enumerate() {
        assert!((last.pos[k] - want).abs() < 1e-9, "{name}: axis {k} ends at {} instead of {want}", last.pos[k]);
    }
    let moving_s = sps.iter().filter(|s| s.v_mm_s.abs() > 1e-9).count() as f64 * config.cycle_s();
    assert!(
        (moving_s - duration_s).abs() <= 4.0 * config.cycle_s(),
        "{name}: moved {moving_s} s, the laws take {duration_s} s"
    );
    eprintln!("{name}: {} setpoints, moving {moving_s:.3} s, limit ratios v/a/j {r:.4?}", sps.len());
}

#[test]
fn law_moves_stream_within_the_limits_to_the_exact_stroke() {
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();

    // Too fast: refused with the factor, and nothing moves.
    let e = c.call("motion.law", json!({ "statement": "LAW PRESET=rr7 DURATION=0.1 X=30" }));
    assert_eq!(e["error"]["code"], -32001, "{e}");
    let msg = e["error"]["message"].as_str().unwrap_or_default();
    assert!(msg.contains("axis X") && msg.contains("grow by a factor of"), "{msg}");
    let bad = c.call("motion.law", json!({ "statement": "G1 X10" }));
    assert_eq!(bad["error"]["code"], -32602, "{bad}");

    // The refused requests left the axes where they were.
    let before = collector.snapshot();
    assert!(before.iter().all(|s| s.pos[..2] == [0.0, 0.0]), "a refused law moved the axes");

    // One move over JSON-RPC.
    let from = before.len();
    let r = c.ok("motion.law", json!({ "statement": "LAW PRESET=rr7 DURATION=0.4 X=30 Y=-10" }));
    assert_eq!(r["duration_s"], 0.4, "{r}");
    // While it moves, another move is refused for the state (−32002), before any limit check:
    // a too-fast one too.
    let busy = c.call("motion.law", json!({ "statement": "LAW PRESET=rr7 DURATION=0.1 X=30" }));
    assert_eq!(busy["error"]["code"], -32002, "{busy}");
    let sps = run(&mut c, &collector, from);
    check("motion.law", &config, &sps, [30.0, -10.0, 0.0], 0.4);

    // A program of LAW statements, from where the first move ended.
    let from = collector.snapshot().len();
    c.ok("program.load", json!({ "path": example("laws.ngc").display().to_string() }));
    c.ok("motion.start", Value::Null);
    let sps = run(&mut c, &collector, from);
    check("laws.ngc", &config, &sps, [30.0, -10.0, 0.0], laws_duration_s(&config));

    let sps = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "exit status; stderr:\n{stderr}");
    assert!(!sps.is_empty());
}

/// The duration of examples/laws.ngc's moves (the stretched one included), from the law module.
fn laws_duration_s(config: &Config) -> f64 {
    let text = std::fs::read_to_string(example("laws.ngc")).expect("laws.ngc");
    let prog = parse_law_program(&text, "laws.ngc").expect("parses").expect("a law program");
    let mut here = [0.0; interpd_motion::path::MAX_AXES];
    here[..2].copy_from_slice(&[30.0, -10.0]);
    prog.moves(&Settings::from(config), &here, "laws.ngc").expect("feasible").iter().map(|m| m.duration_s()).sum()
}

#[test]
fn law_program_drives_the_simulated_plant() {
    let dir = std::env::temp_dir().join(format!("interpd-law-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = std::process::Command::new(binary("interpd"))
        .args(["demo", "--program"])
        .arg(example("laws.ngc"))
        .current_dir(&dir)
        .output()
        .expect("run interpd demo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "interpd demo failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("missed cycles: 0"), "the plant missed setpoints:\n{stdout}");
    eprintln!("{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}
