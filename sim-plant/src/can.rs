//! `sim-plant --source can:IFACE`: every axis a CiA 402 drive node ([`crate::can_node`]) on a
//! SocketCAN bus, node-IDs and scales from `[sinks.can]` (the same file the daemon reads).
//!
//! The plant runs on the SYNC clock: each SYNC every node answers TPDO1 with the position of
//! its axis at that instant, applies its RPDO1, and the plant integrates one communication
//! cycle (0x1006 = `[machine] cycle_ms`) toward the new targets. Only positions come over the
//! bus, so the drives interpolate linearly between them (as CSP drives do). Without SYNC the
//! nodes' watchdogs run on the kernel's receive timestamps (a descheduled simulator reading
//! queued frames late does not mistake them for silence); a drive whose watchdog tripped
//! ramps down on wall time until it stands. A drive that neither follows nor ramps (not yet
//! enabled, quick stop or fault reaction complete) holds its motor with the brake: its
//! position actual, the motor encoder, stays still while the load may swing out.

use crate::PlantError;
use crate::can_homing::AxisSensors;
use crate::can_node::{DriveNode, Motion, NodeParams, NodeStats};
use crate::metrics::Metrics;
use crate::plant::{AxisTarget, Plant};
use interpd_config::Config;
use interpd_protocol::MAX_AXES;
use interpd_protocol::can_socket::{from_socketcan, to_socketcan};
use interpd_protocol::cia301::{self, CobObject, DecodeError, Frame, Message, NmtState, NodeId};
use interpd_protocol::cia402::{PowerState, Scale};
use socketcan::{CanSocket, Socket, SocketOptions};
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Counters of the bus side.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BusStats {
    pub rx_frames: u64,
    pub syncs: u64,
    /// RPDO1s for node-IDs this simulator does not serve.
    pub rpdo_other_node: u64,
    pub wrong_dlc: u64,
    pub unknown_cob_id: u64,
    pub bad_value: u64,
    pub not_data: u64,
    /// EMCY, TPDO1 and heartbeats of other nodes (e.g. an EMCY storm from another device).
    pub other_node_frames: u64,
    /// Frames of other devices that use one of this simulator's node-IDs.
    pub node_id_conflicts: u64,
    pub rx_errors: u64,
    pub tx_frames: u64,
    pub tx_errors: u64,
    /// Cycles the plant ran on wall time, without SYNC (quick-stop ramps after a watchdog trip).
    pub free_running_cycles: u64,
}

/// What a run did.
#[derive(Debug, Clone)]
pub struct CanReport {
    pub bus: BusStats,
    pub nodes: Vec<(NodeId, NmtState, PowerState, NodeStats)>,
    pub wall_s: f64,
    pub simulated_s: f64,
}

/// Set by SIGINT/SIGTERM.
static TERMINATE: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    TERMINATE.store(true, Ordering::SeqCst);
}

/// Installs SIGINT/SIGTERM handlers that end [`run`]; returns the flag they set.
pub fn install_signal_handlers() -> &'static AtomicBool {
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
    &TERMINATE
}

fn wall_us() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64)
}

/// The drives and their socket.
struct Bus {
    socket: CanSocket,
    nodes: Vec<DriveNode>,
    out: Vec<Frame>,
    stats: BusStats,
    cycle_us: u64,
    dt_s: f64,
    /// Wall time (µs) of the last plant step, SYNC-driven or free-running.
    last_step_us: u64,
}

