//! Planner benchmarks on a synthetic scene-3-like map (`planner::synth::scene3_map`: desk with 6
//! objects, cafe table with 4, chair with a vase, partly observed SOPMs, 64 sample points each).
//!
//! Targets (issue 5): LBV of 18 candidates p99 ≤ 200 µs, 360 candidates ≤ 2 ms; GBV of 36
//! candidates (full f_a + f_c) ≤ 20 ms on 2 threads, 1000 candidates ≤ 300 ms.
//! Besides criterion's means, the LBV latency distribution (p50/p99/max over 20 000 calls) is
//! printed, since the target is a tail figure, split by whether the thread waited on a run queue
//! during the call (`/proc/thread-self/schedstat`).
//!
//! Run: `cargo bench -p vpsom --bench planner`.
//!
//! Recorded (2 shared vCPUs, other builds running; `-- --warm-up-time 1 --measurement-time 3`):
//! LBV 18: mean 36 µs, single-call p50 21 µs / p99 37 µs; LBV 360: mean 0.65 ms (p50 0.60 ms);
//! GBV eval 36 on 2 threads: 0.34 ms; 1000: 8.0 ms; whole GBV job with a 256 × 256 grid
//! (inflation + Dijkstra + 36 candidates): 2.4 ms.
//!
//! The LBV-360 tail (p99 4.7 ms) is descheduling, not work: every call has the same inputs, and
//! with another helper's builds on the 2 vCPUs (load ≈ 2–4), 546 of 20 000 calls waited on the
//! run queue; calls that did not: p50 0.61 ms, p99 0.80 ms; wall minus run-queue wait over all
//! calls: p99 0.81 ms. The same binary under `chrt -f 50` (the LBV thread's policy when allowed):
//! p50 0.61 ms, p99 0.74 ms (one call stalled by RT throttling). The ≤ 2 ms target holds for the
//! work itself; the host's real-time policy is what keeps other processes off the LBV thread.

use criterion::{Criterion, criterion_group};
use runtime::executor::ThreadSchedStat;
use shm_types::{ObjectMap, OccupancyGrid, boxed_zeroed, grid_cell};
use std::hint::black_box;
use std::time::Instant;
use vpsom::config::CameraConfig;
use vpsom::planner::clusters::{SideTracker, clusters, unfinished_centroid};
use vpsom::planner::gbv::{GbvJob, GbvParams, evaluate_poses, ring_poses};
use vpsom::planner::lbv::neck_yaws;
use vpsom::planner::reach::NavParams;
use vpsom::planner::synth::scene3_map;
use vpsom::planner::{EvalParams, Lbv, PlannerConfig, Target, Weights};

fn setup() -> (PlannerConfig, CameraConfig, Target) {
    let cfg = PlannerConfig::default();
    let cam = CameraConfig::default();
    let map = scene3_map();
    let cl = clusters(&map, cfg.eps_sopm, &SideTracker::new(8), 4);
    let desk = cl
        .iter()
        .find(|c| c.id == 1)
        .copied()
        .expect("desk cluster");
    let target = Target {
        cluster_id: 1,
        centroid: unfinished_centroid(&map, &desk, cfg.eps_sopm),
    };
    (cfg, cam, target)
}

fn lbv_with(m: usize) -> Lbv {
    let (cfg, cam, _) = setup();
    Lbv::with(
        EvalParams::new(&cfg, &cam),
        Weights {
            alpha: 0.0,
            beta: 1.0,
        },
        neck_yaws(-std::f32::consts::PI, std::f32::consts::PI, m),
    )
}

fn gbv_params(n: usize) -> GbvParams {
    let (cfg, cam, _) = setup();
    GbvParams {
        eval: EvalParams::new(&cfg, &cam),
        weights: Weights {
            alpha: 1.0,
            beta: 0.2,
        },
        candidates: n,
        safe_distance: 0.6,
        nav: NavParams {
            robot_radius: 0.3,
            inflated: false,
            unknown_traversable: true,
        },
        revisit_radius: 0.5,
        sectors: 8,
        neck: vpsom::planner::gbv::GbvNeck::new(&cfg),
        fa: vpsom::planner::evaluate::FaFilter::new(&cfg),
        distance_weight: cfg.gbv.distance_weight,
    }
}

/// A 256 × 256 navigation grid at 5 cm (12.8 m square) with the room's walls and the furniture.
fn nav_grid() -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.origin = [-7.4, -6.4];
    g.resolution = 0.05;
    g.width = 256;
    g.height = 256;
    let map = scene3_map();
    for i in 0..256 * 256 {
        let (x, y) = (
            -7.4 + ((i % 256) as f32 + 0.5) * 0.05,
            -6.4 + ((i / 256) as f32 + 0.5) * 0.05,
        );
        let wall = !(-5.0..=1.5).contains(&x) || !(-3.0..=3.0).contains(&y);
        let furniture = map.objects().iter().filter(|o| o.is_background()).any(|o| {
            (x - o.center[0]).abs() <= o.size[0] / 2.0 && (y - o.center[1]).abs() <= o.size[1] / 2.0
        });
        if wall || furniture {
            g.cells[i] = grid_cell::OCCUPIED;
        }
    }
    g
}

