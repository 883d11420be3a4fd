//! The smoothing stage: programmed elements in, smoothed elements out, online.
//!
//! Consecutive G64 elements form a run. Their points are placed as the elements arrive; as
//! soon as `window_segments` segments lie ahead of the committed node, the window is solved
//! and its first segment committed as quintic pieces (Haas 2012, §3.6.3, windowing III, started
//! from the program start). A window that fails falls back to a smaller window, then to a
//! looser end, and finally to an exact stop and the programmed path for that segment; each
//! fallback is logged and counted. G61 elements pass through unchanged.

use super::bspline;
use super::condition::{Conditioned, Conditioner};
use super::elements::{RunElem, angle_between};
use super::pieces;
use super::points::Placer;
use super::qp::QpFailure;
use super::run::{Run, RunEnd};
use super::settings::StageSettings;
use super::simplify;
use super::stats::PrepStats;
use super::verify;
use super::window::{RightEnd, STATE_LEVELS, Solution, Solvers, State, WindowInput};
use crate::Settings;
use crate::path::{
    AxisDerivs, AxisVec, Blend, Element, Geometry, JointKind, Line, MAX_AXES, Pause, QuinticSpan, SpanError,
    classify_joint,
};
use interpd_config::PrepMethod;
use std::collections::VecDeque;
use std::time::Instant;

/// Re-solves with a narrower band when the check finds a piece outside the tolerance.
const VERIFY_RETRIES: usize = 3;
/// Re-solves with one more point inside every piece that left the band, per window attempt: the
/// QP's points pinned to alternate band edges (ringing on a short leg, a reversal) leave the
/// pieces between them room to bulge out, which a point in between takes away.
const REFINE_RETRIES: usize = 8;
/// A piece shorter than this many tolerances is not split further; its band narrows instead.
const REFINE_MIN_PER_TOL: f64 = 0.25;
/// Band factor applied around a piece that failed the check.
const VERIFY_SHRINK: f64 = 0.5;
/// A committed node farther than this from the programmed path gets a connecting line before
/// an exact stop, mm.
const ON_PATH_MM: f64 = 1e-9;

/// A failure the fallbacks could not absorb: the program line and path position, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: path smoothing failed at s = {s_mm:.4} mm: {reason}")]
pub struct PrepError {
    pub line: u32,
    pub s_mm: f64,
    pub reason: PrepFailure,
}

/// Why the stage failed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PrepFailure {
    /// Where the stage returns to the programmed path, a part of a programmed element could
    /// not be represented as path geometry.
    #[error("cannot follow the programmed element exactly: {0:?}")]
    ExactPart(SpanError),
}

/// The B-spline's state at a window's committed point and the levels the next window keeps
/// (`None`: the window's pieces are Hermite pieces, the QP's state holds).
type SplineEnd = Option<(State, usize)>;

/// Which rung of the fallback ladder a window attempt is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rung {
    Normal,
    Smaller,
    Looser,
}

/// The online smoothing stage.
pub(crate) struct Prep {
    st: StageSettings,
    solvers: Solvers,
    out: VecDeque<Element>,
    out_s_mm: f64,
    last_out: Option<Element>,
    run: Option<Run>,
    cond: Conditioner,
    /// The B-spline basis values of the last window's points, which the next window shares.
    spline_basis: bspline::BasisCache,
    pub(crate) stats: PrepStats,
}

impl Prep {
    pub(crate) fn new(settings: &Settings) -> Self {
        Self {
            st: StageSettings::new(settings),
            solvers: Solvers::default(),
            out: VecDeque::new(),
            out_s_mm: 0.0,
            last_out: None,
            run: None,
            cond: Conditioner::new(settings.axes.len()),
            spline_basis: bspline::BasisCache::default(),
            stats: PrepStats { max_excess_mm: f64::NEG_INFINITY, ..PrepStats::default() },
        }
    }

    /// Takes the next programmed element.
    pub(crate) fn push(&mut self, e: Element) -> Result<(), PrepError> {
        self.stats.moves_in += 1;
        let tol = self.g64_tol(&e);
        if let Some(t) = tol.filter(|_| Conditioner::mergeable(&e)) {
            return match self.cond.push(e, t) {
                Some(c) => self.push_conditioned(c),
                None => Ok(()),
            };
        }
        if let Some(c) = self.cond.flush() {
            self.push_conditioned(c)?;
        }
        let c = self.cond.pass(e);
        self.push_conditioned(c)
    }

