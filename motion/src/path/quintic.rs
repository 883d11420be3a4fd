//! Quintic Hermite pieces: the smoothed path the tolerance-band stage emits (Haas 2012, §4.5).

use super::arclength::{self, ArcLengthTable};
use super::{AxisDerivs, AxisVec, MAX_AXES, SpanError};

/// Value, first and second derivative per axis at one end of a quintic piece, with respect to
/// the piece's own parameter t ∈ [0, 1].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct HermiteEnd {
    pub pos: AxisVec,
    pub d1: AxisVec,
    pub d2: AxisVec,
    /// Third and fourth derivative, used by the degree-7 and degree-9 pieces only.
    pub d3: AxisVec,
    pub d4: AxisVec,
}

/// Coefficients a piece holds: up to degree 9 (x … x⁗ at both ends).
const MAX_COEF: usize = 10;

/// Quintic Hermite piece between two smoothed points (Haas 2012, §4.5, eq. 4.17–4.21, as a full
/// quintic: the printed eq. 4.21 stops at t⁴): per axis the degree-5 polynomial in t ∈ [0, 1]
/// that matches position, first and second derivative at both ends, so consecutive pieces
/// built from the same end data join C² (only the third derivative jumps). Evaluated over its
/// arc length s like [`super::CubicSpan`].
#[derive(Debug, Clone, PartialEq)]
pub struct QuinticSpan {
    /// `P(t) = Σᵢ c[k][i] tⁱ` per axis k (i < `n_coef`).
    c: [[f64; MAX_COEF]; MAX_AXES],
    /// 6 for a quintic; 8 or 10 for the degree-7 / degree-9 Hermite pieces of higher continuity.
    n_coef: usize,
    linear: [bool; MAX_AXES],
    table: ArcLengthTable,
}

/// Inverse of the end-condition matrix `[[1,1,1],[3,4,5],[6,12,20]]` of the quintic Hermite
/// problem once c₀ = p₀, c₁ = p′₀, c₂ = p″₀/2 are fixed (exact fractions).
const END_INV: [[f64; 3]; 3] = [[10.0, -4.0, 0.5], [-15.0, 7.0, -1.0], [6.0, -3.0, 0.5]];

/// Samples per piece when looking for a vanishing tangent.
const CUSP_SAMPLES: usize = 64;
/// A piece whose speed |P′| drops below this fraction of its length is degenerate.
const CUSP_REL_TOL: f64 = 1e-6;

impl QuinticSpan {
    /// The quintic Hermite piece from `a` to `b` (Haas 2012, §4.5, eq. 4.17–4.21: value, first
    /// and second derivative at both ends); derivatives are per unit t. Axes flagged in `linear`
    /// define the arc length.
    pub(crate) fn hermite(a: &HermiteEnd, b: &HermiteEnd, linear: &[bool]) -> Result<Self, SpanError> {
        let mut c = [[0.0; MAX_COEF]; MAX_AXES];
        for (k, ck) in c.iter_mut().enumerate() {
            ck[0] = a.pos[k];
            ck[1] = a.d1[k];
            ck[2] = 0.5 * a.d2[k];
            let r = [b.pos[k] - (ck[0] + ck[1] + ck[2]), b.d1[k] - (ck[1] + 2.0 * ck[2]), b.d2[k] - 2.0 * ck[2]];
            for (i, row) in END_INV.iter().enumerate() {
                ck[3 + i] = row[0] * r[0] + row[1] * r[1] + row[2] * r[2];
            }
        }
        Self::from_coefficients(c, 6, linear)
    }

