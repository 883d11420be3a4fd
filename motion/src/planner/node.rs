//! Sample nodes s_i of the path with the geometry the planner needs there (A′, A″, A‴ per axis,
//! Kopp et al. 2019, §2), the geometry of the interval between two of them ([`SpanPoly`],
//! [`IntervalGeom`]: the limit checks, scalar and in lanes, and the planner's steps all take
//! it from here), and the velocity bounds there: v̄(s_i) of eq. 6 (in its corrected per-axis
//! form) and the acceleration-only maximum velocity curve (eq. 1a–1b with the path
//! acceleration free).

use super::limits::Limits;
use crate::path::{AxisDerivs, AxisVec, MAX_AXES};
use std::sync::Arc;

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

/// Coefficients per axis of the exact geometry of an interval (`SpanPoly`): A′ (degree 6), A″
/// (5), A‴ (4).
pub const SPAN_POLY_COEFS: usize = 7 + 6 + 5;

/// The exact geometry of the interval from a node to the next where the path is a polynomial
/// in s there (a path table's degree-7 rows): A′, A″, A‴ per axis as polynomials in the
/// fraction σ ∈ [0, 1] of the interval's length, in increasing s. The limit checks evaluate it
/// instead of interpolating between the nodes (`check::geom_at`), so the nodes need not be
/// dense enough for the interpolation to be accurate: only for the motion's sake.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SpanPoly {
    /// Per coefficient the axes side by side (the limit checks take four axes at a time,
    /// `lanes`), lowest order first: A′ in `[0..7]`, A″ in `[7..13]`, A‴ in `[13..18]`.
    coef: [[f64; MAX_AXES]; SPAN_POLY_COEFS],
    /// The nodes' data interpolate the interval as closely as the sampling makes them for
    /// other elements (`sampling::INTERP_ERROR_TOL`).
    interpolable: bool,
    /// `check::interior_vbar` of the interval, where the sampling computed it along with the
    /// span (it shares the middle's geometry with the interpolation test). The
    /// acceleration-only bound is exact only where it is below both nodes' bounds as sampled,
    /// the only case `Planner::refine_vbar` uses it (`check::interior_vbar_around`).
    interior_vbar: Option<(f64, f64)>,
}

impl SpanPoly {
    /// From the position polynomial of every axis, A(s₀ + σ·ds) = Σ cᵢ σⁱ, over an interval
    /// `ds_mm` long. Only the first `axes` axes are read: the others are zero.
    pub(crate) fn from_position(c: &[[f64; 8]; MAX_AXES], axes: usize, ds_mm: f64, interpolable: bool) -> Self {
        let (i1, i2, i3) = (1.0 / ds_mm, 1.0 / (ds_mm * ds_mm), 1.0 / (ds_mm * ds_mm * ds_mm));
        let mut coef = [[0.0; MAX_AXES]; SPAN_POLY_COEFS];
        for (k, c) in c.iter().enumerate().take(axes) {
            for i in 0..7 {
                coef[i][k] = (i + 1) as f64 * c[i + 1] * i1;
            }
            for i in 0..6 {
                coef[7 + i][k] = ((i + 2) * (i + 1)) as f64 * c[i + 2] * i2;
            }
            for i in 0..5 {
                coef[13 + i][k] = ((i + 3) * (i + 2) * (i + 1)) as f64 * c[i + 3] * i3;
            }
        }
        Self { coef, interpolable, interior_vbar: None }
    }

    /// Marks whether the nodes interpolate the interval well (see [`SpanPoly::fine_checks`]).
    pub(crate) fn set_interpolable(&mut self, interpolable: bool) {
        self.interpolable = interpolable;
    }

    /// Records `check::interior_vbar` of the interval.
    pub(crate) fn set_interior_vbar(&mut self, bounds: (f64, f64)) {
        self.interior_vbar = Some(bounds);
    }