    /// The tolerance of an element the stage smooths, `None` for one it passes through.
    fn g64_tol(&self, e: &Element) -> Option<f64> {
        match e.blend {
            Blend::Tolerance { tol_mm, .. } if self.smoothable(e) => Some(tol_mm),
            _ => None,
        }
    }

    /// Takes the next conditioned element: it continues the open run, closes it, or starts one.
    fn push_conditioned(&mut self, c: Conditioned) -> Result<(), PrepError> {
        if c.programmed.len() > 1 {
            self.stats.chords += 1;
            self.stats.moves_merged += c.programmed.len() as u64 - 1;
            self.stats.merge_deviation_mm = self.stats.merge_deviation_mm.max(c.deviation_mm);
        }
        let e = &c.element;
        let tol = self.g64_tol(e);
        if let Some(run) = self.run.as_mut() {
            if let Some(t) = tol {
                let last = run.elems.last().expect("a run holds an element");
                let mut d = AxisDerivs::default();
                e.geometry.eval(0.0, &mut d);
                let turn = angle_between(&last.t_end, &d.d1, self.st.n_axes);
                if !e.holds() && turn <= self.st.max_corner_rad {
                    run.push(c, t);
                    run.place(&self.st);
                    return self.advance();
                }
            }
            let tangent = matches!(e.joint, JointKind::Smooth | JointKind::CurvatureJump);
            let end = if tol.is_none() && tangent && !e.holds() {
                RunEnd::Join(start_state(e, self.st.spacing_mm))
            } else {
                RunEnd::Stop
            };
            self.close_run(end)?;
        }
        match tol {
            Some(t) => self.start_run(c, t),
            None => {
                self.emit_programmed(c.element);
                Ok(())
            }
        }
    }

    /// No more elements follow.
    pub(crate) fn finish(&mut self) -> Result<(), PrepError> {
        if let Some(c) = self.cond.flush() {
            self.push_conditioned(c)?;
        }
        if self.run.is_some() {
            self.close_run(RunEnd::Stop)?;
        }
        Ok(())
    }

    /// Whether every element before the next stop has been given out and the next element
    /// given out starts with that stop: a run that has given out nothing since it started at
    /// rest (or since an exact stop inside it), or a chord held for a run that will start at
    /// rest. The planner can then plan to the stop before the element is there.
    pub(crate) fn rests_before_next(&self) -> bool {
        if self.last_out.is_none() {
            return false;
        }
        match (&self.run, self.cond.first()) {
            (Some(run), _) => matches!(run.next_joint, JointKind::Start | JointKind::Corner),
            (None, Some(first)) => {
                !matches!(first.joint, JointKind::Smooth | JointKind::CurvatureJump) || first.holds()
            }
            (None, None) => false,
        }
    }

    /// The next smoothed (or passed-through) element, when one is ready.
    pub(crate) fn pop(&mut self) -> Option<Element> {
        self.out.pop_front()
    }

    /// Only elements whose path length counts over the linear axes and that move no rotary
    /// axis can be smoothed in the linear tolerance band.
    fn smoothable(&self, e: &Element) -> bool {
        if matches!(e.geometry, Geometry::Septic(_)) {
            return false;
        }
        let mut a = AxisDerivs::default();
        e.geometry.eval(0.0, &mut a);
        let unit = (0..self.st.n_axes).filter(|&k| self.st.linear[k]).map(|k| a.d1[k] * a.d1[k]).sum::<f64>();
        let rotary_turns = |k: usize| a.d1[k] != 0.0;
        // A line moves an axis exactly where its direction does; other shapes are asked at
        // their end too.
        let rotary_moves = match &e.geometry {
            Geometry::Line(_) => (0..self.st.n_axes).any(|k| !self.st.linear[k] && rotary_turns(k)),
            g => {
                let mut b = AxisDerivs::default();
                g.eval(g.length_mm(), &mut b);
                (0..self.st.n_axes).any(|k| !self.st.linear[k] && (a.pos[k] != b.pos[k] || rotary_turns(k)))
            }
        };
        !rotary_moves && (unit - 1.0).abs() < 1e-6
    }

