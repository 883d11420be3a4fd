//! The soak run: the daemon and the plant for a long time under a client that loads, starts,
//! overrides, holds, resumes, stops and reloads at random (seeded), with the whole setpoint
//! stream recorded by `interpd record` in a process of its own and checked afterwards. It
//! reports what a long run must not show: limit violations, cycle gaps, underruns, and resident
//! memory of the daemon that grows. (The recorder is a process of its own so that the
//! daemon's memory is the daemon's: an MCAP writer keeps one chunk index entry per written
//! chunk for the file's summary, which grows with the recording's length.)
//! `tests/src/bin/soak.rs` is the command; `tests/tests/soak.rs` the short version in CI.

use crate::daemon::{AxisLimits, Client, Daemon};
use crate::process::{Plant, rss_kib};
use crate::rng::{Rng, seeded};
use crate::stream::{RecordingCheck, check_recording};
use interpd::config::Config;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::fmt;
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Programs the client loads, by path relative to the repository (the daemon's programs
/// directory): straight lines, arcs, corners, G64 smoothing and G06 splines.
pub const PROGRAMS: &[&str] = &[
    "examples/demo.ngc",
    "examples/circle_r10.ngc",
    "examples/line_arc_line.ngc",
    "examples/zigzag.ngc",
    "examples/staircase.ngc",
    "examples/two_arcs.ngc",
    "examples/ellipse_g06.ngc",
    "examples/corner_90.ngc",
];
/// Resident memory the daemon may gain over a run, per hour: the figure the soak is held to.
pub const RSS_GROWTH_KIB_PER_HOUR: f64 = 1024.0;
/// Resident memory the daemon may gain in any run, whatever its length: the allocator's heaps
/// rise and fall by up to about 1.4 MB between two samples of a soak (blocks freed but not yet
/// trimmed), so a shorter run cannot tell less than that from a leak.
pub const RSS_GROWTH_SLACK_KIB: f64 = 1536.0;
/// Share of the run (at most [`WARMUP_MAX`]) before the starting resident memory is taken,
/// and not before every program of [`PROGRAMS`] has run once: every buffer, thread and
/// allocator arena has been used by then.
const WARMUP_SHARE: f64 = 0.1;
const WARMUP_MAX: Duration = Duration::from_secs(60);
/// Resident memory is sampled this often.
const RSS_EVERY: Duration = Duration::from_secs(5);
const STATE_TIMEOUT: Duration = Duration::from_secs(30);
/// The client's actions, one line each with the daemon's cycle before it (in the soak's
/// directory).
pub const ACTIONS_LOG: &str = "actions.log";

/// What a soak run does.
#[derive(Debug, Clone)]
pub struct SoakOptions {
    pub duration: Duration,
    pub seed: u64,
    /// Directory for the recording and the logs (created).
    pub dir: PathBuf,
    /// Keep the recording afterwards.
    pub keep: bool,
    /// Print progress lines every this often (none when `None`).
    pub progress: Option<Duration>,
}

/// Counts of what the client did and what the daemon said.
#[derive(Debug, Clone, Default)]
pub struct Actions {
    pub counts: BTreeMap<&'static str, u64>,
    /// Calls refused with −32002 because the state changed between `status` and the call.
    pub raced: u64,
    /// Unexpected error answers (anything but such a race).
    pub unexpected: Vec<String>,
    pub events: BTreeMap<String, u64>,
    /// Programs of [`PROGRAMS`] loaded at least once (by index).
    pub loaded: std::collections::BTreeSet<usize>,
}

impl Actions {
    fn count(&mut self, what: &'static str) {
        *self.counts.entry(what).or_default() += 1;
    }
}

/// The figures of a soak run.
#[derive(Debug, Clone)]
pub struct SoakReport {
    pub seed: u64,
    pub duration_s: f64,
    pub actions: Actions,
    pub recording: RecordingCheck,
    pub recording_bytes: u64,
    /// Recorder (`interpd record`) resident memory after the warm-up and at the end, KiB.
    pub recorder_rss_kib: (u64, u64),
    /// Daemon resident memory, KiB: right after start, after the warm-up, at the end, largest.
    pub rss_start_kib: u64,
    pub rss_warm_kib: u64,
    pub rss_end_kib: u64,
    pub rss_max_kib: u64,
    pub rss_allowed_growth_kib: f64,
    /// Least-squares slope of the daemon's resident memory after the warm-up, KiB per hour
    /// (robust to the allocator's ups and downs on a long run; noisy on a short one).
    pub rss_slope_kib_per_h: f64,
    /// When the warm-up ended (s from the start).
    pub warmup_s: f64,
    /// Plant resident memory after the warm-up and at the end, KiB.
    pub plant_rss_kib: (u64, u64),
    /// The daemon's own counters (`status.cycles`): late cycles, overruns, and the wake-up
    /// latency percentiles, µs.
    pub late_cycles: u64,
    pub overruns: u64,
    pub wakeup_us: Value,
    pub daemon_exit: Option<i32>,
    pub daemon_summary: String,
    /// The first cycle of each underrun (the first ten) with the client's last actions before
    /// it (from the actions log).
    pub underrun_context: Vec<(u64, Vec<String>)>,
    /// What `interpd record` reports it lost: setpoint cycles missing and samples dropped from
    /// its write queue (`None` when its report is not found).
    pub recorder_lost: Option<(u64, u64)>,
    pub plant_alive: bool,
}

impl SoakReport {
    /// Why the run fails: limit violations or gaps in the recording, an unreadable recording,
    /// underruns, memory growth beyond the bound, unexpected answers, a daemon or plant that
    /// did not last.
    pub fn failures(&self) -> Vec<String> {
        let mut out = self.recording.setpoints.violations();
        if let Some(e) = &self.recording.error {
            out.push(format!("recording not readable to its end: {e}"));
        }
        let underruns = self.recording.setpoints.underruns + self.actions.events.get("underrun").copied().unwrap_or(0);
        if underruns > 0 {
            out.push(format!(
                "{} underruns in the recording ({} cycles, the first from cycles {:?}), {} underrun events",
                self.recording.setpoints.underruns,
                self.recording.setpoints.underrun_cycles,
                self.recording.setpoints.underrun_starts,
                self.actions.events.get("underrun").copied().unwrap_or(0)
            ));
        }
        let growth = self.rss_end_kib as f64 - self.rss_warm_kib as f64;
        if growth > self.rss_allowed_growth_kib {
            out.push(format!(
                "resident memory grew by {growth:.0} KiB (from {} to {} KiB), more than {:.0} KiB",
                self.rss_warm_kib, self.rss_end_kib, self.rss_allowed_growth_kib
            ));
        }
        if !self.actions.unexpected.is_empty() {
            out.push(format!("unexpected answers: {:?}", self.actions.unexpected));
        }
        match self.recorder_lost {
            Some((0, 0)) => {}
            Some((missing, dropped)) => out.push(format!(
                "interpd record lost {missing} setpoint cycles ({dropped} samples dropped from its write queue)"
            )),
            None => out.push("no report from interpd record".into()),
        }
        if self.daemon_exit != Some(0) {
            out.push(format!("interpd run exited with {:?}", self.daemon_exit));
        }
        if !self.plant_alive {
            out.push("sim-plant ended during the run".into());
        }
        if self.recording.setpoints.count == 0 {
            out.push("nothing recorded".into());
        }
        out
    }
}

impl fmt::Display for SoakReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.recording.setpoints;
        writeln!(f, "soak: SOAK_SEED={} duration {:.0} s", self.seed, self.duration_s)?;
        writeln!(f, "  client actions: {:?}; refused by a state race: {}", self.actions.counts, self.actions.raced)?;
        writeln!(f, "  events: {:?}", self.actions.events)?;
        writeln!(
            f,
            "  recording: {} setpoints (cycles {}..={}), {} feedback, {} bytes; missing cycles {}; underruns {} ({} \
             cycles); LATE-flagged cycles {}",
            s.count,
            s.first_cycle.unwrap_or(0),
            s.last_cycle,
            self.recording.feedback,
            self.recording_bytes,
            s.missing,
            s.underruns,
            s.underrun_cycles,
            s.late_cycles
        )?;
        writeln!(
            f,
            "  limit ratios (finite differences at the cycle): vel {:.4} acc {:.4} jerk {:.4}, reported acc {:.4}; \
             reported v/a against the positions {:.3} {:.3} of the allowed",
            s.ratios[0], s.ratios[1], s.ratios[2], s.ratios[3], s.agreement[0], s.agreement[1]
        )?;
        writeln!(
            f,
            "  daemon: late cycles {}, overruns {}, wake-up latency µs {}; exit {:?}",
            self.late_cycles, self.overruns, self.wakeup_us, self.daemon_exit
        )?;
        writeln!(f, "  daemon summary: {}", self.daemon_summary.trim())?;
        writeln!(
            f,
            "  daemon RSS KiB: start {}, after the warm-up ({:.0} s) {}, end {}, max {}; growth {} KiB (allowed {:.0}), \
             trend {:.0} KiB/h; plant RSS KiB {} -> {}; recorder RSS KiB {} -> {}",
            self.rss_start_kib,
            self.warmup_s,
            self.rss_warm_kib,
            self.rss_end_kib,
            self.rss_max_kib,
            self.rss_end_kib as i64 - self.rss_warm_kib as i64,
            self.rss_allowed_growth_kib,
            self.rss_slope_kib_per_h,
            self.plant_rss_kib.0,
            self.plant_rss_kib.1,
            self.recorder_rss_kib.0,
            self.recorder_rss_kib.1
        )?;
        for (cycle, actions) in &self.underrun_context {
            writeln!(f, "  underrun from cycle {cycle}, after: {}", actions.join(" | "))?;
        }
        let failures = self.failures();
        if failures.is_empty() { write!(f, "  PASS") } else { write!(f, "  FAIL: {}", failures.join("; ")) }
    }
}

