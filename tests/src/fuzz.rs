//! Requests for the JSON-RPC fuzzing of the fault campaign: well-formed calls of every method
//! with valid and invalid parameters (the daemon must answer each, by its id), and lines
//! mutated from them (wrong types, huge numbers, NaN, deep nesting, broken bytes), which it
//! may refuse any way it likes but must survive.

use crate::rng::Rng;
use serde_json::{Value, json};

/// Programs small enough to load many times a second, by path (the daemon runs in the
/// repository).
const PROGRAMS: &[&str] =
    &["examples/circle_r10.ngc", "examples/corner_90.ngc", "examples/line_arc_line.ngc", "examples/two_arcs.ngc"];
/// Every method, and some that do not exist.
const METHODS: &[&str] = &[
    "program.load",
    "program.append",
    "motion.start",
    "motion.hold",
    "motion.resume",
    "motion.stop",
    "feed.override",
    "status",
    "subscribe",
    "motion.law",
    "motion.jog",
    "motion.jog_stop",
    "motion.move_to",
    "mdi",
    "tools.get",
    "tools.set",
    "offsets.get",
    "offsets.set",
    "motion.Start",
    "rpc.discover",
    "",
    "status ",
];
/// Numbers that are valid JSON but out of every range, or at its edges.
const ODD_NUMBERS: &[&str] =
    &["1e308", "-1e308", "1.7976931348623157e308", "5e-324", "-0.0", "18446744073709551616", "-9223372036854775809"];
/// Texts that are not JSON numbers (a parse error where a number stood).
const NOT_NUMBERS: &[&str] = &["NaN", "Infinity", "-Infinity", "1e400", "0x10", "+1", ".5", "1.", "--1"];

/// One line to send, and the id the answer must carry if it is a well-formed request.
pub struct FuzzLine {
    pub bytes: Vec<u8>,
    pub answered_id: Option<String>,
}

/// A well-formed request (`"jsonrpc": "2.0"`, a string id, a string method, params an object
/// or absent): the daemon must answer it with `id`.
pub fn well_formed(rng: &mut impl Rng, id: &str) -> FuzzLine {
    let (method, params) = call(rng);
    let mut msg = json!({ "jsonrpc": "2.0", "id": id, "method": method });
    if let Some(p) = params {
        msg["params"] = p;
    }
    FuzzLine { bytes: msg.to_string().into_bytes(), answered_id: Some(id.to_string()) }
}

/// A method and parameters: mostly valid calls in random order, some with wrong or missing
/// parameters, some unknown methods.
fn call(rng: &mut impl Rng) -> (String, Option<Value>) {
    let axis = ["X", "Y", "Z", "Q", "x"][rng.random_range(0..5)];
    let num = |rng: &mut dyn FnMut() -> f64| rng();
    let mut f = || rng.random_range(-50.0..50.0);
    let small = num(&mut f);
    let (method, params) = match rng.random_range(0..24) {
        0 | 1 => ("status", None),
        2 => ("program.load", Some(json!({ "path": PROGRAMS[rng.random_range(0..PROGRAMS.len())] }))),
        3 => {
            ("program.load", Some(json!({ "text": format!("G1 X{small:.3} F{}\nG1 Y1\n", rng.random_range(1..9000)) })))
        }
        4 => ("motion.start", None),
        5 => ("motion.hold", None),
        6 => ("motion.resume", None),
        7 => ("motion.stop", None),
        8 => ("feed.override", Some(json!({ "factor": rng.random_range(0.0..2.2) }))),
        9 => ("feed.override", Some(json!({ "percent": rng.random_range(-10.0..220.0) }))),
        10 => ("motion.jog", Some(json!({ "axes": { axis: rng.random_range(-300.0..300.0) } }))),
        11 => ("motion.jog", Some(json!({ "axes": { axis: small }, "mode": "distance" }))),
        12 => ("motion.jog_stop", None),
        13 => (
            "motion.move_to",
            Some(json!({ "target": { axis: small }, "velocity_factor": rng.random_range(0.0..1.2) })),
        ),
        14 => ("mdi", Some(json!({ "line": format!("G1 {axis}{small:.3} F{}", rng.random_range(100..6000)) }))),
        15 => (
            "motion.law",
            Some(
                json!({ "statement": format!("LAW PRESET=rr7 DURATION={:.2} X={small:.2}", rng.random_range(0.05..2.0)) }),
            ),
        ),
        16 => ("tools.get", None),
        17 => (
            "tools.set",
            Some(
                json!({ "tools": [{ "number": rng.random_range(0..3), "diameter_mm": rng.random_range(-1.0..10.0) }] }),
            ),
        ),
        18 => ("offsets.get", None),
        19 => (
            "offsets.set",
            Some(json!({ "offsets": { ["G54", "G55", "G60"][rng.random_range(0..3)]: { axis: small } } })),
        ),
        20 => ("program.append", Some(json!({ "text": "G1 X1\n" }))),
        21 => ("subscribe", None),
        // Wrong parameter types and names for a valid method.
        22 => {
            let m = METHODS[rng.random_range(0..18)];
            let p = match rng.random_range(0..6) {
                0 => json!({ "factor": "fast" }),
                1 => json!({ "path": 17 }),
                2 => json!({ "axes": [1, 2, 3] }),
                3 => json!({ "target": null, "bogus": true }),
                4 => json!({ "text": { "nested": [] } }),
                _ => json!({ "line": "" }),
            };
            (m, Some(p))
        }
        _ => (METHODS[rng.random_range(18..METHODS.len())], None),
    };
    (method.to_string(), params)
}

