//! The `[compensation]` section of a machine whose X and Y run one strategy on the deflection
//! model a static load test identified (`sim_plant::process::identify`): what
//! `interpd demo --scenario milling-circle` runs (`cli/milling.rs`), and its in-process test
//! (`tests/comp_plant.rs`).

use sim_plant::process::identify::Identified;

/// `machine` (TOML text) with `strategy` on X and Y, the identified models in `id` (X, Y);
/// `machine` unchanged for `none`.
pub fn machine_with_strategy(machine: &str, strategy: &str, id: &[Identified]) -> String {
    let mut s = machine.to_string();
    if strategy == "none" {
        return s;
    }
    s.push_str(
        "\n[compensation]\n[compensation.measurement]\nforce_axes = [\"X\", \"Y\"]\nposition_axes = [\"X\", \
         \"Y\"]\nactuator_axes = [\"X\", \"Y\"]\n",
    );
    for (axis, m) in ["X", "Y"].iter().zip(id) {
        s.push_str(&format!(
            "\n[[compensation.axis]]\nname = \"{axis}\"\nstrategy = \"{strategy}\"\nstiffness_pos_n_per_mm = {:.6}\n\
             stiffness_neg_n_per_mm = {:.6}\ngap_mm = {:.6}\nzero_load_n = {:.6}\n",
            m.k_pos_n_per_mm,
            m.k_neg_n_per_mm,
            m.gap_mm.max(0.0),
            m.zero_load_n
        ));
    }
    s
}
