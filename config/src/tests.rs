use super::*;

const AXIS_X: &str = r#"
[[axis]]
name = "X"
kind = "linear"
max_vel = 100.0
max_acc = 1000.0
max_jerk = 10000.0
min = -10.0
max = 10.0
"#;

fn parse(text: &str) -> Result<Config, ConfigError> {
    Config::from_toml_str(text, "m.toml")
}

fn err_text(text: &str) -> String {
    parse(text).expect_err("configuration must be rejected").to_string()
}

#[test]
fn embedded_machines_are_valid() {
    let c = Config::default_machine();
    assert_eq!(c.axis_names(), ["X", "Y", "Z"]);
    assert_eq!(c.machine.cycle_ms, 4.0);
    let c5 = Config::five_axis_machine();
    assert_eq!(c5.axis_names(), ["X", "Y", "Z", "A", "B"]);
    assert_eq!(c5.axes[3].kind, AxisKind::Rotary);
}

#[test]
fn cycle_defaults_to_4_ms() {
    let c = parse(&format!("[machine]\n{AXIS_X}")).unwrap();
    assert_eq!(c.machine.cycle_ms, 4.0);
    assert_eq!(c.planner, PlannerConfig::default());
}

#[test]
fn unknown_key_is_named_with_position() {
    let e = err_text(&format!("[machine]\ncycle_ms = 4.0\nspeed = 3\n{AXIS_X}"));
    assert!(e.starts_with("m.toml:3:1:"), "{e}");
    assert!(e.contains("unknown field `speed`"), "{e}");
    assert!(e.contains("[machine]"), "{e}");
}

#[test]
fn unknown_key_in_axis_names_the_axis() {
    let e = err_text(&format!("[machine]\n{AXIS_X}\n[[axis]]\nname = \"Y\"\nvelocity = 3\n"));
    assert!(e.contains("unknown field `velocity`"), "{e}");
    assert!(e.contains("axis[1]"), "{e}");
}

#[test]
fn missing_key_is_named() {
    let text = AXIS_X.replace("max_jerk = 10000.0\n", "");
    let e = err_text(&format!("[machine]\n{text}"));
    assert!(e.contains("missing field `max_jerk`"), "{e}");
    assert!(e.starts_with("m.toml:"), "{e}");
}

#[test]
fn missing_machine_section() {
    let e = err_text(AXIS_X);
    assert!(e.contains("missing field `machine`"), "{e}");
}

#[test]
fn non_positive_and_non_finite_limits() {
    for (from, to, key) in [
        ("max_vel = 100.0", "max_vel = 0.0", "axis[0].max_vel (X)"),
        ("max_acc = 1000.0", "max_acc = -5.0", "axis[0].max_acc (X)"),
        ("max_jerk = 10000.0", "max_jerk = nan", "axis[0].max_jerk (X)"),
        ("max_vel = 100.0", "max_vel = inf", "axis[0].max_vel (X)"),
        ("min = -10.0", "min = -inf", "axis[0].min (X)"),
    ] {
        let e = err_text(&format!("[machine]\n{}", AXIS_X.replace(from, to)));
        assert_eq!(e.split(": ").nth(1), Some(key), "{e}");
    }
}

#[test]
fn duplicate_axis_names() {
    let e = err_text(&format!("[machine]\n{AXIS_X}{AXIS_X}"));
    assert!(e.contains("axis[1].name"), "{e}");
    assert!(e.contains("duplicate axis name X"), "{e}");
}

#[test]
fn min_not_below_max() {
    let e = err_text(&format!("[machine]\n{}", AXIS_X.replace("min = -10.0", "min = 10.0")));
    assert!(e.contains("axis[0].min (X): min (10) must be less than max (10)"), "{e}");
}

#[test]
fn bad_axis_letter_and_kind() {
    let e = err_text(&format!("[machine]\n{}", AXIS_X.replace("\"X\"", "\"Q\"")));
    assert!(e.contains("unknown variant `Q`"), "{e}");
    let e = err_text(&format!("[machine]\n{}", AXIS_X.replace("\"linear\"", "\"swivel\"")));
    assert!(e.contains("unknown variant `swivel`"), "{e}");
}

#[test]
fn cycle_out_of_range() {
    let e = err_text(&format!("[machine]\ncycle_ms = 0\n{AXIS_X}"));
    assert!(e.contains("machine.cycle_ms"), "{e}");
}

#[test]
fn planner_section_validated() {
    let e = err_text(&format!("[machine]\n[planner]\nlimit_fraction = 1.5\n{AXIS_X}"));
    assert!(e.contains("planner.limit_fraction"), "{e}");
    let e = err_text(&format!("[machine]\n[planner]\nlookahead = 3\n{AXIS_X}"));
    assert!(e.contains("unknown field `lookahead`"), "{e}");
}

