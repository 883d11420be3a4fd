//! Refinement of a final profile: Newton iterations on its phase durations (jerks fixed) so that
//! its phases, integrated from the start, end exactly on the target, keep their duration, and
//! hold plateaus at an acceleration limit or at zero exactly.
//!
//! The closed forms of step 1 and step 2 and Ruckig's one or two Newton steps on a root leave end
//! errors up to the check's precision (1e-8), and the check pins plateau accelerations to the
//! values they are known to have, which hides the drift their rounding causes over a long
//! plateau. The sampled trajectory follows the stored states, an integration of the phases does
//! not: the refinement makes both agree to rounding. (Added in interpd; Ruckig has no such
//! step.) The system has 2 to 7 equations (end a, v, p; duration; pins) in the non-empty phase
//! durations and is usually underdetermined: minimum-norm steps, by Householder QR.

use crate::Limits;
use crate::phase::integrate;
use crate::profile::{Candidate, Direction, Profile, magnitude, magnitude_or_one};

/// Refinement runs when a final profile's phases, integrated from the start (pinned plateau
/// accelerations as they come out, unless within rounding), miss the end state by more than
/// this, relative to max(1, magnitude of the quantity along the profile): well above rounding,
/// well below the target precisions.
const REFINE_TRIGGER: f64 = 1e-12;
/// Refinement stops once every scaled residual is below this.
const REFINE_GOAL: f64 = 2.0 * f64::EPSILON;
/// A refined candidate replaces the original only if its scaled residuals are below this.
const REFINE_ACCEPT: f64 = 1e-11;
/// An iteration that does not reduce the residual below this fraction of the best so far made no
/// progress; two in a row end the refinement (the rounding floor).
const REFINE_PROGRESS: f64 = 0.5;
/// Newton iterations of the refinement (quadratic convergence from ~1e-9 needs two).
const REFINE_ITERATIONS: usize = 6;
/// A pinned acceleration this many ulps (of the values it is computed from) off its value is
/// that value: the resolution of the phase durations (the test's integration does the same).
const PIN_ROUNDING_ULPS: f64 = 8.0;
/// A plateau acceleration within this (relative to the acceleration limit) of a limit or of zero
/// is held exactly there by the refinement.
const PIN_DETECT_REL: f64 = 1e-9;

/// One equation of the refinement.
#[derive(Clone, Copy)]
enum Row {
    EndA,
    EndV,
    EndP,
    Duration(f64),
    /// The acceleration at the start of phase `.0` equals its pinned value.
    Pin(usize),
}

