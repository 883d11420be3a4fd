//! The SDO frames of CiA 301 (7.2.4.3): every request a client sends and every response a
//! server sends, as typed values with a total codec over the 8 data bytes. Block transfer
//! (command specifiers 5 and 6) is not implemented: it decodes as an unknown command, which a
//! server answers with abort 0x05040001, as CiA 301 allows.

use crate::sdo_abort::SdoAbort;
use interpd_protocol::cia301::{Frame, NodeId};
use std::fmt;

/// The SDO COB-IDs of the predefined connection set (CiA 301), kept with the others.
pub use interpd_protocol::cia301::cob::{sdo_request as request_cob, sdo_response as response_cob};

/// An object dictionary entry: index and sub-index (the SDO "multiplexer").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Address {
    pub index: u16,
    pub sub: u8,
}

impl Address {
    pub const fn new(index: u16, sub: u8) -> Address {
        Address { index, sub }
    }

    fn to_bytes(self) -> [u8; 3] {
        let [a, b] = self.index.to_le_bytes();
        [a, b, self.sub]
    }

    fn from_bytes(d: &[u8; 8]) -> Address {
        Address { index: u16::from_le_bytes([d[1], d[2]]), sub: d[3] }
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:04X}:{}", self.index, self.sub)
    }
}

/// Up to `N` data bytes of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunk<const N: usize> {
    bytes: [u8; N],
    len: u8,
}

impl<const N: usize> Chunk<N> {
    /// The first `N` bytes of `data` at most.
    pub fn new(data: &[u8]) -> Chunk<N> {
        let len = data.len().min(N);
        let mut bytes = [0; N];
        bytes[..len].copy_from_slice(&data[..len]);
        Chunk { bytes, len: len as u8 }
    }

    pub fn as_slice(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }
}

/// What an initiate frame says about the data: carried in the frame (expedited) or following in
/// segments, with the total size when the sender indicates it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Initiate {
    Expedited(Chunk<4>),
    Segmented { size: Option<u32> },
}

/// Client → server (COB-ID 0x600 + node).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    InitiateDownload { at: Address, data: Initiate },
    DownloadSegment { toggle: bool, data: Chunk<7>, last: bool },
    InitiateUpload { at: Address },
    UploadSegment { toggle: bool },
    Abort { at: Address, abort: SdoAbort },
}

/// Server → client (COB-ID 0x580 + node).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response {
    InitiateDownload { at: Address },
    DownloadSegment { toggle: bool },
    InitiateUpload { at: Address, data: Initiate },
    UploadSegment { toggle: bool, data: Chunk<7>, last: bool },
    Abort { at: Address, abort: SdoAbort },
}

/// Why 8 bytes are not an SDO frame this implementation understands.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SdoFrameError {
    #[error("SDO frame with {got} data bytes: CiA 301 SDO frames carry 8")]
    WrongDlc { got: usize },
    #[error("SDO command byte 0x{byte:02X}: command specifier {cs} is not one this implementation serves")]
    UnknownCommand { byte: u8, cs: u8 },
}

fn eight(payload: &[u8]) -> Result<[u8; 8], SdoFrameError> {
    <[u8; 8]>::try_from(payload).map_err(|_| SdoFrameError::WrongDlc { got: payload.len() })
}

fn initiate_bits(data: &Initiate) -> (u8, [u8; 4]) {
    match data {
        // e = 1, s = 1, n = 4 − len.
        Initiate::Expedited(c) => {
            let mut b = [0; 4];
            b[..c.as_slice().len()].copy_from_slice(c.as_slice());
            ((((4 - c.len) & 3) << 2) | 0b11, b)
        }
        Initiate::Segmented { size: Some(s) } => (0b01, s.to_le_bytes()),
        Initiate::Segmented { size: None } => (0b00, [0; 4]),
    }
}

