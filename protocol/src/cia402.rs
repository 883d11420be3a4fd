//! CANopen (CiA 301) and CiA 402 frames for cyclic synchronous position (CSP) streaming.
//!
//! The daemon is the NMT master and SYNC producer; each axis is one CiA 402 drive node. Per
//! cycle the master sends one RPDO1 per node (controlword 0x6040 + target position 0x607A) and
//! then SYNC; the drives apply the setpoints on SYNC and answer with TPDO1 (statusword 0x6041 +
//! position actual value 0x6064). Everything here is plain data and pure functions: the socket
//! handling lives with the master and the drives, so the same code decodes live traffic and
//! candump logs.
//!
//! No function in this module panics, whatever the input: bad frames come back as a typed
//! [`DecodeError`] that names the COB-ID, the object and what was wrong, so a receiver can count
//! and drop them.

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
// CiA 402 power drive system state machine
// ---------------------------------------------------------------------------------------------

/// Controlword (0x6040) values for the device control commands (CiA 402-2, table 32). Bits:
/// 0 switch on, 1 enable voltage, 2 quick stop (active low), 3 enable operation, 7 fault reset
/// (rising edge), 8 halt.
pub mod controlword {
    pub const SWITCH_ON_BIT: u16 = 1 << 0;
    pub const ENABLE_VOLTAGE_BIT: u16 = 1 << 1;
    /// Active low: 0 requests a quick stop.
    pub const QUICK_STOP_BIT: u16 = 1 << 2;
    pub const ENABLE_OPERATION_BIT: u16 = 1 << 3;
    pub const FAULT_RESET_BIT: u16 = 1 << 7;
    pub const HALT_BIT: u16 = 1 << 8;

    /// Transitions 2, 6, 8 → Ready to switch on.
    pub const SHUTDOWN: u16 = 0x0006;
    /// Transition 3 → Switched on.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Transition 5 (Operation enabled → Switched on); the same bits as `SWITCH_ON`.
    pub const DISABLE_OPERATION: u16 = 0x0007;
    /// Transitions 4, 16 → Operation enabled (from Ready to switch on: 3 then 4 automatically).
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Transitions 7, 9, 10, 12 → Switch on disabled.
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Transitions 7, 10, 11 → Quick stop active or Switch on disabled.
    pub const QUICK_STOP: u16 = 0x0002;
    /// Transition 15 (Fault → Switch on disabled) on the rising edge of bit 7.
    pub const FAULT_RESET: u16 = 0x0080;
}

/// The device control command encoded in controlword bits 0–3 (CiA 402-2 table 32). Every bit
/// pattern maps to exactly one command, checked in the table's priority order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DriveCommand {
    /// x x 0 x: bit 1 (enable voltage) clear.
    DisableVoltage,
    /// x 0 1 x: bit 2 (quick stop, active low) clear.
    QuickStop,
    /// x 1 1 0.
    Shutdown,
    /// 0 1 1 1: switch on, or disable operation when operation is enabled.
    SwitchOn,
    /// 1 1 1 1: enable operation (switch on + enable operation from Ready to switch on).
    EnableOperation,
}

impl DriveCommand {
    pub const fn from_controlword(cw: u16) -> DriveCommand {
        use controlword::*;
        if cw & ENABLE_VOLTAGE_BIT == 0 {
            DriveCommand::DisableVoltage
        } else if cw & QUICK_STOP_BIT == 0 {
            DriveCommand::QuickStop
        } else if cw & SWITCH_ON_BIT == 0 {
            DriveCommand::Shutdown
        } else if cw & ENABLE_OPERATION_BIT == 0 {
            DriveCommand::SwitchOn
        } else {
            DriveCommand::EnableOperation
        }
    }
}

/// The states of the CiA 402 power drive system state machine (CiA 402-2 figure 32).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PowerState {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
}

