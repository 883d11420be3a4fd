//! Commissioning of the CAN drives over the control API: `drives.sdo_read`, `drives.sdo_write`
//! (one SDO transfer with one node, typed values) and `drives.reset` (fault reset). The daemon
//! runs them only while nothing moves (docs/control-api.md).

use super::Method;
use super::tooling::{members, refuse};
use crate::jsonrpc::ErrorObject;
use crate::jsonrpc::params::Params;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// How the bytes of an object are read and written: the basic types of CiA 301, little endian.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SdoType {
    Bool,
    U8,
    U16,
    U32,
    U64,
    I8,
    I16,
    I32,
    I64,
    /// VISIBLE_STRING: the value is a JSON string.
    String,
    /// OCTET_STRING or anything else: the value is the bytes in hex, e.g. `"0A1B"`.
    Bytes,
}

impl SdoType {
    pub const ALL: [SdoType; 11] = [
        SdoType::Bool,
        SdoType::U8,
        SdoType::U16,
        SdoType::U32,
        SdoType::U64,
        SdoType::I8,
        SdoType::I16,
        SdoType::I32,
        SdoType::I64,
        SdoType::String,
        SdoType::Bytes,
    ];

    pub const fn name(self) -> &'static str {
        match self {
            SdoType::Bool => "bool",
            SdoType::U8 => "u8",
            SdoType::U16 => "u16",
            SdoType::U32 => "u32",
            SdoType::U64 => "u64",
            SdoType::I8 => "i8",
            SdoType::I16 => "i16",
            SdoType::I32 => "i32",
            SdoType::I64 => "i64",
            SdoType::String => "string",
            SdoType::Bytes => "bytes",
        }
    }

    pub fn from_name(name: &str) -> Option<SdoType> {
        SdoType::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The names, for messages: `bool, u8, …`.
    pub fn names() -> String {
        SdoType::ALL.map(SdoType::name).join(", ")
    }

    /// Size and signedness of the integer types.
    fn int(self) -> Option<(usize, bool)> {
        Some(match self {
            SdoType::Bool | SdoType::U8 => (1, false),
            SdoType::U16 => (2, false),
            SdoType::U32 => (4, false),
            SdoType::U64 => (8, false),
            SdoType::I8 => (1, true),
            SdoType::I16 => (2, true),
            SdoType::I32 => (4, true),
            SdoType::I64 => (8, true),
            SdoType::String | SdoType::Bytes => return None,
        })
    }

    /// The bytes of `value`: an integer within the type's range (JSON number, or a string in
    /// decimal or `0x` hex), `true`/`false` for bool, a string for string, hex for bytes.
    pub fn encode(self, value: &Value) -> Result<Vec<u8>, String> {
        if let Some((size, signed)) = self.int() {
            let v: i128 = match (self, value) {
                (SdoType::Bool, Value::Bool(b)) => i128::from(*b),
                (_, Value::Number(n)) => match (n.as_i64(), n.as_u64()) {
                    (Some(i), _) => i128::from(i),
                    (None, Some(u)) => i128::from(u),
                    _ => return Err(format!("{n} is not an integer")),
                },
                (_, Value::String(s)) => parse_int(s).ok_or_else(|| format!("{s:?} is not an integer"))?,
                (_, other) => return Err(format!("expected an integer for type {}, got {other}", self.name())),
            };
            let bits = 8 * size as u32;
            let (lo, hi) = if self == SdoType::Bool {
                (0, 1)
            } else if signed {
                (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
            } else {
                (0, (1i128 << bits) - 1)
            };
            if !(lo..=hi).contains(&v) {
                return Err(format!("{v} is out of range for {} ({lo} to {hi})", self.name()));
            }
            return Ok(v.to_le_bytes()[..size].to_vec());
        }
        match (self, value) {
            (SdoType::String, Value::String(s)) if !s.is_empty() => Ok(s.as_bytes().to_vec()),
            (SdoType::Bytes, Value::String(s)) => {
                let s = s.strip_prefix("0x").unwrap_or(s);
                if s.is_empty() || s.len() % 2 != 0 {
                    return Err(format!("{s:?} is not an even number of hex digits"));
                }
                (0..s.len())
                    .step_by(2)
                    .map(|i| u8::from_str_radix(&s[i..i + 2], 16).map_err(|_| format!("{s:?} is not hex")))
                    .collect()
            }
            (_, other) => Err(format!("expected a non-empty string for type {}, got {other}", self.name())),
        }
    }

    /// The value of `bytes` as this type; an integer of the wrong length is an error.
    pub fn decode(self, bytes: &[u8]) -> Result<Value, String> {
        if let Some((size, signed)) = self.int() {
            if bytes.len() != size {
                return Err(format!("{} bytes do not make a {}", bytes.len(), self.name()));
            }
            let mut b = [0u8; 16];
            b[..size].copy_from_slice(bytes);
            if signed && bytes[size - 1] & 0x80 != 0 {
                b[size..].fill(0xFF);
            }
            let v = i128::from_le_bytes(b);
            return Ok(match self {
                SdoType::Bool => Value::Bool(v != 0),
                _ if signed => Value::from(v as i64),
                _ => Value::from(v as u64),
            });
        }
        Ok(match self {
            SdoType::String => Value::String(String::from_utf8_lossy(bytes).into_owned()),
            _ => Value::String(hex(bytes)),
        })
    }
}

/// Decimal, or hex with `0x`, optionally negative.
fn parse_int(s: &str) -> Option<i128> {
    let (neg, t) = match s.trim().strip_prefix('-') {
        Some(t) => (true, t),
        None => (false, s.trim()),
    };
    let v = match t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        Some(h) => i128::from_str_radix(h, 16).ok()?,
        None => t.parse::<i128>().ok()?,
    };
    Some(if neg { -v } else { v })
}

