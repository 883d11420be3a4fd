//! CAN tests over a real SocketCAN interface (vcan).
//!
//! They run only when `INTERPD_VCAN` names an interface that is up (e.g. `vcan0`); otherwise
//! each test prints a note and passes, so a plain `cargo test` on a host without CAN stays fast.
//! `scripts/vcan-vm.sh` sets the variable: on the host when it has vcan, otherwise inside a
//! small QEMU VM whose kernel has the CAN modules. There `INTERPD_BIN_DIR` says where the
//! binaries the tests start are, and `INTERPD_VCAN_BINS` lists them.
//!
//! All tests share one bus, and every socket on it sees every frame, so they take a lock and
//! run one at a time even when the test harness runs them in parallel threads.
//!
//! These cover the protocol layer (interpd_protocol::cia301, ::cia402 and ::candump) over a
//! real kernel CAN stack; the daemon as master and sim-plant's drives are tested end to end in
//! can_daemon.rs.

use interpd_protocol::candump::{self, Iface, Record, Timestamp};
use interpd_protocol::cia301::{
    self, CanId, DecodeError, Emcy, Frame, FrameKind, Message, NmtCommand, NmtState, NodeId,
};
use interpd_protocol::cia402::{self, PowerState, PowerStateMachine, Rpdo1, Scale, Tpdo1, controlword_toward_enabled};
use socketcan::{CanFrame, CanSocket, EmbeddedFrame, ExtendedId, Frame as _, Id, Socket, SocketOptions, StandardId};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Serialises the tests: they share the bus.
static BUS: Mutex<()> = Mutex::new(());

/// The interface under test and the bus lock, or `None` (with a note) when CAN tests are off.
fn bus(test: &str) -> Option<(String, MutexGuard<'static, ()>)> {
    match std::env::var("INTERPD_VCAN") {
        Ok(iface) if !iface.is_empty() => {
            // A test that failed while holding the lock poisons it; the bus itself is fine.
            let guard = BUS.lock().unwrap_or_else(|p| p.into_inner());
            Some((iface, guard))
        }
        _ => {
            eprintln!(
                "note: {test} skipped: INTERPD_VCAN is not set (run scripts/vcan-vm.sh, which uses the \
                 host's vcan0 or boots a VM with one)"
            );
            None
        }
    }
}

/// A binary the tests start: from `INTERPD_BIN_DIR` (inside the VM) or next to the test
/// executable (a normal cargo build).
fn bin_path(name: &str) -> PathBuf {
    match std::env::var_os("INTERPD_BIN_DIR") {
        Some(dir) => PathBuf::from(dir).join(name),
        None => interpd_e2e::binary(name),
    }
}

fn open(iface: &str) -> CanSocket {
    let s = CanSocket::open(iface)
        .unwrap_or_else(|e| panic!("cannot open CAN interface {iface}: {e} (does it exist and is it up?)"));
    s.set_read_timeout(Duration::from_secs(2)).expect("set read timeout");
    s
}

fn to_socketcan(f: &Frame) -> CanFrame {
    let id = f.id();
    let id: Id = if id.is_extended() {
        ExtendedId::new(id.raw()).expect("29-bit id").into()
    } else {
        StandardId::new(id.raw() as u16).expect("11-bit id").into()
    };
    let out = match f.kind() {
        FrameKind::Data => CanFrame::new(id, f.payload()),
        FrameKind::Remote => CanFrame::new_remote(id, f.len() as usize),
        FrameKind::Error => panic!("error frames come from the kernel, user space cannot send them"),
    };
    out.expect("a valid classic frame")
}

fn from_socketcan(f: &CanFrame) -> Frame {
    Frame::from_socketcan(f.id_word(), f.dlc() as u8, f.data()).expect("kernel frames are valid")
}

