//! Cutter radius compensation on the exact geometry: contours of lines, convex and concave
//! arcs, and a closed G06 ellipse of 20 support points (Huan's example), each traversed both
//! ways with G41/G42 (tool table) and G41.1/G42.1 (diameter). Every sampled point of the
//! planned motion (0.25 ms), away from the entry and exit moves, lies at the tool radius from
//! the programmed contour within 1 µm and on the programmed side, and the motion keeps the axis
//! limits (velocity and acceleration ≤ 1.001 ×, jerk ≤ 1.02 ×). With G64 P the smoothed
//! compensated path stays within the tolerance of the exact offset.

use interpd_motion::Settings;
use interpd_motion::config::ToolConfig;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::Planner;
use interpd_motion::planner::profile::{Cursor, duration_s, limit_ratios};
use interpd_motion::prep::prepare_path;
use interpd_motion::program;
use std::f64::consts::PI;

/// The compensated path is held to the exact offset within this, mm.
const OFFSET_TOL_MM: f64 = 1e-3;
const DT_S: f64 = 2.5e-4;
const TOOL_DIAMETER_MM: f64 = 6.0;

fn machine() -> Settings {
    let mut s = Settings::default_machine();
    s.tools = vec![ToolConfig { number: 1, diameter_mm: TOOL_DIAMETER_MM, length_mm: 40.0, name: None }];
    s
}

/// A closed contour starting and ending in the middle of its bottom edge at (20, 0): lines,
/// convex and concave arcs of radius 10, a V notch (an inside corner from either side) and
/// sharp corners. Counter-clockwise or clockwise.
/// A contour point with the arc that ends there, if any: (clockwise when traversed
/// counter-clockwise, I, J).
type ContourPoint = (f64, f64, Option<(bool, f64, f64)>);
/// Where the tool approaches from and where the contour starts.
type Approach = fn(bool) -> ((f64, f64), (f64, f64));

fn shape_blocks(ccw: bool) -> Vec<String> {
    let ccw_path: Vec<ContourPoint> = vec![
        (40.0, 0.0, None),
        (50.0, 10.0, Some((false, 0.0, 10.0))), // convex
        (50.0, 30.0, None),
        (40.0, 40.0, Some((true, 0.0, 10.0))), // concave: centre (50, 40)
        (30.0, 40.0, None),
        (25.0, 30.0, None), // V notch
        (20.0, 40.0, None),
        (10.0, 40.0, None),
        (0.0, 30.0, Some((false, 0.0, -10.0))), // convex: centre (10, 30)
        (0.0, 0.0, None),
        (20.0, 0.0, None),
    ];
    let start = (20.0, 0.0);
    let mut pts = vec![(start.0, start.1, None)];
    pts.extend(ccw_path);
    let mut out = Vec::new();
    if ccw {
        for w in pts.windows(2) {
            let (x, y, arc) = w[1];
            out.push(match arc {
                None => format!("G1 X{x} Y{y}"),
                Some((cw, i, j)) => format!("G{} X{x} Y{y} I{i} J{j}", if cw { 2 } else { 3 }),
            });
        }
    } else {
        for w in pts.windows(2).rev() {
            let (x, y, _) = w[0];
            let (ex, ey, arc) = w[1];
            out.push(match arc {
                None => format!("G1 X{x} Y{y}"),
                Some((cw, i, j)) => {
                    // The same circle from the other end: I J were taken from (x, y).
                    let (cx, cy) = (x + i, y + j);
                    format!("G{} X{x} Y{y} I{} J{}", if cw { 3 } else { 2 }, cx - ex, cy - ey)
                }
            });
        }
    }
    out
}

/// Huan's ellipse (a = 40, b = 20) through 20 support points with tangents, closed at (40, 0),
/// counter-clockwise or clockwise.
fn ellipse_blocks(ccw: bool) -> Vec<String> {
    let n = 20;
    let dir = if ccw { 1.0 } else { -1.0 };
    let mut out = vec![format!("G06 I0 J{} K0", dir * 20.0 * 2.0 * PI / n as f64)];
    for i in 1..=n {
        let th = dir * 2.0 * PI * i as f64 / n as f64;
        let (x, y) = (40.0 * th.cos(), 20.0 * th.sin());
        let k = dir * 2.0 * PI / n as f64;
        let (tx, ty) = (-40.0 * th.sin() * k, 20.0 * th.cos() * k);
        out.push(format!("X{x:.9} Y{y:.9} Z0 P{tx:.9} Q{ty:.9} R0;"));
    }
    out.push("CR".into());
    out
}

