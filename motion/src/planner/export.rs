//! The planning problem as the planner samples it, and a profile at its nodes: what
//! `interpd plan --export-nodes` writes for an independent optimiser to compare against
//! (benches/reference/). The nodes carry A′, A″, A‴ on both sides and the velocity bound v̄
//! (Kopp et al. 2019, eq. 6 and §2.2), so the optimiser solves the same discretised problem
//! under the same profile definition (eq. 2).

use super::Planner;
use super::check::{CHECK_FRACTIONS, FINE_CHECK_FRACTIONS};
use super::limits::Limits;
use super::node::SpanPoly;
pub use super::node::{NodeGeom, SPAN_POLY_COEFS};
use super::profile::Segment;
use crate::Settings;
use crate::path::Path;

/// The sampled planning problem of a path and a profile of it at the nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeExport {
    /// The axis limits the planner works with (the configured ones times
    /// `planner.limit_fraction`).
    pub limits: Limits,
    /// Time fractions of an interval at which the planner checks the axis limits.
    pub check_fractions: &'static [f64],
    /// The same on an interval whose nodes do not interpolate its geometry well
    /// ([`ExportedNode::fine`]).
    pub fine_check_fractions: &'static [f64],
    /// At a curvature jump the axis acceleration steps by ΔA″·v²; the planner caps v there so
    /// that the step is what the jerk limit moves in this time, s (`planner.curvature_jump_ms`).
    pub curvature_jump_s: f64,
    /// The nodes in path order.
    pub nodes: Vec<ExportedNode>,
    /// Per node, the profile's segment starting there as (v₀, a₀, j, dt); `None` where no
    /// segment starts at the node (inside a block planned in closed form).
    pub profile: Vec<Option<[f64; 4]>>,
}

/// One node of a [`NodeExport`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedNode {
    /// Path position, mm.
    pub s_mm: f64,
    /// Velocity bound v̄, mm/s.
    pub vbar_mm_s: f64,
    /// Programmed feed of the interval after the node, mm/s (∞ for rapid moves).
    pub feed_mm_s: f64,
    /// The motion must be at rest here.
    pub stop: bool,
    /// Geometry as the end of the interval before the node.
    pub left: NodeGeom,
    /// Geometry as the start of the interval after the node.
    pub right: NodeGeom,
    /// The exact geometry of the interval to the next node where the path is a polynomial in
    /// s there (a path table's rows): per axis, the coefficients of A′ (σ⁰ … σ⁶), A″ (σ⁰ … σ⁵)
    /// and A‴ (σ⁰ … σ⁴) in the fraction σ ∈ [0, 1] of the interval, lowest order first.
    pub span: Option<Vec<[f64; SPAN_POLY_COEFS]>>,
    /// The interval to the next node is checked at [`NodeExport::fine_check_fractions`].
    pub fine: bool,
}

impl NodeExport {
    /// Samples `path` as the planner does and reads the profile `segments` (planned from
    /// `settings` for `path`) at the nodes.
    pub fn of(settings: &Settings, path: &Path, segments: &[Segment]) -> Self {
        let nodes = Planner::sample_path(settings, path);
        let n = path.n_axes;
        // The segment starting at each node's s (node-aligned blocks).
        let mut profile = Vec::with_capacity(nodes.len());
        let mut k = 0;
        for node in &nodes {
            while k + 1 < segments.len() && (segments[k].ds_mm == 0.0 || segments[k].s0_mm < node.s_mm - 1e-12) {
                k += 1;
            }
            let seg = &segments[k];
            let aligned = (seg.s0_mm - node.s_mm).abs() <= 1e-9 * node.s_mm.abs().max(1.0);
            profile.push(aligned.then_some([seg.v0, seg.a0, seg.j, seg.dt_s]));
        }
        let nodes = nodes
            .iter()
            .map(|nd| ExportedNode {
                s_mm: nd.s_mm,
                vbar_mm_s: nd.vbar_mm_s,
                feed_mm_s: nd.feed_mm_s,
                stop: nd.stop,
                left: nd.left,
                right: nd.right,
                span: nd.span.as_ref().map(|p| (0..n).map(|k| p.coefficients(k)).collect()),
                fine: nd.span.as_deref().is_some_and(SpanPoly::fine_checks),
            })
            .collect();
        NodeExport {
            limits: Limits::from_settings(settings),
            check_fractions: &CHECK_FRACTIONS,
            fine_check_fractions: &FINE_CHECK_FRACTIONS,
            curvature_jump_s: settings.planner.curvature_jump_ms * 1e-3,
            nodes,
            profile,
        }
    }
}
