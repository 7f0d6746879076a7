//! Conversion of our messages into the JSON written to the file (runs on the writer thread),
//! plus the producer-side copies into pooled buffers.

use super::{LatencySummary, LogLevel, MountGeometry, TruthBox};
use serde::Serialize;
use shm_types::{
    DeadlineEvent, DepthFrame, MapObject, NavGoal, NeckGoal, ObjectMap, PlannerDecision,
    RobotState, class_name, decision_kind, goal_kind, miss_cause, planner_state,
};

// ---- producer-side copies (no allocation) --------------------------------------------------

/// Copy the used part of `src` into `dst`.
pub(super) fn copy_depth(src: &DepthFrame, dst: &mut DepthFrame) {
    dst.header = src.header;
    dst.width = src.width.min(shm_types::MAX_WIDTH as u32);
    dst.height = src.height.min(shm_types::MAX_HEIGHT as u32);
    dst.intrinsics = src.intrinsics;
    dst.camera_pose = src.camera_pose;
    let n = (dst.width * dst.height) as usize;
    dst.depth_mm[..n].copy_from_slice(&src.depth_mm[..n]);
}

/// Copy the used part of `src` into `dst`.
pub(super) fn copy_decision(src: &PlannerDecision, dst: &mut PlannerDecision) {
    dst.header = src.header;
    dst.map_seq = src.map_seq;
    dst.eval_ns = src.eval_ns;
    dst.cluster_id = src.cluster_id;
    dst.evaluated = src.evaluated;
    dst.kind = src.kind;
    dst.state = src.state;
    let c = src.candidates();
    dst.count = c.len() as u32;
    dst.candidates[..c.len()].copy_from_slice(c);
}

// ---- small math -----------------------------------------------------------------------------

type V3 = [f64; 3];

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Unit quaternion `[x, y, z, w]` of a rotation about +z.
pub(super) fn quat_z(yaw: f64) -> [f64; 4] {
    let (s, c) = (yaw * 0.5).sin_cos();
    [0.0, 0.0, s, c]
}

/// Unit quaternion `[x, y, z, w]` of the rotation matrix with columns `x`, `y`, `z`.
pub(super) fn quat_from_cols(x: V3, y: V3, z: V3) -> [f64; 4] {
    // m[row][col]
    let m = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]];
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
            0.25 * s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[2][1] - m[1][2]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
            (m[0][2] - m[2][0]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
            (m[1][0] - m[0][1]) / s,
        ]
    };
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
}

/// Axes `(right, down, forward)` of an optical camera whose forward axis has yaw `yaw` and is
/// pitched down by `pitch` (same convention as `nodes::geom::optical_rotation`).
pub(super) fn optical_axes(yaw: f64, pitch: f64) -> (V3, V3, V3) {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let forward = [cy * cp, sy * cp, -sp];
    let right = [sy, -cy, 0.0];
    (right, cross(forward, right), forward)
}

fn hsv(h: f64, s: f64, v: f64, a: f64) -> Color {
    let h6 = (h.rem_euclid(1.0)) * 6.0;
    let c = v * s;
    let x = c * (1.0 - ((h6 % 2.0) - 1.0).abs());
    let (r, g, b) = match h6 as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    Color {
        r: r + m,
        g: g + m,
        b: b + m,
        a,
    }
}

/// A stable, well-spread colour per class id.
pub(super) fn class_color(class_id: u16, a: f64) -> Color {
    hsv(f64::from(class_id) * 0.618_033_988_75, 0.75, 0.95, a)
}

/// Red (t = 0) to green (t = 1).
pub(super) fn score_color(t: f64, a: f64) -> Color {
    let t = t.clamp(0.0, 1.0);
    Color {
        r: 1.0 - t,
        g: t,
        b: 0.15,
        a,
    }
}

// ---- Foxglove types (JSON shape of the well-known schemas) ----------------------------------

#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct Time {
    sec: u64,
    nsec: u32,
}

