//! The limit uses of Kopp et al. 2019, eq. 1a–1c at one check point, four axes at a time: the
//! same operations in the same order as the scalar `check::axis_uses`, lane by lane, so every
//! lane rounds exactly as the scalar code would and the result is the same to the bit (a test
//! compares them; Rust never fuses a multiply and an add). Written as plain arrays, which the
//! compiler turns into vector instructions: SSE2 pairs on every x86-64 CPU, AVX quads where
//! the CPU has AVX (detected at run time, `check::point_violation`). On machines with four or
//! more axes, checking the limits at the points inside the intervals is the planner's largest
//! cost.
//!
//! The axes go in chunks of four that may overlap (five axes: 0–3 and 1–4), which the maximum
//! does not mind; with fewer than four axes the lanes past the last axis are left out.

use super::hermite_basis::HermiteBasis;
use super::limits::Limits;
use super::node::{IntervalGeom, NodeGeom, SpanPoly};
use crate::path::MAX_AXES;

/// Axes per chunk.
const LANES: usize = 4;
type Lanes = [f64; LANES];

/// `[f(0), f(1), f(2), f(3)]` (`array::map` is not always inlined, and then nothing is
/// vectorized).
#[inline(always)]
fn each<T>(f: impl Fn(usize) -> T) -> [T; LANES] {
    [f(0), f(1), f(2), f(3)]
}

#[inline(always)]
fn splat(x: f64) -> Lanes {
    [x; LANES]
}

/// Axes k … k+3 of `x`. The chunks never reach past the machine's axes (≤ `MAX_AXES`), nor
/// past `MAX_AXES` with fewer than four.
#[inline(always)]
fn load(x: &[f64; MAX_AXES], k: usize) -> Lanes {
    let c: &[f64; LANES] = x[k..k + LANES].try_into().expect("a chunk within the axes");
    *c
}

#[inline(always)]
fn zip(a: Lanes, b: Lanes, f: impl Fn(f64, f64) -> f64) -> Lanes {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
}

#[inline(always)]
fn add(a: Lanes, b: Lanes) -> Lanes {
    zip(a, b, |x, y| x + y)
}

#[inline(always)]
fn mul(a: Lanes, b: Lanes) -> Lanes {
    zip(a, b, |x, y| x * y)
}

#[inline(always)]
fn abs(a: Lanes) -> Lanes {
    [a[0].abs(), a[1].abs(), a[2].abs(), a[3].abs()]
}

/// `check::raise_to` per lane: `m` raised to `x`, a NaN `x` skipped.
#[inline(always)]
fn raise(m: Lanes, x: Lanes) -> Lanes {
    zip(m, x, |m, x| if x > m { x } else { m })
}

/// A′, A″, A‴ of four axes in traversal order.
type Geom4 = (Lanes, Lanes, Lanes);

/// The state at a check point, in every lane: v, v², v³, a, 3va, j.
struct State {
    v: Lanes,
    v2: Lanes,
    v3: Lanes,
    a: Lanes,
    va3: Lanes,
    j: Lanes,
}

/// The largest of the velocity, acceleration and jerk uses of axes k … k+3 with geometry
/// (A′, A″, A‴) per lane: `check::axis_uses`.
#[inline(always)]
fn chunk_uses((d1, d2, d3): Geom4, st: &State, lim: &Limits, k: usize) -> Lanes {
    let vel = mul(d1, st.v); // Kopp et al. 2019, eq. 1a
    let acc = add(mul(d2, st.v2), mul(d1, st.a)); // eq. 1b
    let jerk = add(add(mul(d3, st.v3), mul(d2, st.va3)), mul(d1, st.j)); // eq. 1c
    // acc ≥ 0 (false for NaN, as in the scalar code) takes the upper limit's reciprocal.
    let (up, down) = (load(&lim.inv_acc_max, k), load(&lim.inv_acc_min, k));
    let pick = |i: usize| if acc[i] >= 0.0 { up[i] } else { down[i] };
    let r_vel = mul(abs(vel), load(&lim.inv_vel, k));
    let r_acc = mul(acc, each(pick));
    let r_jerk = mul(abs(jerk), load(&lim.inv_jerk, k));
    raise(raise(raise(splat(f64::NEG_INFINITY), r_vel), r_acc), r_jerk)
}

