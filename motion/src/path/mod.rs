//! The path: geometry elements over path length s, and for every axis k the position A_k(s)
//! and its derivatives A′_k(s), A″_k(s), A‴_k(s) (′ = d/ds).
//!
//! s is arc length in mm over the linear axes (the programmed feed applies to it), or, for a
//! move of rotary axes alone, the angle in degrees; a path table brings its own s.

mod arc;
mod arclength;
mod cubic;
mod line;
mod quintic;
mod septic;
pub(crate) mod spline;
mod suffix;

pub use arc::Helix;
pub(crate) use cubic::MIN_CURVATURE_RADIUS_MM;
pub use cubic::{CubicSpan, SpanError};
pub use line::Line;
pub(crate) use quintic::HermiteEnd;
pub use quintic::QuinticSpan;
pub use septic::SepticSpan;
pub use suffix::Suffix;

pub use interpd_config::MAX_AXES;

/// One value per axis; only the first `n_axes` entries of a path are meaningful.
pub type AxisVec = [f64; MAX_AXES];

/// Position and its first three derivatives with respect to s, per axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AxisDerivs {
    pub pos: AxisVec,
    pub d1: AxisVec,
    pub d2: AxisVec,
    pub d3: AxisVec,
}

impl AxisDerivs {
    /// Axis `k`'s velocity, acceleration and jerk where the path moves with velocity `v`,
    /// acceleration `a` and jerk `j`: the chain rule Ȧ = A′v, Ä = A″v² + A′a,
    /// A⃛ = A‴v³ + 3A″va + A′j (Kopp et al. 2019, eq. 1a–1c).
    #[inline]
    pub fn axis_rates(&self, k: usize, v: f64, a: f64, j: f64) -> [f64; 3] {
        let vel = self.d1[k] * v;
        let acc = self.d2[k] * v * v + self.d1[k] * a;
        let jerk = self.d3[k] * v.powi(3) + 3.0 * self.d2[k] * v * a + self.d1[k] * j;
        [vel, acc, jerk]
    }
}

/// A geometry element parameterised by its own path length s ∈ [0, length_mm].
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    Line(Line),
    Helix(Helix),
    Cubic(Box<CubicSpan>),
    Septic(Box<SepticSpan>),
    /// The rest of an element from a point inside it (replanning from a stop or hand-over).
    Suffix(Box<Suffix>),
    /// A smoothed piece from the tolerance-band preparation (Haas 2012).
    Quintic(Box<QuinticSpan>),
}

impl Geometry {
    /// A path table's span (also seen through a suffix) and the local position where this
    /// element starts on it: geometry that is a polynomial in s between its rows.
    pub(crate) fn as_septic(&self) -> Option<(&SepticSpan, f64)> {
        match self {
            Geometry::Septic(g) => Some((g, 0.0)),
            Geometry::Suffix(sf) => match sf.inner() {
                Geometry::Septic(g) => Some((g, sf.offset_mm())),
                _ => None,
            },
            _ => None,
        }
    }

    /// Path length of the element (mm, or the table's s units).
    pub fn length_mm(&self) -> f64 {
        match self {
            Geometry::Line(g) => g.length_mm(),
            Geometry::Helix(g) => g.length_mm(),
            Geometry::Cubic(g) => g.length_mm(),
            Geometry::Septic(g) => g.length_mm(),
            Geometry::Suffix(g) => g.length_mm(),
            Geometry::Quintic(g) => g.length_mm(),
        }
    }

    /// A(s) … A‴(s) at local path position `s_mm` (clamped to the element).
    pub fn eval(&self, s_mm: f64, out: &mut AxisDerivs) {
        let s = s_mm.clamp(0.0, self.length_mm());
        match self {
            Geometry::Line(g) => g.eval(s, out),
            Geometry::Helix(g) => g.eval(s, out),
            Geometry::Cubic(g) => g.eval(s, out),
            Geometry::Septic(g) => g.eval(s, out),
            Geometry::Suffix(g) => g.eval(s, out),
            Geometry::Quintic(g) => g.eval(s, out),
        }
    }

