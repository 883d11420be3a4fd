//! `[sinks]`: where the setpoints go (iceoryx2 shared memory, SocketCAN).
//!
//! ```toml
//! [sinks]
//! shm = true
//!
//! [sinks.can]                        # CiA 402 cyclic synchronous position over SocketCAN
//! interface = "can0"                 # empty: no CAN sink (`interpd run --can IFACE` sets it)
//! nodes = [1, 2, 3]                  # CANopen node-ID per axis, in [[axis]] order
//! increments_per_unit = [10000.0, 10000.0, 10000.0]   # drive increments per mm (or deg)
//! heartbeat_timeout_ms = 500         # a drive silent this long is lost
//! boot_timeout_ms = 3000             # start-up waits this long for every drive's first answer
//! enable_window_increments = 1000    # |actual − setpoint| a drive may have to be enabled
//! tx_fail_cycles = 3                 # cycles with failed sends in a row before a controlled stop
//! heartbeat_producer_ms = 100        # 0x1017 the master writes into every drive
//! sdo_timeout_ms = 1000              # one SDO answer may take this long
//! home_order = ["Z", "X", "Y"]       # machine.home homes the axes in this order (default: all, [[axis]] order)
//! homing_timeout_ms = 30000          # one axis's homing may take this long
//! require_homing = false             # true: motion.start, jog, move-to and MDI wait for machine.home
//!
//! [sinks.can.node.2]                 # what node 2 must be (default: the simulated drive)
//! vendor_id = 0x0000_0000
//! product_code = 0x0000_0402
//! sdo = [{ index = 0x6065, sub = 0, type = "u32", value = 20000 }]   # written at boot
//! eds = "drives/servo.eds"           # or its identity from an EDS/DCF ([DeviceInfo])
//! homing = { method = 3, speed_switch = 10.0, speed_zero = 1.0, acceleration = 100.0, offset = 0.0 }
//! sim_home_switch = 12.5             # sim-plant only: the drive's home switch is active above this
//! sim_index_pitch = 5.0              # sim-plant only: an index pulse every this many units
//! ```

use crate::{AxisConfig, ConfigError, Validator};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The identity of the project's simulated drive (its EDS's `[DeviceInfo]`): what every node is
/// expected to be unless `[sinks.can.node.N]` says otherwise.
pub const SIM_DRIVE_VENDOR_ID: u32 = 0;
pub const SIM_DRIVE_PRODUCT_CODE: u32 = 0x402;

/// `[sinks.can.node.N]`: what the master expects node N to be.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CanNodeConfig {
    /// Expected 0x1018:1; default: the EDS's `VendorNumber`, else the simulated drive's.
    pub vendor_id: Option<u32>,
    /// Expected 0x1018:2; default: the EDS's `ProductNumber`, else the simulated drive's.
    pub product_code: Option<u32>,
    /// An EDS or DCF of the device, read by the master at start-up (a relative path is taken
    /// from the daemon's working directory). A DCF's `ParameterValue`s are written at boot.
    pub eds: Option<String>,
    /// Objects the master writes at boot, after the DCF's values and before NMT start, in this
    /// order: `sdo = [{ index = 0x6065, sub = 0, type = "u32", value = 20000 }]`.
    pub sdo: Vec<CanSdoValue>,
    /// How `machine.home` homes this node (CiA 402 homing mode 6).
    pub homing: CanHomingConfig,
    /// The simulated drive only (`sim-plant --source can:`): its home switch is active at axis
    /// positions at or above this (plant coordinates, axis units); none: the axis has no
    /// home switch, so a switch method ends at the travel's end with a homing error.
    pub sim_home_switch: Option<f64>,
    /// The simulated drive only: the distance between two index pulses of its encoder (one
    /// revolution), axis units; the pulses lie at whole multiples of it (plant coordinates).
    pub sim_index_pitch: f64,
}

/// Default index pulse spacing of the simulated drive: a 5 mm ball screw's revolution.
pub const DEFAULT_SIM_INDEX_PITCH: f64 = 5.0;

impl Default for CanNodeConfig {
    fn default() -> Self {
        Self {
            vendor_id: None,
            product_code: None,
            eds: None,
            sdo: Vec::new(),
            homing: CanHomingConfig::default(),
            sim_home_switch: None,
            sim_index_pitch: DEFAULT_SIM_INDEX_PITCH,
        }
    }
}

