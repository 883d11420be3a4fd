//! End to end, the fault campaign: the real daemon with the plant (`sim-plant` over iceoryx2),
//! and faults from outside. Each case ends in the state docs/architecture.md ("Faults and the
//! states they end in") names, with the evidence: the setpoint stream has no cycle gap and
//! keeps the axis limits by finite differences, and what was recorded stays readable.
//!
//! - JSON-RPC fuzzing: `FAULT_FUZZ_REQUESTS` (100 000) well-formed and mutated requests from
//!   several pipelining clients, valid calls in random order during motion; every well-formed
//!   request answered once, `status` consistent after every burst, no panic.
//! - Clients that disconnect mid-request, stall in the middle of a line, do not read, or
//!   flood subscriptions: the motion is undisturbed; threads and descriptors return to their
//!   level, resident memory to within the stacks the C library keeps for reuse.
//! - A recording whose file cannot grow (the disk is full): an `error` event names the file,
//!   the motion goes on, the file is readable up to its last complete chunk.
//! - The plant and a shared-memory subscriber killed and started again mid-motion; the
//!   planner thread stalled (an underrun, braked along the path, then continued).

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Collector, Daemon, FeedbackCollector};
use interpd_e2e::fuzz::{FuzzLine, mutated, well_formed};
use interpd_e2e::process::{Plant, Resources, fd_targets};
use interpd_e2e::rng::{Rng, seed_from_env, seeded};
use interpd_e2e::stream::{StreamCheck, check_recording};
use interpd_protocol::shm::Setpoints;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);
/// Requests of the fuzzing, over all clients (`FAULT_FUZZ_REQUESTS` overrides).
const FUZZ_REQUESTS: usize = 100_000;
const FUZZ_CLIENTS: usize = 4;
/// Requests per burst: after each, `status` is checked.
const FUZZ_BURST: usize = 1000;
/// Share of the fuzz lines that are well-formed requests (the rest are mutated).
const WELL_FORMED_SHARE: f64 = 0.6;
/// Longest fuzz line sent: below the 1 MiB line limit, which closes a connection.
const MAX_FUZZ_LINE: usize = 900_000;
/// A program of many short lines, long enough to run through any of the cases (about 20 s at
/// F3000), with a line reached every few cycles (events for the subscribers).
const STATES: &[&str] = &["idle", "running", "holding", "stopping", "finished", "error", "jogging"];

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("interpd-e2e-faults-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A zigzag of `n` short moves back and forth over X 0–100 mm, as program text.
fn zigzag(n: usize, feed: u32) -> String {
    let mut text = format!("G21 G90 G64 P0.01\nG1 X100 Y0 F{feed}\n");
    for i in 1..=n {
        let x = ((i % 200) as f64 - 100.0).abs();
        text.push_str(&format!("G1 X{x} Y{}\n", if i % 2 == 0 { 0.0 } else { 2.0 }));
    }
    text.push_str("M30\n");
    text
}

fn stream_check(config: &Config) -> StreamCheck {
    StreamCheck::new(AxisLimits::of(config), config.cycle_s())
}

/// The stream has every cycle and keeps the limits.
fn assert_stream(what: &str, sps: &[Setpoints]) -> StreamCheck {
    let mut check = stream_check(&Config::default_machine());
    sps.iter().for_each(|s| check.push(s));
    assert!(check.count > 100, "{what}: {} setpoints", check.count);
    if !check.violations().is_empty() {
        // The setpoints around the worst finite-difference acceleration and the worst reported
        // acceleration.
        for at in [check.worst_cycle[1], check.worst_cycle[3], check.agreement_cycle[1]] {
            for s in sps.iter().filter(|s| s.cycle + 6 >= at && s.cycle <= at + 3) {
                eprintln!(
                    "cycle {} flags {:#x} line {} s {:.6} v {:.4} a {:.2} override {:.3} pos {:.9?} vel {:.4?} acc {:.2?}",
                    s.cycle,
                    s.flags,
                    s.line,
                    s.s_mm,
                    s.v_mm_s,
                    s.a_mm_s2,
                    s.feed_override,
                    &s.pos[..3],
                    &s.vel[..3],
                    &s.acc[..3]
                );
            }
        }
    }
    assert!(check.violations().is_empty(), "{what}: {:?}", check.violations());
    check
}

/// The invariants of a `status` result that hold in every state.
fn assert_consistent(st: &Value, config: &Config) {
    let state = st["state"].as_str().unwrap_or("");
    assert!(STATES.contains(&state), "unknown state: {st}");
    let ov = st["override"].as_f64().expect("override");
    assert!((0.0..=2.0).contains(&ov), "override {ov}");
    let fill = st["queue_fill"].as_f64().expect("queue_fill");
    assert!((0.0..=1.0).contains(&fill), "queue_fill {fill}");
    for (k, axis) in config.axes.iter().enumerate() {
        let p = st["position"][k].as_f64().expect("position");
        assert!(
            p.is_finite() && p >= axis.min_pos - 1e-6 && p <= axis.max_pos + 1e-6,
            "axis {} at {p}: {st}",
            axis.name
        );
    }
    if state == "error" {
        assert!(st["last_error"].as_str().is_some_and(|m| !m.is_empty()), "error without last_error: {st}");
    }
    if matches!(state, "idle" | "finished") {
        assert_eq!(st["feed_mm_s"].as_f64(), Some(0.0), "moving while {state}: {st}");
    }
}

// ---------------------------------------------------------------------------------------------
// JSON-RPC fuzzing
// ---------------------------------------------------------------------------------------------

/// What one fuzzing client saw.
#[derive(Debug, Default)]
struct FuzzTally {
    sent: usize,
    well_formed: usize,
    answers: usize,
    events: usize,
    bursts: usize,
}

/// One client: bursts of pipelined lines, each followed by a `status` whose answer says the
/// burst has been read (answers come in request order); then every well-formed request of the
/// burst must have been answered exactly once.
fn fuzz_client(socket: &Path, client: usize, seed: u64, requests: usize, config: &Config) -> FuzzTally {
    let stream = UnixStream::connect(socket).expect("connect");
    stream.set_read_timeout(Some(TIMEOUT)).expect("timeout");
    let answered: Arc<Mutex<HashMap<String, u32>>> = Arc::default();
    let (sentinel_tx, sentinel_rx) = mpsc::channel::<Value>();
    let reader = {
        let (stream, answered) = (stream.try_clone().expect("clone"), answered.clone());
        std::thread::spawn(move || {
            let (mut answers, mut events) = (0usize, 0usize);
            let mut lines = BufReader::new(stream);
            let mut line = Vec::new();
            loop {
                line.clear();
                match lines.read_until(b'\n', &mut line) {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {}
                }
                let v: Value = serde_json::from_slice(&line)
                    .unwrap_or_else(|e| panic!("not JSON from the daemon ({e}): {}", String::from_utf8_lossy(&line)));
                let items = if let Value::Array(items) = v { items } else { vec![v] };
                for item in items {
                    assert_eq!(item["jsonrpc"], "2.0", "{item}");
                    if item["method"] == "event" {
                        events += 1;
                        continue;
                    }
                    assert!(item.get("result").is_some() != item.get("error").is_some(), "{item}");
                    answers += 1;
                    if let Some(id) = item["id"].as_str() {
                        if id.starts_with("sentinel-") {
                            let _ = sentinel_tx.send(item);
                        } else if id.starts_with("w-") {
                            *answered.lock().expect("ids").entry(id.to_string()).or_default() += 1;
                        }
                    }
                }
            }
            (answers, events)
        })
    };
    let mut writer = stream;
    let mut rng = seeded(seed ^ (client as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let mut tally = FuzzTally::default();
    let mut n = 0usize;
    while tally.sent < requests {
        let mut buf = Vec::new();
        let mut expected = Vec::new();
        for _ in 0..FUZZ_BURST.min(requests - tally.sent) {
            let FuzzLine { mut bytes, answered_id } = if rng.random_bool(WELL_FORMED_SHARE) {
                n += 1;
                well_formed(&mut rng, &format!("w-{client}-{n}"))
            } else {
                mutated(&mut rng)
            };
            bytes.truncate(MAX_FUZZ_LINE);
            if let Some(id) = answered_id {
                expected.push(id);
            }
            buf.extend_from_slice(&bytes);
            buf.push(b'\n');
            tally.sent += 1;
        }
        let sentinel = format!("sentinel-{client}-{}", tally.bursts);
        buf.extend_from_slice(json!({"jsonrpc": "2.0", "id": sentinel, "method": "status"}).to_string().as_bytes());
        buf.push(b'\n');
        writer.write_all(&buf).expect("send a burst");
        let st = loop {
            let answer = sentinel_rx.recv_timeout(TIMEOUT).expect("the burst's status answered");
            if answer["id"] == sentinel.as_str() {
                break answer["result"].clone();
            }
        };
        assert_consistent(&st, config);
        let mut ids = answered.lock().expect("ids");
        for id in &expected {
            assert_eq!(ids.remove(id), Some(1), "well-formed request {id} answered not exactly once");
        }
        assert!(
            ids.is_empty(),
            "answers to requests not sent in this burst: {:?}",
            ids.keys().take(5).collect::<Vec<_>>()
        );
        tally.well_formed += expected.len();
        tally.bursts += 1;
    }
    writer.shutdown(std::net::Shutdown::Write).expect("close");
    let (answers, events) = reader.join().expect("reader");
    tally.answers = answers;
    tally.events = events;
    tally
}

#[test]
fn json_rpc_fuzzing_from_several_clients_during_motion() {
    let requests = std::env::var("FAULT_FUZZ_REQUESTS").ok().and_then(|s| s.parse().ok()).unwrap_or(FUZZ_REQUESTS);
    let seed = seed_from_env("FAULT_FUZZ_SEED");
    eprintln!("json_rpc_fuzzing: FAULT_FUZZ_SEED={seed}");
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let dir = temp_dir("fuzz");
    let mut plant = Plant::start(&daemon.prefix, &[], &dir.join("plant.log"));
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("program.load", json!({ "text": zigzag(400, 3000), "name": "zigzag.ngc" }));
    c.ok("motion.start", Value::Null);
    let t0 = Instant::now();
    let tallies: Vec<FuzzTally> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..FUZZ_CLIENTS)
            .map(|k| {
                let (socket, config) = (&daemon.socket, &config);
                s.spawn(move || fuzz_client(socket, k, seed, requests / FUZZ_CLIENTS, config))
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("fuzz client")).collect()
    });
    let wall_s = t0.elapsed().as_secs_f64();
    let st = c.ok("status", Value::Null);
    assert_consistent(&st, &config);
    // The end: whatever the fuzzing left running is stopped along the path.
    c.ok("motion.stop", Value::Null);
    let end = c.wait_state(&["idle", "finished"], TIMEOUT);
    assert_consistent(&end, &config);
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    assert!(plant.running(), "sim-plant ended: {}", plant.stderr());
    drop(c);
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let check = assert_stream("fuzzing", &sps);
    let sent: usize = tallies.iter().map(|t| t.sent).sum();
    let well: usize = tallies.iter().map(|t| t.well_formed).sum();
    let answers: usize = tallies.iter().map(|t| t.answers).sum();
    let events: usize = tallies.iter().map(|t| t.events).sum();
    eprintln!(
        "json_rpc_fuzzing: {sent} lines ({well} well-formed, each answered once; {answers} answers, {events} events) \
         from {FUZZ_CLIENTS} clients in {wall_s:.1} s; {} setpoints, 0 missing, {} underruns, limit ratios {:.4?}, \
         reported v/a agreement {:.3?} of the allowed",
        check.count, check.underruns, check.ratios, check.agreement
    );
    assert!(sent >= requests - FUZZ_CLIENTS, "{sent} sent");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// A recording whose disk fills up
// ---------------------------------------------------------------------------------------------

/// Largest file the daemon may write in the disk-full case (RLIMIT_FSIZE): above the
/// iceoryx2 shared-memory segments it sizes itself (about 240 KB for the setpoints), and
/// reached by the recording after some seconds of motion.
const FILE_SIZE_LIMIT_BYTES: u64 = 384 * 1024;
/// Setpoints a recording may lose at its end when the disk fills: the chunk being written
/// (64 KiB uncompressed, about 0.4 s of both streams at 4 ms) and the recorder's poll.
const LOST_AT_DISK_FULL_CYCLES: u64 = 250;

#[test]
fn a_recording_whose_disk_fills_up_stops_with_an_error_event_and_the_motion_goes_on() {
    let config = Config::default_machine();
    let dir = temp_dir("diskfull");
    let recording = dir.join("run.mcap");
    let record_arg = recording.to_str().expect("UTF-8").to_string();
    // The stand-in for a full disk: a file size limit on the daemon (write(2) then fails with
    // EFBIG where a full disk gives ENOSPC, in the same write path; SIGXFSZ ignored, as
    // otherwise it would end the process). It needs no root and no mount.
    let daemon = Daemon::start_with(&["--record", &record_arg], |cmd| {
        use std::os::unix::process::CommandExt;
        // SAFETY: only async-signal-safe calls (setrlimit, signal) between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let limit = libc::rlimit { rlim_cur: FILE_SIZE_LIMIT_BYTES, rlim_max: FILE_SIZE_LIMIT_BYTES };
                if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                Ok(())
            });
        }
    });
    let _plant = Plant::start(&daemon.prefix, &[], &dir.join("plant.log"));
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    c.ok("program.load", json!({ "text": zigzag(1500, 3000), "name": "zigzag.ngc" }));
    c.ok("motion.start", Value::Null);
    let t0 = Instant::now();
    c.wait_event("error", TIMEOUT);
    let failed_after_s = t0.elapsed().as_secs_f64();
    let failed_at_cycle = collector.snapshot().last().map_or(0, |s| s.cycle);
    let event = c.events.iter().find(|e| e["event"] == "error").expect("error event").clone();
    let message = event["message"].as_str().unwrap_or_default();
    assert!(message.contains(&record_arg) && message.contains("recording stopped"), "{event}");
    // The motion goes on.
    std::thread::sleep(Duration::from_secs(1));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "running", "{st}");
    assert!(st["last_error"].is_null(), "{st}");
    c.ok("motion.stop", Value::Null);
    c.wait_state(&["idle"], TIMEOUT);
    let sps = collector.finish();
    drop(c);
    let (code, stderr) = daemon.terminate();
    // The failure is reported again at exit, with exit status 1.
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("recording failed") && stderr.contains(&record_arg), "{stderr}");
    let stream = assert_stream("disk full", &sps);
    assert!(stream.last_cycle > failed_at_cycle + 200, "the motion did not go on after the recording stopped");
    // The file: readable message by message up to the chunk that did not fit.
    let file_bytes = std::fs::metadata(&recording).expect("recording").len();
    assert!(file_bytes <= FILE_SIZE_LIMIT_BYTES, "{file_bytes} bytes");
    let rec = check_recording(&recording, AxisLimits::of(&config), config.cycle_s()).expect("opens");
    assert!(rec.setpoints.missing == 0 && rec.setpoints.limits_kept(), "{:?}", rec.setpoints.violations());
    let readable_to = rec.setpoints.last_cycle;
    assert!(rec.setpoints.count > 500 && rec.feedback > 500, "{} setpoints readable", rec.setpoints.count);
    assert!(
        readable_to + LOST_AT_DISK_FULL_CYCLES >= failed_at_cycle,
        "readable to cycle {readable_to}, the recording stopped at about {failed_at_cycle}"
    );
    eprintln!(
        "disk full: the recording stopped after {failed_after_s:.1} s of motion ({file_bytes} bytes, limit \
         {FILE_SIZE_LIMIT_BYTES}); readable: {} setpoints to cycle {readable_to} (stopped at about cycle \
         {failed_at_cycle}), {} feedback, ending with {:?}; the motion went on to cycle {}; event: {}",
        rec.setpoints.count, rec.feedback, rec.error, stream.last_cycle, message
    );
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// Clients that disconnect, stall, do not read or flood
// ---------------------------------------------------------------------------------------------

