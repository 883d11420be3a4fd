//! The planner thread and the executor driven in lockstep in simulated time: the whole chain
//! from program to setpoints, deterministic, without threads or clocks.

use super::feeder::{Feeder, FeederCommand, FeederReport, Queues};
use super::path_feed::PathSource;
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

/// A law program started in the simulation from machine zero; returns its line path and the
/// total duration of its moves.
fn start_laws(sim: &mut Sim, text: &str) -> (Arc<Path>, f64) {
    let prog = super::law_run::parse_law_program(text, "laws.ngc").unwrap().expect("a law program");
    let here = [0.0; interpd_motion::path::MAX_AXES];
    let moves = prog.moves(&Settings::from(&sim.config), &here, "laws.ngc").unwrap();
    let duration_s = moves.iter().map(interpd_motion::law::LawMove::duration_s).sum();
    let (path, laws) = super::law_run::law_path(&Settings::from(&sim.config), moves, here, &prog.lines());
    let path = Arc::new(path);
    sim.feeder.command(FeederCommand::StartLaws {
        path: path.clone(),
        laws: Box::new(laws),
        epoch: Epoch::FIRST,
        feed_override: 1.0,
    });
    (path, duration_s)
}

const LAW_PROGRAM: &str = "; three law moves\nLAW PRESET=rr7 DURATION=0.4 X=30 Y=-10\n\nLAW PRESET=rr5 DURATION=0.25 Z=5\nLAW PRESET=asymmetric DURATION=0.05 X=-20 STRETCH\n";

fn assert_ends_at(sim: &Sim, want: [f64; 3]) {
    let last = sim.out.last().unwrap();
    for (k, w) in want.iter().enumerate() {
        assert!((last.pos[k] - w).abs() < 1e-9, "axis {k} ends at {} not {w}", last.pos[k]);
    }
}

#[test]
fn law_moves_run_their_time_profile_within_the_limits_to_the_exact_stroke() {
    let config = Config::default_machine();
    let mut sim = Sim::new(config.clone());
    let (path, duration_s) = start_laws(&mut sim, LAW_PROGRAM);
    sim.run_to_end(5_000);
    assert_ends_at(&sim, [10.0, -10.0, 5.0]);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(r[1] > 0.5, "the stretched move should use its limit: {r:?}");
    assert!(path_deviation_mm(&path, &sim.out) <= 1e-3);
    let moving = sim.out.iter().filter(|s| s.v_mm_s.abs() > 1e-9).count() as f64 * config.cycle_s();
    assert!((moving - duration_s).abs() <= 4.0 * config.cycle_s(), "moved {moving} s, laws take {duration_s} s");
    assert!(!sim.seen.iter().any(|n| matches!(n, Notice::Diverted { .. })), "diverted: {:?}", sim.seen);
}

#[test]
fn law_move_is_held_on_its_line_and_completed_after_resume() {
    let config = Config::default_machine();
    let mut sim = Sim::new(config.clone());
    let (path, _) = start_laws(&mut sim, LAW_PROGRAM);
    for _ in 0..40 {
        sim.cycle();
    }
    sim.hold = true;
    for _ in 0..100 {
        sim.cycle();
    }
    assert!(sim.seen.iter().any(|n| matches!(n, Notice::Stood { cause: DivertCause::Hold, .. })), "{:?}", sim.seen);
    sim.hold = false;
    sim.feeder.command(FeederCommand::Resume);
    sim.run_to_end(10_000);
    assert_ends_at(&sim, [10.0, -10.0, 5.0]);
    let r = stream_ratios(&config, &sim.out);
    assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "limits: {r:?}");
    assert!(path_deviation_mm(&path, &sim.out) <= 1e-3);
}

#[test]
fn law_program_errors_name_the_line() {
    let config = Config::default_machine();
    let parse = |t: &str| super::law_run::parse_law_program(t, "p.ngc");
    assert_eq!(parse("G1 X1 F100\n").unwrap(), None);
    let mixed = parse("LAW PRESET=rr7 DURATION=1 X=1\nG1 X2\n").unwrap_err().to_string();
    assert!(mixed.starts_with("p.ngc:2: \"G1 X2\""), "{mixed}");
    let syntax = parse("LAW PRESET=rr7 X=1\n").unwrap_err().to_string();
    assert_eq!(syntax, "p.ngc:1:19: DURATION=<seconds> is missing");
    let fast = parse("\nLAW PRESET=rr7 DURATION=0.1 X=30\n").unwrap().unwrap();
    let e =
        fast.moves(&Settings::from(&config), &[0.0; interpd_motion::path::MAX_AXES], "p.ngc").unwrap_err().to_string();
    assert!(e.starts_with("p.ngc:2: axis X") && e.contains("grow by a factor of"), "{e}");
}

