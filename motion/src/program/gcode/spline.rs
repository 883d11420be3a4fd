//! LinuxCNC's splines: G5 (cubic Bézier with the implicit first-derivative rule), G5.1
//! (quadratic Bézier) and G5.2 … G5.3 (a NURBS of order L, control points X Y with weights P),
//! read as LinuxCNC 2.9's interpreter reads them (`convert_spline` and `convert_nurbs` of its
//! `interp_convert.cc`), our own code.
//!
//! Each curve becomes straight feed moves through the points LinuxCNC's `gcode` module (its
//! preview, and the oracle of `scripts/rs274_canon.py`) puts on it: `15·(n+1)` equal steps of
//! the curve parameter for `n+1` control points, with LinuxCNC's knot vector and basis
//! recursion (`nurbs_additional_functions.cc`). The path smoothing then blends the chords
//! like any other short moves. Coordinates here are program coordinates in program units in
//! the XY plane, as in LinuxCNC; the moves are converted at the end.

use super::{Block, Interpreter, Motion, Plane};
use crate::path::{Feed, Source};
use crate::program::error::Diagnostics;
use interpd_config::AxisLetter;

/// Which spline motion mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SplineKind {
    /// G5: a cubic through the current point and X Y, with I J and P Q the offsets of the
    /// inner control points.
    Cubic,
    /// G5.1: a quadratic with I J the offset of the middle control point.
    Quadratic,
    /// G5.2: a NURBS control point (X Y P), drawn at G5.3.
    Nurbs,
}

impl SplineKind {
    pub(super) fn name(self) -> &'static str {
        match self {
            SplineKind::Cubic => "G5",
            SplineKind::Quadratic => "G5.1",
            SplineKind::Nurbs => "G5.2",
        }
    }

    /// The code `#<_motion_mode>` reports (LinuxCNC's G-code number times ten).
    pub(super) fn motion_code(self) -> f64 {
        match self {
            SplineKind::Cubic => 50.0,
            SplineKind::Quadratic => 51.0,
            SplineKind::Nurbs => 52.0,
        }
    }
}

/// Most control points of one NURBS (including the start point): far beyond what CAM posts
/// in one G5.2 block, and it bounds the memory of the block and of its `15·(n+1)` moves.
pub(crate) const MAX_NURBS_POINTS: usize = 5_000;
/// Highest NURBS order L: LinuxCNC evaluates the basis by recursion, so no real program goes
/// near it, and it bounds the evaluation cost (order² per point).
pub(crate) const MAX_NURBS_ORDER: usize = 16;
/// Chords per control point, as LinuxCNC's `gcode` module divides the curve parameter.
const CHORDS_PER_POINT: usize = 15;

/// A control point in program coordinates with its weight.
#[derive(Debug, Clone, Copy)]
struct ControlPoint {
    x: f64,
    y: f64,
    w: f64,
}

/// What the spline codes keep between blocks.
#[derive(Debug, Clone, Default)]
pub(crate) struct SplineState {
    /// The control points of the open G5.2 NURBS, the start point first.
    points: Vec<ControlPoint>,
    /// Its order (LinuxCNC's `nurbs_order`: 3 unless an L above 3 is given).
    order: usize,
    /// The I J a G5 without them uses: minus the previous G5's P Q (LinuxCNC's `cycle_i`,
    /// `cycle_j`; zero before any G5).
    implicit_ij: (f64, f64),
}