/// Connections the daemon serves at a time (docs/control-api.md).
const MAX_CLIENTS: usize = 16;
/// A slow client is disconnected after 5 s of blocked writes; a little more for the check.
const SLOW_CLIENT_TIMEOUT: Duration = Duration::from_secs(7);
/// Resident memory a second round of the same client faults may add to the first: the
/// allocator's ups and downs; connection stacks are reused from the first round.
const SECOND_ROUND_RSS_SLACK_KIB: u64 = 1024;

fn raw(socket: &Path) -> UnixStream {
    let s = UnixStream::connect(socket).expect("connect");
    s.set_read_timeout(Some(TIMEOUT)).expect("timeout");
    s.set_write_timeout(Some(Duration::from_secs(1))).expect("timeout");
    s
}

/// One round of misbehaving clients while the motion runs; returns the clients still held
/// open (stalled in the middle of a line) for the caller to close.
fn misbehave(socket: &Path, pid: u32, base: Resources) -> Vec<UnixStream> {
    let request = br#"{"jsonrpc":"2.0","id":1,"method":"status"}"#;
    // Disconnect in the middle of a request, and right after a whole one without reading; in
    // rounds of 8 connections, each released before the next, so that a daemon slowed by a
    // loaded host never holds 16 at once (a 17th would be refused, by design).
    for _ in 0..5 {
        for _ in 0..4 {
            let mut s = raw(socket);
            s.write_all(&request[..request.len() / 2]).expect("half a request");
            drop(s);
            let mut s = raw(socket);
            s.write_all(&[request.as_slice(), b"\n"].concat()).expect("a request");
            drop(s);
        }
        // Their connections end.
        let released = settle(pid, base);
        assert_eq!(
            (released.threads, released.sockets),
            (base.threads, base.sockets),
            "disconnected clients not released: {:?}",
            fd_targets(pid)
        );
    }
    // One connection subscribing 10 000 times, reading everything.
    let mut s = raw(socket);
    let subscribe = b"{\"jsonrpc\":\"2.0\",\"id\":2,\"method\":\"subscribe\"}\n".repeat(10_000);
    let reader = {
        let s = s.try_clone().expect("clone");
        std::thread::spawn(move || {
            let mut answers = 0;
            for line in BufReader::new(s).lines() {
                let Ok(line) = line else { break };
                assert!(!line.contains("\"error\":{"), "{line}");
                if line.contains("\"subscribed\"") {
                    answers += 1;
                    if answers == 10_000 {
                        break;
                    }
                }
            }
            answers
        })
    };
    s.set_write_timeout(None).expect("timeout");
    let sent = s.write_all(&subscribe);
    assert_eq!(reader.join().expect("reader"), 10_000, "every subscribe answered");
    sent.expect("subscribe 10 000 times");
    drop(s);
    // Half a line, then silence: kept open.
    let stalled: Vec<UnixStream> = (0..8)
        .map(|_| {
            let mut s = raw(socket);
            s.write_all(b"{\"jsonrpc\":\"2.0\",\"id\":7,\"meth").expect("half a line");
            s
        })
        .collect();
    // Subscribers that never read, flooded with answers as well: disconnected by the daemon.
    let flooders: Vec<std::thread::JoinHandle<()>> = (0..4)
        .map(|_| {
            let mut s = raw(socket);
            std::thread::spawn(move || {
                let _ = s.write_all(b"{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"subscribe\"}\n");
                let burst = [request.as_slice(), b"\n"].concat().repeat(3000);
                let _ = s.write_all(&burst);
                std::thread::sleep(SLOW_CLIENT_TIMEOUT);
            })
        })
        .collect();
    // At the limit the next client is told so.
    let mut extra: Vec<UnixStream> = Vec::new();
    let refused = loop {
        let s = raw(socket);
        let mut probe = s.try_clone().expect("clone");
        let _ = probe.write_all(b"{\"jsonrpc\":\"2.0\",\"id\":3,\"method\":\"status\"}\n");
        let mut line = String::new();
        let _ = BufReader::new(s.try_clone().expect("clone")).read_line(&mut line);
        if line.contains("-32004") {
            break line;
        }
        extra.push(s);
        assert!(extra.len() <= MAX_CLIENTS, "more than {MAX_CLIENTS} connections served");
    };
    assert!(refused.contains("too many clients"), "{refused}");
    for f in flooders {
        f.join().expect("flooder");
    }
    let mut held = stalled;
    held.extend(extra);
    held
}

