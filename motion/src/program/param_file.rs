//! LinuxCNC's parameter file (its `.var` file): the numbered parameters a machine keeps from
//! run to run, one `NUMBER VALUE` pair a line, numbers increasing. interpd reads and writes the
//! work offsets G54 … G59 in it (#5221 + 20·k + slot, slot 0 … 8 = X Y Z A B C U V W, as
//! LinuxCNC numbers them); every other line is kept as it is when the file is written again.
//!
//! Writing is atomic: the new text goes to a temporary file beside it, is flushed to the disk
//! and renamed over the old one, so a crash leaves either the old file or the new one.

use crate::path::MAX_AXES;
use interpd_config::{AxisConfig, AxisLetter};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// Highest parameter number (as the interpreter's store).
const MAX_NUMBER: usize = super::params::MAX_NUMBERED;
/// `#5221`: G54's X; each further system adds [`WORK_STRIDE`].
const WORK_BASE: usize = 5221;
/// Parameters per work system (9 axes, the rotation, 10 unused).
const WORK_STRIDE: usize = 20;

/// A parameter file's values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParamFile {
    values: BTreeMap<usize, f64>,
}

/// Why a parameter file cannot be used: the file, the line (0 for the whole file) and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter file {file}:{line}: {message}")]
pub struct ParamFileError {
    pub file: String,
    pub line: usize,
    pub message: String,
}

impl ParamFile {
    /// Reads `text` (named `file` in errors): blank lines are skipped; every other line is a
    /// parameter number 1 … 5602 and a finite value, numbers increasing (LinuxCNC refuses a
    /// file out of order too).
    pub fn parse(text: &str, file: &str) -> Result<ParamFile, ParamFileError> {
        let err = |line: usize, message: String| ParamFileError { file: file.to_string(), line, message };
        let mut values = BTreeMap::new();
        let mut last = 0usize;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let mut words = raw.split_whitespace();
            let Some(first) = words.next() else { continue };
            let (Some(second), None) = (words.next(), words.next()) else {
                return Err(err(line, format!("expected a parameter number and its value, got {:?}", raw.trim())));
            };
            let n: usize = first
                .parse()
                .ok()
                .filter(|n| (1..=MAX_NUMBER).contains(n))
                .ok_or_else(|| err(line, format!("{first:?} is not a parameter number 1 … {MAX_NUMBER}")))?;
            let v: f64 = second
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| err(line, format!("the value of #{n}, {second:?}, is not a finite number")))?;
            if n <= last {
                return Err(err(line, format!("#{n} follows #{last}: the numbers must increase")));
            }
            last = n;
            values.insert(n, v);
        }
        Ok(ParamFile { values })
    }

    /// Reads the file at `path`; a file that does not exist is empty (a machine's first start).
    pub fn load(path: &Path) -> Result<ParamFile, ParamFileError> {
        let file = path.display().to_string();
        match std::fs::read_to_string(path) {
            Ok(text) => ParamFile::parse(&text, &file),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(ParamFile::default()),
            Err(e) => Err(ParamFileError { file, line: 0, message: format!("cannot read: {e}") }),
        }
    }

    pub fn get(&self, n: usize) -> Option<f64> {
        self.values.get(&n).copied()
    }

    pub fn set(&mut self, n: usize, v: f64) {
        self.values.insert(n, v);
    }

    /// The number of work system `system`'s (0 = G54) offset of axis `letter`.
    pub fn work_number(system: usize, letter: AxisLetter) -> usize {
        let slot = AxisLetter::ALL.iter().position(|l| *l == letter).unwrap_or(0);
        WORK_BASE + WORK_STRIDE * system + slot
    }

    /// The offsets of work system `system` in the file, per machine axis (`None` where the
    /// file has none).
    pub fn work_offsets(&self, system: usize, axes: &[AxisConfig]) -> [Option<f64>; MAX_AXES] {
        let mut out = [None; MAX_AXES];
        for (o, a) in out.iter_mut().zip(axes) {
            *o = self.get(Self::work_number(system, a.name));
        }
        out
    }

    /// Sets work system `system`'s offsets of the machine's axes.
    pub fn set_work_offsets(&mut self, system: usize, axes: &[AxisConfig], values: &[f64]) {
        for (a, v) in axes.iter().zip(values) {
            self.set(Self::work_number(system, a.name), *v);
        }
    }

    /// The file's text: one `NUMBER<TAB>VALUE` line per parameter, numbers increasing, each
    /// value written so that it reads back exactly.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for (n, v) in &self.values {
            s.push_str(&format!("{n}\t{v:?}\n"));
        }
        s
    }

    /// Writes the file at `path` atomically (a temporary file beside it, flushed, renamed).
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
        let write = || -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(self.to_text().as_bytes())?;
            f.sync_all()?;
            std::fs::rename(&tmp, path)
        };
        write().inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_linuxcnc_files_and_names_the_line_of_a_fault() {
        let f = ParamFile::parse("5161\t0.000000\n\n5241   5.5\n5242 -1e-3\n", "m.var").unwrap();
        assert_eq!((f.get(5161), f.get(5241), f.get(5242), f.get(5221)), (Some(0.0), Some(5.5), Some(-0.001), None));
        let e = |t: &str| ParamFile::parse(t, "m.var").unwrap_err().to_string();
        assert_eq!(e("5221 1\n5221 2\n"), "parameter file m.var:2: #5221 follows #5221: the numbers must increase");
        assert_eq!(e("5221 x\n"), "parameter file m.var:1: the value of #5221, \"x\", is not a finite number");
        assert_eq!(e("5221 nan\n"), "parameter file m.var:1: the value of #5221, \"nan\", is not a finite number");
        assert_eq!(e("\n9999 1\n"), "parameter file m.var:2: \"9999\" is not a parameter number 1 … 5602");
        assert_eq!(e("5221\n"), "parameter file m.var:1: expected a parameter number and its value, got \"5221\"");
        assert_eq!(
            e("5221 1 2\n"),
            "parameter file m.var:1: expected a parameter number and its value, got \"5221 1 2\""
        );
    }

    #[test]
    fn writes_what_it_reads_and_replaces_the_file_whole() {
        let dir = std::env::temp_dir().join(format!("interpd-param-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.var");
        assert_eq!(ParamFile::load(&path).unwrap(), ParamFile::default(), "a missing file is empty");
        let mut f = ParamFile::parse("5161 1.5\n5400 7\n", "m.var").unwrap();
        assert_eq!(ParamFile::work_number(1, AxisLetter::X), 5241);
        assert_eq!(ParamFile::work_number(8, AxisLetter::W), 5389);
        f.set(5241, 0.1 + 0.2);
        f.save(&path).unwrap();
        let back = ParamFile::load(&path).unwrap();
        assert_eq!(back, f);
        assert_eq!(back.get(5241), Some(0.1 + 0.2), "exactly");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "no temporary file left");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
