//! The control API's messages: JSON-RPC 2.0, one message per line on a Unix socket
//! (DESIGN.md "Control API"; the reference with examples is docs/control-api.md).
//!
//! This module describes and checks messages only. The socket, the threads, the 1 MiB line
//! limit and the calls into the motion core live in the daemon (`interpd::control`).
//!
//! - [`parse_incoming`] turns one received line into requests (or per-request errors), keeping
//!   the JSON-RPC distinctions the server needs: parse error versus invalid request, request
//!   (with an `id`, possibly `null`) versus notification (no `id`, never answered), single
//!   versus batch.
//! - [`Call::parse`] checks a method name and its parameters and names what is wrong.
//! - [`Response`], [`ErrorObject`], [`Notification`] are what the server writes; clients can
//!   deserialize them with the same types.
//! - [`Status`] and [`Event`] are the results of `status` and the payloads of `subscribe`.

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::{Map, Value};
use std::fmt;

/// The only protocol version spoken.
pub const JSONRPC_VERSION: &str = "2.0";

/// Longest accepted line, without its terminating `\n` (and an optional `\r` before it).
/// Longer lines get [`codes::REQUEST_TOO_LARGE`] and the connection is closed.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Method name of the notifications that carry [`Event`]s.
pub const EVENT_METHOD: &str = "event";

/// Largest feed override factor (`feed.override {"factor": ...}`); 0 is allowed (feed stop).
pub const OVERRIDE_MAX: f64 = 2.0;

/// The same bound in percent (`feed.override {"percent": ...}`).
pub const OVERRIDE_MAX_PERCENT: f64 = 200.0;

/// Name given to a program loaded as inline text without a `name`.
pub const INLINE_PROGRAM_NAME: &str = "inline";

/// JSON-RPC error codes. −32768…−32000 are reserved by the specification; the application
/// codes are in −32099…−32000.
pub mod codes {
    /// The line is not valid JSON.
    pub const PARSE_ERROR: i32 = -32700;
    /// Valid JSON but not a JSON-RPC 2.0 request object.
    pub const INVALID_REQUEST: i32 = -32600;
    /// No such method.
    pub const METHOD_NOT_FOUND: i32 = -32601;
    /// The method exists but its parameters are missing, of the wrong type or out of range.
    pub const INVALID_PARAMS: i32 = -32602;
    /// The daemon failed for a reason that is not the client's.
    pub const INTERNAL_ERROR: i32 = -32603;
    /// `program.load`: the program could not be read, parsed or prepared.
    pub const BAD_PROGRAM: i32 = -32001;
    /// The command is not allowed in the current state (`data` holds `state` and `action`).
    pub const NOT_ALLOWED: i32 = -32002;
    /// The line is longer than [`super::MAX_LINE_BYTES`]; the connection is closed after it.
    pub const REQUEST_TOO_LARGE: i32 = -32003;
    /// The server already serves its maximum number of clients; the connection is closed.
    pub const TOO_MANY_CLIENTS: i32 = -32004;
    /// `motion.start`: a CAN drive is not in Operation enabled (the message names the drive).
    pub const DRIVES_NOT_READY: i32 = -32005;
}

// ---------------------------------------------------------------------------------------------
// Envelope
// ---------------------------------------------------------------------------------------------

/// The `"jsonrpc": "2.0"` member: serializes as `"2.0"` and accepts nothing else.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Version;

impl Serialize for Version {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(JSONRPC_VERSION)
    }
}

impl<'de> Deserialize<'de> for Version {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = String::deserialize(d)?;
        if v == JSONRPC_VERSION {
            Ok(Version)
        } else {
            Err(D::Error::custom(format!("\"jsonrpc\" must be \"2.0\", got {v:?}")))
        }
    }
}

/// A request id: a number, a string or `null`, echoed unchanged in the response.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Id {
    /// Kept as a JSON number so that `7`, `-1`, `1.5` and `18446744073709551615` come back
    /// exactly as sent.
    Number(serde_json::Number),
    String(String),
    Null,
}

impl From<u64> for Id {
    fn from(n: u64) -> Id {
        Id::Number(n.into())
    }
}

impl From<&str> for Id {
    fn from(s: &str) -> Id {
        Id::String(s.to_string())
    }
}

/// A request or, without `id`, a notification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Request {
    pub jsonrpc: Version,
    pub method: String,
    /// An object or an array; absent (or `null`, accepted as absent) for none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<Value>,
    /// `None`: a notification, which is executed but never answered. `Some(Id::Null)`: a
    /// request whose id is `null`, which is answered.
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "present")]
    pub id: Option<Id>,
}

/// Tells a member that is present with value `null` (`Some(Id::Null)`) from an absent one
/// (`None`, via `#[serde(default)]`).
fn present<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Id>, D::Error> {
    Id::deserialize(d).map(Some)
}

impl Request {
    /// A request with an id (answered).
    pub fn new(method: &str, params: Option<Value>, id: Id) -> Request {
        Request { jsonrpc: Version, method: method.to_string(), params, id: Some(id) }
    }

    /// A notification (no id, not answered).
    pub fn notification(method: &str, params: Option<Value>) -> Request {
        Request { jsonrpc: Version, method: method.to_string(), params, id: None }
    }

