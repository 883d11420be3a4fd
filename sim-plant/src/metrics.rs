//! Evaluation of a run: following error, load error, contour error (distance of the load
//! point from the programmed path), residual vibration after the motion ends and the spectrum
//! of the load error.
//!
//! [`Metrics`] records one sample per setpoint into preallocated ring buffers (no allocation
//! per sample) and keeps running maxima over the whole run; [`Metrics::summary`] evaluates the
//! recording.

use crate::axis::AxisOutput;
use interpd_config::{AxisKind, AxisLetter};
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use std::collections::VecDeque;
use std::fmt;

/// Removes the least-squares straight line from `x`.
pub fn detrend(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let nf = n as f64;
    let mean_i = (nf - 1.0) / 2.0;
    let mean_x = x.iter().sum::<f64>() / nf;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, &v) in x.iter().enumerate() {
        let di = i as f64 - mean_i;
        sxy += di * (v - mean_x);
        sxx += di * di;
    }
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    x.iter().enumerate().map(|(i, &v)| v - mean_x - slope * (i as f64 - mean_i)).collect()
}

/// One-sided amplitude spectrum of `x` sampled every `dt_s`: Hann window, zero padding to at
/// least 16× the length (power of two). Returns (frequency Hz, amplitude in the unit of x).
pub fn spectrum(x: &[f64], dt_s: f64) -> Vec<(f64, f64)> {
    let n = x.len();
    if n < 4 || dt_s.is_nan() || dt_s <= 0.0 {
        return Vec::new();
    }
    let n_fft = (16 * n).next_power_of_two();
    let mut buf: Vec<Complex<f64>> = vec![Complex::new(0.0, 0.0); n_fft];
    let mut wsum = 0.0;
    for (i, &v) in x.iter().enumerate() {
        let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
        wsum += w;
        buf[i] = Complex::new(v * w, 0.0);
    }
    let fft = FftPlanner::new().plan_fft_forward(n_fft);
    fft.process(&mut buf);
    let df = 1.0 / (n_fft as f64 * dt_s);
    buf[..n_fft / 2].iter().enumerate().map(|(k, c)| (k as f64 * df, 2.0 * c.norm() / wsum)).collect()
}

/// Frequency of the largest spectral peak within [`f_lo`, `f_hi`] Hz, refined by a parabola
/// through the three bins around it; `None` for an empty band or a zero signal.
pub fn peak_frequency(spec: &[(f64, f64)], f_lo: f64, f_hi: f64) -> Option<f64> {
    let (k, (_, amp)) = spec
        .iter()
        .enumerate()
        .filter(|(_, (f, _))| *f >= f_lo && *f <= f_hi)
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1))?;
    // Only a local maximum is a peak: a spectrum falling from the band edge (a decay, not an
    // oscillation) has none.
    let rises_to = |j: usize| spec.get(j).is_none_or(|s| s.1 < *amp);
    if *amp <= 0.0 || (k > 0 && !rises_to(k - 1)) || !rises_to(k + 1) {
        return None;
    }
    if k == 0 || k + 1 >= spec.len() {
        return Some(spec[k].0);
    }
    let (a, b, c) = (spec[k - 1].1, spec[k].1, spec[k + 1].1);
    let denom = a - 2.0 * b + c;
    let offset = if denom != 0.0 { 0.5 * (a - c) / denom } else { 0.0 };
    let df = spec[1].0 - spec[0].0;
    Some(spec[k].0 + offset.clamp(-0.5, 0.5) * df)
}

/// The programmed path as the setpoints sampled it: points, and optionally the velocity at each
/// point with the sample times, which make the path between two points the cubic Hermite
/// curve the drives' fine interpolation follows (instead of the chord, whose sag on an arc of
/// radius r is Δs²/8r: 12 µm for 1 mm per cycle on r = 10 mm).
#[derive(Debug, Clone, Default)]
pub struct SampledPath {
    pub points: Vec<Vec<f64>>,
    /// Velocity at each point (unit/s); empty for straight chords between the points.
    pub velocities: Vec<Vec<f64>>,
    /// Time of each point, s (needed with `velocities`).
    pub t_s: Vec<f64>,
}

