//! PNG plot of a recorded run: setpoint and load position, following error, load error,
//! contour error and the load-error spectrum.
//!
//! Drawn with plotters' bitmap backend and the embedded DejaVu Sans (ab_glyph), so it needs no
//! system font libraries. Long recordings are reduced to a min/max envelope per pixel column,
//! so peaks survive the decimation.

use crate::PlantError;
use crate::metrics::{Metrics, Sample, peak_frequency};
use interpd_config::AxisKind;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// DejaVu Sans (license in `assets/LICENSE-DejaVuSans.txt`), registered as plotters'
/// `sans-serif` family.
static FONT_TTF: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Axis colours (colour-blind-safe Okabe–Ito palette).
const COLORS: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(120, 120, 120),
    RGBColor(0, 0, 0),
];

/// Fraction of the largest amplitude below which spectrum content is left off the panel.
const SPECTRUM_FLOOR: f64 = 0.01;

/// Points kept per time series (two per bucket: its minimum and maximum).
const ENVELOPE_BUCKETS: usize = 1500;

/// Size and title of the plot.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    pub title: String,
    pub width_px: u32,
    pub height_px: u32,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self { title: "sim-plant".to_string(), width_px: 1600, height_px: 1200 }
    }
}

/// Registers the embedded font as plotters' `sans-serif` family (once per process), for this
/// plot and for other plots drawn in the same process (`interpd-sim`'s milling scenario).
pub fn register_font() -> Result<(), PlantError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok =
        *REGISTERED.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_TTF).is_ok());
    if ok { Ok(()) } else { Err(PlantError::Plot("the embedded font could not be loaded".into())) }
}

/// One curve of a panel.
struct Curve {
    label: String,
    color: RGBColor,
    dashed: bool,
    points: Vec<(f64, f64)>,
}

