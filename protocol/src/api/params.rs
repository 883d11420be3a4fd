//! The parameters of `program.load`, `feed.override` and `motion.law`, and the check that
//! methods without parameters get none.
//!
//! Each method's members are a struct deserialized by serde (`deny_unknown_fields`); a
//! validation step after it turns the members into the parameter type and checks what serde
//! cannot: which members go together, ranges, empty strings. Refusals are −32602 naming the
//! parameter at fault in `data.param`.

use super::{Method, OVERRIDE_MAX, OVERRIDE_MAX_PERCENT, invalid_params};
use crate::jsonrpc::params::{FaultKind, ParamFault, Params, from_named};
use crate::jsonrpc::{ErrorObject, describe, excerpt};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// `program.load` parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged, try_from = "LoadMembers")]
pub enum LoadParams {
    /// A program file, read by the daemon: relative paths are relative to the daemon's working
    /// directory, so clients should send absolute paths.
    Path {
        path: String,
        /// The program continues with `program.append` (see [`AppendParams`]).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        open: bool,
    },
    /// Program text sent inline (up to the line limit, less the envelope).
    Text {
        text: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        open: bool,
    },
}

/// `program.append` parameters: `{"text": "G1 X10\nG1 Y5\n"}`, optionally `"end": true` when
/// no more text follows (as M2 would say).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AppendParams {
    pub text: String,
    #[serde(default)]
    pub end: bool,
}

/// `motion.law` parameters: one motion-law statement in the program syntax, e.g.
/// `{"statement": "LAW PRESET=rr7 DURATION=0.8 X=10 Y=-5"}` (docs/motion-laws.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LawParams {
    pub statement: String,
}

/// `feed.override` parameters: the factor applied to the programmed feed, 0.0..=2.0. On the
/// wire either `{"factor": 0.8}` or `{"percent": 80}`; it always serializes as `factor`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "OverrideMembers")]
pub struct OverrideParams {
    pub factor: f64,
}

/// How a method's parameters are described in its refusals.
struct Usage {
    method: Method,
    /// A complete example of the parameters.
    example: &'static str,
    /// What is expected instead of an unknown member.
    known: &'static str,
    /// The parameter named when none is given, and the text saying so.
    missing: (&'static str, &'static str),
}

