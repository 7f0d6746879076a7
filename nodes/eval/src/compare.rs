//! `vpsom report --compare A B`: paired differences B − A between two bench folders, for
//! example before and after a mapper change, and whether each is separated from the seed
//! spread.
//!
//! Pairing:
//! - by (scene, planner, seed) over the runs present in both folders, when they share any seed;
//! - otherwise (e.g. the same code run with other seeds) by (scene, planner), on each room's
//!   mean over its seeds in each folder.
//!
//! Per planner and metric (the report's tables, [`super::report::TABLES`]): the means of A and B
//! over the paired units, the mean difference with its 95 % CI (bootstrap over rooms of the
//! room's differences, [`stats::paired`]), the Wilcoxon signed-rank p-value Holm-corrected over
//! the metrics of a table, and a verdict: "separated" (p_holm < 0.05, with the direction) or
//! "within seed spread". With few pairs the exact test cannot reach 0.05 at all (2 / 2ⁿ: at
//! least 6 pairs of one sign, more after the Holm correction); the markdown says so.

use super::metrics::Metrics;
use super::report::{Better, MetricDef, TABLES, format_p, paper_planner, planner_title};
use super::stats::{self, Paired};
use super::{EvalError, find_metrics_files, load_metrics};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// File name of the comparison written by `vpsom report --compare`.
pub const COMPARE_FILE: &str = "compare.md";

/// How the runs of the two folders were paired.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pairing {
    /// Same (scene, planner, seed) in both folders.
    BySeed,
    /// Same (scene, planner); each side is the room's mean over its seeds (the folders share
    /// no seed).
    ByRoomMean,
}

/// One metric of one planner.
#[derive(Debug, Clone, Copy)]
pub struct CompareRow {
    /// Table name (`table1`, ...; the Holm family).
    pub table: &'static str,
    /// The metric.
    pub def: MetricDef,
    /// Mean of A over the paired units.
    pub mean_a: f64,
    /// Mean of B over the paired units.
    pub mean_b: f64,
    /// B − A.
    pub diff: Paired,
}

impl CompareRow {
    /// `separated: B better`, `separated: B worse` or `within seed spread`.
    pub fn verdict(&self) -> &'static str {
        let dir = self.diff.test.direction();
        if !self.diff.significant() || dir == 0.0 {
            return "within seed spread";
        }
        if (dir > 0.0) == (self.def.better == Better::Higher) {
            "separated: B better"
        } else {
            "separated: B worse"
        }
    }

    /// Whether the difference is separated from the seed spread.
    pub fn separated(&self) -> bool {
        self.verdict().starts_with("separated")
    }
}

/// The comparison of two sets of runs.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Folder A (before).
    pub a: PathBuf,
    /// Folder B (after).
    pub b: PathBuf,
    /// Runs read from A and B.
    pub runs: (usize, usize),
    /// How runs were paired.
    pub pairing: Pairing,
    /// Runs of A and B left without a partner.
    pub unpaired: (usize, usize),
    /// Planners compared, with their rows.
    pub planners: Vec<(String, Vec<CompareRow>)>,
}

type Key = (String, String, u64);

fn keys(runs: &[Metrics]) -> BTreeSet<Key> {
    runs.iter()
        .map(|m| (m.scene.clone(), m.planner.clone(), m.seed))
        .collect()
}

