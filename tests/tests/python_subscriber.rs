//! The Python example `examples/python/subscribe_setpoints.py` (iceoryx2 from PyPI, the payload
//! declared with ctypes) reads the same setpoint stream as a Rust subscriber: a daemon with a
//! service prefix of its own runs an example program; every line the script prints equals the
//! setpoint the Rust subscriber received for that cycle (cycle, time, flags, s, v and every
//! axis position, exactly), the script's cycles have no gaps, and with `--until-finished` alone
//! it follows the motion to the program's end, however many setpoints that takes. Without
//! `--until-finished` it stops after 100 setpoints, and a `--samples` count given with it still
//! applies.
//!
//! Skipped, with a message on stderr, only when `python3` or its `iceoryx2` module is missing
//! (`python3 -m pip install -r .ci/python-requirements.txt`).

use interpd_e2e::daemon::{Collector, Daemon};
use interpd_e2e::{example, repo_root};
use interpd_protocol::shm::{Setpoints, flags};
use serde_json::{Value, json};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::thread::JoinHandle;
use std::time::Duration;

const RUN_TIMEOUT: Duration = Duration::from_secs(60);
/// The script's own time limit, s (it exits earlier at the FINISHED setpoint).
const SCRIPT_TIMEOUT_S: &str = "60";
/// Longest wait for the script to import iceoryx2 and subscribe.
const SUBSCRIBE_TIMEOUT: Duration = Duration::from_secs(30);
const MACHINE: &str = "config/machines/xyzab.toml";
const PROGRAM: &str = "five_axis_table.csv";
const AXES: usize = 5;
/// The script's count without `--samples` and `--until-finished`.
const DEFAULT_SAMPLES: usize = 100;

/// `python3` if it can import iceoryx2; otherwise says why the test is skipped.
fn python_with_iceoryx2() -> Option<&'static str> {
    match Command::new("python3").args(["-c", "import iceoryx2"]).output() {
        Ok(out) if out.status.success() => Some("python3"),
        Ok(out) => {
            eprintln!(
                "SKIPPED python_subscriber: python3 cannot import iceoryx2 (install it with \
                 `python3 -m pip install -r .ci/python-requirements.txt`): {}",
                String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("").trim()
            );
            None
        }
        Err(e) => {
            eprintln!("SKIPPED python_subscriber: no python3 ({e})");
            None
        }
    }
}

/// The script as a child process, killed if the test fails before it exits. Its stdout is read
/// continuously by a thread of its own: a full pipe would block the script, and iceoryx2 would
/// then drop the setpoints it cannot queue.
struct Script {
    child: Child,
    lines: Receiver<String>,
    reader: Option<JoinHandle<()>>,
}