const LOAD: Usage = Usage {
    method: Method::ProgramLoad,
    example: r#"{"path": "/abs/part.ngc"} or {"text": "G1 X10 F600\n", "name": "part"}"#,
    known: r#""path", or "text" with an optional "name"; an optional "open" (bool)"#,
    missing: ("path", r#"missing parameter "path" or "text""#),
};

const APPEND: Usage = Usage {
    method: Method::ProgramAppend,
    example: r#"{"text": "G1 X10\nG1 Y5\n"} or {"text": "M2\n", "end": true}"#,
    known: r#""text" and an optional "end" (bool)"#,
    missing: ("text", r#"missing parameter "text""#),
};

const OVERRIDE: Usage = Usage {
    method: Method::FeedOverride,
    example: r#"{"factor": 0.8} (0.0 to 2.0) or {"percent": 80} (0 to 200)"#,
    known: r#"{"factor": 0.8} (0.0 to 2.0) or {"percent": 80} (0 to 200)"#,
    missing: ("factor", r#"missing parameter "factor""#),
};

const LAW: Usage = Usage {
    method: Method::MotionLaw,
    example: r#"{"statement": "LAW PRESET=rr7 DURATION=0.8 X=10"}"#,
    known: r#"{"statement": "LAW PRESET=rr7 DURATION=0.8 X=10"}"#,
    missing: ("statement", r#"missing parameter "statement""#),
};

impl Usage {
    /// The members of named parameters, deserialized; `params` must be named (an object with
    /// at least one member).
    fn members<T: DeserializeOwned>(&self, params: Params) -> Result<T, ErrorObject> {
        let map = match params {
            Params::Named(map) => map,
            Params::None => return Err(self.refuse(Some(self.missing.0), &self.missing_text())),
            Params::Positional(other) => {
                return Err(self.refuse(
                    None,
                    &format!(
                        "{} takes named parameters (an object) such as {}, got {}",
                        self.method,
                        self.example,
                        describe(&other)
                    ),
                ));
            }
        };
        from_named(map).map_err(|fault| self.fault(fault))
    }

    fn missing_text(&self) -> String {
        format!("{}; expected {}", self.missing.1, self.example)
    }

    fn refuse(&self, param: Option<&str>, detail: &str) -> ErrorObject {
        invalid_params(self.method, param, detail)
    }

    fn fault(&self, fault: ParamFault) -> ErrorObject {
        let param = fault.param.as_deref();
        let name = param.unwrap_or_default();
        let detail = match &fault.kind {
            FaultKind::Unknown => format!("unknown parameter {:?}; expected {}", excerpt(name, 40), self.known),
            FaultKind::Missing => self.missing_text(),
            // `statement` is the one member of motion.law: its message needs no "parameter".
            FaultKind::WrongType { .. } if self.method == Method::MotionLaw => {
                format!("{name:?} must be a string")
            }
            FaultKind::WrongType { expected, got } => format!("parameter {name:?} must be {expected}, got {got}"),
            FaultKind::Other(message) => format!("parameter {name:?}: {message}"),
        };
        self.refuse(param, &detail)
    }
}

/// Methods without parameters accept none, `{}` or `[]`; anything else is probably a client
/// expecting a feature that does not exist, so it is refused rather than ignored.
pub(super) fn none(method: Method, params: Params) -> Result<(), ErrorObject> {
    /// No members at all: the first one given is unknown.
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct NoMembers {}

    match params {
        Params::None => Ok(()),
        Params::Named(map) => match from_named::<NoMembers>(map) {
            Ok(NoMembers {}) => Ok(()),
            Err(fault) => {
                let key = fault.param.unwrap_or_default();
                Err(invalid_params(
                    method,
                    Some(&key),
                    &format!("{method} takes no parameters, got {:?}", excerpt(&key, 40)),
                ))
            }
        },
        Params::Positional(_) => Err(invalid_params(method, None, &format!("{method} takes no parameters"))),
    }
}

// ---------------------------------------------------------------------------------------------
// program.load
// ---------------------------------------------------------------------------------------------

/// The members `program.load` may have, before [`LoadMembers::validate`] decides which form
/// they are.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadMembers {
    path: Option<String>,
    text: Option<String>,
    name: Option<String>,
    #[serde(default)]
    open: bool,
}

/// A validation refusal: the parameter at fault and why.
#[derive(Debug, Clone, PartialEq)]
struct Refusal {
    param: Option<&'static str>,
    detail: String,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.detail)
    }
}

impl Refusal {
    fn new(param: &'static str, detail: impl Into<String>) -> Refusal {
        Refusal { param: Some(param), detail: detail.into() }
    }

    fn into_error(self, usage: &Usage) -> ErrorObject {
        usage.refuse(self.param, &self.detail)
    }
}

impl LoadMembers {
    fn validate(self) -> Result<LoadParams, Refusal> {
        match (self.path, self.text, self.name) {
            (Some(_), Some(_), _) => Err(Refusal::new("text", "give either \"path\" or \"text\", not both")),
            (Some(_), None, Some(_)) => Err(Refusal::new(
                "name",
                "\"name\" goes with \"text\"; a program loaded from \"path\" is named by its path",
            )),
            (Some(p), None, None) if p.is_empty() => Err(Refusal::new("path", "parameter \"path\" is empty")),
            (Some(path), None, None) => Ok(LoadParams::Path { path, open: self.open }),
            (None, Some(text), name) => Ok(LoadParams::Text { text, name, open: self.open }),
            (None, None, _) => Err(Refusal::new(LOAD.missing.0, LOAD.missing_text())),
        }
    }
}

impl TryFrom<LoadMembers> for LoadParams {
    type Error = String;

    fn try_from(m: LoadMembers) -> Result<LoadParams, String> {
        m.validate().map_err(|r| r.detail)
    }
}

impl LoadParams {
    pub fn parse(params: Params) -> Result<LoadParams, ErrorObject> {
        LOAD.members::<LoadMembers>(params)?.validate().map_err(|r| r.into_error(&LOAD))
    }
}

// ---------------------------------------------------------------------------------------------
// feed.override
// ---------------------------------------------------------------------------------------------

/// The members `feed.override` may have: one of the two.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OverrideMembers {
    factor: Option<f64>,
    percent: Option<f64>,
}

