//! Interprets RS274 / ISO 6983 blocks with the modal state of a real controller and builds the
//! path. Supported: G0 G1 G2 G3 (centre I J K or radius R, helical with the other axes), G4 P
//! dwell, G06 spline blocks (Huan), G17/G18/G19, G20/G21, G61/G64 P, G90/G91, F (per
//! minute), N, M2/M30; spindle, coolant and tool words (M3–M9, S, T) are accepted and counted as
//! ignored, since interpd interpolates motion only.
mod context;
mod cycles;
mod flow;
mod frame;
mod offsets;
mod spline;
mod tool_table;

pub(super) use flow::{LineAt, LinePos};

use super::active::{ActiveCutter, ActiveModal, ActiveTool, CompSide, ModalLog, WORK_SYSTEM_NAMES};
use super::arc_rule;
use super::cutter::{Cutter, Piece, Side};
use super::error::Diagnostics;
use super::lexer::{Line, Word, lex_block};
use super::message::{self, Message, MessageKind, MessageQueue};
use super::params::{Params, Snapshot};
use super::{G06_END_MARKER, Summary};
use crate::Settings;
use crate::path::Line as LineGeom;
use crate::path::{
    AxisVec, Blend, CubicSpan, Feed, Geometry, Helix, MAX_AXES, MIN_CURVATURE_RADIUS_MM, MIN_MOVE_MM, Path, Pause,
    Source, SpanError, StopCode, spline::natural_tangents,
};
use context::Contexts;
use cycles::{CycleKind, CycleState};
use flow::Flow;
use interpd_config::{AxisKind, AxisLetter};
use offsets::OffsetWord;
use spline::{SplineKind, SplineState};
use std::cell::Cell;
use std::f64::consts::PI;
use tool_table::ToolTable;

// `pub(crate)`: `program::fmt_num` (mod.rs) re-exports it from here.
pub(crate) use super::error::fmt_num;

/// Slack of the travel check on elements (the rounding of programmed end points), mm. Arc end
/// points are judged by LinuxCNC's rules (arc_rule.rs).
pub(super) const ARC_RADIUS_ABS_TOL_MM: f64 = 0.002;
/// Arcs with a smaller radius are degenerate.
pub(super) const MIN_ARC_RADIUS_MM: f64 = 1e-6;
/// Millimetres per inch (G20).
const MM_PER_INCH: f64 = 25.4;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Motion {
    Rapid,
    Linear,
    ArcCw,
    ArcCcw,
    /// A canned cycle (G73, G81 … G89).
    Cycle(CycleKind),
    /// G5, G5.1, G5.2 (LinuxCNC's splines).
    Spline(SplineKind),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Plane {
    Xy,
    Zx,
    Yz,
}

impl Plane {
    /// (first, second) plane axes and the letters of their centre offsets.
    fn axes(self) -> ((AxisLetter, char), (AxisLetter, char)) {
        match self {
            Plane::Xy => ((AxisLetter::X, 'I'), (AxisLetter::Y, 'J')),
            Plane::Zx => ((AxisLetter::Z, 'K'), (AxisLetter::X, 'I')),
            Plane::Yz => ((AxisLetter::Y, 'J'), (AxisLetter::Z, 'K')),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Plane::Xy => "G17 (XY)",
            Plane::Zx => "G18 (ZX)",
            Plane::Yz => "G19 (YZ)",
        }
    }
}

/// The modal state a controller keeps between blocks.
#[derive(Debug, Clone)]
pub(crate) struct Modal {
    pub(super) motion: Option<Motion>,
    plane: Plane,
    /// mm per program length unit (1 for G21, 25.4 for G20).
    pub(super) unit_mm: f64,
    pub(super) absolute: bool,
    pub(super) feed_mm_s: Option<f64>,
    /// G93: F is the inverse of each feed move's time, minutes (1/min), given in every block.
    pub(super) inverse_time: bool,
    pub(super) blend: Blend,
    /// Machine position (work offset and tool length applied).
    pub(super) pos: AxisVec,
    /// Active work coordinate system, 0 = G54 … 5 = G59; its origin is read from the settings
    /// at every target, so a changed offset applies to the next block.
    pub(super) work_system: usize,
    /// Active tool length compensation: the tool (None for G43.1) and its length, mm.
    pub(super) tool_length: Option<(Option<u32>, f64)>,
    /// The tool offset G43 applies on every axis (Z: the length), mm or deg; zero after G49.
    pub(super) tool_offset: AxisVec,
    /// The G92 offset per axis, added to every work offset, and the values G92 saved last
    /// (G92.3 restores them; LinuxCNC's parameters 5211–5219).
    pub(super) g92: AxisVec,
    pub(super) g92_saved: AxisVec,
    /// The tool `T` selected last, and the tool `M6` put in the spindle.
    prepared_tool: Option<u32>,
    pub(super) tool: Option<u32>,
    /// Active cutter compensation as `status` reports it.
    comp: Option<ActiveCutter>,
}

/// A span record inside a G06 block.
#[derive(Clone)]
struct SpanRecord {
    target: AxisVec,
    tangent: Option<[f64; 3]>,
    line: u32,
    col: u32,
    block: u32,
}

/// An open G06 block.
#[derive(Clone)]
struct G06Block {
    start: AxisVec,
    start_tangent: Option<[f64; 3]>,
    spans: Vec<SpanRecord>,
    line: u32,
    col: u32,
    /// The motion mode to return to after the spline data.
    resume: Option<Motion>,
    feed: Feed,
    /// Current support point (for absolute and incremental coordinates).
    point: AxisVec,
    unterminated: bool,
}

#[derive(Clone)]
pub(crate) struct Interpreter {
    pub(super) settings: Settings,
    /// The origin of each work system G54 … G59 per machine axis, read once from the settings
    /// (an axis lookup by name per coordinate would dominate the reading of micro-segments).
    pub(super) work_origins: [AxisVec; WORK_SYSTEM_NAMES.len()],
    /// The rotation of each work system about Z, degrees counter-clockwise (G10 L2 R;
    /// frame.rs).
    pub(super) work_rotations_deg: [f64; WORK_SYSTEM_NAMES.len()],
    pub(super) linear: [bool; MAX_AXES],
    pub(super) modal: Modal,
    /// Cutter radius compensation: contour elements go through it on their way to the path.
    pub(super) cutter: Cutter,
    g06: Option<G06Block>,
    pub(super) pending_dwell_s: f64,
    default_tol_mm: f64,
    /// Smoothing method of G64 without Q (`[prep] method`).
    default_method: interpd_config::PrepMethod,
    pub path: Path,
    pub summary: Summary,
    ended: bool,
    /// A line other than a blank one was read (a `%` is a tape mark only as the first).
    started: bool,
    /// The program began with `%`: the next `%` ends it.
    tape: bool,
    /// Where the tool and offset state changes, when someone reads it (the running program).
    modal_log: Option<ModalLog>,
    /// G93: the F of the block being executed, 1/min (each feed move's inverse time).
    inverse_f: Option<f64>,
    /// A planned pause (M0, M1, M60, operator messages) waiting for the next element, and the
    /// element's source once it has gone into the compensation stage (the pause goes with it
    /// to the path).
    pending_pause: Option<Pause>,
    pause_for: Option<(Source, Pause)>,
    /// The program stop of the block being executed.
    block_pause: Option<StopCode>,
    /// Operator messages read and not yet taken (message.rs); `summary.messages` numbers them.
    messages: MessageQueue,
    /// Messages read since the last element (one place in the motion), and the newest beyond
    /// [`message::PLACE_CAP`] of them, held back with the count of those it stands for.
    messages_here: usize,
    overflow: Option<Message>,
    /// Numbered and named parameters.
    pub(super) params: Params,
    /// O-word control flow.
    pub(super) flow: Flow,
    /// Canned cycle state.
    pub(super) cycle: CycleState,
    /// G5 … G5.3 state (the open NURBS).
    spline: SplineState,
    /// Modal states M70/M73 saved, by call level.
    contexts: Contexts,
    /// The tools G10 L1/L10/L11 wrote (tool_table.rs).
    pub(super) tools: ToolTable,
    /// The block being executed moves in machine coordinates (G53).
    block_g53: bool,
    /// The line being read.
    pub(super) current_line: u32,
}

/// Words of one block, by letter. Reading a word consumes it: a word that nothing in its
/// block consumed is an error, so a typo never vanishes in silence (every letter other than G
/// and M appears at most once per block, so one bit per letter records it).
pub(super) struct Block<'l> {
    pub(super) words: &'l [Word],
    pub(super) line: u32,
    consumed: Cell<u32>,
}

impl<'l> Block<'l> {
    fn new(words: &'l [Word], line: u32) -> Self {
        Self { words, line, consumed: Cell::new(0) }
    }

    /// The word of `letter`, consumed.
    pub(super) fn get(&self, letter: char) -> Option<&'l Word> {
        let w = self.words.iter().find(|w| w.letter == letter);
        if w.is_some() {
            self.consume(letter);
        }
        w
    }

    /// Consumes every axis word (their values were used whole).
    pub(super) fn consume_axes(&self) {
        for w in self.words {
            if AxisLetter::from_char(w.letter).is_some() {
                self.consume(w.letter);
            }
        }
    }

    /// A word of `letter` was used by something in the block already.
    fn is_consumed(&self, letter: char) -> bool {
        self.consumed.get() & letter_bit(letter) != 0
    }

    fn consume(&self, letter: char) {
        self.consumed.set(self.consumed.get() | letter_bit(letter));
    }

    /// The first word (in the line) that nothing consumed.
    fn unconsumed(&self) -> Option<&'l Word> {
        self.words.iter().find(|w| self.consumed.get() & letter_bit(w.letter) == 0)
    }
}

/// One bit per letter A–Z (the lexer upper-cases letters) and the polar words `@` and `^`.
fn letter_bit(letter: char) -> u32 {
    match letter {
        POLAR_RADIUS => 1 << 26,
        POLAR_ANGLE => 1 << 27,
        _ => 1 << ((letter as u32).wrapping_sub('A' as u32) % 26),
    }
}

/// LinuxCNC's polar coordinate words: the radius and the angle (degrees) of the XY target
/// about the program origin.
pub(super) const POLAR_RADIUS: char = '@';
pub(super) const POLAR_ANGLE: char = '^';

/// A word that gives a target: an axis word or a polar one.
pub(super) fn is_target_word(letter: char) -> bool {
    AxisLetter::from_char(letter).is_some() || letter == POLAR_RADIUS || letter == POLAR_ANGLE
}

/// Why a word that no code of its block uses is refused.
fn unused_word_message(letter: char) -> String {
    match letter {
        'P' => "P is only valid with G4, G64 or in G06 spline data".into(),
        // Tool length compensation (G43) would consume H.
        'H' => "H word with no G43 to use it".into(),
        'D' => "D word with no G41/G42 (or G41.1/G42.1) to use it".into(),
        'Q' => "Q word with no G-code that uses it (G64 Q1 / Q2 select the smoothing method; LinuxCNC's \
                 naive-CAM tolerance Q is not supported)"
            .into(),
        _ => format!("{letter} word with no G-code that uses it"),
    }
}

