//! The plant's acceptance figures, in-process and deterministic: T1 static compliance, T2
//! backlash reversal and T3 residual vibration on the presets fitted to Schneider 2016, and the
//! 3-mass axis of Haas 2012, §5.2. Each test prints its measured figure, so
//! `cargo test -- --nocapture` shows the numbers.
#![allow(clippy::print_stdout)]

use interpd_config::plant::PlantModel;
use interpd_config::{AxisKind, Config};
use sim_plant::analysis;
use sim_plant::scenario::{self, SCurve};
use sim_plant::{AxisTarget, Plant};

/// Schneider 2016, §3.2: 300 N at the TCP (450 N·m at 1.5 m) through k₊ = 1.23e6 N·m/rad
/// deflects 0.549 mm, through k₋ = 3.60e6 N·m/rad 0.1875 mm (the thesis: 0.19–0.55 mm).
const T1_SOFT_MM: f64 = 0.549;
const T1_STIFF_MM: f64 = 0.190;
/// Relative tolerance of T1.
const T1_TOL: f64 = 0.01;
/// Schneider 2016, §3.2, Fig. 3.6: backlash 1.52e-4 rad × 1.5 m = 0.228 mm.
const BACKLASH_MM: f64 = 0.228;
/// Schneider 2016, Tab. 3.1: 6.02 Hz free motion in z, 23.77 Hz milling in y. T3 allows ±5 %,
/// about the shift of the measured modes between free motion and milling.
const MODE_SOFT_HZ: f64 = 6.02;
const MODE_STIFF_HZ: f64 = 23.77;
const T3_TOL: f64 = 0.05;
/// Preload (N) that keeps the backlash closed in T3, as gravity does on the thesis robot; the
/// thesis measured the modes on a preloaded arm (Schneider 2016, Tab. 3.1).
const T3_PRELOAD_N: f64 = 300.0;
/// Open-loop modes of the Table 5.1 axis of Haas 2012 (signs of eq. 5.11 restored),
/// k₂ = 2e8 N/m, computed from the model: the thesis gives none.
const HAAS_MODES_HZ: [f64; 2] = [85.04, 278.61];
const HAAS_K2_N_PER_M: f64 = 2.0e8;
const HAAS_TOL: f64 = 0.01;

fn rel(x: f64, y: f64) -> f64 {
    (x - y).abs() / y.abs()
}

#[test]
fn t1_static_compliance_soft_300n_deflects_0_549mm() {
    let c = scenario::static_compliance("schneider-soft", AxisKind::Linear, 300.0).unwrap();
    println!("T1 soft: {c:?}");
    assert!(rel(c.deflection, T1_SOFT_MM) <= T1_TOL, "deflection {} mm", c.deflection);
    // With the preset's backlash the load first crosses half the gap; the elastic part is the same.
    assert!(rel(c.elastic_twist_with_backlash, T1_SOFT_MM) <= T1_TOL, "twist {}", c.elastic_twist_with_backlash);
    assert!((c.displacement_with_backlash - c.elastic_twist_with_backlash - BACKLASH_MM / 2.0).abs() < 0.002);
}

#[test]
fn t1_static_compliance_stiff_300n_deflects_0_190mm() {
    let c = scenario::static_compliance("schneider-stiff", AxisKind::Linear, 300.0).unwrap();
    println!("T1 stiff: {c:?}");
    assert!(rel(c.deflection, T1_STIFF_MM) <= T1_TOL, "deflection {} mm", c.deflection);
    assert!(rel(c.elastic_twist_with_backlash, T1_STIFF_MM) <= T1_TOL, "twist {}", c.elastic_twist_with_backlash);
}

#[test]
fn t1_rotary_joint1_450nm_uses_the_asymmetric_stiffness() {
    // Schneider 2016, §3.2, on the joint itself: 450 N·m twists it by 3.66e-4 rad (k₊) and
    // 1.25e-4 rad (k₋).
    let rad_to_deg = 180.0 / std::f64::consts::PI;
    let pos = scenario::static_compliance("schneider-joint1", AxisKind::Rotary, 450.0).unwrap();
    let neg = scenario::static_compliance("schneider-joint1", AxisKind::Rotary, -450.0).unwrap();
    println!("T1 joint1 +450 N·m: {pos:?}\nT1 joint1 −450 N·m: {neg:?}");
    assert!(rel(pos.deflection / rad_to_deg, 3.66e-4) <= T1_TOL, "{}", pos.deflection / rad_to_deg);
    assert!(rel(neg.deflection / rad_to_deg, 1.25e-4) <= T1_TOL, "{}", neg.deflection / rad_to_deg);
}

