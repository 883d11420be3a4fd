//! Property tests of the planner on random programs (lines, arcs, G06 splines, corners and
//! tangent joints) and random machines (limits over several orders of magnitude): planning
//! always succeeds, the profile is finite and continuous, and the motion sampled densely keeps
//! every axis within 1.001 × its velocity and acceleration limit and 1.02 × its jerk limit.

use interpd_motion::Settings;
use interpd_motion::planner::Planner;
use interpd_motion::program;
use proptest::prelude::*;

fn machine(vel: f64, acc: f64, jerk: f64) -> Settings {
    let axis = |n: &str| {
        format!(
            "[[axis]]\nname = \"{n}\"\nkind = \"linear\"\nmax_vel = {vel}\nmax_acc = {acc}\nmax_jerk = {jerk}\nmin = -1000\nmax = 1000\n"
        )
    };
    Settings::from_toml_str(&format!("[machine]\n{}{}{}", axis("X"), axis("Y"), axis("Z")), "prop.toml")
        .expect("machine")
}

#[derive(Debug, Clone)]
enum Move {
    Line(f64, f64),
    Arc { turn_deg: f64, radius: f64, ccw: bool },
    Spline(Vec<(f64, f64)>),
}

fn move_strategy() -> impl Strategy<Value = Move> {
    prop_oneof![
        (-40.0..40.0f64, -40.0..40.0f64).prop_map(|(x, y)| Move::Line(x, y)),
        (5.0..300.0f64, 0.5..30.0f64, any::<bool>()).prop_map(|(t, r, c)| Move::Arc { turn_deg: t, radius: r, ccw: c }),
        prop::collection::vec((-20.0..20.0f64, -20.0..20.0f64), 2..5).prop_map(Move::Spline),
    ]
}

/// G-code for the moves, each relative to the current point; arcs continue tangentially
/// from the current direction half of the time (G¹ joints), otherwise start perpendicular.
fn program_text(moves: &[Move], feed: f64) -> String {
    let mut t = format!("G21 G90 G17\nG1 F{feed:.3}\n");
    let (mut x, mut y, mut dir) = (0.0f64, 0.0f64, 0.0f64);
    for (i, m) in moves.iter().enumerate() {
        match m {
            Move::Line(dx, dy) => {
                if dx.hypot(*dy) < 0.01 {
                    continue;
                }
                x += dx;
                y += dy;
                dir = dy.atan2(*dx);
                t += &format!("X{x:.6} Y{y:.6}\n");
            }
            Move::Arc { turn_deg, radius, ccw } => {
                let start_dir = if i % 2 == 0 { dir } else { dir + std::f64::consts::FRAC_PI_2 };
                let side = if *ccw { 1.0 } else { -1.0 };
                let (cx, cy) = (x - side * radius * start_dir.sin(), y + side * radius * start_dir.cos());
                let a0 = (y - cy).atan2(x - cx);
                let a1 = a0 + side * turn_deg.to_radians();
                let (ex, ey) = (cx + radius * a1.cos(), cy + radius * a1.sin());
                t += &format!("{} X{ex:.9} Y{ey:.9} I{:.9} J{:.9}\n", if *ccw { "G3" } else { "G2" }, cx - x, cy - y);
                t += "G1\n";
                x = ex;
                y = ey;
                dir = start_dir + side * turn_deg.to_radians();
            }
            Move::Spline(pts) => {
                t += "G06\n";
                for (dx, dy) in pts {
                    x += dx;
                    y += dy;
                    t += &format!("X{x:.6} Y{y:.6} Z0;\n");
                }
                t += "\nG1\n";
            }
        }
    }
    t
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, max_shrink_iters: 200, ..ProptestConfig::default() })]

    #[test]
    fn random_programs_plan_within_limits(
        moves in prop::collection::vec(move_strategy(), 1..5),
        feed in 300.0..60000.0f64,
        vel in 10.0..1000.0f64,
        acc_over_vel in 2.0..100.0f64,
        jerk_over_acc in 5.0..200.0f64,
    ) {
        let (acc, jerk) = (vel * acc_over_vel, vel * acc_over_vel * jerk_over_acc);
        let cfg = machine(vel, acc, jerk);
        let text = program_text(&moves, feed);
        let Ok(prog) = program::parse(&text, "prop.ngc", &cfg) else { return Ok(()) };
        if prog.path.elements.is_empty() {
            return Ok(());
        }
        let (segs, _stats) = Planner::plan_path(&cfg, &prog.path)
            .map_err(|e| TestCaseError::fail(format!("planning failed: {e}\nprogram:\n{text}")))?;
        for w in segs.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            let e = a.at(a.dt_s);
            prop_assert!(a.v0.is_finite() && a.a0.is_finite() && a.j.is_finite() && a.dt_s.is_finite());
            prop_assert!((e.v - b.v0).abs() <= 1e-6 * (1.0 + b.v0.abs()), "v jump at s={}: {} → {}\n{text}", b.s0_mm, e.v, b.v0);
            prop_assert!((e.a - b.a0).abs() <= 1e-4 * (1.0 + b.a0.abs()), "a jump at s={}: {} → {}\n{text}", b.s0_mm, e.a, b.a0);
        }
        let total: f64 = segs.iter().map(|s| s.ds_mm).sum();
        prop_assert!((total - prog.path.length_mm()).abs() <= 1e-6 * prog.path.length_mm().max(1.0));
        let [v, a, j] = interpd_motion::planner::profile::limit_ratios(&prog.path, &segs, &cfg, 2e-4);
        prop_assert!(v <= 1.001 && a <= 1.001 && j <= 1.02, "vel {v:.5} acc {a:.5} jerk {j:.5}\nprogram:\n{text}\nlimits {vel} {acc} {jerk}");
    }
}
