//! Exact stop vs smoothed on the Haas axis plant (Haas 2012, §3.6.4, §5.3): the programmed
//! motion of the 90° corner and the staircase, sampled every cycle, drives the 3-mass axes of
//! `config/plants/haas-laser.toml` (with crosstalk); printed are the lateral deviation of the
//! setpoints and of the TCP (load) from the programmed path, and the excitation metric, the
//! TCP's deviation minus the setpoints' own deviation at each instant.
//!
//! ```sh
//! cargo bench -p interpd --bench prep_plant
//! ```

// Shared with `prep_methods`, which also uses its trace and its reference from a path.
#[path = "common/haas_plant.rs"]
#[allow(dead_code)]
mod haas_plant;
#[path = "common/reference.rs"]
#[allow(dead_code)]
mod reference;

use haas_plant::{Reference, repo_file, simulate, with_mode};
use interpd::config::Config;
use interpd_motion::Settings;
use interpd_motion::prep::prepare_path;
use interpd_motion::program;
use std::io::Write;

fn main() {
    let text = format!(
        "{}\n[plant]\npreset = \"haas-laser\"\napply_crosstalk = true\n",
        interpd::config::DEFAULT_MACHINE_TOML
    );
    let config = Config::from_toml_str(&text, "<default machine, haas-laser plant>").expect("machine");
    let mut out = std::io::stdout().lock();
    let shapes: [(&str, Vec<(f64, f64)>); 2] = [
        ("corner_90", vec![(0.0, 0.0), (100.0, 0.0), (100.0, 100.0)]),
        (
            "staircase",
            vec![(0.0, 0.0), (40.0, 0.0), (40.0, 20.0), (60.0, 20.0), (60.0, 40.0), (80.0, 40.0), (80.0, 80.0)],
        ),
    ];
    for (name, corners) in &shapes {
        let source = repo_file(&format!("examples/{name}.ngc"));
        for mode in ["G61", "G64 P0.1", "G64 P0.01"] {
            let path =
                program::parse(&with_mode(&source, mode), "bench.ngc", &Settings::from(&config)).expect("parses").path;
            let path = prepare_path(&Settings::from(&config), &path).expect("smoothing").path;
            let f = simulate(&config, &path, &Reference::from_points(corners));
            writeln!(
                out,
                "{name:>10} {mode:<9}: {:.4} s; lateral deviation max: setpoints {:.4} mm, TCP {:.4} mm; \
                 excitation (TCP − setpoint deviation) max {:.5} mm, rms {:.5} mm",
                f.duration_s, f.setpoint_max_mm, f.load_max_mm, f.excitation_max_mm, f.excitation_rms_mm
            )
            .ok();
        }
    }
}
