//! `config/example.toml`, the commented example shipped with the systemd unit, parses and
//! validates (with its optional `#? ` keys left out and put in) and names every key of every
//! section, so it cannot go out of date when the schema changes.

use interpd_config::plant::PlantConfig;
use interpd_config::sinks::SinksConfig;
use interpd_config::{
    AxisConfig, Config, ControlConfig, MachineSection, PlannerConfig, PrepConfig, ProgramsConfig, RtConfig, ToolConfig,
    WorkOffsetsConfig,
};
use serde::de::DeserializeOwned;
use std::collections::BTreeSet;

const EXAMPLE: &str = include_str!("../example.toml");
const ORIGIN: &str = "config/example.toml";
/// Marks an optional key that is unset by default.
const OPTIONAL_MARK: &str = "#? ";

/// The example with its optional keys put in.
fn with_optional_keys() -> String {
    EXAMPLE.lines().map(|l| l.strip_prefix(OPTIONAL_MARK).unwrap_or(l)).collect::<Vec<_>>().join("\n")
}

fn parse(text: &str) -> Config {
    Config::from_toml_str(text, ORIGIN).unwrap_or_else(|e| panic!("{e}"))
}

/// The TOML keys of a configuration struct.
fn keys_of<T: DeserializeOwned>() -> BTreeSet<&'static str> {
    let fields = interpd_config::keys_of::<T>();
    assert!(!fields.is_empty(), "{} has no fields", std::any::type_name::<T>());
    fields.iter().copied().collect()
}

fn keys_in(table: &toml::Table) -> BTreeSet<&str> {
    table.keys().map(String::as_str).collect()
}

#[test]
fn the_example_parses_and_validates_with_and_without_its_optional_keys() {
    let plain = parse(EXAMPLE);
    assert_eq!(plain.axis_names(), ["X", "Y", "Z", "A", "B"]);
    assert_eq!(plain.control.socket.as_deref(), Some("/run/interpd/interpd.sock"));
    assert_eq!(plain.programs.dir.as_deref(), Some("/var/lib/interpd/programs"));
    assert_eq!((plain.rt.cpu, plain.planner.lookahead_samples, plain.planner.rapid_feed_mm_s), (None, None, None));
    // Every section's values are the defaults the comments claim ("Defaults shown").
    assert_eq!(plain.planner, PlannerConfig::default());
    assert_eq!(plain.prep, PrepConfig::default());
    assert_eq!(plain.sinks, SinksConfig::default());
    assert_eq!(plain.rt, RtConfig::default());
    let full = parse(&with_optional_keys());
    assert!(
        full.rt.cpu.is_some() && full.planner.lookahead_samples.is_some() && full.planner.rapid_feed_mm_s.is_some()
    );
    let plants = full.plant.resolve(&full.axes, ORIGIN).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(plants.len(), full.axes.len());
}

#[test]
fn the_example_names_every_key_of_every_section() {
    let table: toml::Table = toml::from_str(&with_optional_keys()).expect("TOML");
    let same = |what: &str, got: BTreeSet<&str>, want: BTreeSet<&'static str>| {
        assert_eq!(got, want, "{ORIGIN}: keys of {what} differ from the schema (left: the file)");
    };
    same("the top level", keys_in(&table), keys_of::<Config>());
    let section = |name: &str| table[name].as_table().unwrap_or_else(|| panic!("[{name}] is not a table"));
    same("[machine]", keys_in(section("machine")), keys_of::<MachineSection>());
    same("[planner]", keys_in(section("planner")), keys_of::<PlannerConfig>());
    same("[prep]", keys_in(section("prep")), keys_of::<PrepConfig>());
    same("[sinks]", keys_in(section("sinks")), keys_of::<SinksConfig>());
    same("[control]", keys_in(section("control")), keys_of::<ControlConfig>());
    same("[programs]", keys_in(section("programs")), keys_of::<ProgramsConfig>());
    same("[rt]", keys_in(section("rt")), keys_of::<RtConfig>());
    same("[plant]", keys_in(section("plant")), keys_of::<PlantConfig>());
    same("[work_offsets]", keys_in(section("work_offsets")), keys_of::<WorkOffsetsConfig>());
    for (i, tool) in table["tool"].as_array().expect("[[tool]] tables").iter().enumerate() {
        if i == 0 {
            same(&format!("tool[{i}]"), keys_in(tool.as_table().expect("table")), keys_of::<ToolConfig>());
        }
    }
    for (i, axis) in table["axis"].as_array().expect("[[axis]] tables").iter().enumerate() {
        same(&format!("axis[{i}]"), keys_in(axis.as_table().expect("table")), keys_of::<AxisConfig>());
    }
}
