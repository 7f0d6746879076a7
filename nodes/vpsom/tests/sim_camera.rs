//! Simulator camera and detector, end to end: visibility, occlusion, determinism.

use shm_types::{DepthFrame, Detections, NeckGoal, Validate, boxed_zeroed, class_id};
use std::path::Path;
use vpsom::config::{CameraConfig, Config};
use vpsom::sim::{
    DepthCamera, Detector, DetectorConfig, RenderBuffers, Scene, Sim, SimPool, World,
};

fn small_config() -> Config {
    let mut cfg = Config::builtin();
    (cfg.camera.width, cfg.camera.height) = (160, 120);
    cfg
}

/// A detector that never misses, confuses, merges, bleeds or sees what is not there (to test
/// visibility alone).
fn perfect_detector() -> DetectorConfig {
    DetectorConfig {
        miss_rate: 0.0,
        miss_small: 0.0,
        miss_occluded: 0.0,
        miss_truncated: 0.0,
        score_min: 0.0,
        nms_iou: 1.0,
        fp_per_frame: 0.0,
        fp_confident_per_tp: 0.0,
        dup_per_tp: 0.0,
        confusion_rate: 0.0,
        other_rate: 0.0,
        mask_bleed_px: 0,
        min_pixels: 5,
        ..DetectorConfig::default()
    }
}

struct Rig {
    world: World,
    cam: DepthCamera,
    det: Detector,
    cfg: CameraConfig,
    depth: Vec<u16>,
    buf: RenderBuffers,
    dets: Box<Detections>,
}

impl Rig {
    fn new(scene: &Scene, det: &DetectorConfig) -> Rig {
        let cfg = small_config();
        Rig {
            world: World::new(scene),
            cam: DepthCamera::new(&cfg.camera, &cfg.sim, 1),
            det: Detector::new(scene, det, 1),
            cfg: cfg.camera,
            depth: vec![0; shm_types::MAX_PIXELS],
            buf: RenderBuffers::new(),
            dets: boxed_zeroed(),
        }
    }

    /// Render and detect from base pose `[x, y, yaw]` (neck straight); returns visible pixels
    /// per object.
    fn look(&mut self, base: [f32; 3], objects: usize) -> Vec<usize> {
        let m = self.cfg.mount;
        let pose = m.camera_pose(base, 0.0, m.pitch());
        self.cam
            .render(&self.world, &pose, 0, &mut self.depth, &mut self.buf);
        let n = (self.cfg.width * self.cfg.height) as usize;
        self.det.detect(
            &self.buf.instance,
            self.cam.camera(),
            &pose,
            0,
            &mut self.dets,
        );
        let mut seen = vec![0; objects];
        for &k in &self.buf.instance[..n] {
            if k > 0 {
                seen[k as usize - 1] += 1;
            }
        }
        seen
    }

    fn detected_classes(&self) -> Vec<u16> {
        self.dets.detections().iter().map(|d| d.class_id).collect()
    }
}

#[test]
fn every_object_of_paper_scene_1_is_seen_and_detected_from_some_pose() {
    let scene = Scene::builtin("paper-scene-1").unwrap();
    let mut rig = Rig::new(&scene, &perfect_detector());
    let centre = scene.objects[0].center.truncate();
    let n = scene.objects.len();
    let mut best = vec![0; n];
    let mut detected = vec![false; n];
    for ring in [1.6f32, 2.2] {
        for i in 0..12 {
            let a = i as f32 * std::f32::consts::TAU / 12.0;
            let p = centre + glam::Vec2::new(a.cos(), a.sin()) * ring;
            if !scene.room.contains(p, 0.3)
                || scene.objects.iter().any(|o| o.footprint_distance(p) < 0.3)
            {
                continue;
            }
            let yaw = (centre - p).to_angle();
            let seen = rig.look([p.x, p.y, yaw], n);
            assert_eq!(rig.dets.validate(), Ok(()));
            for k in 0..n {
                best[k] = best[k].max(seen[k]);
                if seen[k] >= 5 {
                    detected[k] = true;
                }
            }
        }
    }
    for (k, o) in scene.objects.iter().enumerate() {
        assert!(
            best[k] >= 30,
            "{} is never seen well ({} px)",
            o.name,
            best[k]
        );
        assert!(detected[k], "{} is never detected", o.name);
    }
}

