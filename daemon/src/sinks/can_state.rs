//! What the CAN master knows about its drives and the bus, shared between the real-time sink
//! (reads states, writes what it sent) and the receive thread (writes states, counts frames).
//!
//! Everything the real-time thread touches is an atomic: it never locks. The fault queue is a
//! mutex, used only by the receive thread and the supervisor.

use super::{DriveNotReady, DrivesNotReady, EnableWindow, NotReady};
use crate::rt::clock;
use interpd_protocol::api::DriveStatus;
use interpd_protocol::cia301::{NmtState, NodeId};
use interpd_protocol::cia402::{DriveCommand, PowerState, Scale};
use serde_json::{Value, json};
use std::collections::VecDeque;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU32, AtomicU64, Ordering};

/// Marks a u32 cell as holding a received value (the low 16 bits).
const VALID: u32 = 1 << 16;
/// Faults kept for the supervisor; older ones are dropped (they are also logged).
const FAULT_QUEUE: usize = 64;

/// One drive as the master sees it.
#[derive(Debug)]
pub struct NodeShared {
    pub axis: usize,
    pub axis_name: String,
    pub node: NodeId,
    pub scale: Scale,
    /// Statusword of the last TPDO1 (| VALID).
    statusword: AtomicU32,
    position_actual: AtomicI32,
    /// NMT state code of the last heartbeat (| VALID).
    nmt: AtomicU32,
    last_tpdo_ns: AtomicU64,
    last_heartbeat_ns: AtomicU64,
    pub tpdo_count: AtomicU64,
    pub heartbeat_count: AtomicU64,
    pub emcy_count: AtomicU64,
    /// Error code of the last EMCY (| VALID).
    last_emcy: AtomicU32,
    /// Controlword of the last RPDO1 the master sent (| VALID).
    controlword: AtomicU32,
    target: AtomicI32,
    /// The drive was in Operation enabled at its last TPDO1 (to notice it leaving).
    pub was_enabled: AtomicBool,
    /// A heartbeat-lost fault was reported and not yet cleared by a new heartbeat.
    pub heartbeat_lost: AtomicBool,
    /// The master has configured the node (boot-up round done); a boot-up message clears it.
    pub configured: AtomicBool,
    /// The boot thread is configuring the node now (its boot-up messages are answers to its
    /// own reset, not reboots).
    pub configuring: AtomicBool,
    /// `drives.reset` asks for a fault reset of this drive: the real-time sink sends the
    /// rising edge of controlword bit 7 while the drive is in Fault (without it, a drive in
    /// Fault stays there).
    pub fault_reset: AtomicBool,
    /// The last failed SDO transfer with the node (configuration or commissioning), as text.
    /// Not touched by the real-time thread.
    pub last_sdo_error: Mutex<Option<String>>,
    /// `machine.home` asks for controlword bit 4 (homing operation start) while the drive is
    /// in Operation enabled.
    pub homing_start: AtomicBool,
    /// `machine.home` is homing this drive (motion may not start).
    pub homing: AtomicBool,
    /// Homed, and not booted again or out of NMT operational since.
    pub homed: AtomicBool,
    /// `[sinks.can.node.N] homing`.
    pub homing_params: interpd_config::sinks::CanHomingConfig,
}

impl NodeShared {
    pub fn new(axis: usize, axis_name: String, node: NodeId, scale: Scale) -> Self {
        Self {
            axis,
            axis_name,
            node,
            scale,
            statusword: AtomicU32::new(0),
            position_actual: AtomicI32::new(0),
            nmt: AtomicU32::new(0),
            last_tpdo_ns: AtomicU64::new(0),
            last_heartbeat_ns: AtomicU64::new(0),
            tpdo_count: AtomicU64::new(0),
            heartbeat_count: AtomicU64::new(0),
            emcy_count: AtomicU64::new(0),
            last_emcy: AtomicU32::new(0),
            controlword: AtomicU32::new(0),
            target: AtomicI32::new(0),
            was_enabled: AtomicBool::new(false),
            heartbeat_lost: AtomicBool::new(false),
            configured: AtomicBool::new(false),
            configuring: AtomicBool::new(false),
            fault_reset: AtomicBool::new(false),
            last_sdo_error: Mutex::new(None),
            homing_start: AtomicBool::new(false),
            homing: AtomicBool::new(false),
            homed: AtomicBool::new(false),
            homing_params: interpd_config::sinks::CanHomingConfig::default(),
        }
    }

