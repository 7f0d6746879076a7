//! Property test: valid but extreme messages into the mapper's and the planners' entry points.
//!
//! Every generated input passes `validate()` (asserted: the generators stay inside the rules of
//! `shm_types`), with values at the edges of what the rules admit: depth anywhere in `u16`
//! (0 = none, 65.535 m), focal lengths from 20 to 5000 px, any unit quaternion, cameras and
//! objects hundreds of metres from the origin, 1-pixel and full-image boxes, scores 0 and 1,
//! masks that overlap, objects of zero size, SOPM probabilities 0 and 1, empty and full grids.
//! Properties:
//! - [`Mapper::integrate`] never panics, and the map and exploration grid it then publishes
//!   validate (no NaN, nothing out of range);
//! - each planner's `neck_goal` and `next_goal` (with the jobs run and handed back) never panic,
//!   and every neck goal, chassis goal and decision they emit validates.
//!
//! Camera positions stay within 600 m of the origin: the farthest point a generated frame can
//! show is 65.535 m deep through the corner of a 160 × 120 image at fx = 20 px, i.e.
//! 65.5 · √(1 + 4² + 3²) = 334 m from the camera, so every mapped point stays inside
//! `shm_types::bounds::MAX_WORLD_COORD_M` (1 km). From farther out a valid frame can give a map
//! point past 1 km, and that map is rejected and counted by its receivers (found by this test
//! with `REACH` = 900 m: a point at -1072 m).
//!
//! Cases: 64 for the mapper (up to 3 frames, each integrated 3 times), 16 per planner; about 2 s in
//! `cargo test --release -p vpsom --test entry_props` (56 s with `PROPTEST_CASES=1000`, which
//! overrides the counts).

use proptest::prelude::*;
use shm_types::{
    COCO_CLASSES, DepthFrame, Detection, Detections, Intrinsics, MAX_OBJECTS, NavGoal, ObjectMap,
    OccupancyGrid, PlannerDecision, Pose3, RobotState, Validate, boxed_zeroed, grid_cell,
    mask_mode, nav_status,
};
use std::f32::consts::{FRAC_PI_2, PI};
use vpsom::config::Config;
use vpsom::mapper::Mapper;
use vpsom::planner::{PlannerInputs, PlannerKind, Step, make_planner};

/// Largest |coordinate| of a generated camera position, metres (see the module docs).
const REACH: f32 = 600.0;

fn config(cases: u32) -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(cases);
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// A float in `[lo, hi]` that is often exactly an end point or 0 when 0 is inside.
fn edgy(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    let mut ends = vec![lo, hi];
    if lo < 0.0 && hi > 0.0 {
        ends.push(0.0);
    }
    prop_oneof![
        1 => prop::sample::select(ends),
        3 => lo..=hi,
    ]
}