/// `[sinks.can.node.N] homing`: the CiA 402 homing parameters the master writes before it
/// homes the node, in axis units (converted with the node's `increments_per_unit`).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CanHomingConfig {
    /// 0x6098: the homing method (CiA 402-2; 35 and 37: the current position is home; 3, 4:
    /// home switch and index pulse).
    pub method: i8,
    /// 0x6099:1: speed during the search for the switch, axis units/s.
    pub speed_switch: f64,
    /// 0x6099:2: speed during the search for zero (the index pulse), axis units/s.
    pub speed_zero: f64,
    /// 0x609A: homing acceleration, axis units/s².
    pub acceleration: f64,
    /// 0x607C: the position the drive reports at the home position, axis units.
    pub offset: f64,
}

impl Default for CanHomingConfig {
    fn default() -> Self {
        Self { method: 37, speed_switch: 10.0, speed_zero: 1.0, acceleration: 100.0, offset: 0.0 }
    }
}

/// One value of `[sinks.can.node.N] sdo`. `type` is one of bool, u8, u16, u32, u64, i8, i16,
/// i32, i64, string, bytes (hex); the master checks it with the value at start-up.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CanSdoValue {
    pub index: u16,
    #[serde(default)]
    pub sub: u8,
    #[serde(rename = "type")]
    pub ty: String,
    pub value: toml::Value,
}

impl CanSdoValue {
    /// The value as text for the type's parser: an integer in decimal, a string as it is, a
    /// boolean as 1 or 0.
    pub fn value_text(&self) -> Result<String, String> {
        match &self.value {
            toml::Value::Integer(i) => Ok(i.to_string()),
            toml::Value::String(s) => Ok(s.clone()),
            toml::Value::Boolean(b) => Ok(if *b { "1" } else { "0" }.into()),
            other => Err(format!("expected an integer, a string or a boolean, got {other}")),
        }
    }
}

/// `[sinks]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SinksConfig {
    /// Publish setpoints on the iceoryx2 service `<shm_prefix>/setpoints`.
    pub shm: bool,
    /// Prefix of the iceoryx2 service names (`<prefix>/setpoints`, `<prefix>/feedback`).
    pub shm_prefix: String,
    /// `[sinks.can]`: the CANopen master (CiA 402 CSP) and the simulated drives' node set-up.
    pub can: CanConfig,
}

/// Default iceoryx2 service prefix: the services are `interpd/setpoints` and `interpd/feedback`.
pub const DEFAULT_SHM_PREFIX: &str = "interpd";

impl Default for SinksConfig {
    fn default() -> Self {
        Self { shm: true, shm_prefix: DEFAULT_SHM_PREFIX.to_string(), can: CanConfig::default() }
    }
}

/// `[sinks.can]`: the CiA 402 master. The simulated drives (`sim-plant --source can:IFACE`)
/// read the same node-IDs and scales, so one file configures both ends of the bus.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CanConfig {
    /// SocketCAN interface (e.g. `can0`, `vcan0`); empty means no CAN sink.
    pub interface: String,
    /// CANopen node-ID (1..=127) of each axis, in `[[axis]]` order; empty: 1, 2, 3, ….
    pub nodes: Vec<u8>,
    /// Drive position increments (0x607A, 0x6064) per axis unit (mm or deg), one per axis;
    /// empty: [`DEFAULT_INCREMENTS_PER_UNIT`] for every axis. Negative inverts the direction.
    pub increments_per_unit: Vec<f64>,
    /// Heartbeat consumer time: a drive whose heartbeat is older than this is reported lost and
    /// stops the motion, ms.
    pub heartbeat_timeout_ms: f64,
    /// At start-up the master waits this long for every drive's first TPDO1 (its actual
    /// position becomes the daemon's start position), ms. Drives that answer later are taken
    /// on when their position matches the setpoint within `enable_window_increments`.
    pub boot_timeout_ms: f64,
    /// Largest |position actual − setpoint| with which the master enables a drive, in
    /// increments: enabling further away would make the drive jump.
    pub enable_window_increments: u32,
    /// Cycles in a row in which sending failed (ENOBUFS, interface down, bus-off) before the
    /// master requests a controlled stop.
    pub tx_fail_cycles: u32,
    /// Heartbeat producer time the master writes into every drive's 0x1017 at boot, ms.
    pub heartbeat_producer_ms: u32,
    /// Longest wait for one SDO answer while configuring a drive, ms.
    pub sdo_timeout_ms: f64,
    /// Per node (the key is the node-ID): the identity the master checks at boot.
    pub node: BTreeMap<String, CanNodeConfig>,
    /// The axes (by name) `machine.home` homes, one after the other; empty: every axis in
    /// `[[axis]]` order.
    pub home_order: Vec<String>,
    /// Longest time one axis's homing may take (from the start bit to "homing attained"), ms.
    pub homing_timeout_ms: f64,
    /// Motion (`motion.start`, jog, move-to, MDI) is refused until every axis is homed.
    pub require_homing: bool,
}

