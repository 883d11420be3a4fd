//! The master's boot of the drives over a real SocketCAN interface (scripts/vcan-vm.sh; without
//! `INTERPD_VCAN` each test prints a note and passes): `interpd run --can` resets, checks and
//! configures `sim-plant --source can:` drives that power up with CiA 402's default mapping and
//! heartbeat off, for 3 and for 6 nodes (boot and configuration time measured on the bus); a
//! wrong identity and an SDO abort during configuration refuse the start, naming the node, and
//! nothing moves (no SYNC, no RPDO on the bus).

use interpd_e2e::daemon::Daemon;
use interpd_e2e::vcan::{self, Capture, Proc};
use interpd_protocol::cia301::{self, Frame, Message, NmtCommand, NmtState};
use serde_json::{Value, json};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant, SystemTime};

const SLOW: Duration = Duration::from_secs(60);
const AXES: [&str; 6] = ["X", "Y", "Z", "A", "B", "C"];

fn virtual_time() -> bool {
    std::env::var("INTERPD_VCAN_VIRTUAL_TIME").is_ok_and(|v| v == "1")
}

/// A machine of `n` linear axes on nodes 1..=n at `cycle_ms`, plus `extra` TOML.
fn config(dir: &Path, n: usize, cycle_ms: f64, extra: &str) -> String {
    let mut text = format!("[machine]\nname = \"boot test\"\ncycle_ms = {cycle_ms}\n");
    for name in &AXES[..n] {
        text += &format!(
            "[[axis]]\nname = \"{name}\"\nkind = \"linear\"\nmax_vel = 250.0\nmax_acc = 2500.0\nmax_jerk = \
             50000.0\nmin = -1000.0\nmax = 1000.0\n"
        );
        if *name == "A" || *name == "B" || *name == "C" {
            text = text.replace(
                &format!("name = \"{name}\"\nkind = \"linear\""),
                &format!("name = \"{name}\"\nkind = \"rotary\""),
            );
        }
    }
    text += &format!("[sinks.can]\nboot_timeout_ms = 500\n{extra}\n");
    let path = dir.join("machine.toml");
    std::fs::write(&path, &text).expect("write config");
    path.display().to_string()
}

fn start_drives(iface: &str, cfg: &str, dir: &Path) -> Proc {
    let source = format!("can:{iface}");
    let mut args = vec!["--config", cfg, "--source", source.as_str()];
    if virtual_time() {
        args.extend(["--rt-priority", "70"]);
    }
    let mut p = Proc::start("sim-plant", &args, dir);
    p.wait_for_stderr("sim-plant: ready", SLOW);
    p
}