/// Path searched for the nearest point to each load point, ± s around its instant: the load
/// lags the setpoint by the position-loop time constant 1/Kv (≤ 0.1 s for Kv ≥ 10/s) plus
/// vibration, so ±0.5 s covers it while keeping the search linear in the recording length.
const CONTOUR_WINDOW_S: f64 = 0.5;

/// Sub-chords per Hermite span in the contour search: the sag of a sub-chord is 1/256 of the
/// span's chord sag.
const HERMITE_SUBDIVISIONS: usize = 16;

impl SampledPath {
    fn has_tangents(&self) -> bool {
        self.velocities.len() == self.points.len() && self.t_s.len() == self.points.len()
    }

    /// Point at fraction `u` ∈ [0, 1] of span `i` (cubic Hermite from positions and velocities).
    fn span_point(&self, i: usize, u: f64, out: &mut [f64]) {
        let h = self.t_s[i + 1] - self.t_s[i];
        let (u2, u3) = (u * u, u * u * u);
        let (h00, h10, h01, h11) = (2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2);
        for (d, o) in out.iter_mut().enumerate() {
            *o = h00 * self.points[i][d]
                + h10 * h * self.velocities[i][d]
                + h01 * self.points[i + 1][d]
                + h11 * h * self.velocities[i + 1][d];
        }
    }

    /// Distance from `p` to span `i`, through [`HERMITE_SUBDIVISIONS`] sub-chords.
    fn span_distance(&self, p: &[f64], i: usize) -> f64 {
        let mut a = self.points[i].clone();
        let mut b = vec![0.0; p.len()];
        let mut best = f64::INFINITY;
        for j in 1..=HERMITE_SUBDIVISIONS {
            self.span_point(i, j as f64 / HERMITE_SUBDIVISIONS as f64, &mut b);
            best = best.min(segment_distance(p, &a, &b));
            std::mem::swap(&mut a, &mut b);
        }
        best
    }
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: &[f64], a: &[f64], b: &[f64]) -> f64 {
    let (mut ab2, mut apab) = (0.0, 0.0);
    for i in 0..p.len() {
        let ab = b[i] - a[i];
        ab2 += ab * ab;
        apab += (p[i] - a[i]) * ab;
    }
    let t = if ab2 > 0.0 { (apab / ab2).clamp(0.0, 1.0) } else { 0.0 };
    let mut d2 = 0.0;
    for i in 0..p.len() {
        let q = a[i] + t * (b[i] - a[i]);
        d2 += (p[i] - q) * (p[i] - q);
    }
    d2.sqrt()
}

/// Contour error of each load point: its distance to the programmed path, searched within
/// `window` spans of the same index (the path sampled at the same instants as the load points,
/// as the setpoint stream is). The nearest chord is found first; with tangents the spans
/// around it are then measured along the Hermite curve.
pub fn contour_errors(load: &[Vec<f64>], path: &SampledPath, window: usize) -> Vec<f64> {
    let n = path.points.len();
    let curved = path.has_tangents();
    load.iter()
        .enumerate()
        .map(|(k, p)| {
            if n == 0 {
                return 0.0;
            }
            if n == 1 {
                return segment_distance(p, &path.points[0], &path.points[0]);
            }
            let lo = k.saturating_sub(window).min(n - 2);
            let hi = (k + window).min(n - 2);
            let (nearest, chord) = (lo..=hi)
                .map(|i| (i, segment_distance(p, &path.points[i], &path.points[i + 1])))
                .fold((lo, f64::INFINITY), |best, c| if c.1 < best.1 { c } else { best });
            if !curved {
                return chord;
            }
            let (a, b) = (nearest.saturating_sub(1), (nearest + 1).min(n - 2));
            (a..=b).map(|i| path.span_distance(p, i)).fold(f64::INFINITY, f64::min)
        })
        .collect()
}

