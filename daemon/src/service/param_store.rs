//! The configured parameter file (`[programs] parameter_file`, LinuxCNC's `.var` format): the
//! work offsets G54 … G59.3 with their rotations and the G28/G30 positions are read from it at
//! start-up (over `[work_offsets]`), and written to it whenever they change for good: by
//! `offsets.set`, and at the end of a program whose G10 L2/L20, G28.1/G30.1 (or assignments of
//! #5161 …) changed them. Lines of other parameters are kept as they are.

use interpd_config::{AxisConfig, WORK_SYSTEMS, WorkOffsetsConfig};
use interpd_motion::program::{HomePositions, ParamFile, ParamFileError, Persistent};
use std::path::PathBuf;
use std::sync::Mutex;

/// The file and what it holds now.
pub struct ParamStore {
    path: PathBuf,
    file: Mutex<ParamFile>,
}

/// What the parameter file keeps: the work offsets (with rotations) and the G28/G30
/// positions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Kept {
    pub work_offsets: WorkOffsetsConfig,
    pub home_positions: HomePositions,
}

impl Kept {
    /// What a program left (`end`, per machine axis and parameter slot).
    pub fn of_program(end: &Persistent, axes: &[AxisConfig]) -> Kept {
        let mut work_offsets = WorkOffsetsConfig::default();
        for (map, origin) in work_offsets.systems_mut().into_iter().zip(&end.work_origins) {
            for (a, v) in axes.iter().zip(origin) {
                map.insert(a.name.to_string(), *v);
            }
        }
        for (sys, deg) in end.work_rotations_deg.iter().enumerate() {
            work_offsets.set_rotation(sys, *deg);
        }
        Kept { work_offsets, home_positions: end.home_positions }
    }

    /// The same values on the machine's axes, whatever a map leaves out (read as 0).
    pub fn same_on(&self, other: &Kept, axes: &[AxisConfig]) -> bool {
        self.work_offsets.same_on(&other.work_offsets, axes) && self.home_positions == other.home_positions
    }
}

impl ParamStore {
    /// Reads the configured file (a missing one is empty); `None` without one.
    pub fn open(path: Option<&str>) -> Result<Option<ParamStore>, ParamFileError> {
        let Some(path) = path else { return Ok(None) };
        let path = PathBuf::from(path);
        let file = ParamFile::load(&path)?;
        tracing::info!(file = %path.display(), "parameter file read");
        Ok(Some(ParamStore { path, file: Mutex::new(file) }))
    }

    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// `kept` with the file's values where it has them.
    pub fn apply(&self, kept: &mut Kept, axes: &[AxisConfig]) {
        let file = super::lock(&self.file);
        for (sys, map) in kept.work_offsets.systems_mut().into_iter().enumerate() {
            for (a, v) in axes.iter().zip(file.work_offsets(sys, axes)) {
                if let Some(v) = v {
                    map.insert(a.name.to_string(), v);
                }
            }
        }
        for sys in 0..WORK_SYSTEMS.len() {
            if let Some(deg) = file.get(ParamFile::rotation_number(sys)) {
                kept.work_offsets.set_rotation(sys, deg);
            }
        }
        for (slots, file_slots) in kept.home_positions.slots.iter_mut().zip(file.home_positions(axes)) {
            for (v, f) in slots.iter_mut().zip(file_slots) {
                if let Some(f) = f {
                    *v = f;
                }
            }
        }
    }

    /// Writes `kept` (every system with its rotation, the G28/G30 positions, on every axis of
    /// the machine) to the file, if it differs from what the file holds.
    pub fn save(&self, kept: &Kept, axes: &[AxisConfig]) -> std::io::Result<()> {
        let mut file = super::lock(&self.file);
        let mut next = file.clone();
        let offsets = &kept.work_offsets;
        for sys in 0..WORK_SYSTEMS.len() {
            next.set_work_offsets(sys, axes, &offsets.vector(sys, axes)[..axes.len()]);
            next.set(ParamFile::rotation_number(sys), offsets.rotation(sys));
        }
        next.set_home_positions(axes, &kept.home_positions);
        if next == *file {
            return Ok(());
        }
        next.save(&self.path)?;
        *file = next;
        tracing::info!(file = %self.path.display(), "parameter file written");
        Ok(())
    }
}
