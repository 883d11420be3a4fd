//! The CANopen master (sink `can:IFACE`): CiA 402 cyclic synchronous position over SocketCAN.
//!
//! - [`CanMaster::start`] opens the bus, starts the receive thread (`can_rx.rs`) and the boot
//!   thread (`can_boot.rs`), which resets, checks and configures every node over SDO and starts
//!   it; any failure there refuses the start, naming the node. Then SYNC once per cycle until
//!   every drive has answered with TPDO1 (or `boot_timeout_ms` passed): the drives' actual
//!   positions become the daemon's start position, so nothing jumps when they are enabled.
//! - The [`CanSink`] it returns goes into the real-time thread: per cycle one RPDO1 per axis,
//!   then SYNC, on a non-blocking socket (`can_sink.rs`).
//! - `BusShared` (`can_state.rs`) is the [`DriveMonitor`] the service asks before `motion.start` and polls
//!   for faults; `status.drives` and `status.can_bus` come from it.
//! - `--candump FILE` is written by the receive thread (`can_log.rs`).

use super::can_boot::{BootInput, BootPlan, BootReport};
use super::can_log::CandumpLog;
pub use super::can_sink::CanSink;
use super::can_state::{BusShared, NodeShared};
use super::{DriveMonitor, SinkError};
use crate::rt::clock;
use interpd_config::Config;
use interpd_protocol::MAX_AXES;
use interpd_protocol::can_socket::to_socketcan;
use interpd_protocol::cia301::{Message, NodeId};
use interpd_protocol::cia402::Scale;
use serde_json::Value;
use socketcan::{CanSocket, Socket, SocketOptions};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// What [`CanMaster::start`] hands over.
pub struct CanStart {
    pub master: CanMaster,
    /// For the real-time thread.
    pub sink: CanSink,
    /// Where the drives stand (axis units; 0 for drives that did not answer in time).
    pub start_position: [f64; MAX_AXES],
    /// Drives that answered during start-up, of all configured.
    pub answered: usize,
    /// The configuration round of the boot thread.
    pub boot: BootReport,
}

/// The running master: the receive thread and the shared state.
pub struct CanMaster {
    shared: Arc<BusShared>,
    stop: Arc<AtomicBool>,
    rx: Option<JoinHandle<Option<CandumpLog>>>,
    boot: Option<JoinHandle<()>>,
}

impl DriveMonitor for BusShared {
    fn drives(&self) -> Vec<interpd_protocol::api::DriveStatus> {
        self.drives_report()
    }
    fn bus(&self) -> Option<Value> {
        Some(self.bus_report())
    }
    fn ready_for_motion(&self) -> Result<(), super::DrivesNotReady> {
        BusShared::ready_for_motion(self)
    }
    fn take_fault(&self) -> Option<String> {
        BusShared::take_fault(self)
    }
    fn sdo(
        &self,
        node: u8,
        op: super::drive_command::SdoOp,
    ) -> Result<Vec<u8>, super::drive_command::DriveCommandError> {
        self.sdo_command(node, op)
    }
    fn reset(&self, nodes: &[u8]) -> super::drive_command::ResetOutcome {
        self.reset_command(nodes)
    }
    fn home(&self, reposition: super::drive_command::Reposition) -> super::drive_command::HomeOutcome {
        self.home_command(reposition)
    }
    fn homed(&self) -> Option<bool> {
        Some(self.nodes.iter().all(|n| n.homed.load(Ordering::Acquire)))
    }
}

