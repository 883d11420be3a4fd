//! The MCAP schema of the recorded streams: OMG IDL text (schema encoding `omgidl`) and CDR
//! messages (message encoding `cdr`), generated from one field table per payload.
//!
//! Why IDL + CDR and not a private encoding: both are MCAP well-known encodings, so standard
//! MCAP tools can decode and plot a recording without interpd. And for these payloads CDR costs
//! nothing: XCDR1 ("plain CDR") little endian puts every primitive at its natural alignment
//! counted from the end of the 4-byte encapsulation header, and the `#[repr(C)]` structs of
//! `protocol/src/shm.rs` have every field at its natural alignment and no padding. So a
//! message is the header `00 01 00 00` followed by exactly the bytes published on iceoryx2;
//! recording and replay copy bytes and never convert a field.

use interpd_protocol::MAX_AXES;
use interpd_protocol::shm::{Feedback, PAYLOAD_VERSION, Setpoints};
use std::fmt::Write as _;

/// MCAP schema encoding of [`PayloadSchema::idl`].
pub const SCHEMA_ENCODING: &str = "omgidl";
/// MCAP message encoding of the recorded messages.
pub const MESSAGE_ENCODING: &str = "cdr";
/// CDR encapsulation header: representation CDR_LE (0x0001, XCDR1 little endian), options 0.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A primitive of the payloads, with its IDL name and size (= alignment, in CDR and in C).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prim {
    U32,
    U64,
    F64,
}

impl Prim {
    pub fn size(self) -> usize {
        match self {
            Prim::U32 => 4,
            Prim::U64 | Prim::F64 => 8,
        }
    }

    pub fn idl(self) -> &'static str {
        match self {
            Prim::U32 => "unsigned long",
            Prim::U64 => "unsigned long long",
            Prim::F64 => "double",
        }
    }
}

/// One field: `count` = 1 for a scalar, else a fixed array of `count` elements.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    pub name: &'static str,
    pub prim: Prim,
    pub count: usize,
    pub doc: &'static str,
}

const fn scalar(name: &'static str, prim: Prim, doc: &'static str) -> Field {
    Field { name, prim, count: 1, doc }
}

const fn axes(name: &'static str, doc: &'static str) -> Field {
    Field { name, prim: Prim::F64, count: MAX_AXES, doc }
}

/// Which recorded stream: one MCAP channel and one iceoryx2 service each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stream {
    Setpoints,
    Feedback,
}

impl Stream {
    pub const ALL: [Stream; 2] = [Stream::Setpoints, Stream::Feedback];

    pub fn schema(self) -> &'static PayloadSchema {
        match self {
            Stream::Setpoints => &SETPOINTS,
            Stream::Feedback => &FEEDBACK,
        }
    }

    /// The stream whose schema is called `name` (MCAP schema name).
    pub fn from_schema_name(name: &str) -> Option<Stream> {
        Stream::ALL.into_iter().find(|s| s.schema().name == name)
    }
}

/// The recorded form of one payload type.
#[derive(Debug)]
pub struct PayloadSchema {
    /// MCAP schema name: the IDL scoped name, equal to the iceoryx2 type name.
    pub name: &'static str,
    /// Struct name inside `module interpd`.
    pub idl_struct: &'static str,
    /// iceoryx2 service suffix: the service is `<prefix>/<service>`.
    pub service: &'static str,
    /// Payload size in bytes (without the CDR header).
    pub size: usize,
    pub fields: &'static [Field],
    /// How the MCAP log and publish times are taken from the payload.
    pub times: &'static str,
}

