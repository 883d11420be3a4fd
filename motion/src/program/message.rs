//! Operator messages as LinuxCNC 2.9 writes them in comments: `(MSG,…)`, `(DEBUG,…)` and
//! `(PRINT,…)` (its `convert_comment` and `convert_param_comment`, interp_convert.cc).
//!
//! - The keyword is the start of the comment after blanks, in any case, with the comma right
//!   after it; the text is everything after the comma, as written (case and blanks kept).
//! - `MSG` text is shown as written. `DEBUG` and `PRINT` text has parameters substituted:
//!   `#123` and `#<name>` (blanks inside the brackets ignored, case-insensitive) become their
//!   value with `%lf`, six decimals; `%d` before them switches to no decimals, `%f` to four,
//!   `%.Nf` to N (0–9), for the rest of the text. A parameter that does not exist (a named one
//!   never set, a number out of range) shows `######`, as does a value longer than 29
//!   characters; a value within 1e-4 of zero shows as zero (LinuxCNC's `equal`, against
//!   `-0.000000`). A `#` at the end of the text, or `#<` without `>`, is an error.
//! - `DEBUG` comes out only while `#5599` is above 0 (1 at the start, as in LinuxCNC).
//! - The text is cut to [`MAX_TEXT_BYTES`] (LinuxCNC's comment buffer holds 255 characters).
//! - Bounded: at most [`PLACE_CAP`] messages at one place in the motion and [`QUEUE_CAP`]
//!   waiting to be taken; beyond that the newest stands for the rest (its `dropped`).

pub(super) use super::params::DEBUG_FLAG_PARAM;
use super::params::{MAX_NUMBERED, Params};
use std::collections::VecDeque;

/// Longest message text, bytes (cut at a character boundary).
pub const MAX_TEXT_BYTES: usize = 255;
/// Messages the interpreter holds until they are taken ([`MessageQueue`]).
pub(crate) const QUEUE_CAP: usize = 1024;
/// Messages at one place in the motion (no element between them, as in a loop that writes
/// messages and does not move): beyond this many, only the newest comes out, counting the
/// ones it stands for. They all come out at once when the motion gets there, so this bounds
/// that burst (a subscriber of the control API holds 1024 events).
pub const PLACE_CAP: usize = 256;
/// What LinuxCNC writes for a parameter it cannot show.
const NO_VALUE: &str = "######";
/// LinuxCNC's `VAL_LEN`: a value needs fewer characters than this.
const VAL_LEN: usize = 30;
/// LinuxCNC's `TOLERANCE_EQUAL`: values this close to 0 are written as 0.
const ZERO_TOL: f64 = 1e-4;

/// Which comment a message came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageKind {
    Msg,
    Debug,
    Print,
}

impl MessageKind {
    /// The keyword, lower case (`msg`, `debug`, `print`).
    pub fn name(self) -> &'static str {
        match self {
            MessageKind::Msg => "msg",
            MessageKind::Debug => "debug",
            MessageKind::Print => "print",
        }
    }
}

/// An operator message of the program, formatted when its block executed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// Number in program order, from 1 ([`crate::path::Pause`] names it).
    pub id: u64,
    pub kind: MessageKind,
    pub text: String,
    /// Program line of the comment.
    pub line: u32,
    /// Messages dropped just before this one because too many waited ([`MessageQueue`]).
    pub dropped: u64,
}

/// `LINE: kind: text` (and how many were dropped before it, if any): how `interpd check` and
/// `interpd plan` print a message after the file name.
impl std::fmt::Display for Message {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.line, self.kind.name(), self.text)?;
        if self.dropped > 0 {
            write!(f, " ({} messages dropped before this one)", self.dropped)?;
        }
        Ok(())
    }
}

/// The message a comment holds (`comment` is the text inside the parentheses): its kind and
/// the text after the comma, or None for an ordinary comment.
pub(super) fn parse(comment: &str) -> Option<(MessageKind, &str)> {
    let t = comment.trim_start_matches(|c: char| c.is_ascii_whitespace());
    for (kind, key) in [(MessageKind::Msg, "msg,"), (MessageKind::Debug, "debug,"), (MessageKind::Print, "print,")] {
        if t.len() >= key.len() && t.is_char_boundary(key.len()) && t[..key.len()].eq_ignore_ascii_case(key) {
            return Some((kind, &t[key.len()..]));
        }
    }
    None
}

