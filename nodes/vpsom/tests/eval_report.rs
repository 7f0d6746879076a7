//! Bench report: aggregation, bolding, CSVs, directory scan and figures on fixed inputs.

use serde_json::json;
use std::path::PathBuf;
use vpsom::eval::metrics::REQUIRED_KEYS;
use vpsom::eval::report::{AVERAGE, TABLE1, TABLE2, report_dirs};
use vpsom::eval::*;

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("eval_report")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A run with the given precision, CDE and path length (other keys fixed).
fn run(
    scene: &str,
    planner: &str,
    seed: u64,
    precision: f64,
    cde: Option<f64>,
    path: f64,
) -> Metrics {
    let v = json!({
        "scene": scene, "planner": planner, "seed": seed, "terminated": seed != 2,
        "objects_gt": 10, "objects_estimated": 10, "precision": precision, "recall": 1.0,
        "iou": cde.map(|_| 0.7), "cde_m": cde, "path_length_m": path, "time_s": 100.0 * seed as f64,
        "non_occlusion": 0.5, "localization_failures": seed, "deadline_misses": 0
    });
    assert_eq!(v.as_object().unwrap().len(), REQUIRED_KEYS.len());
    serde_json::from_value(v).unwrap()
}

fn runs() -> Vec<Metrics> {
    let s1 = "paper-scene-1";
    vec![
        run(s1, "vpsom", 1, 0.8, Some(0.04), 10.0),
        run(s1, "vpsom", 2, 1.0, Some(0.06), 12.0),
        run(s1, "cover", 1, 0.5, Some(0.08), 12.0),
        run(s1, "cover", 2, 0.5, Some(0.10), 14.0),
        run(s1, "frontier", 1, 0.3, None, 8.0),
        run(s1, "frontier", 2, 0.5, Some(0.2), 9.0),
        run(s1, "vpsom-no-h_iou", 1, 0.9, Some(0.05), 11.0),
        run(s1, "vpsom-no-h_iou", 2, 0.9, Some(0.05), 11.0),
        run("kitchen", "vpsom", 1, 0.6, Some(0.05), 20.0),
        run("kitchen", "cover", 1, 0.7, Some(0.05), 25.0),
    ]
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn cells_are_mean_std_n_over_seeds_and_ave_pools_runs() {
    let r = Report::from_metrics(&runs());
    assert_eq!(r.runs, 10);
    assert_eq!(r.scenes, ["kitchen", "paper-scene-1"]);
    assert_eq!(r.planners, ["vpsom", "cover", "frontier", "vpsom-no-h_iou"]);
    let c = r.cell("paper-scene-1", "vpsom", "precision").unwrap();
    assert!(close(c.mean, 0.9) && close(c.std, 0.02f64.sqrt()) && c.n == 2);
    let c = r.cell("paper-scene-1", "cover", "precision").unwrap();
    assert!(close(c.mean, 0.5) && close(c.std, 0.0));
    // A null CDE leaves the run out of that cell only.
    let c = r.cell("paper-scene-1", "frontier", "cde_m").unwrap();
    assert!(close(c.mean, 0.2) && c.n == 1);
    assert_eq!(
        r.cell("paper-scene-1", "frontier", "precision").unwrap().n,
        2
    );
    let c = r.cell(AVERAGE, "vpsom", "precision").unwrap();
    assert!(close(c.mean, 0.8) && c.n == 3);
    assert!(r.cell("kitchen", "frontier", "precision").is_none());
    let t = r.cell(AVERAGE, "vpsom", "terminated").unwrap();
    assert!(close(t.mean, 2.0 / 3.0));
}

/// The highest mean per row (`best`) is still computed, but bold now needs a significant
/// paired difference (issue 46): these few runs (3 pairs at most) make every difference a tie.
#[test]
fn best_mean_by_direction_with_ties_is_not_bold_without_a_test() {
    let r = Report::from_metrics(&runs());
    let [precision, _, _, cde] = TABLE1;
    let [path, _, _, failures] = TABLE2;
    assert_eq!(
        r.best("paper-scene-1", &precision),
        ["vpsom", "vpsom-no-h_iou"]
    );
    assert_eq!(r.best("kitchen", &precision), ["cover"]);
    assert_eq!(r.best("paper-scene-1", &cde), ["vpsom", "vpsom-no-h_iou"]);
    assert_eq!(r.best("paper-scene-1", &path), ["frontier"]);
    assert_eq!(r.best("paper-scene-1", &failures).len(), 4);

    for def in TABLE1.iter().chain(&TABLE2) {
        for scene in ["paper-scene-1", "kitchen", AVERAGE] {
            assert!(r.bold(scene, def).is_empty(), "{scene} {}", def.key);
        }
    }

    let md = r.markdown(&[]);
    assert!(!md.contains("**"), "{md}");
    assert!(
        md.contains(
            "| paper-scene-1 | Precision | 0.90 ± 0.14 (2) | 0.50 ± 0.00 (2) | \
             0.40 ± 0.14 (2) | 0.90 ± 0.00 (2) | 0.90 | 0.50 | 0.38 |"
        ),
        "{md}"
    );
    assert!(md.contains(
        "| paper-scene-1 | Length of path | 11.00 ± 1.41 (2) | 13.00 ± 1.41 (2) | 8.50 ± 0.71 (2) |"
    ));
    assert!(md.contains(
        "| kitchen | Precision | 0.60 ± 0.00 (1) | 0.70 ± 0.00 (1) | – | – | – | – | – |"
    ));
    // The average pools a non-paper room, so the paper's averages are not put beside it. With
    // two rooms it carries the CI over rooms: VP-SOM's resamples are kitchen twice (0.6), both
    // (2.4 / 3 = 0.8) or paper-scene-1 twice (0.9); Cover's 0.7, 0.567 or 0.5. Frontier and
    // the ablation ran one room: mean ± std.
    assert!(
        md.contains(
            "| Ave | Precision | 0.80 [0.60, 0.90] (3) | 0.57 [0.50, 0.70] (3) | \
             0.40 ± 0.14 (2) | 0.90 ± 0.00 (2) | – | – | – |"
        ),
        "{md}"
    );
    // Paired differences VP-SOM − other: precision against Cover over (paper-scene-1, 1),
    // (paper-scene-1, 2), (kitchen, 1) = +0.3, +0.5, −0.1, mean 0.233; three pairs: a tie.
    assert!(
        md.contains("| Metric | VP-SOM − Cover | VP-SOM − Frontier | VP-SOM − vpsom-no-h_iou |")
    );
    let p = r.paired("cover", "precision").unwrap();
    assert_eq!((p.test.n, p.test.w_plus, p.test.w_minus), (3, 5.0, 1.0));
    assert!(close(p.ci.mean, 0.7 / 3.0));
    assert!(
        md.contains("| Precision | +0.233 [-0.100, +0.400] p 1.000, tie (3) |"),
        "{md}"
    );
    // Over the paper's scenes only, they are.
    let paper_only: Vec<_> = runs()
        .into_iter()
        .filter(|m| m.scene.starts_with("paper"))
        .collect();
    let md = Report::from_metrics(&paper_only).markdown(&[]);
    assert!(
        md.contains("| Ave | Precision | 0.90 ± 0.14 (2) | 0.50 ± 0.00 (2) |"),
        "{md}"
    );
    assert!(
        md.lines()
            .any(|l| l.starts_with("| Ave | Precision") && l.ends_with("| 0.76 | 0.53 | 0.38 |")),
        "{md}"
    );
    assert!(md.contains("| VP-SOM | Cover | Frontier | vpsom-no-h_iou | paper VP-SOM |"));
}

/// Eight rooms × two seeds: VP-SOM's precision is 0.3 above Cover's in every pair, Cover's path
/// 2 m shorter in every pair, recall equal. Bold goes to the winner of each significant paired
/// difference, in the "Ave" row only; the equal metric is a tie.
#[test]
fn bold_follows_significant_paired_differences() {
    let mut runs = Vec::new();
    for k in 0..8 {
        let scene = format!("room-{k}");
        let x = 0.01 * k as f64;
        for seed in 1..=2 {
            runs.push(run(&scene, "vpsom", seed, 0.6 + x, Some(0.05), 12.0 + x));
            runs.push(run(&scene, "cover", seed, 0.3 + x, Some(0.05), 10.0 + x));
        }
    }
    let r = Report::from_metrics(&runs);
    let [precision, recall, _, _] = TABLE1;
    let [path, _, _, _] = TABLE2;
    assert_eq!(r.bold(AVERAGE, &precision), ["vpsom"]);
    assert_eq!(r.bold(AVERAGE, &path), ["cover"]);
    assert!(r.bold(AVERAGE, &recall).is_empty());
    assert!(r.bold("room-3", &precision).is_empty());
    // 16 pairs, all +0.3 (one tie group): z = (136 − 68 − 0.5) / 17, p = 7.2e-5; Holm over the
    // 4 metrics of Table 1 (two all-zero: p = 1).
    let p = r.paired("cover", "precision").unwrap();
    assert_eq!((p.test.n, p.test.w_plus), (16, 136.0));
    assert!(p.test.p < 1e-4 && p.p_holm < 4e-4 && p.p_holm >= p.test.p);
    let md = r.markdown(&[]);
    let line = |start: &str| {
        md.lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("{start}\n{md}"))
            .to_string()
    };
    assert!(
        line("| Ave | Precision | **0.").contains("]** (16) | 0."),
        "{md}"
    );
    assert!(
        line("| Ave | Length of path | ").contains("| **10."),
        "{md}"
    );
    assert!(
        md.contains("| Precision | **+0.300 [+0.300, +0.300]** p < 0.001, VP-SOM better (16) |"),
        "{md}"
    );
    assert!(
        md.contains("| Recall | +0.000 [+0.000, +0.000] p 1.000, tie (16) |"),
        "{md}"
    );
    assert!(
        md.contains(
            "| Length of path | **+2.000 [+2.000, +2.000]** p < 0.001, Cover better (16) |"
        ),
        "{md}"
    );
    let csv = r.paired_csv();
    assert!(csv.lines().any(|l| l.starts_with("table1,vpsom,cover,precision,16,0,8,")
        && l.ends_with(",vpsom")), "{csv}");
    assert!(
        csv.lines()
            .any(|l| l.starts_with("table1,vpsom,cover,recall,16,16,8,") && l.ends_with(",tie")),
        "{csv}"
    );
}