/// Sends a frame, retrying briefly when the interface queue is full (ENOBUFS), as the master
/// will have to.
fn send(sock: &CanSocket, f: &Frame) {
    let frame = to_socketcan(f);
    let mut tries = 0;
    loop {
        match sock.write_frame(&frame) {
            Ok(()) => return,
            Err(e) if e.raw_os_error() == Some(105 /* ENOBUFS */) && tries < 100 => {
                tries += 1;
                thread::sleep(Duration::from_millis(1));
            }
            Err(e) => panic!("send {f:?}: {e}"),
        }
    }
}

fn recv(sock: &CanSocket) -> Frame {
    let f = sock.read_frame().unwrap_or_else(|e| panic!("no frame within the read timeout: {e}"));
    from_socketcan(&f)
}

fn node(n: u8) -> NodeId {
    NodeId::new(n).expect("node-ID")
}

/// Every frame type of the protocol crosses the kernel unchanged, and decodes to what was sent.
#[test]
fn every_cia402_frame_type_crosses_vcan_unchanged() {
    let Some((iface, _bus)) = bus("every_cia402_frame_type_crosses_vcan_unchanged") else { return };
    let tx = open(&iface);
    let rx = open(&iface);
    let messages = [
        Message::Nmt { command: NmtCommand::Start, target: None },
        Message::Nmt { command: NmtCommand::ResetNode, target: Some(node(5)) },
        Message::Sync { counter: None },
        Message::Sync { counter: Some(240) },
        Message::Rpdo1 { node: node(1), pdo: Rpdo1 { controlword: 0x000F, target_position: -123_456_789 } },
        Message::Tpdo1 { node: node(127), pdo: Tpdo1 { statusword: 0x1637, position_actual: i32::MAX } },
        Message::Heartbeat { node: node(3), state: NmtState::Operational },
        Message::Emcy {
            node: node(2),
            emcy: Emcy { error_code: 0x8611, error_register: 0x21, vendor: [1, 2, 3, 4, 5] },
        },
    ];
    for m in messages {
        let sent = m.encode();
        send(&tx, &sent);
        let got = recv(&rx);
        assert_eq!(got, sent, "frame changed on the way");
        assert_eq!(cia301::decode(&got), Ok(m));
    }
    // Non-CANopen frames survive the conversion too (they must be logged faithfully).
    let others = [
        Frame::data(CanId::extended(0x1ABC_DEF0).expect("id"), &[0xDE, 0xAD]).expect("frame"),
        Frame::data(CanId::extended(0x201).expect("id"), &[0; 6]).expect("frame"),
        Frame::remote(CanId::standard(0x701).expect("id"), 1).expect("frame"),
        Frame::standard(0x7FF, &[]).expect("frame"),
    ];
    for sent in others {
        send(&tx, &sent);
        assert_eq!(recv(&rx), sent);
    }
}

/// Receive queue of the capture socket, bytes. The capture thread only reads, while the master
/// and the drives exchange in lock step: on a loaded machine or an emulated CPU (the QEMU VM of
/// CI) it can fall behind by many cycles, and the kernel drops what overflows the default queue
/// (about 200 frames); a SYNC missing from the capture then looks like two RPDO1s in one cycle.
/// 8 MiB holds the whole exchange.
const CAPTURE_QUEUE_BYTES: libc::c_int = 8 << 20;

/// Raises the socket's receive queue to `CAPTURE_QUEUE_BYTES`: past `net.core.rmem_max` where
/// the test may (CAP_NET_ADMIN, as in the VM), else as far as that allows.
fn deepen_receive_queue(sock: &CanSocket) {
    use std::os::fd::AsRawFd;
    let size = CAPTURE_QUEUE_BYTES;
    let set = |opt: libc::c_int| {
        // SAFETY: setsockopt reads one c_int from the valid pointer it is given, for a socket
        // this process owns.
        unsafe {
            libc::setsockopt(
                sock.as_raw_fd(),
                libc::SOL_SOCKET,
                opt,
                (&size as *const libc::c_int).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            )
        }
    };
    if set(libc::SO_RCVBUFFORCE) != 0 {
        set(libc::SO_RCVBUF);
    }
}

