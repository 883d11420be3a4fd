//! The `interpd law` command line: the JSON contract fields, text, CSV and plot output, and
//! bad input exiting 2 with a message naming the option and value.

use std::process::{Command, Output};

/// The accuracy every condition of a solved law must meet.
const RESIDUAL_MAX: f64 = 1e-9;

fn interpd_law(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_interpd")).arg("law").args(args).output().expect("run interpd")
}

fn json_of(out: &Output) -> serde_json::Value {
    assert_eq!(out.status.code(), Some(0), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

fn num(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("no number '{key}' in {v}"))
}

#[test]
fn cli_json_has_the_contract_fields_and_the_known_values() {
    let v = json_of(&interpd_law(&["--preset", "rr5", "--json"]));
    assert_eq!(v["degree"], 5);
    assert!((num(&v, "cv") - 1.875).abs() < 1e-12);
    assert!((num(&v, "ca") - 10.0 / 3f64.sqrt()).abs() < 1e-12);
    assert!((num(&v, "cj") - 60.0).abs() < 1e-10);
    assert!(num(&v, "max_residual") <= RESIDUAL_MAX);
    let mono: Vec<f64> = v["monomial"].as_array().expect("monomial").iter().filter_map(|x| x.as_f64()).collect();
    for (a, want) in mono.iter().zip([0.0, 0.0, 0.0, 10.0, -15.0, 6.0]) {
        assert!((a - want).abs() < 1e-11, "{mono:?}");
    }
    assert_eq!(v["chebyshev"].as_array().map(Vec::len), Some(6));
    assert_eq!(v["conditions"].as_array().map(Vec::len), Some(6));

    let v = json_of(&interpd_law(&["--preset", "rr7", "--json"]));
    assert_eq!(v["degree"], 7);
    assert!((num(&v, "cv") - 2.1875).abs() < 1e-12);
    assert!((num(&v, "ca") - 7.5132).abs() < 1e-4);
    assert!((num(&v, "cj") - 52.5).abs() < 1e-10);

    // The seed's degree-8 example given condition by condition, as in the text.
    let conds = ["0,0,0", "0,1,1", "1,0,0", "1,1,0", "2,0,0", "3,0,0", "3,1,0", "4,1,0", "0,0.4,0.2"];
    let mut args: Vec<&str> = conds.iter().flat_map(|c| ["--cond", c]).collect();
    args.push("--json");
    let v = json_of(&interpd_law(&args));
    assert_eq!(v["degree"], 8);
    for cond in v["conditions"].as_array().expect("conditions") {
        assert!(num(cond, "residual") <= RESIDUAL_MAX && num(cond, "residual_f64") <= RESIDUAL_MAX, "{cond}");
    }
    // A preset plus a condition: the inflection shift added to the 7th-order law by hand equals
    // the preset.
    let a = json_of(&interpd_law(&["--preset", "rr7", "--cond", "0,0.4,0.4", "--json"]));
    let b = json_of(&interpd_law(&["--preset", "inflection:0.4", "--json"]));
    assert_eq!(a["degree"], 8);
    assert!((num(&a, "ca") - num(&b, "ca")).abs() < 1e-12);
}

#[test]
fn cli_text_csv_and_plot() {
    let dir = std::env::temp_dir().join(format!("interpd-law-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let csv = dir.join("law.csv");
    let png = dir.join("law.png");
    let out = interpd_law(&[
        "--preset",
        "constant-velocity",
        "--out",
        csv.to_str().expect("utf-8 path"),
        "--plot",
        png.to_str().expect("utf-8 path"),
        "--samples",
        "501",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("degree 15 (16 conditions)"), "{text}");
    assert!(text.contains("C_v = 1.49823"), "{text}");
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(&csv)
        .expect("csv")
        .lines()
        .enumerate()
        .filter_map(|(k, l)| {
            if k == 0 {
                assert_eq!(l, "z,f,f1,f2,f3");
                return None;
            }
            Some(l.split(',').map(|x| x.parse().expect("number")).collect())
        })
        .collect();
    assert_eq!(rows.len(), 501);
    assert_eq!(rows[0][0], 0.0);
    assert_eq!(rows[500][0], 1.0);
    assert!((rows[500][1] - 1.0).abs() < 1e-12 && rows[0][1].abs() < 1e-12);
    // f′ peaks at C_v in the middle, where the law is nearly constant-velocity.
    assert!((rows[250][2] - 1.4982320812).abs() < 1e-9, "{:?}", rows[250]);
    let png_bytes = std::fs::read(&png).expect("png");
    assert!(png_bytes.starts_with(b"\x89PNG\r\n\x1a\n") && png_bytes.len() > 10_000);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn cli_bad_input_exits_2_naming_the_option_and_value() {
    for (args, wants) in [
        (vec!["--cond", "0,1.5,1"], vec!["--cond '0,1.5,1'", "z must be a number in [0, 1], got 1.5"]),
        (vec!["--cond", "x,0,0"], vec!["--cond 'x,0,0'", "derivative order 'x'"]),
        (vec!["--cond", "0,0"], vec!["--cond '0,0'", "expected three numbers"]),
        (vec!["--cond", "0,0,nan"], vec!["--cond '0,0,nan'", "value must be finite"]),
        (vec!["--cond", "-1,0,0"], vec!["--cond '-1,0,0'", "derivative order '-1'"]),
        (vec!["--preset", "rr9"], vec!["--preset rr9", "unknown preset 'rr9'"]),
        (vec!["--preset", "inflection:1.5"], vec!["--preset inflection:1.5", "strictly between 0 and 1"]),
        (vec!["--preset", "rr5", "--samples", "1"], vec!["--samples must be 2"]),
        (vec![], vec!["no conditions"]),
        (vec!["--cond", "0,0,0", "--cond", "0,0,1"], vec!["contradict", "(--cond 0,0,1)"]),
        (vec!["--cond", "0,0,0", "--cond", "0,1,1", "--cond", "1,0.5,0"], vec!["contradict", "f'(0.5) = 0"]),
        (vec!["--preset", "rr5", "--cond", "0,0,0"], vec!["conditions 1 and 7 are the same", "(preset rr5)"]),
        (vec!["--cond", "0,0,0", "--cond", "3,1,0"], vec!["above the degree 1"]),
    ] {
        let out = interpd_law(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(out.stdout.is_empty(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        for w in wants {
            assert!(err.contains(w), "{args:?}: '{w}' not in: {err}");
        }
    }
}