    fn start_run(&mut self, c: Conditioned, tol: f64) -> Result<(), PrepError> {
        let e = &c.element;
        let tangent = matches!(e.joint, JointKind::Smooth | JointKind::CurvatureJump) && !e.holds();
        let (state, levels, joint) = match &self.last_out {
            Some(prev) if tangent => (end_state(prev, self.st.spacing_mm), 3.min(self.st.levels), JointKind::Smooth),
            prev => {
                let mut s = start_state(e, self.st.spacing_mm);
                s.iter_mut().for_each(|a| a[1..].iter_mut().for_each(|x| *x = 0.0));
                (s, 1, if prev.is_none() { JointKind::Start } else { JointKind::Corner })
            }
        };
        self.stats.runs += 1;
        let mut run = Run::new(e.dwell_before_s, e.pause_before, state, levels, joint, self.st.n_axes);
        run.push(c, tol);
        run.place(&self.st);
        self.run = Some(run);
        self.advance()
    }

    fn close_run(&mut self, end: RunEnd) -> Result<(), PrepError> {
        if let Some(run) = self.run.as_mut() {
            run.end = end;
            run.place(&self.st);
        }
        self.advance()?;
        if let Some(run) = self.run.take() {
            debug_assert!(run.points.len() <= 1, "a closed run is committed to its end");
        }
        Ok(())
    }

    /// Solves and commits windows while enough points lie ahead.
    fn advance(&mut self) -> Result<(), PrepError> {
        let w = self.st.window_segments;
        loop {
            let Some(run) = self.run.as_ref() else { return Ok(()) };
            let (mut count, mut w_end, mut last_end) = (0, 0, 0);
            for i in run.segment_ends() {
                count += 1;
                if count == w {
                    w_end = i;
                }
                last_end = i;
            }
            if run.points.len() <= 1 {
                return Ok(());
            }
            let at_end = run.reached_end();
            if at_end && count >= 1 && count <= w {
                // The run's last windows: solved to its end (a fallback may commit less).
                self.commit_window(last_end, true)?;
                continue;
            }
            if count >= w && w_end > 0 {
                self.commit_window(w_end, false)?;
                continue;
            }
            return Ok(());
        }
    }

    /// Solves the window `points[..=last]` down the fallback ladder and commits its first
    /// segment (all of it when it ends the run).
    fn commit_window(&mut self, last: usize, is_final: bool) -> Result<(), PrepError> {
        let run = self.run.as_ref().expect("advance checked");
        let ends: Vec<usize> = run.segment_ends().take_while(|&i| i <= last).collect();
        let first_end = ends[0];
        tracing::debug!(
            s_mm = run.points[0].s_mm,
            first_end_mm = run.points[first_end].s_mm,
            last_mm = run.points[last].s_mm,
            points = last + 1,
            is_final,
            "window"
        );
        let final_right = match run.end {
            RunEnd::Join(s) => RightEnd::Join(s),
            _ => RightEnd::Position,
        };
        let mut ladder: Vec<(usize, RightEnd, usize, Rung)> = Vec::new();
        ladder.push((
            last,
            if is_final { final_right } else { RightEnd::Position },
            if is_final { last } else { first_end },
            Rung::Normal,
        ));
        for m in (1..ends.len()).rev() {
            ladder.push((ends[m - 1], RightEnd::Position, first_end, Rung::Smaller));
        }
        if !is_final {
            ladder.push((last, RightEnd::Band, first_end, Rung::Looser));
        } else if matches!(final_right, RightEnd::Join(_)) {
            ladder.push((last, RightEnd::Position, last, Rung::Looser));
        }
        let mut commit_on_failure = if is_final { last } else { first_end };
        for i in 0..ladder.len() {
            let (mut w_last, right, mut commit, rung) = ladder[i];
            let mut inserted = Vec::new();
            let result = self.try_window(&mut w_last, right, &mut commit, &mut inserted);
            // Points inserted into this attempt stay: the later rungs' indices move past them.
            for &at in &inserted {
                for r in &mut ladder[i + 1..] {
                    r.0 += usize::from(r.0 >= at);
                    r.2 += usize::from(r.2 >= at);
                }
                commit_on_failure += usize::from(commit_on_failure >= at);
            }
            match result {
                Ok((pieces, sol, spline_end)) => {
                    self.count_rung(rung, w_last);
                    self.emit_pieces(pieces, commit);
                    let state = spline_end.map_or(sol.states[commit], |(s, _)| s);
                    let run = self.run.as_mut().expect("open run");
                    // Hermite pieces of higher continuity need the QP's next window to start on
                    // x‴ (and x⁗) too.
                    run.commit_to(commit, state, self.st.hermite_levels.min(self.st.levels), self.st.spacing_mm);
                    if let Some((_, levels)) = spline_end {
                        run.spline_levels = levels;
                    }
                    self.stats.windows += 1;
                    return Ok(());
                }
                Err(f) => {
                    tracing::debug!(
                        ?rung,
                        ?f,
                        s_mm = self.run.as_ref().map_or(0.0, |r| r.points[0].s_mm),
                        "window failed"
                    )
                }
            }
        }
        self.exact_stop(commit_on_failure)
    }

