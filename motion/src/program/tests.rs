use super::*;
use crate::Settings;
use crate::path::{AxisDerivs, Feed, Geometry, JointKind};

fn xyz() -> Settings {
    Settings::default_machine()
}

fn ok(text: &str) -> Program {
    parse(text, "t.ngc", &xyz()).unwrap_or_else(|e| panic!("program rejected:\n{e}"))
}

fn first_error(text: &str) -> String {
    parse(text, "t.ngc", &xyz()).expect_err("program must be rejected").0[0].to_string()
}

fn end(p: &Program) -> [f64; 3] {
    let e = p.path.end_position();
    [e[0], e[1], e[2]]
}

/// The end point of element `i`.
fn end_at(p: &Program, i: usize) -> [f64; 3] {
    let g = &p.path.elements[i].geometry;
    let mut d = AxisDerivs::default();
    g.eval(g.length_mm(), &mut d);
    [d.pos[0], d.pos[1], d.pos[2]]
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b.iter()).all(|(x, y)| (x - y).abs() < 1e-9)
}

#[test]
fn modal_state_carries_between_blocks() {
    let p = ok("G21 G90 G17\nG1 X10 F600\nY5\nG91 X1 Y1\nG0 Z2\n");
    assert_eq!(p.path.elements.len(), 4);
    assert!(close(end(&p), [11.0, 6.0, 2.0]));
    assert_eq!(p.path.elements[1].feed, Feed::Programmed { mm_per_s: 10.0 });
    assert_eq!(p.path.elements[3].feed, Feed::Rapid);
    assert!((p.path.length_mm() - (10.0 + 5.0 + 2f64.sqrt() + 2.0)).abs() < 1e-12);
}

#[test]
fn inches_convert_to_mm() {
    let p = ok("G20\nG1 X1 F10\n");
    assert!(close(end(&p), [25.4, 0.0, 0.0]));
    assert_eq!(p.path.elements[0].feed, Feed::Programmed { mm_per_s: 25.4 * 10.0 / 60.0 });
}

#[test]
fn arcs_centre_and_radius_form_agree() {
    let a = ok("G1 X10 F600\nG3 X0 Y10 I-10 J0\n");
    let b = ok("G1 X10 F600\nG3 X0 Y10 R10\n");
    assert!(close(end(&a), [0.0, 10.0, 0.0]) && close(end(&b), [0.0, 10.0, 0.0]));
    let (la, lb) = (a.path.elements[1].geometry.length_mm(), b.path.elements[1].geometry.length_mm());
    assert!((la - 5.0 * std::f64::consts::PI).abs() < 1e-12 && (la - lb).abs() < 1e-12);
    // Negative R takes the long way round.
    let c = ok("G1 X10 F600\nG3 X0 Y10 R-10\n");
    assert!((c.path.elements[1].geometry.length_mm() - 15.0 * std::f64::consts::PI).abs() < 1e-9);
}

#[test]
fn full_circle_and_helix() {
    let p = ok("G1 X10 F600\nG2 X10 Y0 Z5 I-10 J0\n");
    let h = &p.path.elements[1].geometry;
    let expect = ((20.0 * std::f64::consts::PI).powi(2) + 25.0).sqrt();
    assert!((h.length_mm() - expect).abs() < 1e-9);
    assert!(close(end(&p), [10.0, 0.0, 5.0]));
    // Clockwise: from (10,0) about the origin the first step goes towards −y.
    let mut d = AxisDerivs::default();
    h.eval(0.0, &mut d);
    assert!(d.d1[1] < 0.0);
}

#[test]
fn planes_g18_g19() {
    // G18: ZX plane, centre offsets K (Z) and I (X); G3 turns counter-clockwise in (Z, X).
    let p = ok("G18 G1 Z10 F600\nG3 Z0 X10 K-10 I0\n");
    assert!(close(end(&p), [10.0, 0.0, 0.0]));
    let p = ok("G19 G1 Y10 F600\nG2 Y0 Z-10 J-10 K0\n");
    assert!(close(end(&p), [0.0, 0.0, -10.0]));
}

#[test]
fn joints_are_classified() {
    let p = ok("G1 X10 F600\nY10\n");
    assert_eq!(p.path.elements[1].joint, JointKind::Corner);
    let p = ok("G1 X10 F600\nX20\n");
    assert_eq!(p.path.elements[1].joint, JointKind::Smooth);
    let p = ok("G1 X10 F600\nG3 X20 Y10 I0 J10\n");
    assert_eq!(p.path.elements[1].joint, JointKind::CurvatureJump);
}

#[test]
fn dwell_attaches_to_next_move() {
    let p = ok("G1 X10 F600\nG4 P0.5\nX20\nG4 P1\n");
    assert_eq!(p.path.elements[1].dwell_before_s, 0.5);
    assert!(p.path.elements[1].stops_before());
    assert_eq!(p.path.final_dwell_s, 1.0);
}

#[test]
fn g06_explicit_tangents_absolute_and_incremental() {
    let abs = ok("G1 X0 F600\nG06 I10 J0 K0\nX10 Y10 Z0 P0 Q10 R0;\nX0 Y20 Z0 P-10 Q0 R0;\n\nG1 X0 Y0\n");
    let inc = ok("G1 X0 F600\nG91\nG06 I10 J0 K0\nX10 Y10 Z0 P0 Q10 R0;\nX-10 Y10 Z0 P-10 Q0 R0;\nCR\n");
    assert_eq!(abs.path.elements.iter().filter(|e| matches!(e.geometry, Geometry::Cubic(_))).count(), 2);
    assert!(close(end(&inc), [0.0, 20.0, 0.0]));
    let sa = &abs.path.elements[0].geometry;
    let si = &inc.path.elements[0].geometry;
    assert!((sa.length_mm() - si.length_mm()).abs() < 1e-12);
    // After the spline data the earlier motion mode (G1) is back.
    assert!(close(end(&abs), [0.0, 0.0, 0.0]));
}

#[test]
fn g06_natural_spline_through_points() {
    let p = ok("G1 X0 F600\nG06\nX10 Y5 Z0;\nX20 Y0 Z0;\nX30 Y5 Z0;\nCR\n");
    assert_eq!(p.path.elements.len(), 3);
    // An empty line or the next block end the spline data as well.
    for end in ["\n", "M30\n"] {
        let q = ok(&format!("G1 X0 F600\nG06\nX10 Y5 Z0;\nX20 Y0 Z0;\nX30 Y5 Z0;\n{end}"));
        assert_eq!(q.path.elements.len(), 3, "ended by {end:?}");
    }
    for e in &p.path.elements[1..] {
        assert_eq!(e.joint, JointKind::Smooth, "natural spline is C² at its support points");
    }
    assert!(close(end(&p), [30.0, 5.0, 0.0]));
}