/// Solution of the m×n system `J x = r` (m, n ≤ 7) by Householder QR: the minimum-norm solution
/// if it is underdetermined (m ≤ n, QR of Jᵀ), the least-squares one otherwise (QR of J). No
/// normal equations, so the condition number is not squared. `None` if J is rank-deficient.
fn solve_small(jac: &[[f64; 7]; 7], rhs: &[f64; 7], m: usize, n: usize) -> Option<[f64; 7]> {
    // A is rows × cols with rows ≥ cols: Jᵀ (n × m) or J (m × n).
    let transpose = m <= n;
    let (rows, cols) = if transpose { (n, m) } else { (m, n) };
    let mut qr = [[0.0f64; 7]; 7];
    for r in 0..rows {
        for c in 0..cols {
            qr[r][c] = if transpose { jac[c][r] } else { jac[r][c] };
        }
    }
    // Householder vectors are kept below the diagonal, R on and above it.
    let mut diag = [0.0f64; 7];
    let mut column_norm = [0.0f64; 7];
    for (c, norm) in column_norm.iter_mut().enumerate().take(cols) {
        *norm = (0..rows).map(|r| qr[r][c] * qr[r][c]).sum::<f64>().sqrt();
    }
    for k in 0..cols {
        // What is left of column k after removing its components along the previous ones.
        let norm = (k..rows).map(|r| qr[r][k] * qr[r][k]).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= RANK_TOLERANCE * column_norm[k] {
            return None;
        }
        let alpha = if qr[k][k] > 0.0 { -norm } else { norm };
        qr[k][k] -= alpha;
        let vnorm2: f64 = (k..rows).map(|r| qr[r][k] * qr[r][k]).sum();
        for c in k + 1..cols {
            let dot: f64 = (k..rows).map(|r| qr[r][k] * qr[r][c]).sum();
            let f = 2.0 * dot / vnorm2;
            for row in qr.iter_mut().take(rows).skip(k) {
                row[c] -= f * row[k];
            }
        }
        diag[k] = alpha;
        // Store the reflector normalised so that it can be applied later.
        let scale = (2.0 / vnorm2).sqrt();
        for row in qr.iter_mut().take(rows).skip(k) {
            row[k] *= scale;
        }
    }
    let r_at = |r: usize, c: usize| if r == c { diag[r] } else { qr[r][c] };
    let apply_reflector = |x: &mut [f64; 7], k: usize| {
        let dot: f64 = (k..rows).map(|r| qr[r][k] * x[r]).sum();
        for (r, xr) in x.iter_mut().enumerate().take(rows).skip(k) {
            *xr -= dot * qr[r][k];
        }
    };
    let mut x = [0.0f64; 7];
    if transpose {
        // J = Rᵀ Qᵀ: solve Rᵀ y = r (forward), then x = Q [y; 0].
        for c in 0..cols {
            let s: f64 = (0..c).map(|k| r_at(k, c) * x[k]).sum();
            x[c] = (rhs[c] - s) / r_at(c, c);
        }
        for k in (0..cols).rev() {
            apply_reflector(&mut x, k);
        }
    } else {
        // J = Q R: x = R⁻¹ (Qᵀ r)[..n].
        let mut y = *rhs;
        for k in 0..cols {
            apply_reflector(&mut y, k);
        }
        for c in (0..cols).rev() {
            let s: f64 = (c + 1..cols).map(|k| r_at(c, k) * x[k]).sum();
            x[c] = (y[c] - s) / r_at(c, c);
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// A column of the refinement's system whose part independent of the previous columns is
/// shorter than this (relative to its length) makes the system rank-deficient.
const RANK_TOLERANCE: f64 = 1e-13;

impl Profile {
    /// Refine the phase durations of a final profile (see [`Profile::refined_durations`]) if integrating
    /// its phases from the start would miss the target by more than [`REFINE_TRIGGER`]: the
    /// closed forms and Ruckig's root refinement leave up to 1e-8, and a pinned plateau
    /// acceleration hides the drift its rounding causes. The refined profile replaces this one
    /// only if it passes the check again. `duration`: the phases must keep lasting this long.
    pub(crate) fn polish(&mut self, position: bool, duration: Option<f64>, lim: &Limits) {
        let (v_max, v_min, a_max, a_min) = match self.direction {
            Direction::Up => (lim.v_max, lim.v_min, lim.a_max, lim.a_min),
            Direction::Down => (lim.v_min, lim.v_max, lim.a_min, lim.a_max),
        };
        if self.integrates_onto_target(position) {
            return;
        }
        let Some(durations) = self.refined_durations(duration, position, a_max, a_min) else {
            return;
        };
        let mut refined = *self;
        refined.t = durations;
        let c = Candidate {
            signs: self.control_signs,
            limits: self.limits,
            set_limits: false,
            jf: self.ramp_jerk(),
            v_max,
            v_min,
            a_max,
            a_min,
        };
        let ok = if position { refined.check_position(&c) } else { refined.check_velocity(&c) };
        if ok {
            // The check recomputes the bookkeeping; keep what the profile reported before.
            refined.limits = self.limits;
            *self = refined;
        }
    }

    /// Cheap pre-check of [`Profile::polish`]: the stored boundary states equal the integration of
    /// the phases (no acceleration was pinned by more than rounding) and end on the target within
    /// [`REFINE_TRIGGER`].
    fn integrates_onto_target(&self, position: bool) -> bool {
        let unpinned = (0..7).all(|i| {
            let step = self.t[i] * self.j[i];
            let raw = self.a[i] + step;
            (raw - self.a[i + 1]).abs() <= PIN_ROUNDING_ULPS * f64::EPSILON * (self.a[i].abs() + step.abs())
        });
        let near = |x: f64, target: f64, along: &[f64]| {
            let err = (x - target).abs();
            err <= REFINE_TRIGGER || err <= REFINE_TRIGGER * magnitude(along, target)
        };
        unpinned
            && near(self.a[7], self.af, &self.a)
            && near(self.v[7], self.vf, &self.v)
            && (!position || near(self.p[7], self.pf, &self.p))
    }

    /// Newton iterations on the durations of the non-empty phases (jerks fixed) so that the
    /// phases, integrated from the start without any pinning, end exactly on the target, last
    /// `duration` (step 2), and hold plateaus at the acceleration limit or at zero exactly.
    /// Minimum-norm steps: the system is usually underdetermined. Returns the new durations, or
    /// `None` if nothing needs refining, it does not converge, or a duration turns negative.
    fn refined_durations(&self, duration: Option<f64>, position: bool, a_max: f64, a_min: f64) -> Option<[f64; 7]> {
        let mut durations = self.t;
        let mut active = [0usize; 7];
        let mut n = 0;
        for i in 0..7 {
            if self.t[i] > 0.0 {
                active[n] = i;
                n += 1;
            }
        }
        if n == 0 {
            return None;
        }
        let active = &active[..n];
        let a_scale = a_max.abs().max(a_min.abs());
        // Plateaus (hold phases) at a limit or at zero keep that acceleration exactly.
        let mut pins = [(0usize, 0.0f64); 3];
        let mut n_pins = 0;
        for k in [1, 3, 5] {
            if self.t[k] > 0.0 {
                if let Some(value) =
                    [a_max, a_min, 0.0].into_iter().find(|&x| (self.a[k] - x).abs() <= PIN_DETECT_REL * a_scale)
                {
                    pins[n_pins] = (k, value);
                    n_pins += 1;
                }
            }
        }
        let pins = &pins[..n_pins];
        let mut rows = [Row::EndA; 7];
        let mut m = 0;
        let mut add = |row: Row| {
            rows[m] = row;
            m += 1;
        };
        add(Row::EndA);
        add(Row::EndV);
        if position {
            add(Row::EndP);
        }
        if let Some(d) = duration {
            add(Row::Duration(d));
        }
        for &(k, _) in pins {
            add(Row::Pin(k));
        }
        let rows = &rows[..m];

        let mut first_residual = f64::INFINITY;
        let mut best = (f64::INFINITY, durations);
        let mut stalled = 0;
        for iteration in 0..=REFINE_ITERATIONS {
            // Integrate without pinning, except that a pinned acceleration within rounding of its
            // value is that value (durations cannot resolve it any finer; a long plateau after it
            // would otherwise turn the last ulp into a drift).
            let (mut a, mut v, mut p) = ([0.0f64; 8], [0.0f64; 8], [0.0f64; 8]);
            (a[0], v[0], p[0]) = (self.a[0], self.v[0], self.p[0]);
            let mut pin_residual = [0.0f64; 8];
            let mut t_end = [0.0f64; 7];
            let mut total = 0.0;
            for i in 0..7 {
                let (t, j) = (durations[i], self.j[i]);
                (p[i + 1], v[i + 1], a[i + 1]) = integrate(t, p[i], v[i], a[i], j);
                if let Some(&(_, value)) = pins.iter().find(|&&(k, _)| k == i + 1) {
                    let offset = a[i + 1] - value;
                    let rounding = PIN_ROUNDING_ULPS * f64::EPSILON * (a[i].abs() + (t * j).abs());
                    if offset.abs() <= rounding {
                        a[i + 1] = value;
                    } else {
                        pin_residual[i + 1] = offset;
                    }
                }
                total += t;
                t_end[i] = total;
            }
            if iteration == 0 {
                // Off by more than the trigger (relative to max(1, magnitude), like the target
                // precisions)? Otherwise there is nothing to refine.
                let off = |err: f64, target: f64, along: &[f64]| {
                    err > REFINE_TRIGGER && err > REFINE_TRIGGER * magnitude(along, target)
                };
                let missed = off((a[7] - self.af).abs(), self.af, &a)
                    || off((v[7] - self.vf).abs(), self.vf, &v)
                    || (position && off((p[7] - self.pf).abs(), self.pf, &p));
                if !missed {
                    return None;
                }
            }
            let sa = magnitude(&a, self.af).max(a_scale);
            let sv = magnitude_or_one(&v, self.vf);
            let sp = magnitude_or_one(&p, self.pf);
            let mut jac = [[0.0f64; 7]; 7];
            let mut rhs = [0.0f64; 7];
            let mut residual = 0.0f64;
            for (r, row) in rows.iter().enumerate() {
                let (value, scale) = match *row {
                    Row::EndA => (a[7] - self.af, sa),
                    Row::EndV => (v[7] - self.vf, sv),
                    Row::EndP => (p[7] - self.pf, sp),
                    Row::Duration(d) => (total - d, d.max(f64::MIN_POSITIVE)),
                    Row::Pin(k) => (pin_residual[k], sa),
                };
                rhs[r] = -value / scale;
                residual = residual.max((value / scale).abs());
                for (col, &i) in active.iter().enumerate() {
                    let rem = total - t_end[i];
                    let (j, a1, v1) = (self.j[i], a[i + 1], v[i + 1]);
                    let d = match *row {
                        Row::EndA => j,
                        Row::EndV => a1 + j * rem,
                        Row::EndP => v1 + rem * (a1 + j * rem / 2.0),
                        Row::Duration(_) => 1.0,
                        Row::Pin(k) => {
                            if i < k {
                                j
                            } else {
                                0.0
                            }
                        }
                    };
                    jac[r][col] = d / scale;
                }
            }
            if iteration == 0 {
                first_residual = residual;
            }
            // Stop at the rounding floor: once two iterations in a row do not halve the best
            // residual (one may not: the max over rows is no merit function for Newton, a step
            // that fixes one row can raise another by its second-order terms).
            if residual < REFINE_PROGRESS * best.0 {
                stalled = 0;
            } else {
                stalled += 1;
            }
            if residual < best.0 {
                best = (residual, durations);
            }
            if residual <= REFINE_GOAL || stalled >= 2 || iteration == REFINE_ITERATIONS {
                break;
            }
            let delta = solve_small(&jac, &rhs, m, n)?;
            for (col, &i) in active.iter().enumerate() {
                durations[i] += delta[col];
                if durations[i].is_nan() || durations[i] < 0.0 {
                    return None;
                }
            }
        }
        (best.0 < first_residual && best.0 <= REFINE_ACCEPT).then_some(best.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_solver_square_underdetermined_and_overdetermined() {
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][..3].copy_from_slice(&[2.0, 1.0, 0.0]);
        jac[1][..3].copy_from_slice(&[1.0, 3.0, 1.0]);
        jac[2][..3].copy_from_slice(&[0.0, 1.0, 4.0]);
        let mut rhs = [0.0f64; 7];
        rhs[..3].copy_from_slice(&[3.0, 5.0, 5.0]);
        let x = solve_small(&jac, &rhs, 3, 3).unwrap();
        for (got, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((got - want).abs() < 1e-14, "{x:?}");
        }
        // x + y = 2: minimum norm (1, 1).
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][..2].copy_from_slice(&[1.0, 1.0]);
        let mut rhs = [0.0f64; 7];
        rhs[0] = 2.0;
        let x = solve_small(&jac, &rhs, 1, 2).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15, "{x:?}");
        // x = 1, x = 3: least squares 2.
        let mut jac = [[0.0f64; 7]; 7];
        jac[0][0] = 1.0;
        jac[1][0] = 1.0;
        let mut rhs = [0.0f64; 7];
        rhs[..2].copy_from_slice(&[1.0, 3.0]);
        let x = solve_small(&jac, &rhs, 2, 1).unwrap();
        assert!((x[0] - 2.0).abs() < 1e-15, "{x:?}");
    }
}
