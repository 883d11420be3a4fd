//! Splits one line of RS274 / ISO 6983 text into words.
//!
//! A word is a letter and a number (`X-12.5`, `G1`, `F600`); letters are case-insensitive and
//! blanks between the letter and its number are allowed. `( … )` is a comment inside a line,
//! `;` starts a comment that runs to the end of the line (in G06 spline data it also ends a
//! span). A line holding only `%` marks the start or end of a tape and is skipped.
//!
//! A word's value may be a parameter or an expression (`X[#1 + 2]`, `G#5`, `Y-#<depth>`),
//! evaluated as the line is read with the parameter values from before the line; `#… = value`
//! assignments are collected and take effect after the whole line is read (as LinuxCNC). An
//! `O` word opens a control-flow line (`o100 while [#1 LT 3]`), returned unevaluated: its
//! arguments are read only when it executes.

use super::expr::{self, Cursor, ExprError};
use super::params::{ParamRef, Params};

/// One word with the column (1-based, characters) of its letter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Word {
    pub letter: char,
    pub value: f64,
    pub col: u32,
    /// The number had a decimal point (G-codes like G6.1 and integer words like N care).
    pub has_point: bool,
}

/// A lexed line.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Line {
    pub words: Vec<Word>,
    /// Column of the `;` if the line has one.
    pub semicolon_col: Option<u32>,
    /// Column just after the last word (for "expected … here" messages).
    pub end_col: u32,
    /// Nothing but blanks (no words, no comments).
    pub blank: bool,
    /// The line holds only `%` (a tape mark).
    pub percent: bool,
    /// Bytes of the text inside the line's last `( … )` comment (LinuxCNC keeps the last one of
    /// a block): an operator message may be there.
    pub comment: Option<(usize, usize)>,
}

/// A parameter assignment of a line: the parameter, its new value and the column of its `#`.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Assign {
    pub param: ParamRef,
    pub value: f64,
    pub col: u32,
}

/// The O word of a control-flow line: `o<name> keyword …` or `o123 keyword …`.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct OWord {
    /// `123` or the name in lower case.
    pub name: String,
    pub col: u32,
    /// Lower case (`sub`, `call`, `while` …); empty if none.
    pub keyword: String,
    pub keyword_col: u32,
    /// Byte where the arguments start (read with [`o_args`]).
    pub rest_at: usize,
}

/// A lexed line with what RS274NGC adds to words.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Lexed {
    pub line: Line,
    pub assigns: Vec<Assign>,
    pub oword: Option<OWord>,
}

/// A lexing error: column and message.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LexError {
    pub col: u32,
    pub message: String,
}

/// Lexes one line without parameters (a `#` reads 0 or is undefined).
#[cfg(test)]
pub(super) fn lex_line(text: &str) -> Result<Line, LexError> {
    lex_block(text, &Params::default()).map(|l| l.line)
}

/// The column (1-based, characters) of byte `at` of `text`.
pub(super) fn col_of(text: &str, at: usize) -> u32 {
    let at = at.min(text.len());
    let mut k = at;
    while !text.is_char_boundary(k) {
        k -= 1;
    }
    text[..k].chars().count() as u32 + 1
}

fn expr_error(text: &str, e: ExprError) -> LexError {
    LexError { col: col_of(text, e.at), message: e.message }
}

/// The O word of a line and nothing else (for lines skipped by control flow: their values are
/// not evaluated). None if the line has none.
pub(super) fn o_word_only(text: &str, params: &Params) -> Option<OWord> {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() && b[i].is_ascii_whitespace() {
        i += 1;
    }
    // A block number may come first.
    if matches!(b.get(i), Some(b'n' | b'N')) {
        i += 1;
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.' || b[i].is_ascii_whitespace()) {
            i += 1;
        }
    }
    if !matches!(b.get(i), Some(b'o' | b'O')) {
        return None;
    }
    read_o_word(text, i, params).ok()
}

