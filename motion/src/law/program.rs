//! The program statement for law moves; the daemon and `interpd check` read programs of them:
//!
//! ```text
//! LAW PRESET=rr7 DURATION=0.8 X=10 Y=-5            ; 7th-order R-R, 0.8 s, X +10 mm, Y −5 mm
//! LAW PRESET=rr7 COND=0,0.4,0.45 DURATION=1 A=90 STRETCH
//! LAW COND=0,0,0 COND=0,1,1 COND=1,0,0 COND=1,1,0 COND=2,0,0 COND=2,1,0 DURATION=0.5 Z=-20
//! ```
//!
//! One line, whitespace-separated `KEY=VALUE` words after the keyword `LAW` (case-insensitive),
//! mirroring `interpd law`'s options: `PRESET=` (at most once) and `COND=I,Z,F` (any number,
//! added to the preset's), `DURATION=` in seconds, one `<axis letter>=<stroke>` per moving axis
//! (incremental, in the axis unit; the move starts where the previous block ended), and the
//! flag `STRETCH` (grow the duration to the shortest feasible one instead of rejecting the
//! move). `;` starts a comment.

use super::condition::{Condition, LawError};
use super::limits::{AxisLimits, LimitError};
use super::movement::{LawAxis, LawMove, LawMoveError};
use super::polynomial::Law;
use super::preset::Preset;
use crate::Settings;
use interpd_config::AxisLetter;

/// The statement's keyword.
pub(crate) const KEYWORD: &str = "LAW";