/// Statusword (0x6041) bits (CiA 402-2 table 30).
pub mod statusword {
    pub const READY_TO_SWITCH_ON_BIT: u16 = 1 << 0;
    pub const SWITCHED_ON_BIT: u16 = 1 << 1;
    pub const OPERATION_ENABLED_BIT: u16 = 1 << 2;
    pub const FAULT_BIT: u16 = 1 << 3;
    pub const VOLTAGE_ENABLED_BIT: u16 = 1 << 4;
    /// Active low: 0 while a quick stop is active.
    pub const QUICK_STOP_BIT: u16 = 1 << 5;
    pub const SWITCH_ON_DISABLED_BIT: u16 = 1 << 6;
    pub const WARNING_BIT: u16 = 1 << 7;
    pub const REMOTE_BIT: u16 = 1 << 9;
    pub const TARGET_REACHED_BIT: u16 = 1 << 10;
    pub const INTERNAL_LIMIT_BIT: u16 = 1 << 11;
    /// CSP: drive follows the command value.
    pub const CSP_FOLLOWING_BIT: u16 = 1 << 12;
    /// CSP: following error.
    pub const CSP_FOLLOWING_ERROR_BIT: u16 = 1 << 13;
}

/// The statusword mask/value table of CiA 402-2 table 31, one row per state.
const STATUSWORD_TABLE: [(u16, u16, PowerState); 8] = [
    (0x004F, 0x0000, PowerState::NotReadyToSwitchOn),
    (0x004F, 0x0040, PowerState::SwitchOnDisabled),
    (0x006F, 0x0021, PowerState::ReadyToSwitchOn),
    (0x006F, 0x0023, PowerState::SwitchedOn),
    (0x006F, 0x0027, PowerState::OperationEnabled),
    (0x006F, 0x0007, PowerState::QuickStopActive),
    (0x004F, 0x000F, PowerState::FaultReactionActive),
    (0x004F, 0x0008, PowerState::Fault),
];

impl PowerState {
    /// Decodes the state from a statusword; `None` for bit patterns the table does not define
    /// (e.g. 0x0001 or 0x0041).
    pub const fn from_statusword(sw: u16) -> Option<PowerState> {
        let mut i = 0;
        while i < STATUSWORD_TABLE.len() {
            let (mask, value, state) = STATUSWORD_TABLE[i];
            if sw & mask == value {
                return Some(state);
            }
            i += 1;
        }
        None
    }

    /// The state bits of the statusword (bits 0–3, 5, 6) for this state; the drive ORs in the
    /// other bits (voltage enabled, remote, target reached, …). Bit 5 is set wherever the table
    /// leaves it free, since 0 there would mean "quick stop active".
    pub const fn statusword_bits(self) -> u16 {
        match self {
            PowerState::NotReadyToSwitchOn => 0x0000,
            PowerState::SwitchOnDisabled => 0x0040,
            PowerState::ReadyToSwitchOn => 0x0021,
            PowerState::SwitchedOn => 0x0023,
            PowerState::OperationEnabled => 0x0027,
            PowerState::QuickStopActive => 0x0007,
            PowerState::FaultReactionActive => 0x000F,
            PowerState::Fault => 0x0008,
        }
    }

    /// Whether the drive follows setpoints (and holds torque) in this state.
    pub const fn is_operation_enabled(self) -> bool {
        matches!(self, PowerState::OperationEnabled)
    }

    /// Whether the drive is in Fault reaction active or Fault.
    pub const fn is_fault(self) -> bool {
        matches!(self, PowerState::FaultReactionActive | PowerState::Fault)
    }

    /// Snake-case name for status reports (`operation_enabled`, …).
    pub const fn name(self) -> &'static str {
        match self {
            PowerState::NotReadyToSwitchOn => "not_ready_to_switch_on",
            PowerState::SwitchOnDisabled => "switch_on_disabled",
            PowerState::ReadyToSwitchOn => "ready_to_switch_on",
            PowerState::SwitchedOn => "switched_on",
            PowerState::OperationEnabled => "operation_enabled",
            PowerState::QuickStopActive => "quick_stop_active",
            PowerState::FaultReactionActive => "fault_reaction_active",
            PowerState::Fault => "fault",
        }
    }
}

