//! Property test against Ruckig (the C++ library through the `ruckig` crate): random problems
//! with states inside and outside the limits, limits over six decades, 1 to 6 DoFs, position and
//! velocity interface, time and phase synchronisation, asymmetric limits and discrete durations
//! (see `common::Kind`).
//!
//! For every problem our trajectory is integrated independently and must reach the target
//! (1e-8 relative to max(1, magnitude)) and respect the limits (1e-9 relative); its duration must
//! equal Ruckig's (1e-6 relative). Where the durations differ, Ruckig's trajectory is validated by
//! sampling too: ours being longer than a valid Ruckig trajectory fails the test. Where Ruckig
//! refuses a duration above 7.6e3 s, it is asked again for the time-scaled problem (t' = t/k,
//! v·k, a·k², j·k³: the same path, k times faster). Asymmetric limits are checked against Ruckig
//! with the loosest and tightest symmetric limits around them; discrete durations must be
//! multiples of the period and not shorter than the continuous optimum.
//!
//! `OTG_PROBLEMS=N` sets the problems per kind (default 20 000: 160 000 problems, a few seconds in
//! release), `OTG_SEED=S` the random seed; `OTG_SHOW_ERR=1e-10` prints the problems whose target
//! error exceeds the value.

mod common;

use common::{
    DURATION_REL_TOL, KINDS, Kind, Outcome, Rng, RuckigOracle, Validation, compare_with_ruckig, fmt_input,
    random_problem, target_is_valid, validate_ours, validate_ruckig,
};
use interpd_otg::{Input, Limits, Otg, Trajectory};
use std::collections::BTreeMap;

/// A discrete duration is a multiple of its period within this (relative).
const MULTIPLE_REL_TOL: f64 = 1e-9;

#[derive(Default, Debug)]
struct Stats {
    problems: usize,
    equal: usize,
    equal_scaled: usize,
    ours_shorter_valid: usize,
    ruckig_invalid: usize,
    ruckig_error: usize,
    checked: usize,
    ours_failed: usize,
    max_target_err: f64,
    max_limit_excess: f64,
    max_rel_diff_when_equal: f64,
}

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// One DoF of `input` as a single-DoF problem with symmetric limits `(v, a)`.
fn single_symmetric(input: &Input, dof: usize, v: f64, a: f64) -> Input {
    let mut single = Input::new(1);
    single.control = input.control;
    single.current[0] = input.current[dof];
    single.target[0] = input.target[dof];
    single.limits[0] = Limits::symmetric(v, a, input.limits[dof].j_max);
    single
}

/// Asymmetric limits: each DoF's minimum duration lies between the optimum with the loosest
/// symmetric limits around them (any trajectory of ours is feasible there) and Ruckig's with the
/// tightest (any trajectory feasible there is feasible for ours), if the states are inside the
/// latter. The loose optimum is the shorter of Ruckig's and ours, both validated (Ruckig misses
/// it now and then for limits far from 1).
fn asymmetric_bounds(input: &Input, traj: &Trajectory, oracle: &mut RuckigOracle, otg: &mut Otg) -> Outcome {
    let position = input.control == interpd_otg::ControlInterface::Position;
    let mut compared = false;
    for dof in 0..input.dofs {
        let l = input.limits[dof];
        // The DoF alone: our trajectory must be valid and last its minimum duration.
        let mut single = single_symmetric(input, dof, 1.0, 1.0);
        single.limits[0] = l;
        let mut alone = Trajectory::default();
        if otg.calculate(&single, &mut alone).is_err() || !validate_ours(&single, &alone).ok {
            return Outcome::Failed("asymmetric: single DoF failed".into(), fmt_input(&single));
        }
        let ours = alone.duration();
        if (ours - traj.independent_min_durations()[dof]).abs() > 1e-12 * ours {
            return Outcome::Failed("asymmetric: minimum duration differs alone".into(), fmt_input(input));
        }
        let loose = single_symmetric(input, dof, l.v_max.max(-l.v_min), l.a_max.max(-l.a_min));
        let mut ours_loose = Trajectory::default();
        if otg.calculate(&loose, &mut ours_loose).is_err() || !validate_ours(&loose, &ours_loose).ok {
            return Outcome::Failed("asymmetric: loose symmetric problem failed".into(), fmt_input(&loose));
        }
        let mut lower = ours_loose.duration();
        if let Ok(d) = oracle.calculate(&loose) {
            compared = true;
            if validate_ruckig(&loose, oracle, &[0.0]).ok {
                lower = lower.min(d);
            }
        }
        if ours < lower * (1.0 - DURATION_REL_TOL) {
            return Outcome::Failed(
                "asymmetric: shorter than with the loosest limits".into(),
                format!("DoF {dof}: ours {ours} < {lower}: {}", fmt_input(input)),
            );
        }
        let tight = single_symmetric(input, dof, l.v_max.min(-l.v_min), l.a_max.min(-l.a_min));
        let (c, tl) = (tight.current[0], tight.limits[0]);
        let v_stop = c.v + c.a * c.a.abs() / (2.0 * tl.j_max);
        let inside = c.v.abs() <= tl.v_max && c.a.abs() <= tl.a_max && v_stop.abs() <= tl.v_max;
        if inside && target_is_valid(&tight.target[0], &tl, position) {
            if let Ok(d) = oracle.calculate(&tight) {
                compared = true;
                if ours > d * (1.0 + DURATION_REL_TOL) {
                    return Outcome::Failed(
                        "asymmetric: longer than with the tightest limits".into(),
                        format!("DoF {dof}: ours {ours} > {d}: {}", fmt_input(input)),
                    );
                }
            }
        }
    }
    if compared { Outcome::Checked } else { Outcome::RuckigError("no bound".into()) }
}