/// Polls until the daemon's threads and sockets have been back to `base` for half a second
/// (closed clients may still wait in the listen backlog, to be accepted and ended in a burst);
/// returns what they are.
/// Waits until process `pid` has a thread named `name`.
fn wait_for_thread(pid: u32, name: &str) {
    let until = Instant::now() + TIMEOUT;
    loop {
        let names: Vec<String> = std::fs::read_dir(format!("/proc/{pid}/task"))
            .map(|d| d.flatten().filter_map(|t| std::fs::read_to_string(t.path().join("comm")).ok()).collect())
            .unwrap_or_default();
        if names.iter().any(|n| n.trim() == name) {
            return;
        }
        assert!(Instant::now() < until, "no thread {name} in {names:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn settle(pid: u32, base: Resources) -> Resources {
    let until = Instant::now() + TIMEOUT;
    let mut steady = 0;
    loop {
        let now = Resources::of(pid);
        steady = if now.threads <= base.threads && now.sockets <= base.sockets { steady + 1 } else { 0 };
        if steady >= 5 || Instant::now() > until {
            return now;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn clients_that_disconnect_stall_or_flood_leave_the_motion_undisturbed() {
    let dir = temp_dir("clients");
    let daemon = Daemon::start(&[]);
    let pid = daemon.pid().expect("pid");
    let mut plant = Plant::start(&daemon.prefix, &[], &dir.join("plant.log"));
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("program.load", json!({ "text": zigzag(800, 6000), "name": "zigzag.ngc" }));
    c.ok("motion.start", Value::Null);
    c.wait_state(&["running"], TIMEOUT);
    // The run's program reading thread is part of the base (it starts as the look-ahead thread
    // takes the start, which may come after the state turns to running).
    wait_for_thread(pid, "interpd-read");
    let base = Resources::of(pid);
    eprintln!("base descriptors: {:?}", fd_targets(pid));
    let mut rounds = Vec::new();
    for _ in 0..2 {
        let held = misbehave(&daemon.socket, pid, base);
        let during = Resources::of(pid);
        drop(held);
        let after = settle(pid, base);
        rounds.push((during, after));
        let st = c.ok("status", Value::Null);
        assert_eq!(st["state"], "running", "the motion ended during the faults: {st}");
    }
    // The program would go on; the test ends it along the path.
    c.ok("motion.stop", Value::Null);
    c.wait_state(&["idle"], TIMEOUT);
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    assert!(plant.running(), "{}", plant.stderr());
    drop(c);
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
    let check = assert_stream("client faults", &sps);
    assert_eq!(check.underruns, 0, "the motion was disturbed: underruns");
    eprintln!(
        "client faults: base {base:?}; per round (during, after): {rounds:?}; {} setpoints, 0 missing, 0 underruns, \
         limit ratios {:.4?}",
        check.count, check.ratios
    );
    for (during, after) in &rounds {
        assert!(during.threads > base.threads, "the faults held no threads: {during:?}");
        assert_eq!((after.threads, after.sockets), (base.threads, base.sockets), "threads and sockets not released");
    }
    let (first, second) = (rounds[0].1.rss_kib, rounds[1].1.rss_kib);
    assert!(
        second <= first + SECOND_ROUND_RSS_SLACK_KIB,
        "resident memory grew from {first} to {second} KiB over a second round of the same faults"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------------
// The plant and shared-memory subscribers killed; the planner stalled
// ---------------------------------------------------------------------------------------------

/// Subscribers killed and started again in turn: more than the services' subscriber slots
/// (`qos::MAX_SUBSCRIBERS` = 8), so a slot a killed process held must come back.
const SUBSCRIBER_RESTARTS: usize = 10;

/// `interpd record` on `prefix` as a shared-memory subscriber process of its own.
fn recorder(prefix: &str, out: &Path, log: &Path) -> std::process::Child {
    std::process::Command::new(interpd_e2e::binary("interpd"))
        .arg("record")
        .arg("--out")
        .arg(out)
        .args(["--service-prefix", prefix])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::from(std::fs::File::create(log).expect("log")))
        .spawn()
        .expect("start interpd record")
}

#[test]
fn the_plant_and_subscribers_killed_and_started_again_mid_motion() {
    let config = Config::default_machine();
    let dir = temp_dir("kill");
    let daemon = Daemon::start(&[]);
    let collector = Collector::start(&daemon.prefix);
    let feedback = FeedbackCollector::start(&daemon.prefix);
    let plant = Plant::start(&daemon.prefix, &[], &dir.join("plant1.log"));
    let mut c = daemon.client();
    c.ok("program.load", json!({ "text": zigzag(800, 6000), "name": "zigzag.ngc" }));
    c.ok("motion.start", Value::Null);
    c.wait_state(&["running"], TIMEOUT);
    std::thread::sleep(Duration::from_millis(1500));
    // The plant crashes (SIGKILL) and is started again.
    plant.kill();
    let killed_at = collector.snapshot().last().map_or(0, |s| s.cycle);
    std::thread::sleep(Duration::from_millis(500));
    let mut plant = Plant::start(&daemon.prefix, &[], &dir.join("plant2.log"));
    std::thread::sleep(Duration::from_millis(1500));
    // Shared-memory subscribers crash one after the other; each new one subscribes and records.
    for k in 0..SUBSCRIBER_RESTARTS {
        let mut r = recorder(&daemon.prefix, &dir.join(format!("sub{k}.mcap")), &dir.join(format!("sub{k}.log")));
        std::thread::sleep(Duration::from_millis(400));
        assert!(
            r.try_wait().expect("status").is_none(),
            "subscriber {k} ended: {:?}",
            std::fs::read_to_string(dir.join(format!("sub{k}.log")))
        );
        let _ = r.kill();
        let _ = r.wait();
    }
    let last = dir.join("last.mcap");
    let r = recorder(&daemon.prefix, &last, &dir.join("last.log"));
    std::thread::sleep(Duration::from_millis(1000));
    // SAFETY: kill(2) on our own child's pid; SIGTERM finishes the file.
    unsafe { libc::kill(r.id() as i32, libc::SIGTERM) };
    let out = r.wait_with_output().expect("wait");
    assert_eq!(out.status.code(), Some(0), "{:?}", std::fs::read_to_string(dir.join("last.log")));
    let st = c.ok("status", Value::Null);
    assert_eq!(st["state"], "running", "{st}");
    c.ok("motion.stop", Value::Null);
    c.wait_state(&["idle"], TIMEOUT);
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    let fb = feedback.finish();
    assert!(plant.running(), "{}", plant.stderr());
    drop(c);
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
    let check = assert_stream("plant and subscribers killed", &sps);
    assert_eq!(check.underruns, 0, "the motion was disturbed");
    // The second plant took over: feedback for cycles after the first one died.
    let after = fb.iter().filter(|f| f.cycle > killed_at + 250).count();
    assert!(after > 250, "{after} feedback samples from the restarted plant");
    let rec = check_recording(&last, AxisLimits::of(&config), config.cycle_s()).expect("last recording");
    assert!(rec.error.is_none() && rec.setpoints.missing == 0, "{:?} {:?}", rec.error, rec.setpoints.violations());
    assert!(rec.setpoints.count > 150, "{} setpoints recorded by the last subscriber", rec.setpoints.count);
    eprintln!(
        "killed: plant at cycle {killed_at}, {after} feedback samples from its successor; {SUBSCRIBER_RESTARTS} \
         subscribers killed, the next recorded {} setpoints; the daemon's stream: {} setpoints, 0 missing, 0 \
         underruns, limit ratios {:.4?}",
        rec.setpoints.count, check.count, check.ratios
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stalled_planner_brakes_along_the_path_and_the_program_goes_on() {
    let config = Config::default_machine();
    let dir = temp_dir("stall");
    let recording = dir.join("run.mcap");
    let daemon = Daemon::start(&["--debug-stall-planner", "1.0:0.6", "--record", recording.to_str().expect("UTF-8")]);
    let _plant = Plant::start(&daemon.prefix, &[], &dir.join("plant.log"));
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    let text = "G21 G90\nG1 X0 Y0 F6000\nG1 X150\nG1 Y60\nG1 X0\nM30\n";
    c.ok("program.load", json!({ "text": text, "name": "square.ngc" }));
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    c.wait_event("finished", TIMEOUT);
    let names: Vec<String> = c.events.iter().filter_map(|e| e["event"].as_str().map(String::from)).collect();
    let (under, cleared) = (
        names.iter().position(|n| *n == "underrun").expect("an underrun event"),
        names.iter().position(|n| *n == "underrun_cleared").expect("an underrun_cleared event"),
    );
    assert!(under < cleared, "{names:?}");
    // The status shows why: a look-ahead step longer than the queue that bridged it.
    let lookahead = c.ok("status", Value::Null)["lookahead"].clone();
    let step_ms = lookahead["step_max_ms"].as_f64().expect("lookahead.step_max_ms");
    let queue_min_s = lookahead["queue_min_s"].as_f64().expect("lookahead.queue_min_s");
    assert!(step_ms >= 600.0 && step_ms > queue_min_s * 1e3, "{lookahead}");
    std::thread::sleep(Duration::from_millis(100));
    let sps = collector.finish();
    drop(c);
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");
    let check = assert_stream("planner stalled", &sps);
    assert!(check.underruns >= 1, "no underrun in the stream");
    let rest =
        sps.iter().filter(|s| s.flags & interpd_protocol::shm::flags::UNDERRUN != 0).any(|s| s.v_mm_s.abs() < 1e-9);
    assert!(rest, "the underrun did not brake to rest");
    let last = sps.last().expect("setpoints");
    assert!(last.pos[0].abs() < 1e-9 && (last.pos[1] - 60.0).abs() < 1e-9, "ended at {:?}", &last.pos[..3]);
    let rec = check_recording(&recording, AxisLimits::of(&config), config.cycle_s()).expect("recording");
    assert!(
        rec.error.is_none() && rec.setpoints.violations().is_empty(),
        "{:?} {:?}",
        rec.error,
        rec.setpoints.violations()
    );
    assert_eq!(rec.setpoints.underruns, check.underruns, "the recording and the live stream differ");
    eprintln!(
        "planner stalled: events {names:?}; {} underrun cycles in {} setpoints, 0 missing, limit ratios {:.4?}; \
         recorded {} setpoints; lookahead {lookahead}",
        check.underrun_cycles, check.count, check.ratios, rec.setpoints.count
    );
    let _ = std::fs::remove_dir_all(&dir);
}
