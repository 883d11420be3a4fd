//! One simulated CiA 402 drive as a CANopen node (sim-plant/eds/interpd-sim-drive.eds): the NMT
//! state machine, the power drive system state machine on the statusword, cyclic synchronous
//! position (RPDO1 applied on SYNC, TPDO1 answered), EMCY on faults, the SYNC watchdog and the
//! quick-stop ramp. Pure logic with explicit times: the bus loop ([`crate::can`]) feeds it
//! frames and ticks, it returns the frames to send and the position its axis is to follow.

use interpd_protocol::cia301::{Emcy, Message, NmtCommand, NmtState, NodeId, emcy_code, error_register};
use interpd_protocol::cia402::{PowerState, PowerStateMachine, Rpdo1, Scale, Tpdo1, statusword};

/// EDS 0x1017: producer heartbeat time, ms.
pub const HEARTBEAT_PERIOD_MS: u64 = 100;
/// EDS 0x1015 (inhibit time EMCY, 100 µs units): at most one EMCY per node per 10 ms.
pub const EMCY_INHIBIT_US: u64 = 10_000;
/// EDS 0x6065: following error window, increments.
pub const FOLLOWING_ERROR_WINDOW: i64 = 100_000;
/// SYNC watchdog: this many communication cycles (0x1006) without SYNC trip it.
pub const WATCHDOG_CYCLES: u64 = 3;
/// Vendor byte 0 of EMCY 0x8100 (communication): why.
pub mod comm_fault {
    /// No SYNC for [`super::WATCHDOG_CYCLES`] cycles.
    pub const SYNC_WATCHDOG: u8 = 1;
    /// NMT left Operational while the drive was in Operation enabled.
    pub const NMT_LEFT_OPERATIONAL: u8 = 2;
}

/// What a node's axis does in the coming cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Stand still: power stage off (not yet enabled, or a quick stop or fault reaction is
    /// complete), the holding brake clamps the motor where it is.
    Hold,
    /// Follow the RPDO1 target (Operation enabled).
    Follow,
    /// Quick-stop ramp at the quick-stop deceleration, velocity in axis units per second.
    Ramp { vel: f64 },
}

/// Fixed parameters of a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeParams {
    pub node: NodeId,
    pub scale: Scale,
    /// Communication cycle period (0x1006), µs.
    pub cycle_us: u64,
    /// Quick-stop deceleration, axis units/s² (the axis's max_acc).
    pub quick_stop_dec: f64,
}

/// Counters of one node.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    pub syncs: u64,
    pub rpdos: u64,
    /// RPDO1 with a DLC other than 6 (answered with EMCY 0x8210).
    pub rpdo_bad_length: u64,
    pub nmt_commands: u64,
    pub watchdog_trips: u64,
    pub following_errors: u64,
    pub emcy_sent: u64,
    /// EMCY not sent because of the inhibit time.
    pub emcy_inhibited: u64,
}

/// One drive node.
#[derive(Debug, Clone)]
pub struct DriveNode {
    p: NodeParams,
    nmt: NmtState,
    power: PowerStateMachine,
    /// The last RPDO1 received (applied on each SYNC, as CSP drives keep the last value).
    rpdo: Option<Rpdo1>,
    motion: Motion,
    /// Commanded position of the cycle now running and of the one before, axis units.
    target: f64,
    prev_target: f64,
    last_sync_us: Option<u64>,
    last_emcy_us: Option<u64>,
    error_register: u8,
    pub stats: NodeStats,
}

impl DriveNode {
    /// A node that has just powered up at `position` (axis units): NMT boot-up, power state
    /// Switch on disabled. Returns it and its boot-up message.
    pub fn boot(p: NodeParams, position: f64) -> (DriveNode, Message) {
        let node = DriveNode {
            p,
            nmt: NmtState::BootUp.after_boot_up(),
            power: PowerStateMachine::new(PowerState::NotReadyToSwitchOn.on_init_complete()),
            rpdo: None,
            motion: Motion::Hold,
            target: position,
            prev_target: position,
            last_sync_us: None,
            last_emcy_us: None,
            error_register: 0,
            stats: NodeStats::default(),
        };
        (node, Message::Heartbeat { node: p.node, state: NmtState::BootUp })
    }