#[test]
fn an_object_hidden_behind_another_is_not_detected() {
    let scene = Scene::parse(
        Path::new("occlusion.toml"),
        "name = \"occlusion\"\n[room]\nmin = [-4.0, -3.0]\nmax = [2.0, 3.0]\nheight = 2.6\n\
         [[object]]\nname = \"fridge\"\nclass = \"refrigerator\"\ncenter = [-2.0, 0.0, 0.9]\n\
         size = [0.6, 0.8, 1.8]\n\
         [[object]]\nname = \"cup\"\nclass = \"cup\"\ncenter = [-2.6, 0.0, 0.06]\n\
         size = [0.1, 0.1, 0.12]\nshape = \"cylinder\"\n",
    )
    .unwrap();
    let cup = class_id("cup").unwrap();
    let fridge = class_id("refrigerator").unwrap();
    let mut rig = Rig::new(&scene, &perfect_detector());
    // From the front the fridge hides the cup completely.
    let seen = rig.look([0.0, 0.0, std::f32::consts::PI], 2);
    assert_eq!(seen[1], 0);
    assert!(seen[0] > 1000);
    assert_eq!(rig.detected_classes(), vec![fridge]);
    // From the side the cup is visible and detected (the test can fail).
    let seen = rig.look([-2.6, 1.6, -std::f32::consts::FRAC_PI_2], 2);
    assert!(seen[1] > 20, "{seen:?}");
    assert!(rig.detected_classes().contains(&cup));
}

#[test]
fn partly_hidden_small_objects_are_missed_more_often() {
    let scene = Scene::builtin("paper-scene-1").unwrap();
    let cfg = small_config();
    let world = World::new(&scene);
    let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 1);
    let mut buf = RenderBuffers::new();
    let mut depth = vec![0; shm_types::MAX_PIXELS];
    let m = cfg.camera.mount;
    let pose = m.camera_pose([-0.2, 0.0, std::f32::consts::PI], 0.0, m.pitch());
    cam.render(&world, &pose, 0, &mut depth, &mut buf);
    // Masks mode: detections are attributed to objects by their mask pixels. The desk is cut
    // by the image border from here: truncation misses are not this test's subject.
    let masks = DetectorConfig {
        mode: "masks".into(),
        fp_per_frame: 0.0,
        fp_confident_per_tp: 0.0,
        dup_per_tp: 0.0,
        miss_truncated: 0.0,
        ..DetectorConfig::default()
    };
    let mut det = Detector::new(&scene, &masks, 5);
    let mut dets = boxed_zeroed::<Detections>();
    let n = scene.objects.len();
    let mut hits = vec![0u32; n];
    let frames = 200;
    for f in 0..frames {
        det.detect(&buf.instance, cam.camera(), &pose, f, &mut dets);
        for d in dets.detections() {
            let l = d.label as u8;
            // The object under most of the detection's mask pixels.
            let mut votes = vec![0u32; n + 1];
            for (i, &x) in dets.label_pixels().iter().enumerate() {
                if x == l {
                    votes[buf.instance[i] as usize] += 1;
                }
            }
            let k = (1..=n).max_by_key(|k| votes[*k]).unwrap();
            hits[k - 1] += 1;
        }
    }
    let desk = hits[0] as f32 / frames as f32;
    let keyboard = scene
        .objects
        .iter()
        .position(|o| o.name == "keyboard")
        .unwrap();
    let small = hits[keyboard] as f32 / frames as f32;
    assert!(desk > 0.9, "desk detection rate {desk}");
    assert!(small < desk - 0.1, "keyboard {small} vs desk {desk}");
}

#[test]
fn same_seed_same_frames_different_seed_different_noise_any_thread_count() {
    let cfg = small_config();
    let run = |seed: u64, threads: usize| {
        let mut sim = Sim::new(Scene::builtin("paper-scene-2").unwrap(), &cfg, seed).unwrap();
        sim.set_pool(SimPool::new(threads).unwrap());
        sim.set_neck_goal(&NeckGoal {
            yaw: 0.4,
            pitch: cfg.camera.mount.pitch(),
            ..Default::default()
        });
        let mut frame = boxed_zeroed::<DepthFrame>();
        let mut dets = boxed_zeroed::<Detections>();
        let mut out = Vec::new();
        for _ in 0..3 {
            sim.step(100_000_000);
            let now = sim.time_ns();
            sim.render(&mut frame, &mut dets, now);
            assert_eq!(frame.validate(), Ok(()));
            assert_eq!(dets.validate(), Ok(()));
            out.push((
                frame.pixels().to_vec(),
                dets.detections().to_vec(),
                dets.label_pixels().to_vec(),
            ));
        }
        out
    };
    let a = run(7, 1);
    assert_eq!(a, run(7, 3), "same seed, 1 vs 3 threads");
    let b = run(8, 2);
    assert_ne!(a[0].0, b[0].0, "different seed, different depth noise");
    let valid = a[0].0.iter().filter(|d| **d > 0).count();
    assert!(valid > a[0].0.len() / 2, "{valid} valid pixels");
}