/// Reads `O<name> keyword` from byte `i` (at the `O`).
fn read_o_word(text: &str, i: usize, params: &Params) -> Result<OWord, LexError> {
    let b = text.as_bytes();
    let col = col_of(text, i);
    let mut c = Cursor::new(b, i + 1);
    let name = match c.peek() {
        Some(b'<') => {
            c.i += 1;
            let mut name = String::new();
            loop {
                match b.get(c.i) {
                    None => return Err(LexError { col, message: "O word name '<' is not closed with '>'".into() }),
                    Some(b'>') => break,
                    Some(b' ' | b'\t') => {}
                    Some(&x) if x.is_ascii() => name.push(char::from(x.to_ascii_lowercase())),
                    Some(_) => {
                        return Err(LexError {
                            col: col_of(text, c.i),
                            message: "an O word name holds ASCII letters, digits and '_' only".into(),
                        });
                    }
                }
                c.i += 1;
            }
            c.i += 1;
            if name.is_empty() {
                return Err(LexError { col, message: "empty O word name 'o<>'".into() });
            }
            name
        }
        Some(x) if x.is_ascii_digit() || x == b'#' || x == b'[' => {
            // A number, or one computed as LinuxCNC allows (`o#<sub> call`, `O[#2 * 10] call`).
            let v = if x.is_ascii_digit() {
                expr::number(&mut c).map_err(|e| expr_error(text, e))?
            } else {
                expr::real_value(&mut c, params).map_err(|e| expr_error(text, e))?
            };
            if v.fract() != 0.0 || v < 0.0 {
                return Err(LexError {
                    col,
                    message: format!("O word number must be a non-negative integer, got {v}"),
                });
            }
            format!("{}", v as u64)
        }
        _ => return Err(LexError { col, message: "O word needs a number or a <name>".into() }),
    };
    c.skip_blanks();
    let keyword_at = c.i;
    while b.get(c.i).is_some_and(u8::is_ascii_alphabetic) {
        c.i += 1;
    }
    let keyword = text[keyword_at..c.i].to_ascii_lowercase();
    Ok(OWord { name, col, keyword, keyword_col: col_of(text, keyword_at), rest_at: c.i })
}

/// The values after an O word's keyword (`[…] […]`, up to a comment or the end): the
/// arguments of `call`, the condition of `if`/`while`, the count of `repeat`.
pub(super) fn o_args(text: &str, at: usize, params: &Params) -> Result<Vec<f64>, LexError> {
    let b = text.as_bytes();
    let mut c = Cursor::new(b, at);
    let mut out = Vec::new();
    loop {
        match c.peek() {
            None | Some(b';') => return Ok(out),
            Some(b'(') => match text[c.i..].find(')') {
                Some(off) => c.i += off + 1,
                None => {
                    return Err(LexError {
                        col: col_of(text, c.i),
                        message: "comment '(' is not closed with ')' on this line".into(),
                    });
                }
            },
            Some(b'[') => out.push(expr::bracketed(&mut c, params).map_err(|e| expr_error(text, e))?),
            Some(_) => {
                return Err(LexError {
                    col: col_of(text, c.i),
                    message: "an O word takes only [ ] values after its keyword".into(),
                });
            }
        }
    }
}

