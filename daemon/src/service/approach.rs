//! The move from where the machine stands to where a program starts.
//!
//! A program is parsed from machine zero (G-code) or brings its own start (path tables). When
//! the machine stands elsewhere, a straight rapid move (G0, within the axis limits, ending at
//! rest) to the program's start runs first, as part of the same motion.

use interpd_config::{AxisKind, Config};
use interpd_motion::path::{AxisVec, Blend, Feed, Geometry, Line, Path, Source};

/// Distances below this (in every axis) count as being at the program start.
pub const AT_START_TOL: f64 = 1e-9;

/// `path`, preceded by a rapid line from `here` if the machine is not at its start.
pub fn with_approach(path: &Path, here: &AxisVec, config: &Config) -> Path {
    let n = path.n_axes;
    let apart = (0..n).any(|k| (here[k] - path.start[k]).abs() > AT_START_TOL);
    if !apart {
        return path.clone();
    }
    let dist = |kind: AxisKind| {
        (0..n)
            .filter(|&k| config.axes.get(k).is_some_and(|a| a.kind == kind))
            .map(|k| (path.start[k] - here[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let linear = dist(AxisKind::Linear);
    let length = if linear > AT_START_TOL { linear } else { dist(AxisKind::Rotary) };
    let mut out = Path::new(path.axis_names.clone(), *here);
    out.push(Geometry::Line(Line::new(*here, path.start, length)), Feed::Rapid, Source::default(), 0.0, Blend::Exact);
    for e in &path.elements {
        out.push(e.geometry.clone(), e.feed, e.source, e.dwell_before_s, e.blend);
    }
    out.final_dwell_s = path.final_dwell_s;
    out
}
