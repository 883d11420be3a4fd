//! The path a feed plans along, as a window that moves with the motion.
//!
//! A program is read from its file or text, parsed and smoothed (G64) read by read as the
//! planner asks for more, and up to a look-ahead length beyond it while the caller has time
//! ([`Window::read_ahead`]); the elements behind the machine are dropped. So the window holds
//! the look-ahead and what the machine still runs, never the whole program. A path made whole
//! (MDI blocks, motion-law lines) is held in the same window.
//!
//! Each read of the program hands the smoothing stage one programmed element and takes what the
//! stage gives back ([`Reader`]); the window marks where each read's elements end, so the
//! planner plans after the same elements whether the program was read just in time, ahead, or
//! by a thread of its own ([`After`]).

use super::FeedError;
use super::reader::{Read, Reader, ReaderThread, ThreadRead};
use crate::Settings;
use crate::path::{AxisDerivs, Element, Path};
use crate::prep::PrepStats;
use crate::program::{ActiveModal, AppendBuffer, Message, ProgramStream, Summary};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What the planner does after taking an element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum After {
    /// Takes the next element: this one did not end a read of the program.
    Take,
    /// Plans: this element ends a read of the program (or a path held whole, element by element).
    Plan,
    /// Learns that no element follows, then plans: this element ends the last read.
    Finish,
}

/// The elements a feed plans along, from a little behind the machine to the planner's horizon.
pub(super) struct Window {
    input: Input,
    /// The elements held, with absolute path positions.
    path: Path,
    /// For each element held: what the planner does after taking it.
    after: VecDeque<After>,
    /// Index (in the whole path) of `path.elements[0]`.
    first_index: usize,
    /// Every element is in the window (or was).
    done: bool,
    /// The last read found nothing more yet: the program goes on with appended text.
    waiting: bool,
    /// A read ahead of the planner failed: returned where the planner reaches it.
    deferred: Option<FeedError>,
    /// Indices (in the whole path, ascending) of elements that a read learned start at rest
    /// before they were given out ([`Window::rest_before`]), from the planner's on.
    rests: VecDeque<usize>,
    /// Time spent reading the program and in the smoothing stage.
    pub(super) read_time: Duration,
    pub(super) prep_time: Duration,
    /// Time spent waiting for the reading thread's next read.
    pub(super) read_wait: Duration,
}

enum Input {
    /// Read in the caller's thread.
    Here {
        reader: Box<Reader>,
        appends: Option<Arc<AppendBuffer>>,
    },
    /// Read by a thread of its own ([`ReaderThread`]).
    Thread(Box<Threaded>),
    Whole,
}

/// A reading thread and what its reads brought beside the elements.
struct Threaded {
    thread: ReaderThread,
    modal: VecDeque<(u32, ActiveModal)>,
    messages: VecDeque<Message>,
    prep_stats: PrepStats,
    summary: Summary,
}

impl Window {
    /// A window over a path held whole: the planner plans after each element.
    pub(super) fn whole(path: Path) -> Window {
        let after = path.elements.iter().map(|_| After::Plan).collect();
        Window {
            input: Input::Whole,
            path,
            after,
            first_index: 0,
            done: true,
            waiting: false,
            deferred: None,
            rests: VecDeque::new(),
            read_time: Duration::ZERO,
            prep_time: Duration::ZERO,
            read_wait: Duration::ZERO,
        }
    }

    /// A window over a program read from `stream`, behind the elements of `before` (the
    /// approach move, or nothing). With `thread`, a thread of its own reads the program ahead
    /// (not for a program continued by `program.append`, whose reads only the planner's need
    /// may decide), starting with `thread`'s function (to set its scheduling).
    pub(super) fn stream(
        stream: ProgramStream,
        before: Path,
        settings: &Settings,
        appends: Option<Arc<AppendBuffer>>,
        thread: Option<fn()>,
    ) -> Result<Window, FeedError> {
        let s_offset_mm = before.length_mm();
        let mut window = Window::whole(before);
        window.done = false;
        let reader = Reader::new(stream, settings, s_offset_mm);
        window.input = match (appends, thread) {
            (Some(buffer), _) => {
                Input::Here { reader: Box::new(reader.with_appends(buffer.clone())), appends: Some(buffer) }
            }
            (None, None) => Input::Here { reader: Box::new(reader), appends: None },
            (None, Some(on_start)) => {
                let summary = reader.summary().clone();
                let thread =
                    ReaderThread::spawn(reader, on_start).map_err(|e| FeedError::ReaderThread(e.to_string()))?;
                Input::Thread(Box::new(Threaded {
                    thread,
                    modal: VecDeque::new(),
                    messages: VecDeque::new(),
                    prep_stats: PrepStats::default(),
                    summary,
                }))
            }
        };
        Ok(window)
    }

    /// The elements held (absolute path positions; the first ones may have been dropped).
    pub(super) fn path(&self) -> &Path {
        &self.path
    }