    pub fn statusword(&self) -> Option<u16> {
        valid(self.statusword.load(Ordering::Acquire))
    }

    /// The CiA 402 state of the last TPDO1 (`None`: none yet, or an undefined bit pattern).
    pub fn power_state(&self) -> Option<PowerState> {
        self.statusword().and_then(PowerState::from_statusword)
    }

    pub fn position_actual(&self) -> i32 {
        self.position_actual.load(Ordering::Acquire)
    }

    pub fn nmt(&self) -> Option<NmtState> {
        valid(self.nmt.load(Ordering::Acquire)).and_then(|c| NmtState::from_code(c as u8))
    }

    pub fn last_tpdo_ns(&self) -> Option<u64> {
        Some(self.last_tpdo_ns.load(Ordering::Acquire)).filter(|&t| t > 0)
    }

    pub fn last_heartbeat_ns(&self) -> Option<u64> {
        Some(self.last_heartbeat_ns.load(Ordering::Acquire)).filter(|&t| t > 0)
    }

    pub fn last_emcy_code(&self) -> Option<u16> {
        valid(self.last_emcy.load(Ordering::Acquire))
    }

    pub fn controlword(&self) -> Option<u16> {
        valid(self.controlword.load(Ordering::Acquire))
    }

    pub fn target(&self) -> i32 {
        self.target.load(Ordering::Acquire)
    }

    /// Receive side: a TPDO1 arrived at `now_ns`.
    pub fn on_tpdo(&self, statusword: u16, position_actual: i32, now_ns: u64) {
        self.position_actual.store(position_actual, Ordering::Release);
        self.statusword.store(u32::from(statusword) | VALID, Ordering::Release);
        self.last_tpdo_ns.store(now_ns, Ordering::Release);
        self.tpdo_count.fetch_add(1, Ordering::Relaxed);
    }

    pub fn on_heartbeat(&self, state: NmtState, now_ns: u64) {
        if state != NmtState::Operational {
            // Booted again, or stopped or pre-operational: its reference is not to be trusted.
            self.homed.store(false, Ordering::Release);
        }
        self.nmt.store(u32::from(state.code()) | VALID, Ordering::Release);
        self.last_heartbeat_ns.store(now_ns, Ordering::Release);
        self.heartbeat_count.fetch_add(1, Ordering::Relaxed);
    }

    pub fn on_emcy(&self, error_code: u16) {
        self.last_emcy.store(u32::from(error_code) | VALID, Ordering::Release);
        self.emcy_count.fetch_add(1, Ordering::Relaxed);
    }

    /// Sending side (real-time thread): the RPDO1 just sent.
    pub fn on_sent(&self, controlword: u16, target: i32) {
        self.controlword.store(u32::from(controlword) | VALID, Ordering::Relaxed);
        self.target.store(target, Ordering::Relaxed);
    }

    /// Whether the last controlword sent asked for Operation enabled (so leaving it is a
    /// fault, not something the master commanded).
    pub fn commanded_enabled(&self) -> bool {
        self.controlword().is_some_and(|cw| DriveCommand::from_controlword(cw) == DriveCommand::EnableOperation)
    }

    /// The drive's state as a status entry.
    pub fn report(&self, now_ns: u64) -> DriveStatus {
        let ago_ms = |t: Option<u64>| t.map(|t| now_ns.saturating_sub(t) as f64 * 1e-6);
        let state = match (self.statusword(), self.power_state()) {
            (None, _) => "unknown",
            (Some(_), None) => "undefined_statusword",
            (Some(_), Some(s)) => s.name(),
        };
        DriveStatus {
            axis: self.axis_name.clone(),
            node: self.node.get(),
            state: state.to_string(),
            statusword: self.statusword(),
            nmt: self.nmt().map(|s| s.to_string()),
            position_actual: self.position_actual(),
            position_actual_units: self.scale.to_units(self.position_actual()),
            target_position: self.target(),
            controlword: self.controlword(),
            tpdo_count: self.tpdo_count.load(Ordering::Relaxed),
            last_tpdo_ms_ago: ago_ms(self.last_tpdo_ns()),
            last_heartbeat_ms_ago: ago_ms(self.last_heartbeat_ns()),
            heartbeat_lost: self.heartbeat_lost.load(Ordering::Relaxed),
            emcy_count: self.emcy_count.load(Ordering::Relaxed),
            last_emcy_code: self.last_emcy_code().map(|c| format!("0x{c:04X}")),
            last_emcy_text: self.last_emcy_code().map(|c| interpd_protocol::cia301::emcy_code::text(c).to_string()),
            configured: self.configured.load(Ordering::Relaxed),
            last_sdo_error: self.last_sdo_error.lock().unwrap_or_else(|e| e.into_inner()).clone(),
            homed: self.homed.load(Ordering::Acquire),
        }
    }

