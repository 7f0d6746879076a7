//! A VP-SOM session with the DEFAULT, realistic sensing (YOLO-class boxes with false positives and
//! persistent confusion, Kinect-like depth artefacts, visual-SLAM pose errors): the mapper keeps a
//! usable map and no false positive is published before it has been detected again.
//!
//! Guard at the measured state (issue #14, 2 seeds × 3 paper scenes at 320×240: VP-SOM precision
//! 0.76, recall 0.52; this scene and seed: precision 0.67, recall 0.44). The targets
//! (precision ≥ 0.85, recall ≥ 0.95) are not reached yet; raise these bounds as the mapper improves.

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
}