impl fmt::Display for PowerState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PowerState::NotReadyToSwitchOn => "Not ready to switch on",
            PowerState::SwitchOnDisabled => "Switch on disabled",
            PowerState::ReadyToSwitchOn => "Ready to switch on",
            PowerState::SwitchedOn => "Switched on",
            PowerState::OperationEnabled => "Operation enabled",
            PowerState::QuickStopActive => "Quick stop active",
            PowerState::FaultReactionActive => "Fault reaction active",
            PowerState::Fault => "Fault",
        })
    }
}

/// Drive side: the state after receiving `controlword` in `state` (CiA 402-2 figure 32,
/// transitions 2–12 and 15 — the controlword-driven ones). One transition per call: with
/// ENABLE_OPERATION in Ready to switch on the drive goes to Switched on, and to Operation
/// enabled on the next evaluation, as transition 3 "followed automatically by 4" describes.
///
/// Bit 7 (fault reset) is taken as the edge-detected request: a drive that tracks the previous
/// controlword uses [`PowerStateMachine`], which passes bit 7 on only at its rising edge.
///
/// Quick stop option code 2 (0x605A; slow down on the quick stop ramp, then Switch on
/// disabled) is modelled: Quick stop active leaves only by Disable voltage (12) or by
/// [`PowerState::on_quick_stop_complete`], never back to Operation enabled (16).
///
/// Transitions the controlword cannot cause (0, 1, 13, 14 and the end of a quick stop) are
/// separate functions: [`PowerState::on_init_complete`], [`PowerState::on_fault`],
/// [`PowerState::on_fault_reaction_complete`].
pub const fn next_state(state: PowerState, cw: u16) -> PowerState {
    use DriveCommand as C;
    use PowerState as S;
    let command = DriveCommand::from_controlword(cw);
    match (state, command) {
        (S::NotReadyToSwitchOn, _) | (S::FaultReactionActive, _) => state,
        (S::Fault, _) => {
            if cw & controlword::FAULT_RESET_BIT != 0 {
                S::SwitchOnDisabled // 15
            } else {
                S::Fault
            }
        }
        (S::SwitchOnDisabled, C::Shutdown) => S::ReadyToSwitchOn, // 2
        (S::SwitchOnDisabled, _) => S::SwitchOnDisabled,
        (S::ReadyToSwitchOn, C::SwitchOn | C::EnableOperation) => S::SwitchedOn, // 3
        (S::ReadyToSwitchOn, C::DisableVoltage | C::QuickStop) => S::SwitchOnDisabled, // 7
        (S::ReadyToSwitchOn, C::Shutdown) => S::ReadyToSwitchOn,
        (S::SwitchedOn, C::EnableOperation) => S::OperationEnabled, // 4
        (S::SwitchedOn, C::Shutdown) => S::ReadyToSwitchOn,         // 6
        (S::SwitchedOn, C::DisableVoltage | C::QuickStop) => S::SwitchOnDisabled, // 10
        (S::SwitchedOn, C::SwitchOn) => S::SwitchedOn,
        (S::OperationEnabled, C::SwitchOn) => S::SwitchedOn, // 5 (disable operation)
        (S::OperationEnabled, C::Shutdown) => S::ReadyToSwitchOn, // 8
        (S::OperationEnabled, C::DisableVoltage) => S::SwitchOnDisabled, // 9
        (S::OperationEnabled, C::QuickStop) => S::QuickStopActive, // 11
        (S::OperationEnabled, C::EnableOperation) => S::OperationEnabled,
        (S::QuickStopActive, C::DisableVoltage) => S::SwitchOnDisabled, // 12
        (S::QuickStopActive, _) => S::QuickStopActive,
    }
}

impl PowerState {
    /// Transitions 0/1: the drive finished its self-test and initialisation.
    pub const fn on_init_complete(self) -> PowerState {
        match self {
            PowerState::NotReadyToSwitchOn => PowerState::SwitchOnDisabled,
            other => other,
        }
    }

