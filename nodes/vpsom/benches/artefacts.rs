//! Depth-artefact post-process benchmark: one 640×480 frame of paper-scene-3 (the `sim` bench's
//! view) on 2 and 1 rayon threads. Budget: ≤ 0.5 ms on 2 threads (the whole render + detect
//! must stay ≤ 4 ms).
//!
//! `cargo bench -p vpsom --bench artefacts`
//!
//! Each iteration restores the rendered depth (a 600 kB copy, included) and applies the
//! artefacts of a new frame index.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shm_types::NeckGoal;
use std::hint::black_box;
use vpsom::config::Config;
use vpsom::sim::{DepthArtefacts, DepthCamera, RenderBuffers, Scene, Sim, World};

fn bench_artefacts(c: &mut Criterion) {
    let cfg = Config::builtin();
    assert_eq!((cfg.camera.width, cfg.camera.height), (640, 480));
    let scene = Scene::builtin("paper-scene-3").expect("built-in scene");
    let mut sim = Sim::new(scene.clone(), &cfg, 1).expect("sim");
    sim.set_neck_goal(&NeckGoal {
        yaw: -0.25,
        pitch: cfg.camera.mount.pitch(),
        ..Default::default()
    });
    sim.step(2_000_000_000);
    let pose = sim.true_camera_pose();
    let world = World::new(&scene);
    let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 1);
    let art = DepthArtefacts::new(&scene, &cfg.camera, &cfg.sim, 2);
    let mut buf = RenderBuffers::new();
    let mut rendered = vec![0u16; 640 * 480];
    cam.render(&world, &pose, 0, &mut rendered, &mut buf);
    let mut depth = rendered.clone();

    let mut g = c.benchmark_group("sim_640x480_paper-scene-3");
    g.throughput(Throughput::Elements(1));
    g.sample_size(60);
    let mut k = 0;
    for threads in [2, 1] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("rayon pool");
        g.bench_function(format!("depth_artefacts_{threads}threads"), |b| {
            b.iter(|| {
                k += 1;
                depth.copy_from_slice(&rendered);
                pool.install(|| art.apply(&world, &pose, k, &buf, &mut depth));
                black_box(depth[1000])
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_artefacts);
criterion_main!(benches);
