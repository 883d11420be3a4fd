//! An object dictionary (CiA 301 7.4): entries with their data type, access and current value,
//! served over SDO through [`ObjectAccess`]. Values are kept as the bytes that travel (little
//! endian, the type's length), so an upload is a copy and a download is checked once here.

use crate::sdo_abort::SdoAbort;
use crate::sdo_frame::Address;
use crate::sdo_server::ObjectAccess;
use std::collections::{BTreeMap, BTreeSet};

/// The basic data types of CiA 301 table 44 used by drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataType {
    Boolean,
    Integer8,
    Integer16,
    Integer32,
    Unsigned8,
    Unsigned16,
    Unsigned32,
    Real32,
    VisibleString,
    OctetString,
    Integer64,
    Unsigned64,
}

impl DataType {
    /// From the data type index of CiA 301 (the EDS's `DataType`).
    pub fn from_code(code: u16) -> Option<DataType> {
        Some(match code {
            0x01 => DataType::Boolean,
            0x02 => DataType::Integer8,
            0x03 => DataType::Integer16,
            0x04 => DataType::Integer32,
            0x05 => DataType::Unsigned8,
            0x06 => DataType::Unsigned16,
            0x07 => DataType::Unsigned32,
            0x08 => DataType::Real32,
            0x09 => DataType::VisibleString,
            0x0A => DataType::OctetString,
            0x15 => DataType::Integer64,
            0x1B => DataType::Unsigned64,
            _ => return None,
        })
    }

    /// Bytes of a value; `None` for strings (any length).
    pub fn size(self) -> Option<usize> {
        match self {
            DataType::Boolean | DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer32 | DataType::Unsigned32 | DataType::Real32 => Some(4),
            DataType::Integer64 | DataType::Unsigned64 => Some(8),
            DataType::VisibleString | DataType::OctetString => None,
        }
    }

    pub fn is_signed(self) -> bool {
        matches!(self, DataType::Integer8 | DataType::Integer16 | DataType::Integer32 | DataType::Integer64)
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, DataType::Real32 | DataType::VisibleString | DataType::OctetString)
    }

    /// The value range of an integer type.
    pub fn range(self) -> (i128, i128) {
        match self {
            DataType::Boolean => (0, 1),
            DataType::Integer8 => (i8::MIN.into(), i8::MAX.into()),
            DataType::Integer16 => (i16::MIN.into(), i16::MAX.into()),
            DataType::Integer32 => (i32::MIN.into(), i32::MAX.into()),
            DataType::Integer64 => (i64::MIN.into(), i64::MAX.into()),
            DataType::Unsigned8 => (0, u8::MAX.into()),
            DataType::Unsigned16 => (0, u16::MAX.into()),
            DataType::Unsigned32 => (0, u32::MAX.into()),
            DataType::Unsigned64 => (0, u64::MAX.into()),
            _ => (0, 0),
        }
    }

    /// The bytes of an integer value (little endian, two's complement), `None` outside the range.
    pub fn encode_int(self, v: i128) -> Option<Vec<u8>> {
        let (lo, hi) = self.range();
        let n = self.size()?;
        (self.is_integer() && (lo..=hi).contains(&v)).then(|| v.to_le_bytes()[..n].to_vec())
    }

    /// The integer value of `bytes` (of this type's length).
    pub fn decode_int(self, bytes: &[u8]) -> Option<i128> {
        if !self.is_integer() || Some(bytes.len()) != self.size() {
            return None;
        }
        let mut b = [0u8; 16];
        b[..bytes.len()].copy_from_slice(bytes);
        if self.is_signed() && bytes.last().is_some_and(|&x| x & 0x80 != 0) {
            b[bytes.len()..].fill(0xFF);
        }
        Some(i128::from_le_bytes(b))
    }
}

/// Access of an entry (CiA 306 `AccessType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    ReadOnly,
    WriteOnly,
    ReadWrite,
    /// Read-write, mappable to a TPDO (the drive writes, the master reads).
    ReadWriteRead,
    /// Read-write, mappable to an RPDO (the master writes).
    ReadWriteWrite,
    Const,
}

