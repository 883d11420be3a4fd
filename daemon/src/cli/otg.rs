//! `interpd otg --from P,V,A --to P,V,A --limits VMAX,AMAX,JMAX [--json] [--out FILE.csv
//! --period-ms P]`: one online-trajectory calculation (crate `interpd-otg`), for users and for
//! checks.
//!
//! Several DoFs are separated by `;` in each option (`--from "0,0,0;5,1,0"`); a state may give
//! fewer than three numbers (the missing ones are 0), and a single `--limits`, `--vmin` or
//! `--amin` entry applies to every DoF. The CSV has the header `t,p0,v0,a0,j0,p1,v1,a1,j1,...`:
//! time [s], then per DoF its position, velocity, acceleration and jerk, one row per period from
//! t = 0 to the first multiple of the period at or after the end (the DoFs rest at their targets
//! there, or keep their target velocity and acceleration).

use super::CliError;
use interpd::config::Config;
use interpd::otg::{ControlInterface, Input, Limits, MAX_DOFS, Otg, OtgError, State, Synchronization, Trajectory};
use std::io::{BufWriter, Write};
use std::path::PathBuf;

/// Most CSV rows `--period-ms` may produce (guards against a duration of days at 0.01 ms).
const MAX_CSV_ROWS: f64 = 1e7;
/// Smallest sampling period [ms] (as `interpd plan`).
const MIN_PERIOD_MS: f64 = 0.01;

