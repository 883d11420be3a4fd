//! The master against drives it did not write: each drive a `canopen.LocalNode` of the Python
//! `canopen` package (its object dictionary, SDO server, NMT, heartbeat and PDOs from the
//! simulated drive's EDS; tests/python/canopen_drive.py adds a minimal CiA 402 state machine).
//! They boot with CiA 402's default mapping and heartbeat off; `interpd run --can` configures
//! them over SDO and runs a program in CSP at 4 ms; every target position they receive on each
//! SYNC equals the RPDO1 the master put on the bus before that SYNC, every cycle of the motion,
//! and those are the daemon's setpoints scaled (the program's corners). Over a real SocketCAN
//! interface (scripts/vcan-vm.sh copies python3 with canopen into its VM); without
//! `INTERPD_VCAN` the test prints a note and passes.

use interpd_e2e::daemon::Daemon;
use interpd_e2e::vcan::{self, Capture};
use interpd_protocol::cia301::{self, Message};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SLOW: Duration = Duration::from_secs(120);
const NODES: [u8; 3] = [1, 2, 3];

/// The drive script and the EDS: in the VM under `INTERPD_VCAN_SHARE`, else in the repository.
fn share(name: &str) -> PathBuf {
    match std::env::var_os("INTERPD_VCAN_SHARE") {
        Some(dir) => PathBuf::from(dir).join(name),
        None if name.ends_with(".py") => interpd_e2e::repo_root().join("tests/python").join(name),
        None => interpd_e2e::repo_root().join("sim-plant/eds").join(name),
    }
}

