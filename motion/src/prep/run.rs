//! A run: consecutive G64 elements smoothed as one chain, with the points not yet committed
//! and the state of the committed node they start from.

use super::condition::Conditioned;
use super::elements::RunElems;
use super::points::{Placer, Point};
use super::programmed::ProgrammedMoves;
use super::settings::StageSettings;
use super::window::State;
use crate::path::JointKind;

/// How the run ends.
// The join state is copied once per run end; boxing it would cost more than it saves.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum RunEnd {
    /// Still open: more elements may follow.
    Open,
    /// The motion stops at the end (corner, dwell, program end): position only.
    Stop,
    /// A programmed element continues tangentially: its start state.
    Join(State),
}

#[derive(Debug)]
pub(super) struct Run {
    /// The conditioned elements: what the points, bands and the exact-stop fallback follow.
    pub elems: RunElems,
    /// The programmed elements they stand for: what the check measures against.
    pub programmed: ProgrammedMoves,
    pub placer: Placer,
    /// Points from the committed node on: `points[0]` is the committed node.
    pub points: Vec<Point>,
    /// State at `points[0]` and how many of its levels are fixed for the next window.
    pub state: State,
    pub left_levels: usize,
    /// Levels of `state` the B-spline method keeps at the next window's start: the spline's
    /// continuity + 1 after a spline window, else `left_levels`.
    pub spline_levels: usize,
    pub end: RunEnd,
    /// Joint of the next piece emitted (Start or Corner after a stop, else Smooth).
    pub next_joint: JointKind,
    /// Dwell before the run's first piece.
    pub dwell_s: f64,
    /// Planned pause before the run's first piece.
    pub pause: Option<crate::path::Pause>,
}

impl Run {
    /// A run starting with `first`, from `state` with `left_levels` fixed.
    pub(super) fn new(
        dwell_s: f64,
        pause: Option<crate::path::Pause>,
        state: State,
        left_levels: usize,
        joint: JointKind,
        n_axes: usize,
    ) -> Self {
        Self {
            elems: RunElems::new(n_axes),
            programmed: ProgrammedMoves::new(n_axes),
            placer: Placer::new(),
            points: Vec::new(),
            state,
            left_levels,
            spline_levels: left_levels,
            end: RunEnd::Open,
            next_joint: joint,
            dwell_s,
            pause,
        }
    }

    /// Appends a conditioned element (tolerance `tol_mm`) and the programmed moves it stands
    /// for; a chord keeps the band its merged vertices leave.
    pub(super) fn push(&mut self, c: Conditioned, tol_mm: f64) {
        let prog = (c.programmed[0].s_start_mm, c.programmed[c.programmed.len() - 1].s_end_mm());
        self.elems.push_conditioned(c.element, tol_mm - c.deviation_mm, tol_mm, prog);
        for m in c.programmed {
            self.programmed.push(m);
        }
    }

    pub(super) fn closed(&self) -> bool {
        self.end != RunEnd::Open
    }

    /// Places the points the known elements allow.
    pub(super) fn place(&mut self, st: &StageSettings) {
        let closed = self.closed();
        self.placer.place(&self.elems, st, closed, &mut self.points);
    }

    /// Indices of the segment ends after the committed node.
    pub(super) fn segment_ends(&self) -> impl Iterator<Item = usize> + '_ {
        self.points.iter().enumerate().skip(1).filter(|(_, p)| p.seg_end).map(|(i, _)| i)
    }

    /// Whether the last point placed is the run's end.
    pub(super) fn reached_end(&self) -> bool {
        self.closed()
            && self.points.len() > 1
            && self.elems.last().is_some_and(|e| self.points.last().is_some_and(|p| p.s_mm >= e.s1_mm()))
    }

    /// Drops the points before `c` (committed) and the elements no check needs any more.
    pub(super) fn commit_to(&mut self, c: usize, state: State, left_levels: usize, spacing_mm: f64) {
        self.points.drain(..c);
        self.state = state;
        self.left_levels = left_levels;
        self.spline_levels = left_levels;
        let s_keep = self.points[0].s_mm - 4.0 * spacing_mm;
        let keep = self.elems.index_at(s_keep, self.points[0].elem);
        self.elems.drop_before(keep.min(self.points[0].elem));
        let prog_keep = self.elems.get(self.elems.first_index()).prog_s0_mm;
        let i = self.programmed.index_at_bisect(prog_keep);
        self.programmed.drop_before(i);
    }
}
