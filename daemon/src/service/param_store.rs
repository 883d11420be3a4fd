//! The configured parameter file (`[programs] parameter_file`, LinuxCNC's `.var` format): the
//! work offsets G54 … G59 are read from it at start-up (over `[work_offsets]`), and written to
//! it whenever they change for good: by `offsets.set`, and at the end of a program whose G10
//! L2/L20 changed them. Lines of other parameters are kept as they are.

use interpd_config::{AxisConfig, WORK_SYSTEMS, WorkOffsetsConfig};
use interpd_motion::path::AxisVec;
use interpd_motion::program::{ParamFile, ParamFileError};
use std::path::PathBuf;
use std::sync::Mutex;

/// The file and what it holds now.
pub struct ParamStore {
    path: PathBuf,
    file: Mutex<ParamFile>,
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

    /// `offsets` with the file's values where it has them.
    pub fn apply(&self, offsets: &mut WorkOffsetsConfig, axes: &[AxisConfig]) {
        let file = super::lock(&self.file);
        for (sys, map) in offsets.systems_mut().into_iter().enumerate() {
            for (a, v) in axes.iter().zip(file.work_offsets(sys, axes)) {
                if let Some(v) = v {
                    map.insert(a.name.to_string(), v);
                }
            }
        }
    }

    /// Writes `offsets` (every system, every axis of the machine) to the file, if they differ
    /// from what it holds.
    pub fn save(&self, offsets: &WorkOffsetsConfig, axes: &[AxisConfig]) -> std::io::Result<()> {
        let mut file = super::lock(&self.file);
        let mut next = file.clone();
        for sys in 0..WORK_SYSTEMS.len() {
            next.set_work_offsets(sys, axes, &offsets.vector(sys, axes)[..axes.len()]);
        }
        if next == *file {
            return Ok(());
        }
        next.save(&self.path)?;
        *file = next;
        tracing::info!(file = %self.path.display(), "parameter file written");
        Ok(())
    }
}

/// The work offsets G54 … G59 a program left (`origins` per machine axis, G59.1 … G59.3
/// dropped: `offsets.set` and `[work_offsets]` have only these six).
pub fn offsets_of(origins: &[AxisVec], axes: &[AxisConfig]) -> WorkOffsetsConfig {
    let mut out = WorkOffsetsConfig::default();
    for (map, origin) in out.systems_mut().into_iter().zip(origins) {
        for (a, v) in axes.iter().zip(origin) {
            map.insert(a.name.to_string(), *v);
        }
    }
    out
}

/// The same offsets, whatever axes a map leaves out (read as 0).
pub fn same_offsets(a: &WorkOffsetsConfig, b: &WorkOffsetsConfig, axes: &[AxisConfig]) -> bool {
    (0..WORK_SYSTEMS.len()).all(|sys| a.vector(sys, axes) == b.vector(sys, axes))
}