/// `interpd::Setpoints` (protocol/src/shm.rs).
pub static SETPOINTS: PayloadSchema = PayloadSchema {
    name: "interpd::Setpoints",
    idl_struct: "Setpoints",
    service: "setpoints",
    size: std::mem::size_of::<Setpoints>(),
    fields: &[
        scalar("version", Prim::U32, "payload layout version"),
        scalar("n_axes", Prim::U32, "valid entries of the per-axis arrays"),
        scalar("cycle", Prim::U64, "cycle number, +1 per cycle"),
        scalar("time_ns", Prim::U64, "CLOCK_MONOTONIC time the setpoint is for (cycle deadline), ns"),
        scalar("publish_ns", Prim::U64, "CLOCK_MONOTONIC time the daemon published it, ns"),
        scalar(
            "flags",
            Prim::U32,
            "RUNNING 1, HOLDING 2, STOPPING 4, FINISHED 8, ERROR 16, UNDERRUN 32, LATE 64, IDLE 128",
        ),
        scalar("line", Prim::U32, "program line being executed, 1-based, 0 if none"),
        scalar("s_mm", Prim::F64, "path position, mm"),
        scalar("v_mm_s", Prim::F64, "path velocity, mm/s"),
        scalar("a_mm_s2", Prim::F64, "path acceleration, mm/s^2"),
        scalar("feed_override", Prim::F64, "feed override in effect, 1.0 = 100 %"),
        axes("pos", "axis positions, mm or deg, axis order of the machine file"),
        axes("vel", "axis velocities, per s"),
        axes("acc", "axis accelerations, per s^2"),
    ],
    times: "log_time = time_ns, publish_time = publish_ns",
};

/// `interpd::Feedback` (protocol/src/shm.rs).
pub static FEEDBACK: PayloadSchema = PayloadSchema {
    name: "interpd::Feedback",
    idl_struct: "Feedback",
    service: "feedback",
    size: std::mem::size_of::<Feedback>(),
    fields: &[
        scalar("version", Prim::U32, "payload layout version"),
        scalar("n_axes", Prim::U32, "valid entries of the per-axis arrays"),
        scalar("cycle", Prim::U64, "cycle number of the setpoint this feedback answers"),
        scalar("time_ns", Prim::U64, "CLOCK_MONOTONIC time of the plant state, ns"),
        scalar("setpoint_publish_ns", Prim::U64, "publish_ns of the answered setpoint, ns"),
        scalar("flags", Prim::U32, "SATURATED 1, GAP_OPEN 2, RESYNC 4"),
        scalar("reserved", Prim::U32, "0"),
        axes("motor_pos", "motor-side position (encoder), axis unit"),
        axes("load_pos", "load-side position, axis unit"),
        axes("following_error", "setpoint minus motor position, axis unit"),
        axes("load_error", "setpoint minus load position, axis unit"),
        axes("motor_force", "motor force N or torque N*m"),
    ],
    times: "log_time = time_ns, publish_time = time_ns (the payload carries no publish time)",
};

impl PayloadSchema {
    /// Byte offset of every field in CDR (relative to the end of the encapsulation header):
    /// each field at the next multiple of its primitive's size.
    pub fn offsets(&self) -> Vec<usize> {
        let mut at = 0usize;
        self.fields
            .iter()
            .map(|f| {
                at = at.next_multiple_of(f.prim.size());
                let offset = at;
                at += f.prim.size() * f.count;
                offset
            })
            .collect()
    }

    /// The encoded size: the end of the last field.
    pub fn cdr_size(&self) -> usize {
        let last = self.fields.last().expect("a payload has fields");
        self.offsets().last().copied().unwrap_or(0) + last.prim.size() * last.count
    }

    /// The MCAP schema data: OMG IDL with the layout and times in comments.
    pub fn idl(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "// {} payload version {PAYLOAD_VERSION} (interpd protocol/src/shm.rs).", self.name);
        let _ = writeln!(s, "// Message encoding cdr: the XCDR1 little-endian header 00 01 00 00, then the");
        let _ = writeln!(s, "// {} bytes of the #[repr(C)] struct as published on iceoryx2 service", self.size);
        let _ = writeln!(s, "// <prefix>/{}. Fields at their natural alignment, no padding;", self.service);
        let _ = writeln!(s, "// @offset = byte offset after the header. MCAP {}.", self.times);
        let _ = writeln!(s, "module interpd {{");
        let _ = writeln!(s, "  struct {} {{", self.idl_struct);
        for (f, off) in self.fields.iter().zip(self.offsets()) {
            let decl = if f.count == 1 {
                format!("{} {};", f.prim.idl(), f.name)
            } else {
                format!("{} {}[{}];", f.prim.idl(), f.name, f.count)
            };
            let _ = writeln!(s, "    {decl:<36} // @{off:<3} {}", f.doc);
        }
        let _ = writeln!(s, "  }};");
        let _ = writeln!(s, "}};");
        s
    }
}

