//! A request's `params`, by shape, and named parameters deserialized with serde into the
//! method's parameter type.
//!
//! serde does the parsing (derive `Deserialize` with `deny_unknown_fields`); what this module
//! adds is the error: deserializing from a [`serde_json::Value`] loses which member failed
//! ("invalid type: integer `3`, expected a string"), so [`from_named`] walks the members
//! itself and returns a [`ParamFault`] naming the member and what was wrong with it, for the
//! API to phrase and to put in the error's `data`.
//!
//! Two rules differ from serde_json's: a member given as `null` is refused rather than taken
//! as absent (`Option` means "may be left out"), and a number is only ever a number (a string
//! holding digits is refused).

use serde::de::value::{SeqDeserializer, StrDeserializer};
use serde::de::{self, DeserializeOwned, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, Visitor};
use serde_json::{Map, Value};
use std::borrow::Cow;
use std::fmt;

use super::describe;

/// The `params` member of a request, by shape.
#[derive(Debug, Clone, PartialEq)]
pub enum Params {
    /// Absent, `{}` or `[]`: no parameters.
    None,
    /// A non-empty object.
    Named(Map<String, Value>),
    /// A non-empty array (positional parameters) or, from a caller that did not check the
    /// request with [`super::Request::from_value`], a scalar.
    Positional(Value),
}

impl Params {
    pub fn new(params: Option<Value>) -> Params {
        match params {
            None => Params::None,
            Some(Value::Object(m)) if m.is_empty() => Params::None,
            Some(Value::Array(a)) if a.is_empty() => Params::None,
            Some(Value::Object(m)) => Params::Named(m),
            Some(other) => Params::Positional(other),
        }
    }
}

/// Why named parameters did not deserialize.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamFault {
    /// The member at fault, where one is.
    pub param: Option<String>,
    pub kind: FaultKind,
}

/// What was wrong with the member.
#[derive(Debug, Clone, PartialEq)]
pub enum FaultKind {
    /// The method has no such member (`deny_unknown_fields`).
    Unknown,
    /// A required member is missing.
    Missing,
    /// The member is of the wrong JSON type: `expected` "a string", "a number", …; `got` as
    /// [`describe`] says it.
    WrongType { expected: Cow<'static, str>, got: &'static str },
    /// Anything else a `Deserialize` implementation refused, in its words.
    Other(String),
}

impl ParamFault {
    fn wrong_type(expected: &'static str, got: &Value) -> ParamFault {
        ParamFault { param: None, kind: FaultKind::WrongType { expected: Cow::Borrowed(expected), got: describe(got) } }
    }

    /// Names `member` as the one at fault unless a deeper one is named already.
    fn at(mut self, member: &str) -> ParamFault {
        if self.param.is_none() {
            self.param = Some(member.to_string());
        }
        self
    }
}

impl fmt::Display for ParamFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.param.as_deref().unwrap_or("params");
        match &self.kind {
            FaultKind::Unknown => write!(f, "unknown parameter {p:?}"),
            FaultKind::Missing => write!(f, "missing parameter {p:?}"),
            FaultKind::WrongType { expected, got } => write!(f, "parameter {p:?} must be {expected}, got {got}"),
            FaultKind::Other(m) => write!(f, "parameter {p:?}: {m}"),
        }
    }
}

impl std::error::Error for ParamFault {}

impl de::Error for ParamFault {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        ParamFault { param: None, kind: FaultKind::Other(msg.to_string()) }
    }

    fn invalid_type(unexp: de::Unexpected<'_>, exp: &dyn de::Expected) -> Self {
        use de::Unexpected as U;
        let got = match unexp {
            U::Bool(_) => "a boolean",
            U::Unsigned(_) | U::Signed(_) | U::Float(_) => "a number",
            U::Char(_) | U::Str(_) => "a string",
            U::Unit | U::Option => "null",
            U::Seq => "an array",
            U::Map => "an object",
            _ => "a value of another kind",
        };
        ParamFault { param: None, kind: FaultKind::WrongType { expected: Cow::Owned(exp.to_string()), got } }
    }

    fn unknown_field(field: &str, _expected: &'static [&'static str]) -> Self {
        ParamFault { param: Some(field.to_string()), kind: FaultKind::Unknown }
    }

    fn missing_field(field: &'static str) -> Self {
        ParamFault { param: Some(field.to_string()), kind: FaultKind::Missing }
    }
}

/// Deserializes the members of `params` into `T`. The members are visited in the map's order
/// (sorted by name), so the fault reported is the first one in that order.
pub fn from_named<T: DeserializeOwned>(params: Map<String, Value>) -> Result<T, ParamFault> {
    T::deserialize(Object(params))
}

/// An object's members as a serde deserializer with [`ParamFault`] errors.
struct Object(Map<String, Value>);

