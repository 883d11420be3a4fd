//! Step 1, position interface: all time-extremal profiles of one DoF, hence its minimum duration
//! and its blocked intervals (Berscheid & Kröger, RSS 2021, Sec. IV-A/B).
//!
//! Time-extremal profiles have the jerk pattern UDDU (+j, 0, -j, 0, -j, 0, +j) in one of two
//! directions; they differ in which limits they reach: with a cruise at v_max (ACC0_ACC1_VEL,
//! ACC1_VEL, ACC0_VEL, VEL: closed forms), ACC0_ACC1 (a quadratic), NONE, ACC0 and ACC1 (a
//! quartic each, each root refined by Newton steps on the position equation). When the target is
//! at rest there are no blocked intervals and the first valid profile, searched in the direction
//! of the target first, is the optimum. Inputs on the border between two cases (a phase of exactly
//! zero length) are caught by the "two-step" profiles with fewer phases.
//!
//! The equations, their order and the root refinement are ported from Ruckig's
//! `position-third-step1.cpp` (L. Berscheid, MIT licence, <https://github.com/pantor/ruckig>);
//! the lower direction passes the mirrored limits (v_min, v_max, a_min, a_max, -j_max).

use crate::block::Block;
use crate::profile::{ControlSigns, Profile, ReachedLimits};
use crate::roots::{Roots, solve_quart_monic_arr};

/// Capacity of the candidate list: at most five extremal profiles plus one spare.
pub(crate) const MAX_PROFILES: usize = 6;
/// Roots below this are not refined (the Newton step divides by them) (Ruckig: ε).
const REFINE_MIN_ROOT: f64 = f64::EPSILON;
/// The second and third Newton steps of the ACC1 root run only while the residual exceeds this
/// (Ruckig: 1e-9).
const ACC1_REFINE_RESIDUAL: f64 = 1e-9;
/// Inputs below this count as zero (target at rest, no motion) (Ruckig: ε).
const ZERO: f64 = f64::EPSILON;

use ControlSigns::Uddu;
use ReachedLimits as RL;

/// The problem of one DoF with the expressions all cases share.
struct Step1<'a> {
    v0: f64,
    a0: f64,
    vf: f64,
    af: f64,
    pd: f64,
    v0_v0: f64,
    vf_vf: f64,
    a0_a0: f64,
    a0_p3: f64,
    a0_p4: f64,
    af_af: f64,
    af_p3: f64,
    af_p4: f64,
    j_max_j_max: f64,
    /// Candidates; `profiles[n]` is the one being filled.
    profiles: &'a mut [Profile; MAX_PROFILES],
    n: usize,
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