    /// Index in the whole path of the element after the last one held.
    fn end_index(&self) -> usize {
        self.first_index + self.path.elements.len()
    }

    /// The program goes on, but no more of it is there yet (`program.append`).
    pub(super) fn waiting(&self) -> bool {
        self.waiting && !self.done
    }

    /// More of a waiting program has arrived (a whole line, or its end).
    pub(super) fn has_input(&self) -> bool {
        match &self.input {
            Input::Here { appends: Some(b), .. } => b.has_input(),
            _ => false,
        }
    }

    /// The dwell after the last element, s (once every element is read).
    pub(super) fn final_dwell_s(&self) -> f64 {
        self.path.final_dwell_s
    }

    /// What the program's lines held so far; `None` for a path held whole.
    pub(super) fn summary(&self) -> Option<&Summary> {
        match &self.input {
            Input::Here { reader, .. } => Some(reader.summary()),
            Input::Thread(t) => Some(&t.summary),
            Input::Whole => None,
        }
    }

    /// The smoothing stage's counters; `None` for a path held whole.
    pub(super) fn prep_stats(&self) -> Option<PrepStats> {
        match &self.input {
            Input::Here { reader, .. } => Some(reader.prep_stats()),
            Input::Thread(t) => Some(t.prep_stats),
            Input::Whole => None,
        }
    }

    /// The next change of the tool and offset state read so far (see
    /// [`crate::program::ActiveModal`]).
    pub(super) fn take_modal_change(&mut self) -> Option<(u32, crate::program::ActiveModal)> {
        match &mut self.input {
            Input::Here { reader, .. } => reader.take_modal_change(),
            Input::Thread(t) => t.modal.pop_front(),
            Input::Whole => None,
        }
    }

    /// The oldest operator message read and not yet taken.
    pub(super) fn take_message(&mut self) -> Option<crate::program::Message> {
        match &mut self.input {
            Input::Here { reader, .. } => reader.take_message(),
            Input::Thread(t) => t.messages.pop_front(),
            Input::Whole => None,
        }
    }

    /// Index in the whole path of the element a plan from `s_mm` starts with, reading on until
    /// the window holds it.
    pub(super) fn index_from(&mut self, s_mm: f64) -> Result<usize, FeedError> {
        self.read_past(s_mm)?;
        if self.path.elements.is_empty() || s_mm >= self.path.length_mm() {
            // At the end: nothing is left to plan.
            return Ok(self.end_index());
        }
        Ok(self.first_index + self.path.first_index_from(s_mm))
    }

    /// The element at `index` of the whole path and what the planner does after it, reading on
    /// as needed; `None` after the last. With `until_rest`, `None` also where the reads learn
    /// that the element at `index`, not there yet, starts at rest ([`Window::rest_before`]).
    pub(super) fn element(&mut self, index: usize, until_rest: bool) -> Result<Option<(&Element, After)>, FeedError> {
        debug_assert!(index >= self.first_index, "element {index} was dropped (window from {})", self.first_index);
        self.waiting = false;
        let stop_at_rest = |w: &Window| until_rest && w.rest_before(index);
        while !self.done && !self.waiting && index >= self.end_index() && !stop_at_rest(self) {
            self.read()?;
        }
        let k = index - self.first_index;
        Ok(self.path.elements.get(k).map(|e| (e, self.after[k])))
    }

    /// Whether the element at `index` is the next to come, and the smoothing stage has given
    /// out everything before it and knows that it starts at rest: the planner can plan to that
    /// stop before the element is read (the first smoothing window of a cut after a rapid reads
    /// its whole reach ahead first).
    pub(super) fn rest_before(&self, index: usize) -> bool {
        self.rests.binary_search(&index).is_ok()
    }

    /// Position and derivatives at `s_mm` and the program line there (reading on until the
    /// window holds it).
    pub(super) fn eval(&mut self, s_mm: f64) -> Result<(AxisDerivs, u32), FeedError> {
        self.read_past(s_mm)?;
        let mut d = AxisDerivs::default();
        self.path.eval(s_mm, &mut d);
        let line = self.path.elements.get(self.path.element_index_at(s_mm)).map_or(0, |e| e.source.line);
        Ok((d, line))
    }

    /// Reads on until the window reaches beyond `s_mm`, the program ends or waits for text.
    fn read_past(&mut self, s_mm: f64) -> Result<(), FeedError> {
        self.waiting = false;
        while !self.done && !self.waiting && self.path.length_mm() <= s_mm {
            self.read()?;
        }
        Ok(())
    }

    /// A waiting program stops at the end of what is there: the smoothing stage closes its open
    /// run there (ending at rest), so every element read is in the window. Text appended later
    /// continues from rest at that end.
    pub(super) fn flush(&mut self) -> Result<(), FeedError> {
        let Input::Here { reader, .. } = &mut self.input else { return Ok(()) };
        let elements = reader.flush()?;
        self.append(elements, After::Plan);
        Ok(())
    }

