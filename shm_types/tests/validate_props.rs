//! Property test: arbitrary bytes into every message type's `validate()`.
//!
//! Each case builds a message from a base (all zeros, a valid message filled to capacity, or
//! random bytes) and then overwrites it with up to 12 patches: raw bytes at a random offset, or
//! one scalar field (found through the topic contract's field list, nested structs expanded)
//! set to an edge value (NaN, ±inf, −0, subnormal, `f32::MAX`, 0, 1, 2, `MAX`, ...) or to random
//! bits. Properties:
//! - `validate()` never panics;
//! - an error names the message type;
//! - a message that validates has only finite floats in its used part, counts within capacity
//!   (the accessors return exactly `count` elements, no clamping needed), ids inside their
//!   tables and flags 0/1: checked by an oracle written independently of the rules.
//!
//! Cases: 64 per large type (a case fills up to ~730 KB), 512 per small type; about 2 s in
//! `cargo test --release -p shm_types --test validate_props`. `PROPTEST_CASES=N` overrides.

// Writing arbitrary bytes into a message needs a raw pointer; see `patch` for why it is sound.
#![allow(unsafe_code)]

use proptest::prelude::*;
use shm_types::contract::{self, Elem, Scalar};
use shm_types::{
    Candidate, DeadlineEvent, DepthFrame, Detection, Detections, FrameVisibility, Intrinsics,
    MAX_CANDIDATES, MAX_DETECTIONS, MAX_GRID_CELLS, MAX_HEIGHT, MAX_OBJECT_POINTS, MAX_OBJECTS,
    MAX_SOPM_CELLS, MAX_WIDTH, NavGoal, NeckGoal, NodeHealth, ObjectMap, OccupancyGrid,
    PlannerDecision, Pose3, RobotState, Validate, ZeroValid, boxed_zeroed, class_name, goal_kind,
    grid_cell, mask_mode, miss_cause,
};
use std::collections::HashMap;
use std::sync::{LazyLock, Mutex};

/// Every scalar of type `name` as `(offset, scalar)`, nested structs expanded (computed once
/// per type).
fn scalars(name: &'static str) -> &'static [(usize, Scalar)] {
    type Scalars = &'static [(usize, Scalar)];
    static ALL: LazyLock<Mutex<HashMap<&'static str, Scalars>>> =
        LazyLock::new(|| Mutex::new(HashMap::new()));
    let mut all = ALL.lock().unwrap_or_else(|e| e.into_inner());
    all.entry(name).or_insert_with(|| {
        let types = contract::types();
        let mut out = Vec::new();
        expand(&types, name, 0, &mut out);
        out.leak()
    })
}

fn expand(types: &[contract::TypeLayout], name: &str, base: usize, out: &mut Vec<(usize, Scalar)>) {
    let t = types
        .iter()
        .find(|t| t.name == name)
        .unwrap_or_else(|| panic!("{name} is not in the contract"));
    for f in &t.fields {
        let n = f.count();
        let step = f.size / n.max(1);
        for i in 0..n {
            match f.elem {
                Elem::Scalar(s) => out.push((base + f.offset + i * step, s)),
                Elem::Struct(inner) => expand(types, inner, base + f.offset + i * step, out),
            }
        }
    }
}

/// How a case starts.
#[derive(Debug, Clone)]
enum Base {
    Zeros,
    Valid,
    Random(u64),
}

/// One overwrite.
#[derive(Debug, Clone)]
enum Patch {
    /// `bytes` at `at` (a fraction of the size, in 1/2^32).
    Bytes { at: u32, bytes: Vec<u8> },
    /// Scalar number `pick` (modulo the scalar count) set to edge value `edge` (or `raw` bits
    /// when `edge` is past the edge list).
    Field { pick: u32, edge: u8, raw: u64 },
}

fn base() -> impl Strategy<Value = Base> {
    prop_oneof![
        1 => Just(Base::Zeros),
        3 => Just(Base::Valid),
        1 => any::<u64>().prop_map(Base::Random),
    ]
}

fn patch_strategy() -> impl Strategy<Value = Patch> {
    prop_oneof![
        1 => (any::<u32>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(at, bytes)| Patch::Bytes { at, bytes }),
        3 => (any::<u32>(), any::<u8>(), any::<u64>())
            .prop_map(|(pick, edge, raw)| Patch::Field { pick, edge, raw }),
    ]
}

const F32_EDGES: [f32; 14] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    -0.0,
    0.0,
    1.0e-45, // smallest subnormal
    f32::MIN_POSITIVE,
    f32::MAX,
    f32::MIN,
    1.0,
    -1.0,
    1.000_001,
    1.0e30,
    std::f32::consts::PI,
];

