//! Real-time factor of the plant: simulated time / wall time for 5 axes at the servo rate,
//! against a baseline measured in the same run.
//!
//! ```sh
//! cargo bench -p sim-plant --bench realtime            # 20 s simulated per case
//! SIM_PLANT_BENCH_S=120 cargo bench -p sim-plant --bench realtime
//! ```
//!
//! Each case feeds 4 ms setpoints (jerk-limited moves back and forth on every axis, computed
//! beforehand) through [`Plant::step`]: drive fine interpolation, quantised encoder, cascade
//! controller, current loop, mechanics with backlash and friction. The baseline is the bare
//! linear state update z ← Φz + Γu of the same axes' exact discretisations for the same
//! number of servo steps: the floor any exact-discretisation plant pays. The plant must run 5 axes at ≥ 10 kHz at
//! least 20 × faster than real time, so that it never holds up the daemon it stands in for.
#![allow(clippy::print_stdout)]

use interpd_config::Config;
use interpd_config::plant::{PlantModel, ResolvedAxisPlant};
use nalgebra::{SMatrix, SVector};
use sim_plant::discretize::{Discrete, discretize};
use sim_plant::model::{TwoMass, three_mass};
use sim_plant::scenario::SCurve;
use sim_plant::{AxisTarget, Plant};
use std::hint::black_box;
use std::time::Instant;

const CYCLE_S: f64 = 0.004;
/// Required real-time factor: 5 axes at 10 kHz, 20 × faster than real time.
const REQUIRED_RTF: f64 = 20.0;

/// Setpoints for `n_axes` axes over `duration_s`: each axis runs ±`amplitude` back and forth at
/// its configured limits, phase-shifted so the axes do not move in lock-step.
fn setpoints(config: &Config, duration_s: f64) -> Vec<Vec<AxisTarget>> {
    let moves: Vec<(SCurve, SCurve)> = config
        .axes
        .iter()
        .map(|a| {
            let d = 20.0;
            (
                SCurve::new(-10.0, d, a.max_vel_per_s, a.max_acc_per_s2, a.max_jerk_per_s3),
                SCurve::new(10.0, -d, a.max_vel_per_s, a.max_acc_per_s2, a.max_jerk_per_s3),
            )
        })
        .collect();
    let n = (duration_s / CYCLE_S).round() as usize;
    (0..=n)
        .map(|k| {
            moves
                .iter()
                .enumerate()
                .map(|(i, (fwd, back))| {
                    // Period: forward, 0.1 s dwell, back, 0.1 s dwell.
                    let period = fwd.duration_s() + back.duration_s() + 0.2;
                    let t = (k as f64 * CYCLE_S + 0.05 * i as f64) % period;
                    let (p, v, a) =
                        if t < fwd.duration_s() + 0.1 { fwd.eval(t) } else { back.eval(t - fwd.duration_s() - 0.1) };
                    AxisTarget { pos: p, vel: v, acc: a }
                })
                .collect()
        })
        .collect()
}

/// Simulated seconds per wall second of the full plant, and the servo steps it took.
fn full_plant(config: &Config, sp: &[Vec<AxisTarget>]) -> (f64, u64) {
    let mut plant = Plant::from_config(config).expect("plant");
    let start = Instant::now();
    for targets in sp {
        black_box(plant.step(black_box(targets), CYCLE_S).expect("step"));
    }
    let wall = start.elapsed().as_secs_f64();
    let steps = (plant.time_s() / plant.servo_period_s()).round() as u64;
    (plant.time_s() / wall, steps)
}

/// The linear part of one axis: Φ, Γ of its (contact-regime) exact discretisation. Inline like
/// the plant's own models (no pointer chase per step), hence the size difference.
#[allow(clippy::large_enum_variant)]
enum Linear {
    Two(Discrete<5, 3>, SVector<f64, 5>),
    Three(Discrete<7, 3>, SVector<f64, 7>),
}