    fn count_rung(&mut self, rung: Rung, w_last: usize) {
        let s_mm = self.run.as_ref().map_or(0.0, |r| r.points[0].s_mm);
        match rung {
            Rung::Normal => {}
            Rung::Smaller => {
                self.stats.fallback_smaller += 1;
                tracing::warn!(s_mm, points = w_last + 1, "path smoothing: fallback to a smaller window");
            }
            Rung::Looser => {
                self.stats.fallback_looser += 1;
                tracing::warn!(s_mm, "path smoothing: fallback to a looser window end");
            }
        }
    }

    /// One window solve with the check. A piece outside the band gets a point halfway along it
    /// (while it is long enough), else its band narrows, and the window is solved again.
    /// Points inserted move `last` and `commit` on; `inserted` collects their indices so the
    /// caller can move its other indices too.
    fn try_window(
        &mut self,
        last: &mut usize,
        right: RightEnd,
        commit: &mut usize,
        inserted: &mut Vec<usize>,
    ) -> Result<(Vec<QuinticSpan>, Solution, SplineEnd), QpFailure> {
        let mut shrink = vec![1.0; *last + 1];
        let (mut narrowed, mut refined) = (0, 0);
        loop {
            let run = self.run.as_ref().expect("open run");
            let input = WindowInput {
                points: &run.points[..=*last],
                left: &run.state,
                left_levels: run.left_levels,
                right,
                shrink: &shrink,
            };
            let t0 = Instant::now();
            let result = self.solvers.solve(&self.st, &input);
            let dt = t0.elapsed().as_secs_f64();
            self.stats.solves += 1;
            self.stats.solve_s_total += dt;
            self.stats.solve_s_max = self.stats.solve_s_max.max(dt);
            self.stats.qp_declined = self.solvers.declined;
            self.stats.qp_refined_steps = self.solvers.refined_steps;
            self.stats.qp_rescaled = self.solvers.rescaled;
            let sol = match result {
                Ok(s) => s,
                Err(f) => {
                    match f {
                        QpFailure::Infeasible => self.stats.infeasible += 1,
                        QpFailure::Slow => self.stats.slow += 1,
                        QpFailure::Numerical => self.stats.numerical += 1,
                    }
                    return Err(f);
                }
            };
            self.stats.iterations += u64::from(sol.iterations);
            let checked = match window_method(run, self.st.method) {
                PrepMethod::Hermite => {
                    check_all_pieces(run, &self.st, &mut self.stats, &sol, *commit, true).map(|p| (p, None))
                }
                PrepMethod::Bspline => {
                    let can_refine = |j: usize| {
                        let (a, b) = (&run.points[j], &run.points[j + 1]);
                        refined < REFINE_RETRIES
                            && b.s_mm - a.s_mm >= REFINE_MIN_PER_TOL * a.prog_tol_mm.min(b.prog_tol_mm)
                    };
                    let cache = &mut self.spline_basis;
                    let refine = SplineRefine { can: can_refine, hermite_guides: 2 * refined >= REFINE_RETRIES };
                    check_spline(run, &self.st, &mut self.stats, cache, &sol, *commit, right, refine)
                        .map_err(|j| vec![j])
                }
            };
            let failed = match checked {
                Ok((pieces, spline_end)) => return Ok((pieces, sol, spline_end)),
                Err(failed) => failed,
            };
            let run = self.run.as_mut().expect("open run");
            // Every piece outside the band that is long enough gets a point halfway along it,
            // in one re-solve: the ringing that pushes one piece out pushes its neighbours out
            // too, and refining them one per solve runs out of re-solves before it runs out of
            // pieces.
            let splittable = |j: usize| {
                let (a, b) = (&run.points[j], &run.points[j + 1]);
                b.s_mm - a.s_mm >= REFINE_MIN_PER_TOL * a.prog_tol_mm.min(b.prog_tol_mm)
            };
            let split: Vec<usize> = failed.iter().copied().filter(|&j| splittable(j)).collect();
            if refined < REFINE_RETRIES && !split.is_empty() {
                refined += 1;
                self.stats.refined += 1;
                // From the back, so the indices still to come stay valid.
                for &j in split.iter().rev() {
                    let (a, b) = (run.points[j], run.points[j + 1]);
                    tracing::debug!(
                        piece = j,
                        s_mm = a.s_mm,
                        to_mm = b.s_mm,
                        "point inserted into a piece outside the band"
                    );
                    run.points.insert(j + 1, Placer::midpoint(&run.elems, &self.st, &a, &b));
                    shrink.insert(j + 1, shrink[j].min(shrink[j + 1]));
                    *last += 1;
                    *commit += 1;
                    inserted.push(j + 1);
                }
                continue;
            }
            if narrowed == VERIFY_RETRIES {
                return Err(QpFailure::Numerical);
            }
            narrowed += 1;
            self.stats.verify_retries += 1;
            // The band narrows once on each point near a failed piece, however many failed.
            let mut near = vec![false; *last + 1];
            for &j in &failed {
                near[j.saturating_sub(1)..(j + 3).min(*last + 1)].iter_mut().for_each(|n| *n = true);
            }
            for (s, _) in shrink.iter_mut().zip(&near).filter(|(_, n)| **n) {
                *s *= VERIFY_SHRINK;
            }
        }
    }

