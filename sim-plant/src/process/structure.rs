//! The compliance of the structure between the axes and the tool in the cutting plane: a robot
//! arm deforms anisotropically under a process force, so its Cartesian compliance matrix has
//! off-diagonal terms (Schneider 2016, §2.2.4 and §5; the CCT model K_X = J⁻ᵀ K_Θ J⁻¹,
//! eq. 2.9, is not diagonal in the machine's axes). The tool moves away from the load by
//! C·F, where C = R(θ) diag(c₁, c₂) R(θ)ᵀ holds the principal compliances c₁, c₂ along
//! directions turned by θ from the plane's first axis, behind a second-order mode of the
//! structure (frequency, damping), so a force far above the mode (the tooth-passing harmonic)
//! hardly moves the tool. A force along one axis therefore also moves the tool along the other:
//! a deflection model per axis, identified by loading one axis at a time, cannot see that part.

use interpd_config::plant::StructureConfig;
use std::f64::consts::PI;

/// The structure's compliance in one plane, with its mode.
#[derive(Debug, Clone)]
pub struct Structure {
    /// Plant axis indices of the plane's two axes.
    pub axes: [usize; 2],
    /// Compliance matrix in the plane's axes, mm/N.
    c_mm_per_n: [[f64; 2]; 2],
    /// ω² and 2ζω of the mode, 1/s², 1/s.
    omega_sq: f64,
    two_zeta_omega: f64,
    /// Displacement of the tool from the load, mm, and its rate, mm/s.
    x_mm: [f64; 2],
    v_mm_s: [f64; 2],
}

impl Structure {
    pub fn new(c: &StructureConfig, axes: [usize; 2]) -> Self {
        let (s, co) = c.angle_deg.to_radians().sin_cos();
        let [c1, c2] = [c.compliance_um_per_n[0] * 1e-3, c.compliance_um_per_n[1] * 1e-3];
        // R diag(c1, c2) Rᵀ with R the rotation by θ.
        let c_mm_per_n =
            [[c1 * co * co + c2 * s * s, (c1 - c2) * s * co], [(c1 - c2) * s * co, c1 * s * s + c2 * co * co]];
        let omega = 2.0 * PI * c.mode_hz;
        Self {
            axes,
            c_mm_per_n,
            omega_sq: omega * omega,
            two_zeta_omega: 2.0 * c.damping * omega,
            x_mm: [0.0; 2],
            v_mm_s: [0.0; 2],
        }
    }

    /// The compliance matrix in the plane's axes, mm/N.
    pub fn compliance_mm_per_n(&self) -> [[f64; 2]; 2] {
        self.c_mm_per_n
    }

    /// The static displacement under `f_n` (N along the plane's axes), mm.
    pub fn static_mm(&self, f_n: [f64; 2]) -> [f64; 2] {
        let c = &self.c_mm_per_n;
        [c[0][0] * f_n[0] + c[0][1] * f_n[1], c[1][0] * f_n[0] + c[1][1] * f_n[1]]
    }

    /// Standing in equilibrium with `f_n`.
    pub fn reset(&mut self, f_n: [f64; 2]) {
        self.x_mm = self.static_mm(f_n);
        self.v_mm_s = [0.0; 2];
    }

    /// One step of `h_s` under the force `f_n` on the load (N along the plane's axes):
    /// ẍ + 2ζω ẋ + ω² x = ω² C F, semi-implicit Euler (stable for ω h < 2; the servo step is
    /// far below that for modes of a structure).
    #[inline]
    pub fn step(&mut self, f_n: [f64; 2], h_s: f64) {
        let target = self.static_mm(f_n);
        for ((x, v), t) in self.x_mm.iter_mut().zip(&mut self.v_mm_s).zip(target) {
            *v += (self.omega_sq * (t - *x) - self.two_zeta_omega * *v) * h_s;
            *x += *v * h_s;
        }
    }

    /// Displacement of the tool from the load along the plane's axes, mm.
    #[inline]
    pub fn offset_mm(&self) -> [f64; 2] {
        self.x_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(angle_deg: f64) -> StructureConfig {
        StructureConfig { compliance_um_per_n: [0.8, 0.1], angle_deg, ..StructureConfig::default() }
    }

    #[test]
    fn the_compliance_is_symmetric_and_couples_the_axes_unless_aligned() {
        let s = Structure::new(&config(30.0), [0, 1]);
        let c = s.compliance_mm_per_n();
        assert!((c[0][1] - c[1][0]).abs() < 1e-15);
        // (c1 − c2) sin θ cos θ = 0.7e-3 × 0.433.
        assert!((c[0][1] - 0.7e-3 * 30f64.to_radians().sin() * 30f64.to_radians().cos()).abs() < 1e-12);
        // The trace and determinant are those of diag(c1, c2).
        assert!((c[0][0] + c[1][1] - 0.9e-3).abs() < 1e-12);
        assert!((c[0][0] * c[1][1] - c[0][1] * c[1][0] - 0.08e-6).abs() < 1e-15);
        let aligned = Structure::new(&config(0.0), [0, 1]).compliance_mm_per_n();
        assert_eq!(aligned[0][1], 0.0);
    }

    #[test]
    fn a_constant_force_settles_on_the_static_displacement_and_a_fast_one_barely_moves_it() {
        let mut s = Structure::new(&config(30.0), [0, 1]);
        let h = 1e-4;
        for _ in 0..(2.0 / h) as usize {
            s.step([100.0, 0.0], h);
        }
        let want = s.static_mm([100.0, 0.0]);
        let got = s.offset_mm();
        assert!((got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6, "{got:?} {want:?}");
        assert!(got[1] > 0.0, "a force along X moves the tool along Y too");
        // 1 kHz, 25 × the mode: the response is about (40/1000)² of the static one.
        let mut s = Structure::new(&config(30.0), [0, 1]);
        let mut peak: f64 = 0.0;
        for k in 0..(1.0 / h) as usize {
            let f = 100.0 * (2.0 * PI * 1000.0 * k as f64 * h).sin();
            s.step([f, 0.0], h);
            if k as f64 * h > 0.5 {
                peak = peak.max(s.offset_mm()[0].abs());
            }
        }
        assert!(peak < 0.01 * s.static_mm([100.0, 0.0])[0], "{peak}");
    }
}
