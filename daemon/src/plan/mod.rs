//! `plan PROGRAM [--machine FILE] [--period-ms P] [--out FILE.csv] [--json]`: parse, plan online
//! with the configured look-ahead, and sample the motion in simulated time along the exact
//! geometry. `interpd plan` runs it as it is; `interpd-sim` runs it with the simulated plant as
//! a [`SampleObserver`] (`--plant`), so the planned columns and figures are the same in both.

mod error;
mod export;

pub use error::{ObserverError, PlanError};

use interpd_config::Config;
use interpd_motion::path::AxisDerivs;
use interpd_motion::planner::profile::{Cursor, Sample};
use interpd_motion::{Feed, Segment, Settings, program};
use std::io::{BufWriter, Write};
use std::path::PathBuf;

/// Options of `plan` (the same in `interpd` and `interpd-sim`, which `interpd` hands `--plant`
/// to with its arguments as they are).
#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// Program file (G-code, or a path table .csv).
    pub program: PathBuf,
    /// Machine configuration (TOML); default: the embedded 3-axis machine.
    #[arg(long)]
    pub machine: Option<PathBuf>,
    /// Sampling period of the output, ms (default: the machine's cycle; ≥ 0.01).
    #[arg(long)]
    pub period_ms: Option<f64>,
    /// Write the sampled motion as CSV: t,s,v,a,j,<axis positions>.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print one JSON object with the figures on stdout.
    #[arg(long)]
    pub json: bool,
    /// Override the configured look-ahead, mm (`inf` plans the whole program at once).
    #[arg(long)]
    pub lookahead_mm: Option<f64>,
    /// Write the sampled path (nodes with A′, A″, A‴ on both sides, v̄), the limits the planner
    /// used and its profile at the nodes as JSON, for an independent optimiser (benches/reference/).
    #[arg(long)]
    pub export_nodes: Option<PathBuf>,
    /// Run the simulated plant (sim-plant) on the sampled setpoints, one setpoint per row, and
    /// add the columns <axis>_motor,<axis>_load,<axis>_following_error,<axis>_load_error. No
    /// value: the machine's [plant] section; PRESET: that preset for all axes of its kind; FILE:
    /// a preset file or a TOML file with a [plant] section. Put it after PROGRAM or write
    /// --plant=VALUE. The plant runs in the binary interpd-sim beside interpd.
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "PRESET|FILE")]
    pub plant: Option<String>,
    /// Apply `[prep] max_solve_ms`, the wall-clock limit of a window solve, as the daemon does.
    /// Without it `plan` lifts that limit (to its largest value, 100 s), so that what it plans
    /// does not depend on how busy the computer is.
    #[arg(long)]
    pub timed_solves: bool,
}

/// `[prep] max_solve_ms` of a plan without `--timed-solves`: the largest the configuration
/// allows, so that no window solve reaches it.
const UNTIMED_SOLVE_MS: f64 = 1e5;

/// The machine a plan runs on and its sampling period.
#[derive(Debug)]
pub struct Setup {
    /// The machine configuration with `--lookahead-mm` applied.
    pub config: Config,
    pub period_s: f64,
}

impl Setup {
    pub fn from_args(args: &PlanArgs) -> Result<Self, PlanError> {
        let mut config = Config::load_or_default(args.machine.as_deref())?;
        config.programs.default_to_dir_of(&args.program);
        if let Some(l) = args.lookahead_mm {
            if l.is_nan() || l <= 0.0 {
                return Err(PlanError::Lookahead(l));
            }
            config.planner.lookahead_mm = l;
        }
        // Offline nothing waits for a window solve; the daemon's time limit would only make the
        // plan depend on the host's load (a solve slowed by other processes takes a fallback).
        if !args.timed_solves {
            config.prep.max_solve_ms = UNTIMED_SOLVE_MS;
        }
        let period_s = match args.period_ms {
            Some(p) if p.is_finite() && p >= 0.01 => p * 1e-3,
            Some(p) => return Err(PlanError::Period(p)),
            None => config.cycle_s(),
        };
        Ok(Self { config, period_s })
    }
}

/// One axis at one sample, in the axis unit (mm or deg) and per s, s².
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct AxisSample {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
}

