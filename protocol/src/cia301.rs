//! CANopen application layer (CiA 301) as the CSP bus uses it: classic CAN frames, node-IDs,
//! the COB-IDs of the predefined connection set, NMT node control and NMT states, SYNC, EMCY
//! (error code, error register 0x1001) and the heartbeat (0x1017), and the codec of every frame
//! on the bus ([`Message`], [`decode`]).
//!
//! The daemon is the NMT master and SYNC producer; each axis is one CiA 402 drive node. Per
//! cycle the master sends one RPDO1 per node and then SYNC; the drives apply the setpoints on
//! SYNC and answer with TPDO1. What the PDOs carry is the drive profile's mapping
//! ([`crate::cia402`]: controlword 0x6040 + target position 0x607A in RPDO1, statusword 0x6041 +
//! position actual value 0x6064 in TPDO1); this module puts those bytes on their COB-IDs.
//!
//! Everything here is plain data and pure functions: the socket handling lives with the master
//! and the drives, so the same code decodes live traffic and candump logs. No function in this
//! module panics, whatever the input: bad frames come back as a typed [`DecodeError`] that
//! names the COB-ID, the object and what was wrong, so a receiver can count and drop them.

use crate::cia402::{Rpdo1, Tpdo1};
use std::fmt;

// ---------------------------------------------------------------------------------------------
// Raw CAN frames
// ---------------------------------------------------------------------------------------------

/// Largest 11-bit identifier.
pub const SFF_MAX: u32 = 0x7FF;
/// Largest 29-bit identifier.
pub const EFF_MAX: u32 = 0x1FFF_FFFF;

/// Linux SocketCAN `can_id` flag bits (linux/can.h), for converting to and from the kernel's
/// `struct can_frame` without depending on a socket crate here.
pub mod socketcan_flags {
    /// Extended frame format (29-bit identifier).
    pub const EFF: u32 = 0x8000_0000;
    /// Remote transmission request.
    pub const RTR: u32 = 0x4000_0000;
    /// Error message frame (the identifier holds the error class bits).
    pub const ERR: u32 = 0x2000_0000;
}

/// A CAN identifier: 11-bit standard or 29-bit extended. Only valid values can be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CanId {
    raw: u32,
    extended: bool,
}

impl CanId {
    /// An 11-bit identifier; `None` above 0x7FF.
    pub const fn standard(id: u16) -> Option<CanId> {
        if id as u32 <= SFF_MAX { Some(CanId { raw: id as u32, extended: false }) } else { None }
    }

    /// A 29-bit identifier; `None` above 0x1FFF_FFFF.
    pub const fn extended(id: u32) -> Option<CanId> {
        if id <= EFF_MAX { Some(CanId { raw: id, extended: true }) } else { None }
    }

    /// The identifier without format flags.
    pub const fn raw(self) -> u32 {
        self.raw
    }

    /// Whether this is a 29-bit identifier.
    pub const fn is_extended(self) -> bool {
        self.extended
    }

    /// The standard identifier, or `None` for an extended one. CANopen objects all use 11 bits.
    pub const fn as_standard(self) -> Option<u16> {
        if self.extended { None } else { Some(self.raw as u16) }
    }
}

impl fmt::Display for CanId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended { write!(f, "0x{:08X} (29-bit)", self.raw) } else { write!(f, "0x{:03X}", self.raw) }
    }
}

/// What a frame carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// A data frame (the only kind CANopen PDOs, SYNC, NMT, EMCY and heartbeats use).
    Data,
    /// A remote transmission request: no data, `len` is the requested DLC.
    Remote,
    /// A SocketCAN error message: the identifier holds the error class bits (linux/can/error.h),
    /// the data the details. Produced by the kernel (bus-off, error passive, …), never on the wire.
    Error,
}

/// One classic CAN 2.0 frame (at most 8 data bytes) as plain data. The fields are private so
/// every `Frame` in the program is valid: `len <= 8`, the identifier fits its format, and the
/// bytes past `len` are zero (so derived equality compares only what was on the bus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    id: CanId,
    kind: FrameKind,
    len: u8,
    data: [u8; 8],
}

