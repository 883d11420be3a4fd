//! The `interpd` binary's contract: exit codes and stream use (messages on stderr, data on
//! stdout).

use std::process::Command;

fn interpd() -> Command {
    Command::new(env!("CARGO_BIN_EXE_interpd"))
}

#[test]
fn help_and_version() {
    let out = interpd().arg("--help").output().expect("run");
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("check"));
    let out = interpd().arg("--version").output().expect("run");
    assert!(out.status.success());
}

#[test]
fn bad_arguments_exit_2() {
    let out = interpd().arg("no-such-command").output().expect("run");
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
}

#[test]
fn check_valid_and_invalid() {
    let dir = std::env::temp_dir().join(format!("interpd-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let good = dir.join("good.ngc");
    std::fs::write(&good, "G1 X10 F600\nY10\n").expect("write");
    let out = interpd().arg("check").arg(&good).output().expect("run");
    assert_eq!(out.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("ok: 2 elements (2 lines), length 20.000 mm, 1 corners"), "{stdout}");
    let bad = dir.join("bad.ngc");
    std::fs::write(&bad, "G1 X10 F600\nG1 X20 Y Z\nG7\n").expect("write");
    let out = interpd().arg("check").arg(&bad).output().expect("run");
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 2, "{stderr}");
    assert_eq!(lines[0], format!("{}:2:8: word 'Y' has no number", bad.display()));
    assert_eq!(lines[1], format!("{}:3:1: unsupported G-code G7", bad.display()));
    std::fs::remove_dir_all(&dir).ok();
}
