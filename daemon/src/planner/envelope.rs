//! The backward branches of a block, laid over the velocity bound.
//!
//! Seed 001 §3.1 splits the path into sections at the local minima of v̄; from each section
//! end a backward branch is computed (the fastest way to arrive there at v̄ with a = 0), and
//! from the block end (a stop) one arriving at rest. Branches occupy disjoint runs of nodes:
//! a branch from a minimum is not started where one from further on already lies lower, and a
//! branch ends where it has flattened under v̄ or meets a lower one.

use super::interval::Interval;

/// Where a backward branch starts: its section end and the state there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveStart {
    pub node: usize,
    pub v: f64,
    pub a: f64,
}

/// Per node of a block: the ceiling and, where a backward branch defines it, that branch's
/// state and interval.
#[derive(Debug, Clone, Default)]
pub struct Envelope {
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
}

/// Id of the branch from the block end: it is built first.
pub const END_CURVE: u32 = 1;

impl Envelope {
    /// The bare velocity bounds.
    pub fn from_vbar(vbar: impl Iterator<Item = f64>) -> Self {
        let v: Vec<f64> = vbar.collect();
        let n = v.len();
        Self {
            a: vec![0.0; n],
            curve: vec![0; n],
            iv: vec![Interval::default(); n],
            starts: vec![CurveStart { node: 0, v: 0.0, a: 0.0 }],
            v,
        }
    }

    pub fn len(&self) -> usize {
        self.v.len()
    }

    pub fn is_empty(&self) -> bool {
        self.v.is_empty()
    }

    pub fn on_curve(&self, i: usize) -> bool {
        self.curve[i] != 0
    }

    /// First node of the branch from the block end: the part of the block whose profile
    /// depends on where the block (the planning horizon) ends.
    pub fn end_curve_start(&self) -> usize {
        let n = self.curve.len();
        (0..n).rev().take_while(|&i| self.curve[i] == END_CURVE).last().unwrap_or(n.saturating_sub(1))
    }
}
