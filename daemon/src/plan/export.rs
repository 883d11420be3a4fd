//! `--export-nodes`: the planning problem and the planner's solution at the nodes, for an
//! independent optimiser.

use super::error::PlanError;
use interpd_motion::Settings;
use interpd_motion::path::Path;
use interpd_motion::planner::Segment;
use interpd_motion::planner::export::{NodeExport, NodeGeom};
use interpd_motion::planner::profile::duration_s;

/// The planning problem and our solution at the nodes, as JSON (read by benches/reference/optimum.py; docs/planner.md).
pub(super) fn export_nodes(
    file: &std::path::Path,
    settings: &Settings,
    path: &Path,
    segments: &[Segment],
) -> Result<(), PlanError> {
    let export = NodeExport::of(settings, path, segments);
    let (n, lim) = (path.n_axes, &export.limits);
    let geom = |g: &NodeGeom| serde_json::json!({ "d1": &g.d1[..n], "d2": &g.d2[..n], "d3": &g.d3[..n] });
    let json = serde_json::json!({
        "axes": path.axis_names,
        "limits": {
            "vel": &lim.vel[..n], "acc_max": &lim.acc_max[..n], "acc_min": &lim.acc_min[..n], "jerk": &lim.jerk[..n],
        },
        "check_fractions": export.check_fractions,
        // The check points of a node's interval where it is "fine".
        "fine_check_fractions": export.fine_check_fractions,
        "curvature_jump_s": export.curvature_jump_s,
        "nodes": export.nodes.iter().map(|nd| serde_json::json!({
            "s": nd.s_mm, "vbar": nd.vbar_mm_s, "feed": if nd.feed_mm_s.is_finite() { nd.feed_mm_s } else { f64::MAX },
            "stop": nd.stop, "left": geom(&nd.left), "right": geom(&nd.right),
            // A path table's exact geometry to the next node, which the checks evaluate there.
            "span": nd.span,
            "fine": nd.fine,
        })).collect::<Vec<_>>(),
        "profile": export.profile,
        "duration_s": duration_s(segments),
    });
    std::fs::write(file, json.to_string()).map_err(|source| PlanError::ExportNodes { path: file.to_path_buf(), source })
}