    /// The Hermite piece of degree 2L − 1 that matches the first L = `levels` (3, 4 or 5) of
    /// x, x′, x″, x‴, x⁗ at both ends (per unit t): C^(L − 1) between pieces built from the same
    /// end data. `levels` = 3 is [`Self::hermite`].
    pub(crate) fn hermite_levels(
        a: &HermiteEnd,
        b: &HermiteEnd,
        levels: usize,
        linear: &[bool],
    ) -> Result<Self, SpanError> {
        if levels <= 3 {
            return Self::hermite(a, b, linear);
        }
        let l = levels.min(5);
        let n = 2 * l;
        // (k!/(k − m)!) for the m-th derivative of tᵏ at t = 1.
        let falling = |k: usize, m: usize| -> f64 { (0..m).map(|i| (k - i) as f64).product() };
        let fact = |m: usize| -> f64 { (1..=m).map(|i| i as f64).product() };
        // The end-condition matrix of the upper coefficients c_l … c_{2l−1}, inverted once.
        let m = nalgebra::DMatrix::from_fn(l, l, |r, i| falling(l + i, r));
        let inv = m.try_inverse().ok_or(SpanError::ZeroTangent)?;
        let mut c = [[0.0; MAX_COEF]; MAX_AXES];
        for (k, ck) in c.iter_mut().enumerate() {
            let da = [a.pos[k], a.d1[k], a.d2[k], a.d3[k], a.d4[k]];
            let db = [b.pos[k], b.d1[k], b.d2[k], b.d3[k], b.d4[k]];
            for j in 0..l {
                ck[j] = da[j] / fact(j);
            }
            let r: Vec<f64> =
                (0..l).map(|row| db[row] - (row..l).map(|j| ck[j] * falling(j, row)).sum::<f64>()).collect();
            for i in 0..l {
                ck[l + i] = (0..l).map(|row| inv[(i, row)] * r[row]).sum();
            }
        }
        Self::from_coefficients(c, n, linear)
    }

    fn from_coefficients(c: [[f64; MAX_COEF]; MAX_AXES], n_coef: usize, linear: &[bool]) -> Result<Self, SpanError> {
        let mut mask = [false; MAX_AXES];
        for (k, m) in mask.iter_mut().enumerate() {
            *m = linear.get(k).copied().unwrap_or(false);
        }
        let speed = |t: f64| speed_of(&c, n_coef, &mask, t);
        let table = ArcLengthTable::build(&speed);
        let len = table.length();
        if !len.is_finite() || len <= 0.0 {
            return Err(SpanError::ZeroTangent);
        }
        if min_speed(&speed) < CUSP_REL_TOL * len {
            return Err(SpanError::ZeroTangent);
        }
        Ok(Self { c, n_coef, linear: mask, table })
    }

    pub(crate) fn length_mm(&self) -> f64 {
        self.table.length()
    }

    /// P(t) in the piece parameter.
    pub(crate) fn point_at_t(&self, t: f64) -> AxisVec {
        let mut p = [0.0; MAX_AXES];
        for (k, pk) in p.iter_mut().enumerate() {
            *pk = horner(&self.c[k], self.n_coef, t);
        }
        p
    }

    /// Piece parameter at arc length `s`.
    pub(crate) fn t_at(&self, s: f64) -> f64 {
        self.table.u_of_s(&|t| speed_of(&self.c, self.n_coef, &self.linear, t), s)
    }

    pub(crate) fn eval(&self, s: f64, out: &mut AxisDerivs) {
        let t = self.t_at(s);
        self.eval_at_t(t, out);
    }

    /// A(s) … A‴(s) at piece parameter `t` (no arc-length inversion).
    pub(crate) fn eval_at_t(&self, t: f64, out: &mut AxisDerivs) {
        let (mut p1, mut p2, mut p3) = ([0.0; MAX_AXES], [0.0; MAX_AXES], [0.0; MAX_AXES]);
        for k in 0..MAX_AXES {
            let c = &self.c[k];
            out.pos[k] = horner(c, self.n_coef, t);
            if self.n_coef == 6 {
                p1[k] = (((5.0 * c[5] * t + 4.0 * c[4]) * t + 3.0 * c[3]) * t + 2.0 * c[2]) * t + c[1];
                p2[k] = ((20.0 * c[5] * t + 12.0 * c[4]) * t + 6.0 * c[3]) * t + 2.0 * c[2];
                p3[k] = (60.0 * c[5] * t + 24.0 * c[4]) * t + 6.0 * c[3];
            } else {
                p1[k] = derivative(c, self.n_coef, 1, t);
                p2[k] = derivative(c, self.n_coef, 2, t);
                p3[k] = derivative(c, self.n_coef, 3, t);
            }
        }
        arclength::reparameterize(&p1, &p2, &p3, &self.linear, MAX_AXES, out);
    }
}