    /// Short name for summaries.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Geometry::Line(_) => "line",
            Geometry::Helix(_) => "arc",
            Geometry::Cubic(_) => "spline",
            Geometry::Septic(_) => "table",
            Geometry::Suffix(g) => g.inner().kind_name(),
            Geometry::Quintic(_) => "smoothed",
        }
    }
}

/// Feed of an element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feed {
    /// Programmed path feed, mm/s (F / 60).
    Programmed { mm_per_s: f64 },
    /// G0: as fast as the axes allow (and `planner.rapid_feed_mm_s`).
    Rapid,
}

/// How an element joins the one before it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// First element of the path.
    Start,
    /// Tangent and curvature continuous (G²): no constraint beyond the limits.
    Smooth,
    /// Tangent continuous, curvature jumps (G¹ but not G²): the axis acceleration steps by
    /// ΔA″·v², so the planner caps the speed there.
    CurvatureJump,
    /// Tangent jumps (G⁰ only, a G¹ break): passed with v = a = 0 unless smoothed.
    Corner,
}

/// Where an element came from in the program.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Source {
    /// 1-based line number.
    pub line: u32,
    /// Programmed block number (N word), 0 if none.
    pub block: u32,
}

/// How the path may be prepared at a joint (G61 exact path / G64 tolerance band).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Blend {
    Exact,
    /// Smoothing within `tol_mm` of the programmed path; `method` turns the smoothed points into
    /// pieces (`[prep] method`, or `G64 … Q1` / `Q2`).
    Tolerance {
        tol_mm: f64,
        method: interpd_config::PrepMethod,
    },
}

/// One element of a path with its place and attributes.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    pub geometry: Geometry,
    /// Path position where the element starts.
    pub s_start_mm: f64,
    pub feed: Feed,
    pub source: Source,
    /// Joint with the previous element.
    pub joint: JointKind,
    /// Dwell before this element starts (G4), s. A dwell forces a stop.
    pub dwell_before_s: f64,
    pub blend: Blend,
    /// A planned pause before this element starts: a program stop (M0, M1, M60), operator
    /// messages (`(MSG,…)`, `(DEBUG,…)`, `(PRINT,…)`), or both. The motion stops exactly there.
    pub pause_before: Option<Pause>,
}

/// A program stop of RS274NGC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopCode {
    /// M0: the program stops until it is resumed.
    Stop,
    /// M1: as M0 when the optional-stop switch is on, else nothing.
    Optional,
    /// M60: a pallet shuttle and a stop (the shuttle is not interpd's; the stop is).
    PalletShuttle,
}

/// What waits for the motion before an element: the motion comes to an exact stop there (as
/// LinuxCNC's task waits for the motion before a program stop or an operator message), then
/// the messages numbered up to `messages_before` come out, then the program stop, then the
/// messages up to `messages_after` (read after the stop). Messages are numbered from 1 in
/// program order; 0 means none.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pause {
    pub messages_before: u64,
    pub stop: Option<StopCode>,
    /// Program line of the stop's block.
    pub stop_line: u32,
    pub messages_after: u64,
}

impl Pause {
    /// A program stop on line `line`.
    pub fn stop(code: StopCode, line: u32) -> Self {
        Self { stop: Some(code), stop_line: line, ..Self::default() }
    }

    /// The last message number that comes out here (0: none).
    pub fn last_message(&self) -> u64 {
        self.messages_before.max(self.messages_after)
    }
}

impl Element {
    pub fn s_end_mm(&self) -> f64 {
        self.s_start_mm + self.geometry.length_mm()
    }