/// Values of a metric per (scene, planner) → seed → value.
fn table(runs: &[Metrics], def: &MetricDef) -> BTreeMap<(String, String), BTreeMap<u64, f64>> {
    let mut t: BTreeMap<(String, String), BTreeMap<u64, f64>> = BTreeMap::new();
    for m in runs {
        if let Some(v) = (def.get)(m).filter(|v| v.is_finite()) {
            t.entry((m.scene.clone(), m.planner.clone()))
                .or_default()
                .insert(m.seed, v);
        }
    }
    t
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Compare runs `a` with runs `b` (B − A). Errors name the folders `dir_a`, `dir_b` when there
/// is nothing to pair.
pub fn compare_runs(
    a: &[Metrics],
    b: &[Metrics],
    dir_a: &Path,
    dir_b: &Path,
) -> Result<Comparison, EvalError> {
    for (runs, dir) in [(a, dir_a), (b, dir_b)] {
        if runs.is_empty() {
            return Err(EvalError::Invalid {
                path: dir.to_path_buf(),
                field: "metrics.json".into(),
                reason: "no run under this folder".into(),
            });
        }
    }
    let (ka, kb) = (keys(a), keys(b));
    let rooms = |k: &BTreeSet<Key>| -> BTreeSet<(String, String)> {
        k.iter().map(|(s, p, _)| (s.clone(), p.clone())).collect()
    };
    let (ra, rb) = (rooms(&ka), rooms(&kb));
    let shared_rooms: BTreeSet<(String, String)> = ra.intersection(&rb).cloned().collect();
    if shared_rooms.is_empty() {
        let list = |r: &BTreeSet<(String, String)>| {
            r.iter()
                .map(|(s, p)| format!("{s}/{p}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(EvalError::Invalid {
            path: dir_b.to_path_buf(),
            field: "(scene, planner)".into(),
            reason: format!(
                "no run pairs with {}: that folder has {}, this one {}",
                dir_a.display(),
                list(&ra),
                list(&rb)
            ),
        });
    }
    let shared: BTreeSet<Key> = ka.intersection(&kb).cloned().collect();
    let (pairing, unpaired) = if shared.is_empty() {
        let count = |k: &BTreeSet<Key>| {
            k.iter()
                .filter(|(s, p, _)| !shared_rooms.contains(&(s.clone(), p.clone())))
                .count()
        };
        (Pairing::ByRoomMean, (count(&ka), count(&kb)))
    } else {
        (
            Pairing::BySeed,
            (ka.len() - shared.len(), kb.len() - shared.len()),
        )
    };
    let mut planners: Vec<String> = shared_rooms.iter().map(|(_, p)| p.clone()).collect();
    planners.sort_by_key(|p| (paper_planner(p).unwrap_or(3), p.clone()));
    planners.dedup();
    let mut out = Vec::new();
    for planner in planners {
        let mut rows = Vec::new();
        for (table_name, defs) in TABLES {
            let mut family: Vec<CompareRow> = Vec::new();
            for def in defs {
                let (ta, tb) = (table(a, def), table(b, def));
                let (mut va, mut vb, mut clusters) = (Vec::new(), Vec::new(), Vec::new());
                for (scene, p) in shared_rooms.iter().filter(|(_, p)| *p == planner) {
                    let key = (scene.clone(), p.clone());
                    let (Some(sa), Some(sb)) = (ta.get(&key), tb.get(&key)) else {
                        continue;
                    };
                    let mut diffs = Vec::new();
                    match pairing {
                        Pairing::BySeed => {
                            for (seed, x) in sa {
                                if let Some(y) = sb.get(seed) {
                                    va.push(*x);
                                    vb.push(*y);
                                    diffs.push(y - x);
                                }
                            }
                        }
                        Pairing::ByRoomMean => {
                            let x = mean(&sa.values().copied().collect::<Vec<_>>());
                            let y = mean(&sb.values().copied().collect::<Vec<_>>());
                            va.push(x);
                            vb.push(y);
                            diffs.push(y - x);
                        }
                    }
                    if !diffs.is_empty() {
                        clusters.push(diffs);
                    }
                }
                if let Some(diff) = stats::paired(&clusters) {
                    family.push(CompareRow {
                        table: table_name,
                        def: *def,
                        mean_a: mean(&va),
                        mean_b: mean(&vb),
                        diff,
                    });
                }
            }
            stats::holm_in_place(&mut family.iter_mut().map(|r| &mut r.diff).collect::<Vec<_>>());
            rows.extend(family);
        }
        out.push((planner, rows));
    }
    Ok(Comparison {
        a: dir_a.to_path_buf(),
        b: dir_b.to_path_buf(),
        runs: (a.len(), b.len()),
        pairing,
        unpaired,
        planners: out,
    })
}

/// Load every `metrics.json` under `a` and under `b` and compare them.
pub fn compare_dirs(a: &Path, b: &Path) -> Result<Comparison, EvalError> {
    let ra = load_metrics(&find_metrics_files(&[a.to_path_buf()])?)?;
    let rb = load_metrics(&find_metrics_files(&[b.to_path_buf()])?)?;
    compare_runs(&ra, &rb, a, b)
}

impl Comparison {
    /// The comparison as markdown (what `vpsom report --compare` prints and writes).
    pub fn markdown(&self) -> String {
        let mut md = String::from("# vpsom-rt bench comparison\n\n");
        let _ = writeln!(
            md,
            "A: {} ({} runs)  \nB: {} ({} runs)  \nPaired {}; runs without a partner: {} in A, \
             {} in B.\n\nEach row: mean of A and of B over the paired units, B − A with its 95 % \
             CI (bootstrap over rooms, fixed seed), the Wilcoxon signed-rank p Holm-corrected \
             over the metrics of the table, the pairs, and the verdict: separated when p_holm < \
             0.05, else within seed spread.\n",
            self.a.display(),
            self.runs.0,
            self.b.display(),
            self.runs.1,
            match self.pairing {
                Pairing::BySeed => "by (scene, planner, seed)",
                Pairing::ByRoomMean =>
                    "by (scene, planner) on each room's mean over its seeds (the folders share \
                     no seed)",
            },
            self.unpaired.0,
            self.unpaired.1
        );
        for (planner, rows) in &self.planners {
            let _ = writeln!(md, "## {}\n", planner_title(planner));
            let pairs = rows
                .iter()
                .map(|r| r.diff.test.n + r.diff.test.zeros)
                .max()
                .unwrap_or(0);
            let floor = stats::min_exact_p(pairs);
            if floor >= stats::ALPHA {
                let _ = writeln!(
                    md,
                    "With {pairs} pairs the exact test's smallest p is {floor:.3}: no difference \
                     can be separated here; run more rooms or seeds.\n"
                );
            }
            md.push_str(
                "| Metric | A | B | B − A [95 % CI] | p_holm | pairs | verdict |\n\
                 |---|---|---|---|---|---|---|\n",
            );
            for r in rows {
                let d = r.def.decimals + 1;
                let verdict = if r.separated() {
                    format!("**{}**", r.verdict())
                } else {
                    r.verdict().to_string()
                };
                let _ = writeln!(
                    md,
                    "| {} | {:.d$} | {:.d$} | {:+.d$} [{:+.d$}, {:+.d$}] | {} | {} | {verdict} |",
                    r.def.label,
                    r.mean_a,
                    r.mean_b,
                    r.diff.ci.mean,
                    r.diff.ci.lo,
                    r.diff.ci.hi,
                    format_p(r.diff.p_holm),
                    r.diff.test.n + r.diff.test.zeros,
                );
            }
            md.push('\n');
        }
        md
    }
}
