//! Runs along a path: a loaded program, read, smoothed and planned as the motion goes through
//! an [`interpd_motion::Feed`], or a path made whole (MDI blocks). Each chunk takes about a
//! chunk's duration of planned segments and the fastest stop from its end as its tail.

use super::run::{Motion, PAUSE_AT_MM, PathRun};
use super::{Feeder, STARVED_STOP_CHUNKS};
use crate::interp::coarse::{CoarseBuilder, CoarsePoint};
use crate::interp::{Chunk, ChunkMessage, ChunkPause};
use crate::service::tooling::Tooling;
use interpd_motion::Segment;
use interpd_motion::path::{AxisVec, Path, Pause, StopCode};
use interpd_motion::program::Appends;
use interpd_motion::{Feed, FeedError};
use interpd_protocol::api::PauseCode;
use std::sync::Arc;
use std::time::SystemTime;

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

/// What a run plans along.
#[derive(Debug, Clone)]
pub enum PathSource {
    /// A path made whole (MDI blocks, law moves).
    Whole(Arc<Path>),
    /// A loaded program, read and smoothed as the motion goes, preceded by a straight rapid
    /// move from `here` to its start when the machine stands elsewhere, read with the tool table
    /// and work offsets it was loaded with; a program without an end continues with the text
    /// appended to `appends`.
    Program { text: ProgramText, here: AxisVec, tooling: Arc<Tooling>, appends: Option<Appends> },
}

