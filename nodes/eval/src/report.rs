//! The bench report: the paper's Tables 1 and 2 from many `metrics.json` (scene × planner × seed).
//!
//! Each cell is mean ± sample standard deviation over the runs of that scene and planner, with
//! the number of runs that define the metric (a run whose IoU or CDE is null, because nothing
//! was assigned, does not enter those cells). The "Ave" row pools every run of a planner over
//! all scenes; with the same number of seeds per scene this equals the paper's mean of the scene
//! means. The best planner per row is bold (ties at the displayed precision are all bold).

use super::metrics::Metrics;
use super::plot::Figure;
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
    cells: BTreeMap<(String, String, &'static str), Stat>,
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
        for def in TABLE1
            .iter()
            .chain(&TABLE2)
            .chain(&HEALTH)
            .chain(&DIAGNOSIS)
        {
            for planner in &planners {
                let mut all = Vec::new();
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
                    }
                }
                if let Some(s) = Stat::of(&all) {
                    cells.insert((AVERAGE.to_string(), planner.clone(), def.key), s);
                }
            }
        }
        Report {
            scenes,
            planners,
            runs: runs.len(),
            cells,
        }
    }

    /// The statistics of one cell (`scene` may be [`AVERAGE`]; `key` a [`MetricDef::key`]).
    pub fn cell(&self, scene: &str, planner: &str, key: &str) -> Option<Stat> {
        self.cells
            .iter()
            .find(|((s, p, k), _)| s == scene && p == planner && *k == key)
            .map(|(_, v)| *v)
    }

    /// Planners whose mean is best in a row (bold), compared at the displayed precision.
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
             (n = runs defining the metric). Bold: best planner of the row. \"Ave\" pools all \
             runs of a planner. Columns `paper …` repeat the paper's Tables 1 and 2 (Gazebo, \
             5 runs per cell) for comparison; scenes named `paper-…-1/2/3` map to its scenes \
             1–3.\n",
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
                let best = self.best(&scene, def);
                let scene_col = if row == 0 { scene.as_str() } else { "" };
                let _ = write!(md, "| {scene_col} | {} |", def.label);
                for p in &self.planners {
                    let text = match self.cell(&scene, p, def.key) {
                        Some(s) => {
                            let body = format!("{:.d$} ± {:.d$}", s.mean, s.std, d = def.decimals);
                            if best.contains(p) {
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

/// Write `report.md`, `table1.csv`, `table2.csv` and `health.csv` into `out_dir` (created).
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
    let mut runs = load_metrics(&files)?;
    // In run order, not path order: shard folders merged give an unsharded bench's sums.
    runs.sort_by(|a, b| (&a.scene, &a.planner, a.seed).cmp(&(&b.scene, &b.planner, b.seed)));
    let report = Report::from_metrics(&runs);
    let figures = super::render_bench_figures(&files, out_dir)?;
    write_report(out_dir, &report, &figures)?;
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
