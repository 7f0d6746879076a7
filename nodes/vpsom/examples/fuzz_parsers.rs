//! A bounded mutation fuzzer for the config and scene parsers, on the stable toolchain
//! (`cargo fuzz` needs nightly; this machine has none). Not run by CI.
//!
//! `cargo run --release -p vpsom --example fuzz_parsers -- [SECONDS [SEED [OUT_DIR]]]`
//! (defaults: 60 s, seed 1, `target/fuzz-parsers`). Run from the repository root (it reads the
//! seed corpus from `config/`).
//!
//! Targets, each fed every input:
//! - `config`: [`vpsom::config::Config::parse`], i.e. `settings::parse_toml` (TOML
//!   syntax, error locations), `vpsom::config::DEFAULTS.parse` (merge over the built-in
//!   defaults, `serde_path_to_error` key paths) and every section's range checks
//!   (`nodes/vpsom/src/config.rs` and the sections it holds);
//! - `scene`: [`vpsom::sim::Scene::parse`] (`nodes/sim/src/scene.rs`: keys, objects, rooms,
//!   the derived geometry).
//!
//! Seed corpus: `config/default.toml`, `config/sensing-ideal.toml`, `config/scenes/*.toml`. Each
//! input is a pool entry with 1 to 4 mutations: a bit flip, a byte replaced, a span deleted or
//! duplicated, a line deleted, duplicated or swapped, a line spliced in from another entry, a
//! value replaced with an edge literal (`nan`, `inf`, `-0.0`, `1e309`, `-1`, `0`, `2^63`, a huge
//! array, an empty string, a wrong type, ...) or the text cut short. Without coverage
//! instrumentation, the feedback is the error *kind*: an input whose error text (digits removed)
//! was not seen before joins the pool.
//!
//! Findings, written to `OUT_DIR` with the input:
//! - `crash-*`: the parser panicked (caught with `catch_unwind`);
//! - `nonfinite-*`: the input was accepted although the parsed value holds a NaN or an infinity
//!   (its `Debug` text shows `NaN`/`inf`): a bad value that no check names;
//! - `unnamed-*`: an error that does not name the file.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::cell::Cell;
use std::collections::HashSet;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use vpsom::config::Config;
use vpsom::sim::Scene;

thread_local! {
    /// Set while a target runs (its panics are findings, not the fuzzer's).
    static IN_TARGET: Cell<bool> = const { Cell::new(false) };
}

/// Inputs longer than this are skipped (repeated duplications grow them without bound).
const MAX_INPUT: usize = 1 << 20;

/// Edge literals put in place of a value.
const EDGES: [&str; 22] = [
    "nan",
    "-nan",
    "inf",
    "-inf",
    "+inf",
    "0",
    "-0.0",
    "-1",
    "1e309",
    "1e-320",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "65536",
    "\"\"",
    "\"\u{0}\"",
    "true",
    "[]",
    "[nan, nan, nan]",
    "{}",
    "1979-05-27T07:32:00Z",
    "[[1, 2], [3]]",
];

struct Outcome {
    /// `Err` text, `None` when accepted.
    error: Option<String>,
    /// The accepted value holds NaN or inf.
    nonfinite: bool,
}

/// A parser under test: the input's file name and text in, the outcome out.
type Target = fn(&Path, &str) -> Outcome;

fn run_config(file: &Path, text: &str) -> Outcome {
    match Config::parse(file, text) {
        Ok(cfg) => Outcome {
            error: None,
            nonfinite: nonfinite(&format!("{cfg:?}")),
        },
        Err(e) => Outcome {
            error: Some(e.to_string()),
            nonfinite: false,
        },
    }
}

fn run_scene(file: &Path, text: &str) -> Outcome {
    match Scene::parse(file, text) {
        Ok(scene) => Outcome {
            error: None,
            nonfinite: nonfinite(&format!("{scene:?}")),
        },
        Err(e) => Outcome {
            error: Some(e.to_string()),
            nonfinite: false,
        },
    }
}

/// Whether a `Debug` rendering shows a non-finite float.
fn nonfinite(debug: &str) -> bool {
    debug
        .split(|c: char| !c.is_ascii_alphanumeric())
        .any(|w| w == "NaN" || w == "inf")
}