    /// Who this is, for messages: "drive Y (node 2)".
    pub fn label(&self) -> String {
        format!("drive {} (node {})", self.axis_name, self.node)
    }
}

fn valid(cell: u32) -> Option<u16> {
    (cell & VALID != 0).then_some(cell as u16)
}

/// Counters of the bus, by what happened. Written with relaxed atomics from both threads.
#[derive(Debug, Default)]
pub struct BusCounters {
    /// Frames received (all, including the master's own via loopback).
    pub rx_frames: AtomicU64,
    /// Received frames that are the master's own RPDO1/SYNC/NMT (loopback).
    pub rx_own: AtomicU64,
    pub rx_wrong_dlc: AtomicU64,
    pub rx_unknown_cob_id: AtomicU64,
    pub rx_bad_value: AtomicU64,
    pub rx_not_data: AtomicU64,
    /// Valid CANopen frames from node-IDs that are not configured.
    pub rx_foreign_node: AtomicU64,
    /// SocketCAN error frames (bus-off, error passive, …) and of those the bus-off ones.
    pub rx_error_frames: AtomicU64,
    pub bus_off: AtomicU64,
    /// Receive errors (interface down, …).
    pub rx_errors: AtomicU64,
    pub tx_frames: AtomicU64,
    pub tx_queue_full: AtomicU64,
    pub tx_would_block: AtomicU64,
    pub tx_interface_down: AtomicU64,
    pub tx_other: AtomicU64,
    /// Cycles in a row with at least one failed send (reset by a clean cycle).
    pub tx_fail_streak: AtomicU64,
    /// SYNCs sent by the real-time sink (= cycles published).
    pub syncs: AtomicU64,
    /// Setpoints outside the i32 increment range (not sent; the previous target is kept).
    pub scale_errors: AtomicU64,
    pub nmt_sent: AtomicU64,
    /// Frames the boot thread sent (NMT and SDO requests while configuring drives).
    pub boot_tx: AtomicU64,
    /// SDO responses received from configured nodes.
    pub rx_sdo: AtomicU64,
    pub log_records: AtomicU64,
    pub log_errors: AtomicU64,
}

impl BusCounters {
    pub fn report(&self) -> Value {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        json!({
            "rx_frames": g(&self.rx_frames),
            "rx_own": g(&self.rx_own),
            "rx_wrong_dlc": g(&self.rx_wrong_dlc),
            "rx_unknown_cob_id": g(&self.rx_unknown_cob_id),
            "rx_bad_value": g(&self.rx_bad_value),
            "rx_not_data": g(&self.rx_not_data),
            "rx_foreign_node": g(&self.rx_foreign_node),
            "rx_error_frames": g(&self.rx_error_frames),
            "bus_off": g(&self.bus_off),
            "rx_errors": g(&self.rx_errors),
            "tx_frames": g(&self.tx_frames),
            "tx_queue_full": g(&self.tx_queue_full),
            "tx_would_block": g(&self.tx_would_block),
            "tx_interface_down": g(&self.tx_interface_down),
            "tx_other": g(&self.tx_other),
            "syncs": g(&self.syncs),
            "scale_errors": g(&self.scale_errors),
            "nmt_sent": g(&self.nmt_sent),
            "boot_tx": g(&self.boot_tx),
            "rx_sdo": g(&self.rx_sdo),
            "log_records": g(&self.log_records),
            "log_errors": g(&self.log_errors),
        })
    }
}

