//! The path a run plans along, as a window that moves with the motion.
//!
//! A loaded program is read from its file, parsed and smoothed (G64) element by element as the
//! planner asks for more, and up to a look-ahead length beyond while the queue is full
//! ([`PathFeed::read_ahead`]; [`interpd_motion::program::ProgramStream`] → [`Prep`]); the
//! elements behind the machine are dropped. So the planner thread holds the look-ahead and what the
//! queue still runs, never the whole program. Paths made whole in memory (MDI blocks, law
//! moves) are handed out from the same window.

use super::approach::approach_line;
use super::lock;
use super::modal_track::ModalTrack;
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, AxisVec, Blend, Element, Feed, Path, Source};
use interpd_motion::prep::Prep;
use interpd_motion::program::{AppendBuffer, ProgramStream};
use std::sync::{Arc, Mutex};
use std::time::{Instant, SystemTime};

/// Where a program's text comes from.
#[derive(Debug, Clone)]
pub enum ProgramText {
    /// A file (inside the programs directory), as it was when it was loaded.
    File { path: std::path::PathBuf, stamp: FileStamp },
    /// Text sent with `program.load`.
    Text { name: String, text: Arc<String> },
}

/// What identifies a file's content cheaply: a file rewritten after `program.load` is refused
/// at the start rather than run half old, half new.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FileStamp {
    pub len: u64,
    pub modified: Option<SystemTime>,
}

impl FileStamp {
    pub fn of(path: &std::path::Path) -> std::io::Result<FileStamp> {
        let meta = std::fs::metadata(path)?;
        Ok(FileStamp { len: meta.len(), modified: meta.modified().ok() })
    }
}

/// The tool table and work offsets a program is read with (`tools.set`, `offsets.set`): taken
/// at `program.load`, so the motion reads the program as it was checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tooling {
    pub tools: Vec<interpd_config::ToolConfig>,
    pub work_offsets: interpd_config::WorkOffsetsConfig,
}

impl Tooling {
    /// `settings` with this tool table and these work offsets.
    pub fn apply(&self, settings: &Settings) -> Settings {
        Settings { tools: self.tools.clone(), work_offsets: self.work_offsets.clone(), ..settings.clone() }
    }
}

/// What a run plans along.
#[derive(Debug, Clone)]
pub enum PathSource {
    /// A path made whole (MDI blocks, law moves).
    Whole(Arc<Path>),
    /// A loaded program, read and smoothed as the motion goes, preceded by a straight rapid
    /// move from `here` to its start when the machine stands elsewhere, read with the tool table
    /// and work offsets it was loaded with; a program without an end continues with the text
    /// appended to `appends`.
    Program { text: ProgramText, here: AxisVec, tooling: Arc<Tooling>, appends: Option<Arc<AppendBuffer>> },
}

/// Why the path cannot go on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeedError {
    #[error("{0}")]
    Program(String),
    #[error("path smoothing: {0}")]
    Prep(#[from] interpd_motion::prep::PrepError),
}

/// The elements a run plans along, from a little behind the machine to the planner's horizon.
pub struct PathFeed {
    input: Input,
    /// The elements held, with absolute path positions.
    window: Path,
    /// Index (in the whole path) of `window.elements[0]`.
    first_index: usize,
    /// Every element is in the window (or was).
    done: bool,
    /// The last read found nothing more yet: the program goes on with appended text.
    waiting: bool,
    /// A read ahead of the planner failed: returned where the planner reaches it.
    deferred: Option<FeedError>,
    final_dwell_s: f64,
    /// Where the program's tool and offset state changes (`status.modal`), when tracked.
    modal: Option<Arc<Mutex<ModalTrack>>>,
}

enum Input {
    Stream { stream: Box<ProgramStream>, prep: Box<Prep>, s_offset_mm: f64, appends: Option<Arc<AppendBuffer>> },
    Empty,
}

impl PathFeed {
    /// A feed over a path held whole (it is small: MDI blocks, law moves).
    pub fn whole(path: &Path) -> PathFeed {
        let final_dwell_s = path.final_dwell_s;
        PathFeed {
            input: Input::Empty,
            window: path.clone(),
            first_index: 0,
            done: true,
            waiting: false,
            deferred: None,
            final_dwell_s,
            modal: None,
        }
    }