fn linear_model(r: &ResolvedAxisPlant, h_s: f64) -> Linear {
    let t_i = 1.0 / (2.0 * std::f64::consts::PI * r.drive.current_loop_hz);
    match &r.model {
        PlantModel::TwoMass(p) => {
            let (a, b) = TwoMass::new(p, t_i, h_s, 1).expect("model").continuous(t_i, p.stiffness_pos);
            Linear::Two(discretize(&a, &b, h_s).expect("discretise"), SVector::zeros())
        }
        PlantModel::ThreeMass(p) => {
            let (a, b) = three_mass::continuous(p, t_i);
            Linear::Three(discretize(&a, &b, h_s).expect("discretise"), SVector::zeros())
        }
    }
}

#[inline]
fn update<const N: usize>(d: &Discrete<N, 3>, z: &mut SVector<f64, N>, u: &SMatrix<f64, 3, 1>) {
    *z = d.phi * *z + d.gamma * u;
}

/// Simulated seconds per wall second of the bare linear update of the same axes.
fn baseline(config: &Config, steps: u64) -> f64 {
    let resolved = config.plant.resolve(&config.axes, "<bench>").expect("resolve");
    let h_s = config.plant.servo_period_s();
    let mut axes: Vec<Linear> = resolved.iter().map(|r| linear_model(r, h_s)).collect();
    let start = Instant::now();
    for k in 0..steps {
        // A bounded input that the optimiser cannot fold away.
        let u = SMatrix::<f64, 3, 1>::new(black_box(((k & 1023) as f64 - 511.5) * 1e-3), 0.0, 0.0);
        for a in axes.iter_mut() {
            match a {
                Linear::Two(d, z) => update(d, z, &u),
                Linear::Three(d, z) => update(d, z, &u),
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    for a in &axes {
        match a {
            Linear::Two(_, z) => black_box(z.sum()),
            Linear::Three(_, z) => black_box(z.sum()),
        };
    }
    steps as f64 * h_s / wall
}

fn case(title: &str, toml: &str, duration_s: f64) {
    let config = Config::from_toml_str(toml, title).expect("bench configuration");
    let sp = setpoints(&config, duration_s);
    // Warm-up (page faults, caches), then the measured runs.
    full_plant(&config, &sp[..sp.len().min(250)]);
    let (rtf, steps) = full_plant(&config, &sp);
    let base = baseline(&config, steps);
    let n = config.axes.len();
    let rate_hz = config.plant.servo_rate_hz;
    let ns_per_axis_step = 1e9 / (rtf * rate_hz * n as f64);
    println!(
        "{title}: {n} axes at {:.0} kHz, {duration_s:.0} s simulated: real-time factor {rtf:.1} ({ns_per_axis_step:.0} ns per \
         axis step); baseline Φz+Γu only: {base:.1}; full plant costs {:.2}× the baseline; requirement ≥ {REQUIRED_RTF:.0}×: {}",
        rate_hz * 1e-3,
        base / rtf,
        if rtf >= REQUIRED_RTF { "met" } else { "NOT MET" }
    );
}

fn main() {
    let duration_s = std::env::var("SIM_PLANT_BENCH_S").ok().and_then(|s| s.parse::<f64>().ok()).unwrap_or(20.0);
    let xyzab = interpd_config::FIVE_AXIS_MACHINE_TOML;
    case("xyzab (3 × haas-laser 3-mass, 2 × schneider-joint1)", xyzab, duration_s);
    case("xyzab at 20 kHz", &format!("{xyzab}\n[plant]\nservo_rate_hz = 20000.0\n"), duration_s);
    // Five two-mass axes with backlash, friction and the quantised encoder.
    let soft = xyzab
        .replace("kind = \"rotary\"", "kind = \"linear\"")
        .replace("name = \"A\"", "name = \"U\"")
        .replace("name = \"B\"", "name = \"V\"");
    case("5 × schneider-soft (backlash)", &format!("{soft}\n[plant]\npreset = \"schneider-soft\"\n"), duration_s);
}