/// A unit quaternion `[x, y, z, w]` (any direction, incl. the identity and 180° turns).
fn quaternion() -> impl Strategy<Value = [f32; 4]> {
    prop_oneof![
        1 => Just([0.0, 0.0, 0.0, 1.0]),
        1 => Just([1.0, 0.0, 0.0, 0.0]),
        4 => Just([-0.5, 0.5, -0.5, 0.5]), // optical frame looking along world +x
        4 => (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_filter("non-zero", |(x, y, z, w)| x * x + y * y + z * z + w * w > 1e-3)
            .prop_map(|(x, y, z, w)| {
                let n = (x * x + y * y + z * z + w * w).sqrt();
                [x / n, y / n, z / n, w / n]
            }),
    ]
}

/// One detection spec: class, score, box corners as fractions of the image.
type DetSpec = (u16, f32, (f32, f32, f32, f32));

fn det_spec() -> impl Strategy<Value = DetSpec> {
    (
        prop_oneof![
            // Tables, chairs, couches, beds (background) and their usual foreground objects.
            2 => prop::sample::select(vec![60u16, 56, 57, 59, 41, 39, 73, 75, 64]),
            1 => 0..COCO_CLASSES.len() as u16,
        ],
        edgy(0.0, 1.0),
        (
            edgy(0.0, 1.0),
            edgy(0.0, 1.0),
            edgy(0.0, 1.0),
            edgy(0.0, 1.0),
        ),
    )
}

/// Frame + detections, both valid: `w × h` image, one depth mode, detections painted in order.
#[derive(Debug, Clone)]
struct FrameSpec {
    size: (u32, u32),
    fx: f32,
    range: (f32, f32),
    position: [f32; 3],
    rotation: [f32; 4],
    depth: DepthMode,
    masks: bool,
    dets: Vec<DetSpec>,
}

#[derive(Debug, Clone)]
enum DepthMode {
    /// Every pixel the same value (0 = no depth, 65535 = 65.5 m).
    Flat(u16),
    /// Pseudo-random per pixel from the seed, anywhere in `u16`.
    Noise(u64),
    /// A near plane in the middle, far behind.
    Step(u16, u16),
}

fn frame_spec() -> impl Strategy<Value = FrameSpec> {
    (
        prop::sample::select(vec![(8u32, 6u32), (64, 48), (160, 120), (160, 120), (1, 1)]),
        edgy(20.0, 5000.0),
        (edgy(0.0, 2.0), edgy(2.5, 100.0)),
        (
            edgy(-REACH, REACH),
            edgy(-REACH, REACH),
            prop_oneof![Just(1.2f32), edgy(-5.0, 5.0)],
        )
            .prop_map(|(x, y, z)| [x, y, z]),
        quaternion(),
        prop_oneof![
            2 => prop::sample::select(vec![0u16, 1, 500, 1500, 3000, 65535])
                .prop_map(DepthMode::Flat),
            1 => any::<u64>().prop_map(DepthMode::Noise),
            2 => (prop_oneof![500u16..3000, any::<u16>()], any::<u16>())
                .prop_map(|(a, b)| DepthMode::Step(a, b)),
        ],
        any::<bool>(),
        prop::collection::vec(det_spec(), 0..12),
    )
        .prop_map(
            |(size, fx, range, position, rotation, depth, masks, dets)| FrameSpec {
                size,
                fx,
                range,
                position,
                rotation,
                depth,
                masks,
                dets,
            },
        )
}

fn build_frame(s: &FrameSpec, seq: u64) -> (Box<DepthFrame>, Box<Detections>) {
    let (w, h) = s.size;
    let mut f = boxed_zeroed::<DepthFrame>();
    f.header.seq = seq;
    f.header.sim_time_ns = seq * 100_000_000;
    f.width = w;
    f.height = h;
    f.intrinsics = Intrinsics {
        fx: s.fx,
        fy: s.fx,
        cx: w as f32 / 2.0,
        cy: h as f32 / 2.0,
        min_range: s.range.0,
        max_range: s.range.1,
    };
    f.camera_pose = Pose3 {
        translation: s.position,
        rotation: s.rotation,
    };
    let mut x = match s.depth {
        DepthMode::Noise(seed) => seed,
        _ => 0,
    };
    for (i, d) in f.pixels_mut().iter_mut().enumerate() {
        let (u, v) = (i as u32 % w, i as u32 / w);
        *d = match s.depth {
            DepthMode::Flat(z) => z,
            DepthMode::Noise(_) => {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 48) as u16
            }
            DepthMode::Step(near, far) => {
                if (w / 4..3 * w / 4).contains(&u) && (h / 4..3 * h / 4).contains(&v) {
                    near
                } else {
                    far
                }
            }
        };
    }

    let mut d = boxed_zeroed::<Detections>();
    d.header = f.header;
    d.frame_seq = seq;
    d.width = w;
    d.height = h;
    d.masks = if s.masks {
        mask_mode::MASKS
    } else {
        mask_mode::BOXES
    };
    d.count = s.dets.len() as u32;
    for (k, (class_id, score, (a, b, c, e))) in s.dets.iter().enumerate() {
        let px = |t: f32, n: u32| ((t * n as f32) as u32).min(n) as u16;
        let (x0, x1) = (px(a.min(*c), w), px(a.max(*c), w));
        let (y0, y1) = (px(b.min(*e), h), px(b.max(*e), h));
        d.items[k] = Detection {
            class_id: *class_id,
            label: if s.masks { k as u16 + 1 } else { 0 },
            score: *score,
            bbox: [x0, y0, x1, y1],
            mask_pixels: 0,
        };
        if s.masks {
            for y in y0 as u32..y1 as u32 {
                for x in x0 as u32..x1 as u32 {
                    d.labels[(y * w + x) as usize] = k as u8 + 1;
                }
            }
        }
    }
    if s.masks {
        let mut counts = [0u32; 256];
        for &l in d.label_pixels() {
            counts[l as usize] += 1;
        }
        for k in 0..s.dets.len() {
            d.items[k].mask_pixels = counts[k + 1];
        }
    }
    (f, d)
}

