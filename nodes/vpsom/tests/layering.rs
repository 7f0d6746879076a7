//! Layering (ARCHITECTURE.md), the part Cargo cannot check.
//!
//! The logic crates ([`LOGIC`]: `geom`, `sim`, `mapper`, `planner`, `eval`) are separate crates,
//! so Cargo already refuses a use of a crate they do not depend on. Two things remain:
//! - **Their manifests**: a logic crate depends only on `shm_types`, `settings`, the other logic
//!   crates below it and the maths/utility crates of [`ALLOWED_DEPS`]; never on the runtime,
//!   iceoryx2, zenoh or the app (nor on `shm_types`' `ipc` feature, which is iceoryx2); and
//!   `mapper` and `planner` never on `sim` or `eval` (no ground truth leaks). Checked on each
//!   `Cargo.toml`.
//! - **`std` inside them**: no threads, no OS clock and no files ([`FORBIDDEN_STD`]:
//!   `std::thread`, `std::time::Instant`, `std::time::SystemTime`, `std::time::UNIX_EPOCH`,
//!   `std::fs`), however reached (grouped, renamed, globbed, in a macro body). The files that
//!   still read or write files are listed in [`FS_ALLOWED`] with the reason.
//!
//! How: each file is parsed with `syn`; every `use` tree is expanded through groups, renames and
//! globs into full paths (`crate`, `self` and `super` resolved against the file's module), and
//! every path in items, types, expressions, patterns and macro bodies (`ident::ident` token runs)
//! is expanded through the file's imports, then checked against the rules.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// The logic crates (folders under `nodes/`).
const LOGIC: [&str; 5] = ["geom", "sim", "mapper", "planner", "eval"];

/// Logic crates that must not see ground truth: no dependency on these.
const NO_GROUND_TRUTH: [(&str, [&str; 2]); 2] =
    [("mapper", ["sim", "eval"]), ("planner", ["sim", "eval"])];

/// Dependencies a logic crate may have (besides the logic crates below it).
const ALLOWED_DEPS: [&str; 21] = [
    "shm_types",
    "settings", // typed config loading and range checks: serde + toml, no hosting
    "bytemuck",
    "csv", // the report's tables as CSV text
    "glam",
    "nalgebra",
    "parry3d",
    "pathfinding", // A*, Dijkstra, Kuhn–Munkres: pure graph algorithms
    "plotters",    // the evaluation's PNG figures
    "rayon",       // data parallelism on the pool the host installs
    "rand",
    "rand_distr",
    "rand_pcg",
    "serde",
    "serde_json",
    "statrs",
    "thiserror",
    "toml", // scene files
    "wide", // portable SIMD lanes (the renderer's kernels): pure arithmetic
    "approx",
    "proptest",
];

/// Logic crates in dependency order: each may depend on those before it.
const LOGIC_ORDER: [&str; 5] = ["geom", "sim", "mapper", "planner", "eval"];

/// `std` items that are threads, the OS clock or files.
const FORBIDDEN_STD: [&str; 5] = [
    "std::thread",
    "std::time::Instant",
    "std::time::SystemTime",
    "std::time::UNIX_EPOCH",
    "std::fs",
];

/// Files of logic crates that still use `std::fs`, with the reason. Nothing else may.
const FS_ALLOWED: [(&str, &str); 4] = [
    ("sim/scene.rs", "Scene::load reads a scene file by path"),
    ("eval/lib.rs", "writes a run's metrics.json and map.json"),
    ("eval/plot.rs", "writes the Figure-10 PNG"),
    (
        "eval/report.rs",
        "reads saved metrics.json trees, writes the report",
    ),
];

/// `true` if `path` is `prefix` or lies below it (segment-wise).
fn under(path: &str, prefix: &str) -> bool {
    path == prefix
        || path
            .strip_prefix(prefix)
            .is_some_and(|rest| rest.starts_with("::"))
}

