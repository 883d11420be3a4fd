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
//!
//! [sinks.can.node.2]                 # what node 2 must be (default: the simulated drive)
//! vendor_id = 0x0000_0000
//! product_code = 0x0000_0402
//! sdo = [{ index = 0x6065, sub = 0, type = "u32", value = 20000 }]   # written at boot
//! eds = "drives/servo.eds"           # or its identity from an EDS/DCF ([DeviceInfo])
//! ```

use crate::{AxisConfig, ConfigError, Validator};
use serde::Deserialize;
use std::collections::BTreeMap;

/// The identity of the project's simulated drive (its EDS's `[DeviceInfo]`): what every node is
/// expected to be unless `[sinks.can.node.N]` says otherwise.
pub const SIM_DRIVE_VENDOR_ID: u32 = 0;
pub const SIM_DRIVE_PRODUCT_CODE: u32 = 0x402;

/// `[sinks.can.node.N]`: what the master expects node N to be.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
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