impl Interpreter {
    /// The modal state a program starts with: G17, G21, G90, no feed and no motion mode yet,
    /// the `[prep]` blend, at `pos`.
    pub(super) fn initial_modal(settings: &Settings, pos: AxisVec) -> Modal {
        let blend = match settings.prep.mode {
            interpd_config::PrepMode::Exact => Blend::Exact,
            interpd_config::PrepMode::Smooth => {
                Blend::Tolerance { tol_mm: settings.prep.tolerance_mm, method: settings.prep.method }
            }
        };
        Modal {
            motion: None,
            plane: Plane::Xy,
            unit_mm: 1.0,
            absolute: true,
            feed_mm_s: None,
            inverse_time: false,
            blend,
            pos,
            work_system: 0,
            tool_length: None,
            tool_offset: [0.0; MAX_AXES],
            g92: [0.0; MAX_AXES],
            g92_saved: [0.0; MAX_AXES],
            prepared_tool: None,
            tool: None,
            comp: None,
        }
    }

    pub(super) fn new(settings: &Settings) -> Self {
        let mut linear = [false; MAX_AXES];
        for (k, a) in settings.axes.iter().enumerate() {
            linear[k] = a.kind == AxisKind::Linear;
        }
        Self {
            settings: settings.clone(),
            work_origins: std::array::from_fn(|sys| settings.work_offsets.vector(sys, &settings.axes)),
            work_rotations_deg: std::array::from_fn(|sys| settings.work_offsets.rotation(sys)),
            linear,
            modal: Self::initial_modal(settings, [0.0; MAX_AXES]),
            cutter: Cutter::new(&linear[..settings.axes.len()]),
            g06: None,
            pending_dwell_s: 0.0,
            default_tol_mm: settings.prep.tolerance_mm,
            default_method: settings.prep.method,
            path: Path::new(settings.axis_names(), [0.0; MAX_AXES]),
            summary: Summary::default(),
            ended: false,
            started: false,
            tape: false,
            modal_log: None,
            inverse_f: None,
            pending_pause: None,
            pause_for: None,
            block_pause: None,
            messages: MessageQueue::with_cap(message::QUEUE_CAP),
            messages_here: 0,
            overflow: None,
            params: settings.home_positions.params(),
            flow: Flow::default(),
            cycle: CycleState::default(),
            spline: SplineState::default(),
            contexts: Contexts::default(),
            tools: ToolTable::default(),
            block_g53: false,
            current_line: 0,
        }
    }

    /// An operator message in `comment` (line `line_no`): formatted now, with the parameters as
    /// they are at this block, queued, and attached to the next element as a pause (the motion
    /// before it ends first). False after an error.
    fn message(&mut self, comment: &str, col: u32, line_no: u32, d: &mut Diagnostics) -> bool {
        let Some((kind, raw)) = message::parse(comment) else { return true };
        if kind == MessageKind::Debug && self.params.stored(message::DEBUG_FLAG_PARAM) <= 0.0 {
            return true;
        }
        let text = if kind == MessageKind::Msg {
            let mut t = raw.to_string();
            message::truncate(&mut t);
            t
        } else {
            match message::expand(raw, &self.params) {
                Ok(t) => t,
                Err(m) => {
                    d.error(line_no, col, format!("({}, …): {m}", kind.name().to_uppercase()));
                    return false;
                }
            }
        };
        self.summary.messages += 1;
        let id = self.summary.messages as u64;
        let m = Message { id, kind, text, line: line_no, dropped: 0 };
        self.messages_here += 1;
        if self.messages_here > message::PLACE_CAP {
            let dropped = self.overflow.take().map_or(0, |o| o.dropped + 1);
            self.overflow = Some(Message { dropped, ..m });
        } else {
            self.messages.push(m);
        }
        let p = self.pending_pause.get_or_insert_default();
        if p.stop.is_some() {
            p.messages_after = id;
        } else {
            p.messages_before = id;
        }
        true
    }

    /// The oldest operator message read and not yet taken.
    pub(super) fn take_message(&mut self) -> Option<Message> {
        self.messages.pop()
    }

    /// The place of the messages read so far is closed (an element follows, or the program
    /// ends): the newest of those beyond the cap joins the queue.
    fn close_message_place(&mut self) {
        self.messages_here = 0;
        if let Some(m) = self.overflow.take() {
            self.messages.push(m);
        }
    }

    /// Records where the tool and offset state changes (see [`ModalLog`]). The state the
    /// program starts with applies from line 0: a move to the program's start comes first.
    pub(super) fn track_modal(&mut self) {
        let mut log = ModalLog::default();
        log.record(0, self.active());
        log.element();
        self.modal_log = Some(log);
    }

    /// The next change of the tool and offset state followed by an element.
    pub(super) fn take_modal_change(&mut self) -> Option<(u32, ActiveModal)> {
        self.modal_log.as_mut()?.take()
    }

    /// The tool and offset state now.
    pub(super) fn active(&self) -> ActiveModal {
        let m = &self.modal;
        ActiveModal {
            work_system: m.work_system,
            work_offset: self.work_origins[m.work_system],
            g92_offset: m.g92,
            tool: m.tool.map(|number| {
                let t = self.program_tool(number);
                let length_mm = t.map(|t| self.settings.axis_index(AxisLetter::Z).map_or(0.0, |z| t.offset[z]));
                ActiveTool { number, length_mm, radius_mm: t.map(|t| t.diameter_mm / 2.0) }
            }),
            tool_length: m.tool_length,
            cutter: if self.cutter.is_on() { m.comp } else { None },
        }
    }

    /// An interpreter that continues from `modal` (its position is where the path starts).
    pub(super) fn resume(settings: &Settings, modal: Modal) -> Self {
        let mut interp = Self::new(settings);
        interp.path = Path::new(settings.axis_names(), modal.pos);
        interp.modal = modal;
        interp
    }

    /// The modal state after the lines fed so far.
    pub(super) fn modal(&self) -> &Modal {
        &self.modal
    }

    /// Whether the program has ended (M2, M30, a closing `%`): later lines are not read.
    pub(super) fn ended(&self) -> bool {
        self.ended
    }

    /// Whether a G06 block is open (its spans wait for the block's end).
    pub(super) fn in_g06(&self) -> bool {
        self.g06.is_some()
    }

    /// Feeds one source line (1-based number).
    pub(super) fn line(&mut self, text: &str, line_no: u32, d: &mut Diagnostics) {
        let _ = self.line_at(text, line_no, None, d);
    }

    /// Feeds one source line at `at` (its place in the program text, so that control flow can
    /// go back to it); returns where reading goes on if not at the next line.
    pub(super) fn line_at(
        &mut self,
        text: &str,
        line_no: u32,
        at: Option<&LineAt>,
        d: &mut Diagnostics,
    ) -> Option<LinePos> {
        self.current_line = line_no;
        if self.ended {
            return None;
        }
        self.summary.lines = self.summary.lines.max(line_no);
        if self.flow.skipping() {
            return self.skipped_line(text, at, d);
        }
        self.line_text(text, line_no, at, d)
    }

    fn line_text(&mut self, text: &str, line_no: u32, at: Option<&LineAt>, d: &mut Diagnostics) -> Option<LinePos> {
        if self.g06.is_some() && text.trim().eq_ignore_ascii_case(G06_END_MARKER) {
            self.finish_g06(d);
            return None;
        }
        if text.contains('#') {
            self.refresh_snapshot(line_no);
        }
        let lexed = match lex_block(text, &self.params) {
            Ok(l) => l,
            Err(e) => {
                d.error(line_no, e.col, e.message);
                if let Some(b) = &mut self.g06 {
                    b.unterminated = false; // a broken line inside spline data: do not pile on
                }
                return None;
            }
        };
        // Assignments take effect after the whole line is read, before the block executes.
        for a in &lexed.assigns {
            if let Err(m) = self.params.set(&a.param, a.value) {
                d.error(line_no, a.col, m);
                return None;
            }
        }
        if let Some(o) = &lexed.oword {
            if self.g06.is_some() {
                self.finish_g06(d);
            }
            return self.o_word(text, o, at, d);
        }
        let line = lexed.line;
        if let Some(m) = line.words.iter().find(|w| w.letter == 'M' && (w.value == 98.0 || w.value == 99.0)) {
            if self.g06.is_some() {
                self.finish_g06(d);
            }
            self.summary.blocks += 1;
            return self.fanuc_word(&line, m, at, d);
        }
        if line.percent {
            if self.g06.is_some() {
                self.finish_g06(d);
            }
            if !self.started {
                self.tape = true;
            } else if self.tape {
                self.ended = true;
                self.summary.program_end = true;
            } else {
                d.error(line_no, 1, "'%' is only valid as the first line of a program (and then as its last)");
            }
            self.started = true;
            return None;
        }
        self.started |= !line.blank;
        if self.g06.is_some() {
            if line.blank {
                self.finish_g06(d);
                return None;
            }
            if line.words.is_empty() {
                return None; // comment-only line inside spline data
            }
            if is_span_line(&line) {
                self.g06_span(&line, line_no, d);
                return None;
            }
            self.finish_g06(d);
        }
        // The comment first, as LinuxCNC's `execute_block`: a message comes before the block's
        // motion, after the motion before it.
        if let Some((a, b)) = line.comment {
            if !self.message(&text[a..b], super::lexer::col_of(text, a), line_no, d) {
                return None;
            }
        }
        if line.words.is_empty() {
            return None;
        }
        self.summary.blocks += 1;
        self.block(&line, line_no, d);
        if self.modal_log.is_some() {
            let active = self.active();
            if let Some(log) = &mut self.modal_log {
                log.record(line_no, active);
            }
        }
        None
    }

    /// M98 P<n> L<k> and M99 (Fanuc subprograms, as LinuxCNC 2.9): each in a block of its own.
    fn fanuc_word(&mut self, line: &Line, m: &Word, at: Option<&LineAt>, d: &mut Diagnostics) -> Option<LinePos> {
        let line_no = self.current_line;
        let m98 = m.value == 98.0;
        let allowed = |c: char| c == 'N' || (m98 && (c == 'P' || c == 'L'));
        if let Some(w) = line.words.iter().find(|w| !std::ptr::eq(*w, m) && !allowed(w.letter)) {
            let what = if m98 {
                "M98 stands in a block of its own (with P and L)"
            } else {
                "M99 stands in a block of its own"
            };
            d.error(line_no, w.col, what);
            return None;
        }
        if !m98 {
            return self.fanuc_return(m.col, at, d);
        }
        let Some(p) = line.words.iter().find(|w| w.letter == 'P') else {
            d.error(line_no, m.col, "M98 needs P (the number of the subprogram O<n>)");
            return None;
        };
        if p.value < 0.0 || p.value.fract() != 0.0 {
            d.error(line_no, p.col, format!("M98: P must be a subprogram number, got {}", p.value));
            return None;
        }
        let repeats = match line.words.iter().find(|w| w.letter == 'L') {
            None => 1,
            Some(l) if l.value >= 0.0 && l.value.fract() == 0.0 && l.value <= 1e9 => l.value as u64,
            Some(l) => {
                d.error(line_no, l.col, format!("M98: L (repeats) must be a non-negative integer, got {}", l.value));
                return None;
            }
        };
        self.fanuc_call(p.value, repeats, m.col, at, d)
    }

