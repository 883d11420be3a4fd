//! `interpd demo --scenario milling-circle [--json]`: the circle of Schneider 2016, Tab. 5.1
//! (Ø 70 mm, 300 mm/min, full engagement, start at 12 o'clock, counter-clockwise) milled by the
//! soft robot axis under the process force, once per compensation strategy (`none`,
//! `deflection`, `position`, `position+actuator`), each a run of `interpd run` and `sim-plant`
//! over iceoryx2. The deflection model is identified first from a static load test on the
//! simulated plant, with the measurement's noise (`sim_plant::process::identify`). The figures
//! are taken at the tool, from the plant's true load and actuator positions, where it cut.
//! `interpd` hands the command to `interpd-sim` (the static load test runs the plant
//! in-process).

use interpd::cmdline::CliError;
use interpd::demo::{DemoArgs, Pair};
use interpd_config::Config;
use interpd_config::plant::PlantModel;
use plotters::prelude::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The machine: the soft robot axis on X and Y with the process force, the sensors and the
/// fast actuators.
const MACHINE: &str = include_str!("../../../examples/milling_circle.toml");
/// Circle radius, mm; centre (0, −R): the machine starts at 12 o'clock.
const R_MM: f64 = 35.0;
/// The program: one full circle counter-clockwise at 300 mm/min.
const PROGRAM: &str = "(Schneider 2016, Tab. 5.1: circle 70 mm, 300 mm/min)\nG21 G90 G17\nG3 X0 Y0 I0 J-35 F300\nM30\n";
/// The strategies in the order of the table.
const STRATEGIES: [&str; 4] = ["none", "deflection", "position", "position+actuator"];
/// The tool cuts where the process force is at least this share of its static part (the
/// engagement's rise and fall are left out, as the milled contour has no surface there).
const CUTTING_SHARE: f64 = 0.5;
/// Surface error: the part of the radial error that a moving average over this many samples
/// (1 s, 5 mm of path at 300 mm/min) does not follow.
const SURFACE_WINDOW: usize = 250;
/// Step of the in-process static load test, s (the setpoint cycle).
const ID_STEP_S: f64 = 0.004;

/// The figures of one strategy, µm.
#[derive(Debug, Clone)]
struct Figures {
    name: &'static str,
    roundness_um: f64,
    max_dev_um: f64,
    mae_um: f64,
    surface_std_um: f64,
    /// (angle rad, radial error µm) at the tool where it cut.
    polar: Vec<(f64, f64)>,
}

pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    let plot = if args.plot.as_os_str() == "interpd-demo.png" {
        PathBuf::from("interpd-milling-circle.png")
    } else {
        args.plot.clone()
    };
    let plot = std::path::absolute(&plot).map_err(|e| CliError::BadInput(format!("--plot: {e}")))?;
    let dir = std::env::temp_dir().join(format!("interpd-milling-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::Failure(format!("{}: {e}", dir.display())))?;
    let config = Config::from_toml_str(MACHINE, "milling_circle.toml").map_err(|e| CliError::Failure(e.to_string()))?;
    let force_n = config.plant.milling.as_ref().map_or(0.0, |m| m.force_n);

    // The deflection model from a static load test on the plant, with the measurement noise.
    eprintln!("milling-circle: static load test on X and Y (identifies the deflection model)");
    let mut plant = sim_plant::Plant::from_config(&config).map_err(|e| CliError::Failure(e.to_string()))?;
    let id = sim_plant::process::identify::static_load_test(&mut plant, &[0, 1], ID_STEP_S)
        .map_err(|e| CliError::Failure(e.to_string()))?;
    let truth = plant_truth(&config)?;
    for (i, (axis, m)) in ["X", "Y"].iter().zip(&id).enumerate() {
        eprintln!(
            "milling-circle: {axis}: identified k+ {:.1} N/mm, k- {:.1} N/mm, backlash {:.4} mm, zero load {:.2} N; \
             the plant has {:.1} / {:.1} N/mm along the axis ({:.1} / {:.1} at the axis, the structure {:.3} µm/N \
             on top), {:.4} mm, 0 N, and a cross-coupling of {:.3} µm/N to the other axis that a per-axis model \
             does not have",
            m.k_pos_n_per_mm,
            m.k_neg_n_per_mm,
            m.gap_mm,
            m.zero_load_n,
            1.0 / (1.0 / truth.k_pos + truth.c[i][i] * 1e-3),
            1.0 / (1.0 / truth.k_neg + truth.c[i][i] * 1e-3),
            truth.k_pos,
            truth.k_neg,
            truth.c[i][i],
            truth.gap_mm,
            truth.c[0][1],
        );
    }

    // The four runs go side by side, each its own daemon, plant, service prefix and directory:
    // a run takes 44 s of real time and one daemon with its plant uses a few per cent of a core.
    eprintln!("milling-circle: milling the circle once per strategy, side by side (44 s)");
    let runs: Vec<Result<Figures, CliError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = STRATEGIES
            .iter()
            .map(|&name| {
                let (dir, id) = (&dir, &id);
                scope.spawn(move || mill(name, dir, id, force_n))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err(CliError::Failure("a strategy's run panicked".into()))))
            .collect()
    });
    let figures = runs.into_iter().collect::<Result<Vec<_>, _>>()?;
    write_polar(&plot, &figures).map_err(CliError::Failure)?;
    print_table(&figures, &plot, args.json, force_n);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// Mills the circle with `strategy` in a directory of its own under `dir`; its figures.
