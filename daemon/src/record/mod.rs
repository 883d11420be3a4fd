//! Recording and replay of the shared-memory streams as MCAP (docs/formats.md).
//!
//! - [`schema`]: the documented schema (OMG IDL, CDR messages byte-identical to the
//!   `#[repr(C)]` payloads after a 4-byte header) and payload validation;
//! - [`file`](mod@file): writing and reading the MCAP file;
//! - [`recorder`]: a non-real-time thread that subscribes to `<prefix>/setpoints` and
//!   `<prefix>/feedback` and records every sample, counting lost cycles ([`gaps`]), in an
//!   order that depends on the streams' contents only ([`interleave`]);
//! - [`replay`]: validates a recording, then republishes it at its original timing.

pub mod file;
pub mod gaps;
pub mod interleave;
pub mod recorder;
pub mod replay;
pub mod schema;

pub use file::{RecordFile, Recorded, read_messages};
pub use recorder::{RecordOptions, RecordReport, Recorder};

use std::path::PathBuf;

/// Why recording or replay failed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum RecordError {
    /// The file cannot be created or opened (bad input: exit 2).
    #[error("{}: {message}", path.display())]
    Open { path: PathBuf, message: String },
    /// The file is not a readable MCAP file (bad input).
    #[error("{}: not a valid MCAP recording at message {index}: {message}", path.display())]
    Corrupt { path: PathBuf, index: u64, message: String },
    /// A message is not a valid interpd payload (bad input).
    #[error("{}: message {index} on `{topic}`: {message}", path.display())]
    Message { path: PathBuf, index: u64, topic: String, message: String },
    /// The file holds no message (bad input).
    #[error("{}: the recording holds no message", path.display())]
    Empty { path: PathBuf },
    /// Writing the file failed.
    #[error("{}: cannot write: {message}", path.display())]
    Write { path: PathBuf, message: String },
    /// iceoryx2 or thread set-up failed.
    #[error("{0}")]
    Setup(String),
    /// iceoryx2 failed while running.
    #[error("{0}")]
    Transport(String),
}

impl RecordError {
    /// True for errors caused by the input file (exit code 2), false for failures (exit 1).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            RecordError::Open { .. }
                | RecordError::Corrupt { .. }
                | RecordError::Message { .. }
                | RecordError::Empty { .. }
        )
    }
}
