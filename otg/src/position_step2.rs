//! Step 2, position interface: a profile of one DoF that lasts exactly a given duration (the
//! synchronised duration), respecting all limits (Berscheid & Kröger, RSS 2021, Sec. IV-C).
//!
//! The candidates are tried in order of likelihood, first in the direction that the mean velocity
//! suggests, then in the other: the profiles with a cruise phase (ACC0_ACC1_VEL, VEL, ACC0_VEL,
//! ACC1_VEL; VEL needs the real roots of a quintic or sextic, found between the roots of its
//! derivatives), then those without (ACC0_ACC1 and NONE with the jerk reduced below the limit,
//! ACC0, ACC1, NONE with an acceleration plateau inside the limits). Every root is refined by
//! Newton steps on the position equation and every candidate is integrated and checked.
//!
//! The equations, their order and the root refinement are ported from Ruckig's
//! `position-third-step2.cpp` (L. Berscheid, MIT licence, <https://github.com/pantor/ruckig>);
//! the lower direction passes the mirrored limits (v_min, v_max, a_min, a_max, -j_max). When
//! all of them fail (durations far beyond the ramp times), the cruise family of
//! [`crate::position_step2_cruise`] is the fallback.

use crate::profile::{ControlSigns, Profile, ReachedLimits};
use crate::roots::{
    TOLERANCE, poly_derivative, poly_eval, poly_monic_derivative, shrink_interval, solve_cubic, solve_quart_monic,
    solve_quart_monic_arr,
};

/// Durations beyond this multiple of the DoF's minimum duration try the cruise family first.
const CRUISE_FIRST_RATIO: f64 = 100.0;
/// Inputs and roots below this count as zero (Ruckig: ε).
const EPS: f64 = f64::EPSILON;
/// The second Newton step of a VEL-UDUD root runs only while the residual exceeds this
/// (Ruckig: 1e-9).
const SECOND_NEWTON_RESIDUAL: f64 = 1e-9;
/// A candidate root of the VEL polynomials is taken where the polynomial is below this many
/// times the tolerance times its second derivative (a double root) (Ruckig: 64).
const DOUBLE_ROOT_FACTOR: f64 = 64.0;
/// The VEL-UDDU polynomial counts as zero at the upper end of the interval below this
/// (Ruckig: 8 ε).
const END_ROOT_EPS: f64 = 8.0 * f64::EPSILON;

use ControlSigns::{Uddu, Udud};
use ReachedLimits as RL;

#[inline]
fn sqrt(x: f64) -> f64 {
    x.sqrt()
}
#[inline]
fn abs(x: f64) -> f64 {
    x.abs()
}
#[inline]
fn min(a: f64, b: f64) -> f64 {
    a.min(b)
}
#[inline]
fn max(a: f64, b: f64) -> f64 {
    a.max(b)
}
#[inline]
fn pow2(x: f64) -> f64 {
    x * x
}

/// The limits in the direction a family is evaluated in (mirrored for the lower direction).
#[derive(Clone, Copy)]
struct Lim {
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
    j_max: f64,
}

impl Lim {
    fn mirrored(self) -> Lim {
        Lim { v_max: self.v_min, v_min: self.v_max, a_max: self.a_min, a_min: self.a_max, j_max: -self.j_max }
    }
}

/// The problem of one DoF for a given duration `tf`, with the expressions all cases share.
#[derive(Clone, Copy)]
struct Step2 {
    v0: f64,
    a0: f64,
    tf: f64,
    vf: f64,
    af: f64,
    pd: f64,
    tf_tf: f64,
    tf_p3: f64,
    tf_p4: f64,
    vd: f64,
    vd_vd: f64,
    ad: f64,
    ad_ad: f64,
    vf_vf: f64,
    a0_a0: f64,
    a0_p3: f64,
    a0_p4: f64,
    a0_p5: f64,
    a0_p6: f64,
    af_af: f64,
    af_p3: f64,
    af_p4: f64,
    af_p5: f64,
    af_p6: f64,
    jj: f64,
    g1: f64,
    g2: f64,
}

/// A profile of the main part lasting exactly `tf` (s); `p` carries the boundary (braked start
/// state, target, brake) and receives the profile. False if none is found. `t_min` is the DoF's
/// minimum duration: for durations far beyond it the cruise family is tried first (the closed
/// forms then usually all fail, after doing all their work).
#[allow(clippy::too_many_arguments)]
pub(crate) fn calculate(
    p: &mut Profile,
    tf: f64,
    t_min: f64,
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
    j_max: f64,
) -> bool {
    let (v0, a0, vf, af) = (p.v[0], p.a[0], p.vf, p.af);
    let pd = p.pf - p.p[0];
    let (tf_tf, a0_a0, af_af, vd, ad) = (tf * tf, a0 * a0, af * af, vf - v0, af - a0);
    let (a0_p3, af_p3, a0_p4, af_p4) = (a0 * a0_a0, af * af_af, a0_a0 * a0_a0, af_af * af_af);
    let s = Step2 {
        v0,
        a0,
        tf,
        vf,
        af,
        pd,
        tf_tf,
        tf_p3: tf_tf * tf,
        tf_p4: tf_tf * tf_tf,
        vd,
        vd_vd: vd * vd,
        ad,
        ad_ad: ad * ad,
        vf_vf: vf * vf,
        a0_a0,
        a0_p3,
        a0_p4,
        a0_p5: a0_p3 * a0_a0,
        a0_p6: a0_p4 * a0_a0,
        af_af,
        af_p3,
        af_p4,
        af_p5: af_p3 * af_af,
        af_p6: af_p4 * af_af,
        jj: j_max * j_max,
        g1: -pd + tf * v0,
        g2: -2.0 * pd + tf * (v0 + vf),
    };
    let long = tf > CRUISE_FIRST_RATIO * t_min;
    if long && crate::position_step2_cruise::calculate(p, tf, v_max, v_min, a_max, a_min, j_max) {
        return true;
    }
    // Guess the direction from the mean velocity and try it first.
    let up = Lim { v_max, v_min, a_max, a_min, j_max };
    let first = if pd > tf * v0 { up } else { up.mirrored() };
    let second = first.mirrored();
    s.time_acc0_acc1_vel(p, first)
        || s.time_vel(p, first)
        || s.time_acc0_vel(p, first)
        || s.time_acc1_vel(p, first)
        || s.time_acc0_acc1_vel(p, second)
        || s.time_vel(p, second)
        || s.time_acc0_vel(p, second)
        || s.time_acc1_vel(p, second)
        || s.time_acc0_acc1(p, first)
        || s.time_acc0(p, first)
        || s.time_acc1(p, first)
        || s.time_none(p, first)
        || s.time_acc0_acc1(p, second)
        || s.time_acc0(p, second)
        || s.time_acc1(p, second)
        || s.time_none(p, second)
        || (!long && crate::position_step2_cruise::calculate(p, tf, v_max, v_min, a_max, a_min, j_max))
}