/// Why a recorded message is not a valid payload.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PayloadError {
    #[error("{got} bytes, expected {expected} (4-byte CDR header + {payload}-byte payload)")]
    Size { got: usize, expected: usize, payload: usize },
    #[error("CDR encapsulation header {got:02x?}, expected {CDR_LE_HEADER:02x?} (XCDR1 little endian)")]
    Header { got: [u8; 4] },
    #[error("payload version {got}, this build reads version {PAYLOAD_VERSION}")]
    Version { got: u32 },
    #[error("n_axes {got} exceeds {MAX_AXES}")]
    Axes { got: u32 },
    #[error("field {field} is not finite")]
    NotFinite { field: String },
}

/// Appends the MCAP message for `payload` (the raw struct bytes) to `out`.
pub fn encode(payload: &[u8], out: &mut Vec<u8>) {
    out.extend_from_slice(&CDR_LE_HEADER);
    out.extend_from_slice(payload);
}

/// A decoded, validated payload.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Payload {
    Setpoints(Setpoints),
    Feedback(Feedback),
}

impl Payload {
    pub fn stream(&self) -> Stream {
        match self {
            Payload::Setpoints(_) => Stream::Setpoints,
            Payload::Feedback(_) => Stream::Feedback,
        }
    }

    /// The raw struct bytes (what iceoryx2 carries).
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            Payload::Setpoints(s) => s.as_bytes(),
            Payload::Feedback(f) => f.as_bytes(),
        }
    }

    pub fn cycle(&self) -> u64 {
        match self {
            Payload::Setpoints(s) => s.cycle,
            Payload::Feedback(f) => f.cycle,
        }
    }

    /// (MCAP log_time, publish_time) of this payload, ns (see [`PayloadSchema::times`]).
    pub fn mcap_times(&self) -> (u64, u64) {
        match self {
            Payload::Setpoints(s) => (s.time_ns, s.publish_ns),
            Payload::Feedback(f) => (f.time_ns, f.time_ns),
        }
    }
}

/// Decodes and validates one MCAP message of `stream`: size, header, version, axis count, and
/// finite values in the fields that matter (the first `n_axes` of every per-axis array).
pub fn decode(stream: Stream, data: &[u8]) -> Result<Payload, PayloadError> {
    let schema = stream.schema();
    let expected = CDR_LE_HEADER.len() + schema.size;
    if data.len() != expected {
        return Err(PayloadError::Size { got: data.len(), expected, payload: schema.size });
    }
    let (header, body) = data.split_at(CDR_LE_HEADER.len());
    if header != CDR_LE_HEADER {
        return Err(PayloadError::Header { got: [header[0], header[1], header[2], header[3]] });
    }
    let version = u32::from_le_bytes([body[0], body[1], body[2], body[3]]);
    if version != PAYLOAD_VERSION {
        return Err(PayloadError::Version { got: version });
    }
    let n_axes = u32::from_le_bytes([body[4], body[5], body[6], body[7]]);
    if n_axes as usize > MAX_AXES {
        return Err(PayloadError::Axes { got: n_axes });
    }
    let payload = match stream {
        Stream::Setpoints => Setpoints::from_bytes(body).map(Payload::Setpoints),
        Stream::Feedback => Feedback::from_bytes(body).map(Payload::Feedback),
    };
    let payload = payload.ok_or(PayloadError::Version { got: version })?;
    check(&payload)?;
    Ok(payload)
}