/// The program: approach, the compensation word, the entry move to the contour start, the
/// contour, G40 with the exit move. Returns (text, entry line, exit line).
fn program(comp: &str, approach: (f64, f64), start: (f64, f64), contour: &[String], blend: &str) -> (String, u32, u32) {
    let mut lines = vec![
        "G21 G90 G17".to_string(),
        blend.to_string(),
        format!("G0 X{} Y{} Z0", approach.0, approach.1),
        "F3000".to_string(),
        comp.to_string(),
        format!("G1 X{} Y{}", start.0, start.1),
    ];
    let entry = lines.len() as u32;
    lines.extend(contour.iter().cloned());
    lines.push(format!("G40 G1 X{} Y{}", approach.0, approach.1));
    let exit = lines.len() as u32;
    (lines.join("\n") + "\n", entry, exit)
}

/// Nearest point of the contour to (x, y): (distance, side) with side > 0 when the point lies
/// left of the direction of travel there, 0 when the nearest point is a corner (an element's
/// end, where the tool turns around it and the side is that of the distance alone).
/// A circle in the plane that holds an element: its centre and radius, mm.
type Bound = ((f64, f64), f64);

/// The bounding circle of each element of `contour` (from its samples and the largest gap
/// between them, so no point of the element lies outside).
fn bounds(contour: &Path) -> Vec<Bound> {
    let mut d = AxisDerivs::default();
    contour
        .elements
        .iter()
        .map(|e| {
            let len = e.geometry.length_mm();
            let n = 16;
            let pts: Vec<(f64, f64)> = (0..=n)
                .map(|i| {
                    e.geometry.eval(len * i as f64 / n as f64, &mut d);
                    (d.pos[0], d.pos[1])
                })
                .collect();
            let c = (
                pts.iter().map(|p| p.0).sum::<f64>() / pts.len() as f64,
                pts.iter().map(|p| p.1).sum::<f64>() / pts.len() as f64,
            );
            // A point between two samples lies within half the arc length between them of one of them.
            let r = pts.iter().map(|p| (p.0 - c.0).hypot(p.1 - c.1)).fold(0.0, f64::max) + 0.5 * len / n as f64;
            (c, r)
        })
        .collect()
}

/// Distance from (x, y) to the contour and on which side of it (positive: left of the
/// direction of travel; 0 at an element's end).
fn nearest(contour: &Path, bounds: &[Bound], x: f64, y: f64) -> (f64, f64) {
    let mut best = (f64::INFINITY, 0.0);
    let mut d = AxisDerivs::default();
    // Nearest bounding circles first, and none whose circle lies farther than the best found.
    let mut order: Vec<(f64, usize)> =
        bounds.iter().enumerate().map(|(i, ((cx, cy), r))| (((x - cx).hypot(y - cy) - r).max(0.0), i)).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (lower_bound, i) in order {
        if lower_bound > best.0 {
            break;
        }
        let e = &contour.elements[i];
        let len = e.geometry.length_mm();
        let n = ((len / 0.2) as usize).max(8);
        let mut s_best = (f64::INFINITY, 0.0);
        for i in 0..=n {
            let s = len * i as f64 / n as f64;
            e.geometry.eval(s, &mut d);
            let dist = (d.pos[0] - x).hypot(d.pos[1] - y);
            if dist < s_best.0 {
                s_best = (dist, s);
            }
        }
        // Newton on (P(s) − x)·P′(s) = 0 (unit speed in the plane: P′·P′ = 1).
        let mut s = s_best.1;
        for _ in 0..30 {
            e.geometry.eval(s, &mut d);
            let (rx, ry) = (d.pos[0] - x, d.pos[1] - y);
            let f = rx * d.d1[0] + ry * d.d1[1];
            let fp = d.d1[0].powi(2) + d.d1[1].powi(2) + rx * d.d2[0] + ry * d.d2[1];
            let next = (s - f / fp).clamp(0.0, len);
            if (next - s).abs() < 1e-13 {
                break;
            }
            s = next;
        }
        e.geometry.eval(s, &mut d);
        let (rx, ry) = (x - d.pos[0], y - d.pos[1]);
        let dist = rx.hypot(ry);
        if dist < best.0 {
            let at_end = s <= 1e-9 || s >= len - 1e-9;
            best = (dist, if at_end { 0.0 } else { d.d1[0] * ry - d.d1[1] * rx });
        }
    }
    best
}

