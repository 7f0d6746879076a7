//! The bench report: the paper's Tables 1 and 2 from many `metrics.json` (scene × planner × seed).
//!
//! Each cell is mean ± sample standard deviation over the runs of that scene and planner, with
//! the number of runs that define the metric (a run whose IoU or CDE is null, because nothing
//! was assigned, does not enter those cells). The "Ave" row pools every run of a planner over
//! all scenes; with the same number of seeds per scene this equals the paper's mean of the scene
//! means, and it carries a 95 % confidence interval bootstrapped over rooms, the seeds of a room
//! kept together ([`stats::mean_ci`]; with at least two rooms).
//!
//! Below each table, the paired differences VP-SOM minus each other planner on the same (scene,
//! seed): the mean with its 95 % CI (bootstrap over rooms of the room's differences) and the
//! Wilcoxon signed-rank p-value, Holm-corrected over the metrics of that table
//! ([`stats::paired`], [`stats::holm`]). Bold marks only a difference significant at
//! p_holm < 0.05, in VP-SOM's favour or the other planner's; any other difference is written as
//! a tie. In the tables, an "Ave" cell is bold when its planner wins every such paired test it
//! is in (VP-SOM against every other planner, another planner against VP-SOM); scene rows (one
//! room) are never bold. `paired.csv` and `ci.csv` hold the same figures.

use super::metrics::Metrics;
use super::plot::Figure;
use super::stats::{self, Ci, Paired};
use super::{EvalError, METRICS_FILE, read_json};
use statrs::statistics::Statistics;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Name of the average row.
pub const AVERAGE: &str = "Ave";

/// Whether larger or smaller values are better.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Better {
    /// Larger is better.
    Higher,
    /// Smaller is better.
    Lower,
}

/// One reported metric (a table row).
#[derive(Debug, Clone, Copy)]
pub struct MetricDef {
    /// Key in `metrics.json` and in the CSVs.
    pub key: &'static str,
    /// Row label as in the paper.
    pub label: &'static str,
    /// Which way is better (for bolding).
    pub better: Better,
    /// Decimals shown.
    pub decimals: usize,
    /// The value of a run, `None` if undefined for it.
    pub get: fn(&Metrics) -> Option<f64>,
}

/// Table 1 rows: the sparse object map.
pub const TABLE1: [MetricDef; 4] = [
    MetricDef {
        key: "precision",
        label: "Precision",
        better: Better::Higher,
        decimals: 2,
        get: |m| Some(m.precision),
    },
    MetricDef {
        key: "recall",
        label: "Recall",
        better: Better::Higher,
        decimals: 2,
        get: |m| Some(m.recall),
    },
    MetricDef {
        key: "iou",
        label: "IoU",
        better: Better::Higher,
        decimals: 3,
        get: |m| m.iou,
    },
    MetricDef {
        key: "cde_m",
        label: "CDE(m)",
        better: Better::Lower,
        decimals: 3,
        get: |m| m.cde_m,
    },
];

/// Table 2 rows: the observation trajectory.
pub const TABLE2: [MetricDef; 4] = [
    MetricDef {
        key: "path_length_m",
        label: "Length of path",
        better: Better::Lower,
        decimals: 2,
        get: |m| Some(m.path_length_m),
    },
    MetricDef {
        key: "time_s",
        label: "Cost time",
        better: Better::Lower,
        decimals: 0,
        get: |m| Some(m.time_s),
    },
    MetricDef {
        key: "non_occlusion",
        label: "Non-occlusion",
        better: Better::Higher,
        decimals: 3,
        get: |m| m.non_occlusion,
    },
    MetricDef {
        key: "localization_failures",
        label: "Localization failure",
        better: Better::Lower,
        decimals: 1,
        get: |m| Some(f64::from(m.localization_failures)),
    },
];

/// Extra rows (not in the paper's tables): eq. 21 on true boxes, run health and background objects.
pub const HEALTH: [MetricDef; 5] = [
    MetricDef {
        key: "non_occlusion_eq21",
        label: "Non-occlusion, eq. 21 on true boxes",
        better: Better::Higher,
        decimals: 3,
        get: |m| m.non_occlusion_eq21,
    },
    MetricDef {
        key: "terminated",
        label: "Terminated (fraction)",
        better: Better::Higher,
        decimals: 2,
        get: |m| Some(if m.terminated { 1.0 } else { 0.0 }),
    },
    MetricDef {
        key: "deadline_misses",
        label: "Deadline misses",
        better: Better::Lower,
        decimals: 1,
        get: |m| Some(m.deadline_misses as f64),
    },
    MetricDef {
        key: "background_precision",
        label: "Background precision",
        better: Better::Higher,
        decimals: 2,
        get: |m| m.background.as_ref().map(|b| b.precision),
    },
    MetricDef {
        key: "background_recall",
        label: "Background recall",
        better: Better::Higher,
        decimals: 2,
        get: |m| m.background.as_ref().map(|b| b.recall),
    },
];

