//! Defaults stated once: complete TOML files built into the binary ([`Defaults`]) give every
//! key its default; a user file is deep-merged over them ([`merge_tables`]) and the merged table
//! is deserialised into structs with `deny_unknown_fields` and no `#[serde(default)]`.
//!
//! Each owner builds in its own file: the runtime `config/runtime.toml` ([`RUNTIME_DEFAULTS`],
//! its `[executor]`, `[ports]` and `[recorder]`), the logic crates and the app
//! `config/default.toml`; the app's defaults are both, layered ([`Defaults::layered`]).
//!
//! So a user file sets only the keys it changes, an unknown key is still an error naming the
//! file and the key, and a section's `Default` is that section of the built-in file
//! ([`Defaults::section`]; not `#[serde(default)]`, which would call `Default` while
//! deserialising the very file `Default` reads).

use super::ConfigError;
use serde::de::DeserializeOwned;
use std::path::Path;
use std::sync::OnceLock;

/// The shipped `config/runtime.toml`: the runtime's own sections (`[executor]`, `[ports]`,
/// `[recorder]`), built into every binary.
pub const RUNTIME_TOML: &str = include_str!("../../../config/runtime.toml");
/// Path of the runtime's shipped defaults relative to the repository root.
pub const RUNTIME_PATH: &str = "config/runtime.toml";

/// The defaults of `config/runtime.toml`: the runtime's sections' `Default`s come from here.
pub static RUNTIME_DEFAULTS: Defaults = Defaults::new(RUNTIME_PATH, RUNTIME_TOML);

/// A complete configuration file built into the binary: the default of every key (of its
/// sections), possibly over another such file ([`Defaults::layered`]).
#[derive(Debug)]
pub struct Defaults {
    file: &'static str,
    text: &'static str,
    /// Defaults this file is layered over (their sections, merged with this file's).
    base: Option<&'static Defaults>,
    table: OnceLock<toml::Table>,
}

impl Defaults {
    /// Defaults from `text`, the built-in copy of `file` (named in errors).
    pub const fn new(file: &'static str, text: &'static str) -> Self {
        Self {
            file,
            text,
            base: None,
            table: OnceLock::new(),
        }
    }

    /// Defaults from `text` (the built-in copy of `file`) deep-merged over `base`: how the app
    /// assembles its sections' file and the runtime's into one set of defaults. Each file
    /// should state its own sections (a key in both takes `text`'s value).
    pub const fn layered(base: &'static Defaults, file: &'static str, text: &'static str) -> Self {
        Self {
            file,
            text,
            base: Some(base),
            table: OnceLock::new(),
        }
    }

    /// The file the defaults were built from (relative to the repository root).
    pub fn file(&self) -> &'static str {
        self.file
    }

    /// The built-in text.
    pub fn text(&self) -> &'static str {
        self.text
    }

    /// The parsed table, merged over the base's if layered (parsed once).
    ///
    /// # Panics
    /// If the built-in text is not valid TOML (a test of each file covers this).
    pub fn table(&self) -> &toml::Table {
        self.table.get_or_init(|| {
            let own: toml::Table = super::parse_toml(Path::new(self.file), self.text)
                .unwrap_or_else(|e| panic!("the built-in {} is not valid TOML: {e}", self.file));
            match self.base {
                Some(base) => {
                    let mut t = base.table().clone();
                    merge_tables(&mut t, own);
                    t
                }
                None => own,
            }
        })
    }

    /// The section at the dotted `path` (`""` = the whole file) of the built-in defaults.
    ///
    /// # Panics
    /// If the built-in file lacks the section or it does not deserialise into `T` (a test of
    /// each file covers this).
    pub fn section<T: DeserializeOwned>(&self, path: &str) -> T {
        let mut value = toml::Value::Table(self.table().clone());
        for key in path.split('.').filter(|k| !k.is_empty()) {
            value = match value {
                toml::Value::Table(mut t) => t.remove(key),
                _ => None,
            }
            .unwrap_or_else(|| panic!("the built-in {} has no [{path}]", self.file));
        }
        deserialize_merged(Path::new(self.file), "", path, value)
            .unwrap_or_else(|e| panic!("the built-in {} does not load: {e}", self.file))
    }

    /// Parse `text`, the contents of `file`, over the defaults: keys it sets replace the
    /// defaults', tables merge key by key. Errors name `file`, the key and (for values the file
    /// sets) its line.
    pub fn parse<T: DeserializeOwned>(&self, file: &Path, text: &str) -> Result<T, ConfigError> {
        let user: toml::Table = super::parse_toml(file, text)?;
        let mut merged = self.table().clone();
        merge_tables(&mut merged, user);
        deserialize_merged(file, text, "", toml::Value::Table(merged))
    }

    /// Read `file` and parse it over the defaults ([`Defaults::parse`]).
    pub fn load<T: DeserializeOwned>(&self, file: &Path) -> Result<T, ConfigError> {
        let text = std::fs::read_to_string(file).map_err(|source| ConfigError::Read {
            file: file.to_path_buf(),
            source,
        })?;
        self.parse(file, &text)
    }
}