/// Smallest |P′(t)| on [0, 1]: sampled, then every local minimum refined by golden section.
fn min_speed(speed: &impl Fn(f64) -> f64) -> f64 {
    let h = 1.0 / CUSP_SAMPLES as f64;
    let v: Vec<f64> = (0..=CUSP_SAMPLES).map(|i| speed(i as f64 * h)).collect();
    let mut best = v.iter().copied().fold(f64::INFINITY, f64::min);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for i in 1..CUSP_SAMPLES {
        if v[i] > v[i - 1] || v[i] > v[i + 1] {
            continue;
        }
        let (mut a, mut b) = ((i - 1) as f64 * h, (i + 1) as f64 * h);
        for _ in 0..40 {
            let (c, d) = (b - g * (b - a), a + g * (b - a));
            if speed(c) < speed(d) {
                b = d;
            } else {
                a = c;
            }
        }
        best = best.min(speed(0.5 * (a + b)));
    }
    best
}

fn horner(c: &[f64; MAX_COEF], n_coef: usize, t: f64) -> f64 {
    if n_coef == 6 {
        return ((((c[5] * t + c[4]) * t + c[3]) * t + c[2]) * t + c[1]) * t + c[0];
    }
    c[..n_coef].iter().rev().fold(0.0, |acc, &ci| acc * t + ci)
}

/// The `m`-th derivative of Σ cᵢ tⁱ (i < n_coef) at t, by Horner.
fn derivative(c: &[f64; MAX_COEF], n_coef: usize, m: usize, t: f64) -> f64 {
    let mut acc = 0.0;
    for i in (m..n_coef).rev() {
        let f: f64 = (0..m).map(|j| (i - j) as f64).product();
        acc = acc * t + f * c[i];
    }
    acc
}

