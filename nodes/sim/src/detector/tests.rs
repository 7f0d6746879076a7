//! Statistical tests of the detector on synthetic instance images.

use super::*;
use geom::optical_rotation;
use std::path::Path;

const W: usize = 640;
const H: usize = 480;

/// A scene whose objects are only ids for the synthetic images (they stand behind the test
/// camera, so the visible fraction is not estimated): 1 cup, 2 cup, 3 dining table, 4 keyboard,
/// 5 chair, 6 bottle.
fn scene() -> Scene {
    let obj = |name: &str, class: &str, x: f32, y: f32, z: f32, s: f32| {
        format!(
            "[[object]]\nname = \"{name}\"\nclass = \"{class}\"\ncenter = [{x}, {y}, {z}]\n\
             size = [{s}, {s}, {}]\n",
            2.0 * z
        )
    };
    let text = [
        "name = \"synthetic\"\n[room]\nmin = [-4.0, -4.0]\nmax = [4.0, 4.0]\nheight = 2.6\n[robot]\nstart = [-1.5, 1.5, 0.0]\n"
            .to_string(),
        obj("cup_a", "cup", -3.0, -3.0, 0.05, 0.1),
        obj("cup_b", "cup", -3.0, -2.0, 0.05, 0.1),
        obj("table", "dining table", 0.0, 0.0, 0.4, 1.0),
        obj("keyboard", "keyboard", -3.0, 2.0, 0.02, 0.3),
        obj("chair", "chair", 2.5, 2.5, 0.4, 0.5),
        obj("bottle", "bottle", 3.0, -3.0, 0.1, 0.1),
    ]
    .concat();
    Scene::parse(Path::new("synthetic.toml"), &text).unwrap()
}

fn camera() -> Camera {
    Camera::from_fov(W as u32, H as u32, 60.0, 46.8, 0.3, 8.0)
}

/// A camera pose above the room looking up (objects behind it): only the image matters.
fn pose_at(x: f32) -> Affine3A {
    Affine3A::from_translation(Vec3::new(x, 0.0, 10.0))
}

/// A perfect detector (no miss, confusion, jitter, merge or false positive) to start from.
fn perfect() -> DetectorConfig {
    DetectorConfig {
        miss_rate: 0.0,
        miss_small: 0.0,
        miss_occluded: 0.0,
        miss_truncated: 0.0,
        score_min: 0.0,
        box_jitter_px: 0.0,
        box_jitter_frac: 0.0,
        mask_bleed_px: 0,
        nms_iou: 1.0,
        confusion_rate: 0.0,
        other_rate: 0.0,
        fp_per_frame: 0.0,
        fp_confident_per_tp: 0.0,
        dup_per_tp: 0.0,
        ..DetectorConfig::default()
    }
}

/// An instance image with rectangles `(id, [x0, y0, x1, y1])` painted in order.
fn image(rects: &[(u8, [usize; 4])]) -> Vec<u8> {
    let mut img = vec![0u8; W * H];
    for (id, r) in rects {
        for y in r[1]..r[3] {
            img[y * W + r[0]..y * W + r[2]].fill(*id);
        }
    }
    img
}

fn run(det: &mut Detector, img: &[u8], pose: &Affine3A, frame: u64) -> Box<Detections> {
    let mut out = shm_types::boxed_zeroed::<Detections>();
    det.detect(img, &camera(), pose, frame, &mut out);
    assert_eq!(shm_types::Validate::validate(&*out), Ok(()));
    out
}

fn rect_u16(r: [usize; 4]) -> [u16; 4] {
    r.map(|v| v as u16)
}

#[test]
fn box_mode_reports_boxes_only_and_leaves_the_label_image_untouched() {
    let mut det = Detector::new(&scene(), &perfect(), 1);
    let img = image(&[(1, [100, 100, 160, 180]), (3, [300, 200, 500, 400])]);
    let mut out = shm_types::boxed_zeroed::<Detections>();
    out.labels.fill(7);
    det.detect(&img, &camera(), &pose_at(0.0), 0, &mut out);
    assert_eq!(out.masks, mask_mode::BOXES);
    assert!(out.labels.iter().all(|l| *l == 7));
    let d = out.detections();
    assert_eq!(d.len(), 2);
    assert!(d.iter().all(|d| d.label == 0 && d.mask_pixels == 0));
    let mut boxes: Vec<_> = d.iter().map(|d| d.bbox).collect();
    boxes.sort();
    assert_eq!(boxes, vec![[100, 100, 160, 180], [300, 200, 500, 400]]);

    // Masks mode: the label image holds each item's mask.
    let cfg = DetectorConfig {
        mode: "masks".into(),
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 1);
    det.detect(&img, &camera(), &pose_at(0.0), 0, &mut out);
    assert_eq!(out.masks, mask_mode::MASKS);
    for d in out.detections() {
        let n = out
            .label_pixels()
            .iter()
            .filter(|l| **l as u16 == d.label)
            .count();
        assert_eq!(n as u32, d.mask_pixels);
        assert!(n == 60 * 80 || n == 200 * 200, "{n}");
    }
}