/// Where the path goes and where recall is lost (not in the paper): the base path split by the
/// kind of chassis goal being driven to, the localization recoveries, and the ground-truth foreground objects not correctly
/// mapped at the end, split by whether any frame showed them well (`metrics.json` `views`).
pub const DIAGNOSIS: [MetricDef; 5] = [
    MetricDef {
        key: "path_gbv_m",
        label: "Path to GBVs / coverage waypoints (m)",
        better: Better::Lower,
        decimals: 2,
        get: |m| match (m.path_gbv_m, m.path_coverage_m) {
            (None, None) => None,
            (a, b) => Some(a.unwrap_or(0.0) + b.unwrap_or(0.0)),
        },
    },
    MetricDef {
        key: "path_explore_m",
        label: "Path to frontiers (m)",
        better: Better::Lower,
        decimals: 2,
        get: |m| m.path_explore_m,
    },
    MetricDef {
        key: "localization_recoveries",
        label: "Localization recoveries (lost > planner.recovery.lost_grace_s)",
        better: Better::Lower,
        decimals: 1,
        get: |m| m.localization_recoveries.map(f64::from),
    },
    MetricDef {
        key: "missed_never_well_seen",
        label: "Missed objects never well seen",
        better: Better::Lower,
        decimals: 2,
        get: |m| missed(m, false),
    },
    MetricDef {
        key: "missed_well_seen",
        label: "Missed objects well seen (not mapped, merged or > 0.1 m off)",
        better: Better::Lower,
        decimals: 2,
        get: |m| missed(m, true),
    },
];

/// Foreground ground-truth objects of a run not correctly mapped whose best frames did
/// (`well_seen`) or did not show them well (`ObjectViews::frames_well_seen`); `None` for a run
/// without view records.
fn missed(m: &Metrics, well_seen: bool) -> Option<f64> {
    if m.views.is_empty() {
        return None;
    }
    let n = m
        .per_object
        .iter()
        .filter(|o| !o.background && !o.correct)
        .filter(|o| {
            let seen = m
                .views
                .iter()
                .find(|v| v.name == o.name)
                .is_some_and(|v| v.frames_well_seen > 0);
            seen == well_seen
        })
        .count();
    Some(n as f64)
}

/// The paper's values (Tables 1 and 2), rows scene 1, 2, 3, Ave; columns VP-SOM, Cover,
/// Frontier; metrics in [`TABLE1`] / [`TABLE2`] order.
pub const PAPER_TABLE1: [[[f64; 3]; 4]; 4] = [
    [
        [0.90, 0.50, 0.38],
        [1.0, 1.0, 0.67],
        [0.769, 0.558, 0.590],
        [0.041, 0.084, 0.113],
    ],
    [
        [0.79, 0.64, 0.41],
        [1.0, 0.82, 0.63],
        [0.789, 0.562, 0.728],
        [0.089, 0.127, 0.103],
    ],
    [
        [0.59, 0.45, 0.35],
        [0.91, 0.82, 0.73],
        [0.795, 0.647, 0.401],
        [0.052, 0.062, 0.534],
    ],
    [
        [0.76, 0.53, 0.38],
        [0.97, 0.88, 0.68],
        [0.784, 0.589, 0.573],
        [0.061, 0.091, 0.250],
    ],
];

/// See [`PAPER_TABLE1`].
pub const PAPER_TABLE2: [[[f64; 3]; 4]; 4] = [
    [
        [10.39, 12.05, 8.58],
        [248.0, 295.0, 273.0],
        [0.631, 0.426, 0.279],
        [3.0, 4.0, 7.0],
    ],
    [
        [17.94, 21.22, 11.25],
        [385.0, 463.0, 472.0],
        [0.601, 0.519, 0.200],
        [7.0, 9.0, 14.0],
    ],
    [
        [18.80, 23.62, 19.55],
        [664.0, 830.0, 807.0],
        [0.464, 0.383, 0.239],
        [5.0, 6.0, 13.0],
    ],
    [
        [15.71, 18.96, 13.13],
        [432.0, 529.0, 517.0],
        [0.565, 0.443, 0.239],
        [5.0, 6.0, 11.0],
    ],
];

