//! Frame-to-map registration (issue 14): the camera poses given to the mapper drift (a slowly
//! varying offset of a few cm, a yaw bias and per-frame yaw noise, as SLAM + neck-encoder errors);
//! with `[mapper.registration]` on, the objects' cuboids match the truth better than with it off.

mod mapper_common;

use glam::Vec3;
use mapper_common::{RenderOpts, camera, render, state, table_scene, view};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;
use shm_types::{DepthFrame, Detections, boxed_zeroed, is_background_class};
use vpsom::geom::affine_to_pose;
use vpsom::mapper::cuboid::Box3;
use vpsom::mapper::register::Correction;
use vpsom::mapper::{Mapper, MapperConfig};

/// Mean IoU of the scene's foreground objects with the mapped object of their class.
fn mean_iou(registration: bool) -> f32 {
    let scene = table_scene();
    let cam = camera();
    let mut cfg = MapperConfig::default();
    cfg.registration.enabled = registration;
    let mut mapper = Mapper::new(&cfg, &cam).unwrap();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut rng = Pcg64::seed_from_u64(5);
    let yaw_noise = Normal::new(0.0f32, 0.4f32.to_radians()).unwrap();
    let target = Vec3::new(0.0, 0.0, 0.8);
    // Two laps, 20° apart, with the pose error of a drifting SLAM and a biased neck encoder.
    for k in 0..36u64 {
        let deg = k as f32 * 20.0;
        let pose = view(target, 1.3, deg);
        render(
            &scene,
            &cam,
            &pose,
            k + 1,
            k * 100_000_000,
            &RenderOpts::default(),
            &mut rng,
            &mut frame,
            &mut dets,
        );
        let s = k as f32;
        let err = Correction {
            yaw: 0.3f32.to_radians() + yaw_noise.sample(&mut rng),
            t: Vec3::new(
                0.03 * (s / 6.0).sin(),
                0.03 * (s / 9.0 + 1.0).cos(),
                0.008 * (s / 4.0).sin(),
            ),
        };
        let c: Vec3 = pose.translation.into();
        frame.camera_pose = affine_to_pose(&(err.affine(c) * pose));
        mapper.integrate(&frame, &dets, &state()).unwrap();
    }
    let mut sum = 0.0;
    let mut n = 0;
    for shape in scene
        .objects
        .iter()
        .filter(|o| !is_background_class(o.class_id))
    {
        let truth = Box3 {
            center: shape.cuboid.center,
            size: shape.cuboid.size,
            yaw: shape.cuboid.yaw,
        };
        let best = mapper
            .objects()
            .iter()
            .filter(|o| o.class_id == shape.class_id)
            .map(|o| o.cuboid.iou(&truth))
            .fold(0.0f32, f32::max);
        sum += best;
        n += 1;
    }
    sum / n as f32
}

#[test]
fn registration_raises_the_cuboid_iou_under_pose_errors() {
    let off = mean_iou(false);
    let on = mean_iou(true);
    println!("mean IoU: registration off {off:.3}, on {on:.3}");
    assert!(on > off + 0.02, "registration off {off:.3}, on {on:.3}");
}