    /// Checks one JSON value against the request object rules. The error carries the id when
    /// it could be read, so the client can match the error to its request, else `null`.
    pub fn from_value(value: Value) -> Result<Request, Invalid> {
        let mut obj = match value {
            Value::Object(obj) => obj,
            other => {
                return Err(Invalid::new(
                    Id::Null,
                    format!(
                        "expected a JSON object with \"jsonrpc\": \"2.0\" and \"method\", got {}",
                        describe(&other)
                    ),
                ));
            }
        };
        // The id first: every later error can then be matched to its request.
        let id = match obj.remove("id") {
            None => None,
            Some(Value::Null) => Some(Id::Null),
            Some(Value::Number(n)) => Some(Id::Number(n)),
            Some(Value::String(s)) => Some(Id::String(s)),
            Some(other) => {
                return Err(Invalid::new(
                    Id::Null,
                    format!("\"id\" must be a number, a string or null, got {}", describe(&other)),
                ));
            }
        };
        let err_id = id.clone().unwrap_or(Id::Null);
        match obj.remove("jsonrpc") {
            Some(Value::String(s)) if s == JSONRPC_VERSION => {}
            Some(other) => {
                return Err(Invalid::new(
                    err_id,
                    format!("\"jsonrpc\" must be \"2.0\", got {}", excerpt(&other.to_string(), 40)),
                ));
            }
            None => return Err(Invalid::new(err_id, "missing \"jsonrpc\": \"2.0\"".to_string())),
        }
        let method = match obj.remove("method") {
            Some(Value::String(m)) => m,
            Some(other) => {
                return Err(Invalid::new(err_id, format!("\"method\" must be a string, got {}", describe(&other))));
            }
            None => {
                return Err(Invalid::new(err_id, "missing \"method\" (a string such as \"status\")".to_string()));
            }
        };
        let params = match obj.remove("params") {
            // `null` is not a structured value, but clients commonly send it for "no params";
            // treating it as absent is harmless and saves them an error.
            None | Some(Value::Null) => None,
            Some(p @ (Value::Object(_) | Value::Array(_))) => Some(p),
            Some(other) => {
                return Err(Invalid::new(
                    err_id,
                    format!("\"params\" must be an object or an array, got {}", describe(&other)),
                ));
            }
        };
        // Other members are ignored: JSON-RPC does not define them and rejecting them would
        // only break clients that add tracing fields.
        Ok(Request { jsonrpc: Version, method, params, id })
    }
}

/// A message that is valid JSON but not a valid request, with the id to answer under.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    pub id: Id,
    pub error: ErrorObject,
}

impl Invalid {
    fn new(id: Id, detail: String) -> Invalid {
        Invalid { id, error: ErrorObject::invalid_request(&detail) }
    }
}

/// One received line, classified.
#[derive(Debug, Clone, PartialEq)]
pub enum Incoming {
    Single(Result<Request, Invalid>),
    /// A non-empty JSON array: each element is handled on its own and the answers to the
    /// requests among them (not the notifications) go back as one array, or nothing at all if
    /// there are none (JSON-RPC 2.0 section 6).
    Batch(Vec<Result<Request, Invalid>>),
}

/// Classifies one line (without its newline). `Err` is a parse error, to be answered with
/// id `null`. An empty batch `[]` is a single invalid request, as the specification says.
pub fn parse_incoming(line: &[u8]) -> Result<Incoming, ErrorObject> {
    let value: Value = serde_json::from_slice(line).map_err(|e| ErrorObject::parse_error(&e.to_string()))?;
    Ok(match value {
        Value::Array(items) if items.is_empty() => Incoming::Single(Err(Invalid::new(
            Id::Null,
            "an empty batch: send at least one request in the array".to_string(),
        ))),
        Value::Array(items) => Incoming::Batch(items.into_iter().map(Request::from_value).collect()),
        other => Incoming::Single(Request::from_value(other)),
    })
}

/// A response: exactly one of `result` or `error`, and the request's id.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Response {
    pub jsonrpc: Version,
    #[serde(flatten)]
    pub outcome: Outcome,
    pub id: Id,
}

/// The `result` or `error` member of a [`Response`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    Result(Value),
    Error(ErrorObject),
}

impl Response {
    pub fn result(id: Id, result: Value) -> Response {
        Response { jsonrpc: Version, outcome: Outcome::Result(result), id }
    }

    pub fn error(id: Id, error: ErrorObject) -> Response {
        Response { jsonrpc: Version, outcome: Outcome::Error(error), id }
    }

    /// The result, or the error object as an `Err`.
    pub fn into_result(self) -> Result<Value, ErrorObject> {
        match self.outcome {
            Outcome::Result(v) => Ok(v),
            Outcome::Error(e) => Err(e),
        }
    }
}

/// A JSON-RPC error object. `message` says what was wrong and what to do about it; `data`
/// holds machine-readable details where there are any (the offending parameter or method,
/// the state a command was refused in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("{message} (JSON-RPC error {code})")]
pub struct ErrorObject {
    pub code: i32,
    pub message: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<Value>,
}

impl ErrorObject {
    pub fn new(code: i32, message: impl Into<String>) -> ErrorObject {
        ErrorObject { code, message: message.into(), data: None }
    }

    pub fn with_data(mut self, data: Value) -> ErrorObject {
        self.data = Some(data);
        self
    }