/// Why a [`Frame`] could not be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("identifier 0x{id:X} does not fit in {bits} bits")]
    IdOutOfRange { id: u32, bits: u8 },
    #[error("{len} data bytes: a classic CAN frame carries at most 8")]
    TooLong { len: usize },
    #[error("SocketCAN id word 0x{word:08X} has both the error and the remote flag set")]
    BadFlags { word: u32 },
}

impl Frame {
    /// A data frame with up to 8 bytes.
    pub fn data(id: CanId, payload: &[u8]) -> Result<Frame, FrameError> {
        Self::build(id, FrameKind::Data, payload)
    }

    /// A data frame on an 11-bit identifier (the CANopen case).
    pub fn standard(id: u16, payload: &[u8]) -> Result<Frame, FrameError> {
        let id = CanId::standard(id).ok_or(FrameError::IdOutOfRange { id: id as u32, bits: 11 })?;
        Self::data(id, payload)
    }

    /// A remote frame requesting `len` bytes (`len <= 8`).
    pub fn remote(id: CanId, len: u8) -> Result<Frame, FrameError> {
        if len > 8 {
            return Err(FrameError::TooLong { len: len as usize });
        }
        Ok(Frame { id, kind: FrameKind::Remote, len, data: [0; 8] })
    }

    /// A SocketCAN error message frame with the error `class` bits (at most 29 bits).
    pub fn error(class: u32, payload: &[u8]) -> Result<Frame, FrameError> {
        let id = CanId::extended(class).ok_or(FrameError::IdOutOfRange { id: class, bits: 29 })?;
        Self::build(id, FrameKind::Error, payload)
    }

    /// From the kernel's representation: `can_id` with the EFF/RTR/ERR flag bits, the DLC and
    /// the data. For remote frames only `dlc` matters.
    pub fn from_socketcan(word: u32, dlc: u8, payload: &[u8]) -> Result<Frame, FrameError> {
        use socketcan_flags::{EFF, ERR, RTR};
        let body = word & EFF_MAX;
        if word & ERR != 0 {
            if word & RTR != 0 {
                return Err(FrameError::BadFlags { word });
            }
            return Self::error(body, payload);
        }
        let id = if word & EFF != 0 {
            CanId::extended(body).ok_or(FrameError::IdOutOfRange { id: body, bits: 29 })?
        } else {
            CanId::standard((word & SFF_MAX) as u16)
                .filter(|_| body <= SFF_MAX)
                .ok_or(FrameError::IdOutOfRange { id: body, bits: 11 })?
        };
        if word & RTR != 0 { Self::remote(id, dlc) } else { Self::data(id, payload) }
    }

    /// The kernel's `can_id` word with the EFF/RTR/ERR flags.
    pub const fn socketcan_id_word(&self) -> u32 {
        use socketcan_flags::{EFF, ERR, RTR};
        match self.kind {
            FrameKind::Error => self.id.raw | ERR,
            FrameKind::Remote => self.id.raw | RTR | if self.id.extended { EFF } else { 0 },
            FrameKind::Data => self.id.raw | if self.id.extended { EFF } else { 0 },
        }
    }

