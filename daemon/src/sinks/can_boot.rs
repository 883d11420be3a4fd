//! The boot of the drives by the master (CiA 302-2, simplified), in a thread of its own off the
//! real-time thread: every node reset (NMT reset communication), its identity checked, its PDOs,
//! mode, interpolation period and heartbeat written over SDO, then started; all nodes side by
//! side, one SDO transfer at a time per node (`interpd_canopen::boot::NodeBoot`). The first
//! round is the start-up: [`super::can::CanMaster::start`] waits for it and refuses to run on
//! a wrong identity or a refused SDO transfer, naming the node; a node that does not answer
//! the reset at all is configured when it boots (its boot-up message), as is a node that
//! reboots later (its configuration is gone with the reset).

use super::can_state::BusShared;
use crate::rt::clock;
use interpd_canopen::boot::{BootError, CspSetup, NodeBoot, Op, csp_ops};
use interpd_canopen::eds;
use interpd_protocol::can_socket::to_socketcan;
use interpd_protocol::cia301::{Frame, NodeId};
use socketcan::{CanSocket, Socket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

/// What the receive thread hands the boot thread.
#[derive(Debug, Clone)]
pub enum BootInput {
    /// An SDO response or a heartbeat of a configured node.
    Frame(Frame),
    /// A node sent its boot-up message: it is not (or no longer) configured.
    Rebooted(usize),
}

/// How one round of configuration went.
#[derive(Debug, Clone, PartialEq)]
pub struct BootReport {
    /// Nodes configured in this round.
    pub nodes: usize,
    /// Nodes that did not answer NMT reset communication (configured when they boot).
    pub silent: usize,
    pub elapsed_ms: f64,
    pub sdo_transfers: u32,
}

/// The boot of each configured node, in the order of the axes.
pub struct BootPlan {
    pub ops: Vec<Vec<Op>>,
    pub sdo_timeout_us: u64,
    pub boot_timeout_us: u64,
}

impl BootPlan {
    /// The CSP configuration of every node from `[sinks.can]`: the identity from
    /// `[sinks.can.node.N]` (or its EDS's `[DeviceInfo]`, or the simulated drive's).
    pub fn from_config(config: &interpd_config::Config, nodes: &[NodeId]) -> Result<BootPlan, String> {
        let can = &config.sinks.can;
        let mut ops = Vec::with_capacity(nodes.len());
        for &node in nodes {
            let c = can.node_config(node.get());
            let from_eds = match &c.eds {
                Some(path) => {
                    let text = std::fs::read_to_string(path)
                        .map_err(|e| format!("sinks.can.node.{node}.eds: cannot read {path}: {e}"))?;
                    let e = eds::parse(&text, node).map_err(|e| format!("sinks.can.node.{node}.eds: {path}: {e}"))?;
                    Some((e.vendor_id, e.product_code))
                }
                None => None,
            };
            let (eds_vendor, eds_product) = from_eds
                .unwrap_or((interpd_config::sinks::SIM_DRIVE_VENDOR_ID, interpd_config::sinks::SIM_DRIVE_PRODUCT_CODE));
            let setup = CspSetup {
                vendor_id: c.vendor_id.unwrap_or(eds_vendor),
                product_code: c.product_code.unwrap_or(eds_product),
                cycle_us: (config.cycle_s() * 1e6).round() as u32,
                heartbeat_ms: can.heartbeat_producer_ms as u16,
                extra: Vec::new(),
            };
            ops.push(csp_ops(node, &setup));
        }
        Ok(BootPlan {
            ops,
            sdo_timeout_us: (can.sdo_timeout_ms * 1e3) as u64,
            boot_timeout_us: (can.boot_timeout_ms.max(100.0) * 1e3) as u64,
        })
    }
}

fn now_us() -> u64 {
    clock::now_ns() / 1000
}

/// The boot thread: the start-up round (its outcome sent on `started`), then reconfiguration
/// of nodes that reboot, until `stop` is set.
pub fn run(
    socket: CanSocket,
    shared: Arc<BusShared>,
    plan: BootPlan,
    inputs: Receiver<BootInput>,
    started: Sender<Result<BootReport, String>>,
    stop: Arc<AtomicBool>,
) {
    let all: Vec<usize> = (0..shared.nodes.len()).collect();
    let mut booted = Vec::new();
    let first = configure(&socket, &shared, &plan, &all, &inputs, &stop, true, &mut booted);
    let ok = first.is_ok();
    let _ = started.send(first);
    if !ok {
        return;
    }
    while !stop.load(Ordering::Acquire) {
        let next = match booted.pop() {
            Some(i) => Some(i),
            None => match inputs.recv_timeout(Duration::from_millis(50)) {
                Ok(BootInput::Rebooted(i)) => Some(i),
                Ok(BootInput::Frame(_)) | Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => return,
            },
        };
        let Some(i) = next else { continue };
        let n = &shared.nodes[i];
        tracing::warn!("CAN: {} booted: configuring it", n.label());
        match configure(&socket, &shared, &plan, &[i], &inputs, &stop, false, &mut booted) {
            Ok(r) if r.nodes == 1 => tracing::info!("CAN: {} configured in {:.1} ms", n.label(), r.elapsed_ms),
            Ok(_) => {}
            Err(e) => shared.push_fault(e),
        }
    }
}

/// Boots the nodes `which` side by side; the first failure ends the round with its message,
/// except a node that does not answer the reset: it is left to its boot-up message. Nodes that
/// boot meanwhile and are not in this round go to `booted`.
/// `reset`: begin with NMT reset communication (a node that has just booted skips it).
#[allow(clippy::too_many_arguments)]
fn configure(
    socket: &CanSocket,
    shared: &BusShared,
    plan: &BootPlan,
    which: &[usize],
    inputs: &Receiver<BootInput>,
    stop: &AtomicBool,
    reset: bool,
    booted: &mut Vec<usize>,
) -> Result<BootReport, String> {
    /// Marks the nodes of a round as being configured, until the round ends however it ends.
    struct Configuring<'a>(&'a BusShared, &'a [usize]);
    impl Drop for Configuring<'_> {
        fn drop(&mut self) {
            for &i in self.1 {
                self.0.nodes[i].configuring.store(false, Ordering::Release);
            }
        }
    }
    for &i in which {
        shared.nodes[i].configuring.store(true, Ordering::Release);
    }
    let _configuring = Configuring(shared, which);
    let t0 = now_us();
    let mut boots: Vec<(usize, NodeBoot)> = which
        .iter()
        .map(|&i| {
            let ops = plan.ops[i].iter().filter(|op| reset || **op != Op::ResetCommunication).cloned().collect();
            shared.nodes[i].configured.store(false, Ordering::Release);
            (i, NodeBoot::new(shared.nodes[i].node, ops, plan.sdo_timeout_us, plan.boot_timeout_us))
        })
        .collect();
    let mut out = Vec::new();
    let mut pending: Vec<usize> = (0..boots.len()).collect();
    let mut transfers = 0;
    let mut silent = 0;
    let mut configured = 0;
    let mut finish = |k: usize, result: Result<(), BootError>, boots: &[(usize, NodeBoot)]| {
        let (i, b) = &boots[k];
        transfers += b.transfers;
        match result {
            Ok(()) => {
                shared.nodes[*i].configured.store(true, Ordering::Release);
                configured += 1;
                Ok(())
            }
            Err(e @ BootError::NoBootUp { .. }) => {
                tracing::warn!("CAN: {}: {e}; it is configured when it boots", shared.nodes[*i].label());
                silent += 1;
                Ok(())
            }
            Err(e) => Err(format!("{}: {e}", shared.nodes[*i].label())),
        }
    };
    for k in 0..boots.len() {
        if let Some(r) = boots[k].1.poll(now_us(), &mut out) {
            finish(k, r, &boots)?;
            pending.retain(|&p| p != k);
        }
    }
    send_all(socket, shared, &mut out);
    while !pending.is_empty() {
        if stop.load(Ordering::Acquire) {
            return Err("the daemon stopped during the drives' configuration".into());
        }
        let now = now_us();
        let next = pending.iter().filter_map(|&k| boots[k].1.deadline_us()).min().unwrap_or(now + 50_000);
        let wait = Duration::from_micros(next.saturating_sub(now).clamp(100, 50_000));
        let frame = match inputs.recv_timeout(wait) {
            Ok(BootInput::Frame(f)) => Some(f),
            // A node of this round that boots is answered by the boot-up frame its boot waits
            // for; another one is configured afterwards.
            Ok(BootInput::Rebooted(i)) => {
                if !booted.contains(&i) {
                    booted.push(i);
                }
                None
            }
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => return Err("the CAN receive thread ended".into()),
        };
        let now = now_us();
        for k in pending.clone() {
            let r = match &frame {
                Some(f) => boots[k].1.on_frame(f, now, &mut out),
                None => None,
            };
            let r = r.or_else(|| boots[k].1.poll(now, &mut out));
            if let Some(r) = r {
                let done = finish(k, r, &boots);
                if done.is_err() {
                    send_all(socket, shared, &mut out);
                }
                done?;
                pending.retain(|&p| p != k);
            }
        }
        send_all(socket, shared, &mut out);
    }
    Ok(BootReport { nodes: configured, silent, elapsed_ms: (now_us() - t0) as f64 * 1e-3, sdo_transfers: transfers })
}

fn send_all(socket: &CanSocket, shared: &BusShared, out: &mut Vec<Frame>) {
    for f in out.drain(..) {
        let Some(cf) = to_socketcan(&f) else { continue };
        // A blocking socket with a write timeout: this thread is not real-time, and a full
        // queue only slows the configuration.
        match socket.write_frame(&cf) {
            Ok(()) => {
                shared.counters.boot_tx.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => tracing::warn!("CAN boot: sending {f:?} failed: {e}"),
        }
    }
}