fn initiate_from(byte: u8, d: &[u8; 8]) -> Initiate {
    let e = byte & 0b10 != 0;
    let s = byte & 0b01 != 0;
    let tail = [d[4], d[5], d[6], d[7]];
    match (e, s) {
        (true, true) => Initiate::Expedited(Chunk::new(&tail[..4 - ((byte >> 2) & 3) as usize])),
        // Expedited without a size: all 4 bytes, the receiver knows the type's length.
        (true, false) => Initiate::Expedited(Chunk::new(&tail)),
        (false, true) => Initiate::Segmented { size: Some(u32::from_le_bytes(tail)) },
        (false, false) => Initiate::Segmented { size: None },
    }
}

fn with_address(cmd: u8, at: Address, tail: [u8; 4]) -> [u8; 8] {
    let [a, b, c] = at.to_bytes();
    [cmd, a, b, c, tail[0], tail[1], tail[2], tail[3]]
}

fn segment(cmd: u8, toggle: bool, data: &Chunk<7>, last: bool) -> [u8; 8] {
    let n = 7 - data.len;
    let mut d = [0; 8];
    d[0] = cmd | (u8::from(toggle) << 4) | ((n & 7) << 1) | u8::from(last);
    d[1..1 + data.as_slice().len()].copy_from_slice(data.as_slice());
    d
}

fn segment_from(d: &[u8; 8]) -> (bool, Chunk<7>, bool) {
    let n = ((d[0] >> 1) & 7) as usize;
    (d[0] & 0x10 != 0, Chunk::new(&d[1..8 - n]), d[0] & 1 != 0)
}

fn abort_bytes(at: Address, abort: SdoAbort) -> [u8; 8] {
    with_address(0x80, at, abort.code().to_le_bytes())
}

fn abort_from(d: &[u8; 8]) -> (Address, SdoAbort) {
    (Address::from_bytes(d), SdoAbort::from_code(u32::from_le_bytes([d[4], d[5], d[6], d[7]])))
}

impl Request {
    pub fn to_bytes(&self) -> [u8; 8] {
        match *self {
            Request::InitiateDownload { at, data } => {
                let (bits, tail) = initiate_bits(&data);
                with_address(0x20 | bits, at, tail)
            }
            Request::DownloadSegment { toggle, data, last } => segment(0x00, toggle, &data, last),
            Request::InitiateUpload { at } => with_address(0x40, at, [0; 4]),
            Request::UploadSegment { toggle } => [0x60 | (u8::from(toggle) << 4), 0, 0, 0, 0, 0, 0, 0],
            Request::Abort { at, abort } => abort_bytes(at, abort),
        }
    }

    /// Decodes the data bytes of a frame on 0x600 + node.
    pub fn decode(payload: &[u8]) -> Result<Request, SdoFrameError> {
        let d = eight(payload)?;
        let cs = d[0] >> 5;
        Ok(match cs {
            1 => Request::InitiateDownload { at: Address::from_bytes(&d), data: initiate_from(d[0], &d) },
            0 => {
                let (toggle, data, last) = segment_from(&d);
                Request::DownloadSegment { toggle, data, last }
            }
            2 => Request::InitiateUpload { at: Address::from_bytes(&d) },
            3 => Request::UploadSegment { toggle: d[0] & 0x10 != 0 },
            4 => {
                let (at, abort) = abort_from(&d);
                Request::Abort { at, abort }
            }
            _ => return Err(SdoFrameError::UnknownCommand { byte: d[0], cs }),
        })
    }

    /// The frame to `node`.
    pub fn frame(&self, node: NodeId) -> Frame {
        sdo_frame(request_cob(node), self.to_bytes())
    }
}

impl Response {
    pub fn to_bytes(&self) -> [u8; 8] {
        match *self {
            Response::InitiateDownload { at } => with_address(0x60, at, [0; 4]),
            Response::DownloadSegment { toggle } => [0x20 | (u8::from(toggle) << 4), 0, 0, 0, 0, 0, 0, 0],
            Response::InitiateUpload { at, data } => {
                let (bits, tail) = initiate_bits(&data);
                with_address(0x40 | bits, at, tail)
            }
            Response::UploadSegment { toggle, data, last } => segment(0x00, toggle, &data, last),
            Response::Abort { at, abort } => abort_bytes(at, abort),
        }
    }

