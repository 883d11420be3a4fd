//! Cutter radius compensation (G41/G42, G41.1/G42.1, G40) as a stage of its own: the
//! interpreter hands it the programmed contour element by element, and it hands back the path
//! of the tool centre, offset by the tool radius to the left (G41) or right (G42) of the
//! direction of travel in the selected plane.
//!
//! - Lines and arcs are offset exactly; G06 spline spans are offset by cubic spans that stay
//!   within [`SPLINE_OFFSET_TOL_MM`] of the true offset curve P(u) + r·n(u) (Huan, §4 has the
//!   spline interpolator carry out the compensation; here it is a stage before the planner).
//! - Outside corners get an arc of the tool radius around the corner point, so the path stays
//!   tangent-continuous; inside corners are trimmed at the intersection of the two offsets.
//! - The move after G41/G42 (the entry move) as LinuxCNC (`convert_straight_comp1`,
//!   `convert_arc_comp1`): a line goes from where the tool stands to the offset of its end
//!   point across its own direction; at an inside corner that end moves back along the
//!   line's direction to where the line's parallel offset meets the next offset. An arc ends
//!   at the offset of its end point (towards or away from its centre) and turns about a new
//!   centre on that radius, equidistant from where the tool stands. The move after G40 (the
//!   exit move, a line) goes from the offset of the contour's last point to its programmed
//!   end.
//! - Near a reversal (within LinuxCNC's 0.05 rad) a corner is inside or outside by
//!   LinuxCNC's rule for arcs, not by its angle: inside where the tool runs outside the arc
//!   that turns back (a cusp between two humps), so the offsets are trimmed where they cross.
//! - Short elements at inside corners (CAM chords) are swallowed as by the true offset curve:
//!   where two offsets do not meet, either the new offset meets a piece kept back before the
//!   tail (the pieces between are dropped), or the new element lies inside the corner (it is
//!   dropped and the next one is joined to the tail).
//! - A concave arc or spline section whose radius is not larger than the tool radius, or an
//!   inside corner the tool cannot reach, is an error naming the block.
//!
//! Look-ahead is bounded: the stage holds back the offset of the last contour element (its end
//! depends on the next corner), the moves without motion in the plane that follow it (at most
//! [`MAX_HELD_MOVES`]), and the tool path pieces before it that a later inside corner may
//! still trim back into (at most [`MAX_STAGED`]).

use super::error::fmt_num;
use crate::path::{AxisDerivs, AxisVec, Blend, CubicSpan, Feed, Geometry, Helix, Line, MAX_AXES, MIN_MOVE_MM, Source};
use std::collections::VecDeque;
use std::f64::consts::PI;

/// The offset of a spline span stays this close to the true offset curve, mm: a quarter of
/// the 1 µm the compensated path is held to, the rest for the planner's sampling.
pub(crate) const SPLINE_OFFSET_TOL_MM: f64 = 0.25e-3;
/// Interior points at which each offset piece is checked against the true offset curve.
const SPLINE_CHECK_POINTS: usize = 9;
/// Pieces each spline span starts with before bisection.
const SPLINE_INITIAL_PIECES: usize = 2;
/// Bisection depth limit for one spline span (2¹⁶ pieces): a span that needs more is
/// reported, not approximated forever.
const SPLINE_MAX_DEPTH: usize = 16;
/// Points per spline span at which its curvature is checked against the tool radius.
const GOUGE_SCAN_POINTS: usize = 256;
/// Moves without motion in the plane (a Z plunge, a rotary move) held back at one corner.
pub(crate) const MAX_HELD_MOVES: usize = 16;
/// Tool path pieces kept back after the tail, so that an inside corner can trim back across
/// the short chords it swallows: a 2 mm tool entering a circle of 5 mm radius of chords of
/// 0.05 and 0.005 mm from its centre swallows the chords of 22° of it (70).
const MAX_STAGED: usize = 256;
/// Contour elements in a row that an inside corner may swallow whole (their offsets lie
/// entirely inside the corner's trim), as many as pieces are kept back.
const MAX_SWALLOWED: usize = MAX_STAGED;
/// Corners turning less than this are joined straight (the next offset starts where the last
/// ends, moving its start by r·θ, below 1 nm for tool radii up to 10 mm): the intersection of
/// two offsets this close to parallel is lost in rounding (CAM programs rounded to 0.1 µm have
/// such joints between collinear chords).
const STRAIGHT_JOINT_RAD: f64 = 1e-7;
/// An inside corner whose offsets do not intersect (nearly tangent elements: arcs rounded to
/// the program's decimals meet at turns of 1e-7 rad, where the offsets meet far away or not at
/// all) is joined where the tail ends when the offsets' ends are this close, mm: the tool path
/// then errs by less than this.
const NEAR_TANGENT_GAP_MM: f64 = 1e-6;
/// An intersection this far beyond an element's end (rounding of nearly parallel offsets) is
/// taken at the end, mm.
const INTERSECT_SLACK_MM: f64 = 1e-6;
/// Corners within this of a full reversal (π) are passed as a reversal: the offsets are too
/// close to parallel to intersect reliably.
const REVERSAL_RAD: f64 = 1e-9;
/// LinuxCNC's `TOLERANCE_CONCAVE_CORNER`: within this of a reversal a corner is inside or
/// outside by LinuxCNC's rule for arcs ([`Cutter::reversal_is_inside`]), not by its angle.
const REVERSAL_BAND_RAD: f64 = 0.05;
/// Moves shorter than this in the plane count as moves without motion in the plane, mm.
const MIN_PLANE_MOVE_MM: f64 = 1e-9;
/// Newton steps for the intersection of two offset elements at an inside corner.
const INTERSECT_STEPS: usize = 60;
/// The intersection is accepted when the two points agree to this, mm.
const INTERSECT_TOL_MM: f64 = 1e-10;
/// An intersection found in closed form is accepted when the two elements' points there agree
/// to this, mm (the rounding of the closed form, far below the 1 µm the path is held to).
const CLOSED_FORM_TOL_MM: f64 = 1e-7;
/// Elements that meet this closely are left as they are, mm.
const CONNECT_EXACT_MM: f64 = 1e-12;
/// Only elements that meet in the plane to this (as trimmed ones do, to the intersection's
/// tolerance) are joined along the other axes, mm.
const CONNECT_PLANE_MM: f64 = 1e-9;
/// Offset arcs with a smaller radius are degenerate (the tool radius equals the arc's).
const MIN_OFFSET_RADIUS_MM: f64 = 1e-6;
/// How far back (in tool radii, beyond the entry's own length) the parallel offset of a
/// straight entry reaches for the inside corner after it: LinuxCNC moves the entry's end back
/// by r / tan(half the corner), 115 r at a corner of 1°.
const ENTRY_REACH: f64 = 1.0e4;
/// LinuxCNC's `TOLERANCE_EQUAL` (2.9): an entry arc whose new centre lies this close to
/// perpendicular (cosine) is refused.
const ENTRY_ARC_COS_MIN: f64 = 1e-4;

