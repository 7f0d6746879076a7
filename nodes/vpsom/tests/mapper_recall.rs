//! The mapper's recall under box-only sensing (issue 15): small objects the detector often misses
//! survive their existence updates, objects hit from many viewpoints survive a few misses, and two
//! same-class neighbours in one NMS-merged box stay two objects.

mod mapper_common;

use glam::Vec3;
use mapper_common::{RenderOpts, Scene, Shape, camera, find, render, state, view};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use shm_types::{DepthFrame, Detection, Detections, boxed_zeroed, class_id};
use vpsom::mapper::{Mapper, MapperConfig};

fn table() -> Shape {
    Shape::new(
        "dining table",
        [0.0, 0.0, 0.375],
        [1.2, 0.8, 0.75],
        0.0,
        false,
    )
}

fn remove(dets: &mut Detections, i: usize) {
    let n = dets.count as usize;
    dets.items.copy_within(i + 1..n, i);
    dets.count -= 1;
}

/// Render a box-only frame of `scene` from `view(target, radius, deg)`.
#[allow(clippy::too_many_arguments)]
fn frame(
    scene: &Scene,
    target: Vec3,
    radius: f32,
    deg: f32,
    k: u64,
    frame: &mut DepthFrame,
    dets: &mut Detections,
) {
    let cam = camera();
    let mut rng = Pcg64::seed_from_u64(k);
    let opts = RenderOpts {
        boxes: true,
        ..Default::default()
    };
    let pose = view(target, radius, deg);
    render(
        scene,
        &cam,
        &pose,
        k,
        k * 100_000_000,
        &opts,
        &mut rng,
        frame,
        dets,
    );
}

#[test]
fn a_small_object_the_detector_often_misses_survives_five_missed_views() {
    // A cup 2 m away (~0.5 k px at 640 x 480: a COCO "small-to-medium" object, recalled about
    // half the time), detected in the first view and missed in the next five.
    let cup_at = Vec3::new(0.45, 0.0, 0.80);
    let scene = Scene {
        objects: vec![
            table(),
            Shape::new("cup", cup_at.to_array(), [0.08, 0.08, 0.10], 0.0, true),
        ],
        room: [-4.0, -4.0, 4.0, 4.0],
    };
    let cam = camera();
    let cup = class_id("cup").unwrap();
    for detectability in [true, false] {
        let mut cfg = MapperConfig::default();
        cfg.extensions.detectability = detectability;
        let mut m = Mapper::new(&cfg, &cam).unwrap();
        let (mut f, mut d) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
        let mut first = true;
        for k in 1..=6u64 {
            frame(
                &scene,
                cup_at,
                2.0,
                (k as f32 - 3.5) * 12.0,
                k,
                &mut f,
                &mut d,
            );
            if !first && let Some(i) = find(&d, "cup") {
                remove(&mut d, i);
            }
            first = false;
            m.integrate(&f, &d, &state()).unwrap();
        }
        let kept = m.objects().iter().any(|o| o.class_id == cup);
        // With a flat p_detect = 0.7 five misses (-1.10 each) undo the hit (+1.95).
        assert_eq!(kept, detectability, "detectability {detectability}");
    }
}

#[test]
fn an_object_hit_from_many_views_survives_six_missed_views() {
    // A large object (a laptop-sized box) 1.2 m away: seen and detected from eight viewpoints,
    // then missed from six more (a detector's bad streak, e.g. a persistent confusion).
    let at = Vec3::new(0.35, 0.0, 0.86);
    let scene = Scene {
        objects: vec![
            table(),
            Shape::new("laptop", at.to_array(), [0.34, 0.24, 0.22], 0.0, false),
        ],
        room: [-4.0, -4.0, 4.0, 4.0],
    };
    let cam = camera();
    let laptop = class_id("laptop").unwrap();
    for detectability in [true, false] {
        let mut cfg = MapperConfig::default();
        cfg.extensions.detectability = detectability;
        let mut m = Mapper::new(&cfg, &cam).unwrap();
        let (mut f, mut d) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
        for k in 1..=14u64 {
            frame(&scene, at, 1.2, (k as f32 - 7.5) * 11.0, k, &mut f, &mut d);
            if k > 8
                && let Some(i) = find(&d, "laptop")
            {
                remove(&mut d, i);
            }
            m.integrate(&f, &d, &state()).unwrap();
        }
        let kept = m.objects().iter().any(|o| o.class_id == laptop);
        assert_eq!(kept, detectability, "detectability {detectability}");
    }
}