/// Serves the bus `iface` until `stop` is set: boot-up, NMT, CiA 402, CSP on SYNC, heartbeats.
pub fn run(
    config: &Config,
    plant: &mut Plant,
    mut metrics: Option<&mut Metrics>,
    iface: &str,
    stop: &AtomicBool,
) -> Result<CanReport, PlantError> {
    let started = Instant::now();
    let transport = |m: String| PlantError::Transport(format!("CAN {iface}: {m}"));
    let socket = CanSocket::open(iface).map_err(|e| {
        transport(format!("cannot open the interface: {e} (does it exist and is it up? `ip link show {iface}`)"))
    })?;
    let cycle_us = (config.cycle_s() * 1e6).round() as u64;
    // A quarter cycle: the heartbeats and ramps look at a silent bus at least this often.
    let poll = Duration::from_micros((cycle_us / 4).max(250));
    // Reads do not block: the loop waits in ppoll, whose timeout is a high-resolution timer
    // (a socket receive timeout counts in scheduler ticks, up to 4 ms on a 250 Hz kernel, which
    // would let a watchdog trip a tick late).
    socket.set_nonblocking(true).map_err(|e| transport(e.to_string()))?;
    socket.set_write_timeout(Duration::from_millis(10)).map_err(|e| transport(e.to_string()))?;
    socket.set_recv_timestamp(true).map_err(|e| transport(e.to_string()))?;

    let can = &config.sinks.can;
    let n = config.axes.len();
    let positions = [0.0; MAX_AXES];
    plant.reset(0, &positions[..n])?;
    let mut bus = Bus {
        socket,
        nodes: Vec::with_capacity(n),
        out: Vec::with_capacity(64),
        stats: BusStats::default(),
        cycle_us,
        dt_s: cycle_us as f64 * 1e-6,
        last_step_us: wall_us(),
    };
    for (i, (id, k)) in can.node_ids(n).into_iter().zip(can.scales(n)).enumerate() {
        let node = NodeId::new(id).ok_or_else(|| PlantError::Input(format!("sinks.can.nodes[{i}]: {id}")))?;
        let scale = Scale::new(k).map_err(|e| PlantError::Input(format!("sinks.can.increments_per_unit[{i}]: {e}")))?;
        let axis = &config.axes[i];
        let node_config = can.node_config(id);
        let sensors = AxisSensors {
            home_switch: node_config.sim_home_switch,
            index_pitch: node_config.sim_index_pitch,
            travel: (axis.min_pos, axis.max_pos),
        };
        let p = NodeParams { node, scale, cycle_us, quick_stop_dec: axis.max_acc_per_s2, sensors };
        let (drive, boot) = DriveNode::boot(p, positions[i])
            .map_err(|e| PlantError::Input(format!("the drive's EDS (sim-plant/eds/interpd-sim-drive.eds): {e}")))?;
        bus.nodes.push(drive);
        bus.out.push(boot);
    }
    bus.flush();
    while !stop.load(Ordering::SeqCst) {
        // Wake for the next frame, the earliest watchdog deadline or the poll period.
        let now = wall_us();
        let wait_us = bus
            .nodes
            .iter()
            .filter_map(|d| d.watchdog_deadline_us())
            .min()
            .map_or(poll.as_micros() as u64, |deadline| deadline.saturating_sub(now).min(poll.as_micros() as u64));
        wait_readable(&bus.socket, Duration::from_micros(wait_us));
        match bus.socket.read_frame_with_timestamps() {
            Ok((f, ts)) => {
                bus.stats.rx_frames += 1;
                let t_us = ts
                    .socket
                    .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
                    .map_or_else(wall_us, |d| d.as_micros() as u64);
                match from_socketcan(&f) {
                    Ok(frame) => bus.handle(&frame, t_us, plant, metrics.as_deref_mut())?,
                    Err(_) => bus.stats.bad_value += 1,
                }
                // The frame's own time is "now" for the watchdog: a SYNC queued behind it
                // cannot have been missed.
                bus.check_watchdogs(t_us);
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) =>
            {
                // The queue is empty: wall time is the reference.
                let now = wall_us();
                bus.check_watchdogs(now);
                bus.free_run(now, plant, metrics.as_deref_mut())?;
            }
            Err(e) => {
                bus.stats.rx_errors += 1;
                if bus.stats.rx_errors <= 3 {
                    tracing::warn!("CAN {iface}: receive failed: {e}");
                }
                std::thread::sleep(poll);
            }
        }
        // Each node's heartbeat producer runs at its own 0x1017 (off until the master sets it).
        let now = wall_us();
        for i in 0..bus.nodes.len() {
            if let Some(hb) = bus.nodes[i].heartbeat_due(now) {
                bus.out.push(hb);
            }
        }
        bus.flush();
    }
    Ok(CanReport {
        bus: bus.stats,
        nodes: bus.nodes.iter().map(|d| (d.id(), d.nmt(), d.power_state(), d.stats)).collect(),
        wall_s: started.elapsed().as_secs_f64(),
        simulated_s: plant.time_s(),
    })
}

/// Waits until `socket` has a frame to read or `timeout` has passed (an interrupted wait
/// returns early; the caller's loop looks again).
fn wait_readable(socket: &CanSocket, timeout: Duration) {
    let mut fd = libc::pollfd { fd: socket.as_raw_fd(), events: libc::POLLIN, revents: 0 };
    let ts = libc::timespec { tv_sec: timeout.as_secs() as libc::time_t, tv_nsec: timeout.subsec_nanos().into() };
    // SAFETY: one valid pollfd, a valid timespec, no signal mask.
    unsafe {
        libc::ppoll(&mut fd, 1, &ts, std::ptr::null());
    }
}

impl Bus {
    fn flush(&mut self) {
        for m in self.out.drain(..) {
            let Some(f) = to_socketcan(&m) else { continue };
            match self.socket.write_frame(&f) {
                Ok(()) => self.stats.tx_frames += 1,
                Err(e) => {
                    self.stats.tx_errors += 1;
                    if self.stats.tx_errors <= 3 {
                        tracing::warn!("CAN: sending {m:?} failed: {e}");
                    }
                }
            }
        }
    }

    fn index(&self, node: NodeId) -> Option<usize> {
        self.nodes.iter().position(|d| d.id() == node)
    }