impl Access {
    pub fn from_eds(text: &str) -> Option<Access> {
        Some(match text.to_ascii_lowercase().as_str() {
            "ro" => Access::ReadOnly,
            "wo" => Access::WriteOnly,
            "rw" => Access::ReadWrite,
            "rwr" => Access::ReadWriteRead,
            "rww" => Access::ReadWriteWrite,
            "const" => Access::Const,
            _ => return None,
        })
    }

    pub fn readable(self) -> bool {
        self != Access::WriteOnly
    }

    pub fn writable(self) -> bool {
        !matches!(self, Access::ReadOnly | Access::Const)
    }
}

/// One entry (a VAR, or a sub-index of an ARRAY or RECORD).
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub name: String,
    pub data_type: DataType,
    pub access: Access,
    pub pdo_mappable: bool,
    /// Integer limits (`LowLimit`, `HighLimit`), inclusive.
    pub low: Option<i128>,
    pub high: Option<i128>,
    pub value: Vec<u8>,
}

/// The dictionary: entries by index and sub-index.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjectDictionary {
    entries: BTreeMap<Address, Entry>,
    objects: BTreeSet<u16>,
}

impl ObjectDictionary {
    pub fn insert(&mut self, at: Address, entry: Entry) {
        self.objects.insert(at.index);
        self.entries.insert(at, entry);
    }

    pub fn entry(&self, at: Address) -> Option<&Entry> {
        self.entries.get(&at)
    }

    pub fn entries(&self) -> impl Iterator<Item = (&Address, &Entry)> {
        self.entries.iter()
    }

    /// The integer value of `at`.
    pub fn int(&self, at: Address) -> Option<i128> {
        let e = self.entries.get(&at)?;
        e.data_type.decode_int(&e.value)
    }

    pub fn u32(&self, at: Address) -> Option<u32> {
        self.int(at).and_then(|v| u32::try_from(v).ok())
    }

    /// Sets an integer value as the device itself does (no access check: the device writes its
    /// read-only objects, e.g. the statusword). `false` if there is no such integer entry or
    /// the value is outside the type.
    pub fn set_int(&mut self, at: Address, v: i128) -> bool {
        let Some(e) = self.entries.get_mut(&at) else { return false };
        match e.data_type.encode_int(v) {
            Some(bytes) => {
                e.value = bytes;
                true
            }
            None => false,
        }
    }

    fn lookup(&self, at: Address) -> Result<&Entry, SdoAbort> {
        self.entries.get(&at).ok_or(if self.objects.contains(&at.index) {
            SdoAbort::NoSuchSubIndex
        } else {
            SdoAbort::NoSuchObject
        })
    }

    /// Checks `data` for `at` as an SDO download would, without writing.
    pub fn check(&self, at: Address, data: &[u8]) -> Result<(), SdoAbort> {
        let e = self.lookup(at)?;
        if !e.access.writable() {
            return Err(SdoAbort::ReadOnly);
        }
        if let Some(n) = e.data_type.size() {
            if data.len() > n {
                return Err(SdoAbort::LengthTooHigh);
            }
            if data.len() < n {
                return Err(SdoAbort::LengthTooLow);
            }
        }
        if let Some(v) = e.data_type.decode_int(data) {
            if e.low.is_some_and(|lo| v < lo) {
                return Err(SdoAbort::ValueTooLow);
            }
            if e.high.is_some_and(|hi| v > hi) {
                return Err(SdoAbort::ValueTooHigh);
            }
        }
        Ok(())
    }
}

impl ObjectAccess for ObjectDictionary {
    fn read(&mut self, at: Address) -> Result<Vec<u8>, SdoAbort> {
        let e = self.lookup(at)?;
        if !e.access.readable() {
            return Err(SdoAbort::WriteOnly);
        }
        Ok(e.value.clone())
    }

    fn write(&mut self, at: Address, data: &[u8]) -> Result<(), SdoAbort> {
        self.check(at, data)?;
        if let Some(e) = self.entries.get_mut(&at) {
            e.value = data.to_vec();
        }
        Ok(())
    }

    fn writable(&mut self, at: Address) -> Result<(), SdoAbort> {
        let e = self.lookup(at)?;
        if e.access.writable() { Ok(()) } else { Err(SdoAbort::ReadOnly) }
    }
}
