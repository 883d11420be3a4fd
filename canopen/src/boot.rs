//! The boot-up of one node by the master (CiA 302-2, simplified), as a pure state machine: NMT
//! reset communication and the boot-up message, the identity 0x1018 against what is expected,
//! the configuration written over SDO (PDO communication and mapping: disable, map, enable;
//! modes of operation and the check of their display; interpolation period; heartbeat
//! producer), then NMT start. Frames in, frames out, explicit times; one SDO transfer at a time
//! for the node, so the master runs one of these per node side by side, off the real-time
//! thread.

use crate::sdo_client::{SdoClient, SdoError, Step};
use crate::sdo_frame::Address;
use interpd_protocol::cia301::{Frame, Message, NmtCommand, NmtState, NodeId, decode};

/// One step of a node's boot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Op {
    /// NMT reset communication, then wait for the boot-up message.
    ResetCommunication,
    /// Read 0x1018:1 and 0x1018:2 and compare.
    CheckIdentity { vendor_id: u32, product_code: u32 },
    /// SDO download; `what` says what it configures, for the error message.
    Write { at: Address, data: Vec<u8>, what: String },
    /// SDO upload that must give `value`.
    Expect { at: Address, value: Vec<u8>, what: String },
    /// NMT start (operational).
    Start,
}

/// Why a node's boot failed. Each names the node.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BootError {
    #[error("node {node}: no boot-up message within {waited_ms} ms of NMT reset communication")]
    NoBootUp { node: NodeId, waited_ms: u64 },
    #[error(
        "node {node}: wrong device: expected vendor-ID 0x{expected_vendor:08X}, product code 0x{expected_product:08X}; \
         found vendor-ID 0x{found_vendor:08X}, product code 0x{found_product:08X} (object 0x1018)"
    )]
    Identity { node: NodeId, expected_vendor: u32, expected_product: u32, found_vendor: u32, found_product: u32 },
    #[error("node {node}: {what}: {error}")]
    Sdo { node: NodeId, what: String, error: SdoError },
    #[error("node {node}: {what}: {at} reads {found:02X?}, expected {expected:02X?}")]
    Mismatch { node: NodeId, what: String, at: Address, expected: Vec<u8>, found: Vec<u8> },
}

/// Where the boot stands.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Phase {
    /// The step `pos` has not been started.
    Next,
    WaitBootUp {
        deadline_us: u64,
    },
    /// An SDO transfer of step `pos` runs (for identity: `sub` 1 or 2).
    Transfer {
        sub: u8,
    },
    Done,
    Failed,
}

/// The boot of one node.
#[derive(Debug, Clone)]
pub struct NodeBoot {
    node: NodeId,
    ops: Vec<Op>,
    pos: usize,
    phase: Phase,
    client: SdoClient,
    boot_timeout_us: u64,
    found_vendor: u32,
    /// SDO transfers done, for the figures.
    pub transfers: u32,
}

impl NodeBoot {
    pub fn new(node: NodeId, ops: Vec<Op>, sdo_timeout_us: u64, boot_timeout_us: u64) -> NodeBoot {
        NodeBoot {
            node,
            ops,
            pos: 0,
            phase: Phase::Next,
            client: SdoClient::new(node, sdo_timeout_us),
            boot_timeout_us,
            found_vendor: 0,
            transfers: 0,
        }
    }

    pub fn node(&self) -> NodeId {
        self.node
    }

    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// The next time [`NodeBoot::poll`] has something to check, if any.
    pub fn deadline_us(&self) -> Option<u64> {
        match self.phase {
            Phase::WaitBootUp { deadline_us } => Some(deadline_us),
            Phase::Transfer { .. } => self.client.deadline_us(),
            _ => None,
        }
    }

    /// Starts (or goes on with) the steps that need no answer; frames to send go to `out`.
    /// `Some` when the boot has ended.
    pub fn poll(&mut self, now_us: u64, out: &mut Vec<Frame>) -> Option<Result<(), BootError>> {
        match self.phase {
            Phase::WaitBootUp { deadline_us } if now_us >= deadline_us => {
                self.phase = Phase::Failed;
                return Some(Err(BootError::NoBootUp { node: self.node, waited_ms: self.boot_timeout_us / 1000 }));
            }
            Phase::Transfer { .. } => {
                if let Some(step) = self.client.poll(now_us) {
                    return self.on_step(step, now_us, out);
                }
            }
            Phase::Next => return self.advance(now_us, out),
            _ => {}
        }
        None
    }