#[test]
fn ignored_words_and_end() {
    let p = ok("M3 S1000\nG1 X1 F100\nM30\nG1 X999999\n");
    assert_eq!(p.summary.ignored_words, 2);
    assert_eq!(p.path.elements.len(), 1);
}

#[test]
fn error_positions() {
    let cases = [
        ("G1 X1 F100 X2\n", "t.ngc:1:12: word X appears twice in this block"),
        ("G1 X1\n", "t.ngc:1:1: G1 without feed: program F (mm/min) before or in this block"),
        ("G1 A1 F100\n", "t.ngc:1:4: axis A is not on this machine (axes: X Y Z)"),
        ("G1 X2000 F100\n", "t.ngc:1:4: X target 2000 mm is outside the travel range [-1000, 1000]"),
        ("G1 F100\nG2 X10 I0 J0\n", "t.ngc:2:8: degenerate arc: the centre lies on the start point (radius zero)"),
        ("T3 M6\nG42 X1\n", "t.ngc:2:1: tool 3 is not in the tool table"),
        ("G42.1 X1\n", "t.ngc:1:1: G42.1 needs D (the tool diameter)"),
        ("G41 D3\n", "t.ngc:1:5: tool 3 is not in the tool table"),
        ("T5 M6\nG43\n", "t.ngc:2:1: tool 5 is not in the tool table"),
        ("F100\nG3 X0 I5 P1.5\n", "t.ngc:2:10: P (turns of the arc) must be an integer, got 1.5"),
        ("F100\nG3 X0 I5 P0\n", "t.ngc:2:10: P (turns of the arc) must be 1 or more, got 0"),
        ("F100\nG3 R5\n", "t.ngc:2:4: R without an arc end point"),
        ("M61\n", "t.ngc:1:1: M61 needs Q (the number of the tool in the spindle)"),
        ("M19 P3\n", "t.ngc:1:5: M19: P must be 0, 1 or 2, got 3"),
        ("G0 G1 X1\n", "t.ngc:1:4: G1 conflicts with G0 in the same block (same modal group)"),
        ("F100\nG06 I1 J0 K0\nX1 Y0 Z0 P1 Q0 R0\n", "t.ngc:3:18: G06 span must end with ';'"),
        ("F100\nG06 I1\n", "t.ngc:2:1: unterminated G06 block: no spline spans ('X.. Y.. Z.. P.. Q.. R..;') follow"),
        (
            "F100\nG06\nX10 Y5 Z0;\nX20 Y0 Z0;\n",
            "t.ngc:2:1: the program ends inside this G06 block: end its spline data with an empty line, a line 'CR' \
             or the next block",
        ),
    ];
    for (text, expect) in cases {
        assert_eq!(first_error(text), expect, "program:\n{text}");
    }
}

#[test]
fn every_word_is_used_or_an_error() {
    let cases = [
        ("G1 X1 H5 F100\n", "t.ngc:1:7: H word with no G43 to use it"),
        ("G1 X1 F100 E3\n", "t.ngc:1:12: E word with no G-code that uses it"),
        ("G1 X1e300 F100\n", "t.ngc:1:4: 'X1e300': a number with an exponent is not G-code (write it in decimals)"),
        ("G1 X1 F100 P2\n", "t.ngc:1:12: P is only valid with G4, G64 or in G06 spline data"),
        (
            "F100 Q1\n",
            "t.ngc:1:6: Q word with no G-code that uses it (G64 Q1 / Q2 select the smoothing method; LinuxCNC's naive-CAM tolerance Q is not supported)",
        ),
        (
            "G64 P0.1 Q0.01\n",
            "t.ngc:1:10: G64 Q selects the smoothing method, Q1 Hermite or Q2 B-spline, got Q0.01 (LinuxCNC's \
             naive-CAM tolerance Q is not supported)",
        ),
        ("G0 X1 D2\n", "t.ngc:1:7: D word with no G41/G42 (or G41.1/G42.1) to use it"),
        ("G0 X1 L2\n", "t.ngc:1:7: L word with no G-code that uses it"),
        ("O100 G0 X1\n", "t.ngc:1:6: unknown O word keyword 'g'"),
        ("G61 P1\n", "t.ngc:1:5: P is only valid with G4, G64 or in G06 spline data"),
        ("G0 X1 N5\n", "t.ngc:1:7: block number N must be the first word of the block"),
        ("M3 M4\n", "t.ngc:1:4: M4 conflicts with M3 in the same block (same modal group)"),
        ("M7 M8\n", "t.ngc:1:4: M8 conflicts with M7 in the same block (same modal group)"),
        ("M2 M30\n", "t.ngc:1:4: M30 conflicts with M2 in the same block (same modal group)"),
        ("S-1\n", "t.ngc:1:1: spindle speed S must not be negative, got -1"),
        ("T1.5\n", "t.ngc:1:1: tool number T must be a non-negative integer, got 1.5"),
        ("G0 X1\n%\n", "t.ngc:2:1: '%' is only valid as the first line of a program (and then as its last)"),
        ("G4 P1 X5\n", "t.ngc:1:7: axis word without a motion mode: program G0, G1, G2 or G3 first"),
    ];
    for (text, expect) in cases {
        assert_eq!(first_error(text), expect, "program:\n{text}");
    }
}

#[test]
fn g64_q_selects_the_smoothing_method() {
    use crate::path::Blend;
    use interpd_config::PrepMethod;
    let p = ok("G64 P0.1 Q2\nG1 X1 F100\nG64 P0.05 Q1\nG1 X2\nG64\nG1 X3\n");
    let blends: Vec<Blend> = p.path.elements.iter().map(|e| e.blend).collect();
    assert_eq!(blends[0], Blend::Tolerance { tol_mm: 0.1, method: PrepMethod::Bspline });
    assert_eq!(blends[1], Blend::Tolerance { tol_mm: 0.05, method: PrepMethod::Hermite });
    // G64 without Q: the [prep] default.
    assert!(matches!(blends[2], Blend::Tolerance { method: PrepMethod::Hermite, .. }));
}