/// Writes the plot of `metrics` to `path` (PNG).
///
/// Panels: setpoint (solid) and load position (dashed) per axis over time; following error;
/// load error; contour error of the linear axes; amplitude spectrum of the load error after
/// the motion end (or over the whole recording when the motion does not end in it).
pub fn write_png(path: &Path, metrics: &Metrics, options: &PlotOptions) -> Result<(), PlantError> {
    let times = metrics.times();
    if times.len() < 2 {
        return Err(PlantError::Plot(format!("{}: nothing to plot, {} samples recorded", path.display(), times.len())));
    }
    if options.width_px < 400 || options.height_px < 300 {
        return Err(PlantError::Plot(format!("plot size {}×{} px is too small", options.width_px, options.height_px)));
    }
    register_font()?;
    let err = |e: &dyn std::fmt::Display| PlantError::Plot(format!("{}: {e}", path.display()));
    let root = BitMapBackend::new(path, (options.width_px, options.height_px)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(&options.title, ("sans-serif", 26)).map_err(|e| err(&e))?;
    let (top, rest) = root.split_vertically(root.dim_in_pixel().1 * 2 / 5);
    let lower = rest.split_evenly((2, 2));

    let t0 = times[0];
    let t: Vec<f64> = times.iter().map(|x| x - t0).collect();
    let t_range = (0.0, t[t.len() - 1]);
    let kinds = metrics.axis_kinds();
    let names = metrics.axis_names();
    let samples: Vec<Vec<Sample>> = (0..names.len()).map(|i| metrics.samples(i)).collect();
    let err_scale = 1e3; // mm → µm, deg → mdeg
    let err_unit = if kinds.contains(&AxisKind::Rotary) { "µm / mdeg" } else { "µm" };
    let pos_unit = if kinds.contains(&AxisKind::Rotary) { "mm / deg" } else { "mm" };

    let mut positions = Vec::new();
    let (mut fe, mut le, mut spectra) = (Vec::new(), Vec::new(), Vec::new());
    for (i, s) in samples.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let name = names[i].to_string();
        let series =
            |f: &dyn Fn(&Sample) -> f64, scale: f64| envelope(&t, &s.iter().map(|x| f(x) * scale).collect::<Vec<_>>());
        positions.push(Curve {
            label: format!("{name} setpoint"),
            color,
            dashed: false,
            points: series(&|x| x.setpoint, 1.0),
        });
        positions.push(Curve { label: format!("{name} load"), color, dashed: true, points: series(&|x| x.load, 1.0) });
        fe.push(Curve { label: name.clone(), color, dashed: false, points: series(&|x| x.following_error, err_scale) });
        le.push(Curve { label: name.clone(), color, dashed: false, points: series(&|x| x.load_error, err_scale) });
        let spec = metrics.load_error_spectrum(i);
        let nyquist = spec.last().map_or(0.0, |p| p.0);
        let peak = peak_frequency(&spec, 0.5, nyquist).map_or(String::new(), |f| format!(", peak {f:.2} Hz"));
        spectra.push(Curve {
            label: format!("{name}{peak}"),
            color,
            dashed: false,
            points: spec.iter().map(|&(f, a)| (f, a * err_scale)).collect(),
        });
    }
    let contour = metrics.contour_errors();
    let contour_curves = if contour.is_empty() {
        Vec::new()
    } else {
        let c: Vec<f64> = contour.iter().map(|x| x * 1e3).collect();
        vec![Curve { label: "linear axes".into(), color: COLORS[7], dashed: false, points: envelope(&t, &c) }]
    };
    let spec_title = match metrics.summary().motion_end_s {
        Some(te) => format!("Load-error spectrum after the motion end ({te:.2} s), detrended"),
        None => "Load-error spectrum over the recording, detrended".to_string(),
    };
    let f_max = spectrum_range_hz(&spectra);

    panel(&top, "Setpoint (solid) and load position (dashed)", "time [s]", pos_unit, t_range, &positions)
        .map_err(|e| err(&e))?;
    panel(&lower[0], "Following error (setpoint − motor encoder)", "time [s]", err_unit, t_range, &fe)
        .map_err(|e| err(&e))?;
    panel(&lower[1], "Load error (setpoint − load)", "time [s]", err_unit, t_range, &le).map_err(|e| err(&e))?;
    panel(&lower[2], "Contour error (load point to programmed path)", "time [s]", "µm", t_range, &contour_curves)
        .map_err(|e| err(&e))?;
    panel(&lower[3], &spec_title, "frequency [Hz]", &format!("amplitude [{err_unit}]"), (0.0, f_max), &spectra)
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Min/max envelope of `y` over `t` in [`ENVELOPE_BUCKETS`] buckets (all points when fewer).
fn envelope(t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    let n = t.len().min(y.len());
    if n <= 2 * ENVELOPE_BUCKETS {
        return t.iter().zip(y).map(|(&a, &b)| (a, b)).collect();
    }
    let mut out = Vec::with_capacity(2 * ENVELOPE_BUCKETS);
    for b in 0..ENVELOPE_BUCKETS {
        let (lo, hi) = (b * n / ENVELOPE_BUCKETS, ((b + 1) * n / ENVELOPE_BUCKETS).max(b * n / ENVELOPE_BUCKETS + 1));
        let (mut i_min, mut i_max) = (lo, lo);
        for i in lo..hi {
            if y[i] < y[i_min] {
                i_min = i;
            }
            if y[i] > y[i_max] {
                i_max = i;
            }
        }
        let (a, c) = if i_min <= i_max { (i_min, i_max) } else { (i_max, i_min) };
        out.push((t[a], y[a]));
        if c != a {
            out.push((t[c], y[c]));
        }
    }
    out
}

/// Upper frequency of the spectrum panel: 1.5 × the highest frequency where a spectrum still
/// exceeds [`SPECTRUM_FLOOR`] of the largest amplitude, at least 10 Hz, at most Nyquist.
fn spectrum_range_hz(spectra: &[Curve]) -> f64 {
    let nyquist = spectra.iter().filter_map(|c| c.points.last().map(|p| p.0)).fold(0.0, f64::max);
    let top = spectra.iter().flat_map(|c| c.points.iter().map(|p| p.1)).fold(0.0, f64::max);
    let f_hi = spectra
        .iter()
        .flat_map(|c| c.points.iter())
        .filter(|p| p.1 > SPECTRUM_FLOOR * top)
        .map(|p| p.0)
        .fold(0.0, f64::max);
    (1.5 * f_hi).max(10.0).min(nyquist.max(1.0))
}

/// The y range of `curves` with 5 % margin (a unit band around a constant).
fn y_range(curves: &[Curve]) -> (f64, f64) {
    let (lo, hi) = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| (a.min(y), b.max(y)));
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    if span <= 1e-12 * (hi.abs() + lo.abs()).max(1e-300) {
        return (lo - 1.0, hi + 1.0);
    }
    (lo - 0.05 * span, hi + 0.05 * span)
}

/// One line chart with a legend; an empty `curves` draws the frame with a note.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    x_range: (f64, f64),
    curves: &[Curve],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let x_range = if x_range.1 > x_range.0 { x_range } else { (x_range.0, x_range.0 + 1.0) };
    let (y0, y1) = y_range(curves);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x_range.0..x_range.1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    if curves.is_empty() {
        chart.draw_series(std::iter::once(Text::new(
            "no linear axes",
            (x_range.0 + 0.4 * (x_range.1 - x_range.0), 0.5 * (y0 + y1)),
            ("sans-serif", 16),
        )))?;
        return Ok(());
    }
    for c in curves {
        let style = c.color.stroke_width(if c.dashed { 2 } else { 1 });
        let color = c.color;
        if c.dashed {
            chart.draw_series(DashedLineSeries::new(c.points.iter().copied(), 6, 4, style))?
        } else {
            chart.draw_series(LineSeries::new(c.points.iter().copied(), style))?
        }
        .label(c.label.clone())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font(("sans-serif", 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_keeps_the_extremes() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y = vec![0.0; n];
        y[54_321] = 5.0;
        y[12_345] = -3.0;
        let e = envelope(&t, &y);
        assert!(e.len() <= 2 * ENVELOPE_BUCKETS);
        assert!(e.contains(&(54_321.0, 5.0)) && e.contains(&(12_345.0, -3.0)));
        assert!(e.windows(2).all(|w| w[0].0 < w[1].0), "time order");
    }
}
