//! Motion-law moves through the planner thread and the executor.

use super::*;

/// A law program started in the simulation from machine zero; returns its line path and the
/// total duration of its moves.
fn start_laws(sim: &mut Sim, text: &str) -> (Arc<Path>, f64) {
    let prog = crate::service::law_run::parse_law_program(text, "laws.ngc").unwrap().expect("a law program");
    let here = [0.0; interpd_motion::path::MAX_AXES];
    let moves = prog.moves(&Settings::from(&sim.config), &here, "laws.ngc").unwrap();
    let duration_s = moves.iter().map(interpd_motion::law::LawMove::duration_s).sum();
    let (path, laws) = crate::service::law_run::law_path(&Settings::from(&sim.config), moves, here, &prog.lines());
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
    let parse = |t: &str| crate::service::law_run::parse_law_program(t, "p.ngc");
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
