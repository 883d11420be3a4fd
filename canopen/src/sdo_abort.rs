//! SDO abort codes (CiA 301 table 22) with their meanings: what a server answers when it
//! refuses a transfer, and what a client sends when it gives up on one.

use std::fmt;

/// An SDO abort code. The named variants are the codes of CiA 301 table 22; any other code a
/// device sends is kept as [`SdoAbort::Other`] so nothing a drive says is lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SdoAbort {
    ToggleBit,
    Timeout,
    UnknownCommand,
    InvalidBlockSize,
    InvalidSequenceNumber,
    CrcError,
    OutOfMemory,
    UnsupportedAccess,
    WriteOnly,
    ReadOnly,
    NoSuchObject,
    CannotMap,
    PdoTooLong,
    ParameterIncompatibility,
    DeviceIncompatibility,
    HardwareError,
    LengthMismatch,
    LengthTooHigh,
    LengthTooLow,
    NoSuchSubIndex,
    InvalidValue,
    ValueTooHigh,
    ValueTooLow,
    MaxBelowMin,
    ResourceNotAvailable,
    GeneralError,
    CannotStore,
    CannotStoreLocalControl,
    CannotStoreDeviceState,
    NoObjectDictionary,
    NoDataAvailable,
    Other(u32),
}

const TABLE: [(SdoAbort, u32, &str); 31] = [
    (SdoAbort::ToggleBit, 0x0503_0000, "toggle bit not alternated"),
    (SdoAbort::Timeout, 0x0504_0000, "SDO protocol timed out"),
    (SdoAbort::UnknownCommand, 0x0504_0001, "client/server command specifier not valid or unknown"),
    (SdoAbort::InvalidBlockSize, 0x0504_0002, "invalid block size (block mode only)"),
    (SdoAbort::InvalidSequenceNumber, 0x0504_0003, "invalid sequence number (block mode only)"),
    (SdoAbort::CrcError, 0x0504_0004, "CRC error (block mode only)"),
    (SdoAbort::OutOfMemory, 0x0504_0005, "out of memory"),
    (SdoAbort::UnsupportedAccess, 0x0601_0000, "unsupported access to an object"),
    (SdoAbort::WriteOnly, 0x0601_0001, "attempt to read a write-only object"),
    (SdoAbort::ReadOnly, 0x0601_0002, "attempt to write a read-only object"),
    (SdoAbort::NoSuchObject, 0x0602_0000, "object does not exist in the object dictionary"),
    (SdoAbort::CannotMap, 0x0604_0041, "object cannot be mapped to the PDO"),
    (
        SdoAbort::PdoTooLong,
        0x0604_0042,
        "the number and length of the objects to be mapped would exceed the PDO length",
    ),
    (SdoAbort::ParameterIncompatibility, 0x0604_0043, "general parameter incompatibility reason"),
    (SdoAbort::DeviceIncompatibility, 0x0604_0047, "general internal incompatibility in the device"),
    (SdoAbort::HardwareError, 0x0606_0000, "access failed due to a hardware error"),
    (SdoAbort::LengthMismatch, 0x0607_0010, "data type does not match, length of service parameter does not match"),
    (SdoAbort::LengthTooHigh, 0x0607_0012, "data type does not match, length of service parameter too high"),
    (SdoAbort::LengthTooLow, 0x0607_0013, "data type does not match, length of service parameter too low"),
    (SdoAbort::NoSuchSubIndex, 0x0609_0011, "sub-index does not exist"),
    (SdoAbort::InvalidValue, 0x0609_0030, "invalid value for parameter (download only)"),
    (SdoAbort::ValueTooHigh, 0x0609_0031, "value of parameter written too high (download only)"),
    (SdoAbort::ValueTooLow, 0x0609_0032, "value of parameter written too low (download only)"),
    (SdoAbort::MaxBelowMin, 0x0609_0036, "maximum value is less than minimum value"),
    (SdoAbort::ResourceNotAvailable, 0x060A_0023, "resource not available: SDO connection"),
    (SdoAbort::GeneralError, 0x0800_0000, "general error"),
    (SdoAbort::CannotStore, 0x0800_0020, "data cannot be transferred or stored to the application"),
    (
        SdoAbort::CannotStoreLocalControl,
        0x0800_0021,
        "data cannot be transferred or stored to the application because of local control",
    ),
    (
        SdoAbort::CannotStoreDeviceState,
        0x0800_0022,
        "data cannot be transferred or stored to the application because of the present device state",
    ),
    (SdoAbort::NoObjectDictionary, 0x0800_0023, "object dictionary dynamic generation failed or no object dictionary"),
    (SdoAbort::NoDataAvailable, 0x0800_0024, "no data available"),
];

impl SdoAbort {
    /// The 32-bit abort code as it travels in the abort frame (little endian).
    pub fn code(self) -> u32 {
        match self {
            SdoAbort::Other(c) => c,
            known => TABLE.iter().find(|(a, _, _)| *a == known).map_or(0, |(_, c, _)| *c),
        }
    }

    /// The abort of a code read from the bus.
    pub fn from_code(code: u32) -> SdoAbort {
        TABLE.iter().find(|(_, c, _)| *c == code).map_or(SdoAbort::Other(code), |(a, _, _)| *a)
    }

    /// The meaning as CiA 301 words it.
    pub fn text(self) -> &'static str {
        match self {
            SdoAbort::Other(_) => "abort code not defined by CiA 301 (manufacturer- or profile-specific)",
            known => TABLE.iter().find(|(a, _, _)| *a == known).map_or("", |(_, _, t)| t),
        }
    }
}

impl fmt::Display for SdoAbort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "abort 0x{:08X}: {}", self.code(), self.text())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_round_trips_and_has_a_meaning() {
        for (a, c, t) in TABLE {
            assert_eq!(a.code(), c);
            assert_eq!(SdoAbort::from_code(c), a);
            assert_eq!(a.text(), t);
        }
        let codes: std::collections::HashSet<u32> = TABLE.iter().map(|e| e.1).collect();
        assert_eq!(codes.len(), TABLE.len(), "no code twice");
        assert_eq!(SdoAbort::from_code(0x1234_5678), SdoAbort::Other(0x1234_5678));
        assert_eq!(SdoAbort::Other(0x1234_5678).code(), 0x1234_5678);
        assert_eq!(
            SdoAbort::NoSuchObject.to_string(),
            "abort 0x06020000: object does not exist in the object dictionary"
        );
    }
}
