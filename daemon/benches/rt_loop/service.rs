//! The real service under load: `Service` with shared memory on (a service prefix of its
//! own), a program loaded and started through its control interface and restarted each time
//! it finishes, until the loop has run the requested number of cycles; then a controlled stop
//! and the report of `shutdown` (the same figures `interpd run` prints at exit).

use super::stream::{Monitor, StreamCheck};
use interpd::config::Config;
use interpd::control::{Motion, ProgramSource};
use interpd::service::{Service, ServiceOptions, ShutdownReport};
use interpd_protocol::api::{Event, State};
use std::path::Path;
use std::time::{Duration, Instant};

/// How often the benchmark looks at the service's status.
const POLL: Duration = Duration::from_millis(50);
/// Longest a controlled stop may take at the end.
const STOP_TIMEOUT: Duration = Duration::from_secs(10);

/// One service run.
pub struct ServiceRun {
    pub report: ShutdownReport,
    pub stream: StreamCheck,
    /// Times the program was started (it restarts when it finishes).
    pub program_starts: u64,
    pub underruns: u64,
    pub errors: Vec<String>,
    pub wall_s: f64,
}

/// Runs the service on `config` for at least `cycles` cycles, executing `program` over and over.
/// The subscriber runs on `monitor_cpu` at SCHED_FIFO `monitor_priority`.
pub fn run(
    mut config: Config,
    prefix: &str,
    program: &Path,
    cycles: u64,
    monitor_cpu: usize,
    monitor_priority: i32,
) -> Result<ServiceRun, String> {
    config.sinks.shm = true;
    config.sinks.shm_prefix = prefix.to_string();
    let period_ns = (config.machine.cycle_ms * 1e6).round() as u64;
    let monitor = Monitor::start(prefix, period_ns, monitor_cpu, monitor_priority)?;
    let t0 = Instant::now();
    let service = Service::start(ServiceOptions { config, shm: true }).map_err(|e| e.to_string())?;
    let core = service.core();
    let events = core.subscribe();
    core.load(ProgramSource::File(program.to_path_buf()), false).map_err(|e| format!("{}: {e}", program.display()))?;
    core.start().map_err(|e| e.to_string())?;
    let (mut program_starts, mut underruns, mut errors) = (1u64, 0u64, Vec::new());
    loop {
        std::thread::sleep(POLL);
        for e in events.try_iter() {
            match e {
                Event::Underrun { .. } => underruns += 1,
                Event::Error { message } => errors.push(message),
                _ => {}
            }
        }
        let status = core.status();
        if status.cycle + 1 >= cycles {
            break;
        }
        match status.state {
            State::Finished => {
                core.start().map_err(|e| e.to_string())?;
                program_starts += 1;
            }
            State::Error => {
                // Recorded above; clear it and carry on, so the timing figures cover the run.
                let _ = core.stop();
                core.wait_for(&[State::Idle], STOP_TIMEOUT);
                core.start().map_err(|e| e.to_string())?;
                program_starts += 1;
            }
            _ => {}
        }
    }
    let _ = core.stop();
    let state = core.wait_for(&[State::Idle, State::Finished], STOP_TIMEOUT);
    if !matches!(state, State::Idle | State::Finished) {
        errors.push(format!("no rest {} s after the final stop (state {state})", STOP_TIMEOUT.as_secs()));
    }
    let report = service.shutdown();
    let wall_s = t0.elapsed().as_secs_f64();
    let stream = monitor.finish()?;
    Ok(ServiceRun { report, stream, program_starts, underruns, errors, wall_s })
}