/// `interpd run` that is expected to refuse: its exit status and stderr.
fn run_refused(iface: &str, cfg: &str, dir: &Path) -> (Option<i32>, String) {
    let socket = dir.join("control.sock");
    let mut child = Command::new(interpd_e2e::binary("interpd"))
        .args(["run", "--config", cfg, "--can", iface, "--no-shm", "--socket"])
        .arg(&socket)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start interpd run");
    let until = Instant::now() + SLOW;
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > until {
            let _ = child.kill();
            panic!("interpd run did not exit");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn secs(a: SystemTime, b: SystemTime) -> f64 {
    b.duration_since(a).map_or(0.0, |d| d.as_secs_f64())
}

/// A candump line with a note, for the annotated boot sequence.
fn line(t0: SystemTime, t: SystemTime, f: &Frame) -> String {
    let data: String = f.payload().iter().map(|b| format!("{b:02X}")).collect();
    let id = f.id().raw();
    let note = match (id, f.payload()) {
        (0x000, [0x82, n]) => format!("NMT reset communication, node {n}"),
        (0x000, [0x01, n]) => format!("NMT start, node {n}"),
        (0x701..=0x77F, [0]) => "boot-up".into(),
        (0x701..=0x77F, [s]) => format!("heartbeat, state 0x{s:02X}"),
        (0x601..=0x67F, d) if d.len() == 8 => {
            format!("SDO request {:#04X} 0x{:02X}{:02X}:{}", d[0], d[2], d[1], d[3])
        }
        (0x581..=0x5FF, d) if d.len() == 8 => {
            format!("SDO response {:#04X} 0x{:02X}{:02X}:{}", d[0], d[2], d[1], d[3])
        }
        (0x080, _) => "SYNC".into(),
        (0x181..=0x1FF, _) => "TPDO1".into(),
        (0x201..=0x27F, _) => "RPDO1".into(),
        _ => String::new(),
    };
    format!("({:10.6}) {id:03X}#{data:<16}  ; {note}", secs(t0, t))
}

/// A second SDO client on the bus (a commissioning tool): uploads from every node in turn,
/// back to back, until finished.
struct Flood {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    handle: std::thread::JoinHandle<u64>,
}

impl Flood {
    fn finish(self) -> u64 {
        self.stop.store(true, std::sync::atomic::Ordering::Release);
        self.handle.join().expect("flood thread")
    }
}

fn sdo_flood(iface: &str, n: usize) -> Flood {
    use interpd_canopen::Address;
    use interpd_canopen::sdo_client::{SdoClient, Step};
    use socketcan::Socket;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = stop.clone();
    let iface = iface.to_string();
    let handle = std::thread::spawn(move || {
        let sock = vcan::open(&iface, Duration::from_millis(5));
        let t0 = Instant::now();
        let now_us = || t0.elapsed().as_micros() as u64;
        let mut done = 0u64;
        let mut k = 0usize;
        while !flag.load(std::sync::atomic::Ordering::Acquire) {
            let node = cia301::NodeId::new((k % n) as u8 + 1).expect("node");
            let at = if k % 2 == 0 { Address::new(0x1018, 1) } else { Address::new(0x1008, 0) };
            k += 1;
            let mut client = SdoClient::new(node, 200_000);
            let Ok(first) = client.upload(at, now_us()) else { continue };
            vcan::send(&sock, &first);
            loop {
                let Ok(f) = sock.read_frame() else {
                    if client.poll(now_us()).is_some() {
                        break;
                    }
                    continue;
                };
                let Ok(frame) = interpd_protocol::can_socket::from_socketcan(&f) else { continue };
                match client.on_frame(&frame, now_us()) {
                    Some(Step::Send(next)) => vcan::send(&sock, &next),
                    Some(_) => {
                        done += 1;
                        break;
                    }
                    None => {}
                }
            }
        }
        done
    });
    Flood { stop, handle }
}

#[test]
fn the_master_configures_three_and_six_default_drives() {
    let Some((iface, _bus)) = vcan::bus("the_master_configures_three_and_six_default_drives") else { return };
    let mut figures = Vec::new();
    for n in [3usize, 6] {
        let dir = vcan::temp_dir(&format!("can-boot{n}"));
        let cfg = config(&dir, n, 4.0, "");
        let drives = start_drives(&iface, &cfg, &dir);
        let capture = Capture::start(&iface);
        let daemon = Daemon::start(&["--config", cfg.as_str(), "--can", iface.as_str(), "--no-shm"]);
        let mut client = daemon.client();
        // The drives get enabled by the master's cycle; then a short move.
        let until = Instant::now() + SLOW;
        loop {
            let st = client.ok("status", Value::Null);
            let drives = st["drives"].as_array().cloned().unwrap_or_default();
            if drives.len() == n && drives.iter().all(|d| d["state"] == "operation_enabled") {
                break;
            }
            assert!(Instant::now() < until, "drives not enabled: {st}");
            std::thread::sleep(Duration::from_millis(20));
        }
        client.ok("program.load", json!({ "text": "G21 G90\nG1 X10 Y-10 F3000\nG1 X0 Y0\nM30\n" }));
        client.ok("motion.start", Value::Null);
        // SDO traffic while the motion runs, as a commissioning tool makes it: uploads of
        // 0x1018:1 and the segmented 0x1008 from every node, back to back.
        let flood = sdo_flood(&iface, n);
        let st = client.wait_state(&["finished", "error"], SLOW);
        let sdo_during_motion = flood.finish();
        assert_eq!(st["state"], "finished", "{st}");
        drop(client);
        let (code, err) = daemon.terminate();
        assert_eq!(code, Some(0), "{err}");
        let frames = capture.finish();
        let (code, drives_err) = drives.terminate();
        assert_eq!(code, Some(0), "{drives_err}");

        // On the bus: per node reset → boot-up → SDO … → start, and before any SYNC.
        let nmt = |cmd: NmtCommand| {
            frames
                .iter()
                .filter(move |(_, f)| matches!(cia301::decode(f), Ok(Message::Nmt { command, .. }) if command == cmd))
        };
        let first_reset = nmt(NmtCommand::ResetCommunication).next().expect("NMT reset communication").0;
        let last_start = nmt(NmtCommand::Start).next_back().expect("NMT start").0;
        assert_eq!(nmt(NmtCommand::ResetCommunication).count(), n);
        assert_eq!(nmt(NmtCommand::Start).count(), n);
        let first_sync = frames.iter().find(|(_, f)| f.id().raw() == 0x080).expect("SYNC").0;
        assert!(first_sync >= last_start, "SYNC before the last node was started");
        let boot_ups = frames
            .iter()
            .filter(|(_, f)| matches!(cia301::decode(f), Ok(Message::Heartbeat { state: NmtState::BootUp, .. })))
            .count();
        assert_eq!(boot_ups, n, "one boot-up per node, the answer to its reset communication");
        let sdo = frames.iter().filter(|(_, f)| (0x581..=0x5FF).contains(&f.id().raw())).count();
        // The SYNC period while motion runs and the SDO traffic goes on.
        let moving: Vec<SystemTime> = {
            let first_move = frames
                .iter()
                .find(|(_, f)| f.id().raw() == 0x201 && f.payload().get(2..6).is_some_and(|p| p != [0, 0, 0, 0]))
                .expect("an RPDO1 with a target off zero")
                .0;
            // Up to the daemon's shutdown, whose last SYNC follows the last cycle's at once.
            let shutdown = frames
                .iter()
                .find(|(t, f)| *t > first_move && f.id().raw() == 0x201 && f.payload().first() == Some(&0x06))
                .map_or(SystemTime::now(), |(t, _)| *t);
            frames
                .iter()
                .filter(|(t, f)| *t >= first_move && *t < shutdown && f.id().raw() == 0x080)
                .map(|(t, _)| *t)
                .collect()
        };
        let worst_ms = moving.windows(2).map(|w| (secs(w[0], w[1]) * 1e3 - 4.0).abs()).fold(0.0, f64::max);
        let sdo_while_moving = frames
            .iter()
            .filter(|(t, f)| {
                *t >= moving[0] && *t <= moving[moving.len() - 1] && (0x581..=0x5FF).contains(&f.id().raw())
            })
            .count();
        assert!(sdo_while_moving > 100, "SDO traffic during the motion: {sdo_while_moving} responses");
        if virtual_time() {
            // A flood of 60 SDO responses per cycle on the VM's one vCPU: the kernel's receive
            // work for them can run just before the real-time thread wakes (0.021-0.052 ms
            // seen); twice the quiet bus's 0.05 ms, 2.5 % of the period, still fails any SYNC
            // that waited for an SDO transfer (one transfer takes a cycle or more).
            assert!(worst_ms <= 0.1, "a SYNC {worst_ms:.3} ms off its 4 ms period during SDO traffic");
        }
        let said = err.lines().find(|l| l.contains("drives configured in")).unwrap_or("").to_string();
        figures.push(format!(
            "{n} nodes: bus {:.1} ms from the first NMT reset communication to the last NMT start, {} SDO responses; \
             daemon: {said}; during the motion {} SYNC periods with {sdo_while_moving} SDO responses \
             ({sdo_during_motion} transfers by the test): worst |period - 4 ms| {worst_ms:.4} ms",
            secs(first_reset, last_start) * 1e3,
            sdo,
            moving.len() - 1
        ));
        // No heartbeat before 0x1017 was written; then every 100 ms.
        let hb_before_config = frames
            .iter()
            .filter(|(t, f)| {
                *t < first_reset
                    && matches!(cia301::decode(f), Ok(Message::Heartbeat { state, .. }) if state != NmtState::BootUp)
            })
            .count();
        assert_eq!(hb_before_config, 0, "heartbeat off at power-on");
        if n == 3 {
            // The annotated boot sequence of node 1, and the first cycles.
            let mut text = Vec::new();
            let mine = |id: u32| matches!(id, 0x000 | 0x080 | 0x181 | 0x201 | 0x581 | 0x601 | 0x701);
            for (t, f) in frames.iter().filter(|(t, f)| *t >= first_reset && mine(f.id().raw())) {
                if f.id().raw() == 0x000 && f.payload().get(1).is_some_and(|&x| x != 1) {
                    continue;
                }
                text.push(line(first_reset, *t, f));
                if text.len() > 80 {
                    break;
                }
            }
            eprintln!("boot sequence of node 1:\n{}", text.join("\n"));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    eprintln!("boot figures:\n  {}", figures.join("\n  "));
}

#[test]
fn a_wrong_identity_is_refused_naming_the_node_and_nothing_moves() {
    let Some((iface, _bus)) = vcan::bus("a_wrong_identity_is_refused_naming_the_node_and_nothing_moves") else {
        return;
    };
    let dir = vcan::temp_dir("can-identity");
    let cfg = config(&dir, 3, 4.0, "[sinks.can.node.2]\nvendor_id = 0x195\nproduct_code = 0x1234");
    let err = refused_start(&iface, &cfg, &dir);
    assert!(
        err.contains(
            "drive Y (node 2): node 2: wrong device: expected vendor-ID 0x00000195, product code 0x00001234; found \
             vendor-ID 0x00000000, product code 0x00000402"
        ),
        "{err}"
    );
    eprintln!("wrong identity: {}", err.lines().filter(|l| l.contains("node 2")).collect::<Vec<_>>().join(" | "));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_sdo_abort_during_configuration_names_the_node_and_nothing_moves() {
    let Some((iface, _bus)) = vcan::bus("an_sdo_abort_during_configuration_names_the_node_and_nothing_moves") else {
        return;
    };
    let dir = vcan::temp_dir("can-abort");
    // A 0.2 ms cycle: the drive's 0x1006 takes 250 µs at least (its EDS's LowLimit).
    let cfg = config(&dir, 3, 0.2, "");
    let err = refused_start(&iface, &cfg, &dir);
    assert!(
        err.contains(
            "communication cycle period (0x1006:0): node 1: SDO download (write) of 0x1006:0 refused by the drive: \
             abort 0x06090032: value of parameter written too low"
        ),
        "{err}"
    );
    eprintln!("SDO abort: {}", err.lines().filter(|l| l.contains("abort")).collect::<Vec<_>>().join(" | "));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts the drives and a daemon whose start must be refused: the daemon exits with 1, no
/// SYNC and no RPDO1 goes on the bus (nothing moves), the drives end cleanly. Its stderr.
fn refused_start(iface: &str, cfg: &str, dir: &Path) -> String {
    let drives = start_drives(iface, cfg, dir);
    let capture = Capture::start(iface);
    let (code, err) = run_refused(iface, cfg, dir);
    let frames = capture.finish();
    assert_eq!(code, Some(1), "{err}");
    assert!(frames.iter().all(|(_, f)| !matches!(f.id().raw(), 0x080 | 0x201..=0x27F)), "nothing moves");
    let (code, drives_err) = drives.terminate();
    assert_eq!(code, Some(0), "{drives_err}");
    err
}

/// SDO download from the test (a commissioning tool) to `node`.
fn sdo_write(iface: &str, node: u8, index: u16, sub: u8, data: Vec<u8>) {
    use interpd_canopen::Address;
    use interpd_canopen::sdo_client::{SdoClient, Step};
    use socketcan::Socket;
    let sock = vcan::open(iface, Duration::from_millis(5));
    let node = cia301::NodeId::new(node).expect("node");
    let mut client = SdoClient::new(node, 1_000_000);
    let t0 = Instant::now();
    let first = client.download(Address::new(index, sub), data, 0).expect("idle");
    vcan::send(&sock, &first);
    loop {
        let now = t0.elapsed().as_micros() as u64;
        let step = match sock.read_frame() {
            Ok(f) => interpd_protocol::can_socket::from_socketcan(&f).ok().and_then(|f| client.on_frame(&f, now)),
            Err(_) => client.poll(now),
        };
        match step {
            Some(Step::Send(f)) => vcan::send(&sock, &f),
            Some(Step::Downloaded) => return,
            Some(other) => panic!("SDO write to node {node}: {other:?}"),
            None => {}
        }
    }
}

/// The supervision of the configured drives while they move: a drive whose heartbeat stops
/// (0x1017 set to 0 by a commissioning tool) and a drive that sends an EMCY (an RPDO1 of the
/// wrong length) each end the motion in a controlled stop, the message naming the drive, the
/// node and the EMCY code's meaning.
#[test]
fn a_lost_heartbeat_and_an_emcy_mid_motion_stop_the_motion() {
    let Some((iface, _bus)) = vcan::bus("a_lost_heartbeat_and_an_emcy_mid_motion_stop_the_motion") else { return };
    let dir = vcan::temp_dir("can-supervision");
    let cfg = config(&dir, 3, 4.0, "");
    for case in ["heartbeat", "emcy"] {
        let drives = start_drives(&iface, &cfg, &dir);
        let daemon = Daemon::start(&["--config", cfg.as_str(), "--can", iface.as_str(), "--no-shm"]);
        let mut client = daemon.client();
        let until = Instant::now() + SLOW;
        loop {
            let st = client.ok("status", Value::Null);
            let d = st["drives"].as_array().cloned().unwrap_or_default();
            if d.len() == 3 && d.iter().all(|d| d["state"] == "operation_enabled" && d["configured"] == true) {
                break;
            }
            assert!(Instant::now() < until, "drives not enabled: {st}");
            std::thread::sleep(Duration::from_millis(20));
        }
        client.ok("program.load", json!({ "text": "G21 G90\nG1 X40 F3000\nG1 X0\nM30\n" }));
        client.ok("motion.start", Value::Null);
        std::thread::sleep(Duration::from_millis(200));
        let t = Instant::now();
        match case {
            "heartbeat" => sdo_write(&iface, 2, 0x1017, 0, vec![0, 0]),
            _ => vcan::send(
                &vcan::open(&iface, Duration::from_millis(5)),
                &Frame::standard(0x203, &[0x0F; 4]).expect("frame"),
            ),
        }
        let st = client.wait_state(&["finished", "idle", "error"], SLOW);
        let after_s = t.elapsed().as_secs_f64();
        let why = st["last_error"].as_str().unwrap_or_default().to_string();
        assert_ne!(st["state"], "finished", "{case}: the motion went on: {st}");
        match case {
            "heartbeat" => assert!(why.contains("drive Y (node 2) heartbeat lost"), "{st}"),
            _ => assert!(why.contains("drive Z (node 3) EMCY 0x8210 PDO not processed due to length error"), "{st}"),
        }
        let drive = &st["drives"].as_array().expect("drives")[if case == "heartbeat" { 1 } else { 2 }];
        eprintln!("{case}: stopped {after_s:.3} s after the cause, state {}: {why}; drive: {drive}", st["state"]);
        drop(client);
        let _ = daemon.terminate();
        let _ = drives.terminate();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `interpd can …` against the daemon's control socket: (exit code, stdout, stderr).
fn cli(socket: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(interpd_e2e::binary("interpd"))
        .arg("can")
        .args(args)
        .arg("--socket")
        .arg(socket)
        .output()
        .expect("run interpd can");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Commissioning through the daemon: `drives.sdo_read`/`drives.sdo_write` (expedited and
/// segmented, typed values, aborts named with their code and meaning, refused while motion
/// runs), the same through `interpd can sdo`, the values of `[sinks.can.node.N] sdo` and of a
/// DCF written at boot, and `drives.reset` of a drive put in Fault (NMT pre-operational while
/// enabled): the fault stays until the reset, which takes the drive back to Operation enabled.
#[test]
fn commissioning_over_the_control_api_and_the_command_line() {
    let Some((iface, _bus)) = vcan::bus("commissioning_over_the_control_api_and_the_command_line") else { return };
    let dir = vcan::temp_dir("can-commissioning");
    // Node 3's DCF: the simulated drive's EDS with a configured following error window.
    let eds = include_str!("../../sim-plant/eds/interpd-sim-drive.eds");
    let dcf = eds.replacen("[6065]\n", "[6065]\nParameterValue=54321\n", 1);
    assert_ne!(dcf, eds, "the EDS has a [6065] section");
    std::fs::write(dir.join("node3.dcf"), dcf).expect("write DCF");
    let cfg = config(
        &dir,
        3,
        4.0,
        &format!(
            "[sinks.can.node.2]\nsdo = [{{ index = 0x6065, sub = 0, type = \"u32\", value = 77777 }}]\n\
             [sinks.can.node.3]\neds = \"{}\"\n",
            dir.join("node3.dcf").display()
        ),
    );
    let drives = start_drives(&iface, &cfg, &dir);
    let daemon = Daemon::start(&["--config", cfg.as_str(), "--can", iface.as_str(), "--no-shm"]);
    let mut client = daemon.client();
    let wait_enabled = |client: &mut interpd_e2e::daemon::Client| {
        let until = Instant::now() + SLOW;
        loop {
            let st = client.ok("status", Value::Null);
            let d = st["drives"].as_array().cloned().unwrap_or_default();
            if d.len() == 3 && d.iter().all(|d| d["state"] == "operation_enabled") {
                return st;
            }
            assert!(Instant::now() < until, "drives not enabled: {st}");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    wait_enabled(&mut client);
    let read = |client: &mut interpd_e2e::daemon::Client, node: u8, index: &str, sub: u8, ty: &str| {
        client.ok("drives.sdo_read", json!({"node": node, "index": index, "sub": sub, "type": ty}))
    };
    // Written at boot: the node table (node 2) and the DCF's ParameterValue (node 3).
    assert_eq!(read(&mut client, 2, "0x6065", 0, "u32")["value"], 77777);
    assert_eq!(read(&mut client, 3, "0x6065", 0, "u32")["value"], 54321);
    assert_eq!(read(&mut client, 1, "0x6065", 0, "u32")["value"], 100000, "node 1 keeps its default");
    let r = read(&mut client, 2, "0x1018", 2, "u32");
    assert_eq!((r["value"].clone(), r["data"].clone()), (json!(0x402), json!("02040000")), "{r}");
    assert_eq!(read(&mut client, 1, "0x1008", 0, "string")["value"], "interpd sim drive", "segmented upload");
    assert_eq!(read(&mut client, 1, "0x6061", 0, "i8")["value"], 8);
    client.ok("drives.sdo_write", json!({"node": 1, "index": "0x6065", "type": "u32", "value": 20000}));
    assert_eq!(read(&mut client, 1, "0x6065", 0, "u32")["value"], 20000);
    // Refusals: the drive's abort with its code and meaning, in the status too.
    let e = client.call("drives.sdo_write", json!({"node": 2, "index": "0x1018", "sub": 1, "type": "u32", "value": 5}));
    assert_eq!(e["error"]["code"], -32007, "{e}");
    assert_eq!(e["error"]["data"]["abort_code"], "0x06010002", "{e}");
    let msg = e["error"]["message"].as_str().unwrap_or_default().to_string();
    assert!(msg.contains("drive Y (node 2): node 2: SDO download (write) of 0x1018:1 refused by the drive: abort 0x06010002: attempt to write a read-only object"), "{msg}");
    let e = client.call("drives.sdo_read", json!({"node": 2, "index": "0x2000"}));
    assert!(e["error"]["message"].as_str().unwrap_or_default().contains("abort 0x06020000"), "{e}");
    let st = client.ok("status", Value::Null);
    assert!(st["drives"][1]["last_sdo_error"].as_str().unwrap_or_default().contains("abort 0x06020000"), "{st}");
    let e = client.call("drives.sdo_read", json!({"node": 9, "index": "0x1000"}));
    assert_eq!(e["error"]["code"], -32008, "{e}");
    // The command line, through the daemon.
    let (code, out, err) = cli(&daemon.socket, &["sdo", "read", "1", "0x6065", "0", "--type", "u32"]);
    assert_eq!((code, out.trim()), (Some(0), "20000"), "{err}");
    let (code, _, err) = cli(&daemon.socket, &["sdo", "write", "3", "0x6065", "0", "60000", "--type", "u32"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(read(&mut client, 3, "0x6065", 0, "u32")["value"], 60000);
    let (code, _, err) = cli(&daemon.socket, &["sdo", "write", "3", "0x1000", "0", "1", "--type", "u32"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("abort 0x06010002: attempt to write a read-only object"), "{err}");
    // Not while motion runs.
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X20 F3000\nG1 X0\nM30\n" }));
    client.ok("motion.start", Value::Null);
    let e = client.call("drives.sdo_read", json!({"node": 1, "index": "0x6061"}));
    assert_eq!(e["error"]["code"], -32002, "{e}");
    assert_eq!(client.wait_state(&["finished", "error"], SLOW)["state"], "finished");
    // A drive in Fault: NMT pre-operational while enabled (the drive's EMCY 0x8100). The master
    // starts it again but leaves the fault to the operator.
    vcan::send(&vcan::open(&iface, Duration::from_millis(5)), &Frame::standard(0x000, &[0x80, 3]).expect("NMT"));
    let until = Instant::now() + SLOW;
    while client.ok("status", Value::Null)["drives"][2]["state"] != "fault" {
        assert!(Instant::now() < until, "drive Z did not fault");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(600));
    let st = client.ok("status", Value::Null);
    assert_eq!(st["drives"][2]["state"], "fault", "a fault stays until drives.reset: {st}");
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X5 F3000\nM30\n" }));
    let e = client.call("motion.start", Value::Null);
    assert_eq!(e["error"]["code"], -32005, "{e}");
    let (code, out, err) = cli(&daemon.socket, &["reset"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("drive Z (node 3): fault -> operation_enabled"), "{out}");
    wait_enabled(&mut client);
    client.ok("motion.start", Value::Null);
    assert_eq!(client.wait_state(&["finished", "error"], SLOW)["state"], "finished");
    eprintln!("commissioning: {msg} | reset: {}", out.trim());
    drop(client);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    let _ = drives.terminate();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A DCF value the drive refuses: the start is refused naming the node, the object and the
/// abort, and nothing moves.
#[test]
fn a_refused_configured_value_names_node_index_and_sub() {
    let Some((iface, _bus)) = vcan::bus("a_refused_configured_value_names_node_index_and_sub") else { return };
    let dir = vcan::temp_dir("can-value-abort");
    let cfg =
        config(&dir, 3, 4.0, "[sinks.can.node.2]\nsdo = [{ index = 0x6041, sub = 0, type = \"u16\", value = 1 }]\n");
    let err = refused_start(&iface, &cfg, &dir);
    assert!(
        err.contains(
            "drive Y (node 2): node 2: [sinks.can.node.2] sdo[0] (0x6041:0): node 2: SDO download (write) of 0x6041:0 \
             refused by the drive: abort 0x06010002: attempt to write a read-only object"
        ),
        "{err}"
    );
    eprintln!("value abort: {}", err.lines().filter(|l| l.contains("abort")).collect::<Vec<_>>().join(" | "));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Waits until every drive is in Operation enabled and configured.
fn await_enabled(client: &mut interpd_e2e::daemon::Client, n: usize) {
    let until = Instant::now() + SLOW;
    loop {
        let st = client.ok("status", Value::Null);
        let d = st["drives"].as_array().cloned().unwrap_or_default();
        if d.len() == n && d.iter().all(|d| d["state"] == "operation_enabled" && d["configured"] == true) {
            return;
        }
        assert!(Instant::now() < until, "drives not enabled: {st}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The TPDO1s of `node` in the capture: (time, statusword, position actual).
fn tpdos(frames: &[(SystemTime, Frame)], node: u32) -> Vec<(SystemTime, u16, i32)> {
    frames
        .iter()
        .filter(|(_, f)| f.id().raw() == 0x180 + node && f.payload().len() == 6)
        .map(|(t, f)| {
            let p = f.payload();
            (*t, u16::from_le_bytes([p[0], p[1]]), i32::from_le_bytes([p[2], p[3], p[4], p[5]]))
        })
        .collect()
}

/// `machine.home` with `[sinks.can] require_homing`: motion is refused before it; the axes
/// home in `home_order` through CiA 402 homing mode 6 on the simulated drives, X on its home
/// switch and index pulse (method 3), Y on its current position (37), Z on the index above
/// its switch from the switch's active side (method 4); each then reports its home offset, the
/// setpoints take the drives' positions, and a program runs from there. On the bus, X's last
/// position in the old reference before "homing attained" is the index pulse below its switch.
#[test]
fn machine_home_homes_every_axis_then_motion_may_start() {
    let Some((iface, _bus)) = vcan::bus("machine_home_homes_every_axis_then_motion_may_start") else { return };
    let dir = vcan::temp_dir("can-home");
    let extra = "require_homing = true\nhome_order = [\"Z\", \"X\", \"Y\"]\nhoming_timeout_ms = 20000\n\
        [sinks.can.node.1]\nhoming = { method = 3, speed_switch = 20.0, speed_zero = 2.0, acceleration = 200.0, offset = -2.0 }\n\
        sim_home_switch = 12.5\nsim_index_pitch = 5.0\n\
        [sinks.can.node.2]\nhoming = { method = 37, offset = 7.5 }\n\
        [sinks.can.node.3]\nhoming = { method = 4, speed_switch = 20.0, speed_zero = 2.0, acceleration = 200.0, offset = 1.0 }\n\
        sim_home_switch = -3.2\nsim_index_pitch = 2.0\n";
    let cfg = config(&dir, 3, 4.0, extra);
    let drives = start_drives(&iface, &cfg, &dir);
    let capture = Capture::start(&iface);
    let daemon = Daemon::start(&["--config", cfg.as_str(), "--can", iface.as_str(), "--no-shm"]);
    let mut client = daemon.client();
    await_enabled(&mut client, 3);
    let st = client.ok("status", Value::Null);
    assert_eq!(st["homed"], false, "{st}");
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X5 Y10 Z3 F3000\nM30\n" }));
    let refused = client.call("motion.start", Value::Null);
    assert_eq!(refused["error"]["code"], -32005, "{refused}");
    let why = refused["error"]["message"].as_str().unwrap_or_default();
    assert!(why.contains("drive X (node 1) is not homed ([sinks.can] require_homing"), "{refused}");
    let t = Instant::now();
    let homed = client.ok("machine.home", Value::Null);
    let home_s = t.elapsed().as_secs_f64();
    let axes = homed["axes"].as_array().expect("axes").clone();
    let order: Vec<&str> = axes.iter().map(|a| a["axis"].as_str().unwrap_or("")).collect();
    assert_eq!(order, ["Z", "X", "Y"], "{homed}");
    for (a, (offset, method)) in axes.iter().zip([(1.0, 4), (-2.0, 3), (7.5, 37)]) {
        let at = a["position_units"].as_f64().expect("position");
        assert!((at - offset).abs() <= 1e-3, "{} stands at {at}, not its home offset {offset}: {homed}", a["axis"]);
        assert_eq!(a["method"], method, "{homed}");
    }
    let st = client.ok("status", Value::Null);
    assert_eq!(st["homed"], true, "{st}");
    let position: Vec<f64> = st["position"].as_array().expect("position").iter().filter_map(Value::as_f64).collect();
    for (p, want) in position.iter().zip([-2.0, 7.5, 1.0]) {
        assert!((p - want).abs() <= 1e-3, "the setpoints took the drives' positions: {position:?}");
    }
    for d in st["drives"].as_array().expect("drives") {
        assert_eq!((&d["homed"], &d["state"]), (&json!(true), &json!("operation_enabled")), "{d}");
    }
    // Motion from the homed positions.
    client.ok("motion.start", Value::Null);
    let st = client.wait_state(&["finished", "error"], SLOW);
    assert_eq!(st["state"], "finished", "{st}");
    // The drives settle on the program's end a few cycles after the setpoints.
    let until = Instant::now() + Duration::from_secs(5);
    loop {
        let st = client.ok("status", Value::Null);
        let at: Vec<f64> = st["drives"]
            .as_array()
            .expect("drives")
            .iter()
            .filter_map(|d| d["position_actual_units"].as_f64())
            .collect();
        if at.iter().zip([5.0, 10.0, 3.0]).all(|(p, want)| (p - want).abs() <= 1e-3) {
            break;
        }
        assert!(Instant::now() < until, "the drives at the program's end: {at:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(client);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    let frames = capture.finish();
    let _ = drives.terminate();
    // X on the bus: the RPDO1 with bit 4, then homing until bit 12 with bit 10; the last
    // position before it (the old reference) is the index pulse at 10 mm below the switch
    // edge at 12.5 mm, and the search went through the edge.
    let start = frames
        .iter()
        .find(|(_, f)| f.id().raw() == 0x201 && f.payload().first().is_some_and(|b| b & 0x10 != 0))
        .expect("an RPDO1 with bit 4 to node 1")
        .0;
    let x: Vec<(SystemTime, u16, i32)> = tpdos(&frames, 1).into_iter().filter(|(t, _, _)| *t > start).collect();
    let done = x.iter().position(|(_, sw, _)| sw & 0x1400 == 0x1400).expect("homing attained on the bus");
    let (found, highest) = (x[done - 1].2, x[..done].iter().map(|p| p.2).max().unwrap_or(0));
    assert!((found - 100_000).abs() <= 50, "X found home at {found} increments, not the index at 100 000");
    assert!(highest > 125_000, "X's search went through the switch edge: {highest}");
    assert!((x[done].2 + 20_000).abs() <= 50, "X reports its home offset −2 mm: {}", x[done].2);
    // The homing of Y (method 37) on the bus, annotated: its SDO transfers, and of its PDOs
    // each one that differs from the one before.
    let y_first = frames
        .iter()
        .find(|(_, f)| f.id().raw() == 0x602 && f.payload().get(1..3) == Some(&[0x7C, 0x60]))
        .expect("Y's home offset written")
        .0;
    let mut text = Vec::new();
    let mut last_pdo = [Vec::new(), Vec::new()];
    for (t, f) in frames.iter().filter(|(t, _)| *t >= y_first) {
        let id = f.id().raw();
        let pdo = match id {
            0x202 => Some(0),
            0x182 => Some(1),
            0x602 | 0x582 => None,
            _ => continue,
        };
        if let Some(k) = pdo {
            if last_pdo[k] == f.payload() {
                continue;
            }
            last_pdo[k] = f.payload().to_vec();
        }
        text.push(line(y_first, *t, f));
        let back_in_csp = id == 0x582 && f.payload().get(1..5) == Some(&[0x61, 0x60, 0, 8]);
        if back_in_csp || text.len() > 60 {
            break;
        }
    }
    eprintln!("homing of Y (node 2, method 37) on the bus:\n{}", text.join("\n"));
    eprintln!(
        "homing: machine.home took {home_s:.3} s (wall); X found the index at {found} increments (highest {highest}), \
         then reports {}; in {:.3} s of bus time; {homed}",
        x[done].2,
        secs(start, x[done].0)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A homing error: Y (homed first) has no home switch, so method 3 runs to the end of its
/// travel; the drive reports bit 13, `machine.home` fails naming the drive, the node and the
/// method, Y's setpoint takes the position where it stopped, X and Z never move, nothing is
/// homed and motion stays refused.
#[test]
fn a_homing_error_is_reported_and_nothing_else_moves() {
    let Some((iface, _bus)) = vcan::bus("a_homing_error_is_reported_and_nothing_else_moves") else { return };
    let dir = vcan::temp_dir("can-home-error");
    let extra = "require_homing = true\nhome_order = [\"Y\", \"X\", \"Z\"]\n\
        [sinks.can.node.2]\nhoming = { method = 3, speed_switch = 50.0, speed_zero = 2.0, acceleration = 500.0 }\n";
    let cfg = config(&dir, 3, 4.0, extra);
    // A short travel: the search reaches its end after a second.
    let text = std::fs::read_to_string(&cfg)
        .expect("config")
        .replace("min = -1000.0\nmax = 1000.0", "min = -50.0\nmax = 50.0");
    std::fs::write(&cfg, text).expect("config");
    let drives = start_drives(&iface, &cfg, &dir);
    let capture = Capture::start(&iface);
    let daemon = Daemon::start(&["--config", cfg.as_str(), "--can", iface.as_str(), "--no-shm"]);
    let mut client = daemon.client();
    await_enabled(&mut client, 3);
    let failed = client.call("machine.home", Value::Null);
    assert_eq!(failed["error"]["code"], -32007, "{failed}");
    let why = failed["error"]["message"].as_str().unwrap_or_default().to_string();
    assert!(
        why.contains("drive Y (node 2): homing method 3: the drive reports a homing error (statusword"),
        "{failed}"
    );
    let st = client.ok("status", Value::Null);
    assert_eq!(st["homed"], false, "{st}");
    let y = st["drives"][1]["position_actual_units"].as_f64().expect("Y");
    assert!(y > 50.0 && y < 55.0, "Y stopped just beyond its travel: {y}");
    assert!((st["position"][1].as_f64().unwrap_or(0.0) - y).abs() < 1e-3, "Y's setpoint took its position: {st}");
    client.ok("program.load", json!({ "text": "G21 G90\nG1 X5 F3000\nM30\n" }));
    let refused = client.call("motion.start", Value::Null);
    assert!(refused["error"]["message"].as_str().unwrap_or_default().contains("is not homed"), "{refused}");
    drop(client);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    let frames = capture.finish();
    let _ = drives.terminate();
    for node in [1, 3] {
        let moved = tpdos(&frames, node).iter().map(|p| p.2.abs()).max().unwrap_or(0);
        assert!(moved <= 1, "node {node} moved during the homing of node 2: {moved} increments");
        assert!(
            !frames
                .iter()
                .any(|(_, f)| f.id().raw() == 0x200 + node && f.payload().first().is_some_and(|b| b & 0x10 != 0)),
            "node {node} got the homing start bit"
        );
    }
    eprintln!("homing error: {why}");
    let _ = std::fs::remove_dir_all(&dir);
}