impl CanMaster {
    /// Opens `[sinks.can] interface`, starts the receive thread and the drives (see the module
    /// comment). `candump`: write the bus traffic to this file.
    pub fn start(config: &Config, candump: Option<&Path>) -> Result<CanStart, SinkError> {
        let can = &config.sinks.can;
        let iface = can.interface.clone();
        let setup = |message: String| SinkError::Setup { sink: format!("can:{iface}"), message };
        let n_axes = config.axes.len();
        let mut nodes = Vec::with_capacity(n_axes);
        for (i, (id, k)) in can.node_ids(n_axes).into_iter().zip(can.scales(n_axes)).enumerate() {
            let node =
                NodeId::new(id).ok_or_else(|| setup(format!("sinks.can.nodes[{i}]: node-ID {id} is not 1..=127")))?;
            let scale = Scale::new(k).map_err(|e| setup(format!("sinks.can.increments_per_unit[{i}]: {e}")))?;
            let mut shared = NodeShared::new(i, config.axes[i].name.to_string(), node, scale);
            shared.homing_params = can.node_config(id).homing;
            nodes.push(shared);
        }
        let open = |what: &str| {
            CanSocket::open(&iface).map_err(|e| {
                setup(format!(
                    "cannot open the {what} socket on CAN interface {iface}: {e} (does it exist and is it up? `ip link \
                     show {iface}`)"
                ))
            })
        };
        let rx_socket = open("receive")?;
        let sock_err = |e: std::io::Error| setup(format!("socket option: {e}"));
        rx_socket.set_read_timeout(super::can_rx::READ_TIMEOUT).map_err(sock_err)?;
        rx_socket.set_write_timeout(super::can_rx::READ_TIMEOUT).map_err(sock_err)?;
        // Kernel receive timestamps for the log, and error frames (bus-off, error passive).
        rx_socket.set_recv_timestamp(true).map_err(sock_err)?;
        rx_socket.set_error_filter_accept_all().map_err(sock_err)?;
        let tx_socket = open("send")?;
        tx_socket.set_write_timeout(Duration::from_millis(50)).map_err(sock_err)?;
        let boot_socket = open("configuration")?;
        boot_socket.set_write_timeout(Duration::from_millis(50)).map_err(sock_err)?;
        let log = candump.map(|p| CandumpLog::create(p, &iface)).transpose().map_err(setup)?;
        let ids: Vec<NodeId> = nodes.iter().map(|n| n.node).collect();
        let plan = BootPlan::from_config(config, &ids).map_err(setup)?;

        let mut bus = BusShared::new(iface.clone(), nodes, can);
        bus.cycle_ns = (config.cycle_s() * 1e9) as u64;
        bus.home_order = can.home_axes(&config.axes);
        let (boot_tx, boot_rx) = std::sync::mpsc::channel::<BootInput>();
        *bus.requests.get_mut().unwrap_or_else(|p| p.into_inner()) = Some(boot_tx.clone());
        let shared = Arc::new(bus);
        let stop = Arc::new(AtomicBool::new(false));
        let (s2, stop2) = (shared.clone(), stop.clone());
        let rx = std::thread::Builder::new()
            .name("interpd-can-rx".into())
            .spawn(move || super::can_rx::run(rx_socket, s2, log, boot_tx, stop2))
            .map_err(|e| setup(format!("cannot start the receive thread: {e}")))?;
        let (started_tx, started_rx) = std::sync::mpsc::channel();
        let (s3, stop3) = (shared.clone(), stop.clone());
        let boot_thread = std::thread::Builder::new()
            .name("interpd-can-boot".into())
            .spawn(move || super::can_boot::run(boot_socket, s3, plan, boot_rx, started_tx, stop3))
            .map_err(|e| setup(format!("cannot start the boot thread: {e}")))?;
        let master = CanMaster { shared: shared.clone(), stop, rx: Some(rx), boot: Some(boot_thread) };
        // The boot thread bounds every wait by its own timeouts; an ended thread closes the channel.
        let report = match started_rx.recv() {
            Ok(Ok(report)) => report,
            Ok(Err(message)) => return Err(setup(format!("configuring the drives failed: {message}; nothing moves"))),
            Err(_) => return Err(setup("the boot thread ended without a result".into())),
        };
        tracing::info!(
            "CAN {iface}: {} drives configured in {:.1} ms ({} SDO transfers)",
            report.nodes,
            report.elapsed_ms,
            report.sdo_transfers
        );

        let answered = boot(&tx_socket, &shared, config.cycle_s(), can.boot_timeout_ms * 1e-3);
        let mut start_position = [0.0; MAX_AXES];
        let mut targets = Vec::with_capacity(n_axes);
        for n in &shared.nodes {
            let actual = if n.statusword().is_some() { n.position_actual() } else { 0 };
            start_position[n.axis] = n.scale.to_units(actual);
            targets.push(actual);
        }
        let sink = CanSink::new(tx_socket, shared, targets)?;
        Ok(CanStart { master, sink, start_position, answered, boot: report })
    }

    /// The drive monitor for the motion core.
    pub fn monitor(&self) -> Arc<dyn DriveMonitor> {
        self.shared.clone()
    }

    /// Stops the receive thread (after the real-time thread ended) and returns the bus counters
    /// for the exit report.
    pub fn shutdown(mut self) -> Value {
        self.stop_rx();
        self.shared.bus_report()
    }

    fn stop_rx(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(h) = self.boot.take() {
            let _ = h.join();
        }
        if let Some(h) = self.rx.take() {
            if let Ok(Some(log)) = h.join() {
                let c = &self.shared.counters;
                c.log_records.store(log.records, Ordering::Relaxed);
                c.log_errors.store(log.errors, Ordering::Relaxed);
            }
        }
    }
}

impl Drop for CanMaster {
    fn drop(&mut self) {
        self.stop_rx();
    }
}

/// SYNC once per cycle (the boot thread has started the nodes) until every drive has sent
/// TPDO1 or `timeout_s` passed. Returns how many answered. Not real-time: blocking sends are
/// fine here.
fn boot(socket: &CanSocket, shared: &BusShared, cycle_s: f64, timeout_s: f64) -> usize {
    let send = |m: Message| {
        if let Some(f) = to_socketcan(&m.encode()) {
            if let Err(e) = socket.write_frame(&f) {
                tracing::warn!("CAN start-up: sending {m:?} failed: {e}");
            }
        }
    };
    let period_ns = (cycle_s * 1e9) as u64;
    let t0 = clock::now_ns();
    let until = t0 + (timeout_s * 1e9) as u64;
    let answered = || shared.nodes.iter().filter(|n| n.statusword().is_some()).count();
    let mut k = 1;
    while answered() < shared.nodes.len() && clock::now_ns() < until {
        send(Message::Sync { counter: None });
        clock::sleep_until_ns(t0 + k * period_ns);
        k += 1;
    }
    let got = answered();
    if got < shared.nodes.len() {
        let missing: Vec<String> =
            shared.nodes.iter().filter(|n| n.statusword().is_none()).map(NodeShared::label).collect();
        tracing::warn!(
            "CAN start-up: no answer within {:.0} ms from {}; they are taken on when they boot (motion.start waits for \
             them)",
            timeout_s * 1e3,
            missing.join(", ")
        );
    }
    got
}