    /// `check::interior_vbar` of the interval, where recorded.
    pub(crate) fn interior_vbar(&self) -> Option<(f64, f64)> {
        self.interior_vbar
    }

    /// The interval can bulge between the nodes (they do not interpolate it well): its limit
    /// checks take `check::FINE_CHECK_FRACTIONS`, and its viability ramps the full interval
    /// check, not the node-only one (`ramp::Check::Nodes`).
    pub(crate) fn fine_checks(&self) -> bool {
        !self.interpolable
    }

    /// The coefficients of axis `k`, lowest order first: A′ in `[0..7]`, A″ in `[7..13]`, A‴ in
    /// `[13..18]` (for `interpd plan --export-nodes`).
    pub(crate) fn coefficients(&self, k: usize) -> [f64; SPAN_POLY_COEFS] {
        self.coef.map(|axes| axes[k])
    }

    /// Coefficient `i` of every axis (see [`SpanPoly::coefficients`] for the order).
    #[inline(always)]
    pub(crate) fn coefficient(&self, i: usize) -> &[f64; MAX_AXES] {
        &self.coef[i]
    }

    /// The powers σ⁰ … σ⁶ that [`SpanPoly::at`] takes (computed once for all axes).
    #[inline(always)]
    pub(crate) fn powers(sigma: f64) -> [f64; 7] {
        let s2 = sigma * sigma;
        let s3 = s2 * sigma;
        [1.0, sigma, s2, s3, s2 * s2, s2 * s3, s3 * s3]
    }

    /// A′, A″, A‴ of axis `k` at the fraction σ of the interval (increasing s) whose
    /// [`SpanPoly::powers`] are `p`: sums of independent products rather than Horner's chain
    /// of dependent steps (the limit checks spend most of their time here).
    #[inline(always)]
    pub(crate) fn at(&self, p: &[f64; 7], k: usize) -> (f64, f64, f64) {
        let c = |i: usize| self.coef[i][k];
        let d1 = (c(0) + c(1) * p[1] + c(2) * p[2]) + (c(3) * p[3] + c(4) * p[4]) + (c(5) * p[5] + c(6) * p[6]);
        let d2 = (c(7) + c(8) * p[1] + c(9) * p[2]) + (c(10) * p[3] + c(11) * p[4] + c(12) * p[5]);
        let d3 = (c(13) + c(14) * p[1] + c(15) * p[2]) + (c(16) * p[3] + c(17) * p[4]);
        (d1, d2, d3)
    }
}

/// The geometry of one interval in traversal order. `sign` is −1 for branches computed
/// backwards from the end: reversing the path flips A′ and A‴ and keeps A″.
#[derive(Clone, Copy)]
pub(super) struct IntervalGeom<'a> {
    pub start: &'a NodeGeom,
    pub end: &'a NodeGeom,
    pub ds_mm: f64,
    pub sign: f64,
    /// The exact geometry between the nodes where the path has one as a polynomial.
    pub span: Option<&'a SpanPoly>,
    /// Without `span`: interpolate with the quintic Hermite A′ (`hermite_basis::HermiteBasis`, smoothed
    /// pieces) rather than the cubic one with a linear A‴ (`check::CubicBasis`).
    pub quintic: bool,
}

impl IntervalGeom<'_> {
    /// See [`SpanPoly::fine_checks`].
    #[inline]
    pub(super) fn fine_checks(&self) -> bool {
        self.span.is_some_and(SpanPoly::fine_checks)
    }
}

