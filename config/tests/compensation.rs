//! `[compensation]` is validated against the machine and the measurements it names: a strategy
//! on an axis without the measurement it needs is an error naming the key.

use interpd_config::Config;
use interpd_config::compensation::Strategy;

const MACHINE: &str = include_str!("../machines/xyz.toml");

fn load(extra: &str) -> Result<Config, String> {
    Config::from_toml_str(&format!("{MACHINE}\n{extra}"), "m.toml").map_err(|e| e.to_string())
}

#[test]
fn a_strategy_needs_its_measurement() {
    let e = load("[compensation]\n[[compensation.axis]]\nname = \"X\"\nstrategy = \"position\"\n").unwrap_err();
    assert!(e.contains("compensation.axis[0].strategy") && e.contains("position_axes"), "{e}");
    let e = load(
        "[compensation]\n[compensation.measurement]\nposition_axes = [\"X\"]\n[[compensation.axis]]\nname = \
         \"X\"\nstrategy = \"position+actuator\"\n",
    )
    .unwrap_err();
    assert!(e.contains("compensation.axis[0].strategy") && e.contains("actuator_axes"), "{e}");
    let e = load(
        "[compensation]\n[compensation.measurement]\nposition_axes = [\"X\"]\n[[compensation.axis]]\nname = \
         \"Y\"\nstrategy = \"deflection\"\nstiffness_pos_n_per_mm = 545.0\nstiffness_neg_n_per_mm = 545.0\n",
    )
    .unwrap_err();
    assert!(e.contains("compensation.axis[0].strategy") && e.contains("force_axes"), "{e}");
}

#[test]
fn bad_values_name_their_key() {
    let base = "[compensation]\n[compensation.measurement]\nforce_axes = [\"X\"]\n[[compensation.axis]]\nname = \"X\"\n\
                strategy = \"deflection\"\n";
    let e = load(&format!("{base}stiffness_pos_n_per_mm = 0.0\nstiffness_neg_n_per_mm = 545.0\n")).unwrap_err();
    assert!(e.contains("compensation.axis[0].stiffness_pos_n_per_mm"), "{e}");
    let e = load(&format!("{base}stiffness_pos_n_per_mm = 545.0\nstiffness_neg_n_per_mm = nan\n")).unwrap_err();
    assert!(e.contains("stiffness_neg_n_per_mm"), "{e}");
    let e = load("[compensation]\nmax_age_ms = 0.0\n").unwrap_err();
    assert!(e.contains("compensation.max_age_ms"), "{e}");
    let e = load("[compensation]\n[[compensation.axis]]\nname = \"Q\"\n").unwrap_err();
    assert!(e.contains("compensation.axis"), "{e}");
    let e = load("[compensation]\n[compensation.measurement]\nforce_axes = [\"A\"]\n").unwrap_err();
    assert!(e.contains("compensation.measurement.force_axes") && e.contains("no axis A"), "{e}");
    let e = load("[compensation]\nbogus = 1\n").unwrap_err();
    assert!(e.contains("bogus"), "{e}");
}

#[test]
fn a_valid_section_reads() {
    let c = load(
        "[compensation]\n[compensation.measurement]\nforce_axes = [\"X\"]\nposition_axes = [\"Y\"]\n\
         [[compensation.axis]]\nname = \"X\"\nstrategy = \"deflection\"\nstiffness_pos_n_per_mm = 545.0\n\
         stiffness_neg_n_per_mm = 1580.0\ngap_mm = 0.228\n[[compensation.axis]]\nname = \"Y\"\nstrategy = \
         \"position\"\n",
    )
    .expect("valid");
    let comp = c.compensation.expect("section");
    assert!(comp.active() && !comp.uses_actuator());
    assert_eq!(comp.axis[1].strategy, Strategy::Position);
}