/// Default scale: 10 000 increments per mm (0.1 µm resolution), as the EDS's 0x608F/0x6092.
pub const DEFAULT_INCREMENTS_PER_UNIT: f64 = 10_000.0;

impl Default for CanConfig {
    fn default() -> Self {
        Self {
            interface: String::new(),
            nodes: Vec::new(),
            increments_per_unit: Vec::new(),
            heartbeat_timeout_ms: 500.0,
            boot_timeout_ms: 3000.0,
            enable_window_increments: 1000,
            tx_fail_cycles: 3,
            heartbeat_producer_ms: 100,
            sdo_timeout_ms: 1000.0,
            node: BTreeMap::new(),
            home_order: Vec::new(),
            homing_timeout_ms: 30_000.0,
            require_homing: false,
        }
    }
}

impl CanConfig {
    /// Whether the CAN sink is configured (an interface is named).
    pub fn enabled(&self) -> bool {
        !self.interface.is_empty()
    }

    /// The node-ID of each of `n_axes` axes (the configured list, or 1, 2, …).
    pub fn node_ids(&self, n_axes: usize) -> Vec<u8> {
        if self.nodes.is_empty() { (1..=n_axes).map(|n| n as u8).collect() } else { self.nodes.clone() }
    }

    /// The increments per unit of each of `n_axes` axes.
    pub fn scales(&self, n_axes: usize) -> Vec<f64> {
        if self.increments_per_unit.is_empty() {
            vec![DEFAULT_INCREMENTS_PER_UNIT; n_axes]
        } else {
            self.increments_per_unit.clone()
        }
    }

    /// `[sinks.can.node.N]` of node `id` (the defaults when the table is absent).
    pub fn node_config(&self, id: u8) -> CanNodeConfig {
        self.node.get(&id.to_string()).cloned().unwrap_or_default()
    }

    /// The axes (indices into `[[axis]]`) in the order `machine.home` homes them.
    pub fn home_axes(&self, axes: &[AxisConfig]) -> Vec<usize> {
        if self.home_order.is_empty() {
            return (0..axes.len()).collect();
        }
        self.home_order.iter().filter_map(|name| axes.iter().position(|a| a.name.to_string() == *name)).collect()
    }