    /// A frame from the bus (anything: what is not for this boot is ignored).
    pub fn on_frame(&mut self, frame: &Frame, now_us: u64, out: &mut Vec<Frame>) -> Option<Result<(), BootError>> {
        match self.phase {
            Phase::WaitBootUp { .. } => {
                if decode(frame) == Ok(Message::Heartbeat { node: self.node, state: NmtState::BootUp }) {
                    self.pos += 1;
                    self.phase = Phase::Next;
                    return self.advance(now_us, out);
                }
                None
            }
            Phase::Transfer { .. } => {
                let step = self.client.on_frame(frame, now_us)?;
                self.on_step(step, now_us, out)
            }
            _ => None,
        }
    }

    fn on_step(&mut self, step: Step, now_us: u64, out: &mut Vec<Frame>) -> Option<Result<(), BootError>> {
        let Phase::Transfer { sub } = self.phase else { return None };
        let node = self.node;
        match step {
            Step::Send(f) => {
                out.push(f);
                None
            }
            Step::Failed { error, abort } => {
                out.extend(abort);
                self.phase = Phase::Failed;
                let what = match &self.ops[self.pos] {
                    Op::CheckIdentity { .. } => "reading the identity 0x1018".to_string(),
                    Op::Write { what, .. } | Op::Expect { what, .. } => what.clone(),
                    _ => String::new(),
                };
                Some(Err(BootError::Sdo { node, what, error }))
            }
            Step::Downloaded | Step::Uploaded(_) => {
                self.transfers += 1;
                let data = if let Step::Uploaded(d) = step { d } else { Vec::new() };
                match &self.ops[self.pos] {
                    Op::CheckIdentity { vendor_id, product_code } => {
                        let value = u32::from_le_bytes(data.get(..4).and_then(|d| d.try_into().ok()).unwrap_or([0; 4]));
                        if sub == 1 {
                            self.found_vendor = value;
                            self.phase = Phase::Transfer { sub: 2 };
                            return self.start_transfer(now_us, out);
                        }
                        if (self.found_vendor, value) != (*vendor_id, *product_code) {
                            self.phase = Phase::Failed;
                            return Some(Err(BootError::Identity {
                                node,
                                expected_vendor: *vendor_id,
                                expected_product: *product_code,
                                found_vendor: self.found_vendor,
                                found_product: value,
                            }));
                        }
                    }
                    Op::Expect { at, value, what } if *value != data => {
                        self.phase = Phase::Failed;
                        return Some(Err(BootError::Mismatch {
                            node,
                            what: what.clone(),
                            at: *at,
                            expected: value.clone(),
                            found: data,
                        }));
                    }
                    _ => {}
                }
                self.pos += 1;
                self.phase = Phase::Next;
                self.advance(now_us, out)
            }
        }
    }

    /// Runs the steps from `pos` until one waits for an answer.
    fn advance(&mut self, now_us: u64, out: &mut Vec<Frame>) -> Option<Result<(), BootError>> {
        loop {
            let Some(op) = self.ops.get(self.pos) else {
                self.phase = Phase::Done;
                return Some(Ok(()));
            };
            match op {
                Op::ResetCommunication => {
                    out.push(
                        Message::Nmt { command: NmtCommand::ResetCommunication, target: Some(self.node) }.encode(),
                    );
                    self.phase = Phase::WaitBootUp { deadline_us: now_us + self.boot_timeout_us };
                    return None;
                }
                Op::Start => {
                    out.push(Message::Nmt { command: NmtCommand::Start, target: Some(self.node) }.encode());
                    self.pos += 1;
                }
                Op::CheckIdentity { .. } => {
                    self.phase = Phase::Transfer { sub: 1 };
                    return self.start_transfer(now_us, out);
                }
                Op::Write { .. } | Op::Expect { .. } => {
                    self.phase = Phase::Transfer { sub: 0 };
                    return self.start_transfer(now_us, out);
                }
            }
        }
    }

    fn start_transfer(&mut self, now_us: u64, out: &mut Vec<Frame>) -> Option<Result<(), BootError>> {
        let Phase::Transfer { sub } = self.phase else { return None };
        let started = match &self.ops[self.pos] {
            Op::CheckIdentity { .. } => self.client.upload(Address::new(0x1018, sub), now_us),
            Op::Write { at, data, .. } => self.client.download(*at, data.clone(), now_us),
            Op::Expect { at, .. } => self.client.upload(*at, now_us),
            _ => return None,
        };
        match started {
            Ok(f) => {
                out.push(f);
                None
            }
            Err(error) => {
                self.phase = Phase::Failed;
                Some(Err(BootError::Sdo { node: self.node, what: "starting a transfer".into(), error }))
            }
        }
    }
}

