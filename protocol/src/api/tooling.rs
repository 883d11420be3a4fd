//! The tool table and the work offsets over the control API: `tools.get`, `tools.set`,
//! `offsets.get`, `offsets.set`. The daemon starts with the machine file's `[[tool]]` tables
//! and `[work_offsets]`; a change applies to programs loaded (and `mdi` blocks run) after it.

use super::{Method, invalid_params};
use crate::jsonrpc::ErrorObject;
use crate::jsonrpc::params::{FaultKind, Params, from_named};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Largest tool number (as the machine file's `[[tool]] number`).
pub const MAX_TOOL_NUMBER: u32 = 99_999;

/// The names of the work coordinate systems, in order.
pub const WORK_SYSTEMS: [&str; 9] = ["G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"];

/// One tool.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    /// The number programmed in H (G43) and D (G41/G42), 0–99999.
    pub number: u32,
    /// Cutter diameter, mm, ≥ 0.
    pub diameter_mm: f64,
    /// Tool length, mm (G43 adds it to Z).
    #[serde(default)]
    pub length_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

/// Result of `tools.get` and `tools.set`, and the parameters of `tools.set` (the whole table).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolTable {
    pub tools: Vec<Tool>,
}

/// Result of `offsets.get` and `offsets.set`: every system with every axis (mm, deg for rotary
/// axes) and every system's rotation about Z (degrees counter-clockwise, `G10 L2 … R`). As the
/// parameters of `offsets.set`: the systems given in `offsets`, each replaced whole (axes left
/// out are 0), and the rotations given in `rotations_deg`; the rest is kept.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkOffsets {
    #[serde(default)]
    pub offsets: BTreeMap<String, BTreeMap<String, f64>>,
    /// The rotation lives beside the axes, not among them: a client that reads every key of a
    /// system as an axis keeps working.
    #[serde(default)]
    pub rotations_deg: BTreeMap<String, f64>,
}

pub(super) fn refuse(method: Method, param: &str, detail: &str) -> ErrorObject {
    invalid_params(method, Some(param), detail)
}

pub(super) fn members<T: serde::de::DeserializeOwned>(
    method: Method,
    params: Params,
    example: &str,
) -> Result<T, ErrorObject> {
    let map = match params {
        Params::Named(map) => map,
        _ => return Err(invalid_params(method, None, &format!("{method} takes named parameters such as {example}"))),
    };
    from_named(map).map_err(|fault| {
        let param = fault.param.clone().unwrap_or_default();
        let detail = match &fault.kind {
            FaultKind::Unknown => format!("unknown parameter {param:?}; expected {example}"),
            FaultKind::Missing => format!("missing parameter {param:?}; expected {example}"),
            FaultKind::WrongType { expected, got } => format!("parameter {param:?} must be {expected}, got {got}"),
            FaultKind::Other(message) => format!("parameter {param:?}: {message}"),
        };
        invalid_params(method, Some(&param), &detail)
    })
}

const TOOLS_EXAMPLE: &str = r#"{"tools": [{"number": 1, "diameter_mm": 6.0, "length_mm": 50.0}]}"#;
const OFFSETS_EXAMPLE: &str = r#"{"offsets": {"G54": {"X": 100.0, "Y": 50.0}}}"#;

impl ToolTable {
    /// `tools.set`: numbers unique and in range, diameters finite and ≥ 0, lengths finite.
    pub fn parse(params: Params) -> Result<ToolTable, ErrorObject> {
        const M: Method = Method::ToolsSet;
        let t: ToolTable = members(M, params, TOOLS_EXAMPLE)?;
        for (i, tool) in t.tools.iter().enumerate() {
            if tool.number > MAX_TOOL_NUMBER {
                return Err(refuse(
                    M,
                    &format!("tools[{i}].number"),
                    &format!("tool number {} is out of range 0–{MAX_TOOL_NUMBER}", tool.number),
                ));
            }
            if let Some(j) = t.tools[..i].iter().position(|o| o.number == tool.number) {
                return Err(refuse(
                    M,
                    &format!("tools[{i}].number"),
                    &format!("tool number {} appears twice (also tools[{j}])", tool.number),
                ));
            }
            if !(tool.diameter_mm.is_finite() && tool.diameter_mm >= 0.0) {
                return Err(refuse(
                    M,
                    &format!("tools[{i}].diameter_mm"),
                    &format!("the diameter must be a finite number ≥ 0, got {}", tool.diameter_mm),
                ));
            }
            if !tool.length_mm.is_finite() {
                return Err(refuse(
                    M,
                    &format!("tools[{i}].length_mm"),
                    &format!("the length must be finite, got {}", tool.length_mm),
                ));
            }
        }
        Ok(t)
    }
}

impl WorkOffsets {
    /// `offsets.set`: at least one system or rotation, each system named G54 … G59.3, values
    /// finite (the axis names are checked against the machine by the daemon).
    pub fn parse(params: Params) -> Result<WorkOffsets, ErrorObject> {
        const M: Method = Method::OffsetsSet;
        let o: WorkOffsets = members(M, params, OFFSETS_EXAMPLE)?;
        for (system, v) in &o.rotations_deg {
            if !WORK_SYSTEMS.contains(&system.as_str()) {
                return Err(refuse(
                    M,
                    &format!("rotations_deg.{system}"),
                    &format!("unknown coordinate system {system:?}; expected one of G54 … G59.3"),
                ));
            }
            if !v.is_finite() {
                return Err(refuse(
                    M,
                    &format!("rotations_deg.{system}"),
                    &format!("the rotation must be a finite number, got {v}"),
                ));
            }
        }
        if o.offsets.is_empty() && o.rotations_deg.is_empty() {
            return Err(refuse(
                M,
                "offsets",
                &format!("\"offsets\" and \"rotations_deg\" name no coordinate system; expected {OFFSETS_EXAMPLE}"),
            ));
        }
        for (system, axes) in &o.offsets {
            if !WORK_SYSTEMS.contains(&system.as_str()) {
                return Err(refuse(
                    M,
                    &format!("offsets.{system}"),
                    &format!("unknown coordinate system {system:?}; expected one of G54 … G59.3"),
                ));
            }
            for (axis, v) in axes {
                if !v.is_finite() {
                    return Err(refuse(
                        M,
                        &format!("offsets.{system}.{axis}"),
                        &format!("the offset must be a finite number, got {v}"),
                    ));
                }
            }
        }
        Ok(o)
    }
}
