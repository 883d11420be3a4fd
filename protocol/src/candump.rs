//! The can-utils log format written by `candump -l` and read by `canplayer`:
//!
//! ```text
//! (1700000000.123456) vcan0 201#0F00102700
//! (1700000000.123460) vcan0 080#
//! (1700000000.123470) vcan0 701#R1
//! (1700000000.123480) vcan0 12345678#DEADBEEF
//! ```
//!
//! One frame per line: the receive time as seconds and exactly six digits of microseconds in
//! parentheses (seconds zero-padded to ten digits), the interface name, then the frame in
//! can-utils' compact form: the identifier as 3 hex digits (11-bit) or 8 hex digits (29-bit;
//! SocketCAN error frames are 8 digits with bit 29 set), `#`, and the data as uppercase hex
//! pairs, or `R` plus an optional DLC digit for a remote frame.
//!
//! [`Record`]'s `Display` writes exactly what `candump -l` writes, so reading a canonical log
//! and writing it back gives the identical text. The reader also accepts what canplayer
//! accepts of the classic format but can-utils never writes (lowercase hex, padded interface
//! names, `R0`); those lines come back in canonical form. CAN FD (`##`) and the raw-DLC suffix
//! (`_`) are rejected with an error that says so. Reader errors name the line and column.

use crate::cia301::{CanId, Frame, FrameKind, socketcan_flags};
use std::fmt;
use std::io::{self, BufRead, Write};
use std::time::Duration;

/// A receive time with microsecond resolution, as the log stores it (CLOCK_REALTIME seconds
/// since the epoch in logs from candump; any origin works for replay).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Timestamp {
    micros: u64,
}

impl Timestamp {
    pub const fn from_micros(micros: u64) -> Timestamp {
        Timestamp { micros }
    }

    /// `None` if `micros >= 1_000_000` or the total does not fit in u64 microseconds.
    pub const fn from_secs_micros(secs: u64, micros: u32) -> Option<Timestamp> {
        if micros >= 1_000_000 {
            return None;
        }
        match secs.checked_mul(1_000_000) {
            Some(m) => match m.checked_add(micros as u64) {
                Some(t) => Some(Timestamp { micros: t }),
                None => None,
            },
            None => None,
        }
    }

    /// Truncates to whole microseconds, as candump does; `None` past u64 microseconds.
    pub fn from_duration(d: Duration) -> Option<Timestamp> {
        u64::try_from(d.as_micros()).ok().map(Timestamp::from_micros)
    }

    pub const fn as_micros(self) -> u64 {
        self.micros
    }

    pub const fn as_duration(self) -> Duration {
        Duration::from_micros(self.micros)
    }

    pub const fn secs(self) -> u64 {
        self.micros / 1_000_000
    }

    pub const fn subsec_micros(self) -> u32 {
        (self.micros % 1_000_000) as u32
    }
}

impl fmt::Display for Timestamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({:010}.{:06})", self.secs(), self.subsec_micros())
    }
}

/// A Linux network interface name as it appears in the log: 1 to 15 printable ASCII
/// characters without spaces (IFNAMSIZ is 16 with the terminating NUL).
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Iface(String);

/// Longest interface name Linux allows.
pub const IFACE_MAX_LEN: usize = 15;

impl Iface {
    pub fn new(name: &str) -> Option<Iface> {
        Self::valid(name.as_bytes()).then(|| Iface(name.to_owned()))
    }

    fn valid(name: &[u8]) -> bool {
        !name.is_empty() && name.len() <= IFACE_MAX_LEN && name.iter().all(u8::is_ascii_graphic)
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Iface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// One log line: when, on which interface, which frame.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Record {
    pub time: Timestamp,
    pub iface: Iface,
    pub frame: Frame,
}

/// The frame in can-utils' compact syntax (`201#0F00102700`, `701#R1`), as `cansend` takes it.
pub struct CompactFrame<'a>(pub &'a Frame);

impl fmt::Display for CompactFrame<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let frame = self.0;
        let id = frame.id();
        match frame.kind() {
            FrameKind::Error => write!(f, "{:08X}#", id.raw() | socketcan_flags::ERR)?,
            _ if id.is_extended() => write!(f, "{:08X}#", id.raw())?,
            _ => write!(f, "{:03X}#", id.raw())?,
        }
        if frame.kind() == FrameKind::Remote {
            f.write_str("R")?;
            if !frame.is_empty() {
                write!(f, "{}", frame.len())?;
            }
            return Ok(());
        }
        for b in frame.payload() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

