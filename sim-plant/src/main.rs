//! `sim-plant [--config FILE] [--source shm] [--plot FILE.png] [--service-prefix P] ...`:
//! the simulated axis plant as a process (docs/plant.md).
//!
//! Subscribes to `P/setpoints` over iceoryx2, steps the axis models to each setpoint and
//! publishes `P/feedback`; on SIGINT/SIGTERM (or after a FINISHED setpoint with
//! `--exit-on-finish`) prints a summary on stderr, writes the plot and exits 0. Exit 2 for bad
//! arguments or configuration, 1 for transport or output failures.

use clap::Parser;
use interpd_config::Config;
use sim_plant::metrics::Metrics;
use sim_plant::plot::{self, PlotOptions};
use sim_plant::shm::{self, RunOptions, RunReport, ShmPlant, StopReason};
use sim_plant::{Plant, PlantError};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Debug, Parser)]
#[command(
    name = "sim-plant",
    version,
    about = "Simulated elastic axis plant: interpd setpoints in over iceoryx2, drive and mechanics feedback out"
)]
struct Args {
    /// Machine configuration (TOML, its [[axis]] and [plant] sections); default: the embedded XYZ machine.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Setpoint source: `shm` (iceoryx2), or `can:IFACE`: every axis a CiA 402 drive node on
    /// that SocketCAN interface (node-IDs and scales from the configuration's [sinks.can]).
    #[arg(long, default_value = "shm")]
    source: String,
    /// Write a PNG plot of the run (setpoint vs load, errors, spectrum) at exit.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Service prefix: services PREFIX/setpoints and PREFIX/feedback [default: $INTERPD_SERVICE_PREFIX, else interpd].
    #[arg(long)]
    service_prefix: Option<String>,
    /// Poll period of the setpoint subscriber, µs.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u64).range(10..=100_000))]
    poll_us: u64,
    /// Exit after the first setpoint flagged FINISHED (after simulating --settle-s of standstill).
    #[arg(long)]
    exit_on_finish: bool,
    /// Standstill simulated after FINISHED for the residual-vibration figures, s.
    #[arg(long, default_value_t = 1.0)]
    settle_s: f64,
    /// Also write the summary figures as one JSON object to this file at exit.
    #[arg(long)]
    summary_json: Option<PathBuf>,
    /// Write the recorded run as CSV at exit: per setpoint t_s and per axis the setpoint,
    /// load, tool and actuator position (axis unit) and the process force (N).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Run with SCHED_FIFO at this priority (1–99), or fail if the system refuses. For the
    /// drives on CAN sharing a computer with the daemon: just below the daemon's real-time
    /// thread ([rt] priority, default 80), so neither waits for anything else and the master's
    /// cycle is not held up by the drives' work. Also locks the process's memory (as root or
    /// with an unlimited memory-lock limit).
    #[arg(long, value_name = "PRIORITY", value_parser = clap::value_parser!(i32).range(1..=99))]
    rt_priority: Option<i32>,
    /// More log output on stderr (-v debug, -vv trace). RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count)]
    verbose: u8,
}

/// A failure with its exit code: 2 bad input, 1 anything else.
struct Failure {
    code: u8,
    message: String,
}

impl Failure {
    fn bad_input(message: impl Into<String>) -> Self {
        Self { code: 2, message: message.into() }
    }
}