pub(super) fn time(ns: u64) -> Time {
    Time {
        sec: ns / 1_000_000_000,
        nsec: (ns % 1_000_000_000) as u32,
    }
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Vec3 {
    x: f64,
    y: f64,
    z: f64,
}

fn v3(a: V3) -> Vec3 {
    Vec3 {
        x: a[0],
        y: a[1],
        z: a[2],
    }
}

fn v3f(a: [f32; 3]) -> Vec3 {
    v3([a[0].into(), a[1].into(), a[2].into()])
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Quat {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

fn quat(q: [f64; 4]) -> Quat {
    Quat {
        x: q[0],
        y: q[1],
        z: q[2],
        w: q[3],
    }
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Pose {
    position: Vec3,
    orientation: Quat,
}

const IDENTITY: Pose = Pose {
    position: Vec3 {
        x: 0.0,
        y: 0.0,
        z: 0.0,
    },
    orientation: Quat {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    },
};

fn pose(p: V3, q: [f64; 4]) -> Pose {
    Pose {
        position: v3(p),
        orientation: quat(q),
    }
}

#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct Color {
    r: f64,
    g: f64,
    b: f64,
    a: f64,
}

#[derive(Debug, Serialize)]
struct FrameTransform {
    timestamp: Time,
    parent_frame_id: &'static str,
    child_frame_id: &'static str,
    translation: Vec3,
    rotation: Quat,
}

#[derive(Debug, Serialize)]
struct FrameTransforms {
    transforms: Vec<FrameTransform>,
}

#[derive(Debug, Serialize)]
struct PosesInFrame {
    timestamp: Time,
    frame_id: &'static str,
    poses: Vec<Pose>,
}

#[derive(Debug, Serialize)]
struct KeyValue {
    key: &'static str,
    value: String,
}

#[derive(Debug, Serialize)]
struct Cube {
    pose: Pose,
    size: Vec3,
    color: Color,
}

#[derive(Debug, Serialize)]
struct Line {
    #[serde(rename = "type")]
    kind: u8,
    pose: Pose,
    thickness: f64,
    scale_invariant: bool,
    points: Vec<Vec3>,
    color: Color,
    colors: [Color; 0],
    indices: [u32; 0],
}

#[derive(Debug, Serialize)]
struct Text {
    pose: Pose,
    billboard: bool,
    font_size: f64,
    scale_invariant: bool,
    color: Color,
    text: String,
}

#[derive(Debug, Serialize)]
struct Entity {
    timestamp: Time,
    frame_id: &'static str,
    id: String,
    lifetime: Time,
    frame_locked: bool,
    metadata: Vec<KeyValue>,
    arrows: [u8; 0],
    cubes: Vec<Cube>,
    spheres: [u8; 0],
    cylinders: [u8; 0],
    lines: Vec<Line>,
    triangles: [u8; 0],
    texts: Vec<Text>,
    models: [u8; 0],
}

impl Entity {
    fn new(t: Time, id: String) -> Self {
        Entity {
            timestamp: t,
            frame_id: "world",
            id,
            lifetime: time(0),
            frame_locked: false,
            metadata: Vec::new(),
            arrows: [],
            cubes: Vec::new(),
            spheres: [],
            cylinders: [],
            lines: Vec::new(),
            triangles: [],
            texts: Vec::new(),
            models: [],
        }
    }
}

#[derive(Debug, Serialize)]
struct Deletion {
    timestamp: Time,
    #[serde(rename = "type")]
    kind: u8,
    id: &'static str,
}

#[derive(Debug, Serialize)]
struct SceneUpdate {
    deletions: Vec<Deletion>,
    entities: Vec<Entity>,
}

impl SceneUpdate {
    /// An update that replaces everything previously shown on the topic.
    fn replace_all(t: Time) -> Self {
        SceneUpdate {
            deletions: vec![Deletion {
                timestamp: t,
                kind: 1,
                id: "",
            }],
            entities: Vec::new(),
        }
    }
}

#[derive(Debug, Serialize)]
struct Log<'a> {
    timestamp: Time,
    level: u8,
    message: &'a str,
    name: &'a str,
    file: &'a str,
    line: u32,
}

fn to(out: &mut Vec<u8>, v: &impl Serialize) {
    out.clear();
    // Serialising these plain structs into a Vec cannot fail (no maps with non-string keys).
    let _ = serde_json::to_writer(&mut *out, v);
}

// ---- messages ---------------------------------------------------------------------------------

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Append the standard (padded) base64 encoding of `data`.
pub(super) fn base64_into(out: &mut Vec<u8>, data: &[u8]) {
    out.reserve(data.len().div_ceil(3) * 4);
    let mut chunks = data.chunks_exact(3);
    for c in &mut chunks {
        let n = (u32::from(c[0]) << 16) | (u32::from(c[1]) << 8) | u32::from(c[2]);
        out.extend_from_slice(&[
            B64[(n >> 18) as usize & 63],
            B64[(n >> 12) as usize & 63],
            B64[(n >> 6) as usize & 63],
            B64[n as usize & 63],
        ]);
    }
    match *chunks.remainder() {
        [a] => {
            let n = u32::from(a) << 16;
            out.extend_from_slice(&[B64[(n >> 18) as usize & 63], B64[(n >> 12) as usize & 63]]);
            out.extend_from_slice(b"==");
        }
        [a, b] => {
            let n = (u32::from(a) << 16) | (u32::from(b) << 8);
            out.extend_from_slice(&[
                B64[(n >> 18) as usize & 63],
                B64[(n >> 12) as usize & 63],
                B64[(n >> 6) as usize & 63],
            ]);
            out.push(b'=');
        }
        _ => {}
    }
}

/// `foxglove.RawImage` (`16UC1`, little-endian mm) of `f` decimated by `k`, into `out`.
/// `scratch` holds the decimated bytes.
pub(super) fn depth_image(f: &DepthFrame, k: u32, scratch: &mut Vec<u8>, out: &mut Vec<u8>) {
    use std::io::Write;
    let (w, h) = (f.width as usize, f.height as usize);
    let k = k.max(1) as usize;
    let (dw, dh) = (w.div_ceil(k), h.div_ceil(k));
    scratch.clear();
    scratch.reserve(dw * dh * 2);
    let px = f.pixels();
    for row in px.chunks_exact(w.max(1)).step_by(k).take(dh) {
        for v in row.iter().step_by(k) {
            scratch.extend_from_slice(&v.to_le_bytes());
        }
    }
    let t = time(f.header.sim_time_ns);
    out.clear();
    let _ = write!(
        out,
        r#"{{"timestamp":{{"sec":{},"nsec":{}}},"frame_id":"camera","width":{dw},"height":{dh},"encoding":"16UC1","step":{},"data":""#,
        t.sec,
        t.nsec,
        dw * 2
    );
    base64_into(out, scratch);
    out.extend_from_slice(b"\"}");
}

/// `foxglove.FrameTransforms` world→base→neck→camera (or world→`base_frame` alone for truth).
pub(super) fn transforms(s: &RobotState, mount: &MountGeometry, truth: bool, out: &mut Vec<u8>) {
    let t = time(s.header.sim_time_ns);
    let [x, y, yaw] = s.base_pose.map(f64::from);
    let mut tf = FrameTransforms {
        transforms: vec![FrameTransform {
            timestamp: t,
            parent_frame_id: "world",
            child_frame_id: if truth { "base_true" } else { "base" },
            translation: v3([x, y, 0.0]),
            rotation: quat(quat_z(yaw)),
        }],
    };
    if !truth {
        let (r, d, f) = optical_axes(0.0, s.neck_pitch.into());
        tf.transforms.push(FrameTransform {
            timestamp: t,
            parent_frame_id: "base",
            child_frame_id: "neck",
            translation: v3([mount.forward_offset.into(), 0.0, mount.height.into()]),
            rotation: quat(quat_z(s.neck_yaw.into())),
        });
        tf.transforms.push(FrameTransform {
            timestamp: t,
            parent_frame_id: "neck",
            child_frame_id: "camera",
            translation: v3([0.0; 3]),
            rotation: quat(quat_from_cols(r, d, f)),
        });
    }
    to(out, &tf);
}

/// `foxglove.PosesInFrame` of base poses `[x, y, yaw]` in `world`.
pub(super) fn trajectory(time_ns: u64, poses: &[[f32; 3]], out: &mut Vec<u8>) {
    let msg = PosesInFrame {
        timestamp: time(time_ns),
        frame_id: "world",
        poses: poses
            .iter()
            .map(|p| pose([p[0].into(), p[1].into(), 0.0], quat_z(p[2].into())))
            .collect(),
    };
    to(out, &msg);
}

fn cuboid_entity(
    t: Time,
    id: String,
    center: [f32; 3],
    size: [f32; 3],
    yaw: f32,
    color: Color,
    label: String,
) -> Entity {
    let mut e = Entity::new(t, id);
    let c = [center[0].into(), center[1].into(), center[2].into()];
    e.cubes.push(Cube {
        pose: pose(c, quat_z(yaw.into())),
        size: v3f(size),
        color,
    });
    e.texts.push(Text {
        pose: pose(
            add(c, [0.0, 0.0, f64::from(size[2]) * 0.5 + 0.08]),
            [0.0, 0.0, 0.0, 1.0],
        ),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Color {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 1.0,
        },
        text: label,
    });
    e
}

/// `foxglove.SceneUpdate` of the ground-truth cuboids.
pub(super) fn truth_objects(boxes: &[TruthBox], out: &mut Vec<u8>) {
    let t = time(0);
    let mut u = SceneUpdate::replace_all(t);
    for b in boxes {
        let cid = shm_types::class_id(&b.class).unwrap_or(0);
        let mut e = cuboid_entity(
            t,
            format!("truth/{}", b.name),
            b.center,
            b.size,
            b.yaw,
            class_color(cid, 0.25),
            format!("{} ({})", b.name, b.class),
        );
        e.metadata.push(KeyValue {
            key: "class",
            value: b.class.clone(),
        });
        u.entities.push(e);
    }
    to(out, &u);
}

fn map_entity(t: Time, o: &MapObject) -> Entity {
    let class = class_name(o.class_id);
    let alpha = if o.is_background() { 0.35 } else { 0.6 };
    let mut e = cuboid_entity(
        t,
        format!("obj/{}", o.id),
        o.center,
        o.size,
        o.yaw,
        class_color(o.class_id, alpha),
        format!(
            "{class} #{} H={:.2}{}",
            o.id,
            o.h_sopm,
            if o.is_complete() { " ✓" } else { "" }
        ),
    );
    e.metadata.extend([
        KeyValue {
            key: "class",
            value: class.to_string(),
        },
        KeyValue {
            key: "h_sopm",
            value: format!("{:.4}", o.h_sopm),
        },
        KeyValue {
            key: "complete",
            value: o.is_complete().to_string(),
        },
        KeyValue {
            key: "background",
            value: o.is_background().to_string(),
        },
        KeyValue {
            key: "cluster_id",
            value: o.cluster_id.to_string(),
        },
        KeyValue {
            key: "observations",
            value: o.observations.to_string(),
        },
    ]);
    e
}

/// `foxglove.SceneUpdate` of the estimated cuboids (replaces the previous map).
pub(super) fn map_objects(m: &ObjectMap, out: &mut Vec<u8>) {
    let t = time(m.header.sim_time_ns);
    let mut u = SceneUpdate::replace_all(t);
    u.entities
        .extend(m.objects().iter().map(|o| map_entity(t, o)));
    to(out, &u);
}

/// `foxglove.SceneUpdate` of the candidate frusta of a decision, coloured by F(v) (red = lowest,
/// green = highest of the decision); the chosen view is drawn thick and blue.
pub(super) fn frusta(d: &PlannerDecision, mount: &MountGeometry, length: f64, out: &mut Vec<u8>) {
    let t = time(d.header.sim_time_ns);
    let mut u = SceneUpdate::replace_all(t);
    let cands = d.candidates();
    let (lo, hi) = cands
        .iter()
        .filter(|c| c.dropped == 0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(c.value.into()), hi.max(c.value.into()))
        });
    let th = (f64::from(mount.hfov_deg).to_radians() * 0.5).tan();
    let tv = (f64::from(mount.vfov_deg).to_radians() * 0.5).tan();
    let prefix = if d.kind == decision_kind::GBV {
        "gbv"
    } else {
        "lbv"
    };
    for (i, c) in cands.iter().enumerate() {
        let p = c.position.map(f64::from);
        let (r, dn, f) = optical_axes(c.yaw.into(), c.pitch.into());
        let corner = |sx: f64, sy: f64| {
            add(
                p,
                scale(add(f, add(scale(r, sx * th), scale(dn, sy * tv))), length),
            )
        };
        let k = [
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
        ];
        let mut pts = Vec::with_capacity(16);
        for j in 0..4 {
            pts.extend([v3(p), v3(k[j]), v3(k[j]), v3(k[(j + 1) % 4])]);
        }
        let chosen = c.chosen != 0;
        let color = if chosen {
            Color {
                r: 0.1,
                g: 0.4,
                b: 1.0,
                a: 1.0,
            }
        } else if c.dropped != 0 {
            Color {
                r: 0.5,
                g: 0.5,
                b: 0.5,
                a: 0.3,
            }
        } else {
            let tt = if hi > lo {
                (f64::from(c.value) - lo) / (hi - lo)
            } else {
                1.0
            };
            score_color(tt, 0.8)
        };
        let mut e = Entity::new(t, format!("{prefix}/{i}"));
        e.lines.push(Line {
            kind: 2,
            pose: IDENTITY,
            thickness: if chosen { 6.0 } else { 1.5 },
            scale_invariant: true,
            points: pts,
            color,
            colors: [],
            indices: [],
        });
        e.metadata.extend([
            KeyValue {
                key: "value",
                value: format!("{:.4}", c.value),
            },
            KeyValue {
                key: "chosen",
                value: chosen.to_string(),
            },
        ]);
        u.entities.push(e);
    }
    to(out, &u);
}

