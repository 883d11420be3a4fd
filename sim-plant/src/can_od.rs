//! The object dictionary of one simulated drive: its EDS (`sim-plant/eds/interpd-sim-drive.eds`)
//! read for the node, served over SDO with the rules a CiA 301/402 device adds to plain access
//! checks (PDO mapping changes only while the PDO is disabled and its count is 0, mapped
//! objects must exist and be mappable, at most 64 bits, supported modes only), the PDOs built
//! from the mapping it holds, and the resets of NMT.

use interpd_canopen::od::ObjectDictionary;
use interpd_canopen::sdo_server::ObjectAccess;
use interpd_canopen::{Address, SdoAbort, eds};
use interpd_protocol::cia301::NodeId;

/// The simulated drive's EDS, as shipped.
pub const EDS: &str = include_str!("../eds/interpd-sim-drive.eds");

pub const RPDO1_COMM: u16 = 0x1400;
pub const RPDO1_MAP: u16 = 0x1600;
pub const TPDO1_COMM: u16 = 0x1800;
pub const TPDO1_MAP: u16 = 0x1A00;
pub const HEARTBEAT: Address = Address::new(0x1017, 0);
pub const CONTROLWORD: Address = Address::new(0x6040, 0);
pub const STATUSWORD: Address = Address::new(0x6041, 0);
pub const MODES: Address = Address::new(0x6060, 0);
pub const MODES_DISPLAY: Address = Address::new(0x6061, 0);
pub const POSITION_ACTUAL: Address = Address::new(0x6064, 0);
pub const TARGET_POSITION: Address = Address::new(0x607A, 0);
pub const ERROR_CODE: Address = Address::new(0x603F, 0);
pub const ERROR_REGISTER: Address = Address::new(0x1001, 0);
pub const HOME_OFFSET: Address = Address::new(0x607C, 0);
pub const HOMING_METHOD: Address = Address::new(0x6098, 0);
pub const HOMING_SPEED_SWITCH: Address = Address::new(0x6099, 1);
pub const HOMING_SPEED_ZERO: Address = Address::new(0x6099, 2);
pub const HOMING_ACCELERATION: Address = Address::new(0x609A, 0);
/// Modes of operation this drive supports (0x6502): none (0), homing (6) and CSP (8).
pub const SUPPORTED_MODES: [i128; 3] = [0, 6, 8];
/// Bit 31 of a PDO COB-ID: the PDO does not exist (disabled).
const COB_INVALID: u32 = 1 << 31;

/// A mapped object: where and how many bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mapped {
    pub at: Address,
    pub bits: u8,
}

/// The dictionary of one drive.
#[derive(Debug, Clone)]
pub struct DriveDictionary {
    od: ObjectDictionary,
    defaults: ObjectDictionary,
}

impl DriveDictionary {
    /// The dictionary at power-on, from the shipped EDS for `node`.
    pub fn new(node: NodeId) -> Result<DriveDictionary, eds::EdsError> {
        let od = eds::parse(EDS, node)?.od;
        Ok(DriveDictionary { defaults: od.clone(), od })
    }

    pub fn od(&self) -> &ObjectDictionary {
        &self.od
    }

    /// NMT reset communication: the communication area 0x1000–0x1FFF back to its defaults.
    pub fn reset_communication(&mut self) {
        for (at, e) in self.defaults.entries().filter(|(a, _)| a.index < 0x2000) {
            self.od.insert(*at, e.clone());
        }
    }

    /// NMT reset node: every object back to its default.
    pub fn reset_node(&mut self) {
        self.od = self.defaults.clone();
    }

    pub fn int(&self, at: Address) -> i128 {
        self.od.int(at).unwrap_or(0)
    }

    /// The device's own write (no access check), e.g. the statusword.
    pub fn set(&mut self, at: Address, v: i128) {
        self.od.set_int(at, v);
    }

    /// The COB-ID of a PDO whose communication parameter is at `comm`, `None` while disabled.
    fn cob(&self, comm: u16) -> Option<u16> {
        let c = self.od.u32(Address::new(comm, 1))?;
        (c & COB_INVALID == 0).then_some((c & 0x7FF) as u16)
    }

    pub fn rpdo_cob(&self) -> Option<u16> {
        self.cob(RPDO1_COMM)
    }

    pub fn tpdo_cob(&self) -> Option<u16> {
        self.cob(TPDO1_COMM)
    }

    /// Transmission type of TPDO1: 1–240 every n-th SYNC, 254/255 event-driven.
    pub fn tpdo_transmission(&self) -> u8 {
        self.int(Address::new(TPDO1_COMM, 2)) as u8
    }