    /// An empty path at `here` (manual motion plans no path).
    pub fn empty(settings: &Settings, here: AxisVec) -> PathFeed {
        PathFeed {
            input: Input::Empty,
            window: Path::new(settings.axis_names(), here),
            first_index: 0,
            done: true,
            waiting: false,
            deferred: None,
            final_dwell_s: 0.0,
            modal: None,
        }
    }

    /// Opens `source`: a program's file is opened and checked to be the one loaded.
    pub fn open(source: PathSource, settings: &Settings) -> Result<PathFeed, FeedError> {
        let (text, here, tooling, appends) = match source {
            PathSource::Whole(path) => return Ok(PathFeed::whole(&path)),
            PathSource::Program { text, here, tooling, appends } => (text, here, tooling, appends),
        };
        let settings = &tooling.apply(settings);
        let stream = match &text {
            ProgramText::File { path, stamp } => {
                let name = path.display();
                match FileStamp::of(path) {
                    Ok(now) if now == *stamp => {}
                    Ok(_) => {
                        return Err(FeedError::Program(format!(
                            "{name}: the file changed after program.load; load it again"
                        )));
                    }
                    Err(e) => return Err(FeedError::Program(format!("{name}: cannot read: {e}"))),
                }
                ProgramStream::open(path, settings).map_err(|e| FeedError::Program(e.to_string()))?
            }
            ProgramText::Text { name, text } => ProgramStream::from_text(text.to_string(), name, settings),
        };
        let stream = match &appends {
            Some(buffer) => stream.with_appends(buffer.clone()),
            None => stream,
        };
        let mut window = Path::new(settings.axis_names(), here);
        let linear: Vec<bool> = settings.axes.iter().map(|a| a.kind == interpd_config::AxisKind::Linear).collect();
        if let Some(line) = approach_line(&linear, &here, &stream.start()) {
            window.push(line, Feed::Rapid, Source::default(), 0.0, Blend::Exact);
        }
        let s_offset_mm = window.length_mm();
        Ok(PathFeed {
            input: Input::Stream {
                stream: Box::new(stream),
                prep: Box::new(Prep::new(settings)),
                s_offset_mm,
                appends,
            },
            window,
            first_index: 0,
            done: false,
            waiting: false,
            deferred: None,
            final_dwell_s: 0.0,
            modal: None,
        })
    }

    /// Records the program's tool and offset state changes in `track` (emptied first) as its
    /// lines are read; a path made whole has none.
    pub fn track_modal(&mut self, track: Arc<Mutex<ModalTrack>>) {
        if let Input::Stream { stream, .. } = &mut self.input {
            stream.track_modal();
            lock(&track).clear();
            self.modal = Some(track);
        }
    }

    /// The elements held (absolute path positions; the first ones may have been dropped).
    pub fn path(&self) -> &Path {
        &self.window
    }

    /// The program goes on, but no more of it is there yet (`program.append`).
    pub fn waiting(&self) -> bool {
        self.waiting && !self.done
    }

    /// More of a waiting program has arrived (a whole line, or its end).
    pub fn has_input(&self) -> bool {
        match &self.input {
            Input::Stream { appends: Some(b), .. } => b.has_input(),
            _ => false,
        }
    }

    /// The dwell after the last element, s (once [`PathFeed::done`]).
    pub fn final_dwell_s(&self) -> f64 {
        self.final_dwell_s
    }

    /// Index in the whole path of the element a run from `s_mm` starts with, reading on until
    /// the window holds it.
    pub fn index_from(&mut self, s_mm: f64) -> Result<usize, FeedError> {
        self.waiting = false;
        while !self.done && !self.waiting && self.window.length_mm() <= s_mm {
            self.read()?;
        }
        if self.window.elements.is_empty() || s_mm >= self.window.length_mm() {
            // At the end: nothing is left to plan.
            return Ok(self.first_index + self.window.elements.len());
        }
        Ok(self.first_index + self.window.first_index_from(s_mm))
    }

