//! Time-bounded fuzzing of the program parsers (G-code with G06, path tables) and the
//! configuration loader: mutations of the example programs and of the bad-program corpus,
//! plus grammar-shaped random programs. Every input must yield a program or errors, never a
//! panic; an accepted program must evaluate to finite geometry everywhere; and a word that no
//! code uses, put into an accepted G-code program, must make it an error at that line.
//!
//! The run lasts `FUZZ_SECONDS` (default 2 s; CI's scripts/test.sh sets 60 s). Each run prints its
//! `FUZZ_SEED`; setting it replays that run's inputs (up to the time limit).

use interpd_motion::Settings;
use interpd_motion::path::AxisDerivs;
use interpd_motion::program;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const TOKENS: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G4",
    "G06",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G61",
    "G64",
    "G90",
    "G91",
    "X",
    "Y",
    "Z",
    "A",
    "I",
    "J",
    "K",
    "R",
    "P",
    "Q",
    "F",
    "N",
    "M3",
    "M4",
    "M6",
    "M8",
    "M30",
    "S",
    "T",
    "H",
    "E",
    "D",
    "L",
    "O",
    "e",
    "1e300",
    "G43",
    ";",
    "(",
    ")",
    "CR",
    "\n",
    " ",
    "-",
    ".",
    "0",
    "1",
    "5",
    "10",
    "-10",
    "1e3",
    "999999999",
    "0.0001",
    "%",
    "/",
    ",",
    "s",
    "'",
    "nan",
    "inf",
    // LinuxCNC's language: parameters, expressions, O words, cycles, offsets.
    "#1",
    "#<x>",
    "#<_y>",
    "##1",
    "#5420",
    "=",
    "[",
    "]",
    "[1+2]",
    "[#1/0]",
    "**",
    " MOD ",
    " AND ",
    " EQ ",
    "SIN[30]",
    "ATAN[1]/[0]",
    "SQRT[-1]",
    "EXISTS[#<x>]",
    "o1 sub\n",
    "o1 endsub\n",
    "o1 call [2]\n",
    "o<s> call\n",
    "o2 while [#1 LT 5]\n",
    "o2 endwhile\n",
    "o3 if [1]\n",
    "o3 else\n",
    "o3 endif\n",
    "o4 repeat [3]\n",
    "o4 endrepeat\n",
    "o5 do\n",
    "o5 while [0]\n",
    "o2 break\n",
    "o2 continue\n",
    "o1 return [7]\n",
    "#1 = [#1 + 1]\n",
    // Operator messages: parameter substitution, formats, unterminated names.
    "(MSG, text #1)",
    "(DEBUG, #1 #<x> #<_y>)",
    "(PRINT, %d#1 %.3f#<x>)",
    "(debug,#",
    "(PRINT, #<x",
    "#5599 = 0\n",
    "G81",
    "G83",
    "G80",
    "G98",
    "G99",
    "G10 L2 P1",
    "G28",
    "G53",
    "G93",
    "M0",
    // LinuxCNC's splines.
    "G5",
    "G5.1",
    "G5.2",
    "G5.3",
    "G5.2 P1 L4\nX1 Y1 P1\nX2 Y0 P2\nX3 Y1 P1\nG5.3\n",
    "G5 X1 Y1 I1 J1 P-1 Q1",
    // Polar coordinates.
    "@",
    "^",
    "@1 ^45",
    // Modal state, spindle orientation, tool number.
    "M70",
    "M72",
    "M73",
    "M19 R45",
    "M61 Q1",
    // Rotated work systems, EXISTS out of range, the exit move in place.
    "G10 L2 P1 X3 Y7 R45",
    "G10 L2 P0 R-30",
    "G10 L20 P1 X0",
    "G2 X1 Y1 I1 R",
    "EXISTS[#99999]",
    "G40\nG0 X0 Y0\n",
    // Tool offsets written by the program and applied by G43 on every axis; fractional N.
    "G10 L1 P1 X1 Y2 Z3 R2",
    "G10 L10 P1 X0",
    "G10 L11 P1 Z0 Q3",
    "T1 M6 G43",
    "#5401",
    "N10.5",
];