#[test]
fn linuxcnc_forms_are_accepted() {
    // F in a G20/G21 block is read in the units before it, as LinuxCNC reads it.
    let p = ok("G20 G1 X1 F10\nG21 G1 X2 F100\n");
    let feeds: Vec<f64> = p
        .path
        .elements
        .iter()
        .map(|e| match e.feed {
            Feed::Programmed { mm_per_s } => mm_per_s * 60.0,
            Feed::Rapid => f64::NAN,
        })
        .collect();
    assert!((feeds[0] - 10.0).abs() < 1e-9 && (feeds[1] - 2540.0).abs() < 1e-9, "{feeds:?}");
    // A centre-form arc without axis words is a full circle; P adds turns.
    let p = ok("G0 X10\nF100\nG2 I5\nG3 I5 P3\nJ5\n");
    let sweeps: Vec<f64> = p
        .path
        .elements
        .iter()
        .filter_map(|e| match &e.geometry {
            Geometry::Helix(h) => Some(h.sweep_rad() / std::f64::consts::PI),
            _ => None,
        })
        .collect();
    assert_eq!(sweeps.len(), 3);
    assert!((sweeps[0] + 2.0).abs() < 1e-12 && (sweeps[1] - 6.0).abs() < 1e-12 && (sweeps[2] - 2.0).abs() < 1e-12);
    // G43 and G41 without H/D take the tool in the spindle; with none, length and radius 0.
    let mut settings = Settings::default_machine();
    settings.tools = vec![crate::config::ToolConfig { number: 2, diameter_mm: 4.0, length_mm: 10.0, name: None }];
    let p = parse("T2 M6\nG43\nG0 Z0\nG41\nG1 X10 F100\nG40 G1 X20\n", "t.ngc", &settings).expect("ok");
    assert!(close(end_at(&p, 0), [0.0, 0.0, 10.0]));
    assert!(close(end_at(&p, 1), [10.0, 2.0, 10.0]));
    let p = parse("G43\nG0 Z1\nG41\nG1 X10 F100\n", "t.ngc", &settings).expect("ok");
    assert!(close(end(&p), [10.0, 0.0, 1.0]));
}

#[test]
fn words_that_mean_something_are_accepted() {
    // Dwell and motion in one block: the dwell comes first, as in RS274NGC.
    let p = ok("G1 X1 F100\nG4 P1 X5\nG4 P0.5 G0 Y5\n");
    assert_eq!(p.path.elements.len(), 3);
    assert_eq!((p.path.elements[1].dwell_before_s, p.path.elements[2].dwell_before_s), (1.0, 0.5));
    assert!(close(end(&p), [5.0, 5.0, 0.0]));
    // Spindle, coolant and tool words are counted; one of each group per block.
    let p = ok("N10 M3 S1000 M8 T2 M6\nG0 X1\n");
    assert_eq!(p.summary.ignored_words, 5);
    // A tape: `%` first, and the next `%` ends the program.
    let p = ok("%\nG0 X1\n%\nG0 X$\n");
    assert!(close(end(&p), [1.0, 0.0, 0.0]));
}

#[test]
fn path_table_rows_and_corner() {
    let text =
        "s,X,X',X'',X''',Y,Y',Y'',Y'''\n0,0,1,0,0,0,0,0,0\n1,1,1,0,0,0,0,0,0\n1,1,0,0,0,0,1,0,0\n2,1,0,0,0,1,1,0,0\n";
    let p = parse(text, "t.csv", &xyz()).unwrap();
    assert_eq!(p.path.elements.len(), 2);
    assert_eq!(p.path.elements[1].joint, JointKind::Corner);
    assert!((p.path.length_mm() - 2.0).abs() < 1e-15);
}

#[test]
fn path_table_errors() {
    let e = parse("s,X,X',X'',Xq\n", "t.csv", &xyz()).unwrap_err().0[0].to_string();
    assert_eq!(e, "t.csv:1:12: expected column 'X\'\'\'', found 'Xq'");
    let e = parse("s,X,X',X'',X'''\n0,0,1,0,0\n1,1,1,0\n", "t.csv", &xyz()).unwrap_err().0[0].to_string();
    assert_eq!(e, "t.csv:3:8: row has 4 fields, the header has 5");
    let e = parse("s,X,X',X'',X'''\n0,0,1,0,0\n1,nan,1,0,0\n", "t.csv", &xyz()).unwrap_err().0[0].to_string();
    assert_eq!(e, "t.csv:3:3: 'nan' is not a finite number");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]
    /// Any text: the parser returns (program or errors), never panics.
    #[test]
    fn parser_never_panics(text in "[GXYZIJKRFPNMQ0-9 .;()\\-\\n]{0,200}") {
        let _ = parse(&text, "p.ngc", &xyz());
    }

    /// Random polylines of G1 moves end exactly at the last target, with the exact length.
    #[test]
    fn polyline_length_exact(pts in proptest::collection::vec((-100i32..100, -100i32..100), 1..20)) {
        let mut text = String::from("G1 F1000\n");
        let mut prev = (0.0f64, 0.0f64);
        let mut len = 0.0;
        for (x, y) in &pts {
            let (x, y) = (*x as f64 / 4.0, *y as f64 / 4.0);
            text += &format!("X{x} Y{y}\n");
            len += (x - prev.0).hypot(y - prev.1);
            prev = (x, y);
        }
        let p = ok(&text);
        proptest::prop_assert!((p.path.length_mm() - len).abs() < 1e-9);
    }
}

#[test]
fn gcode_continues_from_a_modal_state() {
    let settings = xyz();
    let mut pos = [0.0; crate::path::MAX_AXES];
    pos[0] = 5.0;
    let mut modal = ModalState::new(&settings, pos);
    let first = parse_gcode_from("G91 G1 X10 F600", "mdi", &settings, &mut modal).unwrap();
    assert_eq!(first.path.start[0], 5.0);
    assert_eq!(modal.position()[0], 15.0);
    // G91, G1 and F carry over.
    let second = parse_gcode_from("Y2", "mdi", &settings, &mut modal).unwrap();
    assert_eq!(second.path.elements.len(), 1);
    assert_eq!((modal.position()[0], modal.position()[1]), (15.0, 2.0));
    // An error leaves the state as it was.
    let e = parse_gcode_from("G1 X F600", "mdi", &settings, &mut modal).unwrap_err();
    assert_eq!((e.0[0].line, e.0[0].col), (1, 4));
    assert_eq!(modal.position()[1], 2.0);
}

/// End point of each element on axis `k`.
fn ends_on(p: &Program, k: usize) -> Vec<f64> {
    p.path
        .elements
        .iter()
        .map(|e| {
            let mut d = AxisDerivs::default();
            e.geometry.eval(e.geometry.length_mm(), &mut d);
            d.pos[k]
        })
        .collect()
}

#[test]
fn g92_offsets_the_coordinates_as_linuxcnc() {
    // As LinuxCNC's rs274 reads it (machine X): G92 X0 at X5 makes X1 the machine's 6; G92.2
    // suspends the offset, G92.3 restores it; G92 ignores G91; G92.1 clears it.
    let p = ok("G0 X5 Y1\nG92 X0\nG1 X1 F100\nG92.2\nG1 X2\nG92.3\nG1 X3\nG91\nG92 X10\nG90 G1 X11\nG92.1\nG1 X0\n");
    let want = [5.0, 6.0, 2.0, 8.0, 9.0, 0.0];
    let got = ends_on(&p, 0);
    assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-12), "{got:?}");
    // In inches, added to the work offset and the tool length, and carried by G92.1's axis
    // words to the motion mode (G92.1 itself takes none).
    let p = ok("G20 G0 X1\nG92 X0 Z0\nG0 X1 Z1\nG92.1 X3\n");
    assert!(close(end(&p), [76.2, 0.0, 25.4]), "{:?}", end(&p));
    let got = ends_on(&p, 0);
    assert!(got.iter().zip([25.4, 50.8, 76.2]).all(|(g, w)| (g - w).abs() < 1e-12), "{got:?}");
    let mut settings = xyz();
    settings.tools = vec![interpd_config::ToolConfig { number: 1, diameter_mm: 6.0, length_mm: 50.0, name: None }];
    let p = parse("G43 H1\nG0 Z0\nG92 Z10\nG0 Z0\n", "t.ngc", &settings).expect("valid");
    assert_eq!(ends_on(&p, 2), vec![50.0, 40.0]);
}

