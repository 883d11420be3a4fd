//! Program input: RS274 / ISO 6983 G-code with G06 spline blocks (Huan, §2), and path tables
//! (the data form of the five-axis example in Kopp et al. 2019, §2 and §4), turned into a
//! [`Path`].

mod active;
mod append;
mod arc_rule;
mod cutter;
mod error;
mod expr;
mod gcode;
mod lexer;
mod message;
mod param_file;
mod params;
mod stream;
mod table;

pub use active::{ActiveCutter, ActiveModal, ActiveTool, CompSide, WORK_SYSTEM_NAMES};
pub(crate) use append::AppendBuffer;
pub use append::{AppendError, Appended, Appends};
pub use error::{ProgramError, ProgramErrors};
pub(crate) use gcode::fmt_num;
pub use message::{MAX_TEXT_BYTES, Message, MessageKind, MessageQueue, PLACE_CAP};
pub use param_file::{HomePositions, ParamFile, ParamFileError, Persistent};
pub(crate) use stream::ProgramStream;
pub use stream::{Checked, check, check_open, check_text, check_with_messages};

use crate::Settings;
use crate::path::Path;
use error::Diagnostics;
use std::collections::{BTreeMap, BTreeSet};

/// The longest line read, bytes: far beyond any real block, and it bounds the memory a file
/// without line breaks can take.
pub(crate) const MAX_LINE_BYTES: usize = 64 * 1024;

/// A line holding only this word ends G06 spline data (Huan, §2: "CR", end of record); an
/// empty line or the next ordinary block does too.
pub(crate) const G06_END_MARKER: &str = "CR";

/// Counts for the one-line summary of `interpd check`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    /// Lines read.
    pub lines: u32,
    /// Blocks with words (G-code) or data rows (tables).
    pub blocks: u32,
    /// Elements per kind ("line", "arc", "spline", "table").
    pub kinds: BTreeMap<&'static str, usize>,
    /// Moves of zero length, dropped.
    pub zero_length_moves: usize,
    /// Spindle, coolant and tool words (M3–M9, S, T, G96, G97), accepted and ignored.
    pub ignored_words: usize,
    /// Planned pauses (M0, M1, M60): the motion stops exactly there and waits.
    pub pauses: usize,
    /// Operator messages (`(MSG,…)`, `(DEBUG,…)` shown, `(PRINT,…)`) read.
    pub messages: usize,
    /// The program ends with M2, M30 or a closing `%` (a path table always ends); one without
    /// an end can be continued (`program.append`).
    pub program_end: bool,
    /// Tools of the tool table the program uses (G43 H, G41/G42 D).
    pub tools: BTreeSet<u32>,
    /// Work coordinate systems the program selects (G54 … G59).
    pub work_offsets: BTreeSet<&'static str>,
    /// The program turns cutter radius compensation on.
    pub compensation: bool,
}

/// A parsed program: its path and what was read.
#[derive(Debug, Clone)]
pub struct Program {
    pub path: Path,
    pub summary: Summary,
}

/// Which input format a text is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Format {
    GCode,
    PathTable,
}

impl Format {
    /// Path tables are `.csv` files or texts whose first data line starts with `s,`.
    pub(crate) fn detect(origin: &str, text: &str) -> Self {
        if origin.to_ascii_lowercase().ends_with(".csv") {
            return Format::PathTable;
        }
        let first = text.lines().map(str::trim).find(|l| !l.is_empty() && !l.starts_with('#'));
        match first {
            Some(l) if l.starts_with("s,") || l.starts_with("s ,") => Format::PathTable,
            _ => Format::GCode,
        }
    }
}

/// Parses program text; `origin` names the file in messages.
pub fn parse(text: &str, origin: &str, settings: &Settings) -> Result<Program, ProgramErrors> {
    collect(ProgramStream::from_text(text.to_string(), origin, settings))
}

/// Reads and parses a program file whole (for programs of any length, plan it through a
/// [`crate::Feed`], which reads it as the motion goes).
pub fn load(path: &std::path::Path, settings: &Settings) -> Result<Program, ProgramErrors> {
    collect(ProgramStream::open(path, settings)?)
}

/// The whole path of a stream, or every error of the program (up to the cap).
fn collect(mut stream: ProgramStream) -> Result<Program, ProgramErrors> {
    let mut path = Path::new(stream.axis_names().to_vec(), stream.start());
    loop {
        match stream.next_element() {
            Ok(Some(e)) => path.push_element(e),
            Ok(None) => break,
            Err(_) => return Err(stream.all_errors()),
        }
    }
    path.start = stream.start();
    path.final_dwell_s = stream.final_dwell_s().unwrap_or(0.0);
    Ok(Program { path, summary: stream.summary().clone() })
}

/// The G-code modal state between blocks (motion mode, plane, units, G90/G91, feed, G61/G64,
/// position): what a controller carries from one MDI block to the next.
#[derive(Debug, Clone)]
pub struct ModalState(gcode::Modal);

impl ModalState {
    /// The state a program starts with (G17 G21 G90, no feed, the `[prep]` blend) at `pos`.
    pub fn new(settings: &Settings, pos: crate::path::AxisVec) -> Self {
        ModalState(gcode::Interpreter::initial_modal(settings, pos))
    }

    /// Where the next block starts.
    pub fn position(&self) -> &crate::path::AxisVec {
        &self.0.pos
    }

    /// The active work coordinate system, `"G54"` … `"G59.3"`.
    pub fn work_system(&self) -> &'static str {
        WORK_SYSTEM_NAMES[self.0.work_system.min(WORK_SYSTEM_NAMES.len() - 1)]
    }

    /// Active tool length compensation: the tool (None for G43.1) and the length added to Z, mm.
    pub fn tool_length(&self) -> Option<(Option<u32>, f64)> {
        self.0.tool_length
    }

    /// Moves the position (the machine was moved by other means), keeping the modes.
    pub fn set_position(&mut self, pos: crate::path::AxisVec) {
        self.0.pos = pos;
    }
}

/// Parses G-code `text` as a continuation from `modal`: the path starts at its position, and
/// on success `modal` becomes the state after the text (on error it is left as it was).
pub fn parse_gcode_from(
    text: &str,
    origin: &str,
    settings: &Settings,
    modal: &mut ModalState,
) -> Result<Program, ProgramErrors> {
    let mut d = Diagnostics::new(origin);
    let mut interp = gcode::Interpreter::resume(settings, modal.0.clone());
    for (i, line) in text.lines().enumerate() {
        if d.full() {
            break;
        }
        interp.line(line, i as u32 + 1, &mut d);
    }
    interp.finish(&mut d);
    if !d.errors.is_empty() {
        return Err(ProgramErrors(d.errors));
    }
    modal.0 = interp.modal().clone();
    Ok(Program { path: interp.path, summary: interp.summary })
}

#[cfg(test)]
mod tests;