/// One sample point of the path.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Node {
    /// Path position, mm.
    pub s_mm: f64,
    /// Geometry as the end of the interval before this node.
    pub left: NodeGeom,
    /// Geometry as the start of the interval after this node. Differs from `left` only at
    /// element joints.
    pub right: NodeGeom,
    /// Velocity bound v̄ at this node, mm/s (both sides, programmed feed, joint caps).
    pub vbar_mm_s: f64,
    /// The flat v̄ (Kopp et al. 2019, eq. 6, a = j = 0) under the same caps, mm/s: ≤
    /// `vbar_mm_s`, the ceiling a block is planned under first (see `block`).
    pub vbar_flat_mm_s: f64,
    /// Programmed feed of the interval after this node, mm/s (∞ for rapid moves).
    pub feed_mm_s: f64,
    /// The motion must be at rest here (corner, dwell, program start or end).
    pub stop: bool,
    /// Dwell at this node, s.
    pub dwell_s: f64,
    /// Program line of the element after this node.
    pub line: u32,
    /// The block's acceleration-only passes lowered the ceiling here (`reach`): a dip of the
    /// ceiling the motion brakes into and out of with a ≠ 0, not a stretch it can run flat.
    pub reach_bound: bool,
    /// The exact geometry of the interval to the next node, where it is a polynomial in s.
    pub span: Option<Arc<SpanPoly>>,
    /// The interval to the next node lies on a smoothed piece: its checks interpolate the
    /// geometry with the quintic Hermite A′ ([`IntervalGeom::quintic`]).
    pub quintic: bool,
}

#[cfg(test)]
impl Node {
    /// A node for unit tests: the same geometry on both sides, one bound for both ceilings and
    /// the feed, not a stop.
    pub(crate) fn for_test(s_mm: f64, g: NodeGeom, vbar_mm_s: f64) -> Node {
        Node {
            s_mm,
            left: g,
            right: g,
            vbar_mm_s,
            vbar_flat_mm_s: vbar_mm_s,
            feed_mm_s: vbar_mm_s,
            stop: false,
            dwell_s: 0.0,
            line: 1,
            reach_bound: false,
            span: None,
            quintic: false,
        }
    }
}

/// v̄ from one side's geometry: the largest path velocity at which every axis keeps its
/// velocity limit (Kopp et al. 2019, eq. 5, first term) and *some* path acceleration keeps
/// every axis within its acceleration limit (eq. 1b with a free).
///
/// Eq. 6 takes a = 0 and j = 0, which makes (v̄, 0, 0) a state that keeps every limit but is
/// far below what the axes allow where the acceleration A′a can offset the centripetal A″v²
/// (an orientation swing of rotary axes: the time-optimal motion passes there at several
/// times that v̄, braking into it and accelerating out). The jerk term is left to the interval
/// checks for the same reason. This bound is the maximum velocity curve of the
/// acceleration-only problem; the block planner lowers it to what acceleration alone can
/// reach (`reach`).
pub(super) fn velocity_bound(g: &NodeGeom, lim: &Limits) -> f64 {
    // Per axis with A′ ≠ 0 the allowed a is [p + c·x, r + c·x] with x = v², c = −A″/A′; the
    // ranges intersect iff every lower end lies below every upper end (pairwise, linear in x).
    let mut v = f64::INFINITY;
    let mut x = f64::INFINITY;
    let mut lines = [(0.0f64, 0.0f64, 0.0f64); crate::path::MAX_AXES];
    let mut n = 0;
    for k in 0..lim.n_axes {
        let (d1, d2) = (g.d1[k], g.d2[k]);
        if d1 != 0.0 {
            v = v.min(lim.vel[k] / d1.abs());
            let (lo, hi) = if d1 > 0.0 { (lim.acc_min[k], lim.acc_max[k]) } else { (lim.acc_max[k], lim.acc_min[k]) };
            lines[n] = (lo / d1, hi / d1, -d2 / d1);
            n += 1;
        } else if d2 > 0.0 {
            x = x.min(lim.acc_max[k] / d2);
        } else if d2 < 0.0 {
            x = x.min(lim.acc_min[k] / d2);
        }
    }
    for &(p, _, ck) in &lines[..n] {
        for &(_, r, cl) in &lines[..n] {
            if ck > cl {
                x = x.min((r - p) / (ck - cl));
            }
        }
    }
    v.min(x.sqrt())
}

