#![allow(clippy::print_stdout)]
use interpd_config::AxisKind;
use interpd_config::plant::PlantModel;
use sim_plant::scenario::{self, SCurve};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = &args[1];
    let fc: f64 = args[2].parse().unwrap();
    let v: f64 = args[3].parse().unwrap();
    let a: f64 = args[4].parse().unwrap();
    let dist: f64 = args[5].parse().unwrap();
    let mut plant = scenario::single_axis(preset, AxisKind::Linear, |r| {
        if let PlantModel::TwoMass(p) = &mut r.model {
            p.load_coulomb = fc;
        }
    })
    .unwrap();
    let j = a * 4.0;
    let fwd = SCurve::new(0.0, dist, v, a, j);
    let back = SCurve::new(dist, -dist, v, a, j);
    let (pre, t1, dwell) = (0.5, fwd.duration_s(), 1.0);
    let t_back = pre + t1 + dwell;
    let total = t_back + back.duration_s() + 0.5;
    let tr = scenario::run_profile(&mut plant, 0.004, total, |t| {
        if t < pre {
            (0.0, 0.0, 0.0)
        } else if t < t_back {
            fwd.eval(t - pre)
        } else {
            back.eval(t - t_back)
        }
    })
    .unwrap();
    let step = (tr.t_s.len() / 60).max(1);
    for i in (0..tr.t_s.len()).step_by(step) {
        println!(
            "{:7.3} sp {:9.4} m {:9.4} l {:9.4} twist_um {:8.2} fe_um {:7.2} le_um {:8.2} F {:8.1}",
            tr.t_s[i],
            tr.setpoint[i],
            tr.motor[i],
            tr.load[i],
            (tr.motor[i] - tr.load[i]) * 1e3,
            tr.following_error[i] * 1e3,
            tr.load_error[i] * 1e3,
            tr.motor_force[i]
        );
    }
}