/// `text` with its parameters substituted (see the [module](self)); Err names what is wrong.
pub(super) fn expand(text: &str, params: &Params) -> Result<String, String> {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut decimals = 6usize;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                i += 1;
                match b.get(i) {
                    Some(b'd') => {
                        decimals = 0;
                        i += 1;
                    }
                    Some(b'f') => {
                        decimals = 4;
                        i += 1;
                    }
                    Some(b'.') => {
                        i += 1;
                        match (b.get(i), b.get(i + 1)) {
                            (Some(d), Some(b'f')) if d.is_ascii_digit() => {
                                decimals = usize::from(d - b'0');
                                i += 2;
                            }
                            // Not a format: LinuxCNC keeps the '.' (and drops the '%').
                            _ => out.push('.'),
                        }
                    }
                    _ => out.push('%'),
                }
            }
            b'#' => {
                i += 1;
                match b.get(i) {
                    None => return Err("'#' at the end of the message names no parameter".into()),
                    Some(d) if d.is_ascii_digit() => {
                        let start = i;
                        while i < b.len() && b[i].is_ascii_digit() {
                            i += 1;
                        }
                        let n = text[start..i].parse::<usize>().unwrap_or(usize::MAX);
                        let value = match n {
                            0 => Some(0.0),
                            n if n <= MAX_NUMBERED => params.numbered(n).ok(),
                            _ => None,
                        };
                        out.push_str(&format_value(value, decimals));
                    }
                    Some(b'<') => {
                        i += 1;
                        let mut name = String::new();
                        loop {
                            match text[i..].chars().next() {
                                None => return Err("named parameter '#<' is not closed with '>'".into()),
                                Some('>') => {
                                    i += 1;
                                    break;
                                }
                                Some(c) => {
                                    if !c.is_whitespace() {
                                        name.extend(c.to_lowercase());
                                    }
                                    i += c.len_utf8();
                                }
                            }
                        }
                        out.push_str(&format_value(params.named(&name), decimals));
                    }
                    // Neither a number nor a name: the '#' stays.
                    Some(_) => out.push('#'),
                }
            }
            _ => {
                let c = text[i..].chars().next().unwrap_or('\u{fffd}');
                out.push(c);
                i += c.len_utf8().max(1);
            }
        }
    }
    truncate(&mut out);
    Ok(out)
}

/// A parameter's value as LinuxCNC writes it (`snprintf` with `%.Nf`).
fn format_value(value: Option<f64>, decimals: usize) -> String {
    let Some(v) = value else { return NO_VALUE.into() };
    let v = if (v - 0.0).abs() < ZERO_TOL { 0.0 } else { v };
    let s = if v.is_nan() {
        "nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".to_string() } else { "-inf".to_string() }
    } else {
        format!("{v:.decimals$}")
    };
    if s.len() >= VAL_LEN { NO_VALUE.into() } else { s }
}

/// Cuts `text` to [`MAX_TEXT_BYTES`] at a character boundary.
pub(super) fn truncate(text: &mut String) {
    if text.len() > MAX_TEXT_BYTES {
        let mut k = MAX_TEXT_BYTES;
        while !text.is_char_boundary(k) {
            k -= 1;
        }
        text.truncate(k);
    }
}

/// The messages read and not yet taken, at most [`QUEUE_CAP`]: when it is full, the newest
/// message replaces the last one held and counts it as dropped, so the first ones and the
/// latest always come out, in order, and the count says how many are missing between them.
#[derive(Debug, Clone, Default)]
pub struct MessageQueue {
    held: VecDeque<Message>,
    cap: usize,
}

impl MessageQueue {
    pub fn with_cap(cap: usize) -> Self {
        Self { held: VecDeque::new(), cap: cap.max(1) }
    }

    /// Queues `m` (replacing the last one held when full).
    pub fn push(&mut self, mut m: Message) {
        if self.held.len() >= self.cap.max(1) {
            if let Some(last) = self.held.back_mut() {
                m.dropped += last.dropped + 1;
                *last = m;
                return;
            }
        }
        self.held.push_back(m);
    }

    pub fn pop(&mut self) -> Option<Message> {
        self.held.pop_front()
    }