/// The whole shared state of one CAN master.
#[derive(Debug)]
pub struct BusShared {
    pub iface: String,
    pub nodes: Vec<NodeShared>,
    pub counters: BusCounters,
    /// The receive side currently gets frames (false after a receive error until the next frame).
    pub iface_up: AtomicBool,
    pub heartbeat_timeout_ns: u64,
    pub enable_window: u32,
    pub tx_fail_cycles: u64,
    /// The boot thread's inbox, for commissioning requests (`None` until it runs).
    pub requests: Mutex<Option<std::sync::mpsc::Sender<super::can_inbox::BootInput>>>,
    /// The SYNC period, for how long a fault reset may take.
    pub cycle_ns: u64,
    /// The nodes (indices into `nodes`) in the order `machine.home` homes them.
    pub home_order: Vec<usize>,
    /// Longest homing of one axis.
    pub homing_timeout_ns: u64,
    /// Motion waits until every drive is homed.
    pub require_homing: bool,
    faults: Mutex<VecDeque<String>>,
}

impl BusShared {
    pub fn new(iface: String, nodes: Vec<NodeShared>, config: &interpd_config::sinks::CanConfig) -> Self {
        Self {
            iface,
            nodes,
            counters: BusCounters::default(),
            iface_up: AtomicBool::new(true),
            heartbeat_timeout_ns: (config.heartbeat_timeout_ms * 1e6) as u64,
            enable_window: config.enable_window_increments,
            tx_fail_cycles: u64::from(config.tx_fail_cycles),
            requests: Mutex::new(None),
            cycle_ns: 4_000_000,
            home_order: Vec::new(),
            homing_timeout_ns: (config.homing_timeout_ms * 1e6) as u64,
            require_homing: config.require_homing,
            faults: Mutex::new(VecDeque::new()),
        }
    }

    pub fn node(&self, id: NodeId) -> Option<&NodeShared> {
        self.nodes.iter().find(|n| n.node == id)
    }

    /// Receive side: a condition that must stop the motion. Logged here, taken by the
    /// supervisor through [`BusShared::take_fault`].
    pub fn push_fault(&self, message: String) {
        tracing::error!("CAN: {message}");
        let mut q = self.faults.lock().unwrap_or_else(|e| e.into_inner());
        if q.len() >= FAULT_QUEUE {
            q.pop_front();
        }
        q.push_back(message);
    }

    pub fn take_fault(&self) -> Option<String> {
        self.faults.lock().unwrap_or_else(|e| e.into_inner()).pop_front()
    }

    /// Why motion may not start, naming every drive that is not ready.
    pub fn ready_for_motion(&self) -> Result<(), DrivesNotReady> {
        let now = clock::now_ns();
        let drives: Vec<DriveNotReady> = self
            .nodes
            .iter()
            .filter_map(|n| {
                let reason = self.not_ready(n, now)?;
                Some(DriveNotReady { axis: n.axis_name.clone(), node: n.node.get(), reason })
            })
            .collect();
        let silent_interface = (!self.iface_up.load(Ordering::Relaxed)).then(|| self.iface.clone());
        if drives.is_empty() && silent_interface.is_none() {
            Ok(())
        } else {
            Err(DrivesNotReady { drives, silent_interface })
        }
    }

    fn not_ready(&self, n: &NodeShared, now: u64) -> Option<NotReady> {
        let Some(sw) = n.statusword() else { return Some(NotReady::NoAnswer) };
        if n.homing.load(Ordering::Acquire) {
            return Some(NotReady::Homing);
        }
        let stale = |t: Option<u64>| t.is_some_and(|t| now.saturating_sub(t) > self.heartbeat_timeout_ns);
        if stale(n.last_tpdo_ns()) {
            let silent_ms = now.saturating_sub(n.last_tpdo_ns().unwrap_or(0)) as f64 * 1e-6;
            return Some(NotReady::Silent { silent_ms });
        }
        if n.heartbeat_lost.load(Ordering::Relaxed) || stale(n.last_heartbeat_ns()) {
            return Some(NotReady::HeartbeatLost);
        }
        match PowerState::from_statusword(sw) {
            Some(PowerState::OperationEnabled) if self.require_homing && !n.homed.load(Ordering::Acquire) => {
                Some(NotReady::NotHomed)
            }
            Some(PowerState::OperationEnabled) => None,
            Some(state) => {
                let off = i64::from(n.position_actual()) - i64::from(n.target());
                let outside_window = (off.unsigned_abs() > u64::from(self.enable_window))
                    .then_some(EnableWindow { offset_increments: off, window_increments: self.enable_window });
                Some(NotReady::NotEnabled { state, statusword: sw, outside_window })
            }
            None => Some(NotReady::UndefinedStatusword(sw)),
        }
    }