/// Bytes as upper-case hex without separators.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// The members of `drives.sdo_read` and `drives.sdo_write`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SdoMembers {
    node: u8,
    /// A number or a string in `0x` hex.
    index: Value,
    #[serde(default)]
    sub: u8,
    #[serde(rename = "type")]
    ty: Option<String>,
    value: Option<Value>,
}

const READ_EXAMPLE: &str = r#"{"node": 2, "index": "0x6061", "sub": 0, "type": "i8"}"#;
const WRITE_EXAMPLE: &str = r#"{"node": 2, "index": "0x6065", "sub": 0, "type": "u32", "value": 20000}"#;

/// `drives.sdo_read`: upload `index:sub` from `node`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SdoReadParams {
    pub node: u8,
    pub index: u16,
    pub sub: u8,
    /// How to show the value; without it the result has the bytes only.
    pub ty: Option<SdoType>,
}

/// `drives.sdo_write`: download `data` (the typed `value`) to `index:sub` of `node`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SdoWriteParams {
    pub node: u8,
    pub index: u16,
    pub sub: u8,
    pub ty: SdoType,
    pub data: Vec<u8>,
}

/// The members of a transfer after their checks.
struct Checked {
    node: u8,
    index: u16,
    sub: u8,
    ty: Option<SdoType>,
    value: Option<Value>,
}

impl SdoMembers {
    fn checked(self, method: Method) -> Result<Checked, ErrorObject> {
        if !(1..=127).contains(&self.node) {
            return Err(refuse(method, "node", &format!("node-ID {} is not 1..=127", self.node)));
        }
        let index = match &self.index {
            Value::Number(n) => n.as_u64().and_then(|v| u16::try_from(v).ok()),
            Value::String(s) => parse_int(s).and_then(|v| u16::try_from(v).ok()),
            _ => None,
        }
        .ok_or_else(|| {
            refuse(method, "index", &format!("\"index\" must be 0 to 0xFFFF (a number or \"0x…\"), got {}", self.index))
        })?;
        let ty = match &self.ty {
            None => None,
            Some(name) => Some(SdoType::from_name(name).ok_or_else(|| {
                refuse(method, "type", &format!("unknown type {name:?}; expected one of {}", SdoType::names()))
            })?),
        };
        Ok(Checked { node: self.node, index, sub: self.sub, ty, value: self.value })
    }
}

impl SdoReadParams {
    pub fn parse(params: Params) -> Result<SdoReadParams, ErrorObject> {
        const M: Method = Method::DrivesSdoRead;
        let Checked { node, index, sub, ty, value } = members::<SdoMembers>(M, params, READ_EXAMPLE)?.checked(M)?;
        if value.is_some() {
            return Err(refuse(M, "value", "drives.sdo_read takes no \"value\" (drives.sdo_write writes one)"));
        }
        Ok(SdoReadParams { node, index, sub, ty })
    }
}

impl SdoWriteParams {
    pub fn parse(params: Params) -> Result<SdoWriteParams, ErrorObject> {
        const M: Method = Method::DrivesSdoWrite;
        let Checked { node, index, sub, ty, value } = members::<SdoMembers>(M, params, WRITE_EXAMPLE)?.checked(M)?;
        let ty = ty.ok_or_else(|| {
            refuse(M, "type", &format!("missing parameter \"type\" ({}); expected {WRITE_EXAMPLE}", SdoType::names()))
        })?;
        let value = value
            .ok_or_else(|| refuse(M, "value", &format!("missing parameter \"value\"; expected {WRITE_EXAMPLE}")))?;
        let data = ty.encode(&value).map_err(|e| refuse(M, "value", &e))?;
        Ok(SdoWriteParams { node, index, sub, ty, data })
    }
}

/// Result of `drives.sdo_read` and `drives.sdo_write`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SdoResult {
    pub node: u8,
    /// `"0x6061"`.
    pub index: String,
    pub sub: u8,
    /// The object's bytes (read) or the bytes written, in hex.
    pub data: String,
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    pub ty: Option<String>,
    /// The bytes as `type` (absent without a type, or when they do not fit it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<Value>,
}