    /// Checks an interface name as Linux accepts it (1–15 printable characters, no `/`, no
    /// spaces); the message names what is wrong.
    pub fn check_interface(name: &str) -> Result<(), String> {
        if name.is_empty() || name.len() > 15 {
            return Err(format!("interface name must have 1 to 15 characters, got {name:?}"));
        }
        if name.chars().any(|c| !c.is_ascii_graphic() || c == '/' || c == ':') {
            return Err(format!("interface name {name:?} contains a character Linux does not allow"));
        }
        Ok(())
    }

    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        let n = axes.len();
        if !self.interface.is_empty() {
            Self::check_interface(&self.interface).map_err(|m| v.err("sinks.can.interface", &m))?;
        }
        if !self.nodes.is_empty() && self.nodes.len() != n {
            return Err(v.err(
                "sinks.can.nodes",
                &format!("needs one node-ID per axis ({n}), got {} ({:?})", self.nodes.len(), self.nodes),
            ));
        }
        for (i, &id) in self.nodes.iter().enumerate() {
            if !(1..=127).contains(&id) {
                return Err(v.err(&format!("sinks.can.nodes[{i}]"), &format!("node-ID must lie in 1..=127, got {id}")));
            }
            if let Some(j) = self.nodes[..i].iter().position(|&o| o == id) {
                return Err(
                    v.err(&format!("sinks.can.nodes[{i}]"), &format!("node-ID {id} is used twice (also nodes[{j}])"))
                );
            }
        }
        if !self.increments_per_unit.is_empty() && self.increments_per_unit.len() != n {
            return Err(v.err(
                "sinks.can.increments_per_unit",
                &format!("needs one value per axis ({n}), got {}", self.increments_per_unit.len()),
            ));
        }
        for (i, (&k, axis)) in self.scales(n).iter().zip(axes).enumerate() {
            let key = format!("sinks.can.increments_per_unit[{i}]");
            if !(k.is_finite() && k != 0.0 && k.abs() <= 1e9) {
                return Err(v.err(&key, &format!("must be finite, non-zero and at most 1e9 in size, got {k}")));
            }
            // Every position inside the travel must fit the drive's i32 target position.
            let far = axis.min_pos.abs().max(axis.max_pos.abs()) * k.abs();
            if far > i32::MAX as f64 {
                return Err(v.err(
                    &key,
                    &format!(
                        "axis {} travels to ±{} {}, which is {far:.0} increments: beyond the i32 range of 0x607A",
                        axis.name,
                        axis.min_pos.abs().max(axis.max_pos.abs()),
                        axis.kind.unit()
                    ),
                ));
            }
        }
        v.in_range("sinks.can.heartbeat_timeout_ms", self.heartbeat_timeout_ms, 10.0, 60_000.0)?;
        v.in_range("sinks.can.boot_timeout_ms", self.boot_timeout_ms, 0.0, 60_000.0)?;
        if self.enable_window_increments == 0 {
            return Err(v.err("sinks.can.enable_window_increments", "must be at least 1"));
        }
        if !(1..=u32::from(u16::MAX)).contains(&self.heartbeat_producer_ms) {
            return Err(v.err(
                "sinks.can.heartbeat_producer_ms",
                &format!("must lie in 1..=65535 (0x1017 is 16 bits), got {}", self.heartbeat_producer_ms),
            ));
        }
        if f64::from(self.heartbeat_producer_ms) >= self.heartbeat_timeout_ms {
            return Err(v.err(
                "sinks.can.heartbeat_producer_ms",
                &format!(
                    "{} ms is not below heartbeat_timeout_ms ({} ms): every heartbeat would count as lost",
                    self.heartbeat_producer_ms, self.heartbeat_timeout_ms
                ),
            ));
        }
        v.in_range("sinks.can.sdo_timeout_ms", self.sdo_timeout_ms, 1.0, 60_000.0)?;
        let ids = self.node_ids(n);
        for key in self.node.keys() {
            let ok = key.parse::<u8>().ok().is_some_and(|id| ids.contains(&id));
            if !ok {
                return Err(v.err(
                    &format!("sinks.can.node.{key}"),
                    &format!("is not the node-ID of a configured axis (the node-IDs are {ids:?})"),
                ));
            }
        }
        for (i, name) in self.home_order.iter().enumerate() {
            let key = format!("sinks.can.home_order[{i}]");
            let names: Vec<String> = axes.iter().map(|a| a.name.to_string()).collect();
            if !names.contains(name) {
                return Err(v.err(&key, &format!("{name:?} is not an axis (the axes are {names:?})")));
            }
            if self.home_order[..i].contains(name) {
                return Err(v.err(&key, &format!("axis {name} is named twice")));
            }
        }
        v.in_range("sinks.can.homing_timeout_ms", self.homing_timeout_ms, 100.0, 3_600_000.0)?;
        for (key, node) in &self.node {
            let h = &node.homing;
            let scale = key
                .parse::<u8>()
                .ok()
                .and_then(|id| ids.iter().position(|&o| o == id))
                .map_or(DEFAULT_INCREMENTS_PER_UNIT, |i| self.scales(n)[i].abs());
            for (what, value, unsigned) in [
                ("speed_switch", h.speed_switch, true),
                ("speed_zero", h.speed_zero, true),
                ("acceleration", h.acceleration, true),
                ("offset", h.offset, false),
            ] {
                let k = format!("sinks.can.node.{key}.homing.{what}");
                let inc = value * scale;
                let ok = value.is_finite()
                    && if unsigned { value > 0.0 && inc <= u32::MAX as f64 } else { inc.abs() <= i32::MAX as f64 };
                if !ok {
                    let range = if unsigned {
                        "positive and at most u32::MAX increments"
                    } else {
                        "within the i32 range of increments"
                    };
                    return Err(v.err(&k, &format!("must be {range} ({scale} increments per unit), got {value}")));
                }
            }
            if let Some(s) = node.sim_home_switch {
                if !s.is_finite() {
                    return Err(
                        v.err(&format!("sinks.can.node.{key}.sim_home_switch"), &format!("must be finite, got {s}"))
                    );
                }
            }
            let p = node.sim_index_pitch;
            if !(p.is_finite() && p > 0.0) {
                return Err(
                    v.err(&format!("sinks.can.node.{key}.sim_index_pitch"), &format!("must be positive, got {p}"))
                );
            }
        }
        if !(1..=1000).contains(&self.tx_fail_cycles) {
            return Err(
                v.err("sinks.can.tx_fail_cycles", &format!("must lie in 1..=1000, got {}", self.tx_fail_cycles))
            );
        }
        Ok(())
    }
}

impl SinksConfig {
    pub(crate) fn validate(&self, v: &Validator, axes: &[AxisConfig]) -> Result<(), ConfigError> {
        let p = &self.shm_prefix;
        let ok = !p.is_empty()
            && p.len() <= 200
            && p.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '/' | '.'))
            && !p.starts_with('/')
            && !p.ends_with('/');
        if !ok {
            return Err(v.err(
                "sinks.shm_prefix",
                &format!("must be 1–200 characters of A–Z a–z 0–9 _ - . / (not starting or ending with /), got {p:?}"),
            ));
        }
        self.can.validate(v, axes)
    }
}
