//! Program text that arrives while the program runs (`program.append`): [`Appends`], the
//! handle of a program loaded without an end. It checks each piece against the program so far
//! (modal state, position and line numbers carry on) and keeps it in a bounded buffer that the
//! program's reader empties as the motion goes.

use super::MAX_LINE_BYTES;
use super::error::{Diagnostics, ProgramErrors};
use super::gcode::Interpreter;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

/// A program loaded without an end (M2, M30, a closing `%`), open for text appended while it
/// runs: the control side appends with [`Appends::append`], a [`crate::Feed`] opened with it
/// reads on. Clones share the program.
#[derive(Clone)]
pub struct Appends {
    /// The program so far: one append at a time.
    checker: Arc<Mutex<AppendChecker>>,
    buffer: Arc<AppendBuffer>,
}

impl std::fmt::Debug for Appends {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Appends").field("buffer", &self.buffer).finish_non_exhaustive()
    }
}

impl Appends {
    /// The continuation of the program `checker` has read, buffering at most `limit_bytes`
    /// unread bytes.
    pub(crate) fn new(checker: AppendChecker, limit_bytes: usize) -> Appends {
        Appends { checker: Arc::new(Mutex::new(checker)), buffer: Arc::new(AppendBuffer::new(limit_bytes)) }
    }

    /// Checks `text` as the continuation of the program and buffers it for the reader; with
    /// `end`, nothing can follow. A piece that does not parse, does not fit or comes after the
    /// end is refused whole, and the program stays as it was.
    pub fn append(&self, text: &str, end: bool) -> Result<Appended, AppendError> {
        // The checker holds the program so far: it is consistent after any panic elsewhere,
        // as it is replaced only whole.
        let mut checker = self.checker.lock().unwrap_or_else(|p| p.into_inner());
        if checker.ended() {
            return Err(AppendError::Ended);
        }
        // Refused before it is checked when it cannot fit, so the checker stays as it is.
        let (buffered_bytes, limit_bytes) = (self.buffer.buffered_bytes(), self.buffer.limit_bytes());
        let wanted_bytes = text.len() + 1;
        if buffered_bytes + wanted_bytes > limit_bytes {
            return Err(AppendError::Full { buffered_bytes, limit_bytes, wanted_bytes });
        }
        let mut trial = checker.clone();
        let mut appended = trial.append(text, end)?;
        appended.program_end |= end;
        self.buffer.push(text, appended.program_end)?;
        *checker = trial;
        Ok(appended)
    }

    /// Unread bytes.
    pub fn buffered_bytes(&self) -> usize {
        self.buffer.buffered_bytes()
    }

    /// Bytes a reader has taken so far: a program whose appended text was read cannot run
    /// again from its start (the text is gone).
    pub fn taken_bytes(&self) -> u64 {
        self.buffer.taken_bytes()
    }

    /// The most unread bytes the buffer holds.
    pub fn limit_bytes(&self) -> usize {
        self.buffer.limit_bytes()
    }

    /// Nothing more can be appended: the program has ended.
    pub fn is_closed(&self) -> bool {
        self.buffer.is_closed()
    }

    /// The buffer the program's reader takes lines from.
    pub(crate) fn buffer(&self) -> Arc<AppendBuffer> {
        self.buffer.clone()
    }
}

/// Text appended to an open program, not read yet.
#[derive(Debug)]
pub(crate) struct AppendBuffer {
    state: Mutex<Buffered>,
    limit_bytes: usize,
}

#[derive(Debug, Default)]
struct Buffered {
    text: VecDeque<u8>,
    /// No more text follows (the program ended, or the client said so).
    closed: bool,
    /// Bytes taken by the reader so far.
    taken_bytes: u64,
}

/// Why text cannot be appended.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AppendError {
    /// The text does not parse as the continuation of the program.
    #[error("{0}")]
    Program(#[from] ProgramErrors),
    #[error(
        "the program buffer holds {buffered_bytes} of {limit_bytes} bytes; {wanted_bytes} more do not fit \
         (send again when the motion has used some)"
    )]
    Full { buffered_bytes: usize, limit_bytes: usize, wanted_bytes: usize },
    #[error("the program has ended (M2, M30, a closing '%' or program.append with \"end\"); nothing can follow")]
    Ended,
}

/// What the reader found in the buffer.
pub(crate) enum Take {
    /// A whole line (without its line break) is in the output.
    Line,
    /// No whole line yet; more text may come.
    Waiting,
    /// The buffer is empty and closed.
    End,
}

impl AppendBuffer {
    /// An empty buffer that holds at most `limit_bytes` unread bytes.
    pub(crate) fn new(limit_bytes: usize) -> AppendBuffer {
        AppendBuffer { state: Mutex::new(Buffered::default()), limit_bytes }
    }

