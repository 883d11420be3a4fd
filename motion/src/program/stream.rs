//! A program read as a stream: lines are read as elements are asked for, so memory grows with
//! the elements a caller holds, not with the program's length.
//!
//! [`ProgramStream`] hands out the elements of a G-code program one by one; [`check`] reads a
//! whole program the same way, keeping no geometry, for its errors and summary. A G06 spline
//! block is read whole before its spans are handed out (the natural spline's tangents depend on
//! every support point of the block). Path tables are read whole: they are the data form of
//! short multi-axis paths, not CAM output.

use super::append::{AppendBuffer, AppendChecker, Appends, Take};
use super::error::Diagnostics;
use super::gcode::Interpreter;
use super::gcode::{LineAt, LinePos};
use super::{Format, MAX_LINE_BYTES, ProgramError, ProgramErrors, Summary, table};
use crate::Settings;
use crate::path::{AxisVec, Element, MAX_AXES, Path};
use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read};
use std::path::PathBuf;
use std::sync::Arc;

/// Where the lines come from.
enum Lines {
    File(BufReader<std::fs::File>),
    Text { text: String, at: usize },
}

/// A subroutine file being read (`o<name> call` of a sub in its own file).
struct SubSource {
    reader: BufReader<std::fs::File>,
    path: Arc<PathBuf>,
    /// Byte offset of the next line, and the number of the line read last.
    offset: u64,
    line_no: u32,
}

/// What turns the lines into elements.
enum Reader {
    GCode(Box<Interpreter>),
    /// A path table, parsed whole when the stream opens: its end (the elements are handed
    /// out from `ready`) and what was read.
    Table {
        end: Path,
        summary: Box<Summary>,
    },
}

/// The elements of a program, read from its file as they are asked for.
pub(crate) struct ProgramStream {
    lines: Lines,
    reader: Reader,
    d: Diagnostics,
    line_no: u32,
    /// Byte offset of the program's next line (control flow goes back to a line by it).
    offset: u64,
    /// Subroutine files being read, the innermost last.
    subs: Vec<SubSource>,
    buf: Vec<u8>,
    ready: VecDeque<Element>,
    /// The end of the text was reached and the reader finished.
    eof: bool,
    axis_names: Vec<String>,
    start: AxisVec,
    /// Text appended while the program runs, read after `lines` (`program.append`).
    appends: Option<Arc<AppendBuffer>>,
    /// The last read found no whole line in `appends`: more may come.
    waiting: bool,
    /// The interpreter's last element was handed out by `flush_waiting`.
    flushed: bool,
    /// At the end of the text the interpreter is finished (closing a G06 block, attaching a
    /// trailing dwell); a check of an open program leaves it open for what is appended.
    finish_at_eof: bool,
}

