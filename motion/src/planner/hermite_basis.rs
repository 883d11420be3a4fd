//! The quintic Hermite basis the limit checks interpolate smoothed pieces' steps with
//! (`check.rs`, and the 4-lane fast path in `lanes.rs`, which both use it). Its own file so
//! that neither of the two imports the other.

/// The quintic Hermite basis at fraction σ of an interval `ds` long, shared by the axes of one
/// point (on steps of smoothed pieces: see [`IntervalGeom::quintic`](super::node::IntervalGeom::quintic)). A′ is the quintic that
/// matches A′, A″ and A‴ at both nodes (in traversal order: P, Q, R per node); A″ and A‴ are
/// its first and second derivatives in s. So the three stay consistent (A″ = dA′/ds, A‴ =
/// dA″/ds), and the errors are O(ds⁶), O(ds⁵), O(ds⁴) where a cubic Hermite A′ with a linear A‴
/// leaves A‴ off by O(ds²): that error, weighed by v³, set the node spacing on tight smoothed
/// curves (the sampling halves a step until the interpolated geometry misses the element's own
/// by 1e-3 of a limit).
///
/// Weights, with D = P₁ − P₀:
/// - `d1`: of P₀, P₁, Q₀, Q₁, R₀, R₁;
/// - `d2`, `d3`: of D, Q₀, Q₁, R₀, R₁.
#[derive(Clone, Copy)]
pub(super) struct HermiteBasis {
    pub d1: [f64; 6],
    pub d2: [f64; 5],
    pub d3: [f64; 5],
}

impl HermiteBasis {
    #[inline(always)]
    pub(super) fn at(sigma: f64, ds: f64) -> Self {
        let (s, s2, s3) = (sigma, sigma * sigma, sigma * sigma * sigma);
        let (s4, s5) = (s2 * s2, s2 * s3);
        // H5 (P₁), H1 (Q₀), H4 (Q₁), H2 (R₀), H3 (R₁); H0 = 1 − H5, so H0′ = −H5′.
        let h5 = 10.0 * s3 - 15.0 * s4 + 6.0 * s5;
        let h1 = s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5;
        let h4 = -4.0 * s3 + 7.0 * s4 - 3.0 * s5;
        let h2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5;
        let h3 = 0.5 * s3 - s4 + 0.5 * s5;
        let h5p = 30.0 * s2 - 60.0 * s3 + 30.0 * s4;
        let h1p = 1.0 - 18.0 * s2 + 32.0 * s3 - 15.0 * s4;
        let h4p = -12.0 * s2 + 28.0 * s3 - 15.0 * s4;
        let h2p = s - 4.5 * s2 + 6.0 * s3 - 2.5 * s4;
        let h3p = 1.5 * s2 - 4.0 * s3 + 2.5 * s4;
        let h5pp = 60.0 * s - 180.0 * s2 + 120.0 * s3;
        let h1pp = -36.0 * s + 96.0 * s2 - 60.0 * s3;
        let h4pp = -24.0 * s + 84.0 * s2 - 60.0 * s3;
        let h2pp = 1.0 - 9.0 * s + 18.0 * s2 - 10.0 * s3;
        let h3pp = 3.0 * s - 12.0 * s2 + 10.0 * s3;
        // A zero-length interval has one geometry: D = 0 there, and its weight is moot.
        let inv = if ds > 0.0 { 1.0 / ds } else { 0.0 };
        HermiteBasis {
            d1: [1.0 - h5, h5, ds * h1, ds * h4, ds * ds * h2, ds * ds * h3],
            d2: [h5p * inv, h1p, h4p, ds * h2p, ds * h3p],
            d3: [h5pp * inv * inv, h1pp * inv, h4pp * inv, h2pp, h3pp],
        }
    }
}
