//! Sample nodes s_i of the path with the geometry the planner needs there, and the velocity
//! bound v̄(s_i) (seed 001 eq. 6, corrected).

use super::limits::Limits;
use crate::path::{AxisDerivs, AxisVec};

/// A′, A″, A‴ of every axis at one side of a node.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NodeGeom {
    pub d1: AxisVec,
    pub d2: AxisVec,
    pub d3: AxisVec,
}

impl From<&AxisDerivs> for NodeGeom {
    fn from(d: &AxisDerivs) -> Self {
        NodeGeom { d1: d.d1, d2: d.d2, d3: d.d3 }
    }
}

/// One sample point of the path.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Path position, mm.
    pub s_mm: f64,
    /// Geometry as the end of the interval before this node.
    pub left: NodeGeom,
    /// Geometry as the start of the interval after this node. Differs from `left` only at
    /// element joints.
    pub right: NodeGeom,
    /// Velocity bound v̄ at this node, mm/s (both sides, programmed feed, joint caps).
    pub vbar_mm_s: f64,
    /// Programmed feed of the interval after this node, mm/s (∞ for rapid moves).
    pub feed_mm_s: f64,
    /// The motion must be at rest here (corner, dwell, program start or end).
    pub stop: bool,
    /// Dwell at this node, s.
    pub dwell_s: f64,
    /// Program line of the element after this node.
    pub line: u32,
}

/// v̄ from one side's geometry: the largest path velocity at which every axis keeps its
/// velocity, acceleration and jerk limit with a = 0 and j = 0.
/// Seed 001 eq. 6, corrected: eq. 6 prints the fractions upside down and with vector norms;
/// per axis, eq. 5 gives v ≤ Ȧ_max/|A′|, v ≤ √(Ä_max/|A″|), v ≤ ∛(A⃛_max/|A‴|).
pub fn velocity_bound(g: &NodeGeom, lim: &Limits) -> f64 {
    // Roots are monotone: the smallest v², v³ over the axes first, one root each at the end.
    let (mut v, mut v2, mut v3) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for k in 0..lim.n_axes {
        let (d1, d2, d3) = (g.d1[k].abs(), g.d2[k], g.d3[k].abs());
        if d1 > 0.0 {
            v = v.min(lim.vel[k] / d1);
        }
        if d2 > 0.0 {
            v2 = v2.min(lim.acc_max[k] / d2);
        } else if d2 < 0.0 {
            v2 = v2.min(lim.acc_min[k] / d2);
        }
        if d3 > 0.0 {
            v3 = v3.min(lim.jerk[k] / d3);
        }
    }
    v.min(v2.sqrt()).min(v3.cbrt())
}

/// Speed cap at a curvature jump (G¹ but not G² joint): the axis acceleration steps by
/// ΔA″·v² there. A step is an infinite jerk; the cap keeps it below what the jerk limit moves
/// in `step_s` (v²|ΔA″_k| ≤ J_k·step_s), so sampled jerk stays within the limit.
pub fn curvature_jump_cap(left: &NodeGeom, right: &NodeGeom, lim: &Limits, step_s: f64) -> f64 {
    let mut v = f64::INFINITY;
    for k in 0..lim.n_axes {
        let jump = (left.d2[k] - right.d2[k]).abs();
        if jump > 0.0 {
            v = v.min((lim.jerk[k] * step_s / jump).sqrt());
        }
    }
    v
}
