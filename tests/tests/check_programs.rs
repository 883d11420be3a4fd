//! `interpd check` on the example programs (all valid) and on the corpus of bad programs under
//! tests/programs/bad/, each of which names its exact expected first error in its first line
//! (`; expect: LINE:COL: message`). Runs the real binary.

use interpd_e2e::{binary, repo_root};
use std::process::Command;
use std::time::Instant;

fn check(rel_path: &str, machine: Option<&str>) -> (i32, String, String) {
    let mut cmd = Command::new(binary("interpd"));
    cmd.current_dir(repo_root()).arg("check").arg(rel_path);
    if let Some(m) = machine {
        cmd.arg("--machine").arg(m);
    }
    let out = cmd.output().expect("run interpd check");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_programs_report_exact_positions() {
    let dir = repo_root().join("tests/programs/bad");
    let mut files: Vec<_> = std::fs::read_dir(&dir).expect("corpus dir").map(|e| e.expect("entry").path()).collect();
    files.sort();
    assert!(files.len() >= 30, "the corpus must hold at least 30 bad programs, has {}", files.len());
    let mut failures = Vec::new();
    for path in &files {
        let text = std::fs::read_to_string(path).expect("read corpus file");
        let first = text.lines().next().unwrap_or("");
        let expect = first
            .strip_prefix("; expect: ")
            .or_else(|| first.strip_prefix("# expect: "))
            .unwrap_or_else(|| panic!("{} lacks an '; expect:' line", path.display()));
        let rel = format!("tests/programs/bad/{}", path.file_name().expect("name").to_string_lossy());
        let (code, stdout, stderr) = check(&rel, None);
        let got = stderr.lines().next().unwrap_or("");
        let want = format!("{rel}:{expect}");
        if code != 2 || got != want || stderr.contains("panicked") || !stdout.is_empty() {
            failures.push(format!("{rel}: exit {code}\n  want: {want}\n  got:  {got}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad programs misreported:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n")
    );
}

#[test]
fn examples_are_valid() {
    let dir = repo_root().join("examples");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("examples dir") {
        let path = entry.expect("entry").path();
        let name = path.file_name().expect("name").to_string_lossy().into_owned();
        if !(name.ends_with(".ngc") || name.ends_with(".csv")) {
            continue;
        }
        let machine = name.contains("five_axis").then_some("config/machines/xyzab.toml");
        let (code, stdout, stderr) = check(&format!("examples/{name}"), machine);
        assert_eq!(code, 0, "{name}: {stderr}");
        assert!(stdout.contains(": ok: "), "{name}: {stdout}");
        n += 1;
    }
    assert!(n >= 8, "expected the example programs, found {n}");
}

#[test]
fn dense_program_checks_under_one_second() {
    let t0 = Instant::now();
    let (code, stdout, stderr) = check("examples/dense_freeform.ngc", None);
    let wall = t0.elapsed();
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("100001 elements"), "{stdout}");
    // The budget is for a release build (CI); a debug build gets ten times as much.
    let budget = if cfg!(debug_assertions) { 10.0 } else { 1.0 };
    assert!(wall.as_secs_f64() < budget, "check took {:.3} s", wall.as_secs_f64());
}

#[test]
fn not_utf8_and_missing_file() {
    let dir = std::env::temp_dir().join(format!("interpd-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bin = dir.join("latin1.ngc");
    std::fs::write(&bin, b"G1 X1 F100\n(caf\xe9)\n").expect("write");
    let (code, _, stderr) = check(bin.to_str().expect("utf-8 path"), None);
    assert_eq!(code, 2);
    assert_eq!(stderr.lines().next(), Some(format!("{}:2:5: the file is not UTF-8 text", bin.display()).as_str()));
    let (code, _, stderr) = check("/nonexistent/x.ngc", None);
    assert_eq!(code, 2);
    assert!(stderr.starts_with("/nonexistent/x.ngc:0:0: cannot read"), "{stderr}");
    let (code, _, stderr) = check("examples/corner_90.ngc", Some("/nonexistent/m.toml"));
    assert_eq!(code, 2);
    assert!(stderr.starts_with("/nonexistent/m.toml: cannot read configuration"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `interpd check FILE` (and `plan`) without a configured `[programs] dir` reads subroutine
/// files from the program's own directory, as LinuxCNC's `rs274` does, wherever it is run
/// from (here from the repository, the program in a scratch directory).
#[test]
fn subroutine_files_beside_the_program_are_found() {
    let dir = std::env::temp_dir().join(format!("interpd-check-sub-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("square.ngc"), "o<square> sub\nG1 X#1 F600\nG1 Y#1\no<square> endsub\nM2\n").expect("sub");
    let main = dir.join("main.ngc");
    std::fs::write(&main, "G21 G90\no<square> call [5]\nM2\n").expect("main");
    let (code, out, err) = check(main.to_str().expect("utf-8 path"), None);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(code, 0, "stdout {out}\nstderr {err}");
    assert!(out.contains("2 lines"), "{out}");
}