impl fmt::Display for Record {
    /// The line without its newline, exactly as `candump -l` writes it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", self.time, self.iface, CompactFrame(&self.frame))
    }
}

/// What is wrong at the position a [`ParseError`] names.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParseErrorKind {
    #[error("empty line")]
    EmptyLine,
    #[error("expected {0}")]
    Expected(&'static str),
    #[error("the timestamp has {0} fractional digits, candump -l writes 6 (microseconds)")]
    FractionDigits(usize),
    #[error("the timestamp does not fit in 64-bit microseconds")]
    TimestampOutOfRange,
    #[error("interface name longer than {IFACE_MAX_LEN} characters")]
    IfaceTooLong,
    #[error("the CAN ID has {0} hex digits: 3 for an 11-bit ID, 8 for a 29-bit ID")]
    IdDigits(usize),
    #[error("CAN ID 0x{0:X} is out of range (11-bit IDs go to 0x7FF; 8-digit IDs use 29 bits plus the error flag)")]
    IdOutOfRange(u32),
    #[error("CAN FD frames ('##') are not supported: interpd uses classic CAN")]
    CanFd,
    #[error("the raw DLC suffix '_' is not supported")]
    RawDlc,
    #[error("more than 8 data bytes: a classic CAN frame carries at most 8")]
    TooManyBytes,
    #[error("odd number of hex digits in the data")]
    OddHexDigits,
    #[error("remote frame DLC must be a digit 0..8")]
    RemoteDlc,
    #[error("an error frame cannot be a remote frame")]
    RemoteErrorFrame,
    #[error("unexpected text after the frame")]
    TrailingText,
}

/// A log line that is not in the candump format: where (1-based line and column) and what.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, column {column}: {kind}")]
pub struct ParseError {
    pub line: usize,
    pub column: usize,
    pub kind: ParseErrorKind,
}

/// A read failure: the underlying reader's, or a line that does not parse.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("line {line}: {source}")]
    Io { line: usize, source: io::Error },
    #[error(transparent)]
    Parse(#[from] ParseError),
}

/// A cursor over one line's bytes; errors carry the byte offset, turned into a column later.
struct Cursor<'a> {
    s: &'a [u8],
    pos: usize,
}

type Step<T> = Result<T, (usize, ParseErrorKind)>;

impl<'a> Cursor<'a> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.pos).copied()
    }

    fn fail<T>(&self, kind: ParseErrorKind) -> Step<T> {
        Err((self.pos, kind))
    }

    fn expect(&mut self, c: u8, what: &'static str) -> Step<()> {
        if self.peek() == Some(c) {
            self.pos += 1;
            Ok(())
        } else {
            self.fail(ParseErrorKind::Expected(what))
        }
    }

    fn take_while(&mut self, f: impl Fn(u8) -> bool) -> &'a [u8] {
        let start = self.pos;
        while self.peek().is_some_and(&f) {
            self.pos += 1;
        }
        &self.s[start..self.pos]
    }

    /// One or more spaces (candump right-aligns interface names with spaces when it logs
    /// several interfaces of different name lengths).
    fn spaces(&mut self, what: &'static str) -> Step<()> {
        if self.take_while(|c| c == b' ').is_empty() { self.fail(ParseErrorKind::Expected(what)) } else { Ok(()) }
    }
}

fn hex_value(c: u8) -> Option<u8> {
    (c as char).to_digit(16).map(|d| d as u8)
}

fn parse_timestamp(c: &mut Cursor<'_>) -> Step<Timestamp> {
    c.expect(b'(', "'(' and the timestamp at the start of the line")?;
    let start = c.pos;
    let secs = c.take_while(|b| b.is_ascii_digit());
    if secs.is_empty() {
        return c.fail(ParseErrorKind::Expected("the seconds of the timestamp"));
    }
    let mut s: u64 = 0;
    for &d in secs {
        s = match s.checked_mul(10).and_then(|v| v.checked_add((d - b'0') as u64)) {
            Some(v) => v,
            None => return Err((start, ParseErrorKind::TimestampOutOfRange)),
        };
    }
    c.expect(b'.', "'.' between seconds and microseconds")?;
    let frac_start = c.pos;
    let frac = c.take_while(|b| b.is_ascii_digit());
    if frac.len() != 6 {
        return Err((frac_start, ParseErrorKind::FractionDigits(frac.len())));
    }
    let us = frac.iter().fold(0u32, |acc, &d| acc * 10 + (d - b'0') as u32);
    c.expect(b')', "')' after the timestamp")?;
    Timestamp::from_secs_micros(s, us).ok_or((start, ParseErrorKind::TimestampOutOfRange))
}