fn state_at(pose: [f32; 3], neck: (f32, f32)) -> RobotState {
    RobotState {
        base_pose: pose,
        neck_yaw: neck.0,
        neck_pitch: neck.1,
        localization_ok: 1,
        ..Default::default()
    }
}

#[track_caller]
fn valid(what: &str, r: Result<(), shm_types::ValidationError>) {
    if let Err(e) = r {
        panic!("{what} does not validate: {e}");
    }
}

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn mapper_integrate_survives_extreme_valid_frames(
        frames in prop::collection::vec(frame_spec(), 1..4),
        neck in (edgy(-2.0 * PI, 2.0 * PI), edgy(-FRAC_PI_2, FRAC_PI_2)),
        require_support in any::<bool>(),
    ) {
        let mut cfg = Config::builtin();
        // Off: foreground objects are published without a mapped table under them (more of
        // the map's fields reach the output).
        cfg.mapper.extensions.require_support = require_support;
        let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera()).expect("built-in mapper config");
        let mut map = boxed_zeroed::<ObjectMap>();
        let mut grid = boxed_zeroed::<OccupancyGrid>();
        // Each spec three times over, so that objects reach `min_observations` and are published.
        for (i, spec) in frames.iter().flat_map(|f| [f, f, f]).enumerate() {
            let (f, d) = build_frame(spec, i as u64 + 1);
            valid("generated frame", f.validate());
            valid("generated detections", d.validate());
            let p = spec.position;
            let state = state_at([p[0], p[1], 0.0], neck);
            valid("generated state", state.validate());
            // An error (e.g. nothing usable) is an answer; a panic is not.
            let _ = mapper.integrate(&f, &d, &state);
            mapper.write_map(&mut map, (i as u64 + 1) * 100_000_000);
            valid("published map", map.validate());
            mapper.write_grid(&mut grid);
            valid("published exploration grid", grid.validate());
        }
    }
}

/// One map object spec: background?, class, centre, size, yaw, SOPM probabilities mode,
/// h_sopm, c_asso.
type ObjSpec = (bool, u16, [f32; 3], [f32; 3], f32, u8, f32, f32);

fn obj_spec() -> impl Strategy<Value = ObjSpec> {
    (
        any::<bool>(),
        0..COCO_CLASSES.len() as u16,
        [edgy(-20.0, 20.0), edgy(-20.0, 20.0), edgy(0.0, 3.0)],
        [edgy(0.0, 5.0), edgy(0.0, 5.0), edgy(0.0, 3.0)],
        edgy(-2.0 * PI, 2.0 * PI),
        0u8..4,
        edgy(0.0, 1.0),
        edgy(0.0, 1.0),
    )
}

fn build_map(objs: &[ObjSpec], far: [f32; 2], seq: u64) -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.header.seq = seq;
    m.eps_sopm = 0.4;
    m.count = objs.len().min(MAX_OBJECTS) as u32;
    let first_bg = objs.iter().position(|o| o.0).map(|i| i as i32 + 1);
    for (k, (bg, class_id, c, size, yaw, sopm, h, ca)) in objs.iter().enumerate() {
        let o = &mut m.objects[k];
        o.id = k as u32 + 1;
        o.first_seen_ns = k as u64 * 1000;
        o.class_id = *class_id;
        o.background = *bg as u8;
        o.cluster_id = if *bg {
            o.id as i32
        } else {
            first_bg.unwrap_or(-1)
        };
        o.center = [c[0] + far[0], c[1] + far[1], c[2]];
        o.size = *size;
        o.yaw = *yaw;
        o.h_sopm = *h;
        o.c_asso = *ca;
        o.complete = (*h < 0.4) as u8;
        o.observations = 3;
        o.point_count = 100;
        if *sopm > 0 {
            o.sopm_shape = sopm - 1;
            o.sopm_rows = 18;
            o.sopm_cols = if *sopm == 3 { 36 } else { 18 };
            let n = o.sopm_rows as usize * o.sopm_cols as usize;
            for (i, p) in o.sopm_prob[..n].iter_mut().enumerate() {
                *p = [0.0, 1.0, 0.5, 0.1][(i + k) % 4];
            }
        }
        o.sample_count = 8;
        for i in 0..8 {
            let t = i as f32 / 8.0 * 2.0 * PI;
            o.points[i] = [
                o.center[0] + t.cos() * 0.5 * o.size[0],
                o.center[1],
                o.center[2],
            ];
            o.point_los[i] = [t.cos(), t.sin(), 0.0];
        }
    }
    m
}

