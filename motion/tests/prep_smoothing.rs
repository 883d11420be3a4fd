//! Tolerance-band smoothing (Haas 2012) checked from the outside: the smoothed path,
//! sampled every few micrometres, against a fine polyline of the programmed path (its own
//! sampling, not the stage's check); C² at the joints between smoothed pieces; the stage
//! running ahead online; and the exact-stop fallback.
//!
//! The figures (largest excess over the tolerance, C² residuals) are printed with
//! `cargo test --release -p interpd-motion --test prep_smoothing -- --nocapture`.

use interpd_motion::path::{AxisDerivs, Geometry, JointKind, Path};
use interpd_motion::prep::prepare_path;
use interpd_motion::program;
use interpd_motion::{Feed, Settings};

fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` before its first G1 block, cut after `max_moves` coordinate lines.
fn with_mode(text: &str, word: &str, max_moves: usize) -> String {
    let (mut out, mut moves, mut inserted) = (String::new(), 0, false);
    for line in text.lines() {
        if !inserted && line.starts_with("G1") {
            out.push_str(word);
            out.push('\n');
            inserted = true;
        }
        if line.starts_with('X') {
            moves += 1;
            if moves > max_moves {
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn parse(text: &str, config: &Settings) -> Path {
    program::parse(text, "test.ngc", config).expect("program parses").path
}

/// A fine polyline of a path (lines exact, curves at ≤ 1e-7 mm chord error) in a grid for
/// nearest-segment queries.
struct Reference {
    segs: Vec<([f64; 3], [f64; 3])>,
    cell_mm: f64,
    grid: std::collections::HashMap<(i64, i64), Vec<usize>>,
}

impl Reference {
    fn new(path: &Path, reach_mm: f64) -> Self {
        let mut pts: Vec<[f64; 3]> = Vec::new();
        let mut d = AxisDerivs::default();
        let at = |d: &AxisDerivs| [d.pos[0], d.pos[1], d.pos[2]];
        path.elements[0].geometry.eval(0.0, &mut d);
        pts.push(at(&d));
        let mut segs = Vec::new();
        for e in &path.elements {
            let len = e.geometry.length_mm();
            let n = match e.geometry {
                Geometry::Line(_) => 1,
                // chord error of an arc of radius R over step h: h²/(8R); R ≥ 5 mm in these shapes
                _ => (len / 2e-3).ceil() as usize,
            };
            for i in 1..=n {
                e.geometry.eval(len * i as f64 / n as f64, &mut d);
                let p = at(&d);
                segs.push((*pts.last().unwrap(), p));
                pts.push(p);
            }
        }
        let cell_mm = 1.0;
        let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> = std::collections::HashMap::new();
        for (i, (a, b)) in segs.iter().enumerate() {
            let lo = |k: usize| ((a[k].min(b[k]) - reach_mm) / cell_mm).floor() as i64;
            let hi = |k: usize| ((a[k].max(b[k]) + reach_mm) / cell_mm).floor() as i64;
            for cx in lo(0)..=hi(0) {
                for cy in lo(1)..=hi(1) {
                    grid.entry((cx, cy)).or_default().push(i);
                }
            }
        }
        Self { segs, cell_mm, grid }
    }

    /// Distance to the programmed path (∞ if farther than the reach).
    fn distance(&self, p: [f64; 3]) -> f64 {
        let key = ((p[0] / self.cell_mm).floor() as i64, (p[1] / self.cell_mm).floor() as i64);
        let Some(list) = self.grid.get(&key) else { return f64::INFINITY };
        list.iter()
            .map(|&i| {
                let (a, b) = self.segs[i];
                let ab: Vec<f64> = (0..3).map(|k| b[k] - a[k]).collect();
                let len2: f64 = ab.iter().map(|x| x * x).sum();
                let t = if len2 > 0.0 {
                    ((0..3).map(|k| (p[k] - a[k]) * ab[k]).sum::<f64>() / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (0..3).map(|k| (p[k] - a[k] - t * ab[k]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Largest distance of the densely sampled `smoothed` path from `programmed`, mm.
fn max_deviation(programmed: &Path, smoothed: &Path, step_mm: f64) -> f64 {
    let reference = Reference::new(programmed, 0.5);
    let mut d = AxisDerivs::default();
    let mut worst: f64 = 0.0;
    for e in &smoothed.elements {
        let len = e.geometry.length_mm();
        let n = (len / step_mm).ceil().max(8.0) as usize;
        for i in 0..=n {
            e.geometry.eval(len * i as f64 / n as f64, &mut d);
            worst = worst.max(reference.distance([d.pos[0], d.pos[1], d.pos[2]]));
        }
    }
    worst
}

/// Largest jumps of A, A′, A″ over the joints of `path` (Smooth joints only for A′, A″), and
/// the number of smooth joints.
fn joint_residuals(path: &Path) -> ([f64; 3], usize) {
    let (mut l, mut r) = (AxisDerivs::default(), AxisDerivs::default());
    let mut worst = [0.0f64; 3];
    let mut smooth = 0;
    for w in path.elements.windows(2) {
        w[0].geometry.eval(w[0].geometry.length_mm(), &mut l);
        w[1].geometry.eval(0.0, &mut r);
        let jump = |a: &[f64], b: &[f64]| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max);
        worst[0] = worst[0].max(jump(&l.pos, &r.pos));
        if w[1].joint == JointKind::Smooth {
            smooth += 1;
            worst[1] = worst[1].max(jump(&l.d1, &r.d1));
            let scale = (0..3).map(|k| l.d2[k].abs()).fold(1.0, f64::max);
            worst[2] = worst[2].max(jump(&l.d2, &r.d2) / scale);
        }
    }
    (worst, smooth)
}

const SHAPES: [&str; 5] = ["corner_90", "line_arc_line", "staircase", "zigzag", "two_arcs"];

/// Each Haas shape at P0.01 and P0.1, smoothed with `config`: (name, tolerance, the programmed
/// path, what the smoothing made of it).
fn smoothed_shapes(config: &Settings) -> Vec<(&'static str, f64, Path, interpd_motion::prep::Prepared)> {
    let mut out = Vec::new();
    for name in SHAPES {
        let text = repo_file(&format!("examples/{name}.ngc"));
        let programmed = parse(&text, config);
        for tol in [0.01, 0.1] {
            let program = parse(&with_mode(&text, &format!("G64 P{tol}"), usize::MAX), config);
            out.push((name, tol, programmed.clone(), prepare_path(config, &program).expect("smoothing")));
        }
    }
    out
}

/// Tolerance + 1 µm (Haas 2012, §4.8).
const SLACK_MM: f64 = 1e-3;

#[test]
fn haas_shapes_stay_in_the_band_and_join_c2() {
    let mut config = Settings::default_machine();
    // Smooth every corner of the shapes (the default leaves turns above 90° exact).
    config.prep.max_corner_deg = 170.0;
    for name in SHAPES {
        let text = repo_file(&format!("examples/{name}.ngc"));
        let programmed = parse(&text, &config);
        for tol in [0.01, 0.1] {
            let smoothed =
                prepare_path(&config, &parse(&with_mode(&text, &format!("G64 P{tol}"), usize::MAX), &config))
                    .expect("smoothing")
                    .path;
            assert!(
                smoothed.elements.iter().any(|e| matches!(e.geometry, Geometry::Quintic(_))),
                "{name}: not smoothed"
            );
            let dev = max_deviation(&programmed, &smoothed, 2e-3);
            let ([dp, d1, d2], smooth) = joint_residuals(&smoothed);
            eprintln!(
                "{name:>14} P{tol}: max deviation {dev:.6} mm (excess {:+.2e} mm); {smooth} smooth joints, \
                 max jump A {dp:.1e}, A′ {d1:.1e}, A″ {d2:.1e} (rel)",
                dev - tol
            );
            assert!(dev <= tol + SLACK_MM, "{name} P{tol}: {dev} mm off the programmed path");
            assert!(dp < 1e-9 && d1 < 1e-9 && d2 < 1e-7, "{name} P{tol}: joints not C²: {dp:e} {d1:e} {d2:e}");
            // Same start and end as programmed.
            let (a, b) = (programmed.end_position(), smoothed.end_position());
            assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-9), "{name}: ends at {b:?}, not {a:?}");
        }
    }
}

#[test]
fn dense_cam_slice_stays_in_the_band_and_runs_ahead_online() {
    let config = Settings::default_machine();
    // PREP_TEST_SEGMENTS=100000 checks the whole program (slow); CI checks a bounded slice.
    let segments = std::env::var("PREP_TEST_SEGMENTS").ok().and_then(|v| v.parse().ok()).unwrap_or(5000);
    let text = with_mode(&repo_file("examples/dense_freeform.ngc"), "G64 P0.01", segments);
    let programmed = parse(&text, &config);
    // Online: the program is read line by line as far as the path is asked for, and smoothed
    // pieces come out long before its end.
    let mut feed = Feed::builder(&config).open_text("dense.ngc", text.clone()).expect("opens");
    let quintic = |p: &Path| p.elements.iter().any(|e| matches!(e.geometry, Geometry::Quintic(_)));
    let mut first_piece_at = None;
    let mut s_mm = 0.0;
    while first_piece_at.is_none() && s_mm < programmed.length_mm() {
        feed.eval(s_mm).expect("reads");
        if quintic(feed.path()) {
            first_piece_at = Some(feed.progress().lines_read as usize);
        }
        s_mm += 0.05;
    }
    while !feed.finished() {
        feed.plan(1.0).expect("plans");
        while feed.pop_segment().is_some() {}
    }
    let out = feed.path().clone();
    // The first window needs five 10 mm segments of input (~2500 of these 0.02 mm moves).
    let first = first_piece_at.expect("smoothed pieces before the end of the input");
    eprintln!("dense slice: first smoothed piece out after line {first} of {} elements", programmed.elements.len());
    assert!(first <= 3000, "the stage must run ahead, not wait for the end: line {first}");
    let dev = max_deviation(&programmed, &out, 2e-3);
    let ([dp, d1, d2], smooth) = joint_residuals(&out);
    eprintln!(
        "dense slice P0.01: max deviation {dev:.6} mm; {smooth} smooth joints, max jump A {dp:.1e}, A′ {d1:.1e}, \
         A″ {d2:.1e}; stats {:?}",
        feed.stats().prep
    );
    assert!(dev <= 0.01 + SLACK_MM, "{dev}");
    assert!(dp < 1e-9 && d1 < 1e-9 && d2 < 1e-7);
    assert_eq!(feed.stats().prep.fallback_exact, 0);
}

#[test]
fn exact_stop_fallback_keeps_the_band() {
    // A zero solve budget fails every window: each segment falls back to an exact stop and the
    // programmed path, which must still be continuous and within the tolerance.
    let mut config = Settings::default_machine();
    config.prep.max_solve_ms = 0.0;
    let text = repo_file("examples/staircase.ngc");
    let programmed = parse(&text, &config);
    let prepared = prepare_path(&config, &parse(&with_mode(&text, "G64 P0.05", usize::MAX), &config)).unwrap();
    let st = prepared.stats;
    assert!(st.fallback_exact > 0 && st.slow > 0, "{st:?}");
    let dev = max_deviation(&programmed, &prepared.path, 2e-3);
    let ([dp, _, _], _) = joint_residuals(&prepared.path);
    assert!(dev <= 0.05 + SLACK_MM && dp < 1e-9, "{dev} {dp}");
    let (a, b) = (programmed.length_mm(), prepared.path.length_mm());
    assert!((a - b).abs() < 1e-6, "exact fallback must reproduce the path: {a} vs {b}");
}

#[test]
fn g61_elements_pass_through() {
    let config = Settings::default_machine();
    let text = "G21 G90 G17\nG64 P0.05\nG1 X20 Y0 F6000\nX20 Y20\nG61\nX40 Y20\nX40 Y40\nM30\n";
    let path = parse(text, &config);
    let prepared = prepare_path(&config, &path).unwrap().path;
    let lines: Vec<_> = prepared.elements.iter().filter(|e| matches!(e.geometry, Geometry::Line(_))).collect();
    // The last two moves (G61) are the programmed lines, with a stop between them.
    assert_eq!(lines.len(), 2, "{:?}", prepared.elements.iter().map(|e| e.geometry.kind_name()).collect::<Vec<_>>());
    assert!(lines.iter().all(|l| l.joint == JointKind::Corner));
    let mut d = AxisDerivs::default();
    for (l, end) in lines.iter().zip([[40.0, 20.0], [40.0, 40.0]]) {
        l.geometry.eval(l.geometry.length_mm(), &mut d);
        assert!((d.pos[0] - end[0]).abs() < 1e-12 && (d.pos[1] - end[1]).abs() < 1e-12);
    }
    // The smoothed part ends exactly where the exact part starts.
    let first_exact = prepared.elements.iter().position(|e| matches!(e.geometry, Geometry::Line(_))).unwrap();
    let before = &prepared.elements[first_exact - 1];
    before.geometry.eval(before.geometry.length_mm(), &mut d);
    assert!((d.pos[0] - 20.0).abs() < 1e-9 && (d.pos[1] - 20.0).abs() < 1e-9);
}

/// Largest jump of A‴ over the smooth joints of `path`, relative to max(1, |A‴|).
fn jerk_joint_residual(path: &Path) -> f64 {
    let (mut l, mut r) = (AxisDerivs::default(), AxisDerivs::default());
    let mut worst: f64 = 0.0;
    for w in path.elements.windows(2) {
        if w[1].joint != JointKind::Smooth {
            continue;
        }
        w[0].geometry.eval(w[0].geometry.length_mm(), &mut l);
        w[1].geometry.eval(0.0, &mut r);
        let scale = (0..3).map(|k| l.d3[k].abs()).fold(1.0, f64::max);
        worst = worst.max((0..3).map(|k| (l.d3[k] - r.d3[k]).abs()).fold(0.0, f64::max) / scale);
    }
    worst
}

#[test]
fn bspline_method_keeps_the_band_and_joins_at_every_degree() {
    for degree in [2u32, 3, 4] {
        let mut config = Settings::default_machine();
        config.prep.max_corner_deg = 170.0;
        config.prep.method = interpd_config::PrepMethod::Bspline;
        config.prep.continuity_degree = degree;
        for (name, tol, programmed, prepared) in smoothed_shapes(&config) {
            let (smoothed, stats) = (prepared.path, prepared.stats);
            let dev = max_deviation(&programmed, &smoothed, 2e-3);
            let ([dp, d1, d2], smooth) = joint_residuals(&smoothed);
            let d3 = jerk_joint_residual(&smoothed);
            eprintln!(
                "bspline C{degree} {name:>14} P{tol}: max deviation {dev:.6} mm (excess {:+.2e} mm); \
                 {smooth} smooth joints, max jump A {dp:.1e}, A′ {d1:.1e}, A″ {d2:.1e}, A‴ {d3:.1e} (rel); \
                 spline windows {}, Hermite instead {}, exact stops {}",
                dev - tol,
                stats.bspline_windows,
                stats.bspline_to_hermite,
                stats.fallback_exact
            );
            assert!(stats.bspline_windows > 0, "{name} P{tol}: no spline window");
            assert!(dev <= tol + SLACK_MM, "{name} P{tol}: {dev} mm off the programmed path");
            assert!(dp < 1e-9 && d1 < 1e-9 && d2 < 1e-7, "{name} P{tol}: joints not C²: {dp:e} {d1:e} {d2:e}");
            let (a, b) = (programmed.end_position(), smoothed.end_position());
            assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-9), "{name}: ends at {b:?}, not {a:?}");
        }
    }
}

/// A program of `motion/tests/programs/` through the stage on the CAM family's machine (with
/// `extra` TOML appended): its stats and the largest distance from the programmed path, mm.
fn family_program(extra: &str, program: &str) -> (interpd_motion::prep::PrepStats, f64) {
    let machine = repo_file("benches/cam/family_machine.toml");
    let config = Settings::from_toml_str(&format!("{machine}\n{extra}"), "family.toml").expect("machine file");
    let programmed = parse(&repo_file(&format!("motion/tests/programs/{program}")), &config);
    let prepared = prepare_path(&config, &programmed).unwrap();
    (prepared.stats, max_deviation(&programmed, &prepared.path, 2e-3))
}

#[test]
fn bspline_windows_at_plunge_reversals_need_no_exact_stop() {
    // Plunge-and-retract reversals along a slanted line (the CAM family's plunge): refinements
    // that only chase the spline's failures leave both the spline and the Hermite pieces
    // outside the band and the window stops exactly; with the second half of them guided by
    // where the Hermite pieces fail, the window keeps the band.
    let (st, dev) = family_program("[prep]\nmethod = \"bspline\"\n", "plunge_reversals.ngc");
    eprintln!(
        "plunge reversals: max deviation {dev:.6} mm; spline windows {}, Hermite instead {}, refined {}, exact \
         stops {}",
        st.bspline_windows, st.bspline_to_hermite, st.refined, st.fallback_exact
    );
    assert!(st.bspline_windows > 0, "{st:?}");
    assert_eq!(st.fallback_exact, 0, "{st:?}");
    assert!(dev <= 0.01 + SLACK_MM, "{dev} mm off the programmed path");
}

#[test]
fn windows_between_outlier_spikes_need_no_exact_stop() {
    // Single points 20–200 µm off a sine (the CAM family's outlier): the runs between the
    // spikes start and end at rest beside a corner approached at 2 tol spacing. The QP's
    // points ring after the corner and several pieces leave the band at once, and the short
    // runs' QPs stall in the solver; the window must still keep the band without stopping
    // along the programmed path.
    let (st, dev) = family_program("", "outlier_spikes.ngc");
    eprintln!(
        "outlier spikes: max deviation {dev:.6} mm; refined {}, narrowed {}, exact stops {}",
        st.refined, st.verify_retries, st.fallback_exact
    );
    assert_eq!(st.fallback_exact, 0, "{st:?}");
    assert!(dev <= 0.01 + SLACK_MM, "{dev} mm off the programmed path");
}

#[test]
fn cumulative_point_distribution_keeps_the_band_with_both_methods() {
    // Haas 2012, eq. 3.13: the points crowd towards the block ends; the check still holds the
    // band, for the Hermite pieces and the B-spline alike.
    for method in [interpd_config::PrepMethod::Hermite, interpd_config::PrepMethod::Bspline] {
        let mut config = Settings::default_machine();
        config.prep.max_corner_deg = 170.0;
        config.prep.method = method;
        for name in SHAPES {
            let text = repo_file(&format!("examples/{name}.ngc"));
            let programmed = parse(&text, &config);
            for tol in [0.01, 0.1] {
                let program = parse(&with_mode(&text, &format!("G64 P{tol}"), usize::MAX), &config);
                let equidistant = prepare_path(&config, &program).expect("smoothing").stats;
                let mut cumulative = config.clone();
                cumulative.prep.point_distribution = interpd_config::PointDistribution::Cumulative;
                let prepared = prepare_path(&cumulative, &program).expect("smoothing");
                let dev = max_deviation(&programmed, &prepared.path, 2e-3);
                eprintln!(
                    "{method:?} cumulative {name:>14} P{tol}: max deviation {dev:.6} mm, {} points ({} equidistant), exact stops {}",
                    prepared.stats.points, equidistant.points, prepared.stats.fallback_exact
                );
                assert!(dev <= tol + SLACK_MM, "{method:?} {name} P{tol}: {dev} mm off the programmed path");
                assert_ne!(
                    prepared.stats.points, equidistant.points,
                    "{name} P{tol}: the distribution changed nothing"
                );
            }
        }
    }
}

#[test]
fn banded_qp_solver_keeps_the_band_and_joins_c2() {
    // `qp_solver = "banded"`: the interior-point method on the QP's band, Clarabel for what it
    // declines; the smoothed path keeps the band and its joints as with Clarabel.
    let mut config = Settings::default_machine();
    config.prep.max_corner_deg = 170.0;
    config.prep.qp_solver = interpd_config::QpSolver::Banded;
    for (name, tol, programmed, prepared) in smoothed_shapes(&config) {
        let dev = max_deviation(&programmed, &prepared.path, 2e-3);
        let ([dp, d1, d2], _) = joint_residuals(&prepared.path);
        eprintln!("banded {name:>14} P{tol}: max deviation {dev:.6} mm, declined {}", prepared.stats.qp_declined);
        assert!(dev <= tol + SLACK_MM, "{name} P{tol}: {dev} mm off the programmed path");
        assert!(dp < 1e-9 && d1 < 1e-9 && d2 < 1e-7, "{name} P{tol}: joints not C²: {dp:e} {d1:e} {d2:e}");
        assert_eq!(prepared.stats.fallback_exact, 0, "{name} P{tol}");
    }
}

#[test]
fn hermite_pieces_of_degree_7_and_9_keep_the_band_and_join_c3() {
    for (degree, hermite) in [(3u32, 3u32), (4, 3), (4, 4)] {
        let mut config = Settings::default_machine();
        config.prep.max_corner_deg = 170.0;
        config.prep.continuity_degree = degree;
        config.prep.hermite_continuity = hermite;
        for name in SHAPES {
            let text = repo_file(&format!("examples/{name}.ngc"));
            let programmed = parse(&text, &config);
            for tol in [0.01, 0.1] {
                let prepared =
                    prepare_path(&config, &parse(&with_mode(&text, &format!("G64 P{tol}"), usize::MAX), &config))
                        .expect("smoothing");
                let (smoothed, stats) = (prepared.path, prepared.stats);
                let dev = max_deviation(&programmed, &smoothed, 2e-3);
                let ([dp, d1, d2], smooth) = joint_residuals(&smoothed);
                let d3 = jerk_joint_residual(&smoothed);
                eprintln!(
                    "Hermite C{hermite} (QP {degree}) {name:>14} P{tol}: max deviation {dev:.6} mm (excess {:+.2e} mm); \
                     {smooth} smooth joints, max jump A {dp:.1e}, A′ {d1:.1e}, A″ {d2:.1e}, A‴ {d3:.1e} (rel); \
                     refined {}, exact stops {}",
                    dev - tol,
                    stats.refined,
                    stats.fallback_exact
                );
                assert!(dev <= tol + SLACK_MM, "{name} P{tol}: {dev} mm off the programmed path");
                assert!(dp < 1e-9 && d1 < 1e-9 && d2 < 1e-7, "{name} P{tol}: joints not C²: {dp:e} {d1:e} {d2:e}");
                // C³ wherever the pieces join each other (an exact stop's parts rejoin C²).
                if stats.fallback_exact == 0 {
                    assert!(d3 < 1e-9, "{name} P{tol}: A‴ jumps by {d3:e} (rel) at a joint");
                }
            }
        }
    }
}