/// Discrete durations: a multiple of the period, not shorter than the continuous optimum.
fn discrete_duration(input: &Input, traj: &Trajectory, otg: &mut Otg) -> Outcome {
    let period = input.discrete_period_s.unwrap_or(f64::NAN);
    let d = traj.duration();
    let multiple = (d / period).round();
    if ((d / period) - multiple).abs() > MULTIPLE_REL_TOL * multiple.max(1.0) {
        return Outcome::Failed("discrete: not a multiple".into(), format!("{d} / {period}: {}", fmt_input(input)));
    }
    let mut continuous = *input;
    continuous.discrete_period_s = None;
    let mut t = Trajectory::default();
    match otg.calculate(&continuous, &mut t) {
        Ok(()) if d < t.duration() * (1.0 - DURATION_REL_TOL) => Outcome::Failed(
            "discrete: shorter than continuous".into(),
            format!("{d} < {}: {}", t.duration(), fmt_input(input)),
        ),
        Ok(()) => Outcome::Checked,
        Err(e) => Outcome::Failed("discrete: continuous failed".into(), format!("{e}: {}", fmt_input(input))),
    }
}

/// Solve, validate, and compare one problem.
fn check_problem(
    kind: Kind,
    input: &Input,
    otg: &mut Otg,
    traj: &mut Trajectory,
    oracles: &mut [RuckigOracle],
) -> (Outcome, Option<Validation>) {
    if let Err(e) = otg.calculate(input, traj) {
        let variant = format!("{e:?}");
        let variant = variant.split([' ', '{']).next().unwrap_or("").to_string();
        return (Outcome::Failed(format!("error {variant}"), format!("{e}: {}", fmt_input(input))), None);
    }
    let val = validate_ours(input, traj);
    if !val.ok {
        let detail = format!("err {:e}, excess {:e}: {}", val.target_err, val.limit_excess, fmt_input(input));
        return (Outcome::Failed(format!("invalid: {}", val.reason), detail), Some(val));
    }
    let outcome = match kind {
        Kind::Asymmetric => asymmetric_bounds(input, traj, &mut oracles[1], otg),
        Kind::DiscreteDuration => discrete_duration(input, traj, otg),
        _ => compare_with_ruckig(input, traj, &mut oracles[input.dofs]),
    };
    (outcome, Some(val))
}

