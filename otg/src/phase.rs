//! One constant-jerk phase, the piece every profile is made of: the brake pre-phase
//! (`brake`), the seven phases of a profile (`profile`) and their refinement and sampling all
//! step through phases with it, so it depends on none of them.

/// Integrate one constant-jerk phase: (p, v, a) after `t` seconds.
#[inline]
pub(crate) fn integrate(t: f64, p: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64) {
    (p + t * (v + t * (a / 2.0 + t * j / 6.0)), v + t * (a + t * j / 2.0), a + t * j)
}
