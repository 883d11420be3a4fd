//! The backward branches of a block, laid over the velocity bound.
//!
//! Kopp et al. 2019, §3.1 split the path into sections at the local minima of v̄; from each section
//! end a backward branch is computed (the fastest way to arrive there at v̄ with a = 0), and
//! from the block end (a stop) one arriving at rest. Branches occupy disjoint runs of nodes:
//! a branch from a minimum is not started where one from further on already lies lower, and a
//! branch ends where it has flattened under v̄ or meets a lower one.

use super::interval::Interval;
use std::sync::Arc;

/// One node of a backward branch: the node index, its state (forward acceleration) and the
/// forward interval from it to the next node.
pub(super) type BranchNode = (usize, f64, f64, Interval);

/// Where a backward branch starts: its section end and the state there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CurveStart {
    pub node: usize,
    pub v: f64,
    pub a: f64,
    /// The lowest and the highest node index its build read (every start it tried, and the
    /// forward steps from its section end): the branch is the same on a block whose nodes
    /// between them are the same, under the same envelope.
    pub reads: (usize, usize),
}

/// Per node of a block: the ceiling and, where a backward branch defines it, that branch's
/// state and interval.
#[derive(Debug, Clone, Default)]
pub(super) struct Envelope {
    /// Ceiling velocity, mm/s: the branch where there is one, else v̄.
    pub v: Vec<f64>,
    /// Forward acceleration of the branch at the node (0 where there is none).
    pub a: Vec<f64>,
    /// Branch id at the node, 0 where there is none.
    pub curve: Vec<u32>,
    /// Along a branch: the forward interval from this node to the next.
    pub iv: Vec<Interval>,
    /// Start of every branch, indexed by id (entry 0 unused).
    pub starts: Vec<CurveStart>,
    /// Every branch's nodes as built, indexed by id (entry 0 empty): a branch built later from
    /// a section end further left may replace part of it in the arrays above.
    pub built: Vec<Arc<[BranchNode]>>,
}

/// Id of the branch from the block end: it is built first.
pub(super) const END_CURVE: u32 = 1;

impl Envelope {
    /// The bare velocity bounds.
    pub(super) fn from_vbar(vbar: impl Iterator<Item = f64>) -> Self {
        let v: Vec<f64> = vbar.collect();
        let n = v.len();
        Self {
            a: vec![0.0; n],
            curve: vec![0; n],
            iv: vec![Interval::default(); n],
            starts: vec![CurveStart { node: 0, v: 0.0, a: 0.0, reads: (0, 0) }],
            built: vec![Arc::from([])],
            v,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.v.len()
    }

    pub(super) fn on_curve(&self, i: usize) -> bool {
        self.curve[i] != 0
    }

    /// Every branch as (section end, first node), the latest section end first.
    pub(super) fn extents(&self) -> Vec<(usize, usize)> {
        let mut first = vec![usize::MAX; self.starts.len()];
        for (i, &c) in self.curve.iter().enumerate().rev() {
            first[c as usize] = i;
        }
        let mut out: Vec<(usize, usize)> =
            self.starts.iter().zip(&first).skip(1).map(|(st, &f)| (st.node, f.min(st.node))).collect();
        out.sort_unstable_by_key(|&(end, _)| std::cmp::Reverse(end));
        out
    }

    /// Takes over every branch of `old` from a section end before node `edge`. For a block whose
    /// v̄ before `edge` is as in `old`'s, and where no branch from a later section end reaches
    /// before `edge`, here or in `old`: then those branches are the ones a build would make.
    pub(super) fn take_over_before(&mut self, old: &Envelope, edge: usize) {
        let mut ids = vec![0u32; old.starts.len()];
        for (c, st) in old.starts.iter().enumerate().skip(1) {
            if st.node < edge {
                ids[c] = self.starts.len() as u32;
                self.starts.push(*st);
                self.built.push(old.built[c].clone());
            }
        }
        for i in 0..edge {
            let id = ids[old.curve[i] as usize];
            if id != 0 {
                self.copy_node(old, i, id);
            }
        }
    }

    /// Lays a branch from section end `start` over the envelope: its section end in the state
    /// it starts in and its nodes, replacing what lies there. Returns its id.
    pub(super) fn lay(&mut self, start: CurveStart, branch: Arc<[BranchNode]>) -> u32 {
        let id = self.starts.len() as u32;
        let m = start.node;
        (self.v[m], self.a[m], self.curve[m]) = (start.v, start.a, id);
        for &(i, v, a, iv) in branch.iter() {
            (self.v[i], self.a[i], self.curve[i], self.iv[i]) = (v, a, id, iv);
        }
        self.starts.push(start);
        self.built.push(branch);
        id
    }

    fn copy_node(&mut self, old: &Envelope, i: usize, id: u32) {
        self.v[i] = old.v[i];
        self.a[i] = old.a[i];
        self.iv[i] = old.iv[i];
        self.curve[i] = id;
    }

    /// The first node where this envelope differs from `old` (velocity, acceleration, whether
    /// a branch lies there and where it ends); the length if nowhere.
    pub(super) fn first_difference(&self, old: &Envelope) -> usize {
        let end = |e: &Envelope, i: usize| (e.curve[i] != 0).then(|| e.starts[e.curve[i] as usize].node);
        (0..self.len())
            .find(|&i| self.v[i] != old.v[i] || self.a[i] != old.a[i] || end(self, i) != end(old, i))
            .unwrap_or(self.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ten nodes with v̄ = 10 and branches (section end, first node, velocity) laid on them, ids in
    /// that order.
    fn envelope(branches: &[(usize, usize, f64)]) -> Envelope {
        let mut e = Envelope::from_vbar(std::iter::repeat_n(10.0, 10));
        for &(end, first, v) in branches {
            let id = e.starts.len() as u32;
            e.starts.push(CurveStart { node: end, v, a: 0.0, reads: (first, end) });
            e.built.push(Arc::from([]));
            for i in first..=end {
                (e.v[i], e.curve[i]) = (v, id);
            }
        }
        e
    }

    #[test]
    fn branches_before_an_edge_are_taken_over() {
        // Block end 9 (nodes 7..=9), section ends at 4 (nodes 2..=4) and 1 (node 1 only).
        let old = envelope(&[(9, 7, 1.0), (4, 2, 5.0), (1, 1, 6.0)]);
        assert_eq!(old.extents(), [(9, 7), (4, 2), (1, 1)]);
        let mut new = envelope(&[(9, 8, 1.0)]);
        new.take_over_before(&old, 5);
        assert_eq!(new.first_difference(&old), 7, "the block end's branch differs");
        assert_eq!(&new.curve[..5], &[0, 3, 2, 2, 2]);
        assert_eq!(new.starts[2].node, 4);
    }
}
