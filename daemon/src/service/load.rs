//! `program.load`: reading, parsing and preparing a program in the control thread that asked
//! (never near the real-time thread), then installing it if the state still allows.
//!
//! A program is either G-code or a path table, prepared into a path (with the tolerance-band
//! smoothing of its G64 runs), or a program of `LAW` statements, whose moves are made and
//! checked from where the machine stands (again at every start).

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
    pub(super) fn load_program(&self, source: ProgramSource) -> Result<ProgramInfo, LoadError> {
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
        // The tool table and work offsets as set now (`tools.set`, `offsets.set`).
        let settings = shared.program_settings();
        let parsed = match &source {
            ProgramSource::File(p) => program::load(p, &settings),
            ProgramSource::Text { text, .. } => program::parse(text, &name, &settings),
        };
        let prog = parsed?;
        // Tolerance-band smoothing (G64 P…) of the whole program, here in the control thread:
        // it runs ahead of the planner and never near the real-time thread.
        let prepared = interpd_motion::prep::prepare_path(&shared.settings, &prog.path)
            .map_err(|error| LoadError::Prep { program: name.clone(), error })?;
        if prepared.stats.windows > 0 {
            tracing::info!(
                program = %name,
                windows = prepared.stats.windows,
                wall_ms = prepared.wall_s * 1e3,
                "path smoothing (G64) prepared"
            );
        }
        let info = ProgramInfo {
            name,
            elements: prepared.path.elements.len() as u64,
            length_mm: prepared.path.length_mm(),
            lines: prog.summary.lines,
            tools: prog.summary.tools.iter().copied().collect(),
            work_offsets: prog.summary.work_offsets.iter().map(|s| s.to_string()).collect(),
            cutter_compensation: prog.summary.compensation,
        };
        let mut ctl = lock(&shared.control);
        // The state may have changed while the program was prepared.
        ctl.check(Method::ProgramLoad)?;
        ctl.loaded(info.clone(), Loaded::Path(Arc::new(prepared.path)));
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
            ..ProgramInfo::default()
        };
        let mut ctl = lock(&shared.control);
        ctl.check(Method::ProgramLoad)?;
        ctl.loaded(info.clone(), Loaded::Laws(Arc::new(laws)));
        Ok((info, duration_s))
    }
}

/// The law program in `source` (named `name` in messages), if it is one (see
/// [`law_run::parse_law_program`]).
fn law_program_of(source: &ProgramSource, name: &str) -> Result<Option<LawProgram>, LoadError> {
    let text = match source {
        ProgramSource::Text { text, .. } => Cow::Borrowed(text.as_str()),
        ProgramSource::File(p) => match std::fs::read_to_string(p) {
            Ok(t) => Cow::Owned(t),
            // Unreadable or not text: the program reader reports it.
            Err(_) => return Ok(None),
        },
    };
    Ok(law_run::parse_law_program(&text, name)?)
}