    pub fn id(&self) -> NodeId {
        self.p.node
    }
    pub fn nmt(&self) -> NmtState {
        self.nmt
    }
    pub fn power_state(&self) -> PowerState {
        self.power.state()
    }
    pub fn motion(&self) -> Motion {
        self.motion
    }
    /// The position the axis is to be at the end of the cycle now running, axis units.
    pub fn target(&self) -> f64 {
        self.target
    }

    /// The statusword: the state bits plus voltage enabled, remote, and CSP "drive follows the
    /// command value" while it does.
    pub fn statusword(&self) -> u16 {
        let s = self.power.state();
        let voltage = !matches!(s, PowerState::NotReadyToSwitchOn | PowerState::SwitchOnDisabled | PowerState::Fault);
        let mut sw = s.statusword_bits() | statusword::REMOTE_BIT;
        if voltage {
            sw |= statusword::VOLTAGE_ENABLED_BIT;
        }
        if self.motion == Motion::Follow {
            sw |= statusword::CSP_FOLLOWING_BIT;
        }
        sw
    }

    /// The heartbeat message.
    pub fn heartbeat(&self) -> Message {
        Message::Heartbeat { node: self.p.node, state: self.nmt }
    }

    /// NMT node control addressed to this node (or to all). A reset reboots the node (returns
    /// its boot-up message); leaving Operational while enabled is a communication fault.
    pub fn on_nmt(&mut self, command: NmtCommand, now_us: u64, out: &mut Vec<Message>) {
        self.stats.nmt_commands += 1;
        let before = self.nmt;
        let after = self.nmt.apply(command);
        if after == NmtState::BootUp {
            let (fresh, boot) = DriveNode::boot(self.p, self.target);
            let stats = self.stats;
            *self = fresh;
            self.stats = stats;
            out.push(boot);
            return;
        }
        self.nmt = after;
        if before == NmtState::Operational && after != NmtState::Operational {
            self.rpdo = None;
            if self.power.state().is_operation_enabled() {
                self.fault(emcy_code::COMMUNICATION, comm_fault::NMT_LEFT_OPERATIONAL, now_us, out);
            }
        }
        if after == NmtState::Operational {
            // The watchdog starts with the first SYNC after the start.
            self.last_sync_us = None;
        }
    }

    /// An RPDO1 frame for this node with `len` data bytes; `pdo` when the length was right.
    pub fn on_rpdo(&mut self, pdo: Option<Rpdo1>, len: u8, now_us: u64, out: &mut Vec<Message>) {
        if !self.nmt.pdo_allowed() {
            return;
        }
        match pdo {
            Some(p) => {
                self.stats.rpdos += 1;
                self.rpdo = Some(p);
            }
            None => {
                self.stats.rpdo_bad_length += 1;
                let code = if len < 6 { emcy_code::PDO_LENGTH } else { emcy_code::PDO_LENGTH_EXCEEDED };
                self.emcy(code, error_register::COMMUNICATION, [len, 0, 0, 0, 0], now_us, out);
            }
        }
    }

    /// SYNC at `now_us` with the axis at `actual` (axis units, the state at this instant):
    /// answer TPDO1, apply the controlword, take the new target. Nothing outside Operational.
    pub fn on_sync(&mut self, actual: f64, now_us: u64, out: &mut Vec<Message>) {
        if !self.nmt.pdo_allowed() {
            return;
        }
        self.stats.syncs += 1;
        self.last_sync_us = Some(now_us);
        let was_enabled = self.power.state().is_operation_enabled();
        if let Some(pdo) = self.rpdo {
            self.power.apply(pdo.controlword);
        }
        let state = self.power.state();
        match (state, self.motion) {
            (PowerState::OperationEnabled, _) => {
                let target = self.rpdo.map_or(self.target, |p| self.p.scale.to_units(p.target_position));
                self.motion = Motion::Follow;
                self.prev_target = self.target;
                self.target = target;
                let dev = i64::from(self.increments(actual)) - i64::from(self.increments(target));
                if was_enabled && dev.abs() > FOLLOWING_ERROR_WINDOW {
                    self.stats.following_errors += 1;
                    self.fault(emcy_code::FOLLOWING_ERROR, 0, now_us, out);
                }
            }
            (PowerState::QuickStopActive, Motion::Follow) => {
                self.start_ramp();
                self.complete_if_standing();
            }
            (_, Motion::Ramp { .. }) => {}
            // Shutdown, disable voltage, disable operation: the power stage is off, the axis
            // holds where it was commanded.
            _ => self.motion = Motion::Hold,
        }
        let position_actual = self.increments(actual);
        out.push(Message::Tpdo1 { node: self.p.node, pdo: Tpdo1 { statusword: self.statusword(), position_actual } });
    }