    /// Decodes the data bytes of a frame on 0x580 + node.
    pub fn decode(payload: &[u8]) -> Result<Response, SdoFrameError> {
        let d = eight(payload)?;
        let cs = d[0] >> 5;
        Ok(match cs {
            3 => Response::InitiateDownload { at: Address::from_bytes(&d) },
            1 => Response::DownloadSegment { toggle: d[0] & 0x10 != 0 },
            2 => Response::InitiateUpload { at: Address::from_bytes(&d), data: initiate_from(d[0], &d) },
            0 => {
                let (toggle, data, last) = segment_from(&d);
                Response::UploadSegment { toggle, data, last }
            }
            4 => {
                let (at, abort) = abort_from(&d);
                Response::Abort { at, abort }
            }
            _ => return Err(SdoFrameError::UnknownCommand { byte: d[0], cs }),
        })
    }

    /// The frame from `node`.
    pub fn frame(&self, node: NodeId) -> Frame {
        sdo_frame(response_cob(node), self.to_bytes())
    }
}

fn sdo_frame(cob: u16, bytes: [u8; 8]) -> Frame {
    // 0x580 + 127 and 0x600 + 127 are below 0x7FF and the payload has 8 bytes: cannot fail.
    Frame::standard(cob, &bytes).unwrap_or_else(|_| unreachable!("SDO COB-IDs fit 11 bits"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_bytes_of_cia301() {
        let at = Address::new(0x1017, 0);
        // Expedited download of 2 bytes: ccs 1, n = 2, e = 1, s = 1 → 0x2B.
        let r = Request::InitiateDownload { at, data: Initiate::Expedited(Chunk::new(&[0x64, 0])) };
        assert_eq!(r.to_bytes(), [0x2B, 0x17, 0x10, 0x00, 0x64, 0x00, 0x00, 0x00]);
        assert_eq!(Request::decode(&r.to_bytes()), Ok(r));
        // 1 byte → 0x2F, 4 bytes → 0x23; upload answers 0x4F / 0x4B / 0x43.
        let one = Request::InitiateDownload { at, data: Initiate::Expedited(Chunk::new(&[8])) };
        assert_eq!(one.to_bytes()[0], 0x2F);
        let four = Response::InitiateUpload { at, data: Initiate::Expedited(Chunk::new(&[1, 2, 3, 4])) };
        assert_eq!(four.to_bytes()[0], 0x43);
        assert_eq!(Response::InitiateDownload { at }.to_bytes()[0], 0x60);
        assert_eq!(Request::InitiateUpload { at }.to_bytes()[0], 0x40);
        // Segmented upload initiate with size 17 → 0x41.
        let seg = Response::InitiateUpload { at, data: Initiate::Segmented { size: Some(17) } };
        assert_eq!(seg.to_bytes(), [0x41, 0x17, 0x10, 0x00, 17, 0, 0, 0]);
        // Last upload segment with 3 bytes, toggle 1: t = 1, n = 4, c = 1 → 0x19.
        let last = Response::UploadSegment { toggle: true, data: Chunk::new(b"abc"), last: true };
        assert_eq!(last.to_bytes(), [0x19, b'a', b'b', b'c', 0, 0, 0, 0]);
        assert_eq!(Response::decode(&last.to_bytes()), Ok(last));
        let abort = Request::Abort { at, abort: SdoAbort::Timeout };
        assert_eq!(abort.to_bytes(), [0x80, 0x17, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
    }

    #[test]
    fn codec_is_total_and_rejects_block_transfer() {
        assert_eq!(Request::decode(&[0x40; 7]), Err(SdoFrameError::WrongDlc { got: 7 }));
        assert!(matches!(
            Request::decode(&[0xC0, 0, 0, 0, 0, 0, 0, 0]),
            Err(SdoFrameError::UnknownCommand { cs: 6, .. })
        ));
        for b0 in 0..=255u8 {
            let d = [b0, 0x18, 0x10, 1, 9, 8, 7, 6];
            let _ = Request::decode(&d);
            let _ = Response::decode(&d);
        }
    }
}
