//! The daemon and the simulated plant as two processes on one program: `interpd run` and
//! `sim-plant` over iceoryx2 under a service prefix of their own, the program run through the
//! control socket to its end. `interpd demo` runs one such pair; `interpd-sim` runs one per
//! compensation strategy for the milling scenario.

use crate::cmdline::{CliError, SiblingError, sibling_binary};
use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long a phase may take before the demo gives up.
const START_TIMEOUT: Duration = Duration::from_secs(20);
const RUN_TIMEOUT: Duration = Duration::from_secs(120);

/// Why a run of the pair failed.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// `interpd` or `sim-plant` is not beside the running binary.
    #[error(transparent)]
    Binary(#[from] SiblingError),
    /// A file or socket of the run cannot be created or opened.
    #[error("{}: {source}", path.display())]
    File { path: PathBuf, source: std::io::Error },
    #[error("cannot start {}: {source}", exe.display())]
    Start { exe: PathBuf, source: std::io::Error },
    /// Waiting for a process or setting up the control connection failed.
    #[error("{0}")]
    Os(std::io::Error),
    #[error("{name} did not exit; its log:\n{log}")]
    NoExit { name: &'static str, log: String },
    #[error("timed out waiting for {0}")]
    Timeout(&'static str),
    #[error("control socket: {0}")]
    Socket(std::io::Error),
    #[error("the daemon closed the control connection")]
    Closed,
    #[error("bad reply: {0}")]
    BadReply(serde_json::Error),
    /// The daemon refused a call: the method and the error's message.
    #[error("{method}: {message}")]
    Refused { method: String, message: Value },
    #[error("the program did not finish within {} s", .0.as_secs())]
    NotFinished(Duration),
    /// The motion ended in the `error` state: the daemon's last error.
    #[error("motion ended in error: {0}")]
    Motion(Value),
    #[error("{name} exited with {code}; its log:\n{log}")]
    Exit { name: &'static str, code: i32, log: String },
    #[error("sim-plant wrote no summary; its log:\n{0}")]
    NoSummary(String),
}

impl From<DemoError> for CliError {
    fn from(e: DemoError) -> Self {
        CliError::Failure(e.to_string())
    }
}

/// Options of `demo` (the same in `interpd` and `interpd-sim`, which `interpd` hands
/// `--scenario` to with its arguments as they are).
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Where the plant writes its plot.
    #[arg(long, default_value = "interpd-demo.png")]
    pub plot: PathBuf,
    /// Run this program instead of the embedded one (G-code or path table).
    #[arg(long)]
    pub program: Option<PathBuf>,
    /// Run a scenario instead: `milling-circle` (the Ø 70 mm circle of Schneider 2016, Tab. 5.1,
    /// milled by the soft robot under the process force, once per compensation strategy).
    #[arg(long, value_name = "NAME")]
    pub scenario: Option<String>,
    /// With --scenario: print the figures as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// A child process that is terminated when dropped.
struct Proc {
    name: &'static str,
    child: Child,
    log: PathBuf,
}

impl Proc {
    fn spawn(name: &'static str, exe: &Path, args: &[&str], dir: &Path) -> Result<Proc, DemoError> {
        let log = dir.join(format!("{name}.log"));
        let file = std::fs::File::create(&log).map_err(|source| DemoError::File { path: log.clone(), source })?;
        let child = Command::new(exe)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::from(file))
            .spawn()
            .map_err(|source| DemoError::Start { exe: exe.to_path_buf(), source })?;
        Ok(Proc { name, child, log })
    }

    fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    fn terminate(&mut self) {
        // SAFETY: kill(2) on our own child.
        unsafe { libc::kill(self.child.id() as i32, libc::SIGTERM) };
    }

    /// Waits up to `timeout` for the exit; the exit code, or an error naming the process.
    fn wait(&mut self, timeout: Duration) -> Result<i32, DemoError> {
        let until = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait().map_err(DemoError::Os)? {
                return Ok(status.code().unwrap_or(-1));
            }
            if Instant::now() > until {
                let _ = self.child.kill();
                return Err(DemoError::NoExit { name: self.name, log: self.log_text() });
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            self.terminate();
            let _ = self.wait(Duration::from_secs(5));
        }
    }
}

/// A minimal JSON-RPC client (events are counted, not kept).
struct Rpc {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
    id: u64,
}

impl Rpc {
    fn connect(socket: &Path) -> Result<Rpc, DemoError> {
        let s = UnixStream::connect(socket).map_err(|source| DemoError::File { path: socket.to_path_buf(), source })?;
        s.set_read_timeout(Some(Duration::from_secs(10))).map_err(DemoError::Os)?;
        let reader = BufReader::new(s.try_clone().map_err(DemoError::Os)?);
        Ok(Rpc { reader, writer: s, id: 0 })
    }

    fn call(&mut self, method: &str, params: Value) -> Result<Value, DemoError> {
        self.id += 1;
        let mut msg = json!({"jsonrpc": "2.0", "id": self.id, "method": method});
        if !params.is_null() {
            msg["params"] = params;
        }
        writeln!(self.writer, "{msg}").map_err(DemoError::Socket)?;
        loop {
            let mut line = String::new();
            if self.reader.read_line(&mut line).map_err(DemoError::Socket)? == 0 {
                return Err(DemoError::Closed);
            }
            let v: Value = serde_json::from_str(&line).map_err(DemoError::BadReply)?;
            if v["id"] == json!(self.id) {
                if let Some(e) = v.get("error") {
                    return Err(DemoError::Refused { method: method.to_string(), message: e["message"].clone() });
                }
                return Ok(v["result"].clone());
            }
        }
    }
}

fn wait_until(what: &'static str, timeout: Duration, mut ready: impl FnMut() -> bool) -> Result<(), DemoError> {
    let until = Instant::now() + timeout;
    while !ready() {
        if Instant::now() > until {
            return Err(DemoError::Timeout(what));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(())
}

/// One run of `interpd run` and `sim-plant` together over iceoryx2 on a program.
pub struct Pair {
    /// Working directory: logs, socket, summary.
    pub dir: PathBuf,
    /// Machine file for both (default: the embedded machine).
    pub machine: Option<PathBuf>,
    pub plot: Option<PathBuf>,
    /// Where the plant writes its recorded run (CSV, `sim-plant --trace`).
    pub trace: Option<PathBuf>,
}

impl Pair {
    /// Runs `program_text` to its end; the daemon's final status, the plant's summary JSON and
    /// the motion time. `tag` names the service prefix; `verbose` prints progress on stderr.
    pub fn run(
        &self,
        tag: &str,
        program_text: &str,
        program_name: &str,
        verbose: bool,
    ) -> Result<(Value, Value, f64), DemoError> {
        let interpd = sibling_binary("interpd")?;
        let sim_plant = sibling_binary("sim-plant")?;
        let dir = &self.dir;
        let prefix = format!("{tag}/{}", std::process::id());
        let socket = dir.join("control.sock");
        let _ = std::fs::remove_file(&socket);
        let summary_path = dir.join("plant.json");
        let _ = std::fs::remove_file(&summary_path);
        if verbose {
            eprintln!("demo: starting sim-plant and interpd run (service prefix {prefix})");
        }
        let summary_s = summary_path.display().to_string();
        let mut plant_args: Vec<String> =
            ["--service-prefix", &prefix, "--exit-on-finish", "--summary-json", &summary_s].map(String::from).to_vec();
        let mut daemon_args: Vec<String> = vec!["run".into(), "--socket".into(), socket.display().to_string()];
        daemon_args.extend(["--service-prefix".to_string(), prefix.clone()]);
        if let Some(m) = &self.machine {
            plant_args.extend(["--config".to_string(), m.display().to_string()]);
            daemon_args.extend(["--config".to_string(), m.display().to_string()]);
        }
        if let Some(p) = &self.plot {
            plant_args.extend(["--plot".to_string(), p.display().to_string()]);
        }
        if let Some(t) = &self.trace {
            plant_args.extend(["--trace".to_string(), t.display().to_string()]);
        }
        let pa: Vec<&str> = plant_args.iter().map(String::as_str).collect();
        let da: Vec<&str> = daemon_args.iter().map(String::as_str).collect();
        let mut plant = Proc::spawn("sim-plant", &sim_plant, &pa, dir)?;
        wait_until("sim-plant to subscribe", START_TIMEOUT, || plant.log_text().contains("ready"))?;
        let mut daemon = Proc::spawn("interpd", &interpd, &da, dir)?;
        wait_until("the control socket", START_TIMEOUT, || socket.exists())?;

        let mut rpc = Rpc::connect(&socket)?;
        let info = rpc.call("program.load", json!({ "text": program_text, "name": program_name }))?;
        if verbose {
            eprintln!(
                "demo: loaded {program_name}: {} elements, {:.1} mm",
                info["elements"],
                info["length_mm"].as_f64().unwrap_or(0.0)
            );
        }
        rpc.call("motion.start", Value::Null)?;
        let t0 = Instant::now();
        let mut last_print = Instant::now();
        let status = loop {
            let st = rpc.call("status", Value::Null)?;
            let state = st["state"].as_str().unwrap_or("?").to_string();
            if verbose && last_print.elapsed() > Duration::from_millis(500) {
                eprintln!(
                    "demo: {state} line {} s = {:.1} mm, {:.1} mm/s",
                    st["line"],
                    st["s_mm"].as_f64().unwrap_or(0.0),
                    st["feed_mm_s"].as_f64().unwrap_or(0.0)
                );
                last_print = Instant::now();
            }
            if state == "finished" || state == "error" {
                break st;
            }
            if t0.elapsed() > RUN_TIMEOUT {
                return Err(DemoError::NotFinished(RUN_TIMEOUT));
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        if status["state"] != "finished" {
            return Err(DemoError::Motion(status["last_error"].clone()));
        }
        let motion_s = t0.elapsed().as_secs_f64();
        drop(rpc);
        daemon.terminate();
        let code = daemon.wait(Duration::from_secs(15))?;
        if code != 0 {
            return Err(DemoError::Exit { name: "interpd run", code, log: daemon.log_text() });
        }
        let code = plant.wait(Duration::from_secs(60))?;
        if code != 0 {
            return Err(DemoError::Exit { name: "sim-plant", code, log: plant.log_text() });
        }
        let summary: Value = std::fs::read_to_string(&summary_path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .ok_or_else(|| DemoError::NoSummary(plant.log_text()))?;
        Ok((status, summary, motion_s))
    }
}