/// Deep-merge `over` into `base`: a table merges key by key (recursively); any other value of
/// `over` (including an array) replaces `base`'s.
pub fn merge_tables(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_tables(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Deserialise a merged `value` (at the dotted `section` of the file), naming the dotted key of
/// any error; `text` is the user's file, searched for the key's line.
fn deserialize_merged<T: DeserializeOwned>(
    file: &Path,
    text: &str,
    section: &str,
    value: toml::Value,
) -> Result<T, ConfigError> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let key = match (section.is_empty(), path.as_str()) {
            (true, ".") => "<root>".to_string(),
            (true, _) => path,
            (false, ".") => section.to_string(),
            (false, _) => format!("{section}.{path}"),
        };
        let line = line_of(text, &key).map_or(String::new(), |n| format!("line {n}: "));
        ConfigError::Parse {
            file: file.to_path_buf(),
            message: line + e.inner().message(),
            key,
        }
    })
}

/// Best effort: the line (from 1) of `text` that sets the dotted `key` (a `key = ...` line in its
/// table, or the `[table]` header), `None` if not found.
fn line_of(text: &str, key: &str) -> Option<usize> {
    let key = key.split('[').next().unwrap_or(key);
    let unquote = |s: &str| s.replace(['"', '\'', ' '], "");
    let mut table = String::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.split('#').next().unwrap_or("").trim();
        if let Some(h) = t.strip_prefix('[') {
            table = unquote(h.trim_matches(|c| c == '[' || c == ']'));
            if table == key {
                return Some(i + 1);
            }
        } else if let Some((k, _)) = t.split_once('=') {
            let k = unquote(k);
            let full = if table.is_empty() {
                k
            } else {
                format!("{table}.{k}")
            };
            if full == key {
                return Some(i + 1);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Root {
        rate: Rate,
        name: String,
    }

    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Rate {
        hz: f64,
        cpus: Vec<u32>,
        mode: Mode,
    }

    #[derive(Debug, PartialEq, Deserialize)]
    #[serde(rename_all = "lowercase")]
    enum Mode {
        Fast,
        Slow,
    }

    static D: Defaults = Defaults::new(
        "defaults.toml",
        "name = \"a\"\n[rate]\nhz = 10.0\ncpus = [0, 1]\nmode = \"fast\"\n",
    );

    fn parse(text: &str) -> Result<Root, ConfigError> {
        D.parse(Path::new("user.toml"), text)
    }

    #[test]
    fn a_partial_file_changes_only_its_keys() {
        let r = parse("[rate]\ncpus = [3]\n").unwrap();
        assert_eq!(r.rate.hz, 10.0);
        assert_eq!(r.rate.cpus, [3], "arrays replace, not merge");
        assert_eq!(r.rate.mode, Mode::Fast);
        assert_eq!(r.name, "a");
        assert_eq!(parse("").unwrap(), D.section::<Root>(""));
        assert_eq!(parse("name = \"b\"").unwrap().name, "b");
        assert_eq!(
            parse("[rate]\nmode = \"slow\"").unwrap().rate.mode,
            Mode::Slow
        );
        assert_eq!(D.section::<Rate>("rate").hz, 10.0);
    }

    #[test]
    fn errors_name_the_file_the_key_and_the_line() {
        let e = parse("name = \"b\"\n[rate]\nhz = 10.0\nhzz = 3\n").unwrap_err();
        assert_eq!(e.key(), "rate.hzz", "{e}");
        let msg = e.to_string();
        assert!(msg.starts_with("user.toml: rate.hzz: line 4: "), "{msg}");
        assert!(msg.contains("unknown field `hzz`"), "{msg}");
        let e = parse("[rat]\n").unwrap_err();
        assert_eq!(e.key(), "rat", "{e}");
        assert!(e.to_string().contains("line 1: unknown field `rat`"), "{e}");
        let e = parse("[rate]\nhz = \"fast\"\n").unwrap_err();
        assert_eq!(e.key(), "rate.hz", "{e}");
        assert!(
            e.to_string()
                .contains("line 2: invalid type: string \"fast\""),
            "{e}"
        );
        let e = parse("[rate]\ncpus = [1, -2]\n").unwrap_err();
        assert_eq!(e.key(), "rate.cpus[1]", "{e}");
        let e = parse("[rate]\nmode = \"medium\"\n").unwrap_err();
        assert_eq!(e.key(), "rate.mode", "{e}");
        assert!(e.to_string().contains("medium"), "{e}");
        let e = parse("[rate\n").unwrap_err();
        assert!(matches!(e, ConfigError::Parse { .. }), "{e}");
        assert!(e.to_string().starts_with("user.toml: "), "{e}");
        let e = D
            .load::<Root>(Path::new("/nonexistent/u.toml"))
            .unwrap_err();
        assert!(matches!(e, ConfigError::Read { .. }), "{e}");
    }

    #[test]
    fn merge_is_deep_for_tables_only() {
        let mut base: toml::Table =
            toml::from_str("a = 1\n[t]\nx = 1\ny = [1]\n[t.u]\nz = 1\n").unwrap();
        let over: toml::Table = toml::from_str("[t]\ny = [2, 3]\n[t.u]\nw = 2\n").unwrap();
        merge_tables(&mut base, over);
        let want: toml::Table =
            toml::from_str("a = 1\n[t]\nx = 1\ny = [2, 3]\n[t.u]\nz = 1\nw = 2\n").unwrap();
        assert_eq!(base, want);
    }

    #[test]
    fn the_shipped_file_parses() {
        let t = RUNTIME_DEFAULTS.table();
        let mut sections: Vec<&str> = t.keys().map(String::as_str).collect();
        sections.sort_unstable();
        assert_eq!(sections, ["executor", "ports", "recorder"]);
        assert_eq!(RUNTIME_DEFAULTS.file(), RUNTIME_PATH);
    }

    static BASE: Defaults = Defaults::new("base.toml", "[rate]\nhz = 10.0\ncpus = [0, 1]\n");
    static LAYERED: Defaults =
        Defaults::layered(&BASE, "top.toml", "name = \"a\"\n[rate]\nmode = \"fast\"\n");

    #[test]
    fn layered_defaults_merge_over_their_base() {
        let r: Root = LAYERED.section("");
        assert_eq!(r, D.section::<Root>(""));
        let r: Root = LAYERED
            .parse(Path::new("u.toml"), "[rate]\nhz = 5.0\n")
            .unwrap();
        assert_eq!((r.rate.hz, r.rate.cpus.as_slice()), (5.0, &[0, 1][..]));
        let e = LAYERED
            .parse::<Root>(Path::new("u.toml"), "[rate]\nhzz = 5.0\n")
            .unwrap_err();
        assert_eq!(
            e.to_string().split(": ").take(2).collect::<Vec<_>>(),
            ["u.toml", "rate.hzz"]
        );
    }
}
