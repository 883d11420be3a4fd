//! The planner thread and the executor driven in lockstep in simulated time: the whole chain
//! from program to setpoints, deterministic, without threads or clocks.

mod laws;
mod random;

use super::feeder::{Feeder, FeederCommand, FeederReport, PathSource, Queues};
use crate::interp::{DivertCause, Epoch, Executor, Io, Notice};
use crossbeam::channel;
use crossbeam::queue::ArrayQueue;
use interpd_config::Config;
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::program;
use interpd_protocol::shm::Setpoints;
use std::sync::Arc;

/// The chain in one thread.
pub(crate) struct Sim {
    pub config: Config,
    pub feeder: Feeder,
    pub executor: Executor,
    pub queues: Queues,
    pub notices: ArrayQueue<Notice>,
    pub reports: channel::Receiver<FeederReport>,
    pub hold: bool,
    pub stop: bool,
    pub optional_stop: bool,
    pub releases: u64,
    /// The stop floor the control side publishes.
    pub epoch_floor: Epoch,
    pub cycle: u64,
    pub out: Vec<Setpoints>,
    pub seen: Vec<Notice>,
}

impl Sim {
    pub fn new(config: Config) -> Sim {
        let queues = Queues::new();
        let (tx, rx) = channel::unbounded();
        let feeder = Feeder::new(&config, queues.clone(), tx);
        let executor = Executor::new(config.axes.len(), [0.0; interpd_motion::path::MAX_AXES]);
        Sim {
            config,
            feeder,
            executor,
            queues,
            notices: ArrayQueue::new(4096),
            reports: rx,
            hold: false,
            stop: false,
            optional_stop: true,
            releases: 0,
            epoch_floor: Epoch::NONE,
            cycle: 0,
            out: Vec::new(),
            seen: Vec::new(),
        }
    }

    pub fn start(&mut self, path: Arc<Path>) {
        let source = PathSource::Whole(path);
        self.feeder.command(FeederCommand::Start { source, epoch: Epoch::FIRST, feed_override: 1.0, suspend: false });
    }

    /// One cycle: the planner thread tops up the queue (as if it were fast enough), then the
    /// executor computes the setpoint; notices go to the feeder as the supervisor would send.
    pub fn cycle(&mut self) {
        self.feeder.reclaim();
        while self.feeder.wants_to_produce() {
            self.feeder.produce();
        }
        self.step_executor();
    }

    pub fn step_executor(&mut self) {
        let io = Io {
            chunks: &self.queues.chunks,
            recycle: &self.queues.recycle,
            notices: &self.notices,
            hold: self.hold,
            stop: self.stop,
            epoch_floor: self.epoch_floor,
            optional_stop: self.optional_stop,
            releases: self.releases,
        };
        let mut sp = Setpoints::default();
        self.executor.step(self.cycle, self.config.cycle_s(), &io, &mut sp);
        sp.cycle = self.cycle;
        self.out.push(sp);
        self.cycle += 1;
        while let Some(n) = self.notices.pop() {
            match n {
                Notice::Diverted { epoch, cause, .. } => self.feeder.command(FeederCommand::Diverted { epoch, cause }),
                Notice::Stood { epoch, seq, cause, s_mm, .. } => {
                    self.feeder.command(FeederCommand::Stood { epoch, seq, cause, s_mm })
                }
                _ => {}
            }
            self.seen.push(n);
        }
        while let Ok(r) = self.reports.try_recv() {
            assert!(!matches!(r, FeederReport::Error(_)), "feeder report: {r:?}");
        }
    }

    pub fn finished(&self) -> bool {
        self.seen.iter().any(|n| matches!(n, Notice::Finished { .. }))
    }

    pub fn run_to_end(&mut self, max_cycles: u64) {
        while !self.finished() && self.cycle < max_cycles {
            self.cycle();
        }
        assert!(self.finished(), "not finished after {max_cycles} cycles");
    }
}

