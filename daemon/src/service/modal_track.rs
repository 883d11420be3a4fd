//! The tool and offset state along the running program, for `status.modal`: the changes the
//! look-ahead thread has read (keyed by the source line they apply from), resolved against the
//! line the machine executes. The real-time thread carries nothing new: every setpoint already
//! has its program line. Changes the machine has passed are dropped as the path behind it is,
//! so the track holds at most one change per element read ahead (see
//! `interpd_motion::program::ActiveModal`).

use interpd_motion::program::{ActiveModal, CompSide};
use interpd_protocol::api::{CutterMode, CutterStatus, ProgramModal, SpindleTool, ToolLength};
use std::collections::VecDeque;

/// Changes of the tool and offset state, oldest first.
#[derive(Debug, Default)]
pub struct ModalTrack {
    /// (first source line, state from there on), lines increasing.
    changes: VecDeque<(u32, ActiveModal)>,
}

impl ModalTrack {
    /// Forgets everything (a new program starts).
    pub fn clear(&mut self) {
        self.changes.clear();
    }

    /// A change read by the look-ahead thread.
    pub fn push(&mut self, line: u32, state: ActiveModal) {
        debug_assert!(self.changes.back().is_none_or(|(l, _)| *l <= line), "lines increase along a program");
        self.changes.push_back((line, state));
    }

    /// The machine is at or past source line `line`: only the change in effect there and
    /// later ones are kept.
    pub fn passed(&mut self, line: u32) {
        while self.changes.len() >= 2 && self.changes[1].0 <= line {
            self.changes.pop_front();
        }
    }

    /// The state in effect at source line `line` (the first one for lines before it).
    pub fn at(&self, line: u32) -> Option<&ActiveModal> {
        let i = self.changes.partition_point(|(l, _)| *l <= line);
        self.changes.get(i.saturating_sub(1)).map(|(_, s)| s)
    }

    /// Changes held.
    pub fn len(&self) -> usize {
        self.changes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.changes.is_empty()
    }
}

/// `status.modal` of `state` at program line `line`, for a machine of `n_axes` axes.
pub fn to_status(state: &ActiveModal, line: u32, n_axes: usize) -> ProgramModal {
    let cutter = match state.cutter {
        None => CutterStatus::default(),
        Some(c) => CutterStatus {
            mode: match c.side {
                CompSide::Left => CutterMode::Left,
                CompSide::Right => CutterMode::Right,
            },
            radius_mm: c.radius_mm,
            tool: c.tool,
        },
    };
    ProgramModal {
        line,
        work_offset: state.work_system_name().to_string(),
        work_offset_values: state.work_offset[..n_axes].to_vec(),
        g92_offset: state.g92_offset[..n_axes].to_vec(),
        tool: state.tool.map(|t| SpindleTool { number: t.number, length_mm: t.length_mm, radius_mm: t.radius_mm }),
        tool_length: state.tool_length.map(|(tool, length_mm)| ToolLength { tool, length_mm }),
        cutter,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_motion::path::MAX_AXES;

    fn state(work_system: usize) -> ActiveModal {
        ActiveModal {
            work_system,
            work_offset: [0.0; MAX_AXES],
            g92_offset: [0.0; MAX_AXES],
            tool: None,
            tool_length: None,
            cutter: None,
        }
    }

    #[test]
    fn lines_resolve_to_the_change_in_effect_and_passed_ones_go() {
        let mut t = ModalTrack::default();
        assert!(t.at(3).is_none());
        t.push(0, state(0));
        t.push(5, state(1));
        t.push(9, state(2));
        assert_eq!(t.at(0).map(|s| s.work_system), Some(0));
        assert_eq!(t.at(4).map(|s| s.work_system), Some(0));
        assert_eq!(t.at(5).map(|s| s.work_system), Some(1));
        assert_eq!(t.at(100).map(|s| s.work_system), Some(2));
        t.passed(6);
        assert_eq!(t.len(), 2);
        assert_eq!(t.at(6).map(|s| s.work_system), Some(1));
        t.passed(100);
        assert_eq!(t.len(), 1);
        assert_eq!(t.at(3).map(|s| s.work_system), Some(2), "before the first held: the first");
    }
}
