//! Simulator benchmarks: one 640×480 frame of paper-scene-3 on 2 rayon threads (target ≥ 60
//! frames/s), depth only and the full `Sim::render` (depth + localization features + detector).
//!
//! `cargo bench -p vpsom --bench sim`
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
//!
//! SIMD kernels (`wide::f32x4` slab test and depth readings, PCG in interleaved lanes, one
//! `|dir|` normalisation per pixel), 2026-12-02, old and new binaries alternately twice at load
//! ≈ 5.5: sim_render_full 8.6 / 9.5 → 5.5 / 5.4 ms (× 0.60), depth_only 7.4 / 7.7 → 4.6 / 3.7 ms
//! (× 0.56), depth_only_1thread 7.4 / 7.7 → 5.2 / 4.1 ms (× 0.60). `SIM_CPU_FRAMES` mode, 1
//! thread, minimum CPU time per frame: 5.6–5.7 → 4.0 ms. Profile of one thread now: depth
//! readings 25 %, boxes 17 %, artefacts 16 %, PCG 11 %, room 9 %, detector 3 %.
//!
//! Quiet machine (load ≈ 1.1–1.4, nothing else running), 2026-12-02, two runs: sim_render_full
//! 3.85 / 3.45 ms (target ≤ 4 ms), depth_only 2.69 / 2.98 ms, depth_only_1thread 4.05 / 5.03 ms.

use criterion::{Criterion, Throughput, criterion_group};
use shm_types::{DepthFrame, Detections, NeckGoal, boxed_zeroed};
use std::hint::black_box;
use vpsom::config::Config;
use vpsom::sim::{DepthCamera, RenderBuffers, Scene, Sim, SimPool, World};

/// The simulator of the benchmark: paper-scene-3 at 640×480 on 2 threads, looking between the
/// desk and the cafe table so that most objects are in view.
fn bench_sim() -> (Sim, Config, Scene) {
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
    (sim, cfg, scene)
}

fn bench_render(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("rayon pool");
    let (mut sim, cfg, scene) = bench_sim();
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

/// CPU time (ns) used so far by all the threads of this process (Linux: the first field of
/// every `/proc/self/task/*/schedstat`); `None` elsewhere.
fn process_cpu_ns() -> Option<u64> {
    let mut total = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

/// `SIM_CPU_FRAMES=N cargo bench -p vpsom --bench sim` (optionally `SIM_CPU_THREADS=T`, default
/// 2): instead of criterion, render N frames with `Sim::render` in batches of 25 and print the
/// wall time and the CPU time (all threads, idle workers' spinning included) per frame, the
/// minimum and the median over the batches. The minimum hardly depends on what else the
/// machine runs, so it compares builds on a busy machine (run them alternately).
fn cpu_report(frames: u32) {
    let threads = std::env::var("SIM_CPU_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2);
    let (mut sim, _, _) = bench_sim();
    sim.set_pool(SimPool::new(threads).expect("sim pool"));
    let mut frame = boxed_zeroed::<DepthFrame>();
    let mut dets = boxed_zeroed::<Detections>();
    for _ in 0..20 {
        sim.render(&mut frame, &mut dets, 0);
    }
    const BATCH: u32 = 25;
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for _ in 0..frames.div_ceil(BATCH) {
        let (t0, c0) = (std::time::Instant::now(), process_cpu_ns());
        for _ in 0..BATCH {
            sim.render(&mut frame, &mut dets, 0);
        }
        wall.push(t0.elapsed().as_secs_f64() * 1e3 / f64::from(BATCH));
        if let (Some(c1), Some(c0)) = (process_cpu_ns(), c0) {
            cpu.push((c1 - c0) as f64 * 1e-6 / f64::from(BATCH));
        }
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (
            v.first().copied().unwrap_or(0.0),
            v.get(v.len() / 2).copied().unwrap_or(0.0),
        )
    };
    let ((wmin, wmed), (cmin, cmed)) = (stats(&mut wall), stats(&mut cpu));
    println!(
        "sim_render_full, {threads} threads: wall min {wmin:.3} / median {wmed:.3} ms/frame, \
         CPU min {cmin:.3} / median {cmed:.3} ms/frame"
    );
}

criterion_group!(benches, bench_render);

fn main() {
    if let Some(n) = std::env::var("SIM_CPU_FRAMES")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        cpu_report(n);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
