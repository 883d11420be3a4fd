//! Hermite against the weighted B-spline, continuity degree 2, 3 and 4, on the Haas axis plant:
//! Haas 2012, §4.9–4.11 (Table 4.8, Fig. 4.15–4.17). For the 90° corner and the GKG
//! (line–arc–line) at the thesis's tolerance of 0.1 mm, each method × degree is smoothed,
//! planned, sampled every cycle and run through the plant of `config/plants/haas-laser.toml`
//! (3-mass axes with crosstalk; `PREP_METHODS_PLANT=schneider-stiff` for another preset).
//! Printed: the path time beside the thesis's Table 4.8, the largest lateral deviation of the
//! setpoints and of the TCP from the programmed path, and the excitation as Haas defines it
//! (§3.6.4): the TCP's lateral deviation minus the setpoints' own, per instant (max and rms).
//! A PNG of the excitation over time per shape is written to `target/prep_methods.png`
//! (`PREP_METHODS_PNG=FILE`).
//!
//! ```sh
//! cargo bench -p interpd --bench prep_methods
//! PREP_METHODS_TOL=0.01 PREP_METHODS_PLANT=schneider-stiff cargo bench -p interpd --bench prep_methods
//! PREP_METHODS_POINTS=cumulative cargo bench -p interpd --bench prep_methods   # Haas's eq. 3.13
//! ```

// Shared with `prep_plant`, which builds its reference from the corners it names.
#[path = "common/haas_plant.rs"]
#[allow(dead_code)]
mod haas_plant;
#[path = "common/reference.rs"]
#[allow(dead_code)]
mod reference;

use haas_plant::{Figures, Reference, repo_file, simulate, with_mode};
use interpd::config::Config;
use interpd_config::{PointDistribution, PrepMethod};
use interpd_motion::Settings;
use interpd_motion::prep::{PrepStats, prepare_path};
use interpd_motion::program;
use plotters::prelude::*;
use std::io::Write;

static FONT: &[u8] = include_bytes!("../../sim-plant/assets/DejaVuSans.ttf");

/// Haas 2012, Table 4.8: path time (s) at degree 2, 3, 4 on the Siemens VNCK.
fn thesis_time_s(shape: &str, method: Option<PrepMethod>, degree: u32) -> Option<f64> {
    let row: [f64; 3] = match (shape, method?) {
        ("corner_90", PrepMethod::Hermite) => [0.666, 0.662, 0.662],
        ("corner_90", PrepMethod::Bspline) => [0.662, 0.662, 0.662],
        ("line_arc_line", PrepMethod::Hermite) => [0.462, 0.462, 0.462],
        ("line_arc_line", PrepMethod::Bspline) => [0.466, 0.462, 0.462],
        _ => return None,
    };
    Some(row[degree as usize - 2])
}

struct Row {
    label: String,
    figures: Figures,
    stats: PrepStats,
}

