//! `interpd run [--config FILE] [--socket PATH] ...`: the service. Control socket, planner and
//! real-time threads, sinks; SIGINT/SIGTERM bring the machine to a controlled stop and exit 0.

use super::CliError;
use super::signals::TerminationSignals;
use interpd::config::Config;
use interpd::control::{ControlServer, Motion};
use interpd::record::{RecordFile, RecordOptions, Recorder};
use interpd::service::{CycleStall, Service, ServiceCore, ServiceExtras, ServiceOptions, StartupError};
use interpd::sinks::can::CanMaster;
use interpd_protocol::api::State;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// How long a controlled stop on SIGTERM may take before the daemon exits anyway.
const STOP_TIMEOUT: Duration = Duration::from_secs(10);

/// Options of `interpd run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Machine and daemon configuration (TOML); default: the embedded 3-axis machine.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Control socket path (overrides `[control] socket`).
    #[arg(long)]
    pub socket: Option<PathBuf>,
    /// Do not publish setpoints over iceoryx2 (overrides `[sinks] shm`).
    #[arg(long)]
    pub no_shm: bool,
    /// iceoryx2 service prefix (services `<prefix>/setpoints`, `<prefix>/feedback`); default:
    /// $INTERPD_SERVICE_PREFIX, else `[sinks] shm_prefix`, else "interpd".
    #[arg(long)]
    pub service_prefix: Option<String>,
    /// CANopen master (CiA 402 CSP) on this SocketCAN interface, e.g. `can0` or `vcan0`
    /// (overrides `[sinks.can] interface`; node-IDs and scales come from `[sinks.can]`).
    #[arg(long, value_name = "IFACE")]
    pub can: Option<String>,
    /// Write the CAN bus traffic to FILE in the `candump -l` format (needs a CAN interface).
    #[arg(long, value_name = "FILE")]
    pub candump: Option<PathBuf>,
    /// Testing aid: the planner thread stalls once for FOR_S seconds after AFTER_S seconds of
    /// motion were queued, to provoke an underrun. Format AFTER_S:FOR_S.
    #[arg(long, value_name = "AFTER_S:FOR_S")]
    pub debug_stall_planner: Option<String>,
    /// Testing aid: the real-time thread stalls once for FOR_S seconds in the cycle after
    /// AFTER_S seconds of running motion, before it publishes (its SYNC on CAN comes late), to
    /// provoke the drives' SYNC watchdog. Format AFTER_S:FOR_S.
    #[arg(long, value_name = "AFTER_S:FOR_S")]
    pub debug_stall_cycle: Option<String>,
    /// Record the setpoint and feedback streams to this MCAP file, created or truncated (docs/formats.md,
    /// "Recordings (MCAP)"); the recording ends when the daemon exits.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
}

