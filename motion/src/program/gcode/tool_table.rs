//! The program's copy of the tool table, as LinuxCNC 2.9 keeps it (`convert_setup_tool` and
//! `convert_tool_length_offset` in its `interp_convert.cc`):
//!
//! - a tool has an offset on every axis (in the machine frame: the rotation of a work system
//!   does not turn it) and a diameter;
//! - G10 L1 P<tool> writes the offsets its axis words give, R the radius;
//! - G10 L10 writes them so that the current point, with this tool's offsets applied by G43,
//!   has the given coordinates in the active coordinate system; G10 L11 does the same in G59.3
//!   (the tool touch-off fixture) without the G92 offset;
//! - G43 applies every offset of the tool (its Z offset is the tool length), G49 none; a
//!   tool G10 changes keeps the offset G43 applied until the next G43, as in LinuxCNC.
//!
//! The configuration's tools (`[[tool]]`, `tools.set`) give the diameter and the length (the
//! Z offset); the offsets of the other axes start at zero. What G10 writes lasts until the
//! program ends: the configuration is not changed, and the next program starts from it.
//! I, J (lathe tool angles) and Q (lathe tool orientation) are read and ignored, since
//! interpd's compensation has no lathe tool model.

use super::frame::rotate;
use super::{Block, Interpreter};
use crate::path::{AxisVec, MAX_AXES};
use crate::program::error::Diagnostics;
use interpd_config::AxisLetter;
use std::collections::BTreeMap;

/// One tool as the program sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ProgramTool {
    /// The offset per machine axis, mm or deg (Z: the tool length).
    pub offset: AxisVec,
    pub diameter_mm: f64,
}

/// The tools G10 L1/L10/L11 wrote; the others are read from the configuration. Bounded: only
/// tools the configuration has can be written.
#[derive(Debug, Clone, Default)]
pub(crate) struct ToolTable {
    written: BTreeMap<u32, ProgramTool>,
}

impl Interpreter {
    /// Tool `number` of the program's tool table, or `None` when the table has no such tool.
    pub(in crate::program) fn program_tool(&self, number: u32) -> Option<ProgramTool> {
        if let Some(t) = self.tools.written.get(&number) {
            return Some(*t);
        }
        let t = self.settings.tool(number)?;
        let mut offset = [0.0; MAX_AXES];
        if let Some(z) = self.settings.axis_index(AxisLetter::Z) {
            offset[z] = t.length_mm;
        }
        Some(ProgramTool { offset, diameter_mm: t.diameter_mm })
    }

    /// G10 L1, L10 or L11 (`l`) at column `col` with the block's axis words `axes` (machine
    /// axis, value in mm or deg, letter slot).
    pub(in crate::program) fn g10_tool(
        &mut self,
        name: &str,
        l: f64,
        col: u32,
        block: &Block,
        axes: &[(usize, f64, usize)],
        d: &mut Diagnostics,
    ) {
        let line_no = block.line;
        let lname = format!("{name} L{l}");
        let Some(p) = block.get('P') else {
            d.error(line_no, col, format!("{lname} needs P (the tool number)"));
            return;
        };
        if p.value < 0.0 || p.value.fract() != 0.0 || p.value > f64::from(u32::MAX) {
            d.error(
                line_no,
                p.col,
                format!("{lname}: P must be a tool number (a non-negative integer), got {}", p.value),
            );
            return;
        }
        let number = p.value as u32;
        let Some(mut tool) = self.program_tool(number) else {
            d.error(line_no, p.col, format!("{lname}: tool {number} is not in the tool table"));
            return;
        };
        let radius = block.get('R');
        let lathe: Vec<_> = ['I', 'J', 'Q'].iter().filter_map(|&c| block.get(c)).collect();
        for w in radius.iter().chain(lathe.iter()) {
            if !w.value.is_finite() {
                d.error(line_no, w.col, format!("{lname}: {} is not a finite number", w.letter));
                return;
            }
        }
        if let Some(q) = lathe.iter().find(|w| w.letter == 'Q') {
            if q.value.fract() != 0.0 || !(0.0..=9.0).contains(&q.value) {
                d.error(
                    line_no,
                    q.col,
                    format!("{lname}: Q (the lathe tool orientation) must be 0 … 9, got {}", q.value),
                );
                return;
            }
        }
        if axes.is_empty() && radius.is_none() && lathe.is_empty() {
            // LinuxCNC's message.
            d.error(line_no, col, format!("{lname} without offsets has no effect"));
            return;
        }
        if l == 1.0 {
            for &(k, v, _) in axes {
                tool.offset[k] = v;
            }
        } else {
            self.touch_off(&mut tool, l == 11.0, axes);
        }
        if let Some(r) = radius {
            tool.diameter_mm = 2.0 * r.value * self.modal.unit_mm;
        }
        if tool.offset.iter().any(|v| !v.is_finite()) || !tool.diameter_mm.is_finite() {
            d.error(line_no, col, format!("{lname}: the offset is not a finite number"));
            return;
        }
        self.summary.tools.insert(number);
        self.tools.written.insert(number, tool);
    }

    /// G10 L10 (`fixture` false: in the active system, with G92) or L11 (in G59.3, without
    /// G92): the tool's offsets on the axes of `axes` such that the current point has those
    /// coordinates with them applied (LinuxCNC's `find_current_in_system_without_tlo`).
    fn touch_off(&self, tool: &mut ProgramTool, fixture: bool, axes: &[(usize, f64, usize)]) {
        let sys = if fixture { 8 } else { self.modal.work_system };
        let origin = &self.work_origins[sys];
        let theta = self.work_rotations_deg[sys].to_radians();
        let pos = &self.modal.pos;
        // The current point (machine, tool offsets included) in system `sys`, without offsets.
        let mut t: AxisVec = std::array::from_fn(|k| pos[k] - origin[k]);
        let xy = self.settings.axis_index(AxisLetter::X).zip(self.settings.axis_index(AxisLetter::Y));
        if let Some((xk, yk)) = xy {
            (t[xk], t[yk]) = rotate(t[xk], t[yk], -theta);
        }
        if !fixture {
            for (tk, g) in t.iter_mut().zip(self.modal.g92.iter()) {
                *tk -= g;
            }
        }
        let given = |k: usize| axes.iter().find(|(kk, _, _)| *kk == k).map(|(_, v, _)| *v);
        if let Some((xk, yk)) = xy {
            match (given(xk), given(yk)) {
                (Some(x), Some(y)) => {
                    (tool.offset[xk], tool.offset[yk]) = rotate(t[xk] - x, t[yk] - y, theta);
                }
                (Some(x), None) => {
                    // Keep the part of the offset along the system's (turned) Y axis.
                    let (_, oy) = rotate(tool.offset[xk], tool.offset[yk], -theta);
                    let (ox, oy) = rotate(0.0, oy, theta);
                    let (tx, ty) = rotate(t[xk] - x, 0.0, theta);
                    (tool.offset[xk], tool.offset[yk]) = (tx + ox, ty + oy);
                }
                (None, Some(y)) => {
                    let (ox, _) = rotate(tool.offset[xk], tool.offset[yk], -theta);
                    let (ox, oy) = rotate(ox, 0.0, theta);
                    let (tx, ty) = rotate(0.0, t[yk] - y, theta);
                    (tool.offset[xk], tool.offset[yk]) = (tx + ox, ty + oy);
                }
                (None, None) => {}
            }
        }
        for &(k, v, _) in axes {
            if xy.is_some_and(|(xk, yk)| k == xk || k == yk) {
                continue;
            }
            tool.offset[k] = t[k] - v;
        }
    }
}