fn speed_of(c: &[[f64; MAX_COEF]; MAX_AXES], n_coef: usize, linear: &[bool; MAX_AXES], t: f64) -> f64 {
    let mut sq = 0.0;
    for k in 0..MAX_AXES {
        if linear[k] {
            let ck = &c[k];
            let d = if n_coef == 6 {
                (((5.0 * ck[5] * t + 4.0 * ck[4]) * t + 3.0 * ck[3]) * t + 2.0 * ck[2]) * t + ck[1]
            } else {
                derivative(ck, n_coef, 1, t)
            };
            sq += d * d;
        }
    }
    sq.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::{Geometry, testutil::max_fd_error};

    const LIN: [bool; 3] = [true, true, true];

    fn end(p: [f64; 3], d1: [f64; 3], d2: [f64; 3]) -> HermiteEnd {
        let mut e = HermiteEnd::default();
        e.pos[..3].copy_from_slice(&p);
        e.d1[..3].copy_from_slice(&d1);
        e.d2[..3].copy_from_slice(&d2);
        e
    }

    #[test]
    fn matches_end_data() {
        let a = end([0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 2.0, 1.0]);
        let b = end([4.0, 2.0, 0.5], [1.0, 3.0, 0.2], [-2.0, 0.5, 0.0]);
        let q = QuinticSpan::hermite(&a, &b, &LIN).unwrap();
        let h = 1e-4;
        for k in 0..3 {
            let c = &q.c[k];
            assert!((horner(c, 6, 0.0) - a.pos[k]).abs() < 1e-14);
            assert!((horner(c, 6, 1.0) - b.pos[k]).abs() < 1e-13);
            // Central differences of P at the ends against the data.
            let d1 = |t: f64| (horner(c, 6, t + h) - horner(c, 6, t - h)) / (2.0 * h);
            let d2 = |t: f64| (horner(c, 6, t + h) - 2.0 * horner(c, 6, t) + horner(c, 6, t - h)) / (h * h);
            assert!((d1(0.0) - a.d1[k]).abs() < 1e-6 && (d1(1.0) - b.d1[k]).abs() < 1e-6);
            assert!((d2(0.0) - a.d2[k]).abs() < 1e-5 && (d2(1.0) - b.d2[k]).abs() < 1e-5);
        }
    }

    #[test]
    fn reproduces_a_straight_line() {
        let a = end([1.0, 2.0, 0.0], [3.0, 4.0, 0.0], [0.0; 3]);
        let b = end([4.0, 6.0, 0.0], [3.0, 4.0, 0.0], [0.0; 3]);
        let q = QuinticSpan::hermite(&a, &b, &LIN).unwrap();
        assert!((q.length_mm() - 5.0).abs() < 1e-12);
        let mut d = AxisDerivs::default();
        q.eval(2.5, &mut d);
        assert!((d.pos[0] - 2.5).abs() < 1e-12 && (d.pos[1] - 4.0).abs() < 1e-12);
        assert!((d.d1[0] - 0.6).abs() < 1e-12 && d.d2[0].abs() < 1e-12 && d.d3[1].abs() < 1e-12);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let a = end([0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 2.0, 1.0]);
        let b = end([4.0, 2.0, 0.5], [1.0, 3.0, 0.2], [-2.0, 0.5, 0.0]);
        let q = QuinticSpan::hermite(&a, &b, &LIN).unwrap();
        let e = max_fd_error(&Geometry::Quintic(Box::new(q)), 3, 40);
        assert!(e < 1e-6, "relative FD error {e}");
    }

    #[test]
    fn consecutive_pieces_join_c2_in_arc_length() {
        let a = end([0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 2.0, 1.0]);
        let m = end([4.0, 2.0, 0.5], [1.0, 3.0, 0.2], [-2.0, 0.5, 0.0]);
        // The second piece is twice as long in t: its derivatives per unit t scale by 2 and 4.
        let mut m2 = m;
        for k in 0..3 {
            m2.d1[k] *= 2.0;
            m2.d2[k] *= 4.0;
        }
        let b = end([7.0, 9.0, 1.0], [6.0, 2.0, 0.0], [0.0, -1.0, 0.0]);
        let p = QuinticSpan::hermite(&a, &m, &LIN).unwrap();
        let q = QuinticSpan::hermite(&m2, &b, &LIN).unwrap();
        let (mut l, mut r) = (AxisDerivs::default(), AxisDerivs::default());
        p.eval(p.length_mm(), &mut l);
        q.eval(0.0, &mut r);
        for k in 0..3 {
            assert!((l.pos[k] - r.pos[k]).abs() < 1e-12);
            assert!((l.d1[k] - r.d1[k]).abs() < 1e-12);
            assert!((l.d2[k] - r.d2[k]).abs() < 1e-10, "{} vs {}", l.d2[k], r.d2[k]);
        }
    }

    #[test]
    fn higher_degree_pieces_match_their_end_data_and_finite_differences() {
        let mut a = end([0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 2.0, 1.0]);
        let mut b = end([4.0, 2.0, 0.5], [1.0, 3.0, 0.2], [-2.0, 0.5, 0.0]);
        a.d3[..3].copy_from_slice(&[1.0, -2.0, 0.5]);
        b.d3[..3].copy_from_slice(&[-1.0, 0.0, 2.0]);
        a.d4[..3].copy_from_slice(&[3.0, 1.0, 0.0]);
        b.d4[..3].copy_from_slice(&[0.0, -4.0, 1.0]);
        for levels in [4, 5] {
            let q = QuinticSpan::hermite_levels(&a, &b, levels, &LIN).unwrap();
            assert_eq!(q.n_coef, 2 * levels);
            for k in 0..3 {
                let da = [a.pos[k], a.d1[k], a.d2[k], a.d3[k], a.d4[k]];
                let db = [b.pos[k], b.d1[k], b.d2[k], b.d3[k], b.d4[k]];
                for m in 0..levels {
                    let (v0, v1) = if m == 0 {
                        (horner(&q.c[k], q.n_coef, 0.0), horner(&q.c[k], q.n_coef, 1.0))
                    } else {
                        (derivative(&q.c[k], q.n_coef, m, 0.0), derivative(&q.c[k], q.n_coef, m, 1.0))
                    };
                    assert!((v0 - da[m]).abs() < 1e-9 && (v1 - db[m]).abs() < 1e-9, "levels {levels} axis {k} m {m}");
                }
            }
            let e = max_fd_error(&Geometry::Quintic(Box::new(q)), 3, 40);
            assert!(e < 1e-6, "relative FD error {e}");
        }
        // Three levels is the quintic itself, bit for bit.
        let q3 = QuinticSpan::hermite_levels(&a, &b, 3, &LIN).unwrap();
        assert_eq!(q3, QuinticSpan::hermite(&a, &b, &LIN).unwrap());
    }

    #[test]
    fn cusp_is_rejected() {
        let a = end([0.0, 0.0, 0.0], [-3.0, 0.0, 0.0], [0.0; 3]);
        let b = end([1.0, 0.0, 0.0], [-3.0, 0.0, 0.0], [0.0; 3]);
        assert_eq!(QuinticSpan::hermite(&a, &b, &LIN).unwrap_err(), SpanError::ZeroTangent);
    }
}
