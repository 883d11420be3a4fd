//! M70 … M73: LinuxCNC's saved modal state (`save_settings` and `restore_settings` of its
//! `interp_convert.cc`), our own code. M70 saves the modal state at the current call level,
//! M71 forgets it, M72 restores it, M73 saves it to be restored when the subroutine returns.
//!
//! Restored, as LinuxCNC restores them: units, plane, distance mode, feed mode and feed, path
//! control (G61/G64 with its tolerance), coordinate system, tool length compensation and the
//! canned cycle return mode; not the motion mode, nor the G92 offsets. Spindle and coolant modes are ignored here
//! as everywhere in interpd.

use super::{Interpreter, Plane};
use crate::path::Blend;
use crate::program::error::Diagnostics;

/// The modal state M70/M73 save.
#[derive(Debug, Clone)]
pub(crate) struct SavedModal {
    unit_mm: f64,
    plane: Plane,
    absolute: bool,
    inverse_time: bool,
    feed_mm_s: Option<f64>,
    blend: Blend,
    work_system: usize,
    tool_length: Option<(Option<u32>, f64)>,
    tool_offset: crate::path::AxisVec,
    retract_r: bool,
    /// Cutter compensation was on: it is not restored, so a restore into another state is an
    /// error.
    comp_on: bool,
    /// M73: restored when the subroutine of its level returns.
    auto: bool,
}

/// The saved states, by call level.
#[derive(Debug, Clone, Default)]
pub(crate) struct Contexts {
    levels: Vec<Option<SavedModal>>,
}

impl Interpreter {
    /// M70 (save), M71 (forget), M72 (restore), M73 (save, restored at the return), at column
    /// `col`. False after an error.
    pub(in crate::program) fn modal_context(&mut self, code: i64, col: u32, line: u32, d: &mut Diagnostics) -> bool {
        let level = self.flow.depth();
        if self.contexts.levels.len() <= level {
            self.contexts.levels.resize(level + 1, None);
        }
        match code {
            70 | 73 => {
                let m = &self.modal;
                self.contexts.levels[level] = Some(SavedModal {
                    unit_mm: m.unit_mm,
                    plane: m.plane,
                    absolute: m.absolute,
                    inverse_time: m.inverse_time,
                    feed_mm_s: m.feed_mm_s,
                    blend: m.blend,
                    work_system: m.work_system,
                    tool_length: m.tool_length,
                    tool_offset: m.tool_offset,
                    retract_r: self.cycle.retract_r,
                    comp_on: self.cutter.is_on(),
                    auto: code == 73,
                });
                true
            }
            71 => {
                self.contexts.levels[level] = None;
                true
            }
            _ => {
                let Some(saved) = self.contexts.levels[level].clone() else {
                    d.error(line, col, "M72 without a state saved by M70 (or M73) at this call level");
                    return false;
                };
                self.restore_modal(&saved, "M72", line, col, d)
            }
        }
    }

    /// Leaving the call level `level` (its subroutine returned): an M73 state saved there is
    /// restored, and every state saved there is gone.
    pub(in crate::program) fn leave_context_level(&mut self, level: usize, line: u32, col: u32, d: &mut Diagnostics) {
        if self.contexts.levels.len() <= level {
            return;
        }
        let saved = self.contexts.levels[level].take();
        self.contexts.levels.truncate(level);
        if let Some(saved) = saved.filter(|s| s.auto) {
            self.restore_modal(&saved, "M73", line, col, d);
        }
    }

    fn restore_modal(&mut self, saved: &SavedModal, what: &str, line: u32, col: u32, d: &mut Diagnostics) -> bool {
        if saved.comp_on != self.cutter.is_on() {
            d.error(
                line,
                col,
                format!("{what}: cutter compensation was switched since the state was saved; it is not restored (program G40/G41/G42 again)"),
            );
            return false;
        }
        let m = &mut self.modal;
        m.unit_mm = saved.unit_mm;
        m.plane = saved.plane;
        m.absolute = saved.absolute;
        m.inverse_time = saved.inverse_time;
        m.feed_mm_s = saved.feed_mm_s;
        m.blend = saved.blend;
        m.work_system = saved.work_system;
        m.tool_length = saved.tool_length;
        m.tool_offset = saved.tool_offset;
        self.cycle.retract_r = saved.retract_r;
        true
    }
}
