//! Values of RS274NGC words as LinuxCNC 2.9 reads them: numbers, parameters (`#5`, `##1`,
//! `#<name>`), `[ ]` expressions and unary functions, evaluated as the line is read.
//!
//! Operators and their precedence, highest first (all left-associative, as LinuxCNC's
//! stack evaluator in `read_real_expression`): `**`; `* / MOD`; `+ -`;
//! `EQ NE GT GE LT LE`; `AND OR XOR`. Comparisons give 1 or 0 (EQ, NE, LE, GE with LinuxCNC's
//! tolerance 1e-6); trigonometry is in degrees. Blanks inside values are skipped, letters are
//! case-insensitive.

use super::params::{MAX_NUMBERED, ParamRef, Params};

/// Two numbers compare equal within this (LinuxCNC's `TOLERANCE_EQUAL`).
const TOLERANCE_EQUAL: f64 = 1e-6;
/// An integer value (a parameter number) may miss an integer by this (LinuxCNC's
/// `read_integer_value`).
const INTEGER_TOL: f64 = 1e-4;
/// Deepest nesting of brackets: far beyond real programs; it bounds the recursion.
const MAX_DEPTH: usize = 64;

/// An error at a byte of the line.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct ExprError {
    pub at: usize,
    pub message: String,
}

fn err<T>(at: usize, message: impl Into<String>) -> Result<T, ExprError> {
    Err(ExprError { at, message: message.into() })
}

/// A reader over the bytes of one line.
pub(super) struct Cursor<'a> {
    pub b: &'a [u8],
    pub i: usize,
    depth: usize,
}

impl<'a> Cursor<'a> {
    pub(super) fn new(b: &'a [u8], i: usize) -> Self {
        Self { b, i, depth: 0 }
    }

    pub(super) fn skip_blanks(&mut self) {
        while self.i < self.b.len() && (self.b[self.i] == b' ' || self.b[self.i] == b'\t') {
            self.i += 1;
        }
    }

    pub(super) fn peek(&mut self) -> Option<u8> {
        self.skip_blanks();
        self.b.get(self.i).map(u8::to_ascii_lowercase)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::Pow => 6,
            Op::Mul | Op::Div | Op::Mod => 5,
            Op::Add | Op::Sub => 4,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 3,
            Op::And | Op::Or | Op::Xor => 2,
        }
    }

    fn apply(self, a: f64, b: f64, at: usize) -> Result<f64, ExprError> {
        let t = |c: bool| if c { 1.0 } else { 0.0 };
        Ok(match self {
            Op::Pow => {
                if a < 0.0 && b.floor() != b {
                    return err(at, "a negative number raised to a non-integer power");
                }
                a.powf(b)
            }
            Op::Mul => a * b,
            Op::Div => {
                if b == 0.0 {
                    return err(at, "division by zero");
                }
                a / b
            }
            Op::Mod => {
                // LinuxCNC: always a non-negative result.
                let r = a % b;
                if r < 0.0 { r + b.abs() } else { r }
            }
            Op::Add => a + b,
            Op::Sub => a - b,
            Op::Eq => t((a - b).abs() < TOLERANCE_EQUAL),
            Op::Ne => t((a - b).abs() >= TOLERANCE_EQUAL),
            Op::Gt => t(a > b),
            Op::Ge => t((a - b).abs() < TOLERANCE_EQUAL || a >= b),
            Op::Lt => t(a < b),
            Op::Le => t((a - b).abs() < TOLERANCE_EQUAL || a <= b),
            Op::And => t(a != 0.0 && b != 0.0),
            Op::Or => t(a != 0.0 || b != 0.0),
            Op::Xor => t((a != 0.0) != (b != 0.0)),
        })
    }
}