    /// −32700; `detail` is serde_json's description with line and column.
    pub fn parse_error(detail: &str) -> ErrorObject {
        ErrorObject::new(
            codes::PARSE_ERROR,
            format!("parse error: {detail}; send one JSON-RPC request object per line"),
        )
    }

    /// −32600.
    pub fn invalid_request(detail: &str) -> ErrorObject {
        ErrorObject::new(codes::INVALID_REQUEST, format!("invalid request: {detail}"))
    }

    /// −32601, naming the method and listing the valid ones (also in `data`).
    pub fn method_not_found(method: &str) -> ErrorObject {
        let valid: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        ErrorObject::new(
            codes::METHOD_NOT_FOUND,
            format!("unknown method {:?}; valid methods: {}", excerpt(method, 64), valid.join(", ")),
        )
        .with_data(serde_json::json!({ "method": excerpt(method, 64), "valid": valid }))
    }

    /// −32602 for `method`; `param` (if any) is the parameter at fault, also in `data`.
    pub fn invalid_params(method: Method, param: Option<&str>, detail: &str) -> ErrorObject {
        let e = ErrorObject::new(codes::INVALID_PARAMS, format!("invalid params for {}: {detail}", method.name()));
        match param {
            Some(p) => e.with_data(serde_json::json!({ "method": method.name(), "param": p })),
            None => e.with_data(serde_json::json!({ "method": method.name() })),
        }
    }

    /// −32603.
    pub fn internal(detail: &str) -> ErrorObject {
        ErrorObject::new(codes::INTERNAL_ERROR, format!("internal error: {detail}"))
    }

    /// −32003 for a line longer than `limit` bytes.
    pub fn request_too_large(limit: usize) -> ErrorObject {
        ErrorObject::new(
            codes::REQUEST_TOO_LARGE,
            format!(
                "request too large: a line may hold at most {limit} bytes; the connection is closed \
                 (load big programs with {{\"path\": ...}} instead of inline text)"
            ),
        )
        .with_data(serde_json::json!({ "limit": limit }))
    }

    /// −32004 for a client beyond the server's limit.
    pub fn too_many_clients(max: usize) -> ErrorObject {
        ErrorObject::new(
            codes::TOO_MANY_CLIENTS,
            format!(
                "too many clients: this interpd serves at most {max} connections at a time; \
                 close another connection and retry"
            ),
        )
        .with_data(serde_json::json!({ "max_clients": max }))
    }
}

/// A message without id in the server-to-client direction (events).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Notification<P = Value> {
    pub jsonrpc: Version,
    pub method: String,
    pub params: P,
}

// ---------------------------------------------------------------------------------------------
// Methods and parameters
// ---------------------------------------------------------------------------------------------

/// The methods of the control API.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    ProgramLoad,
    MotionStart,
    MotionHold,
    MotionResume,
    MotionStop,
    FeedOverride,
    Status,
    Subscribe,
}

impl Method {
    pub const ALL: [Method; 8] = [
        Method::ProgramLoad,
        Method::MotionStart,
        Method::MotionHold,
        Method::MotionResume,
        Method::MotionStop,
        Method::FeedOverride,
        Method::Status,
        Method::Subscribe,
    ];

    /// The wire name, e.g. `"motion.start"`.
    pub const fn name(self) -> &'static str {
        match self {
            Method::ProgramLoad => "program.load",
            Method::MotionStart => "motion.start",
            Method::MotionHold => "motion.hold",
            Method::MotionResume => "motion.resume",
            Method::MotionStop => "motion.stop",
            Method::FeedOverride => "feed.override",
            Method::Status => "status",
            Method::Subscribe => "subscribe",
        }
    }

    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A checked method call.
#[derive(Debug, Clone, PartialEq)]
pub enum Call {
    ProgramLoad(LoadParams),
    MotionStart,
    MotionHold,
    MotionResume,
    MotionStop,
    FeedOverride(OverrideParams),
    Status,
    Subscribe,
}

impl Call {
    /// Checks the method name and its parameters: −32601 for an unknown method, −32602 naming
    /// the parameter for missing, unknown, mistyped or out-of-range parameters.
    pub fn parse(method: &str, params: Option<Value>) -> Result<Call, ErrorObject> {
        let m = Method::from_name(method).ok_or_else(|| ErrorObject::method_not_found(method))?;
        Ok(match m {
            Method::ProgramLoad => Call::ProgramLoad(LoadParams::from_params(params)?),
            Method::FeedOverride => Call::FeedOverride(OverrideParams::from_params(params)?),
            Method::MotionStart => no_params(m, params).map(|()| Call::MotionStart)?,
            Method::MotionHold => no_params(m, params).map(|()| Call::MotionHold)?,
            Method::MotionResume => no_params(m, params).map(|()| Call::MotionResume)?,
            Method::MotionStop => no_params(m, params).map(|()| Call::MotionStop)?,
            Method::Status => no_params(m, params).map(|()| Call::Status)?,
            Method::Subscribe => no_params(m, params).map(|()| Call::Subscribe)?,
        })
    }

    pub fn method(&self) -> Method {
        match self {
            Call::ProgramLoad(_) => Method::ProgramLoad,
            Call::MotionStart => Method::MotionStart,
            Call::MotionHold => Method::MotionHold,
            Call::MotionResume => Method::MotionResume,
            Call::MotionStop => Method::MotionStop,
            Call::FeedOverride(_) => Method::FeedOverride,
            Call::Status => Method::Status,
            Call::Subscribe => Method::Subscribe,
        }
    }
}

