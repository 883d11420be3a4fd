//! Every embedded plant preset and every override key resolves to pinned values: the resolved
//! per-axis parameters are what sim-plant simulates, so a change to the configuration code must
//! not move them. The expected values are the presets' numbers (`config/plants/*.toml`) and
//! the overrides below, in SI base units of the axis.

use interpd_config::plant::{
    DriveParams, PlantModel, ProcessParams, ResolvedAxisPlant, ThreeMassParams, TwoMassParams,
};
use interpd_config::{AxisKind, AxisLetter, Config};

/// A machine with three linear axes X Y Z and two rotary axes A B, and `plant` in front.
fn resolve(plant: &str) -> Vec<ResolvedAxisPlant> {
    let axis = |name: &str, kind: &str| {
        format!(
            "[[axis]]\nname = \"{name}\"\nkind = \"{kind}\"\nmax_vel = 1.0\nmax_acc = 1.0\nmax_jerk = 1.0\n\
             min = -1.0\nmax = 1.0\n"
        )
    };
    let axes: String = [("X", "linear"), ("Y", "linear"), ("Z", "linear"), ("A", "rotary"), ("B", "rotary")]
        .iter()
        .map(|(n, k)| axis(n, k))
        .collect();
    let c = Config::from_toml_str(&format!("[machine]\n{plant}\n{axes}"), "m.toml").unwrap_or_else(|e| panic!("{e}"));
    c.plant.resolve(&c.axes, "m.toml").unwrap_or_else(|e| panic!("{e}"))
}

const NO_PROCESS: ProcessParams = ProcessParams { static_force: 0.0, dyn_force: 0.0, dyn_hz: 0.0 };

/// `haas-laser` on linear axis `axis`, crosstalk into the axes at `targets`.
fn haas(axis: AxisLetter, targets: [Option<usize>; 2]) -> ResolvedAxisPlant {
    ResolvedAxisPlant {
        axis,
        kind: AxisKind::Linear,
        preset: "haas-laser".into(),
        model: PlantModel::ThreeMass(ThreeMassParams {
            m1_kg: 200.0,
            m2_kg: 200.0,
            m3_kg: 100.0,
            k1_n_per_m: 3.5e7,
            k2_n_per_m: 2.0e8,
            d_motor_n_s_per_m: 20.0,
            d_slide_n_s_per_m: 100.0,
            d_structure_n_s_per_m: 0.1,
            d1_n_s_per_m: 10.0,
            d2_n_s_per_m: 1.0,
            motor_coulomb_n: 0.0,
            intalk_s2: 5e-5,
            crosstalk_s2: [3e-6, 4e-6],
            crosstalk_targets: targets,
        }),
        drive: DriveParams {
            encoder_step: 1e-8,
            kv_per_s: 100.0,
            kp: 80000.0,
            tn_s: 0.025,
            current_loop_hz: 1000.0,
            force_limit: 20000.0,
            vel_ff: 1.0,
            acc_ff: 0.0,
            velocity_filter_hz: None,
        },
        process: NO_PROCESS,
    }
}

/// `schneider-soft` on linear axis `axis`.
fn soft(axis: AxisLetter) -> ResolvedAxisPlant {
    ResolvedAxisPlant {
        axis,
        kind: AxisKind::Linear,
        preset: "schneider-soft".into(),
        model: PlantModel::TwoMass(TwoMassParams {
            motor_mass: 190.0,
            load_mass: 381.0,
            stiffness_pos: 545000.0,
            stiffness_neg: 545000.0,
            damping: 865.0,
            motor_viscous: 50.0,
            load_viscous: 20.0,
            motor_coulomb: 30.0,
            load_coulomb: 0.25,
            backlash: 0.000228,
            backlash_blend: 2e-6,
        }),
        drive: DriveParams {
            encoder_step: 2e-6,
            kv_per_s: 20.0,
            kp: 200000.0,
            tn_s: 0.01,
            current_loop_hz: 2000.0,
            force_limit: 10000.0,
            vel_ff: 1.0,
            acc_ff: 1.0,
            velocity_filter_hz: Some(200.0),
        },
        process: NO_PROCESS,
    }
}