#[derive(Debug, Serialize)]
struct Hdr {
    seq: u64,
    stamp_ns: u64,
    sim_time_ns: u64,
}

fn hdr(h: &shm_types::Header) -> Hdr {
    Hdr {
        seq: h.seq,
        stamp_ns: h.stamp_ns,
        sim_time_ns: h.sim_time_ns,
    }
}

#[derive(Debug, Serialize)]
struct CandidateJson {
    position: [f32; 3],
    yaw: f32,
    pitch: f32,
    value: f32,
    f_a: f32,
    f_c: f32,
    h_sopm: f32,
    h_iou: f32,
    cos_theta_sopm: f32,
    c_asso: f32,
    n_cp: f32,
    cos_theta_c: f32,
    objects_in_view: u16,
    chosen: bool,
    dropped: bool,
}

#[derive(Debug, Serialize)]
struct DecisionJson {
    #[serde(flatten)]
    header: Hdr,
    kind: &'static str,
    state: &'static str,
    map_seq: u64,
    eval_ns: u64,
    cluster_id: i32,
    evaluated: u32,
    chosen_value: f32,
    candidates: Vec<CandidateJson>,
}

/// `vpsom.PlannerDecision`.
pub(super) fn decision(d: &PlannerDecision, out: &mut Vec<u8>) {
    let cands = d.candidates();
    let msg = DecisionJson {
        header: hdr(&d.header),
        kind: if d.kind == decision_kind::GBV {
            "gbv"
        } else {
            "lbv"
        },
        state: match d.state {
            planner_state::TERMINATED => "terminated",
            planner_state::NO_CANDIDATES => "no_candidates",
            _ => "running",
        },
        map_seq: d.map_seq,
        eval_ns: d.eval_ns,
        cluster_id: d.cluster_id,
        evaluated: d.evaluated,
        chosen_value: cands
            .iter()
            .find(|c| c.chosen != 0)
            .map_or(0.0, |c| c.value),
        candidates: cands
            .iter()
            .map(|c| CandidateJson {
                position: c.position,
                yaw: c.yaw,
                pitch: c.pitch,
                value: c.value,
                f_a: c.f_a,
                f_c: c.f_c,
                h_sopm: c.h_sopm,
                h_iou: c.h_iou,
                cos_theta_sopm: c.cos_theta_sopm,
                c_asso: c.c_asso,
                n_cp: c.n_cp,
                cos_theta_c: c.cos_theta_c,
                objects_in_view: c.objects_in_view,
                chosen: c.chosen != 0,
                dropped: c.dropped != 0,
            })
            .collect(),
    };
    to(out, &msg);
}

