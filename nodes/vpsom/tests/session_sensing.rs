//! A VP-SOM session with the DEFAULT, realistic sensing (YOLO-class boxes with false positives,
//! duplicates and persistent confusion, Kinect-like depth artefacts, 6-DoF visual-SLAM pose
//! errors): the mapper keeps a usable map, no false positive is published before it has been
//! detected again, and the headline is the committed golden one.
//!
//! **Golden headline.** A lockstep session is deterministic: paper-scene-1, seed 1, at the
//! bench's camera must give exactly the precision, recall, IoU, CDE, path length and termination
//! of `tests/golden/paper-scene-1-vpsom-1.json`. A change that moves them (a mapper or planner
//! default, a sensing rate) updates that file in the same commit (`VPSOM_GOLDEN_UPDATE=1 cargo
//! test --release -p vpsom --test session_sensing` rewrites it), and the commit message says why.

use std::path::Path;
use vpsom::config::Config;
use vpsom::lockstep::{self, SessionSpec};
use vpsom::sim::Scene;

#[test]
fn vpsom_keeps_a_usable_map_under_realistic_sensing() {
    let base = Config::builtin();
    let b = base.bench;
    let cfg = base.with_camera(b.camera_width, b.camera_height, b.camera_hz);
    let min_obs = cfg.mapper.min_observations;
    let s = SessionSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: lockstep::config_for(&cfg, "vpsom").unwrap(),
        seed: 1,
        label: "vpsom".into(),
        max_sim_s: b.max_sim_s,
        record: None,
    };
    let r = lockstep::run_session(&s, |_| {}).unwrap();
    assert!(r.summary.status.is_finished(), "{}", r.summary);
    assert!(r.metrics.precision >= 0.5, "{:?}", r.metrics);
    assert!(r.metrics.recall >= 0.3, "{:?}", r.metrics);
    // Every published object was detected at least `min_observations` times: a one-off false
    // positive never reaches the map.
    for o in r.map.objects() {
        assert!(o.observations >= min_obs, "{o:?}");
    }
    golden(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/paper-scene-1-vpsom-1.json"),
        &r.metrics,
    );
}

/// The headline of a run, as the golden file holds it.
fn headline(m: &vpsom::eval::Metrics) -> serde_json::Value {
    serde_json::json!({
        "precision": m.precision,
        "recall": m.recall,
        "iou": m.iou,
        "cde_m": m.cde_m,
        "path_length_m": m.path_length_m,
        "terminated": m.terminated,
    })
}

/// Compare the headline with `file` (or rewrite it with `VPSOM_GOLDEN_UPDATE=1`).
fn golden(file: &Path, m: &vpsom::eval::Metrics) {
    let got = headline(m);
    if std::env::var("VPSOM_GOLDEN_UPDATE").as_deref() == Ok("1") {
        std::fs::write(file, serde_json::to_string_pretty(&got).unwrap() + "\n").unwrap();
        return;
    }
    let want: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    // Numbers equal to 1e-9 relative (a JSON round trip may move the last digit).
    let same = |a: &serde_json::Value, b: &serde_json::Value| match (a.as_f64(), b.as_f64()) {
        (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(1.0),
        _ => a == b,
    };
    let keys = [
        "precision",
        "recall",
        "iou",
        "cde_m",
        "path_length_m",
        "terminated",
    ];
    assert!(
        keys.iter().all(|k| same(&got[k], &want[k])),
        "{got} against {want}: \
        the golden headline moved ({}). If the change is meant, rewrite the file with \
         VPSOM_GOLDEN_UPDATE=1 in the same commit and say why in its message.",
        file.display()
    );
}
