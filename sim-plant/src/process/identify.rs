//! A static load test on the simulated plant, as Schneider 2016 identified the robot's joint
//! stiffness (§4.1.2: known loads applied, the deflection measured with the optical tracker):
//! loads step up and down through both flanks of the backlash, at each one the plant settles and
//! the measured tool position and force signal are averaged, with the measurement's noise and
//! the force signal's drift. Lines through the points above and below the zero-load zone give
//! the stiffnesses, the backlash and the zero-load point of the eq. 4.1 model. The compensation
//! gets these identified values, never the plant's parameters.

use crate::PlantError;
use crate::plant::{AxisTarget, Plant};
use interpd_protocol::MAX_AXES;
use interpd_protocol::shm::Measurement;

/// Loads of the test, N: up through the positive flank, down through the negative one, back.
pub const LOADS_N: [f64; 17] = [
    0.0, 75.0, 150.0, 225.0, 300.0, 225.0, 150.0, 75.0, 0.0, -75.0, -150.0, -225.0, -300.0, -225.0, -150.0, -75.0, 0.0,
];
/// Points with |load| below this are in or near the backlash zone and left out of the lines, N.
pub const LINE_MIN_N: f64 = 50.0;
/// Settling time at each load (the 6 Hz mode with ζ = 0.03 decays by e⁻⁵ in 4.4 s), s.
pub const SETTLE_S: f64 = 5.0;
/// Averaging time at each load, s (about 430 position samples).
pub const AVERAGE_S: f64 = 1.0;

/// The identified model of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Identified {
    /// Stiffness above / below the zero-load point, N/mm.
    pub k_pos_n_per_mm: f64,
    pub k_neg_n_per_mm: f64,
    /// Backlash, mm.
    pub gap_mm: f64,
    /// Zero-load point, N.
    pub zero_load_n: f64,
    /// Measured points: (force signal, N; displacement, mm).
    pub points: [(f64, f64); LOADS_N.len()],
}

/// Runs the test on every axis in `axes` of `plant`, one axis at a time (a load along one
/// axis, as a crane pulls in one direction; what it moves on the other axes is not looked at),
/// the plant at rest at 0; needs `[plant.measurement]`.
pub fn static_load_test(plant: &mut Plant, axes: &[usize], dt_s: f64) -> Result<Vec<Identified>, PlantError> {
    if !plant.has_sensors() {
        return Err(PlantError::Input("the static load test needs [plant.measurement]".into()));
    }
    let n = plant.n_axes();
    let still = [AxisTarget::default(); MAX_AXES];
    plant.step(&still[..n], dt_s)?;
    let mut out = Vec::with_capacity(axes.len());
    let mut m = Measurement::default();
    for &i in axes {
        let mut points = [(0.0, 0.0); LOADS_N.len()];
        for (li, &load) in LOADS_N.iter().enumerate() {
            // The process force pushes towards negative positions: a load along +axis is −F.
            plant.set_process_force(i, Some(-load));
            let settle = (SETTLE_S / dt_s).round() as usize;
            let average = (AVERAGE_S / dt_s).round() as usize;
            let (mut force, mut pos, mut count) = (0.0, 0.0, 0usize);
            for k in 0..settle + average {
                plant.step(&still[..n], dt_s)?;
                while plant.pop_measurement(&mut m) {
                    if k >= settle {
                        force += m.force_n[i];
                        pos += m.tool_pos[i];
                        count += 1;
                    }
                }
            }
            let c = count.max(1) as f64;
            points[li] = (force / c, pos / c);
        }
        plant.set_process_force(i, None);
        out.push(fit(points));
    }
    Ok(out)
}

/// Least-squares line y = a + b x through `pts`.
fn line(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}

fn fit(points: [(f64, f64); LOADS_N.len()]) -> Identified {
    let above: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.0 >= LINE_MIN_N).collect();
    let below: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.0 <= -LINE_MIN_N).collect();
    let (c_pos, s_pos) = line(&above);
    let (c_neg, s_neg) = line(&below);
    // Lines u/k₊ + g/2 and u/k₋ − g/2 in u = F − F₀: c₊ = −F₀/k₊ + g/2, c₋ = −F₀/k₋ − g/2.
    let f0 = -(c_pos + c_neg) / (s_pos + s_neg);
    let gap = c_pos - c_neg - f0 * (s_neg - s_pos);
    Identified { k_pos_n_per_mm: 1.0 / s_pos, k_neg_n_per_mm: 1.0 / s_neg, gap_mm: gap, zero_load_n: f0, points }
}