#[derive(Debug, Serialize)]
struct NavGoalJson {
    #[serde(flatten)]
    header: Hdr,
    goal_id: u64,
    x: f32,
    y: f32,
    yaw: f32,
    score: f32,
    cluster_id: i32,
    kind: &'static str,
}

/// `vpsom.NavGoal`.
pub(super) fn nav_goal(g: &NavGoal, out: &mut Vec<u8>) {
    let msg = NavGoalJson {
        header: hdr(&g.header),
        goal_id: g.goal_id,
        x: g.pose[0],
        y: g.pose[1],
        yaw: g.pose[2],
        score: g.score,
        cluster_id: g.cluster_id,
        kind: match g.kind {
            goal_kind::COVERAGE => "coverage",
            goal_kind::FRONTIER => "frontier",
            _ => "gbv",
        },
    };
    to(out, &msg);
}

#[derive(Debug, Serialize)]
struct NeckGoalJson {
    #[serde(flatten)]
    header: Hdr,
    map_seq: u64,
    frame_stamp_ns: u64,
    yaw: f32,
    pitch: f32,
    score: f32,
}

/// `vpsom.NeckGoal`.
pub(super) fn neck_goal(g: &NeckGoal, out: &mut Vec<u8>) {
    let msg = NeckGoalJson {
        header: hdr(&g.header),
        map_seq: g.map_seq,
        frame_stamp_ns: g.frame_stamp_ns,
        yaw: g.yaw,
        pitch: g.pitch,
        score: g.score,
    };
    to(out, &msg);
}