impl ProgramStream {
    /// Opens the program file at `path` (named as given in messages).
    pub(crate) fn open(path: &std::path::Path, settings: &Settings) -> Result<Self, ProgramErrors> {
        let origin = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| fatal(&origin, format!("cannot read: {e}")))?;
        let mut lines = Lines::File(BufReader::with_capacity(1 << 16, file));
        // The format is decided on the first non-empty line (see `Format::detect`); a path
        // table is read whole here.
        let format = match &mut lines {
            Lines::File(r) => {
                let head = r.fill_buf().map_err(|e| fatal(&origin, format!("cannot read: {e}")))?;
                let head = String::from_utf8_lossy(&head[..head.len().min(MAX_LINE_BYTES)]).into_owned();
                Format::detect(&origin, &head)
            }
            Lines::Text { .. } => unreachable!("opened from a file"),
        };
        let mut stream = Self::with_lines(lines, &origin, settings, Format::GCode);
        if format == Format::PathTable {
            let mut text = String::new();
            if let Lines::File(r) = &mut stream.lines {
                r.read_to_string(&mut text).map_err(|e| not_text(&origin, e))?;
            }
            stream.lines = Lines::Text { text: String::new(), at: 0 };
            stream.read_table(&text, settings);
        }
        Ok(stream)
    }

    /// A stream over program text held in memory (`origin` names it in messages).
    pub(crate) fn from_text(text: String, origin: &str, settings: &Settings) -> Self {
        let format = Format::detect(origin, &text);
        if format == Format::PathTable {
            let mut stream = Self::with_lines(Lines::Text { text: String::new(), at: 0 }, origin, settings, format);
            stream.read_table(&text, settings);
            return stream;
        }
        Self::with_lines(Lines::Text { text, at: 0 }, origin, settings, format)
    }

    fn with_lines(lines: Lines, origin: &str, settings: &Settings, format: Format) -> Self {
        let start = [0.0; MAX_AXES];
        let reader = match format {
            Format::GCode => Reader::GCode(Box::new(Interpreter::new(settings))),
            Format::PathTable => {
                Reader::Table { end: Path::new(settings.axis_names(), start), summary: Box::default() }
            }
        };
        Self {
            lines,
            reader,
            d: Diagnostics::new(origin),
            line_no: 0,
            offset: 0,
            subs: Vec::new(),
            buf: Vec::new(),
            ready: VecDeque::new(),
            eof: false,
            axis_names: settings.axis_names(),
            start,
            appends: None,
            waiting: false,
            flushed: false,
            finish_at_eof: true,
        }
    }

    /// The program continues with the text appended to `buffer` after its own text (a path
    /// table takes none).
    pub(crate) fn with_appends(mut self, buffer: Arc<AppendBuffer>) -> Self {
        if matches!(self.reader, Reader::GCode(_)) {
            self.appends = Some(buffer);
        }
        self
    }

    /// Records where the tool and offset state changes (a G-code program), to be taken with
    /// [`ProgramStream::take_modal_change`].
    pub(crate) fn track_modal(&mut self) {
        if let Reader::GCode(interp) = &mut self.reader {
            interp.track_modal();
        }
    }

    /// The next change of the tool and offset state: the first source line it applies to and
    /// the state from there on. A change is there once an element after it has been read;
    /// the first is the state the program starts with.
    pub(crate) fn take_modal_change(&mut self) -> Option<(u32, super::ActiveModal)> {
        match &mut self.reader {
            Reader::GCode(interp) => interp.take_modal_change(),
            Reader::Table { .. } => None,
        }
    }

    /// The oldest operator message read and not yet taken (a G-code program; see
    /// [`crate::program::Message`]).
    pub(crate) fn take_message(&mut self) -> Option<super::Message> {
        match &mut self.reader {
            Reader::GCode(interp) => interp.take_message(),
            Reader::Table { .. } => None,
        }
    }

    /// The stream has handed out everything there is but the program goes on: text appended
    /// later continues it.
    pub(crate) fn waiting(&self) -> bool {
        self.waiting && !self.eof
    }

    fn read_table(&mut self, text: &str, settings: &Settings) {
        let program = table::parse_table(text, settings, &mut self.d);
        self.start = program.path.start;
        self.ready.extend(program.path.elements);
        self.reader =
            Reader::Table { end: Path { elements: Vec::new(), ..program.path }, summary: Box::new(program.summary) };
        self.eof = true;
    }

    /// Axis names in machine order.
    pub(crate) fn axis_names(&self) -> &[String] {
        &self.axis_names
    }

    /// Where the path starts (the machine origin for G-code; a table's first row).
    pub(crate) fn start(&self) -> AxisVec {
        self.start
    }

    /// Lines read so far and what they held.
    pub(crate) fn summary(&self) -> &Summary {
        match &self.reader {
            Reader::GCode(i) => &i.summary,
            Reader::Table { summary, .. } => summary,
        }
    }

    /// The dwell after the last element, s, once the stream has ended.
    pub(crate) fn final_dwell_s(&self) -> Option<f64> {
        if !self.eof {
            return None;
        }
        Some(match &self.reader {
            Reader::GCode(i) => i.path.final_dwell_s,
            Reader::Table { end, .. } => end.final_dwell_s,
        })
    }

    /// The next element, `None` at the end of the program. The first error ends the stream:
    /// every element handed out before it is valid.
    pub(crate) fn next_element(&mut self) -> Result<Option<Element>, ProgramErrors> {
        self.waiting = false;
        loop {
            if !self.d.errors.is_empty() {
                return Err(ProgramErrors(self.d.errors.clone()));
            }
            if let Some(e) = self.ready.pop_front() {
                return Ok(Some(e));
            }
            if self.eof || self.waiting {
                return Ok(None);
            }
            self.read_line();
        }
    }

    /// After an error: reads the rest of the program for its further errors (up to the cap)
    /// and returns them all.
    pub(crate) fn all_errors(&mut self) -> ProgramErrors {
        self.read_to_end();
        ProgramErrors(self.d.errors.clone())
    }

    /// Reads the rest of the program, handing out nothing: every error (up to the cap) and the
    /// summary.
    fn read_to_end(&mut self) {
        while !self.eof && !self.waiting && !self.d.full() {
            self.read_line();
            self.ready.clear();
        }
    }

    /// Feeds the next line to the interpreter (or finishes it at the end of the text).
    fn read_line(&mut self) {
        let Reader::GCode(interp) = &mut self.reader else {
            self.eof = true;
            return;
        };
        self.buf.clear();
        if !self.subs.is_empty() {
            self.read_sub_line();
            return;
        }
        let offset = self.offset;
        let got = match &mut self.lines {
            Lines::File(r) => r.by_ref().take(MAX_LINE_BYTES as u64 + 1).read_until(b'\n', &mut self.buf),
            Lines::Text { text, at } => {
                let rest = &text.as_bytes()[*at..];
                let n = rest.iter().position(|&b| b == b'\n').map_or(rest.len(), |i| i + 1);
                self.buf.extend_from_slice(&rest[..n.min(MAX_LINE_BYTES + 1)]);
                *at += n;
                Ok(n)
            }
        };
        // After the program's own text, the appended text (nothing after the program's end).
        let mut from_appends = false;
        let got = match (got, &self.appends) {
            (Ok(0), Some(more)) if !interp.ended() => match more.take_line(&mut self.buf, MAX_LINE_BYTES) {
                Take::Line => {
                    from_appends = true;
                    Ok(self.buf.len().max(1))
                }
                Take::Waiting => {
                    self.waiting = true;
                    return;
                }
                Take::End => Ok(0),
            },
            (got, _) => got,
        };
        match got {
            Ok(0) if !self.finish_at_eof && !interp.ended() => {
                // A check of an open program: it stays open for appended text, which cannot
                // continue a loop, a branch or a call.
                interp.finish_flow(&mut self.d);
                self.eof = true;
                return;
            }
            Ok(0) => {
                interp.finish(&mut self.d);
                let before = self.ready.len();
                interp.path.drain_all(&mut self.ready);
                self.skip_flushed(before);
                self.eof = true;
                return;
            }
            Ok(n) => {
                if !from_appends {
                    self.offset += n as u64;
                }
            }
            Err(e) => {
                self.d.error(self.line_no + 1, 0, format!("cannot read: {e}"));
                self.eof = true;
                return;
            }
        }
        self.line_no += 1;
        let at = (!from_appends).then(|| LineAt {
            here: LinePos { source: None, offset, line: self.line_no },
            next: LinePos { source: None, offset: self.offset, line: self.line_no + 1 },
        });
        if self.buf.len() > MAX_LINE_BYTES {
            self.d.error(self.line_no, 1, format!("line longer than {MAX_LINE_BYTES} bytes"));
            self.eof = true;
            return;
        }
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
        }
        if self.buf.last() == Some(&b'\r') {
            self.buf.pop();
        }
        let jump = match std::str::from_utf8(&self.buf) {
            Ok(text) => interp.line_at(text, self.line_no, at.as_ref(), &mut self.d),
            Err(e) => {
                self.d.error(self.line_no, e.valid_up_to() as u32 + 1, "the file is not UTF-8 text");
                self.eof = true;
                return;
            }
        };
        let before = self.ready.len();
        interp.path.drain_settled(&mut self.ready);
        self.skip_flushed(before);
        if let Some(to) = jump {
            self.jump(to);
        }
    }

    /// Reads the next line of the innermost subroutine file; errors name that file.
    fn read_sub_line(&mut self) {
        let Reader::GCode(interp) = &mut self.reader else { return };
        let Some(sub) = self.subs.last_mut() else { return };
        let file = sub.path.display().to_string();
        let got = sub.reader.by_ref().take(MAX_LINE_BYTES as u64 + 1).read_until(b'\n', &mut self.buf);
        let offset = sub.offset;
        let n = match got {
            Ok(0) => {
                self.d.set_file(&file);
                interp.source_ended(&file, &mut self.d);
                self.eof = true;
                return;
            }
            Ok(n) => n,
            Err(e) => {
                self.d.set_file(&file);
                self.d.error(sub.line_no + 1, 0, format!("cannot read: {e}"));
                self.eof = true;
                return;
            }
        };
        sub.offset += n as u64;
        sub.line_no += 1;
        let at = LineAt {
            here: LinePos { source: Some(sub.path.clone()), offset, line: sub.line_no },
            next: LinePos { source: Some(sub.path.clone()), offset: sub.offset, line: sub.line_no + 1 },
        };
        let origin = self.d.file().to_string();
        self.d.set_file(&file);
        if self.buf.len() > MAX_LINE_BYTES {
            self.d.error(at.here.line, 1, format!("line longer than {MAX_LINE_BYTES} bytes"));
            self.eof = true;
            return;
        }
        while matches!(self.buf.last(), Some(b'\n' | b'\r')) {
            self.buf.pop();
        }
        let jump = match std::str::from_utf8(&self.buf) {
            Ok(text) => interp.line_at(text, at.here.line, Some(&at), &mut self.d),
            Err(e) => {
                self.d.error(at.here.line, e.valid_up_to() as u32 + 1, "the file is not UTF-8 text");
                self.eof = true;
                return;
            }
        };
        if self.d.errors.is_empty() {
            self.d.set_file(&origin);
        }
        let before = self.ready.len();
        interp.path.drain_settled(&mut self.ready);
        self.skip_flushed(before);
        if let Some(to) = jump {
            self.jump(to);
        }
    }

    /// Goes on reading at `to`: a line of the program or of a subroutine file (opened if it is
    /// not open).
    fn jump(&mut self, to: LinePos) {
        let Some(path) = &to.source else {
            self.subs.clear();
            match &mut self.lines {
                Lines::File(r) => {
                    let delta = to.offset as i64 - self.offset as i64;
                    if let Err(e) = r.seek_relative(delta) {
                        self.d.error(to.line, 0, format!("cannot go back in the program file: {e}"));
                        self.eof = true;
                        return;
                    }
                }
                Lines::Text { at, .. } => *at = to.offset as usize,
            }
            self.offset = to.offset;
            self.line_no = to.line.saturating_sub(1);
            return;
        };
        let k = match self.subs.iter().position(|s| s.path == *path) {
            Some(k) => k,
            None => match std::fs::File::open(path.as_path()) {
                Ok(f) => {
                    self.subs.push(SubSource {
                        reader: BufReader::with_capacity(1 << 14, f),
                        path: path.clone(),
                        offset: 0,
                        line_no: 0,
                    });
                    self.subs.len() - 1
                }
                Err(e) => {
                    self.d.error(self.line_no, 0, format!("cannot read the subroutine file {}: {e}", path.display()));
                    self.eof = true;
                    return;
                }
            },
        };
        self.subs.truncate(k + 1);
        let sub = &mut self.subs[k];
        let origin = self.d.file().to_string();
        let delta = to.offset as i64 - sub.offset as i64;
        if let Err(e) = sub.reader.seek_relative(delta) {
            self.d.set_file(&path.display().to_string());
            self.d.error(to.line, 0, format!("cannot go back in the subroutine file: {e}"));
            self.d.set_file(&origin);
            self.eof = true;
            return;
        }
        sub.offset = to.offset;
        sub.line_no = to.line.saturating_sub(1);
    }

    /// While waiting for appended text: hands out the last element read too, which otherwise
    /// waits for its successor (the motion is to stop at the end of what is there). It stays
    /// with the interpreter for the joint and the path position of the next one, and is not
    /// handed out again.
    pub(crate) fn flush_waiting(&mut self) {
        let Reader::GCode(interp) = &self.reader else { return };
        if !self.waiting() || self.flushed {
            return;
        }
        if let Some(last) = interp.path.elements.last() {
            self.ready.push_back(last.clone());
            self.flushed = true;
        }
    }

    /// Drops the element [`ProgramStream::flush_waiting`] handed out early from those just
    /// drained (from index `from` of `ready` on).
    fn skip_flushed(&mut self, from: usize) {
        if self.flushed && self.ready.len() > from {
            self.ready.remove(from);
            self.flushed = false;
        }
    }
}

