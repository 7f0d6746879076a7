//! Layering (DESIGN.md), checked on the parsed source of every file of the logic modules.
//!
//! The logic modules ([`LOGIC`]: `sim`, `mapper`, `planner`, `eval`, `geom.rs`, `config.rs`) take
//! inputs and a time and return outputs; the runtime hosts them. So they may use `std`, their own
//! crate, `shm_types`, the chosen maths/utility crates ([`ALLOWED_CRATES`]) and `runtime::config`
//! (plus the config-only items in [`CONFIG_ONLY`]), and never
//! - iceoryx2, or any other crate not in [`ALLOWED_CRATES`];
//! - the runtime's hosting modules (`runtime::ports`, `executor`, `pool`, `launcher`, `clock`,
//!   `recorder`, `os`, ...: anything but `runtime::config`);
//! - threads or the OS clock ([`FORBIDDEN_STD`]: `std::thread`, `std::time::Instant`,
//!   `std::time::SystemTime`, `std::time::UNIX_EPOCH`);
//! - the application (`crate::app`, which hosts them).
//!
//! **No ground truth leaks**: `mapper` and `planner` see only messages, never the simulator's
//! world or scene types nor the evaluation's ground truth, so they must not use `crate::sim` or
//! `crate::eval` at all (however reached: `crate::`, `super::`, `nodes::`, grouped or renamed).
//!
//! How: each file is parsed with `syn`; every `use` tree is expanded through groups, renames and
//! globs into full paths (`crate`, `self` and `super` resolved against the file's module), and
//! every path in items, types, expressions, patterns and macro bodies (`ident::ident` token runs)
//! is expanded through the file's imports, then checked against the rules.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// Files and folders under `nodes/src` that hold logic (not hosting).
const LOGIC: [&str; 6] = ["sim", "mapper", "planner", "eval", "geom.rs", "config.rs"];

/// Logic modules that must not see ground truth.
const NO_GROUND_TRUTH: [&str; 2] = ["mapper", "planner"];

/// Crates (besides their own) the logic modules may use.
const ALLOWED_CRATES: [&str; 18] = [
    "std",
    "core",
    "alloc",
    "shm_types",
    "runtime", // only `runtime::config`, see `check`
    "glam",
    "nalgebra",
    "parry3d",
    "pathfinding", // A*, Dijkstra, Kuhn–Munkres: pure graph algorithms
    "rayon",
    "rand",
    "rand_distr",
    "rand_pcg",
    "serde",
    "serde_json",
    "statrs",
    "thiserror",
    "wide", // portable SIMD lanes (the renderer's kernels): pure arithmetic
];

/// Crates allowed in one logic file only, with the reason.
const ALLOWED_CRATES_IN: [(&str, &str, &str); 3] = [
    // The evaluation writes its plots itself (pure: data in, PNG file out).
    ("eval/plot.rs", "plotters", "plots of the evaluation"),
    // The report's tables are also written as CSV (pure: rows in, text out).
    ("eval/report.rs", "csv", "the report's CSV tables"),
    // Scene files are TOML, parsed by the scene loader (a pure function of the text).
    ("sim/scene.rs", "toml", "scene files"),
];

/// `std` items that are threads or the OS clock.
const FORBIDDEN_STD: [&str; 4] = [
    "std::thread",
    "std::time::Instant",
    "std::time::SystemTime",
    "std::time::UNIX_EPOCH",
];

/// The one runtime module the logic may use: typed config loading and range checks.
const RUNTIME_ALLOWED: &str = "runtime::config";

/// Config-only items of the runtime's hosting modules that a logic file may name, with the
/// reason: `config::Config` is the whole session's configuration, one struct per section of
/// `config/default.toml`, and the `[executor]`, `[ports]` and `[recorder]` sections are
/// deserialised into the runtime's own types. These are plain data (serde + `validate`); naming
/// them starts no thread, opens no port and reads no clock. Only `config.rs` needs them.
const CONFIG_ONLY: [(&str, &str); 4] = [
    ("config.rs", "runtime::executor::ExecutorConfig"),
    // The same type once it lives in `runtime/src/executor/config.rs`.
    ("config.rs", "runtime::executor::config::ExecutorConfig"),
    ("config.rs", "runtime::ports::PortsConfig"),
    ("config.rs", "runtime::recorder::RecorderConfig"),
];

/// `true` if `path` is `prefix` or lies below it (segment-wise).
fn under(path: &str, prefix: &str) -> bool {
    path == prefix
        || path
            .strip_prefix(prefix)
            .is_some_and(|rest| rest.starts_with("::"))
}