#[derive(Debug, Serialize)]
struct DeadlineJson<'a> {
    #[serde(flatten)]
    header: Hdr,
    thread: &'a str,
    cycle: u64,
    period_ns: u64,
    budget_ns: u64,
    lateness_ns: i64,
    exec_ns: u64,
    cpu_ns: u64,
    run_wait_ns: u64,
    sched_stats: bool,
    backup_wake: bool,
    consecutive_misses: u32,
    miss: bool,
    miss_cause: &'static str,
}

/// `vpsom.DeadlineEvent`.
pub(super) fn deadline(e: &DeadlineEvent, out: &mut Vec<u8>) {
    let msg = DeadlineJson {
        header: hdr(&e.header),
        thread: e.thread_name(),
        cycle: e.cycle,
        period_ns: e.period_ns,
        budget_ns: e.budget_ns,
        lateness_ns: e.lateness_ns,
        exec_ns: e.exec_ns,
        cpu_ns: e.cpu_ns,
        run_wait_ns: e.run_wait_ns,
        sched_stats: e.sched_stats != 0,
        backup_wake: e.backup_wake != 0,
        consecutive_misses: e.consecutive_misses,
        miss: e.missed != 0,
        miss_cause: miss_cause::name(e.miss_cause),
    };
    to(out, &msg);
}