fn corpus() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out = Vec::new();
    for dir in ["examples", "tests/programs/bad", "tests/programs/language"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir)) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if name.contains("dense") {
                continue; // large; its first lines are enough
            }
            if let Ok(t) = std::fs::read_to_string(&p) {
                out.push((name, t));
            }
        }
    }
    out.push((
        "dense_head.ngc".into(),
        "G21 G90 G17\nG0 X1 Y2 Z0\nG1 F6000\nX1.0001 Y2.0003 Z0\nX1.0003 Y2.0007 Z0.0001\n".into(),
    ));
    out
}

fn mutate(rng: &mut Rng, base: &str) -> String {
    let mut s: Vec<char> = base.chars().collect();
    for _ in 0..1 + rng.below(8) {
        let pos = rng.below(s.len() + 1);
        match rng.below(5) {
            0 if !s.is_empty() => {
                let end = (pos + rng.below(6)).min(s.len());
                s.drain(pos.min(s.len())..end);
            }
            1 => {
                let tok = TOKENS[rng.below(TOKENS.len())];
                for (i, c) in tok.chars().enumerate() {
                    s.insert((pos + i).min(s.len()), c);
                }
            }
            2 if !s.is_empty() => {
                let i = pos.min(s.len() - 1);
                s[i] = char::from_u32(rng.below(0x80) as u32).unwrap_or('?');
            }
            3 if !s.is_empty() => {
                // duplicate a slice (repeated blocks, long numbers)
                let a = pos.min(s.len() - 1);
                let b = (a + rng.below(20)).min(s.len());
                let chunk: Vec<char> = s[a..b].to_vec();
                for (i, c) in chunk.into_iter().enumerate() {
                    s.insert((b + i).min(s.len()), c);
                }
            }
            _ => {
                let digit = char::from(b'0' + rng.below(10) as u8);
                s.insert(pos.min(s.len()), digit);
            }
        }
    }
    s.into_iter().collect()
}

fn generated(rng: &mut Rng) -> String {
    let mut s = String::new();
    for _ in 0..rng.below(40) {
        s.push_str(TOKENS[rng.below(TOKENS.len())]);
        if rng.below(3) == 0 {
            s.push(' ');
        }
    }
    s
}

