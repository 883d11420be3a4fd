//! The real-time thread: its scheduling, then the loop over the executor and the sinks.
//!
//! The body of the cycle (the closure given to [`rt::run_loop`]) runs under the real-time
//! contract of [`crate::interp`]: it reads atomic flags and counters (hold, stop, the
//! optional-stop switch, the pause releases, a reposition at rest after homing), steps the
//! executor, hands the
//! setpoint to each sink and stores it for `status`. It never allocates, locks, blocks or logs
//! (daemon/tests/rt_no_alloc.rs proves the allocation part).

use super::Shared;
use crate::comp::Compensation;
use crate::comp::io::CompIo;
use crate::interp::executor::ExecutorFaults;
use crate::interp::{Epoch, Executor, Io};
use crate::rt::{self, LoopTotals, sched::SchedReport};
use crate::sinks::SetpointSink;
use crossbeam::channel::Sender;
use interpd_motion::path::MAX_AXES;
use interpd_protocol::shm::{Setpoints, flags};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// Delay from start-up to the first cycle (lets the threads settle).
const FIRST_CYCLE_DELAY_NS: u64 = 20_000_000;

/// Publish errors are copied to the shared counter this often (cycles), so the cycle touches
/// the shared cache line rarely.
const PUBLISH_ERRORS_EVERY: u64 = 256;

/// Testing aid (`interpd run --debug-stall-cycle`): the real-time thread sleeps once for
/// `for_s` in the first cycle after `after_s` seconds of running motion, before the sinks
/// publish, so that cycle's setpoint (and its SYNC on CAN) comes late by that much. The
/// drives' SYNC watchdog is tested with it; a sleep neither allocates nor locks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleStall {
    pub after_s: f64,
    pub for_s: f64,
}

/// The thread's body: applies the real-time scheduling, reports it on `ready`, then runs the
/// cycles until `shared.quit`.
pub(super) fn run(
    shared: Arc<Shared>,
    mut sinks: Vec<Box<dyn SetpointSink + Send>>,
    mut comp: Option<(Compensation, Option<CompIo>)>,
    start_position: Option<[f64; MAX_AXES]>,
    stall: Option<CycleStall>,
    ready: Sender<SchedReport>,
) -> (LoopTotals, ExecutorFaults) {
    let sched = rt::sched::apply(&shared.config.rt);
    let _ = ready.send(sched);
    let n_axes = shared.config.axes.len();
    let mut executor = Executor::new(n_axes, start_position.unwrap_or([0.0; MAX_AXES]));
    let mut sp = Setpoints { n_axes: n_axes as u32, ..Setpoints::default() };
    let period_ns = (shared.config.machine.cycle_ms * 1e6).round() as u64;
    let dt_s = period_ns as f64 * 1e-9;
    let start_ns = rt::clock::now_ns() + FIRST_CYCLE_DELAY_NS;
    let mut publish_errors = 0u64;
    // The stall as (cycles of running motion before it, its length).
    let mut stall = stall.map(|s| ((s.after_s / dt_s).round().max(1.0) as u64, Duration::from_secs_f64(s.for_s)));
    let mut running_cycles = 0u64;
    let totals = rt::run_loop(start_ns, period_ns, &shared.quit, &shared.timing, |cycle, deadline_ns, late| {
        let io = Io {
            chunks: &shared.queues.chunks,
            recycle: &shared.queues.recycle,
            notices: &shared.notices,
            hold: shared.hold.load(Ordering::Relaxed),
            stop: shared.stop.load(Ordering::Relaxed),
            epoch_floor: Epoch::from_number(shared.epoch_floor.load(Ordering::SeqCst)),
            optional_stop: shared.optional_stop.load(Ordering::Relaxed),
            releases: shared.pause_releases.load(Ordering::SeqCst),
        };
        if let Some((axis, pos)) = shared.reposition.pending() {
            // Only at rest: a moving axis keeps its path (the request waits).
            if executor.rest_at(axis, pos) {
                shared.reposition.clear();
            }
        }
        executor.step(cycle, dt_s, &io, &mut sp);
        sp.cycle = cycle;
        sp.time_ns = deadline_ns;
        if late {
            sp.flags |= flags::LATE;
        }
        if let Some((stage, io)) = comp.as_mut() {
            let event = stage.apply(&mut sp, dt_s, || io.as_ref().and_then(|io| io.measurements.pop()));
            if let Some(io) = io.as_ref().filter(|_| stage.uses_actuator()) {
                // Before the setpoints: the plant takes the latest command with each setpoint.
                io.send_actuator(stage.actuator_command());
            }
            if let Some(e) = event {
                let _ = shared.comp_events.push(e);
            }
        }
        if let Some((after, pause)) = stall {
            if sp.flags & flags::RUNNING != 0 {
                running_cycles += 1;
                if running_cycles >= after {
                    std::thread::sleep(pause);
                    stall = None;
                }
            }
        }
        for sink in sinks.iter_mut() {
            if sink.publish(&sp).is_err() {
                publish_errors += 1;
            }
        }
        shared.live.store(&sp);
        if publish_errors > 0 && cycle % PUBLISH_ERRORS_EVERY == 0 {
            shared.publish_errors.store(publish_errors, Ordering::Relaxed);
        }
        true
    });
    shared.publish_errors.store(publish_errors, Ordering::Relaxed);
    if let Some((stage, _)) = &comp {
        let s = stage.stats();
        // After the loop: the lock is outside the cycle.
        *super::lock(&shared.comp_stats) = Some(*s);
        tracing::info!(
            accepted = s.accepted,
            discarded_invalid = s.discarded_invalid,
            discarded_absurd = s.discarded_absurd,
            lost = s.lost,
            limiter_clamps = s.limiter_clamps,
            "compensation: measurements"
        );
    }
    (totals, executor.faults)
}