/// Per-axis figures of a run, in the axis unit (mm or deg).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSummary {
    pub name: AxisLetter,
    pub kind: AxisKind,
    pub preset: String,
    /// Over the whole run (not only the recording).
    pub max_following_error: f64,
    pub rms_following_error: f64,
    pub max_load_error: f64,
    pub rms_load_error: f64,
    pub max_motor_force: f64,
    /// Servo samples at the force limit (counted per setpoint output).
    pub saturated_samples: u64,
    /// Largest |detrended load error| after the motion ended (None: no standstill recorded):
    /// settling and vibration together.
    pub residual_amplitude: Option<f64>,
    /// Peak of the load-error spectrum after the motion ended (or over the recording), Hz;
    /// None for a decay without an oscillation.
    pub residual_peak_hz: Option<f64>,
    /// How the load settled after the motion end (None: no standstill recorded).
    pub settling: Option<Settling>,
}

/// The load error after the motion end, split into its settling and its vibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settling {
    /// Time from the motion end until the load error stays within the band around its final
    /// value, s; None if it has not settled by the end of the recording.
    pub settling_time_s: Option<f64>,
    /// The band: [`SETTLE_FRACTION`] of the deviation at the motion end, at least
    /// [`SETTLE_BAND_MIN`], axis unit.
    pub band: f64,
    /// Largest excursion beyond the final value on the far side from the deviation at the
    /// motion end, axis unit (0: an aperiodic approach).
    pub overshoot: f64,
    /// Amplitude of the oscillation at the spectral peak after the motion end, axis unit; None
    /// when the spectrum has no peak (a decay, no vibration).
    pub vibration_amplitude: Option<f64>,
    /// Frequency of that peak, Hz.
    pub vibration_hz: Option<f64>,
    /// Length of the standstill recorded, s.
    pub window_s: f64,
}

/// Settling band: 2 % of the deviation at the motion end, the usual settling criterion.
pub const SETTLE_FRACTION: f64 = 0.02;
/// Smallest settling band, axis unit (1 µm or 1 mdeg): half an encoder step of the robot presets.
pub const SETTLE_BAND_MIN: f64 = 1e-3;

/// Smallest vibration reported, axis unit (10 nm or 10 µdeg): below every encoder step of the
/// presets, a spectral peak this small is numerical noise.
pub const VIBRATION_FLOOR: f64 = 1e-5;

/// Settling and vibration of the load error `x` sampled every `dt_s` from the motion end.
pub fn settling(x: &[f64], dt_s: f64) -> Option<Settling> {
    let n = x.len();
    if n < 16 || dt_s.is_nan() || dt_s <= 0.0 {
        return None;
    }
    // Final value: the mean of the last tenth.
    let tail = (n / 10).max(4);
    let fin = x[n - tail..].iter().sum::<f64>() / tail as f64;
    let dev0 = x[0] - fin;
    let band = (SETTLE_FRACTION * dev0.abs()).max(SETTLE_BAND_MIN);
    let last_out = x.iter().rposition(|v| (v - fin).abs() > band);
    // A tail that still moves by more than the band has not settled, whatever its mean.
    let (lo, hi) = x[n - tail..].iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
    let settling_time_s = match last_out {
        _ if hi - lo > band => None,
        None => Some(0.0),
        Some(k) if k + tail >= n => None,
        Some(k) => Some((k + 1) as f64 * dt_s),
    };
    let sign = if dev0 >= 0.0 { 1.0 } else { -1.0 };
    let overshoot = x.iter().map(|v| -sign * (v - fin)).fold(0.0_f64, f64::max);
    let d = detrend(x);
    let spec = spectrum(&d, dt_s);
    let peak = peak_frequency(&spec, 0.5, 0.5 / dt_s);
    // The amplitude at the bin nearest the refined peak.
    let vibration = peak
        .map(|f| (f, spec.iter().min_by(|a, b| (a.0 - f).abs().total_cmp(&(b.0 - f).abs())).map_or(0.0, |p| p.1)))
        .filter(|(_, amp)| *amp >= VIBRATION_FLOOR);
    Some(Settling {
        settling_time_s,
        band,
        overshoot,
        vibration_amplitude: vibration.map(|v| v.1),
        vibration_hz: vibration.map(|v| v.0),
        window_s: n as f64 * dt_s,
    })
}