/// A line mutated from a well-formed request (its answer, if any, is not tracked).
pub fn mutated(rng: &mut impl Rng) -> FuzzLine {
    let mut bytes = well_formed(rng, "m").bytes;
    for _ in 0..rng.random_range(1..4) {
        mutate(rng, &mut bytes);
    }
    // A newline inside would split the line in two; both halves are still fuzz.
    FuzzLine { bytes, answered_id: None }
}

fn mutate(rng: &mut impl Rng, bytes: &mut Vec<u8>) {
    let at = rng.random_range(0..=bytes.len());
    match rng.random_range(0..12) {
        0 if !bytes.is_empty() => {
            let i = rng.random_range(0..bytes.len());
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        1 => bytes.truncate(at),
        2 => {
            let end = rng.random_range(at..=bytes.len());
            bytes.drain(at..end);
        }
        3 => {
            let junk: Vec<u8> = (0..rng.random_range(1..8)).map(|_| rng.random::<u8>()).collect();
            bytes.splice(at..at, junk);
        }
        4 => {
            let s = ODD_NUMBERS[rng.random_range(0..ODD_NUMBERS.len())];
            replace_a_number(bytes, s.as_bytes());
        }
        5 => {
            let s = NOT_NUMBERS[rng.random_range(0..NOT_NUMBERS.len())];
            replace_a_number(bytes, s.as_bytes());
        }
        6 => {
            // Deep nesting as the parameters, from harmless to far past any recursion limit.
            let depth = [10, 127, 129, 1000, 100_000][rng.random_range(0..5)];
            let nested = format!("{}{}", "[".repeat(depth), "]".repeat(depth));
            *bytes = format!(r#"{{"jsonrpc":"2.0","id":"deep","method":"status","params":{nested}}}"#).into_bytes();
        }
        7 => {
            // A long string value (well below the line limit).
            let len = [1000, 60_000, 500_000][rng.random_range(0..3)];
            *bytes = format!(
                r#"{{"jsonrpc":"2.0","id":1,"method":"mdi","params":{{"line":"{}"}}}}"#,
                "G1X1".repeat(len / 4)
            )
            .into_bytes();
        }
        8 => {
            // A batch of copies, or an empty one.
            let n = rng.random_range(0..6);
            let item = String::from_utf8_lossy(bytes).into_owned();
            *bytes = format!("[{}]", vec![item; n].join(",")).into_bytes();
        }
        9 => {
            let kinds = [
                r#""jsonrpc":"1.0""#,
                r#""jsonrpc":2"#,
                r#""id":{}"#,
                r#""id":[1]"#,
                r#""method":7"#,
                r#""params":"x""#,
            ];
            let k = kinds[rng.random_range(0..kinds.len())];
            *bytes = format!(r#"{{{k},"method":"status","id":3}}"#).into_bytes();
        }
        10 => bytes.splice(at..at, [0xff, 0xfe, 0xc3]).for_each(drop),
        _ => bytes.splice(at..at, *b"\r").for_each(drop),
    }
}

/// Replaces the first number in `bytes` (or appends, where there is none) by `with`.
fn replace_a_number(bytes: &mut Vec<u8>, with: &[u8]) {
    let start = bytes.iter().position(|b| b.is_ascii_digit());
    match start {
        Some(s) => {
            let end =
                bytes[s..].iter().position(|b| !(b.is_ascii_digit() || *b == b'.')).map_or(bytes.len(), |e| s + e);
            bytes.splice(s..end, with.iter().copied());
        }
        None => bytes.extend_from_slice(with),
    }
}