    /// The interpreter's state as the predefined parameters report it (line `line_no`).
    fn refresh_snapshot(&mut self, line_no: u32) {
        let m = &self.modal;
        let mut snap = Snapshot::default();
        for (slot, letter) in AxisLetter::ALL.iter().enumerate().take(9) {
            let Some(k) = self.settings.axis_index(*letter) else { continue };
            let unit = if self.linear[k] { m.unit_mm } else { 1.0 };
            snap.pos[slot] = self.program_coord(k) / unit;
            snap.abs[slot] = m.pos[k] / unit;
            snap.g92[slot] = m.g92[k] / unit;
        }
        snap.g92_on = m.g92.iter().any(|v| *v != 0.0);
        snap.coord_index = m.work_system + 1;
        snap.coord_code = [540.0, 550.0, 560.0, 570.0, 580.0, 590.0, 591.0, 592.0, 593.0][m.work_system.min(8)];
        snap.metric = m.unit_mm == 1.0;
        snap.absolute = m.absolute;
        snap.inverse_time = m.inverse_time;
        snap.tool = m.tool.map_or(0.0, f64::from);
        snap.selected_tool = m.prepared_tool.map_or(-1.0, f64::from);
        snap.tool_offset_on = m.tool_length.is_some();
        if let Some(tool) = m.tool.and_then(|n| self.program_tool(n)) {
            for (slot, letter) in AxisLetter::ALL.iter().enumerate().take(9) {
                let Some(k) = self.settings.axis_index(*letter) else { continue };
                let unit = if self.linear[k] { m.unit_mm } else { 1.0 };
                snap.loaded_tool_offset[slot] = tool.offset[k] / unit;
            }
        }
        snap.feed = m.feed_mm_s.map_or(0.0, |f| f * 60.0 / m.unit_mm);
        snap.motion_code = match m.motion {
            None | Some(Motion::Rapid) => 0.0,
            Some(Motion::Linear) => 10.0,
            Some(Motion::ArcCw) => 20.0,
            Some(Motion::ArcCcw) => 30.0,
            Some(Motion::Cycle(k)) => match k {
                CycleKind::G73 => 730.0,
                CycleKind::G81 => 810.0,
                CycleKind::G82 => 820.0,
                CycleKind::G83 => 830.0,
                CycleKind::G85 => 850.0,
                CycleKind::G89 => 890.0,
            },
            Some(Motion::Spline(k)) => k.motion_code(),
        };
        snap.plane_code = match m.plane {
            Plane::Xy => 170.0,
            Plane::Zx => 180.0,
            Plane::Yz => 190.0,
        };
        snap.ccomp_code = match m.comp.map(|c| c.side) {
            None => 400.0,
            Some(CompSide::Left) => 410.0,
            Some(CompSide::Right) => 420.0,
        };
        snap.retract_r = self.cycle.retract_r;
        for (sys, origin) in self.work_origins.iter().enumerate() {
            snap.rotation_deg[sys] = self.work_rotations_deg[sys];
            for (slot, letter) in AxisLetter::ALL.iter().enumerate().take(9) {
                if let Some(k) = self.settings.axis_index(*letter) {
                    snap.work[sys][slot] = origin[k];
                }
            }
        }
        snap.line = f64::from(line_no);
        snap.call_level = self.flow.depth() as f64;
        self.params.snap = snap;
    }

    /// Ends the program text: refuses one that stops inside G06 spline data (cut short, most
    /// likely) and attaches a trailing dwell.
    pub(super) fn finish(&mut self, d: &mut Diagnostics) {
        self.finish_flow(d);
        // A file that stops inside spline data was most likely cut short: its last span may
        // be missing or truncated, so nothing of it runs.
        if let Some((line, col)) = self.open_g06_with_spans() {
            d.error(line, col, ends_inside_g06_message());
            self.g06 = None;
        }
        // A G06 line with no spans is reported as such; a span already reported, not again.
        self.finish_g06(d);
        if let Err(e) = self.cutter.finish() {
            d.error(e.line, e.col, e.kind.to_string());
        }
        self.drain(d);
        self.close_message_place();
        self.path.final_dwell_s += self.pending_dwell_s;
        self.pending_dwell_s = 0.0;
    }

    /// Executes one block; then every word must have been consumed by it.
    fn block(&mut self, line: &Line, line_no: u32, d: &mut Diagnostics) {
        let block = Block::new(&line.words, line_no);
        let errors_before = d.found();
        self.block_pause = None;
        self.execute(&block, line, d);
        if let Some(code) = self.block_pause.take() {
            let p = self.pending_pause.get_or_insert_default();
            // A second stop before any motion replaces the first (one stop per place); the
            // messages after the first come before it.
            p.messages_before = p.messages_before.max(p.messages_after);
            p.messages_after = 0;
            p.stop = Some(code);
            p.stop_line = line_no;
        }
        if d.found() == errors_before {
            if let Some(w) = block.unconsumed() {
                d.error(line_no, w.col, unused_word_message(w.letter));
            }
        }
    }

    fn execute(&mut self, block: &Block, line: &Line, d: &mut Diagnostics) {
        let line_no = block.line;
        // Each letter at most once, except G and M (one per modal group, checked below).
        for (i, w) in line.words.iter().enumerate() {
            if w.letter != 'G' && w.letter != 'M' && line.words[..i].iter().any(|o| o.letter == w.letter) {
                d.error(line_no, w.col, format!("word {} appears twice in this block", w.letter));
                return;
            }
        }
        let block_no = block.get('N').map_or(0, |w| w.value as u32);
        if let Some(n) = block.get('N') {
            // A fractional part is accepted and ignored, as LinuxCNC 2.9 (`read_n_number`).
            if n.value < 0.0 || !n.value.is_finite() {
                d.error(line_no, n.col, "block number N must be a non-negative number");
                return;
            }
            if n.col != line.words[0].col {
                d.error(line_no, n.col, "block number N must be the first word of the block");
                return;
            }
        }

        let Some(g) = self.read_g_words(block, d) else { return };
        self.summary.ignored_words += usize::from(g.spindle_mode);
        if !self.read_m_words(block, d) {
            return;
        }
        if !self.read_spindle_and_tool(block, d) {
            return;
        }

        // Modal settings first, as a controller executes them before motion in the same block.
        // RS274NGC sets the feed before the units: an F in a G20/G21 block is read in the
        // units in force before the block (LinuxCNC reads `G21` … `G20 F10` as 10 mm/min).
        let feed_unit_mm = self.modal.unit_mm;
        if let Some(u) = g.units {
            self.modal.unit_mm = u;
        }
        if let Some(a) = g.absolute {
            self.modal.absolute = a;
        }
        if let Some(p) = g.plane {
            if p != self.modal.plane && self.cutter.is_on() {
                d.error(
                    line_no,
                    g.plane_col,
                    format!("cannot change the plane to {} with cutter compensation on: program G40 first", p.name()),
                );
                return;
            }
            self.modal.plane = p;
        }
        if let Some(inverse) = g.inverse_time {
            // As LinuxCNC: a change of the feed mode (even to the mode in force) forgets the
            // feed, so a feed move needs F again.
            self.modal.inverse_time = inverse;
            self.modal.feed_mm_s = None;
        }
        self.inverse_f = None;
        if let Some(f) = block.get('F') {
            if f.value <= 0.0 {
                d.error(line_no, f.col, format!("feed F must be positive, got {}", f.value));
                return;
            }
            if self.modal.inverse_time {
                self.inverse_f = Some(f.value);
            } else {
                self.modal.feed_mm_s = Some(f.value * feed_unit_mm / 60.0);
            }
        }
        if let Some(b) = g.blend {
            match b {
                BlendWord::Exact => self.modal.blend = Blend::Exact,
                BlendWord::Smooth => {
                    let tol = match block.get('P') {
                        Some(p) if p.value <= 0.0 => {
                            d.error(line_no, p.col, format!("G64 tolerance P must be positive, got {}", p.value));
                            return;
                        }
                        Some(p) => p.value * self.modal.unit_mm,
                        None => self.default_tol_mm,
                    };
                    // Q selects the method for this program (an interpd word: LinuxCNC's G64 Q,
                    // the naive-CAM tolerance, is not supported).
                    let method = match block.get('Q') {
                        None => self.default_method,
                        Some(q) if q.value == 1.0 => interpd_config::PrepMethod::Hermite,
                        Some(q) if q.value == 2.0 => interpd_config::PrepMethod::Bspline,
                        Some(q) => {
                            d.error(
                                line_no,
                                q.col,
                                format!(
                                    "G64 Q selects the smoothing method, Q1 Hermite or Q2 B-spline, got Q{} \
                                     (LinuxCNC's naive-CAM tolerance Q is not supported)",
                                    q.value
                                ),
                            );
                            return;
                        }
                    };
                    self.modal.blend = Blend::Tolerance { tol_mm: tol, method };
                }
            }
        }
        if g.dwell {
            match block.get('P') {
                None => {
                    d.error(line_no, line.end_col, "G4 dwell needs P (seconds)");
                    return;
                }
                Some(p) if p.value < 0.0 => {
                    d.error(line_no, p.col, format!("dwell time P must not be negative, got {}", p.value));
                    return;
                }
                Some(p) => self.pending_dwell_s += p.value,
            }
        }
        if !self.tool_and_offsets(&g, block, d) {
            return;
        }
        self.block_g53 = false;
        if let Some((word, col)) = g.offset_word {
            if word == OffsetWord::Machine {
                if !self.machine_coordinates_ok(col, &g.motion, block, d) {
                    return;
                }
                self.block_g53 = true;
            } else {
                let source = Source { line: line_no, block: block_no };
                self.offset_word(word, col, g.motion.is_some(), block, line, source, d);
                return;
            }
        }
        if matches!(g.tool_length, Some((ToolLengthWord::Dynamic, _))) {
            return; // its Z word is the tool length
        }
        if let Some((word, col)) = g.axis_offset {
            if !self.axis_offsets(word, col, &g, block, line, d) || word == AxisOffsetWord::Set {
                return; // G92's axis words are the coordinates, not a move
            }
        }
        if g.spline {
            if self.modal.inverse_time {
                d.error(line_no, block.words[0].col, "G06 in inverse time (G93): program G94 first");
                return;
            }
            self.start_g06(block, block_no, d);
            return;
        }
        let previous_motion = self.modal.motion;
        if let Some(r) = g.retract_r {
            self.cycle.retract_r = r;
        }
        if g.cancel_cycle {
            self.modal.motion = None;
            self.cycle.il = None;
        }
        if let Some(m) = g.motion {
            self.modal.motion = Some(m);
        }
        if let Some(col) = g.nurbs_end {
            let source = Source { line: line_no, block: block_no };
            self.nurbs_end(col, block, source, d);
            return;
        }
        if let Some(Motion::Spline(kind)) = self.modal.motion {
            // As LinuxCNC: a block in the mode runs it when it names the code or has axis words.
            if g.motion.is_some() || line.words.iter().any(|w| is_target_word(w.letter)) {
                let source = Source { line: line_no, block: block_no };
                self.spline_block(kind, previous_motion != Some(Motion::Spline(kind)), block, source, d);
            }
            if kind != SplineKind::Nurbs {
                // LinuxCNC 2.9's `convert_spline` leaves the motion mode as it was: G5 and G5.1
                // act in their own block only.
                self.modal.motion = previous_motion;
            }
            return;
        }

        let has_axis = line.words.iter().any(|w| is_target_word(w.letter));
        if let Some(Motion::Cycle(kind)) = self.modal.motion {
            if has_axis {
                let source = Source { line: line_no, block: block_no };
                self.canned_cycle(kind, previous_motion == Some(Motion::Cycle(kind)), block, source, d);
            } else if let Some(w) = g.motion.and(block.words.iter().find(|w| w.letter == 'G')) {
                d.error(line_no, w.col, "a canned cycle needs the axis words of the hole (at least its Z)");
            }
            return;
        }
        if has_axis {
            self.cycle.il = None;
        }
        // (An R that M19 took as its orientation angle is not an arc word.)
        let arc_words: Vec<&Word> = line
            .words
            .iter()
            .filter(|w| matches!(w.letter, 'I' | 'J' | 'K' | 'R') && !block.is_consumed(w.letter))
            .collect();
        // As LinuxCNC: an arc in the centre form without axis words is a full circle back to
        // where it starts.
        let full_circle = matches!(self.modal.motion, Some(Motion::ArcCw | Motion::ArcCcw))
            && !arc_words.is_empty()
            && arc_words.iter().all(|w| w.letter != 'R');
        if !has_axis && !full_circle {
            if let Some(w) = arc_words.first() {
                d.error(line_no, w.col, format!("{} without an arc end point", w.letter));
            } else if g.motion.is_some() && g.motion != Some(Motion::Rapid) && g.motion != Some(Motion::Linear) {
                d.error(line_no, line.end_col, "arc needs an end point");
            }
            return;
        }
        let Some(motion) = self.modal.motion else {
            let w = line.words.iter().find(|w| is_target_word(w.letter)).expect("has axis");
            d.error(line_no, w.col, "axis word without a motion mode: program G0, G1, G2 or G3 first");
            return;
        };
        let Some(target) = self.target(block, d) else { return };
        let source = Source { line: line_no, block: block_no };
        if self.modal.inverse_time && motion != Motion::Rapid && self.inverse_f.is_none() {
            d.error(
                line_no,
                block.words[0].col,
                "inverse time (G93): a feed move needs F (1/minutes) in its own block, as in LinuxCNC",
            );
            return;
        }
        if self.inverse_f.is_some() {
            // Any value passes here: the move's feed is its length times F (below).
            self.modal.feed_mm_s.get_or_insert(1.0);
        }
        match motion {
            Motion::Rapid | Motion::Linear => {
                if let Some(w) = arc_words.first() {
                    d.error(line_no, w.col, format!("{} is only valid with G2/G3", w.letter));
                    return;
                }
                let feed = if motion == Motion::Rapid {
                    Feed::Rapid
                } else {
                    match self.modal.feed_mm_s {
                        Some(f) => Feed::Programmed { mm_per_s: f },
                        None => {
                            d.error(
                                line_no,
                                block.words[0].col,
                                "G1 without feed: program F (mm/min) before or in this block",
                            );
                            return;
                        }
                    }
                };
                self.linear_move(target, feed, source, block.words[0].col, d);
            }
            Motion::ArcCw | Motion::ArcCcw => {
                let Some(f) = self.modal.feed_mm_s else {
                    d.error(
                        line_no,
                        block.words[0].col,
                        "arc without feed: program F (mm/min) before or in this block",
                    );
                    return;
                };
                self.arc_move(block, target, motion == Motion::ArcCcw, Feed::Programmed { mm_per_s: f }, source, d);
            }
            Motion::Cycle(_) | Motion::Spline(_) => unreachable!("cycles and splines are executed above"),
        }
    }

