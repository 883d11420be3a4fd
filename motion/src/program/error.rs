//! Program errors with file, line and column, and the list of all errors found in one program.

use std::fmt;

/// A problem in a program, at a place a person can find: `FILE:LINE:COL: message`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramError {
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column in characters.
    pub col: u32,
    pub message: String,
}

impl fmt::Display for ProgramError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: {}", self.file, self.line, self.col, self.message)
    }
}

impl std::error::Error for ProgramError {}

/// All errors found in one program, in source order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramErrors(pub Vec<ProgramError>);

impl fmt::Display for ProgramErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ProgramErrors {}

/// Most errors reported for one program; after that the parser stops reading.
pub(crate) const MAX_ERRORS: usize = 100;

/// Collects errors with the file name filled in.
#[derive(Debug)]
pub(crate) struct Diagnostics {
    file: String,
    pub errors: Vec<ProgramError>,
    /// Errors found, repeats at one place included: what ends the reading.
    found: usize,
}

impl Diagnostics {
    pub(super) fn new(file: &str) -> Self {
        Self { file: file.to_string(), errors: Vec::new(), found: 0 }
    }

    /// Records an error, unless one was already recorded at the same place: a loop body or a
    /// subroutine executed again repeats its errors, and copies of one line would hide the
    /// others. Repeats still count towards [`MAX_ERRORS`], so such a loop ends the reading as
    /// soon as before.
    pub(super) fn error(&mut self, line: u32, col: u32, message: impl Into<String>) {
        self.found += 1;
        let seen = self.errors.iter().any(|e| e.line == line && e.col == col && e.file == self.file);
        if !seen && self.errors.len() < MAX_ERRORS {
            self.errors.push(ProgramError { file: self.file.clone(), line, col, message: message.into() });
        }
    }

    /// Names `file` in the errors from here on (a subroutine file is being read).
    pub(super) fn set_file(&mut self, file: &str) {
        if self.file != file {
            self.file = file.to_string();
        }
    }

    /// The file the errors name.
    pub(super) fn file(&self) -> &str {
        &self.file
    }

    /// Errors found so far, repeats at one place included.
    pub(super) fn found(&self) -> usize {
        self.found
    }

    pub(super) fn full(&self) -> bool {
        self.found >= MAX_ERRORS
    }
}

/// Numbers in messages: up to 4 decimals, trailing zeros dropped. Every reader of programs
/// (G-code, the cutter compensation, path tables) phrases its errors with it.
pub(crate) fn fmt_num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_repeated_at_one_place_is_reported_once() {
        let mut d = Diagnostics::new("loop.ngc");
        for k in 0..50 {
            d.error(10, 6, format!("X target {k} is outside the travel range"));
        }
        d.error(12, 1, "another");
        d.set_file("sub.ngc");
        d.error(10, 6, "the same place in another file");
        let places: Vec<String> = d.errors.iter().map(|e| format!("{}:{}:{}", e.file, e.line, e.col)).collect();
        assert_eq!(places, ["loop.ngc:10:6", "loop.ngc:12:1", "sub.ngc:10:6"]);
        assert!(d.errors[0].message.starts_with("X target 0 "), "the first one is kept");
        assert!(!d.full());
        for _ in 0..48 {
            d.error(10, 6, "again");
        }
        assert!(d.full(), "repeats end the reading after {MAX_ERRORS} errors found");
        assert_eq!(d.errors.len(), 3);
    }
}
