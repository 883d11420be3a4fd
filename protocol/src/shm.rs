//! Shared-memory payloads (iceoryx2 publish-subscribe), their service names and settings, and
//! with feature `iceoryx2` the opening of the services ([`NodeOptions`], [`open_service`]).
//!
//! Both payloads are fixed-size `#[repr(C)]` structs without padding, so a client in another
//! language can read them from the sample bytes: little-endian on x86-64, fields in the order
//! written here. Times are CLOCK_MONOTONIC nanoseconds; positions in the axis unit (mm or deg),
//! velocities per second, accelerations per second squared. Only the first `n_axes` entries of
//! the per-axis arrays are meaningful; axis order is the order of `[[axis]]` in the machine
//! file.

use crate::MAX_AXES;
use iceoryx2_bb_derive_macros::ZeroCopySend;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;

#[cfg(feature = "iceoryx2")]
mod service;
#[cfg(feature = "iceoryx2")]
pub use service::{NodeError, NodeOptions, ServiceError, ServicePorts, open_service};

/// Service the daemon publishes setpoints on.
pub const SETPOINTS_SERVICE: &str = "interpd/setpoints";
/// Service the plant publishes feedback on.
pub const FEEDBACK_SERVICE: &str = "interpd/feedback";
/// Layout version carried in every payload; bumped on any change of the structs below.
pub const PAYLOAD_VERSION: u32 = 1;

/// Prefix of the default service names ([`SETPOINTS_SERVICE`], [`FEEDBACK_SERVICE`]).
pub const DEFAULT_SERVICE_PREFIX: &str = "interpd";
/// Environment variable that replaces [`DEFAULT_SERVICE_PREFIX`] for every interpd process
/// started with it (daemon, sim-plant, tests), so parallel instances do not share services.
/// A `--service-prefix` option takes precedence where a program has one.
pub const SERVICE_PREFIX_ENV: &str = "INTERPD_SERVICE_PREFIX";
/// Longest accepted service prefix, in bytes (iceoryx2 service names are bounded).
pub const MAX_SERVICE_PREFIX_LEN: usize = 128;

/// Service settings both sides use, so whichever process starts first creates a service the
/// other can open (iceoryx2 refuses to open a service whose settings are below the request).
pub mod qos {
    /// Samples a publisher keeps for subscribers that connect later: one, so a subscriber that
    /// joins late starts from the latest sample.
    pub const HISTORY_SIZE: usize = 1;
    /// Samples a subscriber can queue: 64 cycles (256 ms at 4 ms) before the oldest are
    /// overwritten (safe overflow: a slow subscriber never blocks the real-time publisher).
    pub const SUBSCRIBER_BUFFER_SIZE: usize = 64;
    /// Publishers per service (one producer, plus one for a replay or test tool).
    pub const MAX_PUBLISHERS: usize = 2;
    /// Subscribers per service (plant, recorder, monitors, tests).
    pub const MAX_SUBSCRIBERS: usize = 8;
}

/// Bits of [`Feedback::flags`].
pub mod feedback_flags {
    /// At least one axis's drive hit its force (torque) limit in the last servo step.
    pub const SATURATED: u32 = 1 << 0;
    /// At least one axis has its backlash gap open: the load is not driven.
    pub const GAP_OPEN: u32 = 1 << 1;
    /// The plant was (re)started at this setpoint instead of moving to it (first setpoint, or
    /// after a silence longer than the plant's resynchronisation limit).
    pub const RESYNC: u32 = 1 << 2;
}

/// Checks a service prefix: 1..=[`MAX_SERVICE_PREFIX_LEN`] bytes of ASCII letters, digits and
/// `_ - . /`, not starting or ending with `/`. The error says what is wrong.
pub fn check_service_prefix(prefix: &str) -> Result<(), String> {
    if prefix.is_empty() || prefix.len() > MAX_SERVICE_PREFIX_LEN {
        return Err(format!("service prefix must have 1 to {MAX_SERVICE_PREFIX_LEN} characters, got {}", prefix.len()));
    }
    if let Some(c) = prefix.chars().find(|c| !(c.is_ascii_alphanumeric() || "_-./".contains(*c))) {
        return Err(format!("service prefix `{prefix}`: character {c:?} not allowed (use letters, digits, _ - . /)"));
    }
    if prefix.starts_with('/') || prefix.ends_with('/') {
        return Err(format!("service prefix `{prefix}` must not start or end with `/`"));
    }
    Ok(())
}

