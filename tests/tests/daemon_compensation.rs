//! The compensation stage in the running daemon against `sim-plant` over iceoryx2: position
//! control on the plant's tool measurement corrects the milling deflection; when the plant, and
//! with it the measurement, goes away mid-motion, the correction fades out without a step, the
//! `measurement_lost` event is raised, and the stream sent to the drives keeps every axis limit.

use interpd::config::Config;
use interpd_e2e::daemon::{AxisLimits, Collector, Daemon, limit_ratios};
use interpd_e2e::process::Plant;
use serde_json::{Value, json};
use std::time::{Duration, Instant};

const MACHINE: &str = include_str!("../../examples/milling_circle.toml");
const TIMEOUT: Duration = Duration::from_secs(30);

/// A straight cut along X at 10 mm/s (the milling force pushes the tool to the left of the
/// feed, +Y, so the correction is along −Y and the programmed Y stays 0).
const PROGRAM: &str = "G21 G90 G17\nG1 X60 F600\nM30\n";

#[test]
fn a_lost_measurement_fades_the_correction_out_and_raises_the_event() {
    let dir = std::env::temp_dir().join(format!("interpd-comp-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = format!(
        "{MACHINE}\n[compensation]\n[compensation.measurement]\nposition_axes = [\"X\", \"Y\"]\n\n\
         [[compensation.axis]]\nname = \"X\"\nstrategy = \"position\"\n\n\
         [[compensation.axis]]\nname = \"Y\"\nstrategy = \"position\"\n"
    );
    let path = dir.join("machine.toml");
    std::fs::write(&path, &text).unwrap();
    let config = Config::load(&path).expect("machine");
    let cfg = path.display().to_string();
    let daemon = Daemon::start(&["--config", &cfg]);
    let plant = Plant::start(&daemon.prefix, &["--config", &cfg], &dir.join("plant.log"));
    let until = Instant::now() + TIMEOUT;
    while !plant.stderr().contains("ready") {
        assert!(Instant::now() < until, "sim-plant not ready: {}", plant.stderr());
        std::thread::sleep(Duration::from_millis(20));
    }
    let collector = Collector::start(&daemon.prefix);
    let mut c = daemon.client();
    c.ok("subscribe", Value::Null);
    c.ok("program.load", json!({"text": PROGRAM, "name": "cut.ngc"}));
    c.ok("motion.start", Value::Null);
    // 2.5 s into the 6 s cut the position loop has taken over the deflection.
    std::thread::sleep(Duration::from_millis(2500));
    let before = collector.snapshot();
    let corrected_y = before.last().expect("setpoints").pos[1];
    // The plant goes away as a crash would: no more measurements.
    plant.kill();
    let killed = Instant::now();
    c.wait_event("measurement_lost", Duration::from_secs(2));
    let noticed = killed.elapsed();
    let st = c.wait_state(&["finished"], TIMEOUT);
    assert_eq!(st["state"], "finished", "{st}");
    std::thread::sleep(Duration::from_millis(300));
    let sps = collector.finish();
    let (code, stderr) = daemon.terminate();
    assert_eq!(code, Some(0), "{stderr}");

    // While the measurement arrived, the correction held the tool against the force.
    assert!(corrected_y < -0.1, "the correction along Y was only {corrected_y} mm");
    // After the fade-out the setpoint is the programmed one again.
    let end = sps.last().expect("setpoints");
    assert!(end.pos[1].abs() < 1e-6 && (end.pos[0] - 60.0).abs() < 1e-6, "ends at {:?}", &end.pos[..2]);
    // No step: the whole stream, the fade-out included, keeps every limit.
    let r = limit_ratios(config.machine.cycle_ms * 1e-3, &AxisLimits::of(&config), &sps);
    eprintln!(
        "compensation: correction {:.1} µm along Y before the plant was killed; measurement_lost {:.0} ms after; \
         {} setpoints, limit ratios v {:.3} a {:.3} j {:.3}",
        corrected_y * 1e3,
        noticed.as_secs_f64() * 1e3,
        sps.len(),
        r[0],
        r[1],
        r[2]
    );
    assert!(r[0] <= 1.0 && r[1] <= 1.0 && r[2] <= 1.0, "limit ratios {r:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
