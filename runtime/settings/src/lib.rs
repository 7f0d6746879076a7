//! Typed configuration loading, shared by the runtime and the logic crates: TOML files
//! deserialised into structs with `deny_unknown_fields`, then range-checked. Every error names
//! the file, the key and the offending value. No iceoryx2, no threads: a logic crate may use it.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `lib.rs` | [`ConfigError`], [`Checker`] (range checks), [`parse_toml`] / [`load_toml`] |
//! | `ranges.rs` | [`ranges!`]: a section's range checks declared field by field, keys from the field names |
//! | `defaults.rs` | [`Defaults`]: a built-in complete file that states every default of its sections once ([`RUNTIME_DEFAULTS`] = `config/runtime.toml`; the app's `config/default.toml` layered over it); user files merge over it |

use serde::de::DeserializeOwned;
use std::fmt;
use std::path::{Path, PathBuf};

mod defaults;
mod ranges;
pub use defaults::{Defaults, RUNTIME_DEFAULTS, RUNTIME_PATH, RUNTIME_TOML, merge_tables};
pub use ranges::Count;

/// Why a configuration file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (missing, unreadable).
    #[error("{file}: cannot read config file: {source}")]
    Read {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML, has an unknown key, a missing key, or a value of the wrong type.
    #[error("{file}: {key}: {message}")]
    Parse {
        /// The file.
        file: PathBuf,
        /// Dotted key path of the offending entry (`<root>` if the parser could not tell).
        key: String,
        /// The parser's message (it names the unknown key or the expected type).
        message: String,
    },
    /// A value parsed but is outside its allowed range.
    #[error("{file}: {key} = {value}: {expected}")]
    Range {
        /// The file.
        file: PathBuf,
        /// Dotted key path, e.g. `planner.lbv_hz`.
        key: String,
        /// The value as written.
        value: String,
        /// What was expected, e.g. `must be in (0, 1000]`.
        expected: String,
    },
}

impl ConfigError {
    /// The dotted key the error is about (`<root>` when not known).
    pub fn key(&self) -> &str {
        match self {
            ConfigError::Read { .. } => "<file>",
            ConfigError::Parse { key, .. } | ConfigError::Range { key, .. } => key,
        }
    }
}

/// Range checks for one file, at one table of it: collects the file name and the table's dotted
/// key so each check reads as one line. [`ranges!`] builds each key from a field's name.
#[derive(Debug, Clone)]
pub struct Checker {
    file: PathBuf,
    /// Dotted key of the table being checked (`""`: the file's root).
    at: String,
}

impl Checker {
    /// Checks values that came from `file`, at its root.
    pub fn new(file: impl Into<PathBuf>) -> Self {
        Self {
            file: file.into(),
            at: String::new(),
        }
    }

    /// The file being checked.
    pub fn file(&self) -> &Path {
        &self.file
    }

    /// The same file, at the table `name` inside this one (`mapper` then `sopm`: `mapper.sopm`).
    pub fn at(&self, name: &str) -> Checker {
        Checker {
            file: self.file.clone(),
            at: self.key(name),
        }
    }

    /// The dotted key of `name` in this table (`rows` at `mapper.sopm`: `mapper.sopm.rows`).
    pub fn key(&self, name: &str) -> String {
        if self.at.is_empty() {
            name.to_string()
        } else {
            format!("{}.{name}", self.at)
        }
    }

    /// `Err(Range)` naming `key` and `value` unless `ok`.
    pub fn require<V: fmt::Display>(
        &self,
        ok: bool,
        key: &str,
        value: V,
        expected: &str,
    ) -> Result<(), ConfigError> {
        if ok {
            Ok(())
        } else {
            Err(self.range(key, value, expected))
        }
    }

    /// A finite value within `[lo, hi]`.
    pub fn in_range(&self, key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
        self.require(
            value.is_finite() && value >= lo && value <= hi,
            key,
            value,
            &format!("must be in [{lo}, {hi}]"),
        )
    }

    /// A finite value strictly greater than zero.
    pub fn positive(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        self.require(
            value.is_finite() && value > 0.0,
            key,
            value,
            "must be a finite number > 0",
        )
    }

    /// A count within `[lo, hi]`.
    pub fn count(&self, key: &str, value: usize, lo: usize, hi: usize) -> Result<(), ConfigError> {
        self.require(
            value >= lo && value <= hi,
            key,
            value,
            &format!("must be in [{lo}, {hi}]"),
        )
    }

    /// A value within `[lo, hi]` (integers: `must be in [1, 98]`).
    pub fn within<T: PartialOrd + fmt::Display>(
        &self,
        key: &str,
        value: T,
        lo: T,
        hi: T,
    ) -> Result<(), ConfigError> {
        self.require(
            value >= lo && value <= hi,
            key,
            &value,
            &format!("must be in [{lo}, {hi}]"),
        )
    }

