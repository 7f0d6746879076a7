//! One test per validation rule beyond "finite" (the rules are documented on each type's
//! `Validate` impl): a valid message passes, and the same message with one bad value is rejected
//! with an error that names the message, the field and the value.

use shm_types::bounds::{MAX_PITCH_RAD, MAX_WORLD_COORD_M, MAX_YAW_RAD};
use shm_types::{
    Candidate, DepthFrame, Detection, Detections, FrameVisibility, Intrinsics, MAX_OBJECTS,
    NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision, Pose3, RobotState, Validate,
    ValidationError, boxed_zeroed, grid_cell, mask_mode,
};

/// `r` is an error of `message` naming `field`, whose reason shows `value`.
#[track_caller]
fn rejects(r: Result<(), ValidationError>, message: &str, field: &str, value: &str) {
    let e = r.expect_err("a bad value was accepted");
    assert_eq!((e.message, e.field.as_str()), (message, field), "{e}");
    assert!(e.reason.contains(value), "{e} does not show {value}");
    let shown = e.to_string();
    assert!(
        shown.starts_with(&format!("{message}.{field}: ")),
        "{shown}"
    );
}

/// A 10 × 10 masks-mode detection set: item 0 (label 1) covers the 4 × 4 block at (1, 1),
/// item 1 (label 2) the 2 × 2 block at (6, 6).
fn masks() -> Box<Detections> {
    let mut d = boxed_zeroed::<Detections>();
    d.width = 10;
    d.height = 10;
    d.masks = mask_mode::MASKS;
    d.count = 2;
    d.items[0] = Detection {
        class_id: 41,
        label: 1,
        score: 0.9,
        bbox: [1, 1, 5, 5],
        mask_pixels: 16,
    };
    d.items[1] = Detection {
        class_id: 60,
        label: 2,
        score: 0.6,
        bbox: [6, 6, 8, 8],
        mask_pixels: 4,
    };
    let px = d.label_pixels_mut();
    for y in 1..5 {
        px[y * 10 + 1..y * 10 + 5].fill(1);
    }
    for y in 6..8 {
        px[y * 10 + 6..y * 10 + 8].fill(2);
    }
    d
}

#[test]
fn detections_masks_rules() {
    let d = masks();
    assert_eq!(d.validate(), Ok(()));

    // A label-image value beyond the detection count (no item has label 3).
    let mut d = masks();
    d.label_pixels_mut()[99] = 3;
    rejects(d.validate(), "Detections", "labels", "value 3");

    // A mask_pixels count beyond the image (10 × 10 = 100 pixels).
    let mut d = masks();
    d.items[1].mask_pixels = 101;
    rejects(
        d.validate(),
        "Detections",
        "items[1].mask_pixels",
        "101 exceeds capacity 100",
    );

    // A mask_pixels count that disagrees with the label image.
    let mut d = masks();
    d.items[0].mask_pixels = 15;
    rejects(
        d.validate(),
        "Detections",
        "items[0].mask_pixels",
        "15 but the label image has 16",
    );

    // Label 0, a label past the u8 image, a duplicated label.
    let mut d = masks();
    d.items[1].label = 0;
    rejects(
        d.validate(),
        "Detections",
        "items[1].label",
        "0 (masks mode",
    );
    let mut d = masks();
    d.items[1].label = 256;
    rejects(d.validate(), "Detections", "items[1].label", "256");
    let mut d = masks();
    d.items[1].label = 1;
    rejects(
        d.validate(),
        "Detections",
        "items[1].label",
        "1 is also items[0].label",
    );

    // A pixel past width × height is not part of the image: not checked.
    let mut d = masks();
    d.labels[100] = 9;
    assert_eq!(d.validate(), Ok(()));
}

#[test]
fn detections_boxes_and_item_rules() {
    // Boxes mode: labels unused (any value), mask_pixels must be 0.
    let mut d = masks();
    d.masks = mask_mode::BOXES;
    d.items[0].mask_pixels = 0;
    d.items[1].mask_pixels = 0;
    d.items[1].label = 77;
    d.label_pixels_mut()[0] = 200;
    assert_eq!(d.validate(), Ok(()));
    d.items[1].mask_pixels = 4;
    rejects(
        d.validate(),
        "Detections",
        "items[1].mask_pixels",
        "4 in boxes mode",
    );

    let mut d = masks();
    d.masks = 2;
    rejects(d.validate(), "Detections", "masks", "2 exceeds capacity 1");
    let mut d = masks();
    d.items[0].class_id = 80;
    rejects(
        d.validate(),
        "Detections",
        "items[0].class_id",
        "80 exceeds capacity 79",
    );
    let mut d = masks();
    d.items[1].score = 1.01;
    rejects(d.validate(), "Detections", "items[1].score", "1.01");
    let mut d = masks();
    d.items[1].score = -0.0001;
    rejects(d.validate(), "Detections", "items[1].score", "-0.0001");
    let mut d = masks();
    d.items[1].bbox = [6, 6, 8, 11];
    rejects(d.validate(), "Detections", "items[1].bbox.y1", "11");
    let mut d = masks();
    d.items[1].bbox = [6, 9, 8, 8];
    rejects(d.validate(), "Detections", "items[1].bbox", "inverted");
}

