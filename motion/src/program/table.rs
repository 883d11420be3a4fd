//! Path tables in the form of the five-axis example of Kopp et al. 2019 (§2, §4: the control
//! supplies A … A‴ at each sample point s_i): one row per sample point with the
//! path position s and, per axis, A, A′, A″, A‴ (′ = d/ds).
//!
//! ```text
//! # F=6000            optional path feed, mm/min (without it the axis limits alone bound v)
//! s,X,X',X'',X''',Y,Y',Y'',Y''',…
//! 0,0,1,0,0,0,0,0,0
//! ```
//! Rows must have non-decreasing s. Two rows with the same s and position but different
//! derivatives mark a corner. Lines starting with `#` are comments.

use super::error::Diagnostics;
use super::{Program, Summary, fmt_num};
use crate::Settings;
use crate::path::{AxisDerivs, Blend, Feed, Geometry, MAX_AXES, Path, SepticSpan, Source};
use interpd_config::{AxisKind, AxisLetter};

/// Rows closer in s than this are the same sample (a corner if their derivatives differ).
const SAME_S_TOL: f64 = 1e-12;
/// At a corner the two rows must have the same position within this.
const CORNER_POS_TOL: f64 = 1e-9;
/// s is the arc length over the linear axes, which no chord between two rows can exceed;
/// relative and absolute slack (mm) for rounding in the table.
const CHORD_REL_TOL: f64 = 1e-6;
const CHORD_ABS_TOL_MM: f64 = 1e-9;

pub(crate) fn parse_table(text: &str, settings: &Settings, d: &mut Diagnostics) -> Program {
    let mut summary = Summary::default();
    let mut path = Path::new(settings.axis_names(), [0.0; MAX_AXES]);
    let mut header: Option<Vec<usize>> = None; // machine axis index per table axis
    let mut feed = Feed::Rapid;
    let mut prev: Option<(f64, AxisDerivs, u32)> = None;
    for (i, raw) in text.lines().enumerate() {
        if d.full() {
            break;
        }
        let line_no = i as u32 + 1;
        summary.lines = line_no;
        let line = raw.trim_end();
        let trimmed = line.trim_start();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(comment) = trimmed.strip_prefix('#') {
            if let Some(f) = parse_feed_directive(comment, line_no, line, d) {
                feed = f;
            }
            continue;
        }
        let fields = split_fields(line);
        let Some(axes) = &header else {
            header = parse_header(&fields, settings, line_no, d);
            if header.is_none() {
                return Program { path, summary };
            }
            continue;
        };
        summary.blocks += 1;
        let expected = 1 + 4 * axes.len();
        if fields.len() != expected {
            let col = fields.get(expected).map_or(line.chars().count() as u32 + 1, |f| f.1);
            d.error(line_no, col, format!("row has {} fields, the header has {expected}", fields.len()));
            continue;
        }
        let mut values = Vec::with_capacity(expected);
        let mut bad = false;
        for (text, col) in &fields {
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => values.push(v),
                _ => {
                    d.error(line_no, *col, format!("'{text}' is not a finite number"));
                    bad = true;
                    break;
                }
            }
        }
        if bad {
            continue;
        }
        let s = values[0];
        let mut row = AxisDerivs::default();
        for (j, &k) in axes.iter().enumerate() {
            row.pos[k] = values[1 + 4 * j];
            row.d1[k] = values[2 + 4 * j];
            row.d2[k] = values[3 + 4 * j];
            row.d3[k] = values[4 + 4 * j];
            let a = &settings.axes[k];
            if row.pos[k] < a.min_pos || row.pos[k] > a.max_pos {
                d.error(
                    line_no,
                    fields[1 + 4 * j].1,
                    format!(
                        "{} position {} {} is outside the travel range [{}, {}]",
                        a.name,
                        fmt_num(row.pos[k]),
                        a.kind.unit(),
                        a.min_pos,
                        a.max_pos
                    ),
                );
                bad = true;
            }
        }
        if bad {
            continue;
        }
        match prev {
            None => {
                path.start = row.pos;
            }
            Some((ps, prow, _)) => {
                let h = s - ps;
                if h < -SAME_S_TOL {
                    d.error(line_no, fields[0].1, format!("s must not decrease: {} after {}", fmt_num(s), fmt_num(ps)));
                    continue;
                }
                if h <= SAME_S_TOL {
                    let jump = axes.iter().map(|&k| (row.pos[k] - prow.pos[k]).abs()).fold(0.0, f64::max);
                    if jump > CORNER_POS_TOL {
                        d.error(
                            line_no,
                            fields[0].1,
                            "two rows at the same s must have the same position (a corner repeats the point)",
                        );
                        continue;
                    }
                } else {
                    let chord_mm = linear_chord_mm(axes, settings, &prow, &row);
                    if chord_mm > h * (1.0 + CHORD_REL_TOL) + CHORD_ABS_TOL_MM {
                        d.error(
                            line_no,
                            fields[0].1,
                            format!(
                                "s advances {} mm but the linear axes move {} mm: s must be the arc length over them",
                                fmt_num(h),
                                fmt_num(chord_mm)
                            ),
                        );
                        continue;
                    }
                    let span = SepticSpan::new(&prow, &row, h);
                    if !span.is_bounded() {
                        d.error(
                            line_no,
                            fields[0].1,
                            format!("derivatives too large for an s step of {} mm (the span overflows)", fmt_num(h)),
                        );
                        continue;
                    }
                    *summary.kinds.entry("table").or_insert(0) += 1;
                    path.push(
                        Geometry::Septic(Box::new(span)),
                        feed,
                        Source { line: line_no, block: 0 },
                        0.0,
                        Blend::Exact,
                    );
                }
            }
        }
        prev = Some((s, row, line_no));
    }
    if header.is_none() {
        d.error(summary.lines.max(1), 1, "path table has no header line 's,<axis>,<axis>',<axis>'',<axis>''',…'");
    } else if path.elements.is_empty() && d.errors.is_empty() {
        d.error(summary.lines.max(1), 1, "path table needs at least two rows with different s");
    }
    summary.program_end = true;
    Program { path, summary }
}

