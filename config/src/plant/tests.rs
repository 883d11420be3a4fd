use super::*;
use crate::Config;

fn machine(plant: &str) -> String {
    format!(
        "[machine]\n{plant}\n[[axis]]\nname = \"X\"\nkind = \"linear\"\nmax_vel = 100.0\nmax_acc = 1000.0\n\
         max_jerk = 10000.0\nmin = -10.0\nmax = 10.0\n[[axis]]\nname = \"A\"\nkind = \"rotary\"\n\
         max_vel = 100.0\nmax_acc = 1000.0\nmax_jerk = 10000.0\nmin = -10.0\nmax = 10.0\n"
    )
}

fn parse(plant: &str) -> Result<Config, ConfigError> {
    Config::from_toml_str(&machine(plant), "m.toml")
}

#[test]
fn presets_parse_and_resolve() {
    for (name, text) in PRESETS {
        let file = PresetFile::parse(text, name).unwrap_or_else(|e| panic!("preset {name}: {e}"));
        assert!(!file.params.contains_key("name") && !file.params.contains_key("preset"), "{name}");
        // Every key the preset sets belongs to its model and kind.
        let allowed = file.param_set().unwrap().keys();
        for k in file.params.keys() {
            assert!(allowed.contains(&k.as_str()), "preset {name} sets foreign key {k}");
        }
        let (letter, kind) = match file.kind {
            AxisKind::Linear => ("X", "linear"),
            AxisKind::Rotary => ("A", "rotary"),
        };
        let text = format!(
            "[machine]\n[plant]\npreset = \"{name}\"\nrotary_preset = \"{name}\"\n[[axis]]\nname = \"{letter}\"\n\
             kind = \"{kind}\"\nmax_vel = 1.0\nmax_acc = 1.0\nmax_jerk = 1.0\nmin = -1.0\nmax = 1.0\n"
        );
        let c = Config::from_toml_str(&text, "m.toml").unwrap_or_else(|e| panic!("preset {name}: {e}"));
        let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
        assert_eq!(r[0].preset, name);
    }
}