    /// Advances a running quick-stop ramp by one cycle (`dt_s`); when it reaches standstill the
    /// state machine completes the quick stop (→ Switch on disabled) or the fault reaction
    /// (→ Fault).
    pub fn advance_ramp(&mut self, dt_s: f64) {
        let Motion::Ramp { vel } = self.motion else { return };
        let dv = self.p.quick_stop_dec * dt_s;
        let v = if vel.abs() <= dv { 0.0 } else { vel - dv * vel.signum() };
        self.prev_target = self.target;
        // Trapezoidal position update over the cycle.
        self.target += 0.5 * (vel + v) * dt_s;
        self.motion = if v == 0.0 { Motion::Hold } else { Motion::Ramp { vel: v } };
        self.complete_if_standing();
    }

    /// The SYNC watchdog at `now_us`: in Operation enabled, no SYNC for [`WATCHDOG_CYCLES`]
    /// cycles trips it (quick-stop ramp, Fault, EMCY 0x8100). Returns whether it tripped now.
    pub fn check_watchdog(&mut self, now_us: u64, out: &mut Vec<Message>) -> bool {
        if self.watchdog_deadline_us().is_some_and(|deadline| now_us >= deadline) {
            self.stats.watchdog_trips += 1;
            self.fault(emcy_code::COMMUNICATION, comm_fault::SYNC_WATCHDOG, now_us, out);
            return true;
        }
        false
    }

    /// When the SYNC watchdog trips if no SYNC comes before (µs, the clock of `on_sync`):
    /// None while it is not armed.
    pub fn watchdog_deadline_us(&self) -> Option<u64> {
        let armed = self.nmt.pdo_allowed() && self.power.state().is_operation_enabled();
        let last = self.last_sync_us?;
        armed.then_some(last + WATCHDOG_CYCLES * self.p.cycle_us + 1)
    }

    /// Microseconds since the last SYNC (None before the first).
    pub fn since_sync_us(&self, now_us: u64) -> Option<u64> {
        self.last_sync_us.map(|t| now_us.saturating_sub(t))
    }

    /// From following to the quick-stop ramp at the velocity of the last cycle.
    fn start_ramp(&mut self) {
        let dt_s = self.p.cycle_us as f64 * 1e-6;
        let vel = (self.target - self.prev_target) / dt_s;
        self.motion = if vel == 0.0 { Motion::Hold } else { Motion::Ramp { vel } };
        self.prev_target = self.target;
    }

    /// A quick stop or fault reaction that starts at standstill is complete at once.
    fn complete_if_standing(&mut self) {
        if !matches!(self.motion, Motion::Ramp { .. }) {
            let s = self.power.state();
            self.power.set(s.on_quick_stop_complete().on_fault_reaction_complete());
        }
    }

    /// Fault (transition 13): fault reaction = quick-stop ramp from the current motion, EMCY.
    fn fault(&mut self, code: u16, vendor0: u8, now_us: u64, out: &mut Vec<Message>) {
        let s = self.power.state();
        if s.is_fault() {
            return;
        }
        if self.motion == Motion::Follow {
            self.start_ramp();
        }
        self.power.set(s.on_fault());
        self.complete_if_standing();
        let reg = if code == emcy_code::FOLLOWING_ERROR {
            error_register::DEVICE_PROFILE
        } else {
            error_register::COMMUNICATION
        };
        self.error_register |= reg | error_register::GENERIC;
        self.emcy(code, self.error_register, [vendor0, 0, 0, 0, 0], now_us, out);
    }

    /// Queues an EMCY unless the inhibit time since the last one has not passed.
    fn emcy(&mut self, code: u16, register: u8, vendor: [u8; 5], now_us: u64, out: &mut Vec<Message>) {
        if self.last_emcy_us.is_some_and(|t| now_us.saturating_sub(t) < EMCY_INHIBIT_US) {
            self.stats.emcy_inhibited += 1;
            return;
        }
        self.last_emcy_us = Some(now_us);
        self.stats.emcy_sent += 1;
        out.push(Message::Emcy {
            node: self.p.node,
            emcy: Emcy { error_code: code, error_register: register, vendor },
        });
    }

