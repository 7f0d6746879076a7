//! Map scoring, metrics.json and map.json on hand-computed cases.

use shm_types::{
    Candidate, DeadlineEvent, FrameVisibility, ObjectMap, ObjectVisibility, PlannerDecision,
    RobotState, boxed_zeroed, class_id, decision_kind,
};
use std::path::PathBuf;
use vpsom::eval::metrics::{Layer, REQUIRED_KEYS};
use vpsom::eval::*;

fn gt(name: &str, class: &str, center: [f32; 3], size: [f32; 3]) -> GtObject {
    GtObject {
        name: name.into(),
        class: class.into(),
        background: false,
        center,
        size,
        yaw: 0.0,
    }
}

fn est(class: &str, center: [f32; 3], size: [f32; 3], yaw: f32) -> EstObject {
    EstObject {
        class: class.into(),
        background: false,
        center,
        size,
        yaw,
        h_sopm: 0.3,
        complete: true,
    }
}

fn fg(g: &[GtObject], e: &[EstObject]) -> MapScore {
    score_map(g, e, &MatchParams::default(), Layer::Foreground)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-5
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("eval_metrics")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn perfect_object_scores_one_and_zero_error() {
    let g = [gt("cup", "cup", [1.0, 2.0, 0.8], [0.1, 0.1, 0.12])];
    let s = fg(&g, &[est("cup", [1.0, 2.0, 0.8], [0.1, 0.1, 0.12], 0.0)]);
    assert_eq!((s.matched, s.assigned), (1, 1));
    assert!(close(s.precision, 1.0) && close(s.recall, 1.0));
    assert!(close(s.iou.unwrap(), 1.0));
    assert!(close(s.cde_m.unwrap(), 0.0));
    assert!(s.per_object[0].correct);
    assert_eq!(s.per_object[0].estimate, Some(0));
}

#[test]
fn shift_of_5_cm_is_correct_15_cm_is_not_but_counts_in_cde() {
    let g = [gt("book", "book", [0.0, 0.0, 0.5], [0.2, 0.3, 0.05])];
    let s = fg(&g, &[est("book", [0.05, 0.0, 0.5], [0.2, 0.3, 0.05], 0.0)]);
    assert!(close(s.precision, 1.0) && close(s.recall, 1.0));
    assert!(close(s.cde_m.unwrap(), 0.05));

    let s = fg(&g, &[est("book", [0.0, 0.15, 0.5], [0.2, 0.3, 0.05], 0.0)]);
    assert_eq!((s.matched, s.assigned), (0, 1));
    assert!(close(s.precision, 0.0) && close(s.recall, 0.0));
    assert!(close(s.cde_m.unwrap(), 0.15));
    assert!(close(s.iou.unwrap(), 1.0));

    // Beyond the 1 m gate nothing is assigned: IoU and CDE are undefined.
    let s = fg(&g, &[est("book", [1.5, 0.0, 0.5], [0.2, 0.3, 0.05], 0.0)]);
    assert_eq!(s.assigned, 0);
    assert_eq!((s.iou, s.cde_m), (None, None));
}

#[test]
fn wrong_class_is_never_matched() {
    let g = [gt("cup", "cup", [0.0, 0.0, 0.5], [0.1; 3])];
    let s = fg(&g, &[est("bottle", [0.0, 0.0, 0.5], [0.1; 3], 0.0)]);
    assert_eq!((s.matched, s.assigned), (0, 0));
    assert!(close(s.precision, 0.0) && close(s.recall, 0.0));
    assert_eq!(s.iou, None);
}

#[test]
fn duplicate_estimates_halve_precision() {
    let g = [gt("cup", "cup", [0.0, 0.0, 0.5], [0.1; 3])];
    let e = [
        est("cup", [0.02, 0.0, 0.5], [0.1; 3], 0.0),
        est("cup", [0.0, 0.03, 0.5], [0.1; 3], 0.0),
    ];
    let s = fg(&g, &e);
    assert_eq!((s.matched, s.assigned, s.objects_estimated), (1, 1, 2));
    assert!(close(s.precision, 0.5) && close(s.recall, 1.0));
    // The closer duplicate is the one assigned.
    assert_eq!(s.per_object[0].estimate, Some(0));
    assert!(close(s.cde_m.unwrap(), 0.02));
}

#[test]
fn iou_depends_on_size_only() {
    let g = [gt("box", "suitcase", [0.0, 0.0, 0.5], [1.0, 1.0, 1.0])];
    for yaw in [0.0, 0.4, -0.6] {
        let s = fg(
            &g,
            &[est("suitcase", [0.03, 0.0, 0.5], [0.5, 1.0, 1.0], yaw)],
        );
        assert!(close(s.iou.unwrap(), 0.5), "yaw {yaw}: {:?}", s.iou);
    }
}

#[test]
fn assignment_keeps_every_correct_model() {
    // Greedy by distance would pair e0 with g0 (0.05) and leave e1 with g1 beyond 0.1 m only;
    // here e0 is also correct for g1, e1 only for g0: the optimum keeps both correct.
    let g = [
        gt("a", "cup", [0.0, 0.0, 0.5], [0.1; 3]),
        gt("b", "cup", [0.12, 0.0, 0.5], [0.1; 3]),
    ];
    let e = [
        est("cup", [0.05, 0.0, 0.5], [0.1; 3], 0.0),
        est("cup", [-0.09, 0.0, 0.5], [0.1; 3], 0.0),
    ];
    let s = fg(&g, &e);
    assert_eq!(s.matched, 2);
    assert_eq!(s.per_object[0].estimate, Some(1));
    assert_eq!(s.per_object[1].estimate, Some(0));
    assert!(close(s.cde_m.unwrap(), (0.09 + 0.07) / 2.0));
}

#[test]
fn edge_cases_and_background_separation() {
    let g = [gt("cup", "cup", [0.0, 0.0, 0.5], [0.1; 3])];
    let s = fg(&g, &[]);
    assert!(close(s.precision, 0.0) && close(s.recall, 0.0));
    let s = fg(&[], &[est("cup", [0.0; 3], [0.1; 3], 0.0)]);
    assert!(close(s.precision, 0.0) && close(s.recall, 1.0));
    let s = fg(&[], &[]);
    assert!(close(s.precision, 0.0) && close(s.recall, 1.0));

    // A background table does not count in the foreground scores.
    let mut table = gt("desk", "dining table", [0.0, 0.0, 0.36], [1.8, 1.6, 0.72]);
    table.background = true;
    let mut table_est = est("dining table", [0.04, 0.0, 0.36], [1.8, 0.8, 0.72], 0.0);
    table_est.background = true;
    let g2 = [g[0].clone(), table];
    let e2 = [est("cup", [0.0, 0.0, 0.5], [0.1; 3], 0.0), table_est];
    let s = fg(&g2, &e2);
    assert_eq!((s.objects_gt, s.objects_estimated, s.matched), (1, 1, 1));
    let b = score_map(&g2, &e2, &MatchParams::default(), Layer::Background);
    assert_eq!((b.objects_gt, b.objects_estimated, b.matched), (1, 1, 1));
    assert!(close(b.iou.unwrap(), 0.5));
    assert_eq!(
        b.per_object[0].estimate,
        Some(1),
        "indexes the full estimate list"
    );
}

fn state(x: f32, y: f32, failures: u32) -> RobotState {
    RobotState {
        base_pose: [x, y, 0.0],
        localization_ok: 1,
        localization_failures: failures,
        ..Default::default()
    }
}

fn decision(kind: u8, h_iou: f32, in_view: u16) -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.kind = kind;
    d.count = 2;
    d.candidates[0] = Candidate {
        h_iou: 0.1,
        objects_in_view: 5,
        ..Default::default()
    };
    d.candidates[1] = Candidate {
        position: [1.0, 2.0, 1.4],
        yaw: 0.5,
        h_iou,
        objects_in_view: in_view,
        chosen: 1,
        ..Default::default()
    };
    d
}