/// Options of `interpd otg`.
#[derive(Debug, clap::Args)]
pub struct OtgArgs {
    /// Current state per DoF: P,V,A (position, velocity, acceleration); DoFs separated by ';'.
    #[arg(long, allow_hyphen_values = true)]
    pub from: String,
    /// Target state per DoF: P,V,A; DoFs separated by ';'.
    #[arg(long, allow_hyphen_values = true)]
    pub to: String,
    /// Limits per DoF: VMAX,AMAX,JMAX (all > 0); one entry applies to every DoF.
    #[arg(long)]
    pub limits: String,
    /// Lower velocity limit per DoF (< 0; default -VMAX).
    #[arg(long, allow_hyphen_values = true)]
    pub vmin: Option<String>,
    /// Lower acceleration limit per DoF (< 0; default -AMAX).
    #[arg(long, allow_hyphen_values = true)]
    pub amin: Option<String>,
    /// Velocity interface: reach the target velocity and acceleration, the position is free.
    #[arg(long)]
    pub velocity: bool,
    /// Synchronisation of the DoFs: time (all end together), phase (straight line when the
    /// inputs are collinear), none (each in its own minimum time).
    #[arg(long, default_value = "time")]
    pub sync: String,
    /// Lower bound of the duration, s.
    #[arg(long, allow_hyphen_values = true)]
    pub min_duration_s: Option<f64>,
    /// Print one JSON object with the duration and every DoF's profile on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write the sampled motion as CSV: t,p0,v0,a0,j0,p1,...
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Sampling period of the CSV, ms (default: the machine's cycle; ≥ 0.01).
    #[arg(long)]
    pub period_ms: Option<f64>,
}

fn bad(option: &str, message: impl std::fmt::Display) -> CliError {
    CliError::BadInput(format!("--{option}: {message}"))
}

/// Parse `text` as DoFs separated by ';' of 1..=`max` comma-separated finite numbers each,
/// padded with `pad` (missing trailing values).
fn parse_rows(option: &str, text: &str, min: usize, max: usize, pad: f64) -> Result<Vec<[f64; 3]>, CliError> {
    let mut rows = Vec::new();
    for (dof, entry) in text.split(';').enumerate() {
        let items: Vec<&str> = entry.split(',').map(str::trim).collect();
        if items.len() < min || items.len() > max || items.iter().any(|s| s.is_empty()) {
            let want = if min == max { format!("{min}") } else { format!("{min} to {max}") };
            return Err(bad(option, format!("DoF {dof}: \"{entry}\" must be {want} comma-separated numbers")));
        }
        let mut row = [pad; 3];
        for (k, item) in items.iter().enumerate() {
            let value: f64 = item
                .parse()
                .map_err(|_| bad(option, format!("DoF {dof}: \"{item}\" in \"{entry}\" is not a number")))?;
            if !value.is_finite() {
                return Err(bad(option, format!("DoF {dof}: \"{item}\" in \"{entry}\" is not a finite number")));
            }
            row[k] = value;
        }
        rows.push(row);
    }
    if rows.len() > MAX_DOFS {
        return Err(bad(option, format!("{} DoFs given, at most {MAX_DOFS} are supported", rows.len())));
    }
    Ok(rows)
}

/// `rows` for `n` DoFs: as given, or one entry for every DoF.
fn per_dof(option: &str, rows: Vec<[f64; 3]>, n: usize) -> Result<Vec<[f64; 3]>, CliError> {
    match rows.len() {
        len if len == n => Ok(rows),
        1 => Ok(vec![rows[0]; n]),
        len => Err(bad(option, format!("{len} DoFs given, but --from has {n}"))),
    }
}

/// The calculation's input from the options.
fn input_from_args(args: &OtgArgs) -> Result<Input, CliError> {
    let from = parse_rows("from", &args.from, 1, 3, 0.0)?;
    let n = from.len();
    let to = parse_rows("to", &args.to, 1, 3, 0.0)?;
    if to.len() != n {
        return Err(bad("to", format!("{} DoFs given, but --from has {n}", to.len())));
    }
    let limits = per_dof("limits", parse_rows("limits", &args.limits, 3, 3, 0.0)?, n)?;
    let optional = |option: &str, text: &Option<String>| -> Result<Option<Vec<[f64; 3]>>, CliError> {
        text.as_deref().map(|t| parse_rows(option, t, 1, 1, 0.0).and_then(|r| per_dof(option, r, n))).transpose()
    };
    let vmin = optional("vmin", &args.vmin)?;
    let amin = optional("amin", &args.amin)?;

    let mut input = Input::new(n);
    input.control = if args.velocity { ControlInterface::Velocity } else { ControlInterface::Position };
    input.sync = match args.sync.as_str() {
        "time" => Synchronization::Time,
        "phase" => Synchronization::Phase,
        "none" => Synchronization::None,
        other => return Err(bad("sync", format!("\"{other}\" is not one of time, phase, none"))),
    };
    input.min_duration_s = args.min_duration_s;
    for dof in 0..n {
        input.current[dof] = State { p: from[dof][0], v: from[dof][1], a: from[dof][2] };
        input.target[dof] = State { p: to[dof][0], v: to[dof][1], a: to[dof][2] };
        let [v, a, j] = limits[dof];
        input.limits[dof] = Limits {
            v_max: v,
            v_min: vmin.as_ref().map_or(-v, |r| r[dof][0]),
            a_max: a,
            a_min: amin.as_ref().map_or(-a, |r| r[dof][0]),
            j_max: j,
        };
    }
    Ok(input)
}

/// A rejected input names the option it came from; a calculation failure is not bad input.
fn otg_error(e: OtgError) -> CliError {
    match e {
        OtgError::InvalidDofs { .. } => bad("from", e),
        OtgError::NonFinite { what, .. } if what.starts_with("target") => bad("to", e),
        OtgError::NonFinite { .. } => bad("from", e),
        OtgError::InvalidLimit { limit: "v_min", .. } => bad("vmin", e),
        OtgError::InvalidLimit { limit: "a_min", .. } => bad("amin", e),
        OtgError::InvalidLimit { .. } => bad("limits", e),
        OtgError::TargetOutsideLimits { .. } => bad("to", e),
        OtgError::InvalidMinDuration { .. } => bad("min-duration-s", e),
        OtgError::InvalidDiscretePeriod { .. } => CliError::BadInput(e.to_string()),
        OtgError::NoProfile { .. } | OtgError::NoSynchronization { .. } => {
            CliError::Failure(format!("no trajectory found: {e}"))
        }
    }
}

pub fn run(args: &OtgArgs) -> Result<(), CliError> {
    let input = input_from_args(args)?;
    let period_s = match args.period_ms {
        Some(p) if p.is_finite() && p >= MIN_PERIOD_MS => p * 1e-3,
        Some(p) => return Err(bad("period-ms", format!("{p} must be a number ≥ {MIN_PERIOD_MS}"))),
        None => Config::load_or_default(None)?.cycle_s(),
    };
    let mut otg = Otg::new();
    let mut traj = Trajectory::default();
    otg.calculate(&input, &mut traj).map_err(otg_error)?;
    tracing::debug!(duration_s = traj.duration(), "otg calculated");

    if let Some(path) = &args.out {
        write_csv(path, &traj, period_s)?;
    }
    let write_err = |e: std::io::Error| CliError::Failure(format!("cannot write to stdout: {e}"));
    let mut stdout = std::io::stdout().lock();
    if args.json {
        writeln!(stdout, "{}", summary_json(&input, &traj)).map_err(write_err)?;
    } else {
        let limiting = traj.limiting_dof().map_or("none (minimum duration)".to_string(), |d| d.to_string());
        writeln!(stdout, "duration {:.9} s, limiting DoF {limiting}", traj.duration()).map_err(write_err)?;
        for (dof, p) in traj.profiles().iter().enumerate() {
            writeln!(
                stdout,
                "DoF {dof}: {:?} {:?} {:?}, brake {:.6} s, phases [s] {:?}",
                p.limits,
                p.direction,
                p.control_signs,
                p.brake.duration,
                p.t.map(|t| (t * 1e9).round() / 1e9)
            )
            .map_err(write_err)?;
        }
    }
    Ok(())
}

/// The JSON summary: `duration_s` and per DoF its profile.
fn summary_json(input: &Input, traj: &Trajectory) -> serde_json::Value {
    let dofs: Vec<serde_json::Value> = traj
        .profiles()
        .iter()
        .enumerate()
        .map(|(dof, p)| {
            serde_json::json!({
                "min_duration_s": traj.independent_min_durations()[dof],
                "brake_s": p.brake.t,
                "brake_jerk": p.brake.j,
                "phases_s": p.t,
                "jerk": p.j,
                "limits": format!("{:?}", p.limits),
                "direction": format!("{:?}", p.direction),
                "signs": format!("{:?}", p.control_signs),
                "end": [p.p[7], p.v[7], p.a[7]],
            })
        })
        .collect();
    serde_json::json!({
        "duration_s": traj.duration(),
        "limiting_dof": traj.limiting_dof(),
        "control": format!("{:?}", input.control),
        "sync": format!("{:?}", input.sync),
        "dofs": dofs,
    })
}

/// One row per period from 0 to the first multiple of the period at or after the end.
fn write_csv(path: &PathBuf, traj: &Trajectory, period_s: f64) -> Result<(), CliError> {
    let steps = (traj.duration() / period_s).ceil();
    if steps + 1.0 > MAX_CSV_ROWS {
        return Err(bad(
            "period-ms",
            format!(
                "{} ms gives {steps:.0} rows for {} s (more than {MAX_CSV_ROWS:.0})",
                period_s * 1e3,
                traj.duration()
            ),
        ));
    }
    let file = std::fs::File::create(path)
        .map_err(|e| CliError::Failure(format!("{}: cannot create: {e}", path.display())))?;
    let mut w = BufWriter::new(file);
    let write_err = |e: std::io::Error| CliError::Failure(format!("{}: cannot write: {e}", path.display()));
    write!(w, "t").map_err(write_err)?;
    for dof in 0..traj.dofs() {
        write!(w, ",p{dof},v{dof},a{dof},j{dof}").map_err(write_err)?;
    }
    writeln!(w).map_err(write_err)?;
    for k in 0..=steps as u64 {
        let t = k as f64 * period_s;
        write!(w, "{t}").map_err(write_err)?;
        for dof in 0..traj.dofs() {
            let (s, j) = traj.state_of(dof, t);
            write!(w, ",{},{},{},{}", s.p, s.v, s.a, j).map_err(write_err)?;
        }
        writeln!(w).map_err(write_err)?;
    }
    w.flush().map_err(write_err)
}