    /// The element at `index` of the whole path, reading on as needed; `None` after the last.
    pub fn element(&mut self, index: usize) -> Result<Option<&Element>, FeedError> {
        debug_assert!(index >= self.first_index, "element {index} was dropped (window from {})", self.first_index);
        self.waiting = false;
        while !self.done && !self.waiting && index >= self.first_index + self.window.elements.len() {
            self.read()?;
        }
        Ok(self.window.elements.get(index - self.first_index))
    }

    /// Position and derivatives at `s_mm` (reading on until the window holds it).
    pub fn eval(&mut self, s_mm: f64) -> Result<(AxisDerivs, u32), FeedError> {
        self.waiting = false;
        while !self.done && !self.waiting && self.window.length_mm() <= s_mm {
            self.read()?;
        }
        let mut d = AxisDerivs::default();
        self.window.eval(s_mm, &mut d);
        let line = self.window.elements.get(self.window.element_index_at(s_mm)).map_or(0, |e| e.source.line);
        Ok((d, line))
    }

    /// A waiting program stops at the end of what is there: the smoothing stage closes its open
    /// run there (ending at rest), so every element read is in the window. Text appended later
    /// continues from rest at that end.
    pub fn flush(&mut self) -> Result<(), FeedError> {
        if let Input::Stream { stream, prep, s_offset_mm, .. } = &mut self.input {
            stream.flush_waiting();
            while let Some(e) = stream.next_element().map_err(|e| FeedError::Program(e.to_string()))? {
                prep.push(e)?;
            }
            prep.finish()?;
            while let Some(e) = prep.pop() {
                self.window.append_shifted(e, *s_offset_mm);
            }
        }
        Ok(())
    }

    /// Drops the elements that end before `s_mm`.
    pub fn trim_before(&mut self, s_mm: f64) {
        let before = self.window.elements.len();
        self.window.trim_before(s_mm);
        self.first_index += before - self.window.elements.len();
        if let (Some(track), Some(first)) = (&self.modal, self.window.elements.first()) {
            lock(track).passed(first.source.line);
        }
    }

    /// Reads on while the window ends before `until_mm` and `deadline` has not passed; `true`
    /// if it read. The planner thread does this while the queue is full, so the reading and
    /// smoothing a replan needs are done before the replan instead of in one step with it. A
    /// read error is kept and returned where the planner reaches that element. Not for a
    /// program continued by `program.append`: there the reads decide whether the program
    /// waits for text, which only the planner's need may decide.
    pub fn read_ahead(&mut self, until_mm: f64, deadline: Instant) -> bool {
        let mut read = false;
        while self.can_read_ahead(until_mm) && Instant::now() < deadline {
            if let Err(e) = self.read() {
                self.deferred = Some(e);
            }
            read = true;
        }
        read
    }

    /// [`PathFeed::read_ahead`] has something to do.
    pub fn can_read_ahead(&self, until_mm: f64) -> bool {
        self.reads_ahead() && !self.done && self.deferred.is_none() && self.window.length_mm() < until_mm
    }

    /// The window may reach beyond what the planner asked for: a program read from its file or
    /// its text, not one continued by `program.append`, nor a path held whole.
    pub fn reads_ahead(&self) -> bool {
        matches!(self.input, Input::Stream { appends: None, .. })
    }

    /// Reads the next element into the window (through the smoothing stage for a program).
    fn read(&mut self) -> Result<(), FeedError> {
        if let Some(e) = self.deferred.take() {
            return Err(e);
        }
        match &mut self.input {
            Input::Stream { stream, prep, s_offset_mm, .. } => {
                let got = stream.next_element().map_err(|e| FeedError::Program(e.to_string()))?;
                if let Some(track) = &self.modal {
                    take_modal_changes(stream, track);
                }
                if got.is_none() && stream.waiting() {
                    // Nothing more yet; the smoothing stage keeps its open run for what comes.
                    self.waiting = true;
                    return Ok(());
                }
                let ended = got.is_none();
                match got {
                    Some(e) => prep.push(e)?,
                    None => prep.finish()?,
                }
                while let Some(e) = prep.pop() {
                    self.window.append_shifted(e, *s_offset_mm);
                }
                if ended {
                    self.done = true;
                    self.final_dwell_s = stream.final_dwell_s().unwrap_or(0.0);
                }
            }
            Input::Empty => self.done = true,
        }
        Ok(())
    }
}