    fn lock(&self) -> MutexGuard<'_, Buffered> {
        // The state is a byte queue and two flags: consistent after any panic elsewhere.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Adds `text` (a line break is added if it lacks one) and, with `end`, closes the buffer.
    pub(crate) fn push(&self, text: &str, end: bool) -> Result<(), AppendError> {
        let mut b = self.lock();
        if b.closed {
            return Err(AppendError::Ended);
        }
        let newline = !text.is_empty() && !text.ends_with('\n');
        let wanted_bytes = text.len() + usize::from(newline);
        if b.text.len() + wanted_bytes > self.limit_bytes {
            return Err(AppendError::Full {
                buffered_bytes: b.text.len(),
                limit_bytes: self.limit_bytes,
                wanted_bytes,
            });
        }
        b.text.extend(text.as_bytes());
        if newline {
            b.text.push_back(b'\n');
        }
        b.closed |= end;
        Ok(())
    }

    /// Unread bytes.
    pub(crate) fn buffered_bytes(&self) -> usize {
        self.lock().text.len()
    }

    /// Bytes the reader has taken so far.
    pub(crate) fn taken_bytes(&self) -> u64 {
        self.lock().taken_bytes
    }

    pub(crate) fn limit_bytes(&self) -> usize {
        self.limit_bytes
    }

    /// No more text can be appended.
    pub(crate) fn is_closed(&self) -> bool {
        self.lock().closed
    }

    /// A whole line or the end is there for the reader.
    pub(crate) fn has_input(&self) -> bool {
        let b = self.lock();
        b.closed || b.text.contains(&b'\n')
    }

    /// Moves the next whole line (at most `max` bytes, without its line break) to `out`.
    pub(crate) fn take_line(&self, out: &mut Vec<u8>, max: usize) -> Take {
        let mut b = self.lock();
        let Some(n) = b.text.iter().position(|&c| c == b'\n') else {
            if b.closed && !b.text.is_empty() {
                let n = b.text.len();
                out.extend(b.text.drain(..).take(max + 1));
                b.taken_bytes += n as u64;
                return Take::Line;
            }
            return if b.closed { Take::End } else { Take::Waiting };
        };
        out.extend(b.text.drain(..n).take(max + 1));
        b.text.pop_front();
        b.taken_bytes += n as u64 + 1;
        Take::Line
    }
}

/// Checks text appended to an open program against the program so far.
#[derive(Clone)]
pub(crate) struct AppendChecker {
    interp: Interpreter,
    line_no: u32,
    origin: String,
}

/// What one piece of appended text held.
#[derive(Debug, Clone, PartialEq)]
pub struct Appended {
    /// The program's lines it took (first, last; 1-based, counted over the whole program).
    pub lines: (u32, u32),
    /// Geometry elements it added.
    pub elements: u64,
    /// Path length it added, mm.
    pub length_mm: f64,
    /// It ended the program (M2, M30, a closing `%`, or `end`).
    pub program_end: bool,
}

impl AppendChecker {
    pub(crate) fn new(interp: Interpreter, line_no: u32, origin: String) -> AppendChecker {
        AppendChecker { interp, line_no, origin }
    }

    /// The program has ended: nothing can follow.
    pub(crate) fn ended(&self) -> bool {
        self.interp.ended()
    }

    /// Checks `text` as the continuation of the program: every error with the program's line
    /// and column, the program unchanged on error. A piece must not end inside a G06 block,
    /// and the last one (`end`) must not leave the program inside one either.
    pub(crate) fn append(&mut self, text: &str, end: bool) -> Result<Appended, ProgramErrors> {
        let mut interp = self.interp.clone();
        let mut d = Diagnostics::new(&self.origin);
        let mut line_no = self.line_no;
        let (kinds_before, length_before) = (elements(&interp), interp.path.length_mm());
        for line in text.lines() {
            if d.full() || interp.ended() {
                break;
            }
            line_no += 1;
            if line.len() > MAX_LINE_BYTES {
                d.error(line_no, 1, format!("line longer than {MAX_LINE_BYTES} bytes"));
                break;
            }
            interp.line(line, line_no, &mut d);
            // The elements made are only counted here; the reader makes them again.
            interp.path.drain_settled(&mut VecDeque::new());
        }
        if d.errors.is_empty() && interp.in_g06() && !end {
            d.error(line_no, 1, "the text ends inside a G06 block: append a spline block whole, with its end");
        }
        if let Some((line, col)) = interp.open_g06_with_spans().filter(|_| end && d.errors.is_empty()) {
            d.error(line, col, super::gcode::ends_inside_g06_message());
        }
        if !d.errors.is_empty() {
            return Err(ProgramErrors(d.errors));
        }
        let appended = Appended {
            lines: (self.line_no + 1, line_no),
            elements: elements(&interp) - kinds_before,
            length_mm: interp.path.length_mm() - length_before,
            program_end: interp.ended(),
        };
        self.interp = interp;
        self.line_no = line_no;
        Ok(appended)
    }
}

fn elements(interp: &Interpreter) -> u64 {
    interp.summary.kinds.values().map(|&n| n as u64).sum()
}