fn sample_session() -> (SessionLog, Vec<GtObject>, Vec<EstObject>) {
    let mut log = SessionLog::starting_at(2_000_000_000);
    for (x, y, f) in [(0.0, 0.0, 0), (3.0, 0.0, 0), (3.0, 4.0, 1), (3.0, 4.0, 2)] {
        log.observe_truth(&state(x, y, f));
    }
    log.observe_decision(&decision(decision_kind::GBV, 0.8, 3));
    log.observe_decision(&decision(decision_kind::LBV, 0.4, 1));
    log.observe_decision(&decision(decision_kind::LBV, 0.9, 0)); // sees nothing: not averaged
    // Ground-truth visibility of three rendered frames: (60/100, 100/100), (20/80), nothing.
    let mut vis = boxed_zeroed::<FrameVisibility>();
    let seen = |object, visible_px, silhouette_px| ObjectVisibility {
        object,
        visible_px,
        silhouette_px,
        ..Default::default()
    };
    vis.count = 2;
    vis.items[0] = seen(0, 60, 100);
    vis.items[1] = seen(1, 100, 100);
    log.observe_visibility(&vis);
    vis.count = 1;
    vis.items[0] = seen(0, 20, 80);
    log.observe_visibility(&vis);
    vis.count = 0;
    log.observe_visibility(&vis);
    let mut no_choice = decision(decision_kind::LBV, 0.0, 0);
    no_choice.candidates[1].chosen = 0;
    log.observe_decision(&no_choice);
    for missed in [0, 1, 1, 0] {
        log.observe_deadline(&DeadlineEvent {
            missed,
            period_ns: 1,
            ..Default::default()
        });
    }
    log.add_deadline_misses(3);
    log.finish(14_500_000_000, true, "all clusters complete");
    let g = vec![
        gt("cup", "cup", [0.0, 0.0, 0.5], [0.1; 3]),
        gt("book", "book", [1.0, 0.0, 0.5], [0.2, 0.3, 0.05]),
    ];
    let e = vec![est("cup", [0.0, 0.05, 0.5], [0.1; 3], 0.0)];
    (log, g, e)
}