fn mill(
    name: &'static str,
    dir: &Path,
    id: &[sim_plant::process::identify::Identified],
    force_n: f64,
) -> Result<Figures, CliError> {
    let file_name = name.replace('+', "-");
    let dir = dir.join(&file_name);
    std::fs::create_dir_all(&dir).map_err(|e| CliError::Failure(format!("{}: {e}", dir.display())))?;
    let machine = dir.join("machine.toml");
    std::fs::write(&machine, interpd_sim::scenario::machine_with_strategy(MACHINE, name, id))
        .map_err(|e| CliError::Failure(format!("{}: {e}", machine.display())))?;
    let trace = dir.join("trace.csv");
    let pair = Pair { dir: dir.clone(), machine: Some(machine), plot: None, trace: Some(trace.clone()) };
    pair.run(&format!("interpd-milling-{file_name}"), PROGRAM, "milling-circle.ngc", false)
        .map_err(|e| CliError::Failure(format!("{name}: {e}")))?;
    let f = evaluate(name, &trace, force_n)?;
    eprintln!(
        "milling-circle: {name}: MAE {:.1} µm, max {:.1} µm, roundness {:.1} µm, surface {:.2} µm",
        f.mae_um, f.max_dev_um, f.roundness_um, f.surface_std_um
    );
    Ok(f)
}

/// The plant's own parameters, for the comparison with the identified model only.
struct Truth {
    /// k₊, k₋ of the X axis's transmission, N/mm.
    k_pos: f64,
    k_neg: f64,
    /// Backlash, mm.
    gap_mm: f64,
    /// The structure's compliance in the X–Y plane, µm/N.
    c: [[f64; 2]; 2],
}

fn plant_truth(config: &Config) -> Result<Truth, CliError> {
    let r = config.plant.resolve(&config.axes, "milling_circle.toml").map_err(|e| CliError::Failure(e.to_string()))?;
    let c = config.plant.structure.as_ref().map_or([[0.0; 2]; 2], |s| {
        let c = sim_plant::process::structure::Structure::new(s, [0, 1]).compliance_mm_per_n();
        [[c[0][0] * 1e3, c[0][1] * 1e3], [c[1][0] * 1e3, c[1][1] * 1e3]]
    });
    match &r[0].model {
        PlantModel::TwoMass(p) => {
            Ok(Truth { k_pos: p.stiffness_pos * 1e-3, k_neg: p.stiffness_neg * 1e-3, gap_mm: p.backlash * 1e3, c })
        }
        PlantModel::ThreeMass(_) => Err(CliError::Failure("the milling machine is a two-mass axis".into())),
    }
}

/// The figures from the plant's trace: the tool's radial error where it cut.
fn evaluate(name: &'static str, trace: &Path, force_n: f64) -> Result<Figures, CliError> {
    let text = std::fs::read_to_string(trace).map_err(|e| CliError::Failure(format!("{}: {e}", trace.display())))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |n: &str| {
        header.iter().position(|h| *h == n).ok_or_else(|| CliError::Failure(format!("trace lacks column {n}")))
    };
    let (ix, iy, ifx, ify) = (col("X_tool")?, col("Y_tool")?, col("X_process_force_n")?, col("Y_process_force_n")?);
    let mut pts = Vec::new();
    for l in lines {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect();
        if v.len() < header.len() {
            continue;
        }
        if v[ifx].hypot(v[ify]) >= CUTTING_SHARE * force_n {
            pts.push((v[ix], v[iy]));
        }
    }
    if pts.len() < 2 * SURFACE_WINDOW {
        return Err(CliError::Failure(format!("{name}: only {} samples while cutting", pts.len())));
    }
    let dev: Vec<f64> = pts.iter().map(|(x, y)| x.hypot(y + R_MM) - R_MM).collect();
    let n = dev.len() as f64;
    let mae_um = dev.iter().map(|d| d.abs()).sum::<f64>() / n * 1e3;
    let max_dev_um = dev.iter().fold(0.0_f64, |m, d| m.max(d.abs())) * 1e3;
    let roundness_um = roundness(&pts) * 1e3;
    // Surface: the deviation less its moving average over the window.
    let half = SURFACE_WINDOW / 2;
    let hp: Vec<f64> = (half..dev.len() - half)
        .map(|k| dev[k] - dev[k - half..=k + half].iter().sum::<f64>() / (2 * half + 1) as f64)
        .collect();
    let m = hp.iter().sum::<f64>() / hp.len() as f64;
    let surface_std_um = (hp.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / hp.len() as f64).sqrt() * 1e3;
    let polar = pts.iter().zip(&dev).map(|((x, y), d)| ((y + R_MM).atan2(*x), d * 1e3)).collect();
    Ok(Figures { name, roundness_um, max_dev_um, mae_um, surface_std_um, polar })
}

