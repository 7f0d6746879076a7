//! `validate()` allocates nothing while a payload is valid, so a receiver can run it on a
//! real-time path; the field names of an error are built only when a check fails.
//!
//! A counting global allocator counts the allocations made on this test's thread while the
//! largest payloads, filled to capacity, are validated.

// A global allocator is an `unsafe` trait impl; this one only forwards to `System`.
#![allow(unsafe_code)]

use shm_types::{
    Detection, Detections, FrameVisibility, MAX_CANDIDATES, MAX_DETECTIONS, MAX_GRID_CELLS,
    MAX_OBJECT_POINTS, MAX_OBJECTS, MAX_SOPM_CELLS, NavGoal, NeckGoal, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, Validate, boxed_zeroed, grid_cell, mask_mode,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    /// Allocations on this thread while `COUNTING` is set.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

// SAFETY: forwards every call to `System` unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCATIONS.with(|a| a.set(a.get() + 1));
        }
        // SAFETY: the caller's contract is passed on to `System`.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made on this thread by `f`.
fn allocations_in(f: impl FnOnce()) -> usize {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get)
}

/// A map with every object slot used, every SOPM cell and every point sample filled.
fn full_map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.42;
    m.count = MAX_OBJECTS as u32;
    for (k, o) in m.objects.iter_mut().enumerate() {
        o.id = k as u32;
        o.cluster_id = -1;
        o.center = [k as f32 * 0.1, 1.0, 0.5];
        o.size = [0.2, 0.2, 0.3];
        o.h_sopm = 0.8;
        o.c_asso = 0.97;
        o.sopm_rows = 18;
        o.sopm_cols = 36;
        o.sopm_prob[..MAX_SOPM_CELLS].fill(0.5);
        o.sample_count = MAX_OBJECT_POINTS as u16;
        o.points.iter_mut().for_each(|p| *p = [1.0, 2.0, 0.5]);
        o.point_los.iter_mut().for_each(|l| *l = [0.0, 0.0, 1.0]);
    }
    m
}

#[test]
fn validating_full_payloads_allocates_nothing_and_errors_still_name_the_field() {
    let mut map = full_map();
    assert_eq!(map.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(map.validate().is_ok())), 0);

    let mut dets = boxed_zeroed::<Detections>();
    dets.width = 640;
    dets.height = 480;
    dets.count = MAX_DETECTIONS as u32;
    dets.items.iter_mut().for_each(|d| {
        *d = Detection {
            class_id: 1,
            label: 1,
            score: 0.5,
            bbox: [10, 10, 100, 100],
            mask_pixels: 0,
        }
    });
    assert_eq!(dets.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(dets.validate().is_ok())), 0);

    // Masks mode: every label used, every pixel labelled (the label-image and mask_pixels
    // checks run over the whole 640 × 480 image).
    let mut masks = boxed_zeroed::<Detections>();
    masks.width = 640;
    masks.height = 480;
    masks.masks = mask_mode::MASKS;
    masks.count = MAX_DETECTIONS as u32;
    let rows = 480 / MAX_DETECTIONS;
    for (k, d) in masks.items.iter_mut().enumerate() {
        *d = Detection {
            class_id: 1,
            label: k as u16 + 1,
            score: 0.5,
            bbox: [0, (k * rows) as u16, 640, ((k + 1) * rows) as u16],
            mask_pixels: (640 * rows) as u32,
        };
    }
    for (y, row) in masks.label_pixels_mut().chunks_mut(640).enumerate() {
        row.fill((y / rows).min(MAX_DETECTIONS - 1) as u8 + 1);
    }
    // The rows past 64 × 7 = 448 belong to the last item.
    masks.items[MAX_DETECTIONS - 1].mask_pixels += 640 * (480 - 64 * rows) as u32;
    assert_eq!(masks.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(masks.validate().is_ok())), 0);

    let mut decision = boxed_zeroed::<PlannerDecision>();
    decision.count = MAX_CANDIDATES as u32;
    assert_eq!(decision.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(decision.validate().is_ok())), 0);

    let mut grid = boxed_zeroed::<OccupancyGrid>();
    grid.resolution = 0.05;
    grid.width = 256;
    grid.height = 256;
    grid.cells[..MAX_GRID_CELLS / 2].fill(grid_cell::UNKNOWN);
    grid.cells[MAX_GRID_CELLS / 2..].fill(grid_cell::OCCUPIED);
    assert_eq!(grid.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(grid.validate().is_ok())), 0);

    let mut vis = boxed_zeroed::<FrameVisibility>();
    vis.count = MAX_OBJECTS as u32;
    assert_eq!(vis.validate(), Ok(()));
    assert_eq!(allocations_in(|| assert!(vis.validate().is_ok())), 0);

    let state = RobotState {
        localization_ok: 1,
        ..Default::default()
    };
    let (nav, neck) = (NavGoal::default(), NeckGoal::default());
    let small = || {
        assert!(state.validate().is_ok());
        assert!(nav.validate().is_ok());
        assert!(neck.validate().is_ok());
    };
    small();
    assert_eq!(allocations_in(small), 0);

    // A failure still says where: the last object's last point sample.
    map.objects[MAX_OBJECTS - 1].points[MAX_OBJECT_POINTS - 1][1] = f32::NAN;
    let e = map.validate().unwrap_err();
    assert_eq!(e.field, format!("objects[{}].points", MAX_OBJECTS - 1));
    assert!(e.reason.contains("NaN"), "{e}");
    dets.items[MAX_DETECTIONS - 1].score = 1.5;
    let e = dets.validate().unwrap_err();
    assert_eq!(e.field, format!("items[{}].score", MAX_DETECTIONS - 1));
}