#[test]
fn csv_is_long_format_with_every_cell() {
    let r = Report::from_metrics(&runs());
    let csv = r.csv("table1", &TABLE1);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("table,scene,planner,metric,mean,std,n"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 7 && r[0] == "table1"));
    let row = rows
        .iter()
        .find(|r| r[1] == "paper-scene-1" && r[2] == "frontier" && r[3] == "cde_m")
        .unwrap();
    assert!(close(row[4].parse().unwrap(), 0.2) && row[6] == "1");
    // kitchen: 2 planners × 4 metrics; paper-scene-1: 4 × 4; Ave: 4 × 4.
    assert_eq!(rows.len(), 8 + 16 + 16);
}

#[test]
fn directory_scan_writes_report_tables_and_figures() {
    let root = tmp("runs");
    let room = Room {
        min: [-3.0, -2.0],
        max: [2.0, 2.0],
    };
    let gt = vec![GtObject {
        name: "cup".into(),
        class: "cup".into(),
        background: false,
        center: [0.0, 0.0, 0.8],
        size: [0.1; 3],
        yaw: 0.0,
    }];
    for m in runs() {
        let dir = root
            .join(&m.scene)
            .join(&m.planner)
            .join(m.seed.to_string());
        if m.scene == "kitchen" {
            // Runs without plot.json are aggregated but get no figure.
            std::fs::create_dir_all(&dir).unwrap();
            let text = serde_json::to_string(&m).unwrap();
            std::fs::write(dir.join(METRICS_FILE), text).unwrap();
            continue;
        }
        let info = RunInfo {
            scene: m.scene.clone(),
            planner: m.planner.clone(),
            seed: m.seed,
        };
        let mut log = SessionLog::new();
        let plot = log.plot_input(&info, room, &gt, &[], &m);
        log.finish(0, true, "");
        write_run_outputs(&dir, &m, &[], &plot).unwrap();
        assert!(dir.join(MAP_FILE).is_file() && dir.join(FIGURE_FILE).is_file());
    }
    std::fs::write(root.join("notes.txt"), "not a run").unwrap();

    // The same tree given twice, once as a file path, is read once.
    let files =
        find_metrics_files(&[root.clone(), root.join("kitchen/vpsom/1/metrics.json")]).unwrap();
    assert_eq!(files.len(), 10);

    let out = tmp("out");
    let r = report_dirs(&[root], &out).unwrap();
    assert_eq!(r.runs, 10);
    for f in [
        "report.md",
        "table1.csv",
        "table2.csv",
        "health.csv",
        "ci.csv",
        "paired.csv",
        "figure10.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let figs: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("fig_"))
        .collect();
    assert_eq!(figs.len(), 4, "{figs:?}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("(fig_paper-scene-1_vpsom-no-h_iou.png)"));
    assert!(md.contains("### paper-scene-1 / VP-SOM (seed 1)"));
}

#[test]
fn bad_metrics_file_is_reported_with_its_path() {
    let dir = tmp("bad").join("s/p/1");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(METRICS_FILE), r#"{"scene": "s"}"#).unwrap();
    let files = find_metrics_files(std::slice::from_ref(&dir)).unwrap();
    let e = load_metrics(&files).unwrap_err().to_string();
    assert!(
        e.contains("s/p/1/metrics.json") && e.contains("missing field"),
        "{e}"
    );
    assert!(find_metrics_files(&[dir.join("nope")]).is_err());
}