impl Interpreter {
    /// A block in a spline motion mode (`entered`: the mode was not in force before it).
    pub(in crate::program) fn spline_block(
        &mut self,
        kind: SplineKind,
        entered: bool,
        block: &Block,
        source: Source,
        d: &mut Diagnostics,
    ) {
        let line = block.line;
        let col0 = block.words[0].col;
        let name = kind.name();
        if let Some(msg) = self.spline_refusal(name) {
            d.error(line, col0, msg);
            return;
        }
        for w in block.words.iter() {
            if let Some(l) = AxisLetter::from_char(w.letter) {
                if l != AxisLetter::X && l != AxisLetter::Y {
                    d.error(line, w.col, format!("{name}: splines move X and Y only (in G17), not {l}"));
                    return;
                }
            }
        }
        let (Some(xk), Some(yk)) = (self.settings.axis_index(AxisLetter::X), self.settings.axis_index(AxisLetter::Y))
        else {
            d.error(line, col0, format!("{name} needs axes X and Y on this machine"));
            return;
        };
        let unit = self.modal.unit_mm;
        let cur = [self.program_coord(xk) / unit, self.program_coord(yk) / unit];
        let xw = block.get('X');
        let yw = block.get('Y');
        // The end point, as LinuxCNC's `find_ends`: a missing word keeps the coordinate.
        let end = |s: &Self| {
            let v = |w: Option<&crate::program::lexer::Word>, c: f64| match w {
                None => c,
                Some(w) if s.modal.absolute => w.value,
                Some(w) => c + w.value,
            };
            [v(xw, cur[0]), v(yw, cur[1])]
        };
        let finite = |v: f64, letter: char, col: u32, d: &mut Diagnostics| {
            if !v.is_finite() {
                d.error(line, col, format!("{name}: {letter} is not a finite number"));
            }
            v.is_finite()
        };
        match kind {
            SplineKind::Nurbs => {
                let p = block.get('P');
                let l = block.get('L');
                if entered {
                    self.spline.points.clear();
                }
                if xw.is_some() != yw.is_some() {
                    let w = xw.or(yw).expect("one of them");
                    d.error(line, w.col, "G5.2: a control point needs both X and Y");
                    return;
                }
                if xw.is_none() && p.is_some() && !self.spline.points.is_empty() {
                    d.error(line, col0, "G5.2: P without X and Y is only valid for the first control point");
                    return;
                }
                if (xw.is_some() || !self.spline.points.is_empty()) && p.is_none_or(|p| p.value <= 0.0) {
                    d.error(line, p.map_or(col0, |p| p.col), "G5.2: every control point needs a positive weight P");
                    return;
                }
                if self.spline.points.is_empty() {
                    // The start point, with the weight P of a block without X Y (else 1).
                    let w = if xw.is_none() { p.map_or(1.0, |p| p.value) } else { 1.0 };
                    if w <= 0.0 || !w.is_finite() {
                        d.error(line, p.map_or(col0, |p| p.col), "G5.2: the weight P must be positive");
                        return;
                    }
                    self.spline.points.push(ControlPoint { x: cur[0], y: cur[1], w });
                    self.spline.order = 3;
                }
                if let Some(l) = l {
                    if l.value.fract() != 0.0 || !(0.0..=MAX_NURBS_ORDER as f64).contains(&l.value) {
                        d.error(
                            line,
                            l.col,
                            format!("G5.2: the order L must be an integer up to {MAX_NURBS_ORDER}, got {}", l.value),
                        );
                        return;
                    }
                    // As LinuxCNC: an L of 3 or less leaves the order as it is.
                    if l.value > 3.0 {
                        self.spline.order = l.value as usize;
                    }
                }
                if let (Some(xw), Some(p)) = (xw, p) {
                    let e = end(self);
                    if !finite(e[0], 'X', xw.col, d) || !finite(e[1], 'Y', xw.col, d) || !finite(p.value, 'P', p.col, d)
                    {
                        return;
                    }
                    if self.spline.points.len() >= MAX_NURBS_POINTS {
                        d.error(line, col0, format!("G5.2: a NURBS has at most {MAX_NURBS_POINTS} control points"));
                        return;
                    }
                    self.spline.points.push(ControlPoint { x: e[0], y: e[1], w: p.value });
                }
            }
            SplineKind::Quadratic | SplineKind::Cubic => {
                let i = block.get('I');
                let j = block.get('J');
                let ij = match (i, j, kind) {
                    (Some(i), Some(j), _) => (i.value, j.value),
                    (None, None, SplineKind::Cubic) => self.spline.implicit_ij,
                    (i, j, _) => {
                        let what = if kind == SplineKind::Cubic {
                            "G5: give both I and J, or neither (then minus the previous G5's P and Q)"
                        } else {
                            "G5.1 needs both I and J"
                        };
                        d.error(line, i.or(j).map_or(col0, |w| w.col), what);
                        return;
                    }
                };
                let e = end(self);
                let p1 = [cur[0] + ij.0, cur[1] + ij.1];
                let mut points =
                    vec![ControlPoint { x: cur[0], y: cur[1], w: 1.0 }, ControlPoint { x: p1[0], y: p1[1], w: 1.0 }];
                if kind == SplineKind::Cubic {
                    let (Some(p), Some(q)) = (block.get('P'), block.get('Q')) else {
                        d.error(line, col0, "G5 needs both P and Q (the second control point, from the end point)");
                        return;
                    };
                    points.push(ControlPoint { x: e[0] + p.value, y: e[1] + q.value, w: 1.0 });
                    self.spline.implicit_ij = (-p.value, -q.value);
                }
                points.push(ControlPoint { x: e[0], y: e[1], w: 1.0 });
                if points.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
                    d.error(line, col0, format!("{name}: a control point is not a finite number"));
                    return;
                }
                let order = points.len();
                self.draw_nurbs(&points, order, xk, yk, source, col0, d);
            }
        }
    }

    /// G5.3: draws the NURBS the G5.2 blocks gave and ends the G5.2 mode.
    pub(in crate::program) fn nurbs_end(&mut self, col: u32, block: &Block, source: Source, d: &mut Diagnostics) {
        let line = block.line;
        if self.modal.motion != Some(Motion::Spline(SplineKind::Nurbs)) {
            d.error(line, col, "G5.3 without G5.2 first");
            return;
        }
        let points = std::mem::take(&mut self.spline.points);
        self.modal.motion = None;
        // At least 3 (LinuxCNC's default order) also when no G5.2 block got as far as a point.
        let order = self.spline.order.max(3);
        if points.len() < order {
            d.error(
                line,
                col,
                format!(
                    "G5.3: a NURBS of order L = {order} needs at least {order} control points (the start point counts), got {}",
                    points.len()
                ),
            );
            return;
        }
        if let Some(msg) = self.spline_refusal("G5.3") {
            d.error(line, col, msg);
            return;
        }
        let (Some(xk), Some(yk)) = (self.settings.axis_index(AxisLetter::X), self.settings.axis_index(AxisLetter::Y))
        else {
            d.error(line, col, "G5.3 needs axes X and Y on this machine");
            return;
        };
        self.draw_nurbs(&points, order, xk, yk, source, col, d);
    }

    /// Why a spline cannot run in the present state, if it cannot.
    fn spline_refusal(&self, name: &str) -> Option<String> {
        if self.cutter.is_on() {
            Some(format!("{name}: splines cannot run with cutter compensation on (program G40 first)"))
        } else if self.modal.plane != Plane::Xy {
            Some(format!("{name}: splines must be in the XY plane (G17)"))
        } else if self.modal.inverse_time {
            Some(format!("{name}: splines cannot run in inverse time (G93): program G94 first"))
        } else if self.modal.feed_mm_s.is_none() {
            Some(format!("{name} without feed: program F (mm/min) before or in this block"))
        } else {
            None
        }
    }

    /// The feed moves through LinuxCNC's points on the curve of `points` (order `order`).
    #[allow(clippy::too_many_arguments)]
    fn draw_nurbs(
        &mut self,
        points: &[ControlPoint],
        order: usize,
        xk: usize,
        yk: usize,
        source: Source,
        col: u32,
        d: &mut Diagnostics,
    ) {
        let Some(f) = self.modal.feed_mm_s else { return };
        let feed = Feed::Programmed { mm_per_s: f };
        let unit = self.modal.unit_mm;
        let emit = |s: &mut Self, p: [f64; 2], d: &mut Diagnostics| -> bool {
            let mut target = s.modal.pos;
            s.set_program_coords(&mut target, &[(xk, p[0] * unit), (yk, p[1] * unit)]);
            for k in [xk, yk] {
                if let Some(msg) = s.travel_violation(k, target[k]) {
                    d.error(source.line, col, msg);
                    return false;
                }
            }
            s.linear_move(target, feed, source, col, d);
            true
        };
        for p in NurbsChords::new(points, order) {
            if !emit(self, p, d) {
                return;
            }
        }
        let last = points[points.len() - 1];
        emit(self, [last.x, last.y], d);
    }
}

