//! JSON-RPC 2.0 over a line-oriented stream: one message per line. Generic: nothing here knows
//! interpd's methods (those are in [`crate::api`]); the reference with examples is
//! docs/control-api.md.
//!
//! - [`parse_incoming`] turns one received line into requests (or per-request errors), keeping
//!   the distinctions a server needs: parse error versus invalid request, request (with an
//!   `id`, possibly `null`) versus notification (no `id`, never answered), single versus batch.
//! - [`params`] deserializes a request's named parameters with serde, and names the member at
//!   fault when they do not fit.
//! - [`Response`], [`ErrorObject`], [`Notification`] are what a server writes; clients can
//!   deserialize them with the same types.
//!
//! This module describes and checks messages only. The socket, the threads and the line limit's
//! enforcement live in the daemon (`interpd::control`).

pub mod params;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::Value;

/// The only protocol version spoken.
pub const JSONRPC_VERSION: &str = "2.0";

/// Longest accepted line, without its terminating `\n` (and an optional `\r` before it).
/// Longer lines get [`codes::REQUEST_TOO_LARGE`] and the connection is closed.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Error codes of the specification and of the transport. −32768…−32000 are reserved by the
/// specification; servers define theirs in −32099…−32000 (interpd's are in
/// [`crate::api::codes`], which re-exports these).
pub mod codes {
    /// The line is not valid JSON.
    pub const PARSE_ERROR: i32 = -32700;
    /// Valid JSON but not a JSON-RPC 2.0 request object.
    pub const INVALID_REQUEST: i32 = -32600;
    /// No such method.
    pub const METHOD_NOT_FOUND: i32 = -32601;
    /// The method exists but its parameters are missing, of the wrong type or out of range.
    pub const INVALID_PARAMS: i32 = -32602;
    /// The server failed for a reason that is not the client's.
    pub const INTERNAL_ERROR: i32 = -32603;
    /// The line is longer than [`super::MAX_LINE_BYTES`]; the connection is closed after it.
    pub const REQUEST_TOO_LARGE: i32 = -32003;
    /// The server already serves its maximum number of clients; the connection is closed.
    pub const TOO_MANY_CLIENTS: i32 = -32004;
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
    ///
    /// Hand-written rather than derived: the derived `Deserialize` (for clients) would lose the
    /// id of an invalid request and name no member in its message.
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

    /// −32601, naming the method and listing the `valid` ones (also in `data`).
    pub fn method_not_found(method: &str, valid: &[&str]) -> ErrorObject {
        ErrorObject::new(
            codes::METHOD_NOT_FOUND,
            format!("unknown method {:?}; valid methods: {}", excerpt(method, 64), valid.join(", ")),
        )
        .with_data(serde_json::json!({ "method": excerpt(method, 64), "valid": valid }))
    }

    /// −32602 for `method`; `param` (if any) is the parameter at fault, also in `data`.
    pub fn invalid_params(method: &str, param: Option<&str>, detail: &str) -> ErrorObject {
        let e = ErrorObject::new(codes::INVALID_PARAMS, format!("invalid params for {method}: {detail}"));
        match param {
            Some(p) => e.with_data(serde_json::json!({ "method": method, "param": p })),
            None => e.with_data(serde_json::json!({ "method": method })),
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

impl<P> Notification<P> {
    pub fn new(method: &str, params: P) -> Notification<P> {
        Notification { jsonrpc: Version, method: method.to_string(), params }
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers for messages
// ---------------------------------------------------------------------------------------------

/// "a string", "an object", … for error messages.
pub fn describe(v: &Value) -> &'static str {
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
pub fn excerpt(s: &str, max: usize) -> String {
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
    fn response_shapes() {
        let r = Response::result(Id::from(1), json!({"ok": true}));
        assert_eq!(serde_json::to_string(&r).expect("ser"), r#"{"jsonrpc":"2.0","result":{"ok":true},"id":1}"#);
        let r = Response::result(Id::Null, Value::Null);
        assert_eq!(serde_json::to_string(&r).expect("ser"), r#"{"jsonrpc":"2.0","result":null,"id":null}"#);
        let r = Response::error(Id::from("x"), ErrorObject::new(-32002, "no"));
        let s = serde_json::to_string(&r).expect("ser");
        assert_eq!(s, r#"{"jsonrpc":"2.0","error":{"code":-32002,"message":"no"},"id":"x"}"#);
        let back: Response = serde_json::from_str(&s).expect("de");
        assert_eq!(back, r);
        let back: Response = serde_json::from_str(r#"{"jsonrpc":"2.0","result":[1],"id":-4}"#).expect("de");
        assert_eq!(back.into_result(), Ok(json!([1])));
    }

    #[test]
    fn excerpts_respect_char_boundaries() {
        assert_eq!(excerpt("äöü", 2), "äö…");
        assert_eq!(excerpt("ab", 2), "ab");
        let e = ErrorObject::method_not_found(&"ü".repeat(1000), &["status"]);
        assert!(e.message.len() < 400, "{}", e.message.len());
    }
}
