//! One simulated CiA 402 drive as a CANopen node: its object dictionary from the shipped EDS
//! ([`crate::can_od`]) with an SDO server on it, the NMT state machine, the PDOs its mapping
//! defines (CiA 402's default at power-on: RPDO1 = controlword, TPDO1 = statusword), the
//! heartbeat producer of 0x1017 (off at power-on), the power drive system state machine on the
//! statusword, cyclic synchronous position once 0x6060 = 8 (target position applied on SYNC),
//! EMCY on faults, the SYNC watchdog and the quick-stop ramp, and homing mode 6
//! ([`crate::can_homing`]), after which the drive reports positions relative to its home. Pure logic with explicit times:
//! the bus loop ([`crate::can`]) feeds it frames and ticks, it returns the frames to send and
//! the position its axis is to follow.

use crate::can_homing::{AxisSensors, Homing, HomingParams, HomingState};
use crate::can_od::{self, DriveDictionary};
use interpd_canopen::eds::EdsError;
use interpd_canopen::sdo_frame::request_cob;
use interpd_canopen::sdo_server::SdoServer;
use interpd_protocol::cia301::{Emcy, Frame, Message, NmtCommand, NmtState, NodeId, emcy_code, error_register};
use interpd_protocol::cia402::{PowerState, PowerStateMachine, Scale, controlword, statusword};

/// EDS 0x1015 (inhibit time EMCY, 100 µs units): at most one EMCY per node per 10 ms.
pub const EMCY_INHIBIT_US: u64 = 10_000;
/// EDS 0x6065: following error window, increments.
pub const FOLLOWING_ERROR_WINDOW: i64 = 100_000;
/// SYNC watchdog: this many communication cycles (0x1006) without SYNC trip it.
pub const WATCHDOG_CYCLES: u64 = 3;
/// Mode of operation 0x6060 for cyclic synchronous position.
pub const MODE_CSP: i128 = 8;
/// Mode of operation 0x6060 for homing.
pub const MODE_HOMING: i128 = 6;
/// Homing is attained once the axis's position actual lies this close to the home position
/// (increments; 1 µm at the default scale), as a drive's position window 0x6067 would say.
pub const HOME_WINDOW_INCREMENTS: i64 = 10;
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
    /// The home switch, index pulses and travel of the axis, for homing.
    pub sensors: AxisSensors,
}

/// Counters of one node.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    pub syncs: u64,
    pub rpdos: u64,
    /// RPDO1 with a length other than its mapping's (answered with EMCY 0x8210/0x8220).
    pub rpdo_bad_length: u64,
    pub nmt_commands: u64,
    pub watchdog_trips: u64,
    pub following_errors: u64,
    pub emcy_sent: u64,
    /// EMCY not sent because of the inhibit time.
    pub emcy_inhibited: u64,
    pub sdo_requests: u64,
    pub sdo_aborts: u64,
}

/// One drive node.
#[derive(Debug, Clone)]
pub struct DriveNode {
    p: NodeParams,
    nmt: NmtState,
    power: PowerStateMachine,
    od: DriveDictionary,
    sdo: SdoServer,
    /// An RPDO1 arrived since NMT start (its objects are applied on each SYNC, as CSP drives
    /// keep the last value).
    rpdo_seen: bool,
    /// The last TPDO1 sent (event-driven transmission sends on change).
    last_tpdo: Option<Vec<u8>>,
    next_heartbeat_us: Option<u64>,
    motion: Motion,
    /// Commanded position of the cycle now running and of the one before, axis units.
    target: f64,
    prev_target: f64,
    last_sync_us: Option<u64>,
    last_emcy_us: Option<u64>,
    error_register: u8,
    /// The homing run of mode 6 (kept after it ends: the axis stands or stops under it).
    homing: Option<Homing>,
    /// The last homing run's outcome: attained, failed (None: not started or running).
    homing_attained: bool,
    homing_error: bool,
    /// Controlword bit 4 at the last SYNC (homing starts on its rising edge).
    homing_bit: bool,
    /// The drive's position minus the plant's, axis units: 0 until homing sets the home
    /// position to the home offset 0x607C. A reset node loses it (an incremental encoder).
    frame_offset: f64,
    pub stats: NodeStats,
}