/// Lexes one line (without its line terminator), evaluating word values with `params`.
///
/// Works on the bytes of the line (numbers and letters are ASCII) and counts columns in
/// characters, so a comment with non-ASCII text before a word keeps its column right.
pub(super) fn lex_block(text: &str, params: &Params) -> Result<Lexed, LexError> {
    let bytes = text.as_bytes();
    let mut line = Line { blank: true, ..Line::default() };
    let mut assigns = Vec::new();
    let trimmed = text.trim();
    if trimmed == "%" {
        line.blank = false;
        line.percent = true;
        return Ok(Lexed { line, ..Lexed::default() });
    }
    // Byte index into the line and the 1-based column (in characters) of the character there.
    let (mut i, mut col) = (0usize, 1u32);
    while i < bytes.len() {
        let c = char_at(text, i);
        let here = col;
        if c.is_whitespace() {
            i += c.len_utf8();
            col += 1;
            continue;
        }
        line.blank = false;
        match c {
            '(' => match text[i..].find(')') {
                Some(off) => {
                    col += text[i..=i + off].chars().count() as u32;
                    line.comment = Some((i + 1, i + off));
                    i += off + 1;
                }
                None => {
                    return Err(LexError {
                        col: here,
                        message: "comment '(' is not closed with ')' on this line".into(),
                    });
                }
            },
            ';' => {
                line.semicolon_col = Some(here);
                break;
            }
            // `@` and `^`: LinuxCNC's polar radius and angle, words like the letters.
            c if c.is_ascii_alphabetic() || c == '@' || c == '^' => {
                let letter = c.to_ascii_uppercase();
                if letter == 'O' {
                    // An O word opens a control-flow line whose keywords are no words; only a
                    // block number may come before it.
                    if line.words.iter().any(|w| w.letter != 'N') || !assigns.is_empty() {
                        return Err(LexError { col: here, message: "an O word must begin its line".into() });
                    }
                    let o = read_o_word(text, i, params)?;
                    line.end_col = col_of(text, o.rest_at);
                    return Ok(Lexed { line, assigns, oword: Some(o) });
                }
                // From here on only ASCII bytes are consumed: one byte is one column.
                let letter_at = i;
                i += 1;
                while i < bytes.len() && (bytes[i] == b' ' || bytes[i] == b'\t') {
                    i += 1;
                }
                let start = i;
                if starts_expression(bytes, i) {
                    let mut cur = Cursor::new(bytes, i);
                    let value = expr::real_value(&mut cur, params).map_err(|e| expr_error(text, e))?;
                    i = cur.i;
                    col = col_of(text, i);
                    line.words.push(Word { letter, value, col: here, has_point: value.fract() != 0.0 });
                    line.end_col = col;
                    continue;
                }
                if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
                    i += 1;
                }
                let mut digits = 0;
                let mut has_point = false;
                while i < bytes.len() && (bytes[i].is_ascii_digit() || (bytes[i] == b'.' && !has_point)) {
                    if bytes[i] == b'.' {
                        has_point = true;
                    } else {
                        digits += 1;
                    }
                    i += 1;
                }
                col = here + (i - letter_at) as u32;
                if digits == 0 {
                    return Err(LexError { col: here, message: format!("word '{letter}' has no number") });
                }
                let number = &text[start..i];
                if let Some(exponent) = exponent_at(bytes, i) {
                    let exponent = &text[i..i + exponent];
                    return Err(LexError {
                        col: here,
                        message: format!(
                            "'{letter}{number}{exponent}': a number with an exponent is not G-code (write it in decimals)"
                        ),
                    });
                }
                let value = parse_decimal(number)
                    .ok_or_else(|| LexError { col: here, message: format!("'{letter}{number}' is not a number") })?;
                if !value.is_finite() {
                    return Err(LexError { col: here, message: format!("number of '{letter}' is out of range") });
                }
                line.words.push(Word { letter, value, col: here, has_point });
                line.end_col = col;
            }
            '#' => {
                let mut cur = Cursor::new(bytes, i);
                let param = expr::param_ref(&mut cur, params).map_err(|e| expr_error(text, e))?;
                if cur.peek() != Some(b'=') {
                    return Err(LexError {
                        col: col_of(text, cur.i),
                        message: format!("expected '=' after {param} (a parameter assignment)"),
                    });
                }
                cur.i += 1;
                let value = expr::real_value(&mut cur, params).map_err(|e| expr_error(text, e))?;
                assigns.push(Assign { param, value, col: here });
                i = cur.i;
                col = col_of(text, i);
                line.end_col = col;
            }
            '/' if line.words.is_empty() => {
                return Err(LexError { col: here, message: "block delete '/' is not supported".into() });
            }
            _ => return Err(LexError { col: here, message: format!("unexpected character '{c}'") }),
        }
    }
    if line.end_col == 0 {
        line.end_col = 1;
    }
    Ok(Lexed { line, assigns, oword: None })
}

/// Whether a word's value at byte `i` is more than a plain number: a parameter, a bracketed
/// expression, a function, or a sign before one of these.
fn starts_expression(b: &[u8], i: usize) -> bool {
    match b.get(i) {
        Some(b'[' | b'#') => true,
        Some(b'+' | b'-') => {
            matches!(b.get(i + 1), Some(b'[' | b'#')) || b.get(i + 1).is_some_and(u8::is_ascii_alphabetic)
        }
        Some(c) if c.is_ascii_alphabetic() => {
            let rest = &b[i..];
            let name_len = rest.iter().take_while(|c| c.is_ascii_alphabetic()).count();
            let after = rest[name_len..].iter().find(|c| **c != b' ' && **c != b'\t');
            after == Some(&b'[')
        }
        _ => false,
    }
}

/// The powers of ten an f64 holds exactly: 10^0 … 10^22.
const EXACT_POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];
/// Largest mantissa the fast path takes: every integer up to 2^53 is an exact f64.
const FAST_MAX_MANTISSA: u64 = 1 << 53;

/// The value of a lexed number (sign, digits, at most one point), correctly rounded.
///
/// A CAM program is millions of numbers like `-12.3456`: their digits form an integer below
/// 2^53 and the decimals a power of ten of at most 10^22, both exact in an f64, so one
/// division rounds correctly (Clinger 1990, the fast path). Anything else goes to the
/// standard parser.
fn parse_decimal(number: &str) -> Option<f64> {
    let bytes = number.as_bytes();
    let (negative, digits) = match bytes.first() {
        Some(b'-') => (true, &bytes[1..]),
        Some(b'+') => (false, &bytes[1..]),
        _ => (false, bytes),
    };
    let mut mantissa: u64 = 0;
    let mut decimals: usize = 0;
    let mut after_point = false;
    for &b in digits {
        if b == b'.' {
            after_point = true;
            continue;
        }
        let d = u64::from(b.wrapping_sub(b'0'));
        mantissa = match mantissa.checked_mul(10).and_then(|m| m.checked_add(d)) {
            Some(m) if d < 10 && m <= FAST_MAX_MANTISSA => m,
            _ => return number.parse().ok(),
        };
        decimals += usize::from(after_point);
    }
    let Some(&scale) = EXACT_POW10.get(decimals) else {
        return number.parse().ok();
    };
    let magnitude = mantissa as f64 / scale;
    Some(if negative { -magnitude } else { magnitude })
}