/// Methods without parameters accept none, `{}` or `[]`; anything else is probably a client
/// expecting a feature that does not exist, so it is refused rather than ignored.
fn no_params(method: Method, params: Option<Value>) -> Result<(), ErrorObject> {
    match params {
        None => Ok(()),
        Some(Value::Object(m)) if m.is_empty() => Ok(()),
        Some(Value::Array(a)) if a.is_empty() => Ok(()),
        Some(Value::Object(m)) => {
            let key = m.keys().next().map(String::as_str).unwrap_or_default();
            Err(ErrorObject::invalid_params(
                method,
                Some(key),
                &format!("{method} takes no parameters, got {:?}", excerpt(key, 40)),
            ))
        }
        Some(_) => Err(ErrorObject::invalid_params(method, None, &format!("{method} takes no parameters"))),
    }
}

/// Named parameters as a map; `None` if there are none. Positional (array) parameters are
/// refused with the expected form, since each of these methods has optional or alternative
/// members that a position cannot express.
fn named(method: Method, params: Option<Value>, usage: &str) -> Result<Option<Map<String, Value>>, ErrorObject> {
    match params {
        None => Ok(None),
        Some(Value::Object(m)) if m.is_empty() => Ok(None),
        Some(Value::Object(m)) => Ok(Some(m)),
        Some(Value::Array(a)) if a.is_empty() => Ok(None),
        Some(other) => Err(ErrorObject::invalid_params(
            method,
            None,
            &format!("{method} takes named parameters (an object) such as {usage}, got {}", describe(&other)),
        )),
    }
}

/// `program.load` parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum LoadParams {
    /// A program file, read by the daemon: relative paths are relative to the daemon's working
    /// directory, so clients should send absolute paths.
    Path { path: String },
    /// Program text sent inline (up to the line limit, less the envelope).
    Text {
        text: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
    },
}

const LOAD_USAGE: &str = r#"{"path": "/abs/part.ngc"} or {"text": "G1 X10 F600\n", "name": "part"}"#;

impl LoadParams {
    pub fn from_params(params: Option<Value>) -> Result<LoadParams, ErrorObject> {
        let m = Method::ProgramLoad;
        let Some(map) = named(m, params, LOAD_USAGE)? else {
            return Err(ErrorObject::invalid_params(
                m,
                Some("path"),
                &format!("missing parameter \"path\" or \"text\"; expected {LOAD_USAGE}"),
            ));
        };
        let (mut path, mut text, mut name) = (None, None, None);
        for (key, value) in map {
            let slot = match key.as_str() {
                "path" => &mut path,
                "text" => &mut text,
                "name" => &mut name,
                other => {
                    return Err(ErrorObject::invalid_params(
                        m,
                        Some(other),
                        &format!(
                            "unknown parameter {:?}; expected \"path\", or \"text\" with an optional \"name\"",
                            excerpt(other, 40)
                        ),
                    ));
                }
            };
            *slot = Some(string_param(m, &key, value)?);
        }
        match (path, text, name) {
            (Some(_), Some(_), _) => {
                Err(ErrorObject::invalid_params(m, Some("text"), "give either \"path\" or \"text\", not both"))
            }
            (Some(_), None, Some(_)) => Err(ErrorObject::invalid_params(
                m,
                Some("name"),
                "\"name\" goes with \"text\"; a program loaded from \"path\" is named by its path",
            )),
            (Some(p), None, None) if p.is_empty() => {
                Err(ErrorObject::invalid_params(m, Some("path"), "parameter \"path\" is empty"))
            }
            (Some(path), None, None) => Ok(LoadParams::Path { path }),
            (None, Some(text), name) => Ok(LoadParams::Text { text, name }),
            (None, None, _) => Err(ErrorObject::invalid_params(
                m,
                Some("path"),
                &format!("missing parameter \"path\" or \"text\"; expected {LOAD_USAGE}"),
            )),
        }
    }
}

impl<'de> Deserialize<'de> for LoadParams {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        LoadParams::from_params(Some(v)).map_err(|e| D::Error::custom(e.message))
    }
}

/// `feed.override` parameters: the factor applied to the programmed feed, 0.0..=2.0. On the
/// wire either `{"factor": 0.8}` or `{"percent": 80}`; it always serializes as `factor`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OverrideParams {
    pub factor: f64,
}

const OVERRIDE_USAGE: &str = r#"{"factor": 0.8} (0.0 to 2.0) or {"percent": 80} (0 to 200)"#;