impl DriveNode {
    /// A node that has just powered up at `position` (axis units): NMT boot-up, power state
    /// Switch on disabled, the dictionary of the EDS. Returns it and its boot-up message.
    pub fn boot(p: NodeParams, position: f64) -> Result<(DriveNode, Frame), EdsError> {
        let node = DriveNode {
            p,
            nmt: NmtState::BootUp.after_boot_up(),
            power: PowerStateMachine::new(PowerState::NotReadyToSwitchOn.on_init_complete()),
            od: DriveDictionary::new(p.node)?,
            sdo: SdoServer::new(p.node),
            rpdo_seen: false,
            last_tpdo: None,
            next_heartbeat_us: None,
            motion: Motion::Hold,
            target: position,
            prev_target: position,
            last_sync_us: None,
            last_emcy_us: None,
            error_register: 0,
            homing: None,
            homing_attained: false,
            homing_error: false,
            homing_bit: false,
            frame_offset: 0.0,
            stats: NodeStats::default(),
        };
        Ok((node, Message::Heartbeat { node: p.node, state: NmtState::BootUp }.encode()))
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
    pub fn dictionary(&self) -> &DriveDictionary {
        &self.od
    }
    /// The position the axis is to be at the end of the cycle now running, axis units.
    pub fn target(&self) -> f64 {
        self.target
    }

    /// Whether `frame` is this node's RPDO1 (on the COB-ID its 0x1400:1 holds while valid).
    pub fn is_rpdo(&self, frame: &Frame) -> bool {
        frame.id().as_standard().is_some_and(|id| self.od.rpdo_cob() == Some(id))
    }

    /// Whether `frame` is an SDO request to this node.
    pub fn is_sdo_request(&self, frame: &Frame) -> bool {
        frame.id().as_standard() == Some(request_cob(self.p.node))
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
        let mode = self.od.int(can_od::MODES_DISPLAY);
        if mode == MODE_CSP && self.motion == Motion::Follow {
            sw |= statusword::CSP_FOLLOWING_BIT;
        }
        if mode == MODE_HOMING {
            let run = self.homing.as_ref();
            let settling = run.is_some_and(Homing::is_attained) && !self.homing_attained;
            if !run.is_some_and(Homing::is_moving) && !settling {
                sw |= statusword::TARGET_REACHED_BIT;
            }
            if self.homing_attained {
                sw |= statusword::HOMING_ATTAINED_BIT;
            }
            if self.homing_error {
                sw |= statusword::HOMING_ERROR_BIT;
            }
        }
        sw
    }

    /// The drive's position minus the plant's (axis units): set by homing.
    pub fn frame_offset(&self) -> f64 {
        self.frame_offset
    }

    /// The heartbeat if it is due at `now_us` (producer time 0x1017; none while it is 0).
    pub fn heartbeat_due(&mut self, now_us: u64) -> Option<Frame> {
        let period_us = self.od.heartbeat_ms() * 1000;
        if period_us == 0 {
            self.next_heartbeat_us = None;
            return None;
        }
        let next = *self.next_heartbeat_us.get_or_insert(now_us + period_us);
        if now_us < next {
            return None;
        }
        self.next_heartbeat_us = Some(if next + period_us > now_us { next + period_us } else { now_us + period_us });
        Some(Message::Heartbeat { node: self.p.node, state: self.nmt }.encode())
    }

    /// When the next heartbeat is due (µs), if the producer runs.
    pub fn next_heartbeat_us(&self) -> Option<u64> {
        self.next_heartbeat_us
    }

    /// An SDO request (the data bytes of a frame on 0x600 + node): served in pre-operational
    /// and operational, as CiA 301 table 80 allows.
    pub fn on_sdo(&mut self, payload: &[u8], out: &mut Vec<Frame>) {
        if !matches!(self.nmt, NmtState::PreOperational | NmtState::Operational) {
            return;
        }
        self.stats.sdo_requests += 1;
        let before = self.sdo.stats.aborts_sent;
        if let Some(f) = self.sdo.on_request(payload, &mut self.od) {
            out.push(f);
        }
        self.stats.sdo_aborts += self.sdo.stats.aborts_sent - before;
    }

    /// NMT node control addressed to this node (or to all). Reset node reboots the node with
    /// its whole dictionary at the defaults; reset communication restores the communication
    /// area (mapping, heartbeat) and keeps the drive's state. Both end with the boot-up message.
    /// Leaving Operational while enabled is a communication fault.
    pub fn on_nmt(&mut self, command: NmtCommand, now_us: u64, out: &mut Vec<Frame>) {
        self.stats.nmt_commands += 1;
        let before = self.nmt;
        let after = self.nmt.apply(command);
        if before == NmtState::Operational && after != NmtState::Operational {
            self.rpdo_seen = false;
            if self.power.state().is_operation_enabled() {
                self.fault(emcy_code::COMMUNICATION, comm_fault::NMT_LEFT_OPERATIONAL, now_us, out);
            }
        }
        if after == NmtState::BootUp {
            if command == NmtCommand::ResetNode {
                self.od.reset_node();
                self.power = PowerStateMachine::new(PowerState::NotReadyToSwitchOn.on_init_complete());
                self.motion = Motion::Hold;
                self.error_register = 0;
                // The incremental encoder's reference is gone with the power.
                self.frame_offset = 0.0;
                self.homing = None;
                self.homing_attained = false;
                self.homing_error = false;
            } else {
                self.od.reset_communication();
            }
            self.sdo = SdoServer::new(self.p.node);
            self.rpdo_seen = false;
            self.last_tpdo = None;
            self.next_heartbeat_us = None;
            self.last_sync_us = None;
            self.nmt = NmtState::BootUp.after_boot_up();
            out.push(Message::Heartbeat { node: self.p.node, state: NmtState::BootUp }.encode());
            return;
        }
        self.nmt = after;
        if after == NmtState::Operational {
            // The watchdog starts with the first SYNC after the start.
            self.last_sync_us = None;
            self.last_tpdo = None;
        }
    }

    /// This node's RPDO1 with its data bytes: written into the mapped objects when the length
    /// is the mapping's, else EMCY 0x8210 (short) or 0x8220 (long). Returns whether it was
    /// accepted.
    pub fn on_rpdo(&mut self, data: &[u8], now_us: u64, out: &mut Vec<Frame>) -> bool {
        if !self.nmt.pdo_allowed() {
            return true;
        }
        match self.od.apply_rpdo(data) {
            Ok(()) => {
                self.stats.rpdos += 1;
                self.rpdo_seen = true;
                true
            }
            Err(expected) => {
                self.stats.rpdo_bad_length += 1;
                let code = if data.len() < expected { emcy_code::PDO_LENGTH } else { emcy_code::PDO_LENGTH_EXCEEDED };
                self.emcy(code, error_register::COMMUNICATION, [data.len() as u8, 0, 0, 0, 0], now_us, out);
                false
            }
        }
    }

    /// SYNC at `now_us` with the axis at `actual` (axis units, the state at this instant):
    /// answer TPDO1 as its transmission type says, apply the controlword, take the new target
    /// in CSP. Nothing outside Operational.
    pub fn on_sync(&mut self, actual: f64, now_us: u64, out: &mut Vec<Frame>) {
        if !self.nmt.pdo_allowed() {
            return;
        }
        self.stats.syncs += 1;
        self.last_sync_us = Some(now_us);
        let was_enabled = self.power.state().is_operation_enabled();
        if self.rpdo_seen {
            self.power.apply(self.od.int(can_od::CONTROLWORD) as u16);
        }
        let state = self.power.state();
        let mode = self.od.int(can_od::MODES_DISPLAY);
        let csp = mode == MODE_CSP;
        let bit4 = self.rpdo_seen && self.od.int(can_od::CONTROLWORD) as u16 & controlword::HOMING_START_BIT != 0;
        let start_homing = bit4 && !self.homing_bit;
        self.homing_bit = bit4;
        if !(state == PowerState::OperationEnabled && mode == MODE_HOMING) {
            self.homing = None;
        }
        match (state, self.motion) {
            (PowerState::OperationEnabled, _) if mode == MODE_HOMING => {
                if start_homing {
                    self.homing = Some(Homing::start(self.homing_params(), &self.p.sensors, self.target));
                    self.homing_attained = false;
                    self.homing_error = false;
                } else if !bit4 {
                    if let Some(h) = self.homing.as_mut() {
                        h.halt();
                    }
                }
                self.motion = Motion::Follow;
                self.prev_target = self.target;
                if let Some(h) = self.homing.as_mut() {
                    let st = h.step(self.p.cycle_us as f64 * 1e-6);
                    self.target = h.position();
                    match st {
                        HomingState::Running => {}
                        HomingState::Attained { home } => {
                            let off = i64::from(self.increments(actual)) - i64::from(self.increments(home));
                            if !self.homing_attained && off.abs() <= HOME_WINDOW_INCREMENTS {
                                let offset = self.p.scale.to_units(self.od.int(can_od::HOME_OFFSET) as i32);
                                self.frame_offset = offset - home;
                                self.homing_attained = true;
                            }
                        }
                        HomingState::Failed(e) => {
                            if !self.homing_error {
                                tracing::warn!("node {}: homing error: {e:?}", self.p.node);
                            }
                            self.homing_error = true;
                        }
                    }
                }
            }
            (PowerState::OperationEnabled, _) if csp => {
                let target = if self.rpdo_seen {
                    self.p.scale.to_units(self.od.int(can_od::TARGET_POSITION) as i32) - self.frame_offset
                } else {
                    self.target
                };
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
            // Shutdown, disable voltage, disable operation, or enabled without a mode: the
            // power stage holds the axis where it was commanded.
            _ => self.motion = Motion::Hold,
        }
        let position_actual = self.increments(actual + self.frame_offset);
        self.od.set(can_od::STATUSWORD, i128::from(self.statusword()));
        self.od.set(can_od::POSITION_ACTUAL, i128::from(position_actual));
        self.send_tpdo(out);
    }

    /// TPDO1 after a SYNC: every n-th SYNC for types 1–240, on change for the event-driven
    /// types (0, 254, 255; this drive evaluates them at SYNC).
    fn send_tpdo(&mut self, out: &mut Vec<Frame>) {
        let Some(cob) = self.od.tpdo_cob() else { return };
        let data = self.od.tpdo_bytes();
        let send = match self.od.tpdo_transmission() {
            n @ 1..=240 => self.stats.syncs % u64::from(n) == 0,
            _ => self.last_tpdo.as_ref() != Some(&data),
        };
        if send {
            if let Ok(f) = Frame::standard(cob, &data) {
                out.push(f);
            }
            self.last_tpdo = Some(data);
        }
    }

    /// The homing parameters of 0x6098, 0x6099 and 0x609A in axis units.
    fn homing_params(&self) -> HomingParams {
        let k = self.p.scale.increments_per_unit().abs();
        let units = |at| self.od.int(at) as f64 / k;
        HomingParams {
            method: self.od.int(can_od::HOMING_METHOD) as i8,
            speed_switch: units(can_od::HOMING_SPEED_SWITCH),
            speed_zero: units(can_od::HOMING_SPEED_ZERO),
            acceleration: units(can_od::HOMING_ACCELERATION),
        }
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
    pub fn check_watchdog(&mut self, now_us: u64, out: &mut Vec<Frame>) -> bool {
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
    fn fault(&mut self, code: u16, vendor0: u8, now_us: u64, out: &mut Vec<Frame>) {
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
        self.od.set(can_od::ERROR_CODE, i128::from(code));
        self.od.set(can_od::ERROR_REGISTER, i128::from(self.error_register));
        self.emcy(code, self.error_register, [vendor0, 0, 0, 0, 0], now_us, out);
    }

    /// Queues an EMCY unless the inhibit time since the last one has not passed.
    fn emcy(&mut self, code: u16, register: u8, vendor: [u8; 5], now_us: u64, out: &mut Vec<Frame>) {
        if self.last_emcy_us.is_some_and(|t| now_us.saturating_sub(t) < EMCY_INHIBIT_US) {
            self.stats.emcy_inhibited += 1;
            return;
        }
        self.last_emcy_us = Some(now_us);
        self.stats.emcy_sent += 1;
        out.push(
            Message::Emcy { node: self.p.node, emcy: Emcy { error_code: code, error_register: register, vendor } }
                .encode(),
        );
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
    use interpd_canopen::boot::{BootError, CspSetup, NodeBoot, Op, csp_ops};
    use interpd_protocol::cia301::decode;
    use interpd_protocol::cia402::{Rpdo1, Tpdo1, controlword};

    const CYCLE_US: u64 = 4000;

    fn params() -> NodeParams {
        NodeParams {
            node: NodeId::new(2).unwrap(),
            scale: Scale::new(10_000.0).unwrap(),
            cycle_us: CYCLE_US,
            quick_stop_dec: 1000.0,
            sensors: AxisSensors { home_switch: Some(12.5), index_pitch: 5.0, travel: (-100.0, 100.0) },
        }
    }

    fn rpdo(cw: u16, mm: f64) -> Vec<u8> {
        Rpdo1 { controlword: cw, target_position: (mm * 1e4).round() as i32 }.to_bytes().to_vec()
    }

    fn msgs(out: &[Frame]) -> Vec<Message> {
        out.iter().filter_map(|f| decode(f).ok()).collect()
    }

    fn last_tpdo(out: &[Frame]) -> Tpdo1 {
        match msgs(out).into_iter().rev().find(|m| matches!(m, Message::Tpdo1 { .. })) {
            Some(Message::Tpdo1 { pdo, .. }) => pdo,
            _ => panic!("no TPDO1 in {out:?}"),
        }
    }

    fn setup() -> CspSetup {
        CspSetup { vendor_id: 0, product_code: 0x402, cycle_us: CYCLE_US as u32, heartbeat_ms: 100, extra: Vec::new() }
    }

    /// A master's frame to the node.
    fn deliver(n: &mut DriveNode, f: &Frame, t: u64, out: &mut Vec<Frame>) {
        if n.is_sdo_request(f) {
            n.on_sdo(f.payload(), out);
        } else if let Ok(Message::Nmt { command, .. }) = decode(f) {
            n.on_nmt(command, t, out);
        }
    }

    /// Runs the master's boot of `ops` against the node; returns the outcome and the frames
    /// the node sent.
    fn run_boot(n: &mut DriveNode, ops: Vec<Op>, t: u64) -> (Result<(), BootError>, Vec<Frame>) {
        let mut boot = NodeBoot::new(n.id(), ops, 1_000_000, 1_000_000);
        let mut to_node = Vec::new();
        let mut seen = Vec::new();
        let mut result = boot.poll(t, &mut to_node);
        while result.is_none() {
            let frames = std::mem::take(&mut to_node);
            assert!(!frames.is_empty(), "the boot stalls");
            let mut from_node = Vec::new();
            for f in &frames {
                deliver(n, f, t, &mut from_node);
            }
            for f in &from_node {
                result = result.or(boot.on_frame(f, t, &mut to_node));
            }
            seen.extend(from_node);
        }
        // The last frames (NMT start) need no answer.
        for f in &to_node {
            deliver(n, f, t, &mut seen);
        }
        (result.unwrap(), seen)
    }

    /// Boots, starts and enables a node; returns it and the time.
    fn enabled() -> (DriveNode, u64) {
        let (mut n, boot) = DriveNode::boot(params(), 0.0).unwrap();
        assert_eq!(decode(&boot), Ok(Message::Heartbeat { node: params().node, state: NmtState::BootUp }));
        assert_eq!(n.nmt(), NmtState::PreOperational);
        let mut out = Vec::new();
        let mut t = 0;
        n.on_sync(0.0, t, &mut out);
        assert!(out.is_empty(), "no PDO before NMT start");
        let (result, _) = run_boot(&mut n, csp_ops(params().node, &setup()), t);
        result.unwrap();
        assert_eq!(n.nmt(), NmtState::Operational);
        for cw in [controlword::SHUTDOWN, controlword::SWITCH_ON, controlword::ENABLE_OPERATION] {
            t += CYCLE_US;
            assert!(n.on_rpdo(&rpdo(cw, 0.0), t, &mut out));
            n.on_sync(0.0, t, &mut out);
        }
        assert_eq!(n.power_state(), PowerState::OperationEnabled);
        let pdo = last_tpdo(&out);
        assert_eq!(PowerState::from_statusword(pdo.statusword), Some(PowerState::OperationEnabled));
        assert!(pdo.statusword & statusword::CSP_FOLLOWING_BIT != 0);
        (n, t)
    }

    /// An expedited SDO download to the node; panics unless confirmed.
    fn sdo_write(n: &mut DriveNode, index: u16, sub: u8, data: &[u8]) {
        let ccs = 0x23 | ((4 - data.len() as u8) << 2);
        let mut payload = [ccs, index as u8, (index >> 8) as u8, sub, 0, 0, 0, 0];
        payload[4..4 + data.len()].copy_from_slice(data);
        let mut out = Vec::new();
        n.on_sdo(&payload, &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].payload()[0], 0x60, "0x{index:04X}:{sub} refused: {:02X?}", out[0].payload());
    }

    /// Homes the enabled node with `method` (the plant follows the target exactly); returns the
    /// statusword and position actual when homing ended, and the cycles it took.
    fn home(n: &mut DriveNode, t: &mut u64, method: u8, offset_increments: i32) -> (u16, i32, usize) {
        sdo_write(n, 0x607C, 0, &offset_increments.to_le_bytes());
        sdo_write(n, 0x6098, 0, &[method]);
        sdo_write(n, 0x6099, 1, &100_000u32.to_le_bytes());
        sdo_write(n, 0x6099, 2, &10_000u32.to_le_bytes());
        sdo_write(n, 0x609A, 0, &1_000_000u32.to_le_bytes());
        sdo_write(n, 0x6060, 0, &[6]);
        let mut out = Vec::new();
        for k in 1..100_000 {
            *t += CYCLE_US;
            let cw = controlword::ENABLE_OPERATION | controlword::HOMING_START_BIT;
            n.on_rpdo(&rpdo(cw, 0.0), *t, &mut out);
            let actual = n.target();
            n.on_sync(actual, *t, &mut out);
            let pdo = last_tpdo(&out);
            out.clear();
            let done = statusword::HOMING_ATTAINED_BIT | statusword::HOMING_ERROR_BIT;
            if k > 1 && pdo.statusword & done != 0 {
                return (pdo.statusword, pdo.position_actual, k);
            }
        }
        panic!("homing does not end");
    }

    #[test]
    fn homing_on_the_index_below_the_switch_sets_the_home_offset_there() {
        let (mut n, mut t) = enabled();
        let (sw, pos, cycles) = home(&mut n, &mut t, 3, -20_000);
        assert_eq!(sw & 0x3400, statusword::HOMING_ATTAINED_BIT | statusword::TARGET_REACHED_BIT, "{sw:04X}");
        assert_eq!(pos, -20_000, "the home offset at the home position");
        assert_eq!(n.target(), 10.0, "the first index pulse below the switch edge at 12.5");
        assert!(cycles > 300, "the search moved: {cycles} cycles");
        // Back in CSP the drive takes targets in its homed frame: no jump.
        sdo_write(&mut n, 0x6060, 0, &[8]);
        let mut out = Vec::new();
        t += CYCLE_US;
        n.on_rpdo(&rpdo(controlword::ENABLE_OPERATION, -2.0), t, &mut out);
        n.on_sync(10.0, t, &mut out);
        assert_eq!((n.target(), last_tpdo(&out).position_actual), (10.0, -20_000));
        // A reset node forgets the home.
        n.on_nmt(NmtCommand::ResetNode, t, &mut out);
        assert_eq!(n.frame_offset(), 0.0);
    }

    #[test]
    fn homing_on_the_current_position_and_a_homing_error() {
        let (mut n, mut t) = enabled();
        let (sw, pos, cycles) = home(&mut n, &mut t, 37, 5_000);
        assert_eq!(sw & 0x3400, statusword::HOMING_ATTAINED_BIT | statusword::TARGET_REACHED_BIT, "{sw:04X}");
        assert_eq!((pos, n.target(), cycles), (5_000, 0.0, 2));
        let mut p = params();
        p.sensors.home_switch = None;
        let (mut n, _) = DriveNode::boot(p, 0.0).unwrap();
        let (result, _) = run_boot(&mut n, csp_ops(p.node, &setup()), 0);
        result.unwrap();
        let mut out = Vec::new();
        let mut t = 0;
        for cw in [controlword::SHUTDOWN, controlword::SWITCH_ON, controlword::ENABLE_OPERATION] {
            t += CYCLE_US;
            n.on_rpdo(&rpdo(cw, 0.0), t, &mut out);
            n.on_sync(0.0, t, &mut out);
        }
        let (sw, _, _) = home(&mut n, &mut t, 4, 0);
        assert_eq!(sw & 0x3000, statusword::HOMING_ERROR_BIT, "{sw:04X}");
        assert!(n.target() > 100.0, "stopped beyond the travel's end: {}", n.target());
        assert_eq!(n.power_state(), PowerState::OperationEnabled);
    }

    #[test]
    fn csp_follows_the_target_applied_on_sync() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        t += CYCLE_US;
        n.on_rpdo(&rpdo(controlword::ENABLE_OPERATION, 0.5), t, &mut out);
        assert_eq!(n.target(), 0.0, "RPDO alone does not move");
        n.on_sync(0.0, t, &mut out);
        assert_eq!(n.target(), 0.5);
        assert_eq!(last_tpdo(&out).position_actual, 0);
    }

    #[test]
    fn watchdog_trips_after_three_cycles_and_ramps_to_fault() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        // Move at 100 mm/s for a few cycles.
        for k in 1..=5 {
            t += CYCLE_US;
            n.on_rpdo(&rpdo(controlword::ENABLE_OPERATION, 0.4 * k as f64), t, &mut out);
            n.on_sync(0.0, t, &mut out);
        }
        out.clear();
        assert_eq!(n.watchdog_deadline_us(), Some(t + 3 * CYCLE_US + 1));
        assert!(!n.check_watchdog(t + 3 * CYCLE_US, &mut out), "exactly 3 cycles is not yet more than 3");
        assert!(n.check_watchdog(t + 3 * CYCLE_US + 1, &mut out));
        assert_eq!(n.power_state(), PowerState::FaultReactionActive);
        assert_eq!(
            msgs(&out),
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
            n.on_rpdo(&rpdo(cw, n.target()), t, &mut out);
            n.on_sync(n.target(), t, &mut out);
        }
        assert_eq!(n.power_state(), PowerState::OperationEnabled);
    }

    #[test]
    fn quick_stop_command_ramps_to_switch_on_disabled() {
        let (mut n, mut t) = enabled();
        let mut out = Vec::new();
        t += CYCLE_US;
        n.on_rpdo(&rpdo(controlword::ENABLE_OPERATION, 0.4), t, &mut out);
        n.on_sync(0.0, t, &mut out);
        t += CYCLE_US;
        n.on_rpdo(&rpdo(controlword::QUICK_STOP, 0.8), t, &mut out);
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
        assert!(!n.on_rpdo(&[0x0F; 4], t, &mut out));
        n.on_rpdo(&[0x0F; 8], t + 1, &mut out); // inhibited
        n.on_rpdo(&[0x0F; 8], t + EMCY_INHIBIT_US, &mut out);
        let codes: Vec<u16> = msgs(&out)
            .iter()
            .filter_map(|m| if let Message::Emcy { emcy, .. } = m { Some(emcy.error_code) } else { None })
            .collect();
        assert_eq!(codes, [emcy_code::PDO_LENGTH, emcy_code::PDO_LENGTH_EXCEEDED]);
        assert_eq!((n.stats.rpdo_bad_length, n.stats.emcy_inhibited), (3, 1));
        assert_eq!(n.power_state(), PowerState::OperationEnabled, "a bad PDO is not a fault");
        out.clear();
        // The axis lags 11 mm behind: beyond the 10 mm window.
        let t2 = t + 2 * EMCY_INHIBIT_US;
        n.on_rpdo(&rpdo(controlword::ENABLE_OPERATION, 11.0), t2, &mut out);
        n.on_sync(0.0, t2, &mut out);
        assert_eq!(n.power_state(), PowerState::FaultReactionActive);
        assert!(
            msgs(&out)
                .iter()
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
        assert_eq!(msgs(&out), [Message::Heartbeat { node: params().node, state: NmtState::BootUp }]);
        assert_eq!((n.nmt(), n.power_state()), (NmtState::PreOperational, PowerState::SwitchOnDisabled));
        assert_eq!(n.stats.nmt_commands, 4, "counters survive a reset (the boot sent reset communication and start)");
    }

    #[test]
    fn power_on_defaults_until_the_master_configures() {
        let (mut n, _) = DriveNode::boot(params(), 1.0).unwrap();
        let mut out = Vec::new();
        assert_eq!(n.heartbeat_due(0), None, "heartbeat off at power-on");
        assert_eq!(n.heartbeat_due(10_000_000), None);
        n.on_nmt(NmtCommand::Start, 0, &mut out);
        // CiA 402's default RPDO1 carries the controlword alone: a 6-byte RPDO1 is too long.
        assert!(!n.on_rpdo(&rpdo(controlword::SHUTDOWN, 0.0), 0, &mut out));
        assert!(n.on_rpdo(&[0x06, 0x00], 0, &mut out));
        n.on_sync(1.0, 0, &mut out);
        // The default TPDO1 is the statusword alone.
        let tpdo: Vec<&Frame> = out.iter().filter(|f| f.id().raw() == 0x182).collect();
        assert_eq!(tpdo.len(), 1);
        assert_eq!(tpdo[0].len(), 2);
        // Enabled without a mode of operation, the drive holds.
        for cw in [controlword::SWITCH_ON, controlword::ENABLE_OPERATION] {
            n.on_rpdo(&cw.to_le_bytes(), 0, &mut out);
            n.on_sync(1.0, 0, &mut out);
        }
        assert_eq!((n.power_state(), n.motion()), (PowerState::OperationEnabled, Motion::Hold));
    }

    #[test]
    fn the_boot_refuses_a_wrong_identity_and_names_an_abort() {
        let (mut n, _) = DriveNode::boot(params(), 0.0).unwrap();
        let wrong = CspSetup { vendor_id: 0x0000_0195, product_code: 0x1234, ..setup() };
        let (result, _) = run_boot(&mut n, csp_ops(params().node, &wrong), 0);
        assert_eq!(
            result.unwrap_err().to_string(),
            "node 2: wrong device: expected vendor-ID 0x00000195, product code 0x00001234; found vendor-ID \
             0x00000000, product code 0x00000402 (object 0x1018)"
        );
        assert_eq!(n.nmt(), NmtState::PreOperational, "not started");
        let mut bad = setup();
        bad.extra.push(Op::Write {
            at: interpd_canopen::Address::new(0x6065, 0),
            data: vec![1, 2],
            what: "following error window (0x6065:0)".into(),
        });
        let (result, _) = run_boot(&mut n, csp_ops(params().node, &bad), 0);
        assert_eq!(
            result.unwrap_err().to_string(),
            "node 2: following error window (0x6065:0): node 2: SDO download (write) of 0x6065:0 refused by the \
             drive: abort 0x06070013: data type does not match, length of service parameter too low"
        );
        assert_eq!(n.nmt(), NmtState::PreOperational, "not started");
        // Configured: the heartbeat runs at 0x1017.
        let (result, _) = run_boot(&mut n, csp_ops(params().node, &setup()), 0);
        result.unwrap();
        assert_eq!(n.heartbeat_due(0), None);
        assert!(n.heartbeat_due(100_000).is_some());
        assert_eq!(n.heartbeat_due(150_000), None);
        assert!(n.heartbeat_due(200_000).is_some());
    }
}