/// The module path of a file under a crate's `src` (`scenegen/layout.rs` → `[scenegen, layout]`,
/// `scenegen/mod.rs` → `[scenegen]`, `lib.rs` → `[]`).
fn module_of(rel: &str) -> Vec<String> {
    let rel = rel.strip_suffix(".rs").unwrap_or(rel);
    let mut parts: Vec<String> = rel.split('/').map(str::to_string).collect();
    if parts.last().is_some_and(|p| p == "mod") || parts == ["lib"] {
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
struct Collector {
    /// The file's module path (from the crate root), plus inline modules while inside them.
    module: Vec<String>,
    /// Name → full path, from the file's `use` items (filled by the first pass).
    imports: BTreeMap<String, String>,
    /// Every path found (second pass).
    uses: Vec<Use>,
    /// First pass: only fill `imports`.
    first_pass: bool,
}

impl Collector {
    /// Resolve the leading `crate`/`self`/`super`/own-crate segments of `segs` into a path from
    /// the crate root (`crate::...`); expand an imported first segment; leave external paths.
    fn resolve(&self, segs: &[String]) -> String {
        let Some(first) = segs.first() else {
            return String::new();
        };
        let mut out: Vec<String>;
        let rest: &[String];
        match first.as_str() {
            "crate" => {
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

impl<'ast> Visit<'ast> for Collector {
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

/// The rule a resolved path breaks in file `rel` (`<crate>/<path under src>`), if any.
fn check(rel: &str, path: &str) -> Option<String> {
    // A glob breaks a rule if it could import something forbidden below it.
    let glob_prefix = path.strip_suffix("::*");
    let breaks = |forbidden: &str| {
        under(path, forbidden) || glob_prefix.is_some_and(|g| under(forbidden, g))
    };
    for f in FORBIDDEN_STD {
        for root in ["std", "core"] {
            let f = f.replacen("std", root, 1);
            if !breaks(&f) {
                continue;
            }
            if f.ends_with("::fs") && FS_ALLOWED.iter().any(|(file, _)| *file == rel) {
                continue;
            }
            return Some(format!(
                "`{f}`: logic never touches threads, the OS clock or files"
            ));
        }
    }
    None
}

/// Every violation in one file's source, as `file: path (as written): rule`.
fn violations(rel: &str, source: &str) -> Vec<String> {
    match uses_of(rel, source) {
        Err(e) => vec![e],
        Ok(uses) => uses
            .iter()
            .filter_map(|u| {
                check(rel, &u.resolved)
                    .map(|why| format!("{rel}: `{}` (= `{}`): {why}", u.written, u.resolved))
            })
            .collect(),
    }
}

/// Every path one file uses (resolved), or a parse error; `rel` is `<crate>/<path under src>`.
fn uses_of(rel: &str, source: &str) -> Result<Vec<Use>, String> {
    let file = syn::parse_file(source).map_err(|e| format!("{rel}: does not parse: {e}"))?;
    let in_crate = rel.split_once('/').map_or(rel, |(_, r)| r);
    let mut c = Collector {
        module: module_of(in_crate),
        imports: BTreeMap::new(),
        uses: Vec::new(),
        first_pass: true,
    };
    c.visit_file(&file);
    c.first_pass = false;
    c.visit_file(&file);
    Ok(c.uses)
}

/// The `[dependencies]` of a logic crate's manifest (as written, `-` kept), each with the
/// features it turns on.
fn dependencies(krate: &str) -> BTreeMap<String, Vec<String>> {
    let manifest = nodes_dir().join(krate).join("Cargo.toml");
    let text = std::fs::read_to_string(&manifest).expect("logic crate manifest");
    let table: toml::Table = toml::from_str(&text).expect("valid Cargo.toml");
    let Some(deps) = table.get("dependencies").and_then(|d| d.as_table()) else {
        return BTreeMap::new();
    };
    deps.iter()
        .map(|(name, spec)| {
            let features = spec
                .get("features")
                .and_then(|f| f.as_array())
                .map(|f| {
                    f.iter()
                        .filter_map(|x| x.as_str().map(String::from))
                        .collect()
                })
                .unwrap_or_default();
            (name.clone(), features)
        })
        .collect()
}

/// The manifest rules broken by `krate` with dependencies `deps`.
fn manifest_violations(krate: &str, deps: &BTreeMap<String, Vec<String>>) -> Vec<String> {
    let below: Vec<&str> = LOGIC_ORDER
        .iter()
        .take_while(|c| **c != krate)
        .copied()
        .collect();
    let mut out = Vec::new();
    for (d, features) in deps {
        if d == "shm_types" && features.iter().any(|f| f == "ipc") {
            out.push(format!(
                "{krate} turns on shm_types' `ipc` feature: that is iceoryx2, for the hosts only"
            ));
        }
        if !ALLOWED_DEPS.contains(&d.as_str()) && !below.contains(&d.as_str()) {
            out.push(format!(
                "{krate} depends on `{d}`: not a logic-layer crate (hosting crates such as the \
                 runtime, iceoryx2 and zenoh belong to the app)"
            ));
        }
        for (c, banned) in NO_GROUND_TRUTH {
            if c == krate && banned.contains(&d.as_str()) {
                out.push(format!(
                    "{krate} depends on `{d}`: it must not see ground truth"
                ));
            }
        }
    }
    out
}

fn nodes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
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
fn logic_crates_depend_only_on_their_layer() {
    let mut found = Vec::new();
    for krate in LOGIC {
        found.extend(manifest_violations(krate, &dependencies(krate)));
    }
    assert!(
        found.is_empty(),
        "layering violations:\n{}",
        found.join("\n")
    );
}

#[test]
fn logic_crates_use_no_threads_clock_or_files() {
    let mut files = Vec::new();
    for krate in LOGIC {
        let root = nodes_dir().join(krate).join("src");
        let mut here = Vec::new();
        sources(&root, &mut here);
        files.extend(here.into_iter().map(|f| (krate, root.clone(), f)));
    }
    assert!(files.len() >= 30, "found only {} files", files.len());
    let mut found = Vec::new();
    let mut paths = 0;
    let mut fs_files = BTreeSet::new();
    for (krate, root, f) in &files {
        let rel = format!(
            "{krate}/{}",
            f.strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/")
        );
        let text = std::fs::read_to_string(f).unwrap();
        let uses = uses_of(&rel, &text).unwrap_or_default();
        paths += uses.len();
        if uses.iter().any(|u| under(&u.resolved, "std::fs")) {
            fs_files.insert(rel.clone());
        }
        found.extend(violations(&rel, &text));
    }
    assert!(paths > 1000, "only {paths} paths seen: is the walk broken?");
    assert!(
        found.is_empty(),
        "layering violations:\n{}",
        found.join("\n")
    );
    // The exceptions stay true: an entry whose file no longer uses files is removed.
    for (file, why) in FS_ALLOWED {
        assert!(
            fs_files.contains(file),
            "{file} no longer uses std::fs ({why}): drop it from FS_ALLOWED"
        );
    }
}

#[test]
fn planted_violations_are_reported() {
    let planted = r#"
        use std::{thread as t, time::{Duration, Instant}};
        use std::time::*;
        use std::fs;
        fn f() {
            std::thread::spawn(|| ());
            let _now = ::std::time::SystemTime::now();
            t::sleep(Duration::ZERO);
            println!("{:?}", std::time::Instant::now());
            let _ = fs::read("x");
            let _ = core::time::Duration::ZERO;
        }
    "#;
    let v = violations("mapper/grid.rs", planted);
    let expect = [
        "`std::thread`",
        "`std::time::Instant`",
        "`std::time::*`",
        "`std::fs`",
        "`std::thread::spawn`",
        "`std::time::SystemTime::now`",
        "`t::sleep` (= `std::thread::sleep`)",
        "`std::time::Instant::now`",
        "`fs::read` (= `std::fs::read`)",
    ];
    for e in expect {
        assert!(
            v.iter().any(|line| line.contains(e)),
            "{e} not reported; got:\n{}",
            v.join("\n")
        );
    }
    assert!(
        !v.iter().any(|line| line.contains("Duration")),
        "Duration wrongly reported:\n{}",
        v.join("\n")
    );
    assert_eq!(v.len(), expect.len(), "{}", v.join("\n"));
    // The file exception is scoped to its file.
    assert!(violations("eval/report.rs", "use std::fs;").is_empty());
    assert_eq!(violations("eval/metrics.rs", "use std::fs;").len(), 1);
}

#[test]
fn planted_dependencies_are_reported() {
    let deps = |names: &[&str]| {
        names
            .iter()
            .map(|s| (s.to_string(), Vec::new()))
            .collect::<BTreeMap<_, _>>()
    };
    assert!(manifest_violations("eval", &deps(&["sim", "geom", "serde"])).is_empty());
    let v = manifest_violations("mapper", &deps(&["sim", "runtime", "iceoryx2", "geom"]));
    assert_eq!(v.len(), 3, "{v:#?}"); // sim (ground truth), runtime, iceoryx2
    assert!(v.iter().any(|l| l.contains("ground truth")), "{v:#?}");
    assert_eq!(manifest_violations("planner", &deps(&["eval"])).len(), 2);
    assert_eq!(manifest_violations("geom", &deps(&["sim"])).len(), 1);
    assert_eq!(manifest_violations("sim", &deps(&["zenoh"])).len(), 1);
    let ipc = BTreeMap::from([("shm_types".to_string(), vec!["ipc".to_string()])]);
    assert_eq!(manifest_violations("planner", &ipc).len(), 1);
}