    /// The element from `s_mm` on, as the first of a path (joint `Start`): cut there unless
    /// `s_mm` is at its start; a cut inside it drops its dwell, which lies behind.
    pub(crate) fn from(&self, s_mm: f64) -> Element {
        let mut e = self.clone();
        let offset = s_mm - e.s_start_mm;
        if offset > SUFFIX_AT_START_MM {
            e.geometry = Geometry::Suffix(Box::new(Suffix::new(e.geometry, offset)));
            e.s_start_mm = s_mm;
            e.dwell_before_s = 0.0;
            e.pause_before = None;
        }
        e.joint = JointKind::Start;
        e
    }

    /// Whether the motion must come to rest (v = a = 0) where this element starts.
    pub(crate) fn stops_before(&self) -> bool {
        matches!(self.joint, JointKind::Start | JointKind::Corner) || self.holds()
    }

    /// Whether the motion holds before this element: a dwell or a planned pause. Nothing is
    /// blended across it.
    pub(crate) fn holds(&self) -> bool {
        self.dwell_before_s > 0.0 || self.pause_before.is_some()
    }
}

/// Tangent angles below this count as continuous: a velocity direction step of 1e-9 rad at
/// 1 m/s is 1e-6 mm/s, far below any measurable acceleration.
pub(crate) const TANGENT_ANGLE_TOL_RAD: f64 = 1e-9;
/// A cut this close to an element's start (mm) is taken as its start: the element is kept
/// whole rather than cut into a sliver.
pub(crate) const SUFFIX_AT_START_MM: f64 = 1e-9;
/// Relative curvature difference below which a joint counts as G².
pub(crate) const CURVATURE_REL_TOL: f64 = 1e-9;
/// Moves shorter than this (mm) become no element: the G-code interpreter drops (and counts)
/// them, and the cutter compensation drops offset pieces as short.
pub(crate) const MIN_MOVE_MM: f64 = 1e-9;

/// A continuous path through the axes: elements back to back in s.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub n_axes: usize,
    /// Axis names in machine order.
    pub axis_names: Vec<String>,
    /// Start position of the path (the machine position before the first element).
    pub start: AxisVec,
    pub elements: Vec<Element>,
    /// Dwell after the last element, s.
    pub final_dwell_s: f64,
}

impl Path {
    pub fn new(axis_names: Vec<String>, start: AxisVec) -> Self {
        Self { n_axes: axis_names.len(), axis_names, start, elements: Vec::new(), final_dwell_s: 0.0 }
    }

    pub fn length_mm(&self) -> f64 {
        self.elements.last().map_or(0.0, Element::s_end_mm)
    }

    /// Appends an element after the last one, classifying the joint between them.
    pub fn push(&mut self, geometry: Geometry, feed: Feed, source: Source, dwell_before_s: f64, blend: Blend) {
        let s_start_mm = self.length_mm();
        let joint = match self.elements.last() {
            None => JointKind::Start,
            Some(prev) => classify_joint(&prev.geometry, &geometry, self.n_axes),
        };
        self.elements.push(Element {
            geometry,
            s_start_mm,
            feed,
            source,
            joint,
            dwell_before_s,
            blend,
            pause_before: None,
        });
    }

    /// Moves every element but the last to `out`: a reader hands elements on as they are made
    /// and keeps the last one for the joint with its successor.
    pub(crate) fn drain_settled(&mut self, out: &mut std::collections::VecDeque<Element>) {
        let n = self.elements.len().saturating_sub(1);
        out.extend(self.elements.drain(..n));
    }

    /// Moves every element to `out` (no successor follows).
    pub(crate) fn drain_all(&mut self, out: &mut std::collections::VecDeque<Element>) {
        out.extend(self.elements.drain(..));
    }

    /// Appends an element made elsewhere (by the smoothing stage or a reader), keeping its
    /// place in s and its joint. A streamed path grows at the end this way and is trimmed at
    /// the front by [`Path::trim_before`].
    pub(crate) fn push_element(&mut self, element: Element) {
        debug_assert!(
            self.elements
                .last()
                .is_none_or(|l| (l.s_end_mm() - element.s_start_mm).abs() <= 1e-6 * l.s_end_mm().max(1.0)),
            "elements are appended back to back in s"
        );
        self.elements.push(element);
    }