fn int_edge(edge: u8, raw: u64, bits: u32) -> u64 {
    let max = if bits == 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    match edge % 8 {
        0 => 0,
        1 => 1,
        2 => 2,
        3 => max,
        4 => max - 1,
        5 => max >> 1,       // signed MAX
        6 => (max >> 1) + 1, // signed MIN
        _ => raw & max,
    }
}

/// Apply `p` to `m`.
fn patch<T: ZeroValid>(m: &mut T, scalars: &[(usize, Scalar)], p: &Patch) {
    let size = std::mem::size_of::<T>();
    let (at, bytes): (usize, Vec<u8>) = match p {
        Patch::Bytes { at, bytes } => {
            let at = ((*at as u64 * size as u64) >> 32) as usize;
            let n = bytes.len().min(size - at);
            (at, bytes[..n].to_vec())
        }
        Patch::Field { pick, edge, raw } => {
            let (at, s) = scalars[*pick as usize % scalars.len()];
            let bytes = match s {
                Scalar::F32 => {
                    let v = F32_EDGES
                        .get(*edge as usize % 32)
                        .copied()
                        .unwrap_or(f32::from_bits(*raw as u32));
                    v.to_ne_bytes().to_vec()
                }
                Scalar::U8 => vec![int_edge(*edge, *raw, 8) as u8],
                Scalar::U16 => (int_edge(*edge, *raw, 16) as u16).to_ne_bytes().to_vec(),
                Scalar::U32 | Scalar::I32 => {
                    (int_edge(*edge, *raw, 32) as u32).to_ne_bytes().to_vec()
                }
                Scalar::U64 | Scalar::I64 => int_edge(*edge, *raw, 64).to_ne_bytes().to_vec(),
            };
            (at, bytes)
        }
    };
    // SAFETY: `at + bytes.len() <= size_of::<T>()`, so the write stays inside `*m`, which is
    // exclusively borrowed. Every field of every message type is an integer or an `f32` (the
    // contract's field list, whose `Scalar` has no other kind, covers every byte: the contract
    // test checks there is no hidden padding), and every bit pattern of those is a valid value,
    // so `*m` is still a valid `T` afterwards.
    unsafe {
        let dst = (m as *mut T).cast::<u8>().add(at);
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), dst, bytes.len());
    }
}

/// `size_of::<T>()` bytes of splitmix64 from `seed` over `*m`.
fn randomize<T: ZeroValid>(m: &mut T, seed: u64) {
    let size = std::mem::size_of::<T>();
    let mut x = seed;
    let mut bytes = Vec::with_capacity(size + 8);
    while bytes.len() < size {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        bytes.extend_from_slice(&(z ^ (z >> 31)).to_ne_bytes());
    }
    // SAFETY: as in `patch`: `size` bytes into an exclusively borrowed `T` whose every field
    // accepts any bit pattern.
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), (m as *mut T).cast::<u8>(), size);
    }
}

/// Build the case, validate it, and check the oracle when it passes.
fn run<T: Validate + ZeroValid>(
    name: &'static str,
    valid: fn() -> Box<T>,
    oracle: fn(&T),
    base: &Base,
    patches: &[Patch],
) {
    let scalars = scalars(name);
    let mut m = match base {
        Base::Zeros => boxed_zeroed::<T>(),
        Base::Valid => valid(),
        Base::Random(seed) => {
            let mut m = boxed_zeroed::<T>();
            randomize(&mut *m, *seed);
            m
        }
    };
    if matches!(base, Base::Valid) && patches.is_empty() {
        assert_eq!(m.validate(), Ok(()), "the valid {name} base");
    }
    for p in patches {
        patch(&mut *m, scalars, p);
    }
    match m.validate() {
        Ok(()) => oracle(&m),
        Err(e) => {
            assert_eq!(e.message, name);
            assert!(e.to_string().starts_with(name), "{e}");
        }
    }
}

#[track_caller]
fn finite(what: &str, v: &[f32]) {
    assert!(v.iter().all(|x| x.is_finite()), "{what}: {v:?} validated");
}

fn flag(what: &str, v: u8) {
    assert!(v <= 1, "{what} = {v} validated");
}

// ---- valid bases, filled to capacity where a type has a count ----------------------------

