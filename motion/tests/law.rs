//! Motion laws (Bewegungsdesign nach Maß): the solver on the article's laws and on degree-15
//! sets (against the monomial system), random condition sets, law moves against axis limits,
//! and the `interpd law` command line.

use interpd_motion::Settings;
use interpd_motion::law::{
    AxisLimits, AxisState, Condition, Law, LawAxis, LawError, LawMove, LawMoveError, LimitError, LimitKind,
    MAX_CONDITIONS, Preset,
};
use nalgebra::DMatrix;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The library's double-double arithmetic (internal to it), compiled in here to evaluate the
/// monomial system's residuals exactly.
#[allow(dead_code)]
#[path = "../src/law/ddouble.rs"]
mod ddouble;
use ddouble::Dd;

/// Counts heap allocations per thread, to show that sampling a law move allocates nothing.
struct CountingAlloc;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: the caller's contract for `alloc` is passed on.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc` is passed on.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

/// The accuracy every condition must meet.
const RESIDUAL_MAX: f64 = 1e-9;

fn c(order: u32, z: f64, value: f64) -> Condition {
    Condition::new(order, z, value)
}

fn solve(conds: Vec<Condition>) -> Law {
    Law::from_conditions(conds).expect("solves")
}

// ---------------------------------------------------------------------------------------------
// Degree 15: Chebyshev basis against the monomial system of the article's f(z) = Σ a_k zᵏ.

/// Three degree-15 sets: the article's constant-velocity law, Hermite data of sin(3z) (f … f‴
/// at 0, ⅓, ⅔, 1), and rest to rest through eight interior positions with flat jerk at the ends.
fn degree_15_sets() -> Vec<(&'static str, Vec<Condition>)> {
    let cv = Preset::ConstantVelocity.conditions();
    let mut hermite = Vec::new();
    for z in [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0] {
        let w = 3.0f64;
        let d = [(w * z).sin(), w * (w * z).cos(), -w * w * (w * z).sin(), -w * w * w * (w * z).cos()];
        for (i, v) in d.iter().enumerate() {
            hermite.push(c(i as u32, z, *v));
        }
    }
    let mut through = Preset::Rr7.conditions();
    for k in 1..=8 {
        let z = k as f64 / 9.0;
        through.push(c(0, z, z * z * (3.0 - 2.0 * z)));
    }
    vec![("constant-velocity", cv), ("hermite sin(3z)", hermite), ("rr7 + 8 points", through)]
}

/// dⁱ/dzⁱ zᵏ at z, the monomial system's entry.
fn monomial_entry(order: u32, z: f64, k: usize) -> f64 {
    let i = order as usize;
    if k < i {
        return 0.0;
    }
    let falling: f64 = ((k - i + 1)..=k).map(|m| m as f64).product();
    falling * z.powi((k - i) as i32)
}

/// |f⁽ⁱ⁾(z) − F| of monomial coefficients `a`, evaluated in double-double so that only the
/// coefficients' error shows, not the evaluation's.
fn monomial_residual(a: &[f64], cond: &Condition) -> f64 {
    let mut sum = Dd::ZERO;
    for (k, ak) in a.iter().enumerate() {
        let i = cond.order as usize;
        if k < i {
            continue;
        }
        let mut term = Dd::from(*ak);
        for m in (k - i + 1)..=k {
            term = term * Dd::from(m as f64);
        }
        for _ in 0..(k - i) {
            term = term * Dd::from(cond.z);
        }
        sum = sum + term;
    }
    (sum - Dd::from(cond.value)).abs().to_f64()
}

/// The largest |f⁽ⁱ⁾_monomial − f⁽ⁱ⁾_law| for i = 0 … 3 on a grid: how far the monomial
/// solution is from the (accurate) Chebyshev one between and at the conditions.
fn monomial_deviation(a: &[f64], law: &Law) -> f64 {
    let mut worst = 0.0f64;
    for k in 0..=200 {
        let z = f64::from(k) / 200.0;
        let d = law.eval(z);
        for (i, v) in [d.f, d.f1, d.f2, d.f3].iter().enumerate() {
            let mono = monomial_residual(a, &c(i as u32, z, 0.0));
            worst = worst.max((mono - v.abs()).abs().min((mono + v.abs()).abs()));
        }
    }
    worst
}