/// A parsed `LAW` statement.
#[derive(Debug, Clone, PartialEq)]
pub struct LawBlock {
    pub preset: Option<Preset>,
    /// The preset's conditions (if any) followed by the `COND=` ones, in order.
    pub conditions: Vec<Condition>,
    pub duration_s: f64,
    /// Signed strokes per axis letter, in the order written.
    pub strokes: Vec<(AxisLetter, f64)>,
    pub stretch: bool,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawBlockError {
    /// A syntax problem at a 1-based character column.
    #[error("{col}: {message}")]
    Syntax { col: usize, message: String },
    #[error(transparent)]
    Law(#[from] LawError),
    #[error(transparent)]
    Move(#[from] LawMoveError),
    #[error(transparent)]
    Limit(#[from] LimitError),
    #[error("axis {0} is not on this machine")]
    UnknownAxis(AxisLetter),
}

/// True when the line (after leading blanks) is a `LAW` statement.
pub fn is_law_statement(line: &str) -> bool {
    let t = line.trim_start();
    // `get`, not indexing: the keyword's length in bytes may end inside a character ("Lé…").
    t.get(..KEYWORD.len()).is_some_and(|w| w.eq_ignore_ascii_case(KEYWORD))
        && t[KEYWORD.len()..].chars().next().is_none_or(|c| c.is_whitespace() || c == ';')
}

/// Words of the line with their 1-based character columns, up to a `;` comment.
fn words(line: &str) -> Vec<(usize, &str)> {
    let code = line.split(';').next().unwrap_or("");
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for (i, c) in code.char_indices().chain(std::iter::once((code.len(), ' '))) {
        match (c.is_whitespace(), start) {
            (false, None) => start = Some(i),
            (true, Some(s)) => {
                out.push((code[..s].chars().count() + 1, &code[s..i]));
                start = None;
            }
            _ => {}
        }
    }
    out
}

/// Parses one `LAW` line. Does not solve the law (see [`LawBlock::to_move`]).
pub fn parse(line: &str) -> Result<LawBlock, LawBlockError> {
    let syntax = |col: usize, message: String| LawBlockError::Syntax { col, message };
    let w = words(line);
    match w.first() {
        Some((_, k)) if k.eq_ignore_ascii_case(KEYWORD) => {}
        _ => return Err(syntax(1, format!("expected the keyword {KEYWORD}"))),
    }
    let mut preset = None;
    let mut extra = Vec::new();
    let mut duration_s = None;
    let mut strokes: Vec<(AxisLetter, f64)> = Vec::new();
    let mut stretch = false;
    for &(col, word) in &w[1..] {
        if word.eq_ignore_ascii_case("STRETCH") {
            stretch = true;
            continue;
        }
        let Some((key, value)) = word.split_once('=') else {
            return Err(syntax(col, format!("'{word}' is not KEY=VALUE (nor STRETCH)")));
        };
        let key_up = key.to_ascii_uppercase();
        let number = |what: &str| -> Result<f64, LawBlockError> {
            value
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| syntax(col + key.len() + 1, format!("{what} '{value}' is not a finite number")))
        };
        match key_up.as_str() {
            "PRESET" if preset.is_some() => return Err(syntax(col, "PRESET given twice".into())),
            "PRESET" => preset = Some(Preset::parse(value).map_err(|e| syntax(col + 7, e.to_string()))?),
            "COND" => extra.push(Condition::parse(value).map_err(|e| syntax(col + 5, e.to_string()))?),
            "DURATION" if duration_s.is_some() => return Err(syntax(col, "DURATION given twice".into())),
            "DURATION" => duration_s = Some(number("duration")?),
            _ => {
                let mut chars = key_up.chars();
                let letter = match (chars.next(), chars.next()) {
                    (Some(c), None) => AxisLetter::from_char(c),
                    _ => None,
                };
                let Some(letter) = letter else {
                    return Err(syntax(
                        col,
                        format!("unknown key '{key}' (PRESET, COND, DURATION, an axis letter, or STRETCH)"),
                    ));
                };
                if strokes.iter().any(|(l, _)| *l == letter) {
                    return Err(syntax(col, format!("axis {letter} given twice")));
                }
                strokes.push((letter, number("stroke")?));
            }
        }
    }
    let end = line.split(';').next().unwrap_or("").chars().count() + 1;
    let duration_s = duration_s.ok_or_else(|| syntax(end, "DURATION=<seconds> is missing".into()))?;
    if strokes.is_empty() {
        return Err(syntax(end, "no axis stroke given (e.g. X=10)".into()));
    }
    if preset.is_none() && extra.is_empty() {
        return Err(syntax(end, "no law given: PRESET=<name> and/or COND=I,Z,F".into()));
    }
    let mut conditions = preset.map(|p| p.conditions()).unwrap_or_default();
    conditions.extend(extra);
    Ok(LawBlock { preset, conditions, duration_s, strokes, stretch })
}

impl LawBlock {
    /// Solves the law and makes the move from the axes' current positions (`positions[i]` for
    /// machine axis i), checked against the configured limits; with `STRETCH` the duration grows
    /// to the shortest feasible one instead of failing.
    pub fn to_move(&self, settings: &Settings, positions: &[f64]) -> Result<LawMove, LawBlockError> {
        let law = Law::from_conditions(self.conditions.clone())?;
        let mut axes = Vec::with_capacity(self.strokes.len());
        for &(letter, stroke) in &self.strokes {
            let axis = settings.axis_index(letter).ok_or(LawBlockError::UnknownAxis(letter))?;
            let start = positions.get(axis).copied().unwrap_or(0.0);
            axes.push(LawAxis { axis, start, stroke });
        }
        let mv = LawMove::new(law, axes, self.duration_s)?;
        let limits = AxisLimits::from_settings(settings);
        if self.stretch {
            Ok(mv.stretched(&limits)?)
        } else {
            mv.check(&limits)?;
            Ok(mv)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_forms() {
        let b = parse("LAW PRESET=rr7 DURATION=0.8 X=10 Y=-5 ; comment").expect("parses");
        assert_eq!(b.preset, Some(Preset::Rr7));
        assert_eq!(b.conditions.len(), 8);
        assert_eq!(b.duration_s, 0.8);
        assert_eq!(b.strokes, vec![(AxisLetter::X, 10.0), (AxisLetter::Y, -5.0)]);
        assert!(!b.stretch);
        let b = parse("law preset=rr7 cond=0,0.4,0.45 duration=1 a=90 stretch").expect("parses");
        assert_eq!(b.conditions.len(), 9);
        assert!(b.stretch);
        assert!(is_law_statement("  LAW X=1") && !is_law_statement("LAWN") && !is_law_statement("G1 X1"));
        // A character across the keyword's length is no keyword (and no panic).
        assert!(!is_law_statement("L\u{fffd}AW X=1") && !is_law_statement("LA\u{e9}") && !is_law_statement("\u{e9}"));
    }

    #[test]
    fn errors_name_the_column() {
        let e = |l: &str| parse(l).expect_err("must fail").to_string();
        assert_eq!(e("LAW PRESET=rr7 DURATION=x X=1"), "25: duration 'x' is not a finite number");
        assert_eq!(
            e("LAW PRESET=rr7 DURATION=1 Q=1"),
            "27: unknown key 'Q' (PRESET, COND, DURATION, an axis letter, or STRETCH)"
        );
        assert_eq!(e("LAW PRESET=rr7 X=1"), "19: DURATION=<seconds> is missing");
        assert!(e("LAW PRESET=nope DURATION=1 X=1").starts_with("12: unknown preset 'nope'"));
        assert_eq!(e("LAW PRESET=rr7 ; DURATION=1 X=1"), "16: DURATION=<seconds> is missing");
        assert!(e("LAW COND=0,1 DURATION=1 X=1").starts_with("10: '0,1': expected three numbers"));
    }

    #[test]
    fn makes_a_checked_move() {
        let config = Settings::default_machine();
        let b = parse("LAW PRESET=rr5 DURATION=100 X=10").expect("parses");
        let mv = b.to_move(&config, &[1.0, 2.0, 3.0]).expect("feasible");
        assert_eq!(mv.axes()[0], LawAxis { axis: 0, start: 1.0, stroke: 10.0 });
        let b = parse("LAW PRESET=rr5 DURATION=0.001 X=10").expect("parses");
        assert!(matches!(b.to_move(&config, &[0.0; 3]), Err(LawBlockError::Limit(LimitError::Exceeded { .. }))));
        let b = parse("LAW PRESET=rr5 DURATION=0.001 X=10 STRETCH").expect("parses");
        assert!(b.to_move(&config, &[0.0; 3]).expect("stretched").duration_s() > 0.001);
    }
}
