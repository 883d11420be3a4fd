//! Conversions between [`crate::cia301::Frame`] and the `socketcan` crate's frames, and the
//! classification of send errors that both ends of the bus count (feature `socketcan`).
//!
//! Pure data conversion: opening sockets and what to do on an error is the caller's policy.

use crate::cia301::{Frame, FrameError, FrameKind};
use socketcan::{CanFrame, EmbeddedFrame, ExtendedId, Frame as _, Id, StandardId};

/// The socketcan frame for a data or remote frame; `None` for error frames (only the kernel
/// produces those, user space cannot send them).
pub fn to_socketcan(f: &Frame) -> Option<CanFrame> {
    let id = f.id();
    let id: Id = if id.is_extended() {
        ExtendedId::new(id.raw())?.into()
    } else {
        StandardId::new(u16::try_from(id.raw()).ok()?)?.into()
    };
    match f.kind() {
        FrameKind::Data => CanFrame::new(id, f.payload()),
        FrameKind::Remote => CanFrame::new_remote(id, f.len() as usize),
        FrameKind::Error => None,
    }
}

/// The plain-data frame for a received socketcan frame (data, remote or error frame).
pub fn from_socketcan(f: &CanFrame) -> Result<Frame, FrameError> {
    let dlc = u8::try_from(f.dlc()).unwrap_or(u8::MAX);
    Frame::from_socketcan(f.id_word(), dlc, f.data())
}

/// Why a frame could not be sent, by the errno classes an operator acts on differently.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SendFailure {
    /// ENOBUFS: the interface's transmit queue is full (bus overloaded or not acknowledged).
    QueueFull,
    /// EAGAIN on a non-blocking socket: the socket's send buffer is full.
    WouldBlock,
    /// ENETDOWN, ENODEV, ENXIO: the interface is down or gone.
    InterfaceDown,
    /// Anything else (EMSGSIZE, EINVAL, …).
    Other,
}

impl SendFailure {
    pub fn classify(e: &std::io::Error) -> SendFailure {
        match e.raw_os_error() {
            Some(libc_errno::ENOBUFS) => SendFailure::QueueFull,
            Some(libc_errno::EAGAIN) => SendFailure::WouldBlock,
            Some(libc_errno::ENETDOWN | libc_errno::ENODEV | libc_errno::ENXIO) => SendFailure::InterfaceDown,
            _ if e.kind() == std::io::ErrorKind::WouldBlock => SendFailure::WouldBlock,
            _ => SendFailure::Other,
        }
    }

    pub const fn name(self) -> &'static str {
        match self {
            SendFailure::QueueFull => "ENOBUFS (transmit queue full)",
            SendFailure::WouldBlock => "EAGAIN (socket buffer full)",
            SendFailure::InterfaceDown => "interface down",
            SendFailure::Other => "other error",
        }
    }
}

/// The Linux errno values used above (x86-64 and aarch64 agree on these).
mod libc_errno {
    pub const ENXIO: i32 = 6;
    pub const EAGAIN: i32 = 11;
    pub const ENODEV: i32 = 19;
    pub const ENETDOWN: i32 = 100;
    pub const ENOBUFS: i32 = 105;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cia301::CanId;

    #[test]
    fn frames_round_trip_through_socketcan() {
        let frames = [
            Frame::standard(0x201, &[0x0F, 0, 1, 2, 3, 4]).unwrap(),
            Frame::standard(0x080, &[]).unwrap(),
            Frame::data(CanId::extended(0x1ABC_DEF0).unwrap(), &[9, 8]).unwrap(),
            Frame::remote(CanId::standard(0x701).unwrap(), 1).unwrap(),
        ];
        for f in frames {
            let s = to_socketcan(&f).expect("sendable");
            assert_eq!(from_socketcan(&s), Ok(f));
        }
        assert!(to_socketcan(&Frame::error(0x40, &[0; 8]).unwrap()).is_none());
    }

    #[test]
    fn send_errors_are_classified() {
        use std::io::Error;
        assert_eq!(SendFailure::classify(&Error::from_raw_os_error(105)), SendFailure::QueueFull);
        assert_eq!(SendFailure::classify(&Error::from_raw_os_error(11)), SendFailure::WouldBlock);
        assert_eq!(SendFailure::classify(&Error::from_raw_os_error(100)), SendFailure::InterfaceDown);
        assert_eq!(SendFailure::classify(&Error::from_raw_os_error(19)), SendFailure::InterfaceDown);
        assert_eq!(SendFailure::classify(&Error::from_raw_os_error(22)), SendFailure::Other);
    }
}