/// Moves the tool and offset state changes `stream` has read into `track`.
fn take_modal_changes(stream: &mut ProgramStream, track: &Mutex<ModalTrack>) {
    let mut next = stream.take_modal_change();
    if next.is_none() {
        return;
    }
    let mut t = lock(track);
    while let Some((line, state)) = next {
        t.push(line, state);
        next = stream.take_modal_change();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_config::Config;
    use std::time::Duration;

    fn program_feed(text: &str) -> PathFeed {
        let config = Config::default_machine();
        let tooling = Arc::new(Tooling { tools: config.tools.clone(), work_offsets: config.work_offsets.clone() });
        let text = ProgramText::Text { name: "t.ngc".into(), text: Arc::new(text.to_string()) };
        let source = PathSource::Program { text, here: [0.0; interpd_motion::path::MAX_AXES], tooling, appends: None };
        PathFeed::open(source, &Settings::from_config(&config)).expect("open")
    }

    #[test]
    fn reading_ahead_stops_at_its_bound_and_keeps_an_error_for_the_planner() {
        // 1 mm moves at an exact stop each, then a bad line (23).
        let mut text = String::from("G21 G90 G61\nG1 F600\n");
        for i in 1..=20 {
            text.push_str(&format!("X{i}\n"));
        }
        text.push_str("G1 X30 Q5\n");
        let mut feed = program_feed(&text);
        let later = Instant::now() + Duration::from_secs(10);
        assert!(feed.can_read_ahead(5.0));
        assert!(feed.read_ahead(5.0, later));
        let read_mm = feed.window.length_mm();
        assert!((5.0..6.5).contains(&read_mm), "read to {read_mm} mm: {:?}", feed.deferred);
        assert!(!feed.can_read_ahead(5.0) && !feed.read_ahead(5.0, later));
        // A deadline already passed reads nothing.
        assert!(!feed.read_ahead(100.0, Instant::now()));
        // Past the bad line: the error is kept, and reading ahead stops there.
        assert!(feed.read_ahead(100.0, later));
        assert!(!feed.can_read_ahead(100.0));
        // The planner gets what it gets without reading ahead: the same elements, then the error.
        let (ahead, error) = elements_until_error(&mut feed);
        let (plain, plain_error) = elements_until_error(&mut program_feed(&text));
        assert!(ahead.len() >= 19 && ahead == plain, "{} elements, without reading ahead {}", ahead.len(), plain.len());
        assert_eq!(error, plain_error);
        assert!(error.to_string().contains("t.ngc:23:"), "{error}");
    }

    fn elements_until_error(feed: &mut PathFeed) -> (Vec<Element>, FeedError) {
        let mut got = Vec::new();
        loop {
            match feed.element(got.len()) {
                Ok(Some(e)) => got.push(e.clone()),
                Ok(None) => panic!("the error of line 23 was lost after {} elements", got.len()),
                Err(e) => return (got, e),
            }
        }
    }

    #[test]
    fn a_program_continued_by_appends_is_not_read_ahead() {
        let config = Config::default_machine();
        let tooling = Arc::new(Tooling { tools: config.tools.clone(), work_offsets: config.work_offsets.clone() });
        let text = ProgramText::Text { name: "t.ngc".into(), text: Arc::new("G21 G90\nG1 F600 X1\nX2\n".to_string()) };
        let appends = Some(Arc::new(AppendBuffer::new(1 << 20)));
        let source = PathSource::Program { text, here: [0.0; interpd_motion::path::MAX_AXES], tooling, appends };
        let mut feed = PathFeed::open(source, &Settings::from_config(&config)).expect("open");
        assert!(!feed.can_read_ahead(100.0));
        assert!(!feed.read_ahead(100.0, Instant::now() + Duration::from_secs(10)));
    }
}