/// The character starting at byte `i` of `text` (a character boundary).
fn char_at(text: &str, i: usize) -> char {
    match text.as_bytes()[i] {
        b if b.is_ascii() => b as char,
        _ => text[i..].chars().next().expect("a character starts at a boundary"),
    }
}

/// Length in bytes of the exponent (`e300`, `E-3`) that follows a number at byte `i`, if
/// any. RS274 numbers have none: LinuxCNC reads `1e300` as the number 1 and an E word, so a
/// program written for a language with exponents would silently lose it.
fn exponent_at(bytes: &[u8], i: usize) -> Option<usize> {
    if !matches!(bytes.get(i), Some(b'e' | b'E')) {
        return None;
    }
    let mut j = i + 1;
    if matches!(bytes.get(j), Some(b'+' | b'-')) {
        j += 1;
    }
    let digits_start = j;
    while bytes.get(j).is_some_and(|c| c.is_ascii_digit()) {
        j += 1;
    }
    (j > digits_start).then_some(j - i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_comments_and_columns() {
        let l = lex_line("N10 g1 X-1.5 (move) y 2. F600 ; done").unwrap();
        let letters: Vec<char> = l.words.iter().map(|w| w.letter).collect();
        assert_eq!(letters, ['N', 'G', 'X', 'Y', 'F']);
        assert_eq!(l.words[2].value, -1.5);
        assert_eq!(l.words[2].col, 8);
        assert_eq!(l.words[3].value, 2.0);
        assert_eq!(l.semicolon_col, Some(31));
    }

    #[test]
    fn errors_have_columns() {
        assert_eq!(lex_line("G1 X").unwrap_err().col, 4);
        assert_eq!(lex_line("G1 (open").unwrap_err().col, 4);
        assert_eq!(lex_line("G1 X1 $").unwrap_err().col, 7);
        assert_eq!(lex_line("X1..2").unwrap_err().col, 4);
    }

    #[test]
    fn huge_number_is_rejected() {
        let text = format!("X{}", "9".repeat(400));
        assert!(lex_line(&text).unwrap_err().message.contains("out of range"));
    }

    #[test]
    fn exponent_is_an_error_at_the_number() {
        for (text, col, shown) in
            [("G1 X1e300 F100", 4, "'X1e300'"), ("G0 Y 2.5E-3", 4, "'Y2.5E-3'"), ("F1e+3", 1, "'F1e+3'")]
        {
            let e = lex_line(text).unwrap_err();
            assert_eq!(e.col, col, "{text}");
            assert!(e.message.starts_with(shown), "{text}: {}", e.message);
        }
        // An E word after a blank, or an `e` without digits, is a separate word.
        assert_eq!(lex_line("G0 X1 E3").unwrap().words.len(), 3);
        assert!(lex_line("G0 X1E").unwrap_err().message.contains("'E' has no number"));
    }

    #[test]
    fn decimals_parse_as_the_standard_parser_does() {
        use proptest::prelude::RngCore;
        let mut rng = proptest::test_runner::TestRng::deterministic_rng(proptest::test_runner::RngAlgorithm::ChaCha);
        for _ in 0..200_000 {
            // Numbers of 0-20 digits with a point anywhere, both signs.
            let x = rng.next_u64();
            let digits = (x % 21) as usize;
            let mut text = String::from(["", "-", "+"][(x >> 8) as usize % 3]);
            let point = (x >> 16) as usize % (digits + 1);
            for k in 0..digits {
                if k == point {
                    text.push('.');
                }
                text.push(char::from(b'0' + ((x >> (k % 50)) % 10) as u8));
            }
            if digits == 0 {
                text.push('7');
            }
            let want: f64 = text.parse().unwrap();
            assert_eq!(parse_decimal(&text).map(f64::to_bits), Some(want.to_bits()), "{text}");
        }
        for text in ["0.1", "-0.0", "12.3456", "9007199254740993", "1.00000000000000000000001", "123456789.987654321"] {
            assert_eq!(parse_decimal(text).map(f64::to_bits), text.parse::<f64>().ok().map(f64::to_bits), "{text}");
        }
    }

    #[test]
    fn percent_and_blank() {
        assert!(lex_line("  ").unwrap().blank);
        assert!(!lex_line("%").unwrap().blank);
        assert!(lex_line(" % ").unwrap().percent);
        assert!(!lex_line("(only a comment)").unwrap().blank);
    }
}