/// What a whole-program check found: the summary and the programmed path's extent.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    pub summary: Summary,
    /// Elements of the programmed path (before smoothing).
    pub elements: u64,
    /// Length of the programmed path, mm.
    pub length_mm: f64,
    /// Joints where the tangent breaks (a stop unless smoothed).
    pub corners: u64,
    /// The work systems G54 … G59.3 and the G28/G30 positions at the program's end (what its
    /// G10 L2/L20 and G28.1/G30.1 left; the parameter file keeps them). `None` for a path table.
    pub persistent_end: Option<super::Persistent>,
}

/// Reads the program at `path` to its end, keeping no geometry: every error (up to the cap,
/// each as FILE:LINE:COL) or the summary.
pub fn check(path: &std::path::Path, settings: &Settings) -> Result<Checked, ProgramErrors> {
    check_stream(ProgramStream::open(path, settings)?, &mut |_| {}).map(|(c, _)| c)
}

/// [`check`] that hands every operator message to `on_message` in program order, as its
/// block executes (`interpd check` prints them).
pub fn check_with_messages(
    path: &std::path::Path,
    settings: &Settings,
    on_message: &mut dyn FnMut(super::Message),
) -> Result<Checked, ProgramErrors> {
    check_stream(ProgramStream::open(path, settings)?, on_message).map(|(c, _)| c)
}

