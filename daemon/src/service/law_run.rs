//! Motion-law moves executed by the daemon (laws from interpolation conditions, after
//! Bewegungsdesign nach Maß and VDI 2143; docs/motion-laws.md): a law move drives its axes
//! along the straight line from start to start + stroke with the law's time profile instead of
//! a planned one. The planner thread samples the law into coarse points (checked against the
//! exact law like planned motion, position and jerk) and gives every chunk the fastest stop
//! along the line as its tail, so a hold, a stop or an underrun works as for programs. After a
//! hold or an underrun the rest of the strokes is completed as rapid moves along the same lines
//! (the law's time profile cannot be resumed from rest mid-stroke).
//!
//! Also here: programs of `LAW` statements ([`LawProgram`]) and their errors.

use crate::control::errors::LawProgramError;
use crate::interp::coarse::{CoarsePoint, JERK_TOLERANCE, TOLERANCE_MM};
use crate::interp::hermite::{self, Kinematic};
use interpd_config::AxisKind;
use interpd_motion::Settings;
use interpd_motion::law::program::{self as law_program, LawBlock, is_law_statement};
use interpd_motion::law::{AxisState, LawMove};
use interpd_motion::path::{AxisVec, Blend, Feed, Geometry, Line, MAX_AXES, Path, Source};
use std::collections::VecDeque;

/// Bisections of a sampling step before a piece is accepted as it is.
const MAX_HALVINGS: usize = 12;
/// Time left in a move below which it counts as sampled to its end, s.
const END_TOL_S: f64 = 1e-12;

/// The moves of a law program and where sampling stands.
#[derive(Debug, Clone)]
pub struct LawPart {
    moves: VecDeque<(LawMove, LineFrame)>,
    /// Time already sampled in the current move, s.
    t_s: f64,
}

/// How a move's axes map to the path coordinate of its line.
#[derive(Debug, Clone, Copy)]
struct LineFrame {
    s0_mm: f64,
    /// ds per unit of position of `ref_axis`.
    per_axis: f64,
    ref_axis: usize,
    line: u32,
}

