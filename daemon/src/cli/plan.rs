//! `interpd plan PROGRAM [--machine FILE] [--period-ms P] [--out FILE.csv] [--json]`:
//! parse, plan online with the configured look-ahead, and sample the motion in simulated time
//! along the exact geometry.

use super::CliError;
use interpd::config::Config;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::export::{NodeExport, NodeGeom};
use interpd_motion::planner::profile::{Cursor, Sample, duration_s};
use interpd_motion::{Feed, FeedError, Segment, Settings, program};
use std::io::{BufWriter, Write};
use std::path::PathBuf;

/// Options of `interpd plan`.
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
    /// --plant=VALUE.
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "PRESET|FILE")]
    pub plant: Option<String>,
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

pub fn run(args: &PlanArgs) -> Result<(), CliError> {
    let mut config = Config::load_or_default(args.machine.as_deref())?;
    if let Some(l) = args.lookahead_mm {
        if l.is_nan() || l <= 0.0 {
            return Err(CliError::BadInput(format!("--lookahead-mm must be positive, got {l}")));
        }
        config.planner.lookahead_mm = l;
    }
    let period_s = match args.period_ms {
        Some(p) if p.is_finite() && p >= 0.01 => p * 1e-3,
        Some(p) => return Err(CliError::BadInput(format!("--period-ms must be a number ≥ 0.01, got {p}"))),
        None => config.cycle_s(),
    };
    let settings = Settings::from_config(&config);
    // One streaming pass for the program's errors, then a second that reads, smooths, plans and
    // samples it as it goes: memory grows with the look-ahead, not with the program.
    let checked = program::check(&args.program, &settings)?;
    if checked.elements == 0 {
        return Err(CliError::BadInput(format!("{}: the program has no motion", args.program.display())));
    }
    let feed = Feed::builder(&settings).open_file(&args.program).map_err(feed_error)?;
    let mut pipe = Sampled::new(feed, args.export_nodes.is_some());

    let mut out: Option<BufWriter<std::fs::File>> = match &args.out {
        Some(p) => Some(BufWriter::new(
            std::fs::File::create(p).map_err(|e| CliError::Failure(format!("{}: cannot create: {e}", p.display())))?,
        )),
        None => None,
    };
    let write_err = |e: std::io::Error| CliError::Failure(format!("cannot write output: {e}"));
    let axis_names = settings.axis_names();
    if let Some(w) = out.as_mut() {
        write!(w, "t,s,v,a,j").map_err(write_err)?;
        for name in &axis_names {
            write!(w, ",{name}").map_err(write_err)?;
        }
        if args.plant.is_none() {
            writeln!(w).map_err(write_err)?;
        }
    }
    let lim = pipe.feed.limits().clone();
    let n = settings.axes.len();
    let mut ratios = Ratios::default();
    let mut d = AxisDerivs::default();
    let mut plant = match &args.plant {
        Some(choice) => Some(PlantRun::new(&config, choice, period_s)?),
        None => None,
    };
    if let (Some(w), Some(p)) = (out.as_mut(), plant.as_ref()) {
        p.write_header(w).map_err(write_err)?;
    }
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
            return Err(CliError::BadInput(format!(
                "{}: the planned motion lasts more than {MAX_SAMPLES} samples at {} ms ({:.3e} s); is the feed \
                 (F, mm/min) or an axis limit far too low?",
                args.program.display(),
                period_s * 1e3,
                MAX_SAMPLES as f64 * period_s
            )));
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
        for i in 0..n {
            let vel = d.d1[i] * st.v;
            let acc = d.d2[i] * st.v * st.v + d.d1[i] * st.a;
            let jerk = d.d3[i] * st.v.powi(3) + 3.0 * d.d2[i] * st.v * st.a + d.d1[i] * st.j;
            ratios.vel = ratios.vel.max(vel.abs() / lim.configured_vel[i]);
            ratios.acc = ratios.acc.max(acc.abs() / lim.configured_acc[i]);
            ratios.jerk = ratios.jerk.max(jerk.abs() / lim.configured_jerk[i]);
            if let Some(p) = plant.as_mut() {
                p.targets[i] = sim_plant::AxisTarget { pos: d.pos[i], vel, acc };
            }
        }
        if let Some(p) = plant.as_mut() {
            p.step()?;
        }
        if let Some(w) = out.as_mut() {
            write!(w, "{},{},{},{},{}", t, st.s_mm, st.v, st.a, st.j).map_err(write_err)?;
            for p in &d.pos[..n] {
                write!(w, ",{p}").map_err(write_err)?;
            }
            if let Some(p) = plant.as_ref() {
                p.write_columns(w).map_err(write_err)?;
            }
            writeln!(w).map_err(write_err)?;
        }
        pipe.release_before(t);
    }
    if let Some(mut w) = out {
        w.flush().map_err(write_err)?;
    }
    if let Some(p) = plant.as_mut() {
        p.settle()?;
    }
    let duration = pipe.planned_until_s();
    if let Some(p) = &args.export_nodes {
        export_nodes(p, &settings, pipe.feed.path(), &pipe.kept)?;
    }
    if !ratios.vel.is_finite() || !ratios.acc.is_finite() || !ratios.jerk.is_finite() || !duration.is_finite() {
        return Err(CliError::Failure("internal error: the planned motion is not finite".into()));
    }
    let feed_stats = pipe.feed.stats();
    let stats = feed_stats.plan;
    let plan_s = feed_stats.plan_s;
    let length_mm = pipe.feed.path().length_mm();
    let mut prep_stats = feed_stats.prep;
    if prep_stats.pieces == 0 {
        // Nothing was smoothed, so no sample was checked against the tolerance.
        prep_stats.max_excess_mm = 0.0;
    }

    let mut stdout = std::io::stdout().lock();
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
            },
            "lookahead_mm": config.planner.lookahead_mm,
            "prep": { "wall_ms": feed_stats.prep_s * 1e3, "stats": prep_stats },
            "programmed": { "lines": checked.summary.lines, "elements": checked.elements, "length_mm": checked.length_mm },
        });
        // The plant figures only when a plant ran (no null members in the output).
        let mut json = json;
        if let Some(p) = plant.as_ref() {
            json["plant"] = p.json();
        }
        writeln!(stdout, "{json}").map_err(write_err)?;
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
        )
        .map_err(write_err)?;
        if let Some(p) = &plant {
            write!(stdout, "{}", p.summary()).map_err(write_err)?;
        }
    }
    Ok(())
}

