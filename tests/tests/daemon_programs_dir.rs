//! End to end: `program.load {"path"}` reads programs from the programs directory only
//! (`[programs] dir`): relative paths inside it, absolute paths that lie in it; `..`, paths
//! outside it and symbolic links that lead out of it are refused with −32602 naming the rule
//! and the `path` parameter, and nothing of any file is echoed.

use interpd_e2e::daemon::Daemon;
use interpd_protocol::api::codes;
use serde_json::{Value, json};
use std::path::PathBuf;

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("interpd-progdir-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn program_load_reads_inside_the_programs_directory_only() {
    let root = temp_dir("load");
    let programs = root.join("programs");
    std::fs::create_dir_all(programs.join("sub")).expect("dirs");
    std::fs::write(programs.join("part.ngc"), "G21 G90\nG1 X1 F600\nM30\n").expect("write");
    std::fs::write(programs.join("sub/other.ngc"), "G21 G90\nG1 Y1 F600\nM30\n").expect("write");
    // A readable file outside, with content that must never appear in an answer.
    std::fs::write(root.join("secret.ngc"), "SECRET-CONTENT 42\n").expect("write");
    std::os::unix::fs::symlink(&root, programs.join("escape")).expect("symlink");
    let cfg = root.join("machine.toml");
    let text = format!("{}\n[programs]\ndir = \"{}\"\n", interpd_config::DEFAULT_MACHINE_TOML, programs.display());
    std::fs::write(&cfg, text).expect("config");
    let daemon = Daemon::start(&["--config", cfg.to_str().expect("utf-8")]);
    let mut c = daemon.client();

    let info = c.ok("program.load", json!({ "path": "part.ngc" }));
    assert_eq!((info["name"].as_str(), info["lines"].as_u64()), (Some("part.ngc"), Some(3)), "{info}");
    let inside = programs.join("sub/other.ngc").display().to_string();
    c.ok("program.load", json!({ "path": inside }));

    let secret = root.join("secret.ngc").display().to_string();
    for (path, rule) in [
        (secret.as_str(), "lies outside the programs directory"),
        ("/etc/passwd", "lies outside the programs directory"),
        ("../secret.ngc", "contains `..`"),
        ("sub/../../secret.ngc", "contains `..`"),
        ("escape/secret.ngc", "lies outside the programs directory"),
    ] {
        let answer = c.call("program.load", json!({ "path": path }));
        let err = &answer["error"];
        assert_eq!(err["code"], codes::INVALID_PARAMS, "{path}: {answer}");
        assert_eq!(err["data"]["param"], "path", "{path}: {answer}");
        let msg = err["message"].as_str().unwrap_or_default();
        assert!(msg.contains(rule) && msg.contains("[programs] dir"), "{path}: {msg}");
        assert!(!msg.contains("SECRET") && !msg.contains("root:"), "{path}: file content in the answer: {msg}");
    }
    // A missing file inside the directory: the usual "cannot read".
    let answer = c.call("program.load", json!({ "path": "missing.ngc" }));
    assert_eq!(answer["error"]["code"], codes::BAD_PROGRAM, "{answer}");
    assert!(answer["error"]["message"].as_str().unwrap_or_default().contains("cannot read"), "{answer}");
    // The refusals left the last good program loaded, and nothing moved.
    let st = c.ok("status", Value::Null);
    assert_eq!((st["state"].as_str(), st["program"]["name"].as_str()), (Some("idle"), Some(inside.as_str())), "{st}");
    drop(c);
    let (code, err) = daemon.terminate();
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains(&format!("program.load reads files from {}", programs.canonicalize().expect("dir").display())),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_programs_directory_that_does_not_exist_stops_the_start() {
    let root = temp_dir("missing");
    let cfg = root.join("machine.toml");
    let text =
        format!("{}\n[programs]\ndir = \"{}\"\n", interpd_config::DEFAULT_MACHINE_TOML, root.join("nope").display());
    std::fs::write(&cfg, text).expect("config");
    let out = std::process::Command::new(interpd_e2e::binary("interpd"))
        .args(["run", "--no-shm", "--socket"])
        .arg(root.join("s.sock"))
        .arg("--config")
        .arg(&cfg)
        .output()
        .expect("run interpd");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("programs.dir") && stderr.contains("nope"), "{stderr}");
    let _ = std::fs::remove_dir_all(&root);
}