    /// G54–G59, G43/G43.1/G49 and G40/G41/G42 (in the order RS274NGC executes them: cutter
    /// compensation, tool length, coordinate system). False after an error.
    fn tool_and_offsets(&mut self, g: &GWords, block: &Block, d: &mut Diagnostics) -> bool {
        let line = block.line;
        if let Some((word, col)) = g.comp {
            match word {
                CompWord::Off => {
                    if let Err(e) = self.cutter.stop() {
                        d.error(e.line, e.col, e.kind.to_string());
                        return false;
                    }
                    self.modal.comp = None;
                }
                CompWord::Table(side) | CompWord::Diameter(side) => {
                    let name = match word {
                        CompWord::Table(Side::Left) => "G41",
                        CompWord::Table(Side::Right) => "G42",
                        CompWord::Diameter(Side::Left) => "G41.1",
                        _ => "G42.1",
                    };
                    if self.cutter.is_on() {
                        d.error(
                            line,
                            col,
                            format!("{name} while cutter compensation is already on: program G40 first"),
                        );
                        return false;
                    }
                    let dw = block.get('D');
                    let mut tool = None;
                    let radius_mm = if let CompWord::Table(_) = word {
                        // Without D, the tool in the spindle (T… M6), as LinuxCNC.
                        let Some((number, col)) = self.tool_word(dw, 'D', line, col, d) else { return false };
                        match number {
                            Some(number) => {
                                let Some(entry) = self.program_tool(number) else {
                                    d.error(line, col, format!("tool {number} is not in the tool table"));
                                    return false;
                                };
                                self.summary.tools.insert(number);
                                tool = Some(number);
                                entry.diameter_mm / 2.0
                            }
                            None => 0.0,
                        }
                    } else {
                        let Some(dw) = dw else {
                            d.error(line, col, format!("{name} needs D (the tool diameter)"));
                            return false;
                        };
                        if !dw.value.is_finite() {
                            d.error(line, dw.col, format!("tool diameter D is not a finite number, got {}", dw.value));
                            return false;
                        }
                        dw.value * self.modal.unit_mm / 2.0
                    };
                    // As LinuxCNC: a negative diameter compensates on the other side.
                    let (side, radius_mm) = if radius_mm < 0.0 {
                        (if side == Side::Left { Side::Right } else { Side::Left }, -radius_mm)
                    } else {
                        (side, radius_mm)
                    };
                    let ((pl, _), (ql, _)) = self.modal.plane.axes();
                    let (Some(p), Some(q)) = (self.settings.axis_index(pl), self.settings.axis_index(ql)) else {
                        d.error(
                            line,
                            col,
                            format!(
                                "cutter compensation in {} needs axes {pl} and {ql} on this machine",
                                self.modal.plane.name()
                            ),
                        );
                        return false;
                    };
                    if self.modal.plane != Plane::Xy && self.xy_rotation().is_some() {
                        d.error(
                            line,
                            col,
                            format!(
                                "{name} in {} in a rotated coordinate system (G10 L2 R) is not supported: the rotation about Z tilts the plane",
                                self.modal.plane.name()
                            ),
                        );
                        return false;
                    }
                    self.summary.compensation = true;
                    self.cutter.start(side, radius_mm, p, q);
                    let side = match side {
                        Side::Left => CompSide::Left,
                        Side::Right => CompSide::Right,
                    };
                    self.modal.comp = Some(ActiveCutter { side, radius_mm, tool });
                }
            }
        }
        if let Some((word, col)) = g.tool_length {
            let Some(z) = self.settings.axis_index(AxisLetter::Z) else {
                d.error(line, col, "tool length compensation needs a Z axis on this machine");
                return false;
            };
            let length = match word {
                ToolLengthWord::Cancel => {
                    self.modal.tool_offset = [0.0; MAX_AXES];
                    None
                }
                ToolLengthWord::Table => {
                    // Without H, the tool in the spindle (T… M6), as LinuxCNC.
                    let Some((number, hcol)) = self.tool_word(block.get('H'), 'H', line, col, d) else { return false };
                    match number {
                        Some(number) => {
                            let Some(tool) = self.program_tool(number) else {
                                d.error(line, hcol, format!("tool {number} is not in the tool table"));
                                return false;
                            };
                            self.summary.tools.insert(number);
                            // Every offset of the tool, as LinuxCNC 2.9 (tool_table.rs).
                            self.modal.tool_offset = tool.offset;
                            Some((Some(number), tool.offset[z]))
                        }
                        None => {
                            self.modal.tool_offset = [0.0; MAX_AXES];
                            Some((Some(0), 0.0))
                        }
                    }
                }
                ToolLengthWord::Dynamic => {
                    // G43.1 Z<length>: the Z word is the length, not a move (as LinuxCNC).
                    if let Some(w) =
                        block.words.iter().find(|w| AxisLetter::from_char(w.letter).is_some() && w.letter != 'Z')
                    {
                        d.error(line, w.col, format!("G43.1 takes the tool length in Z only, not {}", w.letter));
                        return false;
                    }
                    let Some(zw) = block.get('Z') else {
                        d.error(line, col, "G43.1 needs Z (the tool length)");
                        return false;
                    };
                    // The offsets of the other axes stay, as LinuxCNC's G43.1 keeps them.
                    self.modal.tool_offset[z] = zw.value * self.modal.unit_mm;
                    Some((None, self.modal.tool_offset[z]))
                }
            };
            self.modal.tool_length = length;
        }
        if let Some(sys) = g.work {
            if self.cutter.is_on() {
                d.error(
                    line,
                    block.words[0].col,
                    "cannot change the coordinate system with cutter compensation on: program G40 first",
                );
                return false;
            }
            self.modal.work_system = sys;
            self.summary.work_offsets.insert(WORK_SYSTEM_NAMES[sys]);
        }
        true
    }

    /// The tool a D or H word names (with the word's column), or without the word the tool in
    /// the spindle (with the G-code's column `col`), as LinuxCNC. `None` for no tool: none in
    /// the spindle, or tool 0 when the table has none (LinuxCNC's empty spindle: radius and
    /// length 0). `None` overall after an error.
    fn tool_word(
        &self,
        w: Option<&Word>,
        letter: char,
        line: u32,
        col: u32,
        d: &mut Diagnostics,
    ) -> Option<(Option<u32>, u32)> {
        let Some(w) = w else {
            let number = self.modal.tool.filter(|&n| n != 0 || self.program_tool(0).is_some());
            return Some((number, col));
        };
        if w.value < 0.0 || w.value.fract() != 0.0 || w.has_point {
            d.error(line, w.col, format!("{letter} must be a tool number (a non-negative integer), got {}", w.value));
            return None;
        }
        Some((Some(w.value as u32), w.col))
    }