#[test]
fn select_takes_a_preset_a_preset_file_or_a_plant_section() {
    let c = parse("").unwrap();
    let same = c.plant.select("", &c.axes, "--plant").unwrap();
    assert_eq!(same, c.plant);
    let soft = c.plant.select("schneider-soft", &c.axes, "--plant").unwrap();
    assert_eq!(soft.resolve(&c.axes, "m").unwrap()[0].preset, "schneider-soft");
    let e = c.plant.select("nope", &c.axes, "--plant").unwrap_err().to_string();
    assert!(e.contains("--plant: nope: neither a plant preset"), "{e}");

    let dir = std::env::temp_dir().join(format!("interpd-config-select-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A preset file: the embedded soft preset with a different load mass.
    let preset_path = dir.join("heavy.toml");
    let text = PRESETS[0].1.replace("load_mass_kg = 381.0", "load_mass_kg = 500.0");
    std::fs::write(&preset_path, text).unwrap();
    let p = preset_path.to_str().unwrap();
    let heavy = c.plant.select(p, &c.axes, "--plant").unwrap();
    let r = heavy.resolve(&c.axes, "m").unwrap();
    let PlantModel::TwoMass(m) = r[0].model else { panic!("two-mass") };
    assert_eq!((r[0].preset.as_str(), m.load_mass), (p, 500.0));
    assert_eq!(r[1].preset, DEFAULT_ROTARY_PRESET, "rotary axes keep theirs");
    // A bad key in a preset file names the file and key.
    std::fs::write(&preset_path, PRESETS[0].1.replace("load_mass_kg", "m1_kg")).unwrap();
    let e = c.plant.select(p, &c.axes, "--plant").unwrap_err().to_string();
    assert!(e.contains("heavy.toml: params.m1_kg: not a parameter of the two-mass model"), "{e}");
    // A file with a [plant] section replaces the section.
    let section = dir.join("plant.toml");
    std::fs::write(&section, "[machine]\n[plant]\npreset = \"schneider-stiff\"\nservo_rate_hz = 20000.0\n").unwrap();
    let s = c.plant.select(section.to_str().unwrap(), &c.axes, "--plant").unwrap();
    assert_eq!((s.preset.as_deref(), s.servo_rate_hz), (Some("schneider-stiff"), 20000.0));
    std::fs::write(&section, "[plant]\nservo_rate_hz = 5.0\n").unwrap();
    let e = c.plant.select(section.to_str().unwrap(), &c.axes, "--plant").unwrap_err().to_string();
    assert!(e.contains("plant.toml: plant.servo_rate_hz"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn defaults_resolve_per_kind() {
    let c = parse("").unwrap();
    let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
    assert_eq!(r[0].preset, DEFAULT_LINEAR_PRESET);
    assert_eq!(r[1].preset, DEFAULT_ROTARY_PRESET);
    assert!(matches!(r[0].model, PlantModel::ThreeMass(_)));
    let PlantModel::TwoMass(j) = r[1].model else { panic!("joint preset is two-mass") };
    assert_eq!(j.stiffness_pos, 1.23e6);
    assert_eq!(j.stiffness_neg, 3.60e6);
    // Crosstalk of X goes to Y and Z, which this machine lacks.
    let PlantModel::ThreeMass(h) = &r[0].model else { unreachable!() };
    assert_eq!(h.crosstalk_targets, [None, None]);
    assert_eq!(c.plant.servo_rate_hz, 10_000.0);
}

#[test]
fn overrides_apply_and_name_their_key() {
    let c = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nbacklash_m = 0.0\nprocess_force_n = 300.0\n")
        .unwrap();
    let r = c.plant.resolve(&c.axes, "m.toml").unwrap();
    let PlantModel::TwoMass(p) = r[0].model else { panic!() };
    assert_eq!(p.backlash, 0.0);
    assert_eq!(p.stiffness_pos, 0.545e6);
    assert_eq!(r[0].process.static_force, 300.0);

    let e = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nstiffness_n_per_m = -1.0\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("plant.axis[0].stiffness_n_per_m"), "{e}");
    let e = parse("[[plant.axis]]\nname = \"A\"\nbacklash_m = 0.001\n").unwrap_err().to_string();
    assert!(e.contains("plant.axis[0].backlash_m: not a parameter of the two-mass model on a rotary axis"), "{e}");
    let e = parse("[[plant.axis]]\nname = \"X\"\nbacklash_m = 0.001\n").unwrap_err().to_string();
    assert!(e.contains("three-mass"), "{e}");
    let e = parse("[[plant.axis]]\nname = \"Y\"\n").unwrap_err().to_string();
    assert!(e.contains("plant.axis[0].name: no axis Y"), "{e}");
    let e = parse("[plant]\npreset = \"nope\"\n").unwrap_err().to_string();
    assert!(e.contains("plant.preset: unknown preset `nope`"), "{e}");
    let e = parse("[plant]\npreset = \"schneider-joint1\"\n").unwrap_err().to_string();
    assert!(e.contains("is for rotary axes but axis X is linear"), "{e}");
    let e = parse("[plant]\nservo_rate_hz = 1000.0\n").unwrap_err().to_string();
    assert!(e.contains("plant.servo_rate_hz"), "{e}");
    let e = parse("[plant]\nspeed = 1\n").unwrap_err().to_string();
    assert!(e.contains("unknown field `speed`"), "{e}");
    let e =
        parse("[[plant.axis]]\nname = \"X\"\nk2_n_per_m = 2e6\ncrosstalk_targets = [\"X\"]\n").unwrap_err().to_string();
    assert!(e.contains("cannot cross-talk into itself"), "{e}");
    let e = parse("[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nbacklash_blend_m = 0.001\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("plant.axis[0].backlash_blend_m: must not exceed half the backlash"), "{e}");
}

#[test]
fn every_parameter_key_names_itself_in_errors() {
    // The machine has X (haas-laser, three-mass) and A (schneider-joint1, rotary two-mass).
    let sets = [("X", "schneider-soft", ParamSet::LinearTwoMass), ("X", "haas-laser", ParamSet::ThreeMass)];
    let sets = sets.into_iter().chain([("A", "schneider-joint1", ParamSet::RotaryTwoMass)]);
    for (axis, preset, set) in sets {
        let keys = set.keys();
        assert!(keys.len() >= 20, "{set:?}: {keys:?}");
        for key in keys {
            let e = parse(&format!("[[plant.axis]]\nname = \"{axis}\"\npreset = \"{preset}\"\n{key} = nan\n"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(&format!("m.toml: plant.axis[0].{key}: must ")), "{set:?} {key}: {e}");
        }
    }
}

#[test]
fn a_preset_file_holds_the_keys_of_its_model_and_kind() {
    let soft = PRESETS[0].1;
    let e = PresetFile::parse(&soft.replace("kind = \"linear\"", "kind = \"rotary\""), "p.toml").unwrap_err();
    assert!(
        e.to_string()
            .contains("p.toml: params.backlash_blend_m: not a parameter of the two-mass model on a rotary axis"),
        "{e}"
    );
    let haas = PRESETS[3].1;
    let e = PresetFile::parse(&haas.replace("kind = \"linear\"", "kind = \"rotary\""), "p.toml").unwrap_err();
    assert!(e.to_string().contains("p.toml: model: the three-mass model is for linear axes only"), "{e}");
    let e = PresetFile::parse(&soft.replace("kv_per_s = 20.0", ""), "p.toml").unwrap_err();
    assert!(e.to_string().contains("p.toml: params: missing field `kv_per_s`"), "{e}");
    let e = PresetFile::parse(&soft.replace("tn_s = 0.01", "tn_s = \"fast\""), "p.toml").unwrap_err();
    assert!(e.to_string().contains("in [params]: invalid type: string \"fast\", expected f64 (key `tn_s`)"), "{e}");
}