/// v̄ from Kopp et al. 2019, eq. 6: the largest path velocity at which every axis keeps its
/// limits with a = 0 and j = 0; per axis, eq. 5 gives v ≤ Ȧ_max/|A′|, v ≤ √(Ä_max/|A″|),
/// v ≤ ∛(A⃛_max/|A‴|). Eq. 6 prints the fractions upside down and with vector norms; the
/// per-axis minimum of the eq. 5 terms is the form consistent with eq. 5. The ceiling a block
/// is planned under first (`block`), and the speed the node spacing is sized for: where the
/// motion is faster (under [`velocity_bound`]) it is braking or accelerating through a short
/// stretch.
pub(super) fn flat_velocity_bound(g: &NodeGeom, lim: &Limits) -> f64 {
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
    let v = v.min(v2.sqrt());
    // The cube root only where it can be the smallest: clearly above v it is not. (A cube root
    // costs as much as the rest of the bound; the sampling takes this bound ~9 times a node.)
    if v > 0.0 && v.is_finite() && v3 > v * v * v * (1.0 + CBRT_SKIP_REL_MARGIN) {
        return v;
    }
    v.min(v3.cbrt())
}

/// [`flat_velocity_bound`] skips the cube root where v³ clears the other bounds cubed by this
/// (relative): far above the rounding of v·v·v (a few ulp), so the result is the same to the
/// bit.
const CBRT_SKIP_REL_MARGIN: f64 = 1e-9;

/// Speed cap at a curvature jump (G¹ but not G² joint): the axis acceleration steps by
/// ΔA″·v² there. A step is an infinite jerk; the cap keeps it below what the jerk limit moves
/// in `step_s` (v²|ΔA″_k| ≤ J_k·step_s), so sampled jerk stays within the limit.
pub(super) fn curvature_jump_cap(left: &NodeGeom, right: &NodeGeom, lim: &Limits, step_s: f64) -> f64 {
    let mut v = f64::INFINITY;
    for k in 0..lim.n_axes {
        let jump = (left.d2[k] - right.d2[k]).abs();
        if jump > 0.0 {
            v = v.min((lim.jerk[k] * step_s / jump).sqrt());
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::super::check::acc_range;
    use super::*;
    use crate::Settings;
    use proptest::prelude::*;

    fn geom(d: &[f64]) -> NodeGeom {
        let mut g = NodeGeom::default();
        for k in 0..5 {
            (g.d1[k], g.d2[k], g.d3[k]) = (d[3 * k], d[3 * k + 1], d[3 * k + 2]);
        }
        g
    }

    proptest! {
        /// The acceleration-only bound is never below the flat v̄ of eq. 6, and at it some path
        /// acceleration keeps every axis within its limit (the pairwise closed form is exact);
        /// a little above it none does, unless the velocity limit binds.
        #[test]
        fn acceleration_only_bound_is_exact(d in proptest::collection::vec(-50.0f64..50.0, 15)) {
            let lim = Limits::from_settings(&Settings::five_axis_machine());
            let g = geom(&d);
            let (v, v_flat) = (velocity_bound(&g, &lim), flat_velocity_bound(&g, &lim));
            prop_assert!(v >= v_flat * (1.0 - 1e-12), "{v} < {v_flat}");
            prop_assume!(v.is_finite() && v > 0.0);
            let (lo, hi) = acc_range(&g, 1.0, v, &lim);
            prop_assert!(lo <= hi + 1e-9 * (1.0 + lo.abs().max(hi.abs())), "empty at the bound: [{lo}, {hi}]");
            let by_vel = (0..lim.n_axes).any(|k| g.d1[k] != 0.0 && (lim.vel[k] / g.d1[k].abs() - v).abs() <= 1e-12 * v);
            if !by_vel {
                let (lo, hi) = acc_range(&g, 1.0, v * 1.001, &lim);
                prop_assert!(lo > hi, "still feasible above the bound: [{lo}, {hi}]");
            }
        }
    }
}
