//! `vpsom replay`: a recorded lockstep session re-run on its recorded inputs reproduces every map,
//! decision and goal exactly (`--check`), a changed planner is reported as a divergence, and an
//! open-loop replay with another planner writes a new trace and its decision list.

use runtime::recorder::inspect;
use std::path::PathBuf;
use vpsom::config::Config;
use vpsom::lockstep::{self, SessionSpec};
use vpsom::recording::topic;
use vpsom::replay::{self, ReplaySpec};
use vpsom::sim::Scene;

/// A short recorded VP-SOM session (replay profile) at a small camera size.
fn recorded(tag: &str) -> (PathBuf, Config) {
    let dir = std::env::temp_dir().join(format!("vpsom-replay-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = Config::ideal_sensing().with_camera(160, 120, 10.0);
    // The recorder's default room: the lockstep host waits for the writer rather than drop, so
    // a loaded machine loses no input (an exact check refuses a trace with drops; issue 37).
    let cfg = lockstep::config_for(&base, "vpsom").unwrap();
    let spec = SessionSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: cfg.clone(),
        seed: 3,
        label: "vpsom".into(),
        max_sim_s: 12.0,
        record: Some(dir.join("trace.mcap")),
    };
    let r = lockstep::run_session(&spec, |_| {}).unwrap();
    assert_eq!(r.recorder.unwrap().drops.total_dropped(), 0);
    (dir, cfg)
}

#[test]
fn check_reproduces_a_lockstep_session_exactly_and_reports_a_changed_planner() {
    let (dir, cfg) = recorded("check");
    let trace = dir.join("trace.mcap");
    let r = replay::replay(&ReplaySpec {
        trace: trace.clone(),
        config: cfg.clone(),
        check: true,
        out: None,
    })
    .unwrap();
    assert_eq!(r.divergence, None, "{r}");
    let info = inspect::info(&trace).unwrap();
    for t in [
        topic::MAP,
        topic::DECISIONS,
        topic::NECK_GOAL,
        topic::NAV_GOAL,
    ] {
        assert!(r.compared[t] > 0, "{t}: nothing compared\n{r}");
        assert_eq!(
            r.compared[t],
            info.count(t),
            "{t}: every recorded output compared"
        );
    }
    assert_eq!(r.frames, info.count(topic::DEPTH));

    // The same inputs through another F(v): the first LBV decision already differs.
    let other = lockstep::config_for(&cfg, "vpsom-no-h_iou").unwrap();
    let r = replay::replay(&ReplaySpec {
        trace,
        config: other,
        check: true,
        out: None,
    })
    .unwrap();
    let d = r.divergence.expect("a changed planner must diverge");
    assert_eq!(d.topic, topic::DECISIONS, "{d}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn open_loop_replay_with_another_planner_writes_a_trace_and_a_decision_list() {
    let (dir, cfg) = recorded("open");
    let out = dir.join("replay-coverage");
    let r = replay::replay(&ReplaySpec {
        trace: dir.join("trace.mcap"),
        config: lockstep::config_for(&cfg, "coverage").unwrap(),
        check: false,
        out: Some(out.clone()),
    })
    .unwrap();
    assert!(r.divergence.is_none());
    let info = inspect::info(&out.join("trace.mcap")).unwrap();
    assert!(info.end.complete, "{info}");
    assert_eq!(info.count(topic::MAP), r.produced[topic::MAP]);
    assert_eq!(info.count(topic::NAV_GOAL), r.produced[topic::NAV_GOAL]);
    let csv = std::fs::read_to_string(out.join("decisions.csv")).unwrap();
    let rows = csv.lines().count() as u64 - 1;
    assert_eq!(rows, r.produced.get(topic::DECISIONS).copied().unwrap_or(0));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    assert_eq!(m["open_loop"], true);
    assert!(m["foreground"]["objects_gt"].as_u64().unwrap() > 0, "{m}");
    let _ = std::fs::remove_dir_all(&dir);
}