/// The module path of a file under `src` (`mapper/grid.rs` → `[mapper, grid]`, `mapper/mod.rs`
/// → `[mapper]`, `geom.rs` → `[geom]`).
fn module_of(rel: &str) -> Vec<String> {
    let rel = rel.strip_suffix(".rs").unwrap_or(rel);
    let mut parts: Vec<String> = rel.split('/').map(str::to_string).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// One use of a path: the path as written and as resolved.
#[derive(Debug, Clone)]
struct Use {
    written: String,
    resolved: String,
}

/// Collects every path of one file.
struct Collector<'a> {
    /// The file's module path (from the crate root), plus inline modules while inside them.
    module: Vec<String>,
    /// External crate names (dependencies, `std`, `core`, `alloc`).
    crates: &'a BTreeSet<String>,
    /// Name → full path, from the file's `use` items (filled by the first pass).
    imports: BTreeMap<String, String>,
    /// Every path found (second pass).
    uses: Vec<Use>,
    /// First pass: only fill `imports`.
    first_pass: bool,
}

impl Collector<'_> {
    /// Resolve the leading `crate`/`self`/`super`/own-crate segments of `segs` into a path from
    /// the crate root (`crate::...`); expand an imported first segment; leave external paths.
    fn resolve(&self, segs: &[String]) -> String {
        let Some(first) = segs.first() else {
            return String::new();
        };
        let mut out: Vec<String>;
        let rest: &[String];
        match first.as_str() {
            "crate" | "nodes" => {
                out = vec!["crate".into()];
                rest = &segs[1..];
            }
            "self" | "super" => {
                out = self.module.clone();
                let mut i = 0;
                while i < segs.len() && (segs[i] == "self" || segs[i] == "super") {
                    if segs[i] == "super" {
                        out.pop();
                    }
                    i += 1;
                }
                out.insert(0, "crate".into());
                rest = &segs[i..];
            }
            name if !self.first_pass && self.imports.contains_key(name) => {
                out = self.imports[name].split("::").map(str::to_string).collect();
                rest = &segs[1..];
            }
            _ => {
                out = Vec::new();
                rest = segs;
            }
        }
        out.extend(rest.iter().cloned());
        out.join("::")
    }

    fn record(&mut self, segs: &[String]) {
        if segs.is_empty() {
            return;
        }
        let resolved = self.resolve(segs);
        self.uses.push(Use {
            written: segs.join("::"),
            resolved,
        });
    }

    /// Expand a `use` tree into full paths (`prefix` so far); `*` stays as a last segment.
    fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                let name = n.ident.to_string();
                self.import(prefix, &name, &name);
            }
            syn::UseTree::Rename(r) => {
                self.import(prefix, &r.ident.to_string(), &r.rename.to_string());
            }
            syn::UseTree::Glob(_) => {
                prefix.push("*".into());
                if !self.first_pass {
                    let segs = prefix.clone();
                    self.record(&segs);
                }
                prefix.pop();
            }
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(prefix, t);
                }
            }
        }
    }

    fn import(&mut self, prefix: &[String], ident: &str, alias: &str) {
        let mut segs = prefix.to_vec();
        if ident != "self" {
            segs.push(ident.to_string());
        }
        if self.first_pass {
            let full = self.resolve(&segs);
            if alias != "_" && alias != "self" {
                self.imports.insert(alias.to_string(), full);
            } else if alias == "self" {
                let last = segs.last().cloned().unwrap_or_default();
                self.imports.insert(last, full);
            }
        } else {
            self.record(&segs);
        }
    }

    /// `a::b::c` runs of identifiers in a macro body (its tokens are not parsed as Rust).
    fn macro_tokens(&mut self, tokens: proc_macro2::TokenStream) {
        use proc_macro2::TokenTree;
        let toks: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < toks.len() {
            match &toks[i] {
                TokenTree::Group(g) => {
                    self.macro_tokens(g.stream());
                    i += 1;
                }
                TokenTree::Ident(id) => {
                    let mut segs = vec![id.to_string()];
                    let mut j = i + 1;
                    while let (
                        Some(TokenTree::Punct(a)),
                        Some(TokenTree::Punct(b)),
                        Some(TokenTree::Ident(n)),
                    ) = (toks.get(j), toks.get(j + 1), toks.get(j + 2))
                    {
                        if a.as_char() == ':' && b.as_char() == ':' {
                            segs.push(n.to_string());
                            j += 3;
                        } else {
                            break;
                        }
                    }
                    if segs.len() > 1 {
                        self.record(&segs);
                    }
                    i = j;
                }
                _ => i += 1,
            }
        }
    }
}

