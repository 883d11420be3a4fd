//! The programmed elements of the run being smoothed: their place in s, tangents at both ends
//! and the turn at the vertex before each, and the distance of a point to them (what the
//! tolerance is measured against).

use crate::path::{AxisDerivs, AxisVec, Element, Geometry, MAX_AXES};
use std::collections::VecDeque;

/// One programmed element of a run.
#[derive(Debug, Clone)]
pub(super) struct RunElem {
    pub element: Element,
    /// Start on the programmed path (the element's own s_start_mm).
    pub s0_mm: f64,
    pub len_mm: f64,
    pub t_start: AxisVec,
    pub t_end: AxisVec,
    /// Tangent turn at the vertex before this element (0 for the first of a run), rad.
    pub turn_in_rad: f64,
    pub tol_mm: f64,
    /// The programmed tolerance (`tol_mm` is narrower on a conditioned chord), mm.
    pub prog_tol_mm: f64,
    /// Where the programmed moves the element stands for start and end on the programmed
    /// path (its own s range when it was not conditioned).
    pub prog_s0_mm: f64,
    pub prog_s1_mm: f64,
}

impl RunElem {
    /// Whether the element is a chord over several programmed moves (or shifted in s by one).
    pub(super) fn conditioned(&self) -> bool {
        self.prog_s0_mm != self.s0_mm || self.prog_s1_mm != self.s1_mm()
    }

    pub(super) fn s1_mm(&self) -> f64 {
        self.s0_mm + self.len_mm
    }

    pub(super) fn eval(&self, s_mm: f64, d: &mut AxisDerivs) {
        self.element.geometry.eval(s_mm - self.s0_mm, d);
    }

    /// Position at global s.
    pub(super) fn pos(&self, s_mm: f64) -> AxisVec {
        let mut d = AxisDerivs::default();
        self.eval(s_mm, &mut d);
        d.pos
    }
}

/// Cosine of the angle between two tangents over `n` axes.
pub(super) fn cos_between(a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    let dot: f64 = (0..n).map(|k| a[k] * b[k]).sum();
    let na = (0..n).map(|k| a[k] * a[k]).sum::<f64>().sqrt();
    let nb = (0..n).map(|k| b[k] * b[k]).sum::<f64>().sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0)
}

/// Angle between two tangents over `n` axes, rad.
pub(super) fn angle_between(a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    let dot: f64 = (0..n).map(|k| a[k] * b[k]).sum();
    let na = (0..n).map(|k| a[k] * a[k]).sum::<f64>().sqrt();
    let nb = (0..n).map(|k| b[k] * b[k]).sum::<f64>().sqrt();
    (dot / (na * nb)).clamp(-1.0, 1.0).acos()
}

/// The elements of a run with global indices; old ones are dropped once committed past.
#[derive(Debug, Default)]
pub(super) struct RunElems {
    items: VecDeque<RunElem>,
    base: usize,
    n_axes: usize,
}

impl RunElems {
    pub(super) fn new(n_axes: usize) -> Self {
        Self { items: VecDeque::new(), base: 0, n_axes }
    }

    /// Appends a conditioned element with the band left to it, the programmed tolerance and
    /// the programmed s range it stands for.
    pub(super) fn push_conditioned(&mut self, element: Element, tol_mm: f64, prog_tol_mm: f64, prog_s_mm: (f64, f64)) {
        let len_mm = element.geometry.length_mm();
        let mut d = AxisDerivs::default();
        element.geometry.eval(0.0, &mut d);
        let t_start = d.d1;
        element.geometry.eval(len_mm, &mut d);
        let t_end = d.d1;
        let turn_in_rad = self.items.back().map_or(0.0, |p| angle_between(&p.t_end, &t_start, self.n_axes));
        let s0_mm = element.s_start_mm;
        self.items.push_back(RunElem {
            element,
            s0_mm,
            len_mm,
            t_start,
            t_end,
            turn_in_rad,
            tol_mm,
            prog_tol_mm,
            prog_s0_mm: prog_s_mm.0,
            prog_s1_mm: prog_s_mm.1,
        });
    }