impl From<PlantError> for Failure {
    fn from(e: PlantError) -> Self {
        let code = match e {
            PlantError::Config(_) | PlantError::Input(_) => 2,
            _ => 1,
        };
        Self { code, message: e.to_string() }
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    init_logging(args.verbose);
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("sim-plant: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

fn run(args: &Args) -> Result<(), Failure> {
    let can_iface = match args.source.as_str() {
        "shm" => None,
        s if s.starts_with("can:") => {
            let iface = &s[4..];
            interpd_config::sinks::CanConfig::check_interface(iface)
                .map_err(|e| Failure::bad_input(format!("--source {s}: {e}")))?;
            Some(iface.to_string())
        }
        s => return Err(Failure::bad_input(format!("--source {s}: expected `shm` or `can:IFACE`"))),
    };
    if !(args.settle_s.is_finite() && (0.0..=600.0).contains(&args.settle_s)) {
        return Err(Failure::bad_input(format!("--settle-s must lie in [0, 600], got {}", args.settle_s)));
    }
    if let Some(p) = &args.plot {
        check_plot_path(p)?;
    }
    // Memory is locked (and then populated as it is allocated) at normal priority; the loop
    // switches to SCHED_FIFO only once everything it uses is allocated.
    if args.rt_priority.is_some() {
        lock_memory();
    }
    let mut config = Config::load_or_default(args.config.as_deref()).map_err(PlantError::from)?;
    if let Some(iface) = can_iface {
        return run_can(args, &mut config, &iface);
    }
    let mut plant = Plant::from_config(&config)?;
    let capacity = (config.plant.record_s / config.cycle_s()).ceil() as usize;
    let mut metrics = Metrics::new(&plant, capacity);
    let prefix = args.service_prefix.clone().unwrap_or_else(shm::prefix_from_env);
    interpd_protocol::shm::check_service_prefix(&prefix)
        .map_err(|e| Failure::bad_input(format!("--service-prefix: {e}")))?;
    let mut node = ShmPlant::open(&prefix)?;
    node.open_process_io(&plant)?;
    let axes: Vec<String> = plant.axes().iter().map(|a| format!("{} {}", a.name, a.preset)).collect();
    eprintln!(
        "sim-plant: ready: {} axes ({}), servo {:.0} Hz, subscribed to {}, publishing {}",
        plant.n_axes(),
        axes.join(", "),
        1.0 / plant.servo_period_s(),
        node.setpoints_service(),
        node.feedback_service()
    );
    let options = RunOptions {
        poll: Duration::from_micros(args.poll_us),
        exit_on_finish: args.exit_on_finish,
        settle_s: args.settle_s,
    };
    if let Some(priority) = args.rt_priority {
        set_fifo(priority)?;
    }
    let report = node.run(&mut plant, Some(&mut metrics), &options)?;
    print_summary(&report, &metrics);
    print_actuators(&plant);
    if let Some(p) = &args.summary_json {
        let json = summary_json(&report, &metrics);
        std::fs::write(p, format!("{json}\n"))
            .map_err(|e| Failure { code: 1, message: format!("--summary-json {}: {e}", p.display()) })?;
    }
    if let Some(p) = &args.trace {
        write_trace(p, &metrics).map_err(|e| Failure { code: 1, message: format!("--trace {}: {e}", p.display()) })?;
    }
    if let Some(p) = &args.plot {
        if metrics.count() < 2 {
            eprintln!("sim-plant: no plot written to {}: fewer than 2 setpoints received", p.display());
        } else {
            let title = format!("sim-plant: {} setpoints, {}", metrics.count(), axes.join(", "));
            plot::write_png(p, &metrics, &PlotOptions { title, ..PlotOptions::default() })?;
            eprintln!("sim-plant: plot written to {}", p.display());
        }
    }
    Ok(())
}

/// SCHED_FIFO at `priority` for the calling thread (sim-plant's loops run on it).
fn set_fifo(priority: i32) -> Result<(), Failure> {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc != 0 {
        return Err(Failure {
            code: 1,
            message: format!(
                "--rt-priority {priority}: SCHED_FIFO refused: {} (needs CAP_SYS_NICE or an rtprio limit, see \
                 docs/realtime.md)",
                std::io::Error::from_raw_os_error(rc)
            ),
        });
    }
    Ok(())
}

/// With `--rt-priority`: locks the process's memory, present and future (mlockall), so no page
/// fault (a page being zeroed, a transparent huge page) lands in the loop; its buffers are
/// allocated, and so populated, before it starts. Where the memory-lock limit is finite and the
/// process is not root, later allocations beyond it would fail, so the memory stays unlocked
/// there, with a warning.
fn lock_memory() {
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: plain syscalls with valid arguments.
    let unlimited =
        unsafe { libc::getrlimit(libc::RLIMIT_MEMLOCK, &mut limit) } == 0 && limit.rlim_cur == libc::RLIM_INFINITY;
    // SAFETY: as above.
    let root = unsafe { libc::geteuid() } == 0;
    if !(unlimited || root) {
        tracing::warn!("--rt-priority: memory not locked (RLIMIT_MEMLOCK is finite): page faults may delay the loop");
        return;
    }
    // SAFETY: as above.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } != 0 {
        tracing::warn!(
            "--rt-priority: mlockall failed: {}: page faults may delay the loop",
            std::io::Error::last_os_error()
        );
    }
}

/// `--source can:IFACE`: the drives on the bus until SIGINT/SIGTERM.
fn run_can(args: &Args, config: &mut Config, iface: &str) -> Result<(), Failure> {
    if args.exit_on_finish {
        return Err(Failure::bad_input(
            "--exit-on-finish: CAN setpoints carry no end-of-program flag; stop with SIGTERM",
        ));
    }
    // A missing interface is the user's input, reported before anything claims to be ready.
    if !std::path::Path::new("/sys/class/net").join(iface).exists() {
        return Err(Failure::bad_input(format!(
            "--source can:{iface}: there is no network interface {iface} (`ip link show {iface}`; for a virtual bus \
             `ip link add dev {iface} type vcan && ip link set up {iface}`)"
        )));
    }
    // A CSP drive gets positions only: it interpolates linearly between them.
    config.plant.fine_interpolation = interpd_config::plant::FineInterpolation::Linear;
    let mut plant = Plant::from_config(config)?;
    let capacity = (config.plant.record_s / config.cycle_s()).ceil() as usize;
    let mut metrics = Metrics::new(&plant, capacity);
    let stop = sim_plant::can::install_signal_handlers();
    let n = config.axes.len();
    let nodes: Vec<String> =
        config.sinks.can.node_ids(n).iter().zip(&config.axes).map(|(id, a)| format!("{} node {id}", a.name)).collect();
    eprintln!(
        "sim-plant: ready: {n} CiA 402 drives on CAN {iface} ({}), cycle {} ms, servo {:.0} Hz",
        nodes.join(", "),
        config.machine.cycle_ms,
        1.0 / plant.servo_period_s()
    );
    if let Some(priority) = args.rt_priority {
        set_fifo(priority)?;
    }
    let report = sim_plant::can::run(config, &mut plant, Some(&mut metrics), iface, stop)?;
    let b = &report.bus;
    eprintln!(
        "sim-plant: stopped after {:.3} s: {} frames received, {} SYNC; ignored: {} RPDO1 for other nodes, {} wrong \
         DLC, {} unknown COB-ID, {} bad value, {} not data frames, {} frames of other nodes, {} node-ID conflicts, \
         {} receive errors; {} frames sent, {} send errors; {} free-running cycles; {:.3} s simulated",
        report.wall_s,
        b.rx_frames,
        b.syncs,
        b.rpdo_other_node,
        b.wrong_dlc,
        b.unknown_cob_id,
        b.bad_value,
        b.not_data,
        b.other_node_frames,
        b.node_id_conflicts,
        b.rx_errors,
        b.tx_frames,
        b.tx_errors,
        b.free_running_cycles,
        report.simulated_s
    );
    for (id, nmt, power, s) in &report.nodes {
        eprintln!(
            "sim-plant: node {id}: {nmt}, {power}; {} SYNC, {} RPDO1, {} bad RPDO1 length, {} NMT, {} watchdog trips, \
             {} following errors, {} EMCY sent ({} inhibited)",
            s.syncs,
            s.rpdos,
            s.rpdo_bad_length,
            s.nmt_commands,
            s.watchdog_trips,
            s.following_errors,
            s.emcy_sent,
            s.emcy_inhibited
        );
    }
    if metrics.count() > 0 {
        eprint!("{}", metrics.summary());
    }
    Ok(())
}

/// The plot goes into an existing directory and is a .png file (checked before the run, so a
/// long run does not end in an unwritable path).
fn check_plot_path(p: &std::path::Path) -> Result<(), Failure> {
    if p.extension().and_then(|e| e.to_str()).is_none_or(|e| !e.eq_ignore_ascii_case("png")) {
        return Err(Failure::bad_input(format!("--plot {}: the plot is a PNG file, name it *.png", p.display())));
    }
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    if !dir.is_dir() {
        return Err(Failure::bad_input(format!("--plot {}: directory {} does not exist", p.display(), dir.display())));
    }
    Ok(())
}

fn print_summary(report: &RunReport, metrics: &Metrics) {
    let s = &report.stats;
    let why = match report.stop {
        StopReason::Signal => "stopped by signal",
        StopReason::Finished => "program finished",
    };
    let rtf = if report.compute_s > 0.0 { report.simulated_s / report.compute_s } else { 0.0 };
    eprintln!(
        "sim-plant: {why} after {:.3} s: {} setpoints received, {} used, {} rejected (version {}, axis count {}, \
         non-finite {}), {} cycles missed, {} time anomalies, {} resyncs; {} feedback published; {:.3} s simulated \
         in {:.3} s compute (real-time factor {:.0})",
        report.wall_s,
        s.received,
        s.accepted,
        s.rejected(),
        s.bad_version,
        s.bad_axis_count,
        s.non_finite,
        s.missed_cycles,
        s.time_anomalies,
        s.resyncs,
        report.published,
        report.simulated_s,
        report.compute_s,
        rtf
    );
    if metrics.count() > 0 {
        eprint!("{}", metrics.summary());
    }
}

/// Stroke use of the fast actuators (`[plant.actuator]`).
fn print_actuators(plant: &Plant) {
    for (i, a) in plant.axes().iter().enumerate() {
        if let Some(act) = plant.actuator(i) {
            eprintln!(
                "sim-plant: actuator {}: largest |x| {:.4} mm of ±{:.4} mm ({:.0} % of the stroke), {} servo steps at a limit",
                a.name,
                act.max_abs_m() * 1e3,
                act.stroke_m() * 1e3,
                100.0 * act.max_abs_m() / act.stroke_m(),
                act.saturated_steps()
            );
        }
    }
}

/// The figures of a run as JSON (units: mm or deg, N or N·m, s, Hz; null where not measured).
fn summary_json(report: &RunReport, metrics: &Metrics) -> serde_json::Value {
    let m = metrics.summary();
    let axes: Vec<serde_json::Value> = m
        .axes
        .iter()
        .enumerate()
        .map(|(i, a)| {
            serde_json::json!({
                "name": a.name.to_string(),
                "preset": a.preset,
                "max_following_error": a.max_following_error,
                "rms_following_error": a.rms_following_error,
                "max_load_error": a.max_load_error,
                "max_motor_force": a.max_motor_force,
                "residual_amplitude": a.residual_amplitude,
                "residual_peak_hz": a.residual_peak_hz,
                "settling_time_s": a.settling.and_then(|s| s.settling_time_s),
                "settling_band": a.settling.map(|s| s.band),
                "settling_window_s": a.settling.map(|s| s.window_s),
                "overshoot": a.settling.map(|s| s.overshoot),
                "vibration_amplitude": a.settling.and_then(|s| s.vibration_amplitude),
                "vibration_hz": a.settling.and_then(|s| s.vibration_hz),
                "actuator_max_abs": metrics_actuator_max(metrics, i),
            })
        })
        .collect();
    serde_json::json!({
        "setpoints_received": report.stats.received,
        "setpoints_used": report.stats.accepted,
        "missed_cycles": report.stats.missed_cycles,
        "duration_s": m.duration_s,
        "max_contour_error": m.max_contour_error,
        "rms_contour_error": m.rms_contour_error,
        "axes": axes,
    })
}

/// Largest |actuator position| of axis `i` over the recording, axis unit.
fn metrics_actuator_max(metrics: &Metrics, i: usize) -> f64 {
    metrics.samples(i).iter().fold(0.0_f64, |m, s| m.max(s.actuator.abs()))
}

/// The recording as CSV (see `--trace`).
fn write_trace(path: &std::path::Path, metrics: &Metrics) -> std::io::Result<()> {
    use std::io::Write;
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let names = metrics.axis_names();
    let mut header = vec!["t_s".to_string()];
    for n in names {
        for col in ["setpoint", "load", "tool", "actuator", "process_force_n"] {
            header.push(format!("{n}_{col}"));
        }
    }
    writeln!(w, "{}", header.join(","))?;
    let samples: Vec<Vec<sim_plant::metrics::Sample>> = (0..names.len()).map(|i| metrics.samples(i)).collect();
    for (k, t) in metrics.times().iter().enumerate() {
        write!(w, "{t:.6}")?;
        for s in &samples {
            let s = &s[k];
            write!(w, ",{:.9},{:.9},{:.9},{:.9},{:.3}", s.setpoint, s.load, s.tool, s.actuator, s.process_force)?;
        }
        writeln!(w)?;
    }
    w.flush()
}

fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).init();
    // iceoryx2 logs on its own; its start-up notice about the missing config file is noise.
    iceoryx2::prelude::set_log_level(match verbose {
        0 => iceoryx2::prelude::LogLevel::Error,
        1 => iceoryx2::prelude::LogLevel::Info,
        _ => iceoryx2::prelude::LogLevel::Debug,
    });
}
