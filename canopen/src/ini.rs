//! The INI dialect of CiA 306 EDS and DCF files: `[Section]` lines, `Key=Value` lines, `;`
//! comments, section and key names case-insensitive. Every section and key keeps its line, so
//! the EDS reader can point at the place of any error it finds later.

use std::collections::BTreeMap;

/// A position in the file, 1-based.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pos {
    pub line: usize,
    pub column: usize,
}

impl std::fmt::Display for Pos {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}, column {}", self.line, self.column)
    }
}

/// A syntax error with its place.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{pos}: {message}")]
pub struct IniError {
    pub pos: Pos,
    pub message: String,
}

/// A value with the place of its key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Value {
    pub text: String,
    /// Where the value starts.
    pub pos: Pos,
}

/// One section: its keys (lower-cased) and where its header is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Section {
    /// The name as written.
    pub name: String,
    pub pos: Pos,
    pub keys: BTreeMap<String, Value>,
}

impl Section {
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.keys.get(&key.to_ascii_lowercase())
    }
}

/// A whole file: sections by lower-cased name.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Ini {
    pub sections: BTreeMap<String, Section>,
}

impl Ini {
    pub fn section(&self, name: &str) -> Option<&Section> {
        self.sections.get(&name.to_ascii_lowercase())
    }

    /// Parses the text; a duplicate section or key, a key outside a section, an unclosed
    /// header or a line that is neither is an error at its place.
    pub fn parse(text: &str) -> Result<Ini, IniError> {
        let mut ini = Ini::default();
        let mut current: Option<String> = None;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let raw = raw.strip_prefix('\u{feff}').unwrap_or(raw);
            let indent = raw.len() - raw.trim_start().len();
            let t = raw.trim();
            let at = |col: usize| Pos { line, column: col + 1 };
            if t.is_empty() || t.starts_with(';') || t.starts_with('#') {
                continue;
            }
            if let Some(rest) = t.strip_prefix('[') {
                let Some(name) = rest.strip_suffix(']') else {
                    return Err(IniError {
                        pos: at(indent),
                        message: format!("section header {t:?} has no closing ']'"),
                    });
                };
                let name = name.trim();
                if name.is_empty() {
                    return Err(IniError { pos: at(indent), message: "empty section name".into() });
                }
                let key = name.to_ascii_lowercase();
                if let Some(prev) = ini.sections.get(&key) {
                    return Err(IniError {
                        pos: at(indent),
                        message: format!("section [{name}] appears twice (first at line {})", prev.pos.line),
                    });
                }
                ini.sections
                    .insert(key.clone(), Section { name: name.to_string(), pos: at(indent), keys: BTreeMap::new() });
                current = Some(key);
                continue;
            }
            let Some(eq) = t.find('=') else {
                return Err(IniError {
                    pos: at(indent),
                    message: format!("expected `Key=Value` or `[Section]`, got {t:?}"),
                });
            };
            let Some(section) = current.as_ref().and_then(|c| ini.sections.get_mut(c)) else {
                return Err(IniError { pos: at(indent), message: "a key before the first section".into() });
            };
            let key = t[..eq].trim();
            if key.is_empty() {
                return Err(IniError { pos: at(indent), message: "empty key name".into() });
            }
            let after = &t[eq + 1..];
            let value = after.trim();
            let value_col = indent + eq + 1 + (after.len() - after.trim_start().len());
            let k = key.to_ascii_lowercase();
            if let Some(prev) = section.keys.get(&k) {
                return Err(IniError {
                    pos: at(indent),
                    message: format!(
                        "key {key} appears twice in section [{}] (first at line {})",
                        section.name, prev.pos.line
                    ),
                });
            }
            section.keys.insert(k, Value { text: value.to_string(), pos: at(value_col) });
        }
        Ok(ini)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_keys_and_places() {
        let ini = Ini::parse("; c\n[FileInfo]\nFileName = a.eds\n\n[1018sub1]\n  DefaultValue=0x1\n").unwrap();
        let v = ini.section("1018SUB1").unwrap().get("defaultvalue").unwrap();
        assert_eq!((v.text.as_str(), v.pos), ("0x1", Pos { line: 6, column: 16 }));
        assert_eq!(ini.section("fileinfo").unwrap().get("FileName").unwrap().text, "a.eds");
    }

    #[test]
    fn errors_name_their_place() {
        let e = Ini::parse("[A]\nx=1\nx=2\n").unwrap_err();
        assert_eq!(e.to_string(), "line 3, column 1: key x appears twice in section [A] (first at line 2)");
        assert_eq!(Ini::parse("x=1").unwrap_err().pos.line, 1);
        assert!(Ini::parse("[A]\n[a]\n").unwrap_err().message.contains("twice"));
        assert!(Ini::parse("[A\n").unwrap_err().message.contains("closing"));
        assert!(Ini::parse("[A]\n  junk\n").unwrap_err().to_string().starts_with("line 2, column 3"));
    }
}
