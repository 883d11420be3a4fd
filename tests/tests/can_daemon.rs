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
//!   takes them over at the position where they stopped (`drives.reset`, then enable);
//! - malformed and unexpected frames (wrong DLCs, unknown COB-IDs, remote and 29-bit frames,
//!   bad values, EMCY storms) are counted by both sides and neither stops working;
//! - `interpd replay` sends a candump log with its timing, and the capture of the replay
//!   written with the log's timestamps is the identical file.

use interpd::config::Config;
use interpd_config::plant::FineInterpolation;
use interpd_e2e::daemon::{Client, Daemon};
use interpd_e2e::vcan::{self, Capture, Proc};
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::{Feed, Settings};
use interpd_protocol::api::codes;
use interpd_protocol::candump::{self, Iface, Record, Timestamp};
use interpd_protocol::cia301::{self, CanId, Emcy, Frame, Message, NmtState, NodeId, emcy_code};
use interpd_protocol::cia402::{PowerState, Rpdo1, Scale, Tpdo1};
use serde_json::{Value, json};
use sim_plant::{AxisTarget, Plant};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The example program: lines, circles and a helix on X Y Z, 8.7 s at its feeds, from and back
/// to the origin.
const TOUR: &str = include_str!("../../examples/can_tour.ngc");
/// The default machine's cycle, at which the tour lasts over 2000 cycles.
const CYCLE_MS: f64 = 4.0;
/// Cycles of motion the stream test must show.
const MIN_MOTION_CYCLES: usize = 2000;

/// Whether the bus runs in virtual time (scripts/vcan-vm.sh sets `INTERPD_VCAN_VIRTUAL_TIME=1`
/// in its VM, whose clock advances with the instructions it executes: no thread is late
/// because the host was busy, so timing is checked to the microsecond there; on a host's vcan
/// the same checks allow the host's scheduling latency).
fn virtual_time() -> bool {
    std::env::var("INTERPD_VCAN_VIRTUAL_TIME").is_ok_and(|v| v == "1")
}

/// The tour, once (8.7 s at its feeds: over [`MIN_MOTION_CYCLES`] at 4 ms).
fn program() -> String {
    TOUR.lines().filter(|l| !l.starts_with('(')).collect::<Vec<_>>().join("\n") + "\n"
}
/// Node-IDs of X, Y, Z (not 1, 2, 3: the mapping axis → node is checked too).
const NODES: [u8; 3] = [2, 3, 4];
/// Increments per mm (the [sinks.can] default).
const INC_PER_MM: f64 = 10_000.0;
/// Waits in an emulated CPU are generous; the checks below measure what happened.
const SLOW: Duration = Duration::from_secs(60);
/// How far a replayed frame may be off its time, ms: on a host's vcan (its scheduling
/// latency under load) and in virtual time (the replay's own wake-up path).
const REPLAY_TOLERANCE_MS: f64 = 25.0;
const REPLAY_TOLERANCE_VIRTUAL_MS: f64 = 0.2;
/// How far a SYNC may be off the 4 ms grid in virtual time, ms (the real-time thread's wake-up
/// path between its deadline and the frame on the bus).
const SYNC_JITTER_VIRTUAL_MS: f64 = 0.05;
/// SCHED_FIFO priority of the simulated drives in virtual time: below the daemon's real-time
/// thread ([rt] priority 80), so on the guest's one CPU the master's cycle is never held up by
/// the drives' work (page faults, a burst of frames); the drives still preempt everything else,
/// and the master's cycle work (tens of µs) is far below their three-cycle watchdog.
const DRIVES_RT_PRIORITY: &str = "70";
/// The drives' positions against the in-process plant fed with the same targets, mm.
const MODEL_MATCH_MM: f64 = 1e-3;

fn nodes() -> Vec<NodeId> {
    NODES.iter().map(|&n| NodeId::new(n).expect("node-ID")).collect()
}