/// 2-norm condition number of a square matrix.
fn cond2(m: &DMatrix<f64>) -> f64 {
    let s = m.clone().singular_values();
    s.max() / s.min()
}

/// The monomial matrix with each row scaled to max-norm 1 (the same row equilibration the
/// Chebyshev solver uses, so the comparison is fair).
fn monomial_system(conds: &[Condition]) -> (DMatrix<f64>, nalgebra::DVector<f64>) {
    let n = conds.len();
    let mut a = DMatrix::from_fn(n, n, |i, k| monomial_entry(conds[i].order, conds[i].z, k));
    let mut b = nalgebra::DVector::from_iterator(n, conds.iter().map(|c| c.value));
    for i in 0..n {
        let s = a.row(i).amax();
        a.row_mut(i).scale_mut(1.0 / s);
        b[i] /= s;
    }
    (a, b)
}

#[test]
fn degree_15_sets_solve_and_the_monomial_system_does_not() {
    for (name, conds) in degree_15_sets() {
        assert_eq!(conds.len(), 16, "{name}");
        let law = solve(conds.clone());
        assert_eq!(law.degree(), 15);
        // Chebyshev: every condition to 1e-9, also with the f64 coefficients used at run time.
        assert!(law.max_residual() <= RESIDUAL_MAX, "{name}: {:e}", law.max_residual());
        assert!(law.max_residual_f64() <= RESIDUAL_MAX, "{name}: f64 {:e}", law.max_residual_f64());

        // Monomials, solved by LU with partial pivoting in f64 (row-equilibrated).
        let (a, b) = monomial_system(&conds);
        let cond_mono = cond2(&a);
        let coeffs = a.clone().lu().solve(&b).expect("monomial LU");
        let mono_max = conds.iter().map(|c| monomial_residual(coeffs.as_slice(), c)).fold(0.0, f64::max);
        let deviation = monomial_deviation(coeffs.as_slice(), &law);
        eprintln!(
            "{name:18}: cond (monomial, rows scaled) {cond_mono:.2e}, 1/rcond (Chebyshev, equilibrated) {:.2e}; \
             max residual monomial {mono_max:.2e}, Chebyshev {:.2e} (f64 {:.2e}); monomial law off by {deviation:.2e}",
            1.0 / law.rcond(),
            law.max_residual(),
            law.max_residual_f64()
        );
        // The monomial system is worse conditioned by at least three orders of magnitude …
        assert!(cond_mono > 1e3 / law.rcond(), "{name}: monomial system is not much worse conditioned");
        // … and on the motion laws (large monomial coefficients, up to ~1e5) its LU solution
        // misses the conditions by far more than 1e-9. (On smooth data with small monomial
        // coefficients, like sin(3z), LU's backward stability still gives small residuals: the
        // ill-conditioning shows as a risk, not on every data set.)
        if !name.starts_with("hermite") {
            assert!(mono_max > 100.0 * RESIDUAL_MAX, "{name}: the monomial solve met the conditions ({mono_max:e})");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The article's examples.

#[test]
fn the_articles_degree_8_example_meets_its_conditions() {
    // Bewegungsdesign nach Maß: "1. f(0) = 0 … 9. f(0,4) = 0,2" → degree 8.
    let conds = vec![
        c(0, 0.0, 0.0),
        c(0, 1.0, 1.0),
        c(1, 0.0, 0.0),
        c(1, 1.0, 0.0),
        c(2, 0.0, 0.0),
        c(3, 0.0, 0.0),
        c(3, 1.0, 0.0),
        c(4, 1.0, 0.0),
        c(0, 0.4, 0.2),
    ];
    let law = solve(conds.clone());
    assert_eq!(law.degree(), 8);
    for r in law.residuals() {
        assert!(r.abs <= RESIDUAL_MAX && r.abs_f64 <= RESIDUAL_MAX, "{}: {:e} / {:e}", r.condition, r.abs, r.abs_f64);
    }
    // Independently: evaluate the monomial form at the conditions.
    let a = law.monomial_coefficients();
    for cond in &conds {
        assert!(monomial_residual(&a, cond) < 1e-9, "{cond}");
    }
    assert_eq!(Preset::Degree8.conditions(), conds);
}

#[test]
fn quintic_and_seventh_order_characteristic_values() {
    let ch = solve(Preset::Rr5.conditions()).characteristics();
    assert!((ch.cv.value - 1.875).abs() < 1e-12, "{}", ch.cv.value);
    assert!((ch.ca.value - 5.7735).abs() < 1e-4 && (ch.ca.value - 10.0 / 3f64.sqrt()).abs() < 1e-12);
    assert!((ch.cj.value - 60.0).abs() < 1e-10, "{}", ch.cj.value);
    let ch = solve(Preset::Rr7.conditions()).characteristics();
    assert!((ch.cv.value - 2.1875).abs() < 1e-12, "{}", ch.cv.value);
    assert!((ch.ca.value - 7.5132).abs() < 1e-4, "{}", ch.ca.value);
    assert!((ch.cj.value - 52.5).abs() < 1e-10, "{}", ch.cj.value);
}

#[test]
fn every_preset_meets_its_conditions_to_1e_9() {
    for p in Preset::all() {
        let law = solve(p.conditions());
        assert!(law.max_residual() <= RESIDUAL_MAX, "{}: {:e}", p.name(), law.max_residual());
        // Named as in the article: the 11th-order law has degree 11, and so on.
        let want = match p {
            Preset::Rr5 => 5,
            Preset::Rr7 => 7,
            Preset::Rr11 => 11,
            Preset::Asymmetric => 17,
            Preset::ConstantVelocity => 15,
            Preset::Degree8 | Preset::Inflection(_) => 8,
        };
        assert_eq!(law.degree(), want, "{}", p.name());
    }
}

// ---------------------------------------------------------------------------------------------
// Random condition sets.

/// Hermite data (orders 0 … m−1 at distinct nodes) is always solvable: a random valid set.
/// Like a motion law it has conditions at both ends of the section, and its interior nodes are
/// at least 0.1 apart (data clustered in a short stretch determines the polynomial on [0, 1]
/// only with a huge amplification, which the solver rightly rejects as too nearly dependent).
fn hermite_set() -> impl Strategy<Value = Vec<Condition>> {
    // Ends with multiplicity 1 … 4, up to 5 interior nodes on a 1/10 grid with 1 … 3, values
    // in [−5, 5]: at most 23 conditions (degree 22).
    (
        proptest::collection::vec(1u32..=4, 2),
        proptest::sample::subsequence((1..10).collect::<Vec<u32>>(), 0..=5),
        proptest::collection::vec(1u32..=3, 5),
    )
        .prop_flat_map(|(ends, interior, mults)| {
            let mut shape = Vec::new();
            for (node, m) in [(0, ends[0]), (10, ends[1])].into_iter().chain(interior.into_iter().zip(mults)) {
                for i in 0..m {
                    shape.push((i, f64::from(node) / 10.0));
                }
            }
            let n = shape.len();
            (Just(shape), proptest::collection::vec(-5.0f64..5.0, n))
        })
        .prop_map(|(shape, values)| shape.iter().zip(values).map(|(&(i, z), v)| c(i, z, v)).collect())
}

/// Anything: orders, places and values that may be out of range, duplicated or singular.
fn wild_set() -> impl Strategy<Value = Vec<Condition>> {
    let value = prop_oneof![
        8 => -10.0f64..10.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(1e300),
    ];
    let z = prop_oneof![
        8 => 0.0f64..=1.0,
        2 => proptest::sample::select(vec![0.0, 0.5, 1.0]),
        1 => -1.0f64..2.0,
        1 => Just(f64::NAN),
    ];
    proptest::collection::vec((0u32..30, z, value), 0..=MAX_CONDITIONS + 3)
        .prop_map(|v| v.into_iter().map(|(i, z, f)| c(i, z, f)).collect())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 300,
        rng_seed: RngSeed::Fixed(0x1a_3003),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_hermite_sets_solve_and_meet_their_conditions(conds in hermite_set()) {
        let law = Law::from_conditions(conds.clone());
        prop_assert!(law.is_ok(), "{:?}: {}", conds, law.err().map(|e| e.to_string()).unwrap_or_default());
        let law = law.unwrap();
        for r in law.residuals() {
            prop_assert!(r.abs <= RESIDUAL_MAX, "{}: residual {:e}", r.condition, r.abs);
        }
        // The exact peak search finds at least what a grid sees.
        let ch = law.characteristics();
        for k in 0..=500 {
            let d = law.eval(k as f64 / 500.0);
            prop_assert!(ch.cv.value >= d.f1.abs() * (1.0 - 1e-12) - 1e-12);
            prop_assert!(ch.ca.value >= d.f2.abs() * (1.0 - 1e-12) - 1e-12);
            prop_assert!(ch.cj.value >= d.f3.abs() * (1.0 - 1e-12) - 1e-12);
        }
    }

    #[test]
    fn wild_sets_give_a_law_or_a_typed_error(conds in wild_set()) {
        match Law::from_conditions(conds.clone()) {
            Ok(law) => {
                for r in law.residuals() {
                    prop_assert!(r.abs.is_finite());
                }
                let ch = law.characteristics();
                prop_assert!(ch.cv.value.is_finite() && ch.ca.value.is_finite() && ch.cj.value.is_finite());
            }
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                let invalid = conds.is_empty()
                    || conds.len() > MAX_CONDITIONS
                    || conds.iter().any(|c| !(0.0..=1.0).contains(&c.z) || !c.value.is_finite() || c.value.abs() > 1e9);
                if invalid {
                    prop_assert!(!matches!(e, LawError::Dependent { .. } | LawError::Contradictory { .. }), "{e}");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Law moves against the axis limits.

/// The embedded default machine: X, Y 250 mm/s, 2500 mm/s², 50000 mm/s³; Z 200, 2000, 40000.
fn limits() -> Vec<AxisLimits> {
    AxisLimits::from_settings(&Settings::default_machine())
}

fn law_move(p: Preset, axes: &[(usize, f64, f64)], duration_s: f64) -> LawMove {
    let axes = axes.iter().map(|&(axis, start, stroke)| LawAxis { axis, start, stroke }).collect();
    LawMove::new(solve(p.conditions()), axes, duration_s).expect("valid move")
}

/// One linear axis X with the given limits and a wide travel.
fn x_axis(vel: f64, acc: f64, jerk: f64) -> Vec<AxisLimits> {
    let mut l = limits();
    l.truncate(1);
    l[0].max_vel_per_s = vel;
    l[0].max_acc_per_s2 = acc;
    l[0].max_jerk_per_s3 = jerk;
    l
}

#[test]
fn check_names_the_axis_the_limit_and_the_factor() {
    // Quintic, X 100 mm in 0.5 s: peaks 1.875·100/0.5 = 375 mm/s, (10/√3)·100/0.25 = 2309.4
    // mm/s², 60·100/0.125 = 48000 mm/s³. Each case makes one limit the tight one; the factor is
    // (peak/limit)^(1/k).
    let mv = law_move(Preset::Rr5, &[(0, 0.0, 100.0)], 0.5);
    let acc_peak = 10.0 / 3f64.sqrt() * 400.0;
    for (lim, kind, factor) in [
        (x_axis(250.0, 1e9, 1e9), LimitKind::Velocity, 375.0 / 250.0),
        (x_axis(1e9, 1000.0, 1e9), LimitKind::Acceleration, (acc_peak / 1000.0).sqrt()),
        (x_axis(1e9, 1e9, 6000.0), LimitKind::Jerk, 2.0),
        (x_axis(300.0, 2000.0, 24000.0), LimitKind::Jerk, 2f64.cbrt()),
    ] {
        match mv.check(&lim) {
            Err(LimitError::Exceeded { axis_index: 0, kind: k, factor: f, min_duration_s, .. }) => {
                assert_eq!(k, kind);
                assert!((f - factor).abs() < 1e-12 * factor, "{kind}: {f} vs {factor}");
                assert!((min_duration_s - 0.5 * factor).abs() < 1e-12);
                // The reported duration is feasible for that limit, and for all of them.
                let stretched = mv.stretched(&lim).expect("stretch").duration_s();
                assert!((stretched - min_duration_s).abs() < 1e-12 * min_duration_s);
            }
            other => panic!("{kind}: {other:?}"),
        }
    }
    assert_eq!(mv.check(&x_axis(375.0, acc_peak, 48000.0)), Ok(()), "exactly at the limits");
    let lim = limits();
    // Jerk binds for short strokes: X 1 mm in 30 ms → vel 0.25, acc 1.60, jerk 1.644.
    match law_move(Preset::Rr5, &[(0, 0.0, 1.0)], 0.03).check(&lim) {
        Err(LimitError::Exceeded { kind: LimitKind::Jerk, factor, .. }) => {
            let want = (60.0 / (0.03f64.powi(3) * 50_000.0)).cbrt();
            assert!((factor - want).abs() < 1e-12 * want, "{factor} vs {want}");
        }
        other => panic!("{other:?}"),
    }
    // Several axes: the worst one is named, with its own (lower) limits; a negative stroke counts
    // by its size.
    match law_move(Preset::Rr7, &[(0, 0.0, 100.0), (2, 0.0, -150.0)], 0.5).check(&lim) {
        Err(e @ LimitError::Exceeded { axis_index: 2, .. }) => {
            let text = e.to_string();
            assert!(text.starts_with("axis Z: peak"), "{text}");
            assert!(text.contains("the duration must grow by a factor of"), "{text}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn travel_axis_and_law_errors() {
    let lim = limits();
    // X travel is [−1000, 1000].
    let mv = law_move(Preset::Rr7, &[(0, 990.0, 20.0)], 10.0);
    assert!(matches!(mv.check(&lim), Err(LimitError::Travel { axis_index: 0, .. })));
    assert!(matches!(mv.stretched(&lim), Err(LimitError::Travel { .. })));
    // An overshooting law: f(½) = 1.2 puts the peak above the end.
    let mut conds = Preset::Rr5.conditions();
    conds.push(c(0, 0.5, 1.2));
    let over = LawMove::new(solve(conds), vec![LawAxis { axis: 0, start: 900.0, stroke: 90.0 }], 10.0).expect("move");
    assert!(over.characteristics().f_max.value > 1.19);
    match over.check(&lim) {
        Err(LimitError::Travel { pos, .. }) => assert!(pos > 1000.0),
        other => panic!("{other:?}"),
    }
    let nowhere = law_move(Preset::Rr5, &[(7, 0.0, 1.0)], 1.0);
    assert!(matches!(nowhere.check(&lim), Err(LimitError::NoSuchAxis { index: 7, count: 3 })));
    // The article's degree-8 example does not end at rest (f″(1) ≠ 0): not a move.
    let err =
        LawMove::new(solve(Preset::Degree8.conditions()), vec![LawAxis { axis: 0, start: 0.0, stroke: 1.0 }], 1.0);
    assert!(matches!(err, Err(LawMoveError::NotRestToRest { what: "f''(1)", .. })), "{err:?}");
    let axis = vec![LawAxis { axis: 0, start: 0.0, stroke: 1.0 }];
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = LawMove::new(solve(Preset::Rr5.conditions()), axis.clone(), bad);
        assert!(matches!(e, Err(LawMoveError::BadDuration(_))));
    }
    let twice = vec![axis[0], axis[0]];
    assert!(matches!(LawMove::new(solve(Preset::Rr5.conditions()), twice, 1.0), Err(LawMoveError::DuplicateAxis(0))));
    let nan = vec![LawAxis { axis: 0, start: 0.0, stroke: f64::NAN }];
    assert!(matches!(LawMove::new(solve(Preset::Rr5.conditions()), nan, 1.0), Err(LawMoveError::BadPosition { .. })));
}

/// Max |first, second, third difference| / dtᵏ per axis over a sampled move.
fn finite_difference_peaks(mv: &LawMove, steps: usize) -> Vec<[f64; 3]> {
    let n = mv.axes().len();
    let dt = mv.duration_s() / steps as f64;
    let mut pos: Vec<Vec<f64>> = vec![Vec::with_capacity(steps + 1); n];
    let mut st = vec![AxisState::default(); n];
    for k in 0..=steps {
        mv.sample(k as f64 * dt, &mut st);
        for (p, s) in pos.iter_mut().zip(&st) {
            p.push(s.pos);
        }
    }
    pos.iter()
        .map(|p| {
            let d1: Vec<f64> = p.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
            let d2: Vec<f64> = d1.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
            let d3: Vec<f64> = d2.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
            let peak = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            [peak(&d1), peak(&d2), peak(&d3)]
        })
        .collect()
}

#[test]
fn stretched_moves_keep_the_limits_by_finite_differences() {
    let lim = limits();
    let axes = [(0, -200.0, 120.0), (1, 50.0, -80.0), (2, 0.0, 40.0)];
    for p in Preset::all().into_iter().filter(|p| *p != Preset::Degree8) {
        let mv = law_move(p, &axes, 0.01);
        let Err(LimitError::Exceeded { min_duration_s, .. }) = mv.check(&lim) else {
            panic!("{}: 10 ms must be too fast", p.name());
        };
        let st = mv.stretched(&lim).expect("stretch");
        assert_eq!(st.check(&lim), Ok(()), "{}", p.name());
        assert!((st.duration_s() - min_duration_s).abs() < 1e-12 * min_duration_s, "{}", p.name());
        // A stretched move never gets shorter.
        assert_eq!(st.stretched(&lim).expect("again").duration_s(), st.duration_s());
        let peaks = finite_difference_peaks(&st, 4000);
        let mut tightest = 0.0f64;
        for (a, pk) in axes.iter().zip(&peaks) {
            let l = &lim[a.0];
            let ratios = [pk[0] / l.max_vel_per_s, pk[1] / l.max_acc_per_s2, pk[2] / l.max_jerk_per_s3];
            for r in ratios {
                // A k-th difference is a weighted mean of the k-th derivative: ≤ its peak.
                assert!(r <= 1.0 + 1e-6, "{}: axis {} ratio {r}", p.name(), l.name);
                tightest = tightest.max(r);
            }
        }
        // … and the stretch is tight: some limit is reached (to the grid's resolution).
        assert!(tightest > 0.99, "{}: loosest {tightest}", p.name());
    }
}

#[test]
fn samples_start_at_rest_and_end_exactly_at_the_stroke() {
    let mv = law_move(Preset::Rr11, &[(0, 0.1, 123.456), (2, -7.3, -0.7)], 0.9);
    let mut st = [AxisState::default(); 2];
    for t in [0.9, 0.9 + 1e-9, 5.0, f64::INFINITY] {
        mv.sample(t, &mut st);
        assert_eq!(st[0], AxisState { pos: 0.1 + 123.456, ..AxisState::default() });
        assert_eq!(st[1], AxisState { pos: -7.3 + -0.7, ..AxisState::default() });
    }
    for t in [-1.0, f64::NAN, f64::NEG_INFINITY] {
        mv.sample(t, &mut st);
        assert_eq!(st[0], AxisState { pos: 0.1, ..AxisState::default() });
    }
    mv.sample(0.0, &mut st);
    assert!((st[0].pos - 0.1).abs() < 1e-12 && st[0].vel_per_s.abs() < 1e-9 && st[0].acc_per_s2.abs() < 1e-6);
    // Just before the end the motion is continuous with the end state.
    mv.sample(0.9 - 1e-7, &mut st);
    assert!((st[0].pos - (0.1 + 123.456)).abs() < 1e-9 && st[0].vel_per_s.abs() < 1e-6);
    // The sampled derivatives agree with central differences of the positions.
    let (t, h) = (0.37, 1e-5);
    let mut a = [AxisState::default(); 2];
    let mut b = [AxisState::default(); 2];
    mv.sample(t, &mut st);
    mv.sample(t - h, &mut a);
    mv.sample(t + h, &mut b);
    assert!(((b[0].pos - a[0].pos) / (2.0 * h) - st[0].vel_per_s).abs() < 1e-5 * st[0].vel_per_s.abs());
    assert!(
        ((b[0].vel_per_s - a[0].vel_per_s) / (2.0 * h) - st[0].acc_per_s2).abs()
            < 1e-5 * st[0].acc_per_s2.abs().max(1.0)
    );
    assert!(
        ((b[0].acc_per_s2 - a[0].acc_per_s2) / (2.0 * h) - st[0].jerk_per_s3).abs()
            < 1e-4 * st[0].jerk_per_s3.abs().max(1.0)
    );
    // Sampling allocates nothing (it runs in the fine cycle).
    let before = allocations();
    let mut sum = 0.0;
    for k in 0..10_000 {
        mv.sample(f64::from(k) * 1e-4, &mut st);
        sum += st[0].jerk_per_s3;
    }
    assert_eq!(allocations(), before, "sample allocated");
    assert!(sum.is_finite());
    // A shorter output gets the first axes; nothing panics.
    let mut one = [AxisState::default(); 1];
    mv.sample(0.45, &mut one);
    assert!(one[0].pos > 0.1);
}
