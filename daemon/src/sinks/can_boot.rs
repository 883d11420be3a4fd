//! The boot of the drives by the master (CiA 302-2, simplified), in a thread of its own off the
//! real-time thread: every node reset (NMT reset communication), its identity checked, its PDOs,
//! mode, interpolation period and heartbeat written over SDO, then started; all nodes side by
//! side, one SDO transfer at a time per node (`interpd_canopen::boot::NodeBoot`). The first
//! round is the start-up: [`super::can::CanMaster::start`] waits for it and refuses to run on
//! a wrong identity or a refused SDO transfer, naming the node; a node that does not answer
//! the reset at all is configured when it boots (its boot-up message), as is a node that
//! reboots later (its configuration is gone with the reset).
//!
//! The thread also serves the commissioning transfers of `drives.sdo_read` and
//! `drives.sdo_write` ([`SdoRequest`]), one at a time, between configuration rounds: it owns
//! the master's SDO channel to every node, so they never overlap a configuration transfer.

pub use super::can_inbox::{BootInput, SdoRequest};
use super::can_state::BusShared;
use super::drive_command::SdoOp;
use crate::rt::clock;
use interpd_canopen::Address;
use interpd_canopen::boot::{BootError, CspSetup, NodeBoot, Op, csp_ops};
use interpd_canopen::eds;
use interpd_canopen::sdo_client::{SdoClient, Step};
use interpd_protocol::api::SdoType;
use interpd_protocol::can_socket::to_socketcan;
use interpd_protocol::cia301::{Frame, NodeId};
use socketcan::{CanSocket, Socket};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

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
    /// `[sinks.can.node.N]` (or its EDS's `[DeviceInfo]`, or the simulated drive's), then the
    /// DCF's `ParameterValue`s and the node's `sdo` values.
    pub fn from_config(config: &interpd_config::Config, nodes: &[NodeId]) -> Result<BootPlan, String> {
        let can = &config.sinks.can;
        let mut ops = Vec::with_capacity(nodes.len());
        for &node in nodes {
            let c = can.node_config(node.get());
            let mut extra = Vec::new();
            let from_eds = match &c.eds {
                Some(path) => {
                    let text = std::fs::read_to_string(path)
                        .map_err(|e| format!("sinks.can.node.{node}.eds: cannot read {path}: {e}"))?;
                    let e = eds::parse(&text, node).map_err(|e| format!("sinks.can.node.{node}.eds: {path}: {e}"))?;
                    extra.extend(dcf_values(&e, path));
                    Some((e.vendor_id, e.product_code))
                }
                None => None,
            };
            for (k, v) in c.sdo.iter().enumerate() {
                extra.push(table_value(node, k, v)?);
            }
            let (eds_vendor, eds_product) = from_eds
                .unwrap_or((interpd_config::sinks::SIM_DRIVE_VENDOR_ID, interpd_config::sinks::SIM_DRIVE_PRODUCT_CODE));
            let setup = CspSetup {
                vendor_id: c.vendor_id.unwrap_or(eds_vendor),
                product_code: c.product_code.unwrap_or(eds_product),
                cycle_us: (config.cycle_s() * 1e6).round() as u32,
                heartbeat_ms: can.heartbeat_producer_ms as u16,
                extra,
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

/// Whether the master writes `index` itself for CSP (PDOs, SYNC, cycle, heartbeat, mode,
/// interpolation period): a DCF's value there would be overwritten or, for a mapping written
/// while its PDO is valid, refused.
fn master_owned(index: u16) -> bool {
    matches!(index, 0x1005 | 0x1006 | 0x1017 | 0x1400..=0x1BFF | 0x6060 | 0x60C2)
}

/// The downloads of a DCF's `ParameterValue`s: writable entries, in index order, except the
/// objects the master configures itself.
fn dcf_values(e: &eds::Eds, path: &str) -> Vec<Op> {
    e.parameters
        .iter()
        .filter_map(|&at| {
            let entry = e.od.entry(at)?;
            if !entry.access.writable() || master_owned(at.index) {
                tracing::debug!("CAN: {path}: ParameterValue of {at} not written (read-only or set by the master)");
                return None;
            }
            Some(Op::Write {
                at,
                data: entry.value.clone(),
                what: format!("{path} ParameterValue {} ({at})", entry.name),
            })
        })
        .collect()
}

/// One `[sinks.can.node.N] sdo` entry as a download, its type and value checked.
fn table_value(node: NodeId, k: usize, v: &interpd_config::sinks::CanSdoValue) -> Result<Op, String> {
    let key = format!("sinks.can.node.{node}.sdo[{k}]");
    let ty = SdoType::from_name(&v.ty)
        .ok_or_else(|| format!("{key}.type: unknown type {:?}; expected one of {}", v.ty, SdoType::names()))?;
    let text = v.value_text().map_err(|e| format!("{key}.value: {e}"))?;
    let data = ty.encode(&serde_json::Value::String(text)).map_err(|e| format!("{key}.value: {e}"))?;
    let at = Address::new(v.index, v.sub);
    Ok(Op::Write { at, data, what: format!("[sinks.can.node.{node}] sdo[{k}] ({at})") })
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
    let mut wait = Waiting::default();
    let first = configure(&socket, &shared, &plan, &all, &inputs, &stop, true, &mut wait);
    let ok = first.is_ok();
    let _ = started.send(first);
    if !ok {
        return;
    }
    while !stop.load(Ordering::Acquire) {
        // A node to configure comes before a commissioning transfer: it may be its target.
        let next = match wait.booted.pop() {
            Some(i) => Some(i),
            None => match wait.requests.pop_front() {
                Some(req) => {
                    serve(&socket, &shared, &plan, req, &inputs, &stop, &mut wait);
                    continue;
                }
                None => match inputs.recv_timeout(Duration::from_millis(50)) {
                    Ok(BootInput::Rebooted(i)) => Some(i),
                    Ok(BootInput::Sdo(req)) => {
                        wait.requests.push_back(req);
                        None
                    }
                    Ok(BootInput::Frame(_)) | Err(RecvTimeoutError::Timeout) => None,
                    Err(RecvTimeoutError::Disconnected) => return,
                },
            },
        };
        let Some(i) = next else { continue };
        let n = &shared.nodes[i];
        tracing::warn!("CAN: {} booted: configuring it", n.label());
        match configure(&socket, &shared, &plan, &[i], &inputs, &stop, false, &mut wait) {
            Ok(r) if r.nodes == 1 => tracing::info!("CAN: {} configured in {:.1} ms", n.label(), r.elapsed_ms),
            Ok(_) => {}
            Err(e) => shared.push_fault(e),
        }
    }
}

/// What arrives while the thread is busy with a round or a transfer, for afterwards.
#[derive(Debug, Default)]
struct Waiting {
    /// Nodes that booted (to configure).
    booted: Vec<usize>,
    /// Commissioning transfers, in their order.
    requests: VecDeque<SdoRequest>,
}

impl Waiting {
    /// Keeps an input that is not for the work in progress.
    fn keep(&mut self, input: BootInput) {
        match input {
            BootInput::Rebooted(i) if !self.booted.contains(&i) => self.booted.push(i),
            BootInput::Sdo(req) => self.requests.push_back(req),
            BootInput::Rebooted(_) | BootInput::Frame(_) => {}
        }
    }
}

/// One commissioning transfer: its frames go out on the boot socket, the node's SDO responses
/// come from the receive thread; the outcome (the abort code and its meaning on failure) goes
/// to the requester and a failure into the node's `last_sdo_error`.
#[allow(clippy::too_many_arguments)]
fn serve(
    socket: &CanSocket,
    shared: &BusShared,
    plan: &BootPlan,
    req: SdoRequest,
    inputs: &Receiver<BootInput>,
    stop: &AtomicBool,
    wait: &mut Waiting,
) {
    let n = &shared.nodes[req.index];
    let mut client = SdoClient::new(n.node, plan.sdo_timeout_us);
    let mut out = Vec::new();
    let started = match &req.op {
        SdoOp::Read(at) => client.upload(*at, now_us()),
        SdoOp::Write(at, data) => client.download(*at, data.clone(), now_us()),
    };
    let result = match started {
        Err(e) => Err(e),
        Ok(first) => {
            out.push(first);
            send_all(socket, shared, &mut out);
            loop {
                if stop.load(Ordering::Acquire) {
                    return;
                }
                let now = now_us();
                let deadline = client.deadline_us().unwrap_or(now);
                let step =
                    match inputs.recv_timeout(Duration::from_micros(deadline.saturating_sub(now).clamp(100, 50_000))) {
                        Ok(BootInput::Frame(f)) => client.on_frame(&f, now_us()),
                        Ok(other) => {
                            wait.keep(other);
                            None
                        }
                        Err(RecvTimeoutError::Timeout) => client.poll(now_us()),
                        Err(RecvTimeoutError::Disconnected) => return,
                    };
                match step {
                    None => {}
                    Some(Step::Send(f)) => {
                        out.push(f);
                        send_all(socket, shared, &mut out);
                    }
                    Some(Step::Uploaded(data)) => break Ok(data),
                    Some(Step::Downloaded) => break Ok(Vec::new()),
                    Some(Step::Failed { error, abort }) => {
                        out.extend(abort);
                        send_all(socket, shared, &mut out);
                        break Err(error);
                    }
                }
            }
        }
    };
    match &result {
        Ok(data) => tracing::info!("CAN: {}: commissioning {:?}: done ({} bytes)", n.label(), req.op, data.len()),
        Err(e) => {
            tracing::warn!("CAN: {}: commissioning: {e}", n.label());
            *n.last_sdo_error.lock().unwrap_or_else(|p| p.into_inner()) = Some(e.to_string());
        }
    }
    let _ = req.reply.send(result);
}

/// Boots the nodes `which` side by side; the first failure ends the round with its message,
/// except a node that does not answer the reset: it is left to its boot-up message. Nodes that
/// boot meanwhile and are not in this round, and commissioning requests, go to `wait`.
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
    wait: &mut Waiting,
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
            Err(e) => {
                if let BootError::Sdo { error, .. } = &e {
                    *shared.nodes[*i].last_sdo_error.lock().unwrap_or_else(|p| p.into_inner()) =
                        Some(error.to_string());
                }
                Err(format!("{}: {e}", shared.nodes[*i].label()))
            }
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
        let timeout = Duration::from_micros(next.saturating_sub(now).clamp(100, 50_000));
        let frame = match inputs.recv_timeout(timeout) {
            Ok(BootInput::Frame(f)) => Some(f),
            // A node of this round that boots is answered by the boot-up frame its boot waits
            // for; another one is configured afterwards, as a commissioning request is served.
            Ok(other @ (BootInput::Rebooted(_) | BootInput::Sdo(_))) => {
                wait.keep(other);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(extra: &str) -> Result<BootPlan, String> {
        let text = format!("{}\n{extra}", interpd_config::DEFAULT_MACHINE_TOML);
        let config = interpd_config::Config::from_toml_str(&text, "test").map_err(|e| e.to_string())?;
        let nodes: Vec<NodeId> = (1..=3).map(|n| NodeId::new(n).expect("node")).collect();
        BootPlan::from_config(&config, &nodes)
    }

    fn writes(ops: &[Op]) -> Vec<(Address, Vec<u8>, String)> {
        ops.iter()
            .filter_map(|op| match op {
                Op::Write { at, data, what } => Some((*at, data.clone(), what.clone())),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn node_values_are_written_before_the_heartbeat_and_checked_naming_the_key() {
        let p = plan("[sinks.can.node.2]\nsdo = [{ index = 0x6065, type = \"u32\", value = 20000 }, { index = 0x2001, sub = 3, type = \"i8\", value = \"-5\" }]\n")
            .expect("plan");
        let w = writes(&p.ops[1]);
        let at = |a: Address| w.iter().position(|(x, _, _)| *x == a).expect("written");
        assert_eq!(w[at(Address::new(0x6065, 0))].1, vec![0x20, 0x4E, 0, 0]);
        assert_eq!(w[at(Address::new(0x2001, 3))].1, vec![0xFB]);
        assert!(w[at(Address::new(0x2001, 3))].2.contains("[sinks.can.node.2] sdo[1] (0x2001:3)"));
        assert!(at(Address::new(0x6065, 0)) < at(Address::new(0x2001, 3)), "in the table's order");
        assert!(at(Address::new(0x2001, 3)) < at(Address::new(0x1017, 0)), "before the heartbeat");
        assert!(writes(&p.ops[0]).iter().all(|(a, _, _)| a.index != 0x6065), "node 1 has no values");
        let e =
            plan("[sinks.can.node.3]\nsdo = [{ index = 0x6060, type = \"u8\", value = 300 }]\n").err().expect("range");
        assert_eq!(e, "sinks.can.node.3.sdo[0].value: 300 is out of range for u8 (0 to 255)");
        let e =
            plan("[sinks.can.node.3]\nsdo = [{ index = 0x6060, type = \"f32\", value = 1 }]\n").err().expect("type");
        assert!(e.starts_with("sinks.can.node.3.sdo[0].type: unknown type \"f32\""), "{e}");
        let e =
            plan("[sinks.can.node.3]\nsdo = [{ index = 0x6060, type = \"u8\", value = 1.5 }]\n").err().expect("float");
        assert!(e.starts_with("sinks.can.node.3.sdo[0].value: expected an integer"), "{e}");
    }

    #[test]
    fn a_dcf_gives_its_writable_values_except_the_masters_own() {
        let dir = std::env::temp_dir().join(format!("interpd-dcf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let eds = include_str!("../../../sim-plant/eds/interpd-sim-drive.eds");
        let dcf = eds
            .replacen("[6065]\n", "[6065]\nParameterValue=54321\n", 1)
            .replacen("[1017]\n", "[1017]\nParameterValue=7\n", 1)
            .replacen("[6041]\n", "[6041]\nParameterValue=1\n", 1);
        let path = dir.join("n1.dcf");
        std::fs::write(&path, dcf).expect("write");
        let p = plan(&format!("[sinks.can.node.1]\neds = \"{}\"\n", path.display())).expect("plan");
        let dcf_writes: Vec<_> =
            writes(&p.ops[0]).into_iter().filter(|(_, _, what)| what.contains("ParameterValue")).collect();
        assert_eq!(dcf_writes.len(), 1, "0x6041 is read-only, 0x1017 the master's: {dcf_writes:?}");
        assert_eq!(
            (dcf_writes[0].0, dcf_writes[0].1.clone()),
            (Address::new(0x6065, 0), 54321u32.to_le_bytes().to_vec())
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
