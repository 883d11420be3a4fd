//! Property test against Ruckig (the C++ library through the `ruckig` crate): random problems
//! over six decades of limits, states inside and outside the limits, 1 to 6 DoFs, position and
//! velocity interface, time and phase synchronisation.
//!
//! For every problem our trajectory is integrated independently and must reach the target
//! (relative 1e-8) and respect the limits (relative 1e-9); its duration must equal Ruckig's
//! (relative 1e-6). Where the durations differ, both trajectories are validated by sampling:
//! ours failing, or ours being longer than a valid Ruckig trajectory, fails the test.

mod common;

use common::{KINDS, Kind, Rng, RuckigOracle, fmt_input, random_problem, validate_ours, validate_ruckig};
use interpd_otg::{Otg, Trajectory};
use std::collections::BTreeMap;

const DURATION_REL_TOL: f64 = 1e-6;

#[derive(Default, Debug)]
struct Stats {
    problems: usize,
    ours_failed: usize,
    equal: usize,
    ours_shorter_valid: usize,
    ruckig_invalid: usize,
    ruckig_error: usize,
    ruckig_longer_invalid: usize,
    max_target_err: f64,
    max_limit_excess: f64,
    max_duration_rel_diff_when_equal: f64,
}

fn problems_per_kind() -> usize {
    std::env::var("OTG_PROBLEMS").ok().and_then(|s| s.parse().ok()).unwrap_or(20_000)
}

#[test]
fn random_problems_match_ruckig() {
    let per_kind = problems_per_kind();
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut oracles: Vec<RuckigOracle> = (0..=6).map(RuckigOracle::new).collect();
    let mut stats: BTreeMap<(Kind, usize), Stats> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut rng = Rng::new(0x07C0_FFEE);
    let mut err_hist = [0usize; 4];
    let mut shown_err = 0;
    for &kind in &KINDS {
        for i in 0..per_kind {
            let dofs = [1, 1, 2, 3, 6][i % 5];
            let input = random_problem(&mut rng, kind, dofs);
            let st = stats.entry((kind, dofs)).or_default();
            st.problems += 1;
            let ours = otg.calculate(&input, &mut traj);
            if let Err(e) = ours {
                st.ours_failed += 1;
                let variant = format!("{e:?}");
                let variant = variant.split([' ', '{']).next().unwrap_or("").to_string();
                failures.push((format!("{kind:?} error {variant}"), format!("{e}: {}", fmt_input(&input))));
                continue;
            }
            let val = validate_ours(&input, &traj);
            if let Ok(t) = std::env::var("OTG_SHOW_ERR") {
                let t: f64 = t.parse().unwrap_or(1e-9);
                if val.target_err > t && shown_err < 400 {
                    shown_err += 1;
                    eprintln!("ERR {kind:?} {:e} dof {}: {}", val.target_err, val.dof, fmt_input(&input));
                }
            }
            for (k, threshold) in [1e-12, 1e-11, 1e-10, 1e-9].iter().enumerate() {
                if val.target_err > *threshold {
                    err_hist[k] += 1;
                }
            }
            st.max_target_err = st.max_target_err.max(val.target_err);
            st.max_limit_excess = st.max_limit_excess.max(val.limit_excess);
            if !val.ok {
                st.ours_failed += 1;
                failures.push((
                    format!("{kind:?} invalid: {}", val.reason),
                    format!("err {:e}, excess {:e}: {}", val.target_err, val.limit_excess, fmt_input(&input)),
                ));
                continue;
            }
            if kind == Kind::Asymmetric {
                // No oracle (the bindings cannot set asymmetric limits): validity only.
                st.equal += 1;
                continue;
            }
            let oracle = &mut oracles[dofs];
            let d_ours = traj.duration();
            match oracle.calculate(&input) {
                Err(_) => st.ruckig_error += 1,
                Ok(d_ruckig) => {
                    let diff = (d_ours - d_ruckig).abs();
                    let rel = diff / d_ours.max(d_ruckig).max(1e-300);
                    if rel <= DURATION_REL_TOL || diff < 1e-12 {
                        st.equal += 1;
                        st.max_duration_rel_diff_when_equal = st.max_duration_rel_diff_when_equal.max(rel);
                        continue;
                    }
                    let skip: Vec<f64> = traj.profiles().iter().map(|p| p.brake.duration).collect();
                    let rv = validate_ruckig(&input, oracle, &skip);
                    if !rv.ok {
                        st.ruckig_invalid += 1;
                        if d_ruckig > d_ours {
                            st.ruckig_longer_invalid += 1;
                        }
                    } else if d_ours < d_ruckig {
                        st.ours_shorter_valid += 1;
                    } else {
                        st.ours_failed += 1;
                        failures.push((
                            format!("{kind:?} not optimal"),
                            format!("ours {d_ours} > ruckig {d_ruckig} (valid): {}", fmt_input(&input)),
                        ));
                    }
                }
            }
        }
    }
    let mut total = Stats::default();
    eprintln!(
        "kind          dofs  problems  equal  ours<R(valid)  R-invalid  R-error  ours-failed  max-target-err  max-limit-excess"
    );
    for ((kind, dofs), s) in &stats {
        eprintln!(
            "{:<13} {:>4} {:>9} {:>6} {:>14} {:>10} {:>8} {:>12} {:>15.2e} {:>17.2e}",
            format!("{kind:?}"),
            dofs,
            s.problems,
            s.equal,
            s.ours_shorter_valid,
            s.ruckig_invalid,
            s.ruckig_error,
            s.ours_failed,
            s.max_target_err,
            s.max_limit_excess
        );
        total.problems += s.problems;
        total.equal += s.equal;
        total.ours_failed += s.ours_failed;
        total.ruckig_error += s.ruckig_error;
        total.ruckig_invalid += s.ruckig_invalid;
        total.ours_shorter_valid += s.ours_shorter_valid;
        total.max_target_err = total.max_target_err.max(s.max_target_err);
        total.max_limit_excess = total.max_limit_excess.max(s.max_limit_excess);
        total.max_duration_rel_diff_when_equal =
            total.max_duration_rel_diff_when_equal.max(s.max_duration_rel_diff_when_equal);
    }
    eprintln!("total: {total:?}");
    eprintln!("target errors above 1e-12, 1e-11, 1e-10, 1e-9: {err_hist:?}");
    let mut classes: BTreeMap<&str, usize> = BTreeMap::new();
    for (class, detail) in &failures {
        let n = classes.entry(class).or_default();
        *n += 1;
        if *n <= 3 {
            eprintln!("FAIL {class}: {detail}");
        }
    }
    for (class, n) in &classes {
        eprintln!("failure class {class}: {n}");
    }
    assert!(failures.is_empty(), "{} failures of ours", failures.len());
}
