//! What the plant benchmarks share (`prep_plant`, `prep_methods`): the example programs with a
//! blending mode put in, the programmed path as a reference polyline, and one run of a planned
//! path through the plant, sampled every cycle, with the lateral deviation of the setpoints and
//! of the TCP and the excitation as Haas 2012 defines it (§3.6.4): the TCP's deviation minus
//! the setpoints' own, per instant.

use interpd::config::Config;
use interpd_motion::Settings;
use interpd_motion::path::{AxisDerivs, Path};
use interpd_motion::planner::Planner;
use interpd_motion::planner::profile::{Cursor, duration_s};
use sim_plant::{AxisTarget, Plant};

pub use crate::reference::Reference;

pub fn repo_file(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The program with `word` before its first G1 block.
pub fn with_mode(text: &str, word: &str) -> String {
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

/// Settling time simulated after the motion ends, s.
const SETTLE_S: f64 = 0.2;

pub struct Figures {
    pub duration_s: f64,
    pub setpoint_max_mm: f64,
    pub load_max_mm: f64,
    pub excitation_max_mm: f64,
    pub excitation_rms_mm: f64,
    /// (t, excitation) per cycle, for the plot.
    pub trace: Vec<(f64, f64)>,
}

pub fn simulate(config: &Config, path: &Path, reference: &Reference) -> Figures {
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
