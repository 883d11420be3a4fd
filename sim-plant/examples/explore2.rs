#![allow(clippy::print_stdout)]
use interpd_config::AxisKind;
use sim_plant::analysis;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let p = &args[1];
    let kps: Vec<f64> = args[2].split(',').map(|s| s.parse().unwrap()).collect();
    let cls: Vec<f64> = args[3].split(',').map(|s| s.parse().unwrap()).collect();
    let vfs: Vec<f64> = args[4].split(',').map(|s| s.parse().unwrap()).collect();
    let cfg = interpd_config::plant::PlantConfig { preset: Some(p.clone()), ..Default::default() };
    let axes = [interpd_config::AxisConfig {
        name: interpd_config::AxisLetter::X,
        kind: AxisKind::Linear,
        max_vel_per_s: 1.0,
        max_acc_per_s2: 1.0,
        max_jerk_per_s3: 1.0,
        min_pos: -1.0,
        max_pos: 1.0,
    }];
    let r0 = cfg.resolve(&axes, "x").unwrap();
    for &kp in &kps {
        for &cl in &cls {
            for &vf in &vfs {
                for kv in [20.0, 40.0, 80.0] {
                    for tn in [0.005, 0.01, 0.02] {
                        let mut r = r0[0].clone();
                        r.drive.kp = kp;
                        r.drive.kv_per_s = kv;
                        r.drive.tn_s = tn;
                        r.drive.current_loop_hz = cl;
                        r.drive.velocity_filter_hz = if vf > 0.0 { Some(vf) } else { None };
                        let cl_e = analysis::closed_loop_continuous(&r).unwrap();
                        let cd = analysis::closed_loop_discrete(&r, 1e-4).unwrap();
                        // discrete modes: ln(z)/h
                        let dm: Vec<String> = cd
                            .iter()
                            .filter(|z| z.im > 1e-9 && z.norm() > 1e-6)
                            .map(|z| {
                                let s = z.ln() / 1e-4;
                                format!("{:.1}Hz/{:.3}", s.im / (2.0 * std::f64::consts::PI), -s.re / s.norm())
                            })
                            .collect();
                        println!(
                            "kp {kp:>7} cl {cl} vf {vf} kv {kv:>4} tn {tn:>5}: rad {:.6} cont {:?} disc {:?}",
                            analysis::spectral_radius(&cd),
                            analysis::modes(&cl_e)
                                .iter()
                                .map(|m| format!("{:.2}Hz/{:.3}", m.damped_hz, m.damping))
                                .collect::<Vec<_>>(),
                            dm
                        );
                    }
                }
            }
        }
    }
}