fn parse_frame(c: &mut Cursor<'_>) -> Step<Frame> {
    let id_start = c.pos;
    let digits = c.take_while(|b| b.is_ascii_hexdigit());
    if digits.is_empty() {
        return c.fail(ParseErrorKind::Expected("the CAN ID in hex"));
    }
    if digits.len() != 3 && digits.len() != 8 {
        return Err((id_start, ParseErrorKind::IdDigits(digits.len())));
    }
    let value = digits.iter().fold(0u32, |acc, &d| (acc << 4) | hex_value(d).unwrap_or(0) as u32);
    let (id, is_error) = if digits.len() == 3 {
        (CanId::standard(value as u16), false)
    } else if value & !crate::cia301::EFF_MAX == socketcan_flags::ERR {
        (CanId::extended(value & crate::cia301::EFF_MAX), true)
    } else {
        (CanId::extended(value), false)
    };
    let Some(id) = id else {
        return Err((id_start, ParseErrorKind::IdOutOfRange(value)));
    };
    c.expect(b'#', "'#' after the CAN ID")?;
    match c.peek() {
        Some(b'#') => return c.fail(ParseErrorKind::CanFd),
        Some(b'R' | b'r') => {
            if is_error {
                return c.fail(ParseErrorKind::RemoteErrorFrame);
            }
            c.pos += 1;
            let len = match c.peek() {
                None => 0,
                Some(d @ b'0'..=b'8') => {
                    c.pos += 1;
                    d - b'0'
                }
                Some(_) => return c.fail(ParseErrorKind::RemoteDlc),
            };
            if c.peek() == Some(b'_') {
                return c.fail(ParseErrorKind::RawDlc);
            }
            return Frame::remote(id, len).map_err(|_| (c.pos, ParseErrorKind::RemoteDlc));
        }
        _ => {}
    }
    let mut data = [0u8; 8];
    let mut len = 0usize;
    while let Some(hi) = c.peek().and_then(hex_value) {
        if len == 8 {
            return c.fail(ParseErrorKind::TooManyBytes);
        }
        c.pos += 1;
        let Some(lo) = c.peek().and_then(hex_value) else {
            return c.fail(ParseErrorKind::OddHexDigits);
        };
        c.pos += 1;
        data[len] = (hi << 4) | lo;
        len += 1;
    }
    if c.peek() == Some(b'_') {
        return c.fail(ParseErrorKind::RawDlc);
    }
    let built = if is_error { Frame::error(id.raw(), &data[..len]) } else { Frame::data(id, &data[..len]) };
    // Both constructors accept every id and length that reach this point.
    built.map_err(|_| (id_start, ParseErrorKind::IdOutOfRange(value)))
}

fn parse_bytes(line: &[u8]) -> Step<Record> {
    let mut c = Cursor { s: line, pos: 0 };
    if line.is_empty() {
        return c.fail(ParseErrorKind::EmptyLine);
    }
    let time = parse_timestamp(&mut c)?;
    c.spaces("a space after the timestamp")?;
    let iface_start = c.pos;
    let name = c.take_while(|b| b.is_ascii_graphic());
    if name.is_empty() {
        return c.fail(ParseErrorKind::Expected("the interface name"));
    }
    if name.len() > IFACE_MAX_LEN {
        return Err((iface_start, ParseErrorKind::IfaceTooLong));
    }
    // Graphic ASCII only, so this is valid UTF-8 and a valid interface name.
    let iface = Iface(name.iter().map(|&b| b as char).collect());
    c.spaces("a space after the interface name")?;
    let frame = parse_frame(&mut c)?;
    if c.pos != line.len() {
        return c.fail(ParseErrorKind::TrailingText);
    }
    Ok(Record { time, iface, frame })
}

/// Parses one line (without its newline). `line_no` only labels the error.
pub fn parse_line(line: &str, line_no: usize) -> Result<Record, ParseError> {
    parse_bytes(line.as_bytes()).map_err(|(pos, kind)| ParseError { line: line_no, column: column(line, pos), kind })
}