#[test]
fn box_jitter_grows_with_size_and_gives_a_yolo_like_iou() {
    let cfg = DetectorConfig {
        box_jitter_px: 1.0,
        box_jitter_frac: DetectorConfig::default().box_jitter_frac,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 3);
    let (small, large) = ([100, 100, 130, 130], [300, 150, 540, 390]);
    let img = image(&[(1, small), (3, large)]);
    let (mut err, mut ious) = ([0.0f32; 2], [0.0f32; 2]);
    let frames = 300;
    for f in 0..frames {
        let out = run(&mut det, &img, &pose_at(0.0), f);
        for d in out.detections() {
            let (i, t) = if d.class_id == det.class_ids[0] {
                (0, small)
            } else {
                (1, large)
            };
            err[i] += (d.bbox[0] as f32 - t[0] as f32).abs();
            ious[i] += iou(d.bbox, rect_u16(t));
        }
    }
    let f = frames as f32;
    assert!(err[1] > 3.0 * err[0], "edge errors {err:?}");
    let (small_iou, large_iou) = (ious[0] / f, ious[1] / f);
    assert!((0.7..0.9).contains(&large_iou), "large IoU {large_iou}");
    assert!((0.65..0.9).contains(&small_iou), "small IoU {small_iou}");
}

#[test]
fn overlapping_same_class_objects_come_out_as_one_box_union_at_the_configured_rate() {
    let cfg = DetectorConfig {
        nms_iou: 0.45,
        merge_union: 0.3,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 5);
    // Two cups, one partly behind the other (visible boxes' IoU 0.57), and a bottle
    // overlapping them (another class).
    let (a, b) = ([200, 150, 300, 250], [215, 165, 315, 265]);
    let img = image(&[(1, a), (2, b), (6, [305, 100, 345, 200])]);
    let union = rect_u16([200, 150, 315, 265]);
    let frames = 600;
    let mut unions = 0;
    for f in 0..frames {
        let out = run(&mut det, &img, &pose_at(0.0), f);
        let cups: Vec<_> = out
            .detections()
            .iter()
            .filter(|d| d.class_id == det.class_ids[0])
            .collect();
        assert_eq!(cups.len(), 1, "frame {f}");
        assert_eq!(out.count, 2, "the bottle stays");
        if cups[0].bbox == union {
            unions += 1;
        } else {
            assert!(cups[0].bbox == rect_u16(a) || cups[0].bbox == rect_u16(b));
        }
    }
    let rate = unions as f32 / frames as f32;
    assert!((rate - 0.3).abs() < 0.06, "union rate {rate}");

    // Below the NMS IoU both stay.
    let img = image(&[(1, a), (2, [250, 150, 350, 250])]);
    assert_eq!(run(&mut det, &img, &pose_at(0.0), 0).count, 2);
}

#[test]
fn truncated_objects_are_missed_more_often_with_worse_boxes_and_lower_scores() {
    let cfg = DetectorConfig::default();
    let c = DetectorConfig {
        fp_per_frame: 0.0,
        fp_confident_per_tp: 0.0,
        dup_per_tp: 0.0,
        confusion_rate: 0.0,
        other_rate: 0.0,
        ..cfg
    };
    let mut det = Detector::new(&scene(), &c, 9);
    let (inner, cut) = ([100, 100, 220, 220], [520, 100, 640, 220]);
    let img = image(&[(1, inner), (2, cut)]);
    let frames = 800;
    let (mut hits, mut ious, mut scores) = ([0u32; 2], [0.0f32; 2], [0.0f32; 2]);
    for f in 0..frames {
        let out = run(&mut det, &img, &pose_at(0.0), f);
        for d in out.detections() {
            let i = usize::from(d.bbox[0] >= 400);
            let t = if i == 0 { inner } else { cut };
            hits[i] += 1;
            ious[i] += iou(d.bbox, rect_u16(t));
            scores[i] += d.score;
        }
    }
    let rate = hits.map(|n| n as f32 / frames as f32);
    assert!(rate[1] < rate[0] - 0.1, "detection rates {rate:?}");
    let iou = [ious[0] / hits[0] as f32, ious[1] / hits[1] as f32];
    assert!(iou[1] < iou[0], "IoU {iou:?}");
    let score = [scores[0] / hits[0] as f32, scores[1] / hits[1] as f32];
    assert!(score[1] < score[0] - 0.05, "scores {score:?}");
}