    /// A range error for `key`.
    pub fn range<V: fmt::Display>(&self, key: &str, value: V, expected: &str) -> ConfigError {
        ConfigError::Range {
            file: self.file.clone(),
            key: key.to_string(),
            value: value.to_string(),
            expected: expected.to_string(),
        }
    }
}

/// Read and deserialise a TOML file into `T`. Use `#[serde(deny_unknown_fields)]` on every
/// struct so that misspelt keys are errors, not silently ignored.
pub fn load_toml<T: DeserializeOwned>(file: &Path) -> Result<T, ConfigError> {
    let text = std::fs::read_to_string(file).map_err(|source| ConfigError::Read {
        file: file.to_path_buf(),
        source,
    })?;
    parse_toml(file, &text)
}

/// Deserialise TOML text that came from `file` (used for tests and embedded defaults). The key
/// path of an error comes from serde itself (`serde_path_to_error`); a syntax error, found before
/// any key is deserialised, is at `<root>`.
pub fn parse_toml<T: DeserializeOwned>(file: &Path, text: &str) -> Result<T, ConfigError> {
    let parse_error = |key: String, e: toml::de::Error| ConfigError::Parse {
        file: file.to_path_buf(),
        key,
        message: location(text, e.span()) + e.message(),
    };
    let de = toml::Deserializer::parse(text).map_err(|e| parse_error(ROOT_KEY.into(), e))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = match e.path().to_string() {
            p if p == "." => ROOT_KEY.into(), // the empty path
            p => p,
        };
        parse_error(key, e.into_inner())
    })
}

/// The key of an error that no key path is known for.
const ROOT_KEY: &str = "<root>";

/// "line N: " for a parser span.
fn location(text: &str, span: Option<std::ops::Range<usize>>) -> String {
    match span {
        Some(s) => format!(
            "line {}: ",
            text[..s.start.min(text.len())].matches('\n').count() + 1
        ),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)] // fields exist to be parsed, not read
    struct Root {
        rate: Rate,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)] // fields exist to be parsed, not read
    struct Rate {
        hz: f64,
    }

    fn parse(text: &str) -> Result<Root, ConfigError> {
        parse_toml(Path::new("test.toml"), text)
    }

    #[test]
    fn valid_file_parses() {
        assert_eq!(parse("[rate]\nhz = 10.0\n").unwrap().rate.hz, 10.0);
    }

    #[test]
    fn unknown_key_is_named_with_file_and_table() {
        let e = parse("[rate]\nhz = 10.0\nhzz = 3\n").unwrap_err();
        let msg = e.to_string();
        assert_eq!(e.key(), "rate.hzz", "{msg}");
        assert!(msg.starts_with("test.toml: rate.hzz: line 3"), "{msg}");
        assert!(msg.contains("unknown field `hzz`"), "{msg}");
    }

    #[test]
    fn wrong_type_is_named() {
        let e = parse("[rate]\nhz = \"fast\"\n").unwrap_err();
        assert_eq!(e.key(), "rate.hz");
        assert!(
            e.to_string().contains("fast") || e.to_string().contains("string"),
            "{e}"
        );
    }

    #[test]
    fn syntax_error_is_at_the_root_with_its_line() {
        let e = parse("[rate]\nhz = = 3\n").unwrap_err();
        assert_eq!(e.key(), "<root>", "{e}");
        assert!(
            e.to_string().starts_with("test.toml: <root>: line 2"),
            "{e}"
        );
    }

    #[test]
    fn array_elements_are_named_by_index() {
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)] // fields exist to be parsed, not read
        struct Lists {
            groups: Vec<Vec<u32>>,
        }
        let e = parse_toml::<Lists>(Path::new("l.toml"), "groups = [[1, 2], [3, \"x\"]]\n")
            .unwrap_err();
        assert_eq!(e.key(), "groups[1][1]", "{e}");
        assert!(
            e.to_string().starts_with("l.toml: groups[1][1]: line 1"),
            "{e}"
        );
    }

    #[test]
    fn missing_key_and_missing_file() {
        let e = parse("[rate]\n").unwrap_err();
        assert!(e.to_string().contains("missing field `hz`"), "{e}");
        let e = load_toml::<Root>(Path::new("/nonexistent/vpsom.toml")).unwrap_err();
        assert!(matches!(e, ConfigError::Read { .. }));
        assert!(
            e.to_string()
                .starts_with("/nonexistent/vpsom.toml: cannot read"),
            "{e}"
        );
    }

    #[test]
    fn range_errors_name_key_and_value() {
        let c = Checker::new("cfg.toml");
        assert!(c.in_range("planner.alpha", 0.5, 0.0, 1.0).is_ok());
        let e = c.in_range("planner.alpha", 1.5, 0.0, 1.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cfg.toml: planner.alpha = 1.5: must be in [0, 1]"
        );
        let e = c.positive("planner.lbv_hz", f64::NAN).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cfg.toml: planner.lbv_hz = NaN: must be a finite number > 0"
        );
        let e = c.count("planner.candidates", 0, 1, 1000).unwrap_err();
        assert_eq!(e.key(), "planner.candidates");
    }
}