fn check_reversal(preset: &str) {
    let r = scenario::backlash_reversal(preset).unwrap();
    println!("T2 {preset}: {r:?}");
    assert_eq!(r.encoder_step, 0.002);
    assert!((r.lost_motion - BACKLASH_MM).abs() <= r.encoder_step, "lost motion {} mm", r.lost_motion);
    // The motor encoder sits before the gap (Schneider 2016, §3.3): the following error does not see it.
    assert!(r.following_error_shift.abs() < r.encoder_step, "FE shift {} mm", r.following_error_shift);
    assert!(r.max_following_error < BACKLASH_MM / 20.0, "max FE {} mm", r.max_following_error);
}

#[test]
fn t2_backlash_reversal_soft_lost_motion_0_228mm() {
    check_reversal("schneider-soft");
}

#[test]
fn t2_backlash_reversal_stiff_lost_motion_0_228mm() {
    check_reversal("schneider-stiff");
}

fn check_modal(preset: &str, f_hz: f64) {
    let preloaded = scenario::modal_check(preset, T3_PRELOAD_N, true).unwrap();
    let no_backlash = scenario::modal_check(preset, 0.0, false).unwrap();
    println!("T3 {preset} preloaded: {preloaded:?}\nT3 {preset} without backlash: {no_backlash:?}");
    for m in [preloaded, no_backlash] {
        let peak = m.peak_hz.expect("the load rings after the move");
        assert!(rel(peak, f_hz) <= T3_TOL, "peak {peak} Hz, expected {f_hz}");
        // Schneider 2016, Tab. 3.1: free-motion amplitude of the order of ±0.07 mm.
        assert!(m.residual_amplitude > 0.005 && m.residual_amplitude < 0.2, "amplitude {}", m.residual_amplitude);
    }
    // Why the preload: with the gap open the load drifts inside it after the move and stops on
    // its friction; it does not ring, so there is no modal peak to find.
    let open = scenario::modal_check(preset, 0.0, true).unwrap();
    println!("T3 {preset} with the gap open, no preload: {open:?}");
    assert!(open.peak_hz.is_none() && open.residual_amplitude < BACKLASH_MM, "{open:?}");
}

#[test]
fn t3_modal_peak_soft_6_02hz() {
    check_modal("schneider-soft", MODE_SOFT_HZ);
}

#[test]
fn t3_modal_peak_stiff_23_77hz() {
    check_modal("schneider-stiff", MODE_STIFF_HZ);
}

fn haas_axis(k2: f64) -> interpd_config::plant::ResolvedAxisPlant {
    let c = Config::default_machine();
    let mut r = c.plant.resolve(&c.axes, "<default>").unwrap().remove(0);
    let PlantModel::ThreeMass(p) = &mut r.model else { panic!("haas-laser is the 3-mass model") };
    p.k2_n_per_m = k2;
    r
}

#[test]
fn haas_open_loop_modes_85_04_and_278_61hz() {
    let modes = analysis::open_loop_modes(&haas_axis(HAAS_K2_N_PER_M).model).unwrap();
    println!("Haas open loop (k2 = 2e8): {modes:?}");
    assert_eq!(modes.len(), 2);
    for (m, f) in modes.iter().zip(HAAS_MODES_HZ) {
        assert!(rel(m.natural_hz, f) <= HAAS_TOL, "{} Hz vs {f}", m.natural_hz);
        assert!(m.damping > 0.0 && m.damping < 1e-3, "lightly damped: {}", m.damping);
    }
    // The k₂ = m₃/I_T = 2e6 of Haas 2012's text, which contradicts Table 5.1: 24.97 and 94.88 Hz.
    let soft = analysis::open_loop_modes(&haas_axis(2.0e6).model).unwrap();
    assert!(rel(soft[0].natural_hz, 24.97) <= HAAS_TOL && rel(soft[1].natural_hz, 94.88) <= HAAS_TOL, "{soft:?}");
}