/// Why a run's program cannot be opened.
#[derive(Debug, thiserror::Error)]
pub(super) enum OpenError {
    #[error("{name}: the file changed after program.load; load it again")]
    Changed { name: String },
    #[error("{name}: cannot read: {source}")]
    Unreadable {
        name: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Feed(#[from] FeedError),
}

/// How much higher the nice value of the thread that reads a program ahead is than that of the
/// look-ahead thread that spawns it (`rt.planner_nice`, -10 by default, so -5). Planning is what
/// the queue waits for; reading works a look-ahead ahead, and where it falls behind the planner
/// waits for it and leaves it the CPU. At the planner's own value the two shared the CPU evenly
/// and plan calls on the cusp trochoid took up to 247 ms (4 underruns); at the default nice
/// value 0 it fell behind the plant and the test harness of a loaded host (the million-line
/// program underran 57 cycles at the end of its first rapid).
const READER_NICE_ABOVE_PLANNER: i32 = 5;

/// Runs first in the thread that reads a program ahead ([`interpd_motion::FeedBuilder::read_in_thread`]).
fn reader_thread_start() {
    let nice = (crate::rt::sched::thread_nice() + READER_NICE_ABOVE_PLANNER).min(19);
    match crate::rt::sched::set_thread_nice(nice) {
        Ok(()) => tracing::debug!(nice, "program reading thread scheduled"),
        Err(why) => tracing::warn!("program reading thread keeps the planner's nice value: {why}"),
    }
}

impl Feeder {
    /// The path of `source`: a program's file is opened and checked to be the one loaded.
    pub(super) fn open_path(&self, source: PathSource, feed_override: f64) -> Result<PathRun, OpenError> {
        let (text, here, tooling, appends) = match source {
            PathSource::Whole(path) => {
                let feed = Feed::builder(&self.settings).feed_override(feed_override).whole(Arc::unwrap_or_clone(path));
                return Ok(PathRun::new(feed, None));
            }
            PathSource::Program { text, here, tooling, appends } => (text, here, tooling, appends),
        };
        let settings = tooling.apply(&self.settings);
        let mut builder = Feed::builder(&settings).start_from(here).feed_override(feed_override).track_modal();
        match &appends {
            Some(a) => builder = builder.appends(a),
            // The program is read and smoothed ahead in a thread of its own: a look-ahead step
            // then plans and never waits for a window solve of the smoothing stage.
            None => builder = builder.read_in_thread(reader_thread_start),
        }
        let feed = match &text {
            ProgramText::File { path, stamp } => {
                let name = path.display().to_string();
                match FileStamp::of(path) {
                    Ok(now) if now == *stamp => {}
                    Ok(_) => return Err(OpenError::Changed { name }),
                    Err(source) => return Err(OpenError::Unreadable { name, source }),
                }
                builder.open_file(path)?
            }
            ProgramText::Text { name, text } => builder.open_text(name, text.as_str())?,
        };
        Ok(PathRun::new(feed, Some(self.modal.clone())).with_messages(self.messages.clone()))
    }

    /// Fills `chunk` with the next stretch of the path's planned motion (about one chunk
    /// duration, longer where no stop can follow its end); `Ok(false)` when nothing is left.
    pub(super) fn fill_path_chunk(&mut self, chunk: &mut Chunk) -> Result<bool, FeedError> {
        let chunk_s = self.chunk_s;
        let max_piece_s = 2.0 * self.cycle_s;
        // While the queue runs low, a program waiting for appended text is planned to rest at
        // the end of what is there.
        let rest_at_text_end = self.queues.chunks.len() <= STARVED_STOP_CHUNKS;
        let Some(run) = self.run.as_mut() else { return Ok(false) };
        run.open_chunk(chunk);
        let Motion::Path(path) = &mut run.motion else { return Ok(false) };
        let mut segments = Vec::new();
        let mut t = 0.0;
        let mut target = chunk_s;
        let tail = loop {
            let planned =
                if rest_at_text_end { path.feed.plan_or_rest(target - t) } else { path.feed.plan(target - t) };
            path.track_modal();
            planned?;
            t += path.feed.take(target - t, &mut segments);
            let Some(last) = segments.last() else { return Ok(false) };
            let end = last.at(last.dt_s);
            if path.feed.exhausted() {
                break Vec::new();
            }
            if let Some(stop) = path.feed.stop_from(end.s_mm, end.v, end.a, last.line) {
                break stop;
            }
            // No stop from here: end the chunk a little later.
            self.stats.tail_retries += 1;
            target = t + 0.25 * chunk_s;
        };
        let stops = program_stops(path.feed.path(), &segments, &mut run.pause_armed_mm);
        let mut builder = CoarseBuilder::new(path.feed.path(), max_piece_s, &self.max_jerk);
        // Each program stop and message place gets a coarse point of its own: the executor
        // stands exactly there, or reports the messages there.
        let mut from = 0;
        let chunk_time = |points: &Vec<CoarsePoint>| points.last().map_or(0.0, |p| p.t_s);
        for (k, pause) in stops {
            builder.build(&segments[from..k], chunk_time(&chunk.points), &mut chunk.points);
            let point = chunk.points.len().saturating_sub(1);
            if pause.messages_before > 0 {
                let after_pauses = chunk.pauses.len();
                chunk.messages.push(ChunkMessage { point, upto: pause.messages_before, after_pauses });
            }
            if let Some(code) = pause.stop {
                let code = match code {
                    StopCode::Stop => PauseCode::M0,
                    StopCode::Optional => PauseCode::M1,
                    StopCode::PalletShuttle => PauseCode::M60,
                };
                chunk.pauses.push(ChunkPause { point, code, line: pause.stop_line });
            }
            if pause.messages_after > 0 {
                let after_pauses = chunk.pauses.len();
                chunk.messages.push(ChunkMessage { point, upto: pause.messages_after, after_pauses });
            }
            from = k;
        }
        builder.build(&segments[from..], chunk_time(&chunk.points), &mut chunk.points);
        let end = *chunk.points.last().expect("points");
        chunk.last = path.feed.finished();
        if !tail.is_empty() {
            chunk.tail.push(CoarsePoint { t_s: 0.0, ..end });
            builder.build(&tail, 0.0, &mut chunk.tail);
        }
        self.stats.max_coarse_error_mm = self.stats.max_coarse_error_mm.max(builder.max_error_mm);
        run.close_chunk(end, tail);
        Ok(true)
    }
}

/// Path velocity counted as rest at a program stop, mm/s.
const PAUSE_V_MM_S: f64 = 1e-9;

/// The planned pauses (program stops M0, M1, M60 and operator messages) the planned `segments`
/// reach, after `armed_mm` (moved past each one found): the index of the segment that starts
/// there and the pause. The planner plans a stop at rest before such an element, so a segment
/// starts there.
fn program_stops(path: &Path, segments: &[Segment], armed_mm: &mut f64) -> Vec<(usize, Pause)> {
    let mut stops = Vec::new();
    let Some(last) = segments.last() else { return stops };
    let end_mm = last.s1_mm();
    let first = path.elements.partition_point(|e| e.s_start_mm <= *armed_mm);
    for e in &path.elements[first..] {
        if e.s_start_mm > end_mm + PAUSE_AT_MM {
            break;
        }
        let Some(pause) = e.pause_before else { continue };
        // The first segment from rest there (a sliver of the braking before may start within
        // the tolerance too).
        let near = |g: &Segment| (g.s0_mm - e.s_start_mm).abs() <= PAUSE_AT_MM;
        let at = segments
            .iter()
            .position(|g| near(g) && g.v0.abs() <= PAUSE_V_MM_S)
            .or_else(|| segments.iter().position(near));
        match at {
            Some(k) => {
                stops.push((k, pause));
                *armed_mm = e.s_start_mm;
            }
            // The segments end at the stop: the next chunk's first one starts there.
            None if e.s_start_mm >= end_mm - PAUSE_AT_MM => break,
            None => {
                tracing::warn!(
                    line = e.source.line,
                    s_mm = e.s_start_mm,
                    "a program stop the plan does not stop at: passed"
                );
                *armed_mm = e.s_start_mm;
            }
        }
    }
    stops
}