#[derive(Debug, Serialize)]
struct InputJson<'a> {
    topic: &'a str,
    received: u64,
    invalid: u64,
    overflow: u64,
}

#[derive(Debug, Serialize)]
struct HealthJson<'a> {
    #[serde(flatten)]
    header: Hdr,
    node: &'a str,
    pid: u32,
    steps: u64,
    inputs: Vec<InputJson<'a>>,
}

/// `vpsom.NodeHealth`.
pub(super) fn health(h: &shm_types::NodeHealth, out: &mut Vec<u8>) {
    let msg = HealthJson {
        header: hdr(&h.header),
        node: h.node_name(),
        pid: h.pid,
        steps: h.steps,
        inputs: h
            .inputs()
            .iter()
            .map(|i| InputJson {
                topic: i.topic_name(),
                received: i.received,
                invalid: i.invalid,
                overflow: i.overflow,
            })
            .collect(),
    };
    to(out, &msg);
}

/// `vpsom.LatencySummary`.
pub(super) fn latency(s: &LatencySummary, out: &mut Vec<u8>) {
    to(out, s);
}

/// `foxglove.Log`.
pub(super) fn log(time_ns: u64, level: LogLevel, name: &str, text: &str, out: &mut Vec<u8>) {
    let msg = Log {
        timestamp: time(time_ns),
        level: level as u8,
        message: text,
        name,
        file: "",
        line: 0,
    };
    to(out, &msg);
}