struct Figures {
    worst_offset_err_mm: f64,
    samples: usize,
    ratios: [f64; 3],
}

/// Plans `text` (with `prepare` for G64 programs) and checks every 0.25 ms sample outside the
/// entry and exit lines against the contour of `contour_text`.
fn check(text: &str, contour_text: &str, entry: u32, exit: u32, left: bool, band_mm: f64) -> Figures {
    let settings = machine();
    let prog = program::parse(text, "comp.ngc", &settings).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let contour = program::parse(contour_text, "contour.ngc", &settings).unwrap_or_else(|e| panic!("{e}"));
    let mut contour_path = contour.path.clone();
    contour_path.elements.retain(|e| e.source.line > entry && e.source.line < exit);
    let contour_bounds = bounds(&contour_path);
    let path = if band_mm > 0.0 { prepare_path(&settings, &prog.path).expect("prepare").path } else { prog.path };
    let (segs, _) = Planner::plan_path(&settings, &path).expect("plan");
    assert_continuous(&path, text);
    let ratios = limit_ratios(&path, &segs, &settings, DT_S);
    let r = TOOL_DIAMETER_MM / 2.0;
    let mut cursor = Cursor::default();
    let mut d = AxisDerivs::default();
    let mut worst: f64 = 0.0;
    let mut samples = 0;
    let mut corner_samples = 0;
    let n = (duration_s(&segs) / DT_S) as usize + 1;
    for k in 0..=n {
        let Some(sample) = cursor.sample(&segs, k as f64 * DT_S) else { break };
        let s = sample.state.s_mm;
        let el = &path.elements[path.element_index_at(s)];
        if el.source.line <= entry || el.source.line >= exit {
            continue;
        }
        path.eval(s, &mut d);
        let (dist, side) = nearest(&contour_path, &contour_bounds, d.pos[0], d.pos[1]);
        let err = (dist - r).abs();
        assert!(
            err <= OFFSET_TOL_MM + band_mm,
            "at s = {s:.4} mm (line {}) ({:.6}, {:.6}): distance {dist:.7} mm from the contour, tool radius {r}",
            el.source.line,
            d.pos[0],
            d.pos[1]
        );
        assert!(side * if left { 1.0 } else { -1.0 } >= 0.0, "at s = {s} mm the tool is on the wrong side");
        corner_samples += usize::from(side == 0.0);
        worst = worst.max(err);
        samples += 1;
    }
    assert!(samples > 1000, "too few samples on the contour: {samples}");
    assert!(corner_samples < samples / 4, "{corner_samples} of {samples} samples nearest to a corner");
    assert!(
        ratios[0] <= 1.001 && ratios[1] <= 1.001 && ratios[2] <= 1.02,
        "limit ratios v/a/j {ratios:?} beyond 1.001/1.001/1.02"
    );
    Figures { worst_offset_err_mm: worst, samples, ratios }
}

/// Every combination of direction and side for a contour, in both D forms.
fn all_ways(name: &str, blocks: fn(bool) -> Vec<String>, approach_start: Approach, blend: &str) {
    let band = match blend.strip_prefix("G64 P") {
        Some(p) => p.parse::<f64>().expect("tolerance"),
        None => 0.0,
    };
    for ccw in [true, false] {
        let contour = blocks(ccw);
        let (approach, start) = approach_start(ccw);
        for comp in ["G41 D1", "G42 D1", "G41.1 D6", "G42.1 D6"] {
            let (text, entry, exit) = program(comp, approach, start, &contour, blend);
            let (plain, _, _) = program("", approach, start, &contour, blend);
            let f = check(&text, &plain, entry, exit, comp.starts_with("G41"), band);
            eprintln!(
                "{name} {} {comp} {blend}: {} samples, worst |distance − r| {:.3e} mm, limit ratios v {:.4} a {:.4} j {:.4}",
                if ccw { "ccw" } else { "cw" },
                f.samples,
                f.worst_offset_err_mm,
                f.ratios[0],
                f.ratios[1],
                f.ratios[2]
            );
        }
    }
}

