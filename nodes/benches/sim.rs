//! Simulator benchmarks: one 640×480 frame of paper-scene-3 on 2 rayon threads (target ≥ 60
//! frames/s), depth only and the full `Sim::render` (depth + localization features + detector).
//!
//! `cargo bench -p nodes --bench sim`
//!
//! Recorded 2026-11 on the 2-vCPU dev VM (shared with other builds, load ≈ 1–2), per-pixel ray
//! casting: depth_only 7.6 ms (132 frames/s), sim_render_full 12.8 ms (78 frames/s),
//! depth_only_1thread 15.6 ms (64 frames/s). Under heavy load (≈ 4) the figures roughly double.
//!
//! Row packets with vectorised kernels (`sim/rowcast.rs`), 2026-12-01, the old and the new
//! binaries run alternately twice in one session at load ≈ 11–12 (absolute figures ≈ 4× the
//! unloaded ones; the ratios are what carries over): depth_only 28.5 (45.6, a disturbed run) →
//! 17.5 / 18.4 ms (× 0.62),
//! sim_render_full 43.5 / 45.5 → 33.8 / 31.4 ms (× 0.73), depth_only_1thread 32.0 / 25.8 →
//! 20.2 / 20.5 ms (× 0.71). Per-thread CPU time of one frame in the same conditions: depth
//! 6.5 ms, detector 4.7–5.4 ms, localization's `count_visible` 0.15 ms; the detector is now
//! ≈ 40 % of `sim_render_full`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nodes::config::Config;
use nodes::sim::{DepthCamera, RenderBuffers, Scene, Sim, SimPool, World};
use shm_types::{DepthFrame, Detections, NeckGoal, boxed_zeroed};
use std::hint::black_box;

fn bench_render(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("rayon pool");
    let cfg = Config::builtin();
    assert_eq!((cfg.camera.width, cfg.camera.height), (640, 480));
    let scene = Scene::builtin("paper-scene-3").expect("built-in scene");
    let mut sim = Sim::new(scene.clone(), &cfg, 1).expect("sim");
    sim.set_pool(SimPool::new(2).expect("sim pool"));
    // Look between the desk and the cafe table so that most objects are in view.
    sim.set_neck_goal(&NeckGoal {
        yaw: -0.25,
        pitch: cfg.camera.mount.pitch(),
        ..Default::default()
    });
    sim.step(2_000_000_000);
    let mut frame = boxed_zeroed::<DepthFrame>();
    let mut dets = boxed_zeroed::<Detections>();

    let mut g = c.benchmark_group("sim_640x480_paper-scene-3_2threads");
    g.throughput(Throughput::Elements(1));
    g.sample_size(40);
    g.bench_function("sim_render_full", |b| {
        b.iter(|| sim.render(&mut frame, &mut dets, 0))
    });
    let world = World::new(&scene);
    let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 1);
    let pose = sim.true_camera_pose();
    let mut buf = RenderBuffers::new();
    let mut depth = vec![0u16; 640 * 480];
    let mut k = 0;
    g.bench_function("depth_only", |b| {
        b.iter(|| {
            k += 1;
            pool.install(|| cam.render(&world, &pose, k, &mut depth, &mut buf));
            black_box(depth[1000])
        })
    });
    let pool1 = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("rayon pool");
    g.bench_function("depth_only_1thread", |b| {
        b.iter(|| {
            k += 1;
            pool1.install(|| cam.render(&world, &pose, k, &mut depth, &mut buf));
            black_box(depth[1000])
        })
    });
    g.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
