//! The programmed moves a run stands for, as the check after each window measures against
//! them (`verify.rs`): only where each lies in s and its shape. A CAM program brings a move
//! every few micrometres, so this keeps per move no more than the distance needs.

use super::elements::distance_to;
use crate::path::{AxisDerivs, AxisVec, Element, Geometry};
use std::collections::VecDeque;

/// The shape of one programmed move.
#[derive(Debug, Clone)]
enum Shape {
    /// A straight move: its start and unit direction (measured in closed form).
    Line { start: AxisVec, dir: AxisVec },
    /// Anything else, measured by projection.
    Curve(Box<Geometry>),
}

#[derive(Debug, Clone)]
struct Move {
    /// Start on the programmed path, mm.
    s0_mm: f64,
    len_mm: f64,
    shape: Shape,
}

impl Move {
    fn distance(&self, p: &AxisVec, n: usize) -> f64 {
        match &self.shape {
            Shape::Line { start, dir } => {
                let along = (0..n).map(|k| (p[k] - start[k]) * dir[k]).sum::<f64>().clamp(0.0, self.len_mm);
                (0..n).map(|k| (p[k] - start[k] - along * dir[k]).powi(2)).sum::<f64>().sqrt()
            }
            Shape::Curve(g) => distance_to(g, p, n),
        }
    }
}

/// The programmed moves of a run with global indices; old ones are dropped once committed past.
#[derive(Debug, Default)]
pub(super) struct ProgrammedMoves {
    items: VecDeque<Move>,
    base: usize,
    n_axes: usize,
}

impl ProgrammedMoves {
    pub(super) fn new(n_axes: usize) -> Self {
        Self { items: VecDeque::new(), base: 0, n_axes }
    }

    pub(super) fn push(&mut self, e: Element) {
        let len_mm = e.geometry.length_mm();
        let shape = match e.geometry {
            Geometry::Line(_) => {
                let mut d = AxisDerivs::default();
                e.geometry.eval(0.0, &mut d);
                Shape::Line { start: d.pos, dir: d.d1 }
            }
            g => Shape::Curve(Box::new(g)),
        };
        self.items.push_back(Move { s0_mm: e.s_start_mm, len_mm, shape });
    }

    /// One past the last global index.
    fn end(&self) -> usize {
        self.base + self.items.len()
    }

    fn get(&self, i: usize) -> &Move {
        &self.items[i - self.base]
    }

    /// Start of move `i` on the programmed path, mm.
    pub(super) fn s0_mm(&self, i: usize) -> f64 {
        self.get(i).s0_mm
    }

    /// End of move `i` on the programmed path, mm.
    pub(super) fn s1_mm(&self, i: usize) -> f64 {
        let m = self.get(i);
        m.s0_mm + m.len_mm
    }

    /// Drops the moves before global index `i`.
    pub(super) fn drop_before(&mut self, i: usize) {
        let n = i.saturating_sub(self.base).min(self.items.len());
        self.items.drain(..n);
        self.base += n;
    }

    /// Index of the move containing programmed s (the later one at a vertex), by bisection.
    pub(super) fn index_at_bisect(&self, s_mm: f64) -> usize {
        let i = self.items.partition_point(|m| m.s0_mm <= s_mm);
        self.base + i.saturating_sub(1).min(self.items.len().saturating_sub(1))
    }

    /// Distance from `p` to the moves `from..=to` (clamped to those held).
    pub(super) fn distance(&self, p: &AxisVec, from: usize, to: usize) -> f64 {
        let (from, to) = (from.max(self.base), to.min(self.end() - 1));
        (from..=to).map(|i| self.get(i).distance(p, self.n_axes)).fold(f64::INFINITY, f64::min)
    }
}
