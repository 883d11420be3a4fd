//! Arc length of parametric curves by Gauss–Legendre quadrature, and the inversion s ↦ u.
//!
//! A span P(u), u ∈ [0, 1], is split into pieces until 8-point Gauss–Legendre on a piece
//! agrees with the sum over its halves to `QUADRATURE_REL_TOL`; the cumulative lengths at the
//! piece ends form a table. s(u) adds one quadrature over the partial piece; u(s) runs a
//! safeguarded Newton iteration on s(u) − s inside the bracketing piece.

use super::{AxisDerivs, AxisVec, MAX_AXES};

/// Relative agreement required between a piece's quadrature and the sum over its halves.
pub(super) const QUADRATURE_REL_TOL: f64 = 1e-14;
/// Inversion accuracy: |s(u) − s| below this fraction of the span length.
pub(super) const INVERSION_REL_TOL: f64 = 1e-12;
/// Deepest bisection of a piece when building the table.
const MAX_DEPTH: u32 = 24;
/// Most pieces of one table. A span whose speed carries rounding noise above
/// `QUADRATURE_REL_TOL` (a huge or nearly degenerate curve) never meets the tolerance and would
/// be bisected to `MAX_DEPTH` everywhere: 2^24 pieces, 256 MB and a second of work for one span
/// of a program line. Each starting piece gets an equal share; past its share, a piece's parts
/// are taken as they are (at most `MAX_DEPTH` more per starting piece).
const MAX_PIECES: usize = 4096;
/// Newton steps before falling back to bisection alone.
const MAX_NEWTON: usize = 50;

// 8-point Gauss–Legendre nodes and weights on [−1, 1].
const GL_X: [f64; 4] =
    [0.183_434_642_495_649_8, 0.525_532_409_916_329, 0.796_666_477_413_626_7, 0.960_289_856_497_536_2];
const GL_W: [f64; 4] =
    [0.362_683_783_378_362, 0.313_706_645_877_887_3, 0.222_381_034_453_374_5, 0.101_228_536_290_376_3];

/// A′ … A‴ with respect to arc length from P′, P″, P‴ with respect to a curve parameter u, for
/// the first `n` axes: with σ = |P′| over the linear axes, σ_u = P′·P″/σ and
/// σ_uu = (|P″|² + P′·P‴)/σ − σ_u²/σ, the chain rule for u(s) gives u′ = 1/σ, u″ = −σ_u/σ³,
/// u‴ = −σ_uu/σ⁴ + 3σ_u²/σ⁵, and A′ = P′u′, A″ = P″u′² + P′u″, A‴ = P‴u′³ + 3P″u′u″ + P′u‴.
pub(super) fn reparameterize(
    p1: &AxisVec,
    p2: &AxisVec,
    p3: &AxisVec,
    linear: &[bool; MAX_AXES],
    n: usize,
    out: &mut AxisDerivs,
) {
    let (mut p1p1, mut p1p2, mut p2p2, mut p1p3) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        if linear[k] {
            p1p1 += p1[k] * p1[k];
            p1p2 += p1[k] * p2[k];
            p2p2 += p2[k] * p2[k];
            p1p3 += p1[k] * p3[k];
        }
    }
    let sigma = p1p1.sqrt();
    let sigma_u = p1p2 / sigma;
    let sigma_uu = (p2p2 + p1p3) / sigma - sigma_u * sigma_u / sigma;
    let u1 = 1.0 / sigma;
    let u2 = -sigma_u * u1 * u1 * u1;
    let u3 = -sigma_uu * u1.powi(4) + 3.0 * sigma_u * sigma_u * u1.powi(5);
    for k in 0..n {
        out.d1[k] = p1[k] * u1;
        out.d2[k] = p2[k] * u1 * u1 + p1[k] * u2;
        out.d3[k] = p3[k] * u1 * u1 * u1 + 3.0 * p2[k] * u1 * u2 + p1[k] * u3;
    }
}

/// ∫ₐᵇ f(u) du by 8-point Gauss–Legendre.
pub(super) fn gauss_legendre_8(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let half = 0.5 * (b - a);
    let mid = 0.5 * (a + b);
    let mut sum = 0.0;
    for i in 0..4 {
        let dx = half * GL_X[i];
        sum += GL_W[i] * (f(mid - dx) + f(mid + dx));
    }
    sum * half
}

/// Cumulative arc-length table of one span.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct ArcLengthTable {
    /// Piece boundaries in u, from 0 to 1.
    u: Vec<f64>,
    /// Arc length from u = 0 to each boundary.
    s: Vec<f64>,
}

impl ArcLengthTable {
    /// Builds the table for the speed |P′(u)| given by `speed`.
    pub(super) fn build(speed: &impl Fn(f64) -> f64) -> Self {
        // Start from 8 pieces so that features narrower than the span are not missed.
        Self::build_from(speed, &[], 8)
    }

    /// Builds the table starting from the pieces between `breaks` (ascending, inside (0, 1)),
    /// each cut into `per_piece` equal parts, then refined. A curve whose speed can only turn
    /// sharply at known parameters (a cubic's at the minima of |P′|) needs few pieces when
    /// those parameters are breaks: between them the speed is smooth and monotone.
    pub(super) fn build_from(speed: &impl Fn(f64) -> f64, breaks: &[f64], per_piece: usize) -> Self {
        debug_assert!(breaks.windows(2).all(|w| w[0] <= w[1]), "breaks must ascend: {breaks:?}");
        let mut u = vec![0.0];
        let mut s = vec![0.0];
        let per_piece = per_piece.max(1);
        let ends = breaks.iter().copied().filter(|&b| b > 0.0 && b < 1.0).chain(std::iter::once(1.0));
        let starting = per_piece * (breaks.iter().filter(|&&b| b > 0.0 && b < 1.0).count() + 1);
        let share = (MAX_PIECES / starting).max(1);
        let mut from = 0.0;
        for to in ends {
            for i in 0..per_piece {
                let a = from + (to - from) * i as f64 / per_piece as f64;
                let b = if i + 1 == per_piece { to } else { from + (to - from) * (i + 1) as f64 / per_piece as f64 };
                let whole = gauss_legendre_8(speed, a, b);
                let most = u.len() + share;
                refine(speed, (a, b), whole, 0, most, &mut u, &mut s);
            }
            from = to;
        }
        Self { u, s }
    }

