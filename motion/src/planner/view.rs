//! A block of nodes seen in traversal order: forward (increasing s) for the forward branch,
//! backward (decreasing s, geometry mirrored) for the backward branches, so one branch
//! implementation serves both (Kopp et al. 2019, eq. 3: the ± signs flip for the backward branch).

use super::node::{IntervalGeom, Node, NodeGeom};
use std::cell::Cell;

/// The node indices read through the views that record into it: what a computation on them
/// depends on (a backward branch whose build never read a node is the same after that node's
/// v̄ changed, see `branch::build_envelope`).
#[derive(Debug)]
pub(super) struct Reads {
    lo: Cell<usize>,
    hi: Cell<usize>,
}

impl Reads {
    /// Node `i` read.
    pub(super) fn at(i: usize) -> Self {
        Self { lo: Cell::new(i), hi: Cell::new(i) }
    }

    #[inline]
    fn read(&self, i: usize) {
        self.lo.set(self.lo.get().min(i));
        self.hi.set(self.hi.get().max(i));
    }

    /// The lowest and the highest node index read.
    pub(super) fn span(&self) -> (usize, usize) {
        (self.lo.get(), self.hi.get())
    }
}

#[derive(Clone, Copy)]
pub(super) struct View<'a> {
    nodes: &'a [Node],
    reverse: bool,
    /// Where a caller records the nodes read.
    reads: Option<&'a Reads>,
}

impl<'a> View<'a> {
    pub(super) fn forward(nodes: &'a [Node]) -> Self {
        Self { nodes, reverse: false, reads: None }
    }

    pub(super) fn backward(nodes: &'a [Node]) -> Self {
        Self { nodes, reverse: true, reads: None }
    }

    /// The same view, recording every node it reads in `reads`.
    pub(super) fn tracking(self, reads: &'a Reads) -> Self {
        Self { reads: Some(reads), ..self }
    }

    pub(super) fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Node index of traversal position `t`.
    #[inline]
    pub(super) fn index(&self, t: usize) -> usize {
        if self.reverse { self.nodes.len() - 1 - t } else { t }
    }

    /// Traversal position of node index `i`.
    #[inline]
    pub(super) fn position(&self, i: usize) -> usize {
        self.index(i)
    }

    #[inline]
    pub(super) fn node(&self, t: usize) -> &'a Node {
        let i = self.index(t);
        if let Some(reads) = self.reads {
            reads.read(i);
        }
        &self.nodes[i]
    }

    #[inline]
    pub(super) fn sign(&self) -> f64 {
        if self.reverse { -1.0 } else { 1.0 }
    }

    /// Geometry at traversal position `t` as the start of the interval t → t+1.
    #[inline]
    pub(super) fn start_geom(&self, t: usize) -> &'a NodeGeom {
        let n = self.node(t);
        if self.reverse { &n.left } else { &n.right }
    }

    /// Geometry at traversal position `t` as the end of the interval t−1 → t.
    #[inline]
    pub(super) fn end_geom(&self, t: usize) -> &'a NodeGeom {
        let n = self.node(t);
        if self.reverse { &n.right } else { &n.left }
    }

    /// Length of the interval t → t+1.
    #[inline]
    pub(super) fn ds(&self, t: usize) -> f64 {
        (self.node(t + 1).s_mm - self.node(t).s_mm).abs()
    }

    /// The interval t → t+1 for the limit checks.
    #[inline]
    pub(super) fn interval_geom(&self, t: usize) -> IntervalGeom<'a> {
        // The interval's exact geometry (and how to interpolate it) belongs to its node of
        // lower s.
        let first = &self.nodes[self.index(t).min(self.index(t + 1))];
        IntervalGeom {
            start: self.start_geom(t),
            end: self.end_geom(t + 1),
            ds_mm: self.ds(t),
            sign: self.sign(),
            span: first.span.as_deref(),
            quintic: first.quintic,
        }
    }
}