impl SdoResult {
    pub fn new(node: u8, index: u16, sub: u8, data: &[u8], ty: Option<SdoType>) -> SdoResult {
        SdoResult {
            node,
            index: format!("0x{index:04X}"),
            sub,
            data: hex(data),
            ty: ty.map(|t| t.name().to_string()),
            value: ty.and_then(|t| t.decode(data).ok()),
        }
    }
}

/// `drives.reset`: the nodes to reset; none given: every drive in Fault.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetParams {
    #[serde(default)]
    pub nodes: Vec<u8>,
}

impl ResetParams {
    pub fn parse(params: Params) -> Result<ResetParams, ErrorObject> {
        const M: Method = Method::DrivesReset;
        if matches!(params, Params::None) {
            return Ok(ResetParams::default());
        }
        members::<ResetParams>(M, params, r#"{} (every drive in Fault) or {"nodes": [2]}"#)
    }
}

/// One drive in the result of `drives.reset`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetDrive {
    pub axis: String,
    pub node: u8,
    /// The CiA 402 state before and after (`status.drives[].state` names).
    pub state_before: String,
    pub state: String,
}

/// Result of `drives.reset`: every drive reset, all out of Fault.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetResult {
    pub drives: Vec<ResetDrive>,
}

/// One axis in the result of `machine.home`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HomedAxis {
    pub axis: String,
    pub node: u8,
    /// The homing method (0x6098).
    pub method: i8,
    /// Where the drive stands after homing (its position actual, the home offset at the home
    /// position), increments and axis units; the axis's setpoint is now this position.
    pub position_actual: i32,
    pub position_units: f64,
    /// Time from the start bit to "homing attained", s.
    pub duration_s: f64,
}

/// Result of `machine.home`: every axis homed, in the order homed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HomeResult {
    pub axes: Vec<HomedAxis>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn typed_values_round_trip_and_ranges_are_checked() {
        assert_eq!(SdoType::U32.encode(&json!(20000)), Ok(vec![0x20, 0x4E, 0, 0]));
        assert_eq!(SdoType::I8.encode(&json!(-3)), Ok(vec![0xFD]));
        assert_eq!(SdoType::U16.encode(&json!("0x1234")), Ok(vec![0x34, 0x12]));
        assert_eq!(SdoType::I8.decode(&[0xFD]), Ok(json!(-3)));
        assert_eq!(SdoType::U32.decode(&[0x02, 0x04, 0, 0]), Ok(json!(0x402)));
        assert_eq!(SdoType::String.decode(b"drive"), Ok(json!("drive")));
        assert_eq!(SdoType::Bytes.encode(&json!("0A1b")), Ok(vec![0x0A, 0x1B]));
        assert!(SdoType::I8.encode(&json!(300)).unwrap_err().contains("out of range for i8 (-128 to 127)"));
        assert!(SdoType::U8.encode(&json!(-1)).is_err());
        assert!(SdoType::U8.encode(&json!(1.5)).is_err());
        assert!(SdoType::U16.decode(&[1]).is_err());
    }

    #[test]
    fn parameters_are_checked_naming_the_member() {
        let p = |v: Value| Params::new(Some(v));
        let r = SdoReadParams::parse(p(json!({"node": 2, "index": "0x6061"}))).expect("read");
        assert_eq!(r, SdoReadParams { node: 2, index: 0x6061, sub: 0, ty: None });
        let w = SdoWriteParams::parse(p(json!({"node": 1, "index": 24677, "sub": 0, "type": "u32", "value": 7})))
            .expect("write");
        assert_eq!(w.data, vec![7, 0, 0, 0]);
        let e = SdoReadParams::parse(p(json!({"node": 0, "index": 1}))).unwrap_err();
        assert!(e.message.contains("node-ID 0 is not 1..=127"), "{}", e.message);
        let e = SdoReadParams::parse(p(json!({"node": 1, "index": "0x10000"}))).unwrap_err();
        assert!(e.message.contains("\"index\" must be 0 to 0xFFFF"), "{}", e.message);
        let e = SdoWriteParams::parse(p(json!({"node": 1, "index": 1, "value": 1}))).unwrap_err();
        assert!(e.message.contains("missing parameter \"type\""), "{}", e.message);
        let e = SdoWriteParams::parse(p(json!({"node": 1, "index": 1, "type": "f32", "value": 1}))).unwrap_err();
        assert!(e.message.contains("unknown type \"f32\""), "{}", e.message);
        assert_eq!(ResetParams::parse(Params::new(None)), Ok(ResetParams::default()));
        assert_eq!(ResetParams::parse(p(json!({"nodes": [2]}))), Ok(ResetParams { nodes: vec![2] }));
    }
}
