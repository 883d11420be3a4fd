//! The receive half of the CAN master, in a thread of its own (not real-time): decodes every
//! frame on the bus, keeps the drive states the real-time sink and `status` read, counts what
//! does not belong, writes the candump log, starts nodes that boot, and turns what must stop
//! the motion (a drive leaving Operation enabled, a lost heartbeat, bus-off, a run of failed
//! sends, a dead interface) into faults for the supervisor.

use super::can_boot::BootInput;
use super::can_log::CandumpLog;
use super::can_state::{BusShared, NodeShared};
use crate::rt::clock;
use interpd_protocol::can_socket::{from_socketcan, to_socketcan};
use interpd_protocol::cia301::{self, DecodeError, Frame, FrameKind, Message, NmtCommand, NmtState};
use interpd_protocol::cia402::PowerState;
use socketcan::{CanSocket, Socket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::{Duration, SystemTime};

/// How long a read waits, so the periodic checks run even on a silent bus.
pub const READ_TIMEOUT: Duration = Duration::from_millis(20);
/// Pause after a receive error before reading again (an interface that is down fails at once).
const ERROR_BACKOFF: Duration = Duration::from_millis(100);
/// A node reported pre-operational is sent NMT start at most this often.
const NMT_RETRY_NS: u64 = 500_000_000;
/// EMCY messages logged per node; later ones are only counted.
const LOGGED_EMCY: u64 = 5;
/// Frames read after the stop request (the master's last frames), at most.
const DRAIN_MAX: usize = 10_000;
/// SocketCAN error class bits (linux/can/error.h).
const CAN_ERR_BUSOFF: u32 = 0x0000_0040;
const CAN_ERR_RESTARTED: u32 = 0x0000_0100;

/// State of the receive loop that only it uses.
struct Rx {
    shared: Arc<BusShared>,
    socket: CanSocket,
    log: Option<CandumpLog>,
    /// Last NMT start sent per node (ns), for the retry limit.
    nmt_sent_ns: Vec<u64>,
    tpdo_lost: Vec<bool>,
    tx_fail_reported: bool,
    /// SDO responses and heartbeats for the boot thread.
    boot: Sender<BootInput>,
}

/// Runs until `stop` is set; returns the candump log (flushed) for the final report.
pub fn run(
    socket: CanSocket,
    shared: Arc<BusShared>,
    log: Option<CandumpLog>,
    boot: Sender<BootInput>,
    stop: Arc<AtomicBool>,
) -> Option<CandumpLog> {
    let n = shared.nodes.len();
    let mut rx =
        Rx { shared, socket, log, nmt_sent_ns: vec![0; n], tpdo_lost: vec![false; n], tx_fail_reported: false, boot };
    while !stop.load(Ordering::Acquire) {
        rx.receive_one();
        rx.periodic();
    }
    // What the master sent last (the shutdown frames) is still in the socket: log it too, up
    // to a bounded number of frames.
    for _ in 0..DRAIN_MAX {
        if !rx.receive_one() {
            break;
        }
    }
    if let Some(log) = rx.log.as_mut() {
        log.flush();
    }
    rx.log
}

impl Rx {
    /// Reads and handles one frame; `false` when none came within the read timeout (or on an
    /// error).
    fn receive_one(&mut self) -> bool {
        let c = &self.shared.counters;
        match self.socket.read_frame_with_timestamps() {
            Ok((f, ts)) => {
                let now = clock::now_ns();
                self.shared.iface_up.store(true, Ordering::Relaxed);
                c.rx_frames.fetch_add(1, Ordering::Relaxed);
                match from_socketcan(&f) {
                    Ok(frame) => {
                        if let Some(log) = self.log.as_mut() {
                            log.record(ts.socket.unwrap_or_else(SystemTime::now), &frame);
                        }
                        self.handle(&frame, now);
                    }
                    // The kernel does not deliver such frames; counted rather than trusted.
                    Err(_) => {
                        c.rx_bad_value.fetch_add(1, Ordering::Relaxed);
                    }
                }
                true
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => false,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => false,
            Err(e) => {
                c.rx_errors.fetch_add(1, Ordering::Relaxed);
                if self.shared.iface_up.swap(false, Ordering::Relaxed) {
                    self.shared.push_fault(format!("CAN interface {}: receive failed: {e}", self.shared.iface));
                }
                std::thread::sleep(ERROR_BACKOFF);
                false
            }
        }
    }

    fn handle(&mut self, frame: &Frame, now: u64) {
        let c = &self.shared.counters;
        // SDO: responses of our nodes go to the boot thread; requests are our own (loopback).
        if let Some(id) = frame.id().as_standard().filter(|_| frame.kind() == FrameKind::Data) {
            let node = cia301::NodeId::new((id & 0x7F) as u8);
            let ours = node.is_some_and(|n| self.index(n).is_some());
            match id & 0x780 {
                0x580 if ours => {
                    c.rx_sdo.fetch_add(1, Ordering::Relaxed);
                    let _ = self.boot.send(BootInput::Frame(*frame));
                    return;
                }
                0x600 if ours => {
                    c.rx_own.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                0x700 if ours => {
                    let _ = self.boot.send(BootInput::Frame(*frame));
                }
                _ => {}
            }
        }
        match cia301::decode(frame) {
            Ok(Message::Tpdo1 { node, pdo }) => match self.index(node) {
                Some(i) => self.on_tpdo(i, pdo.statusword, pdo.position_actual, now),
                None => {
                    c.rx_foreign_node.fetch_add(1, Ordering::Relaxed);
                }
            },
            Ok(Message::Heartbeat { node, state }) => match self.index(node) {
                Some(i) => self.on_heartbeat(i, state, now),
                None => {
                    c.rx_foreign_node.fetch_add(1, Ordering::Relaxed);
                }
            },
            Ok(Message::Emcy { node, emcy }) => match self.shared.node(node) {
                Some(n) => {
                    n.on_emcy(emcy.error_code);
                    // An error (not the "error reset" 0x0000) from a drive the master runs
                    // stops the motion; at rest the supervisor only logs it.
                    if emcy.error_code != cia301::emcy_code::NO_ERROR && n.commanded_enabled() {
                        self.shared.push_fault(format!(
                            "{} EMCY 0x{:04X} {} (error register 0x{:02X})",
                            n.label(),
                            emcy.error_code,
                            cia301::emcy_code::text(emcy.error_code),
                            emcy.error_register
                        ));
                    }
                    let count = n.emcy_count.load(Ordering::Relaxed);
                    if count <= LOGGED_EMCY {
                        let more = if count == LOGGED_EMCY { " (further EMCY only counted)" } else { "" };
                        tracing::warn!(
                            "CAN: {} EMCY 0x{:04X} ({}), error register 0x{:02X}, vendor {:02X?}{more}",
                            n.label(),
                            emcy.error_code,
                            cia301::emcy_code::text(emcy.error_code),
                            emcy.error_register,
                            emcy.vendor
                        );
                    }
                }
                None => {
                    c.rx_foreign_node.fetch_add(1, Ordering::Relaxed);
                }
            },
            // Our own RPDO1/SYNC/NMT through the loopback (or another master's).
            Ok(Message::Rpdo1 { .. } | Message::Sync { .. } | Message::Nmt { .. }) => {
                c.rx_own.fetch_add(1, Ordering::Relaxed);
            }
            Err(DecodeError::WrongDlc { .. }) => {
                c.rx_wrong_dlc.fetch_add(1, Ordering::Relaxed);
            }
            Err(DecodeError::UnknownCobId { .. }) => {
                c.rx_unknown_cob_id.fetch_add(1, Ordering::Relaxed);
            }
            Err(DecodeError::BadValue { .. }) => {
                c.rx_bad_value.fetch_add(1, Ordering::Relaxed);
            }
            Err(DecodeError::NotDataFrame { kind: FrameKind::Error, .. }) => self.on_error_frame(frame),
            Err(DecodeError::NotDataFrame { .. }) => {
                c.rx_not_data.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn index(&self, node: cia301::NodeId) -> Option<usize> {
        self.shared.nodes.iter().position(|n| n.node == node)
    }

    fn on_tpdo(&mut self, i: usize, statusword: u16, position_actual: i32, now: u64) {
        let n = &self.shared.nodes[i];
        // Read what the master asked for before publishing the new state: the real-time sink
        // reacts to the new state, and must not make the drop look commanded.
        let commanded = n.commanded_enabled();
        n.on_tpdo(statusword, position_actual, now);
        if std::mem::replace(&mut self.tpdo_lost[i], false) {
            tracing::info!("CAN: {} sends TPDO1 again", n.label());
        }
        let enabled = PowerState::from_statusword(statusword) == Some(PowerState::OperationEnabled);
        let was = n.was_enabled.swap(enabled, Ordering::Relaxed);
        if was && !enabled && commanded {
            let state = PowerState::from_statusword(statusword).map_or("an undefined state".into(), |s| s.to_string());
            let emcy = n
                .last_emcy_code()
                .map(|c| format!(", last EMCY 0x{c:04X} {}", cia301::emcy_code::text(c)))
                .unwrap_or_default();
            self.shared.push_fault(format!(
                "{} left Operation enabled: now {state} (statusword 0x{statusword:04X}{emcy})",
                n.label()
            ));
        }
    }

    fn on_heartbeat(&mut self, i: usize, state: NmtState, now: u64) {
        let n = &self.shared.nodes[i];
        n.on_heartbeat(state, now);
        if n.heartbeat_lost.swap(false, Ordering::Relaxed) {
            tracing::info!("CAN: {} heartbeat is back ({state})", n.label());
        }
        match state {
            NmtState::BootUp => {
                if n.was_enabled.swap(false, Ordering::Relaxed) {
                    self.shared.push_fault(format!("{} rebooted while in Operation enabled", n.label()));
                }
                // A node that boots has no configuration (any more): the boot thread configures
                // and starts it, unless it is configuring it right now (then this boot-up is
                // the answer to its reset).
                n.configured.store(false, Ordering::Release);
                if !n.configuring.load(Ordering::Acquire) {
                    let _ = self.boot.send(BootInput::Rebooted(i));
                }
            }
            NmtState::PreOperational if n.configured.load(Ordering::Acquire) => self.nmt_start(i, now, false),
            NmtState::PreOperational => {}
            NmtState::Operational | NmtState::Stopped => {}
        }
    }

    /// NMT start to node `i` (immediately after a boot-up, else at most every NMT_RETRY_NS).
    fn nmt_start(&mut self, i: usize, now: u64, force: bool) {
        if !force && now.saturating_sub(self.nmt_sent_ns[i]) < NMT_RETRY_NS {
            return;
        }
        self.nmt_sent_ns[i] = now;
        let m = Message::Nmt { command: NmtCommand::Start, target: Some(self.shared.nodes[i].node) };
        if let Some(f) = to_socketcan(&m.encode()) {
            // This socket is blocking with a write timeout of its own kind: a short wait here
            // delays only frame reception, never the real-time cycle.
            match self.socket.write_frame(&f) {
                Ok(()) => {
                    self.shared.counters.nmt_sent.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => tracing::warn!("CAN: NMT start to node {}: {e}", self.shared.nodes[i].node),
            }
        }
    }

    fn on_error_frame(&mut self, frame: &Frame) {
        let c = &self.shared.counters;
        c.rx_error_frames.fetch_add(1, Ordering::Relaxed);
        let class = frame.id().raw();
        if class & CAN_ERR_BUSOFF != 0 {
            c.bus_off.fetch_add(1, Ordering::Relaxed);
            self.shared.push_fault(format!(
                "CAN interface {} is bus-off (error class 0x{class:08X}): no frame reaches the drives",
                self.shared.iface
            ));
        } else if class & CAN_ERR_RESTARTED != 0 {
            tracing::info!("CAN: controller on {} restarted after bus-off", self.shared.iface);
        } else {
            tracing::warn!(
                "CAN: error frame on {}: class 0x{class:08X}, data {:02X?}",
                self.shared.iface,
                frame.payload()
            );
        }
    }

    /// Heartbeat and TPDO1 supervision, the send-failure streak, the log flush.
    fn periodic(&mut self) {
        let now = clock::now_ns();
        let timeout = self.shared.heartbeat_timeout_ns;
        for (i, n) in self.shared.nodes.iter().enumerate() {
            let silent = |t: Option<u64>| t.is_some_and(|t| now.saturating_sub(t) > timeout);
            if silent(n.last_heartbeat_ns()) && !n.heartbeat_lost.swap(true, Ordering::Relaxed) {
                self.shared.push_fault(format!(
                    "{} heartbeat lost: none for {:.0} ms (timeout {:.0} ms)",
                    n.label(),
                    since_ms(now, n.last_heartbeat_ns()),
                    timeout as f64 * 1e-6
                ));
            }
            if silent(n.last_tpdo_ns()) && !self.tpdo_lost[i] {
                self.tpdo_lost[i] = true;
                report_tpdo_lost(&self.shared, n, now);
            }
        }
        let c = &self.shared.counters;
        let streak = c.tx_fail_streak.load(Ordering::Relaxed);
        if streak >= self.shared.tx_fail_cycles && !self.tx_fail_reported {
            self.tx_fail_reported = true;
            let g = |a: &std::sync::atomic::AtomicU64| a.load(Ordering::Relaxed);
            self.shared.push_fault(format!(
                "sending on CAN interface {} failed in {streak} cycles in a row (ENOBUFS {}, EAGAIN {}, interface down \
                 {}, other {})",
                self.shared.iface,
                g(&c.tx_queue_full),
                g(&c.tx_would_block),
                g(&c.tx_interface_down),
                g(&c.tx_other)
            ));
        } else if streak == 0 {
            self.tx_fail_reported = false;
        }
        if let Some(log) = self.log.as_mut() {
            log.flush_if_due();
            c.log_records.store(log.records, Ordering::Relaxed);
            c.log_errors.store(log.errors, Ordering::Relaxed);
        }
    }
}

fn since_ms(now: u64, t: Option<u64>) -> f64 {
    now.saturating_sub(t.unwrap_or(0)) as f64 * 1e-6
}

/// TPDO1s stop: only a fault while the master sends SYNC (it always does while running).
fn report_tpdo_lost(shared: &BusShared, n: &NodeShared, now: u64) {
    if n.was_enabled.load(Ordering::Relaxed) {
        shared.push_fault(format!("{} sends no TPDO1: none for {:.0} ms", n.label(), since_ms(now, n.last_tpdo_ns())));
    }
}