/// Standstill simulated after the motion end for the plant summary's residual vibration, s.
const PLANT_SETTLE_S: f64 = 1.0;

/// `--plant`: the simulated axes (sim-plant, in-process) driven by the sampled setpoints.
struct PlantRun {
    plant: sim_plant::Plant,
    metrics: sim_plant::metrics::Metrics,
    /// The current row's setpoint per axis.
    targets: Vec<sim_plant::AxisTarget>,
    period_s: f64,
    names: Vec<String>,
}

impl PlantRun {
    fn new(config: &Config, choice: &str, period_s: f64) -> Result<Self, CliError> {
        let plant_config = config.plant.select(choice, &config.axes, "--plant")?;
        let resolved = plant_config.resolve(&config.axes, "--plant")?;
        let plant =
            sim_plant::Plant::new(&resolved, &plant_config).map_err(|e| CliError::BadInput(format!("--plant: {e}")))?;
        // The recording keeps the last `[plant] record_s` (the summary's residual vibration
        // needs only the settling after the end); the maxima run over everything.
        let metrics = sim_plant::metrics::Metrics::new(&plant, (config.plant.record_s / period_s).ceil() as usize);
        let targets = vec![sim_plant::AxisTarget::default(); plant.n_axes()];
        Ok(Self { plant, metrics, targets, period_s, names: config.axis_names() })
    }

    /// The first row places the plant at rest at its setpoint; each further row is one
    /// setpoint `period_s` later.
    fn step(&mut self) -> Result<(), CliError> {
        self.plant
            .step(&self.targets, self.period_s)
            .map_err(|e| CliError::Failure(format!("internal error: plant step: {e}")))?;
        self.metrics.record_plant(&self.plant);
        Ok(())
    }

    /// Holds the last setpoint for [`PLANT_SETTLE_S`] more (not written to the CSV), so the
    /// summary has the residual vibration after the motion end.
    fn settle(&mut self) -> Result<(), CliError> {
        for t in &mut self.targets {
            *t = sim_plant::AxisTarget { pos: t.pos, vel: 0.0, acc: 0.0 };
        }
        for _ in 0..(PLANT_SETTLE_S / self.period_s).ceil() as u64 {
            self.step()?;
        }
        Ok(())
    }

