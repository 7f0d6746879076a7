//! Pins the simulator's frame output bit for bit: renders of the three paper scenes from a
//! dozen poses at 640×480 with the default sensing (noisy depth, dropouts, ToF artefacts,
//! box-mode detector), hashed. The reference hashes were captured from the renderer before the
//! 2026-12 speed-ups of `camera.rs` / `rowcast.rs` / `artefacts.rs` and re-captured when the
//! sensing was set from sources (issue #33: glass rates, duplicates, confident false
//! positives, "other" confusion); any change of a depth
//! reading, instance id, true depth, incidence cosine (f32 bits) or detection fails the test.

use super::{BUILTIN_SCENES, DepthArtefacts, DepthCamera, Detector, RenderBuffers, Scene, World};
use crate::SimSetup;
use shm_types::{Detections, boxed_zeroed};

/// FNV-1a, 64-bit (stable across Rust versions, unlike `DefaultHasher`).
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// Hash of every output of one frame per pose, per scene.
fn frame_hashes(scene_name: &str) -> Vec<u64> {
    let cfg = SimSetup::default();
    let (w, h) = (cfg.camera.width as usize, cfg.camera.height as usize);
    let scene = Scene::builtin(scene_name).unwrap();
    let world = World::new(&scene);
    let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 11);
    let artefacts = DepthArtefacts::new(&scene, &cfg.camera, &cfg.sim, 12);
    let mut detector = Detector::new(&scene, &cfg.detector, 13);
    let mount = cfg.camera.mount;
    let mut poses = vec![(scene.robot_start, 0.0)];
    for (i, o) in scene.objects.iter().enumerate().take(4) {
        let yaw = 0.4 + 1.7 * i as f32;
        let d = 0.5 + o.size.x.max(o.size.y) * 0.5 + 0.6 * (i % 2) as f32;
        let base = [o.center.x - d * yaw.cos(), o.center.y - d * yaw.sin(), yaw];
        poses.push((base, 0.3 * (i as f32 - 1.5)));
    }
    let mut depth = vec![0u16; w * h];
    let mut buf = RenderBuffers::new();
    let mut dets = boxed_zeroed::<Detections>();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    poses
        .into_iter()
        .enumerate()
        .map(|(i, (base, neck))| {
            let pose = mount.camera_pose(base, neck, mount.pitch());
            let frame = 100 + i as u64;
            pool.install(|| {
                cam.render(&world, &pose, frame, &mut depth, &mut buf);
                artefacts.apply(&world, &pose, frame, &buf, &mut depth);
            });
            detector.detect(&buf.instance, cam.camera(), &pose, frame, &mut dets);
            let objects = buf.instance[..w * h].iter().filter(|&&k| k != 0).count();
            let valid = depth.iter().filter(|&&d| d != 0).count();
            println!(
                "{scene_name} pose {i}: {objects} object pixels, {valid} valid, {} detections",
                dets.count
            );
            let mut f = Fnv(0xcbf2_9ce4_8422_2325);
            depth.iter().for_each(|d| f.bytes(&d.to_le_bytes()));
            f.bytes(&buf.instance[..w * h]);
            let bits =
                |v: &[f32], f: &mut Fnv| v.iter().for_each(|x| f.bytes(&x.to_bits().to_le_bytes()));
            bits(&buf.depth_true[..w * h], &mut f);
            bits(&buf.cos_incidence[..w * h], &mut f);
            for d in &dets.items[..dets.count as usize] {
                f.bytes(&d.class_id.to_le_bytes());
                f.bytes(&d.score.to_bits().to_le_bytes());
                d.bbox.iter().for_each(|b| f.bytes(&b.to_le_bytes()));
            }
            f.0
        })
        .collect()
}

#[test]
fn frames_are_bit_identical_to_the_reference_renderer() {
    // Captured from the renderer at 04027f6 (before the speed-ups).
    let expected: [&[u64]; 3] = [
        &[
            0xb60c_4a7e_800d_e3f1,
            0x3d7e_8ea3_f582_610c,
            0x4c7d_905e_743c_4d7d,
            0xf33a_5a0a_6d8b_bf29,
            0x05cc_13a9_e054_53be,
        ],
        &[
            0xafaf_3b2e_a767_dd66,
            0x3d7e_8ea3_f582_610c,
            0x52ef_8e33_8373_49a6,
            0x4b29_0534_724f_82c0,
            0x05cc_13a9_e054_53be,
        ],
        &[
            0x8683_2e0a_d9ad_2c15,
            0xd465_0f7a_41bb_61c0,
            0x6ca9_9d2a_d665_a0f5,
            0xa2c5_6542_ad35_7570,
            0x1867_3e57_d63d_c075,
        ],
    ];
    let got: Vec<Vec<u64>> = BUILTIN_SCENES
        .iter()
        .map(|(n, _)| frame_hashes(n))
        .collect();
    println!("{got:#018x?}");
    for (((name, _), got), want) in BUILTIN_SCENES.iter().zip(&got).zip(expected) {
        assert_eq!(got, want, "{name}");
    }
}
