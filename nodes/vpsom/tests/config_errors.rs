//! Bad values in each logic crate's config section are refused with the key named, through the
//! app's whole-file parse (the path a user's file takes).

use std::path::Path;
use vpsom::config::Config;
use vpsom::planner::{Occluders, PlannerKind};

#[test]
fn bad_values_name_the_key() {
    let f = Path::new("t.toml");
    let e = Config::parse(f, "[sim]\nnoise_b = -1.0\n").unwrap_err();
    assert_eq!(e.key(), "sim.noise_b");
    let e = Config::parse(f, "[detector]\nconfusion_groups = [[\"cup\", \"mug\"]]\n").unwrap_err();
    assert_eq!(e.key(), "detector.confusion_groups[0][1]", "{e}");
    for (text, key) in [
        ("mode = \"segments\"", "detector.mode"),
        ("miss_truncated = 1.5", "detector.miss_truncated"),
        ("score_occluded = -0.1", "detector.score_occluded"),
        ("score_truncated = 2.0", "detector.score_truncated"),
        ("score_small = -1.0", "detector.score_small"),
        ("score_min = 1.1", "detector.score_min"),
        ("truncated_jitter = 0.5", "detector.truncated_jitter"),
        ("nms_iou = 1.5", "detector.nms_iou"),
        ("merge_union = -0.5", "detector.merge_union"),
        ("confusion_bin_deg = 0.0", "detector.confusion_bin_deg"),
        ("confusion_bin_m = 0.0", "detector.confusion_bin_m"),
        ("fp_per_frame = -1.0", "detector.fp_per_frame"),
        ("fp_score_min = 2.0", "detector.fp_score_min"),
        ("fp_score_max = 0.1", "detector.fp_score_max"),
        (
            "fp_wall_classes = [\"poster\"]",
            "detector.fp_wall_classes[0]",
        ),
        ("fp_on_objects = [[\"chair\"]]", "detector.fp_on_objects[0]"),
        (
            "fp_on_objects = [[\"chair\", \"sofa\"]]",
            "detector.fp_on_objects[0][1]",
        ),
    ] {
        let e = Config::parse(f, &format!("[detector]\n{text}\n")).unwrap_err();
        assert_eq!(e.key(), key, "{text}: {e}");
    }
    let e = Config::parse(f, "[robot]\npitch_min_deg = 30.0\npitch_max_deg = 20.0\n").unwrap_err();
    assert_eq!(e.key(), "robot.pitch_max_deg");
    let e = Config::parse(f, "[robot]\nspeed = 1.0\n").unwrap_err();
    assert_eq!(e.key(), "robot.speed", "{e}");
    let e = Config::parse(f, "[robot.slam]\nresidual_xy_m = -0.1\n").unwrap_err();
    assert_eq!(e.key(), "robot.slam.residual_xy_m", "{e}");
    let e = Config::parse(f, "[robot]\npose_delay_ms = 1000.0\n").unwrap_err();
    assert_eq!(e.key(), "robot.pose_delay_ms", "{e}");
}

#[test]
fn kinds_parse_and_bad_values_are_named() {
    assert_eq!("frontier".parse::<PlannerKind>(), Ok(PlannerKind::Frontier));
    assert_eq!(PlannerKind::Coverage.to_string(), "coverage");
    assert!("greedy".parse::<PlannerKind>().is_err());
    let f = Path::new("x.toml");
    let e = Config::parse(f, "[planner]\nkind = \"greedy\"\n").unwrap_err();
    assert_eq!(e.key(), "planner.kind", "{e}");
    let e = Config::parse(f, "[planner.gbv]\ncandidates = 0\n").unwrap_err();
    assert_eq!(e.key(), "planner.gbv.candidates");
    let e = Config::parse(f, "[planner.ablation]\nh_iuo = false\n").unwrap_err();
    assert!(e.to_string().contains("h_iuo"), "{e}");
    let e = Config::parse(f, "[planner]\nlbv_hz = 100.0\nlbv_budget_ms = 20.0\n").unwrap_err();
    assert_eq!(e.key(), "planner.lbv_budget_ms");
    let ok = Config::parse(
        f,
        "[planner]\nkind = \"coverage\"\noccluders = \"closer\"\n",
    );
    let ok = ok.unwrap();
    assert_eq!(ok.planner.kind, PlannerKind::Coverage);
    assert_eq!(ok.planner.occluders, Occluders::Closer);
}

#[test]
fn bad_mapper_values_name_the_key() {
    let f = Path::new("bad.toml");
    let e = Config::parse(f, "[mapper.sopm]\nrows = 40\ncols = 40\n").unwrap_err();
    assert_eq!(e.key(), "mapper.sopm.rows", "{e}");
    let e = Config::parse(f, "[mapper.sopm]\nshape = \"cone\"\n").unwrap_err();
    assert!(e.to_string().contains("cone"), "{e}");
    let e = Config::parse(f, "[mapper.association]\nalpha = 2.0\n").unwrap_err();
    assert_eq!(e.key(), "mapper.association.alpha");
    let e = Config::parse(f, "[mapper.grid]\nwidth = 512\n").unwrap_err();
    assert_eq!(e.key(), "mapper.grid.height");
}

#[test]
fn link_rate_limits_name_the_topic_and_pair_detections_with_depth() {
    let f = Path::new("robot.toml");
    let e = Config::parse(f, "[link.max_hz]\nstate = 5.0\n").unwrap_err();
    assert_eq!(e.key(), "link.max_hz", "{e}");
    assert!(e.to_string().contains("state"), "{e}");
    // Detections alone, or at depth's rate: accepted.
    let c = Config::parse(f, "[link.max_hz]\ndepth = 0.0\ndetections = 5.0\n").unwrap();
    assert_eq!(c.link.limit("detections"), Some(5.0));
    assert_eq!(c.link.limit("depth"), None);
    Config::parse(f, "[link.max_hz]\ndepth = 5.0\ndetections = 5.0\n").unwrap();
    // Without a key of their own, detections follow depth (the default: 10 Hz pairs);
    // `detections = 0` sends every one at full size.
    let c = Config::parse(f, "[link.max_hz]\ndepth = 4.0\n").unwrap();
    assert_eq!(c.link.limit("detections"), Some(4.0));
    let c = Config::parse(f, "[link.max_hz]\ndetections = 0.0\n").unwrap();
    assert_eq!(
        (c.link.limit("depth"), c.link.limit("detections")),
        (Some(10.0), None)
    );
    // Both limited at different rates: refused, naming detections and depth's value.
    let e = Config::parse(f, "[link.max_hz]\ndepth = 10.0\ndetections = 5.0\n").unwrap_err();
    assert_eq!(e.key(), "link.max_hz.detections", "{e}");
    let text = e.to_string();
    assert!(text.contains("robot.toml") && text.contains("10"), "{text}");
}
