//! Splits one line of RS274 / ISO 6983 text into words.
//!
//! A word is a letter and a number (`X-12.5`, `G1`, `F600`); letters are case-insensitive and
//! blanks between the letter and its number are allowed. `( … )` is a comment inside a line,
//! `;` starts a comment that runs to the end of the line (in G06 spline data it also ends a
//! span). A line holding only `%` marks the start or end of a tape and is skipped.

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
}

/// A lexing error: column and message.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LexError {
    pub col: u32,
    pub message: String,
}

/// Lexes one line (without its line terminator).
pub(super) fn lex_line(text: &str) -> Result<Line, LexError> {
    let chars: Vec<char> = text.chars().collect();
    let mut line = Line { blank: true, ..Line::default() };
    let trimmed = text.trim();
    if trimmed == "%" {
        line.blank = false;
        line.percent = true;
        return Ok(line);
    }
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let col = (i + 1) as u32;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        line.blank = false;
        match c {
            '(' => match chars[i..].iter().position(|&c| c == ')') {
                Some(off) => i += off + 1,
                None => {
                    return Err(LexError { col, message: "comment '(' is not closed with ')' on this line".into() });
                }
            },
            ';' => {
                line.semicolon_col = Some(col);
                break;
            }
            c if c.is_ascii_alphabetic() => {
                let letter = c.to_ascii_uppercase();
                if letter == 'O' {
                    // An O word opens a subroutine or loop line whose keywords are no words.
                    return Err(LexError {
                        col,
                        message: "O word: subroutines and loops (O codes) are not supported".into(),
                    });
                }
                i += 1;
                while i < chars.len() && (chars[i] == ' ' || chars[i] == '\t') {
                    i += 1;
                }
                let start = i;
                if i < chars.len() && (chars[i] == '+' || chars[i] == '-') {
                    i += 1;
                }
                let mut digits = 0;
                let mut has_point = false;
                while i < chars.len() && (chars[i].is_ascii_digit() || (chars[i] == '.' && !has_point)) {
                    if chars[i] == '.' {
                        has_point = true;
                    } else {
                        digits += 1;
                    }
                    i += 1;
                }
                if digits == 0 {
                    return Err(LexError { col, message: format!("word '{letter}' has no number") });
                }
                let number: String = chars[start..i].iter().collect();
                if let Some(exponent) = exponent_at(&chars, i) {
                    return Err(LexError {
                        col,
                        message: format!(
                            "'{letter}{number}{exponent}': a number with an exponent is not G-code (write it in decimals)"
                        ),
                    });
                }
                let value: f64 = number
                    .parse()
                    .map_err(|_| LexError { col, message: format!("'{letter}{number}' is not a number") })?;
                if !value.is_finite() {
                    return Err(LexError { col, message: format!("number of '{letter}' is out of range") });
                }
                line.words.push(Word { letter, value, col, has_point });
                line.end_col = (i + 1) as u32;
            }
            '/' if line.words.is_empty() => {
                return Err(LexError { col, message: "block delete '/' is not supported".into() });
            }
            _ => return Err(LexError { col, message: format!("unexpected character '{c}'") }),
        }
    }
    if line.end_col == 0 {
        line.end_col = 1;
    }
    Ok(line)
}

/// The exponent (`e300`, `E-3`) that follows a number at `i`, if any. RS274 numbers have
/// none: LinuxCNC reads `1e300` as the number 1 and an E word, so a program written for a
/// language with exponents would silently lose it.
fn exponent_at(chars: &[char], i: usize) -> Option<String> {
    if !matches!(chars.get(i), Some('e' | 'E')) {
        return None;
    }
    let mut j = i + 1;
    if matches!(chars.get(j), Some('+' | '-')) {
        j += 1;
    }
    let digits_start = j;
    while chars.get(j).is_some_and(|c| c.is_ascii_digit()) {
        j += 1;
    }
    (j > digits_start).then(|| chars[i..j].iter().collect())
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
    fn percent_and_blank() {
        assert!(lex_line("  ").unwrap().blank);
        assert!(!lex_line("%").unwrap().blank);
        assert!(lex_line(" % ").unwrap().percent);
        assert!(!lex_line("(only a comment)").unwrap().blank);
    }
}