/// Parses `text` under each configuration; describes the first failure (a panic, or an accepted
/// program with non-finite geometry).
fn check_input(name: &str, text: &str, cfgs: &[Settings]) -> Result<(), String> {
    for cfg in cfgs {
        let result = catch_unwind(AssertUnwindSafe(|| program::parse(text, name, cfg)));
        let Ok(result) = result else {
            return Err(format!("the parser panicked (machine with axes {})", cfg.axis_names().join(" ")));
        };
        if let Err(e) = &result {
            if let Some(e) = e.0.iter().find(|e| e.line == 0 || e.col == 0) {
                return Err(format!("an error without its place: {e}"));
            }
        }
        if let Ok(p) = result {
            let mut d = AxisDerivs::default();
            for e in &p.path.elements {
                for f in [0.0, 0.5, 1.0] {
                    let s_mm = e.s_start_mm + f * e.geometry.length_mm();
                    p.path.eval(s_mm, &mut d);
                    let finite = (0..p.path.n_axes).all(|k| {
                        d.pos[k].is_finite() && d.d1[k].is_finite() && d.d2[k].is_finite() && d.d3[k].is_finite()
                    });
                    if !finite {
                        return Err(format!(
                            "non-finite geometry at s = {s_mm} mm (element from line {})",
                            e.source.line
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Words that no code of interpd's dialect takes.
const STRAY_WORDS: &[&str] = &["H1", "E2", "D3", "h0", "e 5"];

/// Puts a stray word at the start of a random line of an accepted G-code program (before its
/// end: M2, M30 or a closing `%`); the program must now be refused at that line. Describes the
/// failure.
fn check_stray_word(rng: &mut Rng, name: &str, text: &str, cfg: &Settings) -> Result<(), String> {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines.iter().position(|l| ends_program(l)).unwrap_or(lines.len());
    if end == 0 {
        return Ok(());
    }
    let at = rng.below(end);
    let word = STRAY_WORDS[rng.below(STRAY_WORDS.len())];
    let mut changed: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    changed[at] = format!("{word} {}", changed[at]);
    let changed = changed.join("\n");
    // G41/G42/G43 without D/H take the tool in the spindle: on their line a D or H word is
    // one they take, not a stray one.
    let takes_tool = |l: &str| ["G41", "G42", "G43"].iter().any(|g| l.to_ascii_uppercase().contains(g));
    match program::parse(&changed, name, cfg) {
        Ok(_) if word.to_ascii_uppercase().starts_with(['D', 'H']) && takes_tool(lines[at]) => Ok(()),
        Ok(_) => Err(format!("the stray word {word} at line {} was accepted", at + 1)),
        Err(e) if e.0.iter().any(|e| e.line == at as u32 + 1) => Ok(()),
        Err(e) => Err(format!("the stray word {word} at line {} gave errors elsewhere: {e}", at + 1)),
    }
}

/// The line may end the program: it holds a `%`, or an M word whose number is 2 or 30 as the
/// parser reads numbers (`M030` and `M2.0` too). Text after the end is not read, so a stray word
/// there is no error. A comment naming M2 counts too, which only narrows where words go.
fn ends_program(line: &str) -> bool {
    let k: Vec<u8> = line.bytes().filter(|c| !c.is_ascii_whitespace()).map(|c| c.to_ascii_uppercase()).collect();
    k.contains(&b'%')
        || k.iter().enumerate().any(|(i, &c)| {
            let number: String =
                k[i + 1..].iter().take_while(|d| d.is_ascii_digit() || **d == b'.').map(|&d| d as char).collect();
            c == b'M' && matches!(number.parse::<f64>(), Ok(v) if v == 2.0 || v == 30.0)
        })
}

/// A failure report a reader can act on: the lines where the input differs from its base,
/// and the whole input saved to a file.
fn report(seed: u64, name: &str, base: &str, text: &str, what: &str) -> String {
    let file = std::env::temp_dir().join(format!("interpd-fuzz-{seed}-{name}"));
    let saved = match std::fs::write(&file, text) {
        Ok(()) => format!("input saved to {}", file.display()),
        Err(e) => format!("input not saved ({e})"),
    };
    let (a, b): (Vec<&str>, Vec<&str>) = (base.lines().collect(), text.lines().collect());
    let changed: Vec<String> = (0..a.len().max(b.len()))
        .filter(|&i| a.get(i) != b.get(i))
        .take(6)
        .map(|i| format!("  line {}: {:?}", i + 1, b.get(i).copied().unwrap_or("<none>")))
        .collect();
    format!(
        "FUZZ_SEED={seed}: {what} on input {name} ({saved}); first lines that differ from its base:\n{}",
        changed.join("\n")
    )
}

/// Inputs and accepted programs with a stray word a run tries at least, however short its time.
const MIN_INPUTS: u64 = 100;
const MIN_STRAY: u64 = 10;
/// A run that has not found `MIN_STRAY` accepted programs by this many inputs fails: the
/// generator or the parser has stopped producing valid programs.
const MAX_INPUTS_FOR_MIN: u64 = 5000;

#[test]
fn fuzz_program_parsers() {
    let seconds: f64 = std::env::var("FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let started = Instant::now();
    let deadline = started + Duration::from_secs_f64(seconds);
    // A small loop cap: a mutated loop that never ends is refused quickly (no hang).
    let capped = |mut s: Settings| {
        s.programs.max_loop_iterations = 2_000;
        s
    };
    let cfgs = [capped(Settings::default_machine()), capped(Settings::five_axis_machine())];
    let corpus = corpus();
    assert!(corpus.len() > 10, "corpus not found");
    // A fresh seed per run explores new inputs; FUZZ_SEED replays the run a failure reports.
    let seed: u64 = match std::env::var("FUZZ_SEED") {
        Ok(s) => s.parse().unwrap_or_else(|_| panic!("FUZZ_SEED={s:?} is not an unsigned integer")),
        Err(_) => 0x9e37_79b9_7f4a_7c15 ^ std::process::id() as u64,
    };
    eprintln!("fuzz_program_parsers: FUZZ_SEED={seed}");
    let mut rng = Rng(seed);
    let mut runs = 0u64;
    let mut stray = 0u64;
    // The slowest input: (seconds, its number in the run, its name).
    let mut slowest = (0.0, 0u64, String::new());
    // A short or slowed-down run (FUZZ_SECONDS defaults to 2 s; tests run side by side) goes on
    // past its time until enough accepted programs have had a stray word put in.
    let enough = |runs: u64, stray: u64| runs >= MIN_INPUTS && stray > MIN_STRAY;
    while Instant::now() < deadline || (!enough(runs, stray) && runs < MAX_INPUTS_FOR_MIN) {
        let (name, base) = &corpus[rng.below(corpus.len())];
        let mutated = rng.below(4) != 0;
        let text = if mutated { mutate(&mut rng, base) } else { generated(&mut rng) };
        // Alternate the format so tables and G-code both get mutated inputs.
        let fname = if rng.below(2) == 0 { name.clone() } else { format!("{name}.ngc") };
        let t_input = Instant::now();
        let checked = check_input(&fname, &text, &cfgs);
        let took_s = t_input.elapsed().as_secs_f64();
        if took_s > slowest.0 {
            slowest = (took_s, runs, fname.clone());
        }
        if let Err(what) = checked {
            panic!("{}", report(seed, &fname, if mutated { base } else { "" }, &text, &what));
        }
        // A stray word on a line that control flow skips is not read (as in LinuxCNC): the check
        // takes programs without O words.
        let gcode = fname.ends_with(".ngc")
            && !text.to_ascii_uppercase().contains("LAW")
            && !text.to_ascii_uppercase().contains('O');
        if gcode && program::parse(&text, &fname, &cfgs[0]).is_ok() {
            if let Err(what) = check_stray_word(&mut rng, &fname, &text, &cfgs[0]) {
                panic!("{}", report(seed, &fname, if mutated { base } else { "" }, &text, &what));
            }
            stray += 1;
        }
        runs += 1;
    }
    eprintln!(
        "fuzz_program_parsers: {runs} inputs in {:.1} s, no panic; {stray} accepted programs with a stray word refused; \
         slowest input {:.3} s (number {}, {})",
        started.elapsed().as_secs_f64(),
        slowest.0,
        slowest.1,
        slowest.2
    );
    assert!(enough(runs, stray), "too few accepted programs to put a stray word into: {stray} of {runs} inputs");
}

#[test]
fn fuzz_config_loader() {
    let seconds: f64 = std::env::var("FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(2.0) / 6.0;
    let deadline = Instant::now() + Duration::from_secs_f64(seconds);
    let bases = [interpd_motion::config::DEFAULT_MACHINE_TOML, interpd_motion::config::FIVE_AXIS_MACHINE_TOML];
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let mut runs = 0u64;
    while Instant::now() < deadline {
        let base = bases[rng.below(2)];
        let text = mutate(&mut rng, base);
        let r = catch_unwind(|| interpd_motion::config::Config::from_toml_str(&text, "fuzz.toml"));
        assert!(r.is_ok(), "config loader panicked on:\n{text}");
        runs += 1;
    }
    eprintln!("fuzz_config_loader: {runs} inputs, no panic");
}