impl Step1<'_> {
    #[inline]
    fn cur(&mut self) -> &mut Profile {
        &mut self.profiles[self.n]
    }

    /// Keep the current candidate and start the next one with the same boundary.
    #[inline]
    fn add_profile(&mut self) {
        if self.n + 1 < MAX_PROFILES {
            self.n += 1;
            let (done, next) = self.profiles.split_at_mut(self.n);
            next[0].set_boundary_from(&done[self.n - 1]);
        }
    }

    /// Check the current candidate; keep it if valid.
    #[inline]
    fn accept(&mut self, limits: ReachedLimits, set_limits: bool, l: Lim) -> bool {
        let ok = self.cur().check(Uddu, limits, set_limits, l.j_max, l.v_max, l.v_min, l.a_max, l.a_min);
        if ok {
            self.add_profile();
        }
        ok
    }

    fn time_all_vel(&mut self, l: Lim) {
        let Lim { v_max, a_max, a_min, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4) =
            (self.a0_a0, self.a0_p3, self.a0_p4, self.af_af, self.af_p3, self.af_p4);
        let (v0_v0, vf_vf, jj) = (self.v0_v0, self.vf_vf, self.j_max_j_max);

        // ACC0_ACC1_VEL
        {
            let t = &mut self.cur().t;
            t[0] = (-a0 + a_max) / j_max;
            t[1] = (a0_a0 / 2.0 - a_max * a_max - j_max * (v0 - v_max)) / (a_max * j_max);
            t[2] = a_max / j_max;
            t[3] = (3.0 * (a0_p4 * a_min - af_p4 * a_max)
                + 8.0 * a_max * a_min * (af_p3 - a0_p3 + 3.0 * j_max * (a0 * v0 - af * vf))
                + 6.0 * a0_a0 * a_min * (a_max * a_max - 2.0 * j_max * v0)
                - 6.0 * af_af * a_max * (a_min * a_min - 2.0 * j_max * vf)
                - 12.0
                    * j_max
                    * (a_max * a_min * (a_max * (v0 + v_max) - a_min * (vf + v_max) - 2.0 * j_max * pd)
                        + (a_min - a_max) * j_max * v_max * v_max
                        + j_max * (a_max * vf_vf - a_min * v0_v0)))
                / (24.0 * a_max * a_min * jj * v_max);
            t[4] = -a_min / j_max;
            t[5] = -(af_af / 2.0 - a_min * a_min - j_max * (vf - v_max)) / (a_min * j_max);
            t[6] = t[4] + af / j_max;
        }
        if self.accept(RL::Acc0Acc1Vel, false, l) {
            return;
        }

        // ACC1_VEL (phases 4..6 as above)
        let t_acc0 = (a0_a0 / (2.0 * jj) + (v_max - v0) / j_max).sqrt();
        {
            let t = &mut self.cur().t;
            t[0] = t_acc0 - a0 / j_max;
            t[1] = 0.0;
            t[2] = t_acc0;
            t[3] = -(3.0 * af_p4 - 8.0 * a_min * (af_p3 - a0_p3) - 24.0 * a_min * j_max * (a0 * v0 - af * vf)
                + 6.0 * af_af * (a_min * a_min - 2.0 * j_max * vf)
                - 12.0
                    * j_max
                    * (2.0 * a_min * j_max * pd
                        + a_min * a_min * (vf + v_max)
                        + j_max * (v_max * v_max - vf_vf)
                        + a_min * t_acc0 * (a0_a0 - 2.0 * j_max * (v0 + v_max))))
                / (24.0 * a_min * jj * v_max);
        }
        if self.accept(RL::Acc1Vel, false, l) {
            return;
        }

        // ACC0_VEL
        let t_acc1 = (af_af / (2.0 * jj) + (v_max - vf) / j_max).sqrt();
        {
            let t = &mut self.cur().t;
            t[0] = (-a0 + a_max) / j_max;
            t[1] = (a0_a0 / 2.0 - a_max * a_max - j_max * (v0 - v_max)) / (a_max * j_max);
            t[2] = a_max / j_max;
            t[3] = (3.0 * a0_p4
                + 8.0 * a_max * (af_p3 - a0_p3)
                + 24.0 * a_max * j_max * (a0 * v0 - af * vf)
                + 6.0 * a0_a0 * (a_max * a_max - 2.0 * j_max * v0)
                - 12.0
                    * j_max
                    * (-2.0 * a_max * j_max * pd
                        + a_max * a_max * (v0 + v_max)
                        + j_max * (v_max * v_max - v0_v0)
                        + a_max * t_acc1 * (-af_af + 2.0 * (vf + v_max) * j_max)))
                / (24.0 * a_max * jj * v_max);
            t[4] = t_acc1;
            t[5] = 0.0;
            t[6] = t_acc1 + af / j_max;
        }
        if self.accept(RL::Acc0Vel, false, l) {
            return;
        }

        // VEL (phases 4..6 as in ACC0_VEL)
        {
            let t = &mut self.cur().t;
            t[0] = t_acc0 - a0 / j_max;
            t[1] = 0.0;
            t[2] = t_acc0;
            t[3] = (af_p3 - a0_p3) / (3.0 * jj * v_max)
                + (a0 * v0 - af * vf + (af_af * t_acc1 + a0_a0 * t_acc0) / 2.0) / (j_max * v_max)
                - (v0 / v_max + 1.0) * t_acc0
                - (vf / v_max + 1.0) * t_acc1
                + pd / v_max;
        }
        self.accept(RL::Vel, false, l);
    }

    fn time_acc0_acc1(&mut self, l: Lim, return_after_found: bool) {
        let Lim { a_max, a_min, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4) =
            (self.a0_a0, self.a0_p3, self.a0_p4, self.af_af, self.af_p3, self.af_p4);
        let jj = self.j_max_j_max;

        let mut h1 = (3.0 * (af_p4 * a_max - a0_p4 * a_min)
            + a_max
                * a_min
                * (8.0 * (a0_p3 - af_p3) + 3.0 * a_max * a_min * (a_max - a_min) + 6.0 * a_min * af_af
                    - 6.0 * a_max * a0_a0)
            + 12.0
                * j_max
                * (a_max * a_min * ((a_max - 2.0 * a0) * v0 - (a_min - 2.0 * af) * vf) + a_min * a0_a0 * v0
                    - a_max * af_af * vf))
            / (3.0 * (a_max - a_min) * jj)
            + 4.0 * (a_max * self.vf_vf - a_min * self.v0_v0 - 2.0 * a_min * a_max * pd) / (a_max - a_min);
        if h1.is_nan() || h1 < 0.0 {
            return;
        }
        h1 = h1.sqrt() / 2.0;
        let h2 = a0_a0 / (2.0 * a_max * j_max) + (a_min - 2.0 * a_max) / (2.0 * j_max) - v0 / a_max;
        let h3 = -af_af / (2.0 * a_min * j_max) - (a_max - 2.0 * a_min) / (2.0 * j_max) + vf / a_min;

        // UDDU: solution 2
        if h2 > h1 / a_max && h3 > -h1 / a_min {
            let t = &mut self.cur().t;
            t[0] = (-a0 + a_max) / j_max;
            t[1] = h2 - h1 / a_max;
            t[2] = a_max / j_max;
            t[3] = 0.0;
            t[4] = -a_min / j_max;
            t[5] = h3 + h1 / a_min;
            t[6] = t[4] + af / j_max;
            if self.accept(RL::Acc0Acc1, true, l) && return_after_found {
                return;
            }
        }

        // UDDU: solution 1
        if h2 > -h1 / a_max && h3 > h1 / a_min {
            let t = &mut self.cur().t;
            t[0] = (-a0 + a_max) / j_max;
            t[1] = h2 + h1 / a_max;
            t[2] = a_max / j_max;
            t[3] = 0.0;
            t[4] = -a_min / j_max;
            t[5] = h3 - h1 / a_min;
            t[6] = t[4] + af / j_max;
            self.accept(RL::Acc0Acc1, true, l);
        }
    }

    fn time_all_none_acc0_acc1(&mut self, l: Lim, return_after_found: bool) {
        let Lim { a_max, a_min, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4) =
            (self.a0_a0, self.a0_p3, self.a0_p4, self.af_af, self.af_p3, self.af_p4);
        let (v0_v0, vf_vf, jj) = (self.v0_v0, self.vf_vf, self.j_max_j_max);

        // NONE, UDDU / UDUD with t7 = 0 (prone to numerical issues).
        let h2_none = (a0_a0 - af_af) / (2.0 * j_max) + (vf - v0);
        let h2_h2 = h2_none * h2_none;
        let t_min_none = (a0 - af) / j_max;
        let t_max_none = (a_max - a_min) / j_max;
        let polynom_none = [
            0.0,
            -2.0 * (a0_a0 + af_af - 2.0 * j_max * (v0 + vf)) / jj,
            4.0 * (a0_p3 - af_p3 + 3.0 * j_max * (af * vf - a0 * v0)) / (3.0 * j_max * jj) - 4.0 * pd / j_max,
            -h2_h2 / jj,
        ];

        // ACC0
        let h3_acc0 = (a0_a0 - af_af) / (2.0 * a_max * j_max) + (vf - v0) / a_max;
        let t_min_acc0 = (a_max - af) / j_max;
        let t_max_acc0 = (a_max - a_min) / j_max;
        let h0_acc0 =
            3.0 * (af_p4 - a0_p4) + 8.0 * (a0_p3 - af_p3) * a_max + 24.0 * a_max * j_max * (af * vf - a0 * v0)
                - 6.0 * a0_a0 * (a_max * a_max - 2.0 * j_max * v0)
                + 6.0 * af_af * (a_max * a_max - 2.0 * j_max * vf)
                + 12.0 * j_max * (j_max * (vf_vf - v0_v0 - 2.0 * a_max * pd) - a_max * a_max * (vf - v0));
        let h2_acc0 = -af_af + a_max * a_max + 2.0 * j_max * vf;
        let polynom_acc0 = [-2.0 * a_max / j_max, h2_acc0 / jj, 0.0, h0_acc0 / (12.0 * jj * jj)];

        // ACC1
        let h3_acc1 = -(a0_a0 + af_af) / (2.0 * j_max * a_min) + a_min / j_max + (vf - v0) / a_min;
        let t_min_acc1 = (a_min - a0) / j_max;
        let t_max_acc1 = (a_max - a0) / j_max;
        let h0_acc1 = (a0_p4 - af_p4) / 4.0
            + 2.0 * (af_p3 - a0_p3) * a_min / 3.0
            + (a0_a0 - af_af) * a_min * a_min / 2.0
            + j_max
                * (af_af * vf
                    + a0_a0 * v0
                    + 2.0 * a_min * (j_max * pd - a0 * v0 - af * vf)
                    + a_min * a_min * (v0 + vf)
                    + j_max * (v0_v0 - vf_vf));
        let h2_acc1 = a0_a0 - a0 * a_min + 2.0 * j_max * v0;
        let polynom_acc1 = [
            2.0 * (2.0 * a0 - a_min) / j_max,
            (5.0 * a0_a0 + a_min * (a_min - 6.0 * a0) + 2.0 * j_max * v0) / jj,
            2.0 * (a0 - a_min) * h2_acc1 / (jj * j_max),
            h0_acc1 / (jj * jj),
        ];

        let roots_none: Roots<4> = solve_quart_monic_arr(&polynom_none);
        let roots_acc0: Roots<4> = solve_quart_monic_arr(&polynom_acc0);
        let roots_acc1: Roots<4> = solve_quart_monic_arr(&polynom_acc1);

        for &root in roots_none.as_slice() {
            let mut t = root;
            if t < t_min_none || t > t_max_none {
                continue;
            }
            // One Newton step on the position equation.
            if t > REFINE_MIN_ROOT {
                let h1 = j_max * t * t;
                let orig = -h2_h2 / (4.0 * j_max * t)
                    + h2_none * (af / j_max + t)
                    + (4.0 * a0_p3 + 2.0 * af_p3 - 6.0 * a0_a0 * (af + 2.0 * j_max * t)
                        + 12.0 * (af - a0) * j_max * v0
                        + 3.0 * jj * (-4.0 * pd + (h1 + 8.0 * v0) * t))
                        / (12.0 * jj);
                let deriv = h2_none + 2.0 * v0 - a0_a0 / j_max + h2_h2 / (4.0 * h1) + (3.0 * h1) / 4.0;
                t -= orig / deriv;
            }
            let h0 = h2_none / (2.0 * j_max * t);
            {
                let p = &mut self.cur().t;
                p[0] = h0 + t / 2.0 - a0 / j_max;
                p[1] = 0.0;
                p[2] = t;
                p[3] = 0.0;
                p[4] = 0.0;
                p[5] = 0.0;
                p[6] = -h0 + t / 2.0 + af / j_max;
            }
            if self.accept(RL::None, false, l) && return_after_found {
                return;
            }
        }

        for &root in roots_acc0.as_slice() {
            let mut t = root;
            if t < t_min_acc0 || t > t_max_acc0 {
                continue;
            }
            if t > REFINE_MIN_ROOT {
                let h1 = j_max * t;
                let orig = h0_acc0 / (12.0 * jj * t) + t * (h2_acc0 + h1 * (h1 - 2.0 * a_max));
                let deriv = 2.0 * (h2_acc0 + h1 * (2.0 * h1 - 3.0 * a_max));
                t -= orig / deriv;
            }
            {
                let p = &mut self.cur().t;
                p[0] = (-a0 + a_max) / j_max;
                p[1] = h3_acc0 - 2.0 * t + j_max / a_max * t * t;
                p[2] = t;
                p[3] = 0.0;
                p[4] = 0.0;
                p[5] = 0.0;
                p[6] = (af - a_max) / j_max + t;
            }
            if self.accept(RL::Acc0, false, l) && return_after_found {
                return;
            }
        }

        for &root in roots_acc1.as_slice() {
            let mut t = root;
            if t < t_min_acc1 || t > t_max_acc1 {
                continue;
            }
            // Up to three Newton steps on the position equation.
            if t > REFINE_MIN_ROOT {
                let h5 = a0_p3 + 2.0 * j_max * a0 * v0;
                let residual = |t: f64| {
                    let h1 = j_max * t;
                    -(h0_acc1 / 2.0
                        + h1 * (h5
                            + a0 * (a_min - 2.0 * h1) * (a_min - h1)
                            + a0_a0 * (5.0 * h1 / 2.0 - 2.0 * a_min)
                            + a_min * a_min * h1 / 2.0
                            + j_max * (h1 / 2.0 - a_min) * (h1 * t + 2.0 * v0)))
                        / j_max
                };
                let derivative = |t: f64| {
                    let h1 = j_max * t;
                    (a_min - a0 - h1) * (h2_acc1 + h1 * (4.0 * a0 - a_min + 2.0 * h1))
                };
                let orig = residual(t);
                t -= (orig / derivative(t)).min(t);
                let orig = residual(t);
                if orig.abs() > ACC1_REFINE_RESIDUAL {
                    t -= orig / derivative(t);
                    let orig = residual(t);
                    if orig.abs() > ACC1_REFINE_RESIDUAL {
                        t -= orig / derivative(t);
                    }
                }
            }
            {
                let p = &mut self.cur().t;
                p[0] = t;
                p[1] = 0.0;
                p[2] = (a0 - a_min) / j_max + t;
                p[3] = 0.0;
                p[4] = 0.0;
                p[5] = h3_acc1 - (2.0 * a0 + j_max * t) * t / a_min;
                p[6] = (af - a_min) / j_max;
            }
            if self.accept(RL::Acc1, true, l) && return_after_found {
                return;
            }
        }
    }

    fn time_acc1_vel_two_step(&mut self, l: Lim) {
        let Lim { v_max, a_min, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_a0, a0_p3, af_af, af_p3, af_p4) = (self.a0_a0, self.a0_p3, self.af_af, self.af_p3, self.af_p4);
        let (vf_vf, jj) = (self.vf_vf, self.j_max_j_max);
        {
            let t = &mut self.cur().t;
            t[0] = 0.0;
            t[1] = 0.0;
            t[2] = a0 / j_max;
            t[3] = -(3.0 * af_p4 - 8.0 * a_min * (af_p3 - a0_p3) - 24.0 * a_min * j_max * (a0 * v0 - af * vf)
                + 6.0 * af_af * (a_min * a_min - 2.0 * j_max * vf)
                - 12.0
                    * j_max
                    * (2.0 * a_min * j_max * pd
                        + a_min * a_min * (vf + v_max)
                        + j_max * (v_max * v_max - vf_vf)
                        + a_min * a0 * (a0_a0 - 2.0 * j_max * (v0 + v_max)) / j_max))
                / (24.0 * a_min * jj * v_max);
            t[4] = -a_min / j_max;
            t[5] = -(af_af / 2.0 - a_min * a_min + j_max * (v_max - vf)) / (a_min * j_max);
            t[6] = t[4] + af / j_max;
        }
        self.accept(RL::Acc1Vel, false, l);
    }

    fn time_acc0_two_step(&mut self, l: Lim) {
        let Lim { a_max, a_min, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_a0, a0_p3, a0_p4, af_af, af_p3, af_p4) =
            (self.a0_a0, self.a0_p3, self.a0_p4, self.af_af, self.af_p3, self.af_p4);
        let (v0_v0, vf_vf, jj) = (self.v0_v0, self.vf_vf, self.j_max_j_max);

        // Two steps.
        self.cur().t = [
            0.0,
            (af_af - a0_a0 + 2.0 * j_max * (vf - v0)) / (2.0 * a0 * j_max),
            (a0 - af) / j_max,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        if self.accept(RL::Acc0, false, l) {
            return;
        }

        // Three steps, without pf.
        self.cur().t = [
            (-a0 + a_max) / j_max,
            (a0_a0 + af_af - 2.0 * a_max * a_max + 2.0 * j_max * (vf - v0)) / (2.0 * a_max * j_max),
            (-af + a_max) / j_max,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        if self.accept(RL::Acc0, false, l) {
            return;
        }

        // Three steps, without a_max.
        {
            let h0 = 3.0 * (af_af - a0_a0 + 2.0 * j_max * (v0 + vf));
            let h2 = a0_p3 + 2.0 * af_p3 + 6.0 * jj * pd + 6.0 * (af - a0) * j_max * vf - 3.0 * a0 * af_af;
            let h1 = (2.0
                * (2.0 * h2 * h2
                    + h0 * (a0_p4 - 6.0 * a0_a0 * (af_af + 2.0 * j_max * vf)
                        + 8.0 * a0 * (af_p3 + 3.0 * jj * pd + 3.0 * af * j_max * vf)
                        - 3.0 * (af_p4 + 4.0 * af_af * j_max * vf + 4.0 * jj * (vf_vf - v0_v0)))))
                .sqrt()
                * j_max.abs()
                / j_max;
            self.cur().t = [
                (4.0 * af_p3 + 2.0 * a0_p3 - 6.0 * a0 * af_af + 12.0 * jj * pd + 12.0 * (af - a0) * j_max * vf + h1)
                    / (2.0 * j_max * h0),
                -h1 / (j_max * h0),
                (-4.0 * a0_p3 - 2.0 * af_p3 + 6.0 * a0_a0 * af + 12.0 * jj * pd - 12.0 * (af - a0) * j_max * v0 + h1)
                    / (2.0 * j_max * h0),
                0.0,
                0.0,
                0.0,
                0.0,
            ];
        }
        if self.accept(RL::Acc0, false, l) {
            return;
        }

        // Three steps with t = (a_max - a_min)/j.
        {
            let t = (a_max - a_min) / j_max;
            self.cur().t = [
                (-a0 + a_max) / j_max,
                (a0_a0 - af_af) / (2.0 * a_max * j_max) + (vf - v0 + j_max * t * t) / a_max - 2.0 * t,
                t,
                0.0,
                0.0,
                0.0,
                (af - a_min) / j_max,
            ];
        }
        self.accept(RL::Acc0, false, l);
    }

    fn time_vel_two_step(&mut self, l: Lim) {
        let Lim { v_max, j_max, .. } = l;
        let (v0, a0, vf, af, pd) = (self.v0, self.a0, self.vf, self.af, self.pd);
        let (a0_p3, af_af, af_p3, jj) = (self.a0_p3, self.af_af, self.af_p3, self.j_max_j_max);
        let h1 = (af_af / (2.0 * jj) + (v_max - vf) / j_max).sqrt();

        // Four steps.
        self.cur().t = [
            -a0 / j_max,
            0.0,
            0.0,
            (af_p3 - a0_p3) / (3.0 * jj * v_max) + (a0 * v0 - af * vf + (af_af * h1) / 2.0) / (j_max * v_max)
                - (vf / v_max + 1.0) * h1
                + pd / v_max,
            h1,
            0.0,
            h1 + af / j_max,
        ];
        if self.accept(RL::Vel, false, l) {
            return;
        }

        // Four steps.
        self.cur().t = [
            0.0,
            0.0,
            a0 / j_max,
            (af_p3 - a0_p3) / (3.0 * jj * v_max)
                + (a0 * v0 - af * vf + (af_af * h1 + a0_p3 / j_max) / 2.0) / (j_max * v_max)
                - (v0 / v_max + 1.0) * a0 / j_max
                - (vf / v_max + 1.0) * h1
                + pd / v_max,
            h1,
            0.0,
            h1 + af / j_max,
        ];
        self.accept(RL::Vel, false, l);
    }

    fn time_none_two_step(&mut self, l: Lim) {
        let j_max = l.j_max;
        let (v0, a0, vf, af) = (self.v0, self.a0, self.vf, self.af);
        // Two steps.
        {
            let h0 = ((self.a0_a0 + self.af_af) / 2.0 + j_max * (vf - v0)).sqrt() * j_max.abs() / j_max;
            self.cur().t = [(h0 - a0) / j_max, 0.0, (h0 - af) / j_max, 0.0, 0.0, 0.0, 0.0];
        }
        if self.accept(RL::None, false, l) {
            return;
        }
        // Single step.
        self.cur().t = [(af - a0) / j_max, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        self.accept(RL::None, false, l);
    }
}

/// Step 1 for one DoF: `profiles[0]` carries the boundary (braked start state, target, brake);
/// the candidates are written to `profiles`. Fills `block`; false if no valid profile exists.
#[allow(clippy::too_many_arguments)]
pub(crate) fn calculate(
    profiles: &mut [Profile; MAX_PROFILES],
    block: &mut Block,
    v_max: f64,
    v_min: f64,
    a_max: f64,
    a_min: f64,
    j_max: f64,
) -> bool {
    let first = &profiles[0];
    let (v0, a0, vf, af) = (first.v[0], first.a[0], first.vf, first.af);
    let pd = first.pf - first.p[0];
    let (a0_a0, af_af) = (a0 * a0, af * af);
    let mut s = Step1 {
        v0,
        a0,
        vf,
        af,
        pd,
        v0_v0: v0 * v0,
        vf_vf: vf * vf,
        a0_a0,
        a0_p3: a0 * a0_a0,
        a0_p4: a0_a0 * a0_a0,
        af_af,
        af_p3: af * af_af,
        af_p4: af_af * af_af,
        j_max_j_max: j_max * j_max,
        profiles,
        n: 0,
    };
    let up = Lim { v_max, v_min, a_max, a_min, j_max };
    let down = up.mirrored();

    if vf.abs() < ZERO && af.abs() < ZERO {
        // A target at rest has no blocked interval: return after the first valid profile,
        // searching in the direction of the target first.
        let l = if pd >= 0.0 { up } else { down };
        if v0.abs() < ZERO && a0.abs() < ZERO && pd.abs() < ZERO {
            s.time_all_none_acc0_acc1(l, true);
        } else {
            for l in [l, l.mirrored()] {
                s.time_all_vel(l);
                if s.n > 0 {
                    break;
                }
                s.time_all_none_acc0_acc1(l, true);
                if s.n > 0 {
                    break;
                }
                s.time_acc0_acc1(l, true);
                if s.n > 0 {
                    break;
                }
            }
        }
    } else {
        s.time_all_none_acc0_acc1(up, false);
        s.time_all_none_acc0_acc1(down, false);
        s.time_acc0_acc1(up, false);
        s.time_acc0_acc1(down, false);
        s.time_all_vel(up);
        s.time_all_vel(down);
    }

    if s.n == 0 {
        // Inputs on the border between cases: profiles with fewer phases.
        for k in 0..8 {
            let l = if k % 2 == 0 { up } else { down };
            match k / 2 {
                0 => s.time_none_two_step(l),
                1 => s.time_acc0_two_step(l),
                2 => s.time_vel_two_step(l),
                _ => s.time_acc1_vel_two_step(l),
            }
            if s.n > 0 {
                break;
            }
        }
    }
    let n = s.n;
    block.calculate(&mut profiles[..], n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Minimum duration from `[p0, v0, a0]` to `[pf, vf, af]` under symmetric limits `[v, a, j]`.
    fn t_min(start: [f64; 3], target: [f64; 3], [v, a, j]: [f64; 3]) -> f64 {
        let mut profiles = [Profile::default(); MAX_PROFILES];
        profiles[0].set_boundary(start[0], start[1], start[2], target[0], target[1], target[2]);
        let mut block = Block::default();
        assert!(calculate(&mut profiles, &mut block, v, -v, a, -a, j), "no profile");
        block.t_min
    }

    #[test]
    fn rest_to_rest_textbook_durations() {
        // Long move: ramp 1 s (v reaches 1 exactly), cruise, mirrored: T = 4 + (10 - 2)/1.
        assert!((t_min([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [1.0, 1.0, 1.0]) - 12.0).abs() < 1e-12);
        // No limit reached: d = 2 → T = 4.
        assert!((t_min([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 1.0, 1.0]) - 4.0).abs() < 1e-12);
        assert!((t_min([0.0, 0.0, 0.0], [-2.0, 0.0, 0.0], [1.0, 1.0, 1.0]) - 4.0).abs() < 1e-12);
        // Tiny move: T = 4 (d/2)^(1/3).
        let d = 1e-9;
        assert!((t_min([0.0, 0.0, 0.0], [d, 0.0, 0.0], [1.0, 1.0, 1.0]) - 4.0 * (d / 2.0f64).cbrt()).abs() < 1e-12);
    }

    #[test]
    fn acceleration_limited_move() {
        // v_max large, a_max 1, j_max 10: trapezoidal acceleration, ramps of 0.1 s.
        let t = t_min([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [100.0, 1.0, 10.0]);
        // Each half: v_p = (t_h + 0.1), distance 1/2 = v_p (t_h + 0.2)/2.
        let th = (-0.3 + (0.09f64 - 4.0 * (0.02 - 1.0)).sqrt()) / 2.0;
        assert!((t - 2.0 * (th + 0.2)).abs() < 1e-12, "{t} vs {}", 2.0 * (th + 0.2));
    }

    #[test]
    fn zero_motion_is_zero_duration() {
        assert_eq!(t_min([3.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 1.0, 1.0]), 0.0);
    }
}