    /// Rounds to increments, saturating at the i32 range (a plant far outside the travel still
    /// gives a defined position actual).
    fn increments(&self, units: f64) -> i32 {
        match self.p.scale.to_increments(units) {
            Ok(i) => i,
            Err(_) if units * self.p.scale.increments_per_unit() > 0.0 => i32::MAX,
            Err(_) => i32::MIN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use interpd_protocol::cia402::controlword;

    const CYCLE_US: u64 = 4000;

    fn params() -> NodeParams {
        NodeParams {
            node: NodeId::new(2).unwrap(),
            scale: Scale::new(10_000.0).unwrap(),
            cycle_us: CYCLE_US,
            quick_stop_dec: 1000.0,
        }
    }

    fn rpdo(cw: u16, mm: f64) -> Option<Rpdo1> {
        Some(Rpdo1 { controlword: cw, target_position: (mm * 1e4).round() as i32 })
    }

    /// Boots, starts and enables a node; returns it and the time.
    fn enabled() -> (DriveNode, u64) {
        let (mut n, boot) = DriveNode::boot(params(), 0.0);
        assert_eq!(boot, Message::Heartbeat { node: params().node, state: NmtState::BootUp });
        assert_eq!(n.nmt(), NmtState::PreOperational);
        let mut out = Vec::new();
        let mut t = 0;
        n.on_sync(0.0, t, &mut out);
        assert!(out.is_empty(), "no PDO before NMT start");
        n.on_nmt(NmtCommand::Start, t, &mut out);
        for cw in [controlword::SHUTDOWN, controlword::SWITCH_ON, controlword::ENABLE_OPERATION] {
            t += CYCLE_US;
            n.on_rpdo(rpdo(cw, 0.0), 6, t, &mut out);
            n.on_sync(0.0, t, &mut out);
        }
        assert_eq!(n.power_state(), PowerState::OperationEnabled);
        let Some(Message::Tpdo1 { pdo, .. }) = out.last() else { panic!("{out:?}") };
        assert_eq!(PowerState::from_statusword(pdo.statusword), Some(PowerState::OperationEnabled));
        assert!(pdo.statusword & statusword::CSP_FOLLOWING_BIT != 0);
        (n, t)
    }

    #[test]
    fn csp_follows_the_target_applied_on_sync() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        t += CYCLE_US;
        n.on_rpdo(rpdo(controlword::ENABLE_OPERATION, 0.5), 6, t, &mut out);
        assert_eq!(n.target(), 0.0, "RPDO alone does not move");
        n.on_sync(0.0, t, &mut out);
        assert_eq!(n.target(), 0.5);
        let Some(Message::Tpdo1 { pdo, .. }) = out.last() else { panic!() };
        assert_eq!(pdo.position_actual, 0);
    }

    #[test]
    fn watchdog_trips_after_three_cycles_and_ramps_to_fault() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        // Move at 100 mm/s for a few cycles.
        for k in 1..=5 {
            t += CYCLE_US;
            n.on_rpdo(rpdo(controlword::ENABLE_OPERATION, 0.4 * k as f64), 6, t, &mut out);
            n.on_sync(0.0, t, &mut out);
        }
        out.clear();
        assert_eq!(n.watchdog_deadline_us(), Some(t + 3 * CYCLE_US + 1));
        assert!(!n.check_watchdog(t + 3 * CYCLE_US, &mut out), "exactly 3 cycles is not yet more than 3");
        assert!(n.check_watchdog(t + 3 * CYCLE_US + 1, &mut out));
        assert_eq!(n.power_state(), PowerState::FaultReactionActive);
        assert_eq!(
            out,
            [Message::Emcy {
                node: params().node,
                emcy: Emcy {
                    error_code: emcy_code::COMMUNICATION,
                    error_register: error_register::GENERIC | error_register::COMMUNICATION,
                    vendor: [comm_fault::SYNC_WATCHDOG, 0, 0, 0, 0],
                },
            }]
        );
        let Motion::Ramp { vel } = n.motion() else { panic!("{:?}", n.motion()) };
        assert!((vel - 100.0).abs() < 1e-9, "{vel}");
        // 100 mm/s at 1000 mm/s²: 0.1 s = 25 cycles, 5 mm.
        let start = n.target();
        let mut cycles = 0;
        while matches!(n.motion(), Motion::Ramp { .. }) {
            n.advance_ramp(CYCLE_US as f64 * 1e-6);
            cycles += 1;
            assert!(cycles < 100);
        }
        assert_eq!(cycles, 25);
        assert!((n.target() - start - 5.0).abs() < 1e-9, "{}", n.target() - start);
        assert_eq!(n.power_state(), PowerState::Fault);
        assert!(!n.check_watchdog(t + 100 * CYCLE_US, &mut out), "a faulted drive does not trip again");
        assert_eq!(n.watchdog_deadline_us(), None, "disarmed in Fault");
        // Fault reset and re-enable.
        for cw in
            [controlword::FAULT_RESET, controlword::SHUTDOWN, controlword::SWITCH_ON, controlword::ENABLE_OPERATION]
        {
            t += CYCLE_US;
            n.on_rpdo(rpdo(cw, n.target()), 6, t, &mut out);
            n.on_sync(n.target(), t, &mut out);
        }
        assert_eq!(n.power_state(), PowerState::OperationEnabled);
    }