fn main() {
    let plant = std::env::var("PREP_METHODS_PLANT").unwrap_or_else(|_| "haas-laser".into());
    let points = match std::env::var("PREP_METHODS_POINTS").as_deref() {
        Ok("cumulative") => PointDistribution::Cumulative,
        Ok("equidistant") | Err(_) => PointDistribution::Equidistant,
        Ok(other) => panic!("PREP_METHODS_POINTS: \"equidistant\" or \"cumulative\", got {other:?}"),
    };
    let tol: f64 = std::env::var("PREP_METHODS_TOL").ok().and_then(|v| v.parse().ok()).unwrap_or(0.1);
    let png = std::env::var("PREP_METHODS_PNG").unwrap_or_else(|_| {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/prep_methods.png").display().to_string()
    });
    let text =
        format!("{}\n[plant]\npreset = \"{plant}\"\napply_crosstalk = true\n", interpd::config::DEFAULT_MACHINE_TOML);
    let config = Config::from_toml_str(&text, &format!("<default machine, {plant} plant>")).expect("machine");
    let mut out = std::io::stdout().lock();
    writeln!(out, "plant {plant}, G64 P{tol}, {points:?} points; thesis: Haas 2012 Table 4.8 (VNCK, 0.1 mm)").ok();
    writeln!(
        out,
        "{:<14} {:<10} {:>9} {:>8} {:>9} {:>9} {:>10} {:>10} {:>7} {:>7} {:>6}",
        "shape",
        "method",
        "time s",
        "thesis",
        "dev sp mm",
        "dev TCP",
        "exc max mm",
        "exc rms mm",
        "spline",
        "→Herm",
        "exact"
    )
    .ok();
    let mut panels: Vec<(String, Vec<Row>)> = Vec::new();
    for shape in ["corner_90", "line_arc_line"] {
        let source = repo_file(&format!("examples/{shape}.ngc"));
        let base = Settings::from(&config);
        let programmed = program::parse(&source, "bench.ngc", &base).expect("parses").path;
        let reference = Reference::new(&programmed);
        let mut rows = Vec::new();
        // (method, QP degree, Hermite pieces' continuity): Haas's Hermite is C² at every degree;
        // "Hermite C3/C4" are the degree-7/9 pieces.
        let mut variants: Vec<(Option<PrepMethod>, u32, u32)> = vec![(None, 0, 2)];
        for method in [PrepMethod::Hermite, PrepMethod::Bspline] {
            for degree in [2, 3, 4] {
                variants.push((Some(method), degree, 2));
            }
        }
        variants.push((Some(PrepMethod::Hermite), 3, 3));
        variants.push((Some(PrepMethod::Hermite), 4, 4));
        for (method, degree, hermite) in variants {
            let mut settings = Settings::from(&config);
            settings.prep.point_distribution = points;
            let (word, label) = match method {
                None => ("G61".to_string(), "G61".to_string()),
                Some(m) => {
                    settings.prep.method = m;
                    settings.prep.continuity_degree = degree;
                    settings.prep.hermite_continuity = hermite;
                    let name = match m {
                        PrepMethod::Hermite if hermite > 2 => "Hermite C",
                        PrepMethod::Hermite => "Hermite ",
                        PrepMethod::Bspline => "B-spline ",
                    };
                    (format!("G64 P{tol}"), format!("{name}{degree}"))
                }
            };
            let path = program::parse(&with_mode(&source, &word), "bench.ngc", &settings).expect("parses").path;
            let prepared = prepare_path(&settings, &path).expect("smoothing");
            let f = simulate(&config, &prepared.path, &reference);
            let thesis = thesis_time_s(shape, method, degree).map_or("".to_string(), |t| format!("{t:.3}"));
            let st = prepared.stats;
            writeln!(
                out,
                "{shape:<14} {label:<10} {:>9.4} {thesis:>8} {:>9.4} {:>9.4} {:>10.5} {:>10.5} {:>7} {:>7} {:>6}",
                f.duration_s,
                f.setpoint_max_mm,
                f.load_max_mm,
                f.excitation_max_mm,
                f.excitation_rms_mm,
                st.bspline_windows,
                st.bspline_to_hermite,
                st.fallback_exact
            )
            .ok();
            rows.push(Row { label, figures: f, stats: st });
        }
        panels.push((shape.to_string(), rows));
    }
    if let Err(e) = plot(&png, &plant, tol, &panels) {
        eprintln!("plot {png}: {e}");
    } else {
        writeln!(out, "plot: {png}").ok();
    }
}

/// Excitation over time, one panel per shape, one line per method × degree.
fn plot(file: &str, plant: &str, tol: f64, panels: &[(String, Vec<Row>)]) -> Result<(), Box<dyn std::error::Error>> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).map_err(|_| "font")?;
    let root = BitMapBackend::new(file, (1200, 500 * panels.len() as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((panels.len(), 1));
    let colours =
        [BLACK, BLUE, CYAN, GREEN, RED, MAGENTA, RGBColor(255, 140, 0), RGBColor(128, 128, 128), RGBColor(128, 0, 0)];
    for ((shape, rows), area) in panels.iter().zip(areas) {
        let t_max = rows.iter().flat_map(|r| r.figures.trace.last().map(|p| p.0)).fold(0.0, f64::max);
        let e_max = rows.iter().map(|r| r.figures.excitation_max_mm * 1e3).fold(1e-3, f64::max);
        let mut chart = ChartBuilder::on(&area)
            .caption(
                format!("{shape}: excitation (TCP − setpoint lateral deviation), {plant}, G64 P{tol}"),
                ("sans-serif", 20),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_max, -e_max * 1.05..e_max * 1.05)?;
        chart.configure_mesh().x_desc("t / s").y_desc("excitation / µm").label_style(("sans-serif", 14)).draw()?;
        for (i, r) in rows.iter().enumerate() {
            let c = colours[i % colours.len()];
            let label = format!(
                "{} ({:.4} s, max {:.1} µm{})",
                r.label,
                r.figures.duration_s,
                r.figures.excitation_max_mm * 1e3,
                if r.stats.bspline_to_hermite > 0 { ", some Hermite" } else { "" }
            );
            chart
                .draw_series(LineSeries::new(r.figures.trace.iter().map(|&(t, e)| (t, e * 1e3)), c.stroke_width(1)))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