/// Largest |value|/limit of velocity, acceleration and jerk by finite differences of the
/// setpoint positions (the 4 ms stream), and the largest step of the reported acceleration.
pub(crate) fn stream_ratios(config: &Config, out: &[Setpoints]) -> [f64; 3] {
    let dt = config.cycle_s();
    let mut worst = [0.0f64; 3];
    for (k, ax) in config.axes.iter().enumerate() {
        for w in out.windows(4) {
            let p: Vec<f64> = w.iter().map(|s| s.pos[k]).collect();
            let v = (p[1] - p[0]) / dt;
            let a = (p[2] - 2.0 * p[1] + p[0]) / (dt * dt);
            let j = (p[3] - 3.0 * p[2] + 3.0 * p[1] - p[0]) / (dt * dt * dt);
            worst[0] = worst[0].max(v.abs() / ax.max_vel_per_s);
            worst[1] = worst[1].max(a.abs() / ax.max_acc_per_s2);
            worst[2] = worst[2].max(j.abs() / ax.max_jerk_per_s3);
        }
    }
    worst
}

/// Largest distance of a setpoint from the exact geometry at its own path position.
pub(crate) fn path_deviation_mm(path: &Path, out: &[Setpoints]) -> f64 {
    let mut d = AxisDerivs::default();
    let mut worst: f64 = 0.0;
    for sp in out {
        path.eval(sp.s_mm, &mut d);
        let e: f64 = (0..path.n_axes).map(|k| (sp.pos[k] - d.pos[k]).powi(2)).sum::<f64>().sqrt();
        worst = worst.max(e);
    }
    worst
}