    fn emit_pieces(&mut self, pieces: Vec<QuinticSpan>, commit: usize) {
        let run = self.run.as_mut().expect("open run");
        let srcs: Vec<Element> = (0..commit).map(|j| run.elems.get(run.points[j].elem).element.clone()).collect();
        self.stats.points += commit as u64;
        self.stats.smoothed_mm += run.points[commit].s_mm - run.points[0].s_mm;
        for (piece, src) in pieces.into_iter().zip(srcs) {
            let run = self.run.as_mut().expect("open run");
            let joint = std::mem::replace(&mut run.next_joint, JointKind::Smooth);
            let dwell = std::mem::take(&mut run.dwell_s);
            let pause = run.pause.take();
            self.stats.pieces += 1;
            self.emit(Geometry::Quintic(Box::new(piece)), joint, (dwell, pause), &src);
        }
    }

    /// The last rung: stop, return to the programmed path and follow it exactly to
    /// `points[commit]`.
    fn exact_stop(&mut self, commit: usize) -> Result<(), PrepError> {
        self.stats.fallback_exact += 1;
        let st = self.st.clone();
        let run = self.run.as_mut().expect("open run");
        let p0 = run.points[0];
        let target = run.points[commit];
        tracing::warn!(
            s_mm = p0.s_mm,
            to_mm = target.s_mm,
            "path smoothing: exact stop, programmed path for one segment"
        );
        let c_pos: AxisVec = std::array::from_fn(|k| run.state[k][0]);
        let from = run.elems.index_at(p0.s_mm - 2.0 * st.spacing_mm, p0.elem);
        let (s_f, f_pos) = run.elems.nearest(&c_pos, from, p0.elem + 1);
        let s_f = s_f.min(target.s_mm);
        // (geometry, joint, source element, the band left to simplify it in; NaN: keep as is).
        let mut parts: Vec<(Geometry, JointKind, Element, f64)> = Vec::new();
        let gap = (0..st.n_axes).map(|k| (c_pos[k] - f_pos[k]).powi(2)).sum::<f64>().sqrt();
        let src_f = run.elems.get(run.elems.index_at(s_f, p0.elem)).element.clone();
        if gap > ON_PATH_MM {
            parts.push((Geometry::Line(Line::new(c_pos, f_pos, gap)), JointKind::Corner, src_f.clone(), f64::NAN));
        }
        let i0 = run.elems.index_at(s_f, p0.elem);
        let mut i = i0;
        while i < run.elems.end() && run.elems.get(i).s0_mm < target.s_mm {
            let e: &RunElem = run.elems.get(i);
            let (a, b) = (s_f.max(e.s0_mm), target.s_mm.min(e.s1_mm()));
            let geoms = pieces::exact_part(e, a, b, &st.linear).map_err(|err| PrepError {
                line: e.element.source.line,
                s_mm: a,
                reason: PrepFailure::ExactPart(err),
            })?;
            for (n, g) in geoms.into_iter().enumerate() {
                // A stop where the exact path is rejoined (the first part emitted: a part of
                // `i0` may be empty where the segment starts on its end); between elements the joint their
                // geometry makes (a conditioned chord's own joint is that of its first
                // programmed move, not the chord's), so every corner stops; the pieces of
                // one element join smoothly.
                let joint = match parts.last() {
                    None => JointKind::Corner,
                    Some((prev, ..)) if n == 0 => classify_joint(prev, &g, st.n_axes),
                    Some(_) => JointKind::Smooth,
                };
                parts.push((g, joint, e.element.clone(), e.tol_mm));
            }
            i += 1;
        }
        // The next window starts on the programmed path: C² from its derivatives, or from
        // rest on a vertex.
        let e_t = run.elems.get(target.elem);
        let (state, levels, next) = if target.vertex {
            let mut s = pieces::programmed_state(e_t, target.s_mm, st.spacing_mm);
            s.iter_mut().for_each(|a| a[1..].iter_mut().for_each(|x| *x = 0.0));
            (s, 1, JointKind::Corner)
        } else {
            (pieces::programmed_state(e_t, target.s_mm, st.spacing_mm), 3.min(st.levels), JointKind::Smooth)
        };
        let dwell = std::mem::take(&mut run.dwell_s);
        let pause = run.pause.take();
        run.next_joint = next;
        run.commit_to(commit, state, levels, st.spacing_mm);
        let parts = simplify_lines(parts, st.n_axes);
        let mut first = true;
        for (g, j, src, _) in parts {
            self.emit(g, j, if first { (dwell, pause) } else { (0.0, None) }, &src);
            first = false;
        }
        self.stats.windows += 1;
        Ok(())
    }