/// LinuxCNC's points on a NURBS: `u` from `umax/div` in steps of `umax/div` while below
/// `umax` (the same floating-point sums as its `NURBS_FEED`); the end point follows apart.
struct NurbsChords<'a> {
    points: &'a [ControlPoint],
    order: usize,
    knots: Vec<i64>,
    u: f64,
    umax: f64,
    step: f64,
    /// Basis values of the window being evaluated (reused).
    basis: Vec<f64>,
}

impl<'a> NurbsChords<'a> {
    fn new(points: &'a [ControlPoint], order: usize) -> Self {
        let n = points.len() - 1;
        let umax = (n + 2 - order) as f64;
        let div = (points.len() * CHORDS_PER_POINT) as f64;
        Self { points, order, knots: knot_vector(n, order), u: 0.0, umax, step: umax / div, basis: Vec::new() }
    }
}

impl Iterator for NurbsChords<'_> {
    type Item = [f64; 2];

    fn next(&mut self) -> Option<[f64; 2]> {
        if self.u + self.step >= self.umax {
            return None;
        }
        let p = nurbs_point(self.u + self.step, self.order, self.points, &self.knots, &mut self.basis);
        self.u += self.step;
        Some(p)
    }
}

/// LinuxCNC's clamped uniform knot vector for `n+1` control points of order `k`: `k` zeros,
/// then 1, 2, …, then `n-k+2` to the end.
fn knot_vector(n: usize, k: usize) -> Vec<i64> {
    (0..=n + k)
        .map(|i| {
            if i < k {
                0
            } else if i <= n {
                (i + 1 - k) as i64
            } else {
                (n + 2 - k) as i64
            }
        })
        .collect()
}

