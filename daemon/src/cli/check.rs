//! `interpd check PROGRAM [--machine FILE]`.

use super::CliError;
use interpd::config::Config;
use interpd::service::law_run::{LawProgram, parse_law_program};
use interpd_motion::Settings;
use interpd_motion::program;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

pub fn run(program_path: &Path, machine: Option<&Path>) -> Result<(), CliError> {
    let mut config = Config::load_or_default(machine)?;
    config.programs.default_to_dir_of(program_path);
    let settings = Settings::from_config(&config);
    let t0 = Instant::now();
    // A law program is read whole; G-code and tables are checked in one streaming pass.
    let has_laws = std::fs::File::open(program_path)
        .is_ok_and(|f| interpd::service::law_run::has_law_statement(std::io::BufReader::new(f)));
    if has_laws {
        if let Ok(text) = std::fs::read_to_string(program_path) {
            let name = program_path.display().to_string();
            if let Some(laws) = parse_law_program(&text, &name).map_err(|e| CliError::BadInput(e.to_string()))? {
                return check_laws(&settings, &laws, &name, t0);
            }
        }
    }
    // Operator messages on stderr in program order as the check executes their blocks, so the
    // summary on stdout stays one line.
    let name = program_path.display().to_string();
    // Buffered (a loop may write a million), flushed before any error is printed.
    let mut err = std::io::BufWriter::new(std::io::stderr().lock());
    let checked = program::check_with_messages(program_path, &settings, &mut |m| {
        let _ = writeln!(err, "{name}:{m}");
    });
    let _ = err.flush();
    drop(err);
    let checked = checked?;
    let elapsed = t0.elapsed();
    let s = &checked.summary;
    let kinds: Vec<String> =
        s.kinds.iter().map(|(k, n)| format!("{n} {k}{}", if *n == 1 { "" } else { "s" })).collect();
    let elements: usize = s.kinds.values().sum();
    let corners = checked.corners;
    let mut extra = String::new();
    if s.zero_length_moves > 0 {
        extra += &format!(", {} zero-length moves dropped", s.zero_length_moves);
    }
    if s.ignored_words > 0 {
        extra += &format!(", {} spindle/coolant/tool words ignored", s.ignored_words);
    }
    if !s.tools.is_empty() {
        let tools: Vec<String> = s
            .tools
            .iter()
            .filter_map(|n| settings.tool(*n))
            .map(|t| format!("T{} (diameter {} mm, length {} mm)", t.number, t.diameter_mm, t.length_mm))
            .collect();
        extra += &format!(", tools {}", tools.join(", "));
    }
    if s.compensation {
        extra += ", cutter radius compensation";
    }
    if !s.work_offsets.is_empty() {
        let systems: Vec<String> = s
            .work_offsets
            .iter()
            .map(|name| {
                let Some(i) = interpd_motion::config::WORK_SYSTEMS.iter().position(|w| w == name) else {
                    return name.to_string();
                };
                let v = settings.work_offsets.vector(i, &settings.axes);
                let axes: Vec<String> =
                    settings.axes.iter().enumerate().map(|(k, a)| format!("{}{}", a.name, v[k])).collect();
                match settings.work_offsets.rotation(i) {
                    0.0 => format!("{name} ({})", axes.join(" ")),
                    deg => format!("{name} ({}, turned {deg}°)", axes.join(" ")),
                }
            })
            .collect();
        extra += &format!(", work offsets {}", systems.join(", "));
    }
    let line = format!(
        "{}: ok: {elements} elements ({}), length {:.3} mm, {corners} corners, axes {}{extra}, parsed in {:.1} ms",
        program_path.display(),
        if kinds.is_empty() { "none".to_string() } else { kinds.join(", ") },
        checked.length_mm,
        config.axis_names().join(" "),
        elapsed.as_secs_f64() * 1e3
    );
    writeln!(std::io::stdout(), "{line}").map_err(|e| CliError::Failure(format!("cannot write to stdout: {e}")))?;
    Ok(())
}

/// A program of `LAW` statements: every move solved and checked against the axis limits from
/// the machine origin (the daemon checks again from where the machine stands).
fn check_laws(settings: &Settings, laws: &LawProgram, name: &str, t0: Instant) -> Result<(), CliError> {
    let here = [0.0; interpd_motion::path::MAX_AXES];
    let moves = laws.moves(settings, &here, name).map_err(|e| CliError::BadInput(e.to_string()))?;
    let duration_s: f64 = moves.iter().map(|m| m.duration_s()).sum();
    let line = format!(
        "{name}: ok: {} law moves, {duration_s:.3} s of motion from the origin, axes {}, checked in {:.1} ms",
        moves.len(),
        settings.axis_names().join(" "),
        t0.elapsed().as_secs_f64() * 1e3
    );
    writeln!(std::io::stdout(), "{line}").map_err(|e| CliError::Failure(format!("cannot write to stdout: {e}")))?;
    Ok(())
}
