//! End-to-end: the real `sim-plant` binary over real iceoryx2 services.
//!
//! Each test starts the process with its own `--service-prefix` (so tests run in parallel
//! without sharing services), publishes setpoints from the test, and reads the feedback. The
//! setpoints are sent in lock-step (the next one after the feedback for the previous one), so
//! nothing depends on scheduling: the plant runs on the setpoints' clock.

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use interpd_config::Config;
use interpd_protocol::shm::{self, Feedback, NodeOptions, Setpoints, feedback_flags, flags, open_service, qos};
use sim_plant::scenario::SCurve;
use sim_plant::{AxisTarget, Plant};
use std::io::{BufRead, BufReader, Read};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

const CYCLE_NS: u64 = 4_000_000;
/// Start of the setpoint clock in these tests (any monotonic time works).
const T0_NS: u64 = 1_000_000_000;
const TIMEOUT: Duration = Duration::from_secs(20);

fn unique_prefix(test: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!("interpd-test/{test}-{}-{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
}

/// The running plant process; killed if a test fails half-way.
struct PlantProcess {
    child: Child,
    stderr: Option<BufReader<ChildStderr>>,
}

impl PlantProcess {
    fn start(args: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_sim-plant"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start sim-plant");
        let mut stderr = BufReader::new(child.stderr.take().unwrap());
        // Wait for the ready line: both services exist and the subscriber is connected.
        let mut line = String::new();
        loop {
            line.clear();
            let n = stderr.read_line(&mut line).expect("read sim-plant stderr");
            assert!(n > 0, "sim-plant exited before it was ready");
            if line.contains("sim-plant: ready") {
                break;
            }
        }
        Self { child, stderr: Some(stderr) }
    }

    /// Sends `signal` and returns (exit code, the rest of stderr).
    fn stop(self, signal: i32) -> (Option<i32>, String) {
        // SAFETY: kill(2) on our own child's pid.
        assert_eq!(unsafe { libc::kill(self.child.id() as i32, signal) }, 0);
        self.finish()
    }

    /// Waits for the process to exit by itself.
    fn finish(mut self) -> (Option<i32>, String) {
        let mut rest = String::new();
        self.stderr.take().unwrap().read_to_string(&mut rest).unwrap();
        let status = self.child.wait().unwrap();
        (status.code(), rest)
    }
}

impl Drop for PlantProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The test's side of the two services.
struct Controller {
    node: Node<ipc::Service>,
    publisher: Publisher<ipc::Service, Setpoints, ()>,
    subscriber: Subscriber<ipc::Service, Feedback, ()>,
}

impl Controller {
    fn open(prefix: &str) -> Self {
        let node = NodeOptions::new().create().unwrap();
        let sp = open_service::<Setpoints>(&node, prefix).unwrap();
        let fb = open_service::<Feedback>(&node, prefix).unwrap();
        let publisher = sp.publisher_builder().create().unwrap();
        let subscriber = fb.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().unwrap();
        Self { node, publisher, subscriber }
    }

    fn publish(&self, sp: &Setpoints) {
        self.publisher.loan_uninit().unwrap().write_payload(*sp).send().unwrap();
    }

    /// The next feedback, or None after `timeout`.
    fn receive(&self, timeout: Duration) -> Option<Feedback> {
        let start = Instant::now();
        loop {
            if let Some(s) = self.subscriber.receive().unwrap() {
                return Some(*s);
            }
            if start.elapsed() > timeout {
                return None;
            }
            self.node.wait(Duration::from_micros(50)).unwrap();
        }
    }
}

/// Cycle `k` of a jerk-limited 0 → `dist` mm move of X (Y, Z at rest), `flags` set.
fn setpoint(k: u64, mv: &SCurve, n_axes: u32, flag_bits: u32) -> Setpoints {
    let (p, v, a) = mv.eval(k as f64 * CYCLE_NS as f64 * 1e-9);
    let mut sp = Setpoints {
        n_axes,
        cycle: k,
        time_ns: T0_NS + k * CYCLE_NS,
        publish_ns: k,
        flags: flags::RUNNING | flag_bits,
        ..Setpoints::default()
    };
    sp.pos[0] = p;
    sp.vel[0] = v;
    sp.acc[0] = a;
    sp
}

