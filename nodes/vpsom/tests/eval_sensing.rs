//! The sensing report's measurements on hand-made inputs: box IoU, one-to-one matching, false
//! positives, confusions, buckets, invalid depth, silhouettes, ATE and RPE, with hand-computed
//! expected values.

use glam::{Affine3A, Mat3, Vec3};
use shm_types::Detection;
use std::path::Path;
use vpsom::eval::sensing::*;
use vpsom::geom::{Camera, optical_rotation};
use vpsom::sim::Scene;

fn det(class_id: u16, bbox: [u16; 4]) -> Detection {
    Detection {
        class_id,
        bbox,
        ..Default::default()
    }
}

fn vis(
    class_id: u16,
    bbox: [u32; 4],
    pixels: u32,
    fraction: f32,
    truncated: bool,
) -> VisibleObject {
    VisibleObject {
        object: class_id as usize,
        class_id,
        pixels,
        bbox,
        visible_fraction: fraction,
        truncated,
    }
}

#[test]
fn box_iou_by_hand() {
    // 10×10 boxes shifted by 5: intersection 50, union 150.
    assert!((box_iou([0, 0, 10, 10], [5, 0, 15, 10]) - 1.0 / 3.0).abs() < 1e-12);
    // Half of a box: 50 / 100.
    assert!((box_iou([0, 0, 10, 10], [0, 0, 10, 5]) - 0.5).abs() < 1e-12);
    assert_eq!(
        box_iou([0, 0, 10, 10], [10, 0, 20, 10]),
        0.0,
        "touching, exclusive ends"
    );
    assert_eq!(box_iou([0, 0, 0, 0], [0, 0, 0, 0]), 0.0);
}

#[test]
fn matching_is_one_to_one_highest_iou_first() {
    let visible = [
        vis(1, [0, 0, 10, 10], 100, 1.0, false),
        vis(2, [20, 0, 30, 10], 100, 1.0, false),
        vis(3, [40, 40, 50, 50], 100, 1.0, false),
    ];
    let dets = [
        det(1, [0, 0, 10, 9]),        // IoU 0.9 with object 1
        det(1, [0, 0, 10, 8]),        // IoU 0.8 with object 1: taken already → false positive
        det(5, [20, 0, 30, 10]),      // IoU 1 with object 2, another class → confusion
        det(3, [100, 100, 110, 110]), // nothing → false positive
        det(3, [40, 40, 50, 44]),     // IoU 0.4 with object 3: below 0.5 → false positive
    ];
    let m = match_boxes(&visible, &dets);
    assert_eq!(m.len(), 2);
    assert_eq!((m[0].visible, m[0].detection), (1, 2));
    assert!((m[0].iou - 1.0).abs() < 1e-12);
    assert_eq!((m[1].visible, m[1].detection), (0, 0));
    assert!((m[1].iou - 0.9).abs() < 1e-12);

    // Two overlapping objects: the best pair goes first, the other detection takes the rest.
    let visible = [
        vis(1, [0, 0, 10, 10], 100, 1.0, false),
        vis(2, [0, 0, 10, 12], 120, 1.0, false),
    ];
    // X: IoU 100/110 with A, 110/120 with B; Y: 1 with A, 100/120 with B.
    let dets = [det(1, [0, 0, 10, 11]), det(2, [0, 0, 10, 10])];
    let m = match_boxes(&visible, &dets);
    assert_eq!(m.len(), 2);
    assert_eq!((m[0].visible, m[0].detection), (0, 1));
    assert_eq!((m[1].visible, m[1].detection), (1, 0));
}