    /// Appends an element of another path moved by `s_offset_mm` along s: a program streamed
    /// behind an approach move. The element that starts its own path joins the last one here
    /// as their geometry does.
    pub(crate) fn append_shifted(&mut self, mut element: Element, s_offset_mm: f64) {
        element.s_start_mm += s_offset_mm;
        if element.joint == JointKind::Start {
            if let Some(prev) = self.elements.last() {
                element.joint = classify_joint(&prev.geometry, &element.geometry, self.n_axes);
            }
        }
        self.push_element(element);
    }

    /// Drops the elements that end before `s_mm`, keeping at least the last one, so a
    /// streamed path holds only what is still ahead of the motion. Path positions stay
    /// absolute; the path's start becomes the first kept element's start.
    pub(crate) fn trim_before(&mut self, s_mm: f64) {
        let n = self.elements.partition_point(|e| e.s_end_mm() < s_mm).min(self.elements.len().saturating_sub(1));
        if n == 0 {
            return;
        }
        self.elements.drain(..n);
        let mut d = AxisDerivs::default();
        self.elements[0].geometry.eval(0.0, &mut d);
        self.start = d.pos;
    }

    /// Index of the element containing path position `s_mm` (the later one at a joint).
    pub fn element_index_at(&self, s_mm: f64) -> usize {
        let i = self.elements.partition_point(|e| e.s_start_mm <= s_mm);
        i.saturating_sub(1).min(self.elements.len().saturating_sub(1))
    }

    /// A(s) … A‴(s) at global path position `s_mm`.
    pub fn eval(&self, s_mm: f64, out: &mut AxisDerivs) {
        match self.elements.get(self.element_index_at(s_mm)) {
            Some(e) => e.geometry.eval(s_mm - e.s_start_mm, out),
            None => {
                *out = AxisDerivs { pos: self.start, ..AxisDerivs::default() };
            }
        }
    }

    /// Like [`Path::eval`], but at a joint between elements it evaluates the element that
    /// ends there (the side a motion arriving at the joint sees).
    pub fn eval_left(&self, s_mm: f64, out: &mut AxisDerivs) {
        let i = self.elements.partition_point(|e| e.s_start_mm < s_mm).saturating_sub(1);
        match self.elements.get(i) {
            Some(e) => e.geometry.eval(s_mm - e.s_start_mm, out),
            None => *out = AxisDerivs { pos: self.start, ..AxisDerivs::default() },
        }
    }

    /// The path from `s_mm` on, keeping absolute path positions: the element that contains
    /// `s_mm` is cut there and starts the new path (joint `Start`); a cut inside it drops its
    /// dwell, which lies behind. What a replan from `s_mm` plans along (a `Feed` cuts the
    /// element the same way as it hands it to the planner); the tests compare with it.
    #[cfg(test)]
    pub(crate) fn suffix_from(&self, s_mm: f64) -> Path {
        let mut start = AxisDerivs::default();
        self.eval(s_mm, &mut start);
        let mut out = Path { start: start.pos, elements: Vec::new(), ..Path::new(self.axis_names.clone(), start.pos) };
        out.final_dwell_s = self.final_dwell_s;
        if s_mm >= self.length_mm() {
            return out;
        }
        let first = self.first_index_from(s_mm);
        for (k, e) in self.elements[first..].iter().enumerate() {
            out.elements.push(if k == 0 { e.from(s_mm) } else { e.clone() });
        }
        out
    }