fn valid_frame() -> Box<DepthFrame> {
    let mut f = boxed_zeroed::<DepthFrame>();
    f.width = MAX_WIDTH as u32;
    f.height = MAX_HEIGHT as u32;
    f.intrinsics = Intrinsics {
        fx: 500.0,
        fy: 500.0,
        cx: 320.0,
        cy: 240.0,
        min_range: 0.3,
        max_range: 8.0,
    };
    f.camera_pose = Pose3::IDENTITY;
    f.depth_mm.fill(1500);
    f
}

fn valid_detections() -> Box<Detections> {
    let mut d = boxed_zeroed::<Detections>();
    d.width = 64;
    d.height = 64;
    d.masks = mask_mode::MASKS;
    d.count = MAX_DETECTIONS as u32;
    for (k, it) in d.items.iter_mut().enumerate() {
        *it = Detection {
            class_id: k as u16,
            label: k as u16 + 1,
            score: k as f32 / 64.0,
            bbox: [0, k as u16, 64, k as u16 + 1],
            mask_pixels: 64,
        };
    }
    for (y, row) in d.label_pixels_mut().chunks_mut(64).enumerate() {
        row.fill(y as u8 + 1);
    }
    d
}

fn valid_state() -> Box<RobotState> {
    let mut s = boxed_zeroed::<RobotState>();
    s.base_pose = [1.0, -2.0, 0.5];
    s.neck_pitch = 0.3;
    s.odom_cov[0] = 1e-4;
    s.localization_ok = 1;
    s
}

fn valid_map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.4;
    m.count = MAX_OBJECTS as u32;
    for (k, o) in m.objects.iter_mut().enumerate() {
        o.id = k as u32;
        o.class_id = 41;
        o.background = (k % 8 == 0) as u8;
        o.cluster_id = (k - k % 8) as i32;
        o.center = [k as f32 * 0.1, 1.0, 0.5];
        o.size = [0.2, 0.2, 0.3];
        o.h_sopm = 0.8;
        o.c_asso = 0.9;
        o.sopm_rows = 18;
        o.sopm_cols = 36;
        o.sopm_prob.fill(0.5);
        o.sample_count = MAX_OBJECT_POINTS as u16;
        o.points.fill([1.0, 2.0, 0.5]);
        o.point_los.fill([0.0, 0.0, 1.0]);
    }
    m
}

fn valid_grid() -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.origin = [-6.4, -6.4];
    g.resolution = 0.05;
    g.width = 256;
    g.height = 256;
    for (i, c) in g.cells.iter_mut().enumerate() {
        *c = [grid_cell::FREE, grid_cell::OCCUPIED, grid_cell::UNKNOWN, 40][i % 4];
    }
    g
}

fn valid_nav_goal() -> Box<NavGoal> {
    let mut g = boxed_zeroed::<NavGoal>();
    g.goal_id = 3;
    g.pose = [1.0, 2.0, -1.0];
    g.cluster_id = -1;
    g
}

fn valid_neck_goal() -> Box<NeckGoal> {
    let mut g = boxed_zeroed::<NeckGoal>();
    g.yaw = 1.0;
    g.pitch = 0.3;
    g
}

fn valid_deadline() -> Box<DeadlineEvent> {
    let mut e = boxed_zeroed::<DeadlineEvent>();
    e.period_ns = 33_000_000;
    e.missed = 1;
    e.miss_cause = miss_cause::RUN_QUEUE;
    e
}

fn valid_decision() -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.count = MAX_CANDIDATES as u32;
    d.cluster_id = 8;
    for (k, c) in d.candidates.iter_mut().enumerate() {
        *c = Candidate {
            position: [k as f32 * 0.1, 0.0, 1.2],
            yaw: -3.0,
            pitch: 0.3,
            value: 1.0,
            chosen: (k == 0) as u8,
            ..Default::default()
        };
    }
    d
}

fn valid_health() -> Box<NodeHealth> {
    let mut h = boxed_zeroed::<NodeHealth>();
    h.set_node_name("recorder");
    while h.push_input("planner/decision", 7, 1, 2) {}
    h
}

fn valid_visibility() -> Box<FrameVisibility> {
    let mut v = boxed_zeroed::<FrameVisibility>();
    v.count = MAX_OBJECTS as u32;
    for it in v.items.iter_mut() {
        it.bbox = [1.0, 2.0, 30.0, 40.0];
    }
    v
}

// ---- oracles: what "validated" must mean, stated without the rules' code ------------------