/// The operator at the cursor, if any (not consumed).
fn peek_op(c: &mut Cursor) -> Option<(Op, usize)> {
    c.skip_blanks();
    let rest = &c.b[c.i.min(c.b.len())..];
    let lower = |n: usize| rest.get(..n).map(|s| s.to_ascii_lowercase());
    if rest.starts_with(b"**") {
        return Some((Op::Pow, 2));
    }
    let one = match rest.first() {
        Some(b'*') => Some(Op::Mul),
        Some(b'/') => Some(Op::Div),
        Some(b'+') => Some(Op::Add),
        Some(b'-') => Some(Op::Sub),
        _ => None,
    };
    if let Some(op) = one {
        return Some((op, 1));
    }
    if let Some(three) = lower(3) {
        let op = match &three[..] {
            b"mod" => Some(Op::Mod),
            b"and" => Some(Op::And),
            b"xor" => Some(Op::Xor),
            _ => None,
        };
        if let Some(op) = op {
            return Some((op, 3));
        }
    }
    let two = lower(2)?;
    let op = match &two[..] {
        b"eq" => Op::Eq,
        b"ne" => Op::Ne,
        b"gt" => Op::Gt,
        b"ge" => Op::Ge,
        b"lt" => Op::Lt,
        b"le" => Op::Le,
        b"or" => Op::Or,
        _ => return None,
    };
    Some((op, 2))
}

/// `[ expression ]` at the cursor.
pub(super) fn bracketed(c: &mut Cursor, p: &Params) -> Result<f64, ExprError> {
    let open = c.i;
    if c.peek() != Some(b'[') {
        return err(c.i, "expected '['");
    }
    c.i += 1;
    c.depth += 1;
    if c.depth > MAX_DEPTH {
        return err(open, format!("expression nested deeper than {MAX_DEPTH} brackets"));
    }
    let v = binary(c, p, 0)?;
    if c.peek() != Some(b']') {
        return match c.peek() {
            None => err(open, "'[' is not closed with ']' on this line"),
            Some(_) => err(c.i, "expected an operator or ']' in the expression"),
        };
    }
    c.i += 1;
    c.depth -= 1;
    Ok(v)
}

/// Precedence climbing: operands joined by operators of precedence above `min`.
fn binary(c: &mut Cursor, p: &Params, min: u8) -> Result<f64, ExprError> {
    let mut left = real_value(c, p)?;
    while let Some((op, len)) = peek_op(c) {
        if op.precedence() <= min {
            break;
        }
        let at = c.i;
        c.i += len;
        let right = binary(c, p, op.precedence())?;
        left = finite(op.apply(left, right, at)?, at)?;
    }
    Ok(left)
}

fn finite(v: f64, at: usize) -> Result<f64, ExprError> {
    if v.is_nan() {
        return err(at, "the calculation gives no number (NaN)");
    }
    if v.is_infinite() {
        return err(at, "the calculation gives infinity");
    }
    Ok(v)
}

/// A value: a number, a parameter, a bracketed expression, a unary function, each optionally
/// preceded by a sign.
pub(super) fn real_value(c: &mut Cursor, p: &Params) -> Result<f64, ExprError> {
    let at = c.i;
    match c.peek() {
        None => err(c.i, "a value is missing here"),
        Some(b'[') => bracketed(c, p),
        Some(b'#') => {
            let r = param_ref(c, p)?;
            p.read(&r).map_err(|m| ExprError { at, message: m })
        }
        Some(b'+' | b'-') if !c.b.get(c.i + 1).is_some_and(|b| b.is_ascii_digit() || *b == b'.') => {
            let neg = c.b[c.i] == b'-';
            c.i += 1;
            c.depth += 1;
            if c.depth > MAX_DEPTH {
                return err(at, "too many signs");
            }
            let v = real_value(c, p)?;
            c.depth -= 1;
            Ok(if neg { -v } else { v })
        }
        Some(b) if b.is_ascii_alphabetic() => function(c, p),
        Some(_) => number(c),
    }
}

/// A decimal number with an optional sign (no exponent, as RS274).
pub(super) fn number(c: &mut Cursor) -> Result<f64, ExprError> {
    c.skip_blanks();
    let start = c.i;
    if matches!(c.b.get(c.i), Some(b'+' | b'-')) {
        c.i += 1;
    }
    let (mut digits, mut point) = (0, false);
    while let Some(&b) = c.b.get(c.i) {
        if b.is_ascii_digit() {
            digits += 1;
        } else if b == b'.' && !point {
            point = true;
        } else {
            break;
        }
        c.i += 1;
    }
    if digits == 0 {
        return err(start, "a number is expected here");
    }
    let text = std::str::from_utf8(&c.b[start..c.i]).unwrap_or("");
    let v: f64 = text.parse().map_err(|_| ExprError { at: start, message: format!("'{text}' is not a number") })?;
    finite(v, start)
}