    fn write_header(&self, w: &mut impl Write) -> std::io::Result<()> {
        for n in &self.names {
            write!(w, ",{n}_motor,{n}_load,{n}_following_error,{n}_load_error")?;
        }
        writeln!(w)
    }

    fn write_columns(&self, w: &mut impl Write) -> std::io::Result<()> {
        for o in self.plant.outputs() {
            write!(w, ",{},{},{},{}", o.motor_pos, o.load_pos, o.following_error, o.load_error)?;
        }
        Ok(())
    }

    fn json(&self) -> serde_json::Value {
        let s = self.metrics.summary();
        let per_axis =
            |f: fn(&sim_plant::metrics::AxisSummary) -> serde_json::Value| s.axes.iter().map(f).collect::<Vec<_>>();
        serde_json::json!({
            "presets": per_axis(|a| a.preset.clone().into()),
            "max_following_error": per_axis(|a| a.max_following_error.into()),
            "max_load_error": per_axis(|a| a.max_load_error.into()),
            "residual_vibration": per_axis(|a| a.residual_amplitude.into()),
            "residual_peak_hz": per_axis(|a| a.residual_peak_hz.into()),
            "max_contour_error_mm": s.max_contour_error,
        })
    }

    fn summary(&self) -> String {
        self.metrics.summary().to_string()
    }
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
    planned_until_s: f64,
}

/// Segments sampled past are dropped in batches of at least this many (each drop moves the
/// rest of the kept list).
const RELEASE_BATCH: usize = 64;

impl Sampled {
    fn new(feed: Feed, keep_all: bool) -> Self {
        Self { feed, kept: Vec::new(), keep_all, cursor: Cursor::default(), planned_until_s: 0.0 }
    }

    /// The whole program is planned.
    fn finished(&self) -> bool {
        self.feed.finished()
    }

    /// End time of the planned motion so far, s.
    fn planned_until_s(&self) -> f64 {
        self.planned_until_s
    }

    /// Plans on until at least one more segment is planned (or the program is planned to its
    /// end).
    fn advance(&mut self) -> Result<(), CliError> {
        self.feed.plan(f64::MIN_POSITIVE).map_err(feed_error)?;
        while let Some(seg) = self.feed.pop_segment() {
            self.planned_until_s = seg.t1_s();
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

/// A feed's error as `interpd plan` reports it: a bad program or a motion that cannot be
/// planned is bad input (exit 2), a failure of the smoothing stage is not.
fn feed_error(e: FeedError) -> CliError {
    match e {
        FeedError::Program(e) => e.into(),
        FeedError::Plan(e) => CliError::BadInput(e.to_string()),
        FeedError::Prep(e) => CliError::Failure(e.to_string()),
    }
}

/// The planning problem and our solution at the nodes, as JSON (read by benches/reference/optimum.py; docs/planner.md).
fn export_nodes(
    file: &std::path::Path,
    settings: &Settings,
    path: &Path,
    segments: &[Segment],
) -> Result<(), CliError> {
    let export = NodeExport::of(settings, path, segments);
    let (n, lim) = (path.n_axes, &export.limits);
    let geom = |g: &NodeGeom| serde_json::json!({ "d1": &g.d1[..n], "d2": &g.d2[..n], "d3": &g.d3[..n] });
    let json = serde_json::json!({
        "axes": path.axis_names,
        "limits": {
            "vel": &lim.vel[..n], "acc_max": &lim.acc_max[..n], "acc_min": &lim.acc_min[..n], "jerk": &lim.jerk[..n],
        },
        "check_fractions": export.check_fractions,
        // The check points of a node's interval where it is "fine".
        "fine_check_fractions": export.fine_check_fractions,
        "curvature_jump_s": export.curvature_jump_s,
        "nodes": export.nodes.iter().map(|nd| serde_json::json!({
            "s": nd.s_mm, "vbar": nd.vbar_mm_s, "feed": if nd.feed_mm_s.is_finite() { nd.feed_mm_s } else { f64::MAX },
            "stop": nd.stop, "left": geom(&nd.left), "right": geom(&nd.right),
            // A path table's exact geometry to the next node, which the checks evaluate there.
            "span": nd.span,
            "fine": nd.fine,
        })).collect::<Vec<_>>(),
        "profile": export.profile,
        "duration_s": duration_s(segments),
    });
    std::fs::write(file, json.to_string())
        .map_err(|e| CliError::Failure(format!("{}: cannot write: {e}", file.display())))
}