impl Script {
    /// The script on `prefix` with `args` and the test's time limit.
    fn start(python: &str, prefix: &str, args: &[&str]) -> Script {
        let script = repo_root().join("examples/python/subscribe_setpoints.py");
        let mut child = Command::new(python)
            .arg(&script)
            .args(["--prefix", prefix, "--timeout", SCRIPT_TIMEOUT_S])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start subscribe_setpoints.py");
        let stdout = BufReader::new(child.stdout.take().expect("stdout"));
        let (tx, lines) = mpsc::channel();
        let reader = std::thread::spawn(move || {
            for line in stdout.lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Script { child, lines, reader: Some(reader) }
    }

    /// Waits for the `# subscribed` line (the subscriber exists from then on).
    fn wait_subscribed(&mut self) {
        match self.lines.recv_timeout(SUBSCRIBE_TIMEOUT) {
            Ok(first) if first.starts_with("# subscribed to ") => {}
            other => panic!("subscribe_setpoints.py did not subscribe: {other:?}; stderr: {}", self.stderr()),
        }
    }

    fn stderr(&mut self) -> String {
        let _ = self.child.kill();
        let mut text = String::new();
        if let Some(mut e) = self.child.stderr.take() {
            let _ = e.read_to_string(&mut text);
        }
        text
    }

    /// The remaining output lines, after the script has exited 0.
    fn finish(mut self) -> Vec<String> {
        let status = self.child.wait().expect("wait for the script");
        if !status.success() {
            panic!("subscribe_setpoints.py: {status}; stderr: {}", self.stderr());
        }
        if let Some(r) = self.reader.take() {
            r.join().expect("output reader");
        }
        self.lines.try_iter().collect()
    }
}

impl Drop for Script {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One printed line: cycle time_ns flags s_mm v_mm_s pos...
#[derive(Debug, PartialEq)]
struct Line {
    cycle: u64,
    time_ns: u64,
    flags: u32,
    s_mm: f64,
    v_mm_s: f64,
    pos: Vec<f64>,
}

fn parse_line(text: &str) -> Line {
    let f: Vec<&str> = text.split_whitespace().collect();
    assert!(f.len() >= 5, "short line from the script: {text:?}");
    let num = |i: usize| f[i].parse::<f64>().unwrap_or_else(|e| panic!("{text:?}: field {i}: {e}"));
    let int = |i: usize| f[i].parse::<u64>().unwrap_or_else(|e| panic!("{text:?}: field {i}: {e}"));
    Line {
        cycle: int(0),
        time_ns: int(1),
        flags: u32::try_from(int(2)).expect("flags fit u32"),
        s_mm: num(3),
        v_mm_s: num(4),
        pos: (5..f.len()).map(num).collect(),
    }
}

fn as_line(sp: &Setpoints) -> Line {
    Line {
        cycle: sp.cycle,
        time_ns: sp.time_ns,
        flags: sp.flags,
        s_mm: sp.s_mm,
        v_mm_s: sp.v_mm_s,
        pos: sp.pos[..sp.n_axes as usize].to_vec(),
    }
}

#[test]
fn the_python_example_prints_what_the_rust_subscriber_receives() {
    let Some(python) = python_with_iceoryx2() else { return };
    let machine = repo_root().join(MACHINE).display().to_string();
    let daemon = Daemon::start(&["--config", &machine]);
    let collector = Collector::start(&daemon.prefix);
    // No --samples: the documented way to follow a program to its end.
    let mut script = Script::start(python, &daemon.prefix, &["--until-finished"]);
    script.wait_subscribed();
    let mut c = daemon.client();
    c.ok("program.load", json!({ "path": example(PROGRAM).display().to_string() }));
    c.ok("motion.start", Value::Null);
    let st = c.wait_state(&["finished", "error"], RUN_TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    let printed: Vec<Line> = script.finish().iter().map(|l| parse_line(l)).collect();
    let received = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "interpd run exit status; stderr:\n{stderr}");

    let by_cycle: HashMap<u64, &Setpoints> = received.iter().map(|s| (s.cycle, s)).collect();
    assert!(
        printed.len() > DEFAULT_SAMPLES,
        "--until-finished without --samples stopped after {} setpoints, not at FINISHED",
        printed.len()
    );
    for w in printed.windows(2) {
        assert_eq!(w[1].cycle, w[0].cycle + 1, "gap in the script's cycle numbers");
    }
    for line in &printed {
        let sp = by_cycle.get(&line.cycle).unwrap_or_else(|| panic!("cycle {} never reached Rust", line.cycle));
        assert_eq!(line.pos.len(), AXES, "cycle {}", line.cycle);
        assert_eq!(*line, as_line(sp), "cycle {}: Python and Rust disagree", line.cycle);
    }
    let moving = printed.iter().filter(|l| l.flags & flags::RUNNING != 0).count();
    let last = printed.last().expect("lines");
    assert!(moving > 100, "the script saw only {moving} setpoints of motion");
    assert!(last.flags & flags::FINISHED != 0, "the script stopped before the program finished: {last:?}");
    let end = &received.last().expect("Rust setpoints").pos[..AXES];
    assert_eq!(last.pos, end, "the script's last position is not the program's end point");
    eprintln!(
        "python subscriber: {} setpoints (cycles {}..={}, {moving} in motion) equal to the Rust subscriber's; \
         end point {:?}",
        printed.len(),
        printed[0].cycle,
        last.cycle,
        last.pos
    );
}

#[test]
fn the_python_example_counts_samples_only_where_asked_to() {
    let Some(python) = python_with_iceoryx2() else { return };
    // A daemon standing idle publishes a setpoint every cycle and none is flagged FINISHED, so
    // only a count ends the reading early.
    let daemon = Daemon::start(&[]);
    for (args, want) in [(&[][..], DEFAULT_SAMPLES), (&["--until-finished", "--samples", "7"][..], 7)] {
        let mut script = Script::start(python, &daemon.prefix, args);
        script.wait_subscribed();
        let printed = script.finish();
        assert_eq!(printed.len(), want, "subscribe_setpoints.py {args:?} printed {} setpoints", printed.len());
    }
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "interpd run exit status; stderr:\n{stderr}");
}
