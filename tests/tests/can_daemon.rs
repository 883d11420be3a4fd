//! End to end over a real SocketCAN interface: `interpd run --can` as the CANopen master,
//! `sim-plant --source can:` as three CiA 402 drives, a capture of the bus with kernel
//! timestamps as the independent witness. Run by scripts/vcan-vm.sh (on the host's vcan0 or
//! inside a VM); without `INTERPD_VCAN` each test prints a note and passes.
//!
//! - the daemon streams an example program (examples/can_tour.ngc, > 2000 cycles) to the
//!   drives; motion.start is refused until every drive is in Operation enabled; every cycle
//!   carries exactly one RPDO1 per node before its SYNC; the drives' positions follow the
//!   setpoints; the daemon's candump log holds the same setpoints as the bus, on the path;
//! - SIGKILL of the daemon mid-motion: every drive's SYNC watchdog trips (EMCY 0x8100) before a
//!   fourth SYNC would have been due, the drives ramp to a stop in Fault, and a new daemon
//!   takes them over (fault reset, enable) at the position where they stopped;
//! - malformed and unexpected frames (wrong DLCs, unknown COB-IDs, remote and 29-bit frames,
//!   bad values, EMCY storms) are counted by both sides and neither stops working;
//! - `interpd replay` sends a candump log with its timing, and the capture of the replay
//!   written with the log's timestamps is the identical file.

use interpd::config::Config;
use interpd::service::approach::with_approach;
use interpd_e2e::daemon::{Client, Daemon};
use interpd_e2e::vcan::{self, Capture, Proc};
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_protocol::api::codes;
use interpd_protocol::candump::{self, Iface, Record, Timestamp};
use interpd_protocol::cia301::{self, CanId, Emcy, Frame, Message, NmtState, NodeId, emcy_code};
use interpd_protocol::cia402::{PowerState, Rpdo1, Tpdo1};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The example program: lines, circles and a helix on X Y Z, 8.7 s at its feeds, from and back
/// to the origin.
const TOUR: &str = include_str!("../../examples/can_tour.ngc");
/// The default machine's cycle, at which the tour lasts over 2000 cycles.
const NOMINAL_CYCLE_MS: f64 = 4.0;
/// Cycles of motion the stream test must show.
const MIN_MOTION_CYCLES: usize = 2000;

/// The interpolation cycle of these tests: 4 ms, or `INTERPD_VCAN_CYCLE_MS` (scripts/vcan-vm.sh
/// sets a longer one in its TCG VM, whose emulated CPU wakes up to 30 ms late; every check
/// below counts in cycles, so the same checks hold at either cycle).
fn cycle_ms() -> f64 {
    match std::env::var("INTERPD_VCAN_CYCLE_MS") {
        Ok(v) => match v.parse::<f64>() {
            Ok(ms) if (NOMINAL_CYCLE_MS..=100.0).contains(&ms) => ms,
            _ => panic!("INTERPD_VCAN_CYCLE_MS={v:?}: expected milliseconds in [4, 100]"),
        },
        Err(_) => NOMINAL_CYCLE_MS,
    }
}

/// How much slower than the nominal cycle these tests run (1 at 4 ms).
fn dilation() -> f64 {
    cycle_ms() / NOMINAL_CYCLE_MS
}

/// The tour, repeated so that it lasts over [`MIN_MOTION_CYCLES`] at [`cycle_ms`].
fn program() -> String {
    let body: Vec<&str> = TOUR.lines().filter(|l| !l.starts_with('(') && l.trim() != "M30").collect();
    let repeats = dilation().ceil() as usize;
    let mut text = body.join("\n");
    for _ in 1..repeats {
        text.push('\n');
        text.push_str(&body.join("\n"));
    }
    text.push_str("\nM30\n");
    text
}
/// Node-IDs of X, Y, Z (not 1, 2, 3: the mapping axis → node is checked too).
const NODES: [u8; 3] = [2, 3, 4];
/// Increments per mm (the [sinks.can] default).
const INC_PER_MM: f64 = 10_000.0;
/// Waits in an emulated CPU are generous; the checks below measure what happened.
const SLOW: Duration = Duration::from_secs(60);
/// Wake-up lateness of a process in the TCG VM that the watchdog timing check allows when the
/// tests run dilated, ms: an emulated CPU wakes a process a few ms late as a rule and over
/// 30 ms late at worst.
const VM_LATENESS_MS: f64 = 35.0;
/// Cycles of motion in which a drive's TPDO1 may miss its cycle (arrive after the next SYNC)
/// when the tests run dilated in the VM; none at the nominal cycle.
const VM_MISSED_TPDO_FRACTION: f64 = 0.005;
/// How far a replayed frame may be off its time at the nominal cycle, ms.
const REPLAY_TOLERANCE_MS: f64 = 25.0;