/// `schneider-stiff` on linear axis `axis`.
fn stiff(axis: AxisLetter) -> ResolvedAxisPlant {
    ResolvedAxisPlant {
        axis,
        kind: AxisKind::Linear,
        preset: "schneider-stiff".into(),
        model: PlantModel::TwoMass(TwoMassParams {
            motor_mass: 35.4,
            load_mass: 70.8,
            stiffness_pos: 1580000.0,
            stiffness_neg: 1580000.0,
            damping: 635.0,
            motor_viscous: 20.0,
            load_viscous: 10.0,
            motor_coulomb: 10.0,
            load_coulomb: 0.25,
            backlash: 0.000228,
            backlash_blend: 2e-6,
        }),
        drive: DriveParams {
            encoder_step: 2e-6,
            kv_per_s: 40.0,
            kp: 120000.0,
            tn_s: 0.01,
            current_loop_hz: 2000.0,
            force_limit: 4000.0,
            vel_ff: 1.0,
            acc_ff: 1.0,
            velocity_filter_hz: Some(500.0),
        },
        process: NO_PROCESS,
    }
}

/// `schneider-joint1` on rotary axis `axis`.
fn joint1(axis: AxisLetter) -> ResolvedAxisPlant {
    ResolvedAxisPlant {
        axis,
        kind: AxisKind::Rotary,
        preset: "schneider-joint1".into(),
        model: PlantModel::TwoMass(TwoMassParams {
            motor_mass: 30.25,
            load_mass: 60.5,
            stiffness_pos: 1230000.0,
            stiffness_neg: 3600000.0,
            damping: 518.0,
            motor_viscous: 50.0,
            load_viscous: 20.0,
            motor_coulomb: 45.0,
            load_coulomb: 0.375,
            backlash: 0.000152,
            backlash_blend: 1.333e-6,
        }),
        drive: DriveParams {
            encoder_step: 1.333e-6,
            kv_per_s: 40.0,
            kp: 100000.0,
            tn_s: 0.01,
            current_loop_hz: 2000.0,
            force_limit: 5000.0,
            vel_ff: 1.0,
            acc_ff: 1.0,
            velocity_filter_hz: Some(500.0),
        },
        process: NO_PROCESS,
    }
}

fn two_mass(r: &mut ResolvedAxisPlant) -> &mut TwoMassParams {
    match &mut r.model {
        PlantModel::TwoMass(m) => m,
        PlantModel::ThreeMass(_) => panic!("{} is not a two-mass axis", r.axis),
    }
}

use AxisLetter::{A, B, X, Y, Z};

#[test]
fn every_embedded_preset_resolves_to_its_pinned_values() {
    let joints = [joint1(A), joint1(B)];
    let defaults = resolve("");
    assert_eq!(defaults[..3], [haas(X, [Some(1), Some(2)]), haas(Y, [Some(0), Some(2)]), haas(Z, [Some(0), Some(1)])]);
    assert_eq!(defaults[3..], joints);
    for (preset, expected) in
        [("schneider-soft", soft as fn(AxisLetter) -> ResolvedAxisPlant), ("schneider-stiff", stiff)]
    {
        let r = resolve(&format!("[plant]\npreset = \"{preset}\"\n"));
        assert_eq!(r[..3], [expected(X), expected(Y), expected(Z)], "{preset}");
        assert_eq!(r[3..], joints, "{preset}");
    }
    let r = resolve(
        "[plant]\nrotary_preset = \"schneider-joint1\"\n[[plant.axis]]\nname = \"Y\"\npreset = \"haas-laser\"\n",
    );
    assert_eq!(r, resolve(""), "naming the default presets changes nothing");
}