    /// The heartbeat producer time, ms (0 = off).
    pub fn heartbeat_ms(&self) -> u64 {
        self.int(HEARTBEAT) as u64
    }

    /// The objects a mapping parameter maps, in order.
    pub fn mapping(&self, map: u16) -> Vec<Mapped> {
        let n = self.int(Address::new(map, 0)) as u8;
        (1..=n)
            .filter_map(|s| self.od.u32(Address::new(map, s)))
            .map(|v| Mapped { at: Address::new((v >> 16) as u16, (v >> 8) as u8), bits: v as u8 })
            .collect()
    }

    /// The bytes of an RPDO1 written into the mapped objects. `Err(expected length)` when the
    /// frame's length is not the mapping's (nothing is written then).
    pub fn apply_rpdo(&mut self, data: &[u8]) -> Result<(), usize> {
        let map = self.mapping(RPDO1_MAP);
        let len: usize = map.iter().map(|m| usize::from(m.bits / 8)).sum();
        if data.len() != len {
            return Err(len);
        }
        let mut pos = 0;
        for m in map {
            let n = usize::from(m.bits / 8);
            if let Some(e) = self.od.entry(m.at) {
                let v = e.data_type.decode_int(&data[pos..pos + n]);
                if let Some(v) = v {
                    self.od.set_int(m.at, v);
                }
            }
            pos += n;
        }
        Ok(())
    }

    /// The bytes of TPDO1 from the mapped objects.
    pub fn tpdo_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(8);
        for m in self.mapping(TPDO1_MAP) {
            let n = usize::from(m.bits / 8);
            match self.od.entry(m.at) {
                Some(e) if e.value.len() == n => out.extend_from_slice(&e.value),
                _ => out.extend(std::iter::repeat_n(0, n)),
            }
        }
        out
    }

    /// The PDO rules of CiA 301 7.5.2.35/36 for a write to a PDO parameter.
    fn check_pdo(&self, at: Address, data: &[u8]) -> Result<(), SdoAbort> {
        let value = || u32::from_le_bytes(data.try_into().unwrap_or([0; 4]));
        let (comm, is_map) = match at.index {
            RPDO1_MAP => (RPDO1_COMM, true),
            TPDO1_MAP => (TPDO1_COMM, true),
            RPDO1_COMM | TPDO1_COMM => (at.index, false),
            _ => return Ok(()),
        };
        let enabled = self.cob(comm).is_some();
        if !is_map {
            // A valid PDO's COB-ID may only be invalidated, not moved (CiA 301 7.5.2.35).
            if at.sub == 1 && data.len() == 4 {
                let old = self.od.u32(at).unwrap_or(0);
                if enabled && value() & COB_INVALID == 0 && value() != old {
                    return Err(SdoAbort::InvalidValue);
                }
            }
            if at.sub == 2 && enabled {
                return Err(SdoAbort::CannotStoreDeviceState);
            }
            return Ok(());
        }
        if enabled {
            return Err(SdoAbort::CannotStoreDeviceState);
        }
        let map = at.index;
        if at.sub == 0 {
            let Some(&n) = data.first() else { return Ok(()) };
            let mut bits = 0u32;
            for s in 1..=n {
                let v = self.od.u32(Address::new(map, s)).ok_or(SdoAbort::InvalidValue)?;
                bits += v & 0xFF;
            }
            if bits > 64 {
                return Err(SdoAbort::PdoTooLong);
            }
            return Ok(());
        }
        // Entries change only while the count is 0.
        if self.int(Address::new(map, 0)) != 0 {
            return Err(SdoAbort::CannotStoreDeviceState);
        }
        let v = value();
        if v == 0 {
            return Ok(());
        }
        let target = Address::new((v >> 16) as u16, (v >> 8) as u8);
        let e = self.od.entry(target).ok_or(SdoAbort::CannotMap)?;
        let fits = e.data_type.size().is_some_and(|n| n * 8 == (v & 0xFF) as usize);
        let direction_ok = if map == RPDO1_MAP { e.access.writable() } else { e.access.readable() };
        if !e.pdo_mappable || !fits || !direction_ok {
            return Err(SdoAbort::CannotMap);
        }
        Ok(())
    }
}

impl ObjectAccess for DriveDictionary {
    fn read(&mut self, at: Address) -> Result<Vec<u8>, SdoAbort> {
        self.od.read(at)
    }