    fn build(id: CanId, kind: FrameKind, payload: &[u8]) -> Result<Frame, FrameError> {
        if payload.len() > 8 {
            return Err(FrameError::TooLong { len: payload.len() });
        }
        let mut data = [0u8; 8];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Frame { id, kind, len: payload.len() as u8, data })
    }

    /// The identifier (for error frames: the error class bits).
    pub const fn id(&self) -> CanId {
        self.id
    }

    /// Data, remote or error frame.
    pub const fn kind(&self) -> FrameKind {
        self.kind
    }

    /// Data length code, 0..=8 (for remote frames: the requested length).
    pub const fn len(&self) -> u8 {
        self.len
    }

    /// Whether the frame carries no data bytes.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The data bytes (empty for remote frames).
    pub fn payload(&self) -> &[u8] {
        match self.kind {
            FrameKind::Remote => &[],
            _ => &self.data[..self.len as usize],
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Node-IDs and COB-IDs
// ---------------------------------------------------------------------------------------------

/// A CANopen node-ID, 1..=127.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u8);

impl NodeId {
    /// `None` outside 1..=127 (0 addresses all nodes in NMT and is not a node).
    pub const fn new(id: u8) -> Option<NodeId> {
        if id >= 1 && id <= 127 { Some(NodeId(id)) } else { None }
    }

    pub const fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The predefined connection set of CiA 301 (the COB-IDs this project uses).
pub mod cob {
    use super::NodeId;

    /// NMT node control, sent by the master.
    pub const NMT: u16 = 0x000;
    /// SYNC, sent by the master once per cycle after the RPDOs.
    pub const SYNC: u16 = 0x080;
    /// EMCY base: node n sends on 0x080 + n.
    pub const EMCY_BASE: u16 = 0x080;
    /// TPDO1 base: node n sends statusword + position actual value on 0x180 + n.
    pub const TPDO1_BASE: u16 = 0x180;
    /// RPDO1 base: node n receives controlword + target position on 0x200 + n.
    pub const RPDO1_BASE: u16 = 0x200;
    /// NMT error control (heartbeat) base: node n sends on 0x700 + n.
    pub const HEARTBEAT_BASE: u16 = 0x700;
    /// SDO server → client base: node n answers on 0x580 + n.
    pub const SDO_TX_BASE: u16 = 0x580;
    /// SDO client → server base: node n listens on 0x600 + n.
    pub const SDO_RX_BASE: u16 = 0x600;

    /// COB-ID on which a client sends SDO requests to `node`.
    pub const fn sdo_request(node: NodeId) -> u16 {
        SDO_RX_BASE + node.get() as u16
    }
    /// COB-ID on which `node` answers SDO requests.
    pub const fn sdo_response(node: NodeId) -> u16 {
        SDO_TX_BASE + node.get() as u16
    }

    pub const fn emcy(node: NodeId) -> u16 {
        EMCY_BASE + node.get() as u16
    }
    pub const fn tpdo1(node: NodeId) -> u16 {
        TPDO1_BASE + node.get() as u16
    }
    pub const fn rpdo1(node: NodeId) -> u16 {
        RPDO1_BASE + node.get() as u16
    }
    pub const fn heartbeat(node: NodeId) -> u16 {
        HEARTBEAT_BASE + node.get() as u16
    }
}

// ---------------------------------------------------------------------------------------------
// NMT
// ---------------------------------------------------------------------------------------------

/// NMT node control command specifiers (CiA 301 7.2.8.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NmtCommand {
    Start,
    Stop,
    EnterPreOperational,
    ResetNode,
    ResetCommunication,
}

impl NmtCommand {
    pub const fn code(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
        }
    }

    pub const fn from_code(code: u8) -> Option<NmtCommand> {
        match code {
            0x01 => Some(NmtCommand::Start),
            0x02 => Some(NmtCommand::Stop),
            0x80 => Some(NmtCommand::EnterPreOperational),
            0x81 => Some(NmtCommand::ResetNode),
            0x82 => Some(NmtCommand::ResetCommunication),
            _ => None,
        }
    }
}

/// NMT states as reported in the heartbeat (CiA 301 7.2.8.3.2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NmtState {
    /// The boot-up message (sent once after initialisation, then the node is pre-operational).
    BootUp,
    Stopped,
    Operational,
    PreOperational,
}

impl NmtState {
    pub const fn code(self) -> u8 {
        match self {
            NmtState::BootUp => 0x00,
            NmtState::Stopped => 0x04,
            NmtState::Operational => 0x05,
            NmtState::PreOperational => 0x7F,
        }
    }

    /// Decodes a heartbeat state byte. Exact values only: bit 7 is the node-guarding toggle bit,
    /// and node guarding is not used here, so a set bit 7 is an error rather than ignored
    /// (ignoring it would also make decode → encode lossy).
    pub const fn from_code(code: u8) -> Option<NmtState> {
        match code {
            0x00 => Some(NmtState::BootUp),
            0x04 => Some(NmtState::Stopped),
            0x05 => Some(NmtState::Operational),
            0x7F => Some(NmtState::PreOperational),
            _ => None,
        }
    }