    fn handle(
        &mut self,
        frame: &cia301::Frame,
        t_us: u64,
        plant: &mut Plant,
        metrics: Option<&mut Metrics>,
    ) -> Result<(), PlantError> {
        // SDO requests and RPDO1s first: their COB-IDs and lengths are the dictionary's, not
        // the fixed ones of the predefined connection set's decoder.
        if let Some(i) = self.nodes.iter().position(|d| d.is_sdo_request(frame)) {
            self.nodes[i].on_sdo(frame.payload(), &mut self.out);
            return Ok(());
        }
        if let Some(i) = self.nodes.iter().position(|d| d.is_rpdo(frame)) {
            if !self.nodes[i].on_rpdo(frame.payload(), t_us, &mut self.out) {
                self.stats.wrong_dlc += 1;
            }
            return Ok(());
        }
        match cia301::decode(frame) {
            Ok(Message::Sync { .. }) => {
                self.stats.syncs += 1;
                self.on_sync(t_us, plant, metrics)?;
            }
            Ok(Message::Rpdo1 { node, .. }) => match self.index(node) {
                // Our node with its RPDO1 disabled or moved.
                Some(_) => self.stats.unknown_cob_id += 1,
                None => self.stats.rpdo_other_node += 1,
            },
            Ok(Message::Nmt { command, target }) => {
                for d in self.nodes.iter_mut().filter(|d| target.is_none_or(|t| t == d.id())) {
                    d.on_nmt(command, t_us, &mut self.out);
                }
            }
            Ok(Message::Tpdo1 { node, .. } | Message::Heartbeat { node, .. } | Message::Emcy { node, .. }) => {
                if self.index(node).is_some() {
                    self.stats.node_id_conflicts += 1;
                } else {
                    self.stats.other_node_frames += 1;
                }
            }
            Err(DecodeError::WrongDlc { id, .. }) => {
                self.stats.wrong_dlc += 1;
                if let Some(CobObject::Rpdo1(node)) = CobObject::classify(id) {
                    if self.index(node).is_none() {
                        self.stats.rpdo_other_node += 1;
                    }
                }
            }
            Err(DecodeError::UnknownCobId { .. }) => self.stats.unknown_cob_id += 1,
            Err(DecodeError::BadValue { .. }) => self.stats.bad_value += 1,
            Err(DecodeError::NotDataFrame { .. }) => self.stats.not_data += 1,
        }
        Ok(())
    }

    /// TPDO1 from every node at the positions of this instant, then one cycle of the plant
    /// toward the targets the nodes took on this SYNC.
    fn on_sync(&mut self, t_us: u64, plant: &mut Plant, metrics: Option<&mut Metrics>) -> Result<(), PlantError> {
        for i in 0..self.nodes.len() {
            let actual = plant.outputs()[i].motor_pos;
            self.nodes[i].on_sync(actual, t_us, &mut self.out);
        }
        self.flush();
        self.step(plant, metrics)?;
        self.last_step_us = t_us;
        Ok(())
    }

    fn step(&mut self, plant: &mut Plant, metrics: Option<&mut Metrics>) -> Result<(), PlantError> {
        let mut targets = [AxisTarget::default(); MAX_AXES];
        for (i, (t, d)) in targets.iter_mut().zip(self.nodes.iter_mut()).enumerate() {
            d.advance_ramp(self.dt_s);
            t.pos = d.target();
            // A drive that neither follows nor ramps has its power stage off: the brake holds
            // the motor, so its position actual stays still (also in Fault).
            if let Some(axis) = plant.axis_mut(i) {
                axis.set_brake(d.motion() == Motion::Hold);
            }
        }
        plant.step(&targets[..self.nodes.len()], self.dt_s)?;
        if let Some(m) = metrics {
            m.record_plant(plant);
        }
        Ok(())
    }

    fn check_watchdogs(&mut self, now_us: u64) {
        let mut tripped = [false; MAX_AXES];
        for (d, t) in self.nodes.iter_mut().zip(tripped.iter_mut()) {
            *t = d.check_watchdog(now_us, &mut self.out);
        }
        if !tripped.contains(&true) {
            return;
        }
        // The EMCYs go out before the log lines are formatted and written: the reaction on
        // the bus must not wait for the diagnostics (in the VM's virtual time their
        // instructions are time, 0.03-0.09 cycles for three drives).
        self.flush();
        for (d, _) in self.nodes.iter().zip(tripped).filter(|(_, t)| *t) {
            let since = d.since_sync_us(now_us).unwrap_or(0) as f64 / self.cycle_us as f64;
            tracing::warn!(
                "node {}: no SYNC for {since:.3} cycles: SYNC watchdog, quick stop and Fault (EMCY 0x8100)",
                d.id()
            );
        }
    }

    /// Without SYNC, a ramping drive still has to come to a stop: step the plant on wall time,
    /// one cycle behind it.
    fn free_run(
        &mut self,
        now_us: u64,
        plant: &mut Plant,
        mut metrics: Option<&mut Metrics>,
    ) -> Result<(), PlantError> {
        if !self.nodes.iter().any(|d| matches!(d.motion(), Motion::Ramp { .. })) {
            return Ok(());
        }
        while now_us.saturating_sub(self.last_step_us) >= 2 * self.cycle_us {
            self.step(plant, metrics.as_deref_mut())?;
            self.last_step_us += self.cycle_us;
            self.stats.free_running_cycles += 1;
        }
        Ok(())
    }
}