// The entry move (as LinuxCNC) ends at the offset of its own end point and meets the contour
// at an ordinary corner; on a closed contour a corner arc around the start point would touch
// the contour's last element, so the approach runs along the contour's first tangent.
fn shape_approach(ccw: bool) -> ((f64, f64), (f64, f64)) {
    (if ccw { (10.0, 0.0) } else { (30.0, 0.0) }, (20.0, 0.0))
}

fn ellipse_approach(ccw: bool) -> ((f64, f64), (f64, f64)) {
    (if ccw { (40.0, -10.0) } else { (40.0, 10.0) }, (40.0, 0.0))
}

#[test]
fn lines_and_arcs_are_offset_exactly_on_both_sides_both_ways() {
    all_ways("shape", shape_blocks, shape_approach, "G61");
}

#[test]
fn the_g06_ellipse_is_offset_within_a_micrometre_on_both_sides_both_ways() {
    all_ways("ellipse", ellipse_blocks, ellipse_approach, "G61");
}

#[test]
fn smoothing_applies_to_the_compensated_path_within_its_tolerance() {
    all_ways("shape", shape_blocks, shape_approach, "G64 P0.01");
    all_ways("ellipse", ellipse_blocks, ellipse_approach, "G64 P0.01");
}

fn errors(text: &str) -> String {
    match program::parse(text, "bad.ngc", &machine()) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.0[0].to_string(),
    }
}

#[test]
fn gouges_and_misuse_are_errors_with_line_and_column() {
    // A concave arc of radius 2 mm with a 3 mm tool on its inside.
    let e = errors("G0 X0 Y0\nF1000\nG41 D1\nG1 X10 Y0\nG1 X20 Y0\nG3 X24 Y0 I2 J0\nG1 X30 Y0\n");
    assert!(
        e.starts_with("bad.ngc:6:1: cutter compensation: the tool radius 3 mm is not smaller than the radius 2 mm"),
        "{e}"
    );
    // An unknown tool.
    assert_eq!(errors("G41 D7\n"), "bad.ngc:1:5: tool 7 is not in the tool table");
    // G41 twice.
    assert_eq!(
        errors("G41 D1\nG42 D1\n"),
        "bad.ngc:2:1: G42 while cutter compensation is already on: program G40 first"
    );
    // A plane change while on.
    assert_eq!(
        errors("G41 D1\nG18\n"),
        "bad.ngc:2:1: cannot change the plane to G18 (ZX) with cutter compensation on: program G40 first"
    );
    // A slot narrower than the tool: the inside corners cannot be reached.
    let e =
        errors("G0 X0 Y0\nF1000\nG42 D1\nG1 X10 Y0\nG1 X10 Y20\nG1 X14 Y20\nG1 X14 Y0\nG1 X30 Y0\nG40 G1 X30 Y-10\n");
    assert!(e.contains("cannot reach the inside corner"), "{e}");
    // A short last element that the inside corner swallows with nothing after it to meet.
    let e = errors("G0 X0 Y0\nF1000\nG41 D1\nG1 X10 Y0\nG1 X10 Y10\nG1 X9.99 Y10\nG40 G1 X0 Y20\n");
    assert!(e.starts_with("bad.ngc:6:1: cutter compensation: the tool (radius 3 mm) cannot reach"), "{e}");
    // The same followed by an outside corner.
    let e = errors("G0 X0 Y0\nF1000\nG41 D1\nG1 X10 Y0\nG1 X10 Y10\nG1 X9.99 Y10\nG1 X9.99 Y0\n");
    assert!(e.starts_with("bad.ngc:6:1: cutter compensation: the tool (radius 3 mm) cannot reach"), "{e}");
    // A spline whose curvature radius on the tool's side is below the tool radius.
    let e = errors("G0 X6 Y0\nF1000\nG41 D1\nG1 X1 Y0\nG06\nX0 Y1 Z0;\nX-1 Y0 Z0;\nCR\n");
    assert!(e.contains("the spline turns on a radius of"), "{e}");
    // An entry move not longer than the tool radius (LinuxCNC refuses it too).
    let e = errors("G0 X0 Y0\nF1000\nG41 D1\nG1 X3 Y0\nG1 X3 Y10\n");
    assert_eq!(
        e,
        "bad.ngc:4:1: cutter compensation: the entry move is not longer than the tool radius 3 mm: start it further from the contour"
    );
    // An entry arc that ends within the tool radius of where the tool stands.
    let e = errors("G0 X0 Y0\nF1000\nG41 D1\nG2 X2 Y0 I1 J0\nG1 X2 Y10\n");
    assert!(e.starts_with("bad.ngc:4:1: cutter compensation: the entry move is not longer"), "{e}");
}