impl Step2 {
    fn time_acc0_acc1_vel(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 { a0, tf, vf, af, pd, vd, vd_vd, ad, a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4, jj, g1, .. } = *self;
        // Profile UDDU, Solution 1
        if (2.0 * (a_max - a_min) + ad) / j_max < tf {
            let h1 = sqrt(
                (a0_p4 + af_p4 - 4.0 * a0_p3 * (2.0 * a_max + a_min) / 3.0 - 4.0 * af_p3 * (a_max + 2.0 * a_min) / 3.0
                    + 2.0 * (a0_a0 - af_af) * a_max * a_max
                    + (4.0 * a0 * a_max - 2.0 * a0_a0)
                        * (af_af - 2.0 * af * a_min + (a_min - a_max) * a_min + 2.0 * j_max * (a_min * tf - vd))
                    + 2.0 * af_af * (a_min * a_min + 2.0 * j_max * (a_max * tf - vd))
                    + 4.0
                        * j_max
                        * (2.0 * a_min * (af * vd + j_max * g1)
                            + (a_max * a_max - a_min * a_min) * vd
                            + j_max * vd_vd)
                    + 8.0 * a_max * jj * (pd - tf * vf))
                    / (a_max * a_min)
                    + 4.0 * af_af
                    + 2.0 * a0_a0
                    + (4.0 * af + a_max - a_min) * (a_max - a_min)
                    + 4.0 * j_max * (a_min - a_max + j_max * tf - 2.0 * af) * tf,
            ) * abs(j_max)
                / j_max;

            p.t[0] = (-a0 + a_max) / j_max;
            p.t[1] = (-(af_af - a0_a0
                + 2.0 * a_max * a_max
                + a_min * (a_min - 2.0 * ad - 3.0 * a_max)
                + 2.0 * j_max * (a_min * tf - vd))
                + a_min * h1)
                / (2.0 * (a_max - a_min) * j_max);
            p.t[2] = a_max / j_max;
            p.t[3] = (a_min - a_max + h1) / (2.0 * j_max);
            p.t[4] = -a_min / j_max;
            p.t[5] = tf - (p.t[0] + p.t[1] + p.t[2] + p.t[3] + 2.0 * p.t[4] + af / j_max);
            p.t[6] = p.t[4] + af / j_max;

            if p.check_with_timing(tf, Uddu, RL::Acc0Acc1Vel, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // Profile UDUD
        if (-a0 + 4.0 * a_max - af) / j_max < tf {
            p.t[0] = (-a0 + a_max) / j_max;
            p.t[1] = (3.0 * (a0_p4 + af_p4) - 4.0 * (a0_p3 + af_p3) * a_max - 4.0 * af_p3 * a_max
                + 24.0 * (a0 + af) * a_max * a_max * a_max
                - 6.0 * (af_af + a0_a0) * (a_max * a_max - 2.0 * j_max * vd)
                + 6.0 * a0_a0 * (af_af - 2.0 * af * a_max - 2.0 * a_max * j_max * tf)
                - 12.0 * a_max * a_max * (2.0 * a_max * a_max - 2.0 * a_max * j_max * tf + j_max * vd)
                - 24.0 * af * a_max * j_max * vd
                + 12.0 * jj * (2.0 * a_max * g1 + vd_vd))
                / (12.0
                    * a_max
                    * j_max
                    * (a0_a0 + af_af - 2.0 * (a0 + af) * a_max
                        + 2.0 * (a_max * a_max - a_max * j_max * tf + j_max * vd)));
            p.t[2] = a_max / j_max;
            p.t[3] = (-a0_a0 - af_af + 2.0 * a_max * (a0 + af - 2.0 * a_max) - 2.0 * j_max * vd)
                / (2.0 * a_max * j_max)
                + tf;
            p.t[4] = p.t[2];
            p.t[5] = tf - (p.t[0] + p.t[1] + p.t[2] + p.t[3] + 2.0 * p.t[4] - af / j_max);
            p.t[6] = p.t[4] - af / j_max;

            if p.check_with_timing(tf, Udud, RL::Acc0Acc1Vel, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        false
    }

    fn time_acc1_vel(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 { v0, a0, tf, af, pd, vd, vd_vd, ad, a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4, jj, g1, .. } = *self;
        // Profile UDDU
        {
            let ph1 = a0_a0 + af_af - a_min * (a0 + 2.0 * af - a_min) - 2.0 * j_max * (vd - a_min * tf);
            let ph2 = 2.0 * a_min * (j_max * g1 + af * vd) - a_min * a_min * vd + j_max * vd_vd;
            let ph3 = af_af + a_min * (a_min - 2.0 * af) - 2.0 * j_max * (vd - a_min * tf);

            let mut polynom = [0.0; 4];
            polynom[0] = (2.0 * (2.0 * a0 - a_min)) / j_max;
            polynom[1] = (4.0 * a0_a0 + ph1 - 3.0 * a0 * a_min) / jj;
            polynom[2] = (2.0 * a0 * ph1) / (jj * j_max);
            polynom[3] = (3.0 * (a0_p4 + af_p4) - 4.0 * (a0_p3 + 2.0 * af_p3) * a_min
                + 6.0 * af_af * (a_min * a_min - 2.0 * j_max * vd)
                + 12.0 * j_max * ph2
                + 6.0 * a0_a0 * ph3)
                / (12.0 * jj * jj);

            let t_min = -a0 / j_max;
            let t_max = min((tf + 2.0 * a_min / j_max - (a0 + af) / j_max) / 2.0, (a_max - a0) / j_max);

            let roots = solve_quart_monic_arr(&polynom);
            for &root in roots.as_slice() {
                let mut t = root;
                if t < t_min || t > t_max {
                    continue;
                }

                // Single Newton step (regarding pd)
                if abs(a0 + j_max * t) > 16.0 * EPS {
                    let h0 = j_max * t * t;
                    let orig = -pd
                        + (3.0 * (a0_p4 + af_p4) - 8.0 * af_p3 * a_min - 4.0 * a0_p3 * a_min
                            + 6.0 * af_af * (a_min * a_min + 2.0 * j_max * (h0 - vd))
                            + 6.0
                                * a0_a0
                                * (af_af - 2.0 * af * a_min
                                    + a_min * a_min
                                    + 2.0 * a_min * j_max * (-2.0 * t + tf)
                                    + 2.0 * j_max * (5.0 * h0 - vd))
                            + 24.0
                                * a0
                                * j_max
                                * t
                                * (a0_a0 + af_af - 2.0 * af * a_min
                                    + a_min * a_min
                                    + 2.0 * j_max * (a_min * (-t + tf) + h0 - vd))
                            - 24.0 * af * a_min * j_max * (h0 - vd)
                            + 12.0 * j_max * (a_min * a_min * (h0 - vd) + j_max * (h0 - vd) * (h0 - vd)))
                            / (24.0 * a_min * jj)
                        + h0 * (tf - t)
                        + tf * v0;
                    let deriv = (a0 + j_max * t)
                        * ((a0_a0 + af_af) / (a_min * j_max)
                            + (a_min - a0 - 2.0 * af) / j_max
                            + (4.0 * a0 * t + 2.0 * h0 - 2.0 * vd) / a_min
                            + 2.0 * tf
                            - 3.0 * t);

                    t -= orig / deriv;
                }

                let h1 = -((a0_a0 + af_af) / 2.0 + j_max * (-vd + 2.0 * a0 * t + j_max * t * t)) / a_min;

                p.t[0] = t;
                p.t[1] = 0.0;
                p.t[2] = a0 / j_max + t;
                p.t[3] = tf - (h1 - a_min + a0 + af) / j_max - 2.0 * t;
                p.t[4] = -a_min / j_max;
                p.t[5] = (h1 + a_min) / j_max;
                p.t[6] = p.t[4] + af / j_max;

                if p.check_with_timing(tf, Uddu, RL::Acc1Vel, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }
        }

        // Profile UDUD
        {
            let ph1 = a0_a0 - af_af + (2.0 * af - a0) * a_max - a_max * a_max - 2.0 * j_max * (vd - a_max * tf);
            let ph2 = a_max * a_max + 2.0 * j_max * vd;
            let ph3 = af_af + ph2 - 2.0 * a_max * (af + j_max * tf);
            let ph4 = 2.0 * a_max * j_max * g1 + a_max * a_max * vd + j_max * vd_vd;

            let mut polynom = [0.0; 4];
            polynom[0] = (4.0 * a0 - 2.0 * a_max) / j_max;
            polynom[1] = (4.0 * a0_a0 - 3.0 * a0 * a_max + ph1) / jj;
            polynom[2] = (2.0 * a0 * ph1) / (jj * j_max);
            polynom[3] = (3.0 * (a0_p4 + af_p4) - 4.0 * (a0_p3 + 2.0 * af_p3) * a_max - 24.0 * af * a_max * j_max * vd
                + 12.0 * j_max * ph4
                - 6.0 * a0_a0 * ph3
                + 6.0 * af_af * ph2)
                / (12.0 * jj * jj);

            let t_min = -a0 / j_max;
            let t_max = min((tf + ad / j_max - 2.0 * a_max / j_max) / 2.0, (a_max - a0) / j_max);

            let roots = solve_quart_monic_arr(&polynom);
            for &root in roots.as_slice() {
                let t = root;
                if t > t_max || t < t_min {
                    continue;
                }

                let h1 = ((a0_a0 - af_af) / 2.0 + jj * t * t - j_max * (vd - 2.0 * a0 * t)) / a_max;

                p.t[0] = t;
                p.t[1] = 0.0;
                p.t[2] = t + a0 / j_max;
                p.t[3] = tf + (h1 + ad - a_max) / j_max - 2.0 * t;
                p.t[4] = a_max / j_max;
                p.t[5] = -(h1 + a_max) / j_max;
                p.t[6] = p.t[4] - af / j_max;

                if p.check_with_timing(tf, Udud, RL::Acc1Vel, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }
        }

        false
    }

    fn time_acc0_vel(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 { a0, tf, vf, af, pd, vd, vd_vd, ad, a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4, jj, .. } = *self;
        if tf < max((-a0 + a_max) / j_max, 0.0) + max(a_max / j_max, 0.0) {
            return false;
        }

        let ph1 = 12.0 * j_max * (-a_max * a_max * vd - j_max * vd_vd + 2.0 * a_max * j_max * (-pd + tf * vf));

        // Profile UDDU
        {
            let mut polynom = [0.0; 4];
            polynom[0] = (2.0 * a_max) / j_max;
            polynom[1] = (a0_a0 - af_af + 2.0 * ad * a_max + a_max * a_max + 2.0 * j_max * (vd - a_max * tf)) / jj;
            polynom[2] = 0.0;
            polynom[3] = -(-3.0 * (a0_p4 + af_p4) + 4.0 * (af_p3 + 2.0 * a0_p3) * a_max
                - 12.0 * a0 * a_max * (af_af - 2.0 * j_max * vd)
                + 6.0 * a0_a0 * (af_af - a_max * a_max - 2.0 * j_max * vd)
                + 6.0 * af_af * (a_max * a_max - 2.0 * a_max * j_max * tf + 2.0 * j_max * vd)
                + ph1)
                / (12.0 * jj * jj);

            let t_min = -af / j_max;
            let t_max = min(tf - (2.0 * a_max - a0) / j_max, -a_min / j_max);

            let roots = solve_quart_monic_arr(&polynom);
            for &root in roots.as_slice() {
                let mut t = root;
                if t < t_min || t > t_max {
                    continue;
                }

                // Single Newton step (regarding pd)
                if t > EPS {
                    let h1 = j_max * t * t + vd;
                    let orig = (-3.0 * (a0_p4 + af_p4) + 4.0 * (af_p3 + 2.0 * a0_p3) * a_max
                        - 24.0 * af * a_max * jj * t * t
                        - 12.0 * a0 * a_max * (af_af - 2.0 * j_max * h1)
                        + 6.0 * a0_a0 * (af_af - a_max * a_max - 2.0 * j_max * h1)
                        + 6.0 * af_af * (a_max * a_max - 2.0 * a_max * j_max * tf + 2.0 * j_max * h1)
                        - 12.0
                            * j_max
                            * (a_max * a_max * h1
                                + j_max * h1 * h1
                                + 2.0 * a_max * j_max * (pd + j_max * t * t * (t - tf) - tf * vf)))
                        / (24.0 * a_max * jj);
                    let deriv = -t
                        * (a0_a0 - af_af
                            + 2.0 * a_max * (ad - j_max * tf)
                            + a_max * a_max
                            + 3.0 * a_max * j_max * t
                            + 2.0 * j_max * h1)
                        / a_max;

                    t -= orig / deriv;
                }

                let h1 = ((a0_a0 - af_af) / 2.0 + j_max * (j_max * t * t + vd)) / a_max;

                p.t[0] = (-a0 + a_max) / j_max;
                p.t[1] = (h1 - a_max) / j_max;
                p.t[2] = a_max / j_max;
                p.t[3] = tf - (h1 + ad + a_max) / j_max - 2.0 * t;
                p.t[4] = t;
                p.t[5] = 0.0;
                p.t[6] = af / j_max + t;

                if p.check_with_timing(tf, Uddu, RL::Acc0Vel, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }
        }

        // Profile UDUD
        {
            let mut polynom = [0.0; 4];
            polynom[0] = (-2.0 * a_max) / j_max;
            polynom[1] =
                -(a0_a0 + af_af - 2.0 * (a0 + af) * a_max + a_max * a_max + 2.0 * j_max * (vd - a_max * tf)) / jj;
            polynom[2] = 0.0;
            polynom[3] = (3.0 * (a0_p4 + af_p4) - 4.0 * (af_p3 + 2.0 * a0_p3) * a_max
                + 6.0 * a0_a0 * (af_af + a_max * a_max + 2.0 * j_max * vd)
                - 12.0 * a0 * a_max * (af_af + 2.0 * j_max * vd)
                + 6.0 * af_af * (a_max * a_max - 2.0 * a_max * j_max * tf + 2.0 * j_max * vd)
                - ph1)
                / (12.0 * jj * jj);

            let t_min = af / j_max;
            let t_max = min(tf - a_max / j_max, a_max / j_max);

            let roots = solve_quart_monic_arr(&polynom);
            for &root in roots.as_slice() {
                let mut t = root;
                if t < t_min || t > t_max {
                    continue;
                }

                // Single Newton step (regarding pd)
                {
                    let h1 = j_max * t * t - vd;
                    let orig = -(3.0 * (a0_p4 + af_p4) - 4.0 * (2.0 * a0_p3 + af_p3) * a_max
                        + 24.0 * af * a_max * jj * t * t
                        - 12.0 * a0 * a_max * (af_af - 2.0 * j_max * h1)
                        + 6.0 * a0_a0 * (af_af + a_max * a_max - 2.0 * j_max * h1)
                        + 6.0 * af_af * (a_max * a_max - 2.0 * j_max * (tf * a_max + h1))
                        + 12.0
                            * j_max
                            * (-a_max * a_max * h1 + j_max * h1 * h1
                                - 2.0 * a_max * j_max * (-pd + j_max * t * t * (t - tf) + tf * vf)))
                        / (24.0 * a_max * jj);
                    let deriv = t
                        * (a0_a0 + af_af - 2.0 * j_max * h1 - 2.0 * (a0 + af + j_max * tf) * a_max
                            + a_max * a_max
                            + 3.0 * a_max * j_max * t)
                        / a_max;

                    t -= orig / deriv;
                }

                let h1 = ((a0_a0 + af_af) / 2.0 + j_max * (vd - j_max * t * t)) / a_max;

                p.t[0] = (-a0 + a_max) / j_max;
                p.t[1] = (h1 - a_max) / j_max;
                p.t[2] = a_max / j_max;
                p.t[3] = tf - (h1 - a0 - af + a_max) / j_max - 2.0 * t;
                p.t[4] = t;
                p.t[5] = 0.0;
                p.t[6] = -(af / j_max) + t;

                if p.check_with_timing(tf, Udud, RL::Acc0Vel, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }
        }

        false
    }

    fn time_acc0_acc1(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 { v0, a0, tf, vf, af, pd, tf_tf, vd, vd_vd, ad, a0_a0, a0_p3, af_af, af_p3, g1, g2, .. } = *self;
        if abs(a0) < EPS && abs(af) < EPS {
            let h1 = 2.0 * a_min * g1 + vd_vd + a_max * (2.0 * pd + a_min * tf_tf - 2.0 * tf * vf);
            let h2 = (a_max - a_min) * (-a_min * vd + a_max * (a_min * tf - vd));

            let jf = h2 / h1;
            p.t[0] = a_max / jf;
            p.t[1] = (-2.0 * a_max * h1 + a_min * a_min * g2) / h2;
            p.t[2] = p.t[0];
            p.t[3] = 0.0;
            p.t[4] = -a_min / jf;
            p.t[5] = tf - (2.0 * p.t[0] + p.t[1] + 2.0 * p.t[4]);
            p.t[6] = p.t[4];

            return p.check_with_timing_and_jerk(tf, Uddu, RL::Acc0Acc1, jf, v_max, v_min, a_max, a_min, j_max);
        }

        // UDDU
        {
            let h1 = sqrt(
                144.0
                    * pow2(
                        (a_max - a_min) * (-a_min * vd + a_max * (a_min * tf - vd)) - af_af * (a_max * tf - vd)
                            + 2.0 * af * a_min * (a_max * tf - vd)
                            + a0_a0 * (a_min * tf + v0 - vf)
                            - 2.0 * a0 * a_max * (a_min * tf - vd),
                    )
                    + 48.0
                        * ad
                        * (3.0 * a0_p3 - 3.0 * af_p3
                            + 12.0 * a_max * a_min * (-a_max + a_min)
                            + 4.0 * af_af * (a_max + 2.0 * a_min)
                            + a0 * (-3.0 * af_af
                                + 8.0 * af * (a_min - a_max)
                                + 6.0 * (a_max * a_max + 2.0 * a_max * a_min - a_min * a_min))
                            + 6.0 * af * (a_max * a_max - 2.0 * a_max * a_min - a_min * a_min)
                            + a0_a0 * (3.0 * af - 4.0 * (2.0 * a_max + a_min)))
                        * (2.0 * a_min * g1 + vd * vd + a_max * (2.0 * pd + a_min * tf * tf - 2.0 * tf * vf)),
            );

            let jf = -(3.0 * af_af * a_max * tf - 3.0 * a0_a0 * a_min * tf - 6.0 * ad * a_max * a_min * tf
                + 3.0 * a_max * a_min * (a_min - a_max) * tf
                + 3.0 * (a0_a0 - af_af) * vd
                + 6.0 * vd * (af * a_min - a0 * a_max)
                + 3.0 * (a_max * a_max - a_min * a_min) * vd
                + h1 / 4.0)
                / (6.0 * (2.0 * a_min * g1 + vd * vd + a_max * (2.0 * pd + a_min * tf_tf - 2.0 * tf * vf)));
            p.t[0] = (a_max - a0) / jf;
            p.t[1] = (a0_a0 - af_af + 2.0 * ad * a_min
                - 2.0 * (a_max * a_max - 2.0 * a_max * a_min + a_min * a_min + a_min * jf * tf - jf * vd))
                / (2.0 * (a_max - a_min) * jf);
            p.t[2] = a_max / jf;
            p.t[3] = 0.0;
            p.t[4] = -a_min / jf;
            p.t[5] = tf - (p.t[0] + p.t[1] + p.t[2] + 2.0 * p.t[4] + af / jf);
            p.t[6] = p.t[4] + af / jf;

            if p.check_with_timing_and_jerk(tf, Uddu, RL::Acc0Acc1, jf, v_max, v_min, a_max, a_min, j_max) {
                return true;
            }
        }

        false
    }

    fn time_acc1(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 {
            a0,
            tf,
            vf,
            af,
            pd,
            tf_tf,
            vd,
            vd_vd,
            ad,
            a0_a0,
            a0_p3,
            a0_p4,
            af_af,
            af_p3,
            af_p4,
            jj,
            g1,
            g2,
            ..
        } = *self;
        // a3 != 0
        // Case UDDU
        {
            let h0 = sqrt(
                jj * (a0_p4 + af_p4 - 4.0 * af_p3 * j_max * tf + 6.0 * af_af * jj * tf_tf
                    - 4.0 * a0_p3 * (af - j_max * tf)
                    + 6.0 * a0_a0 * (af - j_max * tf) * (af - j_max * tf)
                    + 24.0 * af * jj * g1
                    - 4.0 * a0 * (af_p3 - 3.0 * af_af * j_max * tf + 6.0 * jj * (-pd + tf * vf))
                    - 12.0 * jj * (-vd_vd + j_max * tf * g2))
                    / 3.0,
            ) / j_max;
            let h1 = sqrt((a0_a0 + af_af - 2.0 * a0 * af - 2.0 * ad * j_max * tf + 2.0 * h0) / jj + tf_tf);

            p.t[0] = -(a0_a0 + af_af + 2.0 * a0 * (j_max * tf - af) - 2.0 * j_max * vd + h0)
                / (2.0 * j_max * (-ad + j_max * tf));
            p.t[1] = 0.0;
            p.t[2] = (tf - h1) / 2.0 - ad / (2.0 * j_max);
            p.t[3] = 0.0;
            p.t[4] = 0.0;
            p.t[5] = h1;
            p.t[6] = tf - (p.t[0] + p.t[2] + p.t[5]);

            if p.check_with_timing(tf, Uddu, RL::Acc1, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // Case UDUD
        {
            let h0 = sqrt(
                jj * (a0_p4
                    + af_p4
                    + 4.0 * (af_p3 - a0_p3) * j_max * tf
                    + 6.0 * af_af * jj * tf_tf
                    + 6.0 * a0_a0 * (af + j_max * tf) * (af + j_max * tf)
                    + 24.0 * af * jj * g1
                    - 4.0 * a0 * (a0_a0 * af + af_p3 + 3.0 * af_af * j_max * tf + 6.0 * jj * (-pd + tf * vf))
                    + 12.0 * jj * (vd_vd + j_max * tf * g2))
                    / 3.0,
            ) / j_max;
            let h1 = sqrt((a0_a0 + af_af - 2.0 * a0 * af + 2.0 * ad * j_max * tf + 2.0 * h0) / jj + tf_tf);

            p.t[0] = 0.0;
            p.t[1] = 0.0;
            p.t[2] = -(a0_a0 + af_af - 2.0 * a0 * af + 2.0 * j_max * (vd - a0 * tf) + h0)
                / (2.0 * j_max * (ad + j_max * tf));
            p.t[3] = 0.0;
            p.t[4] = ad / (2.0 * j_max) + (tf - h1) / 2.0;
            p.t[5] = h1;
            p.t[6] = tf - (p.t[5] + p.t[4] + p.t[2]);

            if p.check_with_timing(tf, Udud, RL::Acc1, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // Case UDDU, Solution 2
        {
            let h0a = a0_p3 - af_p3 - 3.0 * a0_a0 * a_min
                + 3.0 * a_min * a_min * (a0 + j_max * tf)
                + 3.0 * af * a_min * (-a_min - 2.0 * j_max * tf)
                - 3.0 * af_af * (-a_min - j_max * tf)
                - 3.0 * jj * (-2.0 * pd - a_min * tf_tf + 2.0 * tf * vf);
            let h0b = a0_a0 + af_af - 2.0 * (a0 + af) * a_min + 2.0 * (a_min * a_min - j_max * (-a_min * tf + vd));
            let h0c = a0_p4 + 3.0 * af_p4 - 4.0 * (a0_p3 + 2.0 * af_p3) * a_min
                + 6.0 * a0_a0 * a_min * a_min
                + 6.0 * af_af * (a_min * a_min - 2.0 * j_max * vd)
                + 12.0 * j_max * (2.0 * a_min * j_max * g1 - a_min * a_min * vd + j_max * vd_vd)
                + 24.0 * af * a_min * j_max * vd
                - 4.0
                    * a0
                    * (af_p3 - 3.0 * af * a_min * (-a_min - 2.0 * j_max * tf)
                        + 3.0 * af_af * (-a_min - j_max * tf)
                        + 3.0 * j_max * (-a_min * a_min * tf + j_max * (-2.0 * pd - a_min * tf_tf + 2.0 * tf * vf)));
            let h1 = abs(j_max) / j_max * sqrt(4.0 * h0a * h0a - 6.0 * h0b * h0c);
            let h2 = 6.0 * j_max * h0b;

            p.t[0] = 0.0;
            p.t[1] = 0.0;
            p.t[2] = (2.0 * h0a + h1) / h2;
            p.t[3] = -(a0_a0 + af_af - 2.0 * (a0 + af) * a_min
                + 2.0 * (a_min * a_min + a_min * j_max * tf - j_max * vd))
                / (2.0 * j_max * (a0 - a_min - j_max * p.t[2]));
            p.t[4] = (a0 - a_min) / j_max - p.t[2];
            p.t[5] = tf - (p.t[2] + p.t[3] + p.t[4] + (af - a_min) / j_max);
            p.t[6] = (af - a_min) / j_max;

            if p.check_with_timing(tf, Uddu, RL::Acc1, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // Case UDUD, Solution 1
        {
            let h0a = -a0_p3 + af_p3 + 3.0 * (a0_a0 - af_af) * a_max
                - 3.0 * ad * a_max * a_max
                - 6.0 * af * a_max * j_max * tf
                + 3.0 * af_af * j_max * tf
                + 3.0 * j_max * (a_max * a_max * tf + j_max * (-2.0 * pd - a_max * tf_tf + 2.0 * tf * vf));
            let h0b = a0_a0 - af_af + 2.0 * ad * a_max + 2.0 * j_max * (a_max * tf - vd);
            let h0c = a0_p4 + 3.0 * af_p4 - 4.0 * (a0_p3 + 2.0 * af_p3) * a_max + 6.0 * a0_a0 * a_max * a_max
                - 24.0 * af * a_max * j_max * vd
                + 12.0 * j_max * (2.0 * a_max * j_max * g1 + j_max * vd_vd + a_max * a_max * vd)
                + 6.0 * af_af * (a_max * a_max + 2.0 * j_max * vd)
                - 4.0
                    * a0
                    * (af_p3 + 3.0 * af * a_max * (a_max - 2.0 * j_max * tf) - 3.0 * af_af * (a_max - j_max * tf)
                        + 3.0 * j_max * (a_max * a_max * tf + j_max * (-2.0 * pd - a_max * tf_tf + 2.0 * tf * vf)));
            let h1 = abs(j_max) / j_max * sqrt(4.0 * h0a * h0a - 6.0 * h0b * h0c);
            let h2 = 6.0 * j_max * h0b;

            p.t[0] = 0.0;
            p.t[1] = 0.0;
            p.t[2] = -(2.0 * h0a + h1) / h2;
            p.t[3] = 2.0 * h1 / h2;
            p.t[4] = (a_max - a0) / j_max + p.t[2];
            p.t[5] = tf - (p.t[2] + p.t[3] + p.t[4] + (-af + a_max) / j_max);
            p.t[6] = (-af + a_max) / j_max;

            if p.check_with_timing(tf, Udud, RL::Acc1, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }
        false
    }

    fn time_acc0(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 { v0, a0, tf, af, pd, tf_tf, vd, ad, ad_ad, a0_a0, a0_p3, af_af, af_p3, jj, g1, g2, .. } = *self;
        // UDUD
        {
            let h1 = sqrt(ad_ad / (2.0 * jj) - ad * (a_max - a0) / (jj) + (a_max * tf - vd) / j_max);

            p.t[0] = (a_max - a0) / j_max;
            p.t[1] = tf - ad / j_max - 2.0 * h1;
            p.t[2] = h1;
            p.t[3] = 0.0;
            p.t[4] = (af - a_max) / j_max + h1;
            p.t[5] = 0.0;
            p.t[6] = 0.0;

            if p.check_with_timing(tf, Udud, RL::None, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // UDUD
        {
            let h0a = -a0_a0 + af_af - 2.0 * ad * a_max + 2.0 * j_max * (a_max * tf - vd);
            let h0b = a0_p3 + 2.0 * af_p3
                - 6.0 * af_af * a_max
                - 3.0 * a0_a0 * (af - j_max * tf)
                - 3.0 * a0 * a_max * (a_max - 2.0 * af + 2.0 * j_max * tf)
                - 3.0 * j_max * (j_max * (-2.0 * pd + a_max * tf_tf + 2.0 * tf * v0) + a_max * (a_max * tf - 2.0 * vd))
                + 3.0 * af * (a_max * a_max + 2.0 * a_max * j_max * tf - 2.0 * j_max * vd);
            let h0 = abs(j_max) * sqrt(4.0 * h0b * h0b - 18.0 * h0a * h0a * h0a);
            let h1 = 3.0 * j_max * h0a;

            p.t[0] = (-a0 + a_max) / j_max;
            p.t[1] = (-a0_p3
                + af_p3
                + af_af * (-6.0 * a_max + 3.0 * j_max * tf)
                + a0_a0 * (-3.0 * af + 6.0 * a_max + 3.0 * j_max * tf)
                + 6.0 * af * (a_max * a_max - j_max * vd)
                + 3.0 * a0 * (af_af - 2.0 * (a_max * a_max + j_max * vd))
                - 6.0 * j_max * (a_max * (a_max * tf - 2.0 * vd) + j_max * g2))
                / h1;
            p.t[2] = -(ad + h0 / h1) / (2.0 * j_max) + tf / 2.0 - p.t[1] / 2.0;
            p.t[3] = h0 / (j_max * h1);
            p.t[4] = 0.0;
            p.t[5] = 0.0;
            p.t[6] = tf - (p.t[0] + p.t[1] + p.t[2] + p.t[3]);

            if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // a3 != 0

        // UDDU Solution 1
        {
            let h0a =
                a0_p3 + 2.0 * af_p3 - 6.0 * (af_af + a_max * a_max) * a_max - 6.0 * (a0 + af) * a_max * j_max * tf
                    + 9.0 * a_max * a_max * (af + j_max * tf)
                    + 3.0 * a0 * a_max * (-2.0 * af + 3.0 * a_max)
                    + 3.0 * a0_a0 * (af - 2.0 * a_max + j_max * tf)
                    - 6.0 * jj * g1
                    + 6.0 * (af - a_max) * j_max * vd
                    - 3.0 * a_max * jj * tf_tf;
            let h0b = a0_a0 + af_af + 2.0 * (a_max * a_max - (a0 + af) * a_max + j_max * (vd - a_max * tf));
            let h1 = abs(j_max) / j_max * sqrt(4.0 * h0a * h0a - 18.0 * h0b * h0b * h0b);
            let h2 = 6.0 * j_max * h0b;

            p.t[0] = (-a0 + a_max) / j_max;
            p.t[1] = ad / j_max - 2.0 * p.t[0] - (2.0 * h0a - h1) / h2 + tf;
            p.t[2] = -(2.0 * h0a + h1) / h2;
            p.t[3] = (2.0 * h0a - h1) / h2;
            p.t[4] = tf - (p.t[0] + p.t[1] + p.t[2] + p.t[3]);
            p.t[5] = 0.0;
            p.t[6] = 0.0;

            if p.check_with_timing(tf, Uddu, RL::Acc0, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        false
    }

    fn time_none(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max, .. } = l;
        let Step2 {
            v0,
            a0,
            tf,
            vf,
            af,
            pd,
            tf_tf,
            tf_p3,
            tf_p4,
            vd,
            vd_vd,
            ad,
            ad_ad,
            vf_vf,
            a0_a0,
            a0_p3,
            a0_p4,
            a0_p5,
            a0_p6,
            af_af,
            af_p3,
            af_p4,
            af_p5,
            af_p6,
            jj,
            g1,
            g2,
            ..
        } = *self;
        if abs(v0) < EPS && abs(a0) < EPS && abs(af) < EPS {
            let h1 = sqrt(tf_tf * vf_vf + pow2(4.0 * pd - tf * vf));
            let jf = 4.0 * (4.0 * pd - 2.0 * tf * vf + h1) / tf_p3;

            p.t[0] = tf / 4.0;
            p.t[1] = 0.0;
            p.t[2] = 2.0 * p.t[0];
            p.t[3] = 0.0;
            p.t[4] = 0.0;
            p.t[5] = 0.0;
            p.t[6] = p.t[0];

            if p.check_with_timing_and_jerk(tf, Uddu, RL::None, jf, v_max, v_min, a_max, a_min, j_max) {
                return true;
            }
        }

        if abs(a0) < EPS && abs(af) < EPS {
            // Profiles with a3 != 0, Solution UDDU
            {
                // First acc, then constant
                {
                    let mut polynom = [0.0; 4];
                    polynom[0] = -2.0 * tf;
                    polynom[1] = 2.0 * vd / j_max + tf_tf;
                    polynom[2] = 4.0 * (pd - tf * vf) / j_max;
                    polynom[3] = (vd_vd + j_max * tf * g2) / (jj);

                    let roots = solve_quart_monic_arr(&polynom);
                    for &root in roots.as_slice() {
                        let mut t = root;
                        if t > tf / 2.0 || t > (a_max - a0) / j_max {
                            continue;
                        }

                        // Single Newton step (regarding pd)
                        {
                            let h1 = (j_max * t * (t - tf) + vd) / (j_max * (2.0 * t - tf));
                            let h2 = (2.0 * j_max * t * (t - tf) + j_max * tf_tf - 2.0 * vd)
                                / (j_max * (2.0 * t - tf) * (2.0 * t - tf));
                            let orig = (-2.0 * pd
                                + 2.0 * tf * v0
                                + h1 * h1 * j_max * (tf - 2.0 * t)
                                + j_max * tf * (2.0 * h1 * t - t * t - (h1 - t) * tf))
                                / 2.0;
                            let deriv = (j_max * tf * (2.0 * t - tf) * (h2 - 1.0)) / 2.0
                                + h1 * j_max * (tf - (2.0 * t - tf) * h2 - h1);

                            t -= orig / deriv;
                        }

                        p.t[0] = t;
                        p.t[1] = 0.0;
                        p.t[2] = (j_max * t * (t - tf) + vd) / (j_max * (2.0 * t - tf));
                        p.t[3] = tf - 2.0 * t;
                        p.t[4] = t - p.t[2];
                        p.t[5] = 0.0;
                        p.t[6] = 0.0;

                        if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                            return true;
                        }
                    }
                }
            }
        }

        // UDUD T 0246
        {
            let h0 = sqrt(
                2.0 * jj
                    * (2.0
                        * pow2(
                            a0_p3 - af_p3 - 3.0 * af_af * j_max * tf + 9.0 * af * jj * tf_tf
                                - 3.0 * a0_a0 * (af + j_max * tf)
                                + 3.0 * a0 * pow2(af + j_max * tf)
                                + 3.0 * jj * (8.0 * pd + j_max * tf_tf * tf - 8.0 * tf * vf),
                        )
                        - 3.0
                            * (a0_a0 + af_af
                                - 2.0 * af * j_max * tf
                                - 2.0 * a0 * (af + j_max * tf)
                                - j_max * (j_max * tf_tf + 4.0 * v0 - 4.0 * vf))
                            * (a0_p4 + af_p4 + 4.0 * af_p3 * j_max * tf + 6.0 * af_af * jj * tf_tf
                                - 3.0 * jj * jj * tf_tf * tf_tf
                                - 4.0 * a0_p3 * (af + j_max * tf)
                                + 6.0 * a0_a0 * pow2(af + j_max * tf)
                                - 12.0 * af * jj * (8.0 * pd + j_max * tf_tf * tf - 8.0 * tf * v0)
                                + 48.0 * jj * vd_vd
                                + 48.0 * jj * j_max * tf * g2
                                - 4.0
                                    * a0
                                    * (af_p3 + 3.0 * af_af * j_max * tf
                                        - 9.0 * af * jj * tf_tf
                                        - 3.0 * jj * (8.0 * pd + j_max * tf_tf * tf - 8.0 * tf * vf)))),
            ) / j_max;
            let h1 = 12.0
                * j_max
                * (-a0_a0 - af_af
                    + 2.0 * af * j_max * tf
                    + 2.0 * a0 * (af + j_max * tf)
                    + j_max * (j_max * tf_tf + 4.0 * v0 - 4.0 * vf));
            let h2 = -4.0 * a0_p3 + 4.0 * af_p3 + 12.0 * a0_a0 * af - 12.0 * a0 * af_af
                + 48.0 * jj * pd
                + 12.0 * (a0_a0 - af_af) * j_max * tf
                - 24.0 * jj * tf * (v0 + vf)
                + 24.0 * ad * j_max * vd;
            let h3 = 2.0 * a0_p3 - 2.0 * af_p3 - 6.0 * a0_a0 * af + 6.0 * a0 * af_af;

            p.t[0] = (h3 - 48.0 * jj * (tf * vf - pd) - 6.0 * (a0_a0 + af_af) * j_max * tf
                + 12.0 * a0 * af * j_max * tf
                + 6.0 * (a0 + 3.0 * af + j_max * tf) * tf_tf * jj
                - h0)
                / h1;
            p.t[1] = 0.0;
            p.t[2] = (h2 + h0) / h1;
            p.t[3] = 0.0;
            p.t[4] = (-h2 + h0) / h1;
            p.t[5] = 0.0;
            p.t[6] = (-h3 + 48.0 * jj * (tf * v0 - pd) - 6.0 * (a0_a0 + af_af) * j_max * tf
                + 12.0 * a0 * af * j_max * tf
                + 6.0 * (af + 3.0 * a0 + j_max * tf) * tf_tf * jj
                - h0)
                / h1;

            if p.check_with_timing(tf, Udud, RL::None, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // Profiles with a3 != 0, Solution UDDU
        {
            // T 0234
            {
                let ph1 = af + j_max * tf;

                let mut polynom = [0.0; 4];
                polynom[0] = -2.0 * (ad + j_max * tf) / j_max;
                polynom[1] = 2.0 * (a0_a0 + af_af + j_max * (af * tf + vd) - 2.0 * a0 * ph1) / jj + tf_tf;
                polynom[2] = 2.0
                    * (a0_p3 - af_p3 - 3.0 * af_af * j_max * tf + 3.0 * a0 * ph1 * (ph1 - a0)
                        - 6.0 * jj * (-pd + tf * vf))
                    / (3.0 * jj * j_max);
                polynom[3] = (a0_p4 + af_p4 + 4.0 * af_p3 * j_max * tf - 4.0 * a0_p3 * ph1
                    + 6.0 * a0_a0 * ph1 * ph1
                    + 24.0 * jj * af * g1
                    - 4.0 * a0 * (af_p3 + 3.0 * af_af * j_max * tf + 6.0 * jj * (-pd + tf * vf))
                    + 6.0 * jj * af_af * tf_tf
                    + 12.0 * jj * (vd_vd + j_max * tf * g2))
                    / (12.0 * jj * jj);

                let t_min = ad / j_max;
                let t_max = min((a_max - a0) / j_max, (ad / j_max + tf) / 2.0);

                let roots = solve_quart_monic_arr(&polynom);
                for &root in roots.as_slice() {
                    let mut t = root;
                    if t < t_min || t > t_max {
                        continue;
                    }

                    // Single Newton step (regarding pd)
                    {
                        let h0 = j_max * (2.0 * t - tf) - ad;
                        let h1 = (ad_ad - 2.0 * af * j_max * t
                            + 2.0 * a0 * j_max * (t - tf)
                            + 2.0 * j_max * (j_max * t * (t - tf) + vd))
                            / (2.0 * j_max * h0);
                        let h2 = (-ad_ad + 2.0 * jj * (tf_tf + t * (t - tf)) + (a0 + af) * j_max * tf
                            - ad * h0
                            - 2.0 * j_max * vd)
                            / (h0 * h0);
                        let orig =
                            (-a0_p3 + af_p3 + 3.0 * ad_ad * j_max * (h1 - t) + 3.0 * ad * jj * (h1 - t) * (h1 - t)
                                - 3.0 * a0 * af * ad
                                + 3.0
                                    * jj
                                    * (a0 * tf_tf - 2.0 * pd
                                        + 2.0 * tf * v0
                                        + h1 * h1 * j_max * (tf - 2.0 * t)
                                        + j_max * tf * (2.0 * h1 * t - t * t - (h1 - t) * tf)))
                                / (6.0 * jj);
                        let deriv = (h0 * (-ad + j_max * tf) * (h2 - 1.0)) / (2.0 * j_max)
                            + h1 * (-ad + j_max * (tf - h1) - h0 * h2);

                        t -= orig / deriv;
                    }

                    p.t[0] = t;
                    p.t[1] = 0.0;
                    p.t[2] = (ad_ad + 2.0 * j_max * (-a0 * tf - ad * t + j_max * t * (t - tf) + vd))
                        / (2.0 * j_max * (-ad + j_max * (2.0 * t - tf)));
                    p.t[3] = ad / j_max + tf - 2.0 * t;
                    p.t[4] = tf - (t + p.t[2] + p.t[3]);
                    p.t[5] = 0.0;
                    p.t[6] = 0.0;

                    if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                        return true;
                    }
                }
            }

            // T 3456
            {
                let h1 = 3.0 * j_max * (ad_ad + 2.0 * j_max * (a0 * tf - vd));
                let h2 = ad_ad + 2.0 * j_max * (a0 * tf - vd);
                let h0 = sqrt(
                    4.0 * pow2(
                        2.0 * (a0_p3 - af_p3) - 6.0 * a0_a0 * (af - j_max * tf)
                            + 6.0 * jj * g1
                            + 3.0 * a0 * (2.0 * af_af - 2.0 * j_max * af * tf + jj * tf_tf)
                            + 6.0 * ad * j_max * vd,
                    ) - 18.0 * h2 * h2 * h2,
                ) / h1
                    * abs(j_max)
                    / j_max;

                p.t[0] = 0.0;
                p.t[1] = 0.0;
                p.t[2] = 0.0;
                p.t[3] = (af_p3 - a0_p3 + 3.0 * (af_af - a0_a0) * j_max * tf
                    - 3.0 * ad * (a0 * af + 2.0 * j_max * vd)
                    - 6.0 * jj * g2)
                    / h1;
                p.t[4] = (tf - p.t[3] - h0) / 2.0 - ad / (2.0 * j_max);
                p.t[5] = h0;
                p.t[6] = (tf - p.t[3] + ad / j_max - h0) / 2.0;

                if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }

            // T 2346
            {
                let ph1 = ad_ad + 2.0 * (af + a0) * j_max * tf - j_max * (j_max * tf_tf + 4.0 * vd);
                let ph2 = j_max * tf_tf * g1 - vd * (-2.0 * pd - tf * v0 + 3.0 * tf * vf);
                let ph3 = 5.0 * af_af - 8.0 * af * j_max * tf + 2.0 * j_max * (2.0 * j_max * tf_tf - vd);
                let ph4 = jj * tf_p4 - 2.0 * vd_vd + 8.0 * j_max * tf * (-pd + tf * vf);
                let ph5 = 5.0 * af_p4 - 8.0 * af_p3 * j_max * tf - 12.0 * af_af * j_max * (j_max * tf_tf + vd)
                    + 24.0 * af * jj * (-2.0 * pd + j_max * tf_p3 + 2.0 * tf * vf)
                    - 6.0 * jj * ph4;
                let ph6 = -vd_vd + j_max * tf * (-2.0 * pd + 3.0 * tf * v0 - tf * vf) - af * g2;

                let mut polynom = [0.0; 4];
                polynom[0] = -(4.0 * (a0_p3 - af_p3) - 12.0 * a0_a0 * (af - j_max * tf)
                    + 6.0 * a0 * (2.0 * af_af - 2.0 * af * j_max * tf + j_max * (j_max * tf_tf - 2.0 * vd))
                    + 6.0 * af * j_max * (3.0 * j_max * tf_tf + 2.0 * vd)
                    - 6.0 * jj * (-4.0 * pd + j_max * tf_p3 - 2.0 * tf * v0 + 6.0 * tf * vf))
                    / (3.0 * j_max * ph1);
                polynom[1] = -(-a0_p4 - af_p4
                    + 4.0 * a0_p3 * (af - j_max * tf)
                    + a0_a0 * (-6.0 * af_af + 8.0 * af * j_max * tf - 4.0 * j_max * (j_max * tf_tf - vd))
                    + 2.0 * af_af * j_max * (j_max * tf_tf + 2.0 * vd)
                    - 4.0 * af * jj * (-3.0 * pd + j_max * tf_p3 + 2.0 * tf * v0 + tf * vf)
                    + jj * (jj * tf_p4 - 8.0 * vd_vd + 4.0 * j_max * tf * (-3.0 * pd + tf * v0 + 2.0 * tf * vf))
                    + 2.0
                        * a0
                        * (2.0 * af_p3 - 2.0 * af_af * j_max * tf
                            + af * j_max * (-3.0 * j_max * tf_tf - 4.0 * vd)
                            + jj * (-6.0 * pd + j_max * tf_p3 - 4.0 * tf * v0 + 10.0 * tf * vf)))
                    / (jj * ph1);
                polynom[2] = -(a0_p5 - af_p5 + af_p4 * j_max * tf - 5.0 * a0_p4 * (af - j_max * tf)
                    + 2.0 * a0_p3 * ph3
                    + 4.0 * af_p3 * j_max * (j_max * tf_tf + vd)
                    + 12.0 * jj * af * ph6
                    - 2.0
                        * a0_a0
                        * (5.0 * af_p3 - 9.0 * af_af * j_max * tf - 6.0 * af * j_max * vd
                            + 6.0 * jj * (-2.0 * pd - tf * v0 + 3.0 * tf * vf))
                    - 12.0 * jj * j_max * ph2
                    + a0 * ph5)
                    / (3.0 * jj * j_max * ph1);
                polynom[3] = -(-a0_p6 - af_p6 + 6.0 * a0_p5 * (af - j_max * tf) - 48.0 * af_p3 * jj * g1
                    + 72.0 * jj * j_max * (j_max * g1 * g1 + vd_vd * vd + 2.0 * af * g1 * vd)
                    - 3.0 * a0_p4 * ph3
                    - 36.0 * af_af * jj * vd_vd
                    + 6.0 * af_p4 * j_max * vd
                    + 4.0
                        * a0_p3
                        * (5.0 * af_p3 - 9.0 * af_af * j_max * tf - 6.0 * af * j_max * vd
                            + 6.0 * jj * (-2.0 * pd - tf * v0 + 3.0 * tf * vf))
                    - 3.0 * a0_a0 * ph5
                    + 6.0
                        * a0
                        * (af_p5 - af_p4 * j_max * tf - 4.0 * af_p3 * j_max * (j_max * tf_tf + vd)
                            + 12.0 * jj * (-af * ph6 + j_max * ph2)))
                    / (18.0 * jj * jj * ph1);

                let t_max = (a0 - a_min) / j_max;

                let roots = solve_quart_monic_arr(&polynom);
                for &root in roots.as_slice() {
                    let mut t = root;
                    if t > t_max {
                        continue;
                    }

                    // Single Newton step (regarding pd)
                    {
                        let h1 = ad_ad / 2.0 + j_max * (af * t + (j_max * t - a0) * (t - tf) - vd);
                        let h2 = -ad + j_max * (tf - 2.0 * t);
                        let h3 = sqrt(h1);
                        let orig =
                            (af_p3 - a0_p3 + 3.0 * af * j_max * t * (af + j_max * t) + 3.0 * a0_a0 * (af + j_max * t)
                                - 3.0 * a0 * (af_af + 2.0 * af * j_max * t + jj * (t * t - tf_tf))
                                + 3.0 * jj * (-2.0 * pd + j_max * t * (t - tf) * tf + 2.0 * tf * v0))
                                / (6.0 * jj)
                                - h3 * h3 * h3 / (j_max * abs(j_max))
                                + ((-ad - j_max * t) * h1) / (jj);
                        let deriv = (6.0 * j_max * h2 * h3 / abs(j_max) + 2.0 * (-ad - j_max * tf) * h2
                            - 2.0
                                * (3.0 * ad_ad
                                    + af * j_max * (8.0 * t - 2.0 * tf)
                                    + 4.0 * a0 * j_max * (-2.0 * t + tf)
                                    + 2.0 * j_max * (j_max * t * (3.0 * t - 2.0 * tf) - vd)))
                            / (4.0 * j_max);

                        t -= orig / deriv;
                    }

                    let h1 =
                        sqrt(2.0 * ad_ad + 4.0 * j_max * (ad * t + a0 * tf + j_max * t * (t - tf) - vd)) / abs(j_max);

                    // Solution 2 with aPlat
                    p.t[0] = 0.0;
                    p.t[1] = 0.0;
                    p.t[2] = t;
                    p.t[3] = tf - 2.0 * t - ad / j_max - h1;
                    p.t[4] = h1 / 2.0;
                    p.t[5] = 0.0;
                    p.t[6] = tf - (t + p.t[3] + p.t[4]);

                    if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                        return true;
                    }
                }
            }
        }

        // Profiles with a3 != 0, Solution UDUD
        {
            // T 0124
            {
                let ph0 = -2.0 * pd - tf * v0 + 3.0 * tf * vf;
                let ph1 = -ad + j_max * tf;
                let ph2 = j_max * tf_tf * g1 - vd * ph0;
                let ph3 = 5.0 * af_af + 2.0 * j_max * (2.0 * j_max * tf_tf - vd - 4.0 * af * tf);
                let ph4 = jj * tf_p4 - 2.0 * vd_vd + 8.0 * j_max * tf * (-pd + tf * vf);
                let ph5 = 5.0 * af_p4 - 8.0 * af_p3 * j_max * tf - 12.0 * af_af * j_max * (j_max * tf_tf + vd)
                    + 24.0 * af * jj * (-2.0 * pd + j_max * tf_p3 + 2.0 * tf * vf)
                    - 6.0 * jj * ph4;
                let ph6 = -vd_vd + j_max * tf * (-2.0 * pd + 3.0 * tf * v0 - tf * vf);
                let ph7 = 3.0 * jj * ph1 * ph1;

                let mut polynom = [0.0; 4];
                polynom[0] = (4.0 * af * tf - 2.0 * j_max * tf_tf - 4.0 * vd) / ph1;
                polynom[1] = (-2.0 * (a0_p4 + af_p4)
                    + 8.0 * af_p3 * j_max * tf
                    + 6.0 * af_af * jj * tf_tf
                    + 8.0 * a0_p3 * (af - j_max * tf)
                    - 12.0 * a0_a0 * (af - j_max * tf) * (af - j_max * tf)
                    - 12.0 * af * jj * (-pd + j_max * tf_p3 - 2.0 * tf * v0 + 3.0 * tf * vf)
                    + 2.0
                        * a0
                        * (4.0 * af_p3 - 12.0 * af_af * j_max * tf + 9.0 * af * jj * tf_tf
                            - 3.0 * jj * (2.0 * pd + j_max * tf_p3 - 2.0 * tf * vf))
                    + 3.0 * jj * (jj * tf_p4 + 4.0 * vd_vd - 4.0 * j_max * tf * (pd + tf * v0 - 2.0 * tf * vf)))
                    / ph7;
                polynom[2] = (-a0_p5 + af_p5 - af_p4 * j_max * tf + 5.0 * a0_p4 * (af - j_max * tf)
                    - 2.0 * a0_p3 * ph3
                    - 4.0 * af_p3 * j_max * (j_max * tf_tf + vd)
                    + 12.0 * af_af * jj * g2
                    - 12.0 * af * jj * ph6
                    + 2.0 * a0_a0 * (5.0 * af_p3 - 9.0 * af_af * j_max * tf - 6.0 * af * j_max * vd + 6.0 * jj * ph0)
                    + 12.0 * jj * j_max * ph2
                    + a0 * (-5.0 * af_p4 + 8.0 * af_p3 * j_max * tf + 12.0 * af_af * j_max * (j_max * tf_tf + vd)
                        - 24.0 * af * jj * (-2.0 * pd + j_max * tf_p3 + 2.0 * tf * vf)
                        + 6.0 * jj * ph4))
                    / (j_max * ph7);
                polynom[3] = -(a0_p6 + af_p6 - 6.0 * a0_p5 * (af - j_max * tf) + 48.0 * af_p3 * jj * g1
                    - 72.0 * jj * j_max * (j_max * g1 * g1 + vd_vd * vd + 2.0 * af * g1 * vd)
                    + 3.0 * a0_p4 * ph3
                    - 6.0 * af_p4 * j_max * vd
                    + 36.0 * af_af * jj * vd_vd
                    - 4.0 * a0_p3 * (5.0 * af_p3 - 9.0 * af_af * j_max * tf - 6.0 * af * j_max * vd + 6.0 * jj * ph0)
                    + 3.0 * a0_a0 * ph5
                    - 6.0
                        * a0
                        * (af_p5 - af_p4 * j_max * tf - 4.0 * af_p3 * j_max * (j_max * tf_tf + vd)
                            + 12.0 * jj * (af_af * g2 - af * ph6 + j_max * ph2)))
                    / (6.0 * jj * ph7);

                let roots = solve_quart_monic_arr(&polynom);
                for &root in roots.as_slice() {
                    let t = root;
                    if t > tf || t > (a_max - a0) / j_max {
                        continue;
                    }

                    let h1 = sqrt(ad_ad / (2.0 * jj) + (a0 * (t + tf) - af * t + j_max * t * tf - vd) / j_max);

                    p.t[0] = t;
                    p.t[1] = tf - ad / j_max - 2.0 * h1;
                    p.t[2] = h1;
                    p.t[3] = 0.0;
                    p.t[4] = ad / j_max + h1 - t;
                    p.t[5] = 0.0;
                    p.t[6] = 0.0;

                    if p.check_with_timing(tf, Udud, RL::None, j_max, v_max, v_min, a_max, a_min) {
                        return true;
                    }
                }
            }
        }

        // 3 step profile (ak. UZD), sometimes missed because of numerical errors T 012
        {
            let h1 = sqrt(-ad_ad + j_max * (2.0 * (a0 + af) * tf - 4.0 * vd + j_max * tf_tf)) / abs(j_max);

            p.t[0] = (tf - h1 + ad / j_max) / 2.0;
            p.t[1] = h1;
            p.t[2] = (tf - h1 - ad / j_max) / 2.0;
            p.t[3] = 0.0;
            p.t[4] = 0.0;
            p.t[5] = 0.0;
            p.t[6] = 0.0;

            if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        // 3 step profile (ak. UZU), sometimes missed because of numerical errors
        {
            let mut polynom = [0.0; 4];
            polynom[0] = ad_ad;
            polynom[1] = ad_ad * tf;
            polynom[2] =
                (a0_a0 + af_af + 10.0 * a0 * af) * tf_tf + 24.0 * (tf * (af * v0 - a0 * vf) - pd * ad) + 12.0 * vd_vd;
            polynom[3] =
                -3.0 * tf * ((a0_a0 + af_af + 2.0 * a0 * af) * tf_tf - 4.0 * vd * (a0 + af) * tf + 4.0 * vd_vd);

            let roots = solve_cubic(polynom[0], polynom[1], polynom[2], polynom[3]);
            for &root in roots.as_slice() {
                let t = root;
                if t > tf {
                    continue;
                }

                let jf = ad / (tf - t);

                p.t[0] = (2.0 * (vd - a0 * tf) + ad * (t - tf)) / (2.0 * jf * t);
                p.t[1] = t;
                p.t[2] = 0.0;
                p.t[3] = 0.0;
                p.t[4] = 0.0;
                p.t[5] = 0.0;
                p.t[6] = tf - (p.t[0] + p.t[1]);

                if p.check_with_timing_and_jerk(tf, Uddu, RL::None, jf, v_max, v_min, a_max, a_min, j_max) {
                    return true;
                }
            }
        }

        // 3 step profile (ak. UDU), sometimes missed because of numerical errors
        {
            p.t[0] = (ad_ad / j_max + 2.0 * (a0 + af) * tf - j_max * tf_tf - 4.0 * vd) / (4.0 * (ad - j_max * tf));
            p.t[1] = 0.0;
            p.t[2] = -ad / (2.0 * j_max) + tf / 2.0;
            p.t[3] = 0.0;
            p.t[4] = 0.0;
            p.t[5] = 0.0;
            p.t[6] = tf - (p.t[0] + p.t[2]);

            if p.check_with_timing(tf, Uddu, RL::None, j_max, v_max, v_min, a_max, a_min) {
                return true;
            }
        }

        false
    }

    /// Cruise at the velocity limit without reaching an acceleration limit. UDDU: the first
    /// ramp's length is a root of a quintic; UDUD: of a sextic. Their real roots are isolated
    /// between the roots of the derivatives and polished by safeguarded Newton iterations.
    fn time_vel(&self, p: &mut Profile, l: Lim) -> bool {
        let Lim { v_max, v_min, a_max, a_min, j_max } = l;
        let Step2 {
            v0,
            a0,
            tf,
            vf,
            af,
            pd,
            tf_tf,
            vd,
            vd_vd,
            ad,
            a0_a0,
            a0_p3,
            a0_p4,
            a0_p5,
            a0_p6,
            af_af,
            af_p3,
            af_p4,
            af_p6,
            jj,
            g1,
            ..
        } = *self;
        let tz_min = max(0.0, -a0 / j_max);
        let tz_max = min((tf - a0 / j_max) / 2.0, (a_max - a0) / j_max);

        // Profile UDDU
        if abs(v0) < EPS && abs(a0) < EPS && abs(vf) < EPS && abs(af) < EPS {
            let roots = solve_cubic(1.0, -tf / 2.0, 0.0, pd / (2.0 * j_max));
            for &root in roots.as_slice() {
                let mut t = root;
                if t > tf / 4.0 {
                    continue;
                }
                // Single Newton step (regarding pd)
                if t > EPS {
                    let orig = -pd + j_max * t * t * (tf - 2.0 * t);
                    let deriv = 2.0 * j_max * t * (tf - 3.0 * t);
                    t -= orig / deriv;
                }
                p.t = [t, 0.0, t, tf - 4.0 * t, t, 0.0, t];
                if p.check_with_timing(tf, Uddu, RL::Vel, j_max, v_max, v_min, a_max, a_min) {
                    return true;
                }
            }
        } else {
            let p1 = af_af - 2.0 * j_max * (-2.0 * af * tf + j_max * tf_tf + 3.0 * vd);
            let ph1 = af_p3 - 3.0 * jj * g1 - 3.0 * af * j_max * vd;
            let ph2 = af_p4
                + 8.0 * af_p3 * j_max * tf
                + 12.0
                    * j_max
                    * (3.0 * j_max * vd_vd - af_af * vd + 2.0 * af * j_max * (g1 - tf * vd) - 2.0 * jj * tf * g1);
            let ph3 = a0 * (af - j_max * tf);
            let ph4 = j_max * (-ad + j_max * tf);

            // Find root of 5th order polynom
            let mut polynom = [0.0; 6];
            polynom[0] = 1.0;
            polynom[1] =
                (15.0 * a0_a0 + af_af + 4.0 * af * j_max * tf - 16.0 * ph3 - 2.0 * j_max * (j_max * tf_tf + 3.0 * vd))
                    / (4.0 * ph4);
            polynom[2] =
                (29.0 * a0_p3 - 2.0 * af_p3 - 33.0 * a0 * ph3 + 6.0 * jj * g1 + 6.0 * af * j_max * vd + 6.0 * a0 * p1)
                    / (6.0 * j_max * ph4);
            polynom[3] =
                (61.0 * a0_p4 - 76.0 * a0_a0 * ph3 - 16.0 * a0 * ph1 + 30.0 * a0_a0 * p1 + ph2) / (24.0 * jj * ph4);
            polynom[4] = (a0 * (7.0 * a0_p4 - 10.0 * a0_a0 * ph3 - 4.0 * a0 * ph1 + 6.0 * a0_a0 * p1 + ph2))
                / (12.0 * jj * j_max * ph4);
            polynom[5] = (7.0 * a0_p6 + af_p6 - 12.0 * a0_p4 * ph3 + 48.0 * af_p3 * jj * g1
                - 8.0 * a0_p3 * ph1
                - 72.0 * jj * j_max * (j_max * g1 * g1 + vd_vd * vd + 2.0 * af * g1 * vd)
                - 6.0 * af_p4 * j_max * vd
                + 36.0 * af_af * jj * vd_vd
                + 9.0 * a0_p4 * p1
                + 3.0 * a0_a0 * ph2)
                / (144.0 * jj * jj * ph4);

            let mut deriv = [0.0; 5];
            poly_monic_derivative(&polynom, &mut deriv);
            let mut dderiv = [0.0; 4];
            poly_derivative(&deriv, &mut dderiv);

            // Extrema of the quintic: roots of its (quartic) derivative.
            let d_extremas = solve_quart_monic(deriv[1], deriv[2], deriv[3], deriv[4]);
            let mut tz_current = tz_min;

            let mut check_root = |t: f64| -> bool {
                let mut t = t;
                // Single Newton step (regarding pd)
                {
                    let h1 = sqrt((a0_a0 + af_af) / (2.0 * jj) + (2.0 * a0 * t + j_max * t * t - vd) / j_max);
                    let orig = -pd
                        - (2.0 * a0_p3
                            + 4.0 * af_p3
                            + 24.0 * a0 * j_max * t * (af + j_max * (h1 + t - tf))
                            + 6.0 * a0_a0 * (af + j_max * (2.0 * t - tf))
                            + 6.0 * (a0_a0 + af_af) * j_max * h1
                            + 12.0 * af * j_max * (j_max * t * t - vd)
                            + 12.0 * jj * (j_max * t * t * (h1 + t - tf) - tf * v0 - h1 * vd))
                            / (12.0 * jj);
                    let deriv_newton = -(a0 + j_max * t) * (3.0 * (h1 + t) - 2.0 * tf + (a0 + 2.0 * af) / j_max);
                    if !orig.is_nan() && !deriv_newton.is_nan() && abs(deriv_newton) > EPS {
                        t -= orig / deriv_newton;
                    }
                }
                if t > tf || t.is_nan() {
                    return false;
                }
                let h1 = sqrt((a0_a0 + af_af) / (2.0 * jj) + (t * (2.0 * a0 + j_max * t) - vd) / j_max);
                p.t = [t, 0.0, t + a0 / j_max, tf - 2.0 * (t + h1) - (a0 + af) / j_max, h1, 0.0, h1 + af / j_max];
                p.check_with_timing(tf, Uddu, RL::Vel, j_max, v_max, v_min, a_max, a_min)
            };

            for &extremum in d_extremas.as_slice() {
                let mut tz = extremum;
                if tz >= tz_max {
                    continue;
                }
                let orig = poly_eval(&deriv, tz);
                if abs(orig) > TOLERANCE {
                    tz -= orig / poly_eval(&dderiv, tz);
                }
                let val_new = poly_eval(&polynom, tz);
                if abs(val_new) < DOUBLE_ROOT_FACTOR * abs(poly_eval(&dderiv, tz)) * TOLERANCE {
                    if check_root(tz) {
                        return true;
                    }
                } else if poly_eval(&polynom, tz_current) * val_new < 0.0
                    && check_root(shrink_interval(&polynom, tz_current, tz))
                {
                    return true;
                }
                tz_current = tz;
            }
            let val_max = poly_eval(&polynom, tz_max);
            if poly_eval(&polynom, tz_current) * val_max < 0.0 {
                if check_root(shrink_interval(&polynom, tz_current, tz_max)) {
                    return true;
                }
            } else if abs(val_max) < END_ROOT_EPS && check_root(tz_max) {
                return true;
            }
        }

        // Profile UDUD
        {
            let ph1 = af_af - 2.0 * j_max * (2.0 * af * tf + j_max * tf_tf - 3.0 * vd);
            let ph2 = af_p3 - 3.0 * jj * g1 + 3.0 * af * j_max * vd;
            let ph3 = 2.0 * j_max * tf * g1 + 3.0 * vd_vd;
            let ph4 = af_p4 - 8.0 * af_p3 * j_max * tf
                + 12.0 * j_max * (j_max * ph3 + af_af * vd + 2.0 * af * j_max * (g1 - tf * vd));
            let ph5 = af + j_max * tf;

            // Find root of 6th order polynom
            let mut polynom = [0.0; 7];
            polynom[0] = 1.0;
            polynom[1] = (5.0 * a0 - ph5) / j_max;
            polynom[2] = (39.0 * a0_a0 - ph1 - 16.0 * a0 * ph5) / (4.0 * jj);
            polynom[3] = (55.0 * a0_p3 - 33.0 * a0_a0 * ph5 - 6.0 * a0 * ph1 + 2.0 * ph2) / (6.0 * jj * j_max);
            polynom[4] =
                (101.0 * a0_p4 + ph4 - 76.0 * a0_p3 * ph5 - 30.0 * a0_a0 * ph1 + 16.0 * a0 * ph2) / (24.0 * jj * jj);
            polynom[5] = (a0 * (11.0 * a0_p4 + ph4 - 10.0 * a0_p3 * ph5 - 6.0 * a0_a0 * ph1 + 4.0 * a0 * ph2))
                / (12.0 * jj * jj * j_max);
            polynom[6] = (11.0 * a0_p6 - af_p6 - 12.0 * a0_p5 * ph5 - 48.0 * af_p3 * jj * g1 - 9.0 * a0_p4 * ph1
                + 72.0 * jj * j_max * (j_max * g1 * g1 - vd_vd * vd - 2.0 * af * g1 * vd)
                - 6.0 * af_p4 * j_max * vd
                - 36.0 * af_af * jj * vd_vd
                + 8.0 * a0_p3 * ph2
                + 3.0 * a0_a0 * ph4)
                / (144.0 * jj * jj * jj);

            let mut deriv = [0.0; 6];
            poly_monic_derivative(&polynom, &mut deriv);
            let mut dderiv = [0.0; 5];
            poly_monic_derivative(&deriv, &mut dderiv);
            let mut ddderiv = [0.0; 4];
            poly_derivative(&dderiv, &mut ddderiv);

            // Intervals between the extrema of the derivative that contain one of its roots.
            let mut dd_tz_current = tz_min;
            let mut intervals = [(0.0f64, 0.0f64); 6];
            let mut n_intervals = 0;
            let dd_extremas = solve_quart_monic(dderiv[1], dderiv[2], dderiv[3], dderiv[4]);
            for &extremum in dd_extremas.as_slice() {
                let mut tz = extremum;
                if tz >= tz_max {
                    continue;
                }
                let orig = poly_eval(&dderiv, tz);
                if abs(orig) > TOLERANCE {
                    tz -= orig / poly_eval(&ddderiv, tz);
                }
                if poly_eval(&deriv, dd_tz_current) * poly_eval(&deriv, tz) < 0.0 {
                    intervals[n_intervals] = (dd_tz_current, tz);
                    n_intervals += 1;
                }
                dd_tz_current = tz;
            }
            if poly_eval(&deriv, dd_tz_current) * poly_eval(&deriv, tz_max) < 0.0 {
                intervals[n_intervals] = (dd_tz_current, tz_max);
                n_intervals += 1;
            }
            let intervals = &mut intervals[..n_intervals];
            intervals.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));

            let mut tz_current = tz_min;
            let mut check_root = |t: f64| -> bool {
                let mut t = t;
                // Double Newton step (regarding pd)
                {
                    let mut h1 = sqrt((af_af - a0_a0) / (2.0 * jj) - ((2.0 * a0 + j_max * t) * t - vd) / j_max);
                    let mut orig = -pd
                        + (af_p3 - a0_p3 + 3.0 * a0_a0 * j_max * (tf - 2.0 * t)) / (6.0 * jj)
                        + (2.0 * a0 + j_max * t) * t * (tf - t)
                        + (j_max * h1 - af) * h1 * h1
                        + tf * v0;
                    let mut deriv_newton =
                        (a0 + j_max * t) * (2.0 * (af + j_max * tf) - 3.0 * j_max * (h1 + t) - a0) / j_max;
                    t -= orig / deriv_newton;

                    h1 = sqrt((af_af - a0_a0) / (2.0 * jj) - ((2.0 * a0 + j_max * t) * t - vd) / j_max);
                    orig = -pd
                        + (af_p3 - a0_p3 + 3.0 * a0_a0 * j_max * (tf - 2.0 * t)) / (6.0 * jj)
                        + (2.0 * a0 + j_max * t) * t * (tf - t)
                        + (j_max * h1 - af) * h1 * h1
                        + tf * v0;
                    if abs(orig) > SECOND_NEWTON_RESIDUAL {
                        deriv_newton =
                            (a0 + j_max * t) * (2.0 * (af + j_max * tf) - 3.0 * j_max * (h1 + t) - a0) / j_max;
                        t -= orig / deriv_newton;
                    }
                }
                let h1 = sqrt((af_af - a0_a0) / (2.0 * jj) - ((2.0 * a0 + j_max * t) * t - vd) / j_max);
                p.t = [t, 0.0, t + a0 / j_max, tf - 2.0 * (t + h1) + ad / j_max, h1, 0.0, h1 - af / j_max];
                p.check_with_timing(tf, Udud, RL::Vel, j_max, v_max, v_min, a_max, a_min)
            };

            for &(lo, hi) in intervals.iter() {
                let tz = shrink_interval(&deriv, lo, hi);
                if tz >= tz_max {
                    continue;
                }
                let p_val = poly_eval(&polynom, tz);
                if abs(p_val) < DOUBLE_ROOT_FACTOR * abs(poly_eval(&dderiv, tz)) * TOLERANCE {
                    if check_root(tz) {
                        return true;
                    }
                } else if poly_eval(&polynom, tz_current) * p_val < 0.0
                    && check_root(shrink_interval(&polynom, tz_current, tz))
                {
                    return true;
                }
                tz_current = tz;
            }
            if poly_eval(&polynom, tz_current) * poly_eval(&polynom, tz_max) < 0.0
                && check_root(shrink_interval(&polynom, tz_current, tz_max))
            {
                return true;
            }
        }
        false
    }
}
