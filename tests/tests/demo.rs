//! `interpd demo`, the main job: runs in a fresh directory, exits 0, prints the figures and
//! writes its plot. (`interpd demo --scenario milling-circle` runs in interpd-sim; its test is
//! `sim/tests/milling_circle.rs`.)

use interpd_e2e::binary;
use std::process::Command;

#[test]
fn demo_runs_end_to_end_and_writes_its_plot() {
    let dir = std::env::temp_dir().join(format!("interpd-demo-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let started = std::time::Instant::now();
    let out = Command::new(binary("interpd")).arg("demo").current_dir(&dir).output().expect("run interpd demo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "interpd demo failed:\n{stdout}\n{stderr}");
    assert!(started.elapsed().as_secs() < 60, "the demo took {:?}", started.elapsed());
    for want in [
        "finished in",
        "max following error",
        "max contour error",
        "wake-up latency",
        "overshoot",
        "residual vibration",
        "plot:",
    ] {
        assert!(stdout.contains(want), "summary lacks {want:?}:\n{stdout}");
    }
    assert!(stdout.contains("missed cycles: 0"), "the plant missed setpoints:\n{stdout}");
    let png = std::fs::read(dir.join("interpd-demo.png")).expect("the plot");
    assert!(png.len() > 10_000 && png.starts_with(b"\x89PNG"), "not a plot");
    let _ = std::fs::remove_dir_all(&dir);
}