/// Roundness: the spread of the radii about the least-squares circle (Kasa fit), mm.
fn roundness(pts: &[(f64, f64)]) -> f64 {
    // x² + y² = 2a x + 2b y + c, least squares in (a, b, c), about the mean for conditioning.
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let (mut suu, mut svv, mut suv, mut suuu, mut svvv, mut suvv, mut svuu) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (x, y) in pts {
        let (u, v) = (x - mx, y - my);
        suu += u * u;
        svv += v * v;
        suv += u * v;
        suuu += u * u * u;
        svvv += v * v * v;
        suvv += u * v * v;
        svuu += v * u * u;
    }
    let (b1, b2) = (0.5 * (suuu + suvv), 0.5 * (svvv + svuu));
    let det = suu * svv - suv * suv;
    let (uc, vc) = ((b1 * svv - b2 * suv) / det, (suu * b2 - suv * b1) / det);
    let (cx, cy) = (uc + mx, vc + my);
    let radii = pts.iter().map(|(x, y)| (x - cx).hypot(y - cy));
    let (lo, hi) = radii.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| (l.min(r), h.max(r)));
    hi - lo
}

#[allow(clippy::print_stdout)]
fn print_table(figures: &[Figures], plot: &Path, json_out: bool, force_n: f64) {
    let none_mae = figures.first().map_or(0.0, |f| f.mae_um);
    if json_out {
        let strategies: Vec<Value> = figures
            .iter()
            .map(|f| {
                json!({
                    "name": f.name,
                    "roundness_um": f.roundness_um,
                    "max_dev_um": f.max_dev_um,
                    "mae_um": f.mae_um,
                    "surface_std_um": f.surface_std_um,
                })
            })
            .collect();
        println!("{}", json!({ "strategies": strategies }));
        return;
    }
    println!(
        "milling-circle: Ø 70 mm at 300 mm/min, soft robot axis, {force_n:.0} N process force; at the tool, where it cut"
    );
    println!(
        "{:<19} {:>15} {:>14} {:>10} {:>13} {:>17}",
        "strategy", "roundness [µm]", "max dev [µm]", "MAE [µm]", "MAE vs none", "surface std [µm]"
    );
    for f in figures {
        let red = if none_mae > 0.0 { format!("{:+.1} %", (f.mae_um / none_mae - 1.0) * 100.0) } else { "-".into() };
        println!(
            "{:<19} {:>15.1} {:>14.1} {:>10.1} {:>13} {:>17.2}",
            f.name, f.roundness_um, f.max_dev_um, f.mae_um, red, f.surface_std_um
        );
    }
    println!("  polar plot of the radial error: {}", plot.display());
}

/// The radial error of each strategy around the circle, drawn about a reference circle.
fn write_polar(path: &Path, figures: &[Figures]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: cannot draw: {e}", path.display());
    sim_plant::plot::register_font().map_err(|e| err(&e))?;
    let worst = figures.iter().flat_map(|f| f.polar.iter().map(|p| p.1.abs())).fold(0.0_f64, f64::max);
    // The zero-error circle, with room inside it for the largest inward error.
    let base = (worst * 1.2).max(50.0);
    let lim = base + worst * 1.1;
    let root = BitMapBackend::new(path, (1000, 1000)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("radial error at the tool, Ø 70 mm circle (reference circle = 0, radius {base:.0} µm)"),
            ("sans-serif", 20),
        )
        .margin(20)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-lim..lim, -lim..lim)
        .map_err(|e| err(&e))?;
    chart.configure_mesh().x_desc("µm").y_desc("µm").label_style(("sans-serif", 14)).draw().map_err(|e| err(&e))?;
    let circle: Vec<(f64, f64)> =
        (0..=360).map(|d| (d as f64).to_radians()).map(|a| (base * a.cos(), base * a.sin())).collect();
    chart.draw_series(LineSeries::new(circle, BLACK.stroke_width(1))).map_err(|e| err(&e))?.label("0 µm");
    let colors = [RED, BLUE, RGBColor(0, 140, 0), MAGENTA];
    for (f, c) in figures.iter().zip(colors) {
        let pts: Vec<(f64, f64)> = f.polar.iter().map(|(a, d)| ((base + d) * a.cos(), (base + d) * a.sin())).collect();
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(format!("{} (MAE {:.1} µm)", f.name, f.mae_um))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}
