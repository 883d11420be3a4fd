//! The program frame and the machine frame, as LinuxCNC 2.9 maps them (`get_abs_position` in
//! its `interp_convert.cc`, `rotate_and_offset_pos` in `emccanon.cc`):
//!
//! machine = R(θ) · (program + G92 offset) + work origin + tool offset (G43; on Z the length),
//!
//! where R(θ) turns X and Y about Z by the rotation of the active work system (`G10 L2 … R`,
//! degrees counter-clockwise, LinuxCNC's parameters #5230, #5250 … #5390). Without a rotation
//! every axis maps on its own (`program_offset`); with one, X and Y map together, so every
//! program-to-machine conversion of X and Y goes through this module.

use super::Interpreter;
use crate::path::AxisVec;
use interpd_config::AxisLetter;

impl Interpreter {
    /// The X and Y axis indices and the active rotation in radians, when the active work
    /// system is rotated (and the machine has X and Y).
    pub(in crate::program) fn xy_rotation(&self) -> Option<(usize, usize, f64)> {
        let deg = self.work_rotations_deg[self.modal.work_system];
        if deg == 0.0 {
            return None;
        }
        let xk = self.settings.axis_index(AxisLetter::X)?;
        let yk = self.settings.axis_index(AxisLetter::Y)?;
        Some((xk, yk, deg.to_radians()))
    }

    /// A program-frame vector in the XY plane turned into the machine frame (an arc's centre
    /// offset I J, a G91 increment): the rotation only.
    pub(in crate::program) fn rotate_xy(&self, x: f64, y: f64) -> (f64, f64) {
        match self.xy_rotation() {
            None => (x, y),
            Some((_, _, t)) => rotate(x, y, t),
        }
    }

    /// The current point's program coordinate on axis `k` (mm or deg).
    pub(in crate::program) fn program_coord(&self, k: usize) -> f64 {
        self.program_coord_of(&self.modal.pos, k)
    }

    /// The program coordinate of machine position `m` on axis `k` (mm or deg).
    pub(in crate::program) fn program_coord_of(&self, m: &AxisVec, k: usize) -> f64 {
        if let Some((xk, yk, t)) = self.xy_rotation() {
            if k == xk || k == yk {
                // The tool offset is not turned: it lies in the machine frame (tool_table.rs).
                let origin = &self.work_origins[self.modal.work_system];
                let tool = &self.modal.tool_offset;
                let (x, y) = rotate(m[xk] - origin[xk] - tool[xk], m[yk] - origin[yk] - tool[yk], -t);
                let g92 = &self.modal.g92;
                return if k == xk { x - g92[xk] } else { y - g92[yk] };
            }
        }
        m[k] - self.program_offset(k)
    }

    /// Sets the machine coordinates of `target` from program coordinates `(axis, mm or deg)`:
    /// with a rotation, X and Y go through it together, the one not given keeping the current
    /// point's program coordinate.
    pub(in crate::program) fn set_program_coords(&self, target: &mut AxisVec, coords: &[(usize, f64)]) {
        let rotation = self.xy_rotation();
        let mut xy: Option<(f64, f64)> = None;
        for &(k, v) in coords {
            match rotation {
                Some((xk, yk, _)) if k == xk || k == yk => {
                    let (x, y) = xy.get_or_insert_with(|| (self.program_coord(xk), self.program_coord(yk)));
                    if k == xk {
                        *x = v;
                    } else {
                        *y = v;
                    }
                }
                _ => target[k] = v + self.program_offset(k),
            }
        }
        if let (Some((xk, yk, t)), Some((x, y))) = (rotation, xy) {
            let origin = &self.work_origins[self.modal.work_system];
            let g92 = &self.modal.g92;
            let tool = &self.modal.tool_offset;
            let (mx, my) = rotate(x + g92[xk], y + g92[yk], t);
            target[xk] = mx + origin[xk] + tool[xk];
            target[yk] = my + origin[yk] + tool[yk];
        }
    }
}

/// `(x, y)` turned by `t` radians counter-clockwise (LinuxCNC's `Interp::rotate`).
pub(in crate::program) fn rotate(x: f64, y: f64, t: f64) -> (f64, f64) {
    let (s, c) = t.sin_cos();
    (x * c - y * s, x * s + y * c)
}

#[cfg(test)]
mod tests {
    use super::rotate;

    #[test]
    fn rotation_is_counter_clockwise_in_degrees() {
        let (x, y) = rotate(1.0, 0.0, 90f64.to_radians());
        assert!(x.abs() < 1e-15 && (y - 1.0).abs() < 1e-15);
        let (x, y) = rotate(1.0, 1.0, (-45f64).to_radians());
        assert!((x - 2f64.sqrt()).abs() < 1e-15 && y.abs() < 1e-15);
    }
}