#[test]
fn session_log_accumulates_path_views_failures_and_misses() {
    let (log, g, e) = sample_session();
    let run = RunInfo {
        scene: "paper-scene-1".into(),
        planner: "vpsom".into(),
        seed: 7,
    };
    let m = log.metrics(&run, &g, &e, &MatchParams::default());
    assert!(close(m.path_length_m, 7.0));
    assert!(close(m.time_s, 12.5));
    assert!(m.terminated);
    assert_eq!(m.termination_reason, "all clusters complete");
    // Ground truth, pooled over (frame, object): (0.6 + 1.0 + 0.25) / 3.
    assert!(close(m.non_occlusion.unwrap(), 1.85 / 3.0));
    assert_eq!((m.non_occlusion_samples, m.non_occlusion_frames), (3, 2));
    // The planner's own H_IoU, pooled over (view, object): (0.8·3 + 0.4·1) / 4.
    assert!(close(m.planner_h_iou.unwrap(), 0.7));
    assert!(close(m.planner_h_iou_gbv.unwrap(), 0.8));
    assert!(close(m.planner_h_iou_lbv.unwrap(), 0.4));
    assert_eq!((m.gbv_count, m.lbv_count), (1, 2));
    assert_eq!(m.localization_failures, 2);
    assert_eq!(m.deadline_misses, 5);
    assert_eq!((m.objects_gt, m.objects_estimated, m.matched), (2, 1, 1));
    assert!(close(m.precision, 1.0) && close(m.recall, 0.5));
    assert_eq!(log.trajectory().len(), 3);
    assert_eq!(log.views().0[0].position, [1.0, 2.0, 1.4]);
}