/// The default XYZ machine with the drives on `NODES`; written to `dir` for both processes.
fn config(dir: &std::path::Path) -> (PathBuf, Config) {
    let text = format!(
        "{}\n[sinks.can]\nnodes = [{}, {}, {}]\nboot_timeout_ms = 500\n",
        interpd_config::DEFAULT_MACHINE_TOML,
        NODES[0],
        NODES[1],
        NODES[2]
    );
    let path = dir.join("machine.toml");
    std::fs::write(&path, &text).expect("write config");
    let config = Config::from_toml_str(&text, "machine.toml").expect("valid config");
    assert_eq!(config.machine.cycle_ms, CYCLE_MS, "the default machine's cycle");
    (path, config)
}

fn start_daemon(iface: &str, cfg: &std::path::Path, candump: Option<&std::path::Path>) -> Daemon {
    let log = candump.map(|p| p.display().to_string());
    match &log {
        Some(l) => start_daemon_with(iface, cfg, &["--candump", l.as_str()]),
        None => start_daemon_with(iface, cfg, &[]),
    }
}

fn start_daemon_with(iface: &str, cfg: &std::path::Path, extra: &[&str]) -> Daemon {
    let cfg = cfg.display().to_string();
    let mut args = vec!["--config", cfg.as_str(), "--can", iface, "--no-shm"];
    args.extend(extra);
    Daemon::start(&args)
}