impl OverrideParams {
    pub fn from_params(params: Option<Value>) -> Result<OverrideParams, ErrorObject> {
        let m = Method::FeedOverride;
        let Some(map) = named(m, params, OVERRIDE_USAGE)? else {
            return Err(ErrorObject::invalid_params(
                m,
                Some("factor"),
                &format!("missing parameter \"factor\"; expected {OVERRIDE_USAGE}"),
            ));
        };
        let (mut factor, mut percent) = (None, None);
        for (key, value) in map {
            match key.as_str() {
                "factor" => factor = Some(number_param(m, "factor", &value)?),
                "percent" => percent = Some(number_param(m, "percent", &value)?),
                other => {
                    return Err(ErrorObject::invalid_params(
                        m,
                        Some(other),
                        &format!("unknown parameter {:?}; expected {OVERRIDE_USAGE}", excerpt(other, 40)),
                    ));
                }
            }
        }
        match (factor, percent) {
            (Some(_), Some(_)) => {
                Err(ErrorObject::invalid_params(m, Some("percent"), "give either \"factor\" or \"percent\", not both"))
            }
            (Some(f), None) if (0.0..=OVERRIDE_MAX).contains(&f) => Ok(OverrideParams { factor: f }),
            (Some(f), None) => Err(ErrorObject::invalid_params(
                m,
                Some("factor"),
                &format!("\"factor\" {f} is out of range 0.0 to {OVERRIDE_MAX:.1}"),
            )),
            (None, Some(p)) if (0.0..=OVERRIDE_MAX_PERCENT).contains(&p) => Ok(OverrideParams { factor: p / 100.0 }),
            (None, Some(p)) => Err(ErrorObject::invalid_params(
                m,
                Some("percent"),
                &format!("\"percent\" {p} is out of range 0 to {OVERRIDE_MAX_PERCENT}"),
            )),
            (None, None) => unreachable_empty(m),
        }
    }
}

/// `named` returns `None` for an empty map, so a present map has at least one key and every
/// key either fills a slot or is refused; kept as an error rather than a panic all the same.
fn unreachable_empty<T>(m: Method) -> Result<T, ErrorObject> {
    Err(ErrorObject::invalid_params(m, None, "no parameters given"))
}

impl<'de> Deserialize<'de> for OverrideParams {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        OverrideParams::from_params(Some(v)).map_err(|e| D::Error::custom(e.message))
    }
}

fn string_param(method: Method, key: &str, value: Value) -> Result<String, ErrorObject> {
    match value {
        Value::String(s) => Ok(s),
        other => Err(ErrorObject::invalid_params(
            method,
            Some(key),
            &format!("parameter {key:?} must be a string, got {}", describe(&other)),
        )),
    }
}

fn number_param(method: Method, key: &str, value: &Value) -> Result<f64, ErrorObject> {
    match value.as_f64() {
        Some(x) if value.is_number() => Ok(x),
        _ => Err(ErrorObject::invalid_params(
            method,
            Some(key),
            &format!("parameter {key:?} must be a number, got {}", describe(value)),
        )),
    }
}

/// Result of `motion.start`, `motion.hold`, `motion.resume` and `motion.stop`: the command was
/// accepted (the motion itself proceeds in the background; watch `status` or the events).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ack {
    pub ok: bool,
}

impl Default for Ack {
    fn default() -> Ack {
        Ack { ok: true }
    }
}

/// Result of `feed.override`: the factor now in effect (targeted; the change itself is
/// jerk-limited).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OverrideResult {
    #[serde(rename = "override")]
    pub factor: f64,
}

/// Result of `subscribe`: the connection now also carries event notifications.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Subscribed {
    pub subscribed: bool,
    /// The event names that may follow ([`Event::NAMES`]).
    pub events: Vec<String>,
}

impl Default for Subscribed {
    fn default() -> Subscribed {
        Subscribed { subscribed: true, events: Event::NAMES.iter().map(|s| s.to_string()).collect() }
    }
}

// ---------------------------------------------------------------------------------------------
// Status and events
// ---------------------------------------------------------------------------------------------

/// The machine state as `status` reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// No motion; a program may or may not be loaded.
    #[default]
    Idle,
    Running,
    /// Feed hold active or being approached (the path velocity is brought to zero on the path).
    Holding,
    /// A stop is being executed; the state becomes `idle` when the machine stands.
    Stopping,
    /// The program ran to its end.
    Finished,
    /// Motion was aborted by an error (see `last_error`).
    Error,
}

impl State {
    pub const ALL: [State; 6] =
        [State::Idle, State::Running, State::Holding, State::Stopping, State::Finished, State::Error];

    pub const fn as_str(self) -> &'static str {
        match self {
            State::Idle => "idle",
            State::Running => "running",
            State::Holding => "holding",
            State::Stopping => "stopping",
            State::Finished => "finished",
            State::Error => "error",
        }
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Percentiles of a per-cycle measurement, microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Percentiles {
    pub p50: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
}

/// Statistics of the interpolation cycles since motion started.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct CycleStats {
    /// Wake-up latency: actual wake-up time minus the cycle's deadline.
    pub wakeup_us: Percentiles,
    /// Time spent computing one cycle.
    pub compute_us: Percentiles,
    /// Cycles whose computation ran past the next deadline.
    pub overruns: u64,
    /// Cycles that started late (woke after their deadline by more than the allowed slack).
    pub late: u64,
}

/// The loaded program.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct ProgramInfo {
    /// The path it was loaded from, or the `name` given with inline text.
    pub name: String,
    /// Geometry elements (lines, arcs, spline spans, table rows).
    pub elements: u64,
    /// Path length, mm.
    pub length_mm: f64,
    /// Source lines.
    pub lines: u32,
}