pub fn run(args: &RunArgs) -> Result<(), CliError> {
    let mut config = Config::load_or_default(args.config.as_deref())?;
    // The parameter file lies relative to the configuration file.
    if let (Some(file), Some(dir)) =
        (config.programs.parameter_file.clone(), args.config.as_deref().and_then(std::path::Path::parent))
    {
        config.programs.parameter_file = Some(dir.join(file).display().to_string());
    }
    // The iceoryx2 service prefix: --service-prefix, else INTERPD_SERVICE_PREFIX, else the
    // configuration (`[sinks] shm_prefix`, default "interpd").
    let env_prefix = std::env::var(interpd_protocol::shm::SERVICE_PREFIX_ENV).ok().filter(|p| !p.is_empty());
    if let Some(p) = args.service_prefix.clone().or(env_prefix) {
        interpd_protocol::shm::check_service_prefix(&p)
            .map_err(|e| CliError::BadInput(format!("--service-prefix: {e}")))?;
        config.sinks.shm_prefix = p;
    }
    check_can_args(args, &mut config)?;
    let stall = args.debug_stall_planner.as_deref().map(|s| parse_stall("--debug-stall-planner", s)).transpose()?;
    let cycle_stall = args.debug_stall_cycle.as_deref().map(|s| parse_stall("--debug-stall-cycle", s)).transpose()?;
    let socket = args.socket.clone().unwrap_or_else(|| PathBuf::from(config.control.socket_path()));
    if args.record.is_some() && (!config.sinks.shm || args.no_shm) {
        return Err(CliError::BadInput(
            "--record records the shared-memory streams, but the shared-memory sink is off (--no-shm or [sinks] \
             shm = false)"
                .into(),
        ));
    }
    let record_file = args
        .record
        .as_deref()
        .map(RecordFile::create)
        .transpose()
        .map_err(|e| CliError::BadInput(format!("--record: {e}")))?;
    let signals = TerminationSignals::block();
    // The recorder subscribes before the real-time thread publishes its first setpoint.
    let recorder = record_file.map(|f| start_recorder(f, &config)).transpose()?;

    let mut extras = ServiceExtras::default();
    if let Some((after_s, for_s)) = cycle_stall {
        eprintln!("interpd: debug: the real-time thread will stall for {for_s} s after {after_s} s of motion");
        extras.debug_stall_cycle = Some(CycleStall { after_s, for_s });
    }
    let can = if config.sinks.can.enabled() {
        let start = CanMaster::start(&config, args.candump.as_deref()).map_err(|e| CliError::Failure(e.to_string()))?;
        eprintln!(
            "interpd: CAN {}: {} drives configured in {:.1} ms ({} SDO transfers), {} silent; {} of {} answered at \
             start-up",
            config.sinks.can.interface,
            start.boot.nodes,
            start.boot.elapsed_ms,
            start.boot.sdo_transfers,
            start.boot.silent,
            start.answered,
            config.axes.len()
        );
        extras.sinks.push(Box::new(start.sink));
        extras.drives = Some(start.master.monitor());
        extras.start_position = Some(start.start_position);
        Some(start.master)
    } else {
        None
    };
    let service =
        Service::start_with(ServiceOptions { config: config.clone(), shm: config.sinks.shm && !args.no_shm }, extras)
            .map_err(|e| match e {
            StartupError::ProgramsDir(_) | StartupError::ParamFile(_) => CliError::BadInput(e.to_string()),
            e => CliError::Failure(e.to_string()),
        })?;
    if service.sched().all_granted() {
        tracing::info!("real-time thread: {}", service.sched());
    } else {
        eprintln!(
            "interpd: real-time thread: {} — running with soft real-time only (grant CAP_SYS_NICE and memlock, see docs/realtime.md, \"PREEMPT_RT host settings\")",
            service.sched()
        );
    }
    let core = service.core();
    if let Some(recorder) = &recorder {
        forward_recording_failures(recorder, core.clone())?;
    }
    if let Some((after_s, for_s)) = stall {
        eprintln!("interpd: debug: the planner thread will stall for {for_s} s after {after_s} s of motion");
        core.debug_stall_planner(after_s, for_s);
    }
    let server = ControlServer::builder()
        .socket(&socket)
        .stop_on_disconnect(config.control.stop_on_disconnect)
        .build(Arc::new(core.clone()))
        .map_err(|e| CliError::Failure(e.to_string()))?;
    eprintln!(
        "interpd: running: {} axes, cycle {} ms, control socket {}, setpoints on {}",
        config.axes.len(),
        config.machine.cycle_ms,
        socket.display(),
        if config.sinks.shm && !args.no_shm {
            format!("iceoryx2 {}/setpoints", config.sinks.shm_prefix)
        } else {
            "no sink".into()
        }
    );
    eprintln!("interpd: program.load reads files from {} ([programs] dir)", service.programs_dir().display());
    if can.is_some() {
        eprintln!("interpd: CAN master on {} (CiA 402 CSP)", config.sinks.can.interface);
    }

    // Without a timeout the wait returns only with a signal.
    let signal = signals.wait(None).unwrap_or("SIGTERM");
    eprintln!("interpd: {signal}: stopping the motion");
    let _ = core.stop();
    let state = core.wait_for(&[State::Idle, State::Finished, State::Error], STOP_TIMEOUT);
    if !matches!(state, State::Idle | State::Finished) {
        eprintln!("interpd: the machine did not come to rest within {} s (state {state})", STOP_TIMEOUT.as_secs());
    }
    server.shutdown();
    let recorded = recorder.map(Recorder::stop);
    let report = service.shutdown();
    eprintln!("interpd: {}", report.histograms);
    eprintln!(
        "interpd: {} cycles, {} late, {} overruns; {} chunks planned, {} replans, largest setpoint deviation {:.3} µm; {} publish errors",
        report.totals.cycles,
        report.totals.late_cycles,
        report.totals.overruns,
        report.feeder.chunks,
        report.feeder.replans,
        report.feeder.max_coarse_error_mm * 1e3,
        report.publish_errors
    );
    for p in &report.publishers {
        eprintln!(
            "interpd: shared memory: {} setpoints published, {} dropped, {} failed",
            p.published, p.dropped, p.failed
        );
    }
    if let Some(can) = can {
        eprintln!("interpd: CAN bus: {}", can.shutdown());
    }
    match recorded {
        Some(Ok(r)) => eprintln!("interpd: {r}"),
        Some(Err(e)) => return Err(CliError::Failure(format!("recording failed: {e}"))),
        None => {}
    }
    Ok(())
}