#[test]
fn metrics_json_has_the_design_keys() {
    let (log, g, e) = sample_session();
    let run = RunInfo {
        scene: "s".into(),
        planner: "cover".into(),
        seed: 1,
    };
    let m = log.metrics(&run, &g, &e, &MatchParams::default());
    let v = serde_json::to_value(&m).unwrap();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    for k in REQUIRED_KEYS {
        assert!(keys.contains(&k), "missing {k}");
    }
    let extras = [
        "termination_reason",
        "matched",
        "assigned",
        "non_occlusion_samples",
        "non_occlusion_frames",
        "non_occlusion_eq21",
        "planner_h_iou",
        "planner_h_iou_gbv",
        "planner_h_iou_lbv",
        "gbv_count",
        "lbv_count",
        "match_params",
        "background",
        "per_object",
        "objects_given_up",
        "explored",
        "path_gbv_m",
        "path_explore_m",
        "path_coverage_m",
        "path_recovery_m",
        "localization_recoveries",
        "views",
    ];
    assert_eq!(keys.len(), REQUIRED_KEYS.len() + extras.len(), "{keys:?}");
    assert!(extras.iter().all(|k| keys.contains(k)));
    assert_eq!(v["seed"], 1);
    assert_eq!(v["terminated"], true);
    assert!(v["precision"].is_f64() && v["cde_m"].is_f64());
    // Undefined values are null, and a file with only the required keys parses.
    let mut minimal = serde_json::Map::new();
    for k in REQUIRED_KEYS {
        minimal.insert(k.into(), v[k].clone());
    }
    minimal.insert("iou".into(), serde_json::Value::Null);
    let back: Metrics = serde_json::from_value(minimal.into()).unwrap();
    assert_eq!(back.iou, None);
    assert_eq!(back.deadline_misses, m.deadline_misses);
}

#[test]
fn map_json_round_trips_and_rescores() {
    let mut map = boxed_zeroed::<ObjectMap>();
    map.count = 2;
    map.objects[0].class_id = class_id("cup").unwrap();
    map.objects[0].center = [0.0, 0.05, 0.5];
    map.objects[0].size = [0.1, 0.1, 0.1];
    map.objects[0].h_sopm = 0.3;
    map.objects[0].complete = 1;
    map.objects[1].class_id = class_id("dining table").unwrap();
    map.objects[1].background = 1;
    map.objects[1].center = [0.0, 0.0, 0.36];
    map.objects[1].size = [1.8, 1.6, 0.72];
    map.objects[1].yaw = 0.25;
    map.objects[1].h_sopm = 1.0;
    let file = MapFile::from_object_map("paper-scene-1", &map);
    assert_eq!(file.objects[1].class, "dining table");
    assert!(file.objects[1].background && !file.objects[1].complete);

    let dir = tmp("map");
    let path = dir.join("map.json");
    file.write(&path).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let mut keys: Vec<&str> = v["objects"][0]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "background",
            "center",
            "class",
            "complete",
            "h_sopm",
            "size",
            "yaw"
        ]
    );
    assert_eq!(v["scene"], "paper-scene-1");
    assert_eq!(MapFile::read(&path).unwrap(), file);

    let (_, g, _) = sample_session();
    let scores = rescore_map_file(&path, &g, &MatchParams::default()).unwrap();
    assert_eq!(scores.foreground.matched, 1);
    assert!(close(scores.foreground.recall, 0.5));
    assert_eq!(scores.background.objects_estimated, 1);

    // Invalid content names the file and the field.
    std::fs::write(
        &path,
        r#"{"scene":"s","objects":[{"class":"cup","background":false,"center":[0,0,0],
        "size":[0.1,-1,0.1],"yaw":0,"h_sopm":0.5,"complete":false}]}"#,
    )
    .unwrap();
    let e = MapFile::read(&path).unwrap_err().to_string();
    assert!(
        e.contains("objects[0].size") && e.contains("map.json"),
        "{e}"
    );
    std::fs::write(&path, r#"{"scene":"s","objects":[{"class":"cup"}]}"#).unwrap();
    assert!(matches!(MapFile::read(&path), Err(EvalError::Json { .. })));
}