    /// G92, G92.1, G92.2, G92.3 (after the coordinate system, as RS274NGC orders them). G92
    /// makes the current point have the coordinates of its axis words (whatever G90/G91) by an
    /// offset added to every work offset. False after an error.
    fn axis_offsets(
        &mut self,
        word: AxisOffsetWord,
        col: u32,
        g: &GWords,
        block: &Block,
        line: &Line,
        d: &mut Diagnostics,
    ) -> bool {
        let line_no = block.line;
        if self.cutter.is_on() {
            d.error(
                line_no,
                col,
                "cannot change the axis offsets (G92) with cutter compensation on: program G40 first",
            );
            return false;
        }
        match word {
            AxisOffsetWord::Clear => {
                self.modal.g92 = [0.0; MAX_AXES];
                self.modal.g92_saved = [0.0; MAX_AXES];
            }
            AxisOffsetWord::Suspend => self.modal.g92 = [0.0; MAX_AXES],
            AxisOffsetWord::Restore => self.modal.g92 = self.modal.g92_saved,
            AxisOffsetWord::Set => {
                if g.motion.is_some() || g.spline {
                    d.error(line_no, col, "G92 and a motion G-code in one block: both would use the axis words");
                    return false;
                }
                let axis_words: Vec<&Word> =
                    line.words.iter().filter(|w| AxisLetter::from_char(w.letter).is_some()).collect();
                if axis_words.is_empty() {
                    d.error(line_no, col, "G92 needs at least one axis word (the coordinates of the current point)");
                    return false;
                }
                let mut g92 = self.modal.g92;
                for w in axis_words {
                    block.consume(w.letter);
                    let letter = AxisLetter::from_char(w.letter).expect("axis letter");
                    let Some(k) = self.settings.axis_index(letter) else {
                        d.error(
                            line_no,
                            w.col,
                            format!(
                                "axis {letter} is not on this machine (axes: {})",
                                self.settings.axis_names().join(" ")
                            ),
                        );
                        return false;
                    };
                    let scale = if self.linear[k] { self.modal.unit_mm } else { 1.0 };
                    let v = w.value * scale;
                    if !v.is_finite() {
                        d.error(line_no, w.col, format!("{letter} is not a finite number"));
                        return false;
                    }
                    // pos = program coordinate + work offset + tool length + G92 offset (X and
                    // Y in a rotated system: the G92 offset applies before the rotation).
                    let with_g92 = if self.xy_rotation().is_some() {
                        self.program_coord(k) + self.modal.g92[k]
                    } else {
                        self.modal.pos[k] - (self.program_offset(k) - self.modal.g92[k])
                    };
                    g92[k] = with_g92 - v;
                }
                self.modal.g92 = g92;
                self.modal.g92_saved = g92;
            }
        }
        true
    }

    /// The offset from program to machine coordinates on axis `k`: the work offset, the tool
    /// offset (G43; on Z the tool length), and the G92 offset.
    pub(super) fn program_offset(&self, k: usize) -> f64 {
        self.work_origins[self.modal.work_system][k] + self.modal.tool_offset[k] + self.modal.g92[k]
    }

    /// The axes a canned cycle works on in the active plane: the plane's two and the normal.
    pub(super) fn cycle_letters(&self) -> [AxisLetter; 3] {
        match self.modal.plane {
            Plane::Xy => [AxisLetter::X, AxisLetter::Y, AxisLetter::Z],
            Plane::Zx => [AxisLetter::Z, AxisLetter::X, AxisLetter::Y],
            Plane::Yz => [AxisLetter::Y, AxisLetter::Z, AxisLetter::X],
        }
    }

