//! The programmed path as a fine polyline in X, Y and the distance of a point from it: how far
//! setpoints or the simulated tool lie from what the program asked for. Shared by the plant
//! benches (through `haas_plant.rs`) and `daemon/tests/prep_limits.rs`.

use interpd_motion::path::{AxisDerivs, Path};

/// The programmed path as a fine polyline in X, Y (chord sag on the GKG's 20 mm arc at this
/// step: 0.05² / (8 · 20) mm = 0.016 µm).
pub struct Reference {
    pts: Vec<(f64, f64)>,
}

const REFERENCE_STEP_MM: f64 = 0.05;

impl Reference {
    /// The polyline through `corners` itself (shapes of lines only).
    pub fn from_points(corners: &[(f64, f64)]) -> Self {
        Self { pts: corners.to_vec() }
    }

    pub fn new(path: &Path) -> Self {
        let mut d = AxisDerivs::default();
        let mut pts = Vec::new();
        for e in &path.elements {
            let len = e.geometry.length_mm();
            let n = (len / REFERENCE_STEP_MM).ceil().max(1.0) as usize;
            for i in 0..=n {
                e.geometry.eval(len * i as f64 / n as f64, &mut d);
                pts.push((d.pos[0], d.pos[1]));
            }
        }
        Self { pts }
    }

    pub fn distance(&self, x: f64, y: f64) -> f64 {
        self.pts
            .windows(2)
            .map(|w| {
                let ((ax, ay), (bx, by)) = (w[0], w[1]);
                let (dx, dy) = (bx - ax, by - ay);
                let l2 = dx * dx + dy * dy;
                let t = if l2 > 0.0 { (((x - ax) * dx + (y - ay) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
                (x - ax - t * dx).hypot(y - ay - t * dy)
            })
            .fold(f64::INFINITY, f64::min)
    }
}
