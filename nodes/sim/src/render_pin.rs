//! Pins the simulator's frame output bit for bit: renders of the three paper scenes from a
//! dozen poses at 640×480 with the default sensing (noisy depth, dropouts, ToF artefacts,
//! box-mode detector), hashed. The reference hashes were captured from the renderer before the
//! 2026-12 speed-ups of `camera.rs` / `rowcast.rs` / `artefacts.rs`; any change of a depth
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
            0xd6ac_b253_023c_3e98,
            0xec3f_9880_04e8_3467,
            0x72ef_6f4a_f8aa_b4a7,
            0x88f2_cde3_2422_3829,
            0x8ea1_a154_c1da_d906,
        ],
        &[
            0xe1d6_6776_97a1_99f9,
            0xec3f_9880_04e8_3467,
            0xe764_4831_1803_2d26,
            0xbcc0_bee6_ca50_5b2c,
            0x8ea1_a154_c1da_d906,
        ],
        &[
            0x15bd_2bec_6ace_4697,
            0x79a0_d133_d31f_1b7c,
            0xdcc0_fdf6_848c_1005,
            0x24c8_dc31_443f_6c62,
            0xdbaf_4712_6842_ddd5,
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
