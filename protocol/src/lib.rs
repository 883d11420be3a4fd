//! Wire and file formats shared by the daemon, the simulated plant and tools.
//!
//! Only data layouts, encoders and decoders live here: no threads, no I/O policy.

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