/// Checks a payload as received: version, axis count, finite values in the fields that matter
/// (the first `n_axes` of every per-axis array).
pub fn check(p: &Payload) -> Result<(), PayloadError> {
    let (version, n_axes) = match p {
        Payload::Setpoints(s) => (s.version, s.n_axes),
        Payload::Feedback(f) => (f.version, f.n_axes),
    };
    if version != PAYLOAD_VERSION {
        return Err(PayloadError::Version { got: version });
    }
    if n_axes as usize > MAX_AXES {
        return Err(PayloadError::Axes { got: n_axes });
    }
    check_finite(p)
}

fn check_finite(p: &Payload) -> Result<(), PayloadError> {
    let bad = |field: &str| Err(PayloadError::NotFinite { field: field.into() });
    match p {
        Payload::Setpoints(s) => {
            let n = s.n_axes as usize;
            for (name, v) in
                [("s_mm", s.s_mm), ("v_mm_s", s.v_mm_s), ("a_mm_s2", s.a_mm_s2), ("feed_override", s.feed_override)]
            {
                if !v.is_finite() {
                    return bad(name);
                }
            }
            for (name, arr) in [("pos", &s.pos), ("vel", &s.vel), ("acc", &s.acc)] {
                if let Some(k) = arr[..n].iter().position(|v| !v.is_finite()) {
                    return bad(&format!("{name}[{k}]"));
                }
            }
        }
        Payload::Feedback(f) => {
            let n = f.n_axes as usize;
            for (name, arr) in [
                ("motor_pos", &f.motor_pos),
                ("load_pos", &f.load_pos),
                ("following_error", &f.following_error),
                ("load_error", &f.load_error),
                ("motor_force", &f.motor_force),
            ] {
                if let Some(k) = arr[..n].iter().position(|v| !v.is_finite()) {
                    return bad(&format!("{name}[{k}]"));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::offset_of;

    #[test]
    fn field_tables_match_the_repr_c_layout() {
        let sp = [
            offset_of!(Setpoints, version),
            offset_of!(Setpoints, n_axes),
            offset_of!(Setpoints, cycle),
            offset_of!(Setpoints, time_ns),
            offset_of!(Setpoints, publish_ns),
            offset_of!(Setpoints, flags),
            offset_of!(Setpoints, line),
            offset_of!(Setpoints, s_mm),
            offset_of!(Setpoints, v_mm_s),
            offset_of!(Setpoints, a_mm_s2),
            offset_of!(Setpoints, feed_override),
            offset_of!(Setpoints, pos),
            offset_of!(Setpoints, vel),
            offset_of!(Setpoints, acc),
        ];
        assert_eq!(SETPOINTS.offsets(), sp);
        assert_eq!(SETPOINTS.cdr_size(), SETPOINTS.size);
        let fb = [
            offset_of!(Feedback, version),
            offset_of!(Feedback, n_axes),
            offset_of!(Feedback, cycle),
            offset_of!(Feedback, time_ns),
            offset_of!(Feedback, setpoint_publish_ns),
            offset_of!(Feedback, flags),
            offset_of!(Feedback, reserved),
            offset_of!(Feedback, motor_pos),
            offset_of!(Feedback, load_pos),
            offset_of!(Feedback, following_error),
            offset_of!(Feedback, load_error),
            offset_of!(Feedback, motor_force),
        ];
        assert_eq!(FEEDBACK.offsets(), fb);
        assert_eq!(FEEDBACK.cdr_size(), FEEDBACK.size);
    }

    #[test]
    fn idl_names_every_field_with_its_offset() {
        let idl = SETPOINTS.idl();
        assert!(idl.contains("module interpd {"));
        assert!(idl.contains("struct Setpoints {"));
        assert!(idl.contains("unsigned long long cycle;"));
        assert!(idl.contains("double pos[9];"));
        assert!(idl.contains("// @216 axis accelerations"));
        assert!(FEEDBACK.idl().contains("double motor_force[9];"));
    }

    /// Reads field `i` of `schema` from a CDR body by the table alone (an independent reading
    /// of the encoding, not the Rust struct).
    fn cdr_f64(schema: &PayloadSchema, body: &[u8], name: &str, index: usize) -> f64 {
        let i = schema.fields.iter().position(|f| f.name == name).expect("field");
        let at = schema.offsets()[i] + index * 8;
        f64::from_le_bytes(body[at..at + 8].try_into().expect("8 bytes"))
    }

    fn cdr_u64(schema: &PayloadSchema, body: &[u8], name: &str) -> u64 {
        let i = schema.fields.iter().position(|f| f.name == name).expect("field");
        let at = schema.offsets()[i];
        u64::from_le_bytes(body[at..at + 8].try_into().expect("8 bytes"))
    }

    #[test]
    fn setpoints_round_trip_through_cdr() {
        let mut sp =
            Setpoints { n_axes: 5, cycle: 77, time_ns: 1_000, publish_ns: 1_050, line: 3, ..Setpoints::default() };
        for k in 0..5 {
            sp.pos[k] = 1.5 * k as f64 - 2.0;
            sp.acc[k] = -0.25 * k as f64;
        }
        sp.s_mm = 12.5;
        let mut msg = Vec::new();
        encode(sp.as_bytes(), &mut msg);
        assert_eq!(&msg[..4], &CDR_LE_HEADER);
        let body = &msg[4..];
        assert_eq!(cdr_u64(&SETPOINTS, body, "cycle"), 77);
        assert_eq!(cdr_u64(&SETPOINTS, body, "publish_ns"), 1_050);
        assert_eq!(cdr_f64(&SETPOINTS, body, "s_mm", 0), 12.5);
        assert_eq!(cdr_f64(&SETPOINTS, body, "pos", 4), 4.0);
        assert_eq!(cdr_f64(&SETPOINTS, body, "acc", 3), -0.75);
        let back = decode(Stream::Setpoints, &msg).expect("valid");
        assert_eq!(back, Payload::Setpoints(sp));
        assert_eq!(back.as_bytes(), sp.as_bytes());
        assert_eq!(back.mcap_times(), (1_000, 1_050));
    }

    #[test]
    fn feedback_round_trips_and_times_come_from_the_payload() {
        let mut fb = Feedback { n_axes: 2, cycle: 9, time_ns: 500, ..Feedback::default() };
        fb.load_error[1] = 3e-6;
        let mut msg = Vec::new();
        encode(fb.as_bytes(), &mut msg);
        assert_eq!(cdr_f64(&FEEDBACK, &msg[4..], "load_error", 1), 3e-6);
        let back = decode(Stream::Feedback, &msg).expect("valid");
        assert_eq!(back, Payload::Feedback(fb));
        assert_eq!(back.mcap_times(), (500, 500));
    }

    #[test]
    fn invalid_messages_are_named() {
        let sp = Setpoints { n_axes: 3, ..Setpoints::default() };
        let mut msg = Vec::new();
        encode(sp.as_bytes(), &mut msg);
        assert!(matches!(decode(Stream::Setpoints, &msg[..100]), Err(PayloadError::Size { got: 100, .. })));
        assert!(matches!(decode(Stream::Feedback, &msg), Err(PayloadError::Size { .. })));
        let mut bad = msg.clone();
        bad[1] = 0;
        assert!(matches!(decode(Stream::Setpoints, &bad), Err(PayloadError::Header { .. })));
        let mut bad = msg.clone();
        bad[4] = 7;
        assert_eq!(decode(Stream::Setpoints, &bad), Err(PayloadError::Version { got: 7 }));
        let mut bad = msg.clone();
        bad[8] = 200;
        assert_eq!(decode(Stream::Setpoints, &bad), Err(PayloadError::Axes { got: 200 }));
        let mut nan = sp;
        nan.pos[2] = f64::NAN;
        let mut bad = Vec::new();
        encode(nan.as_bytes(), &mut bad);
        assert_eq!(decode(Stream::Setpoints, &bad), Err(PayloadError::NotFinite { field: "pos[2]".into() }));
        // Entries past n_axes are not used and not checked.
        nan.n_axes = 2;
        let mut ok = Vec::new();
        encode(nan.as_bytes(), &mut ok);
        assert!(decode(Stream::Setpoints, &ok).is_ok());
    }
}