/// Left (G41) or right (G42) of the direction of travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    Left,
    Right,
}

impl Side {
    /// +1 for left, −1 for right: the offset is sign·r·(left normal).
    fn sign(self) -> f64 {
        match self {
            Side::Left => 1.0,
            Side::Right => -1.0,
        }
    }
}

/// Why the contour cannot be compensated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum CutterErrorKind {
    #[error(
        "cutter compensation: the tool radius {radius_mm} mm is not smaller than the radius {arc_mm} mm of this concave arc (gouge)"
    )]
    ConcaveArc { radius_mm: String, arc_mm: String },
    #[error(
        "cutter compensation: the spline turns on a radius of {curve_mm} mm at u = {u:.3} on the tool's side, smaller than the tool radius {radius_mm} mm (gouge)"
    )]
    ConcaveSpline { radius_mm: String, curve_mm: String, u: f64 },
    #[error(
        "cutter compensation: the tool (radius {radius_mm} mm) cannot reach the inside corner where this block starts: the previous or this element is shorter than the tool needs (gouge)"
    )]
    InsideCorner { radius_mm: String },
    #[error("cutter compensation: the move after G41/G42 (the entry move) must be a line or an arc in the plane")]
    EntryNotLine,
    #[error(
        "cutter compensation: the entry move is not longer than the tool radius {radius_mm} mm: start it further from the contour"
    )]
    EntryTooShort { radius_mm: String },
    #[error(
        "cutter compensation: the entry arc ends where its offset would need a centre at infinity (the tool radius {radius_mm} mm against the arc)"
    )]
    EntryArcDegenerate { radius_mm: String },
    #[error("cutter compensation: the entry move would have to turn back to reach the inside corner after it (gouge)")]
    EntryReversed,
    #[error("cutter compensation: the move after G40 (the exit move) must be a straight line (G0/G1)")]
    ExitNotLine,
    #[error("cutter compensation: more than {MAX_HELD_MOVES} moves without motion in the compensation plane in a row")]
    TooManyHeld,
    #[error("cutter compensation: a spline span without motion in the compensation plane")]
    SplineOutOfPlane,
    #[error("cutter compensation: the offset of this spline span is degenerate (it stops or turns back)")]
    DegenerateSplineOffset,
}

/// A compensation error at the block that caused it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{line}:{col}: {kind}")]
pub(crate) struct CutterError {
    pub line: u32,
    pub col: u32,
    pub kind: CutterErrorKind,
}

/// One element of the path with its attributes: what the interpreter pushes (the contour) and
/// what the stage hands back (the tool centre path).
#[derive(Debug, Clone)]
pub(crate) struct Piece {
    pub geometry: Geometry,
    pub feed: Feed,
    pub source: Source,
    /// Column of the block's first word, for messages.
    pub col: u32,
    pub dwell_before_s: f64,
    pub blend: Blend,
}

impl Piece {
    fn with(&self, geometry: Geometry) -> Piece {
        Piece { geometry, dwell_before_s: 0.0, ..self.clone() }
    }

    fn error(&self, kind: CutterErrorKind) -> CutterError {
        CutterError { line: self.source.line, col: self.col, kind }
    }
}

/// What is held back while compensation is on.
#[derive(Debug, Clone)]
struct Held {
    /// The offset of the last contour element (or the entry move), whose end the next corner
    /// may trim.
    tail: Piece,
    /// The contour point where the tail's contour element ends, and its unit tangent there
    /// in the plane.
    corner: AxisVec,
    tangent: [f64; 2],
    /// Moves without motion in the plane after the tail, carried out at the corner.
    moves: Vec<Piece>,
    /// Contour elements after the tail swallowed whole by the corner (the next element's
    /// offset meets the tail), and the error to report if the corner does not resolve.
    swallowed: usize,
    gouge: Option<CutterError>,
    /// For a straight entry move: where the tool stands before it. The tail is then the
    /// parallel offset of the entry's direction (reaching back [`ENTRY_REACH`] tool radii), so
    /// that an inside corner moves the entry's end back along that direction as LinuxCNC does;
    /// the entry handed on goes from here to the tail's (trimmed) end.
    entry_from: Option<AxisVec>,
}

/// A tool path piece kept back: a later inside corner may still trim its end (`full`: the
/// piece before its end was trimmed; `None` for pieces that must stay as they are).
#[derive(Debug, Clone)]
struct Staged {
    piece: Piece,
    full: Option<Geometry>,
    /// Where the tool path ended before this piece.
    prev_end: Option<AxisVec>,
}

#[derive(Debug, Clone)]
enum State {
    Off,
    /// G40 was programmed: the tool stands `shift` (in the plane) from the programmed point
    /// until the exit move.
    Exit {
        shift: [f64; 2],
    },
    /// G41/G42 was programmed and no move in the plane has followed yet; the tool stands
    /// `shift` from the programmed point (non-zero when G40 had no exit move yet).
    Entry {
        shift: [f64; 2],
    },
    On(Box<Held>),
}

/// The compensation stage.
#[derive(Debug, Clone)]
pub(crate) struct Cutter {
    state: State,
    side: Side,
    radius_mm: f64,
    /// Axis indices of the compensation plane (G17: X Y, G18: Z X, G19: Y Z).
    p: usize,
    q: usize,
    linear: [bool; MAX_AXES],
    n_axes: usize,
    out: VecDeque<Piece>,
    /// Tool path pieces kept back (at most [`MAX_STAGED`]).
    staged: VecDeque<Staged>,
    /// Where the last compensated element handed on ends.
    last_end: Option<AxisVec>,
}

impl Cutter {
    pub(crate) fn new(linear: &[bool]) -> Self {
        let mut mask = [false; MAX_AXES];
        mask[..linear.len()].copy_from_slice(linear);
        Self {
            state: State::Off,
            side: Side::Left,
            radius_mm: 0.0,
            p: 0,
            q: 1,
            linear: mask,
            n_axes: linear.len(),
            out: VecDeque::new(),
            staged: VecDeque::new(),
            last_end: None,
        }
    }

    /// Compensation is on (G41/G42 programmed and not cancelled).
    pub(crate) fn is_on(&self) -> bool {
        matches!(self.state, State::Entry { .. } | State::On(_))
    }

    /// G41/G42 (or G41.1/G42.1) in the plane of axes (p, q): the next move in the plane is the
    /// entry move. Compensation must be off.
    pub(crate) fn start(&mut self, side: Side, radius_mm: f64, p: usize, q: usize) {
        debug_assert!(!self.is_on());
        let shift = match self.state {
            State::Exit { shift } => shift,
            _ => [0.0; 2],
        };
        self.side = side;
        self.radius_mm = radius_mm;
        self.p = p;
        self.q = q;
        self.state = State::Entry { shift };
    }

    /// G40: hands on what is held back; the next move in the plane is the exit move.
    pub(crate) fn stop(&mut self) -> Result<(), CutterError> {
        let shift = match std::mem::replace(&mut self.state, State::Off) {
            State::Off => return Ok(()),
            State::Exit { shift } | State::Entry { shift } => shift,
            State::On(held) => self.release(*held)?,
        };
        self.state = State::Exit { shift };
        Ok(())
    }

