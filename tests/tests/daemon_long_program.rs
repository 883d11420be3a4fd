//! A program of a million lines through the real daemon and plant: CAM output of 2 µm moves
//! (scripts/gen-examples.py --cam-dense, coordinates rounded to 4 decimals, zero-length moves,
//! G64 P0.01). `program.load` checks it in one streaming pass; the motion reads, smooths and
//! plans it as it goes. The daemon's peak resident memory stays within the bound whatever the
//! program's length, the first setpoint in motion follows `motion.start` within 200 ms, the
//! stream has no gap and no underrun and keeps the axis limits. An error on line 900 000 is
//! reported with its place, within the same memory bound.

use interpd::config::Config;
use interpd::rt::clock::now_ns;
use interpd_e2e::daemon::{AxisLimits, Collector, Daemon, limit_ratios};
use interpd_e2e::{binary, repo_root};
use interpd_protocol::shm::flags;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Moves in the program.
const MOVES: usize = 1_000_000;
/// Peak resident memory allowed for the daemon, MB.
const RSS_BOUND_MB: f64 = 300.0;
/// Time from `motion.start` to the first setpoint in motion, allowed.
const FIRST_MOTION_MS: f64 = 200.0;
const RUN_TIMEOUT: Duration = Duration::from_secs(180);

/// A generated program inside the programs directory (the daemon's working directory, the
/// repository): removed on drop.
struct Generated {
    dir: PathBuf,
}