/// [`check`] of program text held in memory.
pub fn check_text(text: String, origin: &str, settings: &Settings) -> Result<Checked, ProgramErrors> {
    check_stream(ProgramStream::from_text(text, origin, settings), &mut |_| {}).map(|(c, _)| c)
}

/// [`check`] of the program at `path` (or of `text`, named `path`) that keeps a program
/// without an end (M2, M30, a closing `%`) open for text appended while it runs: its
/// [`Appends`] take that text, buffering at most `buffer_bytes` unread bytes. A program with an
/// end has none.
pub fn check_open(
    path: &std::path::Path,
    text: Option<String>,
    settings: &Settings,
    buffer_bytes: usize,
) -> Result<(Checked, Option<Appends>), ProgramErrors> {
    let mut stream = match text {
        Some(t) => ProgramStream::from_text(t, &path.display().to_string(), settings),
        None => ProgramStream::open(path, settings)?,
    };
    stream.finish_at_eof = false;
    let (checked, checker) = check_stream(stream, &mut |_| {})?;
    Ok((checked, checker.map(|c| Appends::new(c, buffer_bytes))))
}

fn check_stream(
    mut stream: ProgramStream,
    on_message: &mut dyn FnMut(super::Message),
) -> Result<(Checked, Option<AppendChecker>), ProgramErrors> {
    let (mut corners, mut length_mm) = (0u64, 0.0f64);
    loop {
        if !stream.d.errors.is_empty() {
            return Err(stream.all_errors());
        }
        while let Some(e) = stream.ready.pop_front() {
            corners += u64::from(e.joint == crate::path::JointKind::Corner);
            length_mm = length_mm.max(e.s_end_mm());
        }
        while let Some(m) = stream.take_message() {
            on_message(m);
        }
        if stream.eof {
            break;
        }
        stream.read_line();
    }
    let summary = stream.summary().clone();
    let elements = summary.kinds.values().map(|&n| n as u64).sum();
    let (length_mm, checker, persistent_end) = match &stream.reader {
        Reader::GCode(interp) => {
            let checker = (!summary.program_end)
                .then(|| AppendChecker::new((**interp).clone(), stream.line_no, stream.d.file().to_string()));
            (length_mm.max(interp.path.length_mm()), checker, Some(interp.persistent()))
        }
        Reader::Table { .. } => (length_mm, None, None),
    };
    Ok((Checked { summary, elements, length_mm, corners, persistent_end }, checker))
}

