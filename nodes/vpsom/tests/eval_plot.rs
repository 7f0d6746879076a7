//! Figures: a run's PNG is written, has the requested size and shows the drawn elements.

use std::path::PathBuf;
use vpsom::eval::plot::{RUN_FIGURE_SIZE, render_rgb};
use vpsom::eval::*;

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("eval_plot")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn obj(name: &str, class: &str, bg: bool, c: [f32; 3], s: [f32; 3], yaw: f32) -> GtObject {
    GtObject {
        name: name.into(),
        class: class.into(),
        background: bg,
        center: c,
        size: s,
        yaw,
    }
}

/// A small scene like the paper's scene 1: a desk with objects, a chair, a loop around them.
pub fn sample_input(planner: &str, seed: u64) -> PlotInput {
    let gt = vec![
        obj(
            "desk",
            "dining table",
            true,
            [-1.9, -0.06, 0.36],
            [1.8, 1.6, 0.72],
            0.0,
        ),
        obj(
            "chair",
            "chair",
            true,
            [-0.6, 1.6, 0.45],
            [0.5, 0.5, 0.9],
            0.4,
        ),
        obj(
            "cup",
            "cup",
            false,
            [-1.43, -0.57, 0.78],
            [0.12, 0.12, 0.12],
            0.0,
        ),
        obj(
            "book",
            "book",
            false,
            [-2.3, 0.3, 0.74],
            [0.2, 0.28, 0.04],
            0.3,
        ),
        obj(
            "laptop",
            "laptop",
            false,
            [-1.9, 0.45, 0.8],
            [0.35, 0.25, 0.03],
            -0.2,
        ),
        obj(
            "bottle",
            "bottle",
            false,
            [-2.5, -0.5, 0.84],
            [0.08, 0.08, 0.24],
            0.0,
        ),
    ];
    let estimated: Vec<EstObject> = gt
        .iter()
        .enumerate()
        .map(|(i, g)| EstObject {
            class: g.class.clone(),
            background: g.background,
            center: [
                g.center[0] + 0.03 * i as f32,
                g.center[1] - 0.02,
                g.center[2],
            ],
            size: [g.size[0] * 0.9, g.size[1] * 1.1, g.size[2]],
            yaw: g.yaw + 0.1,
            h_sopm: 0.3,
            complete: true,
        })
        .collect();
    let trajectory: Vec<[f32; 2]> = (0..=80)
        .map(|k| {
            let a = k as f32 / 80.0 * 5.5;
            [-1.9 + 1.9 * a.cos(), -0.06 + 1.7 * a.sin()]
        })
        .collect();
    let gbv = (0..5)
        .map(|k| {
            let p = trajectory[k * 16];
            ViewPose {
                position: [p[0], p[1], 1.4],
                yaw: (-0.06 - p[1]).atan2(-1.9 - p[0]),
                pitch: 0.49,
            }
        })
        .collect();
    let lbv = trajectory
        .iter()
        .step_by(3)
        .map(|p| ViewPose {
            position: [p[0], p[1], 1.4],
            yaw: (-0.06 - p[1]).atan2(-1.9 - p[0]) + 0.2,
            pitch: 0.49,
        })
        .collect();
    PlotInput {
        run: RunInfo {
            scene: "paper-scene-1".into(),
            planner: planner.into(),
            seed,
        },
        room: Room {
            min: [-4.0, -3.0],
            max: [1.5, 3.0],
        },
        gt,
        estimated,
        trajectory,
        gbv,
        lbv,
        headline: Some(plot::Headline {
            precision: 0.9,
            recall: 1.0,
            iou: Some(0.769),
            cde_m: Some(0.041),
            path_length_m: 10.39,
            time_s: 248.0,
            non_occlusion: Some(0.631),
        }),
    }
}

fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

#[test]
fn run_figure_is_a_png_of_the_requested_size_showing_all_elements() {
    let input = sample_input("vpsom", 1);
    let path = tmp("run").join("map.png");
    render_png(&input, &path, RUN_FIGURE_SIZE).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(png_size(&bytes), RUN_FIGURE_SIZE);
    assert!(
        bytes.len() > 20_000,
        "a drawn figure compresses to more than a blank one"
    );

    let (w, h) = RUN_FIGURE_SIZE;
    let rgb = render_rgb(&input, (w, h)).unwrap();
    assert_eq!(rgb.len(), 3 * (w * h) as usize);
    let px: Vec<[u8; 3]> = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let non_white = px.iter().filter(|p| **p != [255, 255, 255]).count();
    assert!(non_white > px.len() / 10, "only {non_white} drawn pixels");
    // GBV wedges are red, LBV wedges blue, ground truth black.
    let reddish = px
        .iter()
        .filter(|p| p[0] > 180 && p[1] < 120 && p[2] < 120)
        .count();
    let bluish = px
        .iter()
        .filter(|p| p[2] > 180 && p[0] < 150 && p[1] < 170)
        .count();
    let black = px.iter().filter(|p| p.iter().all(|c| *c < 40)).count();
    assert!(
        reddish > 500 && bluish > 500 && black > 2_000,
        "{reddish} {bluish} {black}"
    );

    // Without views or trajectory, no red pixels appear.
    let mut bare = input.clone();
    bare.gbv.clear();
    bare.lbv.clear();
    bare.trajectory.clear();
    let rgb = render_rgb(&bare, (w, h)).unwrap();
    let red = rgb
        .chunks_exact(3)
        .filter(|p| p[0] > 180 && p[1] < 120 && p[2] < 120)
        .count();
    assert!(red < reddish / 4, "{red} vs {reddish}");
}

#[test]
fn empty_run_still_renders() {
    let mut input = sample_input("frontier", 3);
    input.gt.clear();
    input.estimated.clear();
    input.trajectory.clear();
    input.gbv.clear();
    input.lbv.clear();
    input.headline = None;
    let path = tmp("empty").join("map.png");
    render_png(&input, &path, (400, 300)).unwrap();
    assert_eq!(png_size(&std::fs::read(&path).unwrap()), (400, 300));
}