/// The setpoint service name for `prefix` (`interpd` gives [`SETPOINTS_SERVICE`]).
pub fn setpoints_service(prefix: &str) -> String {
    format!("{prefix}/setpoints")
}

/// The feedback service name for `prefix` (`interpd` gives [`FEEDBACK_SERVICE`]).
pub fn feedback_service(prefix: &str) -> String {
    format!("{prefix}/feedback")
}

/// A payload with a service of its own: the type decides the service name, so a participant
/// cannot open a service with the other stream's payload.
pub trait ServicePayload: std::fmt::Debug + ZeroCopySend + 'static {
    /// The service for `prefix`.
    fn service_name(prefix: &str) -> String;
}

impl ServicePayload for Setpoints {
    fn service_name(prefix: &str) -> String {
        setpoints_service(prefix)
    }
}

impl ServicePayload for Feedback {
    fn service_name(prefix: &str) -> String {
        feedback_service(prefix)
    }
}

impl ServicePayload for Measurement {
    fn service_name(prefix: &str) -> String {
        format!("{prefix}/measurement")
    }
}

impl ServicePayload for ActuatorCommand {
    fn service_name(prefix: &str) -> String {
        format!("{prefix}/actuator")
    }
}

/// Bits of [`Measurement::flags`].
pub mod measurement_flags {
    /// `tool_pos` holds an external position measurement taken at `measured_ns`.
    pub const POSITION: u32 = 1 << 0;
    /// `force_n` holds the force signal at `time_ns`.
    pub const FORCE: u32 = 1 << 1;
    /// `actuator_pos` holds the fast actuators' positions at `time_ns`.
    pub const ACTUATOR: u32 = 1 << 2;
}

/// One sample of the plant's measurements (service `<prefix>/measurement`), published when it
/// arrives: the external position measurement has a cycle and a dead time of its own, so this
/// stream is not paced by the setpoints. 256 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("interpd::Measurement")]
pub struct Measurement {
    /// [`PAYLOAD_VERSION`].
    pub version: u32,
    /// Number of valid axis entries.
    pub n_axes: u32,
    /// Sample number, +1 per sample.
    pub seq: u64,
    /// When the position was measured (plant time, the setpoints' clock), ns.
    pub measured_ns: u64,
    /// When the sample arrived (measured_ns + dead time), ns; the force and actuator values are for this instant.
    pub time_ns: u64,
    /// [`measurement_flags`] bits.
    pub flags: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Measured tool position (load plus fast actuator), axis unit; NaN on axes not measured.
    pub tool_pos: [f64; MAX_AXES],
    /// Force signal at the load along the axis, N (positive: towards positive positions).
    pub force_n: [f64; MAX_AXES],
    /// Fast actuator position relative to its mid-stroke, axis unit; 0 on axes without one.
    pub actuator_pos: [f64; MAX_AXES],
}

impl Default for Measurement {
    fn default() -> Self {
        Self {
            version: PAYLOAD_VERSION,
            n_axes: 0,
            seq: 0,
            measured_ns: 0,
            time_ns: 0,
            flags: 0,
            reserved: 0,
            tool_pos: [f64::NAN; MAX_AXES],
            force_n: [0.0; MAX_AXES],
            actuator_pos: [0.0; MAX_AXES],
        }
    }
}

/// Position commands for the fast actuators, one per interpolation cycle (service
/// `<prefix>/actuator`), published before the cycle's setpoints. 96 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("interpd::ActuatorCommand")]
pub struct ActuatorCommand {
    /// [`PAYLOAD_VERSION`].
    pub version: u32,
    /// Number of valid axis entries.
    pub n_axes: u32,
    /// Cycle number of the setpoints it goes with.
    pub cycle: u64,
    /// The time the commands are for, ns (as [`Setpoints::time_ns`]).
    pub time_ns: u64,
    /// Actuator position relative to mid-stroke, axis unit.
    pub pos: [f64; MAX_AXES],
}