#[test]
fn syntax_error_names_the_key() {
    let e = err_text(&format!("[machine]\n{}", AXIS_X.replace("max_vel = 100.0", "max_vel = NaN")));
    assert!(e.starts_with("m.toml:6:11:"), "{e}");
    assert!(e.contains("key `max_vel`"), "{e}");
}

#[test]
fn io_error_names_file() {
    let e = Config::load(std::path::Path::new("/nonexistent/m.toml")).unwrap_err().to_string();
    assert!(e.starts_with("/nonexistent/m.toml: cannot read configuration"), "{e}");
}

proptest::proptest! {
    /// Arbitrary text never panics the loader.
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,300}") {
        let _ = parse(&text);
    }

    /// Valid limits round-trip; invalid ones are rejected with the key named.
    #[test]
    fn limit_validation(vel in proptest::num::f64::ANY) {
        let toml_value = if vel.is_nan() { "nan".to_string() } else if vel.is_infinite() { (if vel > 0.0 { "inf" } else { "-inf" }).to_string() } else { format!("{vel:?}") };
        let r = parse(&format!("[machine]\n{}", AXIS_X.replace("max_vel = 100.0", &format!("max_vel = {toml_value}"))));
        if vel.is_finite() && vel > 0.0 {
            proptest::prop_assert!(r.is_ok());
        } else {
            let e = r.unwrap_err().to_string();
            proptest::prop_assert!(e.contains("max_vel"), "{}", e);
        }
    }
}

#[test]
fn can_section_defaults_and_keys() {
    let c = parse(&format!("[machine]\n{AXIS_X}")).unwrap();
    assert!(!c.sinks.can.enabled());
    assert_eq!(c.sinks.can.node_ids(1), [1]);
    assert_eq!(c.sinks.can.scales(1), [sinks::DEFAULT_INCREMENTS_PER_UNIT]);
    let text = format!(
        "[machine]\n{AXIS_X}\n[sinks.can]\ninterface = \"vcan0\"\nnodes = [5]\nincrements_per_unit = [-4096.0]\n"
    );
    let c = parse(&text).unwrap();
    assert!(c.sinks.can.enabled());
    assert_eq!((c.sinks.can.node_ids(1), c.sinks.can.scales(1)), (vec![5], vec![-4096.0]));
}

#[test]
fn can_section_errors_name_the_key() {
    let two = format!("{AXIS_X}\n{}", AXIS_X.replace("\"X\"", "\"Y\""));
    let cases = [
        ("nodes = [1]", "sinks.can.nodes", "one node-ID per axis (2)"),
        ("nodes = [1, 0]", "sinks.can.nodes[1]", "1..=127"),
        ("nodes = [1, 128]", "sinks.can.nodes[1]", "1..=127"),
        ("nodes = [3, 3]", "sinks.can.nodes[1]", "used twice"),
        ("increments_per_unit = [1.0]", "sinks.can.increments_per_unit", "one value per axis"),
        ("increments_per_unit = [1.0, 0.0]", "sinks.can.increments_per_unit[1]", "non-zero"),
        ("increments_per_unit = [1.0, 3e8]", "sinks.can.increments_per_unit[1]", "i32 range"),
        ("interface = \"a/b\"", "sinks.can.interface", "does not allow"),
        ("interface = \"sixteen_chars_xx\"", "sinks.can.interface", "1 to 15"),
        ("heartbeat_timeout_ms = 1.0", "sinks.can.heartbeat_timeout_ms", "[10, 60000]"),
        ("boot_timeout_ms = -1.0", "sinks.can.boot_timeout_ms", "[0, 60000]"),
        ("enable_window_increments = 0", "sinks.can.enable_window_increments", "at least 1"),
        ("tx_fail_cycles = 0", "sinks.can.tx_fail_cycles", "1..=1000"),
        ("heartbeat_producer_ms = 0", "sinks.can.heartbeat_producer_ms", "1..=65535"),
        ("heartbeat_producer_ms = 500", "sinks.can.heartbeat_producer_ms", "not below heartbeat_timeout_ms"),
        ("sdo_timeout_ms = 0.0", "sinks.can.sdo_timeout_ms", "[1, 60000]"),
        ("node.7 = { vendor_id = 1 }", "sinks.can.node.7", "not the node-ID of a configured axis"),
        ("home_order = [\"Q\"]", "sinks.can.home_order[0]", "is not an axis"),
        ("home_order = [\"X\", \"X\"]", "sinks.can.home_order[1]", "named twice"),
        ("homing_timeout_ms = 10.0", "sinks.can.homing_timeout_ms", "[100, 3600000]"),
        ("node.2 = { homing = { speed_zero = 0.0 } }", "sinks.can.node.2.homing.speed_zero", "positive"),
        ("node.2 = { homing = { offset = 1e6 } }", "sinks.can.node.2.homing.offset", "i32 range"),
        ("node.1 = { sim_index_pitch = -1.0 }", "sinks.can.node.1.sim_index_pitch", "positive"),
    ];
    for (line, key, what) in cases {
        let e = err_text(&format!("[machine]\n{two}\n[sinks.can]\n{line}\n"));
        assert!(e.contains(key) && e.contains(what), "{line}: {e}");
    }
    let e = err_text(&format!("[machine]\n{AXIS_X}\n[sinks.can]\nnodes = [1]\n[sinks.can.node.1]\nvendor = 1\n"));
    assert!(e.contains("unknown field `vendor`") && e.contains("sinks.can"), "{e}");
    let ok = parse(&format!("[machine]\n{AXIS_X}\n[sinks.can.node.1]\nproduct_code = 0x1234\n")).unwrap();
    assert_eq!(ok.sinks.can.node_config(1).product_code, Some(0x1234));
    assert_eq!(ok.sinks.can.node_config(2), Default::default());
    let two_axes = format!("{AXIS_X}\n{}", AXIS_X.replace("\"X\"", "\"Y\""));
    let homing = parse(&format!(
        "[machine]\n{two_axes}\n[sinks.can]\nhome_order = [\"Y\"]\nrequire_homing = true\n[sinks.can.node.2]\n\
         homing = {{ method = 3, speed_switch = 20.0, offset = -2.0 }}\nsim_home_switch = 12.5\n"
    ))
    .unwrap();
    assert_eq!(homing.sinks.can.home_axes(&homing.axes), [1]);
    assert!(homing.sinks.can.require_homing);
    let h = homing.sinks.can.node_config(2).homing;
    assert_eq!((h.method, h.speed_switch, h.speed_zero, h.offset), (3, 20.0, 1.0, -2.0));
    assert_eq!(homing.sinks.can.node_config(2).sim_home_switch, Some(12.5));
    assert_eq!(ok.sinks.can.home_axes(&ok.axes), [0], "default: every axis in [[axis]] order");
}