/// The lines a sequence of law moves runs along (rapid feed, so a restart after a hold
/// completes them as rapid moves), and the moves with their frames.
pub fn law_path(settings: &Settings, moves: Vec<LawMove>, start: AxisVec, lines: &[u32]) -> (Path, LawPart) {
    let names = settings.axis_names();
    let mut path = Path::new(names, start);
    let mut pos = start;
    let mut part = LawPart { moves: VecDeque::new(), t_s: 0.0 };
    for (i, mv) in moves.into_iter().enumerate() {
        let mut end = pos;
        for a in mv.axes() {
            end[a.axis] = a.start + a.stroke;
        }
        let dist = |kind: AxisKind| {
            (0..settings.axes.len())
                .filter(|&k| settings.axes[k].kind == kind)
                .map(|k| (end[k] - pos[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let linear = dist(AxisKind::Linear);
        let length = if linear > 0.0 { linear } else { dist(AxisKind::Rotary) };
        let line = lines.get(i).copied().unwrap_or(0);
        let s0 = path.length_mm();
        let (ref_axis, delta) = mv
            .axes()
            .iter()
            .map(|a| (a.axis, a.stroke))
            .fold((0, 0.0f64), |best, x| if x.1.abs() > best.1.abs() { x } else { best });
        if length > 0.0 {
            path.push(
                Geometry::Line(Line::new(pos, end, length)),
                Feed::Rapid,
                Source { line, block: 0 },
                0.0,
                Blend::Exact,
            );
        }
        let per_axis = if delta != 0.0 { length / delta } else { 0.0 };
        part.moves.push_back((mv, LineFrame { s0_mm: s0, per_axis, ref_axis, line }));
        pos = end;
    }
    (path, part)
}

impl LawPart {
    /// All moves are sampled to their ends.
    pub fn is_done(&self) -> bool {
        match self.moves.len() {
            0 => true,
            1 => self.moves[0].0.duration_s() - self.t_s <= END_TOL_S,
            _ => false,
        }
    }

    /// Appends about `want_s` of law motion to `out` (first point: `out`'s last), stepping
    /// `step_s` and halving where the quintic misses the exact law (position within
    /// [`TOLERANCE_MM`], jerk within [`JERK_TOLERANCE`] of `max_jerk`). Returns the time added.
    pub fn sample(&mut self, want_s: f64, step_s: f64, max_jerk: &AxisVec, out: &mut Vec<CoarsePoint>) -> f64 {
        let mut added = 0.0;
        while added < want_s - END_TOL_S {
            let Some((mv, frame)) = self.moves.front() else { break };
            let remaining = mv.duration_s() - self.t_s;
            if remaining <= END_TOL_S {
                self.moves.pop_front();
                self.t_s = 0.0;
                continue;
            }
            let mut h = step_s.min(remaining).min(want_s - added + step_s * 0.5);
            let start = *out.last().expect("a start point");
            let mut end = point(mv, frame, self.t_s + h, start.t_s + h, start.pos);
            for _ in 0..MAX_HALVINGS {
                if fits(mv, self.t_s, h, &start, &end, max_jerk) {
                    break;
                }
                h *= 0.5;
                end = point(mv, frame, self.t_s + h, start.t_s + h, start.pos);
            }
            out.push(end);
            self.t_s += h;
            added += h;
        }
        added
    }
}

/// The coarse point of `mv` at its time `t_move_s`, stamped `t_s`; axes not in the move keep
/// their positions from `base`.
fn point(mv: &LawMove, frame: &LineFrame, t_move_s: f64, t_s: f64, base: AxisVec) -> CoarsePoint {
    let mut st = [AxisState::default(); MAX_AXES];
    mv.sample(t_move_s, &mut st);
    let mut p = CoarsePoint { t_s, line: frame.line, pos: base, ..CoarsePoint::default() };
    for (a, s) in mv.axes().iter().zip(&st) {
        p.pos[a.axis] = s.pos;
        p.vel[a.axis] = s.vel_per_s;
        p.acc[a.axis] = s.acc_per_s2;
        if a.axis == frame.ref_axis {
            p.s_mm = frame.s0_mm + (s.pos - a.start) * frame.per_axis;
            p.v_mm_s = s.vel_per_s * frame.per_axis;
            p.a_mm_s2 = s.acc_per_s2 * frame.per_axis;
        }
    }
    p
}

/// The quintic from `start` to `end` matches the law at interior points.
fn fits(mv: &LawMove, t0: f64, h: f64, start: &CoarsePoint, end: &CoarsePoint, max_jerk: &AxisVec) -> bool {
    let mut st = [AxisState::default(); MAX_AXES];
    (1..4).all(|c| {
        let tau = h * f64::from(c) / 4.0;
        mv.sample(t0 + tau, &mut st);
        mv.axes().iter().zip(&st).all(|(a, s)| {
            let k = a.axis;
            let (k0, k1) = (
                Kinematic { p: start.pos[k], v: start.vel[k], a: start.acc[k] },
                Kinematic { p: end.pos[k], v: end.vel[k], a: end.acc[k] },
            );
            (hermite::eval(k0, k1, h, tau).p - s.pos).abs() <= TOLERANCE_MM
                && (hermite::jerk(k0, k1, h, tau) - s.jerk_per_s3).abs() <= JERK_TOLERANCE * max_jerk[k]
        })
    })
}

/// A program of `LAW` statements: each with its 1-based line number.
#[derive(Debug, Clone, PartialEq)]
pub struct LawProgram {
    pub blocks: Vec<(u32, LawBlock)>,
}

/// Whether the text read from `reader` has a `LAW` statement (line by line; unreadable text
/// has none).
pub fn has_law_statement(reader: impl std::io::BufRead) -> bool {
    reader.lines().map_while(Result::ok).any(|l| is_law_statement(&l))
}

/// `Some` when `text` is a law program (it has a `LAW` statement), checked: every other line
/// must be blank or a comment (`;`, `( … )`, `%`), since law moves and G-code do not mix in
/// one program. Errors name the program, line and column.
pub fn parse_law_program(text: &str, name: &str) -> Result<Option<LawProgram>, LawProgramError> {
    if !text.lines().any(is_law_statement) {
        return Ok(None);
    }
    let mut blocks = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let n = u32::try_from(i + 1).unwrap_or(u32::MAX);
        if is_law_statement(line) {
            blocks.push((n, parse_statement(line, name, n)?));
        } else if !is_comment_line(line) {
            return Err(LawProgramError::Mixed { file: name.to_string(), line: n, text: line.trim().to_string() });
        }
    }
    Ok(Some(LawProgram { blocks }))
}

fn parse_statement(line: &str, name: &str, n: u32) -> Result<LawBlock, LawProgramError> {
    law_program::parse(line).map_err(|error| LawProgramError::Statement { file: name.to_string(), line: n, error })
}

fn is_comment_line(line: &str) -> bool {
    let t = line.trim();
    t.is_empty() || t.starts_with(';') || t == "%" || (t.starts_with('(') && t.ends_with(')'))
}

impl LawProgram {
    /// One `LAW` statement as a program of one line (`motion.law`); `None` if `statement` is
    /// not a single `LAW` statement.
    pub fn statement(statement: &str, name: &str) -> Option<Result<LawProgram, LawProgramError>> {
        if statement.contains('\n') || !is_law_statement(statement) {
            return None;
        }
        Some(parse_statement(statement, name, 1).map(|block| LawProgram { blocks: vec![(1, block)] }))
    }

    /// The moves from the axis positions `here`, each starting where the previous ends,
    /// checked against the axis limits (velocity, acceleration, jerk and travel); a move
    /// that is too fast is refused with the factor its duration must grow by (or stretched
    /// when it says `STRETCH`).
    pub fn moves(&self, settings: &Settings, here: &AxisVec, name: &str) -> Result<Vec<LawMove>, LawProgramError> {
        let mut pos = *here;
        let mut out = Vec::with_capacity(self.blocks.len());
        for (n, block) in &self.blocks {
            let mv = block.to_move(settings, &pos[..settings.axes.len()]).map_err(|error| LawProgramError::Move {
                file: name.to_string(),
                line: *n,
                error,
            })?;
            for a in mv.axes() {
                pos[a.axis] = a.start + a.stroke;
            }
            out.push(mv);
        }
        Ok(out)
    }

    pub fn lines(&self) -> Vec<u32> {
        self.blocks.iter().map(|(n, _)| *n).collect()
    }
}