impl OverrideMembers {
    fn validate(self) -> Result<OverrideParams, Refusal> {
        match (self.factor, self.percent) {
            (Some(_), Some(_)) => Err(Refusal::new("percent", "give either \"factor\" or \"percent\", not both")),
            (Some(f), None) if (0.0..=OVERRIDE_MAX).contains(&f) => Ok(OverrideParams { factor: f }),
            (Some(f), None) => {
                Err(Refusal::new("factor", format!("\"factor\" {f} is out of range 0.0 to {OVERRIDE_MAX:.1}")))
            }
            (None, Some(p)) if (0.0..=OVERRIDE_MAX_PERCENT).contains(&p) => Ok(OverrideParams { factor: p / 100.0 }),
            (None, Some(p)) => {
                Err(Refusal::new("percent", format!("\"percent\" {p} is out of range 0 to {OVERRIDE_MAX_PERCENT}")))
            }
            // Named parameters have at least one member and unknown ones are refused, so this
            // is only reached by a client deserializing `{}` itself.
            (None, None) => Err(Refusal { param: None, detail: "no parameters given".into() }),
        }
    }
}

impl TryFrom<OverrideMembers> for OverrideParams {
    type Error = String;

    fn try_from(m: OverrideMembers) -> Result<OverrideParams, String> {
        m.validate().map_err(|r| r.detail)
    }
}

impl OverrideParams {
    pub fn parse(params: Params) -> Result<OverrideParams, ErrorObject> {
        OVERRIDE.members::<OverrideMembers>(params)?.validate().map_err(|r| r.into_error(&OVERRIDE))
    }
}

// ---------------------------------------------------------------------------------------------
// motion.law
// ---------------------------------------------------------------------------------------------

impl LawParams {
    pub fn parse(params: Params) -> Result<LawParams, ErrorObject> {
        LAW.members::<LawParams>(params)
    }
}

/// `motion.optional_stop` parameters: `{"enabled": true}` makes M1 pause the program as M0
/// does; `false` lets the motion go on at M1 (its exact stop stays).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptionalStopParams {
    pub enabled: bool,
}

const OPTIONAL_STOP: Usage = Usage {
    method: Method::MotionOptionalStop,
    example: r#"{"enabled": false}"#,
    known: r#"{"enabled": true} or {"enabled": false}"#,
    missing: ("enabled", r#"missing parameter "enabled""#),
};

impl OptionalStopParams {
    pub fn parse(params: Params) -> Result<OptionalStopParams, ErrorObject> {
        OPTIONAL_STOP.members::<OptionalStopParams>(params)
    }
}

// ---------------------------------------------------------------------------------------------
// motion.jog, motion.move_to, mdi
// ---------------------------------------------------------------------------------------------

/// How `motion.jog` reads its axis values (`"velocity"` or `"distance"` on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JogMode {
    /// Continuous jog: each value is a velocity (axis unit/s, signed) held until
    /// `motion.jog_stop`, a changed jog or a soft limit.
    #[default]
    Velocity,
    /// Incremental jog: each value is a distance (axis unit, signed).
    Distance,
}

/// `motion.jog` parameters, e.g. `{"axes": {"X": 20.0}}` or
/// `{"axes": {"X": 0.1}, "mode": "distance"}`. Axis names are checked by the daemon.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JogParams {
    pub axes: std::collections::BTreeMap<String, f64>,
    pub mode: JogMode,
}

/// The members of `motion.jog` before the mode is read.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JogMembers {
    axes: std::collections::BTreeMap<String, f64>,
    mode: Option<String>,
}

/// `motion.move_to` parameters, e.g. `{"target": {"X": 10, "Y": 5}, "velocity_factor": 0.5}`;
/// `velocity` optionally gives target velocities per axis (axis unit/s) for blending into a
/// following command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MoveToParams {
    pub target: std::collections::BTreeMap<String, f64>,
    #[serde(default)]
    pub velocity: std::collections::BTreeMap<String, f64>,
    #[serde(default = "one")]
    pub velocity_factor: f64,
}

fn one() -> f64 {
    1.0
}

/// `mdi` parameters: `{"line": "G1 X10 Y5 F600"}` (one or a few blocks, `\n`-separated).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MdiParams {
    pub line: String,
}