impl<'de> Deserializer<'de> for Object {
    type Error = ParamFault;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        visitor.visit_map(Members { iter: self.0.into_iter(), value: None })
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option unit
        unit_struct newtype_struct seq tuple tuple_struct map struct enum identifier ignored_any
    }
}

struct Members {
    iter: serde_json::map::IntoIter,
    /// The member whose key was just handed out.
    value: Option<(String, Value)>,
}

impl<'de> MapAccess<'de> for Members {
    type Error = ParamFault;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>, ParamFault> {
        let Some((key, value)) = self.iter.next() else { return Ok(None) };
        let k = seed.deserialize(StrDeserializer::<ParamFault>::new(&key)).map_err(|e| e.at(&key))?;
        self.value = Some((key, value));
        Ok(Some(k))
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, ParamFault> {
        let (key, value) = self.value.take().ok_or_else(|| de::Error::custom("a value without its member name"))?;
        seed.deserialize(Member(value)).map_err(|e| e.at(&key))
    }
}

/// One member's value as a serde deserializer with [`ParamFault`] errors.
struct Member(Value);

impl<'de> IntoDeserializer<'de, ParamFault> for Member {
    type Deserializer = Member;

    fn into_deserializer(self) -> Member {
        self
    }
}

impl<'de> Deserializer<'de> for Member {
    type Error = ParamFault;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        match self.0 {
            Value::Null => visitor.visit_unit(),
            Value::Bool(b) => visitor.visit_bool(b),
            Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
                (Some(u), _, _) => visitor.visit_u64(u),
                (None, Some(i), _) => visitor.visit_i64(i),
                (None, None, Some(x)) => visitor.visit_f64(x),
                (None, None, None) => Err(de::Error::custom(format!("{n} is not a representable number"))),
            },
            Value::String(s) => visitor.visit_string(s),
            Value::Array(a) => visitor.visit_seq(SeqDeserializer::new(a.into_iter().map(Member))),
            Value::Object(m) => visitor.visit_map(Members { iter: m.into_iter(), value: None }),
        }
    }

    /// A member that is present is a value, `null` included: absent members are the ones left
    /// out, so `{"factor": null}` is refused rather than read as no factor.
    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        visitor.visit_some(self)
    }

    fn deserialize_f64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        match &self.0 {
            Value::Number(n) => match n.as_f64() {
                Some(x) => visitor.visit_f64(x),
                None => Err(de::Error::custom(format!("{n} is not a representable number"))),
            },
            other => Err(ParamFault::wrong_type("a number", other)),
        }
    }

    fn deserialize_f32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        self.deserialize_f64(visitor)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        match self.0 {
            Value::String(s) => visitor.visit_string(s),
            other => Err(ParamFault::wrong_type("a string", &other)),
        }
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, ParamFault> {
        self.deserialize_string(visitor)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 char bytes byte_buf unit unit_struct newtype_struct seq
        tuple tuple_struct map struct enum identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;
    use serde_json::json;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Sample {
        name: String,
        scale: Option<f64>,
    }

    fn sample(v: Value) -> Result<Sample, ParamFault> {
        match v {
            Value::Object(m) => from_named(m),
            other => panic!("not an object: {other}"),
        }
    }

    fn fault(param: &str, kind: FaultKind) -> ParamFault {
        ParamFault { param: Some(param.into()), kind }
    }

    #[test]
    fn members_deserialize_and_faults_name_the_member() {
        assert_eq!(sample(json!({"name": "a"})), Ok(Sample { name: "a".into(), scale: None }));
        assert_eq!(sample(json!({"name": "a", "scale": 2})), Ok(Sample { name: "a".into(), scale: Some(2.0) }));
        assert_eq!(sample(json!({"scale": 2})), Err(fault("name", FaultKind::Missing)));
        assert_eq!(sample(json!({"name": "a", "zoom": 2})), Err(fault("zoom", FaultKind::Unknown)));
        let wrong = |expected: &'static str, got| FaultKind::WrongType { expected: Cow::Borrowed(expected), got };
        assert_eq!(sample(json!({"name": 1})), Err(fault("name", wrong("a string", "a number"))));
        assert_eq!(sample(json!({"name": "a", "scale": "2"})), Err(fault("scale", wrong("a number", "a string"))));
        assert_eq!(sample(json!({"name": "a", "scale": null})), Err(fault("scale", wrong("a number", "null"))));
        // Members are visited in name order: the first fault in that order is reported.
        assert_eq!(sample(json!({"zoom": 1, "name": 1})), Err(fault("name", wrong("a string", "a number"))));
    }

    #[test]
    fn shapes() {
        assert_eq!(Params::new(None), Params::None);
        assert_eq!(Params::new(Some(json!({}))), Params::None);
        assert_eq!(Params::new(Some(json!([]))), Params::None);
        assert!(matches!(Params::new(Some(json!({"a": 1}))), Params::Named(_)));
        assert_eq!(Params::new(Some(json!([1]))), Params::Positional(json!([1])));
    }
}
