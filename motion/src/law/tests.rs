//! Unit tests of the solver and characteristic values against closed forms.

use super::*;

/// Residual every condition of the article's laws must meet.
const RESIDUAL_MAX: f64 = 1e-9;

#[test]
fn every_preset_meets_its_conditions() {
    for p in Preset::all() {
        let law = Law::from_conditions(p.conditions()).expect("preset solves");
        assert_eq!(law.degree() + 1, p.conditions().len());
        for r in law.residuals() {
            assert!(r.abs <= RESIDUAL_MAX, "{}: {} off by {:e}", p.name(), r.condition, r.abs);
            // The f64 law used at run time meets the conditions on f … f⁗ just as well.
            if r.condition.order <= 4 {
                assert!(r.abs_f64 <= RESIDUAL_MAX, "{}: {} (f64) off by {:e}", p.name(), r.condition, r.abs_f64);
            }
        }
    }
}

#[test]
fn quintic_matches_its_closed_form() {
    // f = 10z³ − 15z⁴ + 6z⁵: C_v = 15/8 at ½, C_a = 10/√3 at ½ ∓ √3/6, C_j = 60 at 0 and 1.
    let law = Law::from_conditions(Preset::Rr5.conditions()).expect("solves");
    let a = law.monomial_coefficients();
    for (k, want) in [0.0, 0.0, 0.0, 10.0, -15.0, 6.0].iter().enumerate() {
        assert!((a[k] - want).abs() < 1e-12, "a{k} = {}", a[k]);
    }
    let ch = law.characteristics();
    assert!((ch.cv.value - 1.875).abs() < 1e-13 && (ch.cv.z - 0.5).abs() < 1e-9);
    assert!((ch.ca.value - 10.0 / 3f64.sqrt()).abs() < 1e-12);
    assert!((ch.ca.z - (0.5 - 3f64.sqrt() / 6.0)).abs() < 1e-9, "{}", ch.ca.z);
    assert!((ch.cj.value - 60.0).abs() < 1e-11 && ch.cj.z == 0.0);
}

#[test]
fn seventh_order_matches_its_closed_form() {
    // f = 35z⁴ − 84z⁵ + 70z⁶ − 20z⁷: C_v = 35/16, C_j = 52.5 at ½; C_a at the root of f‴ =
    // 420z(1−z)(1−2z)(…) in (0, ½): z = ½ − √5/10, C_a = 84√5/25 = 7.5131884…
    let law = Law::from_conditions(Preset::Rr7.conditions()).expect("solves");
    let a = law.monomial_coefficients();
    for (k, want) in [0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0].iter().enumerate() {
        assert!((a[k] - want).abs() < 1e-10, "a{k} = {}", a[k]);
    }
    let ch = law.characteristics();
    assert!((ch.cv.value - 2.1875).abs() < 1e-13);
    assert!((ch.ca.value - 84.0 * 5f64.sqrt() / 25.0).abs() < 1e-12, "{}", ch.ca.value);
    assert!((ch.ca.z - (0.5 - 5f64.sqrt() / 10.0)).abs() < 1e-9, "{}", ch.ca.z);
    assert!((ch.cj.value - 52.5).abs() < 1e-11 && (ch.cj.z - 0.5).abs() < 1e-9);
}

#[test]
fn peaks_are_not_below_a_dense_sample() {
    // The exact search must find at least what sampling sees, and nothing above the truth.
    for p in Preset::all() {
        let law = Law::from_conditions(p.conditions()).expect("solves");
        let ch = law.characteristics();
        let mut seen = [0.0f64; 3];
        for k in 0..=20_000 {
            let d = law.eval(k as f64 / 20_000.0);
            seen[0] = seen[0].max(d.f1.abs());
            seen[1] = seen[1].max(d.f2.abs());
            seen[2] = seen[2].max(d.f3.abs());
        }
        for (found, sampled) in [ch.cv.value, ch.ca.value, ch.cj.value].iter().zip(seen) {
            assert!(*found >= sampled * (1.0 - 1e-14), "{}: {found} < sampled {sampled}", p.name());
            // A 5e-5 grid misses a smooth peak by at most ~½·f⁽ᵏ⁺²⁾·h², far below 1e-4 relative.
            assert!(*found <= sampled * (1.0 + 1e-4), "{}: {found} ≫ sampled {sampled}", p.name());
        }
    }
}

#[test]
fn inflection_half_is_the_seventh_order_law() {
    let a = Law::from_conditions(Preset::Inflection(0.5).conditions()).expect("solves");
    let b = Law::from_conditions(Preset::Rr7.conditions()).expect("solves");
    for k in 0..=100 {
        let z = k as f64 / 100.0;
        assert!((a.eval(z).f2 - b.eval(z).f2).abs() < 1e-11);
    }
    // λ = 0.4 puts f(0.4) = 0.4 and moves the velocity peak before ½.
    let c = Law::from_conditions(Preset::Inflection(0.4).conditions()).expect("solves");
    assert!((c.eval(0.4).f - 0.4).abs() < 1e-14);
    assert!(c.characteristics().cv.z < 0.5);
}

#[test]
fn typed_errors() {
    let c = Condition::new;
    let err = |v: Vec<Condition>| Law::from_conditions(v).expect_err("must fail");
    assert!(matches!(err(vec![]), LawError::Empty));
    assert!(matches!(err(vec![c(0, 1.5, 0.0)]), LawError::ZOutOfRange { index: 0, .. }));
    assert!(matches!(err(vec![c(0, f64::NAN, 0.0)]), LawError::ZOutOfRange { .. }));
    assert!(matches!(err(vec![c(0, 0.0, f64::INFINITY)]), LawError::BadValue { .. }));
    assert!(matches!(err(vec![c(0, 0.0, 0.0), c(2, 1.0, 0.0)]), LawError::OrderAboveDegree { index: 1, .. }));
    assert!(matches!(err(vec![c(0, 0.0, 0.0), c(0, 0.0, 0.0)]), LawError::Duplicate { first: 0, second: 1, .. }));
    assert!(matches!(err(vec![c(0, 0.0, 0.0), c(0, 0.0, 1.0)]), LawError::Contradictory { .. }));
    assert!(matches!(err(vec![c(0, 0.0, 0.0); MAX_CONDITIONS + 1]), LawError::TooMany { .. }));
    // For any quadratic, f′(½) equals the secant slope f(1) − f(0) = 1: asking f′(½) = 0 with
    // f(0) = 0, f(1) = 1 is contradictory…
    match err(vec![c(0, 0.0, 0.0), c(0, 1.0, 1.0), c(1, 0.5, 0.0)]) {
        LawError::Contradictory { indices, .. } => assert_eq!(indices, vec![0, 1, 2]),
        e => panic!("{e}"),
    }
    // … and 1 is merely dependent (any quadratic through the two points meets it).
    assert!(matches!(err(vec![c(0, 0.0, 0.0), c(0, 1.0, 1.0), c(1, 0.5, 1.0)]), LawError::Dependent { .. }));
}
