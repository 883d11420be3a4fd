#![allow(clippy::print_stdout)]
use interpd_config::AxisKind;
use sim_plant::{analysis, scenario};
fn main() {
    for p in ["schneider-soft", "schneider-stiff", "haas-laser"] {
        let plant = scenario::single_axis(p, AxisKind::Linear, |_| {}).unwrap();
        let _ = plant;
        let cfg = interpd_config::plant::PlantConfig { preset: Some(p.into()), ..Default::default() };
        let axes = [interpd_config::AxisConfig {
            name: interpd_config::AxisLetter::X,
            kind: AxisKind::Linear,
            max_vel_per_s: 1.0,
            max_acc_per_s2: 1.0,
            max_jerk_per_s3: 1.0,
            min_pos: -1.0,
            max_pos: 1.0,
        }];
        let r = cfg.resolve(&axes, "x").unwrap();
        let ol = analysis::open_loop_modes(&r[0].model).unwrap();
        println!("{p}: open loop {:?}", ol.iter().map(|m| (m.damped_hz, m.damping)).collect::<Vec<_>>());
        let cl = analysis::closed_loop_continuous(&r[0]).unwrap();
        println!(
            "  cont max re {:.3}  modes {:?}",
            analysis::max_real_part(&cl),
            analysis::modes(&cl)
                .iter()
                .map(|m| (format!("{:.2}", m.damped_hz), format!("{:.3}", m.damping)))
                .collect::<Vec<_>>()
        );
        let cd = analysis::closed_loop_discrete(&r[0], 1e-4).unwrap();
        println!("  disc radius {:.6}", analysis::spectral_radius(&cd));
    }
    for p in ["schneider-soft", "schneider-stiff"] {
        let c = scenario::static_compliance(p, AxisKind::Linear, 300.0).unwrap();
        println!("{p} T1 {c:?}");
        let r = scenario::backlash_reversal(p).unwrap();
        println!("{p} T2 {r:?}");
        for (pre, bl) in [(300.0, true), (0.0, false), (0.0, true)] {
            let m = scenario::modal_check(p, pre, bl).unwrap();
            println!("{p} T3 preload {pre} backlash {bl}: {m:?}");
        }
    }
    let c = scenario::static_compliance("schneider-joint1", AxisKind::Rotary, 450.0).unwrap();
    println!("joint1 T1 + {c:?}");
    let c = scenario::static_compliance("schneider-joint1", AxisKind::Rotary, -450.0).unwrap();
    println!("joint1 T1 - {c:?}");
    for k2 in [2e8, 2e6] {
        let (h, _) = scenario::haas_positioning(k2).unwrap();
        println!("haas k2 {k2}: {h:?}");
    }
}