    fn write(&mut self, at: Address, data: &[u8]) -> Result<(), SdoAbort> {
        self.od.check(at, data)?;
        self.check_pdo(at, data)?;
        if at == MODES {
            let mode = i128::from(data.first().copied().unwrap_or(0) as i8);
            if !SUPPORTED_MODES.contains(&mode) {
                return Err(SdoAbort::InvalidValue);
            }
            // The drive switches at once: the display follows.
            self.od.set_int(MODES_DISPLAY, mode);
        }
        self.od.write(at, data)
    }

    fn writable(&mut self, at: Address) -> Result<(), SdoAbort> {
        self.od.writable(at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dict() -> DriveDictionary {
        DriveDictionary::new(NodeId::new(2).unwrap()).unwrap()
    }

    #[test]
    fn power_on_has_cia402_default_mapping_heartbeat_off_and_no_mode() {
        let d = dict();
        assert_eq!(d.mapping(RPDO1_MAP), [Mapped { at: CONTROLWORD, bits: 16 }]);
        assert_eq!(d.mapping(TPDO1_MAP), [Mapped { at: STATUSWORD, bits: 16 }]);
        assert_eq!((d.rpdo_cob(), d.tpdo_cob()), (Some(0x202), Some(0x182)));
        assert_eq!((d.heartbeat_ms(), d.int(MODES), d.int(MODES_DISPLAY)), (0, 0, 0));
        assert_eq!(d.tpdo_transmission(), 0xFF);
        assert_eq!(d.od().u32(Address::new(0x1018, 2)), Some(0x402));
    }

    #[test]
    fn mapping_follows_the_cia301_procedure() {
        let mut d = dict();
        let w = |d: &mut DriveDictionary, i: u16, s: u8, v: &[u8]| d.write(Address::new(i, s), v);
        // Mapping a valid PDO is refused; so is moving its COB-ID.
        assert_eq!(w(&mut d, RPDO1_MAP, 0, &[0]), Err(SdoAbort::CannotStoreDeviceState));
        assert_eq!(w(&mut d, RPDO1_COMM, 1, &0x0000_0300u32.to_le_bytes()), Err(SdoAbort::InvalidValue));
        // Disable, count 0, map, count 2, enable.
        w(&mut d, RPDO1_COMM, 1, &(0x8000_0202u32).to_le_bytes()).unwrap();
        assert_eq!(w(&mut d, RPDO1_MAP, 2, &0x607A_0020u32.to_le_bytes()), Err(SdoAbort::CannotStoreDeviceState));
        w(&mut d, RPDO1_MAP, 0, &[0]).unwrap();
        assert_eq!(w(&mut d, RPDO1_MAP, 2, &0x6041_0010u32.to_le_bytes()), Err(SdoAbort::CannotMap), "read-only");
        assert_eq!(w(&mut d, RPDO1_MAP, 2, &0x2000_0010u32.to_le_bytes()), Err(SdoAbort::CannotMap), "none");
        assert_eq!(w(&mut d, RPDO1_MAP, 2, &0x607A_0010u32.to_le_bytes()), Err(SdoAbort::CannotMap), "length");
        w(&mut d, RPDO1_MAP, 2, &0x607A_0020u32.to_le_bytes()).unwrap();
        w(&mut d, RPDO1_COMM, 2, &[1]).unwrap();
        w(&mut d, RPDO1_MAP, 0, &[2]).unwrap();
        w(&mut d, RPDO1_COMM, 1, &0x0000_0202u32.to_le_bytes()).unwrap();
        assert_eq!(d.apply_rpdo(&[0x0F, 0]), Err(6));
        d.apply_rpdo(&[0x0F, 0, 0xFE, 0xFF, 0xFF, 0xFF]).unwrap();
        assert_eq!((d.int(CONTROLWORD), d.int(TARGET_POSITION)), (0x0F, -2));
        // Modes: homing and CSP only; the display follows.
        assert_eq!(w(&mut d, 0x6060, 0, &[1]), Err(SdoAbort::InvalidValue));
        w(&mut d, 0x6060, 0, &[6]).unwrap();
        assert_eq!(d.int(MODES_DISPLAY), 6);
        w(&mut d, 0x6060, 0, &[8]).unwrap();
        assert_eq!(d.int(MODES_DISPLAY), 8);
        // Reset communication restores the default mapping, not the mode.
        d.reset_communication();
        assert_eq!(d.mapping(RPDO1_MAP).len(), 1);
        assert_eq!(d.int(MODES), 8);
        d.reset_node();
        assert_eq!(d.int(MODES), 0);
    }
}