/// `--can IFACE` into the configuration; `--candump` needs a CAN interface and a directory.
fn check_can_args(args: &RunArgs, config: &mut Config) -> Result<(), CliError> {
    if let Some(iface) = &args.can {
        interpd::config::sinks::CanConfig::check_interface(iface)
            .map_err(|e| CliError::BadInput(format!("--can: {e}")))?;
        config.sinks.can.interface = iface.clone();
    }
    if let Some(path) = &args.candump {
        if !config.sinks.can.enabled() {
            return Err(CliError::BadInput(
                "--candump: there is no CAN bus to log: give --can IFACE or set [sinks.can] interface".into(),
            ));
        }
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
        if !dir.is_dir() {
            return Err(CliError::BadInput(format!(
                "--candump {}: directory {} does not exist",
                path.display(),
                dir.display()
            )));
        }
    }
    Ok(())
}

/// Tells the clients (an `error` event) when the recording stops early, a write having failed:
/// a thread that waits for the recorder's failure and ends with the recorder.
fn forward_recording_failures(recorder: &Recorder, core: ServiceCore) -> Result<(), CliError> {
    let failures = recorder.failures();
    std::thread::Builder::new()
        .name("interpd-rec-watch".into())
        .spawn(move || {
            for e in failures.iter() {
                core.report_recording_failure(&e);
            }
        })
        .map(drop)
        .map_err(|e| CliError::Failure(format!("--record: cannot start the thread that watches the recording: {e}")))
}

/// Starts recording `<prefix>/setpoints` and `<prefix>/feedback`, with the machine in the
/// file's metadata.
fn start_recorder(file: RecordFile, config: &Config) -> Result<Recorder, CliError> {
    let mut options = RecordOptions::new(&config.sinks.shm_prefix);
    let axes: Vec<String> = config.axes.iter().map(|a| a.name.to_string()).collect();
    options.metadata.insert("axes".into(), axes.join(" "));
    options.metadata.insert("cycle_ms".into(), config.machine.cycle_ms.to_string());
    Recorder::start(file, options).map_err(|e| CliError::Failure(format!("--record: {e}")))
}

fn parse_stall(flag: &str, s: &str) -> Result<(f64, f64), CliError> {
    let bad = || CliError::BadInput(format!("{flag}: expected AFTER_S:FOR_S (seconds), got {s:?}"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let (a, b): (f64, f64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > 0.0 && b <= 60.0) {
        return Err(bad());
    }
    Ok((a, b))
}