/// Captures every frame on the bus with the kernel's receive timestamp (as candump does).
struct Capture {
    stop: Arc<AtomicBool>,
    handle: thread::JoinHandle<Vec<(SystemTime, Frame)>>,
}

impl Capture {
    fn start(iface: &str) -> Capture {
        let sock = open(iface);
        deepen_receive_queue(&sock);
        sock.set_recv_timestamp(true).expect("SO_TIMESTAMPNS");
        sock.set_read_timeout(Duration::from_millis(20)).expect("timeout");
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let handle = thread::spawn(move || {
            let mut frames = Vec::new();
            loop {
                match sock.read_frame_with_timestamp() {
                    Ok((f, t)) => frames.push((t, from_socketcan(&f))),
                    Err(_) if flag.load(Ordering::Acquire) => return frames,
                    Err(_) => {}
                }
            }
        });
        Capture { stop, handle }
    }

    /// Stops after the bus has been quiet for one read timeout.
    fn finish(self) -> Vec<(SystemTime, Frame)> {
        self.stop.store(true, Ordering::Release);
        self.handle.join().expect("capture thread")
    }
}

/// The drive side for the exchange test: NMT, the CiA 402 power state machine and CSP
/// setpoints applied on SYNC, built only from the protocol crate's pure functions.
fn run_drives(iface: &str, nodes: Vec<NodeId>, stop: Arc<AtomicBool>) -> thread::JoinHandle<()> {
    let sock = open(iface);
    sock.set_read_timeout(Duration::from_millis(20)).expect("timeout");
    thread::spawn(move || {
        struct Drive {
            nmt: NmtState,
            power: PowerStateMachine,
            cw: u16,
            target: i32,
            position: i32,
        }
        let mut drives: BTreeMap<NodeId, Drive> = BTreeMap::new();
        for &n in &nodes {
            let power = PowerStateMachine::new(PowerState::NotReadyToSwitchOn.on_init_complete());
            drives.insert(n, Drive { nmt: NmtState::BootUp, power, cw: 0, target: 0, position: 1000 * n.get() as i32 });
            send(&sock, &Message::Heartbeat { node: n, state: NmtState::BootUp }.encode());
            drives.get_mut(&n).expect("drive").nmt = NmtState::BootUp.after_boot_up();
        }
        while !stop.load(Ordering::Acquire) {
            let Ok(f) = sock.read_frame() else { continue };
            match cia301::decode(&from_socketcan(&f)) {
                Ok(Message::Nmt { command, target }) => {
                    for (n, d) in drives.iter_mut() {
                        if target.is_none() || target == Some(*n) {
                            d.nmt = d.nmt.apply(command).after_boot_up();
                        }
                    }
                }
                Ok(Message::Rpdo1 { node, pdo }) => {
                    if let Some(d) = drives.get_mut(&node).filter(|d| d.nmt.pdo_allowed()) {
                        d.cw = pdo.controlword;
                        d.target = pdo.target_position;
                    }
                }
                Ok(Message::Sync { .. }) => {
                    for (&n, d) in drives.iter_mut().filter(|(_, d)| d.nmt.pdo_allowed()) {
                        let was_enabled = d.power.state().is_operation_enabled();
                        d.power.apply(d.cw);
                        // CSP: a drive in Operation enabled follows the setpoint of this SYNC.
                        if was_enabled && d.power.state().is_operation_enabled() {
                            d.position = d.target;
                        }
                        let statusword = d.power.state().statusword_bits() | cia402::statusword::REMOTE_BIT;
                        let pdo = Tpdo1 { statusword, position_actual: d.position };
                        send(&sock, &Message::Tpdo1 { node: n, pdo }.encode());
                    }
                }
                _ => {}
            }
        }
    })
}

/// One cycle as the master saw it.
struct CycleLog {
    sent: Vec<(NodeId, Rpdo1)>,
    received: BTreeMap<NodeId, Tpdo1>,
}

