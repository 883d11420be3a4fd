//! `interpd check PROGRAM [--machine FILE]`.

use super::CliError;
use interpd::config::Config;
use interpd::program;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

pub fn run(program_path: &Path, machine: Option<&Path>) -> Result<(), CliError> {
    let config = Config::load_or_default(machine)?;
    let t0 = Instant::now();
    let program = program::load(program_path, &config)?;
    let elapsed = t0.elapsed();
    let s = &program.summary;
    let kinds: Vec<String> =
        s.kinds.iter().map(|(k, n)| format!("{n} {k}{}", if *n == 1 { "" } else { "s" })).collect();
    let elements: usize = s.kinds.values().sum();
    let corners = program.path.elements.iter().filter(|e| e.joint == interpd::path::JointKind::Corner).count();
    let mut extra = String::new();
    if s.zero_length_moves > 0 {
        extra += &format!(", {} zero-length moves dropped", s.zero_length_moves);
    }
    if s.ignored_words > 0 {
        extra += &format!(", {} spindle/coolant/tool words ignored", s.ignored_words);
    }
    let line = format!(
        "{}: ok: {elements} elements ({}), length {:.3} mm, {corners} corners, axes {}{extra}, parsed in {:.1} ms",
        program_path.display(),
        if kinds.is_empty() { "none".to_string() } else { kinds.join(", ") },
        program.path.length_mm(),
        config.axis_names().join(" "),
        elapsed.as_secs_f64() * 1e3
    );
    writeln!(std::io::stdout(), "{line}").map_err(|e| CliError::Failure(format!("cannot write to stdout: {e}")))?;
    Ok(())
}