/// An occupancy grid around `far`: `n × n` cells of `res`, cells from a pattern.
fn build_grid(n: u32, res: f32, far: [f32; 2], pattern: u8) -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.origin = [far[0] - n as f32 * res / 2.0, far[1] - n as f32 * res / 2.0];
    g.resolution = res;
    g.width = n;
    g.height = n;
    for (i, c) in g.cells[..(n * n) as usize].iter_mut().enumerate() {
        let (x, y) = (i as u32 % n, i as u32 / n);
        *c = match pattern % 4 {
            0 => grid_cell::FREE,
            1 => grid_cell::UNKNOWN,
            2 if x == 0 || y == 0 || x == n - 1 || y == n - 1 => grid_cell::OCCUPIED,
            2 => grid_cell::FREE,
            _ => [grid_cell::FREE, grid_cell::OCCUPIED, grid_cell::UNKNOWN, 40][(i * 7 % 5) % 4],
        };
    }
    g
}

fn check_planner(
    kind: PlannerKind,
    objs: &[ObjSpec],
    far: [f32; 2],
    pose: [f32; 3],
    neck: (f32, f32),
    grid: (u32, f32, u8, u8),
) {
    let mut cfg = Config::builtin();
    cfg.planner.kind = kind;
    let mut planner = make_planner(&cfg.planner, &cfg.camera);
    let map = build_map(objs, far, 1);
    valid("generated map", map.validate());
    let nav = build_grid(grid.0, grid.1, far, grid.2);
    let explore = build_grid(grid.0, grid.1, far, grid.3);
    valid("generated nav grid", nav.validate());
    valid("generated explore grid", explore.validate());
    let mut state = state_at([pose[0] + far[0], pose[1] + far[1], pose[2]], neck);
    valid("generated state", state.validate());
    let mut decision = boxed_zeroed::<PlannerDecision>();
    let mut goal: Option<NavGoal> = None;
    for round in 0..4u64 {
        let now = round * 500_000_000;
        let neck_goal = planner.neck_goal(&map, &state, now);
        valid("neck goal", neck_goal.validate());
        if planner.lbv_decision(&mut decision) {
            valid("LBV decision", decision.validate());
        }
        if let Some(g) = goal {
            // The base "reaches" every goal at once (or refuses every other one).
            state.nav_goal_id = g.goal_id;
            state.nav_status = if round % 2 == 0 {
                nav_status::REACHED
            } else {
                nav_status::UNREACHABLE
            };
            state.base_pose = g.pose;
        }
        let inputs = PlannerInputs {
            map: &map,
            state: &state,
            nav: &nav,
            explore: &explore,
        };
        let mut step = planner.next_goal(&inputs, now);
        for _ in 0..4 {
            match step {
                Step::Compute(job) => step = planner.job_done(job.run(), now),
                _ => break,
            }
        }
        if let Step::Goal(g) = step {
            valid("nav goal", g.validate());
            goal = Some(g);
        }
        if let Some(d) = planner.take_decision() {
            valid("GBV decision", d.validate());
        }
        if matches!(step, Step::Finished(_)) {
            break;
        }
    }
}

/// A planner case: map objects, where (`far`), base pose, neck, grid (cells per side,
/// resolution, nav pattern, explore pattern).
type PlannerCase = (
    Vec<ObjSpec>,
    [f32; 2],
    [f32; 3],
    (f32, f32),
    (u32, f32, u8, u8),
);

