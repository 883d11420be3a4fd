//! The CAN master's commissioning commands, called from the control API's threads (never the
//! real-time thread): an SDO transfer with one node, handed to the boot thread with a reply
//! channel, and the fault reset of drives, which the real-time sink carries out on the bus.

use super::can_boot::{BootInput, SdoRequest};
use super::can_state::{BusShared, NodeShared};
use super::drive_command::{DriveCommandError, ResetOutcome, SdoOp};
use crate::rt::clock;
use interpd_canopen::sdo_client::SdoError;
use interpd_protocol::api::ResetDrive;
use interpd_protocol::cia402::PowerState;
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long a commissioning transfer may wait for the boot thread: a configuration round in
/// progress first (each of its steps bounded by the SDO timeout), then a segmented transfer,
/// each segment bounded by the SDO timeout.
const SDO_WAIT: Duration = Duration::from_secs(30);
/// How long drives may take to leave Fault after the reset edge, in cycles (the edge goes out
/// within two cycles; a drive acts on it at the next SYNC), and at least this long in time.
const RESET_CYCLES: u64 = 50;
const RESET_MIN: Duration = Duration::from_millis(500);
/// After leaving Fault: how long to wait for the master's enable sequence (shutdown, switch
/// on, enable operation: a cycle each) before reporting the state reached.
const ENABLE_CYCLES: u64 = 25;

impl BusShared {
    fn index_of(&self, node: u8) -> Result<usize, DriveCommandError> {
        self.nodes.iter().position(|n| n.node.get() == node).ok_or_else(|| DriveCommandError::UnknownNode {
            node,
            known: self.nodes.iter().map(NodeShared::label).collect::<Vec<_>>().join(", "),
        })
    }

    /// One SDO transfer with `node`, run by the boot thread.
    pub fn sdo_command(&self, node: u8, op: SdoOp) -> Result<Vec<u8>, DriveCommandError> {
        let index = self.index_of(node)?;
        let (reply, answer) = std::sync::mpsc::channel();
        {
            let inbox = self.requests.lock().unwrap_or_else(|p| p.into_inner());
            let inbox = inbox.as_ref().ok_or_else(|| DriveCommandError::Stopped("no boot thread".into()))?;
            inbox
                .send(BootInput::Sdo(SdoRequest { index, op, reply }))
                .map_err(|_| DriveCommandError::Stopped("the boot thread has ended".into()))?;
        }
        match answer.recv_timeout(SDO_WAIT) {
            Ok(Ok(data)) => Ok(data),
            Ok(Err(e)) => {
                let abort_code = match &e {
                    SdoError::Aborted { abort, .. } | SdoError::Protocol { abort, .. } => Some(abort.code()),
                    _ => None,
                };
                Err(DriveCommandError::Sdo { message: format!("{}: {e}", self.nodes[index].label()), abort_code })
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => Err(DriveCommandError::Sdo {
                message: format!(
                    "{}: the transfer did not end within {} s",
                    self.nodes[index].label(),
                    SDO_WAIT.as_secs()
                ),
                abort_code: None,
            }),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                Err(DriveCommandError::Stopped("the boot thread ended during the transfer".into()))
            }
        }
    }

    /// Fault reset of `nodes` (none: every drive in Fault); see [`super::DriveMonitor::reset`].
    pub fn reset_command(&self, nodes: &[u8]) -> ResetOutcome {
        let in_fault =
            |n: &NodeShared| matches!(n.power_state(), Some(PowerState::Fault | PowerState::FaultReactionActive));
        let which: Vec<usize> = if nodes.is_empty() {
            (0..self.nodes.len()).filter(|&i| in_fault(&self.nodes[i])).collect()
        } else {
            nodes.iter().map(|&n| self.index_of(n)).collect::<Result<_, _>>()?
        };
        let before: Vec<String> = which.iter().map(|&i| state_name(&self.nodes[i])).collect();
        for &i in &which {
            self.nodes[i].fault_reset.store(true, Ordering::Release);
        }
        let cycle = Duration::from_nanos(self.cycle_ns);
        let until = clock::now_ns() + (cycle * RESET_CYCLES as u32).max(RESET_MIN).as_nanos() as u64;
        let all_out = || which.iter().all(|&i| !in_fault(&self.nodes[i]));
        while !all_out() && clock::now_ns() < until {
            std::thread::sleep(cycle);
        }
        for &i in &which {
            self.nodes[i].fault_reset.store(false, Ordering::Release);
        }
        let stuck: Vec<String> = which
            .iter()
            .filter(|&&i| in_fault(&self.nodes[i]))
            .map(|&i| {
                let n = &self.nodes[i];
                let emcy = n
                    .last_emcy_code()
                    .map(|c| format!(" (last EMCY 0x{c:04X} {})", interpd_protocol::cia301::emcy_code::text(c)))
                    .unwrap_or_default();
                format!("{} is still in {}{emcy}", n.label(), state_name(n))
            })
            .collect();
        if !stuck.is_empty() {
            return Err(DriveCommandError::Reset(format!(
                "fault reset: {} after the rising edge of controlword bit 7: the drive's fault persists; clear its cause \
                 and call drives.reset again",
                stuck.join("; ")
            )));
        }
        // The master takes the drives on to Operation enabled at standstill; report where they got.
        let until = clock::now_ns() + (cycle * ENABLE_CYCLES as u32).as_nanos() as u64;
        let enabled = || which.iter().all(|&i| self.nodes[i].power_state() == Some(PowerState::OperationEnabled));
        while !enabled() && clock::now_ns() < until {
            std::thread::sleep(cycle);
        }
        Ok(which
            .iter()
            .zip(before)
            .map(|(&i, state_before)| {
                let n = &self.nodes[i];
                ResetDrive { axis: n.axis_name.clone(), node: n.node.get(), state_before, state: state_name(n) }
            })
            .collect())
    }
}

fn state_name(n: &NodeShared) -> String {
    match (n.statusword(), n.power_state()) {
        (None, _) => "unknown".into(),
        (Some(_), None) => "undefined_statusword".into(),
        (Some(_), Some(s)) => s.name().into(),
    }
}