    /// Index of the element a path cut at `s_mm` starts with ([`Path::suffix_from`]): the one
    /// containing `s_mm`, or the next one when `s_mm` is at its very end (no sliver).
    pub(crate) fn first_index_from(&self, s_mm: f64) -> usize {
        let first = self.element_index_at(s_mm);
        match self.elements.get(first) {
            Some(e) if e.s_end_mm() - s_mm <= SUFFIX_AT_START_MM && first + 1 < self.elements.len() => first + 1,
            _ => first,
        }
    }

    /// End position of the path.
    pub fn end_position(&self) -> AxisVec {
        match self.elements.last() {
            Some(e) => {
                let mut d = AxisDerivs::default();
                e.geometry.eval(e.geometry.length_mm(), &mut d);
                d.pos
            }
            None => self.start,
        }
    }
}

/// Compares the end of `prev` with the start of `next`.
pub(crate) fn classify_joint(prev: &Geometry, next: &Geometry, n_axes: usize) -> JointKind {
    let mut a = AxisDerivs::default();
    let mut b = AxisDerivs::default();
    prev.eval(prev.length_mm(), &mut a);
    next.eval(0.0, &mut b);
    let dot: f64 = (0..n_axes).map(|k| a.d1[k] * b.d1[k]).sum();
    let na: f64 = (0..n_axes).map(|k| a.d1[k] * a.d1[k]).sum::<f64>().sqrt();
    let nb: f64 = (0..n_axes).map(|k| b.d1[k] * b.d1[k]).sum::<f64>().sqrt();
    let cross2: f64 = (0..n_axes)
        .flat_map(|i| (0..n_axes).map(move |j| (i, j)))
        .map(|(i, j)| {
            let c = a.d1[i] * b.d1[j] - a.d1[j] * b.d1[i];
            c * c
        })
        .sum::<f64>()
        / 2.0;
    let angle = cross2.sqrt().atan2(dot);
    // Different s-metrics (a rotary-only move after a linear one) also break the tangent.
    let scale_jump = (na - nb).abs() > 1e-9 * na.max(nb);
    if angle > TANGENT_ANGLE_TOL_RAD || scale_jump {
        return JointKind::Corner;
    }
    let curvature = (0..n_axes).map(|k| a.d2[k].abs().max(b.d2[k].abs())).fold(0.0, f64::max);
    let jump = (0..n_axes).map(|k| (a.d2[k] - b.d2[k]).abs()).fold(0.0, f64::max);
    if jump > CURVATURE_REL_TOL * curvature.max(1e-12) && jump > 1e-12 {
        JointKind::CurvatureJump
    } else {
        JointKind::Smooth
    }
}

#[cfg(test)]
pub(crate) mod testutil {
    use super::*;

    /// Checks A′, A″, A‴ of `g` against central differences of the next-lower derivative at
    /// interior points; returns the largest relative error.
    pub(crate) fn max_fd_error(g: &Geometry, n_axes: usize, points: usize) -> f64 {
        let len = g.length_mm();
        let h = len * 1e-5;
        let mut worst: f64 = 0.0;
        for i in 1..points {
            let s = len * i as f64 / points as f64;
            if s - h < 0.0 || s + h > len {
                continue;
            }
            let (mut m, mut c, mut p) = (AxisDerivs::default(), AxisDerivs::default(), AxisDerivs::default());
            g.eval(s - h, &mut m);
            g.eval(s, &mut c);
            g.eval(s + h, &mut p);
            for k in 0..n_axes {
                let pairs = [
                    ((p.pos[k] - m.pos[k]) / (2.0 * h), c.d1[k], c.d1[k].abs().max(1.0)),
                    ((p.d1[k] - m.d1[k]) / (2.0 * h), c.d2[k], c.d2[k].abs().max(c.d1[k].abs() / len).max(1e-3)),
                    ((p.d2[k] - m.d2[k]) / (2.0 * h), c.d3[k], c.d3[k].abs().max(c.d2[k].abs() / len).max(1e-3)),
                ];
                for (fd, exact, scale) in pairs {
                    worst = worst.max((fd - exact).abs() / scale);
                }
            }
        }
        worst
    }
}