    #[test]
    fn quick_stop_command_ramps_to_switch_on_disabled() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        t += CYCLE_US;
        n.on_rpdo(rpdo(controlword::ENABLE_OPERATION, 0.4), 6, t, &mut out);
        n.on_sync(0.0, t, &mut out);
        t += CYCLE_US;
        n.on_rpdo(rpdo(controlword::QUICK_STOP, 0.8), 6, t, &mut out);
        n.on_sync(0.4, t, &mut out);
        assert_eq!(n.power_state(), PowerState::QuickStopActive);
        assert!(matches!(n.motion(), Motion::Ramp { .. }));
        while matches!(n.motion(), Motion::Ramp { .. }) {
            n.advance_ramp(0.004);
        }
        assert_eq!(n.power_state(), PowerState::SwitchOnDisabled);
    }

    #[test]
    fn bad_rpdo_length_and_following_error_send_emcy_with_inhibit() {
        let (mut n, t) = enabled();
        let mut out = Vec::new();
        n.on_rpdo(None, 4, t, &mut out);
        n.on_rpdo(None, 8, t + 1, &mut out); // inhibited
        n.on_rpdo(None, 8, t + EMCY_INHIBIT_US, &mut out);
        let codes: Vec<u16> = out
            .iter()
            .filter_map(|m| if let Message::Emcy { emcy, .. } = m { Some(emcy.error_code) } else { None })
            .collect();
        assert_eq!(codes, [emcy_code::PDO_LENGTH, emcy_code::PDO_LENGTH_EXCEEDED]);
        assert_eq!((n.stats.rpdo_bad_length, n.stats.emcy_inhibited), (3, 1));
        assert_eq!(n.power_state(), PowerState::OperationEnabled, "a bad PDO is not a fault");
        out.clear();
        // The axis lags 11 mm behind: beyond the 10 mm window.
        let t2 = t + 2 * EMCY_INHIBIT_US;
        n.on_rpdo(rpdo(controlword::ENABLE_OPERATION, 11.0), 6, t2, &mut out);
        n.on_sync(0.0, t2, &mut out);
        assert_eq!(n.power_state(), PowerState::FaultReactionActive);
        assert!(
            out.iter()
                .any(|m| matches!(m, Message::Emcy { emcy, .. } if emcy.error_code == emcy_code::FOLLOWING_ERROR))
        );
    }

    #[test]
    fn nmt_reset_reboots_and_leaving_operational_while_enabled_faults() {
        let (mut n, t) = enabled();
        let mut out = Vec::new();
        n.on_nmt(NmtCommand::EnterPreOperational, t, &mut out);
        assert_eq!(n.power_state(), PowerState::Fault, "standing: the fault reaction completes at once");
        assert_eq!(n.nmt(), NmtState::PreOperational);
        out.clear();
        n.on_nmt(NmtCommand::ResetNode, t, &mut out);
        assert_eq!(out, [Message::Heartbeat { node: params().node, state: NmtState::BootUp }]);
        assert_eq!((n.nmt(), n.power_state()), (NmtState::PreOperational, PowerState::SwitchOnDisabled));
        assert_eq!(n.stats.nmt_commands, 3, "counters survive a reset");
    }
}