#[test]
fn g92_refusals_name_the_place() {
    assert_eq!(
        first_error("G92\n"),
        "t.ngc:1:1: G92 needs at least one axis word (the coordinates of the current point)"
    );
    assert_eq!(
        first_error("G0 X1\nG92 G1 X0 F100\n"),
        "t.ngc:2:1: G92 and a motion G-code in one block: both would use the axis words"
    );
    assert_eq!(first_error("G92 G4 P1 X0\n"), "t.ngc:1:5: G4 conflicts with G92 in the same block (same modal group)");
    let mut settings = xyz();
    settings.tools = vec![interpd_config::ToolConfig { number: 1, diameter_mm: 6.0, length_mm: 0.0, name: None }];
    let e = parse("G0 X0 Y0\nG41 D1\nG92 X0\n", "t.ngc", &settings).expect_err("comp on").0;
    assert_eq!(
        e[0].to_string(),
        "t.ngc:3:1: cannot change the axis offsets (G92) with cutter compensation on: program G40 first"
    );
    assert!(first_error("G92 Q1\n").contains("G92 needs at least one axis word"));
}

#[test]
fn feed_modes_and_spindle_modes() {
    // G94 forgets the feed as LinuxCNC does; G96/G97 are ignored like S.
    let p = ok("G94 G96 D2500 S200\nG97\nG1 X10 F600\n");
    assert_eq!(p.path.elements[0].feed, Feed::Programmed { mm_per_s: 10.0 });
    assert_eq!(p.summary.ignored_words, 3);
    assert!(first_error("G1 X1 F600\nG94\nG1 X2\n").starts_with("t.ngc:3:1: G1 without feed"));
    // G93: a 10 mm move in 1/2 minute runs at 20 mm/min; every feed move needs its own F.
    let p = ok("G93\nG1 X10 F2\nG0 X0\nG2 X10 I5 F1\n");
    let f = |i: usize| match p.path.elements[i].feed {
        Feed::Programmed { mm_per_s } => mm_per_s,
        Feed::Rapid => -1.0,
    };
    assert!((f(0) - 10.0 * 2.0 / 60.0).abs() < 1e-12);
    assert_eq!(f(1), -1.0);
    assert!((f(2) - 5.0 * PI_F64 / 60.0).abs() < 1e-9);
    assert!(first_error("G93\nG1 X10 F2\nG1 X20\n").starts_with("t.ngc:3:1: inverse time (G93)"));
    assert!(first_error("G95 G1 X1 F1\n").contains("needs a spindle"));
}

const PI_F64: f64 = std::f64::consts::PI;

#[test]
fn program_stops_are_planned_pauses_after_the_block_motion() {
    use crate::path::{Pause, StopCode};
    let p = ok("G1 X10 F600\nG1 X20 M0\nG1 X30\nM1\nG1 Y5\nM60\n");
    let pauses: Vec<Option<Pause>> = p.path.elements.iter().map(|e| e.pause_before).collect();
    // Each stop names its own block's line (not the line the motion goes on with).
    assert_eq!(pauses, [None, None, Some(Pause::stop(StopCode::Stop, 2)), Some(Pause::stop(StopCode::Optional, 4))]);
    assert!(p.path.elements[2].stops_before());
    assert_eq!(p.summary.pauses, 3);
    assert!(first_error("M0 M1\n").contains("same modal group"));
}

/// The end points of a program's elements (X Y Z), rounded to 1e-6.
fn ends(p: &Program) -> Vec<[f64; 3]> {
    p.path
        .elements
        .iter()
        .map(|e| {
            let mut d = AxisDerivs::default();
            e.geometry.eval(e.geometry.length_mm(), &mut d);
            [0, 1, 2].map(|k| (d.pos[k] * 1e6).round() / 1e6)
        })
        .collect()
}

fn errors_of(text: &str, settings: &Settings) -> Vec<String> {
    match parse(text, "t.ngc", settings) {
        Ok(_) => panic!("program must be rejected:\n{text}"),
        Err(e) => e.0.iter().map(|e| e.to_string()).collect(),
    }
}

#[test]
fn parameters_expressions_and_control_flow_as_linuxcnc() {
    // Checked against rs274 (LinuxCNC 2.9): the same end points.
    let text = "#<r> = 5\n#1 = 0\no100 while [#1 LT 3]\n  G1 X[#1 * #<r>] Y[#1] F600\n  #1 = [#1 + 1]\n\
                o100 endwhile\no200 sub\n  G1 X#1 Y#2\n  o200 return [#1 + #2]\no200 endsub\no200 call [1] [2]\n\
                o300 if [#<_value> EQ 3]\n  G1 Z-1\no300 elseif [1]\n  G1 Z-2\no300 else\n  G1 Z-3\no300 endif\n\
                o400 repeat [3]\n  G91 G1 X1\no400 endrepeat\nG90\no500 do\n  #1 = [#1 - 1]\n  o510 if [#1 EQ 1]\n\
                o500 continue\n  o510 endif\n  G1 Y#1\no500 while [#1 GT 0]\nM2\n";
    let p = ok(text);
    let want = [
        [5.0, 1.0, 0.0],
        [10.0, 2.0, 0.0],
        [1.0, 2.0, 0.0],
        [1.0, 2.0, -1.0],
        [2.0, 2.0, -1.0],
        [3.0, 2.0, -1.0],
        [4.0, 2.0, -1.0],
        [4.0, 0.0, -1.0],
    ];
    assert_eq!(ends(&p), want);
    // Assignments take effect after the line: X reads the old #1.
    let p = ok("#1 = 2\n#1 = 7 G1 X#1 F100\nG1 Y#1\n");
    assert_eq!(ends(&p), [[2.0, 0.0, 0.0], [2.0, 7.0, 0.0]]);
    // Predefined parameters: the position in program units, the modes.
    let p = ok("G20\nG1 X1 F10\nG1 Y[#5420 * 2 + #<_imperial>]\n");
    assert!(close(end(&p), [25.4, 3.0 * 25.4, 0.0]));
    // G-codes from parameters, break out of a while, a sub's named locals.
    let p = ok("#2 = 1\nG#2 X1 F100\no1 while [1]\n  o1 break\no1 endwhile\no9 sub\n#<a> = #1\nG1 Y#<a>\no9 endsub\n\
                o9 call [4]\n");
    assert_eq!(ends(&p), [[1.0, 0.0, 0.0], [1.0, 4.0, 0.0]]);
}