    pub(super) fn plane_name(&self) -> &'static str {
        self.modal.plane.name()
    }

    fn read_g_words(&self, block: &Block, d: &mut Diagnostics) -> Option<GWords> {
        let mut g = GWords::default();
        let mut groups: [Option<u32>; 12] = [None; 12];
        for w in block.words.iter().filter(|w| w.letter == 'G') {
            let code = (w.value * 10.0).round() as i64;
            if (w.value * 10.0 - code as f64).abs() > 1e-6 || code < 0 {
                d.error(block.line, w.col, format!("unsupported G-code G{}", w.value));
                return None;
            }
            let (group, label) = match code {
                0 => (0, {
                    g.motion = Some(Motion::Rapid);
                    "G0"
                }),
                10 => (0, {
                    g.motion = Some(Motion::Linear);
                    "G1"
                }),
                20 => (0, {
                    g.motion = Some(Motion::ArcCw);
                    "G2"
                }),
                30 => (0, {
                    g.motion = Some(Motion::ArcCcw);
                    "G3"
                }),
                60 => (0, {
                    g.spline = true;
                    "G06"
                }),
                50 => (0, {
                    g.motion = Some(Motion::Spline(SplineKind::Cubic));
                    "G5"
                }),
                51 => (0, {
                    g.motion = Some(Motion::Spline(SplineKind::Quadratic));
                    "G5.1"
                }),
                52 => (0, {
                    g.motion = Some(Motion::Spline(SplineKind::Nurbs));
                    "G5.2"
                }),
                53 => (1, {
                    g.nurbs_end = Some(w.col);
                    "G5.3"
                }),
                40 => (1, {
                    g.dwell = true;
                    "G4"
                }),
                920 => (1, {
                    g.axis_offset = Some((AxisOffsetWord::Set, w.col));
                    "G92"
                }),
                921 => (1, {
                    g.axis_offset = Some((AxisOffsetWord::Clear, w.col));
                    "G92.1"
                }),
                922 => (1, {
                    g.axis_offset = Some((AxisOffsetWord::Suspend, w.col));
                    "G92.2"
                }),
                923 => (1, {
                    g.axis_offset = Some((AxisOffsetWord::Restore, w.col));
                    "G92.3"
                }),
                170 => (2, {
                    g.plane_col = w.col;
                    g.plane = Some(Plane::Xy);
                    "G17"
                }),
                180 => (2, {
                    g.plane_col = w.col;
                    g.plane = Some(Plane::Zx);
                    "G18"
                }),
                190 => (2, {
                    g.plane_col = w.col;
                    g.plane = Some(Plane::Yz);
                    "G19"
                }),
                200 => (3, {
                    g.units = Some(MM_PER_INCH);
                    "G20"
                }),
                210 => (3, {
                    g.units = Some(1.0);
                    "G21"
                }),
                900 => (4, {
                    g.absolute = Some(true);
                    "G90"
                }),
                910 => (4, {
                    g.absolute = Some(false);
                    "G91"
                }),
                610 => (5, {
                    g.blend = Some(BlendWord::Exact);
                    "G61"
                }),
                // LinuxCNC's exact stop: interpd's G61 already stops exactly at every corner.
                611 => (5, {
                    g.blend = Some(BlendWord::Exact);
                    "G61.1"
                }),
                640 => (5, {
                    g.blend = Some(BlendWord::Smooth);
                    "G64"
                }),
                400 => (6, {
                    g.comp = Some((CompWord::Off, w.col));
                    "G40"
                }),
                410 => (6, {
                    g.comp = Some((CompWord::Table(Side::Left), w.col));
                    "G41"
                }),
                411 => (6, {
                    g.comp = Some((CompWord::Diameter(Side::Left), w.col));
                    "G41.1"
                }),
                420 => (6, {
                    g.comp = Some((CompWord::Table(Side::Right), w.col));
                    "G42"
                }),
                421 => (6, {
                    g.comp = Some((CompWord::Diameter(Side::Right), w.col));
                    "G42.1"
                }),
                430 => (7, {
                    g.tool_length = Some((ToolLengthWord::Table, w.col));
                    "G43"
                }),
                431 => (7, {
                    g.tool_length = Some((ToolLengthWord::Dynamic, w.col));
                    "G43.1"
                }),
                490 => (7, {
                    g.tool_length = Some((ToolLengthWord::Cancel, w.col));
                    "G49"
                }),
                800 => (0, {
                    g.cancel_cycle = true;
                    "G80"
                }),
                730 | 810 | 820 | 830 | 850 | 890 => (0, {
                    let (kind, label) = match code {
                        730 => (CycleKind::G73, "G73"),
                        810 => (CycleKind::G81, "G81"),
                        820 => (CycleKind::G82, "G82"),
                        830 => (CycleKind::G83, "G83"),
                        850 => (CycleKind::G85, "G85"),
                        _ => (CycleKind::G89, "G89"),
                    };
                    g.motion = Some(Motion::Cycle(kind));
                    label
                }),
                740 | 760 | 840 | 860 | 870 | 880 | 330 | 331 | 841 | 842 => {
                    d.error(
                        block.line,
                        w.col,
                        format!(
                            "G{} needs a spindle (tapping, boring with spindle stop or orientation, threading); \
                             interpd interpolates motion only",
                            fmt_code(w.value)
                        ),
                    );
                    return None;
                }
                980 | 990 => (11, {
                    g.retract_r = Some(code == 990);
                    if code == 990 { "G99" } else { "G98" }
                }),
                930 => (9, {
                    g.inverse_time = Some(true);
                    "G93"
                }),
                940 => (9, {
                    g.inverse_time = Some(false);
                    "G94"
                }),
                950 => {
                    d.error(
                        block.line,
                        w.col,
                        "G95 (feed per spindle revolution) needs a spindle; interpd interpolates motion only",
                    );
                    return None;
                }
                960 | 970 => (10, {
                    // Constant surface speed: a spindle matter, ignored like S (G96's D is
                    // its speed limit).
                    if code == 960 {
                        block.consume('D');
                    }
                    g.spindle_mode = true;
                    if code == 960 { "G96" } else { "G97" }
                }),
                540 | 550 | 560 | 570 | 580 | 590 => (8, {
                    g.work = Some((code as usize - 540) / 10);
                    WORK_SYSTEM_NAMES[(code as usize - 540) / 10]
                }),
                591..=593 => (8, {
                    g.work = Some(code as usize - 591 + 6);
                    WORK_SYSTEM_NAMES[code as usize - 591 + 6]
                }),
                100 | 280 | 281 | 300 | 301 | 520 | 530 => (1, {
                    let (word, label) = match code {
                        100 => (OffsetWord::G10, "G10"),
                        280 => (OffsetWord::Home(false), "G28"),
                        281 => (OffsetWord::SetHome(false), "G28.1"),
                        300 => (OffsetWord::Home(true), "G30"),
                        301 => (OffsetWord::SetHome(true), "G30.1"),
                        520 => (OffsetWord::Local, "G52"),
                        _ => (OffsetWord::Machine, "G53"),
                    };
                    g.offset_word = Some((word, w.col));
                    label
                }),
                _ => {
                    d.error(block.line, w.col, format!("unsupported G-code G{}", fmt_code(w.value)));
                    return None;
                }
            };
            if let Some(prev) = groups[group] {
                d.error(
                    block.line,
                    w.col,
                    format!(
                        "{label} conflicts with G{} in the same block (same modal group)",
                        fmt_code(prev as f64 / 10.0)
                    ),
                );
                return None;
            }
            groups[group] = Some(code as u32);
        }
        block.consume('G');
        Some(g)
    }

    fn read_m_words(&mut self, block: &Block, d: &mut Diagnostics) -> bool {
        // Modal groups: program end, spindle, tool change, coolant, modal state (M70–M73).
        let mut groups: [Option<i64>; 5] = [None; 5];
        let mut pause = None;
        for w in block.words.iter().filter(|w| w.letter == 'M') {
            let code = w.value as i64;
            let group = match code {
                2 | 30 if w.value.fract() == 0.0 => 0,
                0 | 1 | 60 if w.value.fract() == 0.0 => {
                    pause = Some(match code {
                        0 => StopCode::Stop,
                        1 => StopCode::Optional,
                        _ => StopCode::PalletShuttle,
                    });
                    0
                }
                3..=5 if w.value.fract() == 0.0 => 1,
                19 if w.value.fract() == 0.0 => {
                    if !self.spindle_orientation(block, w, d) {
                        return false;
                    }
                    1
                }
                6 if w.value.fract() == 0.0 => 2,
                61 if w.value.fract() == 0.0 => {
                    // M61 Q<n>: tool n is in the spindle, without a tool change (LinuxCNC's).
                    let Some(q) = block.get('Q') else {
                        d.error(block.line, w.col, "M61 needs Q (the number of the tool in the spindle)");
                        return false;
                    };
                    if q.value < 0.0 || q.value.fract() != 0.0 || q.value > f64::from(u32::MAX) {
                        d.error(block.line, q.col, format!("M61: Q must be a tool number, got {}", q.value));
                        return false;
                    }
                    self.modal.tool = Some(q.value as u32);
                    2
                }
                7..=9 if w.value.fract() == 0.0 => 3,
                70..=73 if w.value.fract() == 0.0 => 4,
                _ => {
                    d.error(
                        block.line,
                        w.col,
                        format!("unsupported M-code M{} (interpd interpolates motion only)", fmt_code(w.value)),
                    );
                    return false;
                }
            };
            if let Some(prev) = groups[group] {
                d.error(
                    block.line,
                    w.col,
                    format!("M{code} conflicts with M{prev} in the same block (same modal group)"),
                );
                return false;
            }
            groups[group] = Some(code);
            if group == 4 {
                // Before the block's G-codes, as LinuxCNC's `convert_m` comes before them.
                if !self.modal_context(code, w.col, block.line, d) {
                    return false;
                }
            } else if group == 0 && matches!(code, 2 | 30) {
                self.ended = true;
                self.summary.program_end = true;
            } else if group == 0 {
                // The stop comes after the block's motion (RS274NGC's order of execution).
                self.block_pause = pause;
                self.summary.pauses += 1;
            } else {
                self.summary.ignored_words += 1;
            }
        }
        block.consume('M');
        true
    }

    /// M19 (spindle orientation, `R` angle, `Q` timeout, `P` direction 0 … 2): accepted and
    /// ignored like the other spindle words, its words checked as LinuxCNC checks them.
    fn spindle_orientation(&self, block: &Block, m: &Word, d: &mut Diagnostics) -> bool {
        let r = block.get('R');
        if let Some(r) = r {
            if block.words.iter().any(|w| w.letter == 'G' && w.value == 64.0) {
                d.error(block.line, r.col, "R is ambiguous in a block with G64 and M19: put them on separate lines");
                return false;
            }
        }
        block.get('Q');
        if let Some(p) = block.get('P') {
            if p.value.fract() != 0.0 || !(0.0..=2.0).contains(&p.value) {
                d.error(block.line, p.col, format!("M19: P must be 0, 1 or 2, got {}", p.value));
                return false;
            }
        }
        let _ = m;
        true
    }

    /// S and T: accepted and counted (interpd interpolates motion only), but checked as a
    /// controller would.
    fn read_spindle_and_tool(&mut self, block: &Block, d: &mut Diagnostics) -> bool {
        if let Some(s) = block.get('S') {
            if s.value < 0.0 {
                d.error(block.line, s.col, format!("spindle speed S must not be negative, got {}", s.value));
                return false;
            }
            self.summary.ignored_words += 1;
        }
        if let Some(t) = block.get('T') {
            if t.value < 0.0 || t.value.fract() != 0.0 {
                d.error(block.line, t.col, format!("tool number T must be a non-negative integer, got {}", t.value));
                return false;
            }
            self.modal.prepared_tool = Some(t.value as u32);
            self.summary.ignored_words += 1;
        }
        // M6 (after T, as RS274NGC orders them) puts the selected tool in the spindle.
        if block.words.iter().any(|w| w.letter == 'M' && w.value == 6.0) {
            if let Some(t) = self.modal.prepared_tool {
                self.modal.tool = Some(t);
            }
        }
        true
    }

    /// Target position of a motion block, after units, G90/G91 and travel checks.
    pub(super) fn target(&self, block: &Block, d: &mut Diagnostics) -> Option<AxisVec> {
        let mut target = self.modal.pos;
        let mut ok = true;
        // In a rotated work system X and Y map to the machine together (frame.rs): their
        // program coordinates are collected and converted after the loop. G53 is unrotated.
        let rotation = if self.block_g53 { None } else { self.xy_rotation() };
        let mut xy: Vec<(usize, f64)> = Vec::new();
        let mut xy_col = block.words[0].col;
        if let Some((xk, yk, x, y)) = self.polar_target(block, d)? {
            let unit = self.modal.unit_mm;
            if rotation.is_some() {
                xy = vec![(xk, x * unit), (yk, y * unit)];
            } else {
                for (k, v) in [(xk, x), (yk, y)] {
                    target[k] = v * unit + self.program_offset(k);
                    if !target[k].is_finite() {
                        d.error(block.line, block.words[0].col, "the polar target is not a finite number");
                        return None;
                    }
                    if let Some(msg) = self.travel_violation(k, target[k]) {
                        d.error(block.line, block.words[0].col, msg);
                        ok = false;
                    }
                }
            }
        }
        for w in block.words {
            let Some(letter) = AxisLetter::from_char(w.letter) else { continue };
            block.consume(w.letter);
            let Some(k) = self.settings.axis_index(letter) else {
                d.error(
                    block.line,
                    w.col,
                    format!("axis {letter} is not on this machine (axes: {})", self.settings.axis_names().join(" ")),
                );
                ok = false;
                continue;
            };
            let scale = if self.linear[k] { self.modal.unit_mm } else { 1.0 };
            let v = w.value * scale;
            if let Some((xk, yk, _)) = rotation {
                if k == xk || k == yk {
                    if xy.is_empty() {
                        xy_col = w.col;
                    }
                    let prog = if self.modal.absolute { v } else { self.program_coord(k) + v };
                    xy.push((k, prog));
                    continue;
                }
            }
            target[k] = if self.block_g53 {
                v // G53: machine coordinates
            } else if self.modal.absolute {
                v + self.program_offset(k)
            } else {
                self.modal.pos[k] + v
            };
            if !target[k].is_finite() {
                d.error(block.line, w.col, format!("{letter} target is not a finite number"));
                ok = false;
                continue;
            }
            if let Some(msg) = self.travel_violation(k, target[k]) {
                d.error(block.line, w.col, msg);
                ok = false;
            }
        }
        if let (Some((xk, yk, _)), false) = (rotation, xy.is_empty()) {
            self.set_program_coords(&mut target, &xy);
            for k in [xk, yk] {
                if !target[k].is_finite() {
                    d.error(block.line, xy_col, "the X Y target is not a finite number");
                    return None;
                }
                if let Some(msg) = self.travel_violation(k, target[k]) {
                    d.error(block.line, xy_col, msg);
                    ok = false;
                }
            }
        }
        ok.then_some(target)
    }

    /// The XY target the polar words `@` `^` of the block give, in program coordinates and
    /// units, as LinuxCNC's `find_ends`: in G90 about the program origin (a missing word keeps
    /// the current point's radius or angle), in G91 the radius and angle added to the current
    /// point's. `Some(None)` without polar words; `None` after an error.
    pub(super) fn polar_target(&self, block: &Block, d: &mut Diagnostics) -> Option<Option<(usize, usize, f64, f64)>> {
        let radius = block.get(POLAR_RADIUS);
        let angle = block.get(POLAR_ANGLE);
        let Some(first) = radius.or(angle) else { return Some(None) };
        let line = block.line;
        let refuse = |d: &mut Diagnostics, msg: &str| {
            d.error(line, first.col, msg);
            None
        };
        if self.modal.plane != Plane::Xy {
            return refuse(d, "polar coordinates (@ ^) are only valid in the XY plane (G17)");
        }
        if self.block_g53 {
            return refuse(d, "polar coordinates (@ ^) cannot be used with G53");
        }
        if let Some(w) = block.words.iter().find(|w| w.letter == 'X' || w.letter == 'Y') {
            d.error(line, w.col, format!("{} and polar coordinates (@ ^) in one block", w.letter));
            return None;
        }
        let (Some(xk), Some(yk)) = (self.settings.axis_index(AxisLetter::X), self.settings.axis_index(AxisLetter::Y))
        else {
            return refuse(d, "polar coordinates (@ ^) need axes X and Y on this machine");
        };
        let unit = self.modal.unit_mm;
        let cx = self.program_coord(xk) / unit;
        let cy = self.program_coord(yk) / unit;
        let at_origin = cx == 0.0 && cy == 0.0;
        let (x, y) = if self.modal.absolute {
            if angle.is_none() && at_origin {
                return refuse(d, "polar coordinates at the origin need the angle ^");
            }
            let r = radius.map_or(cx.hypot(cy), |w| w.value);
            let theta = angle.map_or(cy.atan2(cx), |w| w.value.to_radians());
            (r * theta.cos(), r * theta.sin())
        } else {
            if at_origin {
                return refuse(d, "incremental polar coordinates (G91) are indeterminate at the origin");
            }
            polar_increment(cx, cy, radius.map(|w| w.value), angle.map(|w| w.value))
        };
        Some(Some((xk, yk, x, y)))
    }

    pub(super) fn travel_violation(&self, k: usize, value: f64) -> Option<String> {
        let a = &self.settings.axes[k];
        if value < a.min_pos || value > a.max_pos {
            Some(format!(
                "{} target {} {} is outside the travel range [{}, {}]",
                a.name,
                fmt_num(value),
                a.kind.unit(),
                a.min_pos,
                a.max_pos
            ))
        } else {
            None
        }
    }

    /// Path length between two positions: over the linear axes, or the rotary axes if only
    /// they move.
    fn move_length(&self, a: &AxisVec, b: &AxisVec) -> f64 {
        let n = self.settings.axes.len();
        let sq =
            |lin: bool| (0..n).filter(|&k| self.linear[k] == lin).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
        let l = sq(true);
        if l > MIN_MOVE_MM { l } else { sq(false) }
    }

    /// The one place elements leave the interpreter: the contour element goes through the
    /// cutter compensation stage, and what it hands back goes onto the path.
    fn push(&mut self, geometry: Geometry, feed: Feed, source: Source, col: u32, d: &mut Diagnostics) {
        let dwell = std::mem::take(&mut self.pending_dwell_s);
        *self.summary.kinds.entry(geometry.kind_name()).or_insert(0) += 1;
        if self.modal_log.is_some() {
            let active = self.active();
            if let Some(log) = &mut self.modal_log {
                log.record(source.line, active);
                log.element();
            }
        }
        self.close_message_place();
        if let Some(p) = self.pending_pause.take() {
            self.pause_for = Some((source, p));
        }
        let piece = Piece { geometry, feed, source, col, dwell_before_s: dwell, blend: self.modal.blend };
        if let Err(e) = self.cutter.push(piece) {
            d.error(e.line, e.col, e.kind.to_string());
        }
        self.drain(d);
    }

    /// Moves the tool path elements the compensation stage has ready onto the path, checking
    /// the compensated ones against the travel range.
    fn drain(&mut self, d: &mut Diagnostics) {
        while let Some(p) = self.cutter.pop() {
            if let Some(msg) = self.element_travel_violation(&p.geometry) {
                d.error(p.source.line, p.col, msg);
            }
            self.path.push(p.geometry, p.feed, p.source, p.dwell_before_s, p.blend);
            if let Some((_, pause)) = self.pause_for.filter(|(s, _)| *s == p.source) {
                self.pause_for = None;
                if let Some(e) = self.path.elements.last_mut() {
                    e.pause_before = Some(pause);
                }
            }
        }
    }

    /// The end point of an element (and the extremes of an arc) outside the travel range.
    fn element_travel_violation(&self, g: &Geometry) -> Option<String> {
        if let Geometry::Helix(h) = g {
            let (p, q) = h.plane_axes();
            if let Some(msg) = self.arc_travel_violation(h, p, q) {
                return Some(msg);
            }
        }
        let mut e = crate::path::AxisDerivs::default();
        g.eval(g.length_mm(), &mut e);
        (0..self.settings.axes.len()).find_map(|k| {
            let a = &self.settings.axes[k];
            let v = e.pos[k];
            (v < a.min_pos - ARC_RADIUS_ABS_TOL_MM || v > a.max_pos + ARC_RADIUS_ABS_TOL_MM).then(|| {
                format!(
                    "the tool path leaves the travel range of {}: it reaches {} {}, limits [{}, {}]",
                    a.name,
                    fmt_num(v),
                    a.kind.unit(),
                    a.min_pos,
                    a.max_pos
                )
            })
        })
    }

    pub(super) fn linear_move(&mut self, target: AxisVec, feed: Feed, source: Source, col: u32, d: &mut Diagnostics) {
        let len = self.move_length(&self.modal.pos, &target);
        let feed = self.inverse_time_feed(feed, len);
        if len <= MIN_MOVE_MM {
            // Right after G40 the tool may still stand beside the programmed point: then this
            // move is the exit move, from there (as LinuxCNC).
            if let Some(from) = self.cutter.exit_in_place(&self.modal.pos) {
                let exit_len = self.move_length(&from, &target);
                if exit_len > MIN_MOVE_MM {
                    let feed = self.inverse_time_feed(feed, exit_len);
                    self.push(Geometry::Line(LineGeom::new(from, target, exit_len)), feed, source, col, d);
                    self.modal.pos = target;
                    return;
                }
            }
            self.summary.zero_length_moves += 1;
            self.modal.pos = target;
            return;
        }
        let g = Geometry::Line(LineGeom::new(self.modal.pos, target, len));
        self.push(g, feed, source, col, d);
        self.modal.pos = target;
    }

    fn arc_move(&mut self, block: &Block, target: AxisVec, ccw: bool, feed: Feed, source: Source, d: &mut Diagnostics) {
        let line = block.line;
        let plane = self.modal.plane;
        let ((pl, pc), (ql, qc)) = plane.axes();
        let (Some(p), Some(q)) = (self.settings.axis_index(pl), self.settings.axis_index(ql)) else {
            d.error(
                line,
                block.words[0].col,
                format!("arc in {} needs axes {pl} and {ql} on this machine", plane.name()),
            );
            return;
        };
        // Offsets not belonging to the plane are errors, not silently ignored.
        for w in block.words.iter().filter(|w| matches!(w.letter, 'I' | 'J' | 'K')) {
            if w.letter != pc && w.letter != qc {
                d.error(line, w.col, format!("{} is not an arc centre offset in the {} plane", w.letter, plane.name()));
                return;
            }
        }
        if plane != Plane::Xy && self.xy_rotation().is_some() {
            d.error(
                line,
                block.words[0].col,
                format!(
                    "an arc in {} in a rotated coordinate system (G10 L2 R) is not supported: the rotation about Z tilts its plane",
                    plane.name()
                ),
            );
            return;
        }
        let r_word = block.get('R');
        let (ow_p, ow_q) = (block.get(pc), block.get(qc));
        if r_word.is_some() && (ow_p.is_some() || ow_q.is_some()) {
            let w = ow_p.or(ow_q).expect("one offset");
            d.error(line, w.col, "give either the centre (I J K) or the radius R, not both");
            return;
        }
        let start = self.modal.pos;
        let (s, e) = ([start[p], start[q]], [target[p], target[q]]);
        let chord = (e[0] - s[0]).hypot(e[1] - s[1]);
        let unit = self.modal.unit_mm;
        let (center, sweep) = if let Some(rw) = r_word {
            let r = rw.value * unit;
            if chord <= MIN_MOVE_MM {
                d.error(line, rw.col, "an R-form arc cannot describe a full circle: use the centre form I J K");
                return;
            }
            if r.abs() < MIN_ARC_RADIUS_MM {
                d.error(line, rw.col, "degenerate arc: radius R is zero");
                return;
            }
            let half = chord / 2.0;
            if let Err(msg) = arc_rule::check_radius_form(half, r, unit) {
                d.error(line, rw.col, msg);
                return;
            }
            let h = (r * r - half * half).max(0.0).sqrt();
            let dir = [(e[0] - s[0]) / chord, (e[1] - s[1]) / chord];
            let left = [-dir[1], dir[0]];
            // Short arc (R > 0): the centre lies left of the chord for G3, right for G2.
            let side = if ccw == (r > 0.0) { 1.0 } else { -1.0 };
            let mid = [(s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0];
            let c = [mid[0] + side * h * left[0], mid[1] + side * h * left[1]];
            (c, sweep_angle(s, e, c, ccw, false))
        } else {
            if ow_p.is_none() && ow_q.is_none() {
                d.error(line, block.words[0].col, format!("arc needs its centre ({pc} {qc}) or radius R"));
                return;
            };
            // The offsets are program-frame vectors: a rotated system turns them (in G17; the
            // other planes are refused above).
            let (op, oq) = self.rotate_xy(ow_p.map_or(0.0, |w| w.value * unit), ow_q.map_or(0.0, |w| w.value * unit));
            let c = [s[0] + op, s[1] + oq];
            let r0 = (s[0] - c[0]).hypot(s[1] - c[1]);
            let r1 = (e[0] - c[0]).hypot(e[1] - c[1]);
            let col = ow_p.or(ow_q).expect("one offset").col;
            if r0 < MIN_ARC_RADIUS_MM {
                d.error(line, col, "degenerate arc: the centre lies on the start point (radius zero)");
                return;
            }
            if let Err(msg) = arc_rule::check_centre_form(r0, r1, unit) {
                d.error(line, col, msg);
                return;
            }
            let full = chord <= MIN_MOVE_MM;
            // Move the centre onto the perpendicular bisector so start and end radii agree
            // exactly and the arc ends where programmed.
            let c = if full { c } else { project_on_bisector(s, e, c) };
            (c, sweep_angle(s, e, c, ccw, full))
        };
        // P: the number of turns, as LinuxCNC (the arc plus P - 1 full circles).
        if let (Some(w), true) = (block.get('P'), block.words.iter().any(|w| w.letter == 'G' && w.value == 4.0)) {
            d.error(line, w.col, "G4 is not allowed with G2/G3: both use P");
            return;
        }
        let sweep = match block.get('P').map(|w| (w, arc_rule::turns(w.value))) {
            None => sweep,
            Some((_, Ok(n))) => sweep + sweep.signum() * 2.0 * PI * f64::from(n - 1),
            Some((w, Err(msg))) => {
                d.error(line, w.col, msg);
                return;
            }
        };
        let helix = Helix::new(p, q, center, sweep, start, target, &self.linear[..self.settings.axes.len()]);
        if helix.length_mm() <= MIN_MOVE_MM {
            d.error(line, block.words[0].col, "degenerate arc: zero length");
            return;
        }
        if let Some(msg) = self.arc_travel_violation(&helix, p, q) {
            d.error(line, block.words[0].col, msg);
            return;
        }
        let feed = self.inverse_time_feed(feed, helix.length_mm());
        self.push(Geometry::Helix(helix), feed, source, block.words[0].col, d);
        self.modal.pos = target;
    }

    /// In inverse time (G93) a feed move of `len_mm` takes 1/F minutes: its path feed is
    /// `len_mm · F / 60` mm/s. Rapids and moves in G94 keep `feed`.
    fn inverse_time_feed(&self, feed: Feed, len_mm: f64) -> Feed {
        match (feed, self.inverse_f) {
            (Feed::Programmed { .. }, Some(f)) => Feed::Programmed { mm_per_s: len_mm * f / 60.0 },
            _ => feed,
        }
    }

    /// Checks the extreme points of the arc in its plane against the travel limits.
    fn arc_travel_violation(&self, h: &Helix, p: usize, q: usize) -> Option<String> {
        let c = h.center();
        let r = h.radius_mm();
        let mut d = crate::path::AxisDerivs::default();
        h.eval(0.0, &mut d);
        let phi0 = (d.pos[q] - c[1]).atan2(d.pos[p] - c[0]);
        let sweep = h.sweep_rad();
        for quarter in -8..=8 {
            let ang = quarter as f64 * PI / 2.0;
            let rel = (ang - phi0) * sweep.signum();
            if rel > 0.0 && rel < sweep.abs() {
                let (pp, qq) = (c[0] + r * ang.cos(), c[1] + r * ang.sin());
                for (k, v) in [(p, pp), (q, qq)] {
                    let a = &self.settings.axes[k];
                    if v < a.min_pos - ARC_RADIUS_ABS_TOL_MM || v > a.max_pos + ARC_RADIUS_ABS_TOL_MM {
                        return Some(format!(
                            "arc leaves the travel range of {}: it reaches {} {}, limits [{}, {}]",
                            a.name,
                            fmt_num(v),
                            a.kind.unit(),
                            a.min_pos,
                            a.max_pos
                        ));
                    }
                }
            }
        }
        None
    }

    fn start_g06(&mut self, block: &Block, block_no: u32, d: &mut Diagnostics) {
        let _ = block_no;
        for w in block.words {
            if AxisLetter::from_char(w.letter).is_some() || w.letter == 'R' || w.letter == 'P' || w.letter == 'Q' {
                d.error(
                    block.line,
                    w.col,
                    "the G06 block takes only the start tangent I J K; the support points follow on the next lines",
                );
                return;
            }
        }
        let Some(feed) = self.modal.feed_mm_s else {
            d.error(block.line, block.words[0].col, "G06 without feed: program F (mm/min) before or in this block");
            return;
        };
        if !self.has_xyz(block.line, block.words[0].col, d) {
            return;
        }
        if self.xy_rotation().is_some() {
            d.error(
                block.line,
                block.words[0].col,
                "G06 splines in a rotated coordinate system (G10 L2 R) are not supported",
            );
            return;
        }
        let ijk = ['I', 'J', 'K'].map(|c| block.get(c).map(|w| w.value * self.modal.unit_mm));
        let start_tangent = ijk.iter().any(Option::is_some).then(|| ijk.map(|v| v.unwrap_or(0.0)));
        self.g06 = Some(G06Block {
            start: self.modal.pos,
            start_tangent,
            spans: Vec::new(),
            line: block.line,
            col: block.get('G').map_or(1, |w| w.col),
            resume: self.modal.motion,
            feed: Feed::Programmed { mm_per_s: feed },
            point: self.modal.pos,
            unterminated: false,
        });
    }

    fn has_xyz(&self, line: u32, col: u32, d: &mut Diagnostics) -> bool {
        for l in [AxisLetter::X, AxisLetter::Y, AxisLetter::Z] {
            if self.settings.axis_index(l).is_none() {
                d.error(line, col, format!("G06 splines need axes X, Y and Z; this machine has no {l}"));
                return false;
            }
        }
        true
    }

    fn g06_span(&mut self, line: &Line, line_no: u32, d: &mut Diagnostics) {
        let unit = self.modal.unit_mm;
        let absolute = self.modal.absolute;
        let xyz =
            [AxisLetter::X, AxisLetter::Y, AxisLetter::Z].map(|l| self.settings.axis_index(l).expect("checked at G06"));
        let offsets = xyz.map(|k| self.program_offset(k));
        let block = self.g06.as_mut().expect("in G06 block");
        let words = Block::new(&line.words, line_no);
        let block_no = words.get('N').map_or(0, |w| w.value as u32);
        for (i, w) in line.words.iter().enumerate() {
            if !matches!(w.letter, 'X' | 'Y' | 'Z' | 'P' | 'Q' | 'R' | 'N') {
                d.error(line_no, w.col, format!("{} is not allowed in G06 spline data (X Y Z P Q R only)", w.letter));
                return;
            }
            if line.words[..i].iter().any(|o| o.letter == w.letter) {
                d.error(line_no, w.col, format!("word {} appears twice in this span", w.letter));
                return;
            }
        }
        if line.semicolon_col.is_none() {
            d.error(line_no, line.end_col, "G06 span must end with ';'");
            block.unterminated = true;
            return;
        }
        let pqr = ['P', 'Q', 'R'].map(|c| words.get(c));
        let has_tangent = pqr.iter().any(Option::is_some);
        if block.start_tangent.is_some() && !has_tangent {
            d.error(line_no, line.end_col, "G06 span needs its tangent P Q R (the block gave the start tangent I J K)");
            return;
        }
        if block.start_tangent.is_none() && has_tangent {
            let w = pqr.iter().flatten().next().expect("has tangent");
            d.error(
                line_no,
                w.col,
                "tangent P Q R given but the G06 block has no start tangent I J K: give both or neither",
            );
            return;
        }
        let mut target = block.point;
        for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
            if let Some(w) = words.get(*l) {
                let v = w.value * unit;
                target[xyz[i]] = if absolute { v + offsets[i] } else { block.point[xyz[i]] + v };
            }
        }
        for (i, l) in ['X', 'Y', 'Z'].iter().enumerate() {
            let k = xyz[i];
            let a = &self.settings.axes[k];
            if target[k] < a.min_pos || target[k] > a.max_pos {
                let col = words.get(*l).map_or(1, |w| w.col);
                d.error(
                    line_no,
                    col,
                    format!(
                        "{} target {} mm is outside the travel range [{}, {}]",
                        a.name,
                        fmt_num(target[k]),
                        a.min_pos,
                        a.max_pos
                    ),
                );
                return;
            }
        }
        let tangent = has_tangent.then(|| pqr.map(|w| w.map_or(0.0, |w| w.value * unit)));
        block.spans.push(SpanRecord {
            target,
            tangent,
            line: line_no,
            col: line.words.first().map_or(1, |w| w.col),
            block: block_no,
        });
        block.point = target;
    }

    /// Where the open G06 block starts (line, column), if one is open and has spans.
    pub(super) fn open_g06_with_spans(&self) -> Option<(u32, u32)> {
        self.g06.as_ref().filter(|b| !b.spans.is_empty() && !b.unterminated).map(|b| (b.line, b.col))
    }

    fn finish_g06(&mut self, d: &mut Diagnostics) {
        let Some(block) = self.g06.take() else { return };
        if block.unterminated {
            return; // already reported at the span
        }
        if block.spans.is_empty() {
            d.error(
                block.line,
                block.col,
                "unterminated G06 block: no spline spans ('X.. Y.. Z.. P.. Q.. R..;') follow",
            );
            return;
        }
        let xyz = [AxisLetter::X, AxisLetter::Y, AxisLetter::Z].map(|l| self.settings.axis_index(l).expect("checked"));
        let n = block.spans.len() + 1;
        let mut points = vec![block.start];
        points.extend(block.spans.iter().map(|s| s.target));
        let mut tangents = vec![[0.0; MAX_AXES]; n];
        match block.start_tangent {
            Some(t0) => {
                for i in 0..3 {
                    tangents[0][xyz[i]] = t0[i];
                }
                for (j, s) in block.spans.iter().enumerate() {
                    let t = s.tangent.expect("explicit tangents checked per span");
                    for i in 0..3 {
                        tangents[j + 1][xyz[i]] = t[i];
                    }
                }
            }
            None => {
                for &k in &xyz {
                    let coord: Vec<f64> = points.iter().map(|p| p[k]).collect();
                    for (j, t) in natural_tangents(&coord).into_iter().enumerate() {
                        tangents[j][k] = t; // Huan, eq. 3
                    }
                }
            }
        }
        let nax = self.settings.axes.len();
        for (j, span) in block.spans.iter().enumerate() {
            let (a, b) = (&points[j], &points[j + 1]);
            if self.move_length(a, b) <= MIN_MOVE_MM && tangents[j].iter().all(|&t| t == 0.0) {
                d.error(span.line, span.col, "degenerate G06 span: zero length");
                continue;
            }
            match CubicSpan::hermite(a, b, &tangents[j], &tangents[j + 1], &self.linear[..nax]) {
                Ok(c) => {
                    let source = Source { line: span.line, block: span.block };
                    self.push(Geometry::Cubic(Box::new(c)), block.feed, source, span.col, d);
                }
                Err(SpanError::ZeroTangent) => {
                    d.error(span.line, span.col, "degenerate G06 span: the curve stops or turns back (its tangent vanishes)")
                }
                Err(SpanError::SharpTurn { radius_mm, u }) => d.error(
                    span.line,
                    span.col,
                    format!(
                        "degenerate G06 span: the curve turns on a radius of {} µm at u = {:.3} (at least {} µm needed); check the support points and tangents",
                        fmt_num(radius_mm * 1e3),
                        u,
                        fmt_num(MIN_CURVATURE_RADIUS_MM * 1e3)
                    ),
                ),
            }
        }
        self.modal.pos = *points.last().expect("n ≥ 2");
        self.modal.motion = block.resume;
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BlendWord {
    Exact,
    Smooth,
}

/// G40, G41/G42 (tool table D) or G41.1/G42.1 (diameter D).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CompWord {
    Off,
    Table(Side),
    Diameter(Side),
}

