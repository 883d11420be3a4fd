//! `program.load`: reading, parsing and preparing a program in the control thread that asked
//! (never near the real-time thread), then installing it if the state still allows.
//!
//! A program is either G-code or a path table, checked here in one streaming pass and read
//! again as the motion runs (smoothed and planned as it goes through an `interpd_motion::Feed`),
//! or a program of
//! `LAW` statements, whose moves are made and checked from where the machine stands (again at
//! every start).

use super::feeder::{FileStamp, ProgramText};
use super::law_run::{self, LawProgram};
use super::state::Loaded;
use super::{ServiceCore, lock};
use crate::control::{LoadError, ProgramSource};
use interpd_motion::law::LawMove;
use interpd_motion::program;
use interpd_protocol::api::{Method, ProgramInfo};
use std::borrow::Cow;
use std::sync::Arc;

impl ServiceCore {
    pub(super) fn load_program(&self, source: ProgramSource, open: bool) -> Result<ProgramInfo, LoadError> {
        let shared = &self.shared;
        lock(&shared.control).check(Method::ProgramLoad)?;
        // The name is the path as given; the file read is the one inside the programs directory.
        let (name, source) = match source {
            ProgramSource::File(p) => (p.display().to_string(), ProgramSource::File(shared.programs.resolve(&p)?)),
            ProgramSource::Text { name, text } => (name.clone(), ProgramSource::Text { name, text }),
        };
        if let Some(laws) = law_program_of(&source, &name)? {
            return self.load_laws(name, laws).map(|(info, _)| info);
        }
        // Read with the tool table and work offsets as set now (`tools.set`, `offsets.set`);
        // the motion reads the program again with the same.
        let tooling = shared.tooling_now();
        let settings = tooling.apply(&shared.settings);
        // One streaming pass checks the whole program and keeps no geometry; the motion reads
        // it again, smoothing and planning as it goes (`interpd_motion::Feed`). Only a program
        // loaded open (and without an end) takes appended text; any other ends with its text.
        let buffer_bytes = shared.config.programs.append_buffer_bytes();
        let (checked, appends, text) = match source {
            ProgramSource::File(p) => {
                // Taken before reading: a file changed while it is read or later is refused at
                // the start.
                let stamp = FileStamp::of(&p);
                let (checked, appends) = if open {
                    program::check_open(&p, None, &settings, buffer_bytes)?
                } else {
                    (program::check(&p, &settings)?, None)
                };
                let stamp = stamp.map_err(|e| {
                    program::ProgramErrors(vec![program::ProgramError {
                        file: p.display().to_string(),
                        line: 0,
                        col: 0,
                        message: format!("cannot read: {e}"),
                    }])
                })?;
                (checked, appends, ProgramText::File { path: p, stamp })
            }
            ProgramSource::Text { name, text } => {
                let (checked, appends) = if open {
                    program::check_open(std::path::Path::new(&name), Some(text.clone()), &settings, buffer_bytes)?
                } else {
                    (program::check_text(text.clone(), &name, &settings)?, None)
                };
                (checked, appends, ProgramText::Text { name, text: Arc::new(text) })
            }
        };
        let info = ProgramInfo {
            name,
            elements: checked.elements,
            length_mm: checked.length_mm,
            lines: checked.summary.lines,
            program_end: checked.summary.program_end,
            tools: checked.summary.tools.iter().copied().collect(),
            work_offsets: checked.summary.work_offsets.iter().map(|s| s.to_string()).collect(),
            cutter_compensation: checked.summary.compensation,
        };
        let mut ctl = lock(&shared.control);
        // The state may have changed while the program was checked.
        ctl.check(Method::ProgramLoad)?;
        let offsets_end =
            checked.persistent_end.map(|end| Arc::new(super::param_store::Kept::of_program(&end, &shared.config.axes)));
        ctl.loaded(info.clone(), Loaded::Program { text, tooling, appends, offsets_end });
        Ok(info)
    }

    /// `program.load` of a law program: the moves are made and checked from where the machine
    /// stands now (and again at `motion.start`, from where it stands then).
    /// Returns the program's info and the moves' total duration.
    pub(super) fn load_laws(&self, name: String, laws: LawProgram) -> Result<(ProgramInfo, f64), LoadError> {
        let shared = &self.shared;
        let here = shared.live.load().pos;
        let moves = laws.moves(&shared.settings, &here, &name)?;
        let duration_s = moves.iter().map(LawMove::duration_s).sum();
        let (path, _) = law_run::law_path(&shared.settings, moves, here, &laws.lines());
        let info = ProgramInfo {
            name,
            elements: laws.blocks.len() as u64,
            length_mm: path.length_mm(),
            lines: laws.blocks.last().map_or(0, |(n, _)| *n),
            program_end: true,
            ..ProgramInfo::default()
        };
        let mut ctl = lock(&shared.control);
        ctl.check(Method::ProgramLoad)?;
        ctl.loaded(info.clone(), Loaded::Laws(Arc::new(laws)));
        Ok((info, duration_s))
    }
}

/// The law program in `source` (named `name` in messages), if it is one (see
/// [`law_run::parse_law_program`]). A file is scanned line by line first, so a long G-code
/// program is never read whole.
fn law_program_of(source: &ProgramSource, name: &str) -> Result<Option<LawProgram>, LoadError> {
    let text = match source {
        ProgramSource::Text { text, .. } => Cow::Borrowed(text.as_str()),
        ProgramSource::File(p) => {
            let Ok(file) = std::fs::File::open(p) else { return Ok(None) };
            if !law_run::has_law_statement(std::io::BufReader::new(file)) {
                return Ok(None);
            }
            match std::fs::read_to_string(p) {
                Ok(t) => Cow::Owned(t),
                // Unreadable or not text: the program reader reports it.
                Err(_) => return Ok(None),
            }
        }
    };
    Ok(law_run::parse_law_program(&text, name)?)
}
