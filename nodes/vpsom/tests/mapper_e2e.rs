//! End to end: a scripted camera circles a table with five objects; every object is mapped once,
//! within 5 cm, and every foreground object is complete after the full circle.

mod mapper_common;

use glam::Vec3;
use mapper_common::{RenderOpts, Scene, render, table_scene};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use shm_types::{ObjectMap, RobotState, Validate, boxed_zeroed, class_name, is_background_class};
use vpsom::config::CameraConfig;
use vpsom::geom::{Camera, CameraMount};
use vpsom::mapper::{Mapper, MapperConfig};

fn small_camera() -> Camera {
    CameraConfig {
        width: 320,
        height: 240,
        ..CameraConfig::default()
    }
    .camera()
}

/// The test camera has a quarter of the default pixels (for speed), so stride 1 samples the
/// same point density as the default 640 × 480 camera at the default stride 2.
fn test_config() -> MapperConfig {
    MapperConfig {
        pixel_stride: 1,
        ..MapperConfig::default()
    }
}

/// Run a circle of `steps` views at radius `radius` around the origin and return the mapper.
fn circle(scene: &Scene, steps: usize, radius: f32, opts: &RenderOpts) -> Mapper {
    let camera = small_camera();
    let mount = CameraMount::default();
    let mut mapper = Mapper::new(&test_config(), &camera).unwrap();
    let mut frame = boxed_zeroed::<shm_types::DepthFrame>();
    let mut dets = boxed_zeroed::<shm_types::Detections>();
    let mut rng = Pcg64::seed_from_u64(7);
    for k in 0..steps {
        let a = k as f32 / steps as f32 * std::f32::consts::TAU;
        let base = [radius * a.cos(), radius * a.sin(), a + std::f32::consts::PI];
        let pose = mount.camera_pose(base, 0.0, mount.pitch());
        let t = (k as u64 + 1) * 33_333_333;
        render(
            scene,
            &camera,
            &pose,
            k as u64 + 1,
            t,
            opts,
            &mut rng,
            &mut frame,
            &mut dets,
        );
        let state = RobotState {
            base_pose: base,
            neck_pitch: mount.pitch(),
            localization_ok: 1,
            ..Default::default()
        };
        mapper.integrate(&frame, &dets, &state).unwrap();
    }
    mapper
}

#[test]
fn circling_a_table_maps_every_object_once_and_completes_them() {
    let scene = table_scene();
    let mut mapper = circle(&scene, 36, 1.5, &RenderOpts::default());
    let mut map = boxed_zeroed::<ObjectMap>();
    mapper.write_map(&mut map, 42);
    assert_eq!(map.validate(), Ok(()));
    let objs = map.objects();
    for o in objs {
        eprintln!(
            "{:>12} id {:>2} c {:?} s {:?} yaw {:.2} H {:.3} obs {} cl {} casso {:.2}",
            class_name(o.class_id),
            o.id,
            o.center,
            o.size,
            o.yaw,
            o.h_sopm,
            o.observations,
            o.cluster_id,
            o.c_asso
        );
    }
    assert_eq!(
        objs.len(),
        scene.objects.len(),
        "one map object per scene object"
    );
    let table_id = objs
        .iter()
        .find(|o| o.is_background())
        .map(|o| o.id as i32)
        .unwrap();
    for gt in &scene.objects {
        let same: Vec<_> = objs.iter().filter(|o| o.class_id == gt.class_id).collect();
        assert_eq!(same.len(), 1, "{} mapped once", class_name(gt.class_id));
        let o = same[0];
        let err = (Vec3::from(o.center) - gt.cuboid.center).length();
        assert!(
            err < 0.05,
            "{}: centre error {err}",
            class_name(gt.class_id)
        );
        if !is_background_class(gt.class_id) {
            assert!(
                o.is_complete(),
                "{} complete (H = {})",
                class_name(gt.class_id),
                o.h_sopm
            );
            assert_eq!(
                o.cluster_id,
                table_id,
                "{} on the table",
                class_name(gt.class_id)
            );
            assert!(o.sample_count > 16);
        }
    }
}

#[test]
fn half_circle_leaves_objects_incomplete_with_l_best_towards_the_unseen_side() {
    // Views only from +x (angles −60°..60°): the objects' far (−x) sides stay unknown.
    let scene = table_scene();
    let camera = small_camera();
    let mount = CameraMount::default();
    let mut mapper = Mapper::new(&test_config(), &camera).unwrap();
    let mut frame = boxed_zeroed::<shm_types::DepthFrame>();
    let mut dets = boxed_zeroed::<shm_types::Detections>();
    let mut rng = Pcg64::seed_from_u64(3);
    for k in 0..7 {
        let a = (-60.0 + 20.0 * k as f32).to_radians();
        let base = [1.5 * a.cos(), 1.5 * a.sin(), a + std::f32::consts::PI];
        let pose = mount.camera_pose(base, 0.0, mount.pitch());
        render(
            &scene,
            &camera,
            &pose,
            k + 1,
            k * 1000,
            &RenderOpts::default(),
            &mut rng,
            &mut frame,
            &mut dets,
        );
        let state = RobotState {
            localization_ok: 1,
            ..Default::default()
        };
        mapper.integrate(&frame, &dets, &state).unwrap();
    }
    let mut map = boxed_zeroed::<ObjectMap>();
    mapper.write_map(&mut map, 0);
    let cup = map
        .objects()
        .iter()
        .find(|o| class_name(o.class_id) == "cup")
        .unwrap();
    assert!(cup.h_sopm > 0.2 && cup.h_sopm < 1.0, "H = {}", cup.h_sopm);
    assert!(cup.l_best[0] < 0.0, "l_best {:?} points to −x", cup.l_best);
}
