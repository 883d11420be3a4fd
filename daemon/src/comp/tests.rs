#![allow(clippy::print_stdout)]

use super::*;
use interpd_config::Config;
use interpd_protocol::shm::{Measurement, Setpoints, measurement_flags};

const MACHINE: &str = include_str!("../../../examples/milling_circle.toml");
const DT: f64 = 0.004;
const DT_NS: u64 = 4_000_000;

fn config(strategy: &str) -> Config {
    let text = format!(
        "{MACHINE}\n[compensation]\n[compensation.measurement]\nforce_axes = [\"X\", \"Y\"]\nposition_axes = [\"X\", \
         \"Y\"]\nactuator_axes = [\"X\", \"Y\"]\n[[compensation.axis]]\nname = \"X\"\nstrategy = \"{strategy}\"\n\
         stiffness_pos_n_per_mm = 545.0\nstiffness_neg_n_per_mm = 545.0\ngap_mm = 0.228\n"
    );
    Config::from_toml_str(&text, "test").unwrap_or_else(|e| panic!("{e}"))
}

fn sample(seq: u64, t_ns: u64, x: f64, force: f64) -> Measurement {
    let mut m = Measurement {
        n_axes: 3,
        seq,
        measured_ns: t_ns,
        time_ns: t_ns + 3_700_000,
        flags: measurement_flags::POSITION | measurement_flags::FORCE | measurement_flags::ACTUATOR,
        ..Measurement::default()
    };
    m.tool_pos[..3].copy_from_slice(&[x, 0.0, 0.0]);
    m.force_n[0] = force;
    m.actuator_pos[..3].copy_from_slice(&[0.0; 3]);
    m
}

/// A nominal X stream: a sine within (1 − share) of the X limits of the machine.
fn nominal(k: u64) -> (f64, f64, f64) {
    // 250 mm/s, 2500 mm/s², 50 000 mm/s³ at 90 %: amplitude A, ω with Aω ≤ 225, Aω² ≤ 2250, Aω³ ≤ 45 000.
    let (a, w) = (10.0, 14.0);
    let t = k as f64 * DT;
    (a * (w * t).sin(), a * w * (w * t).cos(), -a * w * w * (w * t).sin())
}

fn setpoint(k: u64) -> Setpoints {
    let (p, v, a) = nominal(k);
    let mut sp = Setpoints { n_axes: 3, cycle: k, time_ns: 1_000_000_000 + k * DT_NS, ..Setpoints::default() };
    sp.pos[0] = p;
    sp.vel[0] = v;
    sp.acc[0] = a;
    sp
}

fn fd_ratios(xs: &[f64], c: &Config) -> (f64, f64, f64) {
    let ax = &c.axes[0];
    let v: Vec<f64> = xs.windows(2).map(|w| (w[1] - w[0]) / DT).collect();
    let a: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / DT).collect();
    let j: Vec<f64> = a.windows(2).map(|w| (w[1] - w[0]) / DT).collect();
    let m = |x: &[f64]| x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    (m(&v) / ax.max_vel_per_s, m(&a) / ax.max_acc_per_s2, m(&j) / ax.max_jerk_per_s3)
}

#[test]
fn the_corrected_stream_keeps_the_axis_limits() {
    for strategy in ["deflection", "position", "position+actuator"] {
        let c = config(strategy);
        let mut stage = Compensation::new(&c).expect("active");
        let mut out = Vec::new();
        let mut nominal_out = Vec::new();
        let mut seed = 7u64;
        for k in 0..3000u64 {
            let mut sp = setpoint(k);
            nominal_out.push(sp.pos[0]);
            // Violent measurements: errors jumping between 1.5 and −0.5 mm every 100 ms, forces
            // between 1000 and −333 N, noise of ±0.1 mm.
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let jump = if (k / 25) % 2 == 0 { 1.5 } else { -0.5 };
            let noise = ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.2;
            let mut m = sample(k, sp.time_ns - 2_000_000, sp.pos[0] - jump - noise, 1000.0 * jump / 1.5);
            // The actuator follows its command (mid-ranging hands its excursion to the axis).
            m.actuator_pos[0] = stage.actuator_command().pos[0];
            let mut once = Some(m);
            stage.apply(&mut sp, DT, || once.take());
            out.push(sp.pos[0]);
        }
        let nom = fd_ratios(&nominal_out, &c);
        let r = fd_ratios(&out, &c);
        println!("{strategy}: nominal uses {nom:.3?} of v, a, j; corrected {r:.3?}");
        assert!(nom.0 <= 0.9 && nom.1 <= 0.9 && nom.2 <= 0.9, "the nominal stream is within 90 %: {nom:?}");
        assert!(r.0 <= 1.0 + 1e-9 && r.1 <= 1.0 + 1e-9 && r.2 <= 1.0 + 1e-9, "{strategy}: {r:?}");
        assert!(stage.stats().limiter_clamps == 0, "{:?}", stage.stats());
        let moved = out.iter().zip(&nominal_out).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(moved > 0.01, "{strategy}: no correction at all ({moved} mm)");
    }
}