/// Where a check point's geometry comes from: A′, A″, A‴ of axes k … k+3 in traversal order.
/// (A trait rather than closures: the compiler did not inline those into the AVX code.)
trait Source {
    fn chunk(&self, k: usize) -> Geom4;
}

/// The largest limit use over the axes minus one, with the geometry from `geom`:
/// `check::axes_violation` in lanes.
#[inline(always)]
fn axes_violation(v: f64, a: f64, j: f64, lim: &Limits, geom: &impl Source) -> f64 {
    let st = State {
        v: splat(v),
        v2: splat(v * v),
        v3: splat(v * v * v),
        a: splat(a),
        va3: splat(3.0 * v * a),
        j: splat(j),
    };
    let n = lim.n_axes;
    let worst = if n <= LANES {
        // One chunk; the lanes past the last axis hold no axis.
        let u = chunk_uses(geom.chunk(0), &st, lim, 0);
        each(|i| if i < n { u[i] } else { f64::NEG_INFINITY })
    } else {
        // Chunks from axis 0 on, the last one ending at the last axis (overlapping).
        let mut worst = splat(f64::NEG_INFINITY);
        let mut k = 0;
        while k + LANES < n {
            worst = raise(worst, chunk_uses(geom.chunk(k), &st, lim, k));
            k += LANES;
        }
        raise(worst, chunk_uses(geom.chunk(n - LANES), &st, lim, n - LANES))
    };
    let [w0, w1, w2, w3] = worst;
    raise(raise(splat(w0), splat(w1)), raise(splat(w2), splat(w3)))[0] - 1.0
}

/// At a node (`check::node_at`).
#[inline(always)]
pub(super) fn at_node(g: &IntervalGeom, n: &NodeGeom, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    axes_violation(v, a, j, lim, &AtNode { n, sign: splat(g.sign) })
}

struct AtNode<'a> {
    n: &'a NodeGeom,
    sign: Lanes,
}

impl Source for AtNode<'_> {
    #[inline(always)]
    fn chunk(&self, k: usize) -> Geom4 {
        let n = self.n;
        (mul(self.sign, load(&n.d1, k)), load(&n.d2, k), mul(self.sign, load(&n.d3, k)))
    }
}

/// On the exact geometry at fraction σ, whose `SpanPoly::powers` (in increasing s) are `p`
/// (`check::span_at`).
#[inline(always)]
pub(super) fn on_span(g: &IntervalGeom, poly: &SpanPoly, p: &[f64; 7], v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    let pw = [splat(p[0]), splat(p[1]), splat(p[2]), splat(p[3]), splat(p[4]), splat(p[5]), splat(p[6])];
    axes_violation(v, a, j, lim, &OnSpan { poly, pw, sign: splat(g.sign) })
}

struct OnSpan<'a> {
    poly: &'a SpanPoly,
    /// σ⁰ … σ⁶.
    pw: [Lanes; 7],
    sign: Lanes,
}

impl Source for OnSpan<'_> {
    /// The sums of `SpanPoly::at`, grouped alike.
    #[inline(always)]
    fn chunk(&self, k: usize) -> Geom4 {
        let c = |i: usize| load(self.poly.coefficient(i), k);
        let t = |i: usize, q: usize| mul(c(i), self.pw[q]);
        let d1 = add(add(add(add(c(0), t(1, 1)), t(2, 2)), add(t(3, 3), t(4, 4))), add(t(5, 5), t(6, 6)));
        let d2 = add(add(add(c(7), t(8, 1)), t(9, 2)), add(add(t(10, 3), t(11, 4)), t(12, 5)));
        let d3 = add(add(add(c(13), t(14, 1)), t(15, 2)), add(t(16, 3), t(17, 4)));
        (mul(self.sign, d1), d2, mul(self.sign, d3))
    }
}