/// The error's kind: its first line without digits (so "line 12" and "line 13" are one kind),
/// at most 200 characters.
fn kind(target: &str, e: &str) -> String {
    let k: String = e
        .lines()
        .next()
        .unwrap_or("")
        .chars()
        .filter(|c| !c.is_ascii_digit())
        .take(200)
        .collect();
    format!("{target}: {k}")
}

fn mutate(rng: &mut Pcg64, text: &str, pool: &[String]) -> String {
    let mut b = text.as_bytes().to_vec();
    for _ in 0..rng.random_range(1..=4) {
        let n = b.len().max(1);
        match rng.random_range(0..11) {
            0 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                b[i] ^= 1 << rng.random_range(0..8);
            }
            1 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                b[i] = *b"=[]{}\"'.,#\n\\ 0-e"
                    .get(rng.random_range(0..17))
                    .unwrap_or(&b'x');
            }
            2 => {
                let i = rng.random_range(0..n).min(b.len());
                let j = (i + rng.random_range(0..64)).min(b.len());
                b.drain(i..j);
            }
            3 => {
                let i = rng.random_range(0..n).min(b.len());
                let j = (i + rng.random_range(0..64)).min(b.len());
                let span = b[i..j].to_vec();
                b.splice(j..j, span);
            }
            4 => {
                let cut = rng.random_range(0..n).min(b.len());
                b.truncate(cut);
            }
            5..=7 => {
                // Replace the value of a random `key = value` line with an edge literal.
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<String> = s.lines().map(str::to_owned).collect();
                let candidates: Vec<usize> = (0..lines.len())
                    .filter(|i| lines[*i].contains('=') && !lines[*i].trim_start().starts_with('#'))
                    .collect();
                if let Some(&i) = candidates.get(rng.random_range(0..candidates.len().max(1))) {
                    let key = lines[i].split('=').next().unwrap_or("").to_owned();
                    let edge = EDGES[rng.random_range(0..EDGES.len())];
                    lines[i] = format!("{key}= {edge}");
                }
                b = (lines.join("\n") + "\n").into_bytes();
            }
            8 => {
                // Delete, duplicate or swap lines.
                let s = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<String> = s.lines().map(str::to_owned).collect();
                if !lines.is_empty() {
                    let i = rng.random_range(0..lines.len());
                    let j = rng.random_range(0..lines.len());
                    match rng.random_range(0..3) {
                        0 => {
                            lines.remove(i);
                        }
                        1 => {
                            let l = lines[i].clone();
                            lines.insert(j, l);
                        }
                        _ => lines.swap(i, j),
                    }
                }
                b = (lines.join("\n") + "\n").into_bytes();
            }
            9 => {
                // Splice a few lines of another pool entry in.
                let other = &pool[rng.random_range(0..pool.len())];
                let lines: Vec<&str> = other.lines().collect();
                if !lines.is_empty() {
                    let i = rng.random_range(0..lines.len());
                    let j = (i + rng.random_range(1..8)).min(lines.len());
                    let s = String::from_utf8_lossy(&b).into_owned();
                    let mut mine: Vec<String> = s.lines().map(str::to_owned).collect();
                    let at = rng.random_range(0..=mine.len());
                    for (k, l) in lines[i..j].iter().enumerate() {
                        mine.insert(at + k, (*l).to_owned());
                    }
                    b = (mine.join("\n") + "\n").into_bytes();
                }
            }
            _ => {
                // A large array or a deep nesting in place of a value.
                let s = String::from_utf8_lossy(&b).into_owned();
                let big = if rng.random_bool(0.5) {
                    format!("[{}]", vec!["1.0"; 10_000].join(","))
                } else {
                    format!("{}1{}", "[".repeat(200), "]".repeat(200))
                };
                b = s.replacen("= [", &format!("= {big}, ["), 1).into_bytes();
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn corpus() -> std::io::Result<Vec<(PathBuf, String)>> {
    let mut files = vec![
        PathBuf::from("config/default.toml"),
        PathBuf::from("config/sensing-ideal.toml"),
    ];
    let mut scenes: Vec<PathBuf> = std::fs::read_dir("config/scenes")?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    files.extend(scenes);
    files
        .into_iter()
        .map(|f| std::fs::read_to_string(&f).map(|t| (f, t)))
        .collect()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let seconds: u64 = args.get(1).map_or(Ok(60), |s| s.parse())?;
    let seed: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let out = PathBuf::from(args.get(3).map_or("target/fuzz-parsers", String::as_str));
    std::fs::create_dir_all(&out)?;
    let seeds = corpus()?;
    let mut pool: Vec<String> = seeds.iter().map(|(_, t)| t.clone()).collect();
    println!(
        "fuzz_parsers: {} seed files, {seconds} s, seed {seed}, findings to {}",
        seeds.len(),
        out.display()
    );

    // A panic inside a target is a finding: keep its message and location, print nothing. A
    // panic anywhere else (the fuzzer itself) is reported as usual.
    let last_panic = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    {
        let last = last_panic.clone();
        let default = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if IN_TARGET.with(Cell::get) {
                if let Ok(mut l) = last.lock() {
                    *l = info.to_string();
                }
            } else {
                default(info);
            }
        }));
    }

    let file = Path::new("fuzz-input.toml");
    let targets: [(&str, Target); 2] = [("config", run_config), ("scene", run_scene)];
    // A target whose accepted seeds already hold NaN/inf cannot use the non-finite oracle.
    let mut nonfinite_ok = [false; 2];
    for (t, (target, run)) in targets.iter().enumerate() {
        for (path, text) in &seeds {
            let o = run(file, text);
            if o.error.is_none() && o.nonfinite {
                println!(
                    "note: {target} accepts seed {} with a NaN/inf in it",
                    path.display()
                );
                nonfinite_ok[t] = true;
            }
        }
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut kinds: HashSet<String> = HashSet::new();
    let mut findings: HashSet<String> = HashSet::new();
    let (mut execs, mut accepted) = (0u64, 0u64);
    let start = Instant::now();
    let mut next_report = Duration::from_secs(10);
    while start.elapsed() < Duration::from_secs(seconds) {
        let base = &pool[rng.random_range(0..pool.len())];
        let input = mutate(&mut rng, base, &pool);
        if input.len() > MAX_INPUT {
            continue;
        }
        for (t, (target, run)) in targets.iter().enumerate() {
            execs += 1;
            IN_TARGET.with(|t| t.set(true));
            let result = panic::catch_unwind(AssertUnwindSafe(|| run(file, &input)));
            IN_TARGET.with(|t| t.set(false));
            let finding = match result {
                Err(_) => {
                    let msg = last_panic.lock().map(|m| m.clone()).unwrap_or_default();
                    Some(("crash", msg))
                }
                Ok(o) if o.nonfinite && !nonfinite_ok[t] => {
                    Some(("nonfinite", "accepted a NaN/inf".to_owned()))
                }
                Ok(Outcome { error: None, .. }) => {
                    accepted += 1;
                    None
                }
                Ok(Outcome { error: Some(e), .. }) => {
                    if !e.contains("fuzz-input.toml") {
                        Some(("unnamed", e))
                    } else {
                        if kinds.insert(kind(target, &e)) && pool.len() < 4000 {
                            pool.push(input.clone());
                        }
                        None
                    }
                }
            };
            if let Some((what, msg)) = finding {
                let key = format!("{what}-{target}-{}", kind(target, &msg));
                if findings.insert(key) {
                    let n = findings.len();
                    let path = out.join(format!("{what}-{target}-{n}.toml"));
                    std::fs::write(&path, &input)?;
                    println!(
                        "FINDING {what} in {target}: {msg} (input: {})",
                        path.display()
                    );
                }
            }
        }
        if start.elapsed() >= next_report {
            println!(
                "{:>4} s: {execs} execs, {accepted} accepted, {} error kinds, pool {}, {} findings",
                start.elapsed().as_secs(),
                kinds.len(),
                pool.len(),
                findings.len()
            );
            next_report += Duration::from_secs(10);
        }
    }
    let _ = panic::take_hook();
    println!(
        "done: {execs} execs in {:.0} s, {accepted} accepted, {} error kinds, {} findings",
        start.elapsed().as_secs_f64(),
        kinds.len(),
        findings.len()
    );
    Ok(())
}