/// Runs `moves` collinear moves of 0.1 mm with a tool change at each (a change of state per
/// element), checking at every cycle that the track resolves the executing line to its tool;
/// returns the most changes the track held.
fn run_tool_changes(moves: usize) -> usize {
    use super::path_feed::{ProgramText, Tooling};
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

/// Uniform in [0, 1) from proptest's deterministic generator (the command sequences below).
fn unit(rng: &mut proptest::test_runner::TestRng) -> f64 {
    use proptest::prelude::RngCore;
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// Largest disagreement between the setpoints' reported velocity and acceleration and their
/// positions (central differences at the cycle), as a share of the axis limit.
pub(crate) fn reported_disagreement(config: &Config, out: &[Setpoints]) -> (f64, f64, u64) {
    let dt = config.cycle_s();
    let (mut dv, mut da, mut at) = (0.0f64, 0.0f64, 0);
    for w in out.windows(3) {
        if w[1].cycle != w[0].cycle + 1 || w[2].cycle != w[1].cycle + 1 {
            continue;
        }
        for (k, ax) in config.axes.iter().enumerate() {
            let v = (w[2].pos[k] - w[0].pos[k]) / (2.0 * dt);
            let a = (w[2].pos[k] - 2.0 * w[1].pos[k] + w[0].pos[k]) / (dt * dt);
            dv = dv.max((w[1].vel[k] - v).abs() / ax.max_vel_per_s);
            let e = (w[1].acc[k] - a).abs() / ax.max_acc_per_s2;
            if e > da {
                da = e;
                at = w[1].cycle;
            }
        }
    }
    (dv, da, at)
}

/// Largest |acceleration| / limit of the quintic of any piece of `points` (main motion or
/// tail) at 32 interior instants: what any cycle landing in the piece would report. With the
/// piece's start index.
fn piece_acc_ratio(config: &Config, points: &[crate::interp::CoarsePoint]) -> (f64, usize) {
    const SAMPLES: usize = 32;
    let mut worst = (0.0f64, 0);
    for (i, w) in points.windows(2).enumerate() {
        let h = w[1].t_s - w[0].t_s;
        for c in 0..=SAMPLES {
            let tau = h * c as f64 / SAMPLES as f64;
            for (k, ax) in config.axes.iter().enumerate() {
                let q = crate::interp::hermite::eval(w[0].axis(k), w[1].axis(k), h, tau);
                let r = q.a.abs() / ax.max_acc_per_s2;
                if r > worst.0 || r.is_nan() {
                    worst = (r, i);
                }
            }
        }
    }
    worst
}

/// Checks the chunks queued since the last call (the queue is emptied and refilled in order;
/// `checked` holds the epoch and sequence number of those seen): the largest piece
/// acceleration ratio of their points and tails, and a description of the worst.
fn check_queued(sim: &Sim, checked: &mut std::collections::HashSet<(Epoch, u64)>, worst: &mut (f64, String)) {
    let mut held = Vec::new();
    while let Some(c) = sim.queues.chunks.pop() {
        if !checked.insert((c.epoch, c.seq)) {
            held.push(c);
            continue;
        }
        for (what, pts) in [("points", &c.points), ("tail", &c.tail)] {
            let (r, i) = piece_acc_ratio(&sim.config, pts);
            if r > worst.0 || r.is_nan() {
                let piece = &pts[i..(i + 2).min(pts.len())];
                *worst = (
                    r,
                    format!(
                        "epoch {} seq {} {what} piece {i} of {} at cycle {}: h {:e} s, {piece:?}",
                        c.epoch,
                        c.seq,
                        pts.len(),
                        sim.cycle,
                        piece[piece.len() - 1].t_s - piece[0].t_s
                    ),
                );
            }
        }
        held.push(c);
    }
    for c in held {
        assert!(sim.queues.chunks.push(c).is_ok());
    }
}

/// The control side's requests in random order and at random moments, with a planner thread
/// that now and then falls behind, on a smoothed zigzag (the program of the fault campaign's
/// fuzzing): the setpoints keep the limits, and what they report as velocity and acceleration
/// is the motion of their positions (a drive may use them as feed-forward).
#[test]
fn random_requests_keep_the_reported_state_the_motion() {
    let config = Config::default_machine();
    let mut text = String::from("G21 G90 G64 P0.01\nG1 X100 Y0 F3000\n");
    for i in 1..=400 {
        let x = ((i % 200) as f64 - 100.0).abs();
        text.push_str(&format!("G1 X{x} Y{}\n", if i % 2 == 0 { 0.0 } else { 2.0 }));
    }
    let text = Arc::new(text);
    let source = |here| PathSource::Program {
        text: super::path_feed::ProgramText::Text { name: "zigzag.ngc".into(), text: text.clone() },
        here,
        tooling: Arc::new(super::path_feed::Tooling::default()),
        appends: None,
    };
    let seeds: u64 = std::env::var("SIM_REQUEST_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(6);
    let only: Option<u64> = std::env::var("SIM_REQUEST_SEED").ok().and_then(|s| s.parse().ok());
    for seed in (1..=seeds).filter(|s| only.is_none_or(|o| o == *s)) {
        let trace = only.is_some();
        let mut seed_bytes = [0u8; 32];
        seed_bytes[..8].copy_from_slice(&seed.to_le_bytes());
        let mut rng =
            proptest::test_runner::TestRng::from_seed(proptest::test_runner::RngAlgorithm::ChaCha, &seed_bytes);
        let mut sim = Sim::new(config.clone());
        let mut epochs = crate::interp::Epochs::default();
        let first = epochs.start();
        sim.feeder.command(FeederCommand::Start {
            source: source([0.0; interpd_motion::path::MAX_AXES]),
            epoch: first,
            feed_override: 1.0,
            suspend: false,
        });
        let mut lag = 0u32;
        let mut worst_piece = (0.0, String::new());
        let mut checked = std::collections::HashSet::new();
        while sim.cycle < 6000 {
            let roll = unit(&mut rng);
            if trace && roll < 0.024 {
                eprintln!("cycle {} roll {roll:.4} hold {} phase {:?}", sim.cycle, sim.hold, sim.executor.phase());
            }
            if roll < 0.01 {
                sim.feeder.command(FeederCommand::Override(0.1 + 1.9 * unit(&mut rng)));
            } else if roll < 0.014 {
                sim.hold = true;
            } else if roll < 0.02 && sim.hold {
                sim.hold = false;
                sim.feeder.command(FeederCommand::Resume);
            } else if roll < 0.022 {
                // The planner thread falls behind for a while.
                lag = (unit(&mut rng) * 60.0) as u32;
            } else if roll < 0.023 && !sim.hold && sim.executor.phase() == crate::interp::Phase::Standing {
                sim.stop = false;
                let epoch = epochs.start();
                if trace {
                    eprintln!("start {epoch}");
                }
                let here = sim.out.last().map_or([0.0; interpd_motion::path::MAX_AXES], |s| s.pos);
                sim.feeder.command(FeederCommand::Start {
                    source: source(here),
                    epoch,
                    feed_override: 0.1 + 1.9 * unit(&mut rng),
                    suspend: false,
                });
            } else if roll < 0.024 {
                sim.stop = true;
                sim.epoch_floor = sim.epoch_floor.max(epochs.floor());
                sim.feeder.command(FeederCommand::Abort);
            }
            if lag > 0 {
                lag -= 1;
                sim.feeder.reclaim();
                sim.step_executor();
            } else {
                sim.feeder.reclaim();
                while sim.feeder.wants_to_produce() {
                    sim.feeder.produce();
                }
                // With the queue full the thread reads ahead; on some cycles it has not got to it.
                if sim.cycle % 3 != 0 {
                    while sim.feeder.wants_to_read_ahead() {
                        sim.feeder.read_ahead();
                    }
                }
                check_queued(&sim, &mut checked, &mut worst_piece);
                sim.step_executor();
            }
            for n in &sim.seen {
                if let Notice::Started { epoch, .. } | Notice::Diverted { epoch, .. } = n {
                    epochs.saw(*epoch);
                }
            }
        }
        let r = stream_ratios(&config, &sim.out);
        let (dv, da, at) = reported_disagreement(&config, &sim.out);
        let axes = &config.axes;
        let reported_acc = sim
            .out
            .iter()
            .flat_map(|s| axes.iter().enumerate().map(move |(k, ax)| s.acc[k].abs() / ax.max_acc_per_s2))
            .fold(0.0, f64::max);
        eprintln!(
            "seed {seed}: limits {r:.4?}, reported acc {reported_acc:.4}; disagreement v {dv:.4} a {da:.4} (cycle {at}); \
             {:?}",
            sim.feeder.stats
        );
        if da > 0.05 {
            for s in sim.out.iter().filter(|s| s.cycle + 4 >= at && s.cycle <= at + 3) {
                eprintln!(
                    "cycle {} flags {:#x} s {:.6} v {:.4} a {:.2} pos {:.9?} vel {:.4?} acc {:.2?}",
                    s.cycle,
                    s.flags,
                    s.s_mm,
                    s.v_mm_s,
                    s.a_mm_s2,
                    &s.pos[..3],
                    &s.vel[..3],
                    &s.acc[..3]
                );
            }
            let back = if trace { 200 } else { 20 };
            for n in sim.seen.iter().filter(|n| notice_cycle(n) + back >= at && notice_cycle(n) <= at + 2) {
                eprintln!("{n:?}");
            }
        }
        if worst_piece.0 > 1.001 {
            eprintln!("seed {seed}: worst piece acceleration {:.4} of the limit: {}", worst_piece.0, worst_piece.1);
        }
        assert!(r[0] <= 1.001 && r[1] <= 1.001 && r[2] <= 1.02, "seed {seed}: limits {r:?}");
        assert!(worst_piece.0 <= 1.001, "seed {seed}: a piece reaches {} of the acceleration limit", worst_piece.0);
        assert!(reported_acc <= 1.001, "seed {seed}: reported acceleration {reported_acc} of the limit");
        assert!(dv <= 0.01 && da <= 0.05, "seed {seed}: reported v/a disagree with the positions: {dv} {da} at {at}");
    }
}

fn notice_cycle(n: &Notice) -> u64 {
    match *n {
        Notice::Started { cycle, .. }
        | Notice::Diverted { cycle, .. }
        | Notice::Stood { cycle, .. }
        | Notice::Finished { cycle, .. }
        | Notice::Line { cycle, .. } => cycle,
    }
}

/// A stop while the planner thread is still queueing the restart of a resume: those chunks
/// (the first of their epoch, from where the machine stands) arrive after the stop completed
/// and the queue was emptied. Below the floor the stop published, they never start.
#[test]
fn a_restart_queued_after_a_stop_never_runs() {
    let config = Config::default_machine();
    let mut sim = Sim::new(config.clone());
    let mut epochs = crate::interp::Epochs::default();
    let path = Arc::new(program::parse("G1 X50 F6000\n", "line.ngc", &Settings::from(&config)).unwrap().path);
    let first = epochs.start();
    sim.feeder.command(FeederCommand::Start {
        source: PathSource::Whole(path),
        epoch: first,
        feed_override: 1.0,
        suspend: false,
    });
    for _ in 0..40 {
        sim.cycle();
    }
    sim.hold = true;
    while !sim.seen.iter().any(|n| matches!(n, Notice::Stood { .. })) {
        sim.cycle();
    }
    for n in &sim.seen {
        if let Notice::Started { epoch, .. } | Notice::Diverted { epoch, .. } = n {
            epochs.saw(*epoch);
        }
    }
    let held = sim.out.last().unwrap().pos;
    // Resume, then a stop before the restart is queued; the stop completes (queue emptied).
    sim.hold = false;
    sim.feeder.command(FeederCommand::Resume);
    sim.stop = true;
    sim.epoch_floor = epochs.floor();
    sim.step_executor();
    while sim.queues.chunks.pop().is_some() {}
    // The planner thread, still on the resume, queues the restart; then the abort arrives.
    while sim.feeder.wants_to_produce() {
        sim.feeder.produce();
    }
    assert!(!sim.queues.chunks.is_empty(), "the restart is queued");
    sim.feeder.command(FeederCommand::Abort);
    sim.stop = false;
    for _ in 0..20 {
        sim.step_executor();
    }
    let moved = sim.out.iter().rev().take(20).map(|s| (s.pos[0] - held[0]).abs()).fold(0.0, f64::max);
    assert!(moved == 0.0, "the stopped program moved on by {moved} mm");
    assert_eq!(sim.seen.iter().filter(|n| matches!(n, Notice::Started { .. })).count(), 1, "{:?}", sim.seen);
}
