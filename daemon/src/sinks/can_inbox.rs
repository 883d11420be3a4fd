//! The boot thread's inbox: what the receive thread (SDO responses, heartbeats, boot-up
//! messages) and the commissioning commands (`can_command`) hand it. Its own file, so the bus's
//! shared state (`can_state`) can hold the inbox's sender without depending on the boot thread.

use super::drive_command::SdoOp;
use interpd_canopen::sdo_client::SdoError;
use interpd_protocol::cia301::Frame;
use std::sync::mpsc::Sender;

/// What the receive thread hands the boot thread.
#[derive(Debug, Clone)]
pub enum BootInput {
    /// An SDO response or a heartbeat of a configured node.
    Frame(Frame),
    /// A node sent its boot-up message: it is not (or no longer) configured.
    Rebooted(usize),
    /// A commissioning transfer (`drives.sdo_read`, `drives.sdo_write`).
    Sdo(SdoRequest),
}

/// One commissioning transfer with the node of axis `index`; the outcome goes to `reply`.
#[derive(Debug, Clone)]
pub struct SdoRequest {
    pub index: usize,
    pub op: SdoOp,
    pub reply: Sender<Result<Vec<u8>, SdoError>>,
}