    /// Transition 13: a fault occurred (from any state except the fault states themselves).
    pub const fn on_fault(self) -> PowerState {
        match self {
            PowerState::FaultReactionActive | PowerState::Fault => self,
            _ => PowerState::FaultReactionActive,
        }
    }

    /// Transition 14: the fault reaction (e.g. the quick-stop ramp) has finished.
    pub const fn on_fault_reaction_complete(self) -> PowerState {
        match self {
            PowerState::FaultReactionActive => PowerState::Fault,
            other => other,
        }
    }

    /// Transition 12 (automatic, quick stop option code 2): the quick-stop ramp has finished.
    pub const fn on_quick_stop_complete(self) -> PowerState {
        match self {
            PowerState::QuickStopActive => PowerState::SwitchOnDisabled,
            other => other,
        }
    }
}

/// Drive side: the power state machine with fault-reset edge detection. The controlword's bit 7
/// resets a fault only on its 0 → 1 edge, so a master that keeps sending FAULT_RESET cannot
/// acknowledge a fault that reappears.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PowerStateMachine {
    state: PowerState,
    last_controlword: u16,
}

impl Default for PowerStateMachine {
    fn default() -> Self {
        PowerStateMachine { state: PowerState::NotReadyToSwitchOn, last_controlword: 0 }
    }
}

impl PowerStateMachine {
    pub const fn new(state: PowerState) -> Self {
        PowerStateMachine { state, last_controlword: 0 }
    }

    pub const fn state(&self) -> PowerState {
        self.state
    }

    /// Applies a received controlword and returns the new state.
    pub fn apply(&mut self, cw: u16) -> PowerState {
        let rising = cw & !self.last_controlword & controlword::FAULT_RESET_BIT;
        let effective = (cw & !controlword::FAULT_RESET_BIT) | rising;
        self.last_controlword = cw;
        self.state = next_state(self.state, effective);
        self.state
    }

    /// Applies one of the internal events (see the `on_*` methods of [`PowerState`]).
    pub fn set(&mut self, state: PowerState) {
        self.state = state;
    }
}

/// Master side: the controlword that moves a drive reported in `state` one step toward
/// Operation enabled (CiA 402-2 figure 32). From Fault it alternates: FAULT_RESET when the
/// previous controlword did not have bit 7 set, otherwise DISABLE_VOLTAGE, so the drive sees a
/// fresh rising edge on each retry.
pub const fn controlword_toward_enabled(state: PowerState, previous_cw: u16) -> u16 {
    use controlword::*;
    match state {
        PowerState::NotReadyToSwitchOn | PowerState::FaultReactionActive => DISABLE_VOLTAGE,
        PowerState::Fault => {
            if previous_cw & FAULT_RESET_BIT == 0 {
                FAULT_RESET
            } else {
                DISABLE_VOLTAGE
            }
        }
        PowerState::SwitchOnDisabled => SHUTDOWN,
        PowerState::ReadyToSwitchOn => SWITCH_ON,
        PowerState::SwitchedOn | PowerState::OperationEnabled => ENABLE_OPERATION,
        // Option code 2: Quick stop active cannot go back to Operation enabled directly.
        PowerState::QuickStopActive => DISABLE_VOLTAGE,
    }
}

// ---------------------------------------------------------------------------------------------
// Messages
// ---------------------------------------------------------------------------------------------

/// RPDO1: what the master sends each cycle to a drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rpdo1 {
    /// 0x6040 controlword.
    pub controlword: u16,
    /// 0x607A target position in increments.
    pub target_position: i32,
}

/// TPDO1: what a drive answers after each SYNC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Tpdo1 {
    /// 0x6041 statusword.
    pub statusword: u16,
    /// 0x6064 position actual value in increments.
    pub position_actual: i32,
}

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

fn u16_le(b: &[u8], at: usize) -> u16 {
    // Callers check the DLC first; missing bytes read as 0 rather than panicking.
    let lo = b.get(at).copied().unwrap_or(0);
    let hi = b.get(at + 1).copied().unwrap_or(0);
    u16::from_le_bytes([lo, hi])
}

