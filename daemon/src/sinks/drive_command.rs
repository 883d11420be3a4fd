//! Commissioning commands for the drives (`drives.sdo_read`, `drives.sdo_write`,
//! `drives.reset`): what the service asks the drive monitor, and why it failed. The CAN master
//! runs the SDO transfers in its boot thread, which owns the master's SDO channel to every
//! node, so a commissioning transfer never overlaps a configuration transfer to the same node.

use interpd_canopen::Address;
use interpd_protocol::api::{HomedAxis, ResetDrive};

/// One SDO transfer with one node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SdoOp {
    /// Upload (read) the object.
    Read(Address),
    /// Download (write) these bytes.
    Write(Address, Vec<u8>),
}

impl SdoOp {
    pub fn address(&self) -> Address {
        match self {
            SdoOp::Read(at) | SdoOp::Write(at, _) => *at,
        }
    }
}

/// Why a drive command failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DriveCommandError {
    /// The daemon drives no CAN bus.
    #[error("the daemon runs no CAN master: drive commands need `interpd run --can IFACE`")]
    NoMaster,
    #[error("no drive has node-ID {node}; the drives are {known}")]
    UnknownNode { node: u8, known: String },
    /// The transfer failed: the message names the node, the object and the abort code with
    /// its meaning (or the timeout).
    #[error("{message}")]
    Sdo { message: String, abort_code: Option<u32> },
    /// A drive stayed in Fault (or another state) after the fault reset.
    #[error("{0}")]
    Reset(String),
    /// Homing failed: the message names the drive, the node and the method, and what went
    /// wrong (homing error bit, timeout, a refused mode).
    #[error("{0}")]
    Homing(String),
    /// The master's boot thread is gone (the daemon is stopping).
    #[error("the CAN master is stopping: {0}")]
    Stopped(String),
}

/// What `drives.reset` did.
pub type ResetOutcome = Result<Vec<ResetDrive>, DriveCommandError>;

/// What `machine.home` did.
pub type HomeOutcome = Result<Vec<HomedAxis>, DriveCommandError>;

/// Moves the setpoint of axis `axis` to `position` (axis units) at rest without motion: after
/// homing, the drive's position has a new reference while the machine stands where it stood.
/// Returns when the real-time sink sends the new position, or why it could not.
pub type Reposition<'a> = &'a (dyn Fn(usize, f64) -> Result<(), String> + Sync);