    /// One past the last global index.
    pub(super) fn end(&self) -> usize {
        self.base + self.items.len()
    }

    pub(super) fn first_index(&self) -> usize {
        self.base
    }

    pub(super) fn get(&self, i: usize) -> &RunElem {
        &self.items[i - self.base]
    }

    pub(super) fn last(&self) -> Option<&RunElem> {
        self.items.back()
    }

    /// Drops the elements before global index `i`.
    pub(super) fn drop_before(&mut self, i: usize) {
        while self.base < i && !self.items.is_empty() {
            self.items.pop_front();
            self.base += 1;
        }
    }

    /// Index of the element containing global s (the later one at a vertex), searched from `hint`.
    pub(super) fn index_at(&self, s_mm: f64, hint: usize) -> usize {
        let mut i = hint.clamp(self.base, self.end() - 1);
        while i + 1 < self.end() && self.get(i + 1).s0_mm <= s_mm {
            i += 1;
        }
        while i > self.base && self.get(i).s0_mm > s_mm {
            i -= 1;
        }
        i
    }

    /// The point of elements `from..=to` nearest to `p`: (global s, position).
    pub(super) fn nearest(&self, p: &AxisVec, from: usize, to: usize) -> (f64, AxisVec) {
        let (from, to) = (from.max(self.base), to.min(self.end() - 1));
        let mut best = (f64::INFINITY, 0.0, [0.0; MAX_AXES]);
        for i in from..=to {
            let e = self.get(i);
            let s = nearest_s(&e.element.geometry, p, self.n_axes);
            let q = e.pos(e.s0_mm + s);
            let d = dist(&q, p, self.n_axes);
            if d < best.0 {
                best = (d, e.s0_mm + s, q);
            }
        }
        (best.1, best.2)
    }
}

fn dist(a: &AxisVec, b: &AxisVec, n: usize) -> f64 {
    (0..n).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Samples when projecting onto a curved element, before Newton refinement.
const PROJECT_SAMPLES: usize = 32;
/// Newton steps of the projection.
const PROJECT_NEWTON: usize = 8;

/// Local s of the point of `g` nearest to `p`.
pub(super) fn nearest_s(g: &Geometry, p: &AxisVec, n: usize) -> f64 {
    let len = g.length_mm();
    let mut d = AxisDerivs::default();
    if let Geometry::Line(_) = g {
        g.eval(0.0, &mut d);
        let along: f64 = (0..n).map(|k| (p[k] - d.pos[k]) * d.d1[k]).sum();
        return along.clamp(0.0, len);
    }
    let mut best = (f64::INFINITY, 0.0);
    for i in 0..=PROJECT_SAMPLES {
        let s = len * i as f64 / PROJECT_SAMPLES as f64;
        g.eval(s, &mut d);
        let e = dist(&d.pos, p, n);
        if e < best.0 {
            best = (e, s);
        }
    }
    // Newton on f(s) = ½|A(s) − p|²: f′ = (A − p)·A′, f″ = |A′|² + (A − p)·A″.
    let mut s = best.1;
    for _ in 0..PROJECT_NEWTON {
        g.eval(s, &mut d);
        let (mut f1, mut f2) = (0.0, 0.0);
        for k in 0..n {
            let r = d.pos[k] - p[k];
            f1 += r * d.d1[k];
            f2 += d.d1[k] * d.d1[k] + r * d.d2[k];
        }
        if f2 <= 0.0 {
            break;
        }
        s = (s - f1 / f2).clamp(0.0, len);
    }
    g.eval(s, &mut d);
    if dist(&d.pos, p, n) <= best.0 { s } else { best.1 }
}

/// Distance from `p` to the element `g`.
pub(super) fn distance_to(g: &Geometry, p: &AxisVec, n: usize) -> f64 {
    let s = nearest_s(g, p, n);
    let mut d = AxisDerivs::default();
    g.eval(s, &mut d);
    dist(&d.pos, p, n)
}