    /// After G40 with the tool still beside the programmed point: a move whose programmed
    /// length is zero is the exit move all the same (LinuxCNC moves the tool from the offset
    /// onto the programmed point). Ends the compensation and gives where the tool stands (the
    /// exit move's start), or `None` when the tool already stands on the programmed point.
    pub(crate) fn exit_in_place(&mut self, programmed: &AxisVec) -> Option<AxisVec> {
        let State::Exit { shift } = self.state else { return None };
        if shift[0].hypot(shift[1]) <= MIN_PLANE_MOVE_MM {
            return None;
        }
        self.flush();
        self.state = State::Off;
        self.last_end = None;
        let mut from = *programmed;
        from[self.p] += shift[0];
        from[self.q] += shift[1];
        Some(from)
    }

    /// The end of the program: hands on what is held back (the tool stays at the offset).
    pub(crate) fn finish(&mut self) -> Result<(), CutterError> {
        if let State::On(held) = std::mem::replace(&mut self.state, State::Off) {
            self.release(*held)?;
        }
        self.flush();
        Ok(())
    }

    /// Hands on every piece kept back.
    fn flush(&mut self) {
        while let Some(s) = self.staged.pop_front() {
            self.out.push_back(s.piece);
        }
    }

    /// The next tool path element ready to be handed on.
    pub(crate) fn pop(&mut self) -> Option<Piece> {
        self.out.pop_front()
    }

    /// Takes the next contour element.
    pub(crate) fn push(&mut self, piece: Piece) -> Result<(), CutterError> {
        let in_plane = self.plane_length(&piece.geometry) > MIN_PLANE_MOVE_MM;
        match &mut self.state {
            State::Off => {
                self.flush();
                self.last_end = None;
                self.out.push_back(piece);
                Ok(())
            }
            State::Exit { shift } => {
                let shift = *shift;
                if !self.pass_off_plane(&piece, in_plane, shift, CutterErrorKind::ExitNotLine)? {
                    return Ok(());
                }
                let (a, b) = self.ends(&piece.geometry);
                let start = self.plus(a, shift);
                if let Some(g) = self.line(start, b) {
                    self.emit(Piece { geometry: g, ..piece });
                }
                self.flush();
                self.state = State::Off;
                Ok(())
            }
            State::Entry { shift } => {
                let shift = *shift;
                if !in_plane {
                    let moved = self.shifted(&piece, shift)?;
                    self.emit(moved);
                    return Ok(());
                }
                let held = self.entry(piece, shift)?;
                self.state = State::On(Box::new(held));
                Ok(())
            }
            State::On(held) => {
                if !in_plane {
                    if held.moves.len() >= MAX_HELD_MOVES {
                        return Err(piece.error(CutterErrorKind::TooManyHeld));
                    }
                    held.moves.push(piece);
                    return Ok(());
                }
                let State::On(held) = std::mem::replace(&mut self.state, State::Off) else { unreachable!() };
                let offsets = self.offset(&piece)?;
                let next = self.join(*held, offsets, &piece)?;
                self.state = State::On(Box::new(next));
                Ok(())
            }
        }
    }

    /// Before the entry move and until the exit move: a move without motion in the plane is
    /// handed on shifted by where the tool stands (`false`: it is done); a move in the plane
    /// must be a line (else `not_line`), and is the entry or exit move (`true`).
    fn pass_off_plane(
        &mut self,
        piece: &Piece,
        in_plane: bool,
        shift: [f64; 2],
        not_line: CutterErrorKind,
    ) -> Result<bool, CutterError> {
        if !in_plane {
            let moved = self.shifted(piece, shift)?;
            self.emit(moved);
            return Ok(false);
        }
        match piece.geometry {
            Geometry::Line(_) => Ok(true),
            _ => Err(piece.error(not_line)),
        }
    }

