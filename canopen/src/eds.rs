//! EDS and DCF files (CiA 306) read into an [`ObjectDictionary`]: the objects listed in
//! `[MandatoryObjects]`, `[OptionalObjects]` and `[ManufacturerObjects]`, each a VAR or an
//! ARRAY/RECORD with its `[XXXXsubN]` sections, values from `ParameterValue` (DCF) or
//! `DefaultValue`, `$NODEID` resolved for the node. The identity of `[DeviceInfo]` is kept for
//! the master's check of 0x1018. Every error names its place in the file.

use crate::ini::{Ini, Pos, Section, Value};
use crate::od::{Access, DataType, Entry, ObjectDictionary};
use crate::sdo_frame::Address;
use interpd_protocol::cia301::NodeId;

/// An error in an EDS/DCF file, with the place when there is one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{message}", pos.map(|p| format!("{p}: ")).unwrap_or_default())]
pub struct EdsError {
    pub pos: Option<Pos>,
    pub message: String,
}

fn err(pos: Pos, message: String) -> EdsError {
    EdsError { pos: Some(pos), message }
}

/// A device description read from an EDS or DCF for one node.
#[derive(Debug, Clone, PartialEq)]
pub struct Eds {
    pub od: ObjectDictionary,
    /// `[DeviceInfo]`: what 0x1018 sub 1, 2 and 3 are to hold.
    pub vendor_id: u32,
    pub product_code: u32,
    pub revision: u32,
    pub product_name: String,
    /// The entries a DCF gives a `ParameterValue` (the configured values a master writes at
    /// boot), in index and sub-index order. Empty for a plain EDS.
    pub parameters: Vec<Address>,
}

/// Reads `text` for node `node`.
pub fn parse(text: &str, node: NodeId) -> Result<Eds, EdsError> {
    let ini = Ini::parse(text).map_err(|e| err(e.pos, e.message))?;
    let info = ini.section("DeviceInfo").ok_or(EdsError { pos: None, message: "no [DeviceInfo] section".into() })?;
    let number = |key: &str| -> Result<u32, EdsError> {
        let v = info.get(key).ok_or_else(|| err(info.pos, format!("[DeviceInfo] has no {key}")))?;
        let n = int(v, node)?;
        u32::try_from(n).map_err(|_| err(v.pos, format!("{key} {n} is not an UNSIGNED32")))
    };
    let (vendor_id, product_code, revision) =
        (number("VendorNumber")?, number("ProductNumber")?, number("RevisionNumber")?);
    let product_name = info.get("ProductName").map(|v| v.text.clone()).unwrap_or_default();

    let mut listed = Vec::new();
    for list in ["MandatoryObjects", "OptionalObjects", "ManufacturerObjects"] {
        let Some(s) = ini.section(list) else { continue };
        let count = match s.get("SupportedObjects") {
            Some(v) => int(v, node)?,
            None => return Err(err(s.pos, format!("[{list}] has no SupportedObjects"))),
        };
        for i in 1..=count {
            let v = s
                .get(&i.to_string())
                .ok_or_else(|| err(s.pos, format!("[{list}] says SupportedObjects={count} but has no entry {i}")))?;
            let index = u16::try_from(int(v, node)?)
                .map_err(|_| err(v.pos, format!("object index {:?} is not 16 bits", v.text)))?;
            listed.push((index, v.pos));
        }
        if s.keys.len() as i128 != count + 1 {
            return Err(err(
                s.pos,
                format!("[{list}] has {} entries, SupportedObjects says {count}", s.keys.len() - 1),
            ));
        }
    }
    let mut od = ObjectDictionary::default();
    let mut parameters = Vec::new();
    let mut add = |od: &mut ObjectDictionary, at: Address, s: &Section| -> Result<(), EdsError> {
        if s.get("ParameterValue").is_some_and(|v| !v.text.is_empty()) {
            parameters.push(at);
        }
        od.insert(at, entry(s, node)?);
        Ok(())
    };
    for &(index, pos) in &listed {
        let name = format!("{index:04X}");
        let s = ini
            .section(&name)
            .ok_or_else(|| err(pos, format!("object 0x{name} is listed but has no [{name}] section")))?;
        let object_type = match s.get("ObjectType") {
            Some(v) => int(v, node)?,
            None => 7,
        };
        match object_type {
            7 => add(&mut od, Address::new(index, 0), s)?,
            8 | 9 => {
                let sub_number = s.get("SubNumber").ok_or_else(|| err(s.pos, format!("[{name}] has no SubNumber")))?;
                let n = int(sub_number, node)?;
                let prefix = format!("{}sub", name.to_ascii_lowercase());
                let mut found = 0;
                for (key, sub) in ini.sections.range(prefix.clone()..).take_while(|(k, _)| k.starts_with(&prefix)) {
                    let digits = &key[prefix.len()..];
                    let sub_index = u8::from_str_radix(digits, 16).map_err(|_| {
                        err(sub.pos, format!("[{}]: sub-index {digits:?} is not hexadecimal", sub.name))
                    })?;
                    add(&mut od, Address::new(index, sub_index), sub)?;
                    found += 1;
                }
                if found != n {
                    return Err(err(
                        sub_number.pos,
                        format!("[{name}] says SubNumber={n} but {found} [{name}subN] sections exist"),
                    ));
                }
            }
            other => {
                let pos = s.get("ObjectType").map_or(s.pos, |v| v.pos);
                return Err(err(pos, format!("[{name}]: ObjectType {other} is not 7 (VAR), 8 (ARRAY) or 9 (RECORD)")));
            }
        }
    }
    for (key, s) in &ini.sections {
        let is_object = key.len() == 4 && key.chars().all(|c| c.is_ascii_hexdigit());
        if is_object && !listed.iter().any(|(i, _)| format!("{i:04x}") == *key) {
            return Err(err(s.pos, format!("[{}] is not listed in any of the ...Objects sections", s.name)));
        }
    }
    parameters.sort();
    Ok(Eds { od, vendor_id, product_code, revision, product_name, parameters })
}

