//! A real `interpd run` process for a test: its own control socket and iceoryx2 service
//! prefix (so tests run side by side), a JSON-RPC client, and a collector of the setpoint
//! stream over iceoryx2.

use iceoryx2::prelude::*;
use interpd_protocol::shm::{NodeOptions, ServicePorts, Setpoints, open_service, qos};
use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A running `interpd run`; SIGTERM and wait on drop.
pub struct Daemon {
    child: Option<Child>,
    pub socket: PathBuf,
    pub prefix: String,
    dir: PathBuf,
}

fn unique(tag: &str) -> String {
    use std::sync::atomic::AtomicU64;
    static N: AtomicU64 = AtomicU64::new(0);
    format!("{tag}{}x{}", std::process::id(), N.fetch_add(1, Ordering::SeqCst))
}

impl Daemon {
    /// Starts `interpd run` with `extra` arguments and waits for its socket.
    pub fn start(extra: &[&str]) -> Daemon {
        Daemon::start_with(extra, |_| {})
    }

    /// [`Daemon::start`], with `configure` applied to the command before it is spawned (an
    /// environment variable, a resource limit set in `pre_exec`).
    pub fn start_with(extra: &[&str], configure: impl FnOnce(&mut Command)) -> Daemon {
        let name = unique("t");
        let dir = std::env::temp_dir().join(format!("interpd-e2e-{name}"));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let socket = dir.join("control.sock");
        let prefix = format!("interpd-test/{name}");
        let mut cmd = Command::new(crate::binary("interpd"));
        // The programs directory is the working directory by default: the repository, so
        // that examples/ can be loaded by path (not there in the CAN tests' VM, which loads
        // programs as text).
        let root = crate::repo_root();
        if root.is_dir() {
            cmd.current_dir(root);
        }
        cmd.arg("run").arg("--socket").arg(&socket).arg("--service-prefix").arg(&prefix).args(extra);
        cmd.stdout(Stdio::null()).stderr(Stdio::from(std::fs::File::create(dir.join("stderr.log")).expect("log file")));
        configure(&mut cmd);
        let child = cmd.spawn().expect("start interpd run");
        let d = Daemon { child: Some(child), socket, prefix, dir };
        let until = Instant::now() + Duration::from_secs(20);
        while !d.socket.exists() {
            assert!(Instant::now() < until, "interpd run did not create its socket; stderr: {}", d.stderr());
            std::thread::sleep(Duration::from_millis(20));
        }
        d
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(self.dir.join("stderr.log")).unwrap_or_default()
    }

    /// Sends SIGTERM and waits for the exit status; returns (status code, stderr).
    pub fn terminate(mut self) -> (Option<i32>, String) {
        let child = self.child.take().expect("running");
        // SAFETY: plain kill(2) on our child's pid.
        unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        let out = child.wait_with_output().expect("wait");
        (out.status.code(), self.stderr())
    }

    /// The process id (for signals).
    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    /// SIGKILL, as a crash would end it: no orderly shutdown. Returns the stderr so far.
    pub fn kill(mut self) -> String {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
        self.stderr()
    }

    pub fn client(&self) -> Client {
        Client::connect(&self.socket)
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            // SAFETY: as above.
            unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
            let _ = c.wait();
        }
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A JSON-RPC client on the control socket (notifications are kept apart).
pub struct Client {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
    next_id: u64,
    pub events: Vec<Value>,
}

impl Client {
    pub fn connect(socket: &Path) -> Client {
        let s = UnixStream::connect(socket).expect("connect to the control socket");
        s.set_read_timeout(Some(Duration::from_secs(30))).expect("timeout");
        Client { reader: BufReader::new(s.try_clone().expect("clone")), writer: s, next_id: 1, events: Vec::new() }
    }

    /// Calls `method`; returns the whole response object.
    pub fn call(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        let mut msg = json!({"jsonrpc": "2.0", "id": id, "method": method});
        if !params.is_null() {
            msg["params"] = params;
        }
        writeln!(self.writer, "{msg}").expect("send");
        loop {
            let v = self.read_message().expect("a response");
            if v.get("id") == Some(&json!(id)) {
                return v;
            }
        }
    }

    /// Calls `method` and returns its `result`, panicking on an error response.
    pub fn ok(&mut self, method: &str, params: Value) -> Value {
        let r = self.call(method, params);
        assert!(r.get("error").is_none(), "{method} failed: {r}");
        r["result"].clone()
    }

    fn read_message(&mut self) -> Option<Value> {
        let mut line = String::new();
        if self.reader.read_line(&mut line).ok()? == 0 {
            return None;
        }
        let v: Value = serde_json::from_str(&line).expect("JSON from the daemon");
        if v.get("method").and_then(Value::as_str) == Some("event") {
            self.events.push(v["params"].clone());
            return self.read_message();
        }
        Some(v)
    }