impl Drop for Generated {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn generate() -> (Generated, PathBuf) {
    let dir = repo_root().join("target").join(format!("e2e-long-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let file = dir.join("dense2.ngc");
    let out = Command::new("python3")
        .arg(repo_root().join("scripts/gen-examples.py"))
        .args(["--cam-dense", "0.002", &MOVES.to_string()])
        .arg(&file)
        .output()
        .expect("python3 scripts/gen-examples.py");
    assert!(out.status.success(), "gen-examples: {}", String::from_utf8_lossy(&out.stderr));
    (Generated { dir }, file)
}

/// Peak and current resident memory of process `pid`, MB.
fn memory_mb(pid: u32) -> (f64, f64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc status");
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
            .map_or(f64::NAN, |kb| kb / 1024.0)
    };
    (field("VmHWM:"), field("VmRSS:"))
}

struct Plant(Child);

impl Drop for Plant {
    fn drop(&mut self) {
        unsafe { libc::kill(self.0.id() as i32, libc::SIGTERM) };
        let _ = self.0.wait();
    }
}

fn relative(file: &Path) -> String {
    file.strip_prefix(repo_root()).expect("inside the repository").display().to_string()
}

#[test]
fn a_million_line_program_loads_and_runs_in_bounded_memory() {
    let (_generated, file) = generate();
    let mut run = Run::start();

    // An error near the end: found with its place, nothing else kept.
    let bad = file.with_file_name("bad.ngc");
    {
        let text = std::fs::read_to_string(&file).expect("read");
        let mut lines: Vec<&str> = text.lines().collect();
        lines[899_999] = "G1 X1 Q5";
        std::fs::write(&bad, lines.join("\n")).expect("write");
    }
    let t0 = Instant::now();
    let r = run.client.call("program.load", json!({ "path": relative(&bad) }));
    let bad_load_s = t0.elapsed().as_secs_f64();
    let message = r["error"]["message"].as_str().unwrap_or_default().to_string();
    assert_eq!(r["error"]["code"], -32001, "{r}");
    assert!(message.contains("bad.ngc:900000:7:") && message.lines().count() == 1, "{message}");
    eprintln!("bad program refused in {bad_load_s:.2} s");

    let info = run.load_and_run(&file, &format!("{MOVES} moves"));
    assert_eq!(info["lines"], MOVES as u64 + 7, "{info}");
}

/// Iterations of the loop in [`a_million_iteration_loop_runs_in_the_same_bounded_memory`].
const ITERATIONS: usize = 1_000_000;

/// A `while` loop of a million iterations, one 2 µm move each along a gentle wave: the
/// interpreter executes the loop as the look-ahead reads, never unrolling it into memory, so
/// the daemon runs it within the same memory bound as a million-line program.
#[test]
fn a_million_iteration_loop_runs_in_the_same_bounded_memory() {
    let dir = repo_root().join("target").join(format!("e2e-loop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let _generated = Generated { dir: dir.clone() };
    let file = dir.join("loop.ngc");
    // A circle of 320 mm radius (once round is 2 011 mm), inside the travel of ±1000 mm; SIN
    // and COS take degrees (LinuxCNC). Each step turns by 0.002 / 320 rad.
    let program = format!(
        "(a while loop of {ITERATIONS} iterations, one 2 um move each)\n\
         G21 G90 G17\nG0 X320 Y0 Z0\nG64 P0.01\nG1 F6000\n#<i> = 0\n\
         o100 while [#<i> LT {ITERATIONS}]\n  #<i> = [#<i> + 1]\n  #<a> = [#<i> * 0.002 / 320 * 180 / 3.14159265358979]\n\
         \x20 G1 X[320 * COS[#<a>]] Y[320 * SIN[#<a>]]\no100 endwhile\nM30\n"
    );
    std::fs::write(&file, program).expect("write");
    let run = Run::start();
    let info = run.load_and_run(&file, &format!("{ITERATIONS} loop iterations"));
    assert_eq!(info["lines"], 12, "{info}");
}

/// The daemon and the plant of one test.
struct Run {
    daemon: Daemon,
    client: interpd_e2e::daemon::Client,
    _plant: Plant,
    pid: u32,
    rss_idle_mb: f64,
}

impl Run {
    fn start() -> Run {
        let daemon = Daemon::start(&[]);
        let pid = daemon.pid().expect("pid");
        let plant = Plant(
            Command::new(binary("sim-plant"))
                .args(["--service-prefix", &daemon.prefix])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("sim-plant"),
        );
        let client = daemon.client();
        let (_, rss_idle_mb) = memory_mb(pid);
        Run { daemon, client, _plant: plant, pid, rss_idle_mb }
    }

    /// Loads `file`, runs it to the end and checks the bounds of this file's tests: peak
    /// memory, the first motion after `motion.start`, no gap and no underrun, the axis limits,
    /// and a motion of about 2 m. Returns `program.load`'s result.
    fn load_and_run(mut self, file: &Path, what: &str) -> Value {
        let (pid, rss_idle) = (self.pid, self.rss_idle_mb);
        let c = &mut self.client;
        let t0 = Instant::now();
        let info = c.ok("program.load", json!({ "path": relative(file) }));
        let load_s = t0.elapsed().as_secs_f64();
        let (peak_loaded, _) = memory_mb(pid);

        let collector = Collector::start(&self.daemon.prefix);
        std::thread::sleep(Duration::from_millis(200));
        let asked_ns = now_ns();
        c.ok("motion.start", Value::Null);
        let st = c.wait_state(&["finished", "error"], RUN_TIMEOUT);
        let (peak, rss_end) = memory_mb(pid);
        assert_eq!(st["state"], "finished", "{st}\n{}", self.daemon.stderr());
        let lookahead = c.ok("status", Value::Null)["lookahead"].clone();
        std::thread::sleep(Duration::from_millis(100));
        let sps = collector.finish();
        drop(self._plant);
        let (code, stderr) = self.daemon.terminate();
        assert_eq!(code, Some(0), "interpd run; stderr:\n{stderr}");
        let moving: Vec<_> = sps.iter().filter(|s| s.flags & flags::RUNNING != 0).collect();
        let first = moving.iter().find(|s| s.v_mm_s > 0.0).expect("motion");
        let first_motion_ms = (first.publish_ns as f64 - asked_ns as f64) * 1e-6;
        for w in sps.windows(2) {
            assert_eq!(w[1].cycle, w[0].cycle + 1, "gap in cycle numbers");
        }
        let underruns = sps.iter().filter(|s| s.flags & flags::UNDERRUN != 0).count();
        let mut runs = Vec::new();
        for w in sps.windows(2) {
            if w[0].flags & flags::UNDERRUN == 0 && w[1].flags & flags::UNDERRUN != 0 {
                runs.push((w[1].cycle, (w[1].s_mm * 10.0).round() / 10.0));
            }
        }
        eprintln!("underruns begin at (cycle, s_mm): {runs:?}");
        // What the look-ahead did when the queue ran low: its longest step, and its warnings.
        eprintln!("lookahead {lookahead}");
        let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("WARN") || l.contains("ERROR")).collect();
        eprintln!("daemon warnings: {}", warnings.len());
        for w in warnings.iter().take(20) {
            eprintln!("  {w}");
        }
        let config = Config::load_or_default(None).expect("default machine");
        let limits: Vec<AxisLimits> = AxisLimits::of(&config);
        let r = limit_ratios(config.cycle_s(), &limits, &sps);
        let last = sps.last().expect("setpoints");
        eprintln!(
            "{what}: loaded in {load_s:.2} s; motion {:.2} s over {:.1} mm; \
             first motion {first_motion_ms:.1} ms after motion.start; {underruns} underrun cycles; limit ratios {r:.4?}; \
             daemon RSS idle {rss_idle:.1} MB, peak after load {peak_loaded:.1} MB, peak {peak:.1} MB, at the end {rss_end:.1} MB",
            moving.len() as f64 * config.cycle_s(),
            last.s_mm
        );
        assert!(peak <= RSS_BOUND_MB, "peak resident memory {peak:.1} MB > {RSS_BOUND_MB} MB");
        assert!(first_motion_ms <= FIRST_MOTION_MS, "first motion {first_motion_ms:.1} ms after motion.start");
        assert_eq!(underruns, 0, "underrun cycles");
        assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02 && r[3] <= 1.001, "limit ratios {r:?}");
        assert!(last.s_mm > 1990.0, "the motion ended at s = {} mm", last.s_mm);
        info
    }
}