/// `NAME[…]` (and `ATAN[…]/[…]`).
fn function(c: &mut Cursor, p: &Params) -> Result<f64, ExprError> {
    let at = c.i;
    let start = c.i;
    while c.b.get(c.i).is_some_and(u8::is_ascii_alphabetic) {
        c.i += 1;
    }
    let name = String::from_utf8_lossy(&c.b[start..c.i]).to_ascii_lowercase();
    const NAMES: [&str; 14] =
        ["abs", "acos", "asin", "atan", "cos", "exists", "exp", "fix", "fup", "ln", "round", "sin", "sqrt", "tan"];
    if !NAMES.contains(&name.as_str()) {
        return err(at, format!("unknown function or word '{}' in a value", name.to_ascii_uppercase()));
    }
    if c.peek() != Some(b'[') {
        return err(c.i, format!("{} needs its argument in [ ]", name.to_ascii_uppercase()));
    }
    if name == "exists" {
        c.i += 1;
        let r = param_ref_in(c, p, false)?;
        if c.peek() != Some(b']') {
            return err(c.i, "EXISTS takes one parameter: EXISTS[#<name>]");
        }
        c.i += 1;
        return Ok(match r {
            ParamRef::Named(n) => f64::from(u8::from(p.exists(&n))),
            ParamRef::Numbered(n) => f64::from(u8::from((1..=MAX_NUMBERED).contains(&n))),
        });
    }
    let x = bracketed(c, p)?;
    let deg = std::f64::consts::PI / 180.0;
    let v = match name.as_str() {
        "abs" => x.abs(),
        "acos" | "asin" if !(-1.0..=1.0).contains(&x) => {
            return err(at, format!("{} of {x}: the argument must lie in [-1, 1]", name.to_ascii_uppercase()));
        }
        "acos" => x.acos() / deg,
        "asin" => x.asin() / deg,
        "atan" => {
            if c.peek() != Some(b'/') {
                return err(c.i, "ATAN takes two arguments: ATAN[y]/[x]");
            }
            c.i += 1;
            let d = bracketed(c, p)?;
            x.atan2(d) / deg
        }
        "cos" => (x * deg).cos(),
        "exp" => x.exp(),
        "fix" => x.floor(),
        "fup" => x.ceil(),
        "ln" if x <= 0.0 => return err(at, format!("LN of {x}: the argument must be positive")),
        "ln" => x.ln(),
        // LinuxCNC: half away from zero.
        "round" => (x + if x < 0.0 { -0.5 } else { 0.5 }).trunc(),
        "sin" => (x * deg).sin(),
        "sqrt" if x < 0.0 => return err(at, format!("SQRT of {x}: the argument must not be negative")),
        "sqrt" => x.sqrt(),
        _ => (x * deg).tan(),
    };
    finite(v, at)
}

/// The parameter named at the cursor (`#`): `#5`, `#[expr]`, `##1`, `#<name>`.
pub(super) fn param_ref(c: &mut Cursor, p: &Params) -> Result<ParamRef, ExprError> {
    param_ref_in(c, p, true)
}