    /// The node-side NMT state machine (CiA 301 figure 48). Reset commands return `BootUp`: the
    /// node re-initialises, sends its boot-up message and then enters `PreOperational` by itself
    /// (see [`NmtState::after_boot_up`]).
    pub const fn apply(self, command: NmtCommand) -> NmtState {
        match command {
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => NmtState::BootUp,
            // A node still initialising only reacts to resets.
            _ if matches!(self, NmtState::BootUp) => NmtState::BootUp,
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::EnterPreOperational => NmtState::PreOperational,
        }
    }

    /// The automatic transition after the boot-up message has been sent.
    pub const fn after_boot_up(self) -> NmtState {
        match self {
            NmtState::BootUp => NmtState::PreOperational,
            other => other,
        }
    }

    /// Whether PDOs may be exchanged in this state (only in Operational, CiA 301 table 80).
    pub const fn pdo_allowed(self) -> bool {
        matches!(self, NmtState::Operational)
    }
}

impl fmt::Display for NmtState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NmtState::BootUp => "boot-up",
            NmtState::Stopped => "stopped",
            NmtState::Operational => "operational",
            NmtState::PreOperational => "pre-operational",
        })
    }
}

// ---------------------------------------------------------------------------------------------
// EMCY
// ---------------------------------------------------------------------------------------------

/// An emergency message (CiA 301 7.2.7.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Emcy {
    /// Emergency error code (0x0000 = error reset / no error); see [`emcy_code`].
    pub error_code: u16,
    /// 0x1001 error register at the time of the message.
    pub error_register: u8,
    /// Manufacturer-specific error field.
    pub vendor: [u8; 5],
}

/// Emergency error codes used by the master and the simulated drives (CiA 301 table 21,
/// CiA 402-2 annex).
pub mod emcy_code {
    pub const NO_ERROR: u16 = 0x0000;
    pub const GENERIC: u16 = 0x1000;
    /// Communication, generic: the simulated drive's SYNC watchdog (vendor byte 0 = 1).
    pub const COMMUNICATION: u16 = 0x8100;
    pub const CAN_OVERRUN: u16 = 0x8110;
    pub const CAN_ERROR_PASSIVE: u16 = 0x8120;
    pub const HEARTBEAT: u16 = 0x8130;
    pub const RECOVERED_FROM_BUS_OFF: u16 = 0x8140;
    pub const PDO_LENGTH: u16 = 0x8210;
    pub const PDO_LENGTH_EXCEEDED: u16 = 0x8220;
    pub const UNEXPECTED_SYNC_LENGTH: u16 = 0x8240;
    pub const RPDO_TIMEOUT: u16 = 0x8250;
    /// CiA 402: following error (position deviation too large).
    pub const FOLLOWING_ERROR: u16 = 0x8611;

    /// What an emergency error code (and the CiA 402 error code 0x603F, which holds the same)
    /// means: the exact entry of CiA 301 table 21 or the CiA 402-2 annex where there is one,
    /// else the class its high byte names.
    pub fn text(code: u16) -> &'static str {
        const EXACT: [(u16, &str); 30] = [
            (0x0000, "error reset or no error"),
            (0x1000, "generic error"),
            (0x2310, "continuous over-current"),
            (0x2320, "short circuit at the motor"),
            (0x3110, "mains over-voltage"),
            (0x3120, "mains under-voltage"),
            (0x3210, "DC link over-voltage"),
            (0x3220, "DC link under-voltage"),
            (0x4210, "excess temperature of the device"),
            (0x4310, "excess temperature of the drive"),
            (0x5441, "enable input off (safe torque off)"),
            (0x6010, "software reset (watchdog)"),
            (0x7121, "motor blocked"),
            (0x7305, "incremental sensor 1 fault"),
            (0x7500, "communication error"),
            (0x8100, "communication: generic"),
            (0x8110, "CAN overrun (objects lost)"),
            (0x8120, "CAN in error passive mode"),
            (0x8130, "life guard or heartbeat error"),
            (0x8140, "recovered from bus-off"),
            (0x8150, "CAN-ID collision"),
            (0x8210, "PDO not processed due to length error"),
            (0x8220, "PDO length exceeded"),
            (0x8240, "unexpected SYNC data length"),
            (0x8250, "RPDO timeout"),
            (0x8400, "velocity speed controller"),
            (0x8611, "following error"),
            (0x8612, "reference limit"),
            (0xFF00, "device-specific"),
            (0x9000, "external error"),
        ];
        if let Some((_, t)) = EXACT.iter().find(|(c, _)| *c == code) {
            return t;
        }
        match code >> 8 {
            0x10 => "generic error",
            0x20..=0x2F => "current",
            0x30..=0x3F => "voltage",
            0x40..=0x4F => "temperature",
            0x50..=0x5F => "device hardware",
            0x60..=0x6F => "device software",
            0x70..=0x7F => "additional modules",
            0x80..=0x8F => "monitoring",
            0x90..=0x9F => "external error",
            0xF0 => "additional functions",
            0xFF => "device-specific",
            _ => "not defined by CiA 301 or CiA 402",
        }
    }
}