#[test]
fn tally_counts_false_positives_confusions_buckets_and_depth() {
    // 200×100: size limits scale by 20000/307200 (small < 66.7 px, large ≥ 600 px).
    let camera = Camera::from_fov(200, 100, 60.0, 40.0, 0.5, 5.0);
    let visible = [
        vis(1, [0, 0, 10, 10], 50, 1.0, true), // small, truncated, matched
        vis(2, [20, 0, 30, 10], 100, 0.7, false), // medium, partly occluded, matched (confused)
        vis(3, [40, 40, 80, 60], 800, 0.3, false), // large, mostly occluded, missed
    ];
    let dets = [
        det(1, [0, 0, 10, 9]),
        det(5, [20, 0, 30, 10]),
        det(3, [100, 80, 110, 90]),
    ];
    let n = 200 * 100;
    let mut depth_true = vec![0.0f32; n];
    let mut depth_mm = vec![0u16; n];
    depth_true[..100].fill(1.0); // in range
    depth_true[100..200].fill(10.0); // beyond max_range
    depth_mm[..90].fill(1000); // 10 of the 100 in-range pixels invalid
    depth_mm[100..200].fill(4999);
    let mut t = Tally::default();
    let f = t.add_frame(&visible, &dets, &camera, &depth_mm, &depth_true);
    assert_eq!(
        (
            f.visible,
            f.detections,
            f.matched,
            f.false_positives,
            f.confused
        ),
        (3, 3, 2, 1, 1)
    );
    assert_eq!((f.depth_in_range, f.depth_in_range_invalid), (100, 10));
    assert_eq!((f.depth_pixels, f.depth_invalid), (20_000, 20_000 - 190));
    // A second, empty frame: FP per frame halves, recall unchanged.
    t.add_frame(&[], &[], &camera, &depth_mm, &depth_true);
    let none = ErrorStats::default();
    let fig = Figures::new("t", &t, &none, &none);
    assert_eq!(fig.frames, 2);
    assert!((fig.recall.unwrap() - 2.0 / 3.0).abs() < 1e-12);
    assert!((fig.fp_per_frame - 0.5).abs() < 1e-12);
    assert!((fig.box_iou.unwrap() - 0.95).abs() < 1e-12);
    assert!((fig.confusion.unwrap() - 0.5).abs() < 1e-12);
    assert!((fig.invalid_depth_in_range.unwrap() - 0.1).abs() < 1e-12);
    let s = fig.recall_by_size;
    assert_eq!((s.small.visible, s.small.matched), (1, 1));
    assert_eq!((s.medium.visible, s.medium.matched), (1, 1));
    assert_eq!(
        (s.large.visible, s.large.matched, s.large.recall),
        (1, 0, Some(0.0))
    );
    let o = fig.recall_by_occlusion;
    assert_eq!(o.visible_at_least_0_9.matched, 1);
    assert_eq!(o.visible_0_5_to_0_9.matched, 1);
    assert_eq!(
        (o.visible_below_0_5.visible, o.visible_below_0_5.matched),
        (1, 0)
    );
    let tr = fig.recall_by_truncation;
    assert_eq!((tr.truncated.visible, tr.not_truncated.visible), (1, 2));
    assert_eq!(fig.ate_rmse_m, None);
    // Merging doubles the counts and keeps the ratios.
    let mut both = t.clone();
    both.merge(&t);
    let fig2 = Figures::new("t", &both, &none, &none);
    assert_eq!((fig2.frames, fig2.false_positives), (4, 2));
    assert_eq!(fig2.recall, fig.recall);
}

#[test]
fn size_buckets_are_coco_areas_scaled_to_the_image() {
    assert_eq!(size_bucket(1023, 640, 480), 0);
    assert_eq!(size_bucket(1024, 640, 480), 1);
    assert_eq!(size_bucket(9215, 640, 480), 1);
    assert_eq!(size_bucket(9216, 640, 480), 2);
    assert_eq!(size_bucket(255, 320, 240), 0);
    assert_eq!(size_bucket(256, 320, 240), 1);
    assert_eq!(min_visible_pixels(640, 480), 50.0);
    assert_eq!(min_visible_pixels(320, 240), 12.5);
    assert_eq!(occlusion_bucket(0.9), 0);
    assert_eq!(occlusion_bucket(0.5), 1);
    assert_eq!(occlusion_bucket(0.49), 2);
}

fn one_box_scene() -> Scene {
    Scene::parse(
        Path::new("t.toml"),
        "name = \"t\"\n[room]\nmin = [-3.0, -3.0]\nmax = [3.0, 3.0]\nheight = 2.5\n\
         [[object]]\nname = \"box\"\nclass = \"book\"\ncenter = [2.0, 0.0, 0.5]\n\
         size = [0.5, 1.0, 1.0]\n",
    )
    .unwrap()
}

