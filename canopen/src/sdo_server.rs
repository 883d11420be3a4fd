//! The SDO server (CiA 301 7.2.4) of one node on its default channel: expedited and segmented
//! upload and download on an object dictionary behind [`ObjectAccess`]. A pure state machine:
//! request bytes in, the response frame out.
//!
//! A new initiate request ends a transfer in progress (the client has given up on it); a
//! segmented download collects at most [`MAX_DOWNLOAD_BYTES`] and writes the object once, when
//! the last segment has arrived, so a broken-off transfer changes nothing.

use crate::sdo_abort::SdoAbort;
use crate::sdo_frame::{Address, Chunk, Initiate, Request, Response, request_cob};
use interpd_protocol::cia301::{Frame, FrameKind, NodeId};

/// Largest segmented download this server accepts (its largest object is a short string).
pub const MAX_DOWNLOAD_BYTES: usize = 1024;

/// Reading and writing objects: the object dictionary the server serves.
pub trait ObjectAccess {
    /// The value of `at` as it travels (little endian, the type's length).
    fn read(&mut self, at: Address) -> Result<Vec<u8>, SdoAbort>;
    /// Writes `data` to `at`; checks access, length and value range.
    fn write(&mut self, at: Address, data: &[u8]) -> Result<(), SdoAbort>;
    /// Whether `at` exists and may be written at all (checked when a segmented download
    /// starts; the value itself is checked by [`ObjectAccess::write`]).
    fn writable(&mut self, at: Address) -> Result<(), SdoAbort>;
}

#[derive(Debug, Clone)]
enum State {
    Idle,
    Download { at: Address, buf: Vec<u8>, size: Option<u32>, toggle: bool },
    Upload { at: Address, data: Vec<u8>, pos: usize, toggle: bool },
}

/// Counters of one server.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServerStats {
    pub requests: u64,
    pub uploads: u64,
    pub downloads: u64,
    /// Aborts this server sent.
    pub aborts_sent: u64,
    /// Aborts clients sent.
    pub aborts_received: u64,
}

#[derive(Debug, Clone)]
pub struct SdoServer {
    node: NodeId,
    state: State,
    pub stats: ServerStats,
}

impl SdoServer {
    pub fn new(node: NodeId) -> SdoServer {
        SdoServer { node, state: State::Idle, stats: ServerStats::default() }
    }

    /// Whether `frame` is a request to this server.
    pub fn is_request(&self, frame: &Frame) -> bool {
        frame.kind() == FrameKind::Data && frame.id().as_standard() == Some(request_cob(self.node))
    }

    /// Serves one request (the data bytes of a frame on 0x600 + node); returns the response
    /// frame, or `None` for a client's abort.
    pub fn on_request(&mut self, payload: &[u8], od: &mut dyn ObjectAccess) -> Option<Frame> {
        self.stats.requests += 1;
        let response = match Request::decode(payload) {
            Ok(r) => self.serve(r, od)?,
            Err(_) => self.abort(self.current(), SdoAbort::UnknownCommand),
        };
        if matches!(response, Response::Abort { .. }) {
            self.stats.aborts_sent += 1;
        }
        Some(response.frame(self.node))
    }

    fn current(&self) -> Address {
        match &self.state {
            State::Idle => Address::new(0, 0),
            State::Download { at, .. } | State::Upload { at, .. } => *at,
        }
    }

    fn abort(&mut self, at: Address, abort: SdoAbort) -> Response {
        self.state = State::Idle;
        Response::Abort { at, abort }
    }

    fn serve(&mut self, request: Request, od: &mut dyn ObjectAccess) -> Option<Response> {
        let state = std::mem::replace(&mut self.state, State::Idle);
        Some(match (state, request) {
            (_, Request::Abort { .. }) => {
                self.stats.aborts_received += 1;
                return None;
            }
            (_, Request::InitiateDownload { at, data: Initiate::Expedited(c) }) => match od.write(at, c.as_slice()) {
                Ok(()) => {
                    self.stats.downloads += 1;
                    Response::InitiateDownload { at }
                }
                Err(a) => self.abort(at, a),
            },
            (_, Request::InitiateDownload { at, data: Initiate::Segmented { size } }) => {
                if size.is_some_and(|s| s as usize > MAX_DOWNLOAD_BYTES) {
                    return Some(self.abort(at, SdoAbort::OutOfMemory));
                }
                // Refuse at once what could never be written (no such object, read-only), before
                // the client sends the segments.
                if let Err(a) = od.writable(at) {
                    return Some(self.abort(at, a));
                }
                self.state = State::Download { at, buf: Vec::new(), size, toggle: false };
                Response::InitiateDownload { at }
            }
            (State::Download { at, mut buf, size, toggle }, Request::DownloadSegment { toggle: t, data, last }) => {
                if t != toggle {
                    return Some(self.abort(at, SdoAbort::ToggleBit));
                }
                buf.extend_from_slice(data.as_slice());
                if buf.len() > MAX_DOWNLOAD_BYTES || size.is_some_and(|s| buf.len() as u64 > u64::from(s)) {
                    return Some(self.abort(at, SdoAbort::LengthTooHigh));
                }
                if !last {
                    self.state = State::Download { at, buf, size, toggle: !toggle };
                    return Some(Response::DownloadSegment { toggle: t });
                }
                if size.is_some_and(|s| buf.len() as u64 != u64::from(s)) {
                    return Some(self.abort(at, SdoAbort::LengthMismatch));
                }
                match od.write(at, &buf) {
                    Ok(()) => {
                        self.stats.downloads += 1;
                        Response::DownloadSegment { toggle: t }
                    }
                    Err(a) => self.abort(at, a),
                }
            }
            (_, Request::InitiateUpload { at }) => match od.read(at) {
                Ok(data) if (1..=4).contains(&data.len()) => {
                    self.stats.uploads += 1;
                    Response::InitiateUpload { at, data: Initiate::Expedited(Chunk::new(&data)) }
                }
                Ok(data) => {
                    let size = data.len() as u32;
                    self.state = State::Upload { at, data, pos: 0, toggle: false };
                    Response::InitiateUpload { at, data: Initiate::Segmented { size: Some(size) } }
                }
                Err(a) => self.abort(at, a),
            },
            (State::Upload { at, data, pos, toggle }, Request::UploadSegment { toggle: t }) => {
                if t != toggle {
                    return Some(self.abort(at, SdoAbort::ToggleBit));
                }
                let end = (pos + 7).min(data.len());
                let chunk = Chunk::new(&data[pos..end]);
                let last = end == data.len();
                if last {
                    self.stats.uploads += 1;
                } else {
                    self.state = State::Upload { at, data, pos: end, toggle: !toggle };
                }
                Response::UploadSegment { toggle: t, data: chunk, last }
            }
            // A segment without a transfer, or of the other direction.
            (state, Request::DownloadSegment { .. } | Request::UploadSegment { .. }) => {
                self.state = state;
                self.abort(self.current(), SdoAbort::UnknownCommand)
            }
        })
    }
}