    /// The oldest message held.
    pub fn front(&self) -> Option<&Message> {
        self.held.front()
    }

    pub fn len(&self) -> usize {
        self.held.len()
    }

    pub fn is_empty(&self) -> bool {
        self.held.is_empty()
    }

    pub fn clear(&mut self) {
        self.held.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::params::ParamRef;

    fn params() -> Params {
        let mut p = Params::default();
        p.set(&ParamRef::Numbered(1), 2.5).unwrap();
        p.set(&ParamRef::Numbered(2), -1.0 / 3.0).unwrap();
        p.set(&ParamRef::Named("i".into()), 7.0).unwrap();
        p.set(&ParamRef::Named("_depth".into()), -0.00004).unwrap();
        p
    }

    #[test]
    fn keywords_are_case_insensitive_and_the_text_is_kept_as_written() {
        assert_eq!(parse("MSG,Hello World"), Some((MessageKind::Msg, "Hello World")));
        assert_eq!(parse("  msg, spaced "), Some((MessageKind::Msg, " spaced ")));
        assert_eq!(parse("Debug,x"), Some((MessageKind::Debug, "x")));
        assert_eq!(parse("PRINT,"), Some((MessageKind::Print, "")));
        // The comma must follow the keyword at once (LinuxCNC's `startswith(lc, "msg,")`).
        assert_eq!(parse("MSG ,x"), None);
        assert_eq!(parse("message, x"), None);
        assert_eq!(parse("just a comment"), None);
    }

    #[test]
    fn parameters_are_written_with_six_decimals_as_lf() {
        let p = params();
        assert_eq!(expand("a=#1 b=#2 i=#<i>", &p).unwrap(), "a=2.500000 b=-0.333333 i=7.000000");
        // Blanks and case inside the brackets do not matter.
        assert_eq!(expand("#< I >", &p).unwrap(), "7.000000");
        // Within 1e-4 of zero: zero (LinuxCNC's `equal`), never -0.000000.
        assert_eq!(expand("#<_depth>", &p).unwrap(), "0.000000");
        // Unset numbered parameters read 0, #0 too.
        assert_eq!(expand("#3 #0", &p).unwrap(), "0.000000 0.000000");
    }

    #[test]
    fn formats_switch_for_the_rest_of_the_text() {
        let p = params();
        assert_eq!(expand("%d#1 %f#2 %.2f#<i> #1", &p).unwrap(), "2 -0.3333 7.00 2.50");
        // Not a format: '%' kept, or '.' kept without the '%' (as LinuxCNC).
        assert_eq!(expand("100% %.x", &p).unwrap(), "100% .x");
    }

    #[test]
    fn what_cannot_be_shown_is_hashes_and_a_bad_reference_an_error() {
        let p = params();
        assert_eq!(expand("#<nope> #9999", &p).unwrap(), "###### ######");
        let mut big = Params::default();
        big.set(&ParamRef::Numbered(5), 1e40).unwrap();
        assert_eq!(expand("#5", &big).unwrap(), "######");
        assert_eq!(expand("a # b", &p).unwrap(), "a # b");
        assert!(expand("end #", &p).is_err());
        assert!(expand("#<open", &p).is_err());
        // MSG text is not expanded by the interpreter; expand itself passes plain text through.
        assert_eq!(expand("plain", &p).unwrap(), "plain");
    }

    #[test]
    fn text_is_cut_at_a_character_boundary() {
        let mut s = "é".repeat(200);
        truncate(&mut s);
        assert!(s.len() <= MAX_TEXT_BYTES && s.len() >= MAX_TEXT_BYTES - 1);
        assert!(s.chars().all(|c| c == 'é'));
    }

    #[test]
    fn a_full_queue_keeps_the_first_and_the_latest_and_counts_the_rest() {
        let mut q = MessageQueue::with_cap(3);
        for id in 1..=10 {
            q.push(Message { id, kind: MessageKind::Debug, text: id.to_string(), line: 1, dropped: 0 });
        }
        let got: Vec<(u64, u64)> = std::iter::from_fn(|| q.pop()).map(|m| (m.id, m.dropped)).collect();
        assert_eq!(got, [(1, 0), (2, 0), (10, 7)]);
    }
}