/// What runs in-process on the sampled motion, one sample at a time (`interpd-sim` runs the
/// simulated plant on it for `--plant`): it adds columns to each CSV row, a member to the JSON
/// figures and lines to the text output.
pub trait SampleObserver {
    /// The extra CSV header columns, each after a comma (the line end follows).
    fn write_header(&self, w: &mut dyn Write) -> std::io::Result<()>;
    /// The next sample of every axis, one period after the previous one.
    fn step(&mut self, axes: &[AxisSample]) -> Result<(), ObserverError>;
    /// The current row's extra columns, each after a comma.
    fn write_columns(&self, w: &mut dyn Write) -> std::io::Result<()>;
    /// After the last sample (the machine rests there), before the figures are taken.
    fn settle(&mut self) -> Result<(), ObserverError>;
    /// The member of the JSON figures: its name and value.
    fn json(&self) -> (&'static str, serde_json::Value);
    /// The figures as text, after the plan's own line.
    fn summary(&self) -> String;
}

/// Most output samples `plan` produces (10⁸: 7 hours of motion at 0.25 ms); a longer motion is
/// almost surely a mistyped feed or limit, and sampling it would not finish.
const MAX_SAMPLES: u64 = 100_000_000;

/// Largest |value| / limit per quantity over all axes and samples.
#[derive(Debug, Default, Clone, Copy)]
struct Ratios {
    vel: f64,
    acc: f64,
    jerk: f64,
}

/// Plans and samples `args.program` on `setup`, with `observer` on every sample; the CSV goes
/// to `--out`, the figures (JSON or text) to `stdout`.
pub fn run(
    args: &PlanArgs,
    setup: &Setup,
    mut observer: Option<&mut dyn SampleObserver>,
    stdout: &mut dyn Write,
) -> Result<(), PlanError> {
    let (config, period_s) = (&setup.config, setup.period_s);
    let settings = Settings::from_config(config);
    // One streaming pass for the program's errors, then a second that reads, smooths, plans and
    // samples it as it goes: memory grows with the look-ahead, not with the program.
    // Operator messages on stderr in program order (stdout carries the figures).
    let name = args.program.display().to_string();
    // Buffered (a loop may write a million), flushed before any error is printed.
    let mut err = std::io::BufWriter::new(std::io::stderr().lock());
    let checked = program::check_with_messages(&args.program, &settings, &mut |m| {
        let _ = writeln!(err, "{name}:{m}");
    });
    let _ = err.flush();
    drop(err);
    let checked = checked?;
    if checked.elements == 0 {
        return Err(PlanError::NoMotion(args.program.clone()));
    }
    let feed = Feed::builder(&settings).open_file(&args.program)?;
    let mut pipe = Sampled::new(feed, args.export_nodes.is_some());

    let mut out: Option<BufWriter<std::fs::File>> = match &args.out {
        Some(p) => Some(BufWriter::new(
            std::fs::File::create(p).map_err(|source| PlanError::Create { path: p.clone(), source })?,
        )),
        None => None,
    };
    let axis_names = settings.axis_names();
    if let Some(w) = out.as_mut() {
        write!(w, "t,s,v,a,j")?;
        for name in &axis_names {
            write!(w, ",{name}")?;
        }
        if let Some(o) = observer.as_deref() {
            o.write_header(w)?;
        }
        writeln!(w)?;
    }
    let lim = pipe.feed.limits().clone();
    let n = settings.axes.len();
    let mut ratios = Ratios::default();
    let mut d = AxisDerivs::default();
    let mut axes = vec![AxisSample::default(); n];
    let mut samples = 0u64;
    loop {
        // Uniform time steps, also past the end (the machine rests there), so finite
        // differences of the output are exact in their spacing.
        let t = samples as f64 * period_s;
        // Sample only what is planned for good: up to the end of the planned segments, or
        // past it once the program is planned to its end.
        while !pipe.finished() && pipe.planned_until_s() <= t {
            pipe.advance()?;
        }
        if pipe.finished() && samples as f64 >= (pipe.planned_until_s() / period_s).ceil() + 1.0 {
            break;
        }
        if samples >= MAX_SAMPLES {
            return Err(PlanError::TooLong {
                program: args.program.clone(),
                max_samples: MAX_SAMPLES,
                period_ms: period_s * 1e3,
                duration_s: MAX_SAMPLES as f64 * period_s,
            });
        }
        let Some(sample) = pipe.sample(t) else { break };
        samples += 1;
        let st = sample.state;
        // The geometry on the segment's side of a joint (they differ only at corners).
        if sample.at_start {
            pipe.feed.path().eval(st.s_mm, &mut d)
        } else {
            pipe.feed.path().eval_left(st.s_mm, &mut d)
        }
        for (i, axis) in axes.iter_mut().enumerate() {
            let [vel, acc, jerk] = d.axis_rates(i, st.v, st.a, st.j);
            ratios.vel = ratios.vel.max(vel.abs() / lim.configured_vel[i]);
            ratios.acc = ratios.acc.max(acc.abs() / lim.configured_acc[i]);
            ratios.jerk = ratios.jerk.max(jerk.abs() / lim.configured_jerk[i]);
            *axis = AxisSample { pos: d.pos[i], vel, acc };
        }
        if let Some(o) = observer.as_deref_mut() {
            o.step(&axes).map_err(PlanError::Observer)?;
        }
        if let Some(w) = out.as_mut() {
            write!(w, "{},{},{},{},{}", t, st.s_mm, st.v, st.a, st.j)?;
            for p in &d.pos[..n] {
                write!(w, ",{p}")?;
            }
            if let Some(o) = observer.as_deref() {
                o.write_columns(w)?;
            }
            writeln!(w)?;
        }
        pipe.release_before(t);
    }
    if let Some(mut w) = out {
        w.flush()?;
    }
    if let Some(o) = observer.as_deref_mut() {
        o.settle().map_err(PlanError::Observer)?;
    }
    let duration = pipe.planned_until_s();
    if let Some(p) = &args.export_nodes {
        export::export_nodes(p, &settings, pipe.feed.path(), &pipe.kept)?;
    }
    if !ratios.vel.is_finite() || !ratios.acc.is_finite() || !ratios.jerk.is_finite() || !duration.is_finite() {
        return Err(PlanError::NotFinite);
    }
    let length_mm = pipe.feed.path().length_mm();
    let figures = Figures { duration_s: duration, samples, period_s, ratios, length_mm, feed: pipe.feed.stats() };
    report(args, config, &checked, &figures, observer.as_deref(), stdout)
}

/// What a plan measured, for [`report`].
struct Figures {
    duration_s: f64,
    samples: u64,
    period_s: f64,
    ratios: Ratios,
    length_mm: f64,
    feed: interpd_motion::feed::FeedStats,
}

/// Writes the figures to `stdout`: one JSON object (`--json`) or a line of text, with the
/// observer's figures after them.
fn report(
    args: &PlanArgs,
    config: &Config,
    checked: &program::Checked,
    figures: &Figures,
    observer: Option<&dyn SampleObserver>,
    stdout: &mut dyn Write,
) -> Result<(), PlanError> {
    let Figures { duration_s: duration, samples, period_s, ratios, length_mm, feed: feed_stats } = *figures;
    let (stats, plan_s) = (feed_stats.plan, feed_stats.plan_s);
    let mut prep_stats = feed_stats.prep;
    if prep_stats.pieces == 0 {
        // Nothing was smoothed, so no sample was checked against the tolerance.
        prep_stats.max_excess_mm = 0.0;
    }
    let axis_names = config.axis_names();
    let evals_per_node = stats.work.evals as f64 / stats.nodes.max(1) as f64;
    if args.json {
        let json = serde_json::json!({
            "program": args.program.display().to_string(),
            "duration_s": duration,
            "plan_ms": plan_s * 1e3,
            "plan_call_max_ms": feed_stats.plan_call_max_s * 1e3,
            "read_ms": feed_stats.read_s * 1e3,
            "step_max_ms": feed_stats.step_max_s * 1e3,
            "samples": samples,
            "period_ms": period_s * 1e3,
            "axes": axis_names,
            "max_ratio": { "vel": ratios.vel, "acc": ratios.acc, "jerk": ratios.jerk },
            "length_mm": length_mm,
            "nodes": stats.nodes,
            "segments": feed_stats.segments,
            "nodes_per_s": stats.nodes as f64 / plan_s.max(1e-12),
            "evals_per_node": evals_per_node,
            "joins": stats.work.joins,
            "repairs": stats.work.repairs,
            "horizon_stops": stats.horizon_stops,
            "horizon_brakes": stats.horizon_brakes,
            "forced_stops": stats.forced_stops,
            "work": {
                "evals": stats.work.evals,
                "steps": stats.work.steps,
                "ramps": stats.work.ramps,
                "ramp_nodes": stats.work.ramp_nodes,
                "bisections": stats.work.bisections,
                "term_evals": stats.work.term_evals,
                "cap_tries": stats.work.cap_tries,
                "end_caps": stats.work.end_caps,
                "relaxed_tried": stats.work.relaxed_tried,
                "relaxed_kept": stats.work.relaxed_kept,
                "seed_skipped": stats.work.flat_skipped,
                "units": stats.work.units(),
                "block_max_units": stats.block_work_max,
                "search_pauses": stats.search_pauses,
            },
            "lookahead_mm": config.planner.lookahead_mm,
            "prep": { "wall_ms": feed_stats.prep_s * 1e3, "stats": prep_stats },
            "programmed": { "lines": checked.summary.lines, "elements": checked.elements, "length_mm": checked.length_mm },
        });
        // The observer's figures only when one ran (no null members in the output).
        let mut json = json;
        if let Some(o) = observer {
            let (name, figures) = o.json();
            json[name] = figures;
        }
        writeln!(stdout, "{json}")?;
    } else {
        writeln!(
            stdout,
            "{}: {:.4} s motion over {:.3} mm, planned in {:.2} ms ({} nodes, {:.1} evaluations per node); \
             max |value|/limit: vel {:.4}, acc {:.4}, jerk {:.4}{}",
            args.program.display(),
            duration,
            length_mm,
            plan_s * 1e3,
            stats.nodes,
            evals_per_node,
            ratios.vel,
            ratios.acc,
            ratios.jerk,
            args.out.as_ref().map_or(String::new(), |p| format!("; {samples} samples in {}", p.display()))
        )?;
        if let Some(o) = observer {
            write!(stdout, "{}", o.summary())?;
        }
    }
    Ok(())
}

/// The planned motion being sampled: the program planned through its [`Feed`] just ahead of
/// the samples, the segments and the path they run on kept only until the samples have passed
/// them (all of them for `--export-nodes`).
struct Sampled {
    feed: Feed,
    /// Planned segments from the one being sampled on.
    kept: Vec<Segment>,
    keep_all: bool,
    cursor: Cursor,
}

/// Segments sampled past are dropped in batches of at least this many (each drop moves the
/// rest of the kept list).
const RELEASE_BATCH: usize = 64;

impl Sampled {
    fn new(feed: Feed, keep_all: bool) -> Self {
        Self { feed, kept: Vec::new(), keep_all, cursor: Cursor::default() }
    }

    /// The whole program is planned.
    fn finished(&self) -> bool {
        self.feed.finished()
    }

    /// End time of the planned motion so far, s (the samples never drop the last segment).
    fn planned_until_s(&self) -> f64 {
        self.kept.last().map_or(0.0, Segment::t1_s)
    }

    /// Plans on until at least one more segment is planned (or the program is planned to its
    /// end).
    fn advance(&mut self) -> Result<(), PlanError> {
        self.feed.plan(f64::MIN_POSITIVE)?;
        while let Some(seg) = self.feed.pop_segment() {
            self.kept.push(seg);
        }
        Ok(())
    }

    /// The planned state at time `t`.
    fn sample(&mut self, t: f64) -> Option<Sample> {
        self.cursor.sample(&self.kept, t)
    }

    /// Drops the segments that end before `t` and the path behind them.
    fn release_before(&mut self, t: f64) {
        if self.keep_all {
            return;
        }
        let k = self.kept.partition_point(|s| s.t1_s() < t).min(self.kept.len().saturating_sub(1));
        if k < RELEASE_BATCH {
            return;
        }
        self.kept.drain(..k);
        self.cursor = Cursor::default();
        self.feed.trim_before(self.kept[0].s0_mm);
    }
}
