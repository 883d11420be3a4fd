//! Where the setpoints go: iceoryx2 shared memory ([`shm`]) and SocketCAN with CiA 402 cyclic
//! synchronous position ([`can`]).
//!
//! A sink's `publish` runs inside the real-time cycle: it must not allocate, lock, block or
//! log. Failures are counted and reported outside the cycle.

pub mod can;
mod can_log;
mod can_rx;
mod can_sink;
mod can_state;
pub mod deferred;
pub mod shm;

use interpd_protocol::shm::Setpoints;

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
    fn drives(&self) -> Vec<interpd_protocol::api::DriveStatus>;
    /// Bus counters (`status.can_bus`).
    fn bus(&self) -> Option<serde_json::Value>;
    /// `Ok` when every drive is ready for motion, else a message naming each drive that is not
    /// and why.
    fn ready_for_motion(&self) -> Result<(), String>;
    /// The oldest fault not yet taken (a drive left Operation enabled, a heartbeat was lost,
    /// the bus failed): the motion core stops the machine on it.
    fn take_fault(&self) -> Option<String>;
}