/// Column titles of the paper's planners.
pub const PAPER_PLANNERS: [&str; 3] = ["VP-SOM", "Cover", "Frontier"];

/// The tables, with their CSV names: each is one family of the Holm correction.
pub const TABLES: [(&str, &[MetricDef]); 4] = [
    ("table1", &TABLE1),
    ("table2", &TABLE2),
    ("health", &HEALTH),
    ("diagnosis", &DIAGNOSIS),
];

/// Mean, sample standard deviation (0 for one value) and count.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1 denominator); 0 when `n == 1`.
    pub std: f64,
    /// Number of values.
    pub n: usize,
}

impl Stat {
    /// Statistics of `values`; `None` when empty.
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.mean();
        let std = if n > 1 { values.std_dev() } else { 0.0 };
        Some(Stat { mean, std, n })
    }
}

/// Display title of a planner name (`vpsom` → `VP-SOM`, `cover`/`coverage` → `Cover`,
/// `frontier` → `Frontier`; anything else, e.g. an ablation, as is).
pub fn planner_title(name: &str) -> String {
    match paper_planner(name) {
        Some(i) => PAPER_PLANNERS[i].to_string(),
        None => name.to_string(),
    }
}

/// Column of the paper's tables for a planner name.
pub fn paper_planner(name: &str) -> Option<usize> {
    match name.to_ascii_lowercase().as_str() {
        "vpsom" | "vp-som" | "vp_som" => Some(0),
        "cover" | "coverage" | "all-views-coverage" => Some(1),
        "frontier" | "frontier-exploration" => Some(2),
        _ => None,
    }
}

/// Row of the paper's tables for a scene name: a name containing `paper` and ending in 1, 2 or 3
/// (e.g. `paper-scene-2`) is that scene; [`AVERAGE`] is the average row.
pub fn paper_scene(name: &str) -> Option<usize> {
    if name == AVERAGE {
        return Some(3);
    }
    if !name.to_ascii_lowercase().contains("paper") {
        return None;
    }
    let digits: String = name
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    match digits.parse::<usize>() {
        Ok(k @ 1..=3) => Some(k - 1),
        _ => None,
    }
}

