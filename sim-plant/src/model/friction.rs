//! Coulomb friction, solved implicitly per step (stick/slip without chattering).
//!
//! Friction is Coulomb plus viscous, both user parameters (Schneider 2016 names stick/slip
//! friction among the error sources without a value); the viscous part is linear and lives in
//! the system matrix. The Coulomb force F ∈ [−F_c, F_c] is chosen per step like a
//! velocity-level (Moreau) time-stepping scheme: with `v_free` the end-of-step velocity without
//! friction and `gain` the end-of-step velocity per newton of force held over the step (an
//! entry of Γ), the force stops the mass if it can (stick), else it is −F_c·sign(v) (slip).
//! This never injects energy and needs no smoothing velocity.

/// Friction force for one step. `gain` > 0 is ∂v_end/∂F; `f_c` ≥ 0 the Coulomb level.
#[inline]
pub fn coulomb_force(v_free: f64, gain: f64, f_c: f64) -> f64 {
    if f_c <= 0.0 || gain <= 0.0 {
        return 0.0;
    }
    let stop = -v_free / gain;
    stop.clamp(-f_c, f_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sticks_when_it_can_and_slides_otherwise() {
        // 1 kg, 1 ms step: gain = 1e-3 (m/s)/N. 10 N can remove 0.01 m/s.
        assert_eq!(coulomb_force(0.005, 1e-3, 10.0), -5.0);
        assert_eq!(coulomb_force(0.5, 1e-3, 10.0), -10.0);
        assert_eq!(coulomb_force(-0.5, 1e-3, 10.0), 10.0);
        assert_eq!(coulomb_force(0.5, 1e-3, 0.0), 0.0);
    }
}