/// G43 (tool table H), G43.1 (length from the Z word), G49.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ToolLengthWord {
    Table,
    Dynamic,
    Cancel,
}

/// G92 (set), G92.1 (clear), G92.2 (zero, keeping the saved values), G92.3 (restore them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AxisOffsetWord {
    Set,
    Clear,
    Suspend,
    Restore,
}

#[derive(Default)]
struct GWords {
    motion: Option<Motion>,
    spline: bool,
    dwell: bool,
    plane: Option<Plane>,
    plane_col: u32,
    /// With the column of the word.
    comp: Option<(CompWord, u32)>,
    tool_length: Option<(ToolLengthWord, u32)>,
    work: Option<usize>,
    axis_offset: Option<(AxisOffsetWord, u32)>,
    units: Option<f64>,
    absolute: Option<bool>,
    blend: Option<BlendWord>,
    /// G93 (true) or G94 (false).
    inverse_time: Option<bool>,
    /// G96/G97: accepted and ignored.
    spindle_mode: bool,
    /// G80.
    cancel_cycle: bool,
    /// G10, G28, G28.1, G30, G30.1, G52, G53 (non-modal), with the column of the word.
    offset_word: Option<(OffsetWord, u32)>,
    /// G98 (false) or G99 (true).
    retract_r: Option<bool>,
    /// G5.3 (the end of a NURBS), with the column of the word.
    nurbs_end: Option<u32>,
}