/// Any JSON value.
pub(super) fn value(v: &serde_json::Value, out: &mut Vec<u8>) {
    to(out, v);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot(q: [f64; 4], v: V3) -> V3 {
        // v' = v + 2w (u × v) + 2 u × (u × v)
        let u = [q[0], q[1], q[2]];
        let t = scale(cross(u, v), 2.0);
        add(add(v, scale(t, q[3])), cross(u, t))
    }

    fn close(a: V3, b: V3) {
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-9, "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (input, expect) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            let mut out = Vec::new();
            base64_into(&mut out, input.as_bytes());
            assert_eq!(String::from_utf8(out).unwrap(), expect);
        }
    }

    #[test]
    fn optical_camera_looks_along_yaw_and_down_by_pitch() {
        // Pitch 90° down: forward is -z, right is (sin yaw, -cos yaw, 0).
        let (r, d, f) = optical_axes(0.0, std::f64::consts::FRAC_PI_2);
        close(f, [0.0, 0.0, -1.0]);
        close(r, [0.0, -1.0, 0.0]);
        close(d, [-1.0, 0.0, 0.0]);
        // The quaternion of the axes maps the optical z axis onto forward, x onto right.
        let (r, d, f) = optical_axes(0.7, 0.4);
        let q = quat_from_cols(r, d, f);
        close(rot(q, [0.0, 0.0, 1.0]), f);
        close(rot(q, [1.0, 0.0, 0.0]), r);
        close(rot(q, [0.0, 1.0, 0.0]), d);
        close(
            rot(quat_z(std::f64::consts::FRAC_PI_2), [1.0, 0.0, 0.0]),
            [0.0, 1.0, 0.0],
        );
    }

    #[test]
    fn depth_is_decimated_row_major_little_endian() {
        let mut f = shm_types::boxed_zeroed::<DepthFrame>();
        f.width = 5;
        f.height = 3;
        for (i, p) in f.pixels_mut().iter_mut().enumerate() {
            *p = i as u16 * 300;
        }
        f.header.sim_time_ns = 2_500_000_000;
        let (mut s, mut out) = (Vec::new(), Vec::new());
        depth_image(&f, 2, &mut s, &mut out);
        // Kept: rows 0, 2 × columns 0, 2, 4 → pixels 0, 2, 4, 10, 12, 14.
        let expect: Vec<u8> = [0u16, 2, 4, 10, 12, 14]
            .iter()
            .flat_map(|i| (i * 300).to_le_bytes())
            .collect();
        assert_eq!(s, expect);
        let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(v["width"], 3);
        assert_eq!(v["height"], 2);
        assert_eq!(v["step"], 6);
        assert_eq!(v["timestamp"]["sec"], 2);
        assert_eq!(v["timestamp"]["nsec"], 500_000_000);
        let mut b = Vec::new();
        base64_into(&mut b, &expect);
        assert_eq!(v["data"].as_str().unwrap().as_bytes(), &b[..]);
    }

    #[test]
    fn tf_chain_composes_to_the_camera_pose_of_the_mount() {
        // world_from_camera = world_from_base · base_from_neck · neck_from_camera must equal the
        // mount formula: neck at base + forward_offset along yaw at mount height, optical axes of
        // yaw + neck_yaw and the pitch.
        let mount = MountGeometry {
            height: 1.5,
            forward_offset: 0.25,
            ..Default::default()
        };
        let s = RobotState {
            base_pose: [1.0, -2.0, 0.5],
            neck_yaw: 0.8,
            neck_pitch: 0.45,
            ..Default::default()
        };
        let mut out = Vec::new();
        transforms(&s, &mount, false, &mut out);
        let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
        let tfs = v["transforms"].as_array().unwrap();
        let get = |i: usize| {
            let t = &tfs[i]["translation"];
            let q = &tfs[i]["rotation"];
            let f = |x: &serde_json::Value| x.as_f64().unwrap();
            (
                [f(&t["x"]), f(&t["y"]), f(&t["z"])],
                [f(&q["x"]), f(&q["y"]), f(&q["z"]), f(&q["w"])],
            )
        };
        let names: Vec<_> = tfs
            .iter()
            .map(|t| format!("{}->{}", t["parent_frame_id"], t["child_frame_id"]))
            .collect();
        assert_eq!(
            names,
            [
                "\"world\"->\"base\"",
                "\"base\"->\"neck\"",
                "\"neck\"->\"camera\""
            ]
        );
        let apply = |i: usize, p: V3| {
            let (t, q) = get(i);
            add(rot(q, p), t)
        };
        let chain = |p: V3| apply(0, apply(1, apply(2, p)));
        let origin = chain([0.0; 3]);
        let yaw = 0.5f64;
        close(
            origin,
            [1.0 + 0.25 * yaw.cos(), -2.0 + 0.25 * yaw.sin(), 1.5],
        );
        let (r, _, f) = optical_axes(0.5 + f64::from(0.8f32), f64::from(0.45f32));
        let fwd = chain([0.0, 0.0, 1.0]);
        let right = chain([1.0, 0.0, 0.0]);
        for i in 0..3 {
            assert!((fwd[i] - origin[i] - f[i]).abs() < 1e-6, "{fwd:?} {f:?}");
            assert!((right[i] - origin[i] - r[i]).abs() < 1e-6);
        }
    }
}