fn planner_case() -> impl Strategy<Value = PlannerCase> {
    (
        prop::collection::vec(obj_spec(), 0..10),
        [
            edgy(-REACH + 50.0, REACH - 50.0),
            edgy(-REACH + 50.0, REACH - 50.0),
        ],
        [edgy(-5.0, 5.0), edgy(-5.0, 5.0), edgy(-2.0 * PI, 2.0 * PI)],
        (edgy(-2.0 * PI, 2.0 * PI), edgy(-FRAC_PI_2, FRAC_PI_2)),
        (
            prop::sample::select(vec![1u32, 16, 64, 200]),
            edgy(0.05, 0.25),
            any::<u8>(),
            any::<u8>(),
        ),
    )
}

proptest! {
    #![proptest_config(config(16))]

    #[test]
    fn vpsom_planner_survives_extreme_valid_inputs(c in planner_case()) {
        check_planner(PlannerKind::Vpsom, &c.0, c.1, c.2, c.3, c.4);
    }

    #[test]
    fn coverage_planner_survives_extreme_valid_inputs(c in planner_case()) {
        check_planner(PlannerKind::Coverage, &c.0, c.1, c.2, c.3, c.4);
    }

    #[test]
    fn frontier_planner_survives_extreme_valid_inputs(c in planner_case()) {
        check_planner(PlannerKind::Frontier, &c.0, c.1, c.2, c.3, c.4);
    }
}

/// A full map (every object slot used, all at the SOPM capacity) through each planner once.
#[test]
fn planners_survive_a_full_map() {
    let objs: Vec<ObjSpec> = (0..MAX_OBJECTS)
        .map(|k| {
            let (x, y) = ((k % 12) as f32 - 6.0, (k / 12) as f32 - 5.0);
            (
                k % 6 == 0,
                if k % 6 == 0 { 60 } else { 41 },
                [x, y, 0.5],
                [0.3, 0.3, 0.3],
                0.0,
                3,
                0.9,
                0.9,
            )
        })
        .collect();
    for kind in [
        PlannerKind::Vpsom,
        PlannerKind::Coverage,
        PlannerKind::Frontier,
    ] {
        check_planner(
            kind,
            &objs,
            [0.0, 0.0],
            [0.0, 0.0, 0.0],
            (0.0, 0.3),
            (200, 0.1, 2, 3),
        );
    }
}

/// Regression (found by `mapper_integrate_survives_extreme_valid_frames`): a flat object (one
/// depth plane, camera looking straight up 600 m from the origin) was published with a size of
/// -4.8e-6 m along z, which fails `ObjectMap` validation, so every receiver dropped the whole
/// map. `write_map` now clamps sizes at 0.
#[test]
fn flat_object_far_from_the_origin_is_published_with_a_non_negative_size() {
    let spec = FrameSpec {
        size: (160, 120),
        fx: 5000.0,
        range: (0.0, 36.968155),
        position: [-600.0, -600.0, 1.2],
        rotation: [0.0, 0.0, 0.0, 1.0],
        depth: DepthMode::Step(500, 5720),
        masks: false,
        dets: vec![
            (60, 1.0, (0.93877643, 0.0, 0.0, 0.3443254)),
            (41, 1.0, (1.0, 0.68823856, 0.0, 0.0)),
        ],
    };
    let mut cfg = Config::builtin();
    cfg.mapper.extensions.require_support = false;
    let mut mapper =
        Mapper::new(&cfg.mapper, &cfg.camera.camera()).expect("built-in mapper config");
    let mut map = boxed_zeroed::<ObjectMap>();
    let state = state_at([-600.0, -600.0, 0.0], (-2.0 * PI, -FRAC_PI_2));
    let (mut published, mut negative) = (0, false);
    for seq in 1..=3 {
        let (f, d) = build_frame(&spec, seq);
        mapper.integrate(&f, &d, &state).expect("a valid frame");
        negative |= mapper
            .objects()
            .iter()
            .any(|o| o.cuboid.size.min_element() < 0.0);
        mapper.write_map(&mut map, seq * 100_000_000);
        valid("published map", map.validate());
        published = published.max(map.count);
    }
    assert!(
        published > 0,
        "the case publishes objects (else it tests nothing)"
    );
    // The case still makes the mapper's own cuboid negative: the clamp is what keeps it out.
    assert!(
        negative,
        "the case no longer reproduces the negative extent"
    );
}
