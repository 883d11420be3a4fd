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
//! ```

use interpd::config::Config;
use interpd_config::PrepMethod;
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::Planner;
use interpd_motion::planner::profile::{Cursor, duration_s};
use interpd_motion::prep::{PrepStats, prepare_path};
use interpd_motion::program;
use plotters::prelude::*;
use sim_plant::{AxisTarget, Plant};
use std::io::Write;

static FONT: &[u8] = include_bytes!("../../sim-plant/assets/DejaVuSans.ttf");

fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` before its first G1 block.
fn with_mode(text: &str, word: &str) -> String {
    let mut out = String::new();
    let mut inserted = false;
    for line in text.lines() {
        if !inserted && line.starts_with("G1") {
            out.push_str(word);
            out.push('\n');
            inserted = true;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The programmed path as a fine polyline in X, Y (chord sag on the GKG's 20 mm arc at this
/// step: 0.05² / (8 · 20) mm = 0.016 µm).
struct Reference {
    pts: Vec<(f64, f64)>,
}

const REFERENCE_STEP_MM: f64 = 0.05;

impl Reference {
    fn new(path: &Path) -> Self {
        let mut d = AxisDerivs::default();
        let mut pts = Vec::new();
        let mut s0 = 0.0;
        for e in &path.elements {
            let len = e.geometry.length_mm();
            let n = (len / REFERENCE_STEP_MM).ceil().max(1.0) as usize;
            for i in 0..=n {
                e.geometry.eval(len * i as f64 / n as f64, &mut d);
                pts.push((d.pos[0], d.pos[1]));
            }
            s0 += len;
        }
        let _ = s0;
        Self { pts }
    }

    fn distance(&self, x: f64, y: f64) -> f64 {
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

/// Settling time simulated after the motion ends, s.
const SETTLE_S: f64 = 0.2;

struct Figures {
    duration_s: f64,
    setpoint_max_mm: f64,
    load_max_mm: f64,
    excitation_max_mm: f64,
    excitation_rms_mm: f64,
    /// (t, excitation) per cycle, for the plot.
    trace: Vec<(f64, f64)>,
}

fn simulate(config: &Config, path: &Path, reference: &Reference) -> Figures {
    let (segments, _) = Planner::plan_path(&Settings::from(config), path).expect("plans");
    let duration = duration_s(&segments);
    let mut plant = Plant::from_config(config).expect("plant");
    let n = path.n_axes;
    let cycle = config.cycle_s();
    let mut cursor = Cursor::default();
    let mut d = AxisDerivs::default();
    let (mut sp_max, mut load_max, mut ex_max, mut ex_sq, mut count) = (0.0f64, 0.0f64, 0.0f64, 0.0, 0usize);
    let steps = ((duration + SETTLE_S) / cycle).ceil() as usize;
    let mut targets = vec![AxisTarget::default(); n];
    let mut trace = Vec::with_capacity(steps + 1);
    for k in 0..=steps {
        let t = k as f64 * cycle;
        let Some(sample) = cursor.sample(&segments, t) else { break };
        let st = sample.state;
        if sample.at_start {
            path.eval(st.s_mm, &mut d)
        } else {
            path.eval_left(st.s_mm, &mut d)
        }
        for (i, tg) in targets.iter_mut().enumerate() {
            *tg = AxisTarget { pos: d.pos[i], vel: d.d1[i] * st.v, acc: d.d2[i] * st.v * st.v + d.d1[i] * st.a };
        }
        let out = plant.advance_to((t * 1e9).round() as u64, &targets).expect("plant step");
        let sp = reference.distance(d.pos[0], d.pos[1]);
        let load = reference.distance(out[0].load_pos, out[1].load_pos);
        sp_max = sp_max.max(sp);
        load_max = load_max.max(load);
        ex_max = ex_max.max((load - sp).abs());
        ex_sq += (load - sp) * (load - sp);
        count += 1;
        trace.push((t, load - sp));
    }
    Figures {
        duration_s: duration,
        setpoint_max_mm: sp_max,
        load_max_mm: load_max,
        excitation_max_mm: ex_max,
        excitation_rms_mm: (ex_sq / count.max(1) as f64).sqrt(),
        trace,
    }
}

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
    let tol: f64 = std::env::var("PREP_METHODS_TOL").ok().and_then(|v| v.parse().ok()).unwrap_or(0.1);
    let png = std::env::var("PREP_METHODS_PNG").unwrap_or_else(|_| {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/prep_methods.png").display().to_string()
    });
    let text =
        format!("{}\n[plant]\npreset = \"{plant}\"\napply_crosstalk = true\n", interpd::config::DEFAULT_MACHINE_TOML);
    let config = Config::from_toml_str(&text, &format!("<default machine, {plant} plant>")).expect("machine");
    let mut out = std::io::stdout().lock();
    writeln!(out, "plant {plant}, G64 P{tol}; thesis: Haas 2012 Table 4.8 (VNCK, 0.1 mm)").ok();
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