fn entry(s: &Section, node: NodeId) -> Result<Entry, EdsError> {
    let need = |key: &str| s.get(key).ok_or_else(|| err(s.pos, format!("[{}] has no {key}", s.name)));
    let dt = need("DataType")?;
    let code = u16::try_from(int(dt, node)?).unwrap_or(0);
    let data_type =
        DataType::from_code(code).ok_or_else(|| err(dt.pos, format!("data type 0x{code:04X} is not supported")))?;
    let acc = need("AccessType")?;
    let access = Access::from_eds(&acc.text)
        .ok_or_else(|| err(acc.pos, format!("AccessType {:?} is not ro, wo, rw, rwr, rww or const", acc.text)))?;
    let pdo_mappable = match s.get("PDOMapping") {
        Some(v) => int(v, node)? != 0,
        None => false,
    };
    let limit = |key: &str| s.get(key).filter(|v| !v.text.is_empty()).map(|v| int(v, node)).transpose();
    let (low, high) = (limit("LowLimit")?, limit("HighLimit")?);
    // A DCF's ParameterValue is the configured value; the EDS's DefaultValue otherwise.
    let value = s.get("ParameterValue").or_else(|| s.get("DefaultValue"));
    let bytes = match (data_type, value) {
        (DataType::VisibleString | DataType::OctetString, v) => {
            v.map(|v| v.text.as_bytes().to_vec()).unwrap_or_default()
        }
        (DataType::Real32, Some(v)) if !v.text.is_empty() => {
            let x: f32 = v.text.parse().map_err(|_| err(v.pos, format!("{:?} is not a REAL32", v.text)))?;
            x.to_le_bytes().to_vec()
        }
        (DataType::Real32, _) => 0f32.to_le_bytes().to_vec(),
        (t, v) => {
            let n = match v {
                Some(v) if !v.text.is_empty() => int(v, node)?,
                _ => 0,
            };
            t.encode_int(n).ok_or_else(|| {
                err(value.map_or(s.pos, |v| v.pos), format!("[{}]: value {n} does not fit {t:?}", s.name))
            })?
        }
    };
    Ok(Entry { name: need("ParameterName")?.text.clone(), data_type, access, pdo_mappable, low, high, value: bytes })
}