fn nodes() -> Vec<NodeId> {
    NODES.iter().map(|&n| NodeId::new(n).expect("node-ID")).collect()
}

/// The default XYZ machine with the drives on `NODES`; written to `dir` for both processes.
fn config(dir: &std::path::Path) -> (PathBuf, Config) {
    let machine =
        interpd_config::DEFAULT_MACHINE_TOML.replacen("cycle_ms = 4.0", &format!("cycle_ms = {:.1}", cycle_ms()), 1);
    assert!(machine.contains(&format!("cycle_ms = {:.1}", cycle_ms())), "the default machine's cycle_ms line moved");
    let text = format!(
        "{}\n[sinks.can]\nnodes = [{}, {}, {}]\nboot_timeout_ms = 500\n",
        machine, NODES[0], NODES[1], NODES[2]
    );
    let path = dir.join("machine.toml");
    std::fs::write(&path, &text).expect("write config");
    let config = Config::from_toml_str(&text, "machine.toml").expect("valid config");
    (path, config)
}

fn start_daemon(iface: &str, cfg: &std::path::Path, candump: Option<&std::path::Path>) -> Daemon {
    let cfg = cfg.display().to_string();
    let log = candump.map(|p| p.display().to_string());
    let mut args = vec!["--config", cfg.as_str(), "--can", iface, "--no-shm"];
    if let Some(l) = &log {
        args.extend(["--candump", l.as_str()]);
    }
    Daemon::start(&args)
}

fn start_drives(iface: &str, cfg: &std::path::Path, dir: &std::path::Path) -> Proc {
    let source = format!("can:{iface}");
    let cfg = cfg.display().to_string();
    let mut p = Proc::start("sim-plant", &["--config", &cfg, "--source", &source], dir);
    p.wait_for_stderr("sim-plant: ready", SLOW);
    p
}

/// Polls `status` until every drive reports Operation enabled; returns the status.
fn wait_enabled(client: &mut Client) -> Value {
    let until = Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        let drives = st["drives"].as_array().cloned().unwrap_or_default();
        if drives.len() == NODES.len() && drives.iter().all(|d| d["state"] == "operation_enabled") {
            return st;
        }
        assert!(Instant::now() < until, "drives not enabled after {SLOW:?}: {}", st["drives"]);
        std::thread::sleep(Duration::from_millis(20));
    }
}

// ---------------------------------------------------------------------------------------------
// The bus as cycles
// ---------------------------------------------------------------------------------------------

/// One SYNC with the RPDO1s sent before it and the TPDO1s answering it.
#[derive(Debug, Clone, Default)]
struct Cycle {
    sync_t: Option<SystemTime>,
    rpdos: Vec<(NodeId, Rpdo1)>,
    tpdos: BTreeMap<NodeId, Tpdo1>,
}

#[derive(Debug, Default)]
struct Bus {
    cycles: Vec<Cycle>,
    emcy: Vec<(SystemTime, NodeId, Emcy)>,
    heartbeats: Vec<(SystemTime, NodeId, NmtState)>,
}

fn split(frames: &[(SystemTime, Frame)]) -> Bus {
    let mut bus = Bus::default();
    let mut pending = Vec::new();
    for (t, f) in frames {
        match cia301::decode(f) {
            Ok(Message::Rpdo1 { node, pdo }) => pending.push((node, pdo)),
            Ok(Message::Sync { .. }) => {
                bus.cycles.push(Cycle { sync_t: Some(*t), rpdos: std::mem::take(&mut pending), tpdos: BTreeMap::new() })
            }
            Ok(Message::Tpdo1 { node, pdo }) => {
                if let Some(c) = bus.cycles.last_mut() {
                    c.tpdos.insert(node, pdo);
                }
            }
            Ok(Message::Emcy { node, emcy }) => bus.emcy.push((*t, node, emcy)),
            Ok(Message::Heartbeat { node, state }) => bus.heartbeats.push((*t, node, state)),
            _ => {}
        }
    }
    bus
}

fn state_of(t: &Tpdo1) -> Option<PowerState> {
    PowerState::from_statusword(t.statusword)
}

fn secs_between(a: SystemTime, b: SystemTime) -> f64 {
    b.duration_since(a).map_or_else(|e| -e.duration().as_secs_f64(), |d| d.as_secs_f64())
}

/// Index of the first and last cycle whose targets differ from the cycle before.
fn motion_span(cycles: &[Cycle]) -> Option<(usize, usize)> {
    let moved: Vec<usize> = (1..cycles.len())
        .filter(|&k| {
            let (a, b) = (&cycles[k - 1].rpdos, &cycles[k].rpdos);
            a.len() == b.len() && a.iter().zip(b).any(|(x, y)| x.1.target_position != y.1.target_position)
        })
        .collect();
    Some((*moved.first()?, *moved.last()?))
}

