//! `interpd demo`: the main job on the embedded defaults. Starts `interpd run` and `sim-plant`
//! as two processes talking over iceoryx2 (a service prefix of their own), runs the embedded
//! example program through the control socket, and prints a summary: motion time, following
//! and contour error of the simulated plant, residual vibration, the real-time loop's wake-up
//! latency; the plant writes a PNG plot.

use super::CliError;
use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The embedded program.
const DEMO_PROGRAM: &str = include_str!("../../../examples/demo.ngc");
/// How long a phase may take before the demo gives up.
const START_TIMEOUT: Duration = Duration::from_secs(20);
const RUN_TIMEOUT: Duration = Duration::from_secs(120);

/// Options of `interpd demo`.
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
    fn spawn(name: &'static str, exe: &Path, args: &[&str], dir: &Path) -> Result<Proc, CliError> {
        let log = dir.join(format!("{name}.log"));
        let file = std::fs::File::create(&log).map_err(|e| CliError::Failure(format!("{}: {e}", log.display())))?;
        let child = Command::new(exe)
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::from(file))
            .spawn()
            .map_err(|e| CliError::Failure(format!("cannot start {}: {e}", exe.display())))?;
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
    fn wait(&mut self, timeout: Duration) -> Result<i32, CliError> {
        let until = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait().map_err(|e| CliError::Failure(e.to_string()))? {
                return Ok(status.code().unwrap_or(-1));
            }
            if Instant::now() > until {
                let _ = self.child.kill();
                return Err(CliError::Failure(format!("{} did not exit; its log:\n{}", self.name, self.log_text())));
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
    fn connect(socket: &Path) -> Result<Rpc, CliError> {
        let s = UnixStream::connect(socket).map_err(|e| CliError::Failure(format!("{}: {e}", socket.display())))?;
        s.set_read_timeout(Some(Duration::from_secs(10))).map_err(|e| CliError::Failure(e.to_string()))?;
        let reader = BufReader::new(s.try_clone().map_err(|e| CliError::Failure(e.to_string()))?);
        Ok(Rpc { reader, writer: s, id: 0 })
    }

    fn call(&mut self, method: &str, params: Value) -> Result<Value, CliError> {
        self.id += 1;
        let mut msg = json!({"jsonrpc": "2.0", "id": self.id, "method": method});
        if !params.is_null() {
            msg["params"] = params;
        }
        let fail = |e: std::io::Error| CliError::Failure(format!("control socket: {e}"));
        writeln!(self.writer, "{msg}").map_err(fail)?;
        loop {
            let mut line = String::new();
            if self.reader.read_line(&mut line).map_err(fail)? == 0 {
                return Err(CliError::Failure("the daemon closed the control connection".into()));
            }
            let v: Value = serde_json::from_str(&line).map_err(|e| CliError::Failure(format!("bad reply: {e}")))?;
            if v["id"] == json!(self.id) {
                if let Some(e) = v.get("error") {
                    return Err(CliError::Failure(format!("{method}: {}", e["message"])));
                }
                return Ok(v["result"].clone());
            }
        }
    }
}

fn sibling_binary(name: &str) -> Result<PathBuf, CliError> {
    let exe = std::env::current_exe().map_err(|e| CliError::Failure(e.to_string()))?;
    let path = exe.with_file_name(name);
    if path.exists() {
        Ok(path)
    } else {
        Err(CliError::Failure(format!(
            "{} not found next to {}: build the whole workspace (`cargo build --release`)",
            name,
            exe.display()
        )))
    }
}

fn wait_until(what: &str, timeout: Duration, mut ready: impl FnMut() -> bool) -> Result<(), CliError> {
    let until = Instant::now() + timeout;
    while !ready() {
        if Instant::now() > until {
            return Err(CliError::Failure(format!("timed out waiting for {what}")));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(())
}

pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    if let Some(name) = &args.scenario {
        return match name.as_str() {
            "milling-circle" => super::milling::run(args),
            other => Err(CliError::BadInput(format!("--scenario {other}: unknown; known: milling-circle"))),
        };
    }
    if args.json {
        return Err(CliError::BadInput("--json goes with --scenario".into()));
    }
    let (program_text, program_name) = match &args.program {
        Some(p) => (
            std::fs::read_to_string(p).map_err(|e| CliError::BadInput(format!("--program {}: {e}", p.display())))?,
            p.display().to_string(),
        ),
        None => (DEMO_PROGRAM.to_string(), "demo.ngc".to_string()),
    };
    let plot = std::path::absolute(&args.plot).map_err(|e| CliError::BadInput(format!("--plot: {e}")))?;
    let dir = std::env::temp_dir().join(format!("interpd-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::Failure(format!("{}: {e}", dir.display())))?;
    let started = Instant::now();
    let pair = Pair { dir: dir.clone(), machine: None, plot: Some(plot.clone()), trace: None };
    let (status, summary, motion_s) = pair.run("interpd-demo", &program_text, &program_name, true)?;
    print_summary(&status, &summary, motion_s, &plot, started.elapsed());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// One run of `interpd run` and `sim-plant` together over iceoryx2 on a program.
pub(super) struct Pair {
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
    ) -> Result<(Value, Value, f64), CliError> {
        let interpd = std::env::current_exe().map_err(|e| CliError::Failure(e.to_string()))?;
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
                return Err(CliError::Failure(format!(
                    "the program did not finish within {} s",
                    RUN_TIMEOUT.as_secs()
                )));
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        if status["state"] != "finished" {
            return Err(CliError::Failure(format!("motion ended in error: {}", status["last_error"])));
        }
        let motion_s = t0.elapsed().as_secs_f64();
        drop(rpc);
        daemon.terminate();
        let code = daemon.wait(Duration::from_secs(15))?;
        if code != 0 {
            return Err(CliError::Failure(format!("interpd run exited with {code}; its log:\n{}", daemon.log_text())));
        }
        let code = plant.wait(Duration::from_secs(60))?;
        if code != 0 {
            return Err(CliError::Failure(format!("sim-plant exited with {code}; its log:\n{}", plant.log_text())));
        }
        let summary: Value = std::fs::read_to_string(&summary_path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .ok_or_else(|| CliError::Failure(format!("sim-plant wrote no summary; its log:\n{}", plant.log_text())))?;
        Ok((status, summary, motion_s))
    }
}

#[allow(clippy::print_stdout)]
fn print_summary(status: &Value, plant: &Value, motion_s: f64, plot: &Path, wall: Duration) {
    let um = |v: &Value| v.as_f64().map_or("n/a".to_string(), |x| format!("{:.2} µm", x * 1e3));
    println!(
        "interpd demo: {} finished in {:.2} s of motion ({:.1} s wall)",
        status["program"]["name"].as_str().unwrap_or("program"),
        motion_s,
        wall.as_secs_f64()
    );
    println!(
        "  setpoints received by the plant: {}, missed cycles: {}",
        plant["setpoints_received"], plant["missed_cycles"]
    );
    if let Some(axes) = plant["axes"].as_array() {
        for a in axes {
            println!(
                "  axis {} ({}): max following error {}, max load error {}",
                a["name"].as_str().unwrap_or("?"),
                a["preset"].as_str().unwrap_or("?"),
                um(&a["max_following_error"]),
                um(&a["max_load_error"]),
            );
            println!("    after the motion end: {}", settling_text(a));
        }
    }
    println!("  max contour error (load side): {}", um(&plant["max_contour_error"]));
    let w = &status["cycles"]["wakeup_us"];
    println!(
        "  real-time loop: wake-up latency p50 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs; {} late cycles",
        w["p50"].as_f64().unwrap_or(0.0),
        w["p999"].as_f64().unwrap_or(0.0),
        w["max"].as_f64().unwrap_or(0.0),
        status["cycles"]["late"]
    );
    println!("  plot: {}", plot.display());
}

/// Settling and vibration after the motion end, apart: a decay is settling (time, overshoot),
/// an oscillation (a spectral peak) is vibration (amplitude, frequency).
fn settling_text(a: &Value) -> String {
    let um = |v: &Value| v.as_f64().map_or("n/a".to_string(), |x| format!("{:.2} µm", x * 1e3));
    let window = a["settling_window_s"].as_f64().unwrap_or(0.0);
    if a["settling_band"].is_null() {
        return "no standstill recorded".to_string();
    }
    let settle = match a["settling_time_s"].as_f64() {
        Some(t) => format!("settled in {t:.3} s within ±{}", um(&a["settling_band"])),
        None => format!("still settling after {window:.2} s (band ±{})", um(&a["settling_band"])),
    };
    let vib = match (a["vibration_amplitude"].as_f64(), a["vibration_hz"].as_f64()) {
        (Some(x), Some(f)) => format!("residual vibration {:.2} µm at {f:.1} Hz", x * 1e3),
        _ => "residual vibration none (no spectral peak)".to_string(),
    };
    format!("{settle}, overshoot {}, {vib}", um(&a["overshoot"]))
}