#[test]
fn small_objects_are_missed_more_often_and_score_lower() {
    let c = DetectorConfig {
        fp_per_frame: 0.0,
        fp_confident_per_tp: 0.0,
        dup_per_tp: 0.0,
        ..DetectorConfig::default()
    };
    let mut det = Detector::new(&scene(), &c, 11);
    let img = image(&[(1, [100, 100, 120, 120]), (2, [300, 100, 420, 220])]);
    let frames = 800;
    let (mut hits, mut scores) = ([0u32; 2], [0.0f32; 2]);
    for f in 0..frames {
        for d in run(&mut det, &img, &pose_at(0.0), f).detections() {
            let i = usize::from(d.bbox[0] >= 200);
            hits[i] += 1;
            scores[i] += d.score;
        }
    }
    let rate = hits.map(|n| n as f32 / frames as f32);
    assert!(
        rate[0] < 0.6 && rate[1] > 0.85,
        "small/large detection rates {rate:?}"
    );
    assert!(scores[0] / (hits[0] as f32) < scores[1] / (hits[1] as f32) - 0.05);
}

#[test]
fn confusion_persists_for_a_view_and_stays_within_look_alikes() {
    let cfg = DetectorConfig {
        confusion_rate: 0.3,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 13);
    let img = image(&[(1, [100, 100, 200, 200])]);
    let cup = det.class_ids[0];
    let group: Vec<ClassId> = ["cup", "bowl", "vase", "bottle", "wine glass"]
        .iter()
        .map(|n| shm_types::class_id(n).unwrap())
        .collect();
    let views = 400;
    let mut confused = 0;
    for v in 0..views {
        // Views from all around the cup and at several distances.
        let a = v as f32 * 0.37;
        let r = 0.5 + (v % 7) as f32;
        let obj = det.centers[0];
        let pose =
            Affine3A::from_translation(Vec3::new(obj.x + r * a.cos(), obj.y + r * a.sin(), 10.0));
        let first = run(&mut det, &img, &pose, 0).items[0].class_id;
        assert!(group.contains(&first));
        for f in 1..5 {
            assert_eq!(
                run(&mut det, &img, &pose, f).items[0].class_id,
                first,
                "view {v}"
            );
        }
        confused += usize::from(first != cup);
    }
    let rate = confused as f32 / views as f32;
    assert!((rate - 0.3).abs() < 0.08, "confusion rate {rate}");
}

#[test]
fn false_positives_lie_on_background_with_low_scores_and_match_no_object() {
    let cfg = DetectorConfig {
        fp_per_frame: 1.0,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 17);
    // A camera in the room 1.2 m high looking at a wall (+x, 1.5 m away), pitched down 0.5 rad:
    // wall above row ~340 (0.3 m high at row ~263), floor below; the table in the lower half,
    // a cup on it.
    let pose =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.5), Vec3::new(2.5, 0.0, 1.2));
    let (table, cup) = ([150, 260, 500, 480], [300, 300, 330, 340]);
    let img = image(&[(3, table), (1, cup)]);
    let table_id = det.class_ids[2];
    let frames = 500;
    let (mut fps, mut on_table, mut on_wall) = (0, 0, 0);
    for f in 0..frames {
        let out = run(&mut det, &img, &pose, f);
        for d in out.detections() {
            if d.bbox == rect_u16(table) || d.bbox == rect_u16(cup) {
                continue;
            }
            fps += 1;
            assert!(d.score >= cfg.fp_score_min && d.score <= cfg.fp_score_max);
            assert!(iou(d.bbox, rect_u16(table)) < 0.5 && iou(d.bbox, rect_u16(cup)) < 0.5);
            let name = shm_types::class_name(d.class_id);
            if ["laptop", "book", "keyboard", "cell phone"].contains(&name) {
                on_table += 1;
                let b = d.bbox.map(usize::from);
                assert!(
                    b[0] >= table[0] && b[1] >= table[1] && b[2] <= table[2] && b[3] <= table[3]
                );
            } else {
                assert!(["tv", "clock", "refrigerator"].contains(&name), "{name}");
                on_wall += 1;
                // Sample rows (1/6, 1/2, 5/6 of the box) lie above row 263.
                assert!(
                    d.bbox[3] <= 290,
                    "wall false positive on the floor: {:?}",
                    d.bbox
                );
            }
            assert_ne!(d.class_id, table_id);
        }
    }
    let rate = fps as f32 / frames as f32;
    assert!(rate > 0.8 && rate < 1.2, "false positives per frame {rate}");
    assert!(
        on_table > 50 && on_wall > 50,
        "table {on_table}, wall {on_wall}"
    );
}

