//! LinuxCNC's rules for what an arc block may say (2.9: `arc_data_ijk` and `arc_data_r` in
//! its `interp_arc.cc`, the P checks in `interp_check.cc`), so that interpd accepts the arcs
//! LinuxCNC accepts and refuses those it refuses. The tolerances are in the program's units
//! (inches under G20, mm under G21), as LinuxCNC applies them:
//!
//! - Centre form (I J K): the radii to the start (r0) and to the end (r1) may differ by
//!   [`CENTRE_ABS_TOL_IN`] (G20) or [`CENTRE_ABS_TOL_MM`] (G21), or by up to 100 times that
//!   when the difference is within [`CENTRE_REL_TOL`] of the larger radius; either radius below
//!   [`RADIUS_TOL_IN`] / [`RADIUS_TOL_MM`] is a zero-radius arc.
//! - Radius form (R): half the chord may exceed |R| by [`RADIUS_TOL_IN`] / [`RADIUS_TOL_MM`].
//! - P (turns): an integer within 0.001, at least 1.

use super::error::fmt_num;

/// `CENTER_ARC_RADIUS_TOLERANCE_INCH`: 2 · 0.001 · √2 in.
pub(super) const CENTRE_ABS_TOL_IN: f64 = 2.0 * 0.001 * std::f64::consts::SQRT_2;
/// `CENTER_ARC_RADIUS_TOLERANCE_MM`: 2 · 0.01 · √2 mm (ten times the inch value in length).
pub(super) const CENTRE_ABS_TOL_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;
/// `SPIRAL_RELATIVE_TOLERANCE`: 0.1 % of the larger radius.
pub(super) const CENTRE_REL_TOL: f64 = 0.001;
/// `RADIUS_TOLERANCE_INCH`: 0.00005 in.
pub(super) const RADIUS_TOL_IN: f64 = 0.00005;
/// `RADIUS_TOLERANCE_MM`: the inch value in mm, 0.00127 mm.
pub(super) const RADIUS_TOL_MM: f64 = RADIUS_TOL_IN * MM_PER_INCH;
/// `P` must be this close to an integer.
const TURNS_INTEGER_TOL: f64 = 0.001;
const MM_PER_INCH: f64 = 25.4;

/// The program's units: inches when one unit is 25.4 mm.
fn inch(unit_mm: f64) -> bool {
    (unit_mm - MM_PER_INCH).abs() < 1e-9
}

/// The unit's name for messages.
fn unit_name(unit_mm: f64) -> &'static str {
    if inch(unit_mm) { "in" } else { "mm" }
}

/// Centre form: the radii at the start and the end (mm) under the program's unit (mm per
/// unit). Err: the message.
pub(super) fn check_centre_form(r0_mm: f64, r1_mm: f64, unit_mm: f64) -> Result<(), String> {
    let (abs_tol, zero_tol) =
        if inch(unit_mm) { (CENTRE_ABS_TOL_IN, RADIUS_TOL_IN) } else { (CENTRE_ABS_TOL_MM, RADIUS_TOL_MM) };
    let (r0, r1) = (r0_mm / unit_mm, r1_mm / unit_mm);
    let u = unit_name(unit_mm);
    if r0 < zero_tol || r1 < zero_tol {
        return Err(format!(
            "degenerate arc: zero radius (radius {} {u} at the start, {} {u} at the end)",
            fmt_num(r0),
            fmt_num(r1)
        ));
    }
    let abs_err = (r0 - r1).abs();
    let rel_err = abs_err / r0.max(r1);
    if abs_err > 100.0 * abs_tol || (rel_err > CENTRE_REL_TOL && abs_err > abs_tol) {
        return Err(format!(
            "arc end point is not on the circle: radius {} {u} at the start, {} {u} at the end (difference {} {u}; LinuxCNC's limit: {} {u}, or 0.1 % of the radius up to {} {u})",
            fmt_num(r0),
            fmt_num(r1),
            fmt_num(abs_err),
            fmt_num(abs_tol),
            fmt_num(100.0 * abs_tol)
        ));
    }
    Ok(())
}

/// Radius form: half the chord and |R| (mm) under the program's unit. Err: the message.
pub(super) fn check_radius_form(half_chord_mm: f64, r_mm: f64, unit_mm: f64) -> Result<(), String> {
    let tol = if inch(unit_mm) { RADIUS_TOL_IN } else { RADIUS_TOL_MM };
    if (half_chord_mm - r_mm.abs()) / unit_mm > tol {
        let u = unit_name(unit_mm);
        return Err(format!(
            "arc radius R {} {u} is smaller than half the chord ({} {u})",
            fmt_num(r_mm.abs() / unit_mm),
            fmt_num(half_chord_mm / unit_mm)
        ));
    }
    Ok(())
}

/// The number of turns of a P word with G2/G3. Err: the message.
pub(super) fn turns(p: f64) -> Result<u32, String> {
    let n = p.round();
    if (n - p).abs() > TURNS_INTEGER_TOL {
        return Err(format!("P (turns of the arc) must be an integer, got {}", fmt_num(p)));
    }
    if n < 1.0 {
        return Err(format!("P (turns of the arc) must be 1 or more, got {}", fmt_num(p)));
    }
    if n > f64::from(MAX_TURNS) {
        return Err(format!("P (turns of the arc) must be at most {MAX_TURNS}, got {}", fmt_num(p)));
    }
    Ok(n as u32)
}

/// More turns than this are refused: a path element of thousands of turns is a typo, and the
/// planner takes an arc as one element.
pub(super) const MAX_TURNS: u32 = 1000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_decimal_inch_arcs_pass_and_mm_arcs_have_ten_times_the_length() {
        // 0.0025 mm off on a 10 mm radius (0.0001 in): within 0.0028 in, within 0.028 mm.
        assert!(check_centre_form(10.0, 10.0025, 25.4).is_ok());
        assert!(check_centre_form(10.0, 10.0025, 1.0).is_ok());
        // 0.05 mm off on 10 mm: 0.5 % > 0.1 % and 0.05 mm > 0.028 mm (G21) but < 0.072 mm (G20).
        assert!(check_centre_form(10.0, 10.05, 1.0).is_err());
        assert!(check_centre_form(10.0, 10.05, 25.4).is_ok());
        // Large radii: 0.1 % of 2000 mm is 2 mm, but at most 100 × 0.028 mm = 2.83 mm.
        assert!(check_centre_form(2000.0, 2001.9, 1.0).is_ok());
        assert!(check_centre_form(3000.0, 3002.9, 1.0).is_err());
        assert!(check_centre_form(0.0001, 0.0001, 1.0).is_err());
    }

    #[test]
    fn radius_form_and_turns() {
        assert!(check_radius_form(5.001, 5.0, 1.0).is_ok());
        assert!(check_radius_form(5.002, 5.0, 1.0).is_err());
        assert!(check_radius_form(5.001, 5.0, 25.4).is_ok());
        assert_eq!(turns(2.0005), Ok(2));
        assert!(turns(1.5).is_err());
        assert!(turns(0.0).is_err());
    }
}