fn example(name: &str) -> String {
    std::fs::read_to_string(format!("{}/../examples/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn load(name: &str, config: &Config) -> Arc<Path> {
    Arc::new(program::parse(&example(name), name, &Settings::from(config)).unwrap().path)
}

#[test]
fn circle_runs_to_the_end_within_limits_and_on_the_path() {
    let config = Config::default_machine();
    let path = load("circle_r10.ngc", &config);
    let mut sim = Sim::new(config.clone());
    let t = std::time::Instant::now();
    sim.start(path.clone());
    sim.run_to_end(20_000);
    eprintln!("simulated {} cycles in {:?}; {:?}", sim.cycle, t.elapsed(), sim.feeder.stats);
    let end = path.end_position();
    let last = sim.out.last().unwrap();
    for (k, (got, want)) in last.pos.iter().zip(end.iter()).take(3).enumerate() {
        assert!((got - want).abs() < 1e-9, "axis {k} ends at {got} not {want}");
    }
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    let dev = path_deviation_mm(&path, &sim.out);
    assert!(dev <= 1e-3, "deviation {dev} mm");
    assert!(!sim.seen.iter().any(|n| matches!(n, Notice::Diverted { .. })), "diverted: {:?}", sim.seen);
}

#[test]
fn hold_stops_on_the_path_and_resume_finishes() {
    let config = Config::default_machine();
    let path = load("line_arc_line.ngc", &config);
    let mut sim = Sim::new(config.clone());
    sim.start(path.clone());
    for _ in 0..100 {
        sim.cycle();
    }
    sim.hold = true;
    for _ in 0..150 {
        sim.cycle();
    }
    assert!(sim.seen.iter().any(|n| matches!(n, Notice::Stood { cause: DivertCause::Hold, .. })), "{:?}", sim.seen);
    let held = *sim.out.last().unwrap();
    assert!(held.v_mm_s.abs() < 1e-9);
    sim.hold = false;
    sim.feeder.command(FeederCommand::Resume);
    sim.run_to_end(50_000);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(path_deviation_mm(&path, &sim.out) <= 1e-3);
}

#[test]
fn override_changes_apply_within_the_limits() {
    let config = Config::default_machine();
    let text = "G21 G90 G17\nG1 X0 Y0 F6000\nG1 X100 Y0\nG3 X110 Y10 I0 J10\nG1 X110 Y60\nG3 X100 Y70 I-10 J0\nG1 X0 Y70\nG3 X-10 Y60 I0 J-10\nG1 X-10 Y10\nG3 X0 Y0 I10 J0\nG1 X100 Y0\n";
    let path = Arc::new(program::parse(text, "loop.ngc", &Settings::from(&config)).unwrap().path);
    let mut sim = Sim::new(config.clone());
    sim.start(path.clone());
    let mut worst_chunk_s: f64 = 0.0;
    for (at_cycle, factor) in [(150u64, 1.5), (300, 0.3), (600, 1.0)] {
        while sim.cycle < at_cycle {
            let t = std::time::Instant::now();
            sim.cycle();
            worst_chunk_s = worst_chunk_s.max(t.elapsed().as_secs_f64());
        }
        sim.feeder.command(FeederCommand::Override(factor));
    }
    let t = std::time::Instant::now();
    sim.run_to_end(60_000);
    eprintln!(
        "override sim: {} cycles, {:?}, worst cycle incl. planning {:.1} ms, {:?}",
        sim.cycle,
        t.elapsed(),
        worst_chunk_s * 1e3,
        sim.feeder.stats
    );
    let v_at = |c: usize| sim.out[c].v_mm_s;
    eprintln!("v at 140: {:.1}, 290: {:.1}, 580: {:.1}, 900: {:.1}", v_at(140), v_at(290), v_at(580), v_at(900));
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(path_deviation_mm(&path, &sim.out) <= 1e-3);
    assert!(sim.out.iter().any(|s| s.feed_override == 1.5) && sim.out.iter().any(|s| s.feed_override == 0.3));
}

#[test]
fn smoothed_corner_is_passed_in_motion_within_the_limits() {
    let config = Config::default_machine();
    let text = "G21 G90 G17 G64 P0.05\nG1 X0 Y0 F6000\nG1 X40 Y0\nG1 X40 Y40\nG1 X0 Y40\n";
    let parsed = program::parse(text, "g64.ngc", &Settings::from(&config)).unwrap().path;
    let prepared = interpd_motion::prep::prepare_path(&Settings::from(&config), &parsed).unwrap();
    assert!(prepared.stats.windows > 0, "nothing was smoothed");
    let path = Arc::new(prepared.path);
    let mut sim = Sim::new(config.clone());
    sim.start(path.clone());
    sim.run_to_end(20_000);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(path_deviation_mm(&path, &sim.out) <= 1e-3);
    // Near the corner (40, 0) the machine keeps moving.
    let near: Vec<f64> = sim
        .out
        .iter()
        .filter(|s| ((s.pos[0] - 40.0).powi(2) + s.pos[1].powi(2)).sqrt() < 0.2)
        .map(|s| s.v_mm_s)
        .collect();
    assert!(!near.is_empty() && near.iter().all(|&v| v > 1.0), "stopped at the smoothed corner: {near:?}");
}

/// Runs `moves` collinear moves of 0.1 mm with a tool change at each (a change of state per
/// element), checking at every cycle that the track resolves the executing line to its tool;
/// returns the most changes the track held.
fn run_tool_changes(moves: usize) -> usize {
    use super::feeder::ProgramText;
    use super::tooling::Tooling;
    let mut text = String::from("G21 G90 G61\nF12000\n");
    for i in 0..moves {
        text.push_str(&format!("T{} M6 G1 X{:.1}\n", 1 + i % 2, 0.1 * (i + 1) as f64));
    }
    let mut sim = Sim::new(Config::default_machine());
    let track = sim.feeder.modal_track();
    let source = PathSource::Program {
        text: ProgramText::Text { name: "tools".into(), text: Arc::new(text) },
        here: [0.0; interpd_motion::path::MAX_AXES],
        tooling: Arc::new(Tooling::default()),
        appends: None,
    };
    sim.feeder.command(FeederCommand::Start { source, epoch: Epoch::FIRST, feed_override: 1.0, suspend: false });
    let (mut max_held, mut checked) = (0, 0);
    while !sim.finished() && sim.cycle < 50_000 {
        sim.cycle();
        let line = sim.out.last().unwrap().line;
        let t = super::lock(&track);
        max_held = max_held.max(t.len());
        let tool = t.at(line).expect("a state").tool.map(|t| t.number);
        // Line 3 + i holds move i with tool 1 + i % 2.
        let want = (line >= 3).then(|| 1 + (line - 3) % 2);
        assert_eq!(tool, want, "line {line}");
        checked += u32::from(line >= 3);
    }
    assert!(sim.finished());
    assert!(checked > 100, "{checked} cycles checked");
    max_held
}

#[test]
fn the_modal_track_follows_the_machine_in_bounded_memory() {
    // The track holds the changes of the path window (the queue behind the machine, the
    // look-ahead before it), whatever the program's length.
    let (short, long) = (run_tool_changes(5_000), run_tool_changes(10_000));
    eprintln!("modal track: at most {short} changes held of 5000, {long} of 10000");
    assert!(long <= short + short / 10, "the track grows with the program: {short} → {long} changes held");
    assert!(long < 10_000 / 2, "{long} changes held");
}

/// A stop that completes at rest empties the queue while the planner thread may still push
/// later chunks of the stopped start (it learns of the stop asynchronously); at rest the
/// executor must start none of them: their motion begins where the dropped first chunk ended,
/// so starting one is a jump (the fault campaign's fuzzing found it, 21.7 mm in one cycle).
#[test]
fn at_rest_only_the_first_chunk_of_an_epoch_starts() {
    let config = Config::default_machine();
    let mut sim = Sim::new(config.clone());
    let path = Arc::new(program::parse("G1 X50 F6000\n", "line.ngc", &Settings::from(&config)).unwrap().path);
    sim.start(path);
    sim.stop = true;
    for _ in 0..3 {
        sim.cycle();
    }
    let first = sim.queues.chunks.pop().expect("chunks queued while the stop holds the executor");
    assert_eq!(first.seq, 0);
    assert!(!sim.queues.chunks.is_empty(), "later chunks queued");
    sim.stop = false;
    for _ in 0..10 {
        sim.step_executor();
    }
    assert!(sim.out.iter().all(|s| s.pos[0] == 0.0), "moved: X = {}", sim.out.last().unwrap().pos[0]);
    assert!(!sim.seen.iter().any(|n| matches!(n, Notice::Started { .. })), "{:?}", sim.seen);
}

/// Runs `sim` until a pause notice, at most `max_cycles`; the index of that notice.
fn run_to_pause(sim: &mut Sim, max_cycles: u64) -> Option<usize> {
    let before = sim.seen.len();
    for _ in 0..max_cycles {
        sim.cycle();
        if let Some(i) = sim.seen[before..].iter().position(|n| matches!(n, Notice::Paused { .. })) {
            return Some(before + i);
        }
        if sim.finished() {
            return None;
        }
    }
    None
}

#[test]
fn program_stops_stand_exactly_until_released_and_m1_follows_the_switch() {
    use interpd_protocol::api::PauseCode;
    let text = "G21 G90 G1 F1200 X10\nM0\nG1 X20\nM1\nG1 X30\nM60\nG1 X40\nM2\n";
    let config = Config::default_machine();
    let path = Arc::new(program::parse(text, "stops.ngc", &Settings::from(&config)).unwrap().path);
    let mut sim = Sim::new(config.clone());
    sim.start(path.clone());
    // M0: stands at X10 with every setpoint constant while paused.
    let i = run_to_pause(&mut sim, 20_000).expect("paused at M0");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M0, line: 2, .. }), "{:?}", sim.seen[i]);
    let at = *sim.out.last().unwrap();
    assert!((at.pos[0] - 10.0).abs() < 1e-9 && at.v_mm_s.abs() < 1e-9, "{at:?}");
    for _ in 0..200 {
        sim.cycle();
    }
    for sp in &sim.out[sim.out.len() - 201..] {
        assert_eq!(sp.pos[..3], at.pos[..3], "a setpoint moved while paused");
        assert_ne!(sp.flags & interpd_protocol::shm::flags::PAUSED, 0);
    }
    // Released; M1 with the switch on pauses at X20.
    sim.releases += 1;
    let i = run_to_pause(&mut sim, 20_000).expect("paused at M1");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M1, line: 4, .. }), "{:?}", sim.seen[i]);
    assert!((sim.out.last().unwrap().pos[0] - 20.0).abs() < 1e-9);
    // Switch off: M60 still pauses, at X30.
    sim.optional_stop = false;
    sim.releases += 1;
    let i = run_to_pause(&mut sim, 20_000).expect("paused at M60");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M60, line: 6, .. }), "{:?}", sim.seen[i]);
    assert!((sim.out.last().unwrap().pos[0] - 30.0).abs() < 1e-9);
    sim.releases += 1;
    sim.run_to_end(20_000);
    assert!((sim.out.last().unwrap().pos[0] - 40.0).abs() < 1e-9);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(!sim.seen.iter().any(|n| matches!(n, Notice::Diverted { .. })), "nothing replanned: {:?}", sim.seen);
    // The switch off from the start: M1 is passed at its exact stop without waiting.
    let mut sim = Sim::new(config.clone());
    sim.optional_stop = false;
    sim.start(path);
    run_to_pause(&mut sim, 20_000).expect("M0");
    sim.releases += 1;
    let i = run_to_pause(&mut sim, 20_000).expect("M60");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M60, .. }), "M1 skipped: {:?}", sim.seen[i]);
}