/// Figures of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricsSummary {
    pub samples: u64,
    pub duration_s: f64,
    pub axes: Vec<AxisSummary>,
    /// Contour error over the linear axes (recording only), max and rms, mm.
    pub max_contour_error: Option<f64>,
    pub rms_contour_error: Option<f64>,
    /// Time of the motion end used for the residual figures (s since the first sample).
    pub motion_end_s: Option<f64>,
    /// Samples dropped from the front of the recording (older than `[plant] record_s`).
    pub dropped_samples: u64,
}

#[derive(Debug, Clone, Copy, Default)]
struct Running {
    max_fe: f64,
    sum_fe2: f64,
    max_le: f64,
    sum_le2: f64,
    max_force: f64,
    saturated: u64,
}

/// One recorded sample of one axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sample {
    pub setpoint: f64,
    /// Setpoint velocity, unit/s.
    pub setpoint_vel: f64,
    pub motor: f64,
    pub load: f64,
    pub following_error: f64,
    pub load_error: f64,
    /// Tool position (load plus fast actuator), axis unit.
    pub tool: f64,
    /// Fast actuator position from mid-stroke, axis unit.
    pub actuator: f64,
    /// Process force on the load, N (N·m), positive towards negative positions.
    pub process_force: f64,
}

/// Accumulates the plant outputs, one call per setpoint.
#[derive(Debug, Clone)]
pub struct Metrics {
    names: Vec<AxisLetter>,
    kinds: Vec<AxisKind>,
    presets: Vec<String>,
    capacity: usize,
    t: VecDeque<f64>,
    rec: Vec<VecDeque<Sample>>,
    running: Vec<Running>,
    samples: u64,
    t_first: Option<f64>,
    t_last: f64,
    dropped: u64,
}

impl Metrics {
    /// Metrics for the axes of `plant`, recording the last `capacity` samples.
    pub fn new(plant: &crate::Plant, capacity: usize) -> Self {
        let capacity = capacity.max(16);
        let n = plant.n_axes();
        Self {
            names: plant.axes().iter().map(|a| a.name).collect(),
            kinds: plant.axes().iter().map(|a| a.kind).collect(),
            presets: plant.axes().iter().map(|a| a.preset.clone()).collect(),
            capacity,
            t: VecDeque::with_capacity(capacity),
            rec: (0..n).map(|_| VecDeque::with_capacity(capacity)).collect(),
            running: vec![Running::default(); n],
            samples: 0,
            t_first: None,
            t_last: 0.0,
            dropped: 0,
        }
    }

    /// Records the outputs at plant time `t_s`.
    pub fn record(&mut self, t_s: f64, outputs: &[AxisOutput]) {
        if self.t.len() == self.capacity {
            self.t.pop_front();
            for r in &mut self.rec {
                r.pop_front();
            }
            self.dropped += 1;
        }
        self.t.push_back(t_s);
        self.t_first.get_or_insert(t_s);
        self.t_last = t_s;
        self.samples += 1;
        for ((r, run), o) in self.rec.iter_mut().zip(&mut self.running).zip(outputs) {
            r.push_back(Sample {
                setpoint: o.setpoint,
                setpoint_vel: o.setpoint_vel,
                motor: o.motor_pos,
                load: o.load_pos,
                following_error: o.following_error,
                load_error: o.load_error,
                tool: o.tool_pos,
                actuator: o.actuator_pos,
                process_force: o.process_force,
            });
            run.max_fe = run.max_fe.max(o.following_error.abs());
            run.sum_fe2 += o.following_error * o.following_error;
            run.max_le = run.max_le.max(o.load_error.abs());
            run.sum_le2 += o.load_error * o.load_error;
            run.max_force = run.max_force.max(o.motor_force.abs());
            run.saturated += u64::from(o.saturated);
        }
    }

    /// Records the plant's current outputs at its time ([`crate::Plant::time_s`]).
    pub fn record_plant(&mut self, plant: &crate::Plant) {
        self.record(plant.time_s(), plant.outputs());
    }