#[test]
fn entries_end_where_linuxcnc_ends_them() {
    // G41 with a 3 mm tool: the entry along +X ends at (10, 3), the offset of its end point;
    // the inside corner to +Y moves that end back along the entry's direction to where the
    // offsets meet, (7, 3) (LinuxCNC's convert_straight_comp2), not to where the entry line
    // itself crosses the next offset.
    let p = program::parse("G0 X0 Y0 Z0\nF1000\nG41 D1\nG1 X10 Y0\nG1 X10 Y10\nG40 G1 X10 Y20\n", "e.ngc", &machine())
        .expect("accepted");
    assert_ends(&ends(&p.path), &[[7.0, 3.0, 0.0], [7.0, 10.0, 0.0], [10.0, 20.0, 0.0]]);
    // An arc entry (G3 from (0, 0) to (10, 10) about (0, 10), tool left: inside the arc) ends
    // 3 mm towards the centre, at (7, 10), on an arc about a new centre on that radius.
    let p = program::parse("G0 X0 Y0 Z0\nF1000\nG41 D1\nG3 X10 Y10 I0 J10\nG1 X10 Y20\n", "e.ngc", &machine())
        .expect("accepted");
    let e = ends(&p.path);
    assert_ends(&e[..1], &[[7.0, 10.0, 0.0]]);
    match &p.path.elements[0].geometry {
        interpd_motion::path::Geometry::Helix(h) => {
            let c = h.center();
            let (r0, r1) = (c[0].hypot(c[1]), (7.0 - c[0]).hypot(10.0 - c[1]));
            assert!((r0 - r1).abs() < 1e-9 && (c[1] - 10.0).abs() < 1e-9, "centre {c:?}");
        }
        g => panic!("entry arc expected, got {}", g.kind_name()),
    }
}

#[test]
fn tool_length_and_work_offsets_move_the_programmed_coordinates() {
    let mut settings = machine();
    settings.work_offsets.g55.insert("X".into(), 100.0);
    settings.work_offsets.g55.insert("Z".into(), -5.0);
    let p = program::parse("G55 G43 H1\nG0 X1 Y2 Z3\nG49 G54\nG0 X1 Y2 Z3\nG43.1 Z2.5\nG0 Z0\n", "t.ngc", &settings)
        .unwrap_or_else(|e| panic!("{e}"));
    let ends: Vec<[f64; 3]> = p
        .path
        .elements
        .iter()
        .map(|e| {
            let mut d = AxisDerivs::default();
            e.geometry.eval(e.geometry.length_mm(), &mut d);
            [d.pos[0], d.pos[1], d.pos[2]]
        })
        .collect();
    let want = [[101.0, 2.0, 38.0], [1.0, 2.0, 3.0], [1.0, 2.0, 2.5]];
    assert_eq!(ends.len(), want.len());
    for (got, want) in ends.iter().zip(want) {
        assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12), "{got:?} against {want:?}");
    }
    assert_eq!(p.summary.tools.iter().copied().collect::<Vec<_>>(), vec![1]);
    assert_eq!(p.summary.work_offsets.iter().copied().collect::<Vec<_>>(), vec!["G54", "G55"]);
}

/// The end points of the path's elements in X, Y, Z.
fn ends(path: &Path) -> Vec<[f64; 3]> {
    path.elements
        .iter()
        .map(|e| {
            let mut d = AxisDerivs::default();
            e.geometry.eval(e.geometry.length_mm(), &mut d);
            [d.pos[0], d.pos[1], d.pos[2]]
        })
        .collect()
}

