//! The move from where the machine stands to where a program starts.
//!
//! A program is parsed from machine zero (G-code) or brings its own start (path tables). When
//! the machine stands elsewhere, a straight rapid move (G0, within the axis limits, ending at
//! rest) to the program's start runs first, as part of the same motion.

use interpd_config::{AxisKind, Config};
use interpd_motion::path::{AxisVec, Blend, Feed, Geometry, Line, Path, Source};

/// Distances below this (in every axis) count as being at the program start.
pub const AT_START_TOL: f64 = 1e-9;

/// The straight line from `here` to `start`, `None` when the machine stands there. Its length
/// counts over the linear axes, or over the rotary ones when no linear axis moves
/// (`linear[k]`: axis k is linear).
pub fn approach_line(linear: &[bool], here: &AxisVec, start: &AxisVec) -> Option<Geometry> {
    let n = linear.len();
    if (0..n).all(|k| (here[k] - start[k]).abs() <= AT_START_TOL) {
        return None;
    }
    let dist =
        |lin: bool| (0..n).filter(|&k| linear[k] == lin).map(|k| (start[k] - here[k]).powi(2)).sum::<f64>().sqrt();
    let along_linear = dist(true);
    let length = if along_linear > AT_START_TOL { along_linear } else { dist(false) };
    Some(Geometry::Line(Line::new(*here, *start, length)))
}

/// `path`, preceded by a rapid line from `here` if the machine is not at its start (a whole
/// path; a running program is streamed behind the same line by `PathFeed`).
pub fn with_approach(path: &Path, here: &AxisVec, config: &Config) -> Path {
    let linear: Vec<bool> =
        (0..path.n_axes).map(|k| config.axes.get(k).is_some_and(|a| a.kind == AxisKind::Linear)).collect();
    let Some(line) = approach_line(&linear, here, &path.start) else { return path.clone() };
    let mut out = Path::new(path.axis_names.clone(), *here);
    out.push(line, Feed::Rapid, Source::default(), 0.0, Blend::Exact);
    for e in &path.elements {
        out.push(e.geometry.clone(), e.feed, e.source, e.dwell_before_s, e.blend);
    }
    out.final_dwell_s = path.final_dwell_s;
    out
}
