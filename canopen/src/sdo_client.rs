//! The SDO client (CiA 301 7.2.4): one confirmed transfer at a time with one server, expedited
//! when the data fits 4 bytes, segmented otherwise, with a timeout. A pure state machine with
//! explicit times: the caller sends the frames it returns, feeds it the server's frames and
//! polls it for the timeout, so it runs wherever the caller likes (the master runs it off the
//! real-time thread) and is tested without a bus.

use crate::sdo_abort::SdoAbort;
use crate::sdo_frame::{Address, Chunk, Initiate, Request, Response, response_cob};
use interpd_protocol::cia301::{Frame, FrameKind, NodeId};

/// Default time a server may take for each answer (CiA 301 leaves it to the application;
/// drives answer within milliseconds, a second also covers a busy EEPROM write).
pub const DEFAULT_TIMEOUT_US: u64 = 1_000_000;

/// Why a transfer failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SdoError {
    #[error("node {node}: SDO {dir} of {at} refused by the drive: {abort}")]
    Aborted { node: NodeId, dir: Direction, at: Address, abort: SdoAbort },
    #[error("node {node}: SDO {dir} of {at}: no answer within {timeout_ms} ms")]
    Timeout { node: NodeId, dir: Direction, at: Address, timeout_ms: u64 },
    #[error("node {node}: SDO {dir} of {at}: {what} (the transfer was aborted with {abort})")]
    Protocol { node: NodeId, dir: Direction, at: Address, what: String, abort: SdoAbort },
    #[error("node {node}: an SDO transfer is already running ({dir} of {at}); one at a time per node")]
    Busy { node: NodeId, dir: Direction, at: Address },
}

/// Upload (read from the node) or download (write to it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Upload,
    Download,
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Direction::Upload => "upload (read)",
            Direction::Download => "download (write)",
        })
    }
}

/// What the caller does after feeding a frame or polling.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Step {
    /// Send this frame to the server; the transfer goes on.
    Send(Frame),
    /// The upload is complete: the object's bytes.
    Uploaded(Vec<u8>),
    /// The download is complete.
    Downloaded,
    /// The transfer failed; send `abort` if given (the client aborts on a timeout or a protocol
    /// error, never in reply to the server's own abort).
    Failed { error: SdoError, abort: Option<Frame> },
}

#[derive(Debug, Clone)]
enum State {
    Idle,
    /// Waiting for the initiate download response, or for the segment response `toggle`.
    Download {
        at: Address,
        data: Vec<u8>,
        sent: usize,
        toggle: bool,
        initiated: bool,
    },
    /// Waiting for the initiate upload response, or for the segment `toggle`.
    Upload {
        at: Address,
        buf: Vec<u8>,
        size: Option<u32>,
        toggle: bool,
        initiated: bool,
    },
}

/// The client side of one SDO channel (the default channel of one node).
#[derive(Debug, Clone)]
pub struct SdoClient {
    node: NodeId,
    timeout_us: u64,
    state: State,
    deadline_us: u64,
}

impl SdoClient {
    pub fn new(node: NodeId, timeout_us: u64) -> SdoClient {
        SdoClient { node, timeout_us, state: State::Idle, deadline_us: 0 }
    }

    pub fn node(&self) -> NodeId {
        self.node
    }

    /// Whether a transfer is running.
    pub fn busy(&self) -> bool {
        !matches!(self.state, State::Idle)
    }

    /// When the running transfer times out (µs on the caller's clock).
    pub fn deadline_us(&self) -> Option<u64> {
        self.busy().then_some(self.deadline_us)
    }

    /// Starts reading `at`; returns the first frame to send.
    pub fn upload(&mut self, at: Address, now_us: u64) -> Result<Frame, SdoError> {
        self.check_idle()?;
        self.state = State::Upload { at, buf: Vec::new(), size: None, toggle: false, initiated: false };
        self.deadline_us = now_us + self.timeout_us;
        Ok(Request::InitiateUpload { at }.frame(self.node))
    }

    /// Starts writing `data` to `at`: expedited for 1 to 4 bytes, segmented otherwise (the size
    /// always indicated). Returns the first frame to send.
    pub fn download(&mut self, at: Address, data: Vec<u8>, now_us: u64) -> Result<Frame, SdoError> {
        self.check_idle()?;
        let init = if (1..=4).contains(&data.len()) {
            Initiate::Expedited(Chunk::new(&data))
        } else {
            Initiate::Segmented { size: Some(data.len() as u32) }
        };
        self.state = State::Download { at, data, sent: 0, toggle: false, initiated: false };
        self.deadline_us = now_us + self.timeout_us;
        Ok(Request::InitiateDownload { at, data: init }.frame(self.node))
    }

    fn check_idle(&self) -> Result<(), SdoError> {
        match &self.state {
            State::Idle => Ok(()),
            State::Download { at, .. } => Err(SdoError::Busy { node: self.node, dir: Direction::Download, at: *at }),
            State::Upload { at, .. } => Err(SdoError::Busy { node: self.node, dir: Direction::Upload, at: *at }),
        }
    }

    /// Times out the running transfer if its answer is overdue at `now_us`.
    pub fn poll(&mut self, now_us: u64) -> Option<Step> {
        if !self.busy() || now_us < self.deadline_us {
            return None;
        }
        let (dir, at) = self.current()?;
        Some(self.fail(
            SdoError::Timeout { node: self.node, dir, at, timeout_ms: self.timeout_us / 1000 },
            Some(SdoAbort::Timeout),
        ))
    }