fn frame_ok(f: &DepthFrame) {
    assert!(f.width as usize <= MAX_WIDTH && f.height as usize <= MAX_HEIGHT);
    assert_eq!(f.pixels().len(), (f.width * f.height) as usize);
    let i = f.intrinsics;
    finite(
        "intrinsics",
        &[i.fx, i.fy, i.cx, i.cy, i.min_range, i.max_range],
    );
    assert!(i.fx > 0.0 && i.fy > 0.0 && i.min_range < i.max_range);
    finite("camera_pose", &f.camera_pose.translation);
    finite("camera_pose", &f.camera_pose.rotation);
}

fn detections_ok(d: &Detections) {
    assert!(d.width as usize <= MAX_WIDTH && d.height as usize <= MAX_HEIGHT);
    assert_eq!(d.detections().len(), d.count as usize);
    assert_eq!(d.label_pixels().len(), (d.width * d.height) as usize);
    assert!(d.masks <= 1);
    let image = d.label_pixels().len();
    for it in d.detections() {
        finite("score", &[it.score]);
        assert!((0.0..=1.0).contains(&it.score));
        assert_ne!(class_name(it.class_id), "?");
        assert!(it.bbox[2] as u32 <= d.width && it.bbox[3] as u32 <= d.height);
        assert!(it.mask_pixels as usize <= image);
        if d.masks == mask_mode::MASKS {
            assert!((1..=255).contains(&it.label));
        } else {
            assert_eq!(it.mask_pixels, 0);
        }
    }
    if d.masks == mask_mode::MASKS {
        let total: u64 = d.detections().iter().map(|it| it.mask_pixels as u64).sum();
        let labelled = d.label_pixels().iter().filter(|v| **v != 0).count() as u64;
        assert_eq!(
            total, labelled,
            "every labelled pixel belongs to exactly one item"
        );
    }
}

fn state_ok(s: &RobotState) {
    finite("base_pose", &s.base_pose);
    finite("neck", &[s.neck_yaw, s.neck_pitch, s.speed, s.distance_m]);
    finite("odom_cov", &s.odom_cov);
    flag("localization_ok", s.localization_ok);
    assert!(s.nav_status <= 3);
}

fn map_ok(m: &ObjectMap) {
    assert_eq!(m.objects().len(), m.count as usize);
    finite("eps_sopm", &[m.eps_sopm]);
    for o in m.objects() {
        finite("object", &o.center);
        finite("object", &o.size);
        finite("object", &[o.yaw, o.h_sopm, o.c_asso, o.support_height]);
        finite("l_best", &o.l_best);
        assert!(o.sopm_rows as usize * o.sopm_cols as usize <= MAX_SOPM_CELLS);
        assert_eq!(o.cells().len(), o.sopm_rows as usize * o.sopm_cols as usize);
        assert!(o.cells().iter().all(|p| (0.0..=1.0).contains(p)));
        assert!(o.sample_count as usize <= MAX_OBJECT_POINTS);
        assert_eq!(o.samples().count(), o.sample_count as usize);
        for (p, l) in o.samples() {
            finite("point", p);
            finite("los", l);
        }
        assert_ne!(class_name(o.class_id), "?");
        flag("background", o.background);
        flag("complete", o.complete);
        assert!(o.cluster_id >= -1 && o.sopm_shape <= 2);
    }
}

fn grid_ok(g: &OccupancyGrid) {
    finite("origin", &g.origin);
    assert!(g.resolution > 0.0 && g.resolution.is_finite());
    assert!(g.width >= 1 && g.height >= 1);
    assert!(g.width as usize * g.height as usize <= MAX_GRID_CELLS);
    assert_eq!(g.used().len(), g.width as usize * g.height as usize);
    assert!(
        g.used()
            .iter()
            .all(|c| *c <= 100 || *c == grid_cell::UNKNOWN)
    );
}

fn nav_goal_ok(g: &NavGoal) {
    finite("pose", &g.pose);
    finite("score", &[g.score]);
    assert!(g.kind <= goal_kind::RECOVERY && g.cluster_id >= -1);
}

fn neck_goal_ok(g: &NeckGoal) {
    finite("neck", &[g.yaw, g.pitch, g.score]);
}

fn deadline_ok(e: &DeadlineEvent) {
    assert_ne!(miss_cause::name(e.miss_cause), "invalid");
    assert!(e.period_ns > 0);
    flag("missed", e.missed);
    flag("sched_stats", e.sched_stats);
    flag("backup_wake", e.backup_wake);
}