fn i32_le(b: &[u8], at: usize) -> i32 {
    let mut v = [0u8; 4];
    for (i, byte) in v.iter_mut().enumerate() {
        *byte = b.get(at + i).copied().unwrap_or(0);
    }
    i32::from_le_bytes(v)
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
            Message::Tpdo1 { node, pdo } => {
                let [s0, s1] = pdo.statusword.to_le_bytes();
                let [p0, p1, p2, p3] = pdo.position_actual.to_le_bytes();
                frame(cob::tpdo1(node), &[s0, s1, p0, p1, p2, p3])
            }
            Message::Rpdo1 { node, pdo } => {
                let [c0, c1] = pdo.controlword.to_le_bytes();
                let [p0, p1, p2, p3] = pdo.target_position.to_le_bytes();
                frame(cob::rpdo1(node), &[c0, c1, p0, p1, p2, p3])
            }
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
/// DLCs are strict — a PDO must have exactly its mapped length of 6 bytes. CiA 301 has a drive
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
            if d.len() != 8 {
                return Err(wrong_dlc("8"));
            }
            let mut vendor = [0u8; 5];
            vendor.copy_from_slice(&d[3..8]);
            Ok(Message::Emcy { node, emcy: Emcy { error_code: u16_le(d, 0), error_register: d[2], vendor } })
        }
        CobObject::Tpdo1(node) => {
            if d.len() != 6 {
                return Err(wrong_dlc("6"));
            }
            Ok(Message::Tpdo1 { node, pdo: Tpdo1 { statusword: u16_le(d, 0), position_actual: i32_le(d, 2) } })
        }
        CobObject::Rpdo1(node) => {
            if d.len() != 6 {
                return Err(wrong_dlc("6"));
            }
            Ok(Message::Rpdo1 { node, pdo: Rpdo1 { controlword: u16_le(d, 0), target_position: i32_le(d, 2) } })
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

// ---------------------------------------------------------------------------------------------
// Position scaling
// ---------------------------------------------------------------------------------------------

/// Why a position could not be converted to increments.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScaleError {
    #[error("increments per unit must be finite and non-zero, got {0}")]
    BadScale(f64),
    #[error("position {0} is not a finite number")]
    NotFinite(f64),
    #[error("position {units} is {increments:.0} increments, outside the i32 range of 0x607A")]
    OutOfRange { units: f64, increments: f64 },
}

/// Conversion between axis units (mm or degrees) and drive increments (0x607A/0x6064), e.g.
/// 10 000 increments per mm. A negative scale inverts the axis direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    increments_per_unit: f64,
}

impl Scale {
    pub fn new(increments_per_unit: f64) -> Result<Scale, ScaleError> {
        if increments_per_unit.is_finite() && increments_per_unit != 0.0 {
            Ok(Scale { increments_per_unit })
        } else {
            Err(ScaleError::BadScale(increments_per_unit))
        }
    }

    pub const fn increments_per_unit(&self) -> f64 {
        self.increments_per_unit
    }

    /// Rounds to the nearest increment (ties away from zero). Outside the i32 range is an error,
    /// never a wrap-around: a wrapped setpoint would command a jump of 2³² increments.
    pub fn to_increments(&self, units: f64) -> Result<i32, ScaleError> {
        if !units.is_finite() {
            return Err(ScaleError::NotFinite(units));
        }
        let increments = (units * self.increments_per_unit).round();
        // Both bounds are exactly representable in f64, so the comparison is exact.
        if increments.is_finite() && increments >= i32::MIN as f64 && increments <= i32::MAX as f64 {
            Ok(increments as i32)
        } else {
            Err(ScaleError::OutOfRange { units, increments })
        }
    }