/// The master side: NMT start, then per cycle one RPDO1 per node and SYNC, waiting for every
/// node's TPDO1 (lock-step, so the test does not depend on the speed of an emulated CPU).
/// `sock` is opened before the drives start, so it sees their boot-up messages.
fn run_master(sock: CanSocket, nodes: &[NodeId], cycles: usize, scale: Scale) -> Vec<CycleLog> {
    let mut booted = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(10);
    while booted.len() < nodes.len() && Instant::now() < deadline {
        if let Ok(Message::Heartbeat { node, state: NmtState::BootUp }) = cia301::decode(&recv(&sock)) {
            booted.push(node);
        }
    }
    booted.sort();
    assert_eq!(booted, nodes, "every drive sends its boot-up message");
    send(&sock, &Message::Nmt { command: NmtCommand::Start, target: None }.encode());

    let mut states: BTreeMap<NodeId, PowerState> = nodes.iter().map(|&n| (n, PowerState::NotReadyToSwitchOn)).collect();
    let mut last_cw: BTreeMap<NodeId, u16> = nodes.iter().map(|&n| (n, 0)).collect();
    let mut origin: BTreeMap<NodeId, f64> = BTreeMap::new();
    let mut motion_start = None;
    let mut log = Vec::with_capacity(cycles);
    for cycle in 0..cycles {
        let all_enabled = states.values().all(|s| s.is_operation_enabled());
        if all_enabled && motion_start.is_none() {
            motion_start = Some(cycle);
        }
        let mut sent = Vec::new();
        for &n in nodes {
            let cw = controlword_toward_enabled(states[&n], last_cw[&n]);
            last_cw.insert(n, cw);
            // Before motion the setpoint holds the drive's reported position; then each axis
            // moves along its own sine (mm), converted to increments.
            let hold = *origin.get(&n).unwrap_or(&0.0);
            let mm = match motion_start {
                Some(c0) => hold + (n.get() as f64) * (((cycle - c0) as f64) * 0.01).sin(),
                None => hold,
            };
            let pdo = Rpdo1 { controlword: cw, target_position: scale.to_increments(mm).expect("in range") };
            send(&sock, &Message::Rpdo1 { node: n, pdo }.encode());
            sent.push((n, pdo));
        }
        send(&sock, &Message::Sync { counter: None }.encode());
        let mut received = BTreeMap::new();
        while received.len() < nodes.len() {
            match cia301::decode(&recv(&sock)) {
                Ok(Message::Tpdo1 { node, pdo }) => {
                    let state = PowerState::from_statusword(pdo.statusword).expect("defined statusword");
                    states.insert(node, state);
                    if !state.is_operation_enabled() {
                        origin.insert(node, scale.to_units(pdo.position_actual));
                    }
                    assert!(received.insert(node, pdo).is_none(), "two TPDO1 from node {node} in cycle {cycle}");
                }
                other => panic!("cycle {cycle}: unexpected {other:?}"),
            }
        }
        log.push(CycleLog { sent, received });
    }
    log
}