    /// Drops the elements that end before `s_mm` (keeping at least the last one).
    pub(super) fn trim_before(&mut self, s_mm: f64) {
        let before = self.path.elements.len();
        self.path.trim_before(s_mm);
        let dropped = before - self.path.elements.len();
        self.after.drain(..dropped);
        self.first_index += dropped;
        while self.rests.front().is_some_and(|&i| i < self.first_index) {
            self.rests.pop_front();
        }
    }

    /// Reads on while the window ends before `until_mm` and `deadline` has not passed; `true`
    /// if it read. A read error is kept and returned where the planner reaches that element.
    /// With a reading thread: sets its target and takes the reads it has done, waiting for none.
    pub(super) fn read_ahead(&mut self, until_mm: f64, deadline: Instant) -> bool {
        let mut read = false;
        self.read_to(until_mm);
        while self.can_read_ahead(until_mm) && Instant::now() < deadline {
            let got = match &mut self.input {
                Input::Thread(t) => match t.thread.try_next() {
                    Some(r) => self.take_thread_read(r),
                    None => break,
                },
                _ => self.read(),
            };
            if let Err(e) = got {
                self.deferred = Some(e);
            }
            read = true;
        }
        read
    }

    /// The planner plans (`true`) or has finished ([`ReaderThread::owner_planning`]).
    pub(super) fn planning(&self, planning: bool) {
        if let Input::Thread(t) = &self.input {
            t.thread.owner_planning(planning);
        }
    }

    /// A reading thread reads on to `until_mm` (at least); nothing without one.
    pub(super) fn read_to(&self, until_mm: f64) {
        if let Input::Thread(t) = &self.input {
            t.thread.read_to(until_mm);
        }
    }

    /// [`Window::read_ahead`] has something to do: reading, or taking what the reading thread
    /// has read.
    pub(super) fn can_read_ahead(&self, until_mm: f64) -> bool {
        let reading = match &self.input {
            Input::Thread(t) => t.thread.has_read() || !t.thread.reads_to(until_mm),
            _ => self.reads_ahead(),
        };
        reading && !self.done && self.deferred.is_none() && self.path.length_mm() < until_mm
    }

    /// The window may reach beyond what the planner asked for: a program read from its file or
    /// its text. Not one continued by `program.append`: there the reads decide whether the
    /// program waits for text, which only the planner's need may decide. Nor a path held whole.
    pub(super) fn reads_ahead(&self) -> bool {
        matches!(self.input, Input::Here { appends: None, .. } | Input::Thread(_))
    }

    /// One read: the next programmed element through the smoothing stage into the window (or
    /// the reading thread's next read).
    fn read(&mut self) -> Result<(), FeedError> {
        if let Some(e) = self.deferred.take() {
            return Err(e);
        }
        match &mut self.input {
            Input::Here { reader, .. } => {
                let read = reader.read();
                self.take_read(read)
            }
            Input::Thread(t) => {
                let waited = Instant::now();
                let got = t.thread.next();
                self.read_wait += waited.elapsed();
                let Some(r) = got else { return Err(FeedError::ReaderThreadEnded) };
                self.take_thread_read(r)
            }
            Input::Whole => {
                self.done = true;
                Ok(())
            }
        }
    }

    /// Takes a read of the reading thread, with its modal changes and messages.
    fn take_thread_read(&mut self, r: ThreadRead) -> Result<(), FeedError> {
        let ThreadRead { read, modal, messages, prep_stats, summary } = r;
        if let Input::Thread(t) = &mut self.input {
            t.modal.extend(modal);
            t.messages.extend(messages);
            t.prep_stats = prep_stats;
            t.summary.lines = read.lines;
            if let Some(s) = summary {
                t.summary = s;
            }
        }
        self.take_read(read)
    }

    /// Takes one read into the window.
    fn take_read(&mut self, read: Read) -> Result<(), FeedError> {
        self.read_time += read.read_time;
        self.prep_time += read.prep_time;
        if let Some(e) = read.error {
            return Err(e);
        }
        if read.waiting {
            self.waiting = true;
            return Ok(());
        }
        if read.ended {
            self.done = true;
            self.path.final_dwell_s = read.final_dwell_s;
        }
        self.append(read.elements, if read.ended { After::Finish } else { After::Plan });
        let next = self.end_index();
        if read.rests && self.rests.back() != Some(&next) {
            self.rests.push_back(next);
        }
        Ok(())
    }

    /// Appends elements the smoothing stage gave out (on the window's path positions); the
    /// last of them gets `last`.
    fn append(&mut self, elements: Vec<Element>, last: After) {
        let any = !elements.is_empty();
        for e in elements {
            self.path.append_shifted(e, 0.0);
            self.after.push_back(After::Take);
        }
        if any {
            if let Some(a) = self.after.back_mut() {
                *a = last;
            }
        }
    }
}
