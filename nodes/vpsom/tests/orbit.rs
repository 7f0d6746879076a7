//! The orbit experiment (issue #34) end to end: the robot circles the desk of paper-scene-1 and
//! the map is scored after each lap; and the verdict's rule on hand-made laps.

use vpsom::config::Config;
use vpsom::orbit::{LapScore, OrbitObject, OrbitResult, OrbitSpec, run_orbit};
use vpsom::sim::Scene;

#[test]
fn the_orbit_scores_every_desk_object_after_each_lap() {
    let base = Config::builtin();
    let b = base.bench;
    let spec = OrbitSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: base.with_camera(b.camera_width, b.camera_height, b.camera_hz),
        seed: 1,
        laps: 2,
        waypoints: 12,
    };
    let r = run_orbit(&spec).unwrap();
    println!("{}", r.table());
    assert_eq!(r.cluster, "desk");
    assert_eq!(r.lap_end_s.len(), 2);
    assert!(r.lap_end_s[1] > r.lap_end_s[0]);
    assert!(r.objects.len() >= 5, "{} desk objects", r.objects.len());
    for o in &r.objects {
        assert_eq!(o.laps.len(), 2, "{}", o.name);
        assert!(
            o.laps[1].frames > o.laps[0].frames,
            "{}: seen on lap 2",
            o.name
        );
    }
    // Most objects are in the map (the glass bottles may not be), and the floor levels most
    // frames' poses (the camera looks down at the floor around the desk).
    let mapped = r.objects.iter().filter(|o| o.laps[1].iou.is_some()).count();
    assert!(
        mapped * 3 >= r.objects.len() * 2,
        "{mapped} of {} mapped",
        r.objects.len()
    );
    let (frames, levelled) = r.frames;
    assert!(
        levelled * 2 > frames,
        "{levelled} of {frames} frames levelled"
    );
}

#[test]
fn a_regression_is_a_fall_in_iou_beyond_the_slack_or_a_growing_centre_error() {
    let lap = |iou, c| LapScore {
        iou,
        centre_m: c,
        frames: 100,
    };
    let obj = |name: &str, px, laps| OrbitObject {
        name: name.into(),
        max_visible_px: px,
        laps,
    };
    let r = OrbitResult {
        cluster: "desk".into(),
        radius_m: 2.0,
        waypoints: 12,
        lap_end_s: vec![50.0, 100.0],
        frames: (10, 5),
        yaw_offset_deg: 0.0,
        objects: vec![
            obj(
                "steady",
                500,
                vec![lap(Some(0.70), Some(0.02)), lap(Some(0.69), Some(0.02))],
            ),
            obj(
                "shrinks",
                500,
                vec![lap(Some(0.70), Some(0.02)), lap(Some(0.60), Some(0.02))],
            ),
            obj(
                "drifts",
                500,
                vec![lap(Some(0.70), Some(0.02)), lap(Some(0.70), Some(0.05))],
            ),
            obj(
                "lost",
                500,
                vec![lap(Some(0.70), Some(0.02)), lap(None, None)],
            ),
            obj(
                "tiny",
                30,
                vec![lap(Some(0.70), Some(0.02)), lap(Some(0.10), Some(0.30))],
            ),
        ],
    };
    let bad = r.regressions(0.02, 0.0);
    assert_eq!(
        bad,
        vec![
            "shrinks: IoU 0.700 → 0.600",
            "drifts: centre error 0.020 → 0.050 m",
            "lost: lost from the map",
        ]
    );
    let table = r.table();
    assert!(table.contains("| mean of 4 |"), "{table}");
}