/// The point at `u`: LinuxCNC's `nurbs_point` (Σ Pᵢ·Nᵢ,ₖ(u)·wᵢ / Σ Nᵢ,ₖ(u)·wᵢ) with its basis
/// recursion `Nmix`, including its closed intervals at order 1. The recursion is evaluated
/// bottom-up over the few indices whose basis is not zero at `u`, which gives the same values.
fn nurbs_point(u: f64, k: usize, points: &[ControlPoint], t: &[i64], basis: &mut Vec<f64>) -> [f64; 2] {
    let tf = |i: usize| t[i] as f64;
    // Order 1: Nᵢ,₁(u) = 1 where t[i] ≤ u ≤ t[i+1] (i < t.len() - 1).
    let last = t.len() - 2;
    let first_ge = t.partition_point(|&x| (x as f64) < u); // first i with t[i] >= u
    let lo1 = first_ge.saturating_sub(1);
    let hi1 = t.partition_point(|&x| (x as f64) <= u).saturating_sub(1).min(last);
    // Indices base..=hi1 can be non-zero at any order up to k.
    let base = lo1.saturating_sub(k - 1);
    let len = hi1 + 2 - base;
    basis.clear();
    basis.extend((base..base + len).map(|i| if i <= last && tf(i) <= u && u <= tf(i + 1) { 1.0 } else { 0.0 }));
    for m in 2..=k {
        // Nᵢ,ₘ from Nᵢ,ₘ₋₁ and Nᵢ₊₁,ₘ₋₁, in place (index i reads i and i+1 before i+1 changes).
        for off in 0..len {
            let i = base + off;
            if i + m >= t.len() {
                basis[off] = 0.0;
                continue;
            }
            let left = t[i + m - 1] - t[i];
            let right = t[i + m] - t[i + 1];
            let ni = basis[off];
            let ni1 = if off + 1 < len { basis[off + 1] } else { 0.0 };
            basis[off] = if left == 0 && right != 0 {
                ((tf(i + m) - u) * ni1) / right as f64
            } else if right == 0 && left != 0 {
                ((u - tf(i)) * ni) / left as f64
            } else if left == 0 && right == 0 {
                0.0
            } else {
                ((u - tf(i)) * ni) / left as f64 + ((tf(i + m) - u) * ni1) / right as f64
            };
        }
    }
    let n_at = |i: usize| if i >= base && i < base + len { basis[i - base] } else { 0.0 };
    let hi = (base + len).min(points.len());
    let den: f64 = (base.min(hi)..hi).map(|i| n_at(i) * points[i].w).sum();
    let mut p = [0.0, 0.0];
    for (i, cp) in points.iter().enumerate().take(hi).skip(base.min(hi)) {
        p[0] += cp.x * n_at(i) * cp.w / den;
        p[1] += cp.y * n_at(i) * cp.w / den;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// LinuxCNC's `Nmix`, recursively, as its `nurbs_additional_functions.cc` has it.
    fn nmix(i: usize, k: usize, u: f64, t: &[i64]) -> f64 {
        let tf = |i: usize| t[i] as f64;
        if k == 1 {
            return if u >= tf(i) && u <= tf(i + 1) { 1.0 } else { 0.0 };
        }
        let left = t[i + k - 1] - t[i];
        let right = t[i + k] - t[i + 1];
        if left == 0 && right != 0 {
            ((tf(i + k) - u) * nmix(i + 1, k - 1, u, t)) / right as f64
        } else if right == 0 && left != 0 {
            ((u - tf(i)) * nmix(i, k - 1, u, t)) / left as f64
        } else if left == 0 && right == 0 {
            0.0
        } else {
            ((u - tf(i)) * nmix(i, k - 1, u, t)) / left as f64
                + ((tf(i + k) - u) * nmix(i + 1, k - 1, u, t)) / right as f64
        }
    }

    fn reference_point(u: f64, k: usize, points: &[ControlPoint], t: &[i64]) -> [f64; 2] {
        let den: f64 = (0..points.len()).map(|i| nmix(i, k, u, t) * points[i].w).sum();
        let mut p = [0.0, 0.0];
        for (i, cp) in points.iter().enumerate() {
            p[0] += cp.x * nmix(i, k, u, t) * cp.w / den;
            p[1] += cp.y * nmix(i, k, u, t) * cp.w / den;
        }
        p
    }

    fn cps(v: &[(f64, f64, f64)]) -> Vec<ControlPoint> {
        v.iter().map(|&(x, y, w)| ControlPoint { x, y, w }).collect()
    }

    #[test]
    fn the_windowed_basis_gives_linuxcncs_recursion() {
        let points = cps(&[
            (0.0, 0.0, 1.0),
            (0.0, 1.0, 1.0),
            (2.0, 2.0, 1.0),
            (2.0, 0.0, 1.0),
            (0.0, 0.0, 2.0),
            (3.0, -1.0, 0.5),
            (4.0, 2.0, 1.0),
        ]);
        for order in 2..=6 {
            let t = knot_vector(points.len() - 1, order);
            let mut basis = Vec::new();
            let chords: Vec<_> = NurbsChords::new(&points, order).collect();
            // div - 1 interior points, or div when the summed steps stay below umax (then the
            // last chord is a sliver, as in LinuxCNC).
            let div = points.len() * CHORDS_PER_POINT;
            assert!(chords.len() == div - 1 || chords.len() == div, "order {order}: {} points", chords.len());
            let umax = (points.len() + 1 - order) as f64;
            // Every sample, and the knots themselves (where the closed intervals overlap).
            let mut us: Vec<f64> = (1..200).map(|j| umax * j as f64 / 200.0).collect();
            us.extend((1..umax as usize).map(|j| j as f64));
            for u in us {
                let a = nurbs_point(u, order, &points, &t, &mut basis);
                let b = reference_point(u, order, &points, &t);
                assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12, "order {order} u {u}: {a:?} {b:?}");
            }
        }
    }

    #[test]
    fn a_cubic_bezier_is_its_polynomial() {
        // Order 4 on 4 points is the Bézier cubic (what G5 draws).
        let points = cps(&[(0.0, 0.0, 1.0), (1.0, 2.0, 1.0), (3.0, 2.0, 1.0), (4.0, 0.0, 1.0)]);
        let t = knot_vector(3, 4);
        let mut basis = Vec::new();
        for j in 1..10 {
            let u = j as f64 / 10.0;
            let p = nurbs_point(u, 4, &points, &t, &mut basis);
            let b = |a: [f64; 4]| {
                let s = 1.0 - u;
                s * s * s * a[0] + 3.0 * s * s * u * a[1] + 3.0 * s * u * u * a[2] + u * u * u * a[3]
            };
            assert!((p[0] - b([0.0, 1.0, 3.0, 4.0])).abs() < 1e-12);
            assert!((p[1] - b([0.0, 2.0, 2.0, 0.0])).abs() < 1e-12);
        }
    }
}