    /// Joins the held tail to the offsets of the next contour element `piece` at the corner;
    /// hands on everything up to the last offset piece, which is held.
    fn join(&mut self, held: Held, mut offsets: Vec<Piece>, piece: &Piece) -> Result<Held, CutterError> {
        let Held { tail, corner, tangent: t1, moves, swallowed, gouge, entry_from } = held;
        let t2 = self.start_tangent(&piece.geometry);
        let n1 = self.normal(t1);
        let n2 = self.normal(t2);
        let (_, contour_end) = self.ends(&piece.geometry);
        let end_tangent = self.end_tangent(&piece.geometry);
        let last = tail;
        let mut turn = cross(t1, t2).atan2(dot(t1, t2));
        // Near a reversal (the path turns back on itself, within LinuxCNC's 0.05 rad) the
        // corner is inside or outside as LinuxCNC decides it (`convert_arc_comp2`,
        // `convert_straight_comp2`): inside where the tool runs on the outside of the arc that
        // turns back (the new element's, or for a line the previous one's: the cusp between
        // two humps, the top of an "h"), else outside: a line reversing on a line is passed
        // around its end, the offsets being parallel.
        if turn.abs() > PI - REVERSAL_BAND_RAD {
            let inside = self.reversal_is_inside(&last.geometry, &piece.geometry);
            if inside != (self.side.sign() * turn > 0.0) {
                turn -= turn.signum() * 2.0 * PI;
            }
            if turn.abs() >= PI - REVERSAL_RAD {
                turn = if inside { self.side.sign() } else { -self.side.sign() } * PI;
            }
        }
        let outside = self.side.sign() * turn < 0.0;
        // A straight entry into an inside corner whose offsets meet beyond the next element
        // (LinuxCNC's tool path would run back along it): the entry is the line the tool
        // moves on, and the corner is resolved as any other (the elements it swallows are
        // dropped).
        let (last, entry_from) = match entry_from {
            Some(from)
                if !outside
                    && turn.abs() > STRAIGHT_JOINT_RAD
                    && self.trim_corner(&last.geometry, &offsets[0].geometry).is_none() =>
            {
                (self.tail_piece(last, Some(from), t1)?.0, None)
            }
            other => (last, other),
        };
        if swallowed > 0 && (outside || turn.abs() <= STRAIGHT_JOINT_RAD) {
            // Past elements the corner swallowed, the contour turns away: no inside corner
            // to resolve them.
            return Err(gouge.unwrap_or_else(|| self.inside_corner_error(piece)));
        }
        if turn.abs() <= STRAIGHT_JOINT_RAD {
            let (last, full) = self.tail_piece(last, entry_from, t1)?;
            self.stage(last, Some(full));
            self.hand_on_moves(moves, n1)?;
            // The offsets miss each other by at most r·θ: the next starts where this ends.
            if let Some(end) = self.last_end {
                if let Some(g) = self.starting_at(&offsets[0].geometry, end) {
                    offsets[0].geometry = g;
                }
            }
        } else if outside {
            let (last, full) = self.tail_piece(last, entry_from, t1)?;
            self.stage(last, Some(full));
            let at = self.hand_on_moves(moves, n1)?.unwrap_or(corner);
            let a = self.plus(at, n1);
            let b = self.plus(at, n2);
            let arc = Helix::new(self.p, self.q, [at[self.p], at[self.q]], turn, a, b, &self.linear[..self.n_axes]);
            if arc.length_mm() > MIN_PLANE_MOVE_MM {
                // The corner arc comes after arriving at the corner: a dwell programmed
                // for the next block happens before it.
                let dwell = std::mem::take(&mut offsets[0].dwell_before_s);
                let arc = Geometry::Helix(arc);
                self.stage(Piece { geometry: arc.clone(), dwell_before_s: dwell, ..piece.clone() }, Some(arc));
            }
        } else if let Some((g1, g2)) = self.trim_corner(&last.geometry, &offsets[0].geometry) {
            let mut d = AxisDerivs::default();
            g1.eval(g1.length_mm(), &mut d);
            let shift = [d.pos[self.p] - corner[self.p], d.pos[self.q] - corner[self.q]];
            let full = last.geometry.clone();
            let trimmed = Piece { geometry: g1, ..last };
            let (trimmed, full) = match entry_from {
                Some(_) => self.tail_piece(trimmed, entry_from, t1)?,
                None => (trimmed, full),
            };
            self.stage(trimmed, Some(full));
            self.hand_on_moves(moves, shift)?;
            offsets[0].geometry = g2;
        } else {
            // The offsets do not meet: either the tail is swallowed (the new offset meets a
            // piece before it), or this element is (the next one's offset meets the tail),
            // or the tool cannot reach the corner (a gouge).
            let error = self.inside_corner_error(piece);
            let (_, a) = self.ends(&last.geometry);
            let (b, _) = self.ends(&offsets[0].geometry);
            if swallowed == 0
                && moves.is_empty()
                && (a[self.p] - b[self.p]).hypot(a[self.q] - b[self.q]) <= NEAR_TANGENT_GAP_MM
            {
                // Nearly tangent elements (rounded arc data): the offsets meet only far away or
                // not at all; they are joined where the tail ends.
                let (last, full) = self.tail_piece(last, entry_from, t1)?;
                self.stage(last, Some(full));
                if let Some(g) = self.last_end.and_then(|end| self.starting_at(&offsets[0].geometry, end)) {
                    offsets[0].geometry = g;
                }
                let last = offsets.pop().expect("an offset has at least one piece");
                for o in offsets {
                    let full = o.geometry.clone();
                    self.stage(o, Some(full));
                }
                return Ok(Held {
                    tail: last,
                    corner: contour_end,
                    tangent: end_tangent,
                    moves: Vec::new(),
                    swallowed: 0,
                    gouge: None,
                    entry_from: None,
                });
            }
            if !moves.is_empty() {
                return Err(error);
            }
            match self.trim_back(&offsets[0].geometry, corner) {
                Some(g2) => offsets[0].geometry = g2,
                None if swallowed < MAX_SWALLOWED && offsets.len() == 1 => {
                    return Ok(Held {
                        tail: last,
                        corner,
                        tangent: t1,
                        moves,
                        swallowed: swallowed + 1,
                        gouge: Some(gouge.unwrap_or(error)),
                        entry_from,
                    });
                }
                None => return Err(gouge.unwrap_or(error)),
            }
        }
        let last = offsets.pop().expect("an offset has at least one piece");
        for o in offsets {
            let full = o.geometry.clone();
            self.stage(o, Some(full));
        }
        Ok(Held {
            tail: last,
            corner: contour_end,
            tangent: end_tangent,
            moves: Vec::new(),
            swallowed: 0,
            gouge: None,
            entry_from: None,
        })
    }

    /// The entry move (the first move in the plane after G41/G42) as LinuxCNC's
    /// `convert_straight_comp1` and `convert_arc_comp1`, from where the tool stands (the
    /// programmed start moved by `shift`); held as the tail for the corner after it.
    fn entry(&mut self, piece: Piece, shift: [f64; 2]) -> Result<Held, CutterError> {
        let (a, b) = self.ends(&piece.geometry);
        let start = self.plus(a, shift);
        let (p, q, r) = (self.p, self.q, self.radius_mm);
        let (dp, dq) = (b[p] - start[p], b[q] - start[q]);
        let dist = dp.hypot(dq);
        if dist <= r {
            return Err(piece.error(CutterErrorKind::EntryTooShort { radius_mm: fmt_num(r) }));
        }
        match &piece.geometry {
            Geometry::Line(_) => {
                // The tool ends beside the end point, across the direction from where it stands.
                let tangent = [dp / dist, dq / dist];
                let end = self.plus(b, self.normal(tangent));
                let reach = dist + ENTRY_REACH * r;
                let mut from = end;
                from[p] -= tangent[0] * reach;
                from[q] -= tangent[1] * reach;
                let tail = Piece { geometry: Geometry::Line(Line::new(from, end, reach)), ..piece };
                Ok(Held {
                    tail,
                    corner: b,
                    tangent,
                    moves: Vec::new(),
                    swallowed: 0,
                    gouge: None,
                    entry_from: Some(start),
                })
            }
            Geometry::Helix(h) => {
                let c = h.center();
                let turn = h.sweep_rad().signum();
                // The tool is inside the arc on the left of a counter-clockwise one.
                let inside = self.side.sign() * turn > 0.0;
                let radius = h.radius_mm();
                if inside && radius <= r {
                    return Err(
                        piece.error(CutterErrorKind::ConcaveArc { radius_mm: fmt_num(r), arc_mm: fmt_num(radius) })
                    );
                }
                // The end moves by r along the radius (towards the centre inside).
                let (ep, eq) = (b[p] - c[0], b[q] - c[1]);
                let re = ep.hypot(eq);
                let k = if inside { -r } else { r } / re;
                let mut end = b;
                end[p] += k * ep;
                end[q] += k * eq;
                // The new centre lies on the line from the new end towards the programmed
                // centre, as far from where the tool stands as from the new end.
                let ab = (c[1] - end[q]).atan2(c[0] - end[p]);
                let half = (start[p] - end[p]).hypot(start[q] - end[q]) / 2.0;
                let cos_a = ((start[q] - end[q]).atan2(start[p] - end[p]) - ab).cos();
                if cos_a.abs() < ENTRY_ARC_COS_MIN {
                    return Err(piece.error(CutterErrorKind::EntryArcDegenerate { radius_mm: fmt_num(r) }));
                }
                let len = half / cos_a;
                let centre = [end[p] + len * ab.cos(), end[q] + len * ab.sin()];
                // One turn in the arc's direction, as LinuxCNC's find_turn.
                let alpha = (start[q] - centre[1]).atan2(start[p] - centre[0]);
                let beta = (end[q] - centre[1]).atan2(end[p] - centre[0]);
                let sweep = if turn > 0.0 {
                    if beta <= alpha { beta + 2.0 * PI - alpha } else { beta - alpha }
                } else if alpha <= beta {
                    beta - alpha - 2.0 * PI
                } else {
                    beta - alpha
                };
                let arc = Helix::new(p, q, centre, sweep, start, end, &self.linear[..self.n_axes]);
                let tangent = self.end_tangent(&piece.geometry);
                Ok(Held {
                    tail: Piece { geometry: Geometry::Helix(arc), ..piece },
                    corner: b,
                    tangent,
                    moves: Vec::new(),
                    swallowed: 0,
                    gouge: None,
                    entry_from: None,
                })
            }
            _ => Err(piece.error(CutterErrorKind::EntryNotLine)),
        }
    }