/// The path split by goal kind and the per-object view record (`path_*_m`, `views`), and the
/// report's "where recall is lost" counts built on them.
#[test]
fn path_splits_by_goal_kind_and_views_say_where_recall_is_lost() {
    use shm_types::goal_kind;
    let mut log = SessionLog::new();
    // 1 m before any goal (counted in no kind), 2 m to a frontier, 3 m to a GBV.
    log.observe_truth(&state(0.0, 0.0, 0));
    log.observe_truth(&state(1.0, 0.0, 0));
    log.observe_goal(goal_kind::FRONTIER);
    log.observe_truth(&state(3.0, 0.0, 0));
    log.observe_goal(goal_kind::GBV);
    log.observe_truth(&state(3.0, 3.0, 0));
    // The cup (scene object 0) is well seen in one frame of two; the book (1) only as 100 px;
    // the vase (3) never; object 2 is the table (background).
    let mut vis = boxed_zeroed::<FrameVisibility>();
    let seen = |object, visible_px, silhouette_px| ObjectVisibility {
        object,
        visible_px,
        silhouette_px,
        ..Default::default()
    };
    vis.count = 2;
    vis.items[0] = seen(0, 300, 400);
    vis.items[1] = seen(1, 100, 120);
    log.observe_visibility(&vis);
    vis.items[0] = seen(0, 300, 900);
    log.observe_visibility(&vis);
    log.finish(1_000_000_000, true, "done");
    let mut table = gt("table", "dining table", [1.0, 0.0, 0.36], [1.0, 1.0, 0.72]);
    table.background = true;
    let g = vec![
        gt("cup", "cup", [0.0, 0.0, 0.5], [0.1; 3]),
        gt("book", "book", [1.0, 0.0, 0.5], [0.2, 0.3, 0.05]),
        table,
        gt("vase", "vase", [2.0, 0.0, 0.5], [0.1, 0.1, 0.3]),
    ];
    // Nothing mapped: all three foreground objects are missed.
    let run = RunInfo {
        scene: "s".into(),
        planner: "vpsom".into(),
        seed: 1,
    };
    let m = log.metrics(&run, &g, &[], &MatchParams::default());
    assert!(close(m.path_length_m, 6.0));
    assert!(close(m.path_explore_m.unwrap(), 2.0));
    assert!(close(m.path_gbv_m.unwrap(), 3.0));
    assert!(close(m.path_coverage_m.unwrap(), 0.0));
    let v: Vec<(&str, u64, u64, u32)> = m
        .views
        .iter()
        .map(|v| {
            (
                v.name.as_str(),
                v.frames,
                v.frames_well_seen,
                v.max_visible_px,
            )
        })
        .collect();
    assert_eq!(
        v,
        [("cup", 2, 1, 300), ("book", 2, 0, 100), ("vase", 0, 0, 0)],
        "foreground only, scene order; 300 of 900 px is less than half visible"
    );
    let r = Report::from_metrics(&[m]);
    let cell = |key| r.cell("s", "vpsom", key).unwrap().mean;
    assert!(close(cell("missed_well_seen"), 1.0), "the cup");
    assert!(
        close(cell("missed_never_well_seen"), 2.0),
        "the book and the vase"
    );
    assert!(close(cell("path_explore_m"), 2.0));
    assert!(close(cell("path_gbv_m"), 3.0));
    // A host that reports no goals leaves the split undefined.
    let (log, g, e) = sample_session();
    let m = log.metrics(&run, &g, &e, &MatchParams::default());
    assert_eq!((m.path_gbv_m, m.path_explore_m), (None, None));
}