fn fatal(origin: &str, message: String) -> ProgramErrors {
    ProgramErrors(vec![ProgramError { file: origin.to_string(), line: 0, col: 0, message }])
}

fn not_text(origin: &str, e: std::io::Error) -> ProgramErrors {
    let message = if e.kind() == std::io::ErrorKind::InvalidData {
        "the file is not UTF-8 text".to_string()
    } else {
        format!("cannot read: {e}")
    };
    fatal(origin, message)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::AppendError;

    fn xyz() -> Settings {
        Settings::default_machine()
    }

    /// A program of `n` short G1 moves along a zig-zag.
    fn moves(n: usize) -> String {
        let mut t = String::from("G21 G90 G64 P0.01\nG1 X0 Y0 F600\n");
        for i in 1..=n {
            t.push_str(&format!("X{:.4} Y{:.4}\n", i as f64 * 0.01, (i % 2) as f64 * 0.003));
        }
        t.push_str("M2\n");
        t
    }

    #[test]
    fn elements_are_handed_out_as_the_lines_are_read() {
        let mut s = ProgramStream::from_text(moves(10_000), "z.ngc", &xyz());
        let mut count = 0;
        while let Some(e) = s.next_element().expect("valid") {
            count += 1;
            // The reader is at most one line ahead of the element it hands out (the last
            // element waits for its successor's joint).
            assert!(s.line_no <= e.source.line + 2, "line {} read for element of line {}", s.line_no, e.source.line);
            assert!(s.ready.len() <= 1);
        }
        assert_eq!(count, 10_000, "the move to X0 Y0 has zero length");
        assert_eq!(s.final_dwell_s(), Some(0.0));
    }

    #[test]
    fn a_loop_streams_in_bounded_memory() {
        // 200 000 iterations of a three-line loop body from a file: the reader goes back to the
        // loop's head in the file, never holding more than one element ahead.
        let text = "G1 X0 Y0 F6000\n#1 = 0\no1 while [#1 LT 200000]\n  G1 X[#1 MOD 2 + 1] Y[#1 * 0.001]\n  \
                    #1 = [#1 + 1]\no1 endwhile\nM2\n";
        let dir = std::env::temp_dir().join(format!("interpd-loop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let file = dir.join("loop.ngc");
        std::fs::write(&file, text).expect("write");
        let mut s = ProgramStream::open(&file, &xyz()).expect("open");
        let mut count = 0u64;
        while let Some(e) = s.next_element().expect("valid") {
            count += 1;
            assert!(s.ready.len() <= 1 && e.source.line == 4);
        }
        assert_eq!(count, 200_000);
        assert_eq!(s.summary().lines, 7);
        let checked = check(&file, &xyz()).expect("check runs the loop too");
        assert_eq!(checked.elements, 200_000);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_stream_gives_the_whole_parse_for_files_and_text() {
        let text = "G21\nG1 X1 F100\r\nG2 X3 Y0 I1 J0\nG4 P0.5\nG0 Z2\nG4 P0.25\n";
        let dir = std::env::temp_dir().join(format!("interpd-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let file = dir.join("p.ngc");
        std::fs::write(&file, text).expect("write");
        let from_file = super::super::load(&file, &xyz()).expect("file");
        let from_text = super::super::parse(text, &file.display().to_string(), &xyz()).expect("text");
        assert_eq!(from_file.path, from_text.path);
        assert_eq!(from_file.path.elements.len(), 3);
        assert_eq!(from_file.path.final_dwell_s, 0.25);
        assert_eq!(from_file.summary, from_text.summary);
        let checked = check(&file, &xyz()).expect("check");
        assert_eq!(checked.elements, 3);
        assert!((checked.length_mm - from_file.path.length_mm()).abs() < 1e-12);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn check_reads_on_after_an_error_and_reports_each_with_its_line() {
        let mut t = moves(2_000);
        t = t.replacen("X0.0100", "X0.0100 H1", 1);
        t = t.replacen("X10.0000", "X10.0000 E2", 1);
        let errs = check_text(t, "z.ngc", &xyz()).expect_err("two errors").0;
        let at: Vec<(u32, u32)> = errs.iter().map(|e| (e.line, e.col)).collect();
        assert_eq!(at, vec![(3, 9), (1002, 10)], "{errs:?}");
    }

    #[test]
    fn an_overlong_line_and_bad_utf8_are_errors_at_their_line() {
        let long = format!("G1 X1 F100\n({})\nG1 X2\n", "a".repeat(MAX_LINE_BYTES));
        let e = check_text(long, "l.ngc", &xyz()).expect_err("long").0;
        assert_eq!((e[0].line, e[0].col), (2, 1));
        assert!(e[0].message.contains("longer than"), "{}", e[0].message);

        let dir = std::env::temp_dir().join(format!("interpd-stream-utf8-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let file = dir.join("u.ngc");
        std::fs::write(&file, b"G1 X1 F100\nG1 X2 (\xff)\n").expect("write");
        let e = check(&file, &xyz()).expect_err("utf8").0;
        assert_eq!((e[0].line, e[0].col, e[0].message.as_str()), (2, 8, "the file is not UTF-8 text"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn appended_text_continues_an_open_program_and_waits_for_more() {
        let settings = xyz();
        let (checked, appends) =
            check_open(std::path::Path::new("open.ngc"), Some("G1 X1 F600\nG1 X2\n".into()), &settings, 64)
                .expect("valid");
        assert!(!checked.summary.program_end);
        assert_eq!((checked.elements, checked.length_mm), (2, 2.0));
        let appends = appends.expect("an open program takes appended text");

        let mut s = ProgramStream::from_text("G1 X1 F600\nG1 X2\n".into(), "open.ngc", &settings)
            .with_appends(appends.buffer());
        assert_eq!(s.next_element().expect("ok").map(|e| e.source.line), Some(1));
        // The second element waits for its successor's joint; nothing more is there.
        assert_eq!(s.next_element().expect("ok"), None);
        assert!(s.waiting());

        // A bad piece is refused with the program's line and column and changes nothing.
        let refused = |e: AppendError| match e {
            AppendError::Program(e) => e.0,
            e => panic!("not a program error: {e}"),
        };
        let e = refused(appends.append("G1 X3 H1\n", false).expect_err("H"));
        assert_eq!((e[0].line, e[0].col), (3, 7));
        // Spline data must come whole, and the last piece must not end inside it either.
        let e = refused(appends.append("G06\nX3 Y1 Z0;\n", false).expect_err("open G06"));
        assert_eq!((e[0].line, e[0].col), (4, 1), "{}", e[0].message);
        let e = refused(appends.append("G06\nX3 Y1 Z0;\n", true).expect_err("program ends in G06"));
        assert_eq!((e[0].line, e[0].col), (3, 1));
        assert!(e[0].message.starts_with("the program ends inside this G06 block"), "{}", e[0].message);
        assert_eq!(appends.buffered_bytes(), 0, "nothing refused is buffered");
        let a = appends.append("G1 X3\nG1 Y1", false).expect("valid");
        assert_eq!((a.lines, a.elements, a.length_mm, a.program_end), ((3, 4), 2, 2.0, false));
        assert_eq!(s.next_element().expect("ok").map(|e| e.source.line), Some(2));
        assert_eq!(s.next_element().expect("ok").map(|e| e.source.line), Some(3));
        assert_eq!(s.next_element().expect("ok"), None);
        assert!(s.waiting());

        // The buffer is bounded, and a piece that does not fit leaves the program as it was;
        // M2 ends the program.
        let full = appends.append(&"G1 X5\n".repeat(20), false).expect_err("full");
        assert!(matches!(full, AppendError::Full { limit_bytes: 64, .. }), "{full}");
        let a = appends.append("G1 X0 Y0\nM2\n", false).expect("valid");
        assert!(a.program_end && appends.is_closed());
        let lines: Vec<u32> = std::iter::from_fn(|| s.next_element().expect("ok")).map(|e| e.source.line).collect();
        assert_eq!(lines, vec![4, 5]);
        assert!(!s.waiting());
        assert_eq!(appends.append("G1 X1", false), Err(AppendError::Ended));
        assert!(appends.taken_bytes() > 0);
    }
}
