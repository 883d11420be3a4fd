//! Wire and file formats shared by the daemon, the simulated plant and tools.
//!
//! Only data layouts, encoders and decoders live here: no threads, no I/O policy.