#[test]
fn silhouette_of_a_box_seen_head_on_is_its_front_face() {
    let scene = one_box_scene();
    let camera = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 5.0);
    // Camera at (0, 0, 0.5) looking along +x: the 1 × 1 m front face is at 1.75 m.
    let world_from_camera =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::new(0.0, 0.0, 0.5));
    let area = silhouette_area(&scene.objects[0], &camera, &world_from_camera.inverse());
    let expected = camera.k.fx * camera.k.fy / (1.75 * 1.75);
    assert!(
        (area - expected).abs() < 1e-3 * expected,
        "{area} vs {expected}"
    );
    // From 1 m away the face (1 × 1 m at 0.75 m) overflows the image: clipped to W·H.
    let near =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::new(1.0, 0.0, 0.5));
    let area = silhouette_area(&scene.objects[0], &camera, &near.inverse());
    assert!((area - 640.0 * 480.0).abs() < 1.0, "{area}");
    // Looking away: nothing.
    let away = Affine3A::from_mat3_translation(
        optical_rotation(std::f32::consts::PI, 0.0),
        Vec3::new(0.0, 0.0, 0.5),
    );
    assert_eq!(
        silhouette_area(&scene.objects[0], &camera, &away.inverse()),
        0.0
    );
}

#[test]
fn clipped_area_by_hand() {
    use glam::Vec2;
    let tri = [
        Vec2::new(-1.0, 0.0),
        Vec2::new(3.0, 0.0),
        Vec2::new(-1.0, 4.0),
    ];
    // Clipped to x ≥ 0: a right triangle with legs 3 → 4.5.
    assert!((clipped_area(&tri, Vec2::new(10.0, 10.0)) - 4.5).abs() < 1e-5);
    let sq = [
        Vec2::new(0.0, 0.0),
        Vec2::new(4.0, 0.0),
        Vec2::new(4.0, 2.0),
        Vec2::new(0.0, 2.0),
    ];
    assert!((clipped_area(&sq, Vec2::new(3.0, 1.0)) - 3.0).abs() < 1e-5);
}

/// Samples at 10 Hz for 2 s, the truth moving along x at 1 m/s.
fn track(est: impl Fn(Affine3A, f32) -> Affine3A) -> Vec<PoseSample> {
    (0..=20)
        .map(|k| {
            let t = k as f32 * 0.1;
            let truth = Affine3A::from_translation(Vec3::new(t, 0.0, 0.0));
            PoseSample {
                t_ns: k * 100_000_000,
                est: est(truth, t),
                truth,
            }
        })
        .collect()
}

#[test]
fn ate_and_rpe_of_known_errors() {
    const DELTA: u64 = 1_000_000_000;
    // A constant 5 cm offset (3, 4): ATE 0.05 everywhere, no relative error.
    let tr = track(|q, _| Affine3A::from_translation(Vec3::new(0.0, 0.03, 0.04)) * q);
    let (a, r) = (ate(&tr), rpe(&tr, DELTA));
    assert_eq!(a.n, 21);
    assert!((a.rmse().unwrap() - 0.05).abs() < 1e-6 && (a.max - 0.05).abs() < 1e-6);
    assert_eq!(r.n, 11, "pairs (i, i + 10)");
    assert!(r.rmse().unwrap() < 1e-6);
    // Scale drift of 10 %: error 0.1·t; RPE 0.1 m per 1 m travelled.
    let tr = track(|_, t| Affine3A::from_translation(Vec3::new(1.1 * t, 0.0, 0.0)));
    // mean (k/10)² over k = 0..=20 is 2870 / 2100.
    let expected = 0.1 * (2870.0f64 / 2100.0).sqrt();
    assert!((ate(&tr).rmse().unwrap() - expected).abs() < 1e-5);
    assert!((rpe(&tr, DELTA).rmse().unwrap() - 0.1).abs() < 1e-5);
    // A global rigid offset (rotation and translation): ATE > 0, RPE 0.
    let g = Affine3A::from_mat3_translation(Mat3::from_rotation_z(0.1), Vec3::new(0.2, -0.1, 0.0));
    let tr = track(|q, _| g * q);
    assert!(ate(&tr).rmse().unwrap() > 0.1);
    assert!(rpe(&tr, DELTA).rmse().unwrap() < 1e-5);
    // Too short for Δ: no pairs.
    assert_eq!(rpe(&tr[..10], DELTA).rmse(), None);
}
