//! Inspect one OTG problem: ours and Ruckig's duration, our profiles, and the independent
//! validation of both. The case is the literal the property test prints for a failure:
//!
//! ```sh
//! cargo run --release -p interpd-otg --example inspect -- 'case("Position/Time", &[[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 1.0, -1.0, 1.0, 1.0]])'
//! ```
#![allow(clippy::print_stdout)]

#[path = "../tests/common/mod.rs"]
mod common;

use interpd_otg::{Otg, Trajectory};

fn main() {
    let text = std::env::args().skip(1).collect::<Vec<_>>().join(" ");
    let Some(input) = common::parse_case(&text) else {
        eprintln!(
            "usage: inspect 'case(\"Position/Time\", &[[p0, v0, a0, pf, vf, af, v_min, v_max, a_min, a_max, j], ...])'"
        );
        std::process::exit(2);
    };
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let result = otg.calculate(&input, &mut traj);
    println!("ours: {result:?}, duration {:?}, limiting DoF {:?}", traj.duration(), traj.limiting_dof());
    println!("independent minimum durations: {:?}", traj.independent_min_durations());
    if result.is_ok() {
        for (dof, p) in traj.profiles().iter().enumerate() {
            println!("DoF {dof}: {:?} {:?} {:?}, duration {:?}", p.direction, p.control_signs, p.limits, p.duration());
            println!("  brake t {:?} j {:?}", p.brake.t, p.brake.j);
            println!("  t {:?}\n  j {:?}\n  a {:?}\n  v {:?}\n  p {:?}", p.t, p.j, p.a, p.v, p.p);
        }
        println!("validation of ours: {:?}", common::validate_ours(&input, &traj));
        compare(&input, &traj, common::validate_ours(&input, &traj).worst_target_dof);
    }
    let mut oracle = common::RuckigOracle::new(input.dofs);
    match oracle.calculate(&input) {
        Ok(d) => {
            let skip: Vec<f64> = traj.profiles().iter().map(|p| p.brake.duration).collect();
            let skip = if skip.len() == input.dofs { skip } else { vec![0.0; input.dofs] };
            println!("ruckig: duration {d:?}, validation {:?}", common::validate_ruckig(&input, &oracle, &skip));
        }
        Err(e) => println!("ruckig: {e:?}"),
    }
}

/// Integrate DoF `dof` phase by phase from the input's current state (as the validator does,
/// without its snapping) and print the boundary states next to the stored ones.
fn compare(input: &interpd_otg::Input, traj: &Trajectory, dof: usize) {
    let prof = &traj.profiles()[dof];
    let c = input.current[dof];
    let (mut p, mut v, mut a) = (c.p, c.v, c.a);
    for k in 0..2 {
        if prof.brake.t[k] > 0.0 {
            let t = prof.brake.t[k];
            let j = prof.brake.j[k];
            p += t * (v + t * (a / 2.0 + t * j / 6.0));
            v += t * (a + t * j / 2.0);
            a += t * j;
        }
    }
    println!("after brake: ({p:e}, {v:e}, {a:e}) ours ({:e}, {:e}, {:e})", prof.p[0], prof.v[0], prof.a[0]);
    for k in 0..7 {
        let (t, j) = (prof.t[k], prof.j[k]);
        p += t * (v + t * (a / 2.0 + t * j / 6.0));
        v += t * (a + t * j / 2.0);
        a += t * j;
        println!(
            "phase {k}: ({p:e}, {v:e}, {a:e}) ours ({:e}, {:e}, {:e})",
            prof.p[k + 1],
            prof.v[k + 1],
            prof.a[k + 1]
        );
    }
}