#[test]
fn tool_table_and_work_offsets_are_checked_by_key() {
    let base = format!("[machine]\n{AXIS_X}");
    let ok = parse(&format!(
        "{base}\n[[tool]]\nnumber = 3\ndiameter = 6.0\nlength = 40.0\n[work_offsets]\nG55 = {{ X = 2.5 }}\n\"G59.2\" = {{ X = -1.0 }}\nrotation = {{ \"G59.2\" = 30.0 }}\n"
    ))
    .unwrap();
    assert_eq!((ok.tools[0].number, ok.tools[0].diameter_mm, ok.tools[0].length_mm), (3, 6.0, 40.0));
    assert_eq!(ok.work_offsets.vector(1, &ok.axes)[0], 2.5);
    assert_eq!(ok.work_offsets.vector(0, &ok.axes)[0], 0.0);
    assert_eq!((ok.work_offsets.vector(7, &ok.axes)[0], ok.work_offsets.rotation(7)), (-1.0, 30.0));
    assert_eq!(ok.work_offsets.rotation(1), 0.0);
    for (extra, key) in [
        ("[[tool]]\nnumber = 1\ndiameter = -1.0\n", "tool[0].diameter"),
        ("[[tool]]\nnumber = 1\ndiameter = 1.0\n[[tool]]\nnumber = 1\ndiameter = 2.0\n", "tool[1].number"),
        ("[[tool]]\nnumber = 100000\ndiameter = 1.0\n", "tool[0].number"),
        ("[work_offsets]\nG54 = { Y = 1.0 }\n", "work_offsets.G54.Y"),
        ("[work_offsets]\nG54 = { X = nan }\n", "work_offsets.G54.X"),
        ("[work_offsets]\nrotation = { G60 = 1.0 }\n", "work_offsets.rotation.G60"),
        ("[work_offsets]\nrotation = { G54 = inf }\n", "work_offsets.rotation.G54"),
    ] {
        let e = err_text(&format!("{base}\n{extra}"));
        assert!(e.contains(key), "{extra}: {e}");
    }
    let e = err_text(&format!("{base}\n[work_offsets]\nG60 = {{ X = 1.0 }}\n"));
    assert!(e.contains("G60"), "{e}");
}

#[test]
fn check_and_plan_read_subroutines_beside_the_program_unless_a_dir_is_configured() {
    let mut p = ProgramsConfig::default();
    p.default_to_dir_of(std::path::Path::new("/data/jobs/part.ngc"));
    assert_eq!(p.base_dir(), std::path::PathBuf::from("/data/jobs"));
    let mut p = ProgramsConfig::default();
    p.default_to_dir_of(std::path::Path::new("part.ngc"));
    assert_eq!(p.base_dir(), std::path::PathBuf::from("."));
    let mut p = ProgramsConfig { dir: Some("/srv/programs".into()), ..ProgramsConfig::default() };
    p.default_to_dir_of(std::path::Path::new("/data/jobs/part.ngc"));
    assert_eq!(p.base_dir(), std::path::PathBuf::from("/srv/programs"), "a configured dir stays");
}
