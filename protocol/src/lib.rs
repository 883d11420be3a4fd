//! Wire and file formats shared by the daemon, the simulated plant and tools.
//!
//! Data layouts, encoders and decoders, no threads and no I/O policy; with the features
//! `socketcan` and `iceoryx2`, the conversions to SocketCAN frames and the one place the
//! shared-memory services are opened.

pub mod api;
#[cfg(feature = "socketcan")]
pub mod can_socket;
pub mod candump;
pub mod cia301;
pub mod cia402;
pub mod jsonrpc;
pub mod shm;

/// Most axes in any payload (one per G-code axis letter X Y Z A B C U V W).
pub const MAX_AXES: usize = 9;