/// Error register (0x1001) bits.
pub mod error_register {
    pub const GENERIC: u8 = 1 << 0;
    pub const CURRENT: u8 = 1 << 1;
    pub const VOLTAGE: u8 = 1 << 2;
    pub const TEMPERATURE: u8 = 1 << 3;
    pub const COMMUNICATION: u8 = 1 << 4;
    pub const DEVICE_PROFILE: u8 = 1 << 5;
    pub const MANUFACTURER: u8 = 1 << 7;
}

// ---------------------------------------------------------------------------------------------
// Messages of the predefined connection set
// ---------------------------------------------------------------------------------------------

/// A decoded CANopen frame of the predefined connection set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Message {
    /// NMT node control; `target: None` addresses all nodes (node-ID 0 on the wire).
    Nmt {
        command: NmtCommand,
        target: Option<NodeId>,
    },
    /// SYNC, with the optional counter byte (CiA 301 allows DLC 0 or 1).
    Sync {
        counter: Option<u8>,
    },
    Emcy {
        node: NodeId,
        emcy: Emcy,
    },
    Tpdo1 {
        node: NodeId,
        pdo: Tpdo1,
    },
    Rpdo1 {
        node: NodeId,
        pdo: Rpdo1,
    },
    Heartbeat {
        node: NodeId,
        state: NmtState,
    },
}

/// Why a frame is not a valid message of the predefined connection set. Each variant names the
/// COB-ID and the object, so a counter per variant tells an operator what is on the bus.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("COB-ID {id} ({object}): DLC {got}, expected {expected}")]
    WrongDlc { id: CanId, object: &'static str, expected: &'static str, got: u8 },
    #[error("COB-ID {id}: not an object of the CANopen predefined connection set used here")]
    UnknownCobId { id: CanId },
    #[error("COB-ID {id} ({object}): {field} 0x{value:X} is not defined")]
    BadValue { id: CanId, object: &'static str, field: &'static str, value: u32 },
    #[error("COB-ID {id}: {kind:?} frame, CANopen objects here are data frames")]
    NotDataFrame { id: CanId, kind: FrameKind },
}

fn frame(id: u16, payload: &[u8]) -> Frame {
    // Every COB-ID built in this module is at most 0x77F and every payload at most 8 bytes,
    // so the checked constructor cannot fail; build the frame directly to keep that total.
    let mut data = [0u8; 8];
    let n = payload.len().min(8);
    data[..n].copy_from_slice(&payload[..n]);
    Frame { id: CanId { raw: (id as u32) & SFF_MAX, extended: false }, kind: FrameKind::Data, len: n as u8, data }
}

impl Message {
    /// The frame that carries this message (little-endian, as CANopen requires).
    pub fn encode(&self) -> Frame {
        match *self {
            Message::Nmt { command, target } => frame(cob::NMT, &[command.code(), target.map_or(0, NodeId::get)]),
            Message::Sync { counter: None } => frame(cob::SYNC, &[]),
            Message::Sync { counter: Some(c) } => frame(cob::SYNC, &[c]),
            Message::Emcy { node, emcy } => {
                let [c0, c1] = emcy.error_code.to_le_bytes();
                let v = emcy.vendor;
                frame(cob::emcy(node), &[c0, c1, emcy.error_register, v[0], v[1], v[2], v[3], v[4]])
            }
            Message::Tpdo1 { node, pdo } => frame(cob::tpdo1(node), &pdo.to_bytes()),
            Message::Rpdo1 { node, pdo } => frame(cob::rpdo1(node), &pdo.to_bytes()),
            Message::Heartbeat { node, state } => frame(cob::heartbeat(node), &[state.code()]),
        }
    }