    pub fn drives_report(&self) -> Vec<DriveStatus> {
        let now = clock::now_ns();
        self.nodes.iter().map(|n| n.report(now)).collect()
    }

    pub fn bus_report(&self) -> Value {
        let mut v = self.counters.report();
        v["interface"] = json!(self.iface);
        v["interface_receiving"] = json!(self.iface_up.load(Ordering::Relaxed));
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shared() -> BusShared {
        let nodes = (1..=2u8)
            .map(|i| {
                let id = NodeId::new(i).unwrap();
                NodeShared::new(i as usize - 1, format!("{}", (b'W' + i) as char), id, Scale::new(1000.0).unwrap())
            })
            .collect();
        let config = interpd_config::sinks::CanConfig { enable_window_increments: 10, ..Default::default() };
        BusShared::new("vcan0".into(), nodes, &config)
    }

    #[test]
    fn readiness_names_each_drive_and_why() {
        let s = shared();
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(e.contains("drive X (node 1) has not answered") && e.contains("drive Y (node 2)"), "{e}");
        let now = clock::now_ns();
        s.nodes[0].on_tpdo(0x0237, 0, now);
        s.nodes[1].on_tpdo(0x0250, 500, now);
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(!e.contains("node 1"), "{e}");
        assert!(e.contains("drive Y (node 2) is in state Switch on disabled (statusword 0x0250)"), "{e}");
        assert!(e.contains("500 increments from the setpoint"), "{e}");
        s.nodes[1].on_tpdo(0x0208, 0, now);
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(
            e.contains(
                "is in state Fault (statusword 0x0208), not Operation enabled (a fault stays until drives.reset"
            ),
            "{e}"
        );
        s.nodes[1].on_tpdo(0x1237, 500, now);
        assert_eq!(s.ready_for_motion(), Ok(()));
        s.nodes[1].heartbeat_lost.store(true, Ordering::Relaxed);
        assert!(s.ready_for_motion().unwrap_err().to_string().contains("lost its heartbeat"));
    }

    #[test]
    fn homing_and_require_homing_gate_motion_and_a_reboot_forgets_the_home() {
        let mut s = shared();
        s.require_homing = true;
        let now = clock::now_ns();
        for n in &s.nodes {
            n.on_tpdo(0x1237, 0, now);
            n.on_heartbeat(NmtState::Operational, now);
        }
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(e.contains("drive X (node 1) is not homed ([sinks.can] require_homing"), "{e}");
        s.nodes[0].homing.store(true, Ordering::Release);
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(e.contains("drive X (node 1) is homing (machine.home runs)"), "{e}");
        s.nodes[0].homing.store(false, Ordering::Release);
        for n in &s.nodes {
            n.homed.store(true, Ordering::Release);
        }
        assert_eq!(s.ready_for_motion(), Ok(()));
        assert!(s.drives_report().iter().all(|d| d.homed));
        // Booted again (or pre-operational): the drive's reference is gone.
        s.nodes[1].on_heartbeat(NmtState::BootUp, now);
        assert!(!s.nodes[1].homed.load(Ordering::Acquire));
        let e = s.ready_for_motion().unwrap_err().to_string();
        assert!(e.contains("drive Y (node 2) is not homed"), "{e}");
    }

    #[test]
    fn reports_and_faults() {
        let s = shared();
        s.nodes[0].on_emcy(0x8100);
        s.nodes[0].on_sent(0x000F, 42);
        assert!(s.nodes[0].commanded_enabled());
        let r = s.drives_report();
        assert_eq!(r[0].last_emcy_code.as_deref(), Some("0x8100"));
        assert_eq!(r[0].state, "unknown");
        assert_eq!(r[0].target_position, 42);
        assert_eq!(r[1].emcy_count, 0);
        assert!(s.take_fault().is_none());
        s.push_fault("a".into());
        s.push_fault("b".into());
        assert_eq!((s.take_fault(), s.take_fault(), s.take_fault()), (Some("a".into()), Some("b".into()), None));
        assert_eq!(s.bus_report()["interface"], "vcan0");
    }
}