/// Every key of every model, overridden with a value of its own.
const EVERY_KEY: &str = r#"
[plant]
servo_rate_hz = 20000.0
[[plant.axis]]
name = "X"
preset = "schneider-soft"
motor_mass_kg = 101.0
load_mass_kg = 202.0
stiffness_n_per_m = 3.03e6
stiffness_neg_n_per_m = 4.04e6
damping_n_s_per_m = 505.0
motor_viscous_n_s_per_m = 6.06
load_viscous_n_s_per_m = 7.07
motor_coulomb_n = 8.08
load_coulomb_n = 0.909
backlash_m = 1.0e-4
backlash_blend_m = 1.1e-5
encoder_step_m = 1.2e-7
kv_per_s = 13.0
kp_n_s_per_m = 1.4e5
tn_s = 0.015
current_loop_hz = 1600.0
force_limit_n = 1.7e4
vel_ff = 0.18
acc_ff = 0.19
velocity_filter_hz = 2000.0
process_force_n = -21.0
process_force_dyn_n = 22.0
process_dyn_hz = 23.0
[[plant.axis]]
name = "Y"
crosstalk_targets = ["Z"]
m1_kg = 31.0
m2_kg = 32.0
m3_kg = 33.0
k1_n_per_m = 3.4e7
k2_n_per_m = 3.5e6
d_motor_n_s_per_m = 36.0
d_slide_n_s_per_m = 37.0
d_structure_n_s_per_m = 0.38
d1_n_s_per_m = 39.0
d2_n_s_per_m = 4.0
intalk_s2 = 4.1e-5
crosstalk_y_s2 = 4.2e-6
crosstalk_z_s2 = 4.3e-6
motor_coulomb_n = 4.4
encoder_step_m = 0.0
kv_per_s = 46.0
kp_n_s_per_m = 4.7e4
tn_s = 0.048
current_loop_hz = 490.0
force_limit_n = 5.0e3
vel_ff = 0.51
acc_ff = 0.52
velocity_filter_hz = 0.0
process_force_n = 54.0
process_force_dyn_n = -55.0
process_dyn_hz = 56.0
[[plant.axis]]
name = "A"
motor_inertia_kg_m2 = 61.0
load_inertia_kg_m2 = 62.0
stiffness_nm_per_rad = 6.3e5
stiffness_neg_nm_per_rad = 6.4e5
damping_nm_s_per_rad = 65.0
motor_viscous_nm_s_per_rad = 66.0
load_viscous_nm_s_per_rad = 67.0
motor_coulomb_nm = 68.0
load_coulomb_nm = 0.69
backlash_rad = 7.0e-4
backlash_blend_rad = 7.1e-6
encoder_step_rad = 7.2e-7
kv_per_s = 73.0
kp_nm_s_per_rad = 7.4e4
tn_s = 0.075
current_loop_hz = 760.0
torque_limit_nm = 7.7e3
vel_ff = 0.78
acc_ff = 0.79
velocity_filter_hz = 800.0
process_torque_nm = 81.0
process_torque_dyn_nm = 82.0
process_dyn_hz = 83.0
"#;

