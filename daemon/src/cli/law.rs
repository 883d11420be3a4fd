//! `interpd law --cond I,Z,F ... [--preset NAME] [--json] [--plot FILE.png] [--out FILE.csv]`:
//! design a motion law from interpolation conditions (Bewegungsdesign nach Maß) and inspect it: degree,
//! residuals, VDI 2143 characteristic values, coefficients, samples and a plot.

use super::CliError;
use super::law_plot;
use interpd_motion::law::{Condition, Law, LawError, Preset};
use serde_json::json;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Most sample points for `--out` and `--plot`.
const MAX_SAMPLES: usize = 1_000_000;

/// Options of `interpd law`.
#[derive(Debug, clap::Args)]
pub struct LawArgs {
    /// Interpolation condition f⁽ᴵ⁾(Z) = F: derivative order I ≥ 0, normalised time Z in [0, 1],
    /// value F. Repeat for each condition; added after the preset's.
    #[arg(long = "cond", value_name = "I,Z,F", allow_hyphen_values = true)]
    pub cond: Vec<String>,
    /// Built-in law: rr5, rr7, rr11, asymmetric, constant-velocity, degree8, inflection:LAMBDA.
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Print one JSON object (degree, cv, ca, cj, max_residual, coefficients, residuals, …).
    #[arg(long)]
    pub json: bool,
    /// Draw f, f′, f″, f‴ into a PNG file.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,
    /// Write z,f,f1,f2,f3 on a uniform grid as CSV.
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// Grid points for --out and --plot (2 … 1000000).
    #[arg(long, default_value_t = 1001)]
    pub samples: usize,
}

/// Where a condition came from, for messages.
fn origins(preset: Option<&Preset>, n_preset: usize, cond: &[String]) -> Vec<String> {
    let mut out: Vec<String> =
        (0..n_preset).map(|_| format!("preset {}", preset.map(Preset::name).unwrap_or_default())).collect();
    out.extend(cond.iter().map(|c| format!("--cond {c}")));
    out
}

pub fn run(args: &LawArgs) -> Result<(), CliError> {
    if !(2..=MAX_SAMPLES).contains(&args.samples) {
        return Err(CliError::BadInput(format!("--samples must be 2 … {MAX_SAMPLES}, got {}", args.samples)));
    }
    let preset = match &args.preset {
        Some(name) => Some(Preset::parse(name).map_err(|e| CliError::BadInput(format!("--preset {name}: {e}")))?),
        None => None,
    };
    let mut conditions = preset.as_ref().map(Preset::conditions).unwrap_or_default();
    let n_preset = conditions.len();
    for text in &args.cond {
        let c = Condition::parse(text).map_err(|e| CliError::BadInput(format!("--cond {e}")))?;
        c.validate(conditions.len())
            .map_err(|e| CliError::BadInput(format!("--cond '{text}': {}", without_index(&e))))?;
        conditions.push(c);
    }
    if conditions.is_empty() {
        return Err(CliError::BadInput("no conditions: give --cond I,Z,F (repeatable) and/or --preset NAME".into()));
    }
    let law = Law::from_conditions(conditions.clone()).map_err(|e| {
        let from = origins(preset.as_ref(), n_preset, &args.cond);
        let list: Vec<String> =
            conditions.iter().zip(&from).enumerate().map(|(k, (c, o))| format!("  {:2}  {c}   ({o})", k + 1)).collect();
        let msg = format!("{e}\nconditions:\n{}", list.join("\n"));
        match e {
            LawError::Numerical { .. } => CliError::Failure(msg),
            _ => CliError::BadInput(msg),
        }
    })?;
    if let Some(p) = &args.out {
        write_csv(&law, p, args.samples)?;
    }
    if let Some(p) = &args.plot {
        let title = match &preset {
            Some(p) if args.cond.is_empty() => format!("motion law {} (degree {})", p.name(), law.degree()),
            _ => format!("motion law of degree {} ({} conditions)", law.degree(), law.conditions().len()),
        };
        law_plot::write_png(&law, &title, p, args.samples).map_err(CliError::Failure)?;
    }
    let text = if args.json { report_json(&law, preset.as_ref()) } else { report_text(&law) };
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{text}").map_err(|e| CliError::Failure(format!("cannot write to stdout: {e}")))
}