fn start_drives(iface: &str, cfg: &std::path::Path, dir: &std::path::Path) -> Proc {
    let source = format!("can:{iface}");
    let cfg = cfg.display().to_string();
    let mut args = vec!["--config", cfg.as_str(), "--source", source.as_str()];
    // In virtual time the drives run with SCHED_FIFO just below the daemon's real-time thread:
    // on the VM's one CPU only the master's short cycle work can delay them, and their own work
    // never delays the master. On a host's vcan they run as an ordinary process.
    if virtual_time() {
        args.extend(["--rt-priority", DRIVES_RT_PRIORITY]);
    }
    let mut p = Proc::start("sim-plant", &args, dir);
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

/// Runs the targets of a captured bus through sim-plant's plant in this process, as
/// `sim-plant --source can:` does: at each SYNC a drive in Operation enabled takes the target
/// of the last RPDO1 it received and its axis follows it over one communication cycle with
/// linear fine interpolation; any other drive holds its motor with the brake. Returns the
/// largest difference between the TPDO1 positions on the bus and the model's (a TPDO1 answers
/// its SYNC with the position before that cycle's step), and the largest following error
/// (a TPDO1 against the target of the cycle before), both in mm.
fn replay_through_plant(config: &Config, bus: &Bus, nodes: &[NodeId]) -> (f64, f64) {
    let mut config = config.clone();
    config.plant.fine_interpolation = FineInterpolation::Linear;
    let mut plant = Plant::from_config(&config).expect("the plant of the test's machine");
    let n = nodes.len();
    plant.reset(0, &vec![0.0; n]).expect("plant at rest at 0");
    let scale = Scale::new(INC_PER_MM).expect("scale");
    let mut last_rpdo: Vec<Option<i32>> = vec![None; n];
    let mut target = vec![0.0; n];
    let mut followed = vec![false; n];
    let (mut model_mm, mut follow_mm): (f64, f64) = (0.0, 0.0);
    for c in &bus.cycles {
        for (node, pdo) in &c.rpdos {
            if let Some(i) = nodes.iter().position(|m| m == node) {
                last_rpdo[i] = Some(pdo.target_position);
            }
        }
        let mut targets = vec![AxisTarget::default(); n];
        for (i, node) in nodes.iter().enumerate() {
            let Some(tpdo) = c.tpdos.get(node) else { continue };
            let model = scale.to_increments(plant.outputs()[i].motor_pos).expect("model position in range");
            model_mm = model_mm.max(f64::from(tpdo.position_actual - model).abs() / INC_PER_MM);
            if followed[i] {
                follow_mm = follow_mm.max((f64::from(tpdo.position_actual) / INC_PER_MM - target[i]).abs());
            }
            followed[i] = state_of(tpdo) == Some(PowerState::OperationEnabled);
        }
        for (i, t) in targets.iter_mut().enumerate() {
            if followed[i] {
                if let Some(p) = last_rpdo[i] {
                    target[i] = scale.to_units(p);
                }
            }
            plant.axis_mut(i).expect("axis").set_brake(!followed[i]);
            t.pos = target[i];
        }
        plant.step(&targets, CYCLE_MS * 1e-3).expect("plant step");
    }
    (model_mm, follow_mm)
}

/// The largest distance (mm) of the setpoints from the program path: the path is sampled
/// densely and each setpoint searched in a window ahead of the previous one's match.
fn max_distance_from_path(path: &Path, points: &[[f64; 3]]) -> f64 {
    const DS_MM: f64 = 0.005;
    let n = (path.length_mm() / DS_MM).ceil() as usize + 1;
    let mut d = AxisDerivs::default();
    // Every DS_MM and every element's end: a corner is a vertex of the polyline, not cut by a
    // chord (the machine stands exactly on it at an exact stop).
    let mut at_s: Vec<f64> = (0..=n).map(|i| (i as f64 * DS_MM).min(path.length_mm())).collect();
    at_s.extend(path.elements.iter().map(|e| e.s_end_mm()));
    at_s.sort_by(f64::total_cmp);
    let samples: Vec<[f64; 3]> = at_s
        .iter()
        .map(|&s| {
            path.eval_left(s, &mut d);
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
    // "finished" means the last setpoint is out; the drives follow with their lag. They come
    // to rest at it (checked below from the bus) before the daemon is stopped.
    let until = Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        let drives = st["drives"].as_array().cloned().unwrap_or_default();
        let standing = drives.iter().all(|d| {
            let (p, t) = (d["position_actual"].as_i64(), d["target_position"].as_i64());
            p.zip(t).is_some_and(|(p, t)| (p - t).abs() <= 10)
        });
        if drives.len() == NODES.len() && standing {
            break;
        }
        assert!(Instant::now() < until, "the drives do not come to rest at the last setpoint: {}", st["drives"]);
        std::thread::sleep(Duration::from_millis(20));
    }
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
    assert_eq!(missed_tpdos, 0, "TPDO1s that missed their cycle");
    let enabled_at = (first_rpdo..m0)
        .find(|&k| {
            nodes.iter().all(|n| bus.cycles[k].tpdos.get(n).and_then(state_of) == Some(PowerState::OperationEnabled))
        })
        .expect("an all-enabled cycle before motion");

    // The SYNC period of the master: in virtual time 4 ms to a few µs (the wake-up path) in
    // every cycle from its first RPDO1 to the end of the motion, on a host within a cycle.
    let periods_ms: Vec<(usize, f64)> = bus.cycles[first_rpdo..=(m1 + 1).min(bus.cycles.len() - 1)]
        .windows(2)
        .enumerate()
        .map(|(j, w)| (first_rpdo + j + 1, secs_between(w[0].sync_t.expect("SYNC"), w[1].sync_t.expect("SYNC")) * 1e3))
        .collect();
    let worst_sync_ms = periods_ms.iter().map(|p| (p.1 - CYCLE_MS).abs()).fold(0.0, f64::max);
    let allowed_sync_ms = if virtual_time() { SYNC_JITTER_VIRTUAL_MS } else { CYCLE_MS };
    let off: Vec<&(usize, f64)> = periods_ms.iter().filter(|p| (p.1 - CYCLE_MS).abs() > allowed_sync_ms).collect();
    assert!(off.is_empty(), "SYNC periods off 4 ms by more than {allowed_sync_ms} ms (cycle, ms): {off:?}");

    // The drives do exactly what their model does: the plant of sim-plant, in this process,
    // fed with the targets the bus carried, one communication cycle per SYNC (a CSP drive
    // takes the target of its RPDO1 at SYNC k and reaches it at SYNC k + 1), reports the
    // positions the drives' TPDO1s report. The following error is then the plant's own.
    let (model_mm, worst_follow_mm) = replay_through_plant(&config, &bus, &nodes);
    assert!(model_mm <= MODEL_MATCH_MM, "the drives' positions differ from the plant model by {model_mm} mm");
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
    // The daemon starts at the origin: its motion runs the rapid move to the program's start
    // first, as a feed started there does.
    let settings = Settings::from(&config);
    let path =
        Feed::builder(&settings).start_from([0.0; interpd_motion::path::MAX_AXES]).whole(program.path).path().clone();
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
         cycles {m0}..={m1} ({motion_cycles}); SYNC period at most {:.4} ms off 4 ms; drives at most {:.1e} mm \
         from the plant model, lagging the setpoint of the cycle before by at most {:.4} mm; log setpoints at most \
         {:.2e} mm off the path",
        frames.len(),
        logged.len(),
        bus.cycles.len(),
        master_cycles,
        first_rpdo,
        bus.heartbeats.len(),
        bus.emcy.len(),
        worst_sync_ms,
        model_mm,
        worst_follow_mm,
        off_path
    );
    eprintln!(
        "daemon: {}",
        daemon_err.lines().filter(|l| l.contains("CAN bus") || l.contains("cycles")).collect::<Vec<_>>().join(" | ")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The drives' reaction to a tripped watchdog in virtual time, cycles (600 µs: the wake-up and
/// the EMCY on the bus, after the work each simulated drive does on the VM's one vCPU: since
/// the commissioning commands came in, runs measured 0.034–0.094 cycles).
const WATCHDOG_REACTION_VIRTUAL_CYCLES: f64 = 0.15;
/// SYNCs the test sends to drives in Fault, one per cycle, to see them stand.
const PROBE_SYNCS: usize = 50;

/// The SYNC watchdog trips when more than three cycles passed without SYNC: after the third
/// missed SYNC and before the fourth would be due. sim-plant wakes at the watchdog's deadline,
/// so in virtual time the EMCY follows the 3 cycles within its reaction time; on a host's vcan
/// it comes before the fourth SYNC would have been due.
fn assert_watchdog_timing(node: NodeId, cycles: f64) {
    let latest = if virtual_time() { 3.0 + WATCHDOG_REACTION_VIRTUAL_CYCLES } else { 4.0 };
    assert!(
        cycles > 3.0 && cycles < latest,
        "node {node}: watchdog reacted after {cycles:.3} cycles (> 3, < {latest})"
    );
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
    let t_signal = SystemTime::now();
    let _ = daemon.kill();
    // After the kill has been reaped: the killed daemon's exit (the kernel's teardown of its
    // locked memory) is over.
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
    for _ in 0..PROBE_SYNCS {
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
        assert_watchdog_timing(*n, cycles);
        // Quick stop: Fault, standing, within the braking distance v²/(2a) (+ 2 cycles of travel).
        let probe_states: Vec<(Option<PowerState>, i32)> =
            probes.iter().filter_map(|c| c.tpdos.get(n)).map(|t| (state_of(t), t.position_actual)).collect();
        assert_eq!(probe_states.len(), PROBE_SYNCS, "node {n}: answers to the probe SYNCs");
        assert!(probe_states.iter().all(|s| s.0 == Some(PowerState::Fault)), "node {n}: {probe_states:?}");
        // The brake holds the motor: the position actual does not change by one increment.
        assert!(probe_states.windows(2).all(|w| w[0].1 == w[1].1), "node {n} still moves: {probe_states:?}");
        let p_kill = f64::from(last_answered.tpdos[n].position_actual) / INC_PER_MM;
        let v = (p_kill - f64::from(prev_answered.tpdos[n].position_actual) / INC_PER_MM) / cycle_s;
        let a = config.axes[i].max_acc_per_s2;
        let travel = (f64::from(probe_states[0].1) / INC_PER_MM - p_kill).abs();
        let allowed = v * v / (2.0 * a) + 2.0 * 3.0 * v.abs() * cycle_s + 0.01;
        assert!(travel <= allowed, "node {n} ran {travel} mm after the kill (v {v} mm/s, allowed {allowed})");
        report.push(format!(
            "node {n}: EMCY 0x8100 {cycles:.3} cycles after the last SYNC, v {v:.1} mm/s, stopped after {travel:.3} mm, \
             position actual {} increments at each of {PROBE_SYNCS} SYNCs in Fault",
            probe_states[0].1
        ));
    }
    let (code, drives_err) = drives.terminate();
    assert_eq!(code, Some(0), "{drives_err}");
    assert_eq!(drives_err.matches("1 watchdog trips").count(), nodes.len(), "{drives_err}");
    eprintln!(
        "SIGKILL: sent {:.3} cycles after the last SYNC, the daemon reaped after {:.3}; {}",
        secs_between(last_sync, t_signal) / cycle_s,
        secs_between(last_sync, t_kill) / cycle_s,
        report.join("; ")
    );
    // The drives' own view: how long after their last SYNC each watchdog tripped.
    let trips: Vec<&str> = drives_err.lines().filter(|l| l.contains("no SYNC for")).collect();
    eprintln!("SIGKILL, the drives' trip times: {}", trips.join(" | "));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A late cycle of the daemon (`--debug-stall-cycle`): a SYNC that comes late but before a
/// third one is missed is no fault, and the motion finishes; a delay that leaves three SYNCs
/// out trips every drive's watchdog three cycles after the last SYNC.
#[test]
fn a_late_sync_trips_the_watchdog_only_after_three_missed_cycles() {
    let Some((iface, _bus)) = vcan::bus("a_late_sync_trips_the_watchdog_only_after_three_missed_cycles") else {
        return;
    };
    let dir = vcan::temp_dir("can-late");
    let (cfg, config) = config(&dir);
    let cycle_s = config.cycle_s();
    let nodes = nodes();
    let mut report = Vec::new();
    // Gaps of 2.75 and 3.25 cycles between two SYNCs (the stall plus the cycle itself).
    for (stall_cycles, trips) in [(1.75, false), (2.25, true)] {
        let drives = start_drives(&iface, &cfg, &dir);
        let capture = Capture::start(&iface);
        let stall = format!("0.1:{}", stall_cycles * cycle_s);
        let daemon = start_daemon_with(&iface, &cfg, &["--debug-stall-cycle", stall.as_str()]);
        let mut client = daemon.client();
        wait_enabled(&mut client);
        client.ok("program.load", json!({ "text": "G21 G90\nG1 X10 F6000\nG1 X0\nM30\n" }));
        client.ok("motion.start", Value::Null);
        // A drive fault while moving: a controlled stop along the path, then idle with the
        // fault in last_error (docs/can.md, "What stops the motion").
        let st = client.wait_state(&["finished", "idle", "error"], SLOW);
        std::thread::sleep(Duration::from_millis(200));
        drop(client);
        let (code, daemon_err) = daemon.terminate();
        let (_, drives_err) = drives.terminate();
        let bus = split(&capture.finish());
        // The largest gap between two SYNCs of the daemon's cycles (from its first RPDO1 on).
        let first_rpdo = bus.cycles.iter().position(|c| !c.rpdos.is_empty()).expect("RPDO1s on the bus");
        let syncs: Vec<SystemTime> = bus.cycles[first_rpdo..].iter().filter_map(|c| c.sync_t).collect();
        let (gap_at, gap_s) = syncs
            .windows(2)
            .map(|w| (w[0], secs_between(w[0], w[1])))
            .fold((syncs[0], 0.0), |a, b| if b.1 > a.1 { b } else { a });
        let gap_cycles = gap_s / cycle_s;
        let watchdog: Vec<(NodeId, f64)> = bus
            .emcy
            .iter()
            .filter(|(_, _, e)| e.error_code == emcy_code::COMMUNICATION && e.vendor[0] == 1)
            .map(|(t, n, _)| (*n, secs_between(gap_at, *t) / cycle_s))
            .collect();
        if trips {
            assert!(gap_cycles > 3.0, "the stall left a gap of only {gap_cycles:.3} cycles");
            for n in &nodes {
                let Some(&(_, cycles)) = watchdog.iter().find(|(m, _)| m == n) else {
                    panic!("node {n}: no SYNC watchdog EMCY after a gap of {gap_cycles:.3} cycles: {drives_err}")
                };
                assert_watchdog_timing(*n, cycles);
            }
            assert_ne!(st["state"], "finished", "{st}");
            // The watchdog's EMCY or the Fault in the next TPDO1, whichever the master sees first.
            let why = st["last_error"].as_str().unwrap_or_default();
            assert!(why.contains("left Operation enabled") || why.contains("EMCY 0x8100 communication"), "{st}");
        } else {
            if virtual_time() {
                assert!(gap_cycles > 2.5 && gap_cycles < 3.0, "the stall left a gap of {gap_cycles:.3} cycles");
            }
            assert!(watchdog.is_empty(), "watchdog after a gap of {gap_cycles:.3} cycles: {watchdog:?}");
            assert_eq!(st["state"], "finished", "{st}");
            assert_eq!(code, Some(0), "{daemon_err}");
        }
        report.push(format!(
            "gap {gap_cycles:.3} cycles: {}",
            if watchdog.is_empty() {
                "no watchdog".to_string()
            } else {
                watchdog
                    .iter()
                    .map(|(n, c)| format!("node {n} EMCY after {c:.3} cycles"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ));
    }
    eprintln!("late SYNC: {}", report.join("; "));
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
    // The second one adopts their positions; they stay in Fault (the master does not
    // acknowledge a fault on its own) until drives.reset, then it enables them.
    let second = start_daemon(&iface, &cfg, None);
    let mut client = second.client();
    let until = std::time::Instant::now() + SLOW;
    while !client.ok("status", Value::Null)["drives"]
        .as_array()
        .is_some_and(|d| d.iter().all(|d| d["state"] == "fault"))
    {
        assert!(std::time::Instant::now() < until, "the drives are not in Fault");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let st = client.ok("status", Value::Null);
    assert!(st["drives"].as_array().expect("drives").iter().all(|d| d["state"] == "fault"), "latched: {st}");
    let refused = client.call("motion.start", Value::Null);
    assert_eq!(refused["error"]["code"], -32002, "nothing loaded, and the drives in Fault: {refused}");
    let reset = client.ok("drives.reset", Value::Null);
    let reset = reset["drives"].as_array().expect("reset drives").clone();
    assert_eq!(reset.len(), 3, "{reset:?}");
    for d in &reset {
        assert_eq!(d["state_before"], "fault", "{d}");
        assert_ne!(d["state"], "fault", "{d}");
    }
    eprintln!("drives.reset: {reset:?}");
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
    // Unknown COB-IDs (TIME, TPDO2/3 of node 1, …; SDO is served now), 29-bit and remote
    // frames, undefined values.
    for id in [0x100u16, 0x381, 0x481, 0x281, 0x7E5, 0x7FF] {
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
    // Timing as canplayer: each frame at its offset / speed.
    let allowed_ms = if virtual_time() { REPLAY_TOLERANCE_VIRTUAL_MS } else { REPLAY_TOLERANCE_MS };
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