#[test]
fn a_stop_while_paused_ends_the_program_where_it_stands() {
    let config = Config::default_machine();
    let text = "G21 G90 G1 F1200 X10\nM0\nG1 X20\nM2\n";
    let path = Arc::new(program::parse(text, "stop.ngc", &Settings::from(&config)).unwrap().path);
    let mut sim = Sim::new(config);
    sim.start(path);
    run_to_pause(&mut sim, 20_000).expect("paused");
    sim.stop = true;
    for _ in 0..10 {
        sim.cycle();
    }
    assert!(sim.seen.iter().any(|n| matches!(n, Notice::Stood { cause: DivertCause::Stop, .. })), "{:?}", sim.seen);
    let last = sim.out.last().unwrap();
    assert!((last.pos[0] - 10.0).abs() < 1e-9);
    assert_ne!(last.flags & interpd_protocol::shm::flags::IDLE, 0);
    assert!(!sim.finished());
}

#[test]
fn two_program_stops_in_one_chunk_both_stand_and_the_motion_between_keeps_its_time() {
    use interpd_protocol::api::PauseCode;
    // A move of 0.1 µm between two stops: both fall into one chunk.
    let text = "G21 G90 G1 F1200 X10\nM0\nG1 X10.0001\nM1\nG1 X20\nM2\n";
    let config = Config::default_machine();
    let path = Arc::new(program::parse(text, "stops2.ngc", &Settings::from(&config)).unwrap().path);
    let mut sim = Sim::new(config.clone());
    sim.start(path);
    let i = run_to_pause(&mut sim, 20_000).expect("paused at M0");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M0, .. }), "{:?}", sim.seen[i]);
    assert!((sim.out.last().unwrap().pos[0] - 10.0).abs() < 1e-9);
    sim.releases += 1;
    let i = run_to_pause(&mut sim, 20_000).expect("paused at M1");
    assert!(matches!(sim.seen[i], Notice::Paused { code: PauseCode::M1, .. }), "{:?}", sim.seen[i]);
    assert!((sim.out.last().unwrap().pos[0] - 10.0001).abs() < 1e-9, "{:?}", sim.out.last().unwrap().pos[0]);
    sim.releases += 1;
    sim.run_to_end(20_000);
    assert!((sim.out.last().unwrap().pos[0] - 20.0).abs() < 1e-9);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
}