/// The message of a single-condition error without its "condition N: " prefix (the option
/// value names the condition already).
fn without_index(e: &LawError) -> String {
    let s = e.to_string();
    match s.split_once(": ") {
        Some((head, rest)) if head.starts_with("condition ") => rest.to_string(),
        _ => s,
    }
}

fn write_csv(law: &Law, path: &Path, samples: usize) -> Result<(), CliError> {
    let file = std::fs::File::create(path)
        .map_err(|e| CliError::Failure(format!("{}: cannot create: {e}", path.display())))?;
    let mut w = BufWriter::new(file);
    let werr = |e: std::io::Error| CliError::Failure(format!("{}: cannot write: {e}", path.display()));
    writeln!(w, "z,f,f1,f2,f3").map_err(werr)?;
    for k in 0..samples {
        // k/(n−1) hits 0 and 1 exactly.
        let z = k as f64 / (samples - 1) as f64;
        let d = law.eval(z);
        writeln!(w, "{z},{},{},{},{}", d.f, d.f1, d.f2, d.f3).map_err(werr)?;
    }
    w.flush().map_err(werr)
}

fn report_json(law: &Law, preset: Option<&Preset>) -> String {
    let ch = law.characteristics();
    let conditions: Vec<serde_json::Value> = law
        .residuals()
        .iter()
        .map(|r| {
            json!({
                "i": r.condition.order, "z": r.condition.z, "f": r.condition.value,
                "achieved": r.achieved, "residual": r.abs, "residual_f64": r.abs_f64,
            })
        })
        .collect();
    json!({
        "preset": preset.map(Preset::name),
        "degree": law.degree(),
        "cv": ch.cv.value, "cv_z": ch.cv.z,
        "ca": ch.ca.value, "ca_z": ch.ca.z,
        "cj": ch.cj.value, "cj_z": ch.cj.z,
        "f_min": ch.f_min.value, "f_min_z": ch.f_min.z,
        "f_max": ch.f_max.value, "f_max_z": ch.f_max.z,
        "max_residual": law.max_residual(),
        "max_residual_f64": law.max_residual_f64(),
        "rcond": law.rcond(),
        "conditions": conditions,
        "chebyshev": law.chebyshev_coefficients(),
        "monomial": law.monomial_coefficients(),
    })
    .to_string()
}

fn report_text(law: &Law) -> String {
    let ch = law.characteristics();
    let mut s = format!(
        "degree {} ({} conditions), reciprocal condition number {:.2e}\n\
         C_v = {:.10} at z = {:.6}\nC_a = {:.10} at z = {:.6}\nC_j = {:.10} at z = {:.6}\n\
         f ranges {:.6} (z = {:.4}) … {:.6} (z = {:.4})\n\
         max residual {:.2e} (f64 coefficients as evaluated at run time: {:.2e})\n\
         conditions:\n",
        law.degree(),
        law.conditions().len(),
        law.rcond(),
        ch.cv.value,
        ch.cv.z,
        ch.ca.value,
        ch.ca.z,
        ch.cj.value,
        ch.cj.z,
        ch.f_min.value,
        ch.f_min.z,
        ch.f_max.value,
        ch.f_max.z,
        law.max_residual(),
        law.max_residual_f64(),
    );
    for (k, r) in law.residuals().iter().enumerate() {
        s += &format!("  {:2}  {:<22} residual {:.1e}\n", k + 1, r.condition.to_string(), r.abs);
    }
    s += "coefficients a_k of f(z) = Σ a_k z^k:\n";
    for (k, a) in law.monomial_coefficients().iter().enumerate() {
        s += &format!("  a{k:<2} = {a:+.15e}\n");
    }
    s.trim_end().to_string()
}
