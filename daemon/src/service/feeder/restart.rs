//! How a run goes on after the planned motion was left or changed: a restart from rest (after
//! a hold, an underrun or a planning failure), the return to a held program after an
//! excursion (jog, MDI), and a new feed override (a replan from the end of the queue).

use super::run::{Motion, PathRun, Run, Wait};
use super::{Feeder, RestartError};
use crate::interp::Epoch;
use crate::interp::coarse::CoarsePoint;
use crate::service::manual::{ManualGoal, ManualPart};
use interpd_motion::feed::AT_POSITION_TOL;
use interpd_motion::path::{AxisVec, MAX_AXES};
use interpd_motion::planner::PlanError;

impl Feeder {
    /// The held program continues as `epoch`: first a move-to from `here` back to the point it
    /// was held at, then the rest of the program from rest there.
    pub(super) fn resume_suspended(&mut self, epoch: Epoch, here: AxisVec) {
        let Some(held) = self.suspended.take() else { return };
        // The figures of the excursion (jog, MDI) are not the program's.
        self.health.reset();
        let Wait::Resume { s_mm, .. } = held.wait else {
            tracing::error!("resume: the held program never came to rest");
            return;
        };
        if let Some(mut run) = self.run.take() {
            self.pool.append(&mut run.staged);
        }
        let Some(path) = held.motion.into_path() else {
            tracing::error!("resume: the held motion has no path to return to");
            return;
        };
        match self.return_run(path, held.feed_override, epoch, s_mm, here) {
            Ok(run) => {
                self.stats.replans += 1;
                self.run = Some(run);
            }
            Err(e) => self.failed(&e),
        }
    }

    /// A run of `path` from rest at `s_mm` as `epoch`, preceded by the move from `here` to the
    /// path there when the machine stands elsewhere.
    fn return_run(
        &self,
        mut path: PathRun,
        feed_override: f64,
        epoch: Epoch,
        s_mm: f64,
        here: AxisVec,
    ) -> Result<Run, RestartError> {
        let (at, line) = path.feed.eval(s_mm)?;
        path.feed.restart_at_rest(s_mm, Vec::new());
        let n = self.axis_limits.len();
        let away = (0..n).any(|k| (here[k] - at.pos[k]).abs() > AT_POSITION_TOL);
        path.returning = None;
        if away {
            let mut target = [None; MAX_AXES];
            for (t, p) in target.iter_mut().zip(at.pos).take(n) {
                *t = Some(p);
            }
            let goal = ManualGoal::MoveTo { target, vel: [0.0; MAX_AXES], factor: 1.0 };
            path.returning = Some(ManualPart::new(goal, here, &self.axis_limits, 1.0, Some(s_mm))?);
        }
        let start = CoarsePoint::at_rest(0.0, s_mm, line, if away { here } else { at.pos });
        Ok(Run::new(Motion::Path(path), feed_override, epoch, s_mm, start))
    }

    /// Replans the rest of the path from rest at `s_mm`, as the run's current epoch; a manual
    /// motion continues its goal from rest where the tail of chunk `seq` ended; the rest of a
    /// law program runs as rapid moves along its lines.
    pub(super) fn restart_at_rest(&mut self, seq: u64, s_mm: f64) {
        let Some(old) = self.run.take() else { return };
        let (feed_override, epoch, queued_s, end) = (old.feed_override, old.epoch, old.queued_s, old.end);
        let restarted = match old.motion {
            Motion::Manual(part) => {
                let here = part.tail_end(seq).unwrap_or(end.pos);
                self.stats.replans += 1;
                match part.restarted(here) {
                    Ok(part) => {
                        let start = CoarsePoint::at_rest(0.0, end.s_mm, 0, here);
                        Ok(Run::new(Motion::Manual(part), feed_override, epoch, 0.0, start))
                    }
                    Err(e) => return self.manual_failed(&e),
                }
            }
            Motion::Path(mut path) if path.returning.is_some() => {
                let here = path.returning.take().and_then(|p| p.tail_end(seq)).unwrap_or(end.pos);
                self.stats.replans += 1;
                self.return_run(path, feed_override, epoch, old.s_start_mm, here)
            }
            motion => {
                let Some(mut path) = motion.into_path() else { return };
                self.stats.replans += 1;
                path.feed
                    .eval(s_mm)
                    .map(|(at, line)| {
                        path.feed.restart_at_rest(s_mm, Vec::new());
                        let start = CoarsePoint::at_rest(0.0, s_mm, line, at.pos);
                        Run::new(Motion::Path(path), feed_override, epoch, s_mm, start)
                    })
                    .map_err(RestartError::from)
            }
        };
        match restarted {
            Ok(mut run) => {
                run.queued_s = queued_s;
                self.run = Some(run);
            }
            Err(e) => self.failed(&e),
        }
    }

    /// A new feed override: replans from the end of the queue (the queued motion runs out
    /// first) with the programmed feeds scaled. The stop tail from there floors the new bounds,
    /// so a lower feed is reached by braking no harder than that stop.
    pub(super) fn set_override(&mut self, factor: f64) {
        let Some(run) = self.run.as_mut() else { return };
        run.feed_override = factor;
        let replan = run.wait == Wait::No && !run.complete;
        match &mut run.motion {
            Motion::Manual(part) => {
                if let Err(e) = part.set_override(factor) {
                    self.manual_failed(&e);
                }
            }
            Motion::Law { .. } => {}
            Motion::Path(path) => {
                // Elements the planner takes from now on are scaled by the new factor.
                path.feed.set_feed_override(factor);
                if replan {
                    self.stats.replans += 1;
                    let end = run.end;
                    path.feed.replan(end.s_mm, end.v_mm_s, end.a_mm_s2, run.last_tail.clone());
                }
            }
        }
    }

    /// After a planning failure in motion (the planner could not continue from a state in
    /// motion, e.g. after an override change): the queue ends with a stop tail that is known to
    /// keep the limits. Run it as motion and replan the rest from rest at its end. `false` if
    /// the machine is at rest there already (a failure from rest is a real error).
    pub(super) fn recover(&mut self, e: &PlanError) -> bool {
        let Some(run) = self.run.as_ref().filter(|r| matches!(r.motion, Motion::Path(_))) else { return false };
        let Some(last) = run.last_tail.last() else { return false };
        let s_stop = last.s1_mm();
        tracing::warn!("planner: {e}; stopping along the path at s = {s_stop:.3} mm and replanning from there");
        self.stats.recoveries += 1;
        let Some(Run {
            motion: Motion::Path(mut path),
            mut last_tail,
            feed_override,
            epoch,
            end,
            seq,
            queued_s,
            staged,
            ..
        }) = self.run.take()
        else {
            return false;
        };
        path.feed.restart_at_rest(s_stop, std::mem::take(&mut last_tail));
        let mut fresh = Run::new(Motion::Path(path), feed_override, epoch, s_stop, end);
        fresh.seq = seq;
        fresh.queued_s = queued_s;
        fresh.staged = staged;
        self.run = Some(fresh);
        true
    }
}