    pub fn axis_names(&self) -> &[AxisLetter] {
        &self.names
    }
    pub fn axis_kinds(&self) -> &[AxisKind] {
        &self.kinds
    }
    /// Recorded times, s.
    pub fn times(&self) -> Vec<f64> {
        self.t.iter().copied().collect()
    }
    /// Recorded samples of axis `i`.
    pub fn samples(&self, i: usize) -> Vec<Sample> {
        self.rec.get(i).map(|r| r.iter().copied().collect()).unwrap_or_default()
    }
    /// Number of samples recorded over the run.
    pub fn count(&self) -> u64 {
        self.samples
    }

    /// Index in the recording where the last motion ended: after it no setpoint changes.
    /// `None` if the setpoints still move at the end or never moved.
    pub fn motion_end_index(&self) -> Option<usize> {
        let n = self.t.len();
        if n < 2 {
            return None;
        }
        let mut last_change = None;
        for k in 1..n {
            if self.rec.iter().any(|r| r[k].setpoint != r[k - 1].setpoint) {
                last_change = Some(k);
            }
        }
        let k = last_change?;
        (k + 1 < n).then_some(k)
    }

    /// Sample period of the recording (median spacing), s.
    fn dt(&self) -> f64 {
        let mut d: Vec<f64> = self.t.iter().zip(self.t.iter().skip(1)).map(|(a, b)| b - a).collect();
        if d.is_empty() {
            return 0.0;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    }

    /// Load-error spectrum of axis `i` after the motion end (or over the whole recording),
    /// detrended. (Hz, amplitude in the axis unit).
    pub fn load_error_spectrum(&self, i: usize) -> Vec<(f64, f64)> {
        let Some(r) = self.rec.get(i) else { return Vec::new() };
        let start = self.motion_end_index().unwrap_or(0);
        let x: Vec<f64> = r.iter().skip(start).map(|s| s.load_error).collect();
        spectrum(&detrend(&x), self.dt())
    }

    /// Contour errors over the linear axes for the recording (distance of the load point to
    /// the polyline of setpoints), mm. Empty without linear axes.
    pub fn contour_errors(&self) -> Vec<f64> {
        let lin: Vec<usize> = (0..self.kinds.len()).filter(|&i| self.kinds[i] == AxisKind::Linear).collect();
        if lin.is_empty() {
            return Vec::new();
        }
        let n = self.t.len();
        let pt = |k: usize, f: fn(&Sample) -> f64| lin.iter().map(|&i| f(&self.rec[i][k])).collect::<Vec<f64>>();
        let path = SampledPath {
            points: (0..n).map(|k| pt(k, |s| s.setpoint)).collect(),
            velocities: (0..n).map(|k| pt(k, |s| s.setpoint_vel)).collect(),
            t_s: self.times(),
        };
        let load: Vec<Vec<f64>> = (0..n).map(|k| pt(k, |s| s.load)).collect();
        let window = ((CONTOUR_WINDOW_S / self.dt().max(1e-6)) as usize).max(4);
        contour_errors(&load, &path, window)
    }

    /// Evaluates the run.
    pub fn summary(&self) -> MetricsSummary {
        let end = self.motion_end_index();
        let dt = self.dt();
        let axes = (0..self.names.len())
            .map(|i| {
                let run = &self.running[i];
                let n = self.samples.max(1) as f64;
                let (residual_amplitude, residual_peak_hz, settled) = match end {
                    Some(k) if self.t.len() - k >= 16 => {
                        let x: Vec<f64> = self.rec[i].iter().skip(k).map(|s| s.load_error).collect();
                        let d = detrend(&x);
                        let amp = d.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                        let peak = if amp > 0.0 { peak_frequency(&spectrum(&d, dt), 0.5, 0.5 / dt) } else { None };
                        (Some(amp), peak, settling(&x, dt))
                    }
                    _ => (None, None, None),
                };
                AxisSummary {
                    name: self.names[i],
                    kind: self.kinds[i],
                    preset: self.presets[i].clone(),
                    max_following_error: run.max_fe,
                    rms_following_error: (run.sum_fe2 / n).sqrt(),
                    max_load_error: run.max_le,
                    rms_load_error: (run.sum_le2 / n).sqrt(),
                    max_motor_force: run.max_force,
                    saturated_samples: run.saturated,
                    residual_amplitude,
                    residual_peak_hz,
                    settling: settled,
                }
            })
            .collect();
        let ce = self.contour_errors();
        let (max_ce, rms_ce) = if ce.is_empty() {
            (None, None)
        } else {
            let m = ce.iter().fold(0.0_f64, |a, b| a.max(*b));
            let r = (ce.iter().map(|x| x * x).sum::<f64>() / ce.len() as f64).sqrt();
            (Some(m), Some(r))
        };
        MetricsSummary {
            samples: self.samples,
            duration_s: self.t_first.map_or(0.0, |t0| self.t_last - t0),
            axes,
            max_contour_error: max_ce,
            rms_contour_error: rms_ce,
            motion_end_s: end.zip(self.t_first).map(|(k, t0)| self.t[k] - t0),
            dropped_samples: self.dropped,
        }
    }
}

impl fmt::Display for MetricsSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "plant metrics: {} samples over {:.3} s", self.samples, self.duration_s)?;
        writeln!(
            f,
            "{:<4} {:<17} {:>12} {:>12} {:>12} {:>12} {:>10} {:>12} {:>9}",
            "axis", "preset", "max|FE|", "rms FE", "max|LE|", "rms LE", "max|F|", "vibration", "f_vib"
        )?;
        for a in &self.axes {
            // µm for linear axes, mdeg for rotary axes; force or torque.
            let (k, unit, force_unit) = match a.kind {
                AxisKind::Linear => (1e3, "um", "N "),
                AxisKind::Rotary => (1e3, "mdeg", "Nm"),
            };
            let vib = a.settling.and_then(|s| s.vibration_amplitude);
            let res = vib.map_or("-".to_string(), |r| format!("{:.3} {unit}", r * k));
            let fres = a.settling.and_then(|s| s.vibration_hz).map_or("-".to_string(), |h| format!("{h:.2} Hz"));
            writeln!(
                f,
                "{:<4} {:<17} {:>9.3} {unit:<2} {:>9.3} {unit:<2} {:>9.3} {unit:<2} {:>9.3} {unit:<2} {:>8.1} {force_unit} {:>12} {:>9}",
                a.name.to_string(),
                a.preset,
                a.max_following_error * k,
                a.rms_following_error * k,
                a.max_load_error * k,
                a.rms_load_error * k,
                a.max_motor_force,
                res,
                fres
            )?;
        }
        if let (Some(m), Some(r)) = (self.max_contour_error, self.rms_contour_error) {
            writeln!(f, "contour error (linear axes): max {:.3} um, rms {:.3} um", m * 1e3, r * 1e3)?;
        }
        for a in &self.axes {
            let Some(st) = a.settling else { continue };
            let unit = if a.kind == AxisKind::Linear { "um" } else { "mdeg" };
            let settle = st
                .settling_time_s
                .map_or_else(|| format!("not settled within {:.2} s", st.window_s), |t| format!("settled in {t:.3} s"));
            writeln!(
                f,
                "{:<4} after the motion end: {settle} (band ±{:.3} {unit}), overshoot {:.3} {unit}",
                a.name.to_string(),
                st.band * 1e3,
                st.overshoot * 1e3
            )?;
        }
        if let Some(t) = self.motion_end_s {
            writeln!(
                f,
                "motion end at {t:.3} s; vibration = the spectral peak of the load error after it (- for a decay)"
            )?;
        }
        if self.dropped_samples > 0 {
            writeln!(f, "{} older samples dropped from the recording (plant.record_s)", self.dropped_samples)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectrum_finds_a_sine() {
        let dt = 0.004;
        let x: Vec<f64> = (0..1000)
            .map(|i| 0.07 * (2.0 * std::f64::consts::PI * 6.02 * i as f64 * dt).sin() + 1e-3 * i as f64)
            .collect();
        let d = detrend(&x);
        let s = spectrum(&d, dt);
        let f = peak_frequency(&s, 1.0, 100.0).unwrap();
        assert!((f - 6.02).abs() < 0.01, "{f}");
        let amp = s.iter().map(|p| p.1).fold(0.0, f64::max);
        assert!((amp - 0.07).abs() < 0.01, "{amp}");
    }

    #[test]
    fn a_decay_settles_without_vibration_and_a_ringing_has_both() {
        let dt = 0.004;
        // Aperiodic decay from 45 µm, time constant 1 s, recorded for 1 s: still moving.
        let decay: Vec<f64> = (0..250).map(|i| 0.045 * (-(i as f64) * dt).exp()).collect();
        let s = settling(&decay, dt).unwrap();
        // Excursions within the band are the final value's estimate, not an overshoot.
        assert!(s.vibration_amplitude.is_none() && s.overshoot < s.band, "{s:?}");
        assert!(s.settling_time_s.is_none(), "the tail still moves by more than 1 µm: {s:?}");
        // Time constant 0.3 s over 4 s: the final value ≈ 0, the band 1 µm (its floor), so it
        // settles where 45 µm · e^{−t/0.3} = 1 µm, t = 1.14 s.
        let long: Vec<f64> = (0..1000).map(|i| 0.045 * (-(i as f64) * dt / 0.3).exp()).collect();
        let t = settling(&long, dt).unwrap().settling_time_s.unwrap();
        assert!((t - 1.142).abs() < 0.01, "{t}");
        // A ringing at 6 Hz around 0, 20 µm, slowly decaying.
        let ring: Vec<f64> = (0..500)
            .map(|i| {
                let t = i as f64 * dt;
                0.02 * (-t / 3.0).exp() * (2.0 * std::f64::consts::PI * 6.0 * t).cos()
            })
            .collect();
        let s = settling(&ring, dt).unwrap();
        assert!((s.vibration_hz.unwrap() - 6.0).abs() < 0.1, "{s:?}");
        assert!(s.vibration_amplitude.unwrap() > 0.005 && s.overshoot > 0.015, "{s:?}");
    }

    #[test]
    fn contour_error_of_a_parallel_offset() {
        let path = SampledPath { points: (0..100).map(|i| vec![i as f64, 0.0]).collect(), ..Default::default() };
        let load: Vec<Vec<f64>> = (0..100).map(|i| vec![i as f64 - 0.5, 0.01]).collect();
        let e = contour_errors(&load, &path, 3);
        assert!(e[10..].iter().all(|x| (x - 0.01).abs() < 1e-12));
    }

    #[test]
    fn contour_error_on_a_circle_follows_the_arc_not_the_chords() {
        // r = 10 mm at 250 mm/s sampled every 4 ms: 1 mm chords sag 12.5 µm.
        let (r, w, dt) = (10.0, 25.0, 0.004);
        let n = 300;
        let t_s: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let at = |t: f64, rr: f64| vec![rr * (w * t).cos(), rr * (w * t).sin()];
        let path = SampledPath {
            points: t_s.iter().map(|&t| at(t, r)).collect(),
            velocities: t_s.iter().map(|&t| vec![-r * w * (w * t).sin(), r * w * (w * t).cos()]).collect(),
            t_s: t_s.clone(),
        };
        // Load points 5 µm inside the circle, half a cycle late.
        let load: Vec<Vec<f64>> = t_s.iter().map(|&t| at(t - dt / 2.0, r - 0.005)).collect();
        let e = contour_errors(&load, &path, 10);
        assert!(e[5..].iter().all(|x| (x - 0.005).abs() < 1e-5), "{:?}", &e[5..10]);
        let chords = contour_errors(&load, &SampledPath { points: path.points.clone(), ..Default::default() }, 10);
        assert!(chords[5..].iter().all(|x| (x - 0.005).abs() > 2e-3), "chords sag: {:?}", &chords[5..10]);
    }
}
