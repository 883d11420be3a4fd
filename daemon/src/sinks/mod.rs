//! Where the setpoints go: iceoryx2 shared memory ([`shm`]) and SocketCAN with CiA 402 cyclic
//! synchronous position ([`can`]).
//!
//! A sink's `publish` runs inside the real-time cycle: it must not allocate, lock, block or
//! log. Failures are counted and reported outside the cycle.

pub mod can;
mod can_boot;
mod can_command;
mod can_homing;
mod can_inbox;
mod can_log;
mod can_rx;
mod can_sink;
mod can_state;
pub mod deferred;
pub mod drive_command;
pub mod shm;

use drive_command::{DriveCommandError, HomeOutcome, Reposition, ResetOutcome, SdoOp};
use interpd_protocol::api::DriveStatus;
use interpd_protocol::cia402::PowerState;
use interpd_protocol::shm::Setpoints;
use std::fmt;

/// Why a sink could not be set up or could not publish.
#[derive(Debug, thiserror::Error)]
pub enum SinkError {
    /// The sink could not be created (at start-up).
    #[error("{sink}: cannot set up: {message}")]
    Setup { sink: String, message: String },
    /// One setpoint could not be published (counted by the caller).
    #[error("publish failed")]
    Publish,
}

/// A destination of setpoints. Sinks called in the cycle must be allocation-free and
/// non-blocking; a sink that cannot be (iceoryx2's loan allocates) runs behind
/// [`deferred::spawn`].
pub trait SetpointSink {
    /// Publishes one setpoint. Runs in the real-time cycle.
    fn publish(&mut self, setpoint: &Setpoints) -> Result<(), SinkError>;
}

/// Drives that report their state (the CAN master): what `status` shows, whether motion may
/// start, and faults that must stop the motion. Called outside the real-time cycle.
pub trait DriveMonitor: Send + Sync {
    /// One status entry per drive (`status.drives`).
    fn drives(&self) -> Vec<DriveStatus>;
    /// Bus counters (`status.can_bus`).
    fn bus(&self) -> Option<serde_json::Value>;
    /// `Ok` when every drive is ready for motion, else each drive that is not and why.
    fn ready_for_motion(&self) -> Result<(), DrivesNotReady>;
    /// The oldest fault not yet taken (a drive left Operation enabled, a heartbeat was lost,
    /// the bus failed): the service stops the machine on it.
    fn take_fault(&self) -> Option<String>;
    /// One SDO transfer with drive `node` (commissioning); the bytes read, or none for a write.
    /// The caller has checked that nothing moves.
    fn sdo(&self, node: u8, op: SdoOp) -> Result<Vec<u8>, DriveCommandError> {
        let _ = (node, op);
        Err(DriveCommandError::NoMaster)
    }
    /// Fault reset (controlword bit 7, rising edge) of the drives `nodes` (none: every drive in
    /// Fault), then back toward Operation enabled; waits until they have left Fault.
    fn reset(&self, nodes: &[u8]) -> ResetOutcome {
        let _ = nodes;
        Err(DriveCommandError::NoMaster)
    }
    /// Homes the drives in the configured order (CiA 402 homing mode), each axis's setpoint
    /// moved onto its drive's new position by `reposition` before the drive returns to CSP.
    /// The caller has checked that nothing moves.
    fn home(&self, reposition: Reposition) -> HomeOutcome {
        let _ = reposition;
        Err(DriveCommandError::NoMaster)
    }
    /// Whether every drive is homed (`None`: no drives).
    fn homed(&self) -> Option<bool> {
        None
    }
}

/// Why motion may not start: every drive that is not ready, and a bus that does not receive.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "CAN drives not ready for motion: {}; the master enables drives at standstill once they answer (see \
     status.drives)",
    self.problems()
)]
pub struct DrivesNotReady {
    pub drives: Vec<DriveNotReady>,
    /// The CAN interface, when it does not receive frames (down?).
    pub silent_interface: Option<String>,
}

impl DrivesNotReady {
    /// The problems, one after another.
    fn problems(&self) -> String {
        let mut all: Vec<String> = self.drives.iter().map(ToString::to_string).collect();
        if let Some(iface) = &self.silent_interface {
            all.push(format!("CAN interface {iface} does not receive (down?)"));
        }
        all.join("; ")
    }
}

/// One drive that is not ready for motion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("drive {axis} (node {node}) {reason}")]
pub struct DriveNotReady {
    pub axis: String,
    pub node: u8,
    pub reason: NotReady,
}

/// Why a drive is not ready for motion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotReady {
    #[error("has not answered (no TPDO1 since start-up: powered, NMT operational, right node-ID?)")]
    NoAnswer,
    /// Its TPDO1s stopped coming for longer than the heartbeat timeout.
    #[error("has not sent a TPDO1 for {silent_ms:.0} ms")]
    Silent { silent_ms: f64 },
    #[error("has lost its heartbeat")]
    HeartbeatLost,
    /// In another CiA 402 state; the master enables it only within the enable window.
    #[error(
        "is in state {state} (statusword 0x{statusword:04X}), not Operation enabled{}{}",
        OutsideWindow(outside_window),
        if *state == PowerState::Fault { " (a fault stays until drives.reset acknowledges it)" } else { "" }
    )]
    NotEnabled { state: PowerState, statusword: u16, outside_window: Option<EnableWindow> },
    #[error("reports an undefined statusword 0x{0:04X}")]
    UndefinedStatusword(u16),
    #[error("is homing (machine.home runs)")]
    Homing,
    #[error("is not homed ([sinks.can] require_homing: call machine.home first)")]
    NotHomed,
}

/// A drive's position actual too far from the setpoint for the master to enable it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EnableWindow {
    /// Position actual minus the setpoint, increments.
    pub offset_increments: i64,
    /// The window (`[sinks.can] enable_window_increments`).
    pub window_increments: u32,
}

/// The sentence [`NotReady::NotEnabled`] adds when the drive is outside the enable window.
struct OutsideWindow<'a>(&'a Option<EnableWindow>);

impl fmt::Display for OutsideWindow<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(w) => write!(
                f,
                "; its position actual is {} increments from the setpoint, outside the enable window of {} (restart \
                 the daemon to take over the drive's position)",
                w.offset_increments, w.window_increments
            ),
            None => Ok(()),
        }
    }
}