/// Aggregated results of many runs.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Scenes, sorted by name.
    pub scenes: Vec<String>,
    /// Planners: the paper's three first (VP-SOM, Cover, Frontier), then the rest by name.
    pub planners: Vec<String>,
    /// Number of runs aggregated.
    pub runs: usize,
    /// The planner the paired differences start from (VP-SOM), if it ran.
    pub reference: Option<String>,
    cells: BTreeMap<(String, String, &'static str), Stat>,
    /// Further Markdown sections, placed before the definitions (e.g. [`super::diagnose`]'s).
    pub sections: String,
    /// (planner, metric) → CI of the "Ave" mean over rooms (with two rooms or more).
    cis: BTreeMap<(String, &'static str), Ci>,
    /// (other planner, metric) → reference − other, Holm over the metrics of a table.
    paired: BTreeMap<(String, &'static str), Paired>,
}

/// Values of one planner and metric per seed in one scene (finite values only).
pub fn values_by_seed(
    runs: &[Metrics],
    scene: &str,
    planner: &str,
    def: &MetricDef,
) -> BTreeMap<u64, f64> {
    runs.iter()
        .filter(|m| m.scene == scene && m.planner == planner)
        .filter_map(|m| Some((m.seed, (def.get)(m)?)))
        .filter(|(_, v)| v.is_finite())
        .collect()
}

/// Whether a paired difference `d` (x − y) is significant in x's favour (`Some(true)`), in
/// y's (`Some(false)`), or a tie (`None`); the direction is the signed ranks'.
pub fn verdict(def: &MetricDef, d: &Paired) -> Option<bool> {
    if !d.significant() || d.test.direction() == 0.0 {
        return None;
    }
    let up = d.test.direction() > 0.0;
    Some(up == (def.better == Better::Higher))
}

/// `p` for a table: three decimals, or `< 0.001`.
pub fn format_p(p: f64) -> String {
    if p < 0.001 {
        "< 0.001".to_string()
    } else {
        format!("{p:.3}")
    }
}

impl Report {
    /// Aggregate runs (any order, any mix of scenes, planners and seeds).
    pub fn from_metrics(runs: &[Metrics]) -> Report {
        let mut scenes: Vec<String> = runs.iter().map(|m| m.scene.clone()).collect();
        scenes.sort();
        scenes.dedup();
        let mut planners: Vec<String> = runs.iter().map(|m| m.planner.clone()).collect();
        planners.sort_by_key(|p| (paper_planner(p).unwrap_or(3), p.clone()));
        planners.dedup();
        let mut cells = BTreeMap::new();
        let mut cis = BTreeMap::new();
        for def in TABLE1
            .iter()
            .chain(&TABLE2)
            .chain(&HEALTH)
            .chain(&DIAGNOSIS)
        {
            for planner in &planners {
                let mut all = Vec::new();
                let mut rooms = Vec::new();
                for scene in &scenes {
                    let values: Vec<f64> = runs
                        .iter()
                        .filter(|m| &m.scene == scene && &m.planner == planner)
                        .filter_map(def.get)
                        .filter(|v| v.is_finite())
                        .collect();
                    all.extend_from_slice(&values);
                    if let Some(s) = Stat::of(&values) {
                        cells.insert((scene.clone(), planner.clone(), def.key), s);
                        rooms.push(values);
                    }
                }
                if let Some(s) = Stat::of(&all) {
                    cells.insert((AVERAGE.to_string(), planner.clone(), def.key), s);
                }
                if rooms.len() >= 2
                    && let Some(ci) = stats::mean_ci(&rooms)
                {
                    cis.insert((planner.clone(), def.key), ci);
                }
            }
        }
        let reference = planners
            .iter()
            .find(|p| paper_planner(p) == Some(0))
            .cloned();
        let mut paired = BTreeMap::new();
        for other in planners.iter().filter(|p| Some(*p) != reference.as_ref()) {
            let Some(r) = &reference else { break };
            for (_, defs) in TABLES {
                let mut family: Vec<(&'static str, Paired)> = defs
                    .iter()
                    .filter_map(|def| {
                        let rooms: Vec<Vec<f64>> = scenes
                            .iter()
                            .map(|scene| {
                                let a = values_by_seed(runs, scene, r, def);
                                let b = values_by_seed(runs, scene, other, def);
                                a.iter()
                                    .filter_map(|(seed, x)| Some(x - b.get(seed)?))
                                    .collect::<Vec<f64>>()
                            })
                            .filter(|d| !d.is_empty())
                            .collect();
                        Some((def.key, stats::paired(&rooms)?))
                    })
                    .collect();
                stats::holm_in_place(&mut family.iter_mut().map(|(_, d)| d).collect::<Vec<_>>());
                for (key, d) in family {
                    paired.insert((other.clone(), key), d);
                }
            }
        }
        Report {
            scenes,
            planners,
            runs: runs.len(),
            reference,
            cells,
            sections: String::new(),
            cis,
            paired,
        }
    }

    /// The CI of a planner's "Ave" mean over rooms (`None` with fewer than two rooms).
    pub fn ci(&self, planner: &str, key: &str) -> Option<Ci> {
        self.cis
            .iter()
            .find(|((p, k), _)| p == planner && *k == key)
            .map(|(_, v)| *v)
    }

    /// The paired difference reference (VP-SOM) − `other` of a metric, Holm-corrected over its
    /// table.
    pub fn paired(&self, other: &str, key: &str) -> Option<Paired> {
        self.paired
            .iter()
            .find(|((p, k), _)| p == other && *k == key)
            .map(|(_, v)| *v)
    }

    /// Planners bold in a row: only in the "Ave" row, VP-SOM when its paired difference from
    /// every other planner is significant in its favour, another planner when its difference
    /// from VP-SOM is significant in its favour.
    pub fn bold(&self, scene: &str, def: &MetricDef) -> Vec<String> {
        let Some(r) = self.reference.as_ref().filter(|_| scene == AVERAGE) else {
            return Vec::new();
        };
        let others: Vec<&String> = self.planners.iter().filter(|p| *p != r).collect();
        let verdicts: Vec<(&String, Option<bool>)> = others
            .iter()
            .map(|o| (*o, self.paired(o, def.key).and_then(|d| verdict(def, &d))))
            .collect();
        let mut bold = Vec::new();
        if !verdicts.is_empty() && verdicts.iter().all(|(_, v)| *v == Some(true)) {
            bold.push(r.clone());
        }
        bold.extend(
            verdicts
                .iter()
                .filter(|(_, v)| *v == Some(false))
                .map(|(o, _)| (*o).clone()),
        );
        bold
    }

    /// The statistics of one cell (`scene` may be [`AVERAGE`]; `key` a [`MetricDef::key`]).
    pub fn cell(&self, scene: &str, planner: &str, key: &str) -> Option<Stat> {
        self.cells
            .iter()
            .find(|((s, p, k), _)| s == scene && p == planner && *k == key)
            .map(|(_, v)| *v)
    }

    /// Planners whose mean is best in a row, compared at the displayed precision. Not a claim
    /// (no test): the report bolds by [`Report::bold`].
    pub fn best(&self, scene: &str, def: &MetricDef) -> Vec<String> {
        let scale = 10f64.powi(def.decimals as i32);
        let rounded: Vec<(String, f64)> = self
            .planners
            .iter()
            .filter_map(|p| {
                let s = self.cell(scene, p, def.key)?;
                let r = (s.mean * scale).round();
                Some((p.clone(), if def.better == Better::Higher { r } else { -r }))
            })
            .collect();
        let Some(top) = rounded.iter().map(|(_, v)| *v).reduce(f64::max) else {
            return Vec::new();
        };
        rounded
            .into_iter()
            .filter(|(_, v)| *v == top)
            .map(|(p, _)| p)
            .collect()
    }

    fn rows(&self) -> Vec<String> {
        let mut rows = self.scenes.clone();
        rows.push(AVERAGE.to_string());
        rows
    }

    /// Long-format CSV of a table: `table,scene,planner,metric,mean,std,n`.
    pub fn csv(&self, table: &str, defs: &[MetricDef]) -> String {
        // Writing equal-length records to memory cannot fail.
        const MEMORY: &str = "CSV into memory";
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(["table", "scene", "planner", "metric", "mean", "std", "n"])
            .expect(MEMORY);
        for scene in self.rows() {
            for def in defs {
                for planner in &self.planners {
                    if let Some(s) = self.cell(&scene, planner, def.key) {
                        w.write_record([
                            table,
                            &scene,
                            planner,
                            def.key,
                            &s.mean.to_string(),
                            &s.std.to_string(),
                            &s.n.to_string(),
                        ])
                        .expect(MEMORY);
                    }
                }
            }
        }
        String::from_utf8(w.into_inner().expect(MEMORY)).expect("CSV of UTF-8 fields is UTF-8")
    }

    /// The markdown report (tables, paper reference columns, optional figures).
    pub fn markdown(&self, figures: &[Figure]) -> String {
        let mut md = String::from("# vpsom-rt bench report\n\n");
        let _ = writeln!(
            md,
            "{} runs; scenes: {}; planners: {}.\n\nEach cell: mean ± sample std over seeds \
             (n = runs defining the metric). \"Ave\" pools all runs of a planner: mean [95 % CI, \
             bootstrap over rooms with the seeds of a room together, fixed seed] (n) with two rooms \
             or more. Below each table: paired differences VP-SOM − each other planner on the \
             same (scene, seed), mean [95 % CI over rooms], Wilcoxon signed-rank p Holm-corrected \
             over the table's metrics. Bold only where that difference is significant \
             (p_holm < 0.05): in the \"Ave\" row, VP-SOM when it wins against every other planner, \
             another planner when it wins against VP-SOM; anything else is a tie. Columns \
             `paper …` repeat the paper's Tables 1 and 2 (Gazebo, 5 runs per cell) for \
             comparison; scenes named `paper-…-1/2/3` map to its scenes 1–3.\n",
            self.runs,
            self.scenes.join(", "),
            self.planners
                .iter()
                .map(|p| planner_title(p))
                .collect::<Vec<_>>()
                .join(", ")
        );
        md.push_str("## Table 1. Sparse object map (foreground objects)\n\n");
        self.table_md(&mut md, &TABLE1, Some(&PAPER_TABLE1));
        md.push_str("\n## Table 2. Observation trajectory\n\n");
        self.table_md(&mut md, &TABLE2, Some(&PAPER_TABLE2));
        md.push_str("\n## Eq. 21 on true boxes, run health and background objects\n\n");
        self.table_md(&mut md, &HEALTH, None);
        md.push_str("\n## Where the path goes and where recall is lost\n\n");
        self.table_md(&mut md, &DIAGNOSIS, None);
        md.push_str(&self.sections);
        md.push_str(DEFINITIONS);
        if !figures.is_empty() {
            md.push_str("\n## Figures (one run per scene and planner, lowest seed)\n\n");
            for f in figures {
                let _ = writeln!(
                    md,
                    "### {} / {} (seed {})\n\n![{} {}]({})\n",
                    f.scene,
                    planner_title(&f.planner),
                    f.seed,
                    f.scene,
                    f.planner,
                    f.file_name
                );
            }
        }
        md
    }

    fn table_md(&self, md: &mut String, defs: &[MetricDef], paper: Option<&[[[f64; 3]; 4]; 4]>) {
        let mut header = String::from("| Scene | Metric |");
        let mut rule = String::from("|---|---|");
        for p in &self.planners {
            let _ = write!(header, " {} |", planner_title(p));
            rule.push_str("---|");
        }
        if paper.is_some() {
            for p in PAPER_PLANNERS {
                let _ = write!(header, " paper {p} |");
                rule.push_str("---|");
            }
        }
        let _ = writeln!(md, "{header}\n{rule}");
        for scene in self.rows() {
            for (row, def) in defs.iter().enumerate() {
                let bold = self.bold(&scene, def);
                let scene_col = if row == 0 { scene.as_str() } else { "" };
                let _ = write!(md, "| {scene_col} | {} |", def.label);
                for p in &self.planners {
                    let text = match self.cell(&scene, p, def.key) {
                        Some(s) => {
                            let body = match self.ci(p, def.key).filter(|_| scene == AVERAGE) {
                                Some(ci) => format!(
                                    "{:.d$} [{:.d$}, {:.d$}]",
                                    s.mean,
                                    ci.lo,
                                    ci.hi,
                                    d = def.decimals
                                ),
                                None => {
                                    format!("{:.d$} ± {:.d$}", s.mean, s.std, d = def.decimals)
                                }
                            };
                            if bold.contains(p) {
                                format!("**{body}** ({})", s.n)
                            } else {
                                format!("{body} ({})", s.n)
                            }
                        }
                        None => "–".to_string(),
                    };
                    let _ = write!(md, " {text} |");
                }
                if let Some(table) = paper {
                    // The paper's averages compare only with an average over its own scenes.
                    let all_paper = self.scenes.iter().all(|s| paper_scene(s).is_some());
                    match paper_scene(&scene).filter(|_| scene != AVERAGE || all_paper) {
                        Some(si) => {
                            for v in table[si][row] {
                                let _ = write!(md, " {v:.d$} |", d = def.decimals);
                            }
                        }
                        None => md.push_str(" – | – | – |"),
                    }
                }
                md.push('\n');
            }
        }
        self.paired_md(md, defs);
    }

    /// The paired differences of a table (nothing without VP-SOM and another planner).
    fn paired_md(&self, md: &mut String, defs: &[MetricDef]) {
        let Some(r) = &self.reference else { return };
        let others: Vec<&String> = self.planners.iter().filter(|p| *p != r).collect();
        if others.is_empty() {
            return;
        }
        let rt = planner_title(r);
        let _ = writeln!(
            md,
            "\nPaired differences, {rt} − other planner on the same (scene, seed): mean [95 % CI \
             over rooms], p_holm, verdict (pairs).\n"
        );
        let mut header = String::from("| Metric |");
        let mut rule = String::from("|---|");
        for o in &others {
            let _ = write!(header, " {rt} − {} |", planner_title(o));
            rule.push_str("---|");
        }
        let _ = writeln!(md, "{header}\n{rule}");
        for def in defs {
            let _ = write!(md, "| {} |", def.label);
            for o in &others {
                let text = match self.paired(o, def.key) {
                    Some(d) => {
                        let dd = def.decimals + 1;
                        let body =
                            format!("{:+.dd$} [{:+.dd$}, {:+.dd$}]", d.ci.mean, d.ci.lo, d.ci.hi);
                        let p = format_p(d.p_holm);
                        let n = d.test.n + d.test.zeros;
                        match verdict(def, &d) {
                            Some(true) => format!("**{body}** p {p}, {rt} better ({n})"),
                            Some(false) => {
                                format!("**{body}** p {p}, {} better ({n})", planner_title(o))
                            }
                            None => format!("{body} p {p}, tie ({n})"),
                        }
                    }
                    None => "–".to_string(),
                };
                let _ = write!(md, " {text} |");
            }
            md.push('\n');
        }
    }

    /// CSV of the "Ave" CIs: `planner,metric,mean,ci_lo,ci_hi,rooms,n`.
    pub fn ci_csv(&self) -> String {
        const MEMORY: &str = "CSV into memory";
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(["planner", "metric", "mean", "ci_lo", "ci_hi", "rooms", "n"])
            .expect(MEMORY);
        for (_, defs) in TABLES {
            for def in defs {
                for p in &self.planners {
                    if let Some(ci) = self.ci(p, def.key) {
                        w.write_record([
                            p,
                            def.key,
                            &ci.mean.to_string(),
                            &ci.lo.to_string(),
                            &ci.hi.to_string(),
                            &ci.clusters.to_string(),
                            &ci.n.to_string(),
                        ])
                        .expect(MEMORY);
                    }
                }
            }
        }
        String::from_utf8(w.into_inner().expect(MEMORY)).expect("CSV of UTF-8 fields is UTF-8")
    }

    /// CSV of the paired differences: `table,reference,other,metric,pairs,zeros,rooms,
    /// mean_diff,ci_lo,ci_hi,w_plus,w_minus,exact,p,p_holm,verdict` (verdict: the better
    /// planner, or `tie`).
    pub fn paired_csv(&self) -> String {
        const MEMORY: &str = "CSV into memory";
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record([
            "table",
            "reference",
            "other",
            "metric",
            "pairs",
            "zeros",
            "rooms",
            "mean_diff",
            "ci_lo",
            "ci_hi",
            "w_plus",
            "w_minus",
            "exact",
            "p",
            "p_holm",
            "verdict",
        ])
        .expect(MEMORY);
        let Some(r) = &self.reference else {
            return String::from_utf8(w.into_inner().expect(MEMORY)).expect("UTF-8");
        };
        for (table, defs) in TABLES {
            for def in defs {
                for o in self.planners.iter().filter(|p| *p != r) {
                    let Some(d) = self.paired(o, def.key) else {
                        continue;
                    };
                    let verdict = match verdict(def, &d) {
                        Some(true) => r.as_str(),
                        Some(false) => o.as_str(),
                        None => "tie",
                    };
                    w.write_record([
                        table,
                        r,
                        o,
                        def.key,
                        &(d.test.n + d.test.zeros).to_string(),
                        &d.test.zeros.to_string(),
                        &d.ci.clusters.to_string(),
                        &d.ci.mean.to_string(),
                        &d.ci.lo.to_string(),
                        &d.ci.hi.to_string(),
                        &d.test.w_plus.to_string(),
                        &d.test.w_minus.to_string(),
                        &d.test.exact.to_string(),
                        &d.test.p.to_string(),
                        &d.p_holm.to_string(),
                        verdict,
                    ])
                    .expect(MEMORY);
                }
            }
        }
        String::from_utf8(w.into_inner().expect(MEMORY)).expect("CSV of UTF-8 fields is UTF-8")
    }
}

const DEFINITIONS: &str = "
## Definitions

Foreground objects only (background objects in the health table). Each estimate is assigned to at
most one ground-truth object of the same class (Hungarian algorithm: most pairs closer than
0.1 m, then most pairs within 1 m, then least total distance). Precision = pairs closer than
0.1 m / estimates (0 with no estimate); Recall = the same / ground-truth objects; IoU = 3D IoU
after aligning centres and yaw (only sizes matter) and CDE = centre distance (m), both averaged
over all assigned pairs. Length of path = true base path (m); Cost time = simulated seconds to
termination; Non-occlusion = physically visible fraction of each ground-truth foreground object
in view (visible pixels of the true render / pixels of its unoccluded silhouette, both clipped to
the image, so truncation is not occlusion; every object, background object and wall occludes),
averaged over every (rendered frame, object) pair of the session, GBV and LBV views alike and the
same for every planner; an object is in view when its centre is within the depth range in front
of the camera and its unoccluded silhouette covers at least the detector's minimum pixels (the
paper's eq. 21 estimates the same on projected boxes; the planner's own H_IoU is
`planner_h_iou` in metrics.json); Non-occlusion, eq. 21 on true boxes (health table) = the
paper's Table 2 definition on the same pairs: 1 − Σ over the other foreground objects in view of
|b_i ∩ b_j| / |b_i|, clamped to [0, 1], b the bounding box of the unoccluded silhouette; compare
it, not the visible fraction, with the paper's figures; Localization failure = episodes of the failure model.
Path to GBVs / frontiers = the part of the path driven while the current chassis goal was a GBV
(or coverage waypoint) / a frontier (exploration). Missed objects = foreground ground-truth
objects not correctly mapped at the end: never well seen = no frame showed at least 256 of its
pixels (COCO's small-object limit at 320×240) with at least half its silhouette visible (the
planner never gave the detector a good view); well seen = some frame did (lost by the detector
or the mapper: not detected, merged with a neighbour, or estimated more than 0.1 m off).
";

/// Every `metrics.json` under the given paths: a path that is a file is taken as is, a
/// directory is searched recursively (e.g. `DIR/<scene>/<planner>/<seed>/metrics.json`).
/// Sorted, without duplicates.
pub fn find_metrics_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, EvalError> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), EvalError> {
        let entries = std::fs::read_dir(dir).map_err(|e| EvalError::io(dir, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| EvalError::io(dir, e))?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| EvalError::io(&path, e))?;
            if kind.is_dir() {
                walk(&path, out)?;
            } else if path.file_name().is_some_and(|n| n == METRICS_FILE) {
                out.push(path);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    for p in paths {
        let meta = std::fs::metadata(p).map_err(|e| EvalError::io(p, e))?;
        if meta.is_dir() {
            walk(p, &mut out)?;
        } else {
            out.push(p.clone());
        }
    }
    let mut keyed: Vec<(PathBuf, PathBuf)> = out
        .into_iter()
        .map(|p| (std::fs::canonicalize(&p).unwrap_or_else(|_| p.clone()), p))
        .collect();
    keyed.sort();
    keyed.dedup_by(|a, b| a.0 == b.0);
    Ok(keyed.into_iter().map(|(_, p)| p).collect())
}

/// Parse `metrics.json` files.
pub fn load_metrics(files: &[PathBuf]) -> Result<Vec<Metrics>, EvalError> {
    files.iter().map(|f| read_json(f)).collect()
}

/// Write `report.md`, `table1.csv`, `table2.csv`, `health.csv`, `diagnosis.csv`, `ci.csv` and
/// `paired.csv` into `out_dir` (created).
/// `figures` (e.g. from [`super::render_bench_figures`] into the same directory) are linked
/// from the markdown by file name.
pub fn write_report(out_dir: &Path, report: &Report, figures: &[Figure]) -> Result<(), EvalError> {
    std::fs::create_dir_all(out_dir).map_err(|e| EvalError::io(out_dir, e))?;
    let files = [
        ("report.md", report.markdown(figures)),
        ("table1.csv", report.csv("table1", &TABLE1)),
        ("table2.csv", report.csv("table2", &TABLE2)),
        ("health.csv", report.csv("health", &HEALTH)),
        ("diagnosis.csv", report.csv("diagnosis", &DIAGNOSIS)),
        ("ci.csv", report.ci_csv()),
        ("paired.csv", report.paired_csv()),
    ];
    for (name, text) in files {
        let path = out_dir.join(name);
        std::fs::write(&path, text).map_err(|e| EvalError::io(&path, e))?;
    }
    Ok(())
}

/// `vpsom report RUN_DIR... --out OUT` in one call: find and load every `metrics.json` under
/// `inputs`, render one figure per (scene, planner) into `out_dir` and write the report there.
pub fn report_dirs(inputs: &[PathBuf], out_dir: &Path) -> Result<Report, EvalError> {
    let files = find_metrics_files(inputs)?;
    let runs = load_metrics(&files)?;
    // In run order, not path order: shard folders merged give an unsharded bench's sums.
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by(|&a, &b| {
        let key = |m: &Metrics| (m.scene.clone(), m.planner.clone(), m.seed);
        key(&runs[a]).cmp(&key(&runs[b]))
    });
    let files: Vec<PathBuf> = order.iter().map(|&i| files[i].clone()).collect();
    let runs: Vec<Metrics> = order.iter().map(|&i| runs[i].clone()).collect();
    let mut report = Report::from_metrics(&runs);
    let (section, rows) = super::diagnose::report_files(&files, &runs)?;
    report.sections.push_str(&section);
    let figures = super::render_bench_figures(&files, out_dir)?;
    write_report(out_dir, &report, &figures)?;
    let path = out_dir.join(super::diagnose::CSV_FILE);
    std::fs::write(&path, rows).map_err(|e| EvalError::io(&path, e))?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_scene_and_planner_names() {
        assert_eq!(paper_scene("paper-scene-1"), Some(0));
        assert_eq!(paper_scene("paper-scene-3"), Some(2));
        assert_eq!(paper_scene("paper-scene-4"), None);
        assert_eq!(paper_scene("kitchen-2"), None);
        assert_eq!(paper_scene(AVERAGE), Some(3));
        assert_eq!(planner_title("vpsom"), "VP-SOM");
        assert_eq!(planner_title("coverage"), "Cover");
        assert_eq!(planner_title("vpsom-no-h_iou"), "vpsom-no-h_iou");
    }

    #[test]
    fn stat_uses_sample_std() {
        let s = Stat::of(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!((s.mean - 2.5).abs() < 1e-12);
        assert!((s.std - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(Stat::of(&[7.0]).unwrap().std, 0.0);
        assert!(Stat::of(&[]).is_none());
    }
}