/// Straight-line distance between two rows over the table's linear axes (mm).
fn linear_chord_mm(axes: &[usize], settings: &Settings, a: &AxisDerivs, b: &AxisDerivs) -> f64 {
    axes.iter()
        .filter(|&&k| settings.axes[k].kind == AxisKind::Linear)
        .map(|&k| (b.pos[k] - a.pos[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Splits a CSV line into trimmed fields with their 1-based columns.
fn split_fields(line: &str) -> Vec<(&str, u32)> {
    let mut out = Vec::new();
    let mut col = 1u32;
    for field in line.split(',') {
        let lead = field.chars().take_while(|c| c.is_whitespace()).count() as u32;
        out.push((field.trim(), col + lead));
        col += field.chars().count() as u32 + 1;
    }
    out
}

fn parse_header(fields: &[(&str, u32)], settings: &Settings, line_no: u32, d: &mut Diagnostics) -> Option<Vec<usize>> {
    if fields.first().map(|f| f.0) != Some("s") {
        d.error(line_no, fields.first().map_or(1, |f| f.1), "path table header must start with 's'");
        return None;
    }
    let rest = &fields[1..];
    if rest.is_empty() || rest.len() % 4 != 0 {
        d.error(line_no, fields.last().map_or(1, |f| f.1), "header needs four columns per axis: N,N',N'',N'''");
        return None;
    }
    let mut axes = Vec::new();
    for chunk in rest.chunks(4) {
        let name = chunk[0].0;
        let letter = name.chars().next().filter(|_| name.chars().count() == 1).and_then(AxisLetter::from_char);
        let Some(letter) = letter else {
            d.error(line_no, chunk[0].1, format!("'{name}' is not an axis name"));
            return None;
        };
        let Some(k) = settings.axis_index(letter) else {
            d.error(
                line_no,
                chunk[0].1,
                format!("axis {letter} is not on this machine (axes: {})", settings.axis_names().join(" ")),
            );
            return None;
        };
        if axes.contains(&k) {
            d.error(line_no, chunk[0].1, format!("axis {letter} appears twice in the header"));
            return None;
        }
        for (j, (text, col)) in chunk.iter().enumerate().skip(1) {
            let expect = format!("{letter}{}", "'".repeat(j));
            if *text != expect {
                d.error(line_no, *col, format!("expected column '{expect}', found '{text}'"));
                return None;
            }
        }
        axes.push(k);
    }
    Some(axes)
}

/// `# F=6000` sets the path feed (mm/min).
fn parse_feed_directive(comment: &str, line_no: u32, line: &str, d: &mut Diagnostics) -> Option<Feed> {
    let c = comment.trim();
    let value = c.strip_prefix("F=").or_else(|| c.strip_prefix("F ="))?;
    let col = line.find('F').map_or(1, |i| line[..i].chars().count() as u32 + 1);
    match value.trim().parse::<f64>() {
        Ok(f) if f.is_finite() && f > 0.0 => Some(Feed::Programmed { mm_per_s: f / 60.0 }),
        _ => {
            d.error(line_no, col, format!("feed '{}' must be a positive number (mm/min)", value.trim()));
            None
        }
    }
}
