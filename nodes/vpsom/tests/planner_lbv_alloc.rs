//! The LBV path allocates nothing in steady state: a counting global allocator (this file's own,
//! since the allocator is process-wide) watches `Lbv::evaluate` and `ViewPlanner::neck_goal`.
//!
//! The workspace denies `unsafe_code` in `nodes`; this test crate opts out because a
//! `GlobalAlloc` impl is unsafe by definition. It only forwards to `System` and counts.
#![allow(unsafe_code)]

use shm_types::{PlannerDecision, RobotState, boxed_zeroed};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::hint::black_box;
use std::sync::atomic::{AtomicU64, Ordering};
use vpsom::config::CameraConfig;
use vpsom::planner::clusters::{cluster_info, unfinished_centroid};
use vpsom::planner::synth::scene3_map;
use vpsom::planner::{Lbv, PlannerConfig, Target, ViewPlanner, VpsomPlanner};

struct Counting;

static ALLOCS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Count only this thread's allocations (the test harness allocates on its own threads).
    static TRACK: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if TRACK.with(|t| t.get()) {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards every call unchanged to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn lbv_and_neck_goal_do_not_allocate_after_warm_up() {
    let cfg = PlannerConfig::default();
    let cam = CameraConfig::default();
    let map = scene3_map();
    let mut lbv = Lbv::new(&cfg, &cam);
    let info = cluster_info(&map, 1, cfg.eps_sopm).expect("desk cluster");
    let target = Target {
        cluster_id: 1,
        centroid: unfinished_centroid(&map, &info, cfg.eps_sopm),
    };
    let mut planner = VpsomPlanner::new(&cfg, &cam);
    let mut decision = boxed_zeroed::<PlannerDecision>();
    let mut state = RobotState {
        base_pose: [-0.3, 0.2, std::f32::consts::PI],
        neck_pitch: cam.mount.pitch(),
        localization_ok: 1,
        ..Default::default()
    };
    // Warm-up.
    let warm = lbv.evaluate(&map, state.base_pose, 0.0, Some(&target));
    assert!(warm.is_some_and(|c| c.score > 0.0), "{warm:?}");
    planner.neck_goal(&map, &state, 0);

    // The counter works: a Vec allocates.
    TRACK.with(|t| t.set(true));
    let probe = ALLOCS.load(Ordering::SeqCst);
    drop(black_box(Vec::<u8>::with_capacity(16)));
    assert!(ALLOCS.load(Ordering::SeqCst) > probe);
    let before = ALLOCS.load(Ordering::SeqCst);
    let mut score = 0.0;
    for k in 0..200 {
        state.base_pose[1] = 0.2 + 0.001 * k as f32;
        let c = lbv.evaluate(&map, state.base_pose, state.neck_yaw, Some(&target));
        score += c.map_or(0.0, |c| c.score);
        let g = planner.neck_goal(&map, &state, k);
        state.neck_yaw = g.yaw;
        lbv.fill_decision(c.map(|c| c.index), &mut decision);
        assert!(planner.lbv_decision(&mut decision));
    }
    let after = ALLOCS.load(Ordering::SeqCst);
    TRACK.with(|t| t.set(false));
    assert_eq!(after - before, 0, "allocations on the LBV path");
    assert!(score > 0.0);
}
