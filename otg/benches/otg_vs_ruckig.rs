//! Calculation time of our OTG against Ruckig (C++, through the `ruckig` crate) in the same
//! run, on the same random problems (states inside and outside the limits, limits over six
//! decades, position interface, time synchronisation), for 1, 3 and 6 DoFs.
//!
//! Criterion measures the mean time per calculation (cycling through the problem set, ours and
//! Ruckig one after the other). After it, a table is printed from measurements interleaved
//! problem by problem (ours, then Ruckig), so that both see the same machine load: per problem
//! the median of its repetitions (a single sample may include a preemption on a shared machine),
//! then the mean and the largest of these medians over the problem set, and the ratios
//! ours/Ruckig.
//!
//! Ruckig's figures include its Rust wrapper's copy of the input into C++ `std::vector`s on
//! every call (the wrapper offers no other way to call it).
//!
//! ```sh
//! cargo bench -p interpd-otg --bench otg_vs_ruckig
//! ```
#![allow(clippy::print_stdout)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::{Kind, Rng, RuckigOracle, random_problem};
use criterion::Criterion;
use interpd_otg::{Input, Otg, Trajectory};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Problems per DoF count.
const PROBLEMS: usize = 2000;
/// Repetitions per problem for the table.
const REPEATS: usize = 15;
/// Calculations per timed sample (amortises the clock read).
const BATCH: usize = 4;
const DOFS: [usize; 3] = [1, 3, 6];

/// Random problems that both generators solve (kinds Scaled and OutsideLimits).
fn problems(dofs: usize, oracle: &mut RuckigOracle) -> Vec<Input> {
    let mut rng = Rng::new(0xBE4C_0000 + dofs as u64);
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut out = Vec::with_capacity(PROBLEMS);
    while out.len() < PROBLEMS {
        let kind = if out.len() % 4 == 3 { Kind::OutsideLimits } else { Kind::Scaled };
        let input = random_problem(&mut rng, kind, dofs);
        if otg.calculate(&input, &mut traj).is_ok() && oracle.calculate(&input).is_ok() {
            out.push(input);
        }
    }
    out
}

fn time_batch(f: &mut impl FnMut()) -> f64 {
    let start = Instant::now();
    for _ in 0..BATCH {
        f();
    }
    start.elapsed().as_secs_f64() / BATCH as f64
}

/// Median of each row.
fn medians(samples: &mut [[f64; REPEATS]]) -> impl Iterator<Item = f64> + '_ {
    samples.iter_mut().map(|s| {
        s.sort_by(f64::total_cmp);
        s[REPEATS / 2]
    })
}

/// (mean, worst) over `problems` of the per-problem median time [s], ours and Ruckig's. The
/// repetitions are passes over the whole set (a preemption hits one repetition of a problem, not
/// all), ours and Ruckig interleaved problem by problem.
fn table_row(problems: &[Input], oracle: &mut RuckigOracle) -> ([f64; 2], [f64; 2]) {
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut inputs: Vec<ruckig::InputParameter> = problems.iter().map(|i| oracle.make_input(i)).collect();
    let mut ours = vec![[0.0f64; REPEATS]; problems.len()];
    let mut theirs = vec![[0.0f64; REPEATS]; problems.len()];
    for r in 0..REPEATS {
        for (k, input) in problems.iter().enumerate() {
            ours[k][r] = time_batch(&mut || {
                let _ = black_box(otg.calculate(black_box(input), &mut traj));
            });
            let ri = &mut inputs[k];
            theirs[k][r] = time_batch(&mut || {
                let _ = black_box(oracle.otg.calculate(ri, &mut oracle.trajectory));
            });
        }
    }
    let n = problems.len() as f64;
    let mut mean = [0.0f64; 2];
    let mut worst = [0.0f64; 2];
    for (k, samples) in [&mut ours, &mut theirs].into_iter().enumerate() {
        for m in medians(samples) {
            mean[k] += m / n;
            worst[k] = worst[k].max(m);
        }
    }
    (mean, worst)
}

/// Worst per-problem median time of ours over every kind of the property test (including
/// asymmetric limits, velocity interface, phase synchronisation and the extreme independent
/// limits), repetitions as passes over the set.
fn worst_over_all_kinds(dofs: usize) -> f64 {
    let mut rng = Rng::new(0x5EED_0000 + dofs as u64);
    let problems: Vec<Input> = common::KINDS
        .iter()
        .flat_map(|&kind| (0..PROBLEMS / 4).map(move |_| kind))
        .map(|kind| random_problem(&mut rng, kind, dofs))
        .collect();
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut samples = vec![[0.0f64; REPEATS]; problems.len()];
    for r in 0..REPEATS {
        for (row, input) in samples.iter_mut().zip(&problems) {
            row[r] = time_batch(&mut || {
                let _ = black_box(otg.calculate(black_box(input), &mut traj));
            });
        }
    }
    medians(&mut samples).fold(0.0, f64::max)
}

fn main() {
    let mut criterion = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(30)
        .configure_from_args();
    let mut sets = Vec::new();
    for dofs in DOFS {
        let mut oracle = RuckigOracle::new(dofs);
        let set = problems(dofs, &mut oracle);
        let mut group = criterion.benchmark_group(format!("calculate_{dofs}dof"));
        let mut otg = Otg::new();
        let mut traj = Trajectory::default();
        let mut k = 0;
        group.bench_function("ours", |b| {
            b.iter(|| {
                k = (k + 1) % set.len();
                black_box(otg.calculate(black_box(&set[k]), &mut traj))
            })
        });
        let mut inputs: Vec<ruckig::InputParameter> = set.iter().map(|i| oracle.make_input(i)).collect();
        let mut k = 0;
        group.bench_function("ruckig", |b| {
            b.iter(|| {
                k = (k + 1) % inputs.len();
                black_box(oracle.otg.calculate(&mut inputs[k], &mut oracle.trajectory))
            })
        });
        group.finish();
        sets.push((dofs, set, oracle));
    }
    criterion.final_summary();

    println!();
    println!(
        "calculation time: median of {REPEATS} repetitions per problem, mean and largest over {PROBLEMS} problems \
         (interleaved with Ruckig); last column: largest over every kind of the property test"
    );
    println!(
        "{:>4}  {:>12} {:>12} {:>7}   {:>12} {:>12} {:>7}   {:>16}",
        "dofs", "ours mean", "ruckig mean", "ratio", "ours worst", "ruckig worst", "ratio", "ours worst (all)"
    );
    for (dofs, set, oracle) in &mut sets {
        let (mean, worst) = table_row(set, oracle);
        let all = worst_over_all_kinds(*dofs);
        println!(
            "{:>4}  {:>10.2}µs {:>10.2}µs {:>7.2}   {:>10.2}µs {:>10.2}µs {:>7.2}   {:>14.2}µs",
            dofs,
            mean[0] * 1e6,
            mean[1] * 1e6,
            mean[0] / mean[1],
            worst[0] * 1e6,
            worst[1] * 1e6,
            worst[0] / worst[1],
            all * 1e6
        );
    }
}