    /// The node a message comes from or goes to (`None` for SYNC and broadcast NMT).
    pub const fn node(&self) -> Option<NodeId> {
        match *self {
            Message::Nmt { target, .. } => target,
            Message::Sync { .. } => None,
            Message::Emcy { node, .. }
            | Message::Tpdo1 { node, .. }
            | Message::Rpdo1 { node, .. }
            | Message::Heartbeat { node, .. } => Some(node),
        }
    }
}

/// The object a standard COB-ID belongs to in the predefined connection set, with its node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CobObject {
    Nmt,
    Sync,
    Emcy(NodeId),
    Tpdo1(NodeId),
    Rpdo1(NodeId),
    Heartbeat(NodeId),
}

impl CobObject {
    /// Classifies a COB-ID; `None` for identifiers this project does not use (TIME, SDO, the
    /// other PDOs, LSS, node-ID 0 on the per-node objects, 29-bit identifiers).
    pub const fn classify(id: CanId) -> Option<CobObject> {
        let Some(raw) = id.as_standard() else { return None };
        let base = raw & 0x780;
        let node = NodeId::new((raw & 0x07F) as u8);
        match (raw, base, node) {
            (cob::NMT, _, _) => Some(CobObject::Nmt),
            (cob::SYNC, _, _) => Some(CobObject::Sync),
            (_, cob::EMCY_BASE, Some(n)) => Some(CobObject::Emcy(n)),
            (_, cob::TPDO1_BASE, Some(n)) => Some(CobObject::Tpdo1(n)),
            (_, cob::RPDO1_BASE, Some(n)) => Some(CobObject::Rpdo1(n)),
            (_, cob::HEARTBEAT_BASE, Some(n)) => Some(CobObject::Heartbeat(n)),
            _ => None,
        }
    }

    pub const fn name(self) -> &'static str {
        match self {
            CobObject::Nmt => "NMT",
            CobObject::Sync => "SYNC",
            CobObject::Emcy(_) => "EMCY",
            CobObject::Tpdo1(_) => "TPDO1",
            CobObject::Rpdo1(_) => "RPDO1",
            CobObject::Heartbeat(_) => "heartbeat",
        }
    }
}