/// Runs a soak as `options` say and reports; panics only when the processes cannot be started.
pub fn run(options: &SoakOptions) -> SoakReport {
    std::fs::create_dir_all(&options.dir).expect("soak directory");
    let recording = options.dir.join("soak.mcap");
    let config = Config::default_machine();
    let daemon = Daemon::start(&[]);
    let pid = daemon.pid().expect("daemon pid");
    let rss_start_kib = rss_kib(pid).unwrap_or(0);
    let recorder = Command::new(crate::binary("interpd"))
        .arg("record")
        .arg("--out")
        .arg(&recording)
        .args(["--service-prefix", &daemon.prefix])
        .stdout(Stdio::null())
        .stderr(Stdio::from(std::fs::File::create(options.dir.join("recorder.log")).expect("recorder log")))
        .spawn()
        .expect("start interpd record");
    let recorder_pid = recorder.id();
    let mut plant = Plant::start(&daemon.prefix, &[], &options.dir.join("sim-plant.log"));
    let mut rng = seeded(options.seed);
    let mut actions = Actions::default();
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    fill_connection_slots(&daemon);
    let mut log = std::io::BufWriter::new(std::fs::File::create(options.dir.join(ACTIONS_LOG)).expect("actions log"));

    let started = Instant::now();
    let warmup = options.duration.mul_f64(WARMUP_SHARE).min(WARMUP_MAX);
    let (mut rss_warm_kib, mut plant_warm_kib, mut recorder_warm_kib, mut warmup_s) = (None, 0, 0, 0.0);
    let mut rss_max_kib = rss_start_kib;
    let mut rss_samples: Vec<(f64, f64)> = Vec::new();
    let mut next_rss = started;
    let mut next_progress = started + options.progress.unwrap_or(Duration::MAX / 4);
    while started.elapsed() < options.duration {
        step(&mut c, &daemon, &mut rng, &mut actions, rss_warm_kib.is_none(), &mut log);
        for e in c.events.drain(..) {
            *actions.events.entry(e["event"].as_str().unwrap_or("?").to_string()).or_default() += 1;
        }
        if Instant::now() >= next_rss {
            let rss = rss_kib(pid).unwrap_or(0);
            rss_max_kib = rss_max_kib.max(rss);
            if rss_warm_kib.is_some() {
                rss_samples.push((started.elapsed().as_secs_f64(), rss as f64));
            }
            if rss_warm_kib.is_none() && started.elapsed() >= warmup && actions.loaded.len() == PROGRAMS.len() {
                rss_warm_kib = Some(rss);
                plant_warm_kib = plant.pid().and_then(rss_kib).unwrap_or(0);
                recorder_warm_kib = rss_kib(recorder_pid).unwrap_or(0);
                warmup_s = started.elapsed().as_secs_f64();
            }
            next_rss += RSS_EVERY;
        }
        if let Some(every) = options.progress.filter(|_| Instant::now() >= next_progress) {
            let st = c.ok("status", Value::Null);
            eprintln!(
                "soak: {:.0} s, {} {}, override {}, cycle {}, late {}, RSS {} KiB, actions {:?}, events {:?}",
                started.elapsed().as_secs_f64(),
                st["program"]["name"],
                st["state"],
                st["override"],
                st["cycle"],
                st["cycles"]["late"],
                rss_kib(pid).unwrap_or(0),
                actions.counts,
                actions.events
            );
            next_progress += every;
        }
        std::thread::sleep(Duration::from_millis(rng.random_range(100..1500)));
    }
    // The end: stop, let the machine stand, then the figures.
    c.ok("motion.stop", Value::Null);
    let st = c.wait_state(&["idle", "finished"], STATE_TIMEOUT);
    std::thread::sleep(Duration::from_millis(500));
    let rss_end_kib = rss_kib(pid).unwrap_or(0);
    rss_max_kib = rss_max_kib.max(rss_end_kib);
    rss_samples.push((started.elapsed().as_secs_f64(), rss_end_kib as f64));
    let plant_end_kib = plant.pid().and_then(rss_kib).unwrap_or(0);
    let recorder_end_kib = rss_kib(recorder_pid).unwrap_or(0);
    for e in c.events.drain(..) {
        *actions.events.entry(e["event"].as_str().unwrap_or("?").to_string()).or_default() += 1;
    }
    let duration_s = started.elapsed().as_secs_f64();
    drop(c);
    let _ = log.flush();
    drop(log);
    let plant_alive = plant.running();
    let (daemon_exit, stderr) = daemon.terminate();
    drop(plant);
    // SAFETY: kill(2) on our own child's pid; it finishes the file on SIGTERM.
    unsafe { libc::kill(recorder_pid as i32, libc::SIGTERM) };
    let recorder_out = recorder.wait_with_output().expect("wait for interpd record");
    let recorder_log = std::fs::read_to_string(options.dir.join("recorder.log")).unwrap_or_default();
    let daemon_summary = stderr
        .lines()
        .chain(recorder_log.lines())
        .filter(|l| l.contains("cycles,") || l.contains("recorded"))
        .collect::<Vec<_>>()
        .join("\n  ");
    if recorder_out.status.code() != Some(0) {
        actions.unexpected.push(format!("interpd record exited with {:?}: {recorder_log}", recorder_out.status.code()));
    }
    let recording_bytes = std::fs::metadata(&recording).map_or(0, |m| m.len());
    let recorder_lost = recorder_losses(&recorder_log);
    let check = check_recording(&recording, AxisLimits::of(&config), config.cycle_s()).unwrap_or_else(|e| {
        let mut c = RecordingCheck {
            setpoints: crate::stream::StreamCheck::new(AxisLimits::of(&config), config.cycle_s()),
            feedback: 0,
            error: None,
        };
        c.error = Some(e.to_string());
        c
    });
    if !options.keep {
        let _ = std::fs::remove_file(&recording);
    }
    let actions_log = std::fs::read_to_string(options.dir.join(ACTIONS_LOG)).unwrap_or_default();
    let underrun_context =
        check.setpoints.underrun_starts.iter().map(|&at| (at, actions_before(&actions_log, at, 3))).collect();
    let hours = duration_s / 3600.0;
    SoakReport {
        seed: options.seed,
        duration_s,
        actions,
        recording: check,
        recording_bytes,
        rss_start_kib,
        rss_warm_kib: rss_warm_kib.unwrap_or(rss_start_kib),
        rss_end_kib,
        rss_max_kib,
        rss_allowed_growth_kib: RSS_GROWTH_SLACK_KIB + RSS_GROWTH_KIB_PER_HOUR * hours,
        rss_slope_kib_per_h: slope(&rss_samples) * 3600.0,
        plant_rss_kib: (plant_warm_kib, plant_end_kib),
        recorder_rss_kib: (recorder_warm_kib, recorder_end_kib),
        warmup_s,
        late_cycles: st["cycles"]["late"].as_u64().unwrap_or(0),
        overruns: st["cycles"]["overruns"].as_u64().unwrap_or(0),
        wakeup_us: st["cycles"]["wakeup_us"].clone(),
        daemon_exit,
        daemon_summary,
        recorder_lost,
        underrun_context,
        plant_alive,
    }
}