fn frame() -> Box<DepthFrame> {
    let mut f = boxed_zeroed::<DepthFrame>();
    f.width = 4;
    f.height = 2;
    f.intrinsics = Intrinsics {
        fx: 2.0,
        fy: 2.0,
        cx: 2.0,
        cy: 1.0,
        min_range: 0.5,
        max_range: 5.0,
    };
    f.camera_pose = Pose3::IDENTITY;
    f
}

#[test]
fn depth_frame_pose_within_the_world() {
    let mut f = frame();
    assert_eq!(f.validate(), Ok(()));
    f.camera_pose.translation[0] = MAX_WORLD_COORD_M;
    assert_eq!(f.validate(), Ok(()));
    f.camera_pose.translation[0] = 1500.0;
    rejects(f.validate(), "DepthFrame", "camera_pose", "1500");
}

/// A map with a background table (id 3) and a cup on it (id 5) with an 18 × 18 SOPM.
fn map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.4;
    m.count = 2;
    let t = &mut m.objects[0];
    t.id = 3;
    t.class_id = 60;
    t.background = 1;
    t.cluster_id = 3;
    t.center = [1.0, 2.0, 0.4];
    t.size = [1.2, 0.8, 0.8];
    let c = &mut m.objects[1];
    c.id = 5;
    c.class_id = 41;
    c.cluster_id = 3;
    c.center = [1.0, 2.0, 0.85];
    c.size = [0.1, 0.1, 0.1];
    c.yaw = -3.0;
    c.h_sopm = 0.7;
    c.c_asso = 0.9;
    c.sopm_rows = 18;
    c.sopm_cols = 18;
    c.sopm_prob[..324].fill(0.5);
    c.sample_count = 2;
    c.points[..2].copy_from_slice(&[[1.0, 2.0, 0.85], [1.05, 2.0, 0.85]]);
    c.point_los[..2].copy_from_slice(&[[1.0, 0.0, 0.0], [0.0, 0.6, -0.8]]);
    m
}

#[test]
fn object_map_rules() {
    assert_eq!(map().validate(), Ok(()));

    let mut m = map();
    m.objects[1].cluster_id = -2;
    rejects(m.validate(), "ObjectMap", "objects[1].cluster_id", "-2");
    let mut m = map();
    m.objects[0].cluster_id = 5;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[0].cluster_id",
        "5 on background object 3",
    );
    // A foreground object may name a background object cut off the map, or none.
    let mut m = map();
    m.objects[1].cluster_id = 42;
    assert_eq!(m.validate(), Ok(()));
    m.objects[1].cluster_id = -1;
    assert_eq!(m.validate(), Ok(()));

    let mut m = map();
    m.objects[1].id = 3;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[1].id",
        "3 is also objects[0].id",
    );
    let mut m = map();
    m.objects[1].class_id = 300;
    rejects(m.validate(), "ObjectMap", "objects[1].class_id", "300");
    let mut m = map();
    m.objects[1].background = 2;
    rejects(m.validate(), "ObjectMap", "objects[1].background", "2");
    let mut m = map();
    m.objects[1].complete = 255;
    rejects(m.validate(), "ObjectMap", "objects[1].complete", "255");

    // SOPM grid shape and values.
    let mut m = map();
    m.objects[1].sopm_shape = 3;
    rejects(m.validate(), "ObjectMap", "objects[1].sopm_shape", "3");
    let mut m = map();
    m.objects[1].sopm_cols = 0;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[1].sopm_cells",
        "18 rows x 0 cols",
    );
    let mut m = map();
    m.objects[1].sopm_cols = 37;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[1].sopm_cells",
        "666 exceeds capacity 648",
    );
    let mut m = map();
    m.objects[1].sopm_prob[323] = -0.1;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[1].sopm_prob",
        "cell 323",
    );
    let mut m = map();
    m.objects[1].h_sopm = 1.2;
    rejects(m.validate(), "ObjectMap", "objects[1].h_sopm", "1.2");

    // Geometry within the world bounds.
    let mut m = map();
    m.objects[1].center[1] = -2000.0;
    rejects(m.validate(), "ObjectMap", "objects[1].center", "-2000");
    let mut m = map();
    m.objects[0].size[0] = 1e6;
    rejects(m.validate(), "ObjectMap", "objects[0].size", "1000000");
    let mut m = map();
    m.objects[1].yaw = 100.0;
    rejects(m.validate(), "ObjectMap", "objects[1].yaw", "100");
    let mut m = map();
    m.objects[1].points[1][2] = 5000.0;
    rejects(m.validate(), "ObjectMap", "objects[1].points", "5000");
    let mut m = map();
    m.objects[1].point_los[0] = [0.0, 0.0, 2.0];
    rejects(m.validate(), "ObjectMap", "objects[1].point_los", "2");
    let mut m = map();
    m.objects[0].support_height = f32::NAN;
    rejects(
        m.validate(),
        "ObjectMap",
        "objects[0].support_height",
        "NaN",
    );
    // Past sample_count: not part of the message.
    let mut m = map();
    m.objects[1].points[2] = [f32::NAN; 3];
    assert_eq!(m.validate(), Ok(()));
    // Receipts: each used outcome one of frame_outcome; a count past the capacity is data
    // (receipts were lost), and entries past it are not part of the message.
    let mut m = map();
    m.receipt_count = 2;
    m.receipts[1].outcome = shm_types::frame_outcome::REFUSED + 1;
    rejects(m.validate(), "ObjectMap", "receipts[1].outcome", "4");
    m.receipt_count = 1;
    assert_eq!(m.validate(), Ok(()));
    m.receipt_count = 1000;
    m.receipts[1].outcome = 0;
    m.receipts[15].outcome = 7;
    rejects(m.validate(), "ObjectMap", "receipts[15].outcome", "7");
}