    /// A frame from the bus. `None` when it is not this server's SDO response or no transfer
    /// waits for one (a late answer after a timeout is dropped).
    pub fn on_frame(&mut self, frame: &Frame, now_us: u64) -> Option<Step> {
        if frame.kind() != FrameKind::Data || frame.id().as_standard() != Some(response_cob(self.node)) {
            return None;
        }
        let (dir, at) = self.current()?;
        let response = match Response::decode(frame.payload()) {
            Ok(r) => r,
            Err(e) => return Some(self.protocol(dir, at, e.to_string(), SdoAbort::UnknownCommand)),
        };
        if let Response::Abort { at: a, abort } = response {
            self.state = State::Idle;
            return Some(Step::Failed { error: SdoError::Aborted { node: self.node, dir, at: a, abort }, abort: None });
        }
        self.deadline_us = now_us + self.timeout_us;
        let node = self.node;
        let state = std::mem::replace(&mut self.state, State::Idle);
        match (state, response) {
            (State::Download { at, data, initiated: false, .. }, Response::InitiateDownload { at: a }) if a == at => {
                if (1..=4).contains(&data.len()) {
                    return Some(Step::Downloaded);
                }
                self.state = State::Download { at, data, sent: 0, toggle: false, initiated: true };
                Some(self.next_segment())
            }
            (State::Download { at, data, sent, toggle, initiated: true }, Response::DownloadSegment { toggle: t })
                if t == toggle =>
            {
                if sent >= data.len() {
                    return Some(Step::Downloaded);
                }
                self.state = State::Download { at, data, sent, toggle: !toggle, initiated: true };
                Some(self.next_segment())
            }
            (State::Upload { at, initiated: false, .. }, Response::InitiateUpload { at: a, data }) if a == at => {
                match data {
                    Initiate::Expedited(c) => Some(Step::Uploaded(c.as_slice().to_vec())),
                    Initiate::Segmented { size } => {
                        self.state = State::Upload { at, buf: Vec::new(), size, toggle: false, initiated: true };
                        Some(Step::Send(Request::UploadSegment { toggle: false }.frame(node)))
                    }
                }
            }
            (
                State::Upload { at, mut buf, size, toggle, initiated: true },
                Response::UploadSegment { toggle: t, data, last },
            ) if t == toggle => {
                buf.extend_from_slice(data.as_slice());
                if size.is_some_and(|s| buf.len() as u64 > u64::from(s)) {
                    let what = format!("the server sent more than the {} bytes it indicated", size.unwrap_or(0));
                    self.state = State::Upload { at, buf, size, toggle, initiated: true };
                    return Some(self.protocol(dir, at, what, SdoAbort::LengthTooHigh));
                }
                if last {
                    if let Some(s) = size.filter(|&s| buf.len() as u64 != u64::from(s)) {
                        let what = format!("the server indicated {s} bytes and sent {}", buf.len());
                        self.state = State::Upload { at, buf, size, toggle, initiated: true };
                        return Some(self.protocol(dir, at, what, SdoAbort::LengthMismatch));
                    }
                    return Some(Step::Uploaded(buf));
                }
                self.state = State::Upload { at, buf, size, toggle: !toggle, initiated: true };
                Some(Step::Send(Request::UploadSegment { toggle: !toggle }.frame(node)))
            }
            (state, r @ (Response::DownloadSegment { .. } | Response::UploadSegment { .. })) => {
                self.state = state;
                let abort = if self.toggle_mismatch(&r) { SdoAbort::ToggleBit } else { SdoAbort::UnknownCommand };
                Some(self.protocol(dir, at, format!("unexpected answer {r:?}"), abort))
            }
            (state, r) => {
                self.state = state;
                Some(self.protocol(dir, at, format!("unexpected answer {r:?}"), SdoAbort::UnknownCommand))
            }
        }
    }

    fn toggle_mismatch(&self, r: &Response) -> bool {
        match (&self.state, r) {
            (State::Download { toggle, initiated: true, .. }, Response::DownloadSegment { toggle: t }) => t != toggle,
            (State::Upload { toggle, initiated: true, .. }, Response::UploadSegment { toggle: t, .. }) => t != toggle,
            _ => false,
        }
    }

    /// The next download segment (at most 7 bytes, `last` on the final one).
    fn next_segment(&mut self) -> Step {
        let node = self.node;
        let State::Download { data, sent, toggle, .. } = &mut self.state else {
            unreachable!("next_segment is called in a segmented download")
        };
        let end = (*sent + 7).min(data.len());
        let chunk = Chunk::new(&data[*sent..end]);
        *sent = end;
        Step::Send(Request::DownloadSegment { toggle: *toggle, data: chunk, last: end == data.len() }.frame(node))
    }

    fn current(&self) -> Option<(Direction, Address)> {
        match &self.state {
            State::Idle => None,
            State::Download { at, .. } => Some((Direction::Download, *at)),
            State::Upload { at, .. } => Some((Direction::Upload, *at)),
        }
    }

    fn protocol(&mut self, dir: Direction, at: Address, what: String, abort: SdoAbort) -> Step {
        self.fail(SdoError::Protocol { node: self.node, dir, at, what, abort }, Some(abort))
    }

    fn fail(&mut self, error: SdoError, abort: Option<SdoAbort>) -> Step {
        let at = self.current().map_or(Address::new(0, 0), |(_, at)| at);
        self.state = State::Idle;
        Step::Failed { error, abort: abort.map(|abort| Request::Abort { at, abort }.frame(self.node)) }
    }
}