/// The last `n` lines of the actions log whose cycle is before `cycle`.
fn actions_before(log: &str, cycle: u64, n: usize) -> Vec<String> {
    let at = |l: &str| l.strip_prefix("cycle ")?.split(' ').next()?.parse::<u64>().ok();
    let before: Vec<&str> = log.lines().filter(|l| at(l).is_some_and(|c| c < cycle)).collect();
    before[before.len().saturating_sub(n)..].iter().map(|l| l.to_string()).collect()
}

/// The setpoint cycles missing and the samples dropped that `interpd record` reports in its
/// last line (`recorded setpoints: N (cycles A–B, M missing); …; largest write queue Q of C,
/// D dropped; …`).
fn recorder_losses(log: &str) -> Option<(u64, u64)> {
    let line = log.lines().rev().find(|l| l.contains("recorded setpoints:"))?;
    let number_before = |text: &str, word: &str| -> Option<u64> {
        let end = text.find(word)?;
        text[..end].trim_end().rsplit([' ', '(', ',']).next()?.parse().ok()
    };
    let setpoints = line.split("; feedback:").next()?;
    Some((number_before(setpoints, " missing")?, number_before(line, " dropped")?))
}

/// Least-squares slope of (x, y) points; 0 for fewer than two.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    if points.len() < 2 {
        return 0.0;
    }
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}