#[test]
fn plant_process_answers_every_setpoint_and_the_load_follows_the_ramp() {
    let prefix = unique_prefix("ramp");
    let plant = PlantProcess::start(&["--service-prefix", &prefix]);
    let ctl = Controller::open(&prefix);
    // The same plant in-process, fed the same setpoints: the process must agree bit for bit.
    let mut reference = Plant::from_config(&Config::default_machine()).unwrap();

    let mv = SCurve::new(0.0, 10.0, 100.0, 1000.0, 20_000.0);
    let n = ((mv.duration_s() + 0.3) / (CYCLE_NS as f64 * 1e-9)).ceil() as u64;
    let mut max_following_error = 0.0_f64;
    let mut last = Feedback::default();
    for k in 0..=n {
        let sp = setpoint(k, &mv, 3, 0);
        ctl.publish(&sp);
        let fb = ctl.receive(TIMEOUT).unwrap_or_else(|| panic!("no feedback for cycle {k}"));
        assert_eq!(fb.cycle, k, "feedback echoes the cycle number");
        assert_eq!(fb.setpoint_publish_ns, k, "feedback echoes publish_ns");
        assert_eq!((fb.version, fb.n_axes), (shm::PAYLOAD_VERSION, 3));
        assert_eq!(fb.time_ns, sp.time_ns, "state at the setpoint's time (4 ms = 40 servo periods)");
        assert_eq!(fb.flags & feedback_flags::RESYNC != 0, k == 0, "only the first setpoint places the plant");
        let targets: Vec<AxisTarget> =
            (0..3).map(|i| AxisTarget { pos: sp.pos[i], vel: sp.vel[i], acc: sp.acc[i] }).collect();
        let out = reference.advance_to(sp.time_ns, &targets).unwrap();
        for (i, o) in out.iter().enumerate() {
            assert_eq!(fb.motor_pos[i], o.motor_pos, "cycle {k} axis {i}");
            assert_eq!(fb.load_pos[i], o.load_pos, "cycle {k} axis {i}");
            assert_eq!(fb.following_error[i], o.following_error);
            assert_eq!(fb.load_error[i], o.load_error);
            assert_eq!(fb.motor_force[i], o.motor_force);
        }
        // The load follows the ramp: it lags by well under a tenth of a millimetre.
        assert!(fb.load_error[0].abs() < 0.1, "cycle {k}: load error {} mm", fb.load_error[0]);
        max_following_error = max_following_error.max(fb.following_error[0].abs());
        last = fb;
    }
    assert!(max_following_error > 1e-4, "the motion is seen by the drive: {max_following_error}");
    assert!((last.load_pos[0] - 10.0).abs() < 1e-3, "settled at 10 mm: {}", last.load_pos[0]);
    assert!(last.motor_force[0].abs() < 50.0, "holding force at standstill {}", last.motor_force[0]);

    // A setpoint for the wrong number of axes is rejected: no feedback for it. The next valid
    // one is answered (samples arrive in order, so the rejected one was seen before it).
    ctl.publish(&setpoint(n + 1, &mv, 2, 0));
    ctl.publish(&setpoint(n + 2, &mv, 3, 0));
    assert_eq!(ctl.receive(TIMEOUT).map(|f| f.cycle), Some(n + 2), "a rejected setpoint gets no feedback");

    let (code, stderr) = plant.stop(libc::SIGTERM);
    assert_eq!(code, Some(0), "clean exit on SIGTERM; stderr:\n{stderr}");
    let used = format!("{} setpoints received, {} used, 1 rejected", n + 3, n + 2);
    assert!(stderr.contains("stopped by signal") && stderr.contains(&used), "summary on stderr:\n{stderr}");
    assert!(stderr.contains("axis count 1") && stderr.contains("1 cycles missed"), "summary on stderr:\n{stderr}");
    assert!(stderr.contains("max|FE|") && stderr.contains("contour error"), "summary on stderr:\n{stderr}");
}

#[test]
fn plant_process_exits_on_finish_and_writes_the_plot() {
    let prefix = unique_prefix("finish");
    let dir = std::env::temp_dir().join(format!("sim-plant-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("finish.png");
    let _ = std::fs::remove_file(&png);
    let plant = PlantProcess::start(&[
        "--service-prefix",
        &prefix,
        "--exit-on-finish",
        "--settle-s",
        "0.5",
        "--plot",
        png.to_str().unwrap(),
    ]);
    let ctl = Controller::open(&prefix);
    let mv = SCurve::new(0.0, 20.0, 200.0, 2000.0, 40_000.0);
    let n = (mv.duration_s() / (CYCLE_NS as f64 * 1e-9)).ceil() as u64;
    for k in 0..=n {
        ctl.publish(&setpoint(k, &mv, 3, if k == n { flags::FINISHED } else { 0 }));
        assert_eq!(ctl.receive(TIMEOUT).map(|f| f.cycle), Some(k));
    }
    let (code, stderr) = plant.finish();
    assert_eq!(code, Some(0), "stderr:\n{stderr}");
    assert!(stderr.contains("program finished") && stderr.contains("motion end at"), "stderr:\n{stderr}");
    let bytes = std::fs::read(&png).expect("plot written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 20_000, "{} bytes", bytes.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plant_process_rejects_bad_start_up_input_with_exit_2() {
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_sim-plant")).args(args).output().unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = run(&["--source", "can:nosuchcan7"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("no network interface nosuchcan7") && !err.contains("ready"), "{err}");
    let (code, err) = run(&["--source", "can:"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("interface name"), "{err}");
    let (code, err) = run(&["--config", "/nonexistent/machine.toml"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("/nonexistent/machine.toml"), "{err}");
    let (code, err) = run(&["--service-prefix", "/bad"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--service-prefix"), "{err}");
    let (code, err) = run(&["--plot", "out.svg"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("PNG"), "{err}");
}
