//! `vpsom sensing` end to end: a short tour at 160×120 gives figures in their ranges, the same
//! report twice, a readable `sensing.json`, and an unknown scene is a clear error.

use vpsom::config::Config;
use vpsom::eval::sensing::{Figures, SENSING_FILE};
use vpsom::sensing::{SensingSpec, run_sensing, tour_goals};
use vpsom::sim::{Scene, Sim};

fn spec(frames: u64) -> SensingSpec {
    let mut config = Config::builtin();
    (config.camera.width, config.camera.height) = (160, 120);
    SensingSpec {
        scenes: ["paper-scene-1", "paper-scene-2"]
            .map(|n| Scene::builtin(n).unwrap())
            .to_vec(),
        config,
        seed: 3,
        frames,
    }
}

fn check(f: &Figures, frames: u64) {
    assert_eq!(f.frames, frames, "{}", f.scene);
    let unit = [
        f.recall,
        f.recall_by_size.small.recall,
        f.recall_by_size.medium.recall,
        f.recall_by_size.large.recall,
        f.recall_by_occlusion.visible_at_least_0_9.recall,
        f.recall_by_occlusion.visible_0_5_to_0_9.recall,
        f.recall_by_occlusion.visible_below_0_5.recall,
        f.recall_by_truncation.truncated.recall,
        f.recall_by_truncation.not_truncated.recall,
        f.box_iou,
        f.confusion,
        f.fp_share,
        f.invalid_depth_in_range,
        f.invalid_depth_all,
    ];
    for (i, v) in unit.into_iter().enumerate() {
        if let Some(v) = v {
            assert!((0.0..=1.0).contains(&v), "{}: figure {i} = {v}", f.scene);
        }
    }
    assert!(
        f.recall.is_some() && f.box_iou.is_some(),
        "{}: something was seen and matched",
        f.scene
    );
    assert!(f.visible_per_frame > 0.0 && f.fp_per_frame >= 0.0);
    assert!(f.box_iou.unwrap() >= 0.5, "matches have IoU ≥ 0.5");
    let ate = f.ate_rmse_m.expect("frames have poses");
    assert!(ate.is_finite() && ate >= 0.0 && f.ate_max_m.unwrap() >= ate);
    assert!(f.rpe_rmse_m.is_some_and(|r| r.is_finite() && r >= 0.0));
}

#[test]
fn a_short_tour_gives_figures_in_range_deterministically() {
    let frames = 40;
    let s = spec(frames);
    let mut seen = Vec::new();
    let report = run_sensing(&s, |f| seen.push(f.scene.clone())).unwrap();
    assert_eq!(seen, ["paper-scene-1", "paper-scene-2"]);
    assert_eq!(report.scenes.len(), 2);
    for sc in &report.scenes {
        check(&sc.figures, frames);
        assert_eq!(sc.per_frame.len() as u64, frames);
        // 10 Hz and Δ = 1 s: pairs (i, i + 10).
        assert_eq!(sc.figures.rpe_pairs, frames - 10);
        let t: Vec<f64> = sc.per_frame.iter().map(|f| f.t_s).collect();
        assert!(
            t.windows(2).all(|w| (w[1] - w[0] - 0.1).abs() < 1e-6),
            "one frame per 0.1 s"
        );
    }
    check(&report.overall, 2 * frames);
    assert_eq!(
        report.settings.min_visible_pixels,
        50.0 * 160.0 * 120.0 / (640.0 * 480.0)
    );
    // Pooled counts are the sums.
    let sum: u64 = report
        .scenes
        .iter()
        .map(|s| s.figures.recall_by_size.small.visible)
        .sum();
    assert_eq!(report.overall.recall_by_size.small.visible, sum);

    let again = run_sensing(&s, |_| {}).unwrap();
    assert_eq!(again, report, "same seed, same report");

    let dir = std::env::temp_dir().join(format!("vpsom-sensing-{}", std::process::id()));
    let path = report.write(&dir).unwrap();
    assert_eq!(path, dir.join(SENSING_FILE));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(json["overall"]["frames"], 2 * frames);
    assert_eq!(
        json["acceptance"]["fp_per_frame"]["max"],
        serde_json::Value::Null
    );
    assert_eq!(json["scenes"][1]["figures"]["scene"], "paper-scene-2");
    std::fs::remove_dir_all(&dir).unwrap();

    let table = report.table();
    for needle in [
        "| recall |",
        "0.6–0.9",
        "ATE RMSE (cm)",
        "paper-scene-2",
        "overall",
    ] {
        assert!(table.contains(needle), "{needle} missing from\n{table}");
    }
}

#[test]
fn the_tour_visits_free_goals_and_moves() {
    let s = spec(1);
    for scene in &s.scenes {
        let sim = Sim::new(scene.clone(), &s.config, 1).unwrap();
        let goals = tour_goals(scene, &sim, &s.config);
        let backgrounds = scene.objects.iter().filter(|o| o.background).count();
        assert!(
            goals.len() > backgrounds,
            "{}: {} goals",
            scene.name,
            goals.len()
        );
        for g in &goals {
            assert!(!sim.grid().is_blocked(glam::Vec2::new(g[0], g[1])), "{g:?}");
        }
    }
    // The base really drives: in 10 s the camera travels more than a metre (start → room
    // centre → first ring goal).
    let (_, _, track) = vpsom::sensing::run_tour(&s.scenes[0], &s.config, 1, 100).unwrap();
    let path: f32 = track
        .windows(2)
        .map(|w| (w[1].truth.translation - w[0].truth.translation).length())
        .sum();
    assert!(path > 1.0, "travelled {path} m");
}

#[test]
fn an_unknown_scene_is_a_clear_error() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(["sensing", "no-such-scene", "--frames", "1", "--out"])
        .arg(std::env::temp_dir().join("vpsom-sensing-unknown"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no-such-scene") && err.contains("paper-scene-1"),
        "stderr: {err}"
    );
}