/// What the master configures on a CiA 402 drive for cyclic synchronous position.
#[derive(Debug, Clone, PartialEq)]
pub struct CspSetup {
    pub vendor_id: u32,
    pub product_code: u32,
    /// SYNC period, µs (0x1006, and 0x60C2 as value × 10^index s).
    pub cycle_us: u32,
    /// Heartbeat producer time 0x1017, ms.
    pub heartbeat_ms: u16,
    /// Further downloads from the configuration, after the standard ones.
    pub extra: Vec<Op>,
}

/// 0x60C2 for a period: (value, index) with value × 10^index s = the period exactly, the
/// coarsest index that does; `None` if no 8-bit value down to µs does.
pub fn interpolation_period(cycle_us: u32) -> Option<(u8, i8)> {
    let mut v = u64::from(cycle_us);
    let mut index = -6i8;
    while v % 10 == 0 && index < 0 {
        v /= 10;
        index += 1;
    }
    u8::try_from(v).ok().map(|v| (v, index))
}

/// The CiA 302-2 boot of a CSP drive: reset communication, identity, RPDO1 = controlword +
/// target position and TPDO1 = statusword + position actual value (both synchronous, every
/// SYNC), CSP, its display checked, interpolation period, communication cycle, heartbeat, start.
pub fn csp_ops(node: NodeId, setup: &CspSetup) -> Vec<Op> {
    let n = u32::from(node.get());
    let w = |index: u16, sub: u8, data: Vec<u8>, what: &str| Op::Write {
        at: Address::new(index, sub),
        data,
        what: format!("{what} (0x{index:04X}:{sub})"),
    };
    let u32le = |v: u32| v.to_le_bytes().to_vec();
    let mut ops = vec![
        Op::ResetCommunication,
        Op::CheckIdentity { vendor_id: setup.vendor_id, product_code: setup.product_code },
    ];
    let pdo = |comm: u16, map: u16, cob: u32, entries: [u32; 2], name: &str| {
        vec![
            w(comm, 1, u32le(cob | 0x8000_0000), &format!("disabling {name}")),
            w(map, 0, vec![0], &format!("clearing the {name} mapping")),
            w(map, 1, u32le(entries[0]), &format!("mapping {name} entry 1")),
            w(map, 2, u32le(entries[1]), &format!("mapping {name} entry 2")),
            w(map, 0, vec![2], &format!("setting the {name} mapping count")),
            w(comm, 2, vec![1], &format!("making {name} synchronous")),
            w(comm, 1, u32le(cob), &format!("enabling {name}")),
        ]
    };
    ops.extend(pdo(0x1400, 0x1600, 0x200 + n, [0x6040_0010, 0x607A_0020], "RPDO1"));
    ops.extend(pdo(0x1800, 0x1A00, 0x180 + n, [0x6041_0010, 0x6064_0020], "TPDO1"));
    ops.push(w(0x6060, 0, vec![8], "modes of operation = 8 cyclic synchronous position"));
    ops.push(Op::Expect {
        at: Address::new(0x6061, 0),
        value: vec![8],
        what: "checking modes of operation display = 8".into(),
    });
    if let Some((value, index)) = interpolation_period(setup.cycle_us) {
        ops.push(w(0x60C2, 1, vec![value], "interpolation time period value"));
        ops.push(w(0x60C2, 2, vec![index as u8], "interpolation time period index"));
    }
    ops.push(w(0x1006, 0, u32le(setup.cycle_us), "communication cycle period"));
    ops.extend(setup.extra.iter().cloned());
    ops.push(w(0x1017, 0, setup.heartbeat_ms.to_le_bytes().to_vec(), "heartbeat producer time"));
    ops.push(Op::Start);
    ops
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_periods() {
        assert_eq!(interpolation_period(4000), Some((4, -3)));
        assert_eq!(interpolation_period(500), Some((5, -4)));
        assert_eq!(interpolation_period(250), Some((25, -5)));
        assert_eq!(interpolation_period(100_000), Some((1, -1)));
        assert_eq!(interpolation_period(1_000_001), None);
    }
}