    pub fn to_units(&self, increments: i32) -> f64 {
        increments as f64 / self.increments_per_unit
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
    fn statusword_table_is_cia402() {
        use PowerState::*;
        let cases = [
            (0x0000, NotReadyToSwitchOn),
            (0x0250, SwitchOnDisabled),
            (0x0040, SwitchOnDisabled),
            (0x0231, ReadyToSwitchOn),
            (0x0233, SwitchedOn),
            (0x1237, OperationEnabled),
            (0x0217, QuickStopActive),
            (0x021F, FaultReactionActive),
            (0x0218, Fault),
            (0x0238, Fault), // bit 5 is free in Fault
        ];
        for (sw, state) in cases {
            assert_eq!(PowerState::from_statusword(sw), Some(state), "statusword 0x{sw:04X}");
        }
        for sw in [0x0001u16, 0x0041, 0x0003, 0x0061] {
            assert_eq!(PowerState::from_statusword(sw), None, "0x{sw:04X} is undefined");
        }
        // The table rows are disjoint: no statusword decodes to two states.
        for sw in 0..=u16::MAX {
            let hits = STATUSWORD_TABLE.iter().filter(|(m, v, _)| sw & m == *v).count();
            assert!(hits <= 1, "0x{sw:04X} matches {hits} rows");
        }
        for (_, _, s) in STATUSWORD_TABLE {
            assert_eq!(PowerState::from_statusword(s.statusword_bits()), Some(s));
            assert_eq!(PowerState::from_statusword(s.statusword_bits() | 0x1610), Some(s), "extra bits");
        }
    }

    #[test]
    fn controlword_commands_decode_per_table() {
        use DriveCommand::*;
        assert_eq!(DriveCommand::from_controlword(controlword::SHUTDOWN), Shutdown);
        assert_eq!(DriveCommand::from_controlword(controlword::SWITCH_ON), SwitchOn);
        assert_eq!(DriveCommand::from_controlword(controlword::ENABLE_OPERATION), EnableOperation);
        assert_eq!(DriveCommand::from_controlword(controlword::DISABLE_VOLTAGE), DisableVoltage);
        assert_eq!(DriveCommand::from_controlword(controlword::QUICK_STOP), QuickStop);
        // Don't-care bits: x x 0 x is disable voltage whatever the rest.
        assert_eq!(DriveCommand::from_controlword(0x000D), DisableVoltage);
        assert_eq!(DriveCommand::from_controlword(0x000A), QuickStop);
        assert_eq!(DriveCommand::from_controlword(0x000E), Shutdown);
    }

    #[test]
    fn enable_sequence_and_transitions() {
        use PowerState::*;
        use controlword::*;
        let mut s = NotReadyToSwitchOn.on_init_complete();
        assert_eq!(s, SwitchOnDisabled);
        s = next_state(s, SHUTDOWN);
        assert_eq!(s, ReadyToSwitchOn);
        s = next_state(s, SWITCH_ON);
        assert_eq!(s, SwitchedOn);
        s = next_state(s, ENABLE_OPERATION);
        assert_eq!(s, OperationEnabled);
        assert_eq!(next_state(OperationEnabled, DISABLE_OPERATION), SwitchedOn); // 5
        assert_eq!(next_state(SwitchedOn, SHUTDOWN), ReadyToSwitchOn); // 6
        assert_eq!(next_state(ReadyToSwitchOn, QUICK_STOP), SwitchOnDisabled); // 7
        assert_eq!(next_state(OperationEnabled, SHUTDOWN), ReadyToSwitchOn); // 8
        assert_eq!(next_state(OperationEnabled, DISABLE_VOLTAGE), SwitchOnDisabled); // 9
        assert_eq!(next_state(SwitchedOn, DISABLE_VOLTAGE), SwitchOnDisabled); // 10
        assert_eq!(next_state(OperationEnabled, QUICK_STOP), QuickStopActive); // 11
        assert_eq!(next_state(QuickStopActive, DISABLE_VOLTAGE), SwitchOnDisabled); // 12
        assert_eq!(next_state(QuickStopActive, ENABLE_OPERATION), QuickStopActive); // no 16 (option code 2)
        assert_eq!(QuickStopActive.on_quick_stop_complete(), SwitchOnDisabled);
        assert_eq!(OperationEnabled.on_fault(), FaultReactionActive); // 13
        assert_eq!(FaultReactionActive.on_fault_reaction_complete(), Fault); // 14
        assert_eq!(next_state(Fault, ENABLE_OPERATION), Fault);
        assert_eq!(next_state(Fault, FAULT_RESET), SwitchOnDisabled); // 15
        assert_eq!(next_state(ReadyToSwitchOn, ENABLE_OPERATION), SwitchedOn); // 3, then 4
        assert_eq!(next_state(SwitchOnDisabled, ENABLE_OPERATION), SwitchOnDisabled);
        assert_eq!(next_state(NotReadyToSwitchOn, SHUTDOWN), NotReadyToSwitchOn);
        assert_eq!(next_state(FaultReactionActive, FAULT_RESET), FaultReactionActive);
    }

    #[test]
    fn fault_reset_needs_a_rising_edge() {
        use PowerState::*;
        let mut m = PowerStateMachine::new(Fault);
        assert_eq!(m.apply(controlword::FAULT_RESET), SwitchOnDisabled);
        m.set(m.state().on_fault().on_fault_reaction_complete());
        assert_eq!(m.apply(controlword::FAULT_RESET), Fault, "bit 7 held high is no new edge");
        assert_eq!(m.apply(0), Fault);
        assert_eq!(m.apply(controlword::FAULT_RESET), SwitchOnDisabled);
    }

    #[test]
    fn master_drives_every_state_to_operation_enabled() {
        use PowerState::*;
        for start in [SwitchOnDisabled, ReadyToSwitchOn, SwitchedOn, OperationEnabled, QuickStopActive, Fault] {
            let mut m = PowerStateMachine::new(start);
            let mut cw = 0;
            for _ in 0..10 {
                cw = controlword_toward_enabled(m.state(), cw);
                m.apply(cw);
            }
            assert_eq!(m.state(), OperationEnabled, "from {start}");
        }
    }

    #[test]
    fn every_state_and_controlword_gives_a_defined_state() {
        // Exhaustive: next_state is total and never leaves the fault states by itself.
        let all = STATUSWORD_TABLE.map(|(_, _, s)| s);
        for s in all {
            for cw in 0..=u16::MAX {
                let n = next_state(s, cw);
                if s == PowerState::FaultReactionActive {
                    assert_eq!(n, s);
                }
                if n == PowerState::OperationEnabled {
                    assert!(matches!(s, PowerState::SwitchedOn | PowerState::OperationEnabled));
                }
            }
        }
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

    #[test]
    fn scaling_rounds_and_refuses_to_wrap() {
        let s = Scale::new(10_000.0).unwrap();
        assert_eq!(s.to_increments(1.23456), Ok(12_346));
        assert_eq!(Scale::new(2.0).unwrap().to_increments(-0.25), Ok(-1)); // ties away from zero
        assert_eq!(s.to_units(12_346), 1.2346);
        assert_eq!(s.to_increments(214_748.364_7), Ok(i32::MAX));
        assert!(matches!(s.to_increments(214_748.364_8), Err(ScaleError::OutOfRange { .. })));
        assert_eq!(s.to_increments(-214_748.364_8), Ok(i32::MIN));
        assert!(matches!(s.to_increments(-214_748.364_9), Err(ScaleError::OutOfRange { .. })));
        assert!(matches!(s.to_increments(f64::NAN), Err(ScaleError::NotFinite(_))));
        assert!(matches!(s.to_increments(f64::INFINITY), Err(ScaleError::NotFinite(_))));
        assert!(matches!(Scale::new(1e300).unwrap().to_increments(1e300), Err(ScaleError::OutOfRange { .. })));
        assert!(Scale::new(0.0).is_err());
        assert!(Scale::new(f64::NAN).is_err());
        let inv = Scale::new(-4096.0).unwrap();
        assert_eq!(inv.to_increments(1.0), Ok(-4096));
        assert_eq!(inv.to_units(-4096), 1.0);
    }
}