#[test]
fn random_problems_match_ruckig() {
    let per_kind: usize = env_or("OTG_PROBLEMS", 20_000);
    let show_err: f64 = env_or("OTG_SHOW_ERR", f64::INFINITY);
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    let mut oracles: Vec<RuckigOracle> = (0..=6).map(RuckigOracle::new).collect();
    let mut stats: BTreeMap<(Kind, usize), Stats> = BTreeMap::new();
    let mut ruckig_errors: BTreeMap<String, usize> = BTreeMap::new();
    let mut failures: Vec<(String, String)> = Vec::new();
    let mut err_hist = [0usize; 4];
    let mut rng = Rng::new(env_or("OTG_SEED", 0x07C0_FFEE));
    for &kind in &KINDS {
        for i in 0..per_kind {
            let dofs = [1, 1, 2, 3, 6][i % 5];
            let input = random_problem(&mut rng, kind, dofs);
            let (outcome, val) = check_problem(kind, &input, &mut otg, &mut traj, &mut oracles);
            let st = stats.entry((kind, dofs)).or_default();
            st.problems += 1;
            if let Some(val) = val {
                st.max_target_err = st.max_target_err.max(val.target_err);
                st.max_limit_excess = st.max_limit_excess.max(val.limit_excess);
                for (k, threshold) in [1e-12, 1e-11, 1e-10, 1e-9].iter().enumerate() {
                    err_hist[k] += usize::from(val.target_err > *threshold);
                }
                if val.target_err > show_err {
                    eprintln!("ERR {kind:?} {:e} dof {}: {}", val.target_err, val.worst_target_dof, fmt_input(&input));
                }
            }
            match outcome {
                Outcome::Equal { scaled, rel } => {
                    st.equal += usize::from(!scaled);
                    st.equal_scaled += usize::from(scaled);
                    st.max_rel_diff_when_equal = st.max_rel_diff_when_equal.max(rel);
                }
                Outcome::OursShorterValid => st.ours_shorter_valid += 1,
                Outcome::RuckigInvalid => st.ruckig_invalid += 1,
                Outcome::RuckigError(code) => {
                    st.ruckig_error += 1;
                    *ruckig_errors.entry(code).or_default() += 1;
                }
                Outcome::Checked => st.checked += 1,
                Outcome::Failed(class, detail) => {
                    st.ours_failed += 1;
                    failures.push((format!("{kind:?} {class}"), detail));
                }
            }
        }
    }
    report(&stats, &ruckig_errors, &err_hist);
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

fn report(stats: &BTreeMap<(Kind, usize), Stats>, ruckig_errors: &BTreeMap<String, usize>, err_hist: &[usize; 4]) {
    eprintln!(
        "{:<16} {:>4} {:>8} {:>7} {:>9} {:>9} {:>9} {:>7} {:>7} {:>7} {:>12} {:>12}",
        "kind",
        "dofs",
        "problems",
        "equal",
        "eq(scaled)",
        "ours<R(ok)",
        "R-invalid",
        "R-error",
        "checked",
        "FAILED",
        "target-err",
        "limit-excess"
    );
    let mut total = Stats::default();
    for ((kind, dofs), s) in stats {
        eprintln!(
            "{:<16} {:>4} {:>8} {:>7} {:>9} {:>9} {:>9} {:>7} {:>7} {:>7} {:>12.2e} {:>12.2e}",
            format!("{kind:?}"),
            dofs,
            s.problems,
            s.equal,
            s.equal_scaled,
            s.ours_shorter_valid,
            s.ruckig_invalid,
            s.ruckig_error,
            s.checked,
            s.ours_failed,
            s.max_target_err,
            s.max_limit_excess
        );
        total.problems += s.problems;
        total.equal += s.equal;
        total.equal_scaled += s.equal_scaled;
        total.ours_shorter_valid += s.ours_shorter_valid;
        total.ruckig_invalid += s.ruckig_invalid;
        total.ruckig_error += s.ruckig_error;
        total.checked += s.checked;
        total.ours_failed += s.ours_failed;
        total.max_target_err = total.max_target_err.max(s.max_target_err);
        total.max_limit_excess = total.max_limit_excess.max(s.max_limit_excess);
        total.max_rel_diff_when_equal = total.max_rel_diff_when_equal.max(s.max_rel_diff_when_equal);
    }
    eprintln!(
        "{:<16} {:>4} {:>8} {:>7} {:>9} {:>9} {:>9} {:>7} {:>7} {:>7} {:>12.2e} {:>12.2e}",
        "total",
        "",
        total.problems,
        total.equal,
        total.equal_scaled,
        total.ours_shorter_valid,
        total.ruckig_invalid,
        total.ruckig_error,
        total.checked,
        total.ours_failed,
        total.max_target_err,
        total.max_limit_excess
    );
    eprintln!("largest relative duration difference among equal: {:.2e}", total.max_rel_diff_when_equal);
    eprintln!("Ruckig errors: {ruckig_errors:?}");
    eprintln!("target errors above 1e-12, 1e-11, 1e-10, 1e-9: {err_hist:?}");
}