/// An integer of CiA 306: decimal, `0x` hexadecimal, octal with a leading 0, optionally a sum
/// with `$NODEID` (e.g. `$NODEID+0x180`).
fn int(v: &Value, node: NodeId) -> Result<i128, EdsError> {
    let mut sum: i128 = 0;
    for term in v.text.split('+') {
        let t = term.trim();
        let n = if t.eq_ignore_ascii_case("$NODEID") {
            Some(i128::from(node.get()))
        } else if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
            i128::from_str_radix(h, 16).ok()
        } else if t.len() > 1 && t.starts_with('0') {
            i128::from_str_radix(&t[1..], 8).ok()
        } else {
            t.parse::<i128>().ok()
        };
        let n =
            n.ok_or_else(|| err(v.pos, format!("{:?} is not an integer (decimal, 0x hex, 0 octal, $NODEID)", v.text)))?;
        sum = sum.checked_add(n).ok_or_else(|| err(v.pos, format!("{:?} overflows", v.text)))?;
    }
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node() -> NodeId {
        NodeId::new(3).unwrap()
    }

    const HEAD: &str = "[DeviceInfo]\nVendorNumber=0x10\nProductNumber=0x402\nRevisionNumber=0\nProductName=d\n";

    #[test]
    fn values_node_id_and_records() {
        let text = format!(
            "{HEAD}[MandatoryObjects]\nSupportedObjects=2\n1=0x1017\n2=0x1400\n\
             [1017]\nParameterName=HB\nDataType=0x0006\nAccessType=rw\nDefaultValue=100\nParameterValue=0\n\
             [1400]\nParameterName=RPDO1\nObjectType=9\nSubNumber=2\n\
             [1400sub0]\nParameterName=n\nDataType=5\nAccessType=ro\nDefaultValue=1\n\
             [1400sub1]\nParameterName=COB\nDataType=7\nAccessType=rw\nDefaultValue=$NODEID+0x200\n"
        );
        let eds = parse(&text, node()).unwrap();
        assert_eq!((eds.vendor_id, eds.product_code), (0x10, 0x402));
        assert_eq!(eds.od.int(Address::new(0x1017, 0)), Some(0), "ParameterValue wins");
        assert_eq!(eds.parameters, vec![Address::new(0x1017, 0)], "the DCF's configured values");
        assert_eq!(eds.od.u32(Address::new(0x1400, 1)), Some(0x203));
    }

    #[test]
    fn errors_point_at_their_place() {
        let text = format!(
            "{HEAD}[OptionalObjects]\nSupportedObjects=1\n1=0x6060\n[6060]\nParameterName=m\nDataType=0x0002\nAccessType=rw\nDefaultValue=300\n"
        );
        let e = parse(&text, node()).unwrap_err();
        assert_eq!(e.to_string(), "line 13, column 14: [6060]: value 300 does not fit Integer8");
        let text = format!("{HEAD}[OptionalObjects]\nSupportedObjects=1\n1=0x6061\n");
        assert!(parse(&text, node()).unwrap_err().to_string().starts_with("line 8, column 3: object 0x6061 is listed"));
        let text = format!(
            "{HEAD}[OptionalObjects]\nSupportedObjects=1\n1=0x6060\n[6060]\nParameterName=m\nDataType=0x0002\nAccessType=rx\n"
        );
        assert!(parse(&text, node()).unwrap_err().message.contains("AccessType \"rx\""));
    }
}