/// Whether two pixel boxes overlap or lie within `px` of each other.
fn near(a: [u16; 4], b: [u16; 4], px: u16) -> bool {
    a[0] <= b[2] + px && b[0] <= a[2] + px && a[1] <= b[3] + px && b[1] <= a[3] + px
}

#[test]
fn two_books_side_by_side_in_one_merged_box_stay_two_objects() {
    // Guard (not a reproduction): this renderer has no mixed pixels, so the two books stay apart
    // even without the split; the bench (paper scene 1) still merges them, see the report.
    // Two books 5 cm apart on a table (as paper scene 1's), seen from all around at 1.6 m. A
    // YOLO-class detector's NMS turns their two boxes into one when they overlap; here, harsher,
    // whenever they touch (within 3 px): from every view along the pair's axis, a box holding
    // both books.
    let (a, b) = (Vec3::new(0.1, 0.14, 0.767), Vec3::new(0.1, -0.13, 0.767));
    let scene = Scene {
        objects: vec![
            table(),
            Shape::new("book", a.to_array(), [0.27, 0.2, 0.034], 1.4, false),
            Shape::new("book", b.to_array(), [0.25, 0.165, 0.033], 0.0, false),
        ],
        room: [-4.0, -4.0, 4.0, 4.0],
    };
    let cam = camera();
    let book = class_id("book").unwrap();
    let centre = (a + b) * 0.5;
    let mut merged_views = 0;
    for split in [true, false] {
        let mut cfg = MapperConfig::default();
        cfg.extensions.split_oversize = split;
        let mut m = Mapper::new(&cfg, &cam).unwrap();
        let (mut f, mut d) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
        merged_views = 0;
        for (k, deg) in (0..360).step_by(20).enumerate() {
            frame(
                &scene,
                centre,
                1.6,
                deg as f32,
                k as u64 + 1,
                &mut f,
                &mut d,
            );
            let books: Vec<usize> = (0..d.count as usize)
                .filter(|&i| d.items[i].class_id == book)
                .collect();
            if let [i, j] = books[..]
                && near(d.items[i].bbox, d.items[j].bbox, 3)
            {
                let (p, q) = (d.items[i].bbox, d.items[j].bbox);
                d.items[i] = Detection {
                    bbox: [
                        p[0].min(q[0]),
                        p[1].min(q[1]),
                        p[2].max(q[2]),
                        p[3].max(q[3]),
                    ],
                    ..d.items[i]
                };
                remove(&mut d, j);
                merged_views += 1;
            }
            m.integrate(&f, &d, &state()).unwrap();
        }
        let got: Vec<Vec3> = m
            .objects()
            .iter()
            .filter(|o| o.class_id == book && o.observations >= 2)
            .map(|o| o.cuboid.center)
            .collect();
        println!("split {split}: {merged_views} merged views, books at {got:?}");
        if split {
            assert_eq!(got.len(), 2, "two books: {got:?}");
            for want in [a, b] {
                let dist = got
                    .iter()
                    .map(|g| g.truncate().distance(want.truncate()))
                    .fold(f32::INFINITY, f32::min);
                assert!(dist < 0.05, "book at {want} found {dist:.3} m off: {got:?}");
            }
        }
    }
    assert!(
        merged_views >= 4,
        "the test needs merged boxes: {merged_views}"
    );
}
