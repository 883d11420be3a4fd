//! The tool and offset state a program runs in, per stretch of the program: which work offset,
//! G92 offset, tool, tool length and cutter compensation the elements of a line are made with.
//!
//! The interpreter records a change only where the state changes, keyed by the source line
//! from which it applies (the modal words of a block apply to the block's own motion). An
//! element carries its source line, so whoever knows the line the machine executes finds the
//! state by the last change at or before it. A change is handed out only once an element
//! follows it: changes with no motion in between merge into one, so the changes waiting to be
//! taken never outnumber the elements read ahead.

use crate::path::AxisVec;
use std::collections::VecDeque;

/// Left or right of the direction of travel (G41 / G42).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompSide {
    Left,
    Right,
}

/// The tool in the spindle (the last `T` carried out by `M6`), with its values from the tool
/// table the program is read with (`None` when the table has no such tool).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveTool {
    pub number: u32,
    pub length_mm: Option<f64>,
    pub radius_mm: Option<f64>,
}

/// Active cutter radius compensation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveCutter {
    pub side: CompSide,
    pub radius_mm: f64,
    /// The tool of G41/G42 D; `None` for G41.1/G42.1 (the diameter given in the block).
    pub tool: Option<u32>,
}

/// The tool and offset state of a stretch of a program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveModal {
    /// 0 = G54 … 5 = G59, 6 … 8 = G59.1 … G59.3 ([`WORK_SYSTEM_NAMES`]).
    pub work_system: usize,
    /// The work offset of that system per axis (machine order), mm or deg.
    pub work_offset: AxisVec,
    /// The G92 offset per axis (zero without G92), added to every work offset.
    pub g92_offset: AxisVec,
    pub tool: Option<ActiveTool>,
    /// Tool length compensation: the tool (`None` for G43.1) and the length added to Z, mm.
    pub tool_length: Option<(Option<u32>, f64)>,
    /// `None` when compensation is off (G40).
    pub cutter: Option<ActiveCutter>,
}

/// The work coordinate systems by index: the six of the configuration (`[work_offsets]`) and
/// LinuxCNC's G59.1 … G59.3, which start at zero and are set by G10 L2/L20 in the program.
pub const WORK_SYSTEM_NAMES: [&str; 9] = ["G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"];

impl ActiveModal {
    /// The name of the active work coordinate system (`"G54"` …).
    pub fn work_system_name(&self) -> &'static str {
        WORK_SYSTEM_NAMES[self.work_system.min(WORK_SYSTEM_NAMES.len() - 1)]
    }
}

/// The changes of [`ActiveModal`] along a program, as the interpreter records them.
#[derive(Debug, Clone, Default)]
pub(crate) struct ModalLog {
    /// The state last handed out (or recorded), to see what changes.
    last: Option<ActiveModal>,
    /// A change not yet followed by an element: (first line, state).
    pending: Option<(u32, ActiveModal)>,
    /// Changes followed by an element, to be taken.
    ready: VecDeque<(u32, ActiveModal)>,
}

impl ModalLog {
    /// The state after the block of `line`.
    pub(crate) fn record(&mut self, line: u32, state: ActiveModal) {
        let current = self.pending.as_ref().map(|(_, s)| s).or(self.last.as_ref());
        if current == Some(&state) {
            return;
        }
        if self.last.as_ref() == Some(&state) {
            // Back to the state handed out last, with no element in between.
            self.pending = None;
            return;
        }
        // No element has a line between a pending change and this one: they merge.
        let first = self.pending.map_or(line, |(l, _)| l);
        self.pending = Some((first, state));
    }

    /// An element was made (after [`ModalLog::record`] of its line): the pending change
    /// applies to it.
    pub(crate) fn element(&mut self) {
        if let Some((line, state)) = self.pending.take() {
            self.last = Some(state);
            self.ready.push_back((line, state));
        }
    }

    /// The next change: the first line it applies to and the state from there on.
    pub(crate) fn take(&mut self) -> Option<(u32, ActiveModal)> {
        self.ready.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(work_system: usize) -> ActiveModal {
        ActiveModal {
            work_system,
            work_offset: [0.0; crate::path::MAX_AXES],
            g92_offset: [0.0; crate::path::MAX_AXES],
            tool: None,
            tool_length: None,
            cutter: None,
        }
    }

    #[test]
    fn changes_without_motion_between_them_merge_and_a_return_cancels() {
        let mut log = ModalLog::default();
        log.record(0, state(0));
        log.element();
        assert_eq!(log.take(), Some((0, state(0))));
        log.record(3, state(1));
        log.record(4, state(2));
        log.record(5, state(2));
        assert_eq!(log.take(), None, "not before an element follows");
        log.element();
        assert_eq!(log.take(), Some((3, state(2))));
        log.record(7, state(3));
        log.record(8, state(2));
        log.element();
        assert_eq!(log.take(), None, "back to the state of the last element");
    }
}