/// Three drives, a few hundred cycles: the power state machine reaches Operation enabled before
/// motion, each cycle carries exactly one RPDO1 per node before its SYNC, the drives follow the
/// setpoints, and the candump log of the capture reads back to the same text and setpoints.
#[test]
fn csp_cycle_exchange_and_candump_roundtrip() {
    let Some((iface, _bus)) = bus("csp_cycle_exchange_and_candump_roundtrip") else { return };
    const CYCLES: usize = 300;
    let nodes = vec![node(1), node(2), node(3)];
    let scale = Scale::new(10_000.0).expect("scale");
    let capture = Capture::start(&iface);
    let master = open(&iface);
    let stop = Arc::new(AtomicBool::new(false));
    let drives = run_drives(&iface, nodes.clone(), stop.clone());
    let log = run_master(master, &nodes, CYCLES, scale);
    stop.store(true, Ordering::Release);
    drives.join().expect("drive thread");
    let captured = capture.finish();

    // Power state machine: every drive is enabled within a few cycles, and no drive moves
    // before all of them are.
    let enabled = |t: &Tpdo1| PowerState::from_statusword(t.statusword).is_some_and(PowerState::is_operation_enabled);
    let enabled_at =
        log.iter().position(|c| c.received.values().all(enabled)).expect("all drives reach Operation enabled");
    assert!(enabled_at <= 5, "drives enabled only at cycle {enabled_at}");
    let initial = &log[0].received;
    let first_motion = log
        .iter()
        .position(|c| c.received.iter().any(|(n, t)| t.position_actual != initial[n].position_actual))
        .expect("the drives moved");
    assert!(first_motion > enabled_at, "a drive moved at cycle {first_motion}, all enabled only at {enabled_at}");
    // No jump when motion starts: the first setpoint after enabling is where the drive stands.
    for (n, pdo) in &log[enabled_at + 1].sent {
        assert_eq!(pdo.target_position, initial[n].position_actual, "node {n} jumps on enable");
    }
    // CSP: once enabled, the reported position is the setpoint of the same cycle.
    for (i, c) in log.iter().enumerate().skip(enabled_at + 1) {
        for (n, pdo) in &c.sent {
            assert_eq!(c.received[n].position_actual, pdo.target_position, "cycle {i} node {n}");
        }
    }

    // Bus order: between SYNCs exactly one RPDO1 per node, all before their SYNC.
    let mut rpdos_since_sync: Vec<NodeId> = Vec::new();
    let mut syncs = 0;
    let mut bus_setpoints: Vec<Vec<(NodeId, Rpdo1)>> = Vec::new();
    let mut current = Vec::new();
    for (_, f) in &captured {
        match cia301::decode(f) {
            Ok(Message::Rpdo1 { node, pdo }) => {
                assert!(!rpdos_since_sync.contains(&node), "two RPDO1 for node {node} before SYNC {syncs}");
                rpdos_since_sync.push(node);
                current.push((node, pdo));
            }
            Ok(Message::Sync { .. }) => {
                rpdos_since_sync.sort();
                assert_eq!(rpdos_since_sync, nodes, "RPDO1s before SYNC {syncs}");
                rpdos_since_sync.clear();
                bus_setpoints.push(std::mem::take(&mut current));
                syncs += 1;
            }
            _ => {}
        }
    }
    assert_eq!(syncs, CYCLES, "one SYNC per cycle");

    // candump: write, read back, write again -> identical text; the decoded setpoints are
    // exactly the ones the master sent; an independent parser (socketcan::dump) agrees.
    let iface_name = Iface::new(&iface).expect("interface name");
    let records: Vec<Record> = captured
        .iter()
        .map(|(t, f)| Record {
            time: Timestamp::from_duration(t.duration_since(UNIX_EPOCH).expect("after epoch")).expect("time"),
            iface: iface_name.clone(),
            frame: *f,
        })
        .collect();
    let dir = std::env::temp_dir().join(format!("interpd-can-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("capture.log");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create log"));
        let mut w = candump::Writer::new(file);
        for r in &records {
            w.write(r).expect("write record");
        }
        w.flush().expect("flush");
    }
    let text = std::fs::read_to_string(&path).expect("read log");
    assert_eq!(text.lines().count(), captured.len());
    let back: Vec<Record> = candump::Reader::new(std::io::BufReader::new(std::fs::File::open(&path).expect("open")))
        .collect::<Result<_, _>>()
        .expect("the log reads back");
    assert_eq!(back, records);
    assert_eq!(candump::format_log(&back), text, "read back and written again: identical");
    let from_log: Vec<Vec<(NodeId, Rpdo1)>> = {
        let mut cycles = Vec::new();
        let mut cur = Vec::new();
        for r in &back {
            match cia301::decode(&r.frame) {
                Ok(Message::Rpdo1 { node, pdo }) => cur.push((node, pdo)),
                Ok(Message::Sync { .. }) => cycles.push(std::mem::take(&mut cur)),
                _ => {}
            }
        }
        cycles
    };
    let master: Vec<Vec<(NodeId, Rpdo1)>> = log.iter().map(|c| c.sent.clone()).collect();
    assert_eq!(from_log, master, "the log decodes to the setpoints sent, to the increment");
    assert_eq!(bus_setpoints, master);

    let mut independent = 0;
    for (i, rec) in socketcan::dump::Reader::from_file(&path).expect("open log").enumerate() {
        let rec = rec.unwrap_or_else(|e| panic!("socketcan::dump rejects line {}: {e:?}", i + 1));
        assert_eq!(rec.t_us, records[i].time.as_micros(), "line {}", i + 1);
        assert_eq!(rec.device, iface);
        assert_eq!(socketcan::Frame::id_word(&rec.frame), records[i].frame.socketcan_id_word(), "line {}", i + 1);
        assert_eq!(EmbeddedFrame::data(&rec.frame), records[i].frame.payload(), "line {}", i + 1);
        independent += 1;
    }
    assert_eq!(independent, records.len());
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{CYCLES} cycles, {} frames captured, drives enabled at cycle {enabled_at}", captured.len());
}

