//! The real-time half of the CAN master: per cycle one RPDO1 per drive (controlword + target
//! position in increments), then SYNC (docs/can.md).
//!
//! The socket is non-blocking, so a full queue or a dead interface costs one failed `write`
//! per frame, never a wait: failures are counted by errno class, and a run of failing cycles
//! is reported to the receive thread, which turns it into a controlled stop. Nothing here
//! allocates, locks or logs.
//!
//! Controlwords: a drive in Operation enabled keeps ENABLE_OPERATION. Other drives are moved
//! one step per cycle toward Operation enabled (shutdown → switch on → enable operation) only
//! while the machine stands and the drive's position actual lies within the enable window of
//! the setpoint (so enabling cannot make it jump). A drive in Fault stays there until
//! `drives.reset` asks for its fault reset (the rising edge of bit 7, at standstill): a fault
//! is acknowledged by the operator, never by the master on its own. During motion a drive
//! that is not enabled gets QUICK_STOP: the master never re-enables a drive in mid-motion.
//! While `machine.home` homes a drive (at rest), its controlword carries bit 4, homing
//! operation start.

use super::can_state::BusShared;
use super::{SetpointSink, SinkError};
use interpd_protocol::can_socket::{SendFailure, to_socketcan};
use interpd_protocol::cia301::{Message, NmtCommand};
use interpd_protocol::cia402::{PowerState, Rpdo1, controlword, controlword_toward_enabled};
use interpd_protocol::shm::{Setpoints, flags};
use socketcan::{CanSocket, Socket};
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// The RPDO1/SYNC producer, owned by the real-time thread.
pub struct CanSink {
    socket: CanSocket,
    shared: Arc<BusShared>,
    /// Controlword sent last cycle, per node (for the fault-reset edge).
    last_cw: Vec<u16>,
    /// Target sent last cycle, per node (kept when a setpoint does not scale).
    last_target: Vec<i32>,
}

impl CanSink {
    /// `socket` must be open on the bus and non-blocking; `initial_targets` are the increments
    /// the drives stand at (the start position).
    pub fn new(socket: CanSocket, shared: Arc<BusShared>, initial_targets: Vec<i32>) -> Result<Self, SinkError> {
        socket.set_nonblocking(true).map_err(|e| SinkError::Setup {
            sink: format!("can:{}", shared.iface),
            message: format!("cannot make the socket non-blocking: {e}"),
        })?;
        let n = shared.nodes.len();
        Ok(Self { socket, shared, last_cw: vec![controlword::DISABLE_VOLTAGE; n], last_target: initial_targets })
    }

    /// Sends one frame; `false` (counted) if it could not be sent.
    fn send(&self, m: &Message) -> bool {
        let Some(frame) = to_socketcan(&m.encode()) else { return false };
        let c = &self.shared.counters;
        match self.socket.write_frame(&frame) {
            Ok(()) => {
                c.tx_frames.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(e) => {
                let counter = match SendFailure::classify(&e) {
                    SendFailure::QueueFull => &c.tx_queue_full,
                    SendFailure::WouldBlock => &c.tx_would_block,
                    SendFailure::InterfaceDown => &c.tx_interface_down,
                    SendFailure::Other => &c.tx_other,
                };
                counter.fetch_add(1, Ordering::Relaxed);
                false
            }
        }
    }

    /// The controlword for drive `i` this cycle (see the module comment).
    fn controlword(&self, i: usize, target: i32, standing: bool) -> u16 {
        let n = &self.shared.nodes[i];
        let Some(state) = n.power_state() else {
            // Nothing heard yet (or an undefined statusword): ask for nothing.
            return controlword::DISABLE_VOLTAGE;
        };
        if state == PowerState::OperationEnabled {
            // Homing mode: bit 4 starts the homing operation (machine.home, at rest).
            if standing && n.homing_start.load(Ordering::Acquire) {
                return controlword::ENABLE_OPERATION | controlword::HOMING_START_BIT;
            }
            return controlword::ENABLE_OPERATION;
        }
        if standing && state == PowerState::Fault {
            // Fault → Switch on disabled moves nothing, so the reset needs no enable window.
            return if n.fault_reset.load(Ordering::Acquire) {
                controlword_toward_enabled(state, self.last_cw[i])
            } else {
                controlword::DISABLE_VOLTAGE
            };
        }
        let off = (i64::from(n.position_actual()) - i64::from(target)).unsigned_abs();
        if standing && off <= u64::from(self.shared.enable_window) {
            controlword_toward_enabled(state, self.last_cw[i])
        } else if standing {
            controlword::DISABLE_VOLTAGE
        } else {
            controlword::QUICK_STOP
        }
    }
}

impl SetpointSink for CanSink {
    fn publish(&mut self, sp: &Setpoints) -> Result<(), SinkError> {
        let standing = sp.flags & flags::IDLE != 0;
        let mut ok = true;
        for i in 0..self.shared.nodes.len() {
            let node = &self.shared.nodes[i];
            let target = match node.scale.to_increments(sp.pos[node.axis]) {
                Ok(t) => t,
                Err(_) => {
                    self.shared.counters.scale_errors.fetch_add(1, Ordering::Relaxed);
                    ok = false;
                    self.last_target[i]
                }
            };
            let cw = self.controlword(i, target, standing);
            ok &=
                self.send(&Message::Rpdo1 { node: node.node, pdo: Rpdo1 { controlword: cw, target_position: target } });
            node.on_sent(cw, target);
            self.last_cw[i] = cw;
            self.last_target[i] = target;
        }
        // SYNC even after a failed RPDO: the other drives must not lose their cycle.
        ok &= self.send(&Message::Sync { counter: None });
        let c = &self.shared.counters;
        c.syncs.fetch_add(1, Ordering::Relaxed);
        if ok {
            c.tx_fail_streak.store(0, Ordering::Relaxed);
            Ok(())
        } else {
            c.tx_fail_streak.fetch_add(1, Ordering::Relaxed);
            Err(SinkError::Publish)
        }
    }
}

impl Drop for CanSink {
    /// An orderly end (the real-time thread exits after the motion came to rest): shutdown to
    /// every drive (Operation enabled → Ready to switch on, transition 8) applied on a last
    /// SYNC, then NMT pre-operational, so no drive's SYNC watchdog trips when the cycle stops.
    fn drop(&mut self) {
        for (i, node) in self.shared.nodes.iter().enumerate() {
            let pdo = Rpdo1 { controlword: controlword::SHUTDOWN, target_position: self.last_target[i] };
            self.send(&Message::Rpdo1 { node: node.node, pdo });
        }
        self.send(&Message::Sync { counter: None });
        for node in &self.shared.nodes {
            // Not configured for motion any more: the receive thread must not start it again
            // when its heartbeat says pre-operational.
            node.configured.store(false, std::sync::atomic::Ordering::Release);
            self.send(&Message::Nmt { command: NmtCommand::EnterPreOperational, target: Some(node.node) });
        }
    }
}