/// A line of G06 spline data: only X Y Z P Q R (and N) words.
fn is_span_line(line: &Line) -> bool {
    line.words.iter().any(|w| matches!(w.letter, 'X' | 'Y' | 'Z' | 'P' | 'Q' | 'R'))
        && line.words.iter().all(|w| !matches!(w.letter, 'G' | 'M' | 'F'))
}

/// (x, y) moved by `radius` along its radius and then turned by `angle_deg` about the origin,
/// as LinuxCNC's G91 polar words (the radius first, each only if given).
pub(super) fn polar_increment(x: f64, y: f64, radius: Option<f64>, angle_deg: Option<f64>) -> (f64, f64) {
    let (mut x, mut y) = (x, y);
    if let Some(dr) = radius {
        let theta = y.atan2(x);
        let r = y.hypot(x) + dr;
        (x, y) = (r * theta.cos(), r * theta.sin());
    }
    if let Some(da) = angle_deg {
        let theta = y.atan2(x) + da.to_radians();
        let r = y.hypot(x);
        (x, y) = (r * theta.cos(), r * theta.sin());
    }
    (x, y)
}

/// Signed sweep from s to e about c: positive counter-clockwise. A full circle if `full`.
fn sweep_angle(s: [f64; 2], e: [f64; 2], c: [f64; 2], ccw: bool, full: bool) -> f64 {
    if full {
        return if ccw { 2.0 * PI } else { -2.0 * PI };
    }
    let a0 = (s[1] - c[1]).atan2(s[0] - c[0]);
    let a1 = (e[1] - c[1]).atan2(e[0] - c[0]);
    let mut d = a1 - a0;
    if ccw {
        while d <= 0.0 {
            d += 2.0 * PI;
        }
        while d > 2.0 * PI {
            d -= 2.0 * PI;
        }
    } else {
        while d >= 0.0 {
            d -= 2.0 * PI;
        }
        while d < -2.0 * PI {
            d += 2.0 * PI;
        }
    }
    d
}

/// The point on the perpendicular bisector of s–e nearest to c.
fn project_on_bisector(s: [f64; 2], e: [f64; 2], c: [f64; 2]) -> [f64; 2] {
    let m = [(s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0];
    let chord = [e[0] - s[0], e[1] - s[1]];
    let len = chord[0].hypot(chord[1]);
    let n = [-chord[1] / len, chord[0] / len];
    let t = (c[0] - m[0]) * n[0] + (c[1] - m[1]) * n[1];
    [m[0] + t * n[0], m[1] + t * n[1]]
}

fn fmt_code(v: f64) -> String {
    if v.fract() == 0.0 { format!("{}", v as i64) } else { format!("{v}") }
}

/// The error for a program whose text ends inside G06 spline data.
pub(super) fn ends_inside_g06_message() -> String {
    format!(
        "the program ends inside this G06 block: end its spline data with an empty line, a line '{G06_END_MARKER}' or \
         the next block"
    )
}