/// A parameter reference; with `range_checked` false a number outside 1 … MAX_NUMBERED is no
/// error (`EXISTS[#99999]` is 0 in LinuxCNC): it comes back as `Numbered` out of that range.
fn param_ref_in(c: &mut Cursor, p: &Params, range_checked: bool) -> Result<ParamRef, ExprError> {
    let at = c.i;
    if c.peek() != Some(b'#') {
        return err(c.i, "expected '#'");
    }
    c.i += 1;
    if c.peek() == Some(b'<') {
        c.i += 1;
        let mut name = String::new();
        loop {
            match c.b.get(c.i) {
                None => return err(at, "named parameter '#<' is not closed with '>'"),
                Some(b'>') => break,
                Some(b' ' | b'\t') => {}
                Some(&b) if b.is_ascii() && b != b'[' && b != b']' && b != b'#' => {
                    name.push(char::from(b.to_ascii_lowercase()))
                }
                Some(_) => return err(c.i, "a parameter name holds letters, digits and '_' only"),
            }
            c.i += 1;
        }
        c.i += 1;
        if name.is_empty() {
            return err(at, "empty parameter name '#<>'");
        }
        return Ok(ParamRef::Named(name));
    }
    let n = real_value(c, p)?;
    let k = n.round();
    if (n - k).abs() > INTEGER_TOL {
        return err(at, format!("parameter number {n} is not an integer"));
    }
    if !(1.0..=MAX_NUMBERED as f64).contains(&k) {
        if !range_checked {
            return Ok(ParamRef::Numbered(0));
        }
        return err(at, format!("parameter number {k} is out of range (1 – {MAX_NUMBERED})"));
    }
    Ok(ParamRef::Numbered(k as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(text: &str) -> Result<f64, ExprError> {
        let mut p = Params::default();
        p.set(&ParamRef::Numbered(1), 3.0).unwrap();
        p.set(&ParamRef::Numbered(3), 7.0).unwrap();
        p.set(&ParamRef::Named("r".into()), 2.0).unwrap();
        let mut c = Cursor::new(text.as_bytes(), 0);
        let v = real_value(&mut c, &p)?;
        assert_eq!(c.peek(), None, "{text}: all read");
        Ok(v)
    }

    #[test]
    fn precedence_and_functions_as_linuxcnc() {
        let cases = [
            ("[1 + 2 * 3]", 7.0),
            ("[2 ** 3 ** 2]", 64.0),
            ("[10 - 4 - 3]", 3.0),
            ("[1 + 1 EQ 2]", 1.0),
            ("[1 LT 2 AND 3 GT 4]", 0.0),
            ("[1 or 0 xor 1]", 0.0),
            ("[-7 MOD 3]", 2.0),
            ("[#1 * #<r>]", 6.0),
            ("##1", 7.0),
            ("#[1+2]", 7.0),
            ("-#1", -3.0),
            ("-[1+1]", -2.0),
            ("SIN[30]", 0.5),
            ("[ATAN[1]/[1]]", 45.0),
            ("ROUND[-2.5]", -3.0),
            ("FIX[-2.5]", -3.0),
            ("FUP[2.1]", 3.0),
            ("sqrt[16]", 4.0),
            ("[EXISTS[#<r>] + EXISTS[#<q>]]", 1.0),
            // LinuxCNC's tests/interp/exists: a number out of range does not exist.
            ("[EXISTS[#1] + EXISTS[#99999] * 10]", 1.0),
            ("[3 / 2]", 1.5),
            ("[1 GE 1.0000001]", 1.0),
        ];
        for (text, want) in cases {
            let v = eval(text).unwrap_or_else(|e| panic!("{text}: {e:?}"));
            assert!((v - want).abs() < 1e-9, "{text} = {v}, want {want}");
        }
    }

    #[test]
    fn errors_name_their_byte() {
        for (text, at, msg) in [
            ("[1/0]", 2, "division by zero"),
            ("[1/[2-2]]", 2, "division by zero"),
            ("SQRT[-1]", 0, "SQRT"),
            ("ACOS[2]", 0, "ACOS"),
            ("LN[0]", 0, "LN"),
            ("#<nope>", 0, "not defined"),
            ("#6000", 0, "out of range"),
            ("[1 + 2", 0, "not closed"),
            ("[1 2]", 3, "expected an operator"),
            ("FOO[1]", 0, "unknown function"),
            ("[-2 ** 0.5]", 4, "non-integer power"),
        ] {
            let e = eval(text).expect_err(text);
            assert_eq!(e.at, at, "{text}: {e:?}");
            assert!(e.message.contains(msg), "{text}: {}", e.message);
        }
        let deep = format!("{}1{}", "[".repeat(200), "]".repeat(200));
        assert!(eval(&deep).unwrap_err().message.contains("nested deeper"));
    }
}