/// Decodes any frame. Total: every input gives a message or a [`DecodeError`], never a panic.
///
/// DLCs are strict: a PDO must have exactly its mapped length of 6 bytes. CiA 301 has a drive
/// answer a short RPDO with EMCY 0x8210 and a long one with 0x8220; the caller chooses the
/// reaction from the `got` field.
pub fn decode(f: &Frame) -> Result<Message, DecodeError> {
    let id = f.id();
    if f.kind() != FrameKind::Data {
        return Err(DecodeError::NotDataFrame { id, kind: f.kind() });
    }
    let Some(object) = CobObject::classify(id) else {
        return Err(DecodeError::UnknownCobId { id });
    };
    let d = f.payload();
    let name = object.name();
    let wrong_dlc = |expected: &'static str| DecodeError::WrongDlc { id, object: name, expected, got: f.len() };
    let bad = |field: &'static str, value: u32| DecodeError::BadValue { id, object: name, field, value };
    match object {
        CobObject::Nmt => {
            if d.len() != 2 {
                return Err(wrong_dlc("2"));
            }
            let command = NmtCommand::from_code(d[0]).ok_or(bad("command specifier", d[0] as u32))?;
            let target = match d[1] {
                0 => None,
                n => Some(NodeId::new(n).ok_or(bad("node-ID", n as u32))?),
            };
            Ok(Message::Nmt { command, target })
        }
        CobObject::Sync => match d {
            [] => Ok(Message::Sync { counter: None }),
            [c] => Ok(Message::Sync { counter: Some(*c) }),
            _ => Err(wrong_dlc("0 or 1")),
        },
        CobObject::Emcy(node) => {
            let Ok(b) = <[u8; 8]>::try_from(d) else { return Err(wrong_dlc("8")) };
            let emcy = Emcy {
                error_code: u16::from_le_bytes([b[0], b[1]]),
                error_register: b[2],
                vendor: [b[3], b[4], b[5], b[6], b[7]],
            };
            Ok(Message::Emcy { node, emcy })
        }
        CobObject::Tpdo1(node) => {
            let Ok(b) = <[u8; Tpdo1::LEN]>::try_from(d) else { return Err(wrong_dlc("6")) };
            Ok(Message::Tpdo1 { node, pdo: Tpdo1::from_bytes(b) })
        }
        CobObject::Rpdo1(node) => {
            let Ok(b) = <[u8; Rpdo1::LEN]>::try_from(d) else { return Err(wrong_dlc("6")) };
            Ok(Message::Rpdo1 { node, pdo: Rpdo1::from_bytes(b) })
        }
        CobObject::Heartbeat(node) => {
            if d.len() != 1 {
                return Err(wrong_dlc("1"));
            }
            let state = NmtState::from_code(d[0]).ok_or(bad("NMT state", d[0] as u32))?;
            Ok(Message::Heartbeat { node, state })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).expect("valid node")
    }

    #[test]
    fn cob_ids_follow_the_predefined_connection_set() {
        let n = node(5);
        assert_eq!((cob::emcy(n), cob::tpdo1(n), cob::rpdo1(n), cob::heartbeat(n)), (0x085, 0x185, 0x205, 0x705));
        assert_eq!(NodeId::new(0), None);
        assert_eq!(NodeId::new(128), None);
        assert_eq!(cob::heartbeat(node(127)), 0x77F);
    }

    #[test]
    fn rpdo_and_tpdo_are_little_endian_dlc_6() {
        let f = Message::Rpdo1 { node: node(1), pdo: Rpdo1 { controlword: 0x000F, target_position: -2 } }.encode();
        assert_eq!(f.id(), CanId::standard(0x201).unwrap());
        assert_eq!(f.payload(), &[0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF]);
        let f =
            Message::Tpdo1 { node: node(3), pdo: Tpdo1 { statusword: 0x1237, position_actual: 0x0102_0304 } }.encode();
        assert_eq!(f.id().raw(), 0x183);
        assert_eq!(f.payload(), &[0x37, 0x12, 0x04, 0x03, 0x02, 0x01]);
    }

    #[test]
    fn every_message_round_trips() {
        let emcy = Emcy { error_code: 0x8611, error_register: 0x21, vendor: [1, 2, 3, 4, 5] };
        let msgs = [
            Message::Nmt { command: NmtCommand::Start, target: None },
            Message::Nmt { command: NmtCommand::ResetCommunication, target: Some(node(127)) },
            Message::Sync { counter: None },
            Message::Sync { counter: Some(17) },
            Message::Emcy { node: node(2), emcy },
            Message::Tpdo1 { node: node(9), pdo: Tpdo1 { statusword: 0x0627, position_actual: i32::MIN } },
            Message::Rpdo1 { node: node(1), pdo: Rpdo1 { controlword: 0x000F, target_position: i32::MAX } },
            Message::Heartbeat { node: node(4), state: NmtState::PreOperational },
            Message::Heartbeat { node: node(4), state: NmtState::BootUp },
        ];
        for m in msgs {
            assert_eq!(decode(&m.encode()), Ok(m), "{m:?}");
        }
    }

    #[test]
    fn malformed_frames_give_typed_errors() {
        let short = Frame::standard(0x201, &[0x0F, 0, 0, 0]).unwrap();
        match decode(&short) {
            Err(DecodeError::WrongDlc { object: "RPDO1", got: 4, expected: "6", .. }) => {}
            other => panic!("{other:?}"),
        }
        let e = decode(&short).unwrap_err().to_string();
        assert_eq!(e, "COB-ID 0x201 (RPDO1): DLC 4, expected 6");
        for id in [0x100, 0x180, 0x200, 0x700, 0x581, 0x601, 0x281, 0x7E5] {
            let f = Frame::standard(id, &[0; 8]).unwrap();
            assert!(matches!(decode(&f), Err(DecodeError::UnknownCobId { .. })), "0x{id:X}");
        }
        let ext = Frame::data(CanId::extended(0x201).unwrap(), &[0; 6]).unwrap();
        assert!(matches!(decode(&ext), Err(DecodeError::UnknownCobId { .. })));
        let rtr = Frame::remote(CanId::standard(0x701).unwrap(), 1).unwrap();
        assert!(matches!(decode(&rtr), Err(DecodeError::NotDataFrame { kind: FrameKind::Remote, .. })));
        let bad_nmt = Frame::standard(0x000, &[0x03, 0]).unwrap();
        assert!(matches!(decode(&bad_nmt), Err(DecodeError::BadValue { field: "command specifier", value: 3, .. })));
        let bad_node = Frame::standard(0x000, &[0x01, 200]).unwrap();
        assert!(matches!(decode(&bad_node), Err(DecodeError::BadValue { field: "node-ID", value: 200, .. })));
        let bad_hb = Frame::standard(0x701, &[0x42]).unwrap();
        assert!(matches!(decode(&bad_hb), Err(DecodeError::BadValue { field: "NMT state", .. })));
        let sync2 = Frame::standard(0x080, &[1, 2]).unwrap();
        assert!(matches!(decode(&sync2), Err(DecodeError::WrongDlc { expected: "0 or 1", .. })));
    }

    /// A small deterministic generator: the decoder must be total over every COB-ID and DLC.
    #[test]
    fn decoder_is_total_over_all_standard_ids_and_dlcs() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for id in 0..=0x7FFu16 {
            for len in 0..=8usize {
                let bytes = next().to_le_bytes();
                let f = Frame::standard(id, &bytes[..len]).unwrap();
                if let Ok(m) = decode(&f) {
                    assert_eq!(m.encode(), f, "re-encoding 0x{id:03X} len {len}");
                }
            }
        }
    }

    #[test]
    fn emergency_codes_have_their_meaning() {
        assert_eq!(emcy_code::text(0x8611), "following error");
        assert_eq!(emcy_code::text(0x8100), "communication: generic");
        assert_eq!(emcy_code::text(0x2399), "current");
        assert_eq!(emcy_code::text(0x0100), "not defined by CiA 301 or CiA 402");
    }

    #[test]
    fn nmt_state_machine() {
        use NmtState::*;
        assert_eq!(BootUp.after_boot_up(), PreOperational);
        assert_eq!(PreOperational.apply(NmtCommand::Start), Operational);
        assert_eq!(Operational.apply(NmtCommand::Stop), Stopped);
        assert_eq!(Stopped.apply(NmtCommand::EnterPreOperational), PreOperational);
        assert_eq!(Operational.apply(NmtCommand::ResetNode), BootUp);
        assert_eq!(BootUp.apply(NmtCommand::Start), BootUp);
        assert!(Operational.pdo_allowed() && !PreOperational.pdo_allowed());
        assert_eq!(NmtState::from_code(0x85), None, "node-guarding toggle bit is not a heartbeat");
    }

    #[test]
    fn socketcan_id_words_round_trip() {
        let cases = [
            Frame::standard(0x201, &[1, 2, 3]).unwrap(),
            Frame::data(CanId::extended(0x1ABC_DEF0).unwrap(), &[9]).unwrap(),
            Frame::data(CanId::extended(0x5).unwrap(), &[]).unwrap(),
            Frame::remote(CanId::standard(0x701).unwrap(), 1).unwrap(),
            Frame::remote(CanId::extended(0x701).unwrap(), 8).unwrap(),
            Frame::error(0x0000_0040, &[0; 8]).unwrap(),
        ];
        for f in cases {
            let back = Frame::from_socketcan(f.socketcan_id_word(), f.len(), f.payload()).unwrap();
            assert_eq!(back, f);
        }
        assert_eq!(Frame::standard(0x201, &[]).unwrap().socketcan_id_word(), 0x201);
        assert!(Frame::from_socketcan(0x800, 0, &[]).is_err(), "11-bit frame with a 12-bit id");
        assert!(Frame::from_socketcan(0x6000_0000, 0, &[]).is_err());
        assert!(Frame::standard(0x800, &[]).is_err());
        assert!(Frame::standard(0x1, &[0; 9]).is_err());
        assert!(Frame::remote(CanId::standard(1).unwrap(), 9).is_err());
    }
}