    /// The tail as it is handed on, and its geometry for a later corner to trim back into:
    /// for a straight entry the line from where the tool stood to the end of the (possibly
    /// trimmed) parallel offset; any other tail as it is.
    fn tail_piece(
        &self,
        tail: Piece,
        entry_from: Option<AxisVec>,
        tangent: [f64; 2],
    ) -> Result<(Piece, Geometry), CutterError> {
        let Some(from) = entry_from else {
            let full = tail.geometry.clone();
            return Ok((tail, full));
        };
        let (_, end) = self.ends(&tail.geometry);
        // As LinuxCNC (move_endpoint_and_flush): an end moved behind the entry's start, seen
        // across the entry's direction towards the tool's side, would reverse the move.
        let n = self.normal(tangent);
        if (end[self.p] - from[self.p]) * n[0] + (end[self.q] - from[self.q]) * n[1] < 0.0 {
            return Err(tail.error(CutterErrorKind::EntryReversed));
        }
        let Some(g) = self.line(from, end) else {
            return Err(tail.error(CutterErrorKind::EntryTooShort { radius_mm: fmt_num(self.radius_mm) }));
        };
        Ok((Piece { geometry: g.clone(), ..tail }, g))
    }

    /// LinuxCNC's rule for a corner within [`REVERSAL_BAND_RAD`] of a reversal, from the
    /// tail `prev` (the previous element's offset) into the contour element `next`: inside
    /// when the tool runs outside the arc `next` is (`!TOOL_INSIDE_ARC` in `convert_arc_comp2`),
    /// or, `next` being a line, outside the arc `prev` is (the "h" shape of
    /// `convert_straight_comp2`).
    fn reversal_is_inside(&self, prev: &Geometry, next: &Geometry) -> bool {
        let outside_of = |g: &Geometry| match g {
            Geometry::Helix(h) => Some(self.side.sign() * h.sweep_rad() < 0.0),
            _ => None,
        };
        match next {
            Geometry::Helix(_) => outside_of(next).unwrap_or(false),
            Geometry::Line(_) => outside_of(prev).unwrap_or(false),
            _ => false,
        }
    }

    fn inside_corner_error(&self, piece: &Piece) -> CutterError {
        piece.error(CutterErrorKind::InsideCorner { radius_mm: fmt_num(self.radius_mm) })
    }

    /// `g1` up to and `g2` from their intersection in the plane, both non-empty.
    fn trim_corner(&self, g1: &Geometry, g2: &Geometry) -> Option<(Geometry, Geometry)> {
        let (s1, s2) = intersect_or_closed_form(g1, g2, self.p, self.q)?;
        let linear = &self.linear[..self.n_axes];
        Some((trim(g1, 0.0, s1, linear)?, trim(g2, s2, g2.length_mm(), linear)?))
    }

    /// An inside corner that swallows the tail: the latest piece kept back that the new
    /// offset `g2` meets is trimmed there and the pieces after it are dropped; returns `g2`
    /// from the intersection on. Only pieces within the tool's reach of the contour corner
    /// (2·r) are dropped: what lies further away is not swallowed by this corner.
    fn trim_back(&mut self, g2: &Geometry, corner: AxisVec) -> Option<Geometry> {
        let reach = 2.0 * self.radius_mm + INTERSECT_SLACK_MM;
        let near = |c: &Cutter, g: &Geometry| {
            let (a, b) = c.ends(g);
            [a, b].iter().all(|x| (x[c.p] - corner[c.p]).hypot(x[c.q] - corner[c.q]) <= reach)
        };
        for k in (0..self.staged.len()).rev() {
            let full = self.staged[k].full.as_ref()?;
            if let Some((g1, rest)) = self.trim_corner(full, g2) {
                let full = full.clone();
                let prev_end = self.staged[k].prev_end;
                let kept = self.staged.drain(k..).next().expect("k is in range");
                self.last_end = prev_end;
                self.stage(Piece { geometry: g1, ..kept.piece }, Some(full));
                return Some(rest);
            }
            if !near(self, full) {
                return None;
            }
        }
        None
    }

    /// Hands on a tool path element, starting exactly where the one before ends: trimming
    /// at an inside corner is exact in the plane, but on a contour that moves along the third
    /// axis the two trimmed elements reach the intersection at slightly different heights, so
    /// the later one is made to start at the earlier one's end.
    fn emit(&mut self, piece: Piece) {
        self.stage(piece, None);
    }

    /// [`Cutter::emit`], keeping `full` (the piece before its end was trimmed) for a later
    /// inside corner that may trim back into it.
    fn stage(&mut self, mut piece: Piece, full: Option<Geometry>) {
        if let Some(end) = self.last_end {
            let (start, _) = self.ends(&piece.geometry);
            let gap = (0..self.n_axes).map(|k| (start[k] - end[k]).abs()).fold(0.0, f64::max);
            let plane_gap = (start[self.p] - end[self.p]).hypot(start[self.q] - end[self.q]);
            if gap > CONNECT_EXACT_MM && plane_gap <= CONNECT_PLANE_MM {
                if let Some(g) = self.starting_at(&piece.geometry, end) {
                    piece.geometry = g;
                }
            }
        }
        let end = self.ends(&piece.geometry).1;
        let prev_end = self.last_end.replace(end);
        self.staged.push_back(Staged { piece, full, prev_end });
        while self.staged.len() > MAX_STAGED {
            let s = self.staged.pop_front().expect("not empty");
            self.out.push_back(s.piece);
        }
    }