impl Default for ActuatorCommand {
    fn default() -> Self {
        Self { version: PAYLOAD_VERSION, n_axes: 0, cycle: 0, time_ns: 0, pos: [0.0; MAX_AXES] }
    }
}

/// Bits of [`Setpoints::flags`].
pub mod flags {
    /// Motion is running (program or jog).
    pub const RUNNING: u32 = 1 << 0;
    /// A feed hold is active or being approached.
    pub const HOLDING: u32 = 1 << 1;
    /// A stop is being executed.
    pub const STOPPING: u32 = 1 << 2;
    /// The program has ended; the setpoint is the end point.
    pub const FINISHED: u32 = 1 << 3;
    /// The daemon is in an error state.
    pub const ERROR: u32 = 1 << 4;
    /// The profile queue ran dry; the path velocity is being brought to zero.
    pub const UNDERRUN: u32 = 1 << 5;
    /// This cycle was computed after its deadline (caught up); its values are for its own time.
    pub const LATE: u32 = 1 << 6;
    /// No motion: the machine stands at the setpoint.
    pub const IDLE: u32 = 1 << 7;
    /// The program stands at a program stop (M0, M1, M60) and waits to be resumed (with
    /// `RUNNING`: the program goes on from here).
    pub const PAUSED: u32 = 1 << 8;
}

/// One setpoint per interpolation cycle (service `interpd/setpoints`). 288 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("interpd::Setpoints")]
pub struct Setpoints {
    /// [`PAYLOAD_VERSION`].
    pub version: u32,
    /// Number of valid axis entries.
    pub n_axes: u32,
    /// Cycle number, 0 when motion starts, +1 per cycle without gaps.
    pub cycle: u64,
    /// The time this setpoint is for (the cycle's deadline), ns.
    pub time_ns: u64,
    /// When the daemon published it, ns (for latency measurements).
    pub publish_ns: u64,
    /// [`flags`] bits.
    pub flags: u32,
    /// Program line being executed (1-based, 0 if none).
    pub line: u32,
    /// Path position, mm.
    pub s_mm: f64,
    /// Path velocity, mm/s.
    pub v_mm_s: f64,
    /// Path acceleration, mm/s².
    pub a_mm_s2: f64,
    /// Feed override in effect (1.0 = 100 %).
    pub feed_override: f64,
    /// Axis positions.
    pub pos: [f64; MAX_AXES],
    /// Axis velocities.
    pub vel: [f64; MAX_AXES],
    /// Axis accelerations.
    pub acc: [f64; MAX_AXES],
}

impl Default for Setpoints {
    fn default() -> Self {
        Self {
            version: PAYLOAD_VERSION,
            n_axes: 0,
            cycle: 0,
            time_ns: 0,
            publish_ns: 0,
            flags: flags::IDLE,
            line: 0,
            s_mm: 0.0,
            v_mm_s: 0.0,
            a_mm_s2: 0.0,
            feed_override: 1.0,
            pos: [0.0; MAX_AXES],
            vel: [0.0; MAX_AXES],
            acc: [0.0; MAX_AXES],
        }
    }
}

/// Plant feedback per plant cycle (service `interpd/feedback`). 400 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("interpd::Feedback")]
pub struct Feedback {
    /// [`PAYLOAD_VERSION`].
    pub version: u32,
    /// Number of valid axis entries.
    pub n_axes: u32,
    /// Cycle number of the setpoint this feedback answers.
    pub cycle: u64,
    /// Time of the plant state, ns.
    pub time_ns: u64,
    /// `publish_ns` of the setpoint this feedback answers (round-trip measurements).
    pub setpoint_publish_ns: u64,
    /// Plant status bits, [`feedback_flags`].
    pub flags: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Motor-side position (encoder, quantised), axis unit.
    pub motor_pos: [f64; MAX_AXES],
    /// Load-side position, axis unit.
    pub load_pos: [f64; MAX_AXES],
    /// Setpoint minus motor position, axis unit.
    pub following_error: [f64; MAX_AXES],
    /// Setpoint minus load position, axis unit.
    pub load_error: [f64; MAX_AXES],
    /// Motor force (N) or torque (N·m).
    pub motor_force: [f64; MAX_AXES],
}