/// Connections the daemon serves at most (docs/control-api.md).
const MAX_CONNECTIONS: usize = 16;

/// Opens every connection the daemon serves, each subscribed (two threads each), and closes
/// them: the C library keeps the stacks of ended threads for reuse (all resident, the daemon
/// locks its memory), so this makes the warm-up reach the most the daemon ever holds for its
/// connections, and the soak measures what grows beyond it.
fn fill_connection_slots(daemon: &Daemon) {
    let mut clients: Vec<Client> = (1..MAX_CONNECTIONS).map(|_| daemon.client()).collect();
    for c in &mut clients {
        c.ok("subscribe", Value::Null);
    }
    drop(clients);
    std::thread::sleep(Duration::from_millis(300));
}

/// One random action fitting the state the daemon reports, written to `log` with the cycle
/// the daemon was at before it (to find the action before a finding in the recording).
/// During the warm-up every finished or stopped run loads the next program not yet run.
fn step(
    c: &mut Client,
    daemon: &Daemon,
    rng: &mut impl Rng,
    actions: &mut Actions,
    warming_up: bool,
    log: &mut impl Write,
) {
    let st = c.ok("status", Value::Null);
    let state = st["state"].as_str().unwrap_or("").to_string();
    let cycle = st["cycle"].as_u64().unwrap_or(0);
    let roll: f64 = rng.random();
    let (what, method, params): (&'static str, &str, Value) = match state.as_str() {
        "idle" | "finished"
            if st["program"].is_null() || roll < 0.3 || (warming_up && actions.loaded.len() < PROGRAMS.len()) =>
        {
            let index = match (0..PROGRAMS.len()).find(|i| !actions.loaded.contains(i)) {
                Some(i) if warming_up => i,
                _ => rng.random_range(0..PROGRAMS.len()),
            };
            // Reload on a connection of its own, as a second client would.
            let mut other = daemon.client();
            let r = other.call("program.load", json!({ "path": PROGRAMS[index] }));
            let _ = writeln!(log, "cycle {cycle} {state}: reload {} -> {}", PROGRAMS[index], outcome(&r));
            if r.get("error").is_none() {
                actions.loaded.insert(index);
            }
            answer(actions, "reload", &r);
            return;
        }
        "idle" | "finished" => ("start", "motion.start", Value::Null),
        "running" if roll < 0.45 => {
            // Mostly 10–200 %, now and then 0 % (a hold by override) or a crawl.
            let factor = if rng.random_bool(0.1) { 0.0 } else { rng.random_range(0.1..=2.0) };
            ("override", "feed.override", json!({ "factor": factor }))
        }
        "running" if roll < 0.65 => ("hold", "motion.hold", Value::Null),
        "running" if roll < 0.75 => ("stop", "motion.stop", Value::Null),
        "running" => return,
        "holding" if st["override"].as_f64().unwrap_or(1.0) < 0.001 => {
            ("override", "feed.override", json!({ "factor": rng.random_range(0.1..=2.0) }))
        }
        "holding" if roll < 0.2 => ("stop", "motion.stop", Value::Null),
        "holding" if roll < 0.35 => ("override", "feed.override", json!({ "factor": rng.random_range(0.1..=2.0) })),
        "holding" => ("resume", "motion.resume", Value::Null),
        "error" => {
            actions.unexpected.push(format!("state error: {}", st["last_error"]));
            ("stop", "motion.stop", Value::Null)
        }
        // stopping, jogging: wait.
        _ => return,
    };
    let r = c.call(method, params.clone());
    let _ = writeln!(log, "cycle {cycle} {state}: {method} {params} -> {}", outcome(&r));
    answer(actions, what, &r);
}