    /// Emits a programmed element unchanged (apart from its place in s and its joint).
    fn emit_programmed(&mut self, e: Element) {
        let joint = match (&self.last_out, e.joint) {
            (None, _) => JointKind::Start,
            (_, JointKind::Corner | JointKind::Start) => JointKind::Corner,
            (Some(prev), _) => classify_joint(&prev.geometry, &e.geometry, self.st.n_axes),
        };
        self.emit(e.geometry.clone(), joint, (e.dwell_before_s, e.pause_before), &e);
    }

    /// `hold`: the dwell (s) and the planned pause before the element.
    fn emit(&mut self, geometry: Geometry, joint: JointKind, hold: (f64, Option<Pause>), src: &Element) {
        let (dwell_before_s, pause_before) = hold;
        let len = geometry.length_mm();
        let e = Element {
            geometry,
            s_start_mm: self.out_s_mm,
            feed: src.feed,
            source: src.source,
            joint,
            dwell_before_s,
            blend: src.blend,
            pause_before,
        };
        self.out_s_mm += len;
        self.last_out = Some(e.clone());
        self.out.push_back(e);
    }
}

/// Share of the band left on a line that the exact-stop fallback's simplification may use.
const SIMPLIFY_BAND_SHARE: f64 = 0.5;

/// The exact-stop fallback's parts with each run of programmed lines (same feed) replaced by
/// its Douglas–Peucker simplification within half the band they leave, so the motion stops at
/// the run's real corners only. The last line of a run is kept as programmed: where the
/// fallback ends inside the path, the next window continues along its direction.
fn simplify_lines(
    parts: Vec<(Geometry, JointKind, Element, f64)>,
    n_axes: usize,
) -> Vec<(Geometry, JointKind, Element, f64)> {
    let simplifiable = |p: &(Geometry, JointKind, Element, f64)| matches!(p.0, Geometry::Line(_)) && !p.3.is_nan();
    let mut out: Vec<(Geometry, JointKind, Element, f64)> = Vec::with_capacity(parts.len());
    let mut i = 0;
    while i < parts.len() {
        let mut j = i;
        while j + 1 < parts.len()
            && simplifiable(&parts[i])
            && simplifiable(&parts[j + 1])
            && parts[j + 1].2.feed == parts[i].2.feed
        {
            j += 1;
        }
        // parts[i..j] are simplified, parts[j] (the run's last line) is kept.
        if j >= i + 2 {
            let mut vertices: Vec<AxisVec> = parts[i..j].iter().map(|p| line_ends(&p.0).0).collect();
            vertices.push(line_ends(&parts[j].0).0);
            let tol = parts[i..j].iter().map(|p| p.3).fold(f64::INFINITY, f64::min) * SIMPLIFY_BAND_SHARE;
            let kept = simplify::douglas_peucker(&vertices, n_axes, tol);
            for w in kept.windows(2) {
                let (a, b) = (vertices[w[0]], vertices[w[1]]);
                let len = (0..n_axes).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
                let g = Geometry::Line(Line::new(a, b, len));
                // The run's first line keeps a stop before it; any other joint is what the
                // simplified geometry makes.
                let joint = match out.last() {
                    _ if w[0] == 0 && matches!(parts[i].1, JointKind::Corner | JointKind::Start) => parts[i].1,
                    Some((prev, ..)) => classify_joint(prev, &g, n_axes),
                    None => parts[i].1,
                };
                out.push((g, joint, parts[i + w[0]].2.clone(), parts[i + w[0]].3));
            }
            let (g, _, src, tol) = parts[j].clone();
            let joint = classify_joint(&out.last().expect("a simplified line").0, &g, n_axes);
            out.push((g, joint, src, tol));
        } else {
            out.extend(parts[i..=j].iter().cloned());
        }
        i = j + 1;
    }
    out
}

