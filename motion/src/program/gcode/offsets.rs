//! Offsets and stored positions as LinuxCNC has them: G10 L2/L20 (work offsets), G28/G30
//! with G28.1/G30.1 (home positions in parameters #5161–#5169, #5181–#5189), G52 (local
//! offset, LinuxCNC's G92 offset), G53 (a move in machine coordinates).
//!
//! A work offset G10 sets holds for the rest of the program (the configuration's
//! `[work_offsets]`, `offsets.set` and the parameter file give the values it starts with, the
//! parameter file the G28/G30 positions too); what a program leaves is [`Interpreter::persistent`].

use super::frame::rotate;
use super::{Block, Interpreter, Motion};
use crate::path::{Feed, Source};
use crate::program::error::Diagnostics;
use crate::program::lexer::Line;
use crate::program::param_file::HOME_BASE;
use interpd_config::AxisLetter;

/// The non-modal codes of this module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OffsetWord {
    G10,
    /// G28 (false) or G30 (true).
    Home(bool),
    /// G28.1 (false) or G30.1 (true).
    SetHome(bool),
    Local,
    Machine,
}

/// The first parameter of the G28 and G30 positions (X; then Y Z A B C U V W).
const G28_PARAM: usize = HOME_BASE[0];
const G30_PARAM: usize = HOME_BASE[1];

impl Interpreter {
    /// The work systems and G28/G30 positions as the program has them now: at its end, what
    /// the parameter file keeps.
    pub(in crate::program) fn persistent(&self) -> crate::program::Persistent {
        crate::program::Persistent {
            work_origins: self.work_origins,
            work_rotations_deg: self.work_rotations_deg,
            home_positions: crate::program::HomePositions::of(&self.params),
        }
    }

    /// G53 is allowed here: G0 or G1, absolute, no cutter compensation.
    pub(in crate::program) fn machine_coordinates_ok(
        &self,
        col: u32,
        g_motion: &Option<Motion>,
        block: &Block,
        d: &mut Diagnostics,
    ) -> bool {
        let motion = g_motion.or(self.modal.motion);
        let message = if !matches!(motion, Some(Motion::Rapid | Motion::Linear)) {
            "G53 moves in machine coordinates with G0 or G1 only"
        } else if !self.modal.absolute {
            "G53 cannot be used in incremental distance mode (G91)"
        } else if self.cutter.is_on() {
            "G53 cannot be used with cutter compensation on: program G40 first"
        } else {
            return true;
        };
        d.error(block.line, col, message);
        false
    }