/// The largest distance (mm) of the setpoints from the program path: the path is sampled
/// densely and each setpoint searched in a window ahead of the previous one's match.
fn max_distance_from_path(path: &Path, points: &[[f64; 3]]) -> f64 {
    const DS_MM: f64 = 0.005;
    let n = (path.length_mm() / DS_MM).ceil() as usize + 1;
    let mut d = AxisDerivs::default();
    let samples: Vec<[f64; 3]> = (0..=n)
        .map(|i| {
            path.eval((i as f64 * DS_MM).min(path.length_mm()), &mut d);
            [d.pos[0], d.pos[1], d.pos[2]]
        })
        .collect();
    let seg_dist = |p: &[f64; 3], a: &[f64; 3], b: &[f64; 3]| {
        let ab: Vec<f64> = (0..3).map(|k| b[k] - a[k]).collect();
        let ap: Vec<f64> = (0..3).map(|k| p[k] - a[k]).collect();
        let l2: f64 = ab.iter().map(|x| x * x).sum();
        let t = if l2 > 0.0 { (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0) } else { 0.0 };
        (0..3).map(|k| (ap[k] - t * ab[k]).powi(2)).sum::<f64>().sqrt()
    };
    // A cycle moves at most max_vel · 4 ms = 1 mm, i.e. 200 samples; search generously.
    const WINDOW: usize = 2000;
    let mut at = 0usize;
    let mut worst: f64 = 0.0;
    for p in points {
        let hi = (at + WINDOW).min(samples.len() - 1);
        let (best_i, best) = (at..hi.max(at + 1).min(samples.len() - 1))
            .map(|i| (i, seg_dist(p, &samples[i], &samples[i + 1])))
            .fold((at, f64::INFINITY), |acc, x| if x.1 < acc.1 { x } else { acc });
        at = best_i.saturating_sub(10);
        worst = worst.max(best);
    }
    worst
}

// ---------------------------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------------------------