/// Interpolated between the nodes with the cubic Hermite basis (h00, h10, h01, h11) at σ
/// (`check::cubic_at`).
#[inline(always)]
pub(super) fn interpolated(g: &IntervalGeom, h: [f64; 4], sigma: f64, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    let src = Hermite {
        start: g.start,
        end: g.end,
        h: [splat(h[0]), splat(h[1]), splat(h[2]), splat(h[3])],
        linear: [splat(1.0 - sigma), splat(sigma)],
        sign: splat(g.sign),
        ds: splat(g.ds_mm),
        sign_ds: splat(g.sign * g.ds_mm),
    };
    axes_violation(v, a, j, lim, &src)
}

struct Hermite<'a> {
    start: &'a NodeGeom,
    end: &'a NodeGeom,
    /// h00, h10, h01, h11.
    h: [Lanes; 4],
    /// 1 − σ, σ.
    linear: [Lanes; 2],
    sign: Lanes,
    ds: Lanes,
    sign_ds: Lanes,
}

impl Source for Hermite<'_> {
    #[inline(always)]
    fn chunk(&self, k: usize) -> Geom4 {
        let (s, e) = (self.start, self.end);
        let [h00, h10, h01, h11] = self.h;
        let mix =
            |x: &[f64; MAX_AXES], y: &[f64; MAX_AXES], p: Lanes, q: Lanes| add(mul(p, load(x, k)), mul(q, load(y, k)));
        let d1 = add(mul(self.sign, mix(&s.d1, &e.d1, h00, h01)), mul(self.ds, mix(&s.d2, &e.d2, h10, h11)));
        let d2 = add(mix(&s.d2, &e.d2, h00, h01), mul(self.sign_ds, mix(&s.d3, &e.d3, h10, h11)));
        let d3 = mul(self.sign, mix(&s.d3, &e.d3, self.linear[0], self.linear[1]));
        (d1, d2, d3)
    }
}

/// Interpolated between the nodes with the quintic Hermite basis of `hermite_basis::HermiteBasis`
/// (`check::hermite_at`, whose sums run in the same order).
#[inline(always)]
pub(super) fn interpolated_quintic(g: &IntervalGeom, h: &HermiteBasis, v: f64, a: f64, j: f64, lim: &Limits) -> f64 {
    let src = Quintic { start: g.start, end: g.end, h, sign: splat(g.sign) };
    axes_violation(v, a, j, lim, &src)
}

struct Quintic<'a> {
    start: &'a NodeGeom,
    end: &'a NodeGeom,
    h: &'a HermiteBasis,
    sign: Lanes,
}

impl Source for Quintic<'_> {
    #[inline(always)]
    fn chunk(&self, k: usize) -> Geom4 {
        let (s, e) = (self.start, self.end);
        let (p0, p1) = (mul(self.sign, load(&s.d1, k)), mul(self.sign, load(&e.d1, k)));
        let (q0, q1) = (load(&s.d2, k), load(&e.d2, k));
        let (r0, r1) = (mul(self.sign, load(&s.d3, k)), mul(self.sign, load(&e.d3, k)));
        let d = zip(p1, p0, |x, y| x - y);
        let w = |x: f64| splat(x);
        let h = self.h;
        let d1 = add(
            add(
                add(add(add(mul(w(h.d1[0]), p0), mul(w(h.d1[1]), p1)), mul(w(h.d1[2]), q0)), mul(w(h.d1[3]), q1)),
                mul(w(h.d1[4]), r0),
            ),
            mul(w(h.d1[5]), r1),
        );
        let sum5 = |c: &[f64; 5]| {
            add(add(add(add(mul(w(c[0]), d), mul(w(c[1]), q0)), mul(w(c[2]), q1)), mul(w(c[3]), r0)), mul(w(c[4]), r1))
        };
        (d1, sum5(&h.d2), sum5(&h.d3))
    }
}