/// Start and end of a line.
fn line_ends(g: &Geometry) -> (AxisVec, AxisVec) {
    let (mut a, mut b) = (AxisDerivs::default(), AxisDerivs::default());
    g.eval(0.0, &mut a);
    g.eval(g.length_mm(), &mut b);
    (a.pos, b.pos)
}

/// The pieces of `points[..=commit]`, or the index of the first one outside the tolerance.
fn check_pieces(
    run: &Run,
    st: &StageSettings,
    stats: &mut PrepStats,
    sol: &Solution,
    commit: usize,
) -> Result<Vec<QuinticSpan>, usize> {
    check_all_pieces(run, st, stats, sol, commit, false).map_err(|failed| failed[0])
}

/// The pieces of `points[..=commit]`, or the indices of those outside the tolerance (only the
/// first unless `all`).
fn check_all_pieces(
    run: &Run,
    st: &StageSettings,
    stats: &mut PrepStats,
    sol: &Solution,
    commit: usize,
    all: bool,
) -> Result<Vec<QuinticSpan>, Vec<usize>> {
    let p = &run.points;
    let mut out = Vec::with_capacity(commit);
    let mut failed = Vec::new();
    for j in 0..commit {
        let delta = (p[j + 1].s_mm - p[j].s_mm) / st.spacing_mm;
        let Ok(piece) =
            pieces::smoothed_levels(&sol.states[j], &sol.states[j + 1], delta, st.hermite_levels, &st.linear)
        else {
            failed.push(j);
            if all {
                continue;
            }
            break;
        };
        let (dev, excess) = verify::piece_excess(&piece, &p[j], &p[j + 1], &run.elems, &run.programmed, st.spacing_mm);
        stats.max_deviation_mm = stats.max_deviation_mm.max(dev);
        if excess > 0.0 {
            tracing::debug!(piece = j, excess_um = excess * 1e3, "piece outside the band");
            failed.push(j);
            if all {
                continue;
            }
            break;
        }
        if failed.is_empty() {
            stats.max_excess_mm = stats.max_excess_mm.max(excess);
            out.push(piece);
        }
    }
    if failed.is_empty() { Ok(out) } else { Err(failed) }
}

/// The method of the window starting at the run's committed point: that of the element there
/// (`G64 … Q1` / `Q2`, or `[prep] method`).
fn window_method(run: &Run, default: PrepMethod) -> PrepMethod {
    match run.elems.get(run.points[0].elem).element.blend {
        Blend::Tolerance { method, .. } => method,
        Blend::Exact => default,
    }
}