/// An answer for the actions log: `ok` or the error object.
fn outcome(r: &Value) -> String {
    r.get("error").map_or_else(|| "ok".to_string(), Value::to_string)
}

fn answer(actions: &mut Actions, what: &'static str, r: &Value) {
    match r["error"]["code"].as_i64() {
        None => actions.count(what),
        Some(-32002) => actions.raced += 1,
        Some(_) => actions.unexpected.push(format!("{what}: {}", r["error"])),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_recorders_losses_are_read_from_its_report() {
        let line = "interpd: recorded setpoints: 988 (cycles 0–987, 3 missing); feedback: 494 (cycles 0–493, 7 \
                    missing); 4.0 s to run.mcap (72524 bytes; largest subscriber backlog 5 of 64; largest write queue \
                    12 of 8192, 2 dropped; 0 out of log-time order)";
        assert_eq!(super::recorder_losses(line), Some((3, 2)));
        assert_eq!(super::recorder_losses("nothing"), None);
    }

    #[test]
    fn the_actions_before_an_underrun_are_found_by_cycle() {
        let log = "cycle 10 idle: motion.start null -> ok\ncycle 250 running: motion.hold null -> ok\n\
                   cycle 400 holding: motion.resume null -> ok\ncycle 900 running: motion.stop null -> ok\n";
        assert_eq!(
            super::actions_before(log, 500, 2),
            ["cycle 250 running: motion.hold null -> ok", "cycle 400 holding: motion.resume null -> ok"]
        );
    }
}