impl Default for Feedback {
    fn default() -> Self {
        Self {
            version: PAYLOAD_VERSION,
            n_axes: 0,
            cycle: 0,
            time_ns: 0,
            setpoint_publish_ns: 0,
            flags: 0,
            reserved: 0,
            motor_pos: [0.0; MAX_AXES],
            load_pos: [0.0; MAX_AXES],
            following_error: [0.0; MAX_AXES],
            load_error: [0.0; MAX_AXES],
            motor_force: [0.0; MAX_AXES],
        }
    }
}

impl Setpoints {
    /// The payload as bytes (for recording).
    pub fn as_bytes(&self) -> &[u8] {
        // SAFETY: repr(C), no padding (checked by `layout_has_no_padding`), plain old data.
        unsafe { std::slice::from_raw_parts((self as *const Self).cast::<u8>(), std::mem::size_of::<Self>()) }
    }

    /// Reads a payload from bytes; `None` if the length or version is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        if bytes.len() != std::mem::size_of::<Self>() {
            return None;
        }
        // SAFETY: length checked; every bit pattern is a valid value of every field.
        let v: Self = unsafe { std::ptr::read_unaligned(bytes.as_ptr().cast::<Self>()) };
        (v.version == PAYLOAD_VERSION && v.n_axes as usize <= MAX_AXES).then_some(v)
    }
}

impl Feedback {
    /// The payload as bytes (for recording).
    pub fn as_bytes(&self) -> &[u8] {
        // SAFETY: repr(C), no padding (checked by `layout_has_no_padding`), plain old data.
        unsafe { std::slice::from_raw_parts((self as *const Self).cast::<u8>(), std::mem::size_of::<Self>()) }
    }

    /// Reads a payload from bytes; `None` if the length or version is wrong.
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        if bytes.len() != std::mem::size_of::<Self>() {
            return None;
        }
        // SAFETY: length checked; every bit pattern is a valid value of every field.
        let v: Self = unsafe { std::ptr::read_unaligned(bytes.as_ptr().cast::<Self>()) };
        (v.version == PAYLOAD_VERSION && v.n_axes as usize <= MAX_AXES).then_some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn layout_has_no_padding() {
        assert_eq!(size_of::<Setpoints>(), 288);
        assert_eq!(offset_of!(Setpoints, s_mm), 40);
        assert_eq!(offset_of!(Setpoints, pos), 72);
        assert_eq!(offset_of!(Setpoints, acc), 72 + 2 * 72);
        assert_eq!(size_of::<Feedback>(), 400);
        assert_eq!(offset_of!(Feedback, motor_pos), 40);
        assert_eq!(size_of::<Measurement>(), 256);
        assert_eq!(offset_of!(Measurement, tool_pos), 40);
        assert_eq!(size_of::<ActuatorCommand>(), 96);
    }

    #[test]
    fn bytes_round_trip() {
        let mut s = Setpoints { n_axes: 3, cycle: 42, ..Setpoints::default() };
        s.pos[1] = -1.25;
        assert_eq!(Setpoints::from_bytes(s.as_bytes()), Some(s));
        assert_eq!(Setpoints::from_bytes(&s.as_bytes()[1..]), None);
        let f = Feedback { n_axes: 2, ..Feedback::default() };
        assert_eq!(Feedback::from_bytes(f.as_bytes()), Some(f));
    }

    #[test]
    fn service_names_and_prefixes() {
        assert_eq!(setpoints_service(DEFAULT_SERVICE_PREFIX), SETPOINTS_SERVICE);
        assert_eq!(feedback_service(DEFAULT_SERVICE_PREFIX), FEEDBACK_SERVICE);
        assert!(check_service_prefix("interpd").is_ok());
        assert!(check_service_prefix("test/e2e-123_a.b").is_ok());
        assert!(check_service_prefix("").is_err());
        assert!(check_service_prefix("a b").unwrap_err().contains("' '"));
        assert!(check_service_prefix("/abs").is_err());
        assert!(check_service_prefix(&"x".repeat(MAX_SERVICE_PREFIX_LEN + 1)).is_err());
    }

    #[test]
    fn type_names_are_stable() {
        assert_eq!(unsafe { <Setpoints as ZeroCopySend>::type_name() }, "interpd::Setpoints");
        assert_eq!(unsafe { <Feedback as ZeroCopySend>::type_name() }, "interpd::Feedback");
    }
}
