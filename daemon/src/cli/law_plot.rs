//! A PNG of a law: f, f′, f″, f‴ over z ∈ [0, 1] in four stacked panels, with the conditions
//! on f … f‴ marked and the characteristic values in the panel captions.

use interpd_motion::law::Characteristics;
use interpd_motion::law::Law;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// The embedded font (DejaVu Sans, shipped with sim-plant; licence beside it): plotters' ab_glyph
/// backend draws text with it, so no fontconfig or freetype is needed on the machine.
static FONT: &[u8] = include_bytes!("../../../sim-plant/assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Picture size, px.
const WIDTH_PX: u32 = 1000;
const HEIGHT_PX: u32 = 1200;

pub(super) fn register_font() {
    REGISTER.call_once(|| {
        if plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_err() {
            tracing::warn!("embedded plot font could not be registered; text will be missing");
        }
    });
}

/// Draws the law sampled at `samples` points (≥ 2) into the PNG file `path`.
pub fn write_png(law: &Law, title: &str, path: &Path, samples: usize) -> Result<(), String> {
    register_font();
    let ch = law.characteristics();
    let n = samples.max(2);
    let zs: Vec<f64> = (0..n).map(|k| k as f64 / (n - 1) as f64).collect();
    let values: Vec<[f64; 4]> = zs
        .iter()
        .map(|&z| {
            let d = law.eval(z);
            [d.f, d.f1, d.f2, d.f3]
        })
        .collect();
    let root = BitMapBackend::new(path, (WIDTH_PX, HEIGHT_PX)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| format!("{}: cannot draw: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root.titled(title, ("sans-serif", 26)).map_err(|e| err(&e))?;
    let panels = root.split_evenly((4, 1));
    let colors = [BLUE, RGBColor(0, 140, 0), RED, MAGENTA];
    for (order, area) in panels.iter().enumerate() {
        let caption = caption(order, &ch);
        let series: Vec<(f64, f64)> = zs.iter().zip(&values).map(|(z, v)| (*z, v[order])).collect();
        let (lo, hi) = series.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.1), h.max(p.1)));
        let pad = ((hi - lo) * 0.08).max(1e-9);
        let mut chart = ChartBuilder::on(area)
            .caption(caption, ("sans-serif", 20))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, (lo - pad)..(hi + pad))
            .map_err(|e| err(&e))?;
        chart.configure_mesh().x_desc("z").label_style(("sans-serif", 14)).draw().map_err(|e| err(&e))?;
        chart.draw_series(LineSeries::new(series, colors[order].stroke_width(2))).map_err(|e| err(&e))?;
        let marks = law.conditions().iter().filter(|c| c.order as usize == order);
        chart.draw_series(marks.map(|c| Circle::new((c.z, c.value), 5, BLACK.stroke_width(2)))).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

fn caption(order: usize, ch: &Characteristics) -> String {
    match order {
        0 => format!("f (range {:.4} … {:.4})", ch.f_min.value, ch.f_max.value),
        1 => format!("f′   C_v = {:.4} at z = {:.4}", ch.cv.value, ch.cv.z),
        2 => format!("f″   C_a = {:.4} at z = {:.4}", ch.ca.value, ch.ca.z),
        _ => format!("f‴   C_j = {:.4} at z = {:.4}", ch.cj.value, ch.cj.z),
    }
}