#[test]
fn object_map_checks_every_object_and_ids_across_the_map() {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.count = MAX_OBJECTS as u32;
    for (k, o) in m.objects.iter_mut().enumerate() {
        o.id = k as u32 * 2;
        o.cluster_id = -1;
    }
    assert_eq!(m.validate(), Ok(()));
    m.objects[MAX_OBJECTS - 1].id = 0;
    rejects(
        m.validate(),
        "ObjectMap",
        &format!("objects[{}].id", MAX_OBJECTS - 1),
        "0 is also objects[0].id",
    );
}

fn grid() -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.origin = [-5.0, -5.0];
    g.resolution = 0.05;
    g.width = 200;
    g.height = 100;
    g.cells[..20_000].fill(grid_cell::UNKNOWN);
    g.cells[7] = grid_cell::OCCUPIED;
    g.cells[8] = 37; // an occupancy percentage
    g.cells[9] = grid_cell::FREE;
    g
}

#[test]
fn occupancy_grid_rules() {
    assert_eq!(grid().validate(), Ok(()));

    let mut g = grid();
    g.cells[19_999] = 101;
    rejects(g.validate(), "OccupancyGrid", "cells", "cell 19999 is 101");
    // Past width × height: not part of the grid.
    let mut g = grid();
    g.cells[20_000] = 200;
    assert_eq!(g.validate(), Ok(()));

    let mut g = grid();
    g.width = 0;
    rejects(g.validate(), "OccupancyGrid", "width", "0");
    let mut g = grid();
    g.height = 0;
    rejects(g.validate(), "OccupancyGrid", "height", "0");
    let mut g = grid();
    g.width = 70_000;
    g.height = 1;
    g.cells.fill(0);
    rejects(g.validate(), "OccupancyGrid", "cells", "70000 exceeds");
    let mut g = grid();
    g.width = 256;
    g.height = 257;
    rejects(
        g.validate(),
        "OccupancyGrid",
        "cells",
        "65792 exceeds capacity 65536",
    );
    let mut g = grid();
    g.resolution = 8.0;
    rejects(
        g.validate(),
        "OccupancyGrid",
        "far corner (origin + size)",
        "1595",
    );
    let mut g = grid();
    g.origin[1] = f32::INFINITY;
    rejects(g.validate(), "OccupancyGrid", "origin", "inf");
    let mut g = grid();
    g.resolution = 0.0;
    rejects(g.validate(), "OccupancyGrid", "resolution", "0 is outside");
}