    pub(super) fn length(&self) -> f64 {
        *self.s.last().expect("table has at least two entries")
    }

    /// Arc length from 0 to `u`.
    pub(super) fn s_of_u(&self, speed: &impl Fn(f64) -> f64, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        let i = self.u.partition_point(|&x| x <= u).saturating_sub(1).min(self.u.len() - 2);
        self.s[i] + gauss_legendre_8(speed, self.u[i], u)
    }

    /// Parameter u at arc length `s` (clamped to the span).
    pub(super) fn u_of_s(&self, speed: &impl Fn(f64) -> f64, s: f64) -> f64 {
        let len = self.length();
        if s <= 0.0 {
            return 0.0;
        }
        if s >= len {
            return 1.0;
        }
        let i = self.s.partition_point(|&x| x <= s).saturating_sub(1).min(self.s.len() - 2);
        let (mut lo, mut hi) = (self.u[i], self.u[i + 1]);
        let (s_lo, s_hi) = (self.s[i], self.s[i + 1]);
        // Linear start inside the piece, then Newton with the bracket as safeguard.
        let mut u = lo + (hi - lo) * (s - s_lo) / (s_hi - s_lo).max(f64::MIN_POSITIVE);
        let tol = INVERSION_REL_TOL * len.max(f64::MIN_POSITIVE);
        for _ in 0..MAX_NEWTON {
            let f = self.s[i] + gauss_legendre_8(speed, self.u[i], u) - s;
            if f.abs() <= tol {
                return u;
            }
            if f > 0.0 {
                hi = u;
            } else {
                lo = u;
            }
            let d = speed(u);
            let newton = u - f / d;
            u = if d > 0.0 && newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if hi - lo <= f64::EPSILON * 4.0 {
                return u;
            }
        }
        u
    }
}

/// Bisects [a, b] until the quadrature converges, `MAX_DEPTH` is reached or the table holds
/// `most` boundaries, appending the piece ends to `u` and their arc lengths to `s`.
fn refine(
    speed: &impl Fn(f64) -> f64,
    (a, b): (f64, f64),
    whole: f64,
    depth: u32,
    most: usize,
    u: &mut Vec<f64>,
    s: &mut Vec<f64>,
) {
    let m = 0.5 * (a + b);
    let left = gauss_legendre_8(speed, a, m);
    let right = gauss_legendre_8(speed, m, b);
    let converged = (left + right - whole).abs() <= QUADRATURE_REL_TOL * (left + right).abs().max(1e-300);
    if converged || depth >= MAX_DEPTH || u.len() >= most {
        let base = *s.last().expect("non-empty");
        u.push(b);
        s.push(base + left + right);
        return;
    }
    refine(speed, (a, m), left, depth + 1, most, u, s);
    refine(speed, (m, b), right, depth + 1, most, u, s);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_speed_with_rounding_noise_gets_a_bounded_table() {
        // Noise of 1e-9 relative never meets QUADRATURE_REL_TOL: without the cap every piece
        // would be bisected to MAX_DEPTH (2^24 pieces).
        let noisy =
            |u: f64| 1.0 + 1e-9 * ((u.to_bits().wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 40) as f64 / 16_777_216.0);
        let table = ArcLengthTable::build(&noisy);
        assert!(table.u.len() <= 5000, "{} pieces", table.u.len());
        // Every part of the span gets its share: about as many pieces right of the middle as left.
        let right = table.u.iter().filter(|&&u| u > 0.5).count();
        assert!(right * 5 >= table.u.len() * 2, "{right} of {} pieces right of u = 0.5", table.u.len());
        assert!((table.length() - 1.0).abs() < 2e-9, "{}", table.length());
        // A smooth speed stays far below the cap and exact.
        let smooth = ArcLengthTable::build(&|u: f64| 1.0 + u * u);
        assert!(smooth.u.len() < 100 && (smooth.length() - 4.0 / 3.0).abs() < 1e-14, "{}", smooth.u.len());
    }

    #[test]
    fn parabola_length_matches_closed_form() {
        // P(u) = (u, u²)·10: |P′| = 10·√(1 + 4u²)
        let speed = |u: f64| 10.0 * (1.0 + 4.0 * u * u).sqrt();
        let t = ArcLengthTable::build(&speed);
        let exact = 10.0 * (2.0 * 5f64.sqrt() + (2.0 + 5f64.sqrt()).ln()) / 4.0;
        assert!((t.length() - exact).abs() < 1e-12, "{} vs {exact}", t.length());
    }

    #[test]
    fn inversion_round_trips() {
        let speed = |u: f64| 1.0 + 30.0 * (u - 0.3).powi(2);
        let t = ArcLengthTable::build(&speed);
        let len = t.length();
        for i in 0..=1000 {
            let s = len * i as f64 / 1000.0;
            let u = t.u_of_s(&speed, s);
            let back = t.s_of_u(&speed, u);
            assert!((back - s).abs() <= 1e-9 * len, "s={s} u={u} back={back}");
        }
    }
}