#[test]
fn python_canopen_drives_are_configured_and_follow_every_setpoint() {
    let Some((iface, _bus)) = vcan::bus("python_canopen_drives_are_configured_and_follow_every_setpoint") else {
        return;
    };
    let dir = vcan::temp_dir("can-python");
    let cfg = dir.join("machine.toml");
    std::fs::write(&cfg, format!("{}\n[sinks.can]\nboot_timeout_ms = 2000\n", interpd_config::DEFAULT_MACHINE_TOML))
        .expect("config");
    let out = dir.join("targets.txt");
    let log = dir.join("drives.stderr");
    let python = if std::env::var_os("INTERPD_VCAN_SHARE").is_some() { "/bin/python3" } else { "python3" };
    let mut drives = Command::new(python)
        .arg(share("canopen_drive.py"))
        .arg(&iface)
        .arg(share("interpd-sim-drive.eds"))
        .arg(&out)
        .args(NODES.iter().map(u8::to_string))
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).expect("log"))
        .spawn()
        .expect("start the Python drives");
    let read_log = || std::fs::read_to_string(&log).unwrap_or_default();
    let until = Instant::now() + SLOW;
    while !read_log().contains("canopen_drive: ready") {
        assert!(drives.try_wait().expect("wait").is_none(), "the Python drives exited: {}", read_log());
        assert!(Instant::now() < until, "the Python drives did not start: {}", read_log());
        std::thread::sleep(Duration::from_millis(50));
    }
    let capture = Capture::start(&iface);
    let cfg_s = cfg.display().to_string();
    let daemon = Daemon::start(&["--config", cfg_s.as_str(), "--can", iface.as_str(), "--no-shm"]);
    let mut client = daemon.client();
    let until = Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        let d = st["drives"].as_array().cloned().unwrap_or_default();
        if d.len() == 3 && d.iter().all(|d| d["state"] == "operation_enabled") {
            break;
        }
        assert!(Instant::now() < until, "the Python drives were not enabled: {st}\n{}", read_log());
        std::thread::sleep(Duration::from_millis(20));
    }
    // Commissioning through the daemon against python-canopen's SDO server: its mode display
    // (as the master configured it), the device name (segmented), a write and its read-back.
    let read = |client: &mut interpd_e2e::daemon::Client, index: &str, ty: &str| {
        client.ok("drives.sdo_read", json!({"node": 2, "index": index, "type": ty}))["value"].clone()
    };
    assert_eq!(read(&mut client, "0x6061", "i8"), json!(8));
    assert_eq!(read(&mut client, "0x1008", "string"), json!("interpd sim drive"));
    client.ok("drives.sdo_write", json!({"node": 2, "index": "0x6065", "type": "u32", "value": 123456}));
    assert_eq!(read(&mut client, "0x6065", "u32"), json!(123456));
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X12 Y-7 Z3 F6000\nG1 X-4 Y5 Z-2\nG1 X0 Y0 Z0\nM30\n" }));
    client.ok("motion.start", Value::Null);
    let st = client.wait_state(&["finished", "error"], SLOW);
    assert_eq!(st["state"], "finished", "{st}");
    drop(client);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    std::thread::sleep(Duration::from_millis(200));
    // SAFETY: kill(2) on our own child.
    unsafe { libc::kill(drives.id() as i32, libc::SIGTERM) };
    drives.wait().expect("wait");
    let frames = capture.finish();

    // The bus: before SYNC k, the last RPDO1 of each node. Both this capture and the drives
    // count SYNCs from before the daemon started.
    let mut sent: BTreeMap<(u64, u8), i32> = BTreeMap::new();
    let mut last: BTreeMap<u8, i32> = BTreeMap::new();
    let mut sync = 0u64;
    for (_, f) in &frames {
        match cia301::decode(f) {
            Ok(Message::Rpdo1 { node, pdo }) => {
                last.insert(node.get(), pdo.target_position);
            }
            Ok(Message::Sync { .. }) => {
                sync += 1;
                for (&n, &t) in &last {
                    sent.insert((sync, n), t);
                }
            }
            _ => {}
        }
    }
    let text = std::fs::read_to_string(&out).expect("the drives' record");
    let mut received: BTreeMap<u8, Vec<(u64, i32)>> = BTreeMap::new();
    for line in text.lines() {
        let v: Vec<i64> = line.split_whitespace().map(|x| x.parse().expect("number")).collect();
        received.entry(v[1] as u8).or_default().push((v[0] as u64, v[2] as i32));
    }
    let mut report = Vec::new();
    for n in NODES {
        let got = received.get(&n).unwrap_or_else(|| panic!("node {n} received nothing: {}", read_log()));
        // Every cycle from the first in which it followed to the last: no SYNC missing.
        let (first, last_sync) = (got[0].0, got[got.len() - 1].0);
        assert_eq!(got.len() as u64, last_sync - first + 1, "node {n}: a cycle without a target");
        for &(k, t) in got {
            assert_eq!(sent.get(&(k, n)), Some(&t), "node {n}, SYNC {k}: received {t}, the bus carried another");
        }
        let (min, max) = got.iter().fold((i32::MAX, i32::MIN), |(a, b), &(_, t)| (a.min(t), b.max(t)));
        report.push(format!("node {n}: {} cycles, targets {min}..={max}", got.len()));
    }
    // The setpoints scaled (10 000 increments per mm): the program's corners are reached.
    let range = |n: u8| {
        let g = &received[&n];
        (g.iter().map(|x| x.1).min().unwrap_or(0), g.iter().map(|x| x.1).max().unwrap_or(0))
    };
    assert_eq!(range(1), (-40_000, 120_000));
    assert_eq!(range(2), (-70_000, 50_000));
    assert_eq!(range(3), (-20_000, 30_000));
    for n in NODES {
        assert_eq!(received[&n].last().map(|x| x.1), Some(0), "node {n} ends at the origin");
    }
    let sdo = frames.iter().filter(|(_, f)| (0x581..=0x583).contains(&f.id().raw())).count();
    eprintln!("python canopen drives: {}; {sdo} SDO responses; {}", report.join("; "), read_log().trim());
    let _ = std::fs::remove_dir_all(&dir);
}