/// The result of `status`.
///
/// Missing members deserialize to their defaults so that clients keep working when the daemon
/// adds members, and a daemon's newer members are ignored by older clients.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Status {
    pub state: State,
    /// Program line being executed (1-based, 0 if none).
    pub line: u32,
    /// Path position, mm.
    pub s_mm: f64,
    /// Current path velocity, mm/s (after the override).
    pub feed_mm_s: f64,
    /// Feed override factor in effect, 0.0..=2.0.
    #[serde(rename = "override")]
    pub feed_override: f64,
    /// Fill of the planner-to-interpolator profile queue, 0..=1.
    pub queue_fill: f64,
    /// Seconds of motion planned ahead in the queue.
    pub queue_s: f64,
    /// Interpolation cycle number (0 when motion starts).
    pub cycle: u64,
    pub cycles: CycleStats,
    pub last_error: Option<String>,
    pub program: Option<ProgramInfo>,
    /// Axis names in configuration order.
    pub axes: Vec<String>,
    /// Commanded position per axis, in the order of `axes` (mm or deg).
    pub position: Vec<f64>,
    /// CAN drives, one object per axis when the CAN sink runs (empty otherwise): `axis`,
    /// `node`, `state` (CiA 402 state name), `statusword`, `nmt`, `position_actual`,
    /// `last_heartbeat_ms_ago`, `emcy_count`, `last_emcy_code` and more.
    pub drives: Vec<Value>,
    /// CAN bus counters of the master (frames sent and received, malformed frames by kind,
    /// send failures by errno class, error frames, candump log records); absent without CAN.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub can_bus: Option<Value>,
}

impl Default for Status {
    fn default() -> Status {
        Status {
            state: State::Idle,
            line: 0,
            s_mm: 0.0,
            feed_mm_s: 0.0,
            feed_override: 1.0,
            queue_fill: 0.0,
            queue_s: 0.0,
            cycle: 0,
            cycles: CycleStats::default(),
            last_error: None,
            program: None,
            axes: Vec::new(),
            position: Vec::new(),
            drives: Vec::new(),
            can_bus: None,
        }
    }
}

/// What a `subscribe`d connection receives, each as
/// `{"jsonrpc":"2.0","method":"event","params":{"event":"line_reached","line":12}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// Motion started (`motion.start` accepted and the first cycle ran).
    Started,
    /// Execution reached a new program line.
    LineReached { line: u32 },
    /// The profile queue ran dry at path position `s_mm`: the path velocity is being brought to
    /// zero along the path until the planner catches up.
    Underrun { s_mm: f64 },
    /// The planner caught up after an underrun; motion continues.
    UnderrunCleared,
    /// A feed hold has brought the machine to rest.
    Held,
    /// Motion resumed after a hold.
    Resumed,
    /// A stop has completed; the machine stands.
    Stopped,
    /// The program ran to its end after `duration_s` seconds of motion.
    Finished { duration_s: f64 },
    /// Motion was aborted; `message` says why.
    Error { message: String },
}

impl Event {
    /// The `event` tag of every variant, in declaration order.
    pub const NAMES: [&'static str; 9] =
        ["started", "line_reached", "underrun", "underrun_cleared", "held", "resumed", "stopped", "finished", "error"];

    pub fn name(&self) -> &'static str {
        match self {
            Event::Started => "started",
            Event::LineReached { .. } => "line_reached",
            Event::Underrun { .. } => "underrun",
            Event::UnderrunCleared => "underrun_cleared",
            Event::Held => "held",
            Event::Resumed => "resumed",
            Event::Stopped => "stopped",
            Event::Finished { .. } => "finished",
            Event::Error { .. } => "error",
        }
    }