fn decision_ok(d: &PlannerDecision) {
    assert_eq!(d.candidates().len(), d.count as usize);
    assert!(d.kind <= 1 && d.state <= 2 && d.cluster_id >= -1);
    for c in d.candidates() {
        finite("position", &c.position);
        finite(
            "terms",
            &[
                c.yaw,
                c.pitch,
                c.value,
                c.f_a,
                c.f_c,
                c.h_sopm,
                c.h_iou,
                c.cos_theta_sopm,
                c.c_asso,
                c.n_cp,
                c.cos_theta_c,
            ],
        );
        flag("chosen", c.chosen);
        flag("dropped", c.dropped);
    }
}

fn visibility_ok(v: &FrameVisibility) {
    assert_eq!(v.items().len(), v.count as usize);
    for it in v.items() {
        finite("bbox", &it.bbox);
        flag("truncated", it.truncated);
    }
}

fn health_ok(h: &NodeHealth) {
    assert_eq!(h.inputs().len(), h.count as usize);
    assert!(std::str::from_utf8(&h.node).is_ok());
    assert!(
        h.inputs()
            .iter()
            .all(|e| std::str::from_utf8(&e.topic).is_ok())
    );
}

fn config(cases: u32) -> ProptestConfig {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(cases);
    ProptestConfig {
        cases,
        // Failures are reported with their minimal case; nothing is persisted to the tree.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn patches() -> impl Strategy<Value = Vec<Patch>> {
    prop::collection::vec(patch_strategy(), 0..12)
}

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn depth_frame(b in base(), p in patches()) {
        run("DepthFrame", valid_frame, frame_ok, &b, &p);
    }

    #[test]
    fn detections(b in base(), p in patches()) {
        run("Detections", valid_detections, detections_ok, &b, &p);
    }

    #[test]
    fn object_map(b in base(), p in patches()) {
        run("ObjectMap", valid_map, map_ok, &b, &p);
    }

    #[test]
    fn occupancy_grid(b in base(), p in patches()) {
        run("OccupancyGrid", valid_grid, grid_ok, &b, &p);
    }
}

proptest! {
    #![proptest_config(config(512))]

    #[test]
    fn robot_state(b in base(), p in patches()) {
        run("RobotState", valid_state, state_ok, &b, &p);
    }

    #[test]
    fn nav_goal(b in base(), p in patches()) {
        run("NavGoal", valid_nav_goal, nav_goal_ok, &b, &p);
    }

    #[test]
    fn neck_goal(b in base(), p in patches()) {
        run("NeckGoal", valid_neck_goal, neck_goal_ok, &b, &p);
    }

    #[test]
    fn deadline_event(b in base(), p in patches()) {
        run("DeadlineEvent", valid_deadline, deadline_ok, &b, &p);
    }

    #[test]
    fn planner_decision(b in base(), p in patches()) {
        run("PlannerDecision", valid_decision, decision_ok, &b, &p);
    }

    #[test]
    fn frame_visibility(b in base(), p in patches()) {
        run("FrameVisibility", valid_visibility, visibility_ok, &b, &p);
    }

    #[test]
    fn node_health(b in base(), p in patches()) {
        run("NodeHealth", valid_health, health_ok, &b, &p);
    }
}

/// The patches reach every field: each message type's scalar list covers its whole size.
#[test]
fn scalar_lists_cover_every_byte() {
    let sizes = [
        ("DepthFrame", std::mem::size_of::<DepthFrame>()),
        ("Detections", std::mem::size_of::<Detections>()),
        ("ObjectMap", std::mem::size_of::<ObjectMap>()),
        ("OccupancyGrid", std::mem::size_of::<OccupancyGrid>()),
        ("RobotState", std::mem::size_of::<RobotState>()),
        ("NavGoal", std::mem::size_of::<NavGoal>()),
        ("NeckGoal", std::mem::size_of::<NeckGoal>()),
        ("DeadlineEvent", std::mem::size_of::<DeadlineEvent>()),
        ("PlannerDecision", std::mem::size_of::<PlannerDecision>()),
        ("FrameVisibility", std::mem::size_of::<FrameVisibility>()),
        ("NodeHealth", std::mem::size_of::<NodeHealth>()),
    ];
    for (name, size) in sizes {
        let width = |s: Scalar| match s {
            Scalar::U8 => 1,
            Scalar::U16 => 2,
            Scalar::U32 | Scalar::I32 | Scalar::F32 => 4,
            Scalar::U64 | Scalar::I64 => 8,
        };
        let covered: usize = scalars(name).iter().map(|(_, s)| width(*s)).sum();
        assert_eq!(covered, size, "{name}");
    }
}