const JOG: Usage = Usage {
    method: Method::MotionJog,
    example: r#"{"axes": {"X": 20.0}} (velocities, unit/s) or {"axes": {"X": 0.1}, "mode": "distance"}"#,
    known: r#""axes" and an optional "mode" ("velocity" or "distance")"#,
    missing: ("axes", r#"missing parameter "axes""#),
};

const MOVE_TO: Usage = Usage {
    method: Method::MotionMoveTo,
    example: r#"{"target": {"X": 10, "Y": 5}, "velocity_factor": 1.0}"#,
    known: r#""target", optional "velocity" (per axis) and "velocity_factor" (0 < f <= 1)"#,
    missing: ("target", r#"missing parameter "target""#),
};

const MDI: Usage = Usage {
    method: Method::Mdi,
    example: r#"{"line": "G1 X10 Y5 F600"}"#,
    known: r#"{"line": "G1 X10 Y5 F600"}"#,
    missing: ("line", r#"missing parameter "line""#),
};

/// Every value of an axis map is finite; `param` names the map.
fn finite_axes(map: &std::collections::BTreeMap<String, f64>, param: &str) -> Result<(), (String, String)> {
    for (axis, v) in map {
        if !v.is_finite() {
            return Err((format!("{param}.{axis}"), format!("\"{param}\".{axis} must be a finite number, got {v}")));
        }
    }
    Ok(())
}

impl JogParams {
    pub fn parse(params: Params) -> Result<JogParams, ErrorObject> {
        let m = JOG.members::<JogMembers>(params)?;
        let mode = match m.mode.as_deref() {
            None | Some("velocity") => JogMode::Velocity,
            Some("distance") => JogMode::Distance,
            Some(other) => {
                return Err(JOG.refuse(
                    Some("mode"),
                    &format!("\"mode\" must be \"velocity\" or \"distance\", got {:?}", excerpt(other, 40)),
                ));
            }
        };
        let p = JogParams { axes: m.axes, mode };
        if p.axes.is_empty() {
            return Err(JOG.refuse(Some("axes"), "\"axes\" names no axis; expected e.g. {\"X\": 20.0}"));
        }
        finite_axes(&p.axes, "axes").map_err(|(param, d)| JOG.refuse(Some(&param), &d))?;
        Ok(p)
    }
}

impl MoveToParams {
    pub fn parse(params: Params) -> Result<MoveToParams, ErrorObject> {
        let p = MOVE_TO.members::<MoveToParams>(params)?;
        if p.target.is_empty() {
            return Err(MOVE_TO.refuse(Some("target"), "\"target\" names no axis; expected e.g. {\"X\": 10}"));
        }
        finite_axes(&p.target, "target").map_err(|(param, d)| MOVE_TO.refuse(Some(&param), &d))?;
        finite_axes(&p.velocity, "velocity").map_err(|(param, d)| MOVE_TO.refuse(Some(&param), &d))?;
        if let Some(axis) = p.velocity.keys().find(|a| !p.target.contains_key(*a)) {
            return Err(MOVE_TO.refuse(
                Some(&format!("velocity.{axis}")),
                &format!("\"velocity\" names axis {axis:?}, which \"target\" does not"),
            ));
        }
        let f = p.velocity_factor;
        if !(f > 0.0 && f <= 1.0) {
            return Err(MOVE_TO.refuse(
                Some("velocity_factor"),
                &format!("\"velocity_factor\" {f} is out of range: it must be above 0 and at most 1"),
            ));
        }
        Ok(p)
    }
}

impl AppendParams {
    pub fn parse(params: Params) -> Result<AppendParams, ErrorObject> {
        let p = APPEND.members::<AppendParams>(params)?;
        if p.text.trim().is_empty() && !p.end {
            return Err(APPEND.refuse(Some("text"), "\"text\" is empty (send \"end\": true to end the program)"));
        }
        Ok(p)
    }
}

impl MdiParams {
    pub fn parse(params: Params) -> Result<MdiParams, ErrorObject> {
        let p = MDI.members::<MdiParams>(params)?;
        if p.line.trim().is_empty() {
            return Err(MDI.refuse(Some("line"), "\"line\" is empty"));
        }
        Ok(p)
    }
}