    /// The notification that carries this event.
    pub fn to_notification(&self) -> Notification<&Event> {
        Notification { jsonrpc: Version, method: EVENT_METHOD.to_string(), params: self }
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers for messages
// ---------------------------------------------------------------------------------------------

/// "a string", "an object", … for error messages.
fn describe(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// At most `max` characters of `s`, so that echoing client input keeps messages short.
fn excerpt(s: &str, max: usize) -> String {
    match s.char_indices().nth(max) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn single(line: &str) -> Result<Request, Invalid> {
        match parse_incoming(line.as_bytes()) {
            Ok(Incoming::Single(r)) => r,
            other => panic!("expected a single message, got {other:?}"),
        }
    }

    #[test]
    fn request_ids_and_notifications() {
        let r = single(r#"{"jsonrpc":"2.0","method":"status","id":7}"#).expect("valid");
        assert_eq!(r.id, Some(Id::from(7)));
        let r = single(r#"{"jsonrpc":"2.0","method":"status","id":null}"#).expect("valid");
        assert_eq!(r.id, Some(Id::Null));
        let r = single(r#"{"jsonrpc":"2.0","method":"status"}"#).expect("valid");
        assert_eq!(r.id, None);
        let r = single(r#"{"jsonrpc":"2.0","method":"status","id":"a"}"#).expect("valid");
        assert_eq!(r.id, Some(Id::from("a")));
        let r = single(r#"{"jsonrpc":"2.0","method":"status","id":18446744073709551615}"#).expect("valid");
        assert_eq!(serde_json::to_string(&r.id).expect("ser"), "18446744073709551615");
        let r = single(r#"{"jsonrpc":"2.0","method":"status","id":-1.5}"#).expect("valid");
        assert_eq!(serde_json::to_string(&r.id).expect("ser"), "-1.5");
    }

    #[test]
    fn serde_request_matches_manual_checks() {
        // The derived Deserialize (for clients) agrees with from_value on ids.
        let r: Request = serde_json::from_str(r#"{"jsonrpc":"2.0","method":"x","id":null}"#).expect("de");
        assert_eq!(r.id, Some(Id::Null));
        let r: Request = serde_json::from_str(r#"{"jsonrpc":"2.0","method":"x"}"#).expect("de");
        assert_eq!(r.id, None);
        assert!(serde_json::from_str::<Request>(r#"{"jsonrpc":"1.0","method":"x"}"#).is_err());
        let s = serde_json::to_string(&Request::notification("status", None)).expect("ser");
        assert_eq!(s, r#"{"jsonrpc":"2.0","method":"status"}"#);
    }

    #[test]
    fn invalid_requests() {
        let cases = [
            (r#"1"#, "got a number"),
            (r#"{"method":"status","id":1}"#, "missing \"jsonrpc\""),
            (r#"{"jsonrpc":"1.0","method":"status","id":1}"#, "must be \"2.0\""),
            (r#"{"jsonrpc":2.0,"method":"status","id":1}"#, "must be \"2.0\""),
            (r#"{"jsonrpc":"2.0","id":1}"#, "missing \"method\""),
            (r#"{"jsonrpc":"2.0","method":5,"id":1}"#, "\"method\" must be a string"),
            (r#"{"jsonrpc":"2.0","method":"status","params":"x","id":1}"#, "\"params\" must be"),
            (r#"{"jsonrpc":"2.0","method":"status","id":{}}"#, "\"id\" must be"),
            (r#"{"jsonrpc":"2.0","method":"status","id":true}"#, "\"id\" must be"),
        ];
        for (line, needle) in cases {
            let e = single(line).expect_err(line);
            assert_eq!(e.error.code, codes::INVALID_REQUEST, "{line}");
            assert!(e.error.message.contains(needle), "{line}: {}", e.error.message);
        }
        // A readable id is echoed; an unreadable one becomes null.
        assert_eq!(single(r#"{"jsonrpc":"1.0","method":"status","id":3}"#).expect_err("bad").id, Id::from(3));
        assert_eq!(single(r#"{"jsonrpc":"2.0","method":"status","id":[1]}"#).expect_err("bad").id, Id::Null);
    }

    #[test]
    fn parse_errors_and_batches() {
        let e = parse_incoming(b"{\"jsonrpc\":").expect_err("truncated");
        assert_eq!(e.code, codes::PARSE_ERROR);
        assert!(e.message.contains("line 1"), "{}", e.message);
        assert_eq!(parse_incoming(b"\xff\xfe").expect_err("binary").code, codes::PARSE_ERROR);
        let deep = "[".repeat(10_000);
        assert_eq!(parse_incoming(deep.as_bytes()).expect_err("deep").code, codes::PARSE_ERROR);
        match parse_incoming(b"[]").expect("json") {
            Incoming::Single(Err(inv)) => assert_eq!(inv.error.code, codes::INVALID_REQUEST),
            other => panic!("{other:?}"),
        }
        match parse_incoming(br#"[1, {"jsonrpc":"2.0","method":"status","id":1}]"#).expect("json") {
            Incoming::Batch(items) => {
                assert_eq!(items.len(), 2);
                assert!(items[0].is_err());
                assert!(items[1].is_ok());
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn methods_and_params() {
        assert_eq!(Call::parse("status", None), Ok(Call::Status));
        assert_eq!(Call::parse("motion.start", Some(json!({}))), Ok(Call::MotionStart));
        assert_eq!(Call::parse("motion.stop", Some(json!([]))), Ok(Call::MotionStop));
        let e = Call::parse("motion.begin", None).expect_err("unknown");
        assert_eq!(e.code, codes::METHOD_NOT_FOUND);
        assert!(e.message.contains("\"motion.begin\"") && e.message.contains("motion.start"), "{}", e.message);
        let e = Call::parse("motion.start", Some(json!({"now": true}))).expect_err("extra");
        assert_eq!(e.code, codes::INVALID_PARAMS);
        assert!(e.message.contains("\"now\""), "{}", e.message);

        assert_eq!(
            Call::parse("program.load", Some(json!({"path": "/a.ngc"}))),
            Ok(Call::ProgramLoad(LoadParams::Path { path: "/a.ngc".into() }))
        );
        assert_eq!(
            Call::parse("program.load", Some(json!({"text": "G1 X1", "name": "p"}))),
            Ok(Call::ProgramLoad(LoadParams::Text { text: "G1 X1".into(), name: Some("p".into()) }))
        );
        for (params, param) in [
            (None, "path"),
            (Some(json!({"path": 3})), "path"),
            (Some(json!({"text": ["G1"]})), "text"),
            (Some(json!({"text": "G1", "name": 1})), "name"),
            (Some(json!({"path": "/a", "text": "G1"})), "text"),
            (Some(json!({"path": "/a", "name": "n"})), "name"),
            (Some(json!({"path": ""})), "path"),
            (Some(json!({"file": "/a"})), "file"),
        ] {
            let e = Call::parse("program.load", params.clone()).expect_err("bad load");
            assert_eq!(e.code, codes::INVALID_PARAMS, "{params:?}");
            assert_eq!(e.data.as_ref().and_then(|d| d["param"].as_str()), Some(param), "{params:?}: {e:?}");
        }
        let e = Call::parse("program.load", Some(json!(["/a"]))).expect_err("positional");
        assert!(e.message.contains("named parameters"), "{}", e.message);

        assert_eq!(
            Call::parse("feed.override", Some(json!({"factor": 0.5}))),
            Ok(Call::FeedOverride(OverrideParams { factor: 0.5 }))
        );
        assert_eq!(
            Call::parse("feed.override", Some(json!({"percent": 150}))),
            Ok(Call::FeedOverride(OverrideParams { factor: 1.5 }))
        );
        assert_eq!(
            Call::parse("feed.override", Some(json!({"factor": 0}))),
            Ok(Call::FeedOverride(OverrideParams { factor: 0.0 }))
        );
        assert_eq!(
            Call::parse("feed.override", Some(json!({"factor": 2}))),
            Ok(Call::FeedOverride(OverrideParams { factor: 2.0 }))
        );
        for (params, param) in [
            (json!({"factor": 2.01}), "factor"),
            (json!({"factor": -0.1}), "factor"),
            (json!({"factor": "0.5"}), "factor"),
            (json!({"percent": 201}), "percent"),
            (json!({"percent": null}), "percent"),
            (json!({"factor": 1, "percent": 100}), "percent"),
            (json!({"facter": 1}), "facter"),
            (json!({}), "factor"),
        ] {
            let e = Call::parse("feed.override", Some(params.clone())).expect_err("bad override");
            assert_eq!(e.code, codes::INVALID_PARAMS, "{params}");
            assert_eq!(e.data.as_ref().and_then(|d| d["param"].as_str()), Some(param), "{params}: {e:?}");
        }
    }

    #[test]
    fn response_shapes() {
        let r = Response::result(Id::from(1), json!({"ok": true}));
        assert_eq!(serde_json::to_string(&r).expect("ser"), r#"{"jsonrpc":"2.0","result":{"ok":true},"id":1}"#);
        let r = Response::result(Id::Null, Value::Null);
        assert_eq!(serde_json::to_string(&r).expect("ser"), r#"{"jsonrpc":"2.0","result":null,"id":null}"#);
        let r = Response::error(Id::from("x"), ErrorObject::new(codes::NOT_ALLOWED, "no"));
        let s = serde_json::to_string(&r).expect("ser");
        assert_eq!(s, r#"{"jsonrpc":"2.0","error":{"code":-32002,"message":"no"},"id":"x"}"#);
        let back: Response = serde_json::from_str(&s).expect("de");
        assert_eq!(back, r);
        let back: Response = serde_json::from_str(r#"{"jsonrpc":"2.0","result":[1],"id":-4}"#).expect("de");
        assert_eq!(back.into_result(), Ok(json!([1])));
    }

    #[test]
    fn status_and_events_on_the_wire() {
        let st = Status { axes: vec!["X".into(), "Y".into()], position: vec![1.0, 2.0], ..Status::default() };
        let v = serde_json::to_value(&st).expect("ser");
        for key in [
            "state",
            "line",
            "s_mm",
            "feed_mm_s",
            "override",
            "queue_fill",
            "queue_s",
            "cycle",
            "cycles",
            "last_error",
            "program",
            "axes",
            "position",
            "drives",
        ] {
            assert!(v.get(key).is_some(), "status lacks {key}: {v}");
        }
        assert_eq!(v["state"], "idle");
        assert_eq!(v["override"], 1.0);
        assert_eq!(v["last_error"], Value::Null);
        assert_eq!(v["cycles"]["wakeup_us"]["p999"], 0.0);
        assert_eq!(serde_json::from_value::<Status>(v).expect("de"), st);
        // A newer daemon's extra members and an older one's missing members both parse.
        let st: Status = serde_json::from_str(r#"{"state":"holding","future":1}"#).expect("de");
        assert_eq!(st.state, State::Holding);
        for s in State::ALL {
            assert_eq!(serde_json::to_value(s).expect("ser"), s.as_str());
        }

        let ev = Event::LineReached { line: 12 };
        assert_eq!(
            serde_json::to_string(&ev.to_notification()).expect("ser"),
            r#"{"jsonrpc":"2.0","method":"event","params":{"event":"line_reached","line":12}}"#
        );
        let all = [
            Event::Started,
            Event::LineReached { line: 1 },
            Event::Underrun { s_mm: 2.5 },
            Event::UnderrunCleared,
            Event::Held,
            Event::Resumed,
            Event::Stopped,
            Event::Finished { duration_s: 3.0 },
            Event::Error { message: "boom".into() },
        ];
        for (ev, name) in all.iter().zip(Event::NAMES) {
            let v = serde_json::to_value(ev).expect("ser");
            assert_eq!(v["event"], name);
            assert_eq!(ev.name(), name);
            assert_eq!(&serde_json::from_value::<Event>(v).expect("de"), ev);
        }
        let n: Notification<Event> =
            serde_json::from_str(r#"{"jsonrpc":"2.0","method":"event","params":{"event":"held"}}"#).expect("de");
        assert_eq!(n.params, Event::Held);
    }

    #[test]
    fn excerpts_respect_char_boundaries() {
        assert_eq!(excerpt("äöü", 2), "äö…");
        assert_eq!(excerpt("ab", 2), "ab");
        let e = ErrorObject::method_not_found(&"ü".repeat(1000));
        assert!(e.message.len() < 400, "{}", e.message.len());
    }
}