#[test]
fn every_override_key_reaches_its_parameter() {
    let r = resolve(EVERY_KEY);
    let x = ResolvedAxisPlant {
        model: PlantModel::TwoMass(TwoMassParams {
            motor_mass: 101.0,
            load_mass: 202.0,
            stiffness_pos: 3.03e6,
            stiffness_neg: 4.04e6,
            damping: 505.0,
            motor_viscous: 6.06,
            load_viscous: 7.07,
            motor_coulomb: 8.08,
            load_coulomb: 0.909,
            backlash: 1e-4,
            backlash_blend: 1.1e-5,
        }),
        drive: DriveParams {
            encoder_step: 1.2e-7,
            kv_per_s: 13.0,
            kp: 1.4e5,
            tn_s: 0.015,
            current_loop_hz: 1600.0,
            force_limit: 1.7e4,
            vel_ff: 0.18,
            acc_ff: 0.19,
            velocity_filter_hz: Some(2000.0),
        },
        process: ProcessParams { static_force: -21.0, dyn_force: 22.0, dyn_hz: 23.0 },
        ..soft(X)
    };
    let y = ResolvedAxisPlant {
        model: PlantModel::ThreeMass(ThreeMassParams {
            m1_kg: 31.0,
            m2_kg: 32.0,
            m3_kg: 33.0,
            k1_n_per_m: 3.4e7,
            k2_n_per_m: 3.5e6,
            d_motor_n_s_per_m: 36.0,
            d_slide_n_s_per_m: 37.0,
            d_structure_n_s_per_m: 0.38,
            d1_n_s_per_m: 39.0,
            d2_n_s_per_m: 4.0,
            motor_coulomb_n: 4.4,
            intalk_s2: 4.1e-5,
            crosstalk_s2: [4.2e-6, 4.3e-6],
            crosstalk_targets: [Some(2), None],
        }),
        drive: DriveParams {
            encoder_step: 0.0,
            kv_per_s: 46.0,
            kp: 4.7e4,
            tn_s: 0.048,
            current_loop_hz: 490.0,
            force_limit: 5.0e3,
            vel_ff: 0.51,
            acc_ff: 0.52,
            velocity_filter_hz: None,
        },
        process: ProcessParams { static_force: 54.0, dyn_force: -55.0, dyn_hz: 56.0 },
        ..haas(Y, [None, None])
    };
    let a = ResolvedAxisPlant {
        model: PlantModel::TwoMass(TwoMassParams {
            motor_mass: 61.0,
            load_mass: 62.0,
            stiffness_pos: 6.3e5,
            stiffness_neg: 6.4e5,
            damping: 65.0,
            motor_viscous: 66.0,
            load_viscous: 67.0,
            motor_coulomb: 68.0,
            load_coulomb: 0.69,
            backlash: 7e-4,
            backlash_blend: 7.1e-6,
        }),
        drive: DriveParams {
            encoder_step: 7.2e-7,
            kv_per_s: 73.0,
            kp: 7.4e4,
            tn_s: 0.075,
            current_loop_hz: 760.0,
            force_limit: 7.7e3,
            vel_ff: 0.78,
            acc_ff: 0.79,
            velocity_filter_hz: Some(800.0),
        },
        process: ProcessParams { static_force: 81.0, dyn_force: 82.0, dyn_hz: 83.0 },
        ..joint1(A)
    };
    assert_eq!(r, [x, y, haas(Z, [Some(0), Some(1)]), a, joint1(B)]);
}

#[test]
fn a_preset_blend_shrinks_with_a_smaller_backlash_and_k_minus_follows_k_plus() {
    let r = resolve(
        "[plant]\npreset = \"schneider-soft\"\n[[plant.axis]]\nname = \"X\"\nbacklash_m = 1.0e-6\n\
         [[plant.axis]]\nname = \"Y\"\nstiffness_n_per_m = 2.0e6\n[[plant.axis]]\nname = \"B\"\nbacklash_rad = 1.0e-6\n",
    );
    let mut x = soft(X);
    (two_mass(&mut x).backlash, two_mass(&mut x).backlash_blend) = (1e-6, 5e-7);
    let mut y = soft(Y);
    (two_mass(&mut y).stiffness_pos, two_mass(&mut y).stiffness_neg) = (2e6, 2e6);
    let mut b = joint1(B);
    (two_mass(&mut b).backlash, two_mass(&mut b).backlash_blend) = (1e-6, 5e-7);
    assert_eq!(r, [x, y, soft(Z), joint1(A), b]);
}

#[test]
fn a_preset_file_resolves_like_the_embedded_preset() {
    let dir = std::env::temp_dir().join(format!("interpd-config-preset-file-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let c = Config::five_axis_machine();
    for (name, text) in interpd_config::plant::PRESETS {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let file = path.to_str().unwrap();
        let from_file = c.plant.select(file, &c.axes, "--plant").unwrap().resolve(&c.axes, "m").unwrap();
        let embedded = c.plant.select(name, &c.axes, "--plant").unwrap().resolve(&c.axes, "m").unwrap();
        assert_eq!(from_file.len(), embedded.len());
        for (mut f, e) in from_file.into_iter().zip(embedded) {
            if f.preset == file {
                f.preset = name.to_string();
            }
            assert_eq!(f, e, "{name}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