#[test]
fn language_errors_are_positioned() {
    let s = xyz();
    let cases: [(&str, &str); 14] = [
        ("G1 X[1/0] F100\n", "t.ngc:1:7: division by zero"),
        ("G1 X#<depth> F100\n", "t.ngc:1:5: named parameter #<depth> is not defined"),
        ("#1 = SQRT[-1]\n", "t.ngc:1:6: SQRT of -1"),
        ("#5420 = 1\n", "t.ngc:1:1: parameter #5420 is read-only"),
        ("o1 while [1]\no1 endwhile\n", "t.ngc:1:1: o1 while: the program's loops and calls have run 1000 times"),
        ("o1 do\no1 while [1]\n", "t.ngc:1:1: o1 while: the program's loops and calls have run 1000 times"),
        ("o<r> sub\no<r> call\no<r> endsub\no<r> call\n", "t.ngc:2:1: o<r> call: calls nested deeper than 10"),
        ("o<nope> call\n", "t.ngc:1:1: call of an undefined subroutine o<nope>"),
        ("o<../x> call\n", "t.ngc:1:1: subroutine file name '../x' is refused"),
        ("o1 while [1]\nG1 X1 F100\n", "t.ngc:1:1: o1 is not closed"),
        ("o1 if [0]\nG1 X1 F100\n", "t.ngc:1:1: o1 if: the program ends before its elseif or else or endif"),
        ("o2 endwhile\n", "t.ngc:1:1: o2 endwhile without o2 while"),
        ("o2 if\n", "t.ngc:1:4: o2 if needs its value in [ ]"),
        ("G1 X1 o2 if [1]\n", "t.ngc:1:7: an O word must begin its line"),
    ];
    let mut capped = s.clone();
    capped.programs.max_loop_iterations = 1000;
    for (text, want) in cases {
        let e = errors_of(text, &capped);
        assert!(e[0].starts_with(want), "{text}: {e:?}");
    }
    // MDI text reads parameters but cannot loop.
    let mut m = ModalState::new(&s, [0.0; crate::path::MAX_AXES]);
    let e = parse_gcode_from("o1 while [1]\n", "mdi", &s, &mut m).expect_err("no loops in MDI");
    assert!(e.0[0].message.contains("not supported in appended text or MDI"), "{e}");
}