/// The B-spline method's pieces of `points[..=commit]` and the spline's state at the commit
/// point (with the levels the next window keeps), or the index of the first piece outside the
/// tolerance. Where the spline cannot be fitted, or a span leaves the band and may not be
/// refined (`can_refine`), the window's Hermite pieces are taken instead if they keep the band
/// (`stats.bspline_to_hermite`). `cache` holds the B-spline basis values of the last window's
/// points.
#[allow(clippy::too_many_arguments)]
fn check_spline(
    run: &Run,
    st: &StageSettings,
    stats: &mut PrepStats,
    cache: &mut bspline::BasisCache,
    sol: &Solution,
    commit: usize,
    right: RightEnd,
    refine: SplineRefine<impl Fn(usize) -> bool>,
) -> Result<(Vec<QuinticSpan>, SplineEnd), usize> {
    let SplineRefine { can: can_refine, hermite_guides } = refine;
    let p = &run.points;
    let n = sol.states.len();
    let u: Vec<f64> = p[..n].iter().map(|q| (q.s_mm - p[0].s_mm) / st.spacing_mm).collect();
    let s_mm: Vec<f64> = p[..n].iter().map(|q| q.s_mm).collect();
    // The spline's pieces at `weights` if every one keeps the band; else the first outside it.
    let window = bspline::SplineWindow {
        u: &u,
        s_mm: &s_mm,
        states: &sol.states,
        left: &run.state,
        left_levels: run.spline_levels,
        right,
        commit,
    };
    let mut fit = |weights: [f64; 5], stats: &mut PrepStats| -> Result<bspline::SplinePieces, Option<usize>> {
        let sp = bspline::window_pieces(st, &window, weights, cache).map_err(|f| {
            tracing::debug!(?f, s_mm = p[0].s_mm, "no B-spline for the window");
            None
        })?;
        let mut worst = f64::NEG_INFINITY;
        for (j, piece) in sp.pieces.iter().enumerate() {
            let (dev, excess) =
                verify::piece_excess(piece, &p[j], &p[j + 1], &run.elems, &run.programmed, st.spacing_mm);
            stats.max_deviation_mm = stats.max_deviation_mm.max(dev);
            if excess > 0.0 {
                return Err(Some(j));
            }
            worst = worst.max(excess);
        }
        stats.max_excess_mm = stats.max_excess_mm.max(worst);
        Ok(sp)
    };
    let accept = |sp: bspline::SplinePieces, stats: &mut PrepStats| {
        stats.bspline_windows += 1;
        Ok((sp.pieces, Some((sp.end, sp.levels))))
    };
    let failed = match fit(st.bspline_weights, stats) {
        Ok(sp) => return accept(sp, stats),
        Err(Some(j)) => {
            // The positions weighted more (no QP solve), before a point is inserted.
            for gain in bspline::TIGHTEN_GAINS {
                let mut w = st.bspline_weights;
                w[0] *= gain;
                if let Ok(sp) = fit(w, stats) {
                    stats.bspline_tightened += 1;
                    tracing::debug!(s_mm = p[0].s_mm, gain, "B-spline window: positions weighted more");
                    return accept(sp, stats);
                }
            }
            if can_refine(j) {
                if hermite_guides {
                    // Half the refinements went to the spline: the next ones go where the
                    // Hermite pieces leave the band, so that the fallback to them keeps it
                    // when the refinements run out (the spline is still tried first).
                    let mut scratch = PrepStats::default();
                    if let Err(k) = check_pieces(run, st, &mut scratch, sol, commit) {
                        if can_refine(k) {
                            return Err(k);
                        }
                    }
                }
                return Err(j);
            }
            Some(j)
        }
        Err(None) => None,
    };
    let pieces = check_pieces(run, st, stats, sol, commit);
    match (pieces, failed) {
        (Ok(pieces), _) => {
            stats.bspline_to_hermite += 1;
            tracing::debug!(s_mm = p[0].s_mm, "B-spline window: Hermite pieces instead");
            Ok((pieces, None))
        }
        (Err(j), Some(k)) => Err(j.min(k)),
        (Err(j), None) => Err(j),
    }
}

/// Where a B-spline window that leaves the band may insert a point: `can(j)` for piece j,
/// and whether the Hermite pieces' failures guide the refinement (half the refinements used).
struct SplineRefine<F> {
    can: F,
    hermite_guides: bool,
}

/// State in τ at the start of a programmed element.
fn start_state(e: &Element, spacing_mm: f64) -> State {
    state_at(&e.geometry, 0.0, spacing_mm)
}

/// State in τ at the end of an emitted element.
fn end_state(e: &Element, spacing_mm: f64) -> State {
    state_at(&e.geometry, e.geometry.length_mm(), spacing_mm)
}

fn state_at(g: &Geometry, s_mm: f64, h: f64) -> State {
    let mut d = AxisDerivs::default();
    g.eval(s_mm, &mut d);
    let mut st = [[0.0; STATE_LEVELS]; MAX_AXES];
    for k in 0..MAX_AXES {
        st[k] = [d.pos[k], d.d1[k] * h, d.d2[k] * h * h, d.d3[k] * h * h * h, 0.0];
    }
    st
}