    /// Waits until the event `name` has arrived (events are written apart from responses,
    /// so one may follow the status that already shows its effect).
    pub fn wait_event(&mut self, name: &str, timeout: Duration) {
        let until = Instant::now() + timeout;
        while !self.events.iter().any(|e| e["event"] == name) {
            assert!(Instant::now() < until, "event {name} not received after {timeout:?}: {:?}", self.events);
            self.ok("status", Value::Null);
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Polls `status` until its state is one of `states`; returns the status.
    pub fn wait_state(&mut self, states: &[&str], timeout: Duration) -> Value {
        let until = Instant::now() + timeout;
        loop {
            let st = self.ok("status", Value::Null);
            if states.contains(&st["state"].as_str().unwrap_or("")) {
                return st;
            }
            assert!(Instant::now() < until, "state {} not in {states:?} after {timeout:?}: {st}", st["state"]);
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

/// A subscriber to the setpoint service `<prefix>/setpoints`, opened as every participant
/// opens it (`interpd_protocol::shm::open_service`, the shared QoS); the node and service live
/// as long as it.
pub struct SetpointSubscriber {
    pub port: iceoryx2::port::subscriber::Subscriber<ipc::Service, Setpoints, ()>,
    _service: ServicePorts<Setpoints>,
    _node: Node<ipc::Service>,
}

impl SetpointSubscriber {
    pub fn open(prefix: &str) -> SetpointSubscriber {
        let node = NodeOptions::new().name("interpd-e2e-subscriber").create().expect("iceoryx2 node");
        let service = open_service::<Setpoints>(&node, prefix).expect("setpoint service");
        let port = service.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().expect("subscriber");
        SetpointSubscriber { port, _service: service, _node: node }
    }
}

/// Collects every setpoint published on `<prefix>/setpoints` in a thread of its own.
pub struct Collector {
    stop: Arc<AtomicBool>,
    samples: Arc<Mutex<Vec<Setpoints>>>,
    thread: Option<JoinHandle<()>>,
}

impl Collector {
    pub fn start(prefix: &str) -> Collector {
        let stop = Arc::new(AtomicBool::new(false));
        let samples = Arc::new(Mutex::new(Vec::new()));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let (s2, st2, p2) = (samples.clone(), stop.clone(), prefix.to_string());
        let thread = std::thread::spawn(move || {
            let sub = SetpointSubscriber::open(&p2);
            ready_tx.send(()).expect("ready");
            while !st2.load(Ordering::SeqCst) {
                let mut got = Vec::new();
                while let Ok(Some(sample)) = sub.port.receive() {
                    got.push(*sample);
                }
                s2.lock().expect("samples").extend(got);
                std::thread::sleep(Duration::from_millis(10));
            }
        });
        ready_rx.recv_timeout(Duration::from_secs(10)).expect("collector ready");
        Collector { stop, samples, thread: Some(thread) }
    }

    /// The setpoints received so far.
    pub fn snapshot(&self) -> Vec<Setpoints> {
        self.samples.lock().expect("samples").clone()
    }

    pub fn finish(mut self) -> Vec<Setpoints> {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.snapshot()
    }
}

/// An axis's limits for [`limit_ratios`] (axis units per s, s², s³).
#[derive(Debug, Clone, Copy)]
pub struct AxisLimits {
    pub vel: f64,
    pub acc: f64,
    pub jerk: f64,
}

impl AxisLimits {
    /// The limits of every axis of a machine configuration, in its order.
    pub fn of(config: &interpd::config::Config) -> Vec<AxisLimits> {
        config
            .axes
            .iter()
            .map(|a| AxisLimits { vel: a.max_vel_per_s, acc: a.max_acc_per_s2, jerk: a.max_jerk_per_s3 })
            .collect()
    }
}

/// Largest |value|/limit over all axes of a stream at `cycle_s`: velocity, acceleration and
/// jerk from finite differences of the positions, and the reported acceleration.
pub fn limit_ratios(cycle_s: f64, limits: &[AxisLimits], sps: &[Setpoints]) -> [f64; 4] {
    let dt = cycle_s;
    let mut worst = [0.0f64; 4];
    for (k, lim) in limits.iter().enumerate() {
        for w in sps.windows(4) {
            let p = [w[0].pos[k], w[1].pos[k], w[2].pos[k], w[3].pos[k]];
            let v = (p[1] - p[0]) / dt;
            let a = (p[2] - 2.0 * p[1] + p[0]) / (dt * dt);
            let j = (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]) / (dt * dt * dt);
            worst[0] = worst[0].max(v.abs() / lim.vel);
            worst[1] = worst[1].max(a.abs() / lim.acc);
            worst[2] = worst[2].max(j.abs() / lim.jerk);
            worst[3] = worst[3].max(w[0].acc[k].abs() / lim.acc);
        }
    }
    worst
}

/// Collects every plant feedback published on `<prefix>/feedback` in a thread of its own.
pub struct FeedbackCollector {
    stop: Arc<AtomicBool>,
    samples: Arc<Mutex<Vec<interpd_protocol::shm::Feedback>>>,
    thread: Option<JoinHandle<()>>,
}

impl FeedbackCollector {
    pub fn start(prefix: &str) -> FeedbackCollector {
        let stop = Arc::new(AtomicBool::new(false));
        let samples = Arc::new(Mutex::new(Vec::new()));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let (s2, st2, p2) = (samples.clone(), stop.clone(), prefix.to_string());
        let thread = std::thread::spawn(move || {
            let node = NodeOptions::new().name("interpd-e2e-feedback").create().expect("iceoryx2 node");
            let service = open_service::<interpd_protocol::shm::Feedback>(&node, &p2).expect("feedback service");
            let port =
                service.subscriber_builder().buffer_size(qos::SUBSCRIBER_BUFFER_SIZE).create().expect("subscriber");
            ready_tx.send(()).expect("ready");
            while !st2.load(Ordering::SeqCst) {
                let mut got = Vec::new();
                while let Ok(Some(sample)) = port.receive() {
                    got.push(*sample);
                }
                s2.lock().expect("samples").extend(got);
                std::thread::sleep(Duration::from_millis(10));
            }
        });
        ready_rx.recv_timeout(Duration::from_secs(10)).expect("feedback collector ready");
        FeedbackCollector { stop, samples, thread: Some(thread) }
    }

    pub fn finish(mut self) -> Vec<interpd_protocol::shm::Feedback> {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.samples.lock().expect("samples").clone()
    }
}