#[test]
fn goal_ranges() {
    let g = NavGoal {
        goal_id: 1,
        pose: [3.0, -4.0, -3.1],
        score: 2.5,
        cluster_id: -1,
        ..Default::default()
    };
    assert_eq!(g.validate(), Ok(()));
    let bad = |f: fn(&mut NavGoal)| {
        let mut b = g;
        f(&mut b);
        b.validate()
    };
    rejects(bad(|b| b.pose[0] = 1e4), "NavGoal", "pose", "10000");
    rejects(bad(|b| b.pose[1] = f32::NAN), "NavGoal", "pose", "NaN");
    rejects(bad(|b| b.pose[2] = 13.0), "NavGoal", "pose.yaw", "13");
    rejects(bad(|b| b.score = f32::INFINITY), "NavGoal", "score", "inf");
    rejects(bad(|b| b.cluster_id = -7), "NavGoal", "cluster_id", "-7");
    rejects(bad(|b| b.kind = 4), "NavGoal", "kind", "4");
    assert_eq!(bad(|b| b.pose[2] = MAX_YAW_RAD), Ok(()));

    let n = NeckGoal {
        yaw: -3.0,
        pitch: 0.3,
        score: 1.0,
        ..Default::default()
    };
    assert_eq!(n.validate(), Ok(()));
    let bad = |f: fn(&mut NeckGoal)| {
        let mut b = n;
        f(&mut b);
        b.validate()
    };
    rejects(bad(|b| b.yaw = 180.0), "NeckGoal", "yaw", "180");
    rejects(bad(|b| b.yaw = f32::NAN), "NeckGoal", "yaw", "NaN");
    rejects(bad(|b| b.pitch = 1.6), "NeckGoal", "pitch", "1.6");
    rejects(bad(|b| b.pitch = -45.0), "NeckGoal", "pitch", "-45");
    rejects(bad(|b| b.score = f32::NAN), "NeckGoal", "score", "NaN");
    rejects(bad(|b| b.round_done = 2), "NeckGoal", "round_done", "2");
    assert_eq!(bad(|b| b.pitch = -MAX_PITCH_RAD), Ok(()));
}

#[test]
fn robot_state_ranges() {
    let s = RobotState {
        base_pose: [1.0, 2.0, 3.0],
        neck_yaw: -1.0,
        neck_pitch: 0.35,
        odom_cov: [1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5],
        speed: -0.1,
        distance_m: 12.0,
        localization_ok: 1,
        ..Default::default()
    };
    assert_eq!(s.validate(), Ok(()));
    let bad = |f: fn(&mut RobotState)| {
        let mut b = s;
        f(&mut b);
        b.validate()
    };
    rejects(
        bad(|b| b.base_pose[1] = -1e5),
        "RobotState",
        "base_pose",
        "-100000",
    );
    rejects(
        bad(|b| b.base_pose[2] = 20.0),
        "RobotState",
        "base_pose.yaw",
        "20",
    );
    rejects(
        bad(|b| b.neck_yaw = 1e9),
        "RobotState",
        "neck_yaw",
        "1000000000",
    );
    rejects(bad(|b| b.neck_pitch = 2.0), "RobotState", "neck_pitch", "2");
    rejects(
        bad(|b| b.odom_cov[8] = -1e-3),
        "RobotState",
        "odom_cov",
        "-0.001",
    );
    rejects(
        bad(|b| b.distance_m = -1.0),
        "RobotState",
        "distance_m",
        "-1",
    );
    rejects(
        bad(|b| b.localization_ok = 2),
        "RobotState",
        "localization_ok",
        "2",
    );
}

#[test]
fn planner_decision_ranges() {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.cluster_id = 4;
    d.count = 2;
    d.candidates[1] = Candidate {
        position: [1.0, 2.0, 1.2],
        yaw: 6.0,
        pitch: 0.4,
        chosen: 1,
        ..Default::default()
    };
    assert_eq!(d.validate(), Ok(()));
    d.cluster_id = -3;
    rejects(d.validate(), "PlannerDecision", "cluster_id", "-3");
    d.cluster_id = -1;
    d.candidates[1].position[2] = 2e3;
    rejects(
        d.validate(),
        "PlannerDecision",
        "candidates[1].position",
        "2000",
    );
    d.candidates[1].position[2] = 1.2;
    d.candidates[1].yaw = 30.0;
    rejects(d.validate(), "PlannerDecision", "candidates[1].yaw", "30");
    d.candidates[1].yaw = 0.0;
    d.candidates[1].pitch = -2.0;
    rejects(d.validate(), "PlannerDecision", "candidates[1].pitch", "-2");
    d.candidates[1].pitch = 0.0;
    d.candidates[1].chosen = 2;
    rejects(d.validate(), "PlannerDecision", "candidates[1].chosen", "2");
    d.candidates[1].chosen = 0;
    d.candidates[0].dropped = 9;
    rejects(
        d.validate(),
        "PlannerDecision",
        "candidates[0].dropped",
        "9",
    );
    d.candidates[0].dropped = 1;
    d.state = 3;
    rejects(d.validate(), "PlannerDecision", "state", "3");
}

#[test]
fn frame_visibility_flags() {
    let mut v = boxed_zeroed::<FrameVisibility>();
    v.count = 1;
    v.items[0].truncated = 1;
    assert_eq!(v.validate(), Ok(()));
    v.items[0].truncated = 2;
    rejects(v.validate(), "FrameVisibility", "items[0].truncated", "2");
    v.items[0].truncated = 0;
    v.items[0].bbox[3] = f32::NEG_INFINITY;
    rejects(v.validate(), "FrameVisibility", "items[0].bbox", "-inf");
}
