//! LinuxCNC's parameter file (its `.var` file): the numbered parameters a machine keeps from
//! run to run, one `NUMBER VALUE` pair a line, numbers increasing. interpd reads and writes in
//! it, as LinuxCNC numbers them (slot 0 … 8 = X Y Z A B C U V W):
//!
//! - the G28 and G30 positions, #5161 + slot and #5181 + slot;
//! - the work offsets G54 … G59.3, #5221 + 20·k + slot (k = 0 … 8), and their rotations about
//!   Z, #5230 + 20·k.
//!
//! Every other line is kept as it is when the file is written again.
//!
//! Writing is atomic: the new text goes to a temporary file beside it, is flushed to the disk
//! and renamed over the old one, so a crash leaves either the old file or the new one.

use super::params::Params;
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
/// The rotation's place in a work system's parameters (#5230 for G54).
const ROTATION_SLOT: usize = 9;
/// `#5161` and `#5181`: the X of the G28 and the G30 position.
pub(crate) const HOME_BASE: [usize; 2] = [5161, 5181];

/// The G28 and G30 positions (#5161–#5169, #5181–#5189), X … W in machine units (mm, deg):
/// what a program starts with (0 unless a parameter file keeps them) and what it leaves.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HomePositions {
    /// Index 0: G28 (G28.1 sets it); 1: G30 (G30.1).
    pub slots: [[f64; 9]; 2],
}

impl HomePositions {
    /// A fresh parameter store that starts with these positions.
    pub(super) fn params(&self) -> Params {
        let mut p = Params::default();
        for (base, values) in HOME_BASE.iter().zip(&self.slots) {
            for (slot, v) in values.iter().enumerate() {
                p.set_numbered(base + slot, *v);
            }
        }
        p
    }

    /// The positions `params` holds now (what G28.1/G30.1 or an assignment left).
    pub(super) fn of(params: &Params) -> Self {
        let mut h = HomePositions::default();
        for (base, values) in HOME_BASE.iter().zip(&mut h.slots) {
            for (slot, v) in values.iter_mut().enumerate() {
                *v = params.stored(base + slot);
            }
        }
        h
    }
}

/// What a program leaves that a parameter file keeps (#5161–#5390 but G92's).
#[derive(Debug, Clone, PartialEq)]
pub struct Persistent {
    /// The origins of G54 … G59.3 per machine axis.
    pub work_origins: [crate::path::AxisVec; 9],
    /// Their rotations about Z, degrees.
    pub work_rotations_deg: [f64; 9],
    pub home_positions: HomePositions,
}

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
        WORK_BASE + WORK_STRIDE * system + slot_of(letter).unwrap_or(0)
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

    /// The number of work system `system`'s rotation (#5230 for G54).
    pub fn rotation_number(system: usize) -> usize {
        WORK_BASE + WORK_STRIDE * system + ROTATION_SLOT
    }

    /// The G28/G30 positions in the file, on the slots of the machine's axes (`None` where the
    /// file has none).
    pub fn home_positions(&self, axes: &[AxisConfig]) -> [[Option<f64>; 9]; 2] {
        let mut out = [[None; 9]; 2];
        for (which, base) in HOME_BASE.iter().enumerate() {
            for slot in axes.iter().filter_map(|a| slot_of(a.name)) {
                out[which][slot] = self.get(base + slot);
            }
        }
        out
    }

    /// Sets the G28/G30 positions of the machine's axes (other slots are left as they are).
    pub fn set_home_positions(&mut self, axes: &[AxisConfig], homes: &HomePositions) {
        for (which, base) in HOME_BASE.iter().enumerate() {
            for slot in axes.iter().filter_map(|a| slot_of(a.name)) {
                self.set(base + slot, homes.slots[which][slot]);
            }
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

/// LinuxCNC's parameter slot of an axis letter (X = 0 … W = 8).
fn slot_of(letter: AxisLetter) -> Option<usize> {
    AxisLetter::ALL.iter().take(9).position(|l| *l == letter)
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
        assert_eq!((ParamFile::rotation_number(0), ParamFile::rotation_number(7)), (5230, 5370));
        f.set(5241, 0.1 + 0.2);
        f.save(&path).unwrap();
        let back = ParamFile::load(&path).unwrap();
        assert_eq!(back, f);
        assert_eq!(back.get(5241), Some(0.1 + 0.2), "exactly");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "no temporary file left");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[cfg(test)]
mod home_tests {
    use super::*;

    #[test]
    fn a_program_starts_with_the_kept_values_and_leaves_what_it_changed() {
        let mut s = crate::Settings::default_machine();
        s.home_positions.slots[0][..3].copy_from_slice(&[7.0, 8.0, 9.0]);
        s.work_offsets.g59_2.insert("X".to_string(), 5.0);
        s.work_offsets.set_rotation(7, 90.0);
        let text = "G0 X1\nG28\nG59.2 G0 X1 Y0\nG28.1\nG10 L2 P9 X2 R30\n#5183 = -1\nM2\n";
        let p = crate::program::parse(text, "t.ngc", &s).unwrap_or_else(|e| panic!("{e}"));
        let at = |i: usize| {
            let g = &p.path.elements[i].geometry;
            let mut d = crate::path::AxisDerivs::default();
            g.eval(g.length_mm(), &mut d);
            [d.pos[0], d.pos[1], d.pos[2]]
        };
        assert_eq!(at(1), [7.0, 8.0, 9.0], "G28 goes to the kept G28 position");
        let g59_2 = at(2);
        assert!((g59_2[0] - 5.0).abs() < 1e-12 && (g59_2[1] - 1.0).abs() < 1e-12, "G59.2 turned 90°: {g59_2:?}");
        let end = crate::program::check_text(text.to_string(), "t.ngc", &s).unwrap().persistent_end.unwrap();
        let g28 = end.home_positions.slots[0];
        assert!((g28[0] - 5.0).abs() < 1e-12 && (g28[1] - 1.0).abs() < 1e-12 && g28[2] == 9.0, "{g28:?}");
        assert_eq!(end.home_positions.slots[1][..3], [0.0, 0.0, -1.0], "#5183 assigned");
        assert_eq!((end.work_origins[8][0], end.work_rotations_deg[8]), (2.0, 30.0), "G59.3 as G10 L2 P9 set it");
        assert_eq!((end.work_origins[7][0], end.work_rotations_deg[7]), (5.0, 90.0), "G59.2 as it started");
        // Without kept values (no parameter file) G28 goes to machine zero, as before.
        let p = crate::program::parse("G0 X1\nG28\n", "t.ngc", &crate::Settings::default_machine()).unwrap();
        assert_eq!(p.path.end_position()[..3], [0.0, 0.0, 0.0]);
    }

    #[test]
    fn home_positions_are_5161_and_5181_on_the_machines_slots_only() {
        let axes = crate::Settings::default_machine().axes;
        let f = ParamFile::parse("5161 1\n5162 2\n5164 9\n5183 -3\n", "m.var").unwrap();
        let h = f.home_positions(&axes);
        assert_eq!(h[0][..4], [Some(1.0), Some(2.0), None, None], "A (#5164) is not an axis of X Y Z");
        assert_eq!(h[1][..3], [None, None, Some(-3.0)]);
        let mut g = f.clone();
        let mut homes = HomePositions::default();
        homes.slots[1][2] = 7.5;
        g.set_home_positions(&axes, &homes);
        assert_eq!((g.get(5161), g.get(5164), g.get(5183), g.get(5184)), (Some(0.0), Some(9.0), Some(7.5), None));
    }
}
