//! The move from where the machine stands to where a path starts.
//!
//! A program is parsed from machine zero (G-code) or brings its own start (path tables). When
//! the machine stands elsewhere, a straight rapid move (G0, within the axis limits, ending at
//! rest) to the program's start runs first, as part of the same motion.

use crate::Settings;
use crate::path::{AxisVec, Blend, Feed, Geometry, Line, Path, Source};
use interpd_config::AxisKind;

/// Distances below this (in every axis) count as standing at a position.
pub const AT_POSITION_TOL: f64 = 1e-9;

/// The path a motion from `here` runs first: the straight rapid line to `start`, or nothing
/// when the machine stands there. The line's length counts over the linear axes, or over the
/// rotary ones when no linear axis moves.
pub(super) fn approach(settings: &Settings, here: &AxisVec, start: &AxisVec) -> Path {
    let mut path = Path::new(settings.axis_names(), *here);
    let n = settings.axes.len();
    if (0..n).all(|k| (here[k] - start[k]).abs() <= AT_POSITION_TOL) {
        return path;
    }
    let dist = |kind: AxisKind| {
        (0..n).filter(|&k| settings.axes[k].kind == kind).map(|k| (start[k] - here[k]).powi(2)).sum::<f64>().sqrt()
    };
    let along_linear = dist(AxisKind::Linear);
    let length = if along_linear > AT_POSITION_TOL { along_linear } else { dist(AxisKind::Rotary) };
    path.push(Geometry::Line(Line::new(*here, *start, length)), Feed::Rapid, Source::default(), 0.0, Blend::Exact);
    path
}

/// `path` behind [`approach`] from `here` (a path held whole).
pub(super) fn with_approach(settings: &Settings, here: &AxisVec, path: Path) -> Path {
    let mut out = approach(settings, here, &path.start);
    if out.elements.is_empty() {
        return path;
    }
    for e in path.elements {
        out.push(e.geometry, e.feed, e.source, e.dwell_before_s, e.blend);
        if let Some(last) = out.elements.last_mut() {
            last.pause_before = e.pause_before;
        }
    }
    out.final_dwell_s = path.final_dwell_s;
    out
}