#[test]
fn daemon_streams_a_program_to_three_simulated_drives() {
    let Some((iface, _bus)) = vcan::bus("daemon_streams_a_program_to_three_simulated_drives") else { return };
    let dir = vcan::temp_dir("can-stream");
    let (cfg, config) = config(&dir);
    let log_path = dir.join("bus.log");
    let capture = Capture::start(&iface);

    // The daemon first: no drive answers, so motion must be refused.
    let daemon = start_daemon(&iface, &cfg, Some(&log_path));
    let mut client = daemon.client();
    client.ok("program.load", json!({ "text": program(), "name": "can_tour.ngc" }));
    let refused = client.call("motion.start", Value::Null);
    let err = &refused["error"];
    assert_eq!(err["code"], codes::DRIVES_NOT_READY, "{refused}");
    let msg = err["message"].as_str().unwrap_or_default();
    assert!(msg.contains("drive X (node 2) has not answered") && msg.contains("drive Z (node 4)"), "{msg}");

    // The drives boot; the master starts them (NMT) and enables them at standstill.
    let drives = start_drives(&iface, &cfg, &dir);
    let t_ready = Instant::now();
    let st = wait_enabled(&mut client);
    eprintln!("drives enabled {:.3} s after sim-plant was ready: {}", t_ready.elapsed().as_secs_f64(), st["drives"]);
    client.ok("motion.start", Value::Null);
    let st = client.wait_state(&["finished", "error"], Duration::from_secs(120));
    assert_eq!(st["state"], "finished", "{st}");
    let bus_status = st["can_bus"].clone();
    for key in ["tx_queue_full", "tx_would_block", "tx_interface_down", "tx_other", "scale_errors"] {
        assert_eq!(bus_status[key], 0, "{key}: {bus_status}");
    }
    let (code, daemon_err) = daemon.terminate();
    assert_eq!(code, Some(0), "{daemon_err}");
    let (code, drives_err) = drives.terminate();
    assert_eq!(code, Some(0), "{drives_err}");
    let frames = capture.finish();
    let bus = split(&frames);
    let nodes = nodes();

    // Every cycle of the master carries exactly one RPDO1 per node before its SYNC. The SYNCs
    // of the start-up (before the first RPDO1) only ask the drives for their positions.
    let first_rpdo = bus.cycles.iter().position(|c| !c.rpdos.is_empty()).expect("RPDO1s on the bus");
    for (k, c) in bus.cycles.iter().enumerate().skip(first_rpdo) {
        let mut got: Vec<NodeId> = c.rpdos.iter().map(|r| r.0).collect();
        got.sort();
        assert_eq!(got, nodes, "cycle {k}: RPDO1 nodes before SYNC");
    }
    let master_cycles = bus.cycles.len() - first_rpdo;

    // Enabled before motion, enabled throughout it, and at least 2000 cycles of motion.
    let (m0, m1) = motion_span(&bus.cycles).expect("the targets moved");
    let motion_cycles = m1 - m0 + 1;
    assert!(motion_cycles >= MIN_MOTION_CYCLES, "only {motion_cycles} cycles of motion");
    let mut missed_tpdos = 0usize;
    for k in (m0 - 1)..=m1 {
        for n in &nodes {
            let Some(t) = bus.cycles[k].tpdos.get(n) else {
                missed_tpdos += 1;
                continue;
            };
            assert_eq!(state_of(t), Some(PowerState::OperationEnabled), "cycle {k} node {n}: 0x{:04X}", t.statusword);
        }
    }
    let allowed = if dilation() > 1.0 { (VM_MISSED_TPDO_FRACTION * motion_cycles as f64) as usize } else { 0 };
    assert!(missed_tpdos <= allowed, "{missed_tpdos} TPDO1s missed their cycle (allowed {allowed})");
    let enabled_at = (first_rpdo..m0)
        .find(|&k| {
            nodes.iter().all(|n| bus.cycles[k].tpdos.get(n).and_then(state_of) == Some(PowerState::OperationEnabled))
        })
        .expect("an all-enabled cycle before motion");

    // The drives follow: TPDO1 after SYNC k reports where the axis got to with the target of
    // cycle k − 1 (the drive's following error in between).
    let mut worst_follow_mm: f64 = 0.0;
    for k in (m0 + 1)..=(m1 + 1).min(bus.cycles.len() - 1) {
        for (n, pdo) in &bus.cycles[k - 1].rpdos {
            let Some(t) = bus.cycles[k].tpdos.get(n) else { continue };
            let actual = t.position_actual;
            worst_follow_mm = worst_follow_mm.max(f64::from(actual - pdo.target_position).abs() / INC_PER_MM);
        }
    }
    assert!(worst_follow_mm < 0.05, "the drives lag the setpoints by up to {worst_follow_mm} mm");
    // At the end they stand at the last setpoint (within 1 µm).
    let last = bus.cycles.iter().rev().find(|c| c.tpdos.len() == nodes.len()).expect("a last answered cycle");
    for (n, pdo) in &bus.cycles[m1].rpdos {
        let off = f64::from(last.tpdos[n].position_actual - pdo.target_position).abs() / INC_PER_MM;
        assert!(off <= 1e-3, "node {n} stands {off} mm from its last setpoint");
    }

    // The daemon's candump log: canonical text, and the same RPDO1/SYNC stream as the bus.
    let text = std::fs::read_to_string(&log_path).expect("candump log");
    let logged = candump::parse_log(&text).expect("the log parses");
    assert_eq!(candump::format_log(&logged), text, "read back and written again: identical");
    let log_frames: Vec<(SystemTime, Frame)> =
        logged.iter().map(|r| (UNIX_EPOCH + r.time.as_duration(), r.frame)).collect();
    let log_bus = split(&log_frames);
    let stream = |b: &Bus| b.cycles.iter().map(|c| c.rpdos.clone()).filter(|r| !r.is_empty()).collect::<Vec<_>>();
    assert_eq!(stream(&log_bus), stream(&bus), "the log's setpoints are the bus's, to the increment");
    // … and those setpoints lie on the program's path (1 µm, plus half an increment per axis).
    let program =
        interpd_motion::program::parse(&program(), "can_tour.ngc", &Settings::from(&config)).expect("program");
    let path = with_approach(&program.path, &[0.0; interpd_motion::path::MAX_AXES], &config);
    let points: Vec<[f64; 3]> = log_bus.cycles[m0..=m1]
        .iter()
        .map(|c| {
            let mut p = [0.0; 3];
            for (n, pdo) in &c.rpdos {
                let axis = NODES.iter().position(|&x| x == n.get()).expect("configured node");
                p[axis] = f64::from(pdo.target_position) / INC_PER_MM;
            }
            p
        })
        .collect();
    let off_path = max_distance_from_path(&path, &points);
    assert!(off_path <= 1e-3 + 0.5 * 3f64.sqrt() / INC_PER_MM, "a logged setpoint is {off_path} mm off the path");

    let rpdos: usize = bus.cycles.iter().map(|c| c.rpdos.len()).sum();
    let tpdos: usize = bus.cycles.iter().map(|c| c.tpdos.len()).sum();
    eprintln!(
        "CAN stream: {} frames on the bus ({} in the daemon's log): {} SYNC ({} of the master's cycles, {} start-up), \
         {rpdos} RPDO1, {tpdos} TPDO1, {} heartbeats, {} EMCY; all drives enabled at cycle {enabled_at}, motion \
         cycles {m0}..={m1} ({motion_cycles}); drives lag the setpoint of the cycle before by at most {:.4} mm; log \
         setpoints at most {:.2e} mm off the path",
        frames.len(),
        logged.len(),
        bus.cycles.len(),
        master_cycles,
        first_rpdo,
        bus.heartbeats.len(),
        bus.emcy.len(),
        worst_follow_mm,
        off_path
    );
    eprintln!(
        "daemon: {}",
        daemon_err.lines().filter(|l| l.contains("CAN bus") || l.contains("cycles")).collect::<Vec<_>>().join(" | ")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sigkill_mid_motion_every_drive_quick_stops_within_three_cycles() {
    let Some((iface, _bus)) = vcan::bus("sigkill_mid_motion_every_drive_quick_stops_within_three_cycles") else {
        return;
    };
    let dir = vcan::temp_dir("can-kill");
    let (cfg, config) = config(&dir);
    let cycle_s = config.cycle_s();
    let capture = Capture::start(&iface);
    let drives = start_drives(&iface, &cfg, &dir);
    let daemon = start_daemon(&iface, &cfg, None);
    let mut client = daemon.client();
    wait_enabled(&mut client);
    client.ok("program.load", json!({ "text": program(), "name": "can_tour.ngc" }));
    client.ok("motion.start", Value::Null);
    // Mid-motion: on the first circle, at speed.
    let until = Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        if st["s_mm"].as_f64().unwrap_or(0.0) > 25.0 {
            break;
        }
        assert!(Instant::now() < until && st["state"] == "running", "no progress: {st}");
        std::thread::sleep(Duration::from_millis(10));
    }
    drop(client);
    let _ = daemon.kill();
    let t_kill = SystemTime::now();
    // Let the watchdogs trip and the ramps run out (0.25 s at these speeds and decelerations).
    let nodes = nodes();
    let tripped = capture.wait_for(SLOW, |f| {
        let emcy = split(f).emcy;
        nodes.iter().all(|n| emcy.iter().any(|(_, m, e)| m == n && e.error_code == emcy_code::COMMUNICATION))
    });
    std::thread::sleep(Duration::from_millis(800));
    // Ask the drives where they stand: the test is the master now.
    let probe = vcan::open(&iface, Duration::from_millis(100));
    let t_probe = SystemTime::now();
    for _ in 0..3 {
        vcan::send(&probe, &Message::Sync { counter: None }.encode());
        std::thread::sleep(Duration::from_secs_f64(cycle_s));
    }
    std::thread::sleep(Duration::from_millis(100));
    let frames = capture.finish();
    assert!(tripped, "not every drive sent EMCY 0x8100");
    let bus = split(&frames);
    let before: Vec<&Cycle> = bus.cycles.iter().filter(|c| c.sync_t.is_some_and(|t| t < t_probe)).collect();
    let probes: Vec<&Cycle> = bus.cycles.iter().filter(|c| c.sync_t.is_some_and(|t| t >= t_probe)).collect();
    let last_sync = before.last().and_then(|c| c.sync_t).expect("the daemon's SYNCs");
    assert!(secs_between(last_sync, t_kill) >= 0.0, "SYNC after the kill");
    let last_answered = before.iter().rev().find(|c| c.tpdos.len() == nodes.len()).expect("answers before the kill");
    let prev_answered = before.iter().rev().filter(|c| c.tpdos.len() == nodes.len()).nth(1).expect("two answers");

    let mut report = Vec::new();
    for (i, n) in nodes.iter().enumerate() {
        let (t_emcy, emcy) = bus
            .emcy
            .iter()
            .find(|(t, m, e)| m == n && e.error_code == emcy_code::COMMUNICATION && *t > last_sync)
            .map(|(t, _, e)| (*t, *e))
            .unwrap_or_else(|| panic!("node {n}: no EMCY 0x8100 after the last SYNC"));
        assert_eq!(emcy.vendor[0], 1, "node {n}: EMCY 0x8100 is the SYNC watchdog (vendor byte 1)");
        let cycles = secs_between(last_sync, t_emcy) / cycle_s;
        // Three SYNCs missed, detected before the fourth would have been due (plus, in an
        // emulated VM, the drive process's own wake-up lateness).
        let late_cycles = VM_LATENESS_MS * (dilation() - 1.0).min(1.0) / cycle_ms();
        assert!(cycles > 3.0 && cycles < 4.0 + late_cycles, "node {n}: watchdog reacted after {cycles:.2} cycles");
        // Quick stop: Fault, standing, within the braking distance v²/(2a) (+ 2 cycles of travel).
        let probe_states: Vec<(Option<PowerState>, i32)> =
            probes.iter().filter_map(|c| c.tpdos.get(n)).map(|t| (state_of(t), t.position_actual)).collect();
        assert!(probe_states.len() >= 2, "node {n}: no answers to the probe SYNCs");
        assert!(probe_states.iter().all(|s| s.0 == Some(PowerState::Fault)), "node {n}: {probe_states:?}");
        assert!(probe_states.windows(2).all(|w| w[0].1 == w[1].1), "node {n} still moves: {probe_states:?}");
        let p_kill = f64::from(last_answered.tpdos[n].position_actual) / INC_PER_MM;
        let v = (p_kill - f64::from(prev_answered.tpdos[n].position_actual) / INC_PER_MM) / cycle_s;
        let a = config.axes[i].max_acc_per_s2;
        let travel = (f64::from(probe_states[0].1) / INC_PER_MM - p_kill).abs();
        let allowed = v * v / (2.0 * a) + 2.0 * 3.0 * v.abs() * cycle_s + 0.01;
        assert!(travel <= allowed, "node {n} ran {travel} mm after the kill (v {v} mm/s, allowed {allowed})");
        report.push(format!(
            "node {n}: EMCY 0x8100 {cycles:.2} cycles after the last SYNC, v {v:.1} mm/s, stopped after {travel:.3} mm"
        ));
    }
    let (code, drives_err) = drives.terminate();
    assert_eq!(code, Some(0), "{drives_err}");
    assert_eq!(drives_err.matches("1 watchdog trips").count(), nodes.len(), "{drives_err}");
    eprintln!("SIGKILL: {}", report.join("; "));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_new_daemon_takes_over_faulted_drives_where_they_stand() {
    let Some((iface, _bus)) = vcan::bus("a_new_daemon_takes_over_faulted_drives_where_they_stand") else { return };
    let dir = vcan::temp_dir("can-takeover");
    let (cfg, _config) = config(&dir);
    let drives = start_drives(&iface, &cfg, &dir);
    // Move the drives away from zero with a first daemon, then kill it: they fault there.
    let first = start_daemon(&iface, &cfg, None);
    let mut client = first.client();
    wait_enabled(&mut client);
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X3 Y-2 Z1 F3000\nM30\n" }));
    client.ok("motion.start", Value::Null);
    client.wait_state(&["finished"], SLOW);
    // "finished" means the last setpoint is out; the drives (two-mass plants) follow with a
    // lag. Kill the daemon only once they stand at the target, so they fault exactly there.
    let until = std::time::Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        let at: Vec<f64> = st["drives"]
            .as_array()
            .map_or(Vec::new(), |d| d.iter().filter_map(|d| d["position_actual_units"].as_f64()).collect());
        if at.len() == 3 && at.iter().zip([3.0, -2.0, 1.0]).all(|(p, w)| (p - w).abs() < 5e-4) {
            break;
        }
        assert!(std::time::Instant::now() < until, "the drives did not reach the target: {at:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(client);
    let _ = first.kill();
    std::thread::sleep(Duration::from_millis(300));
    // The second one adopts their positions, resets the fault and enables them.
    let second = start_daemon(&iface, &cfg, None);
    let mut client = second.client();
    let st = wait_enabled(&mut client);
    let position: Vec<f64> = st["position"].as_array().expect("position").iter().filter_map(Value::as_f64).collect();
    for (p, want) in position.iter().zip([3.0, -2.0, 1.0]) {
        assert!((p - want).abs() < 1e-3, "the new daemon starts at {position:?}, the drives stand at 3, -2, 1");
    }
    for d in st["drives"].as_array().expect("drives") {
        assert_eq!(d["last_emcy_code"], Value::Null, "EMCY before this daemon started is not its business: {d}");
    }
    // And moves them on.
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X0 Y0 Z0 F3000\nM30\n" }));
    client.ok("motion.start", Value::Null);
    let st = client.wait_state(&["finished", "error"], SLOW);
    assert_eq!(st["state"], "finished", "{st}");
    drop(client);
    let (code, err) = second.terminate();
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = drives.terminate();
    assert_eq!(code, Some(0), "{err}");
    eprintln!("take-over: {}", err.lines().filter(|l| l.contains("node")).collect::<Vec<_>>().join(" | "));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Numbers after `label` in a text ("3 wrong DLC" → 3 for label "wrong DLC").
fn count_before(text: &str, label: &str) -> u64 {
    let at = text.find(label).unwrap_or_else(|| panic!("{label:?} not in {text}"));
    text[..at]
        .split_whitespace()
        .last()
        .and_then(|w| w.trim_matches(',').parse().ok())
        .unwrap_or_else(|| panic!("no count before {label:?}"))
}

#[test]
fn malformed_and_unexpected_frames_are_counted_on_both_sides() {
    let Some((iface, _bus)) = vcan::bus("malformed_and_unexpected_frames_are_counted_on_both_sides") else { return };
    let dir = vcan::temp_dir("can-malformed");
    let (cfg, _config) = config(&dir);
    let drives = start_drives(&iface, &cfg, &dir);
    let daemon = start_daemon(&iface, &cfg, None);
    let mut client = daemon.client();
    wait_enabled(&mut client);
    let before = client.ok("status", Value::Null)["can_bus"].clone();

    let f = |id: u16, data: &[u8]| Frame::standard(id, data).expect("frame");
    let mut plan: Vec<Frame> = Vec::new();
    // Wrong DLCs: RPDO1 to a drive (sim-plant: EMCY 0x8210/0x8220), TPDO1 and heartbeat from a
    // drive (daemon), SYNC and NMT (both).
    for len in [0usize, 4, 5, 7, 8] {
        plan.push(f(0x200 + u16::from(NODES[1]), &[0x0F; 8][..len]));
        plan.push(f(0x180 + u16::from(NODES[2]), &[0x37; 8][..len]));
    }
    plan.push(f(0x700 + u16::from(NODES[0]), &[5, 5]));
    plan.push(f(0x080, &[1, 2, 3]));
    plan.push(f(0x000, &[1]));
    // Unknown COB-IDs, 29-bit and remote frames, undefined values.
    for id in [0x100u16, 0x581, 0x601, 0x281, 0x7E5, 0x7FF] {
        plan.push(f(id, &[0; 8]));
    }
    plan.push(Frame::data(CanId::extended(0x0000_0202).expect("id"), &[0; 6]).expect("frame"));
    plan.push(Frame::remote(CanId::standard(0x700 + u16::from(NODES[0])).expect("id"), 1).expect("frame"));
    plan.push(f(0x000, &[0x03, 0]));
    plan.push(f(0x700 + u16::from(NODES[2]), &[0x42]));
    // An EMCY storm from a node that is not configured.
    for i in 0..500u32 {
        let b = i.to_le_bytes();
        let emcy = Emcy { error_code: 0x1000, error_register: 1, vendor: [b[0], b[1], 0, 0, 0] };
        plan.push(Message::Emcy { node: NodeId::new(9).expect("node"), emcy }.encode());
    }
    let tx = vcan::open(&iface, Duration::from_millis(100));
    for (i, frame) in plan.iter().enumerate() {
        vcan::send(&tx, frame);
        if i % 32 == 31 {
            // Paced like a busy bus (about 8000 frames/s), not like a flood.
            std::thread::sleep(Duration::from_millis(4));
        }
    }
    std::thread::sleep(Duration::from_millis(300));

    // The daemon counted them and its drives are still enabled.
    let st = wait_enabled(&mut client);
    let after = &st["can_bus"];
    let delta = |k: &str| after[k].as_u64().unwrap_or(0) - before[k].as_u64().unwrap_or(0);
    // RPDO1s of wrong length go by as the master's own object; TPDO1 (5), heartbeat (1),
    // SYNC (1), NMT (1) are the wrong DLCs the master sees from the others.
    const WRONG_DLC_AT_MASTER: u64 = 5 + 1 + 1 + 1;
    assert!(delta("rx_wrong_dlc") >= WRONG_DLC_AT_MASTER, "{after}");
    assert!(delta("rx_unknown_cob_id") >= 7, "{after}");
    assert!(delta("rx_not_data") >= 1 && delta("rx_bad_value") >= 2, "{after}");
    assert!(delta("rx_foreign_node") >= 500, "{after}");
    // It still moves them.
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X2 Y1 Z-1 F3000\nG1 X0 Y0 Z0\nM30\n" }));
    client.ok("motion.start", Value::Null);
    let st = client.wait_state(&["finished", "error"], SLOW);
    assert_eq!(st["state"], "finished", "{st}");
    drop(client);
    let (code, daemon_err) = daemon.terminate();
    assert_eq!(code, Some(0), "{daemon_err}");
    let (code, drives_err) = drives.terminate();
    assert_eq!(code, Some(0), "{drives_err}");
    // The drives counted theirs.
    // RPDO1 (5), TPDO1 (5), heartbeat, SYNC, NMT.
    const WRONG_DLC_AT_DRIVES: u64 = 5 + 5 + 1 + 1 + 1;
    assert!(count_before(&drives_err, "wrong DLC") >= WRONG_DLC_AT_DRIVES, "{drives_err}");
    assert!(count_before(&drives_err, "unknown COB-ID") >= 7, "{drives_err}");
    assert!(count_before(&drives_err, "frames of other nodes") >= 500, "{drives_err}");
    // Per node (one line each): the bad lengths went to one of them.
    let bad_len: u64 = drives_err
        .lines()
        .filter(|l| l.contains("bad RPDO1 length"))
        .map(|l| count_before(l, "bad RPDO1 length"))
        .sum();
    assert!(bad_len >= 5, "{drives_err}");
    eprintln!(
        "malformed: daemon {}; drives: {}",
        after,
        drives_err.lines().filter(|l| l.contains("ignored") || l.contains("node")).collect::<Vec<_>>().join(" | ")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replay_sends_a_candump_log_with_its_timing() {
    let Some((iface, _bus)) = vcan::bus("replay_sends_a_candump_log_with_its_timing") else { return };
    let dir = vcan::temp_dir("can-replay");
    // 300 cycles of a 3-axis master at 4 ms plus heartbeats, as a canonical candump log.
    let t0 = 1_700_000_000_000_000u64;
    let name = Iface::new(&iface).expect("iface");
    let mut original = Vec::new();
    for k in 0..300u64 {
        let t = t0 + k * 4000;
        for (j, &n) in NODES.iter().enumerate() {
            let pdo = Rpdo1 { controlword: 0x000F, target_position: (k as i32) * (j as i32 + 1) * 7 - 1000 };
            let frame = Message::Rpdo1 { node: NodeId::new(n).expect("node"), pdo }.encode();
            original.push(Record { time: Timestamp::from_micros(t + 20 * j as u64), iface: name.clone(), frame });
        }
        original.push(Record {
            time: Timestamp::from_micros(t + 80),
            iface: name.clone(),
            frame: Message::Sync { counter: None }.encode(),
        });
        if k % 25 == 0 {
            let hb = Message::Heartbeat { node: NodeId::new(NODES[0]).expect("node"), state: NmtState::Operational };
            original.push(Record { time: Timestamp::from_micros(t + 2000), iface: name.clone(), frame: hb.encode() });
        }
    }
    let log = dir.join("original.log");
    let text = candump::format_log(&original);
    std::fs::write(&log, &text).expect("write log");

    let speed = 2.0;
    let capture = Capture::start(&iface);
    let log_arg = log.display().to_string();
    let to = format!("can:{iface}");
    let speed_arg = speed.to_string();
    let out = std::process::Command::new(interpd_e2e::binary("interpd"))
        .args(["replay", log_arg.as_str(), "--to", to.as_str(), "--speed", speed_arg.as_str()])
        .output()
        .expect("run interpd replay");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{stderr}");
    std::thread::sleep(Duration::from_millis(100));
    let frames = capture.finish();

    assert_eq!(frames.len(), original.len(), "{stderr}");
    let mut worst_ms: f64 = 0.0;
    for (i, ((t, f), r)) in frames.iter().zip(&original).enumerate() {
        assert_eq!(*f, r.frame, "frame {i}");
        let want_s = (r.time.as_micros() - t0) as f64 * 1e-6 / speed;
        let got_s = secs_between(frames[0].0, *t) + (original[0].time.as_micros() - t0) as f64 * 1e-6 / speed;
        worst_ms = worst_ms.max((got_s - want_s).abs() * 1e3);
    }
    // Timing as canplayer: each frame at its offset / speed (an emulated CPU adds jitter).
    let allowed_ms = REPLAY_TOLERANCE_MS * dilation();
    assert!(worst_ms < allowed_ms, "a replayed frame was {worst_ms} ms off its time (allowed {allowed_ms} ms)");
    // The capture written with the log's own timestamps is the identical file.
    let rewritten: Vec<Record> = frames
        .iter()
        .zip(&original)
        .map(|((_, f), r)| Record { time: r.time, iface: name.clone(), frame: *f })
        .collect();
    assert_eq!(candump::format_log(&rewritten), text);
    let back = candump::parse_log(&text).expect("parse");
    assert_eq!(candump::format_log(&back), text, "read back and written again: identical");
    // Without --to the log's interface is used; --to shm takes MCAP recordings only (exit 2).
    let out = std::process::Command::new(interpd_e2e::binary("interpd"))
        .args(["replay", log_arg.as_str(), "--to", "shm"])
        .output()
        .expect("run interpd replay");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--to shm needs an MCAP recording"));
    eprintln!(
        "replay: {} frames at speed {speed}, worst timing error {worst_ms:.3} ms; {}",
        frames.len(),
        stderr.trim()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
