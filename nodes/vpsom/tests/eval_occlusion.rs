//! The non-occlusion metric measured on ground truth (`eval::occlusion`, fed by
//! `Sim::visibility`): hand-made scenes give the expected visible fractions, the value depends
//! on the frames only (not on the planner or its H_IoU term), and a session with H_IoU ablated
//! still measures it.

use shm_types::{
    Candidate, DepthFrame, Detections, FrameVisibility, PlannerDecision, boxed_zeroed,
    decision_kind,
};
use std::path::Path;
use vpsom::config::Config;
use vpsom::eval::occlusion::object_non_occlusion;
use vpsom::eval::{MatchParams, RunInfo, SessionLog};
use vpsom::lockstep::{self, SessionSpec};
use vpsom::sim::{Scene, Sim};

/// The bench's camera (320×240) with the ideal sensing (the instance render is true either way).
fn config() -> Config {
    let base = Config::ideal_sensing();
    let b = base.bench;
    base.with_camera(b.camera_width, b.camera_height, b.camera_hz)
}

/// A 6 m room with the robot at the origin facing +x and the given `[[object]]` tables.
fn scene(objects: &str) -> Scene {
    let text = format!(
        "name = \"t\"\n[room]\nmin = [-3.0, -3.0]\nmax = [3.0, 3.0]\nheight = 2.5\n\
         [robot]\nstart = [0.0, 0.0, 0.0]\n{objects}"
    );
    Scene::parse(Path::new("t.toml"), &text).unwrap()
}

fn object(name: &str, center: [f32; 3], size: [f32; 3], shape: &str) -> String {
    format!(
        "[[object]]\nname = \"{name}\"\nclass = \"book\"\ncenter = {center:?}\n\
         size = {size:?}\nshape = \"{shape}\"\n"
    )
}

/// Render the start view once; (scene object index, non-occlusion) of the objects in view.
fn first_frame(scene: Scene) -> Vec<(u32, f64)> {
    let mut sim = Sim::new(scene, &config(), 1).unwrap();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    sim.render(&mut frame, &mut dets, 0);
    let v = sim.visibility();
    assert_eq!(v.frame_seq, frame.header.seq);
    v.items()
        .iter()
        .map(|o| (o.object, object_non_occlusion(o).unwrap()))
        .collect()
}

#[test]
fn a_box_behind_another_is_occluded_and_the_front_one_is_not() {
    // The camera (1.4 m high, pitched 28° down) looks over a tall front box at a lower box
    // right behind it: only the back box's top edge shows.
    let s = scene(&format!(
        "{}{}",
        object("front", [1.8, 0.0, 0.35], [0.2, 0.6, 0.7], "box"),
        object("back", [2.4, 0.0, 0.25], [0.2, 0.4, 0.5], "box"),
    ));
    let seen = first_frame(s);
    assert_eq!(seen.len(), 2, "{seen:?}");
    let (front, back) = (seen[0].1, seen[1].1);
    assert!((front - 1.0).abs() < 0.01, "front {front}");
    assert!(back < 0.5, "back {back}");
}

#[test]
fn an_object_alone_in_view_is_not_occluded() {
    for shape in ["box", "cylinder"] {
        let s = scene(&object("alone", [2.2, 0.2, 0.3], [0.4, 0.4, 0.6], shape));
        let seen = first_frame(s);
        assert_eq!(seen.len(), 1, "{shape}: {seen:?}");
        // A box's silhouette is exact; a cylinder's is a 16-gon of the disc's area.
        let tol = if shape == "box" { 0.01 } else { 0.03 };
        assert!((seen[0].1 - 1.0).abs() < tol, "{shape}: {}", seen[0].1);
    }
    // Out of range (beyond camera.max_range) or behind the camera: not in view.
    let s = scene(&object("behind", [-2.0, 0.0, 0.3], [0.4, 0.4, 0.6], "box"));
    assert!(first_frame(s).is_empty());
}

fn decision(kind: u8, h_iou: f32) -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.kind = kind;
    d.count = 1;
    d.candidates[0] = Candidate {
        h_iou,
        objects_in_view: 3,
        chosen: 1,
        ..Default::default()
    };
    d
}

#[test]
fn the_metric_depends_on_the_frames_only() {
    // Frames of a turning neck in paper-scene-2.
    let mut sim = Sim::new(Scene::builtin("paper-scene-2").unwrap(), &config(), 3).unwrap();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut frames: Vec<Box<FrameVisibility>> = Vec::new();
    for i in 0..40 {
        let yaw = -1.2 + 0.06 * i as f32;
        sim.set_neck_goal(&shm_types::NeckGoal {
            yaw,
            pitch: 0.49,
            ..Default::default()
        });
        for _ in 0..3 {
            sim.step(33_333_333);
        }
        sim.render(&mut frame, &mut dets, sim.time_ns());
        frames.push(Box::new(*sim.visibility()));
    }
    // The same frames under three planners' decisions, one with H_IoU ablated (its views carry
    // H_IoU 0, as the planner's term is off).
    let mut values = Vec::new();
    for (planner, h_iou) in [("vpsom", 0.8), ("coverage", 0.5), ("vpsom-no-h_iou", 0.0)] {
        let mut log = SessionLog::new();
        for (i, f) in frames.iter().enumerate() {
            log.observe_visibility(f);
            let kind = if i % 10 == 0 {
                decision_kind::GBV
            } else {
                decision_kind::LBV
            };
            log.observe_decision(&decision(kind, h_iou));
        }
        log.finish(1, true, "t");
        let run = RunInfo {
            scene: "paper-scene-2".into(),
            planner: planner.into(),
            seed: 3,
        };
        let m = log.metrics(&run, &[], &[], &MatchParams::default());
        assert!((m.planner_h_iou.unwrap() - f64::from(h_iou)).abs() < 1e-6);
        values.push(m.non_occlusion);
    }
    let v = values[0].expect("objects were in view");
    assert!(v > 0.0 && v <= 1.0, "{v}");
    assert!(values.iter().all(|x| *x == Some(v)), "{values:?}");
}

#[test]
fn a_session_with_h_iou_ablated_measures_non_occlusion() {
    let cfg = config();
    let label = "vpsom-no-h_iou";
    let spec = SessionSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: lockstep::config_for(&cfg, label).unwrap(),
        seed: 1,
        label: label.into(),
        max_sim_s: 8.0,
        record: None,
    };
    let r = lockstep::run_session(&spec, |_| {}).unwrap();
    let m = &r.metrics;
    let v = m.non_occlusion.expect("objects in view");
    assert!(v > 0.2 && v <= 1.0, "{m:?}");
    assert!(m.non_occlusion_samples >= m.non_occlusion_frames);
    assert!(m.non_occlusion_frames > 0 && m.non_occlusion_frames <= r.frames);
}
