//! The supervisor thread: what the real-time and planner threads report becomes state changes
//! and events, timing samples become histograms, drive faults stop the machine.
//!
//! It polls rather than blocks: the real-time thread reports through lock-free queues it
//! cannot wake anyone on.

use super::feeder::{FeederCommand, FeederReport};
use super::state::{Control, Loaded, RunKind};
use super::{Shared, lock};
use crate::interp::{DivertCause, Notice};
use crossbeam::channel::Receiver;
use interpd_protocol::api::{Event, PauseStatus, State};
use interpd_protocol::shm::flags;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// Poll period: events and state changes lag the motion by at most this.
const PERIOD: Duration = Duration::from_millis(2);

/// The thread's body, until `shared.quit`.
pub(super) fn run(shared: Arc<Shared>, reports: Receiver<FeederReport>) {
    while !shared.quit.load(Ordering::SeqCst) {
        while let Some(n) = shared.notices.pop() {
            on_notice(&shared, n);
        }
        while let Ok(r) = reports.try_recv() {
            on_report(&shared, r);
        }
        while let Some(e) = shared.comp_events.pop() {
            let event = match e {
                crate::comp::CompEvent::Lost { age_ms } => {
                    tracing::warn!(age_ms, "compensation: no valid measurement, the corrections fade out");
                    Event::MeasurementLost { age_ms }
                }
                crate::comp::CompEvent::Restored => {
                    tracing::info!("compensation: measurements again, the corrections fade back in");
                    Event::MeasurementRestored
                }
            };
            shared.emit(event);
        }
        drain_timing(&shared);
        check_drives(&shared);
        finish_stop_if_standing(&shared);
        std::thread::sleep(PERIOD);
    }
}

/// Moves the queued timing samples into the histograms.
pub(super) fn drain_timing(shared: &Shared) {
    let mut h = lock(&shared.histograms);
    while let Some(s) = shared.timing.pop() {
        h.record(&s);
    }
}

fn on_notice(shared: &Shared, n: Notice) {
    let mut ctl = lock(&shared.control);
    match n {
        Notice::Started { epoch, cycle } => {
            ctl.epochs.saw(epoch);
            if ctl.start_event_pending {
                ctl.start_event_pending = false;
                ctl.start_cycle = cycle;
                let event = match (ctl.kind, &ctl.manual) {
                    (RunKind::Manual, Some(m)) => Event::Jogging { kind: m.kind },
                    _ => Event::Started,
                };
                drop(ctl);
                shared.emit(event);
            } else if ctl.underrun {
                ctl.underrun = false;
                drop(ctl);
                shared.emit(Event::UnderrunCleared);
            }
        }
        Notice::Diverted { epoch, cause, .. } => {
            ctl.epochs.saw(epoch);
            let _ = shared.feeder.send(FeederCommand::Diverted { epoch, cause });
            if cause == DivertCause::Underrun {
                ctl.underrun = true;
                drop(ctl);
                tracing::warn!("underrun: the planner did not keep up; stopping along the path");
                shared.emit(Event::Underrun { s_mm: shared.live.load().s_mm });
            }
        }
        Notice::Stood { epoch, seq, cause, s_mm, cycle } => {
            ctl.epochs.saw(epoch);
            let _ = shared.feeder.send(FeederCommand::Stood { epoch, seq, cause, s_mm });
            if ctl.state == State::Stopping {
                drop(ctl);
                complete_stop(shared);
            } else if ctl.state == State::Jogging && cause == DivertCause::Hold {
                manual_done(shared, ctl, cycle);
            } else if cause == DivertCause::Hold && ctl.state == State::Holding {
                drop(ctl);
                shared.emit(Event::Held);
            }
        }
        Notice::Finished { epoch, cycle, .. } => {
            ctl.epochs.saw(epoch);
            if ctl.state == State::Stopping {
                drop(ctl);
                complete_stop(shared);
                return;
            }
            if ctl.state == State::Jogging {
                manual_done(shared, ctl, cycle);
                return;
            }
            // The work offsets a program run to its end leaves are kept (the parameter file),
            // before the state says `finished`: a client that sees it finds the file written.
            if let (RunKind::Program, Some((_, Loaded::Program { offsets_end: Some(o), .. }))) =
                (&ctl.kind, &ctl.program)
            {
                shared.keep_program_offsets(o);
            }
            // An MDI from a hold returns to the held program (resume moves back to it).
            if ctl.kind == RunKind::Mdi && ctl.excursion {
                ctl.state = State::Holding;
                ctl.kind = RunKind::Program;
                shared.hold.store(true, Ordering::SeqCst);
            } else {
                ctl.state = State::Finished;
            }
            let duration_s = (cycle - ctl.start_cycle) as f64 * shared.config.cycle_s();
            // The messages after the program's last motion come out at its end.
            let program_ended = ctl.state == State::Finished && ctl.kind == RunKind::Program;
            drop(ctl);
            if program_ended {
                let events = lock(&shared.messages).take_upto(None);
                events.into_iter().for_each(|e| shared.emit(e));
            }
            shared.emit(Event::Finished { duration_s });
        }
        Notice::Line { line, .. } => {
            drop(ctl);
            shared.emit(Event::LineReached { line });
        }
        Notice::Message { upto, .. } => {
            drop(ctl);
            let events = lock(&shared.messages).take_upto(Some(upto));
            for e in events {
                if let Event::Message { kind, text, line, .. } = &e {
                    tracing::info!(line, ?kind, text = text.as_str(), "program message");
                }
                shared.emit(e);
            }
        }
        Notice::Paused { line, code, .. } => {
            // A hold asked for on the way is answered by the pause: the program stands.
            if !matches!(ctl.state, State::Running | State::Holding) {
                return;
            }
            ctl.state = State::Paused;
            ctl.pause = Some(PauseStatus { line, code });
            drop(ctl);
            tracing::info!(line, ?code, "program stop: waiting for motion.resume");
            shared.emit(Event::Paused { line, code });
        }
    }
}