/// Counts of what a receiver saw, by outcome.
#[derive(Debug, Default, PartialEq, Eq)]
struct Tally {
    ok: usize,
    wrong_dlc: usize,
    unknown_cob_id: usize,
    bad_value: usize,
    not_data: usize,
    emcy: usize,
}

impl Tally {
    fn count(&mut self, r: &Result<Message, DecodeError>) {
        match r {
            Ok(Message::Emcy { .. }) => {
                self.ok += 1;
                self.emcy += 1;
            }
            Ok(_) => self.ok += 1,
            Err(DecodeError::WrongDlc { .. }) => self.wrong_dlc += 1,
            Err(DecodeError::UnknownCobId { .. }) => self.unknown_cob_id += 1,
            Err(DecodeError::BadValue { .. }) => self.bad_value += 1,
            Err(DecodeError::NotDataFrame { .. }) => self.not_data += 1,
        }
    }
}

/// Malformed and unexpected frames on a real bus (wrong DLCs, unknown COB-IDs, 29-bit IDs,
/// remote frames, undefined values, an EMCY storm) are classified and counted by the decoder,
/// and valid frames in between still decode. Nothing is lost in the kernel either.
#[test]
fn malformed_frames_are_counted_not_fatal() {
    let Some((iface, _bus)) = bus("malformed_frames_are_counted_not_fatal") else { return };
    let std_frame = |id: u16, data: &[u8]| Frame::standard(id, data).expect("frame");
    let mut plan: Vec<Frame> = Vec::new();
    let mut expect = Tally::default();
    // Wrong DLCs on every per-node object and on SYNC/NMT.
    for len in [0usize, 1, 4, 5, 7, 8] {
        plan.push(std_frame(0x201, &[0x0F; 8][..len])); // RPDO1 needs 6
        plan.push(std_frame(0x182, &[0x37; 8][..len])); // TPDO1 needs 6
        expect.wrong_dlc += 2;
    }
    for len in [0usize, 2, 8] {
        plan.push(std_frame(0x702, &[0x05; 8][..len])); // heartbeat needs 1
        plan.push(std_frame(0x000, &[0x01; 8][..len.min(1)])); // NMT needs 2
        expect.wrong_dlc += 2;
    }
    plan.push(std_frame(0x080, &[1, 2])); // SYNC takes 0 or 1
    plan.push(std_frame(0x083, &[0; 4])); // EMCY needs 8
    expect.wrong_dlc += 2;
    // Unknown COB-IDs: TIME, SDO, TPDO2..4, RPDO2..4, node-ID 0, LSS, the top of the range.
    for id in [0x100u16, 0x581, 0x601, 0x281, 0x381, 0x481, 0x301, 0x401, 0x501, 0x180, 0x200, 0x700, 0x7E5, 0x7FF] {
        plan.push(std_frame(id, &[0; 6]));
        expect.unknown_cob_id += 1;
    }
    for id in [0x201u32, 0x181, 0x1FFF_FFFF] {
        plan.push(Frame::data(CanId::extended(id).expect("id"), &[0; 6]).expect("frame"));
        expect.unknown_cob_id += 1;
    }
    // Remote frames (node guarding requests, RTR on a PDO).
    for (id, len) in [(0x701u16, 1u8), (0x181, 6), (0x080, 0)] {
        plan.push(Frame::remote(CanId::standard(id).expect("id"), len).expect("frame"));
        expect.not_data += 1;
    }
    // Undefined values: NMT command 0x03, NMT node-ID 200, heartbeat state 0x42.
    plan.push(std_frame(0x000, &[0x03, 0x00]));
    plan.push(std_frame(0x000, &[0x01, 200]));
    plan.push(std_frame(0x701, &[0x42]));
    expect.bad_value += 3;
    // An EMCY storm from node 2 interleaved with valid PDOs and SYNCs.
    for i in 0..600u32 {
        let b = i.to_le_bytes();
        let emcy = Emcy { error_code: 0x8611, error_register: 0x20, vendor: [b[0], b[1], b[2], b[3], 0] };
        plan.push(Message::Emcy { node: node(2), emcy }.encode());
        expect.ok += 1;
        expect.emcy += 1;
        if i % 50 == 0 {
            plan.push(
                Message::Rpdo1 { node: node(1), pdo: Rpdo1 { controlword: 0x0F, target_position: i as i32 } }.encode(),
            );
            plan.push(Message::Sync { counter: None }.encode());
            expect.ok += 2;
        }
    }

    let tx = open(&iface);
    let rx = open(&iface);
    let received = Arc::new(AtomicUsize::new(0));
    let total = plan.len();
    let counter = received.clone();
    let receiver = thread::spawn(move || {
        let mut tally = Tally::default();
        let mut frames = Vec::with_capacity(total);
        while frames.len() < total {
            let f = recv(&rx);
            tally.count(&cia301::decode(&f));
            frames.push(f);
            counter.store(frames.len(), Ordering::Release);
        }
        (tally, frames)
    });
    for (i, f) in plan.iter().enumerate() {
        // Pace the sender so the receiver's socket buffer never overflows, even on a slow
        // emulated CPU: the test is about the decoder, not about kernel drops.
        while i - received.load(Ordering::Acquire) > 64 {
            thread::yield_now();
        }
        send(&tx, f);
    }
    let (tally, frames) = receiver.join().expect("receiver thread");
    assert_eq!(frames, plan, "every frame arrived unchanged and in order");
    assert_eq!(tally, expect);
    eprintln!("{} frames: {tally:?}", frames.len());
}

/// The binaries the harness put into the VM (`INTERPD_VCAN_BINS`) are where the tests look
/// for them.
#[test]
fn extra_binaries_are_reachable() {
    let Some((_iface, _bus)) = bus("extra_binaries_are_reachable") else { return };
    let names = std::env::var("INTERPD_VCAN_BINS").unwrap_or_default();
    for name in names.split_whitespace() {
        let path = bin_path(name);
        let meta = std::fs::metadata(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        use std::os::unix::fs::PermissionsExt;
        assert!(meta.is_file() && meta.permissions().mode() & 0o111 != 0, "{} is not executable", path.display());
        // It must also start here (a dynamically linked binary would not in the VM).
        let mut child = std::process::Command::new(&path)
            .arg("--help")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{} does not start: {e}", path.display()));
        let deadline = Instant::now() + Duration::from_secs(20);
        while child.try_wait().expect("wait").is_none() {
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("{} --help did not exit within 20 s", path.display());
            }
            thread::sleep(Duration::from_millis(20));
        }
    }
}