/// 1-based character column of a byte offset.
fn column(line: &str, byte: usize) -> usize {
    line.get(..byte).map_or(byte, |s| s.chars().count()) + 1
}

/// Parses a whole log held in memory.
pub fn parse_log(text: &str) -> Result<Vec<Record>, ParseError> {
    text.lines().enumerate().map(|(i, l)| parse_line(l, i + 1)).collect()
}

/// Writes a whole log as text (each line ends with `\n`).
pub fn format_log(records: &[Record]) -> String {
    use fmt::Write as _;
    let mut out = String::new();
    for r in records {
        // Writing into a String cannot fail.
        let _ = writeln!(out, "{r}");
    }
    out
}

/// Streams records from a log file, one per line.
pub struct Reader<R> {
    inner: R,
    line: usize,
    buf: Vec<u8>,
}

impl<R: BufRead> Reader<R> {
    pub fn new(inner: R) -> Self {
        Reader { inner, line: 0, buf: Vec::with_capacity(64) }
    }
}

impl<R: BufRead> Iterator for Reader<R> {
    type Item = Result<Record, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.buf.clear();
        self.line += 1;
        match self.inner.read_until(b'\n', &mut self.buf) {
            Ok(0) => None,
            Ok(_) => {
                let bytes = self.buf.strip_suffix(b"\n").unwrap_or(&self.buf);
                // Parse the bytes, so a line that is not UTF-8 is a parse error with a column,
                // not an I/O error.
                Some(parse_bytes(bytes).map_err(|(pos, kind)| {
                    let col = std::str::from_utf8(bytes).map_or(pos + 1, |s| column(s, pos));
                    ReadError::Parse(ParseError { line: self.line, column: col, kind })
                }))
            }
            Err(source) => Some(Err(ReadError::Io { line: self.line, source })),
        }
    }
}

/// Writes records in the `candump -l` format. Wrap a file in a `BufWriter`: every record is
/// formatted straight into the writer, without allocating.
pub struct Writer<W> {
    inner: W,
}

impl<W: Write> Writer<W> {
    pub fn new(inner: W) -> Self {
        Writer { inner }
    }

    pub fn write(&mut self, record: &Record) -> io::Result<()> {
        writeln!(self.inner, "{record}")
    }

    /// Writes one frame without building a [`Record`] (no interface-name clone per frame).
    pub fn write_frame(&mut self, time: Timestamp, iface: &Iface, frame: &Frame) -> io::Result<()> {
        writeln!(self.inner, "{time} {iface} {}", CompactFrame(frame))
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }

    pub fn into_inner(self) -> W {
        self.inner
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CANONICAL: &str = "\
(1700000000.123456) vcan0 201#0F00102700
(1700000000.123460) vcan0 080#
(1700000000.123461) vcan0 081#1082210102030405
(1700000000.123470) vcan0 701#R
(1700000000.123471) vcan0 701#R1
(1700000000.123480) vcan0 12345678#DEADBEEF
(1700000000.123481) can10 00000123#
(1700000000.123490) vcan0 20000040#0000000000000000
(0000000001.000000) vcan0 7FF#0102030405060708
";

    #[test]
    fn canonical_text_round_trips_exactly() {
        let records = parse_log(CANONICAL).expect("parse");
        assert_eq!(records.len(), 9);
        assert_eq!(format_log(&records), CANONICAL);
        let r = &records[0];
        assert_eq!(r.time, Timestamp::from_secs_micros(1_700_000_000, 123_456).unwrap());
        assert_eq!(r.iface.as_str(), "vcan0");
        assert_eq!(r.frame, Frame::standard(0x201, &[0x0F, 0x00, 0x10, 0x27, 0x00]).unwrap());
        assert_eq!(records[3].frame.kind(), FrameKind::Remote);
        assert_eq!(records[4].frame.len(), 1);
        assert!(records[5].frame.id().is_extended());
        assert!(records[6].frame.id().is_extended() && records[6].frame.id().raw() == 0x123);
        assert_eq!(records[7].frame.kind(), FrameKind::Error);
        assert_eq!(records[7].frame.id().raw(), 0x40);
    }

    #[test]
    fn reader_and_writer_stream_the_same_text() {
        let mut w = Writer::new(Vec::new());
        for r in Reader::new(CANONICAL.as_bytes()) {
            w.write(&r.expect("record")).expect("write");
        }
        assert_eq!(String::from_utf8(w.into_inner()).unwrap(), CANONICAL);
    }

    #[test]
    fn lenient_input_is_rewritten_canonically() {
        let r = parse_line("(1.000001)  can0 1ab#deadbeef", 1).unwrap();
        assert_eq!(r.to_string(), "(0000000001.000001) can0 1AB#DEADBEEF");
        let r = parse_line("(1.000001) can0 123#r0", 1).unwrap();
        assert_eq!(r.to_string(), "(0000000001.000001) can0 123#R");
    }

    fn err(line: &str) -> (usize, ParseErrorKind) {
        let e = parse_line(line, 7).expect_err(line);
        assert_eq!(e.line, 7);
        (e.column, e.kind)
    }

    #[test]
    fn errors_name_line_column_and_cause() {
        use ParseErrorKind::*;
        assert_eq!(err(""), (1, EmptyLine));
        assert_eq!(
            err("1700000000.123456 vcan0 123#"),
            (1, Expected("'(' and the timestamp at the start of the line"))
        );
        assert_eq!(err("(1700000000.1234) vcan0 123#"), (13, FractionDigits(4)));
        assert_eq!(err("(99999999999999999999.000000) vcan0 123#"), (2, TimestampOutOfRange));
        assert_eq!(err("(18446744073709.551616) vcan0 123#"), (2, TimestampOutOfRange));
        assert_eq!(err("(1.000000)vcan0 123#"), (11, Expected("a space after the timestamp")));
        assert_eq!(err("(1.000000) vcan0"), (17, Expected("a space after the interface name")));
        assert_eq!(err("(1.000000) vcan0 12#"), (18, IdDigits(2)));
        assert_eq!(err("(1.000000) vcan0 800#"), (18, IdOutOfRange(0x800)));
        assert_eq!(err("(1.000000) vcan0 40000000#"), (18, IdOutOfRange(0x4000_0000)));
        assert_eq!(err("(1.000000) vcan0 123"), (21, Expected("'#' after the CAN ID")));
        assert_eq!(err("(1.000000) vcan0 123##1DEAD"), (22, CanFd));
        assert_eq!(err("(1.000000) vcan0 123#ABC"), (25, OddHexDigits));
        assert_eq!(err("(1.000000) vcan0 123#010203040506070809"), (38, TooManyBytes));
        assert_eq!(err("(1.000000) vcan0 123#0102030405060708_9"), (38, RawDlc));
        assert_eq!(err("(1.000000) vcan0 123#R9"), (23, RemoteDlc));
        assert_eq!(err("(1.000000) vcan0 123#R8_9"), (24, RawDlc));
        assert_eq!(err("(1.000000) vcan0 20000001#R"), (27, RemoteErrorFrame));
        assert_eq!(err("(1.000000) vcan0 123#00 R"), (24, TrailingText));
        assert_eq!(err("(1.000000) vcan0 123#00\r"), (24, TrailingText));
        assert_eq!(err("(1.000000) averyveryverylongname 123#"), (12, IfaceTooLong));
        let e = parse_line("(1.000000) vcan0 12#", 3).unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 3, column 18: the CAN ID has 2 hex digits: 3 for an 11-bit ID, 8 for a 29-bit ID"
        );
    }

    #[test]
    fn reader_reports_line_numbers_and_survives_binary() {
        let text = b"(1.000000) vcan0 123#\n(2.000000) vcan0 \xff\xfe#\n";
        let items: Vec<_> = Reader::new(&text[..]).collect();
        assert!(items[0].is_ok());
        match &items[1] {
            Err(ReadError::Parse(ParseError { line: 2, column: 18, .. })) => {}
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn timestamps() {
        let t = Timestamp::from_duration(Duration::new(5, 123_456_789)).unwrap();
        assert_eq!((t.secs(), t.subsec_micros()), (5, 123_456));
        assert_eq!(t.to_string(), "(0000000005.123456)");
        assert_eq!(Timestamp::from_secs_micros(1, 1_000_000), None);
        assert_eq!(Timestamp::from_micros(12_345_678_901_234_567).to_string(), "(12345678901.234567)");
        assert!(Iface::new("vcan0").is_some());
        assert!(
            Iface::new("").is_none() && Iface::new("a b").is_none() && Iface::new("x".repeat(16).as_str()).is_none()
        );
    }
}