const BASE: [f32; 3] = [-0.5, 0.3, std::f32::consts::PI];

fn bench_lbv(c: &mut Criterion) {
    let (_, _, target) = setup();
    let map = scene3_map();
    for m in [18usize, 360] {
        let mut lbv = lbv_with(m);
        c.bench_function(&format!("lbv_{m}_candidates"), |b| {
            b.iter(|| black_box(lbv.evaluate(&map, BASE, 0.0, Some(&target))))
        });
    }
}

fn bench_gbv(c: &mut Criterion) {
    let (cfg, _, target) = setup();
    let map = scene3_map();
    let desk = clusters(&map, cfg.eps_sopm, &SideTracker::new(8), 4)
        .into_iter()
        .find(|c| c.id == 1)
        .expect("desk");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    for n in [36usize, 1000] {
        let p = gbv_params(n);
        let poses = ring_poses(&desk, n, 0.6, [BASE[0], BASE[1]]);
        c.bench_function(&format!("gbv_eval_{n}_candidates_2_threads"), |b| {
            b.iter(|| pool.install(|| black_box(evaluate_poses(&map, &poses, Some(&target), &p))))
        });
    }
    // The whole round as the host runs it: inflation + Dijkstra on 256 × 256, 36 candidates.
    let nav = nav_grid();
    let p = gbv_params(36);
    c.bench_function("gbv_job_36_candidates_256x256_grid_2_threads", |b| {
        b.iter_batched(
            || {
                let mut m = boxed_zeroed::<ObjectMap>();
                m.copy_from(&map);
                let mut g = boxed_zeroed();
                vpsom::planner::session::copy_grid(&mut g, &nav);
                GbvJob {
                    map: m,
                    nav: g,
                    base: BASE,
                    clusters: vec![desk],
                    visited: Vec::new(),
                    params: p,
                }
            },
            |job| pool.install(|| black_box(job.run().best)),
            criterion::BatchSize::LargeInput,
        )
    });
}

/// p50 / p99 / max of single LBV calls (not a criterion statistic), split by whether the thread
/// was descheduled during the call: the inputs are the same on every call (the base moves by at
/// most 1 mm), so the work is the same, and a tail made of calls during which the thread waited
/// on a run queue is the VM / other processes taking the CPU, not the planner.
fn lbv_tail() {
    let (_, _, target) = setup();
    let map = scene3_map();
    for m in [18usize, 360] {
        let mut lbv = lbv_with(m);
        let stat = ThreadSchedStat::open_current().ok();
        let sched_stat = || stat.as_ref().and_then(|s| s.read().ok());
        // (wall, run-queue wait) per call, ns; wait is None without schedstat.
        let calls: Vec<(u64, Option<u64>)> = (0..20_000)
            .map(|k| {
                let base = [BASE[0], BASE[1] + 1e-5 * (k % 100) as f32, BASE[2]];
                let before = sched_stat();
                let t = Instant::now();
                black_box(lbv.evaluate(&map, base, 0.0, Some(&target)));
                let wall = t.elapsed().as_nanos() as u64;
                let after = sched_stat();
                let wait = before.zip(after).map(|(b, a)| {
                    // Put back on a CPU during the call: it waited this long.
                    if a.timeslices > b.timeslices {
                        a.run_wait_ns.saturating_sub(b.run_wait_ns)
                    } else {
                        0
                    }
                });
                (wall, wait)
            })
            .collect();
        let stats = |mut v: Vec<u64>| -> String {
            if v.is_empty() {
                return "none".into();
            }
            v.sort_unstable();
            let q = |f: f64| v[((v.len() as f64 * f) as usize).min(v.len() - 1)] as f64 / 1e3;
            format!(
                "p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs (n = {})",
                q(0.5),
                q(0.99),
                *v.last().unwrap_or(&0) as f64 / 1e3,
                v.len()
            )
        };
        println!(
            "lbv_{m}_candidates single-call latency: {}",
            stats(calls.iter().map(|c| c.0).collect())
        );
        if calls.iter().all(|c| c.1.is_some()) {
            let undisturbed = calls.iter().filter(|c| c.1 == Some(0)).map(|c| c.0);
            let running = calls.iter().map(|c| c.0.saturating_sub(c.1.unwrap_or(0)));
            println!(
                "  calls without a wait on the run queue: {}\n  \
                 wall minus run-queue wait, all calls: {}\n  \
                 calls descheduled: {}",
                stats(undisturbed.collect()),
                stats(running.collect()),
                calls.iter().filter(|c| c.1 != Some(0)).count()
            );
        }
    }
}

criterion_group!(benches, bench_lbv, bench_gbv);

fn main() {
    lbv_tail();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