#[test]
fn messages_come_when_the_motion_before_them_is_done_and_in_order_with_a_stop() {
    use interpd_protocol::api::PauseCode;
    // Message 1 after X10, 2 before the X20 move (same place), 3 before M0 and 4 after it (in
    // one place), 5 at the program end (no motion after it: the supervisor's part).
    let text =
        "G21 G90 G1 F1200 X10\n(MSG,one)\nG1 X20 (DEBUG,two)\n(MSG,three)\nM0\n(PRINT,four)\nG1 X30\n(MSG,five)\nM2\n";
    let config = Config::default_machine();
    let path = Arc::new(program::parse(text, "msgs.ngc", &Settings::from(&config)).unwrap().path);
    let mut sim = Sim::new(config.clone());
    sim.start(path);
    // Each notice with the setpoints of its cycle and the one before: the notice comes in the
    // first cycle at or past the message's place, an exact stop (v = 0 there).
    let mut got = Vec::new();
    while !sim.finished() && sim.cycle < 40_000 {
        let before = sim.seen.len();
        sim.cycle();
        let n_out = sim.out.len();
        let (prev, sp) = (sim.out[n_out.saturating_sub(2)], sim.out[n_out - 1]);
        for n in &sim.seen[before..] {
            match *n {
                Notice::Message { upto, .. } => got.push((format!("message {upto}"), prev.pos[0], sp.pos[0])),
                Notice::Paused { code: PauseCode::M0, line, .. } => {
                    got.push((format!("M0 line {line}"), prev.pos[0], sp.pos[0]));
                    sim.releases += 1;
                }
                _ => {}
            }
        }
    }
    assert!(sim.finished());
    let want = [("message 2", 10.0), ("message 3", 20.0), ("M0 line 5", 20.0), ("message 4", 20.0)];
    assert_eq!(got.len(), want.len(), "{got:?}");
    // From rest, one cycle (4 ms) moves less than 1 µm at this jerk.
    for ((what, x0, x1), (w, wx)) in got.iter().zip(want) {
        assert_eq!(what, w, "{got:?}");
        assert!(*x0 <= wx + 1e-9 && *x1 >= wx - 1e-9 && x1 - wx < 1e-3, "{what} at X{x0} → X{x1}: {got:?}");
    }
    // The stop itself stands exactly at its place.
    assert_eq!(got[2].2, 20.0);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
}