impl<'ast> Visit<'ast> for Collector<'_> {
    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        self.use_tree(&mut Vec::new(), &u.tree);
    }

    fn visit_item_extern_crate(&mut self, e: &'ast syn::ItemExternCrate) {
        if !self.first_pass {
            self.record(&[e.ident.to_string()]);
        }
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        self.module.push(m.ident.to_string());
        syn::visit::visit_item_mod(self, m);
        self.module.pop();
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        if !self.first_pass {
            let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
            // Single identifiers are locals, prelude items or imports (checked at the `use`).
            if segs.len() > 1 || p.leading_colon.is_some() {
                self.record(&segs);
            }
        }
        syn::visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        syn::visit::visit_macro(self, m);
        if !self.first_pass {
            self.macro_tokens(m.tokens.clone());
        }
    }
}

/// Every path one file uses (resolved), or a parse error.
fn uses_of(rel: &str, source: &str, crates: &BTreeSet<String>) -> Result<Vec<Use>, String> {
    let file = syn::parse_file(source).map_err(|e| format!("{rel}: does not parse: {e}"))?;
    let mut c = Collector {
        module: module_of(rel),
        crates,
        imports: BTreeMap::new(),
        uses: Vec::new(),
        first_pass: true,
    };
    c.visit_file(&file);
    c.first_pass = false;
    c.visit_file(&file);
    let _ = c.crates;
    Ok(c.uses)
}

/// The rule a resolved path breaks in file `rel` (relative to `src`), if any.
fn check(rel: &str, path: &str, crates: &BTreeSet<String>) -> Option<String> {
    let top = rel.split('/').next().unwrap_or(rel);
    let first = path.split("::").next().unwrap_or("");
    // A glob breaks a rule if it could import something forbidden below it.
    let glob_prefix = path.strip_suffix("::*");
    let breaks = |forbidden: &str| {
        under(path, forbidden) || glob_prefix.is_some_and(|g| under(forbidden, g))
    };
    if first == "crate" {
        if breaks("crate::app") {
            return Some("logic must not use the application that hosts it (`crate::app`)".into());
        }
        if NO_GROUND_TRUTH.contains(&top) {
            for m in ["crate::sim", "crate::eval"] {
                if breaks(m) {
                    return Some(format!(
                        "{top} must not see ground truth: no `{m}` (world, scene, truth)"
                    ));
                }
            }
        }
        return None;
    }
    if !crates.contains(first) {
        return None; // a local item, a prelude type, a generic parameter, ...
    }
    let allowed_here = ALLOWED_CRATES.contains(&first)
        || ALLOWED_CRATES_IN
            .iter()
            .any(|(f, c, _)| *f == rel && *c == first);
    if !allowed_here {
        return Some(format!(
            "crate `{first}` is not one of the logic modules' crates (iceoryx2 and other hosting \
             crates belong to the runtime and the app)"
        ));
    }
    if first == "runtime" {
        let config_only = CONFIG_ONLY
            .iter()
            .any(|(f, item)| *f == rel && under(path, item));
        if !config_only && !under(path, RUNTIME_ALLOWED) {
            return Some(format!(
                "only `{RUNTIME_ALLOWED}` of the runtime (hosting: ports, executor, pool, \
                 launcher, clock, recorder, os)"
            ));
        }
        return None;
    }
    for f in FORBIDDEN_STD {
        for root in ["std", "core"] {
            let f = f.replacen("std", root, 1);
            if breaks(&f) {
                return Some(format!(
                    "`{f}`: logic never touches threads or the OS clock"
                ));
            }
        }
    }
    None
}

/// Every violation in one file's source, as `file: path (as written): rule`.
fn violations(rel: &str, source: &str, crates: &BTreeSet<String>) -> Vec<String> {
    match uses_of(rel, source, crates) {
        Err(e) => vec![e],
        Ok(uses) => uses
            .iter()
            .filter_map(|u| {
                check(rel, &u.resolved, crates)
                    .map(|why| format!("{rel}: `{}` (= `{}`): {why}", u.written, u.resolved))
            })
            .collect(),
    }
}