    /// `g` from `start` instead of its own start point, to the same end.
    fn starting_at(&self, g: &Geometry, start: AxisVec) -> Option<Geometry> {
        let (_, end) = self.ends(g);
        let linear = &self.linear[..self.n_axes];
        match g {
            Geometry::Line(_) => self.line(start, end),
            Geometry::Helix(h) => {
                // The centre moves onto the bisector of the new start and the end, so the arc
                // still ends where it ended.
                let (p, q) = h.plane_axes();
                let (a, b) = ([start[p], start[q]], [end[p], end[q]]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let chord = dx.hypot(dy);
                if chord <= MIN_MOVE_MM {
                    return Some(Geometry::Helix(Helix::new(p, q, h.center(), h.sweep_rad(), start, end, linear)));
                }
                let (n, m, c) = ([-dy / chord, dx / chord], [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0], h.center());
                let t = (c[0] - m[0]) * n[0] + (c[1] - m[1]) * n[1];
                let c = [m[0] + t * n[0], m[1] + t * n[1]];
                let turned = (b[1] - c[1]).atan2(b[0] - c[0]) - (a[1] - c[1]).atan2(a[0] - c[0]);
                let mut sweep = h.sweep_rad() + (turned - h.sweep_rad()).rem_euclid(2.0 * PI);
                if sweep - h.sweep_rad() > PI {
                    sweep -= 2.0 * PI;
                }
                Some(Geometry::Helix(Helix::new(p, q, c, sweep, start, end, linear)))
            }
            Geometry::Cubic(c) => c.with_start(&start).ok().map(|c| Geometry::Cubic(Box::new(c))),
            _ => None,
        }
    }

    /// Hands on the held moves shifted by `shift` in the plane; returns where the last one
    /// ends on the contour (None without moves).
    fn hand_on_moves(&mut self, moves: Vec<Piece>, shift: [f64; 2]) -> Result<Option<AxisVec>, CutterError> {
        let mut at = None;
        for m in moves {
            at = Some(self.ends(&m.geometry).1);
            let moved = self.shifted(&m, shift)?;
            self.emit(moved);
        }
        Ok(at)
    }

    /// Hands on the held tail untrimmed; returns the shift of the tool from the contour.
    /// Elements swallowed by a corner that never resolves are an error.
    fn release(&mut self, held: Held) -> Result<[f64; 2], CutterError> {
        if held.swallowed > 0 {
            return Err(held.gouge.expect("a swallowed element names its error"));
        }
        let n1 = self.normal(held.tangent);
        let (tail, _) = self.tail_piece(held.tail, held.entry_from, held.tangent)?;
        self.emit(tail);
        for m in held.moves {
            // Held moves are lines (checked when offset), so shifting cannot fail.
            if let Ok(moved) = self.shifted(&m, n1) {
                self.emit(moved);
            }
        }
        Ok(n1)
    }

    /// The contour element offset by the tool radius: one piece for lines and arcs, several
    /// cubic spans for a spline span.
    fn offset(&self, piece: &Piece) -> Result<Vec<Piece>, CutterError> {
        let sign = self.side.sign();
        let r = self.radius_mm;
        let linear = &self.linear[..self.n_axes];
        match &piece.geometry {
            Geometry::Line(_) => {
                let n = self.normal(self.start_tangent(&piece.geometry));
                Ok(vec![self.shifted(piece, n)?])
            }
            Geometry::Helix(h) => {
                let radius = h.radius_mm();
                let (p, q) = (self.p, self.q);
                // The centre lies left of the travel for G3 (positive sweep): the tool on
                // the left is inside the arc.
                let new_radius = radius - sign * h.sweep_rad().signum() * r;
                if new_radius <= MIN_OFFSET_RADIUS_MM {
                    return Err(
                        piece.error(CutterErrorKind::ConcaveArc { radius_mm: fmt_num(r), arc_mm: fmt_num(radius) })
                    );
                }
                let c = h.center();
                let (mut a, mut b) = self.ends(&piece.geometry);
                for x in [&mut a, &mut b] {
                    let (dp, dq) = (x[p] - c[0], x[q] - c[1]);
                    let len = dp.hypot(dq);
                    x[p] = c[0] + dp / len * new_radius;
                    x[q] = c[1] + dq / len * new_radius;
                }
                let arc = Helix::new(p, q, c, h.sweep_rad(), a, b, linear);
                Ok(vec![Piece { geometry: Geometry::Helix(arc), ..piece.clone() }])
            }
            Geometry::Cubic(c) => {
                let spans = self.offset_spline(c, piece)?;
                let mut out: Vec<Piece> = spans.into_iter().map(|s| piece.with(Geometry::Cubic(Box::new(s)))).collect();
                out[0].dwell_before_s = piece.dwell_before_s;
                Ok(out)
            }
            // The interpreter makes lines, arcs and spline spans only.
            _ => Ok(vec![piece.clone()]),
        }
    }

    /// Q(u) = P(u) + sign·r·n(u) and Q′(u) for a spline span: n is the left unit normal in the
    /// plane, and Q′ = P′·(1 − sign·r·κ) in the plane with κ the signed curvature there.
    fn offset_point(&self, c: &CubicSpan, u: f64) -> (AxisVec, AxisVec, f64) {
        let [mut pos, mut d1, d2] = c.raw_at_u(u);
        let (p, q) = (self.p, self.q);
        let speed = d1[p].hypot(d1[q]);
        let kappa = (d1[p] * d2[q] - d1[q] * d2[p]) / speed.powi(3);
        let f = 1.0 - self.side.sign() * self.radius_mm * kappa;
        let k = self.side.sign() * self.radius_mm / speed;
        pos[p] += -d1[q] * k;
        pos[q] += d1[p] * k;
        d1[p] *= f;
        d1[q] *= f;
        (pos, d1, f)
    }

    fn offset_spline(&self, c: &CubicSpan, piece: &Piece) -> Result<Vec<CubicSpan>, CutterError> {
        let (p, q) = (self.p, self.q);
        // Gouge: the offset turns back where the curvature radius on the tool's side is not
        // larger than the tool radius (1 − sign·r·κ ≤ 0).
        let mut worst = (f64::INFINITY, 0.0);
        for i in 0..=GOUGE_SCAN_POINTS {
            let u = i as f64 / GOUGE_SCAN_POINTS as f64;
            let [_, d1, _] = c.raw_at_u(u);
            if d1[p].hypot(d1[q]) <= 0.0 {
                return Err(piece.error(CutterErrorKind::SplineOutOfPlane));
            }
            let (_, _, f) = self.offset_point(c, u);
            if f < worst.0 {
                worst = (f, u);
            }
        }
        if worst.0 <= 0.0 {
            let [_, d1, d2] = c.raw_at_u(worst.1);
            let speed = d1[p].hypot(d1[q]);
            let kappa = (d1[p] * d2[q] - d1[q] * d2[p]).abs() / speed.powi(3);
            return Err(piece.error(CutterErrorKind::ConcaveSpline {
                radius_mm: fmt_num(self.radius_mm),
                curve_mm: fmt_num(1.0 / kappa),
                u: worst.1,
            }));
        }
        let mut out = Vec::new();
        let mut stack: Vec<(f64, f64, usize)> = (0..SPLINE_INITIAL_PIECES)
            .rev()
            .map(|i| (i as f64 / SPLINE_INITIAL_PIECES as f64, (i + 1) as f64 / SPLINE_INITIAL_PIECES as f64, 0))
            .collect();
        let linear = &self.linear[..self.n_axes];
        while let Some((u0, u1, depth)) = stack.pop() {
            let (a, ta, _) = self.offset_point(c, u0);
            let (b, tb, _) = self.offset_point(c, u1);
            let h = u1 - u0;
            let (ta, tb) = (ta.map(|v| v * h), tb.map(|v| v * h));
            let span = CubicSpan::hermite(&a, &b, &ta, &tb, linear);
            let ok = span.as_ref().is_ok_and(|s| self.within_tol(c, s, u0, u1));
            match span {
                Ok(s) if ok => out.push(s),
                _ if depth < SPLINE_MAX_DEPTH => {
                    let m = 0.5 * (u0 + u1);
                    stack.push((m, u1, depth + 1));
                    stack.push((u0, m, depth + 1));
                }
                _ => return Err(piece.error(CutterErrorKind::DegenerateSplineOffset)),
            }
        }
        Ok(out)
    }

    /// The piece `s` (Hermite over u ∈ [u0, u1]) agrees with the true offset at interior
    /// points, compared at equal parameter: a bound on the distance between the curves.
    fn within_tol(&self, c: &CubicSpan, s: &CubicSpan, u0: f64, u1: f64) -> bool {
        (1..=SPLINE_CHECK_POINTS).all(|i| {
            let t = i as f64 / (SPLINE_CHECK_POINTS + 1) as f64;
            let (want, _, _) = self.offset_point(c, u0 + t * (u1 - u0));
            let [got, _, _] = s.raw_at_u(t);
            let err: f64 = (0..self.n_axes).filter(|&k| self.linear[k]).map(|k| (got[k] - want[k]).powi(2)).sum();
            err.sqrt() <= SPLINE_OFFSET_TOL_MM
        })
    }

    /// A move without motion in the plane (or a line) shifted by `shift` in the plane.
    fn shifted(&self, piece: &Piece, shift: [f64; 2]) -> Result<Piece, CutterError> {
        match &piece.geometry {
            Geometry::Line(l) => {
                let (a, b) = self.ends(&piece.geometry);
                let g = Line::new(self.plus(a, shift), self.plus(b, shift), l.length_mm());
                Ok(Piece { geometry: Geometry::Line(g), ..piece.clone() })
            }
            _ => Err(piece.error(CutterErrorKind::SplineOutOfPlane)),
        }
    }

    /// A line between two points, None if they coincide.
    fn line(&self, a: AxisVec, b: AxisVec) -> Option<Geometry> {
        let lin: f64 = (0..self.n_axes).filter(|&k| self.linear[k]).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
        let len = if lin > MIN_MOVE_MM {
            lin
        } else {
            (0..self.n_axes).filter(|&k| !self.linear[k]).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt()
        };
        (len > MIN_MOVE_MM).then(|| Geometry::Line(Line::new(a, b, len)))
    }

    fn plus(&self, mut a: AxisVec, shift: [f64; 2]) -> AxisVec {
        a[self.p] += shift[0];
        a[self.q] += shift[1];
        a
    }

    /// sign·r times the left unit normal of the unit tangent `t`.
    fn normal(&self, t: [f64; 2]) -> [f64; 2] {
        let k = self.side.sign() * self.radius_mm;
        [-t[1] * k, t[0] * k]
    }

    fn ends(&self, g: &Geometry) -> (AxisVec, AxisVec) {
        let mut d = AxisDerivs::default();
        g.eval(0.0, &mut d);
        let a = d.pos;
        g.eval(g.length_mm(), &mut d);
        (a, d.pos)
    }

    fn tangent_at(&self, g: &Geometry, s: f64) -> [f64; 2] {
        let mut d = AxisDerivs::default();
        g.eval(s, &mut d);
        let (tp, tq) = (d.d1[self.p], d.d1[self.q]);
        let n = tp.hypot(tq);
        [tp / n, tq / n]
    }

    fn start_tangent(&self, g: &Geometry) -> [f64; 2] {
        self.tangent_at(g, 0.0)
    }

    fn end_tangent(&self, g: &Geometry) -> [f64; 2] {
        self.tangent_at(g, g.length_mm())
    }

    /// Length of the element's projection on the plane, from its end points and middle (an
    /// arc in the plane or a spline always moves its ends or its middle there).
    fn plane_length(&self, g: &Geometry) -> f64 {
        let mut d = AxisDerivs::default();
        let mut pts = [[0.0; 2]; 3];
        for (i, s) in [0.0, 0.5, 1.0].iter().enumerate() {
            g.eval(s * g.length_mm(), &mut d);
            pts[i] = [d.pos[self.p], d.pos[self.q]];
        }
        let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        dist(pts[0], pts[1]) + dist(pts[1], pts[2])
    }
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The intersection of `g1` (near its end) and `g2` (near its start) in the plane (p, q), as
/// path positions (s1, s2) inside both: Newton's method from the intersection of the tangent
/// lines at g1's end and g2's start.
fn intersect(g1: &Geometry, g2: &Geometry, p: usize, q: usize) -> Option<(f64, f64)> {
    let (l1, l2) = (g1.length_mm(), g2.length_mm());
    let (mut a, mut b) = (AxisDerivs::default(), AxisDerivs::default());
    g1.eval(l1, &mut a);
    g2.eval(0.0, &mut b);
    let solve = |a: &AxisDerivs, b: &AxisDerivs| -> Option<(f64, f64)> {
        // a.pos + a.d1·x = b.pos + b.d1·y
        let (rp, rq) = (b.pos[p] - a.pos[p], b.pos[q] - a.pos[q]);
        let det = -a.d1[p] * b.d1[q] + a.d1[q] * b.d1[p];
        if det.abs() < 1e-15 {
            return None;
        }
        let x = (-rp * b.d1[q] + rq * b.d1[p]) / det;
        let y = (a.d1[p] * rq - a.d1[q] * rp) / det;
        Some((x, y))
    };
    let (x, y) = solve(&a, &b)?;
    let (mut s1, mut s2) = (l1 + x, y);
    for _ in 0..INTERSECT_STEPS {
        if !(-INTERSECT_SLACK_MM..=l1 + INTERSECT_SLACK_MM).contains(&s1)
            || !(-INTERSECT_SLACK_MM..=l2 + INTERSECT_SLACK_MM).contains(&s2)
        {
            return None;
        }
        (s1, s2) = (s1.clamp(0.0, l1), s2.clamp(0.0, l2));
        g1.eval(s1, &mut a);
        g2.eval(s2, &mut b);
        if (a.pos[p] - b.pos[p]).hypot(a.pos[q] - b.pos[q]) <= INTERSECT_TOL_MM {
            return Some((s1, s2));
        }
        let (x, y) = solve(&a, &b)?;
        s1 += x;
        s2 += y;
    }
    None
}

/// The intersection of `g1` and `g2` in the plane, as [`intersect`], where Newton's method
/// from the tangent lines does not find it: for lines and arcs, in closed form. Near a
/// reversal (an arc that turns back against the line it follows) the tangent lines meet far
/// from the curves and the iteration leaves them; the offsets still meet, and LinuxCNC
/// (`convert_arc_comp2`, `convert_straight_comp2`) finds that point in closed form too. Of
/// several intersections inside both elements, the first on `g2`.
fn intersect_or_closed_form(g1: &Geometry, g2: &Geometry, p: usize, q: usize) -> Option<(f64, f64)> {
    if let Some(s) = intersect(g1, g2, p, q) {
        return Some(s);
    }
    let (c1, c2) = (PlaneCurve::of(g1, p, q)?, PlaneCurve::of(g2, p, q)?);
    let (l1, l2) = (g1.length_mm(), g2.length_mm());
    let mut best: Option<(f64, f64)> = None;
    for x in c1.meet(&c2) {
        for u1 in c1.fractions_at(x, INTERSECT_SLACK_MM / l1) {
            for u2 in c2.fractions_at(x, INTERSECT_SLACK_MM / l2) {
                let (s1, s2) = ((u1 * l1).clamp(0.0, l1), (u2 * l2).clamp(0.0, l2));
                if best.is_none_or(|(b1, b2)| s2 < b2 || (s2 == b2 && s1 > b1)) {
                    best = Some((s1, s2));
                }
            }
        }
    }
    let (s1, s2) = best?;
    let (mut a, mut b) = (AxisDerivs::default(), AxisDerivs::default());
    g1.eval(s1, &mut a);
    g2.eval(s2, &mut b);
    ((a.pos[p] - b.pos[p]).hypot(a.pos[q] - b.pos[q]) <= CLOSED_FORM_TOL_MM).then_some((s1, s2))
}

/// A line or an arc in the compensation plane.
enum PlaneCurve {
    /// From `a` along `d` (the whole element: fraction 0 … 1).
    Line { a: [f64; 2], d: [f64; 2] },
    /// About `c` with radius `r`, from angle `phi0` turning `sweep` (signed).
    Arc { c: [f64; 2], r: f64, phi0: f64, sweep: f64 },
}

impl PlaneCurve {
    fn of(g: &Geometry, p: usize, q: usize) -> Option<Self> {
        let mut d = AxisDerivs::default();
        g.eval(0.0, &mut d);
        let a = [d.pos[p], d.pos[q]];
        match g {
            Geometry::Line(_) => {
                g.eval(g.length_mm(), &mut d);
                let dir = [d.pos[p] - a[0], d.pos[q] - a[1]];
                (dir[0].hypot(dir[1]) > MIN_PLANE_MOVE_MM).then_some(PlaneCurve::Line { a, d: dir })
            }
            Geometry::Helix(h) if h.plane_axes() == (p, q) && h.radius_mm() > MIN_OFFSET_RADIUS_MM => {
                let c = h.center();
                let phi0 = (a[1] - c[1]).atan2(a[0] - c[0]);
                Some(PlaneCurve::Arc { c, r: h.radius_mm(), phi0, sweep: h.sweep_rad() })
            }
            _ => None,
        }
    }

    /// The points where the two curves (as whole lines and circles) cross.
    fn meet(&self, other: &PlaneCurve) -> Vec<[f64; 2]> {
        match (self, other) {
            (PlaneCurve::Line { a: a1, d: d1 }, PlaneCurve::Line { a: a2, d: d2 }) => {
                let det = cross(*d1, *d2);
                if det.abs() < 1e-15 {
                    return Vec::new();
                }
                let t = cross([a2[0] - a1[0], a2[1] - a1[1]], *d2) / det;
                vec![[a1[0] + t * d1[0], a1[1] + t * d1[1]]]
            }
            (PlaneCurve::Line { a, d }, PlaneCurve::Arc { c, r, .. })
            | (PlaneCurve::Arc { c, r, .. }, PlaneCurve::Line { a, d }) => {
                // |a + t·d − c|² = r²
                let f = [a[0] - c[0], a[1] - c[1]];
                let (qa, qb, qc) = (dot(*d, *d), 2.0 * dot(f, *d), dot(f, f) - r * r);
                let disc = qb * qb - 4.0 * qa * qc;
                if disc < 0.0 {
                    return Vec::new();
                }
                let root = disc.sqrt();
                [(-qb - root) / (2.0 * qa), (-qb + root) / (2.0 * qa)]
                    .iter()
                    .map(|t| [a[0] + t * d[0], a[1] + t * d[1]])
                    .collect()
            }
            (PlaneCurve::Arc { c: c1, r: r1, .. }, PlaneCurve::Arc { c: c2, r: r2, .. }) => {
                let (dx, dy) = (c2[0] - c1[0], c2[1] - c1[1]);
                let dist = dx.hypot(dy);
                if dist < 1e-12 || dist > r1 + r2 || dist < (r1 - r2).abs() {
                    return Vec::new();
                }
                let along = (r1 * r1 - r2 * r2 + dist * dist) / (2.0 * dist);
                let h = (r1 * r1 - along * along).max(0.0).sqrt();
                let m = [c1[0] + along * dx / dist, c1[1] + along * dy / dist];
                vec![[m[0] - h * dy / dist, m[1] + h * dx / dist], [m[0] + h * dy / dist, m[1] - h * dx / dist]]
            }
        }
    }

    /// The fractions of the element (0 … 1, `slack` beyond) at which it passes point `x`,
    /// which lies on its line or circle.
    fn fractions_at(&self, x: [f64; 2], slack: f64) -> Vec<f64> {
        let inside = |u: &f64| (-slack..=1.0 + slack).contains(u);
        match self {
            PlaneCurve::Line { a, d } => {
                let u = dot([x[0] - a[0], x[1] - a[1]], *d) / dot(*d, *d);
                [u].into_iter().filter(inside).collect()
            }
            PlaneCurve::Arc { c, phi0, sweep, .. } => {
                // The angle turned from the start in the arc's direction, every turn of it.
                let turned = ((x[1] - c[1]).atan2(x[0] - c[0]) - phi0) * sweep.signum();
                let first = turned.rem_euclid(2.0 * PI);
                let turns = (sweep.abs() / (2.0 * PI)).ceil() as usize + 1;
                (0..=turns)
                    .flat_map(|k| [first + k as f64 * 2.0 * PI, first + (k as f64 - 1.0) * 2.0 * PI])
                    .map(|t| t / sweep.abs())
                    .filter(inside)
                    .collect()
            }
        }
    }
}

/// The part s ∈ [s0, s1] of a line, arc or spline span (None if it is empty).
fn trim(g: &Geometry, s0: f64, s1: f64, linear: &[bool]) -> Option<Geometry> {
    let len = g.length_mm();
    if s1 - s0 <= MIN_MOVE_MM {
        return None;
    }
    if s0 <= 0.0 && s1 >= len {
        return Some(g.clone());
    }
    let (mut a, mut b) = (AxisDerivs::default(), AxisDerivs::default());
    g.eval(s0, &mut a);
    g.eval(s1, &mut b);
    match g {
        Geometry::Line(_) => Some(Geometry::Line(Line::new(a.pos, b.pos, s1 - s0))),
        Geometry::Helix(h) => {
            let (p, q) = h.plane_axes();
            let sweep = h.sweep_rad() * (s1 - s0) / len;
            Some(Geometry::Helix(Helix::new(p, q, h.center(), sweep, a.pos, b.pos, linear)))
        }
        Geometry::Cubic(c) => {
            let (u0, u1) = (c.u_at(s0), c.u_at(s1));
            c.sub_span(u0, u1).ok().map(|c| Geometry::Cubic(Box::new(c)))
        }
        _ => None,
    }
}
