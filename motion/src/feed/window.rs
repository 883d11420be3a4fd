//! The path a feed plans along, as a window that moves with the motion.
//!
//! A program is read from its file or text, parsed and smoothed (G64) read by read as the
//! planner asks for more, and up to a look-ahead length beyond it while the caller has time
//! ([`Window::read_ahead`]); the elements behind the machine are dropped. So the window holds
//! the look-ahead and what the machine still runs, never the whole program. A path made whole
//! (MDI blocks, motion-law lines) is held in the same window.
//!
//! Each read of the program hands the smoothing stage one programmed element and takes what the
//! stage gives back; the window marks where each read's elements end, so the planner plans after
//! the same elements whether the program was read just in time or ahead
//! ([`After`]).

use super::FeedError;
use crate::Settings;
use crate::path::{AxisDerivs, Element, Path};
use crate::prep::{Prep, PrepStats};
use crate::program::{AppendBuffer, ProgramStream, Summary};
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
    /// Index (in the whole path) of the next element to come when the smoothing stage has
    /// given out everything before it and knows that it starts at rest
    /// ([`Window::rest_before`]).
    rest_before: Option<usize>,
    /// Time spent reading the program and in the smoothing stage.
    pub(super) read_time: Duration,
    pub(super) prep_time: Duration,
}

enum Input {
    Stream {
        stream: Box<ProgramStream>,
        prep: Box<Prep>,
        /// Length of the approach move before the program, mm: the program's path positions
        /// are shifted by it.
        s_offset_mm: f64,
        appends: Option<Arc<AppendBuffer>>,
    },
    Whole,
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
            rest_before: None,
            read_time: Duration::ZERO,
            prep_time: Duration::ZERO,
        }
    }

    /// A window over a program read from `stream`, behind the elements of `before` (the
    /// approach move, or nothing).
    pub(super) fn stream(
        stream: ProgramStream,
        before: Path,
        settings: &Settings,
        appends: Option<Arc<AppendBuffer>>,
    ) -> Window {
        let s_offset_mm = before.length_mm();
        let mut window = Window::whole(before);
        window.done = false;
        let stream = match &appends {
            Some(buffer) => stream.with_appends(buffer.clone()),
            None => stream,
        };
        window.input =
            Input::Stream { stream: Box::new(stream), prep: Box::new(Prep::new(settings)), s_offset_mm, appends };
        window
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
            Input::Stream { appends: Some(b), .. } => b.has_input(),
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
            Input::Stream { stream, .. } => Some(stream.summary()),
            Input::Whole => None,
        }
    }

    /// The smoothing stage's counters; `None` for a path held whole.
    pub(super) fn prep_stats(&self) -> Option<PrepStats> {
        match &self.input {
            Input::Stream { prep, .. } => Some(prep.stats),
            Input::Whole => None,
        }
    }

    /// Records where the program's tool and offset state changes, to be taken with
    /// [`Window::take_modal_change`].
    pub(super) fn track_modal(&mut self) {
        if let Input::Stream { stream, .. } = &mut self.input {
            stream.track_modal();
        }
    }

    /// The next change of the tool and offset state read so far (see
    /// [`crate::program::ActiveModal`]).
    pub(super) fn take_modal_change(&mut self) -> Option<(u32, crate::program::ActiveModal)> {
        match &mut self.input {
            Input::Stream { stream, .. } => stream.take_modal_change(),
            Input::Whole => None,
        }
    }

    /// The oldest operator message read and not yet taken.
    pub(super) fn take_message(&mut self) -> Option<crate::program::Message> {
        match &mut self.input {
            Input::Stream { stream, .. } => stream.take_message(),
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
        index == self.end_index() && self.rest_before == Some(index)
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
        let Input::Stream { stream, prep, s_offset_mm, .. } = &mut self.input else { return Ok(()) };
        stream.flush_waiting();
        while let Some(e) = stream.next_element()? {
            prep.push(e)?;
        }
        prep.finish()?;
        let offset = *s_offset_mm;
        self.take_smoothed(offset, After::Plan);
        Ok(())
    }

    /// Drops the elements that end before `s_mm` (keeping at least the last one).
    pub(super) fn trim_before(&mut self, s_mm: f64) {
        let before = self.path.elements.len();
        self.path.trim_before(s_mm);
        let dropped = before - self.path.elements.len();
        self.after.drain(..dropped);
        self.first_index += dropped;
    }

    /// Reads on while the window ends before `until_mm` and `deadline` has not passed; `true`
    /// if it read. A read error is kept and returned where the planner reaches that element.
    pub(super) fn read_ahead(&mut self, until_mm: f64, deadline: Instant) -> bool {
        let mut read = false;
        while self.can_read_ahead(until_mm) && Instant::now() < deadline {
            if let Err(e) = self.read() {
                self.deferred = Some(e);
            }
            read = true;
        }
        read
    }

    /// [`Window::read_ahead`] has something to do.
    pub(super) fn can_read_ahead(&self, until_mm: f64) -> bool {
        self.reads_ahead() && !self.done && self.deferred.is_none() && self.path.length_mm() < until_mm
    }

    /// The window may reach beyond what the planner asked for: a program read from its file or
    /// its text. Not one continued by `program.append`: there the reads decide whether the
    /// program waits for text, which only the planner's need may decide. Nor a path held whole.
    pub(super) fn reads_ahead(&self) -> bool {
        matches!(self.input, Input::Stream { appends: None, .. })
    }

    /// One read: the next programmed element through the smoothing stage into the window.
    fn read(&mut self) -> Result<(), FeedError> {
        if let Some(e) = self.deferred.take() {
            return Err(e);
        }
        let Input::Stream { stream, prep, s_offset_mm, .. } = &mut self.input else {
            self.done = true;
            return Ok(());
        };
        let started = Instant::now();
        let got = stream.next_element();
        let read = Instant::now();
        self.read_time += read - started;
        let got = got?;
        if got.is_none() && stream.waiting() {
            // Nothing more yet; the smoothing stage keeps its open run for what comes.
            self.waiting = true;
            return Ok(());
        }
        let ended = got.is_none();
        let smoothed = match got {
            Some(e) => prep.push(e),
            None => prep.finish(),
        };
        self.prep_time += read.elapsed();
        smoothed?;
        if ended {
            self.done = true;
            self.path.final_dwell_s = stream.final_dwell_s().unwrap_or(0.0);
        }
        let offset = *s_offset_mm;
        let rests = !ended && prep.rests_before_next();
        self.take_smoothed(offset, if ended { After::Finish } else { After::Plan });
        self.rest_before = rests.then(|| self.end_index());
        Ok(())
    }

    /// Moves what the smoothing stage has ready into the window; the last element of them
    /// gets `last`.
    fn take_smoothed(&mut self, s_offset_mm: f64, last: After) {
        let Input::Stream { prep, .. } = &mut self.input else { return };
        let before = self.path.elements.len();
        while let Some(e) = prep.pop() {
            self.path.append_shifted(e, s_offset_mm);
            self.after.push_back(After::Take);
        }
        if self.path.elements.len() > before {
            if let Some(a) = self.after.back_mut() {
                *a = last;
            }
        }
    }
}
