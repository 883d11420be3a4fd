//! Straight line elements (G0, G1, and the connecting moves the daemon and the smoothing insert).

use super::{AxisDerivs, AxisVec};

/// Straight line: A(s) = P₀ + d·s with a constant direction d (|d| = 1 over the axes that
/// define s).
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    start: AxisVec,
    dir: AxisVec,
    length_mm: f64,
}

impl Line {
    /// Line from `start` to `end`; `length_mm` is the path length the caller measured (over
    /// the linear axes, or the rotary axes for a rotary-only move). Must be > 0.
    pub fn new(start: AxisVec, end: AxisVec, length_mm: f64) -> Self {
        debug_assert!(length_mm > 0.0);
        let mut dir = [0.0; super::MAX_AXES];
        for k in 0..dir.len() {
            dir[k] = (end[k] - start[k]) / length_mm;
        }
        Self { start, dir, length_mm }
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.length_mm
    }

    pub(crate) fn eval(&self, s: f64, out: &mut AxisDerivs) {
        for k in 0..self.dir.len() {
            out.pos[k] = self.start[k] + self.dir[k] * s;
            out.d1[k] = self.dir[k];
            out.d2[k] = 0.0;
            out.d3[k] = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn length_and_end_exact() {
        let mut a = [0.0; 9];
        let mut b = [0.0; 9];
        a[0] = 1.0;
        b[0] = 4.0;
        b[1] = 4.0;
        let l = Line::new(a, b, 5.0);
        let mut d = AxisDerivs::default();
        l.eval(5.0, &mut d);
        assert!((d.pos[0] - 4.0).abs() < 1e-12 && (d.pos[1] - 4.0).abs() < 1e-12);
        assert!((d.d1[0] - 0.6).abs() < 1e-15 && (d.d1[1] - 0.8).abs() < 1e-15);
    }
}