    /// G10, G28, G28.1, G30, G30.1, G52: what they set or where they move.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::program) fn offset_word(
        &mut self,
        word: OffsetWord,
        col: u32,
        with_motion: bool,
        block: &Block,
        line: &Line,
        source: Source,
        d: &mut Diagnostics,
    ) {
        let line_no = block.line;
        let name = match word {
            OffsetWord::G10 => "G10",
            OffsetWord::Home(false) => "G28",
            OffsetWord::Home(true) => "G30",
            OffsetWord::SetHome(false) => "G28.1",
            OffsetWord::SetHome(true) => "G30.1",
            OffsetWord::Local => "G52",
            OffsetWord::Machine => "G53",
        };
        if with_motion {
            d.error(line_no, col, format!("{name} and a motion G-code in one block: both would use the axis words"));
            return;
        }
        if self.cutter.is_on() {
            d.error(line_no, col, format!("{name} cannot be used with cutter compensation on: program G40 first"));
            return;
        }
        // Axis words of the block: (machine axis, value in mm or deg, letter slot 0-8).
        let mut axes = Vec::new();
        for w in line.words.iter() {
            let Some(letter) = AxisLetter::from_char(w.letter) else { continue };
            let Some(k) = self.settings.axis_index(letter) else {
                d.error(
                    line_no,
                    w.col,
                    format!("axis {letter} is not on this machine (axes: {})", self.settings.axis_names().join(" ")),
                );
                return;
            };
            let scale = if self.linear[k] { self.modal.unit_mm } else { 1.0 };
            let slot = AxisLetter::ALL.iter().position(|l| *l == letter).unwrap_or(0);
            axes.push((k, w.value * scale, slot));
        }
        match word {
            OffsetWord::G10 => {
                block.consume_axes();
                self.g10(name, col, block, &axes, d);
            }
            OffsetWord::Local => {
                block.consume_axes();
                for (k, v, _) in &axes {
                    self.modal.g92[*k] = *v;
                }
                self.modal.g92_saved = self.modal.g92;
            }
            OffsetWord::SetHome(g30) => {
                if let Some(w) = line.words.iter().find(|w| AxisLetter::from_char(w.letter).is_some()) {
                    d.error(line_no, w.col, format!("{name} stores the current position and takes no axis words"));
                    return;
                }
                let base = if g30 { G30_PARAM } else { G28_PARAM };
                for (slot, letter) in AxisLetter::ALL.iter().enumerate().take(9) {
                    if let Some(k) = self.settings.axis_index(*letter) {
                        self.params.set_numbered(base + slot, self.modal.pos[k]);
                    }
                }
            }
            OffsetWord::Home(g30) => {
                let base = if g30 { G30_PARAM } else { G28_PARAM };
                let feed = Feed::Rapid;
                // First to the point the axis words name (in the active mode), then the named
                // axes (all without axis words) to the stored position.
                if !axes.is_empty() {
                    let Some(via) = self.target(block, d) else { return };
                    self.linear_move(via, feed, source, col, d);
                }
                let mut home = self.modal.pos;
                for (slot, letter) in AxisLetter::ALL.iter().enumerate().take(9) {
                    let Some(k) = self.settings.axis_index(*letter) else { continue };
                    if axes.is_empty() || axes.iter().any(|(kk, _, _)| *kk == k) {
                        home[k] = self.params.stored(base + slot);
                        if let Some(msg) = self.travel_violation(k, home[k]) {
                            d.error(line_no, col, format!("{name}: {msg}"));
                            return;
                        }
                    }
                }
                self.linear_move(home, feed, source, col, d);
            }
            OffsetWord::Machine => unreachable!("G53 is a modifier of the move"),
        }
    }

    fn g10(&mut self, name: &str, col: u32, block: &Block, axes: &[(usize, f64, usize)], d: &mut Diagnostics) {
        let line_no = block.line;
        let Some(l) = block.get('L') else {
            d.error(line_no, col, format!("{name} needs L (L2 or L20: a work offset)"));
            return;
        };
        match l.value {
            v if v == 2.0 || v == 20.0 => {}
            v if v == 1.0 || v == 10.0 || v == 11.0 => {
                self.g10_tool(name, v, col, block, axes, d);
                return;
            }
            v => {
                d.error(
                    line_no,
                    l.col,
                    format!("{name} L{v} is not supported (L1, L10, L11: tool offsets; L2, L20: work offsets)"),
                );
                return;
            }
        }
        let Some(p) = block.get('P') else {
            d.error(
                line_no,
                col,
                format!("{name} L{} needs P (the coordinate system: 1 = G54 … 9 = G59.3, 0 = the active one)", l.value),
            );
            return;
        };
        if p.value.fract() != 0.0 || !(0.0..=9.0).contains(&p.value) {
            d.error(line_no, p.col, format!("{name}: P must be a coordinate system 0 … 9, got {}", p.value));
            return;
        }
        let sys = if p.value == 0.0 { self.modal.work_system } else { p.value as usize - 1 };
        // R: the rotation of the system about Z, degrees (L2 only, as LinuxCNC).
        let rotation_deg = match block.get('R') {
            Some(r) if l.value == 20.0 => {
                d.error(line_no, r.col, format!("{name}: R is not allowed in G10 L20"));
                return;
            }
            Some(r) if !r.value.is_finite() => {
                d.error(line_no, r.col, format!("{name}: R is not a finite number"));
                return;
            }
            Some(r) => r.value,
            None => self.work_rotations_deg[sys],
        };
        let xy = match (self.settings.axis_index(AxisLetter::X), self.settings.axis_index(AxisLetter::Y)) {
            (Some(xk), Some(yk)) => Some((xk, yk)),
            _ => None,
        };
        let mut origin = self.work_origins[sys];
        let g92 = self.modal.g92;
        // The current point without the tool offset: the work offset is where the program's
        // zero lies for the bare spindle.
        let tool = self.modal.tool_offset;
        let pos: crate::path::AxisVec = std::array::from_fn(|k| self.modal.pos[k] - tool[k]);
        if let (true, Some((xk, yk))) = (l.value == 20.0, xy) {
            if axes.iter().any(|(k, _, _)| *k == xk || *k == yk) {
                // L20 in X Y: the current point gets the given program coordinates in that
                // (possibly rotated) system: machine = R(program + G92) + origin.
                let t = rotation_deg.to_radians();
                let (cx, cy) = rotate(pos[xk] - origin[xk], pos[yk] - origin[yk], -t);
                let mut want = (cx - g92[xk], cy - g92[yk]);
                for &(k, v, _) in axes {
                    if k == xk {
                        want.0 = v;
                    } else if k == yk {
                        want.1 = v;
                    }
                }
                let (rx, ry) = rotate(want.0 + g92[xk], want.1 + g92[yk], t);
                origin[xk] = pos[xk] - rx;
                origin[yk] = pos[yk] - ry;
            }
        }
        for &(k, v, _) in axes {
            if l.value == 20.0 && xy.is_some_and(|(xk, yk)| k == xk || k == yk) {
                continue;
            }
            origin[k] = if l.value == 2.0 {
                v
            } else {
                // L20: the current point gets the coordinate v in that system.
                pos[k] - g92[k] - v
            };
        }
        if origin.iter().any(|v| !v.is_finite()) {
            d.error(line_no, col, format!("{name}: the offset is not a finite number"));
            return;
        }
        self.work_origins[sys] = origin;
        self.work_rotations_deg[sys] = rotation_deg;
    }
}
