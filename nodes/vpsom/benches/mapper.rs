//! Mapper benchmark: one 640 × 480 frame with 10 visible objects (a table and nine objects on
//! it) — point extraction, association, cuboid fits and SOPM updates — on a warmed-up map.
//! Also `write_map` into a heap ObjectMap. Target: integrate ≤ 10 ms. Run with instance masks
//! and with box-only detections (box segmentation); the `_boxes_plain` variant switches off
//! `[mapper.extensions] view_extents` and `co_detection`, so one run shows what they cost.

#[path = "../tests/mapper_common/mod.rs"]
mod mapper_common;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use mapper_common::{RenderOpts, busy_scene, render};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use shm_types::{DepthFrame, Detections, ObjectMap, RobotState, boxed_zeroed};
use std::hint::black_box;
use vpsom::config::CameraConfig;
use vpsom::geom::CameraMount;
use vpsom::mapper::{Mapper, MapperConfig};

fn bench(c: &mut Criterion) {
    let cfg = MapperConfig::default();
    run(c, false, &cfg, "");
    run(c, true, &cfg, "_boxes");
    let mut plain = cfg.clone();
    plain.extensions.view_extents = false;
    plain.extensions.co_detection = false;
    run(c, true, &plain, "_boxes_plain");
}

fn run(c: &mut Criterion, boxes: bool, cfg: &MapperConfig, suffix: &str) {
    let scene = busy_scene();
    let opts = RenderOpts {
        boxes,
        ..Default::default()
    };
    let camera = CameraConfig::default().camera();
    let mount = CameraMount::default();
    let mut mapper = Mapper::new(cfg, &camera).expect("default config");
    let mut rng = Pcg64::seed_from_u64(1);
    let state = RobotState {
        localization_ok: 1,
        ..Default::default()
    };
    let mut frame = boxed_zeroed::<DepthFrame>();
    let mut dets = boxed_zeroed::<Detections>();
    // Warm up: 8 views over 80° of a circle.
    for k in 0..9u64 {
        let a = (k as f32 * 10.0).to_radians();
        let base = [1.5 * a.cos(), 1.5 * a.sin(), a + std::f32::consts::PI];
        let pose = mount.camera_pose(base, 0.0, mount.pitch());
        render(
            &scene,
            &camera,
            &pose,
            k + 1,
            k * 33_000_000,
            &opts,
            &mut rng,
            &mut frame,
            &mut dets,
        );
        if k < 8 {
            mapper.integrate(&frame, &dets, &state).expect("frame");
        }
    }
    println!("visible detections in the benchmark frame: {}", dets.count);
    c.bench_function(
        &format!("mapper_integrate_10_objects_640x480{suffix}"),
        |b| {
            b.iter_batched(
                || mapper.clone(),
                |mut m| {
                    black_box(m.integrate(&frame, &dets, &state).expect("frame"));
                    m
                },
                BatchSize::LargeInput,
            )
        },
    );
    mapper.integrate(&frame, &dets, &state).expect("frame");
    let mut map = boxed_zeroed::<ObjectMap>();
    c.bench_function(&format!("mapper_write_map{suffix}"), |b| {
        b.iter(|| mapper.write_map(black_box(&mut map), 0))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