fn on_report(shared: &Shared, r: FeederReport) {
    match r {
        FeederReport::Error(message) => {
            let mut ctl = lock(&shared.control);
            ctl.state = State::Error;
            ctl.last_error = Some(message.clone());
            drop(ctl);
            shared.emit(Event::Error { message });
        }
        FeederReport::Complete { .. } => {}
        FeederReport::JogLimit { axis, limit } => {
            let name = shared.config.axes.get(axis).map(|a| a.name.to_string()).unwrap_or_default();
            let mut ctl = lock(&shared.control);
            if let Some(m) = ctl.manual.as_mut().filter(|m| !m.limit_reached.contains(&name)) {
                m.limit_reached.push(name.clone());
            }
            drop(ctl);
            tracing::info!(axis = %name, limit, "jog brakes to the soft limit");
            shared.emit(Event::JogLimitReached { axis: name, limit });
        }
    }
}

/// A manual motion ended (the machine stands): back to idle, or to the held program it left.
fn manual_done(shared: &Shared, mut ctl: std::sync::MutexGuard<'_, Control>, cycle: u64) {
    let duration_s = cycle.saturating_sub(ctl.start_cycle) as f64 * shared.config.cycle_s();
    let kind = ctl.manual.as_ref().map_or(interpd_protocol::api::ManualKind::Jog, |m| m.kind);
    ctl.manual_braking = false;
    if ctl.excursion {
        ctl.state = State::Holding;
        ctl.kind = RunKind::Program;
    } else {
        ctl.state = State::Idle;
    }
    shared.hold.store(ctl.excursion, Ordering::SeqCst);
    drop(ctl);
    shared.emit(Event::JogDone { kind, duration_s });
}

/// A drive fault (reported by the drive monitor) while the machine moves: a controlled stop
/// along the path, the fault as `last_error` and an error event. At rest it is only logged
/// (motion.start refuses until the drives are ready again).
fn check_drives(shared: &Shared) {
    let Some(drives) = &shared.drives else { return };
    while let Some(message) = drives.take_fault() {
        let mut ctl = lock(&shared.control);
        if !matches!(ctl.state, State::Running | State::Holding | State::Jogging) {
            continue;
        }
        shared.request_stop(&mut ctl);
        ctl.last_error = Some(message.clone());
        drop(ctl);
        tracing::error!("drive fault during motion: {message}; stopping");
        shared.emit(Event::Error { message });
    }
}

/// A stop requested while the machine already stood (held, or after an underrun) completes
/// without a tail.
fn finish_stop_if_standing(shared: &Shared) {
    let stopping = lock(&shared.control).state == State::Stopping;
    if stopping && shared.live.load().flags & flags::IDLE != 0 {
        complete_stop(shared);
    }
}

/// The machine stands after a stop: drop what is queued, clear the requests, go idle.
fn complete_stop(shared: &Shared) {
    let _ = shared.feeder.send(FeederCommand::Abort);
    // The executor takes no chunk while the stop flag is set: empty the queue first.
    while let Some(c) = shared.queues.chunks.pop() {
        let _ = shared.queues.recycle.push(c);
    }
    let mut ctl = lock(&shared.control);
    if ctl.state != State::Stopping {
        return;
    }
    ctl.state = State::Idle;
    ctl.held_by_override = false;
    ctl.excursion = false;
    ctl.manual_braking = false;
    shared.hold.store(false, Ordering::SeqCst);
    shared.stop.store(false, Ordering::SeqCst);
    drop(ctl);
    shared.emit(Event::Stopped);
}