/// The package's dependency names (as Rust identifiers) plus `std`, `core` and `alloc`.
fn crate_names() -> BTreeSet<String> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let text = std::fs::read_to_string(&manifest).expect("nodes/Cargo.toml");
    let table: toml::Table = toml::from_str(&text).expect("valid Cargo.toml");
    let mut names: BTreeSet<String> = ["std", "core", "alloc"].map(String::from).into();
    for section in ["dependencies", "dev-dependencies"] {
        if let Some(deps) = table.get(section).and_then(|d| d.as_table()) {
            names.extend(deps.keys().map(|k| k.replace('-', "_")));
        }
    }
    // Hosting crates that must stay out even when nodes stops depending on them.
    names.extend(["iceoryx2", "libc", "mcap", "signal_hook"].map(String::from));
    names
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    if dir.is_file() {
        out.push(dir.to_path_buf());
        return;
    }
    for entry in std::fs::read_dir(dir).expect("module directory exists") {
        let path = entry.expect("readable entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn logic_modules_keep_to_their_layer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let crates = crate_names();
    let mut files = Vec::new();
    for m in LOGIC {
        sources(&root.join(m), &mut files);
    }
    assert!(files.len() >= 30, "found only {files:?}");
    let mut found = Vec::new();
    let mut paths = 0;
    for f in &files {
        let rel = f
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let text = std::fs::read_to_string(f).unwrap();
        paths += uses_of(&rel, &text, &crates).map_or(0, |u| u.len());
        found.extend(violations(&rel, &text, &crates));
    }
    assert!(paths > 1000, "only {paths} paths seen: is the walk broken?");
    assert!(
        found.is_empty(),
        "layering violations:\n{}",
        found.join("\n")
    );
}

#[test]
fn planted_violations_are_reported() {
    let crates = crate_names();
    let planted = r#"
        use crate::{geom::Camera, sim::world::World};
        use super::super::sim::Scene;
        use nodes::eval::metrics;
        use std::{thread as t, time::{Duration, Instant}};
        use std::time::*;
        use iceoryx2::prelude::*;
        use runtime::{config::Checker, ports::PortContext};
        use crate::app::deploy;
        fn f() {
            std::thread::spawn(|| ());
            let _now = ::std::time::SystemTime::now();
            t::sleep(Duration::ZERO);
            let _e: Option<runtime::executor::Executor> = None;
            println!("{:?}", std::time::Instant::now());
            let _s = crate::sim::Sim::new;
        }
    "#;
    let v = violations("mapper/grid.rs", planted, &crates);
    let expect = [
        "`crate::sim::world::World`",
        "`super::super::sim::Scene` (= `crate::sim::Scene`)",
        "`nodes::eval::metrics`",
        "`std::thread`",
        "`std::time::Instant`",
        "`std::time::*`",
        "`iceoryx2::prelude::*`",
        "`runtime::ports::PortContext`",
        "`crate::app::deploy`",
        "`std::thread::spawn`",
        "`std::time::SystemTime::now`",
        "`t::sleep` (= `std::thread::sleep`)",
        "`runtime::executor::Executor`",
        "`std::time::Instant::now`",
        "`crate::sim::Sim::new`",
    ];
    for e in expect {
        assert!(
            v.iter().any(|line| line.contains(e)),
            "{e} not reported; got:\n{}",
            v.join("\n")
        );
    }
    for ok in ["geom::Camera", "config::Checker", "Duration"] {
        assert!(
            !v.iter().any(|line| line.contains(ok)),
            "{ok} wrongly reported:\n{}",
            v.join("\n")
        );
    }
    assert_eq!(v.len(), expect.len(), "{}", v.join("\n"));
}

#[test]
fn allowed_uses_pass_and_exceptions_are_scoped() {
    let crates = crate_names();
    let clean = r#"
        use crate::config::Config;
        use runtime::config::{Checker, ConfigError};
        use std::time::Duration;
        use rayon::prelude::*;
        fn f(_: Duration) -> runtime::executor::ExecutorConfig { Default::default() }
    "#;
    // The config-only item is allowed in config.rs only; sim may use sim.
    assert!(violations("config.rs", clean, &crates).is_empty());
    let v = violations("sim/camera.rs", clean, &crates);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(v[0].contains("runtime::executor::ExecutorConfig"), "{v:?}");
    // The simulator and the evaluation may read ground truth; the mapper may not.
    let truth = "use crate::sim::World; use super::world::Hit;";
    assert!(violations("eval/metrics.rs", truth, &crates).is_empty());
    assert!(violations("sim/camera.rs", truth, &crates).is_empty());
    assert_eq!(violations("planner/gbv.rs", truth, &crates).len(), 1);
    // `super` from a folder's mod.rs leaves the module: planner/mod.rs → crate::sim.
    assert_eq!(
        violations("planner/mod.rs", "use super::sim::World;", &crates).len(),
        1
    );
    // Inline modules: `super` inside `mod tests` of mapper/mod.rs is the mapper.
    let inline = "mod tests { use super::super::sim::World; use super::grid::GridConfig; }";
    assert_eq!(violations("mapper/mod.rs", inline, &crates).len(), 1);
}