fn assert_ends(got: &[[f64; 3]], want: &[[f64; 3]]) {
    assert_eq!(got.len(), want.len(), "{got:?} against {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(g.iter().zip(w).all(|(a, b)| (a - b).abs() < 1e-9), "{got:?} against {want:?}");
    }
}

#[test]
fn a_plunge_at_a_corner_and_a_reversal_are_carried_out_at_the_offset() {
    // G41 (tool left, 3 mm): entry along +X, a plunge at (10, 0), an outside corner turning
    // right at (20, 0) ... then a reversal at (20, -10) back up, and the exit.
    let text = "G0 X0 Y0 Z5\nF1000\nG41 D1\nG1 X10 Y0\nG1 Z-1\nG1 X20 Y0\nG1 X20 Y-10\nG1 X20 Y0\nG40 G1 X30 Y0\n";
    let p = program::parse(text, "t.ngc", &machine()).unwrap_or_else(|e| panic!("{e}"));
    assert_ends(
        &ends(&p.path),
        &[
            [0.0, 0.0, 5.0],   // G0 to the start
            [10.0, 3.0, 5.0],  // entry to the offset of its end
            [10.0, 3.0, -1.0], // the plunge, at the offset
            [20.0, 3.0, -1.0], // along Y = 3
            [23.0, 0.0, -1.0], // corner arc around (20, 0), turning right
            [23.0, -10.0, -1.0],
            [17.0, -10.0, -1.0], // half circle around the reversal at (20, -10)
            [17.0, 0.0, -1.0],
            [30.0, 0.0, -1.0], // exit from the offset to the programmed point
        ],
    );
}

#[test]
fn the_cusp_between_two_humps_is_an_inside_corner_for_the_tool_above_them() {
    // Two clockwise half circles of radius 5 about (5, 0) and (15, 0) meet at (10, 0) turning
    // back (a reversal); the tool (radius 1) on their left runs above them: as LinuxCNC, the
    // cusp is an inside corner and both offsets (radius 6) are trimmed where they cross, at
    // (10, √11). The entry ends where its parallel offset meets the first hump's, at
    // (5 − √35, 1), and the line after the humps starts at (15 + √35, 1).
    let text = "G0 X-10 Y0\nF1000\nG41.1 D2\nG1 X0 Y0\nG2 X10 Y0 I5 J0\nG2 X20 Y0 I5 J0\nG1 X30 Y0\nG40 G1 X30 Y-10\n";
    let p = program::parse(text, "t.ngc", &machine()).unwrap_or_else(|e| panic!("{e}"));
    let (s35, s11) = (35f64.sqrt(), 11f64.sqrt());
    assert_ends(
        &ends(&p.path),
        &[
            [-10.0, 0.0, 0.0],
            [5.0 - s35, 1.0, 0.0],
            [10.0, s11, 0.0],
            [15.0 + s35, 1.0, 0.0],
            [30.0, 1.0, 0.0],
            [30.0, -10.0, 0.0],
        ],
    );
    // On the right the tool runs inside the humps: the cusp is an outside corner, passed
    // around on an arc of the tool radius.
    let p = program::parse(&text.replace("G41.1", "G42.1"), "t.ngc", &machine()).unwrap_or_else(|e| panic!("{e}"));
    let e = ends(&p.path);
    assert_eq!(e.len(), 9, "{e:?}");
    assert!((e[3][0] - 9.0).abs() < 1e-9 && (e[4][0] - 11.0).abs() < 1e-9 && e[4][1].abs() < 1e-9, "{e:?}");
}

#[test]
fn compensation_works_in_the_zx_plane() {
    // G18: the plane is Z X, counter-clockwise as G3 turns (seen from +Y). Travelling along +Z
    // (direction (1, 0) in (Z, X)), left is a quarter turn counter-clockwise: (0, 1), i.e. +X.
    let text = "G18\nF1000\nG41.1 D4\nG1 Z10\nG1 Z20\nG40 G1 Z30\n";
    let p = program::parse(text, "t.ngc", &machine()).unwrap_or_else(|e| panic!("{e}"));
    assert_ends(&ends(&p.path), &[[2.0, 0.0, 10.0], [2.0, 0.0, 20.0], [0.0, 0.0, 30.0]]);
}