#[test]
fn subroutine_files_come_from_the_subroutine_path_inside_the_programs_directory() {
    let dir = std::env::temp_dir().join(format!("interpd-subs-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("subs")).expect("dir");
    std::fs::write(dir.join("subs/square.ngc"), "o<square> sub\nG1 X#1 F100\nG1 Y#1\no<square> endsub\n").expect("w");
    std::fs::write(dir.join("subs/broken.ngc"), "o<broken> sub\nG1 X1 F100\n").expect("w");
    let mut s = xyz();
    s.programs.dir = Some(dir.display().to_string());
    s.programs.subroutine_path = vec!["subs".into()];
    let p = parse("o<square> call [3]\nG1 Z-1 F100\no<square> call [5]\n", "t.ngc", &s).expect("valid");
    assert_eq!(ends(&p), [[3.0, 0.0, 0.0], [3.0, 3.0, 0.0], [3.0, 3.0, -1.0], [5.0, 3.0, -1.0], [5.0, 5.0, -1.0]]);
    let e = errors_of("o<broken> call\n", &s);
    assert!(e[0].contains("broken.ngc ends before its endsub"), "{e:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn subs_may_follow_the_main_program_and_return_from_inside_a_block() {
    // LinuxCNC's nc_files/retval.ngc and tests/interp/subs-follow-main, in short.
    let p = ok("o1 call [2]\nG1 X#<_value> F100\no1 call [-1]\nG1 Y#<_value>\nM2\n\
                o1 sub\no10 if [#1 GT 0]\no10 return [123 * #1]\no10 endif\no1 endsub [7]\n");
    assert_eq!(ends(&p), [[246.0, 0.0, 0.0], [246.0, 7.0, 0.0]]);
    let p = ok(
        "#<s> = 2\no#<s> call\no[#<s> * 2] call\nM2\no2 sub\nG1 X1 F100\no2 endsub\no4 sub\nG1 Y1 F100\no4 endsub\n",
    );
    assert_eq!(ends(&p), [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]);
    let e = errors_of("o<n> sub\no100 sub\no100 endsub\no<n> endsub\n", &xyz());
    assert!(e[0].starts_with("t.ngc:2:1: nested subroutine definition"), "{e:?}");
}

#[test]
fn offsets_home_positions_and_machine_coordinates() {
    // Checked against rs274 in tests/programs/language/offsets_g10_g28_g53.ngc; here the rules.
    let p = ok("G10 L2 P2 X100\nG55 G0 X1\nG53 G0 X5\nG28.1\nG0 X0\nG28\nG59.3 G0 X3\n");
    assert_eq!(ends(&p), [[101.0, 0.0, 0.0], [5.0, 0.0, 0.0], [100.0, 0.0, 0.0], [5.0, 0.0, 0.0], [3.0, 0.0, 0.0]]);
    assert!(p.summary.work_offsets.contains("G59.3"));
    for (text, want) in [
        ("G91 G53 G0 X1\n", "t.ngc:1:5: G53 cannot be used in incremental distance mode"),
        ("G53 G2 X1 I1 F100\n", "t.ngc:1:1: G53 moves in machine coordinates with G0 or G1 only"),
        ("G10 L1 P1\n", "t.ngc:1:1: G10 L1 without offsets has no effect"),
        ("G10 L1 X1\n", "t.ngc:1:1: G10 L1 needs P (the tool number)"),
        ("G10 L10 P1.5 X1\n", "t.ngc:1:9: G10 L10: P must be a tool number"),
        ("G10 L11 P7 Z1\n", "t.ngc:1:9: G10 L11: tool 7 is not in the tool table"),
        ("G10 L1 P1 Q12\n", "t.ngc:1:11: G10 L1: Q (the lathe tool orientation) must be 0 … 9"),
        ("G10 L3 P1 X1\n", "t.ngc:1:5: G10 L3 is not supported"),
        ("G10 L2 X1\n", "t.ngc:1:1: G10 L2 needs P"),
        ("G10 L2 P10 X1\n", "t.ngc:1:8: G10: P must be a coordinate system 0 … 9"),
        ("G28.1 X1\n", "t.ngc:1:7: G28.1 stores the current position and takes no axis words"),
        ("#5221 = 3\n", "t.ngc:1:1: parameter #5221 is read-only"),
    ] {
        assert!(first_error(text).starts_with(want), "{text}: {}", first_error(text));
    }
}

#[test]
fn fanuc_subprograms_m98_m99_as_linuxcnc() {
    // LinuxCNC's tests/interp/m98m99/05: the subprogram follows the main program, L repeats
    // it, parameters are shared with the caller.
    let p = ok("O7\nF100\n#1 = 0\nM98 P1 L3\nG1 Y#1\nM98 P1 L0\nM30\nO1\nG91 G1 X1\nG90\n#1 = [#1 + 1]\nM99\n");
    assert_eq!(ends(&p), [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 3.0, 0.0]]);
    for (text, want) in [
        ("M98 L2\n", "t.ngc:1:1: M98 needs P"),
        ("M98 P5\nM30\n", "t.ngc:1:1: M98 P5: the program has no subprogram O5"),
        ("G1 X1 F100\nM99\n", "t.ngc:2:1: M99 outside a subprogram called with M98"),
        ("M98 P1 X1\n", "t.ngc:1:8: M98 stands in a block of its own"),
    ] {
        assert!(first_error(text).starts_with(want), "{text}: {}", first_error(text));
    }
}

#[test]
fn canned_cycles_expand_as_linuxcnc() {
    // G81 from Z10 with R2 (LinuxCNC's initial retract mode is G99): rapid over the hole, down
    // to R, feed to the bottom, rapid back to R; the next hole the same from R.
    let p = ok("G0 Z10\nF100\nG81 X5 Y5 Z-3 R2\nX10\nG98 G83 X20 Z-5 R2 Q2\nG80\nG0 X0\n");
    let kinds: Vec<char> = p.path.elements.iter().map(|e| if e.feed == Feed::Rapid { 'r' } else { 'f' }).collect();
    let text: String = kinds.iter().collect();
    assert_eq!(text, "rrrfrrfrrrfrrfrrfrrfrr", "{:?}", ends(&p));
    assert_eq!(ends(&p)[2], [5.0, 5.0, 2.0]);
    assert_eq!(ends(&p)[8], [20.0, 5.0, 10.0], "G98 goes back up to where the cycles started");
    assert!(p.path.elements.iter().all(|e| e.blend == crate::path::Blend::Exact));
    for (text, want) in [
        ("G81 X1 Z-1 F100\n", "t.ngc:1:1: G81 needs R"),
        ("G83 X1 Z-1 R1 F100\n", "t.ngc:1:1: G83 needs Q"),
        ("G82 X1 Z-1 R1 F100\n", "t.ngc:1:1: G82 needs P"),
        ("G81 X1 Z1 R-1 F100\n", "t.ngc:1:11: G81: the retract plane R lies below"),
        ("G81 X1 Z-1 R1 L0 F100\n", "t.ngc:1:15: G81: L (repeats) must be a positive integer"),
        ("G84 X1 Z-1 R1 F100\n", "t.ngc:1:1: G84 needs a spindle"),
        ("G33 X1 K1\n", "t.ngc:1:1: G33 needs a spindle"),
        // Found by the fuzzer: 2.5e10 pecks filled 24 GB before the check after the hole.
        ("G83 X10 Y10 Z-99999999912 R3 Q4 F100\n", "t.ngc:1:1: G83: the cycle makes more than"),
    ] {
        assert!(first_error(text).starts_with(want), "{text}: {}", first_error(text));
    }
}

#[test]
fn nurbs_runs_as_linuxcncs_chords_to_the_last_control_point() {
    // 5 control points (the start point counts): 75 steps of the parameter, the last control
    // point at the end; the current point moves only at G5.3.
    let p = ok("G0 X0 Y0 Z1\nF600\nG5.2 P1 L3\nX0 Y1 P1\nX2 Y2 P1\nX2 Y0 P1\nX0 Y0 P2\nG5.3\nG1 X3\n");
    let chords = p.path.elements.len() - 2;
    assert!((74..=75).contains(&chords), "{chords} chords");
    assert!(close(end_at(&p, chords), [0.0, 0.0, 1.0]));
    assert!(close(end(&p), [3.0, 0.0, 1.0]));
    // G91: control points relative to the start point (the current point does not move).
    let q = ok("G0 X1 Y1\nF600\nG91 G5.2 X1 Y0 P1\nX1 Y1 P1\nG5.3\n");
    assert!(close(end(&q), [2.0, 2.0, 0.0]));
}

#[test]
fn g5_cubics_chain_by_the_implicit_derivative() {
    // The second G5 without I J starts along minus the first one's P Q: a symmetric S.
    let p = ok("G0 X0 Y0\nF600\nG5 X10 Y0 I2 J5 P-2 Q5\nG5 X20 Y0 P-2 Q-5\nX30\n");
    assert!(close(end(&p), [30.0, 0.0, 0.0]));
    // G5 acts in its own block (LinuxCNC 2.9): the X30 after it is a G0.
    assert_eq!(p.path.elements.last().map(|e| e.feed), Some(Feed::Rapid));
    // The curve is a Bézier cubic: at the middle of the first one y = 3/4·5.
    let mid = end_at(&p, 29);
    assert!((mid[0] - 5.0).abs() < 1e-9 && (mid[1] - 3.75).abs() < 1e-9, "{mid:?}");
    assert!(first_error("F600\nG5 X1 Y1 I1\n").contains("G5: give both I and J"));
    assert!(first_error("F600\nG5 X1 Y1 I1 J1\n").contains("G5 needs both P and Q"));
    assert!(first_error("F600\nG18 G5.1 X1 Z1 I1 K1\n").contains("XY plane"));
    assert!(first_error("F600\nG5.2 X1 Y1 P1 Z3\n").contains("X and Y only"));
    assert!(first_error("F600\nG5.2 X1 P1\n").contains("needs both X and Y"));
    assert!(first_error("F600\nG5.2 X1 Y1\n").contains("positive weight P"));
    assert!(first_error("G5.2 X1 Y1 P1\n").contains("without feed"));
}

#[test]
fn polar_words_give_xy_about_the_program_origin() {
    // G90: radius and angle about the origin of the work system (G55 here, X10 Y0).
    let p = ok("G10 L2 P2 X10 Y0\nG55 G0 @2 ^90\nG1 ^180 F600\n@3\n");
    assert!(close(end_at(&p, 0), [10.0, 2.0, 0.0]));
    assert!(close(end_at(&p, 1), [8.0, 0.0, 0.0]));
    assert!(close(end(&p), [7.0, 0.0, 0.0]));
    // G91: added to the current point's radius and angle.
    let q = ok("G0 X1 Y0\nG91 G0 ^90\n@1\n");
    assert!(close(end(&q), [0.0, 2.0, 0.0]));
    // A bolt circle as LinuxCNC's hole-circle.ngc drills it: six holes 60° apart.
    let c = ok("G20 G0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\n");
    assert!(close(end(&c), [1.5 * 25.4, 0.0, 0.1 * 25.4]), "{:?}", end(&c));
    assert!(first_error("G0 X1 @2\n").contains("X and polar coordinates"));
    assert!(first_error("G18 G0 @2 ^3\n").contains("XY plane"));
    assert!(first_error("G0 @2\n").contains("need the angle"));
}

#[test]
fn m70_m72_and_m73_restore_the_modal_state() {
    // M70 … M72 around a subroutine that switches to G20 G91: the X10 after it is absolute mm.
    let p = ok("o<s> sub\nG20 G91 F5\nG1 X1\no<s> endsub\nG21 G90 F600\nM70\no<s> call\nM72\nG1 X10\n");
    assert!(close(end(&p), [10.0, 0.0, 0.0]));
    assert_eq!(p.path.elements.last().map(|e| e.feed), Some(Feed::Programmed { mm_per_s: 10.0 }));
    // M73 in the subroutine restores at its return.
    let q = ok("o<s> sub\nM73\nG20 G91\nG1 X1\no<s> endsub\nG21 G90 F600\no<s> call\nG1 X10\n");
    assert!(close(end(&q), [10.0, 0.0, 0.0]));
    assert!(first_error("M72\n").contains("M72 without a state saved"));
    // M71 forgets the state.
    assert!(first_error("M70\nM71\nM72\n").contains("M72 without"));
}

#[test]
fn a_negative_diameter_compensates_on_the_other_side() {
    let body = "G0 X-10 Y-5\nG1 X0 Y-5 F600\nX20\nY10\nG40 X30 Y20\n";
    let a = ok(&format!("G41.1 D-4\n{body}"));
    let b = ok(&format!("G42.1 D4\n{body}"));
    assert_eq!(a.path.elements.len(), b.path.elements.len());
    for i in 0..a.path.elements.len() {
        assert!(close(end_at(&a, i), end_at(&b, i)));
    }
    // M61 puts a tool in the spindle without a change: G43 without H uses it.
    let t = ok("M61 Q1\nG43\nG0 Z0\n");
    assert_eq!(t.summary.tools.iter().copied().collect::<Vec<_>>(), vec![1]);
}

#[test]
fn rotated_work_systems_as_linuxcnc() {
    // machine = R(program + G92) + origin (LinuxCNC's tests/interp/rotation and g10 tests).
    let s = 0.5f64.sqrt();
    // G54 at X3 Y7 turned 45°: X1 goes along the turned X; G91 moves turn too; G53 does not.
    let p = ok("G10 L2 P1 X3 Y7 R45\nG0 X1 Y0\nG91 Y1\nG90 G53 G0 X1 Y2\n");
    let want = [[3.0 + s, 7.0 + s, 0.0], [3.0, 7.0 + 2.0 * s, 0.0], [1.0, 2.0, 0.0]];
    for (i, w) in want.iter().enumerate() {
        assert!(close(end_at(&p, i), *w), "{:?} != {w:?}", end_at(&p, i));
    }
    // An arc's centre offset turns with the system: a quarter circle about the origin.
    let p = ok("G10 L2 P1 R90\nG0 X10\nG3 X0 Y10 I-10 F100\n");
    assert!(close(end(&p), [-10.0, 0.0, 0.0]), "{:?}", end(&p));
    assert!((p.path.elements[1].geometry.length_mm() - 5.0 * std::f64::consts::PI).abs() < 1e-9);
    // G92 applies before the rotation; #5420 reads the program coordinate back; #5230 the angle.
    let p = ok("G10 L2 P1 R90\nG0 X1\nG92 X0\nG0 X1 Y#5230\n");
    assert!(close(end(&p), [-90.0, 2.0, 0.0]), "{:?}", end(&p));
    // L20 in a rotated system: the current point gets the given program coordinate.
    // (Machine (-2, 1); program (1, 2) becomes (0, 2): the origin moves to (0, 1).)
    let p = ok("G10 L2 P1 R90\nG0 X1 Y2\nG10 L20 P1 X0\nG0 Y0\n");
    assert!(close(end(&p), [0.0, 1.0, 0.0]), "{:?}", end(&p));
    // The active system's rotation changes the mapping, not the machine position.
    let p = ok("G0 X1\nG10 L2 P1 R90\nG0 X#5420 Y#5421\n");
    assert!(close(end(&p), [1.0, 0.0, 0.0]) && p.path.elements.len() == 1, "{:?}", ends(&p));
    for (text, want) in [
        ("G10 L20 P1 R10\n", "t.ngc:1:12: G10: R is not allowed in G10 L20"),
        ("G10 L2 P1 R10\nG18 G2 X1 Z1 R1 F10\n", "t.ngc:2:1: an arc in G18 (ZX) in a rotated coordinate system"),
    ] {
        assert!(first_error(text).starts_with(want), "{text}: {}", first_error(text));
    }
}

#[test]
fn a_zero_length_move_after_g40_is_the_exit_move() {
    // LinuxCNC's nc_files/gmoccapy_2_tools_with_cutter_radius_compensation.ngc: G40, then a
    // move to the point the contour ended on: the tool leaves the offset all the same.
    let p = ok("G1 X0 Y0 F100\nG41.1 D2\nG1 X10\nG1 Y10\nG40\nG0 X10 Y10\nG0 Z5\n");
    let n = p.path.elements.len();
    assert!(close(end_at(&p, n - 2), [10.0, 10.0, 0.0]), "{:?}", ends(&p));
    assert!(close(end(&p), [10.0, 10.0, 5.0]));
    // Only the first block (to where the tool already is) is dropped.
    assert_eq!(p.summary.zero_length_moves, 1);
}

#[test]
fn m19_takes_r_as_its_angle_not_as_an_arc_radius() {
    // LinuxCNC's tests/interp/m19: R is the orientation angle, also under G2/G3.
    let p = ok("M19\nM19 R45 Q2\nM19 R90 P0\nF100 G2 X2 R1\nM19 R90 P1\n");
    assert!(close(end(&p), [2.0, 0.0, 0.0]));
}

#[test]
fn g61_1_is_exact_stop_as_g61() {
    // LinuxCNC's tests/interp/g6164.
    let a = ok("G64 P0.1\nG61.1\nG1 X1 F100\nY1\n");
    let b = ok("G64 P0.1\nG61\nG1 X1 F100\nY1\n");
    assert_eq!(a.path.elements[1].joint, b.path.elements[1].joint);
    assert_eq!(a.path.elements.len(), b.path.elements.len());
}

fn one_tool() -> Settings {
    let mut settings = xyz();
    settings.tools = vec![interpd_config::ToolConfig { number: 1, diameter_mm: 6.0, length_mm: 0.0, name: None }];
    settings
}

#[test]
fn g10_writes_tool_offsets_that_g43_applies_on_every_axis() {
    // As LinuxCNC 2.9 (its tests/interp/g10/g10-l1-l10): G10 L1 sets the offsets, G43 applies
    // X Y and Z; they stay applied until G43 or G49, whatever G10 writes meanwhile.
    let run = |text: &str| parse(text, "t.ngc", &one_tool()).unwrap_or_else(|e| panic!("{text}: {e}"));
    let p = run("G10 L1 P1 X1 Y2 Z3\nT1 M6 G43\nG0 X0 Y0 Z0\nG10 L1 P1 X5\nG0 X1\nG49\nG0 X0 Y0 Z0\n");
    assert_eq!(ends(&p), [[1.0, 2.0, 3.0], [2.0, 2.0, 3.0], [0.0, 0.0, 0.0]]);
    // L10: the offsets make the current point read the given coordinates with G43, here in
    // G55 with a G92 offset (both count).
    let p =
        run("G10 L2 P2 X10\nG55 G92 X0\nT1 M6 G0 X0.1 Y0.2 Z0.3\nG10 L10 P1 X1 Y2 Z3\nG43\nG0 X1 Y2 Z3\nG1 X0 F100\n");
    // The move to X1 Y2 Z3 stays where the tool stands (it is dropped).
    let e = ends(&p);
    assert!(e.len() == 2 && close(e[0], [0.1, 0.2, 0.3]) && close(e[1], [-0.9, 0.2, 0.3]), "{e:?}");
    // L11: in G59.3 (the touch-off fixture) without G92, whatever system is active.
    let p = run("G10 L2 P9 Z-27\nG53 G0 Z-30\nG92 Z5\nG10 L11 P1 Z0\nT1 M6 G43\nG92.1\nG0 Z0\n");
    assert!(close(*ends(&p).last().unwrap(), [0.0, 0.0, -3.0]), "{:?}", ends(&p));
    // In a rotated system the offset stays in the machine frame; L10 with X alone keeps the
    // part of the offset along the turned Y axis.
    let p = run("G10 L2 P1 R90\nG10 L1 P1 X1\nT1 M6 G43\nG0 X0 Y0\nG0 X1\n");
    let e = ends(&p);
    assert!(close(e[0], [1.0, 0.0, 0.0]) && close(e[1], [1.0, 1.0, 0.0]), "{e:?}");
    let p = run("G10 L2 P1 R45\nG0 X3\nG0 X0 Y0\nT1 M6\nG10 L10 P1 X1\nG10 L10 P1 Y1\nG43\nG0 X2 Y2\n");
    let last = *ends(&p).last().unwrap();
    let want = [0.0, std::f64::consts::SQRT_2, 0.0];
    assert!(last.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6), "{last:?}");
    // R sets the radius cutter compensation takes; #5401 … reads the loaded tool's offsets.
    let p = run("G10 L1 P1 R2\nT1 M6\nG41\nG1 X10 F100\n");
    assert!(close(end(&p), [10.0, 2.0, 0.0]), "{:?}", end(&p));
    let p = run("T1 M6\nG10 L1 P1 X1 Y2\n#1 = [#5401 * 10 + #5402]\nG0 X#1\n");
    assert!(close(end(&p), [12.0, 0.0, 0.0]));
}

/// The messages `check_text` hands out, as `(line, kind, text)`.
fn messages(text: &str) -> Vec<(u32, &'static str, String)> {
    let path = std::env::temp_dir().join(format!("interpd-msg-{}-{}.ngc", std::process::id(), text.len()));
    std::fs::write(&path, text).expect("write");
    let mut got = Vec::new();
    let r = super::check_with_messages(&path, &xyz(), &mut |m| got.push((m.line, m.kind.name(), m.text)));
    let _ = std::fs::remove_file(&path);
    r.unwrap_or_else(|e| panic!("program rejected:\n{e}"));
    got
}

#[test]
fn messages_are_formatted_when_their_block_executes() {
    let text = "#<i> = 0\n(MSG, Start: #<i> as written)\no1 while [#<i> LT 3]\n#<i> = [#<i> + 1]\n\
                G1 X#<i> F600 (debug, i=#<i> neg=#<neg>)\no1 endwhile\n#5599 = 0\n(DEBUG, hidden)\n\
                (print,%d#<i> of #<missing>)\nM2\n";
    let text = text.replace("#<neg>", "[0 - #<i> / 3]");
    // `[…]` is no parameter in a message: LinuxCNC writes it as it stands.
    let got = messages(&text);
    let want = [
        (2, "msg", " Start: #<i> as written".to_string()),
        (5, "debug", " i=1.000000 neg=[0 - 1.000000 / 3]".to_string()),
        (5, "debug", " i=2.000000 neg=[0 - 2.000000 / 3]".to_string()),
        (5, "debug", " i=3.000000 neg=[0 - 3.000000 / 3]".to_string()),
        (9, "print", "3 of ######".to_string()),
    ];
    assert_eq!(got, want);
    // A negative value, and a bad reference is a positioned error.
    assert_eq!(messages("#1 = -2.5\n(DEBUG,#1)\nM2\n"), [(2, "debug", "-2.500000".to_string())]);
    assert_eq!(
        first_error("G1 X1 F600\n(DEBUG, #<open)\nM2\n"),
        "t.ngc:2:2: (DEBUG, …): named parameter '#<' is not closed with '>'"
    );
}

#[test]
fn messages_wait_for_the_motion_before_them_as_pauses() {
    use crate::path::{Pause, StopCode};
    // Line 2: a message after the first move; line 3: its move comes after it; line 4: a
    // message and a stop in one block (the message first); line 5: a message after the stop.
    let p = ok("G1 X10 F600\n(MSG,a)\nG1 X20 (MSG,b)\nM0 (MSG,c)\n(MSG,d)\nG1 X30\n(MSG,end)\nM2\n");
    let pauses: Vec<Option<Pause>> = p.path.elements.iter().map(|e| e.pause_before).collect();
    assert_eq!(
        pauses,
        [
            None,
            Some(Pause { messages_before: 2, ..Pause::default() }),
            Some(Pause { messages_before: 3, stop: Some(StopCode::Stop), stop_line: 4, messages_after: 4 }),
        ]
    );
    assert!(p.path.elements[1].stops_before());
    // The last one follows the last motion: it belongs to the program's end.
    assert_eq!(p.summary.messages, 5);
}

#[test]
fn a_loop_of_messages_without_motion_keeps_the_first_and_the_newest() {
    let got = {
        let path = std::env::temp_dir().join(format!("interpd-msg-loop-{}.ngc", std::process::id()));
        std::fs::write(
            &path,
            "G1 X1 F600\no1 while [#1 LT 100000]\n#1 = [#1 + 1]\n(DEBUG,%d#1)\no1 endwhile\nG1 X2\nM2\n",
        )
        .unwrap();
        let mut got = Vec::new();
        super::check_with_messages(&path, &xyz(), &mut |m| got.push(m)).unwrap();
        let _ = std::fs::remove_file(&path);
        got
    };
    let cap = super::message::PLACE_CAP;
    assert_eq!(got.len(), cap + 1);
    assert_eq!(got[cap - 1].text, cap.to_string());
    let last = got.last().unwrap();
    assert_eq!((last.text.as_str(), last.dropped), ("100000", 100_000 - cap as u64 - 1));
    assert!(got.windows(2).all(|w| w[0].id < w[1].id));
}
