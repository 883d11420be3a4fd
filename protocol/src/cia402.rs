//! CiA 402 drive profile as the CSP bus uses it: the controlword (0x6040) and statusword
//! (0x6041), the power drive system state machine on both sides of the bus, the fixed PDO
//! mapping for cyclic synchronous position (CSP) mode and the scaling of positions to
//! increments.
//!
//! RPDO1 carries controlword 0x6040 + target position 0x607A from the master to a drive, which
//! applies it on the next SYNC; TPDO1 carries statusword 0x6041 + position actual value 0x6064
//! back after each SYNC. Quick stop option code 0x605A = 2 (slow down on the quick-stop ramp,
//! then Switch on disabled) is the behaviour modelled. How these PDOs travel (COB-IDs, SYNC,
//! NMT, EMCY) is CiA 301, [`crate::cia301`].
//!
//! Plain data and pure functions, total over every input, as in [`crate::cia301`].

use std::fmt;

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
    /// Homing mode (0x6060 = 6): the rising edge starts homing.
    pub const HOMING_START_BIT: u16 = 1 << 4;

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
    /// Homing mode: homing attained (the same bit as CSP's "following").
    pub const HOMING_ATTAINED_BIT: u16 = 1 << 12;
    /// Homing mode: homing error (the same bit as CSP's "following error").
    pub const HOMING_ERROR_BIT: u16 = 1 << 13;
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
// PDO mapping for CSP (RPDO1, TPDO1)
// ---------------------------------------------------------------------------------------------

/// RPDO1: what the master sends each cycle to a drive. Mapping (0x1600): 0x6040 u16, then
/// 0x607A i32, little-endian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rpdo1 {
    /// 0x6040 controlword.
    pub controlword: u16,
    /// 0x607A target position in increments.
    pub target_position: i32,
}

impl Rpdo1 {
    /// Mapped length in bytes, the only DLC an RPDO1 may have.
    pub const LEN: usize = 6;

    /// The PDO's data bytes.
    pub const fn to_bytes(self) -> [u8; Self::LEN] {
        let [c0, c1] = self.controlword.to_le_bytes();
        let [p0, p1, p2, p3] = self.target_position.to_le_bytes();
        [c0, c1, p0, p1, p2, p3]
    }

    /// The PDO from its data bytes (every bit pattern is a valid PDO).
    pub const fn from_bytes(b: [u8; Self::LEN]) -> Rpdo1 {
        Rpdo1 {
            controlword: u16::from_le_bytes([b[0], b[1]]),
            target_position: i32::from_le_bytes([b[2], b[3], b[4], b[5]]),
        }
    }
}

/// TPDO1: what a drive answers after each SYNC. Mapping (0x1A00): 0x6041 u16, then 0x6064
/// i32, little-endian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Tpdo1 {
    /// 0x6041 statusword.
    pub statusword: u16,
    /// 0x6064 position actual value in increments.
    pub position_actual: i32,
}

impl Tpdo1 {
    /// Mapped length in bytes, the only DLC a TPDO1 may have.
    pub const LEN: usize = 6;

    /// The PDO's data bytes.
    pub const fn to_bytes(self) -> [u8; Self::LEN] {
        let [s0, s1] = self.statusword.to_le_bytes();
        let [p0, p1, p2, p3] = self.position_actual.to_le_bytes();
        [s0, s1, p0, p1, p2, p3]
    }

    /// The PDO from its data bytes (every bit pattern is a valid PDO).
    pub const fn from_bytes(b: [u8; Self::LEN]) -> Tpdo1 {
        Tpdo1 {
            statusword: u16::from_le_bytes([b[0], b[1]]),
            position_actual: i32::from_le_bytes([b[2], b[3], b[4], b[5]]),
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

    #[test]
    fn pdo_codecs_follow_the_mapping_and_round_trip() {
        let rpdo = Rpdo1 { controlword: 0x000F, target_position: -2 };
        assert_eq!(rpdo.to_bytes(), [0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF]);
        let tpdo = Tpdo1 { statusword: 0x1237, position_actual: 0x0102_0304 };
        assert_eq!(tpdo.to_bytes(), [0x37, 0x12, 0x04, 0x03, 0x02, 0x01]);
        for (cw, pos) in [(0u16, 0i32), (u16::MAX, i32::MIN), (0x0080, i32::MAX)] {
            let r = Rpdo1 { controlword: cw, target_position: pos };
            assert_eq!(Rpdo1::from_bytes(r.to_bytes()), r);
            let t = Tpdo1 { statusword: cw, position_actual: pos };
            assert_eq!(Tpdo1::from_bytes(t.to_bytes()), t);
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
