use thiserror::Error;

/// A configuration that cannot be used. Every variant names the file; parse and validation
/// errors also name the key.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: cannot read configuration: {message}")]
    Io { file: String, message: String },
    /// TOML syntax or schema error (unknown key, missing key, wrong type).
    #[error("{file}:{line}:{column}: {message}")]
    Parse { file: String, line: usize, column: usize, message: String },
    /// A value is out of range or inconsistent with another one.
    #[error("{file}: {key}: {message}")]
    Invalid { file: String, key: String, message: String },
}

impl ConfigError {
    pub(crate) fn from_toml(file: &str, text: &str, e: &toml::de::Error) -> Self {
        let (line, column) = match e.span() {
            Some(span) => line_col(text, span.start),
            None => (1, 1),
        };
        // toml's message already names the key ("unknown field `foo`, expected ...",
        // "missing field `max_vel`"); add the enclosing table so "axis" errors say which axis.
        let mut message = e.message().trim().to_string();
        let offset = e.span().map_or(0, |s| s.start);
        if let Some(table) = enclosing_table(text, offset) {
            message = format!("in [{table}]: {message}");
        }
        if let Some(key) = key_on_line(text, offset) {
            if !message.contains(&format!("`{key}`")) {
                message = format!("{message} (key `{key}`)");
            }
        }
        ConfigError::Parse { file: file.to_string(), line, column, message }
    }
}

/// 1-based line and column (in characters) of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = text[line_start..offset].chars().count() + 1;
    (line, column)
}

/// The key of a `key = value` line containing `offset`, if any.
fn key_on_line(text: &str, offset: usize) -> Option<&str> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[start..end];
    let (key, _) = line.split_once('=')?;
    let key = key.trim();
    (!key.is_empty() && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')).then_some(key)
}

/// The header of the table that contains `offset`, with the index for arrays of tables
/// (`axis[1]`), or `None` at top level.
fn enclosing_table(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let mut current: Option<String> = None;
    let mut array_counts: Vec<(String, usize)> = Vec::new();
    let mut pos = 0;
    for line in text.split_inclusive('\n') {
        if pos > offset {
            break;
        }
        let t = line.trim();
        if let Some(name) = t.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = name.trim().to_string();
            let idx = match array_counts.iter_mut().find(|(n, _)| *n == name) {
                Some((_, c)) => {
                    *c += 1;
                    *c - 1
                }
                None => {
                    array_counts.push((name.clone(), 1));
                    0
                }
            };
            current = Some(format!("{name}[{idx}]"));
        } else if let Some(name) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            current = Some(name.trim().to_string());
        }
        pos += line.len();
    }
    current
}