#[test]
fn a_dense_cam_polyline_with_rounded_points_is_compensated_on_both_sides() {
    // The first 8000 chords (about 20 µm, points rounded to 0.1 µm, moving in Z too) of the
    // dense free-form example: between collinear chords the turn is a rounding residue
    // (~1e-12 rad), where the offsets are too close to parallel to intersect.
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/dense_freeform.ngc"))
        .expect("read the example");
    let moves: Vec<&str> = text.lines().filter(|l| l.starts_with('X')).take(8000).collect();
    // Approach along the first chord, 5 mm before the start (19.1770, 56.5968).
    let (x0, y0): (f64, f64) = (19.1770, 56.5968);
    let (dx, dy) = (19.1963 - x0, 56.6023 - y0);
    let n = dx.hypot(dy);
    for comp in ["G41.1 D0.2", "G42.1 D0.2"] {
        let program = format!(
            "G21 G90 G17\nG0 X{:.6} Y{:.6} Z0\nF6000\n{comp}\nG1 X{x0} Y{y0} Z0\n{}\nG40 G1 X0 Y0\n",
            x0 - 5.0 * dx / n,
            y0 - 5.0 * dy / n,
            moves.join("\n")
        );
        let p = program::parse(&program, "dense.ngc", &machine()).unwrap_or_else(|e| panic!("{comp}: {e}"));
        assert!(p.path.elements.len() >= 8000, "{comp}: {} elements", p.path.elements.len());
        // The chords climb in Z: trimmed at an inside corner in the plane, consecutive
        // elements still meet exactly.
        assert_continuous(&p.path, comp);
    }
}

/// Every element starts where the one before ends (1e-9 mm in every axis).
fn assert_continuous(path: &Path, what: &str) {
    let (mut a, mut b) = (AxisDerivs::default(), AxisDerivs::default());
    for w in path.elements.windows(2) {
        w[0].geometry.eval(w[0].geometry.length_mm(), &mut a);
        w[1].geometry.eval(0.0, &mut b);
        let gap = (0..path.n_axes).map(|k| (a.pos[k] - b.pos[k]).abs()).fold(0.0, f64::max);
        assert!(gap <= 1e-9, "{what}: a gap of {gap} mm before line {}", w[1].source.line);
    }
}

/// Radius of the circle the short-chord contours follow, mm.
const CHORD_CIRCLE_MM: f64 = 5.0;

/// Points of the circle of radius 5 mm about the origin from (5, 0) counter-clockwise, one
/// turn, with chords of the `lengths` in turn (a CAM polyline of short chords).
fn chord_points(lengths: &[f64]) -> Vec<(f64, f64)> {
    let (mut a, mut i, mut out) = (0.0f64, 0, Vec::new());
    while a < 2.0 * PI - 1e-9 {
        a = (a + lengths[i % lengths.len()] / CHORD_CIRCLE_MM).min(2.0 * PI);
        out.push((CHORD_CIRCLE_MM * a.cos(), CHORD_CIRCLE_MM * a.sin()));
        i += 1;
    }
    out
}