#[test]
fn a_measurement_that_stops_fades_the_correction_out_without_a_step() {
    let c = config("position");
    let mut stage = Compensation::new(&c).expect("active");
    let mut corrections = Vec::new();
    let mut events = Vec::new();
    for k in 0..1500u64 {
        let mut sp = Setpoints { n_axes: 3, cycle: k, time_ns: 1_000_000_000 + k * DT_NS, ..Setpoints::default() };
        // A 0.3 mm deflection measured until 3 s, then nothing.
        let mut m = (k < 750).then(|| sample(k, sp.time_ns - 2_000_000, stage.correction(0) - 0.3, 0.0));
        if let Some(e) = stage.apply(&mut sp, DT, || m.take()) {
            events.push((k, e));
        }
        corrections.push(sp.pos[0]);
    }
    let before = corrections[749];
    println!("correction at 3 s {before:.4} mm, events {events:?}");
    assert!((before - 0.3).abs() < 0.01, "the loop had corrected: {before}");
    // One lost event, 25 ms after the last sample (max_age_ms).
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(matches!(events[0], (k, CompEvent::Lost { .. }) if (754..=758).contains(&k)), "{events:?}");
    // No step: the largest change per cycle is far below the correction, and it ends at 0.
    let max_step = corrections.windows(2).skip(740).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    assert!(max_step < 0.02 * 0.3 * 4.0, "step {max_step}");
    assert!(corrections[1499].abs() < 1e-6, "faded out to {}", corrections[1499]);
    assert_eq!(stage.weight(), 0.0);
    assert_eq!(stage.stats().lost, 1);
}

#[test]
fn nan_and_absurd_measurements_are_discarded_and_counted() {
    let c = config("position");
    let mut stage = Compensation::new(&c).expect("active");
    let mut k = 0u64;
    let mut run = |stage: &mut Compensation, x: f64, force: f64| {
        let mut sp = Setpoints { n_axes: 3, cycle: k, time_ns: 1_000_000_000 + k * DT_NS, ..Setpoints::default() };
        let mut m = Some(sample(k, sp.time_ns - 2_000_000, x, force));
        stage.apply(&mut sp, DT, || m.take());
        k += 1;
        sp.pos[0]
    };
    // The tool sits 0.1 mm low: the loop corrects it.
    for _ in 0..1000 {
        let x = stage.correction(0) - 0.1;
        run(&mut stage, x, 0.0);
    }
    let settled = stage.correction(0);
    assert!((settled - 0.1).abs() < 0.005, "{settled}");
    let before = *stage.stats();
    for _ in 0..100 {
        let x = stage.correction(0) - 0.1;
        run(&mut stage, x, 0.0);
        run(&mut stage, f64::NAN, 0.0);
        run(&mut stage, 50.0, 0.0);
    }
    let s = *stage.stats();
    println!("{before:?} → {s:?}");
    assert_eq!(
        (s.discarded_invalid - before.discarded_invalid, s.discarded_absurd - before.discarded_absurd),
        (100, 100)
    );
    // Only the valid samples count (one in three cycles, within the allowed age): the
    // correction holds, nothing went stale.
    assert!((stage.correction(0) - 0.1).abs() < 0.005, "{}", stage.correction(0));
    assert_eq!(s.lost, 0);
}

#[test]
fn deflection_without_force_corrects_nothing() {
    let c = config("deflection");
    let mut stage = Compensation::new(&c).expect("active");
    let mut worst = 0.0_f64;
    for k in 0..1000u64 {
        let mut sp = setpoint(k);
        let p = sp.pos[0];
        let mut m = Some(sample(k, sp.time_ns - 2_000_000, p, 0.0));
        stage.apply(&mut sp, DT, || m.take());
        worst = worst.max((sp.pos[0] - p).abs());
    }
    assert!(worst < 1e-9, "{worst}");
    // With 200 N the correction is the model's: −(200/545 + 0.114) mm.
    for k in 1000..2000u64 {
        let mut sp = setpoint(k);
        let mut m = Some(sample(k, sp.time_ns - 2_000_000, sp.pos[0], 200.0));
        stage.apply(&mut sp, DT, || m.take());
    }
    let c0 = stage.correction(0);
    assert!((c0 + 200.0 / 545.0 + 0.114).abs() < 1e-3, "{c0}");
}