#[test]
fn haas_closed_loop_is_stable_continuous_and_sampled() {
    for k2 in [HAAS_K2_N_PER_M, 2.0e6] {
        let r = haas_axis(k2);
        let cont = analysis::closed_loop_continuous(&r).unwrap();
        let max_re = analysis::max_real_part(&cont);
        let disc = analysis::closed_loop_discrete(&r, 1e-4).unwrap();
        let radius = analysis::spectral_radius(&disc);
        println!("Haas closed loop k2 = {k2:e}: max Re λ = {max_re:.4} 1/s, spectral radius at 10 kHz = {radius:.7}");
        assert!(max_re < 0.0, "continuous closed loop unstable: {max_re}");
        assert!(radius < 1.0, "sampled closed loop unstable: {radius}");
        // The power module's PT1 (Haas 2012, Table 5.2) gives a real pole near −5867 1/s.
        assert!(cont.iter().any(|l| l.im.abs() < 1e-6 && (l.re + 5867.0).abs() < 100.0), "{cont:?}");
    }
}

#[test]
fn haas_positioning_move_shows_the_crosstalk_output() {
    let (p, tr) = scenario::haas_positioning(HAAS_K2_N_PER_M).unwrap();
    println!("Haas 0 → 100 mm (k2 = 2e8): {p:?}");
    // Quasi-static crosstalk (C_Ty/I_T)(x₃ − x₂) with x₂ − x₃ = m₃a/k₂: 3e-8 m per m/s²;
    // the sign follows the lagging structure mass.
    let expected = -3.0e-6 / 5.0e-5 * 100.0 / HAAS_K2_N_PER_M;
    assert!(rel(p.crosstalk_per_acc, expected) < 0.1, "{} vs {expected}", p.crosstalk_per_acc);
    assert!(p.max_crosstalk_mm > 5e-5, "{}", p.max_crosstalk_mm);
    assert!(p.settled_error_mm < 1e-3, "settles: {}", p.settled_error_mm);
    assert!((tr.setpoint.last().unwrap() - 100.0).abs() < 1e-12);
    let (soft, _) = scenario::haas_positioning(2.0e6).unwrap();
    println!("Haas 0 → 100 mm (k2 = 2e6): {soft:?}");
    assert!(rel(soft.crosstalk_per_acc, expected * 100.0) < 0.1, "{}", soft.crosstalk_per_acc);
}

/// On an XY machine of Haas axes, moving X alone moves Y's TCP by X's crosstalk output.
#[test]
fn haas_crosstalk_reaches_the_other_axis() {
    let text = format!("{}\n[plant]\napply_crosstalk = true\n", interpd_config::DEFAULT_MACHINE_TOML);
    let config = Config::from_toml_str(&text, "<xyz + crosstalk>").unwrap();
    let mut plant = Plant::from_config(&config).unwrap();
    let mv = SCurve::new(0.0, 100.0, 250.0, 2500.0, 50000.0);
    let dt = 0.004;
    let mut max_y = 0.0_f64;
    let mut max_ct = 0.0_f64;
    let n = ((mv.duration_s() + 0.2) / dt).ceil() as usize;
    for k in 0..=n {
        let (p, v, a) = mv.eval(k as f64 * dt);
        let targets = [AxisTarget { pos: p, vel: v, acc: a }, AxisTarget::default(), AxisTarget::default()];
        let out = if k == 0 { plant.reset(0, &[p, 0.0, 0.0]).unwrap() } else { plant.step(&targets, dt).unwrap() };
        // Y holds still: its load position is exactly X's first crosstalk output.
        assert!((out[1].load_pos - out[0].crosstalk[0]).abs() < 1e-12, "{:?}", out[1]);
        assert!((out[2].load_pos - out[0].crosstalk[1]).abs() < 1e-12, "{:?}", out[2]);
        max_y = max_y.max(out[1].load_pos.abs());
        max_ct = max_ct.max(out[0].crosstalk[0].abs());
    }
    println!("Haas XY: max |Y load| = {max_y:e} mm from X's crosstalk");
    assert!(max_y > 5e-5 && max_y == max_ct);
}