/// Distance from (x, y) to the closed polygon through `points` (starting at (5, 0)).
fn polygon_distance(points: &[(f64, f64)], x: f64, y: f64) -> f64 {
    let mut prev = (CHORD_CIRCLE_MM, 0.0);
    // Squared distances: one square root per sample, not per chord.
    let mut best = f64::INFINITY;
    for &p in points {
        let (dx, dy) = (p.0 - prev.0, p.1 - prev.1);
        let t = (((x - prev.0) * dx + (y - prev.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        let (ex, ey) = (prev.0 + t * dx - x, prev.1 + t * dy - y);
        best = best.min(ex * ex + ey * ey);
        prev = p;
    }
    best.sqrt()
}

/// The circle of short chords (or short arcs) from its centre, compensated by `comp`; every
/// 0.25 ms sample off the entry and exit moves lies at the tool radius `r` from the contour
/// within 1 µm (inside it for G41, outside for G42), within the axis limits.
fn check_chords(name: &str, lengths: &[f64], arcs: bool, comp: &str, r: f64) {
    let points = chord_points(lengths);
    // Inside, the entry comes from the centre (and swallows the first elements); outside, it
    // runs along the first tangent (a corner arc around the start point would touch the
    // contour's last elements).
    let (ax, ay) = if comp.starts_with("G41") { (0.0, 0.0) } else { (CHORD_CIRCLE_MM, -10.0) };
    let mut lines = vec!["G21 G90 G17 G61".to_string(), format!("G0 X{ax} Y{ay} Z0"), "F3000".into(), comp.into()];
    lines.push(format!("G1 X{CHORD_CIRCLE_MM} Y0"));
    let entry = lines.len() as u32;
    let mut from = (CHORD_CIRCLE_MM, 0.0);
    for &(x, y) in &points {
        if arcs {
            lines.push(format!("G3 X{x:.9} Y{y:.9} I{:.9} J{:.9}", -from.0, -from.1));
            from = (x, y);
        } else {
            lines.push(format!("G1 X{x:.9} Y{y:.9}"));
        }
    }
    lines.push(format!("G40 G1 X{ax} Y{ay}"));
    let exit = lines.len() as u32;
    let text = lines.join("\n") + "\n";
    let settings = machine();
    let prog = program::parse(&text, "chords.ngc", &settings).unwrap_or_else(|e| panic!("{name} {comp}: {e}"));
    let path = prog.path;
    assert_continuous(&path, name);
    let (segs, _) = Planner::plan_path(&settings, &path).expect("plan");
    let ratios = limit_ratios(&path, &segs, &settings, DT_S);
    let (mut cursor, mut d) = (Cursor::default(), AxisDerivs::default());
    let (mut worst, mut samples) = (0.0f64, 0);
    let n = (duration_s(&segs) / DT_S) as usize + 1;
    for k in 0..=n {
        let Some(sample) = cursor.sample(&segs, k as f64 * DT_S) else { break };
        let s = sample.state.s_mm;
        let line = path.elements[path.element_index_at(s)].source.line;
        if line <= entry || line >= exit {
            continue;
        }
        path.eval(s, &mut d);
        let (x, y) = (d.pos[0], d.pos[1]);
        let dist = if arcs { (x.hypot(y) - CHORD_CIRCLE_MM).abs() } else { polygon_distance(&points, x, y) };
        let inside = x.hypot(y) < CHORD_CIRCLE_MM;
        assert_eq!(inside, comp.starts_with("G41"), "{name} {comp}: ({x}, {y}) on the wrong side (line {line})");
        let err = (dist - r).abs();
        assert!(err <= OFFSET_TOL_MM, "{name} {comp}: ({x:.6}, {y:.6}) at {dist:.7} mm from the contour (line {line})");
        worst = worst.max(err);
        samples += 1;
    }
    assert!(samples > 1000, "{name} {comp}: {samples} samples on the contour");
    assert!(
        ratios[0] <= 1.001 && ratios[1] <= 1.001 && ratios[2] <= 1.02,
        "{name} {comp}: limit ratios v/a/j {ratios:?} beyond 1.001/1.001/1.02"
    );
    eprintln!(
        "{name} {comp}: {} elements, {samples} samples, worst |distance − r| {worst:.3e} mm, limit ratios v {:.4} a {:.4} j {:.4}",
        path.elements.len(),
        ratios[0],
        ratios[1],
        ratios[2]
    );
}

#[test]
fn short_chords_swallowed_by_inside_corners_are_dropped_on_both_sides() {
    // Chords of 0.05 mm, and CAM-like chords alternating 0.05 and 0.005 mm (an inside corner
    // between two long ones swallows the short one), offset inwards by 2 mm and by 4.9 mm
    // (and outwards). The entry from the centre swallows the first chords.
    for (name, lengths) in [("chords 0.05", &[0.05][..]), ("chords 0.05/0.005", &[0.05, 0.005][..])] {
        for (d, r) in [(4.0, 2.0), (9.8, 4.9)] {
            for side in ["G41.1", "G42.1"] {
                check_chords(name, lengths, false, &format!("{side} D{d}"), r);
            }
        }
    }
    // Short arcs on the circle: the entry line swallows the first ones; the joints between
    // arcs rounded to 9 decimals turn by about 1e-7 rad.
    for side in ["G41.1", "G42.1"] {
        check_chords("arcs 0.05/0.005", &[0.05, 0.005], true, &format!("{side} D4"), 2.0);
    }
}
