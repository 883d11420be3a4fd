//! Random sequences of control requests against the chain: what the executor reports is the
//! motion it runs, whatever the requests.

use super::*;

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
        text: crate::service::feeder::ProgramText::Text { name: "zigzag.ngc".into(), text: text.clone() },
        here,
        tooling: Arc::new(crate::service::tooling::Tooling::default()),
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
        | Notice::Line { cycle, .. }
        | Notice::Paused { cycle, .. }
        | Notice::Message { cycle, .. } => cycle,
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