#[test]
fn duplicates_are_mislocalised_boxes_of_the_class_scored_like_the_object() {
    let cfg = DetectorConfig {
        dup_per_tp: 0.5,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 19);
    let cup_box = [100, 100, 200, 200];
    let img = image(&[(1, cup_box)]);
    let cup = det.class_ids[0];
    let frames = 400;
    let (mut dups, mut dup_score, mut own_score) = (0, 0.0, 0.0);
    for f in 0..frames {
        let out = run(&mut det, &img, &pose_at(0.0), f);
        assert!(out.count <= 2);
        for d in out.detections() {
            assert_eq!(d.class_id, cup);
            if d.bbox == rect_u16(cup_box) {
                own_score += d.score;
                continue;
            }
            dups += 1;
            dup_score += d.score;
            let i = iou(d.bbox, rect_u16(cup_box));
            assert!((0.1..0.5).contains(&i), "duplicate IoU {i}");
        }
    }
    let rate = dups as f32 / frames as f32;
    assert!((rate - 0.5).abs() < 0.08, "duplicates per detection {rate}");
    let (dup_mean, own_mean) = (dup_score / dups as f32, own_score / frames as f32);
    assert!(
        (dup_mean - own_mean).abs() < 0.02,
        "duplicate score {dup_mean} vs the object's {own_mean}"
    );
}

#[test]
fn confident_false_positives_score_like_true_positives_and_match_no_object() {
    let cfg = DetectorConfig {
        fp_confident_per_tp: 0.5,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 23);
    let pose =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.5), Vec3::new(2.5, 0.0, 1.2));
    let (table, cup) = ([150, 260, 500, 480], [300, 300, 330, 340]);
    let img = image(&[(3, table), (1, cup)]);
    let frames = 500;
    let (mut fps, mut score) = (0, 0.0);
    for f in 0..frames {
        let out = run(&mut det, &img, &pose, f);
        for d in out.detections() {
            if d.bbox == rect_u16(table) || d.bbox == rect_u16(cup) {
                continue;
            }
            fps += 1;
            score += d.score;
            assert!(iou(d.bbox, rect_u16(table)) < 0.5 && iou(d.bbox, rect_u16(cup)) < 0.5);
        }
    }
    // Two objects reported per frame: one confident false positive per frame on average.
    let rate = fps as f32 / frames as f32;
    assert!(
        rate > 0.8 && rate < 1.2,
        "confident false positives per frame {rate}"
    );
    let mean = score / fps as f32;
    assert!(
        (mean - cfg.score_mean).abs() < 0.03,
        "mean score {mean}, true positives' {}",
        cfg.score_mean
    );
}

#[test]
fn same_seed_same_detections() {
    let cfg = DetectorConfig::default();
    let img = image(&[
        (1, [100, 100, 160, 180]),
        (3, [300, 200, 500, 400]),
        (2, [620, 0, 640, 100]),
    ]);
    let pose =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.2), Vec3::new(2.5, 0.0, 1.2));
    let all = |seed| {
        let mut det = Detector::new(&scene(), &cfg, seed);
        (0..50)
            .map(|f| run(&mut det, &img, &pose, f).detections().to_vec())
            .collect::<Vec<_>>()
    };
    assert_eq!(all(1), all(1));
    assert_ne!(all(1), all(2));
}

#[test]
fn masks_mode_merged_objects_share_one_mask_and_false_positives_get_their_source_pixels() {
    let cfg = DetectorConfig {
        mode: "masks".into(),
        nms_iou: 0.45,
        merge_union: 1.0,
        fp_per_frame: 2.0,
        ..perfect()
    };
    let mut det = Detector::new(&scene(), &cfg, 19);
    let pose =
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.5), Vec3::new(2.5, 0.0, 1.2));
    let (a, b, table) = (
        [200, 150, 300, 250],
        [215, 165, 315, 265],
        [150, 300, 500, 480],
    );
    let img = image(&[(3, table), (1, a), (2, b)]);
    let (mut fps, mut empty) = (0, 0);
    for f in 0..50 {
        let out = run(&mut det, &img, &pose, f);
        for d in out.detections() {
            let mut n = 0;
            for (i, l) in out.label_pixels().iter().enumerate() {
                if *l as u16 == d.label {
                    n += 1;
                    if d.class_id == det.class_ids[0] {
                        assert!(img[i] == 1 || img[i] == 2);
                    }
                }
            }
            assert_eq!(n, d.mask_pixels);
            if d.class_id == det.class_ids[0] {
                assert_eq!(n, 100 * 100 + 100 * 100 - 85 * 85, "union mask");
                assert_eq!(d.bbox, [200, 150, 315, 265]);
            } else if d.class_id != det.class_ids[2] {
                // (Empty only when an earlier false positive took its pixels.)
                fps += 1;
                empty += usize::from(n == 0);
            }
        }
    }
    assert!(
        fps > 50 && empty * 10 < fps,
        "{fps} false positives, {empty} empty"
    );
}
