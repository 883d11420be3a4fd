//! Where the setpoints go: iceoryx2 shared memory ([`shm`]); SocketCAN with CiA 402 follows.
//!
//! A sink's `publish` runs inside the real-time cycle: it must not allocate, lock, block or
//! log. Failures are counted and reported outside the cycle.

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
